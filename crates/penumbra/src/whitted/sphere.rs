//! Analytic spheres, the primitive of the bounded-error paper's scenes,
//! beside the triangles of the kd-tree. A scene has few of them, so every
//! ray tests them all (a few dozen cost less than a tree walk); tessellate
//! a large number into a mesh instead.
//!
//! Twin of `Sphere` and `intersect_sphere` in `wgsl/whitted.wgsl`.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// A sphere and its shading, as the GPU reads it (32 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Sphere {
    pub center: [f32; 3],
    pub radius: f32,
    /// Index into the scene's surfaces.
    pub surface: u32,
    /// Object id in ray trees.
    pub object: u32,
    pub _pad: [u32; 2],
}

impl Sphere {
    pub fn center(&self) -> Vec3 {
        Vec3::from_array(self.center)
    }

    /// Magnitude of its coordinates, for ray offsets.
    pub fn magnitude(&self) -> f32 {
        crate::geom::offset::max_abs(self.center()) + self.radius
    }

    /// Whether `p` is strictly inside.
    pub fn contains(&self, p: Vec3) -> bool {
        (p - self.center()).length_squared() < self.radius * self.radius
    }
}

/// The nearest `t` in `(0, t_max)` where `o + t d` meets the sphere
/// (`d` need not be unit length).
///
/// The roots of `|f + t d|^2 = r^2`, `f = o - c`, are computed as in
/// Haines et al., "Precision Improvements for Ray/Sphere Intersection"
/// (Ray Tracing Gems, 2019): the discriminant from the distance of the
/// centre to the line, `r^2 - |f - (f.d / d.d) d|^2`, which does not cancel
/// catastrophically for distant or large spheres, and the smaller root
/// from the larger one by Vieta's formula.
#[inline]
pub fn intersect_sphere(center: Vec3, radius: f32, o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
    let f = o - center;
    let a = d.dot(d);
    let h = -f.dot(d);
    let l = f + (h / a) * d;
    let disc = a * (radius - l.length()) * (radius + l.length());
    if disc < 0.0 {
        return None;
    }
    // sign(h), with +1 at 0 (WGSL's sign() is 0 there).
    let q = h + if h >= 0.0 { disc.sqrt() } else { -disc.sqrt() };
    let c = f.dot(f) - radius * radius;
    let (mut t0, mut t1) = (c / q, q / a);
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    if t0 > 0.0 && t0 < t_max {
        return Some(t0);
    }
    (t1 > 0.0 && t1 < t_max).then_some(t1)
}

/// A UV sphere of `rings` x `segments` quads (the poles' rings as
/// triangles): positions, radial unit normals and triangles, in the
/// orientation of the analytic sphere (counter-clockwise seen from
/// outside), for tessellated twins of analytic scenes.
pub fn tessellate(center: Vec3, radius: f32, rings: u32, segments: u32) -> (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>) {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut normals = vec![Vec3::Y];
    for i in 1..rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            normals.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            ));
        }
    }
    normals.push(-Vec3::Y);
    let positions = normals.iter().map(|&n| center + radius * n).collect();
    let mut triangles = Vec::new();
    crate::scene::animated::sphere_grid(segments, rings, &mut triangles, 0);
    (positions, normals, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_the_near_side_then_the_far_side_from_inside() {
        let c = Vec3::new(0.0, 0.0, -5.0);
        let t = intersect_sphere(c, 1.0, Vec3::ZERO, -Vec3::Z, f32::INFINITY).unwrap();
        assert!((t - 4.0).abs() < 1e-6);
        // Unnormalised direction: t in its units.
        let t = intersect_sphere(c, 1.0, Vec3::ZERO, -2.0 * Vec3::Z, f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        // From the centre: the far side.
        let t = intersect_sphere(c, 1.0, c, Vec3::X, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        assert_eq!(intersect_sphere(c, 1.0, Vec3::ZERO, Vec3::Z, f32::INFINITY), None);
        assert_eq!(intersect_sphere(c, 1.0, Vec3::ZERO, -Vec3::Z, 3.9), None);
        assert_eq!(intersect_sphere(c, 1.0, Vec3::new(1.5, 0.0, 0.0), -Vec3::Z, 1e9), None);
    }

    #[test]
    fn small_distant_spheres_are_hit_precisely() {
        // A sphere of radius 1e-3 at 1e4: the naive discriminant b^2 - c
        // cancels 1e8 against 1e8 (an ulp of 1e8 is 8, the answer 2e-7);
        // the distance form sees the ray pass 9e-4 from the centre (a hit)
        // or 1.1e-3 (a miss), and t is right to an ulp of 1e4.
        let c = Vec3::new(0.0, 0.0, -1e4);
        let hit = Vec3::new(0.9e-7, 0.0, -1.0).normalize();
        let t = intersect_sphere(c, 1e-3, Vec3::ZERO, hit, f32::INFINITY).expect("hit");
        assert!((t - (1e4 - 4.36e-4)).abs() < 2e-3, "{t}");
        let miss = Vec3::new(1.1e-7, 0.0, -1.0).normalize();
        assert_eq!(intersect_sphere(c, 1e-3, Vec3::ZERO, miss, f32::INFINITY), None);
    }

    #[test]
    fn tessellation_is_closed_and_outward() {
        let (p, n, t) = tessellate(Vec3::new(1.0, 2.0, 3.0), 2.0, 8, 12);
        let mesh = crate::scene::Mesh::new(p.clone(), t.clone()).unwrap();
        for (k, tri) in t.iter().enumerate() {
            let centroid = (p[tri[0] as usize] + p[tri[1] as usize] + p[tri[2] as usize]) / 3.0;
            assert!(
                mesh.face_normal(k).dot(centroid - Vec3::new(1.0, 2.0, 3.0)) > 0.0,
                "triangle {k}"
            );
        }
        assert!(n.iter().all(|v| (v.length() - 1.0).abs() < 1e-6));
        // Closed: every edge is shared by exactly two triangles.
        let mut edges = std::collections::HashMap::new();
        for tri in &t {
            for e in 0..3 {
                let (a, b) = (tri[e], tri[(e + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        assert!(edges.values().all(|&c| c == 2));
    }
}
