//! Where a secondary ray starts: off the surface it leaves, by a distance
//! that scales with the floating-point error of the hit point, so that the
//! ray neither hits its own surface again ("acne") nor starts visibly far
//! from it, at any scene scale.
//!
//! The error of a hit point (computed from barycentric coordinates, or
//! reprojected onto a sphere) and of the intersection test that must not
//! find the surface again is a few units in the last place of the largest
//! coordinate involved: the primitive's vertices (a sphere's centre plus
//! radius) and the point. The offset is 2^-16 of that magnitude, 128 ulps,
//! along the geometric normal: large enough for every rounding in between,
//! and relative, so a scene at 1e-4 or 1e5 units behaves the same (Wächter
//! and Binder, "A Fast and Robust Method for Avoiding Self-Intersection",
//! Ray Tracing Gems, 2019, make the same argument in integer ulps; a fixed
//! float fallback near the origin, as theirs has, would not be scale-free).
//!
//! Twin of `offset_point` and `max_abs` in `wgsl/whitted.wgsl`.

use glam::Vec3;

/// The offset over the magnitude of the coordinates involved.
pub const OFFSET_SCALE: f32 = 1.0 / 65536.0;

/// The largest absolute coordinate of `v`.
#[inline]
pub fn max_abs(v: Vec3) -> f32 {
    v.abs().max_element()
}

/// `p` moved off its surface along the unit normal `n` (towards the side
/// the new ray leaves into), for a primitive whose coordinates reach
/// `magnitude`.
#[inline]
pub fn offset_point(p: Vec3, n: Vec3, magnitude: f32) -> Vec3 {
    let m = magnitude.max(max_abs(p));
    p + n * (m * OFFSET_SCALE).max(f32::MIN_POSITIVE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_is_relative_and_on_the_normal_side() {
        for scale in [1e-4f32, 1.0, 1e5] {
            let p = Vec3::new(0.3, 0.7, -0.2) * scale;
            let n = Vec3::new(0.0, 0.6, 0.8);
            let q = offset_point(p, n, scale);
            let along = (q - p).dot(n);
            assert!(along > 0.0);
            // Between 1e-6 and 1e-4 of the scale: far above rounding, far
            // below anything visible.
            assert!(along > 1e-6 * scale && along < 1e-4 * scale, "{scale}: {along}");
        }
    }
}
