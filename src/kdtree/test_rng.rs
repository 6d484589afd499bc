//! A deterministic xorshift generator for the kd-tree's tests.

use glam::Vec3;

pub(crate) struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// Uniform in [0, 1), 24 bits.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    pub fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.next_f32(), self.next_f32(), self.next_f32()) * (hi - lo) + Vec3::splat(lo)
    }
}

/// Floats where IEEE rules bite: signed zeros and ones, the smallest
/// normal and subnormal magnitudes, the extremes, infinities and NaNs.
pub(crate) const SPECIAL_F32: [f32; 14] = [
    1.0,
    -1.0,
    0.0,
    -0.0,
    f32::MIN_POSITIVE,
    -f32::MIN_POSITIVE,
    1e-45,
    -1e-45,
    f32::MAX,
    f32::MIN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    -f32::NAN,
];
