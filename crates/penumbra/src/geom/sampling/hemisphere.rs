//! Cosine-weighted hemisphere directions by Malley's method: a uniformly
//! distributed point on the unit disk lifted to the hemisphere,
//! z = sqrt(1 - x^2 - y^2), has density cos(theta)/pi. Monte Carlo estimates
//! of (1/pi) * integral of V(w) cos(theta) dw then reduce to the fraction of
//! unoccluded rays.

use glam::Vec3;

use super::concentric::{concentric_disk, concentric_square};

/// Cosine-weighted direction around +z from a point of [0,1)^2.
#[inline]
pub fn cosine_hemisphere(u: f32, v: f32) -> Vec3 {
    let [x, y] = concentric_disk(u, v);
    malley_lift(x, y)
}

/// A point of the unit disk lifted to the hemisphere above it.
#[inline(always)]
pub fn malley_lift(x: f32, y: f32) -> Vec3 {
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    Vec3::new(x, y, z)
}

/// The square point that `cosine_hemisphere` maps to direction `w` (z >= 0).
#[inline]
pub fn malley_inverse(w: Vec3) -> [f32; 2] {
    concentric_square(w.x, w.y)
}

/// An orthonormal basis (t, b, n) around a unit normal, after Duff et al.,
/// "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017: branchless
/// and continuous except across n.z = 0's sign.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// The tangent: local +x.
    pub t: Vec3,
    /// The bitangent: local +y, with `t.cross(b) == n` (right-handed).
    pub b: Vec3,
    /// The normal given: local +z.
    pub n: Vec3,
}

impl Frame {
    /// The frame around the unit normal `n`.
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Frame {
            t: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            b: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    /// A vector given in the frame's (t, b, n) coordinates, in world
    /// coordinates: a `cosine_hemisphere` direction turned around `n`.
    #[inline]
    pub fn to_world(&self, local: Vec3) -> Vec3 {
        self.t * local.x + self.b * local.y + self.n * local.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::sampling::SampleSequence;

    #[test]
    fn frames_are_orthonormal_everywhere() {
        let normals = [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            -Vec3::Y,
            Vec3::new(1e-8, 0.0, -1.0).normalize(),
            Vec3::new(0.3, -0.5, 0.81).normalize(),
        ];
        for n in normals {
            let f = Frame::from_normal(n);
            for (a, b) in [(f.t, f.b), (f.b, f.n), (f.n, f.t)] {
                assert!(a.dot(b).abs() < 1e-6, "{n}");
            }
            for v in [f.t, f.b, f.n] {
                assert!((v.length() - 1.0).abs() < 1e-6, "{n}");
            }
            assert!((f.t.cross(f.b) - n).length() < 1e-5, "right-handed for {n}");
        }
    }

    #[test]
    fn cosine_weighted_moments() {
        // E[cos theta] = 2/3 and E[cos^2 theta] = 1/2 under p = cos/pi.
        let seq = SampleSequence::new(0);
        let n = 4096;
        let (mut m1, mut m2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let [u, v] = seq.sample(0, i);
            let w = cosine_hemisphere(u, v);
            assert!((w.length() - 1.0).abs() < 1e-5 && w.z >= 0.0);
            m1 += w.z as f64;
            m2 += (w.z * w.z) as f64;
        }
        assert!((m1 / n as f64 - 2.0 / 3.0).abs() < 1e-3);
        assert!((m2 / n as f64 - 0.5).abs() < 1e-3);
    }

    #[test]
    fn malley_inverse_round_trips() {
        for (u, v) in [(0.1, 0.7), (0.5, 0.5), (0.99, 0.01), (0.3, 0.3)] {
            let [u2, v2] = malley_inverse(cosine_hemisphere(u, v));
            assert!((u - u2).abs() < 1e-5 && (v - v2).abs() < 1e-5);
        }
    }
}
