//! The x86-64 lanes: AVX-512 (one register, `__mmask16` masks), AVX2 (two
//! registers) and SSE2 (four registers, always present on x86-64).
//!
//! The methods are `#[inline(always)]` wrappers of single intrinsics; they
//! are compiled into the `#[target_feature]` functions that dispatch to
//! them (`kdtree::occlusion`), where the intrinsics inline as one
//! instruction each. Comparisons use the ordered-quiet predicates (false on
//! NaN) and `ne` the unordered one (true on NaN), as Rust's `f32` does.
//! No fused multiply-add is used anywhere: lanes must round as scalar code.

#![allow(unused_unsafe)]

use std::arch::x86_64::*;

use super::lanes::{Lanes, Mask};

/// Sixteen lanes in one AVX-512 register.
#[derive(Clone, Copy)]
pub struct Avx512(__m512);

/// An AVX-512 mask register.
#[derive(Clone, Copy)]
pub struct K16(__mmask16);

impl Mask for K16 {
    #[inline(always)]
    fn from_bits(bits: u16) -> Self {
        K16(bits)
    }
    #[inline(always)]
    fn bits(self) -> u16 {
        self.0
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        K16(self.0 & o.0)
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        K16(self.0 | o.0)
    }
    #[inline(always)]
    fn and_not(self, o: Self) -> Self {
        K16(self.0 & !o.0)
    }
}

macro_rules! cmp512 {
    ($name:ident, $pred:ident) => {
        #[inline(always)]
        fn $name(self, o: Self) -> K16 {
            // SAFETY: see the trait's contract.
            K16(unsafe { _mm512_cmp_ps_mask::<$pred>(self.0, o.0) })
        }
    };
}

macro_rules! op512 {
    ($name:ident, $intr:ident) => {
        #[inline(always)]
        fn $name(self, o: Self) -> Self {
            // SAFETY: see the trait's contract.
            Avx512(unsafe { $intr(self.0, o.0) })
        }
    };
}

// SAFETY: values exist only inside functions that checked for AVX-512F.
unsafe impl Lanes for Avx512 {
    type M = K16;
    // `run_avx512`'s AVX-512F implies AVX2.
    const AVX2: bool = true;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Avx512(unsafe { _mm512_set1_ps(x) })
    }
    #[inline(always)]
    fn from_array(a: [f32; 16]) -> Self {
        Avx512(unsafe { _mm512_loadu_ps(a.as_ptr()) })
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 16] {
        let mut a = [0.0f32; 16];
        unsafe { _mm512_storeu_ps(a.as_mut_ptr(), self.0) };
        a
    }
    op512!(add, _mm512_add_ps);
    op512!(sub, _mm512_sub_ps);
    op512!(mul, _mm512_mul_ps);
    op512!(div, _mm512_div_ps);
    #[inline(always)]
    fn sqrt(self) -> Self {
        // SAFETY: see the trait's contract.
        Avx512(unsafe { _mm512_sqrt_ps(self.0) })
    }
    op512!(min, _mm512_min_ps);
    op512!(max, _mm512_max_ps);
    cmp512!(lt, _CMP_LT_OQ);
    cmp512!(le, _CMP_LE_OQ);
    cmp512!(gt, _CMP_GT_OQ);
    cmp512!(ge, _CMP_GE_OQ);
    cmp512!(eq, _CMP_EQ_OQ);
    cmp512!(ne, _CMP_NEQ_UQ);
    const FAST_COMPRESS: bool = true;
    #[inline(always)]
    fn compress(self, m: K16) -> Self {
        // SAFETY: see the trait's contract.
        Avx512(unsafe { _mm512_maskz_compress_ps(m.0, self.0) })
    }
    #[inline(always)]
    fn expand(self, m: K16, src: Self) -> Self {
        // SAFETY: see the trait's contract.
        Avx512(unsafe { _mm512_mask_expand_ps(src.0, m.0, self.0) })
    }
    #[inline(always)]
    fn select(m: K16, a: Self, b: Self) -> Self {
        // The blend takes its second operand where the mask bit is set.
        Avx512(unsafe { _mm512_mask_blend_ps(m.0, b.0, a.0) })
    }
    #[inline(always)]
    fn min_lane(self) -> f32 {
        // AVX-512 implies AVX: the 256-bit halves' minimum, then theirs.
        unsafe {
            hmin256(_mm256_min_ps(
                _mm512_castps512_ps256(self.0),
                _mm512_extractf32x8_ps::<1>(self.0),
            ))
        }
    }
    #[inline(always)]
    fn max_lane(self) -> f32 {
        unsafe {
            hmax256(_mm256_max_ps(
                _mm512_castps512_ps256(self.0),
                _mm512_extractf32x8_ps::<1>(self.0),
            ))
        }
    }
}

/// Sixteen lanes in two AVX2 registers (lanes 0-7, 8-15).
#[derive(Clone, Copy)]
pub struct Avx2x2([__m256; 2]);

/// Sixteen lanes in four SSE registers.
#[derive(Clone, Copy)]
pub struct Ssex4([__m128; 4]);

/// Masks of the multi-register lanes: all-ones or all-zero lanes.
#[derive(Clone, Copy)]
pub struct Avx2Mask([__m256; 2]);

#[derive(Clone, Copy)]
pub struct SseMask([__m128; 4]);

/// An implementation over `$n` registers of `$w` lanes: every operation is
/// the register operation on each part.
// Each register of the multi-register lanes is written out (`parts`: their
// indices), not made by `array::from_fn` closures: those were compiled
// without AVX2 in some uses and left `_mm256_and_si256`, `_mm256_cmpeq_epi32`
// and three more as calls in the packets' mask code.
macro_rules! parts {
    ($lanes:ident, $mask:ident, $n:literal, $w:literal, $reg:ty,
     set1: $set1:ident, loadu: $loadu:ident, storeu: $storeu:ident,
     add: $add:ident, sub: $sub:ident, mul: $mul:ident, div: $div:ident, sqrt: $sqrt:ident,
     min: $min:ident, max: $max:ident, and: $and:ident, or: $or:ident, andnot: $andnot:ident,
     movemask: $movemask:ident, blend: $blend:expr, from_bits: $from_bits:expr,
     cmp: $cmp:expr, hmin: $hmin:expr, hmax: $hmax:expr, avx2: $avx2:literal, parts: [$($p:literal),*]) => {
        impl Mask for $mask {
            #[inline(always)]
            fn from_bits(bits: u16) -> Self {
                $mask([$(unsafe { $from_bits((bits >> ($w * $p)) as i32) }),*])
            }
            #[inline(always)]
            fn bits(self) -> u16 {
                0u16 $(| ((unsafe { $movemask(self.0[$p]) } as u16) << ($w * $p)))*
            }
            #[inline(always)]
            fn and(self, o: Self) -> Self {
                $mask([$(unsafe { $and(self.0[$p], o.0[$p]) }),*])
            }
            #[inline(always)]
            fn or(self, o: Self) -> Self {
                $mask([$(unsafe { $or(self.0[$p], o.0[$p]) }),*])
            }
            #[inline(always)]
            fn and_not(self, o: Self) -> Self {
                // andnot(a, b) = !a & b
                $mask([$(unsafe { $andnot(o.0[$p], self.0[$p]) }),*])
            }
        }

        // SAFETY: values exist only inside functions that checked for the
        // instruction set (SSE2 is always present on x86-64).
        unsafe impl Lanes for $lanes {
            type M = $mask;
            const AVX2: bool = $avx2;
            #[inline(always)]
            fn splat(x: f32) -> Self {
                $lanes([unsafe { $set1(x) }; $n])
            }
            #[inline(always)]
            fn from_array(a: [f32; 16]) -> Self {
                $lanes([$(unsafe { $loadu(a.as_ptr().add($w * $p)) }),*])
            }
            #[inline(always)]
            fn to_array(self) -> [f32; 16] {
                let mut a = [0.0f32; 16];
                for p in 0..$n {
                    unsafe { $storeu(a.as_mut_ptr().add($w * p), self.0[p]) };
                }
                a
            }
            #[inline(always)]
            fn add(self, o: Self) -> Self {
                $lanes([$(unsafe { $add(self.0[$p], o.0[$p]) }),*])
            }
            #[inline(always)]
            fn sub(self, o: Self) -> Self {
                $lanes([$(unsafe { $sub(self.0[$p], o.0[$p]) }),*])
            }
            #[inline(always)]
            fn mul(self, o: Self) -> Self {
                $lanes([$(unsafe { $mul(self.0[$p], o.0[$p]) }),*])
            }
            #[inline(always)]
            fn div(self, o: Self) -> Self {
                $lanes([$(unsafe { $div(self.0[$p], o.0[$p]) }),*])
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                $lanes([$(unsafe { $sqrt(self.0[$p]) }),*])
            }
            #[inline(always)]
            fn min(self, o: Self) -> Self {
                $lanes([$(unsafe { $min(self.0[$p], o.0[$p]) }),*])
            }
            #[inline(always)]
            fn max(self, o: Self) -> Self {
                $lanes([$(unsafe { $max(self.0[$p], o.0[$p]) }),*])
            }
            #[inline(always)]
            fn lt(self, o: Self) -> $mask {
                $mask([$(unsafe { $cmp(self.0[$p], o.0[$p], Cmp::Lt) }),*])
            }
            #[inline(always)]
            fn le(self, o: Self) -> $mask {
                $mask([$(unsafe { $cmp(self.0[$p], o.0[$p], Cmp::Le) }),*])
            }
            #[inline(always)]
            fn gt(self, o: Self) -> $mask {
                $mask([$(unsafe { $cmp(o.0[$p], self.0[$p], Cmp::Lt) }),*])
            }
            #[inline(always)]
            fn ge(self, o: Self) -> $mask {
                $mask([$(unsafe { $cmp(o.0[$p], self.0[$p], Cmp::Le) }),*])
            }
            #[inline(always)]
            fn eq(self, o: Self) -> $mask {
                $mask([$(unsafe { $cmp(self.0[$p], o.0[$p], Cmp::Eq) }),*])
            }
            #[inline(always)]
            fn ne(self, o: Self) -> $mask {
                $mask([$(unsafe { $cmp(self.0[$p], o.0[$p], Cmp::Ne) }),*])
            }
            #[inline(always)]
            fn select(m: $mask, a: Self, b: Self) -> Self {
                $lanes([$(unsafe { $blend(m.0[$p], a.0[$p], b.0[$p]) }),*])
            }
            #[inline(always)]
            fn min_lane(self) -> f32 {
                // The registers' lane-wise minimum, then across its lanes.
                let mut m = self.0[0];
                for p in 1..$n {
                    m = unsafe { $min(m, self.0[p]) };
                }
                unsafe { $hmin(m) }
            }
            #[inline(always)]
            fn max_lane(self) -> f32 {
                let mut m = self.0[0];
                for p in 1..$n {
                    m = unsafe { $max(m, self.0[p]) };
                }
                unsafe { $hmax(m) }
            }
        }
    };
}

/// The four comparisons the multi-register lanes are built from (`gt` and
/// `ge` swap the operands).
#[derive(Clone, Copy)]
enum Cmp {
    Lt,
    Le,
    Eq,
    Ne,
}

#[inline(always)]
unsafe fn cmp256(a: __m256, b: __m256, c: Cmp) -> __m256 {
    unsafe {
        match c {
            Cmp::Lt => _mm256_cmp_ps::<_CMP_LT_OQ>(a, b),
            Cmp::Le => _mm256_cmp_ps::<_CMP_LE_OQ>(a, b),
            Cmp::Eq => _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b),
            Cmp::Ne => _mm256_cmp_ps::<_CMP_NEQ_UQ>(a, b),
        }
    }
}

#[inline(always)]
unsafe fn cmp128(a: __m128, b: __m128, c: Cmp) -> __m128 {
    // SSE2's predicates: lt/le ordered (false on NaN), neq unordered.
    unsafe {
        match c {
            Cmp::Lt => _mm_cmplt_ps(a, b),
            Cmp::Le => _mm_cmple_ps(a, b),
            Cmp::Eq => _mm_cmpeq_ps(a, b),
            Cmp::Ne => _mm_cmpneq_ps(a, b),
        }
    }
}

#[inline(always)]
unsafe fn blend256(m: __m256, a: __m256, b: __m256) -> __m256 {
    unsafe { _mm256_blendv_ps(b, a, m) }
}

#[inline(always)]
unsafe fn blend128(m: __m128, a: __m128, b: __m128) -> __m128 {
    // SSE2 has no blend: (m & a) | (!m & b).
    unsafe { _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)) }
}

#[inline(always)]
unsafe fn bits256(bits: i32) -> __m256 {
    unsafe {
        let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let set = _mm256_and_si256(_mm256_set1_epi32(bits), lane_bits);
        _mm256_castsi256_ps(_mm256_cmpeq_epi32(set, lane_bits))
    }
}

#[inline(always)]
unsafe fn bits128(bits: i32) -> __m128 {
    unsafe {
        let lane_bits = _mm_setr_epi32(1, 2, 4, 8);
        let set = _mm_and_si128(_mm_set1_epi32(bits), lane_bits);
        _mm_castsi128_ps(_mm_cmpeq_epi32(set, lane_bits))
    }
}

/// The smallest of four lanes: halves, then neighbours.
#[inline(always)]
unsafe fn hmin128(x: __m128) -> f32 {
    unsafe {
        let x = _mm_min_ps(x, _mm_movehl_ps(x, x));
        _mm_cvtss_f32(_mm_min_ss(x, _mm_shuffle_ps::<0b01>(x, x)))
    }
}

#[inline(always)]
unsafe fn hmax128(x: __m128) -> f32 {
    unsafe {
        let x = _mm_max_ps(x, _mm_movehl_ps(x, x));
        _mm_cvtss_f32(_mm_max_ss(x, _mm_shuffle_ps::<0b01>(x, x)))
    }
}

#[inline(always)]
unsafe fn hmin256(x: __m256) -> f32 {
    unsafe { hmin128(_mm_min_ps(_mm256_castps256_ps128(x), _mm256_extractf128_ps::<1>(x))) }
}

#[inline(always)]
unsafe fn hmax256(x: __m256) -> f32 {
    unsafe { hmax128(_mm_max_ps(_mm256_castps256_ps128(x), _mm256_extractf128_ps::<1>(x))) }
}

parts!(Avx2x2, Avx2Mask, 2, 8, __m256,
    set1: _mm256_set1_ps, loadu: _mm256_loadu_ps, storeu: _mm256_storeu_ps,
    add: _mm256_add_ps, sub: _mm256_sub_ps, mul: _mm256_mul_ps, div: _mm256_div_ps, sqrt: _mm256_sqrt_ps,
    min: _mm256_min_ps, max: _mm256_max_ps, and: _mm256_and_ps, or: _mm256_or_ps, andnot: _mm256_andnot_ps,
    movemask: _mm256_movemask_ps, blend: blend256, from_bits: bits256, cmp: cmp256,
    hmin: hmin256, hmax: hmax256, avx2: true, parts: [0, 1]);

parts!(Ssex4, SseMask, 4, 4, __m128,
    set1: _mm_set1_ps, loadu: _mm_loadu_ps, storeu: _mm_storeu_ps,
    add: _mm_add_ps, sub: _mm_sub_ps, mul: _mm_mul_ps, div: _mm_div_ps, sqrt: _mm_sqrt_ps,
    min: _mm_min_ps, max: _mm_max_ps, and: _mm_and_ps, or: _mm_or_ps, andnot: _mm_andnot_ps,
    movemask: _mm_movemask_ps, blend: blend128, from_bits: bits128, cmp: cmp128,
    hmin: hmin128, hmax: hmax128, avx2: false, parts: [0, 1, 2, 3]);
