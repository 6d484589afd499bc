//! The G-buffer: per pixel the camera-space normal and depth, the radiance
//! (albedo x direct light) and the albedo. `wgsl/gbuffer.wgsl` rasterises
//! it (`gpu::GBufferPass`); `gbuffer` is its CPU twin, built from kd-tree
//! primary rays through the same pixel centres.
//!
//! Layout (two `Rgba32Float` targets, the same on the CPU):
//! * `geometry[i] = (n.x, n.y, n.z, z)`: the unit face normal in camera space
//!   (x right, y up, z forward), turned towards the camera, and the
//!   camera-space depth z > 0. Background pixels are all zero (z = 0).
//! * `shade[i] = (L.r, L.g, L.b, albedo)`: reflected direct radiance
//!   L = a * sum over lights of E cos+ (no shadows), and the albedo a
//!   packed exactly into one float as r + 256 g + 65536 b (8 bits each).
//!
//! Albedo: a material's diffuse colour, times its colour map where it has
//! one (`surfaces`: the map is read at the pixel's surface point). The
//! shared models have no materials, so each object of such a mesh (an OBJ
//! `o`/`g` block, or a scene instance) gets a colour from a fixed palette;
//! colour bleeding in the indirect term needs some variety. Alpha cut-outs'
//! holes are no surface: a pixel shows what lies behind them.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use rayon::prelude::*;

use super::surfaces::GBufferSurfaces;
use crate::accel::kdtree::KdTree;
use crate::error::{Error, Result};
use crate::scene::{Camera, Light, Mesh};

/// Depths above this are treated as background, like 0, NaN and infinity
/// (a far plane written as a huge value must not make sums infinite).
pub const MAX_DEPTH: f32 = 3.0e38;

/// Whether `d` is the depth of a surface: 0 < d <= MAX_DEPTH (`valid_depth`
/// in the WGSL).
#[inline]
pub fn valid_depth(d: f32) -> bool {
    d > 0.0 && d <= MAX_DEPTH
}

/// Camera-space view of the G-buffer: what the SSAO kernels need to turn a
/// pixel and its depth into a point and back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenView {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// tan(fov/2) x width / height: half the image's width at depth 1.
    pub tan_half_x: f32,
    /// tan(fov/2), fov the camera's vertical field of view: half the image's
    /// height at depth 1.
    pub tan_half_y: f32,
}

impl ScreenView {
    /// The view of `camera` (its vertical field of view) at `width` x `height`
    /// pixels.
    pub fn new(camera: &Camera, width: u32, height: u32) -> ScreenView {
        let tan_half_y = (0.5 * camera.fov_degrees.to_radians()).tan();
        ScreenView {
            width,
            height,
            tan_half_x: tan_half_y * width as f32 / height as f32,
            tan_half_y,
        }
    }

    /// Constants precomputed once for CPU and GPU alike, so that both do
    /// the same arithmetic.
    pub fn constants(&self) -> ScreenConstants {
        ScreenConstants {
            width: self.width,
            height: self.height,
            tan_half_x: self.tan_half_x,
            tan_half_y: self.tan_half_y,
            inv_tan_half_x: 1.0 / self.tan_half_x,
            inv_tan_half_y: 1.0 / self.tan_half_y,
            half_w: 0.5 * self.width as f32,
            half_h: 0.5 * self.height as f32,
            px_x: 2.0 / self.width as f32,
            px_y: 2.0 / self.height as f32,
        }
    }
}

/// See `ScreenView::constants`; mirrored field by field in `SsaoUniforms`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenConstants {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// tan(fov/2) x width / height: half the image's width at depth 1.
    pub tan_half_x: f32,
    /// tan(fov/2): half the image's height at depth 1.
    pub tan_half_y: f32,
    /// 1 / `tan_half_x`.
    pub inv_tan_half_x: f32,
    /// 1 / `tan_half_y`.
    pub inv_tan_half_y: f32,
    /// Half the width in pixels.
    pub half_w: f32,
    /// Half the height in pixels.
    pub half_h: f32,
    /// A pixel's width in normalised device coordinates: 2 / width.
    pub px_x: f32,
    /// A pixel's height in normalised device coordinates: 2 / height.
    pub px_y: f32,
}

impl ScreenConstants {
    /// Camera-space point of pixel (x, y)'s centre at depth z (`cam_point`
    /// in `wgsl/ssao_common.wgsl`).
    #[inline]
    pub fn cam_point(&self, x: u32, y: u32, z: f32) -> Vec3 {
        let ndc_x = (x as f32 + 0.5) * self.px_x - 1.0;
        let ndc_y = 1.0 - (y as f32 + 0.5) * self.px_y;
        Vec3::new(ndc_x * self.tan_half_x * z, ndc_y * self.tan_half_y * z, z)
    }

    /// The pixel a camera-space point projects to, or None outside the
    /// image or behind the camera (`project` in the WGSL).
    #[inline]
    pub fn project(&self, p: Vec3) -> Option<(u32, u32)> {
        if p.z <= 0.0 {
            return None;
        }
        let inv_z = 1.0 / p.z;
        let fx = (p.x * inv_z * self.inv_tan_half_x + 1.0) * self.half_w;
        let fy = (1.0 - p.y * inv_z * self.inv_tan_half_y) * self.half_h;
        let inside = fx >= 0.0 && fx < self.width as f32 && fy >= 0.0 && fy < self.height as f32;
        inside.then_some((fx as u32, fy as u32))
    }

    /// (fx z, fy z, z) of camera-space p, where (fx, fy) is where `project`
    /// puts it (before truncation; `homogeneous` in the WGSL). Linear in
    /// p: a pixel maps its tangent frame once (`HomogeneousFrame`) and each
    /// sample costs a multiply-add per axis and coordinate.
    #[inline]
    pub fn homogeneous(&self, p: Vec3) -> Vec3 {
        Vec3::new(
            (p.x * self.inv_tan_half_x + p.z) * self.half_w,
            (p.z - p.y * self.inv_tan_half_y) * self.half_h,
            p.z,
        )
    }

    /// The pixel of h = `homogeneous(p)`, or None outside the image or
    /// behind the camera (`occluded_homogeneous` in the WGSL).
    #[inline]
    pub fn project_homogeneous(&self, h: Vec3) -> Option<(u32, u32)> {
        // NaN falls through to the bounds test, which it fails.
        if h.z <= 0.0 {
            return None;
        }
        let inv_z = 1.0 / h.z;
        let (fx, fy) = (h.x * inv_z, h.y * inv_z);
        let inside = fx >= 0.0 && fx < self.width as f32 && fy >= 0.0 && fy < self.height as f32;
        inside.then_some((fx as u32, fy as u32))
    }
}

/// A W x H G-buffer, row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct GBuffer {
    /// Width W in pixels.
    pub width: u32,
    /// Height H in pixels.
    pub height: u32,
    /// Per pixel, row-major: (n.x, n.y, n.z, z), the unit face normal in camera
    /// space (x right, y up, z forward) turned towards the camera, and the
    /// camera-space depth z > 0; all zero on the background.
    pub geometry: Vec<[f32; 4]>,
    /// Per pixel: (L.r, L.g, L.b, albedo), the reflected direct radiance
    /// (albedo x direct light, no shadows) and the packed albedo
    /// (`pack_albedo`); all zero on the background.
    pub shade: Vec<[f32; 4]>,
}

impl GBuffer {
    /// Pixels: W x H.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Camera-space depth of pixel `i` (row-major); 0 on the background.
    pub fn depth(&self, i: usize) -> f32 {
        self.geometry[i][3]
    }

    /// Camera-space unit normal of pixel `i`; zero on the background.
    pub fn normal(&self, i: usize) -> Vec3 {
        let g = self.geometry[i];
        Vec3::new(g[0], g[1], g[2])
    }

    /// Whether pixel i shows a surface (`valid_depth`).
    pub fn is_surface(&self, i: usize) -> bool {
        valid_depth(self.geometry[i][3])
    }

    /// Pixels that show a surface.
    pub fn surface_pixels(&self) -> usize {
        (0..self.pixels()).filter(|&i| self.is_surface(i)).count()
    }
}

/// Albedo packed into one float, exactly: r + 256 g + 65536 b < 2^24.
pub fn pack_albedo(rgb: [u8; 3]) -> f32 {
    (rgb[0] as u32 + 256 * rgb[1] as u32 + 65536 * rgb[2] as u32) as f32
}

/// The albedo, each channel in [0, 1], of a value of `pack_albedo`.
pub fn unpack_albedo(v: f32) -> Vec3 {
    let b = v as u32;
    Vec3::new((b & 255) as f32, ((b >> 8) & 255) as f32, ((b >> 16) & 255) as f32) * (1.0 / 255.0)
}

/// The palette colour of object `o`: object 0 a light clay, the others
/// hashed into albedos between 0.35 and 0.85 per channel.
pub fn object_albedo(o: usize) -> [u8; 3] {
    if o == 0 {
        return [205, 190, 170];
    }
    let h = crate::geom::sampling::hash_u32(o as u32 ^ 0x051a_bed0);
    let c = |shift: u32| (90 + ((h >> shift) & 0x7f)) as u8;
    [c(0), c(8), c(16)]
}

/// Packed albedo of every triangle of `mesh`, by object.
pub fn triangle_albedos(mesh: &Mesh) -> Vec<f32> {
    let mut out = vec![pack_albedo(object_albedo(0)); mesh.triangles.len()];
    for (o, obj) in mesh.objects.iter().enumerate() {
        let a = pack_albedo(object_albedo(o));
        for t in obj.triangles.clone() {
            if let Some(slot) = out.get_mut(t as usize) {
                *slot = a;
            }
        }
    }
    out
}

/// Packed albedo of every triangle of `scene.world_mesh(|_| true)`: the
/// diffuse colour `Kd` of its material where it has one (the instance's
/// scene-file material, else the OBJ's MTL material of the triangle; a
/// triangle with no `usemtl` has none), else its instance's palette colour
/// as `triangle_albedos` gives it. `Kd` is clamped to [0, 1] and rounded to
/// 8 bits, as the G-buffer stores albedo.
pub fn scene_albedos(scene: &crate::scene::Scene) -> Vec<f32> {
    let mut out = Vec::new();
    for (o, inst) in scene.instances.iter().enumerate() {
        let source = &scene.meshes[inst.mesh];
        let named = inst
            .material
            .as_ref()
            .and_then(|n| scene.materials.iter().find(|m| &m.name == n));
        let shading = source.shading.as_ref();
        out.extend((0..source.mesh.triangles.len()).map(|t| {
            let own = shading.and_then(|s| {
                let m = s.triangle_materials[t] as usize;
                (m != 0).then(|| s.materials[m].kd)
            });
            match named.map(|m| m.kd).or(own) {
                Some(kd) => pack_albedo(kd.to_array().map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)),
                None => pack_albedo(object_albedo(o)),
            }
        }));
    }
    out
}

/// The lights of the G-buffer's direct term. Directional lights' `direction`
/// is the direction the light travels.
pub fn lights_or_default(lights: &[Light]) -> Vec<Light> {
    if lights.is_empty() {
        vec![Light::default_light()]
    } else {
        lights.to_vec()
    }
}

/// At most this many lights reach the GPU's uniform.
pub const MAX_LIGHTS: usize = 4;

/// Checks that the G-buffer takes `lights`: at most `MAX_LIGHTS`.
pub fn validate_lights(lights: &[Light]) -> Result<()> {
    if lights.len() > MAX_LIGHTS {
        return Err(Error::param(
            "scene",
            format!(
                "lights: the G-buffer takes at most {MAX_LIGHTS} lights, the scene has {}",
                lights.len()
            ),
        ));
    }
    Ok(())
}

/// Direct radiance (before albedo) at world point p with normal n
/// (`direct_light` in `wgsl/gbuffer.wgsl`).
pub fn direct_light(lights: &[Light], p: Vec3, n: Vec3) -> Vec3 {
    let mut e = Vec3::ZERO;
    for light in lights {
        match *light {
            Light::Directional { direction, radiance } => {
                let l = -direction.normalize_or_zero();
                e += radiance * n.dot(l).max(0.0);
            }
            Light::Point { position, intensity } => {
                let d = position - p;
                let d2 = d.length_squared().max(1e-12);
                e += intensity * (n.dot(d) / d2.sqrt()).max(0.0) / d2;
            }
        }
    }
    e
}

/// The G-buffer texel of a hit: world point `p`, unit world face normal `n`
/// (zero for degenerate triangles), seen from `camera`.
pub fn texel(camera: &Camera, lights: &[Light], p: Vec3, n: Vec3, albedo: f32) -> ([f32; 4], [f32; 4]) {
    let (right, up, forward) = camera.basis();
    let rel = p - camera.eye;
    let n = if n.dot(rel) > 0.0 { -n } else { n };
    let nc = [n.dot(right), n.dot(up), n.dot(forward)];
    let z = rel.dot(forward);
    let radiance = unpack_albedo(albedo) * direct_light(lights, p, n);
    ([nc[0], nc[1], nc[2], z], [radiance.x, radiance.y, radiance.z, albedo])
}

/// CPU twin of the G-buffer pass: the closest hit of each pixel's primary
/// ray through its centre (the rasteriser samples pixel centres too).
pub fn gbuffer(tree: &KdTree, mesh: &Mesh, camera: &Camera, lights: &[Light], width: u32, height: u32) -> GBuffer {
    gbuffer_with(
        tree,
        mesh,
        &GBufferSurfaces::palette(mesh),
        camera,
        lights,
        (width, height),
    )
}

/// `gbuffer` with the surfaces given (`GBufferSurfaces::of_scene`): each
/// pixel shows the first surface past the cut-outs' holes, with its albedo
/// at the point.
pub fn gbuffer_with(
    tree: &KdTree,
    mesh: &Mesh,
    surfaces: &GBufferSurfaces,
    camera: &Camera,
    lights: &[Light],
    (width, height): (u32, u32),
) -> GBuffer {
    let rays = camera.primary_rays(width, height);
    let lights = lights_or_default(lights);
    let (geometry, shade) = rays
        .par_iter()
        .with_min_len(256)
        .map(|r| {
            let Some((t, p)) = surfaces.first_surface(tree, mesh, r.o(), r.d()) else {
                return ([0.0; 4], [0.0; 4]);
            };
            let n = mesh.unit_face_normal(t);
            let (g, s) = texel(camera, &lights, p, n, surfaces.albedo(mesh, t, p));
            // A hit exactly at the eye has no depth: keep it background.
            if g[3] > 0.0 { (g, s) } else { ([0.0; 4], [0.0; 4]) }
        })
        .unzip();
    GBuffer {
        width,
        height,
        geometry,
        shade,
    }
}

/// World-space point and normal of a G-buffer pixel (for ray-traced truth
/// at the same points).
pub fn world_point(camera: &Camera, sc: &ScreenConstants, gb: &GBuffer, x: u32, y: u32) -> (Vec3, Vec3) {
    let i = (y * gb.width + x) as usize;
    let c = sc.cam_point(x, y, gb.depth(i));
    let n = gb.normal(i);
    let (right, up, forward) = camera.basis();
    (
        camera.eye + right * c.x + up * c.y + forward * c.z,
        (right * n.x + up * n.y + forward * n.z).normalize_or_zero(),
    )
}

/// `View` in `wgsl/gbuffer.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct ViewUniform {
    /// The camera's position, world space.
    pub eye: [f32; 3],
    /// Lights in `lights` (at most `MAX_LIGHTS`).
    pub light_count: u32,
    /// The camera's unit right axis, world space.
    pub right: [f32; 3],
    /// tan(fov/2) x width / height.
    pub tan_half_x: f32,
    /// The camera's unit up axis, world space.
    pub up: [f32; 3],
    /// tan(fov/2), fov the vertical field of view.
    pub tan_half_y: f32,
    /// The camera's unit viewing direction, world space.
    pub forward: [f32; 3],
    /// Camera-space depth of the near plane (reversed-Z projection, infinite
    /// far plane): nearer geometry is clipped.
    pub near: f32,
    /// Per light: (position or travel direction, 1 = point / 0 = directional),
    /// (intensity or radiance, 0).
    pub lights: [[[f32; 4]; 2]; MAX_LIGHTS],
}

impl ViewUniform {
    /// `near`: the near plane (camera-space z); nearer geometry is clipped.
    pub fn new(camera: &Camera, view: &ScreenView, lights: &[Light], near: f32) -> ViewUniform {
        let (right, up, forward) = camera.basis();
        let mut packed = [[[0.0; 4]; 2]; MAX_LIGHTS];
        let lights = lights_or_default(lights);
        for (slot, light) in packed.iter_mut().zip(&lights) {
            *slot = match *light {
                Light::Directional { direction, radiance } => {
                    let d = direction.normalize_or_zero();
                    [[d.x, d.y, d.z, 0.0], [radiance.x, radiance.y, radiance.z, 0.0]]
                }
                Light::Point { position, intensity } => [
                    [position.x, position.y, position.z, 1.0],
                    [intensity.x, intensity.y, intensity.z, 0.0],
                ],
            };
        }
        ViewUniform {
            eye: camera.eye.to_array(),
            light_count: lights.len().min(MAX_LIGHTS) as u32,
            right: right.to_array(),
            tan_half_x: view.tan_half_x,
            up: up.to_array(),
            tan_half_y: view.tan_half_y,
            forward: forward.to_array(),
            near,
            lights: packed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn albedo_packing_is_exact() {
        for rgb in [[0, 0, 0], [255, 255, 255], [1, 2, 3], [205, 190, 170]] {
            let v = unpack_albedo(pack_albedo(rgb));
            let back = [v.x, v.y, v.z].map(|c| (c * 255.0).round() as u8);
            assert_eq!(back, rgb);
        }
    }

    #[test]
    fn projection_inverts_cam_point() {
        let cam = Camera {
            eye: Vec3::ZERO,
            target: Vec3::Z,
            fov_degrees: 50.0,
        };
        let sc = ScreenView::new(&cam, 37, 23).constants();
        for y in 0..23 {
            for x in 0..37 {
                let p = sc.cam_point(x, y, 3.7);
                assert_eq!(sc.project(p), Some((x, y)));
            }
        }
        assert_eq!(sc.project(Vec3::new(0.0, 0.0, -1.0)), None);
        assert_eq!(sc.project(Vec3::new(100.0, 0.0, 1.0)), None);
    }

    #[test]
    fn homogeneous_projection_finds_the_same_pixels() {
        let cam = Camera {
            eye: Vec3::ZERO,
            target: Vec3::Z,
            fov_degrees: 60.0,
        };
        let sc = ScreenView::new(&cam, 37, 23).constants();
        // Points a quarter pixel off the centres, at several depths: the
        // same pixel as `project`, and the map is linear.
        for z in [0.3f32, 1.0, 7.5] {
            for y in 0..23 {
                for x in 0..37 {
                    let c = sc.cam_point(x, y, z);
                    let off = Vec3::new(
                        0.25 * sc.px_x * sc.tan_half_x * z,
                        -0.25 * sc.px_y * sc.tan_half_y * z,
                        0.0,
                    );
                    let p = c + off;
                    assert_eq!(sc.project_homogeneous(sc.homogeneous(p)), Some((x, y)));
                    assert_eq!(sc.project(p), Some((x, y)));
                    let sum = sc.homogeneous(c) + sc.homogeneous(off);
                    assert!((sum - sc.homogeneous(p)).length() <= 1e-4 * sum.length());
                }
            }
        }
        for p in [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(100.0, 0.0, 1.0),
            Vec3::new(0.0, -100.0, 1.0),
        ] {
            assert_eq!(sc.project_homogeneous(sc.homogeneous(p)), None);
        }
        assert_eq!(sc.project_homogeneous(Vec3::splat(f32::NAN)), None);
    }

    #[test]
    fn cam_point_matches_the_cameras_rays() {
        let cam = Camera {
            eye: Vec3::new(1.0, 2.0, 3.0),
            target: Vec3::new(-2.0, 0.5, 0.0),
            fov_degrees: 45.0,
        };
        let (w, h) = (16, 9);
        let sc = ScreenView::new(&cam, w, h).constants();
        let (right, up, forward) = cam.basis();
        for (i, r) in cam.primary_rays(w, h).iter().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let p = r.o() + 2.0 * r.d();
            let z = (p - cam.eye).dot(forward);
            let c = sc.cam_point(x, y, z);
            let world = cam.eye + right * c.x + up * c.y + forward * c.z;
            assert!((world - p).length() < 1e-5, "{x},{y}");
        }
    }
}
