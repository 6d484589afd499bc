//! Blocker triangles against the horizon (section 3.1.1: only geometry
//! above the tangent plane is rasterised).
//!
//! A triangle wholly below the horizon (all z <= 0 in the tangent frame) is
//! culled. One that crosses it need not be clipped before rasterisation:
//! the image of a triangle abc on the sphere is the cone
//! `{α a + β b + γ c : α, β, γ >= 0}`, the intersection of the three
//! half-spaces bounded by the planes through the origin and each edge.
//! Clipping the triangle against z = 0 replaces part of two edges by
//! sub-segments *of the same lines*, so by planes through the origin equal
//! to the originals, and adds one edge lying in z = 0, whose plane is the
//! horizon itself — and every mask pixel is above the horizon. The masks of
//! the clipped polygon and of the unclipped triangle are therefore the same
//! intersection of edge masks restricted to z > 0; the test
//! `clipping_does_not_change_the_mask` (tests/prt.rs) checks it pixel by
//! pixel. `clip_to_horizon` is kept for that check and for callers that
//! need the visible polygon (its vertices bound the image).

use glam::Vec3;

/// The part of triangle `t` with z >= 0 (Sutherland–Hodgman against the
/// plane z = 0): 0, 3 or 4 vertices, in the triangle's winding.
pub fn clip_to_horizon(t: [Vec3; 3]) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(4);
    for i in 0..3 {
        let (p, q) = (t[i], t[(i + 1) % 3]);
        let (pin, qin) = (p.z >= 0.0, q.z >= 0.0);
        if pin {
            out.push(p);
        }
        if pin != qin {
            let s = p.z / (p.z - q.z);
            let mut x = p + (q - p) * s;
            x.z = 0.0;
            out.push(x);
        }
    }
    if out.len() < 3 {
        out.clear();
    }
    out
}

/// Whether the triangle has any point strictly above the horizon.
#[inline(always)]
pub fn above_horizon(t: &[Vec3; 3]) -> bool {
    t[0].z > 0.0 || t[1].z > 0.0 || t[2].z > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clips_one_and_two_vertices_below() {
        let t = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
        ];
        let p = clip_to_horizon(t);
        assert_eq!(p.len(), 3);
        assert!(p.iter().all(|v| v.z >= 0.0));
        let t = [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        assert_eq!(clip_to_horizon(t).len(), 4);
        let below = [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        assert!(!above_horizon(&below));
    }
}
