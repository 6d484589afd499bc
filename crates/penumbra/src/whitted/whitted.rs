//! The Whitted ray tracer, one pixel at a time: the CPU twin of
//! `wgsl/whitted.wgsl`, written in the same order of operations over the
//! same data (`RenderScene`'s arrays, `WhittedUniforms`, `PixelOut`).
//!
//! A pixel's samples are traced one after another; each sample's ray tree
//! is walked depth first with an explicit stack (WGSL has no recursion):
//! a popped ray finds its closest hit among the kd-tree's triangles and the
//! spheres, adds its weighted local radiance (emission, ambient, and per
//! light a shadow ray and the diffuse and specular terms, `surface`), and
//! pushes its reflected and refracted rays with their weights until the
//! depth limit. Refraction follows Snell's law, with total internal
//! reflection sending the transmitted weight to the reflection; a ray
//! carries the stack of glass media it is inside (nested glass, a camera
//! inside glass), so each interface knows both of its indices.
//!
//! Shadow rays run from a point light to the lifted hit point (as MLRTA's
//! shadow packets do), or from the point towards a directional light. In a
//! scene with glass, a shadow ray walks through transmitting surfaces,
//! filtered by each one's transmission, up to `MAX_SHADOW_CROSSINGS`.

use std::cell::RefCell;

use glam::{Vec2, Vec3};

use super::tree_records::TreeRay;
use crate::accel::kdtree::KdTree;
use crate::geom::offset::{max_abs, offset_point};
use crate::geom::ray::Hit;
use crate::geom::sampling::SampleSequence;
use crate::scene::texture_table::NO_MAP;
use crate::whitted::lights::{DIRECTIONAL, LightSample};
use crate::whitted::optics::{reflect_dir, refract_dir, schlick, schlick_mirror};
use crate::whitted::ray_tree::{
    FNV_OFFSET, LightCode, NodeLights, NodeOccluders, RayKind, RayNode, RayTree, TreeHit, children_word, fnv_word,
    light_word, ray_word,
};
use crate::whitted::scene::{MISS, NO_NORMAL, NO_TEXCOORDS, RenderScene};
use crate::whitted::sphere::intersect_sphere;
use crate::whitted::surface::Surface;

/// Deepest reflection/refraction (the explicit stack holds one more ray).
pub const MAX_DEPTH: u32 = 16;
/// Nested glass media a ray keeps track of; deeper nesting is not tracked.
pub const MAX_MEDIA: usize = 4;
/// Transmitting surfaces a shadow ray passes before it counts as blocked.
pub const MAX_SHADOW_CROSSINGS: u32 = 16;
/// Cut-out holes a ray passes before the next surface counts as hit.
pub const MAX_HOLE_CROSSINGS: u32 = 16;

/// `WhittedUniforms::flags`: Fresnel-weighted reflection and transmission.
pub const FRESNEL: u32 = 1;

/// What one render asks, as the GPU reads it (it mirrors `WhittedUniforms`
/// in `wgsl/whitted.wgsl`) and as the CPU twin (`Whitted`) takes it, so a
/// test can run both on the same input; `WhittedRenderer::params` makes it.
///
/// The camera is a pinhole: the ray through image point (x, y) is
/// `normalize(forward + (2x/w - 1) right + (1 - 2y/h) up)`, with `right`
/// and `up` scaled by the field of view's half-width and half-height.
/// Positions and directions are in the scene's frame.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WhittedUniforms {
    /// The camera's eye: where primary rays start.
    pub eye: [f32; 3],
    /// Image width in pixels.
    pub width: u32,
    /// Unit viewing direction.
    pub forward: [f32; 3],
    /// Image height in pixels.
    pub height: u32,
    /// The camera's right axis times `tan(fov / 2) * width / height`: half
    /// the image plane's width at distance 1.
    pub right: [f32; 3],
    /// Samples per pixel: 1 through the pixel's centre, more jittered.
    pub spp: u32,
    /// The camera's up axis times `tan(fov / 2)`: half the image plane's
    /// height at distance 1.
    pub up: [f32; 3],
    /// Seeds the jitter (with more than one sample per pixel).
    pub seed: u32,
    /// Ambient light `A` per colour channel: a lit surface adds `ka A`
    /// (times its texture).
    pub ambient: [f32; 3],
    /// Deepest reflection/refraction (0: primary rays and shadows only).
    pub max_depth: u32,
    /// Radiance of rays that leave the scene.
    pub background: [f32; 3],
    /// Bit flags: `FRESNEL`.
    pub flags: u32,
    /// The media the eye is inside (surface ids, outermost first).
    pub media: [u32; MAX_MEDIA],
    /// Entries of `media` in use.
    pub media_len: u32,
    /// Lights in the scene's records (point, directional and emitter
    /// samples).
    pub light_count: u32,
    /// Analytic spheres in the scene's records.
    pub sphere_count: u32,
    /// Whether shadow rays pass transmitting surfaces (a scene with glass).
    pub transmissive: u32,
    /// The batch's first pixel, row-major (0 for a list of pixels or rays).
    pub first_pixel: u32,
    /// Pixels (listed pixels, or rays for `whitted_trees`) in the batch.
    pub pixel_count: u32,
    /// Invocations per row of the 2D dispatch grid.
    pub row_pitch: u32,
    /// Where the lights start in the GPU's records, in words4 (the surfaces
    /// come first, 8 words4 each; a light takes 3, a sphere 2).
    pub lights_at: u32,
    /// Where the spheres start in the GPU's records, in words4 (after the
    /// lights).
    pub spheres_at: u32,
    /// `whitted_trees`: nodes a ray's slot holds
    /// (`tree_records::TreeLayout::capacity`; 0 for the pixel entries).
    pub tree_capacity: u32,
    /// `whitted_trees`: words4 a node takes (`TreeLayout::stride`).
    pub tree_stride: u32,
    /// Where the texture maps start in the GPU's records, in words4 (after
    /// the spheres: the sRGB table, then the maps, then their texels).
    pub maps_at: u32,
}

/// One pixel's result, as the GPU writes it (32 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PixelOut {
    /// Mean radiance of its samples.
    pub radiance: [f32; 3],
    /// The ray-tree signature of its first sample.
    pub signature: u32,
    /// Rays traced by kind: primary, shadow, reflection, refraction.
    pub rays: [u32; 4],
}

/// The glass a ray is inside: surface ids, innermost last.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Media {
    pub ids: [u32; MAX_MEDIA],
    pub len: u32,
}

impl Media {
    pub fn from_ids(ids: &[u32]) -> Media {
        let mut m = Media::default();
        for &id in ids.iter().take(MAX_MEDIA) {
            m = m.push(id);
        }
        m
    }

    /// Entering `id` (not tracked beyond `MAX_MEDIA`).
    pub fn push(mut self, id: u32) -> Media {
        if (self.len as usize) < MAX_MEDIA {
            self.ids[self.len as usize] = id;
            self.len += 1;
        }
        self
    }

    /// Leaving `id`: its innermost entry is removed (nothing if absent).
    pub fn remove(mut self, id: u32) -> Media {
        let mut k = self.len;
        while k > 0 {
            k -= 1;
            if self.ids[k as usize] == id {
                for i in k..self.len - 1 {
                    self.ids[i as usize] = self.ids[i as usize + 1];
                }
                self.len -= 1;
                return self;
            }
        }
        self
    }

    /// The index of refraction around the ray (1 outside all glass).
    pub fn ni(&self, scene: &RenderScene) -> f32 {
        if self.len == 0 {
            1.0
        } else {
            scene.surface(self.ids[self.len as usize - 1]).ni
        }
    }
}

/// What the twin reads: the scene, its tree and the render's parameters.
pub struct Whitted<'a> {
    /// The scene's shading data, spheres and lights.
    pub scene: &'a RenderScene,
    /// The kd-tree over the scene's triangles (spheres are tested apart).
    pub tree: &'a KdTree,
    /// The render's parameters, as the kernel reads them.
    pub params: &'a WhittedUniforms,
}

/// The primary ray's hits found elsewhere (MLRTA packets): its closest hit
/// as the ray sees it (`None`: a miss), and per light whether triangles
/// block the shadow ray (`None`: not traced there).
pub struct FirstHit<'a> {
    pub facing: Option<Facing>,
    pub blocked: &'a [Option<bool>],
}

/// A ray on the stack.
#[derive(Debug, Clone, Copy)]
struct PathRay {
    origin: Vec3,
    dir: Vec3,
    weight: Vec3,
    depth: u32,
    kind: RayKind,
    media: Media,
    /// Its parent's node in a recorded tree.
    parent: u32,
}

/// A hit, ready to shade.
#[derive(Debug, Clone, Copy)]
pub struct SurfaceHit {
    pub t: f32,
    /// Triangle index, or triangles + sphere index.
    pub primitive: u32,
    pub point: Vec3,
    /// Unit geometric normal (the winding's side; a sphere's outside).
    pub geometric: Vec3,
    /// Unit shading normal, on the geometric normal's side of the surface.
    pub shading: Vec3,
    pub surface: u32,
    pub object: u32,
    pub face: u32,
    /// Largest coordinate of the primitive, for ray offsets.
    pub magnitude: f32,
    /// Texture coordinates, where the triangle has them.
    pub uv: Option<Vec2>,
}

/// A hit as the ray that found it sees it (`Whitted::facing`).
#[derive(Debug, Clone, Copy)]
pub struct Facing {
    pub hit: SurfaceHit,
    /// The ray meets the geometric normal's side.
    pub front: bool,
    /// Geometric and shading normals, towards the ray.
    pub n_g: Vec3,
    pub n_s: Vec3,
    /// Where rays leave it on the ray's side.
    pub lifted: Vec3,
}

/// A light as a lifted point sees it.
#[derive(Debug, Clone, Copy)]
pub struct LightGeometry {
    /// Unit direction to the light.
    pub l: Vec3,
    /// Squared distance (1 for a directional light).
    pub dist2: f32,
    /// Cosine to the shading normal.
    pub cos: f32,
    /// An emitter sample's cosine to its normal (1 otherwise).
    pub emitted: f32,
    /// The shadow ray `from + t dir`, `0 < t < t_max`: from a point light
    /// to the lifted point, or from the point towards a directional light.
    pub from: Vec3,
    pub dir: Vec3,
    pub t_max: f32,
}

/// What textures make of a surface's colours at a point: factors of its
/// ambient, diffuse and highlight colours.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureFactors {
    /// On `ka`: the checker's, times the `ka` map's (else the `kd` map's).
    pub ka: Vec3,
    /// On `kd`: the checker's, times the `kd` map's.
    pub kd: Vec3,
    /// On the highlight (`ks`): the `ks` map's.
    pub ks: Vec3,
}

/// A light's terms at a point: what reaches it (transmission times the
/// light's irradiance at normal incidence), the cosine to the shading
/// normal and the specular lobe times `ks`.
#[derive(Debug, Clone, Copy, Default)]
struct LightTerm {
    irradiance: Vec3,
    cos: f32,
    specular: Vec3,
}

/// One ray's radiance, its tree's signature and the rays it took.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RayOut {
    pub radiance: Vec3,
    /// The first hit's ambient and diffuse terms before its texture:
    /// `ka A + sum_j V_j E_j kd (N.L_j)`, so that `radiance = texture x
    /// diffuse + (the rest)` (how the bounded renderer interpolates a
    /// textured surface; `kd` for a surface that is not lit).
    pub diffuse: Vec3,
    pub signature: u32,
    pub rays: [u32; 4],
}

/// `PixelOut::rays` slots.
const PRIMARY: usize = 0;
const SHADOW: usize = 1;

impl Whitted<'_> {
    /// The CPU twin of the `whitted` kernel: pixel `pixel` (row-major).
    pub fn whitted(&self, pixel: u32) -> PixelOut {
        let media = Media::from_ids(&self.params.media[..self.params.media_len as usize]);
        let mut sum = Vec3::ZERO;
        let mut out = PixelOut::default();
        for s in 0..self.params.spp {
            let (o, d) = pixel_ray(self.params, pixel, s);
            let r = self.shade(o, d, media, None, None);
            sum += r.radiance;
            if s == 0 {
                out.signature = r.signature;
            }
            for k in 0..4 {
                out.rays[k] += r.rays[k];
            }
        }
        out.radiance = (sum / self.params.spp as f32).to_array();
        out
    }

    /// The CPU twin of the kernel's `whitted_trees`: the ray `r` in air
    /// from its given root hit (no shadow test given), its tree recorded.
    pub fn trace_tree(&self, r: &TreeRay) -> (RayOut, RayTree) {
        let (o, d) = (Vec3::from_array(r.origin), Vec3::from_array(r.dir));
        let facing = (r.root_primitive != super::scene::MISS).then(|| self.facing(o, d, r.root_t, r.root_primitive));
        let blocked = vec![None; self.params.light_count as usize];
        let given = FirstHit {
            facing,
            blocked: &blocked,
        };
        // The tree grows in a list this thread keeps from ray to ray, then
        // is copied at its size: grown afresh, every kept tree's list was
        // reallocated as it doubled (4, 8, 16 nodes), a fifth of the
        // extremal rays' time at 1280x960.
        thread_local! {
            static GROWING: RefCell<RayTree> = RefCell::new(RayTree::default());
        }
        GROWING.with_borrow_mut(|tree| {
            tree.nodes.clear();
            let out = self.shade(o, d, Media::default(), Some(&given), Some(tree));
            (out, tree.clone())
        })
    }

    /// The radiance of the ray `o + t d` (unit `d`) that starts inside
    /// `media`, with its tree recorded into `tree` when given. `first`
    /// supplies the root's triangle hit and shadow tests traced elsewhere.
    pub fn shade(
        &self,
        o: Vec3,
        d: Vec3,
        media: Media,
        first: Option<&FirstHit>,
        mut tree: Option<&mut RayTree>,
    ) -> RayOut {
        let p = self.params;
        let mut stack = [PathRay {
            origin: o,
            dir: d,
            weight: Vec3::ONE,
            depth: 0,
            kind: RayKind::Primary,
            media,
            parent: u32::MAX,
        }; MAX_DEPTH as usize + 1];
        let mut len = 1usize;
        let mut out = RayOut {
            signature: FNV_OFFSET,
            ..RayOut::default()
        };
        while len > 0 {
            len -= 1;
            let ray = stack[len];
            out.rays[ray_slot(ray.kind)] += 1;
            let given = first.filter(|_| ray.depth == 0);
            let node = tree.as_deref_mut().map(|t| {
                t.nodes.push(node_of(&ray));
                t.nodes.len() as u32 - 1
            });
            let mut sig = fnv_word(out.signature, ray_word(ray.kind, ray.depth));
            let mut found = match given {
                Some(g) => g.facing,
                None => self
                    .closest(ray.origin, ray.dir, f32::INFINITY, None)
                    .map(|(t, primitive)| self.facing(ray.origin, ray.dir, t, primitive)),
            };
            // Cut-out holes: the ray goes on from just past each one.
            let mut holes = 0;
            while let Some(f) = found.filter(|f| holes < MAX_HOLE_CROSSINGS && self.is_hole(&f.hit)) {
                holes += 1;
                let past = offset_point(f.hit.point, -f.n_g, f.hit.magnitude);
                found = self
                    .closest(past, ray.dir, f32::INFINITY, None)
                    .map(|(t, primitive)| self.facing(past, ray.dir, t, primitive));
            }
            let Some(Facing {
                hit,
                front,
                n_g,
                n_s,
                lifted,
            }) = found
            else {
                out.radiance += ray.weight * Vec3::from_array(p.background);
                sig = fnv_word(fnv_word(fnv_word(sig, MISS), MISS), MISS);
                out.signature = fnv_word(sig, children_word(false, false, false));
                continue;
            };
            sig = fnv_word(fnv_word(fnv_word(sig, hit.object), hit.face), hit.surface);
            let surf = self.scene.surface(hit.surface);
            let mut local = Vec3::from_array(surf.ke);
            let mut codes = NodeLights::new();
            let mut occluders = NodeOccluders::new();
            if surf.lit() {
                let tex = self.textures(surf, &hit);
                let (ka, kd) = (Vec3::from_array(surf.ka), Vec3::from_array(surf.kd));
                local += ka * tex.ka * Vec3::from_array(p.ambient);
                let root = ray.depth == 0;
                if root {
                    out.diffuse = ka * Vec3::from_array(p.ambient);
                }
                for j in 0..p.light_count {
                    let light = &self.scene.lights[j as usize];
                    let blocked = given.and_then(|g| g.blocked[j as usize]);
                    let (code, term) = self.light_term(light, lifted, n_g, n_s, ray.dir, surf, blocked, &mut out.rays);
                    sig = fnv_word(sig, light_word(j, code));
                    if tree.is_some() {
                        codes.push(code);
                        occluders.push(self.occluder(light, lifted, n_g, n_s, code));
                    }
                    local += term.irradiance * (kd * tex.kd * term.cos + term.specular * tex.ks);
                    if root {
                        out.diffuse += term.irradiance * (kd * term.cos);
                    }
                }
            } else {
                local += Vec3::from_array(surf.kd) * self.textures(surf, &hit).kd;
                if ray.depth == 0 {
                    out.diffuse = Vec3::from_array(surf.kd);
                }
            }
            out.radiance += ray.weight * local;

            // Children: reflected and refracted rays.
            let (mut reflected, mut refracted, mut tir) = (false, false, false);
            if ray.depth < p.max_depth {
                let mut kr = Vec3::from_array(surf.kr);
                let mut kt = Vec3::from_array(surf.kt);
                let cos_i = -ray.dir.dot(n_s);
                let fresnel = p.flags & FRESNEL != 0;
                let mut transmitted = None;
                if surf.refracts() && kt.max_element() > 0.0 {
                    let (n1, n2, inner) = if front {
                        (ray.media.ni(self.scene), surf.ni, ray.media.push(hit.surface))
                    } else {
                        let outer = ray.media.remove(hit.surface);
                        (surf.ni, outer.ni(self.scene), outer)
                    };
                    let eta = n1 / n2;
                    if fresnel {
                        let f = schlick(cos_i, n1, n2);
                        kr = Vec3::splat(f);
                        kt *= 1.0 - f;
                    }
                    let mut t = refract_dir(ray.dir, n_s, eta);
                    if t.is_some_and(|t| t.dot(n_g) >= 0.0) {
                        // The shading normal bent it back out: use the surface's.
                        t = refract_dir(ray.dir, n_g, eta);
                    }
                    match t {
                        Some(t) => transmitted = Some((t, inner)),
                        None => {
                            tir = true;
                            kr = (kr + kt).min(Vec3::ONE);
                            kt = Vec3::ZERO;
                        }
                    }
                } else if kt.max_element() > 0.0 {
                    transmitted = Some((ray.dir, ray.media));
                }
                if !surf.refracts() && fresnel && kr.max_element() > 0.0 {
                    kr = schlick_mirror(cos_i, kr);
                }
                let parent = node.unwrap_or(u32::MAX);
                if kr.max_element() > 0.0 {
                    let mut r = reflect_dir(ray.dir, n_s);
                    if r.dot(n_g) <= 0.0 {
                        r = reflect_dir(ray.dir, n_g);
                    }
                    stack[len] = PathRay {
                        origin: lifted,
                        dir: r,
                        weight: ray.weight * kr,
                        depth: ray.depth + 1,
                        kind: RayKind::Reflection,
                        media: ray.media,
                        parent,
                    };
                    len += 1;
                    reflected = true;
                }
                if let (Some((t, inner)), true) = (transmitted, kt.max_element() > 0.0) {
                    stack[len] = PathRay {
                        origin: offset_point(hit.point, -n_g, hit.magnitude),
                        dir: t,
                        weight: ray.weight * kt,
                        depth: ray.depth + 1,
                        kind: RayKind::Refraction,
                        media: inner,
                        parent,
                    };
                    len += 1;
                    refracted = true;
                }
            }
            out.signature = fnv_word(sig, children_word(reflected, refracted, tir));
            if let (Some(t), Some(n)) = (tree.as_deref_mut(), node) {
                let node = &mut t.nodes[n as usize];
                node.hit = Some(TreeHit {
                    object: hit.object,
                    face: hit.face,
                    surface: hit.surface,
                    primitive: hit.primitive,
                    t: hit.t,
                    point: hit.point,
                    front,
                });
                node.lights = codes;
                node.occluders = occluders;
                (node.reflected, node.refracted, node.tir) = (reflected, refracted, tir);
            }
        }
        out
    }

    /// The closest hit of `o + t d`, `0 < t < t_max`, among the triangles
    /// (or the given triangle hit) and the spheres: `(t, primitive)`.
    pub fn closest(&self, o: Vec3, d: Vec3, t_max: f32, given: Option<Hit>) -> Option<(f32, u32)> {
        let tri = given.unwrap_or_else(|| self.tree.closest_hit(o, d, t_max));
        let mut best = tri.is_hit().then_some((tri.t, tri.triangle));
        let mut t_best = best.map_or(t_max, |b| b.0);
        let n = self.scene.triangles.len() as u32;
        for (k, s) in self.scene.spheres[..self.params.sphere_count as usize]
            .iter()
            .enumerate()
        {
            if let Some(t) = intersect_sphere(s.center(), s.radius, o, d, t_best) {
                t_best = t;
                best = Some((t, n + k as u32));
            }
        }
        best
    }

    /// Whether anything opaque or not lies on `o + t d`, `0 < t < t_max`.
    fn any_hit(&self, o: Vec3, d: Vec3, t_max: f32, given: Option<bool>) -> bool {
        if given.unwrap_or_else(|| self.tree.any_hit(o, d, t_max)) {
            return true;
        }
        let spheres = &self.scene.spheres[..self.params.sphere_count as usize];
        spheres
            .iter()
            .any(|s| intersect_sphere(s.center(), s.radius, o, d, t_max).is_some())
    }

    /// Where and how `o + t d` meets primitive `primitive` at `t`.
    pub fn hit_info(&self, o: Vec3, d: Vec3, t: f32, primitive: u32) -> SurfaceHit {
        let n_tri = self.scene.triangles.len() as u32;
        if primitive >= n_tri {
            let s = &self.scene.spheres[(primitive - n_tri) as usize];
            let c = s.center();
            let n = (o + t * d - c).normalize();
            return SurfaceHit {
                t,
                primitive,
                point: c + s.radius * n,
                geometric: n,
                shading: n,
                surface: s.surface,
                object: s.object,
                face: 0,
                magnitude: s.magnitude(),
                uv: None,
            };
        }
        let [v0, v1, v2] = self.tree.triangles[primitive as usize];
        let (e1, e2) = (v1 - v0, v2 - v0);
        let vp = o + t * d - v0;
        // Barycentric coordinates of the hit, clamped into the triangle.
        let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (d20, d21) = (vp.dot(e1), vp.dot(e2));
        let denom = d00 * d11 - d01 * d01;
        let (mut b1, mut b2) = (0.0, 0.0);
        if denom > 0.0 {
            b1 = ((d11 * d20 - d01 * d21) / denom).clamp(0.0, 1.0);
            b2 = ((d00 * d21 - d01 * d20) / denom).clamp(0.0, 1.0 - b1);
        }
        let b0 = 1.0 - b1 - b2;
        // Edges scaled to unit size first: their cross product neither
        // underflows for tiny triangles nor overflows for huge ones.
        let scale = max_abs(e1).max(max_abs(e2));
        let geometric = (e1 / scale).cross(e2 / scale).normalize();
        let info = &self.scene.triangles[primitive as usize];
        let mut shading = geometric;
        if info.normals[0] != NO_NORMAL {
            let n = |k: usize| Vec3::from_slice(&self.scene.normals[info.normals[k] as usize][..3]);
            let s = b0 * n(0) + b1 * n(1) + b2 * n(2);
            if s.length_squared() > 0.0 {
                shading = s.normalize();
                if shading.dot(geometric) < 0.0 {
                    // Normals given for the other side than the winding's.
                    shading = -shading;
                }
            }
        }
        let uv = (info.texcoords != NO_TEXCOORDS).then(|| {
            let k = info.texcoords as usize;
            let [u0, v0, u1, v1] = self.scene.normals[k];
            let [u2, v2, _, _] = self.scene.normals[k + 1];
            b0 * Vec2::new(u0, v0) + b1 * Vec2::new(u1, v1) + b2 * Vec2::new(u2, v2)
        });
        SurfaceHit {
            t,
            primitive,
            point: v0 + b1 * e1 + b2 * e2,
            geometric,
            shading,
            surface: info.surface,
            object: info.object,
            face: info.face,
            magnitude: max_abs(v0).max(max_abs(v1)).max(max_abs(v2)),
            uv,
        }
    }

    /// The textures' factors at a hit: the checker's and the maps'
    /// (`textures` in whitted.wgsl).
    pub fn textures(&self, surf: &Surface, hit: &SurfaceHit) -> TextureFactors {
        let checker = surf.texture(hit.point);
        let mut f = TextureFactors {
            ka: checker,
            kd: checker,
            ks: Vec3::ONE,
        };
        let Some(uv) = hit.uv else {
            return f;
        };
        let table = &self.scene.textures;
        if surf.map_kd != NO_MAP {
            f.kd = checker * table.sample(surf.map_kd, uv);
            f.ka = f.kd;
        }
        if surf.map_ka != NO_MAP {
            f.ka = checker * table.sample(surf.map_ka, uv);
        }
        if surf.map_ks != NO_MAP {
            f.ks = table.sample(surf.map_ks, uv);
        }
        f
    }

    /// Whether a hit falls in a cut-out's hole (`is_hole` in whitted.wgsl).
    pub fn is_hole(&self, hit: &SurfaceHit) -> bool {
        let m = self.scene.surface(hit.surface).map_alpha;
        m != NO_MAP && hit.uv.is_some_and(|uv| self.scene.textures.is_hole(m, uv))
    }

    /// A hit seen from the ray `o + t d`: the normals turned towards the
    /// ray (the shading normal falls back to the geometric one where it
    /// faces away from the viewer) and the point lifted off the surface.
    pub fn facing(&self, o: Vec3, d: Vec3, t: f32, primitive: u32) -> Facing {
        let hit = self.hit_info(o, d, t, primitive);
        let front = d.dot(hit.geometric) < 0.0;
        let n_g = if front { hit.geometric } else { -hit.geometric };
        let mut n_s = if front { hit.shading } else { -hit.shading };
        if n_s.dot(d) >= 0.0 {
            n_s = n_g;
        }
        Facing {
            lifted: offset_point(hit.point, n_g, hit.magnitude),
            hit,
            front,
            n_g,
            n_s,
        }
    }

    /// Light `light` seen from a lifted point with normals `n_g`, `n_s`:
    /// `None` where it is behind the surface or its emitter faces away (no
    /// shadow ray is traced), else its direction and shadow ray.
    pub fn light_geometry(&self, light: &LightSample, lifted: Vec3, n_g: Vec3, n_s: Vec3) -> Option<LightGeometry> {
        let g = if light.kind == DIRECTIONAL {
            let l = -light.position();
            LightGeometry {
                l,
                dist2: 1.0,
                cos: n_s.dot(l),
                emitted: 1.0,
                from: lifted,
                dir: l,
                t_max: f32::INFINITY,
            }
        } else {
            let to = light.position() - lifted;
            let dist2 = to.dot(to);
            let l = to / dist2.sqrt();
            LightGeometry {
                l,
                dist2,
                cos: n_s.dot(l),
                emitted: 1.0,
                from: light.position(),
                dir: -to,
                t_max: 1.0,
            }
        };
        if n_g.dot(g.l) <= 0.0 || g.cos <= 0.0 {
            return None;
        }
        if light.normal() == Vec3::ZERO {
            return Some(g);
        }
        let emitted = -light.normal().dot(g.l);
        (emitted > 0.0).then_some(LightGeometry { emitted, ..g })
    }

    /// The primitive nearest the light on a blocked or filtered shadow ray
    /// (`u32::MAX` for another code): what a ray tree records as the
    /// light's occluder.
    fn occluder(&self, light: &LightSample, lifted: Vec3, n_g: Vec3, n_s: Vec3, code: LightCode) -> u32 {
        if !matches!(code, LightCode::Blocked | LightCode::Filtered) {
            return u32::MAX;
        }
        self.light_geometry(light, lifted, n_g, n_s)
            .and_then(|g| self.closest(g.from, g.dir, g.t_max, None))
            .map_or(u32::MAX, |(_, primitive)| primitive)
    }

    /// Light `light`'s contribution at the lifted point `lifted` with
    /// normals facing the viewer, seen along `d`: its code and its terms
    /// (the caller adds `irradiance (kd cos + specular)`, `kd` textured).
    #[allow(clippy::too_many_arguments)]
    fn light_term(
        &self,
        light: &LightSample,
        lifted: Vec3,
        n_g: Vec3,
        n_s: Vec3,
        d: Vec3,
        surf: &Surface,
        blocked: Option<bool>,
        rays: &mut [u32; 4],
    ) -> (LightCode, LightTerm) {
        let none = LightTerm::default();
        let Some(g) = self.light_geometry(light, lifted, n_g, n_s) else {
            return (LightCode::FacesAway, none);
        };
        let (filter, code) = self.transmittance(g.from, g.dir, g.t_max, blocked, rays);
        if code == LightCode::Blocked {
            return (code, none);
        }
        let e = light.intensity() * (g.emitted / g.dist2);
        let h = (g.l - d).normalize();
        let n_h = n_s.dot(h);
        let mut specular = Vec3::ZERO;
        if n_h > 0.0 {
            specular = Vec3::from_array(surf.ks) * n_h.powf(surf.ns);
        }
        let term = LightTerm {
            irradiance: filter * e,
            cos: g.cos,
            specular,
        };
        (code, term)
    }

    /// What reaches the end of the shadow ray `o + t d`, `0 < t < t_max`:
    /// the product of the transmission of what it passes, and its code.
    fn transmittance(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        blocked: Option<bool>,
        rays: &mut [u32; 4],
    ) -> (Vec3, LightCode) {
        if self.params.transmissive == 0 {
            rays[SHADOW] += 1;
            return if self.any_hit(o, d, t_max, blocked) {
                (Vec3::ZERO, LightCode::Blocked)
            } else {
                (Vec3::ONE, LightCode::Visible)
            };
        }
        let end = o + d * t_max;
        let (mut origin, mut dir, mut filter, mut code) = (o, d, Vec3::ONE, LightCode::Visible);
        for _ in 0..MAX_SHADOW_CROSSINGS {
            rays[SHADOW] += 1;
            let Some((t, primitive)) = self.closest(origin, dir, t_max, None) else {
                return (filter, code);
            };
            let hit = self.hit_info(origin, dir, t, primitive);
            let surf = self.scene.surface(hit.surface);
            // A cut-out's hole lets the light through unfiltered.
            if !self.is_hole(&hit) {
                if !surf.transmits() {
                    return (Vec3::ZERO, LightCode::Blocked);
                }
                filter *= Vec3::from_array(surf.kt);
            }
            code = LightCode::Filtered;
            let through = if dir.dot(hit.geometric) > 0.0 {
                hit.geometric
            } else {
                -hit.geometric
            };
            origin = offset_point(hit.point, through, hit.magnitude);
            if t_max.is_finite() {
                dir = end - origin;
            }
        }
        (Vec3::ZERO, LightCode::Blocked)
    }
}

fn ray_slot(kind: RayKind) -> usize {
    match kind {
        RayKind::Primary => PRIMARY,
        RayKind::Reflection => 2,
        RayKind::Refraction => 3,
    }
}

fn node_of(ray: &PathRay) -> RayNode {
    RayNode {
        kind: ray.kind,
        depth: ray.depth,
        parent: (ray.parent != u32::MAX).then_some(ray.parent),
        origin: ray.origin,
        dir: ray.dir,
        weight: ray.weight,
        hit: None,
        lights: NodeLights::new(),
        occluders: NodeOccluders::new(),
        reflected: false,
        refracted: false,
        tir: false,
    }
}

/// The ray of sample `sample` of pixel `pixel`: through the pixel's centre
/// with one sample, else through an Owen-scrambled Sobol point of the
/// pixel (seeded by `params.seed`, one stream per pixel).
pub fn pixel_ray(params: &WhittedUniforms, pixel: u32, sample: u32) -> (Vec3, Vec3) {
    let (x, y) = (pixel % params.width, pixel / params.width);
    let [jx, jy] = if params.spp == 1 {
        [0.5, 0.5]
    } else {
        SampleSequence::new(params.seed).sample(pixel, sample)
    };
    let sx = 2.0 * (x as f32 + jx) / params.width as f32 - 1.0;
    let sy = 1.0 - 2.0 * (y as f32 + jy) / params.height as f32;
    let d = Vec3::from_array(params.forward) + sx * Vec3::from_array(params.right) + sy * Vec3::from_array(params.up);
    (Vec3::from_array(params.eye), d.normalize())
}

/// An error naming the first of `pixels` outside the image `params`
/// describes (a list of pixels to render).
pub fn check_pixels(params: &WhittedUniforms, pixels: &[u32]) -> crate::error::Result<()> {
    let total = params.width as u64 * params.height as u64;
    match pixels.iter().find(|&&p| p as u64 >= total) {
        Some(&p) => Err(crate::error::Error::param(
            "pixels",
            format!("pixel {p} is outside the {}x{} image", params.width, params.height),
        )),
        None => Ok(()),
    }
}
