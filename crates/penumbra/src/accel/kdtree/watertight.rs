//! Watertight ray–triangle intersection: Woop, Benthin and Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2(1), 2013.
//!
//! The ray is sheared so that it becomes the +z axis through the origin; each
//! triangle is then tested in 2D with three edge functions U, V, W. For an edge
//! shared by two triangles both compute the edge function from the same two
//! transformed vertices, and `a*b - c*d` is exactly antisymmetric in IEEE
//! arithmetic, so one triangle's value is the exact negation of the other's: a
//! ray through the edge is accepted by at least one of them and never slips
//! through. Where an edge function rounds to exactly 0 the paper recomputes it
//! in double precision; we instead accept 0 on both sides (a ray through the
//! edge may then report either triangle, both at the same t), which keeps the
//! guarantee with the single-precision arithmetic that WGSL has.
//!
//! The WGSL twin is `wgsl/kdtree_traverse.wgsl` (`intersect_triangle`); it
//! evaluates each edge in a canonical vertex order so that the guarantee also
//! survives a GPU compiler contracting `a*b - c*d` into a fused multiply-add.

use glam::Vec3;

/// Per-ray constants of the shear transform (section 3 of the paper).
///
/// The test runs in a frame scaled by a power of two (`scale`, the tree's
/// `frame_scale`): `origin` and the vertices it is given are multiplied by
/// it, so `t_scaled`, a cubic in the coordinates, neither overflows for
/// scenes of size 1e13 and up nor underflows for scenes of 1e-13 and down.
/// Scaling by a power of two is exact, so every intermediate is the
/// unscaled one times a power of two and the hits are bit for bit those of
/// the unscaled test wherever that one neither overflowed nor underflowed.
#[derive(Debug, Clone, Copy)]
pub struct ShearedRay {
    /// The ray's origin times `scale`.
    pub origin: Vec3,
    /// The first of the two axes other than `kz`: it becomes the sheared
    /// frame's x (`kx` and `ky` swapped when `d[kz] < 0`, which keeps the
    /// triangles' winding).
    pub kx: usize,
    /// The second axis other than `kz`: it becomes the sheared frame's y.
    pub ky: usize,
    /// Axis of the direction's largest |component|: it becomes the sheared
    /// frame's z.
    pub kz: usize,
    /// Shear constant `S_x = d_kx / d_kz`.
    pub sx: f32,
    /// Shear constant `S_y = d_ky / d_kz`.
    pub sy: f32,
    /// Shear constant `S_z = 1 / d_kz`.
    pub sz: f32,
    /// The frame's power of two.
    pub scale: f32,
    /// `1 / scale`, exact: it takes a t found in the frame back to units
    /// of the ray's direction.
    pub inv_scale: f32,
}

pub use crate::geom::float::frame_scale;

/// The shear's axes for a direction: `kz` the axis of the largest |component|,
/// `kx` and `ky` the others, in an order that keeps the triangles' winding
/// (swapped when `d[kz] < 0`).
#[inline]
pub fn shear_axes(dir: Vec3) -> [usize; 3] {
    let a = dir.abs();
    let kz = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if dir[kz] < 0.0 { [ky, kx, kz] } else { [kx, ky, kz] }
}

impl ShearedRay {
    /// A ray tested against unscaled vertices.
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self::in_frame(origin, dir, 1.0)
    }

    /// A ray tested against vertices multiplied by `scale` (a power of two).
    #[inline]
    pub fn in_frame(origin: Vec3, dir: Vec3, scale: f32) -> Self {
        let [kx, ky, kz] = shear_axes(dir);
        let dir = dir.to_array();
        ShearedRay {
            origin: origin * scale,
            kx,
            ky,
            kz,
            sx: dir[kx] / dir[kz],
            sy: dir[ky] / dir[kz],
            sz: 1.0 / dir[kz],
            scale,
            inv_scale: 1.0 / scale,
        }
    }

    /// Hit distance `t` in units of the ray direction if the ray hits the
    /// triangle (vertices in the ray's frame) at `0 < t < t_max`, else
    /// `None`. Both faces are hit.
    #[inline(always)]
    pub fn intersect(&self, v0: Vec3, v1: Vec3, v2: Vec3, t_max: f32) -> Option<f32> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        // Plain arrays: indexing glam vectors by a run-time axis is a match.
        let a = (v0 - self.origin).to_array();
        let b = (v1 - self.origin).to_array();
        let c = (v2 - self.origin).to_array();
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];

        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t_scaled = u * az + v * bz + w * cz;
        // t = t_scaled / det; compare before dividing where the sign allows,
        // and after, so that the reported t is exactly the one compared.
        if (det > 0.0 && t_scaled <= 0.0) || (det < 0.0 && t_scaled >= 0.0) {
            return None;
        }
        // In the frame, t is `scale` times the world's (exactly).
        let t = t_scaled / det;
        (t > 0.0 && t < t_max * self.scale).then_some(t * self.inv_scale)
    }
}

/// Whether a triangle has area: the cross product of its edges, from its
/// f32 vertices in f64, is not the zero vector. A triangle without area (a
/// segment or a point) has no inside for a ray to cross, but a ray whose
/// origin lies on its line projects all three vertices onto one line
/// through the origin, where the edge functions above are rounding error
/// and may agree in sign: a "hit" far from the segment (the kitchen's AO
/// rays from vertex 24,890, t = 0.35 on a segment they never meet). The
/// trees leave such triangles out of their leaves.
pub fn has_area(t: &[Vec3; 3]) -> bool {
    let (a, b, c) = (t[0].as_dvec3(), t[1].as_dvec3(), t[2].as_dvec3());
    (b - a).cross(c - a) != glam::DVec3::ZERO
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(o: Vec3, d: Vec3, tri: [Vec3; 3]) -> Option<f32> {
        ShearedRay::new(o, d).intersect(tri[0], tri[1], tri[2], f32::INFINITY)
    }

    const TRI: [Vec3; 3] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];

    #[test]
    fn frame_scale_brings_extents_to_half_or_more_below_one() {
        for extent in [1e-19f32, 3e-7, 0.5, 1.0, 1.5, 7.0, 1024.0, 3e18] {
            let k = frame_scale(extent);
            assert_eq!(k, 2f32.powi(k.log2() as i32), "{extent}: a power of two");
            assert!((0.5..1.0).contains(&(extent * k)), "{extent}: {k}");
        }
        assert_eq!(frame_scale(0.0), 1.0);
        assert_eq!(frame_scale(f32::INFINITY), 1.0);
    }

    #[test]
    fn hits_both_faces_with_t_in_direction_units() {
        assert_eq!(hit(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.0, 0.0, -2.0), TRI), Some(0.5));
        assert_eq!(
            hit(Vec3::new(0.2, 0.2, -1.0), Vec3::new(0.0, 0.0, 4.0), TRI),
            Some(0.25)
        );
        assert_eq!(hit(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.0, 0.0, 1.0), TRI), None);
        assert_eq!(hit(Vec3::new(2.0, 2.0, 1.0), Vec3::new(0.0, 0.0, -1.0), TRI), None);
    }

    #[test]
    fn origin_on_the_surface_is_not_a_hit() {
        // t = 0 is excluded: a ray leaving a surface does not hit it again.
        assert_eq!(hit(Vec3::new(0.2, 0.2, 0.0), Vec3::new(0.0, 0.0, 1.0), TRI), None);
        assert_eq!(hit(Vec3::new(0.2, 0.2, 0.0), Vec3::new(0.3, 0.1, -1.0), TRI), None);
    }

    #[test]
    fn degenerate_and_coplanar_rays_miss() {
        let line = [Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0)];
        assert_eq!(hit(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z, line), None);
        let point = [Vec3::ZERO; 3];
        assert_eq!(hit(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z, point), None);
        // Ray in the triangle's plane.
        assert_eq!(hit(Vec3::new(-1.0, 0.2, 0.0), Vec3::X, TRI), None);
    }

    #[test]
    fn shared_edges_and_vertices_never_leak() {
        // A fan of triangles around the origin; rays through the shared edges
        // and the shared vertex must hit at least one triangle.
        let n = 7;
        let ring: Vec<Vec3> = (0..n)
            .map(|i| {
                let a = i as f32 / n as f32 * std::f32::consts::TAU;
                Vec3::new(a.cos(), a.sin(), 0.13 * a.sin())
            })
            .collect();
        let tris: Vec<[Vec3; 3]> = (0..n).map(|i| [Vec3::ZERO, ring[i], ring[(i + 1) % n]]).collect();
        let mut rays = vec![Vec3::ZERO];
        for corner in &ring {
            for k in 1..50 {
                rays.push(*corner * (k as f32 / 50.0));
            }
        }
        for target in rays {
            let o = Vec3::new(0.31, -0.17, 3.0);
            let d = target - o;
            let hits = tris.iter().filter(|t| hit(o, d, **t).is_some()).count();
            assert!(hits >= 1, "ray to {target} leaked through");
        }
    }
}
