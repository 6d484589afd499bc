//! The operations a packet kernel needs on sixteen f32 lanes and their masks.

/// A mask over sixteen lanes (the result of a lane comparison).
pub trait Mask: Copy {
    /// Lanes whose bit is set in `bits` (bit r = lane r).
    fn from_bits(bits: u16) -> Self;
    /// Lane r's state as bit r.
    fn bits(self) -> u16;
    /// Lanes set in both.
    fn and(self, o: Self) -> Self;
    /// Lanes set in either.
    fn or(self, o: Self) -> Self;
    /// `self & !o`.
    fn and_not(self, o: Self) -> Self;
    /// Whether some lane is set.
    #[inline(always)]
    fn any(self) -> bool {
        self.bits() != 0
    }
}

/// Sixteen f32 lanes. Each operation is the IEEE operation of Rust's `f32`
/// lane by lane (`min` and `max` only for operands that are not NaN, and
/// either zero for `min(-0, 0)`: kernels only compare their results), and
/// comparisons follow Rust's: ordered ones are false where a lane is NaN,
/// `ne` is true there.
///
/// # Safety
///
/// Implementations may execute instructions the CPU lacks unless the
/// instruction set is available; an implementation's values must be created
/// only after `Isa::is_available` said so (the dispatching functions check).
pub unsafe trait Lanes: Copy {
    /// The mask the comparisons return.
    type M: Mask;
    /// The CPU has AVX2 wherever these lanes exist (they are made only
    /// inside functions compiled with it), so code inlined beside them may
    /// use 256-bit intrinsics: eight-wide work such as a BVH node's boxes.
    const AVX2: bool = false;
    /// `x` in every lane.
    fn splat(x: f32) -> Self;
    /// Lane r from `a[r]`.
    fn from_array(a: [f32; 16]) -> Self;
    /// Lane r into element r.
    fn to_array(self) -> [f32; 16];
    /// `self + o` per lane.
    fn add(self, o: Self) -> Self;
    /// `self - o` per lane.
    fn sub(self, o: Self) -> Self;
    /// `self * o` per lane (no fused multiply-add).
    fn mul(self, o: Self) -> Self;
    /// `self / o` per lane, correctly rounded.
    fn div(self, o: Self) -> Self;
    /// The correctly rounded square root, as `f32::sqrt`.
    fn sqrt(self) -> Self;
    /// The smaller of each pair (operands not NaN).
    fn min(self, o: Self) -> Self;
    /// The larger of each pair (operands not NaN).
    fn max(self, o: Self) -> Self;
    /// `self < o` per lane (false on NaN).
    fn lt(self, o: Self) -> Self::M;
    /// `self <= o` per lane (false on NaN).
    fn le(self, o: Self) -> Self::M;
    /// `self > o` per lane (false on NaN).
    fn gt(self, o: Self) -> Self::M;
    /// `self >= o` per lane (false on NaN).
    fn ge(self, o: Self) -> Self::M;
    /// `self == o` per lane (false on NaN; `-0 == 0`).
    fn eq(self, o: Self) -> Self::M;
    /// `self != o` per lane (true on NaN).
    fn ne(self, o: Self) -> Self::M;
    /// `m ? a : b` per lane.
    fn select(m: Self::M, a: Self, b: Self) -> Self;
    /// Whether `compress` and `expand` are single instructions (else lane
    /// by lane: correct, but too slow to pay for themselves).
    const FAST_COMPRESS: bool = false;
    /// The lanes of `m`, in order, moved to the lowest lanes (zeros above).
    #[inline(always)]
    fn compress(self, m: Self::M) -> Self {
        let (a, bits) = (self.to_array(), m.bits());
        let mut out = [0.0f32; 16];
        let mut n = 0;
        for (r, &x) in a.iter().enumerate() {
            if bits & (1 << r) != 0 {
                out[n] = x;
                n += 1;
            }
        }
        Self::from_array(out)
    }
    /// The lowest lanes, in order, spread to the lanes of `m`; `src`'s lanes
    /// elsewhere (the inverse of `compress`).
    #[inline(always)]
    fn expand(self, m: Self::M, src: Self) -> Self {
        let (a, bits) = (self.to_array(), m.bits());
        let mut out = src.to_array();
        let mut n = 0;
        for (r, x) in out.iter_mut().enumerate() {
            if bits & (1 << r) != 0 {
                *x = a[n];
                n += 1;
            }
        }
        Self::from_array(out)
    }
    /// The smallest lane (lanes not NaN; either zero where both signs are
    /// there, as `min`).
    #[inline(always)]
    fn min_lane(self) -> f32 {
        self.to_array()
            .into_iter()
            .fold(f32::INFINITY, |m, x| if x < m { x } else { m })
    }
    /// The largest lane (lanes not NaN; a zero of either sign, as `max`).
    #[inline(always)]
    fn max_lane(self) -> f32 {
        self.to_array()
            .into_iter()
            .fold(f32::NEG_INFINITY, |m, x| if x > m { x } else { m })
    }
}
