//! Smooth patches: the linetree surfaces of tessellated meshes.
//!
//! The paper's objects are analytic (spheres, cylinders, cones: section
//! 8.2), and its linetrees hang off objects, "or smooth surface patches"
//! as the issue puts it. A mesh with shading normals is a smooth surface
//! whose triangles, at any useful resolution, each cover a few pixels: a
//! linetree per triangle would need cells smaller than its triangle, which
//! the cost model never builds, so nothing on a user's scanned or modelled
//! mesh was ever interpolated. Here the smooth triangles of one object with
//! one surface that neither reflects nor refracts form one patch, and one
//! linetree per face pair covers the patch: a cell's extremal rays may land
//! on different triangles of it. How the predicate bounds a cell over
//! several triangles is in `predicate::Predicate::patch_hit`; a pixel is
//! interpolated only when its own hit (found by the kd-tree, exactly) lies
//! on a triangle the predicate covered (`Accepted::covers`).
//!
//! Off by default (`BoundedSettings::patches`): on the shared meshes the
//! cells cost more than they save (docs/results/bounded.md).
//!
//! Reflective and refractive smooth surfaces keep a linetree per triangle:
//! their children's shafts start on the patch, and proving that no
//! triangle of the patch blocks a reflected ray from another is not built.

use std::sync::OnceLock;

use glam::{DVec3, Vec3};

use crate::accel::kdtree::{KdTree, KdTreeSettings};
use crate::bounded::affine::AVec3;
use crate::bounded::geometry::Polygon;
use crate::geom::aabb::Aabb;
use crate::whitted::RenderScene;
use crate::whitted::scene::{NO_NORMAL, SMOOTH_FACE};

/// Marks a triangle that belongs to no patch.
pub const NO_PATCH: u32 = u32::MAX;

/// The smooth triangles of one object and one surface.
#[derive(Debug)]
pub struct Patch {
    /// Its triangles (indices into the scene's), ascending.
    pub triangles: Vec<u32>,
    pub bounds: Aabb,
    /// Per triangle of `triangles` (same order), the patch's triangles
    /// that share an edge with it (the same two vertex positions).
    neighbours: Vec<Vec<u32>>,
    /// Its triangles' vertices (f32, as the renderer's kd-tree holds them).
    vertices: Vec<[Vec3; 3]>,
    /// A kd-tree over the patch alone, made the first time a line asks
    /// where it meets the patch (`first_hit`); `None` if it cannot be made.
    tree: OnceLock<Option<KdTree>>,
}

/// Every patch of `scene` and each triangle's patch (`NO_PATCH` for flat
/// triangles and those of mirrors and glass), in a repeatable order: by
/// object, then surface.
pub fn patches_of(scene: &RenderScene, triangles: &[[Vec3; 3]]) -> (Vec<Patch>, Vec<u32>) {
    let mut keys: Vec<(u32, u32, u32)> = scene
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, s)| s.face == SMOOTH_FACE && s.normals[0] != NO_NORMAL)
        .filter(|(_, s)| {
            let surface = scene.surface(s.surface);
            surface.kr == [0.0; 3] && surface.kt == [0.0; 3]
        })
        .map(|(t, s)| (s.object, s.surface, t as u32))
        .collect();
    keys.sort_unstable();
    let mut patches: Vec<Patch> = Vec::new();
    let mut of = vec![NO_PATCH; scene.triangles.len()];
    let mut last = None;
    for (object, surface, t) in keys {
        if last != Some((object, surface)) {
            last = Some((object, surface));
            patches.push(Patch {
                triangles: Vec::new(),
                bounds: Aabb::EMPTY,
                neighbours: Vec::new(),
                vertices: Vec::new(),
                tree: OnceLock::new(),
            });
        }
        let patch = patches.last_mut().expect("pushed above");
        patch.triangles.push(t);
        patch.vertices.push(triangles[t as usize]);
        for v in triangles[t as usize] {
            patch.bounds = patch.bounds.grow(v);
        }
        of[t as usize] = patches.len() as u32 - 1;
    }
    for patch in &mut patches {
        patch.neighbours = edge_neighbours(&patch.triangles, &patch.vertices);
    }
    (patches, of)
}

/// The edge between two vertices, whichever way round: triangles share an
/// edge where they share both vertices' positions bit for bit.
pub(crate) fn edge_key(a: Vec3, b: Vec3) -> ([u32; 3], [u32; 3]) {
    let (a, b) = (a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits));
    if a <= b { (a, b) } else { (b, a) }
}

/// For each of `own` (the scene's indices, with their `vertices`), the
/// others of `own` that share an edge with it.
fn edge_neighbours(own: &[u32], vertices: &[[Vec3; 3]]) -> Vec<Vec<u32>> {
    let mut by_edge: std::collections::HashMap<_, Vec<u32>> = std::collections::HashMap::new();
    for (&t, v) in own.iter().zip(vertices) {
        for k in 0..3 {
            by_edge.entry(edge_key(v[k], v[(k + 1) % 3])).or_default().push(t);
        }
    }
    own.iter()
        .zip(vertices)
        .map(|(&t, v)| {
            let mut n: Vec<u32> = (0..3)
                .flat_map(|k| by_edge[&edge_key(v[k], v[(k + 1) % 3])].iter().copied())
                .filter(|&u| u != t)
                .collect();
            n.sort_unstable();
            n.dedup();
            n
        })
        .collect()
}

impl Patch {
    /// The triangles of the patch that share an edge with triangle `t` (a
    /// triangle of it, the scene's index).
    pub fn neighbours_of(&self, t: u32) -> &[u32] {
        match self.triangles.binary_search(&t) {
            Ok(i) => &self.neighbours[i],
            Err(_) => &[],
        }
    }

    /// Where the line `o + t d` (unit `d`) first meets the patch, `t > 0`,
    /// ignoring everything else: the distance and the triangle (the
    /// scene's index).
    pub fn first_hit(&self, o: DVec3, d: DVec3) -> Option<(f64, u32)> {
        let tree = self
            .tree
            .get_or_init(|| KdTree::from_triangles(self.vertices.clone(), &KdTreeSettings::for_cpu()).ok())
            .as_ref()?;
        let hit = tree.closest_hit(o.as_vec3(), d.as_vec3(), f32::INFINITY);
        hit.is_hit()
            .then(|| (hit.t as f64, self.triangles[hit.triangle as usize]))
    }
}

/// The convex polygon `poly` clipped to the box `[lo, hi]` (Sutherland and
/// Hodgman, one slab side at a time); empty if nothing of it is inside.
pub(crate) fn clip_to_box(mut poly: Vec<DVec3>, lo: DVec3, hi: DVec3) -> Vec<DVec3> {
    for axis in 0..3 {
        for (bound, keep_above) in [(lo[axis], true), (hi[axis], false)] {
            let inside = |p: &DVec3| if keep_above { p[axis] >= bound } else { p[axis] <= bound };
            let mut out = Vec::with_capacity(poly.len() + 2);
            for k in 0..poly.len() {
                let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                if inside(&a) {
                    out.push(a);
                }
                if inside(&a) != inside(&b) {
                    let s = (bound - a[axis]) / (b[axis] - a[axis]);
                    let mut x = a + (b - a) * s;
                    x[axis] = bound;
                    out.push(x);
                }
            }
            poly = out;
            if poly.is_empty() {
                return poly;
            }
        }
    }
    poly
}

/// A smooth triangle's blend of its corner normals at point `x` (not
/// normalised), by `x`'s barycentric coordinates: an affine function of
/// the point, as `smooth_normal` and the renderer compute it.
pub(crate) fn barycentric_blend<'a>(p: &'a Polygon, normals: &'a [DVec3; 3]) -> impl Fn(DVec3) -> DVec3 + 'a {
    let (v0, k1, k2) = p.barycentric_duals();
    move |x| {
        let rel = x - v0;
        let (b1, b2) = (rel.dot(k1), rel.dot(k2));
        normals[0] * (1.0 - b1 - b2) + normals[1] * b1 + normals[2] * b2
    }
}

/// An affine field of shading normals over a patch region, `n(x) = c +
/// gu (x - o) . u + gv (x - o) . v` (`u`, `v` spanning a plane), fitted
/// by least squares to the corner normals of the region's triangles.
/// Within a triangle the renderer's blend is affine too, so its distance
/// from the field is largest at a corner: `deviation` over the corners
/// bounds it over the whole region.
pub(crate) struct NormalField {
    o: DVec3,
    u: DVec3,
    v: DVec3,
    /// Per component: constant, and slopes along `u` and `v`.
    coef: [[f64; 3]; 3],
}

impl NormalField {
    /// The field of the corners `(point, normal)` over the plane of
    /// `normal`; `None` if they do not span it.
    pub(crate) fn fit(normal: DVec3, corners: &[(DVec3, DVec3)]) -> Option<NormalField> {
        let o = corners.iter().map(|c| c.0).sum::<DVec3>() / corners.len() as f64;
        let (u, v) = normal.any_orthonormal_pair();
        let coords: Vec<[f64; 3]> = corners
            .iter()
            .map(|c| [1.0, (c.0 - o).dot(u), (c.0 - o).dot(v)])
            .collect();
        let mut ata = [[0.0f64; 3]; 3];
        for a in &coords {
            for i in 0..3 {
                for j in 0..3 {
                    ata[i][j] += a[i] * a[j];
                }
            }
        }
        let inv = invert3(ata)?;
        let mut coef = [[0.0; 3]; 3];
        for (comp, out) in coef.iter_mut().enumerate() {
            let mut atb = [0.0; 3];
            for (a, c) in coords.iter().zip(corners) {
                for i in 0..3 {
                    atb[i] += a[i] * c.1[comp];
                }
            }
            for i in 0..3 {
                out[i] = (0..3).map(|j| inv[i][j] * atb[j]).sum();
            }
        }
        coef.iter()
            .flatten()
            .all(|x| x.is_finite())
            .then_some(NormalField { o, u, v, coef })
    }

    fn at(&self, x: DVec3) -> DVec3 {
        let (a, b) = ((x - self.o).dot(self.u), (x - self.o).dot(self.v));
        DVec3::from_array(self.coef.map(|c| c[0] + c[1] * a + c[2] * b))
    }

    /// The field over the points `q`.
    pub(crate) fn at_form(&self, q: &AVec3) -> AVec3 {
        let rel = q.add_const(-self.o);
        let (a, b) = (rel.dot_const(self.u), rel.dot_const(self.v));
        let comp = |c: [f64; 3]| a.scale(c[1]).add(b.scale(c[2])).add_const(c[0]);
        AVec3::new(comp(self.coef[0]), comp(self.coef[1]), comp(self.coef[2]))
    }

    /// The largest distance, per component, of a corner's normal from the
    /// field.
    pub(crate) fn deviation(&self, corners: &[(DVec3, DVec3)]) -> DVec3 {
        corners
            .iter()
            .fold(DVec3::ZERO, |m, c| m.max((c.1 - self.at(c.0)).abs()))
    }
}

/// The inverse of a 3x3 matrix, or `None` where it is (nearly) singular.
fn invert3(m: [[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    let scale = m.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
    // NaN (a degenerate fit) fails as well.
    if det.abs().partial_cmp(&(1e-12 * scale.powi(3))) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    Some(std::array::from_fn(|i| std::array::from_fn(|j| c(j, i) / det)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::device::Device;
    use crate::progress::Reporter;
    use crate::whitted::{LightingSettings, WhittedRenderer};

    fn renderer(file: &str) -> WhittedRenderer {
        let scene = crate::scene::load_scene_shaded(
            &std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/raytrace")).join(file),
        )
        .expect("scene");
        let rs = RenderScene::new(&scene, 0, &LightingSettings::default()).expect("render scene");
        WhittedRenderer::new(&Device::cpu(), rs, &Reporter::silent()).expect("renderer")
    }

    /// Clipping keeps what lies in the box, on the triangle's plane, and
    /// nothing of a triangle outside it.
    #[test]
    fn a_triangle_clipped_to_a_box_is_its_part_inside() {
        let tri = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 1.0),
            DVec3::new(0.0, 2.0, 1.0),
        ];
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        let (lo, hi) = (DVec3::new(0.5, 0.5, -1.0), DVec3::new(1.5, 1.2, 3.0));
        let part = clip_to_box(tri.clone(), lo, hi);
        assert!(part.len() >= 3);
        for p in &part {
            assert!(p.cmpge(lo - 1e-12).all() && p.cmple(hi + 1e-12).all(), "{p}");
            assert!((n.dot(*p - tri[0])).abs() < 1e-12, "{p} off the plane");
        }
        assert_eq!(
            clip_to_box(tri.clone(), DVec3::splat(5.0), DVec3::splat(6.0)),
            Vec::<DVec3>::new()
        );
        assert_eq!(clip_to_box(tri.clone(), DVec3::splat(-1.0), DVec3::splat(3.0)), tri);
    }

    /// The fitted field's `deviation` over the corners of triangles bounds
    /// the renderer's blend anywhere in them (both are affine over a
    /// triangle): random clusters of triangles with tilted normals, points
    /// inside each. It fails if the deviation is shrunk by a tenth.
    #[test]
    fn the_normal_fields_deviation_bounds_every_point_of_its_triangles() {
        let mut rng = crate::accel::kdtree::test_rng::Rng(0x2545_f491_4f6c_dd1d);
        let mut u = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let mut tight = 0;
        for case in 0..200 {
            let centre = DVec3::new(u(), u(), u()) * 4.0;
            let mut tris = Vec::new();
            for _ in 0..(2 + case % 6) {
                let v = [0, 1, 2].map(|_| centre + DVec3::new(u() - 0.5, u() - 0.5, 0.3 * (u() - 0.5)));
                let n = [0, 1, 2].map(|_| DVec3::new(0.3 * (u() - 0.5), 0.3 * (u() - 0.5), 1.0).normalize());
                let normal = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                let poly = Polygon {
                    normal,
                    w: normal.dot(v[0]),
                    vertices: v.to_vec(),
                };
                tris.push((v, n, poly));
            }
            let samples: Vec<(DVec3, DVec3)> = tris
                .iter()
                .flat_map(|(v, n, p)| {
                    let blend = barycentric_blend(p, n);
                    v.map(|x| (x, blend(x)))
                })
                .collect();
            let Some(field) = NormalField::fit(DVec3::Z, &samples) else {
                continue;
            };
            let dev = field.deviation(&samples);
            let mut worst = DVec3::ZERO;
            for (v, n, p) in &tris {
                let blend = barycentric_blend(p, n);
                for _ in 0..50 {
                    let (a, b) = (u(), u());
                    let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                    let x = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b;
                    let off = (blend(x) - field.at(x)).abs();
                    assert!(off.cmple(dev + 1e-9).all(), "case {case}: {off} beyond {dev}");
                    worst = worst.max(off);
                }
            }
            tight += (worst.cmpgt(dev * 0.9).any()) as u32;
        }
        assert!(tight > 50, "the deviation is tight in only {tight} cases");
    }

    /// The phong ball of the tessellated scene is one patch; its mirror and
    /// glass balls and the flat floor are none; a line through the patch
    /// meets the triangle the scene's own kd-tree finds.
    #[test]
    fn smooth_matte_surfaces_are_patches_and_lines_find_their_triangles() {
        let w = renderer("checker-spheres-tessellated.json");
        let (rs, tree) = (w.scene(), w.tree());
        let (patches, of) = patches_of(rs, &tree.triangles);
        assert_eq!(patches.len(), 1, "only the phong ball");
        let p = &patches[0];
        for &t in &p.triangles {
            assert_eq!(of[t as usize], 0);
            let s = rs.surface(rs.triangles[t as usize].surface);
            assert!(s.kr == [0.0; 3] && s.kt == [0.0; 3]);
        }
        let outside = of.iter().filter(|&&x| x == NO_PATCH).count();
        assert_eq!(outside + p.triangles.len(), rs.triangles.len());
        // Lines from outside the ball towards points of its box.
        let c = (p.bounds.min + p.bounds.max) * 0.5;
        let mut hits = 0;
        for k in 0..200 {
            let a = k as f32 * 0.731;
            let o = c + Vec3::new(a.cos() * 5.0, 1.0 + (k % 7) as f32 * 0.3, a.sin() * 5.0);
            let target = c + Vec3::new((a * 3.1).sin(), (a * 1.7).cos(), (a * 2.3).sin()) * 0.6;
            let d = (target - o).normalize();
            let own = p.first_hit(o.as_dvec3(), d.as_dvec3());
            let full = tree.closest_hit(o, d, f32::INFINITY);
            if let Some((t, tri)) = own {
                hits += 1;
                if of[full.triangle as usize] == 0 {
                    assert_eq!(tri, full.triangle, "line {k}");
                    assert!((t as f32 - full.t).abs() <= 1e-5 * full.t, "line {k}");
                }
            }
        }
        assert!(hits > 150, "{hits} of 200 lines met the ball");
    }
}
