//! Sixteen lanes as a plain array: the fallback where no vector
//! instruction set is known, and the reference the others are tested against.

use super::lanes::{Lanes, Mask};

/// Sixteen f32 in an array; masks are bit sets.
#[derive(Debug, Clone, Copy)]
pub struct Scalar16([f32; 16]);

impl Mask for u16 {
    #[inline(always)]
    fn from_bits(bits: u16) -> Self {
        bits
    }
    #[inline(always)]
    fn bits(self) -> u16 {
        self
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        self & o
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        self | o
    }
    #[inline(always)]
    fn and_not(self, o: Self) -> Self {
        self & !o
    }
}

#[inline(always)]
fn zip(a: [f32; 16], b: [f32; 16], f: impl Fn(f32, f32) -> f32) -> Scalar16 {
    Scalar16(std::array::from_fn(|r| f(a[r], b[r])))
}

#[inline(always)]
fn cmp(a: [f32; 16], b: [f32; 16], f: impl Fn(f32, f32) -> bool) -> u16 {
    (0..16).fold(0u16, |m, r| m | ((f(a[r], b[r]) as u16) << r))
}

// SAFETY: plain Rust arithmetic, available everywhere.
unsafe impl Lanes for Scalar16 {
    type M = u16;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Scalar16([x; 16])
    }
    #[inline(always)]
    fn from_array(a: [f32; 16]) -> Self {
        Scalar16(a)
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 16] {
        self.0
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        zip(self.0, o.0, |a, b| a + b)
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        zip(self.0, o.0, |a, b| a - b)
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        zip(self.0, o.0, |a, b| a * b)
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        zip(self.0, o.0, |a, b| a / b)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Scalar16(self.0.map(f32::sqrt))
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        zip(self.0, o.0, f32::min)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        zip(self.0, o.0, f32::max)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> u16 {
        cmp(self.0, o.0, |a, b| a < b)
    }
    #[inline(always)]
    fn le(self, o: Self) -> u16 {
        cmp(self.0, o.0, |a, b| a <= b)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> u16 {
        cmp(self.0, o.0, |a, b| a > b)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> u16 {
        cmp(self.0, o.0, |a, b| a >= b)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> u16 {
        cmp(self.0, o.0, |a, b| a == b)
    }
    #[inline(always)]
    fn ne(self, o: Self) -> u16 {
        cmp(self.0, o.0, |a, b| a != b)
    }
    #[inline(always)]
    fn select(m: u16, a: Self, b: Self) -> Self {
        Scalar16(std::array::from_fn(|r| if m & (1 << r) != 0 { a.0[r] } else { b.0[r] }))
    }
}
