//! Float operations that x86-64's baseline (SSE2, no SSE4.1 rounding)
//! would otherwise leave to a library call in hot loops.

/// `f32::floor`, bit for bit (zeros keep their sign, NaN stays NaN),
/// without the library call `floor` compiles to below SSE4.1: a checker
/// lookup took seven (the renderer's hit shading, the bounded renderer's
/// texture test), a field position lookup two per ray.
#[inline(always)]
pub fn floor(x: f32) -> f32 {
    // From 2^23 up (and infinities, NaN) every f32 is its own floor.
    if x.abs() >= 8_388_608.0 || x.is_nan() {
        return x;
    }
    let t = x as i32 as f32;
    // Truncation rounded up below zero; the sign keeps floor(-0.0) = -0.0.
    (if t > x { t - 1.0 } else { t }).copysign(x)
}

/// The power of two that brings a scene whose largest extent is `extent`
/// to a size in [0.5, 1): exact to apply, kept within the normal range.
/// Read off the float's exponent bits (no logarithm): it runs per triangle
/// in unit normals, barycentrics and clipped areas.
#[inline]
pub fn frame_scale(extent: f32) -> f32 {
    if !(extent.is_finite() && extent > 0.0) {
        return 1.0;
    }
    // extent is in [2^(e-1), 2^e) for e = biased exponent - 126.
    let e = (((extent.to_bits() >> 23) & 0xff) as i32 - 126).clamp(-120, 120);
    f32::from_bits(((127 - e) as u32) << 23)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_is_the_library_floor_bit_for_bit() {
        let mut xs = crate::accel::kdtree::test_rng::SPECIAL_F32.to_vec();
        xs.extend([
            0.5,
            -0.5,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            -8_388_608.0,
            8_388_609.0,
            -8_388_609.0,
        ]);
        // Every integer near zero and its neighbours, then bit patterns
        // spread over the whole range.
        for k in -300..300 {
            let k = k as f32 * 0.25;
            xs.extend([k, k.next_up(), k.next_down()]);
        }
        let mut rng = crate::accel::kdtree::test_rng::Rng(0x2545_f491_4f6c_dd1d);
        xs.extend((0..1_000_000).map(|_| f32::from_bits(rng.next_u64() as u32)));
        for x in xs {
            let (a, b) = (floor(x), x.floor());
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "floor({x:e}) = {a:e}, the library's {b:e}"
            );
        }
    }
}
