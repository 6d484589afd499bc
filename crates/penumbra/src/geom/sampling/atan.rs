//! The arctangent on [-1, 1] as a polynomial (Abramowitz and Stegun 4.4.49:
//! atan(t) / t = 1 + a2 t^2 + ... + a16 t^16, error at most 2e-8), the one
//! the square-from-disk and square-from-sphere inverses need: both split
//! their domain by the diagonals, so the ratio of the smaller coordinate to
//! the larger never leaves [-1, 1]. Eight multiply-adds without a branch
//! against libm's range-reduced `atan2f` (a third of a field lookup's time
//! went there); `wgsl/field_lookup.wgsl` evaluates the same polynomial in
//! the same order.

const A: [f32; 8] = [
    -0.333_331_45,
    0.199_935_51,
    -0.142_089,
    0.106_562_64,
    -0.075_289_64,
    0.042_909_614,
    -0.016_165_737,
    0.002_866_225_7,
];

/// atan(t) for t in [-1, 1] (outside it the error grows quickly).
#[inline]
pub fn atan_unit(t: f32) -> f32 {
    let z = t * t;
    let mut p = A[7];
    for &a in A[..7].iter().rev() {
        p = p * z + a;
    }
    t + t * (z * p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn within_float_rounding_of_the_arctangent_on_the_unit_interval() {
        let n = 200_000;
        let mut worst = 0.0f64;
        for i in -n..=n {
            let t = i as f32 / n as f32;
            worst = worst.max((atan_unit(t) as f64 - (t as f64).atan()).abs());
        }
        // 2e-8 of the polynomial plus a few roundings of numbers below pi/4.
        assert!(worst < 2.5e-7, "worst error {worst:e}");
        assert_eq!(atan_unit(0.0), 0.0);
        assert_eq!(atan_unit(-0.5), -atan_unit(0.5));
    }
}
