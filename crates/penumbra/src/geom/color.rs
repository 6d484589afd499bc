//! Colour helpers shared by every image penumbra writes.

/// Linear [0, 1] to an 8-bit sRGB value (clamped; NaN is black).
pub fn srgb8(x: f32) -> u8 {
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

/// Root-mean-square difference of `a` and `b` over the entries `mask` keeps
/// (all without one); 0 for none.
pub fn rms_difference(a: &[f32], b: &[f32], mask: Option<&[bool]>) -> f64 {
    let (mut sum, mut count) = (0.0f64, 0usize);
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        if mask.is_none_or(|m| m[i]) {
            let d = *x as f64 - *y as f64;
            sum += d * d;
            count += 1;
        }
    }
    if count == 0 { 0.0 } else { (sum / count as f64).sqrt() }
}

#[cfg(test)]
mod tests {
    #[test]
    fn srgb_ends_and_nan() {
        assert_eq!(super::srgb8(0.0), 0);
        assert_eq!(super::srgb8(1.0), 255);
        assert_eq!(super::srgb8(f32::NAN), 0);
        assert_eq!(super::srgb8(0.5), 188);
    }

    #[test]
    fn rms_over_a_mask() {
        let (a, b) = ([1.0, 2.0, 3.0], [1.0, 0.0, 3.0]);
        assert_eq!(super::rms_difference(&a, &b, Some(&[false, true, false])), 2.0);
        assert!((super::rms_difference(&a, &b, None) - (4.0f64 / 3.0).sqrt()).abs() < 1e-12);
    }
}
