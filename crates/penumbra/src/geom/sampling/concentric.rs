//! Shirley and Chiu's concentric map from the square [0,1)^2 to the unit
//! disk ("A Low Distortion Map Between Disk and Square", 1997), with the
//! branch structure of pbrt-v4 (`SampleUniformDiskConcentric`), and its inverse.
//!
//! With a = 2u - 1, b = 2v - 1, the square is split into four triangles by
//! its diagonals: where |a| > |b|, r = a and phi = (pi/4) (b/a); elsewhere
//! r = b and phi = pi/2 - (pi/4) (a/b). The map preserves area fractions, so
//! stratified squares give stratified disks.

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

use super::atan::atan_unit;

/// Square [0, 1]^2 to unit disk.
#[inline]
pub fn concentric_disk(u: f32, v: f32) -> [f32; 2] {
    let [r, phi] = concentric_polar(u, v);
    let (s, c) = phi.sin_cos();
    [r * c, r * s]
}

/// The disk point of `concentric_disk` as (r, phi), before the sine and
/// cosine: signed radius and angle, (0, 0) at the centre (which then maps
/// to the same +0 coordinates). Both triangles' quotients are computed and
/// the answer selected, with no early exit, so that loops over many
/// samples vectorise it (`ao::PointDirections`); libm's `sin_cos` stays a
/// separate scalar step.
#[inline(always)]
pub fn concentric_polar(u: f32, v: f32) -> [f32; 2] {
    let a = 2.0 * u - 1.0;
    let b = 2.0 * v - 1.0;
    let a_major = a.abs() > b.abs();
    let (r, phi) = if a_major {
        (a, FRAC_PI_4 * (b / a))
    } else {
        (b, FRAC_PI_2 - FRAC_PI_4 * (a / b))
    };
    if a == 0.0 && b == 0.0 { [0.0, 0.0] } else { [r, phi] }
}

/// Unit disk to square [0, 1]^2: the inverse of `concentric_disk`. The
/// diagonals split the disk as they split the square: where |x| >= |y| the
/// point came from the triangle r = a, whose angle is phi = atan(y / x) off
/// the x axis (pi added for x < 0, which the ratio absorbs), so b = a phi /
/// (pi/4); elsewhere the roles swap. The ratio stays in [-1, 1], where
/// `atan_unit` needs no range reduction.
/// Both sides of the branch evaluate the polynomial at the ratio they pick,
/// and the centre is a select at the end: no early exit, so the loops of
/// `field::batch` vectorise it.
#[inline(always)]
pub fn concentric_square(x: f32, y: f32) -> [f32; 2] {
    let r = (x * x + y * y).sqrt();
    let x_major = x.abs() >= y.abs();
    let angle = atan_unit(if x_major { y / x } else { x / y });
    let (a, b) = if x_major {
        let a = r.copysign(x);
        (a, a * angle / FRAC_PI_4)
    } else {
        let b = r.copysign(y);
        (b * angle / FRAC_PI_4, b)
    };
    if r == 0.0 {
        [0.5, 0.5]
    } else {
        [(a + 1.0) * 0.5, (b + 1.0) * 0.5]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_over_the_square() {
        let n = 64;
        let mut worst = 0.0f32;
        for i in 0..=n {
            for j in 0..=n {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                let [x, y] = concentric_disk(u, v);
                assert!(x * x + y * y <= 1.0 + 1e-6);
                let [u2, v2] = concentric_square(x, y);
                worst = worst.max((u - u2).abs()).max((v - v2).abs());
            }
        }
        assert!(worst < 2e-6, "worst round-trip error {worst}");
    }

    #[test]
    fn centre_corners_and_seams() {
        assert_eq!(concentric_disk(0.5, 0.5), [0.0, 0.0]);
        assert_eq!(concentric_square(0.0, 0.0), [0.5, 0.5]);
        // Corners go to the diagonals at radius 1.
        let [x, y] = concentric_disk(1.0, 1.0);
        assert!((x - y).abs() < 1e-6 && (x * x + y * y - 1.0).abs() < 1e-6);
        // The seam |a| = |b| is continuous: points just either side agree.
        let e = 1e-4;
        let p = concentric_disk(0.8, 0.8 - e);
        let q = concentric_disk(0.8 - e, 0.8);
        assert!((p[0] - q[0]).abs() < 1e-3 && (p[1] - q[1]).abs() < 1e-3);
    }

    #[test]
    fn preserves_area_fractions() {
        // The disk of radius 1/2 is the image of the square ring's inner
        // half-width square: a quarter of the points.
        let n = 200;
        let inside = (0..n * n)
            .filter(|k| {
                let (u, v) = ((k % n) as f32 + 0.5, (k / n) as f32 + 0.5);
                let [x, y] = concentric_disk(u / n as f32, v / n as f32);
                x * x + y * y < 0.25
            })
            .count();
        assert_eq!(inside, n * n / 4);
    }
}
