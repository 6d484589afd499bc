//! A deterministic xorshift generator for the kd-tree's and the BVH's
//! tests, and what both test against: random soups and brute force.

use glam::Vec3;

use super::watertight::ShearedRay;
use crate::geom::ray::Hit;

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

/// The closest hit over all triangles in index order with a strict `<` (so
/// at an equal t the smaller index), tested in the frame `scale` (a power
/// of two; 1 for the plain test).
pub(crate) fn brute_force(tris: &[[Vec3; 3]], scale: f32, o: Vec3, d: Vec3, t_max: f32) -> Hit {
    let ray = ShearedRay::in_frame(o, d, scale);
    let mut best = Hit::MISS;
    let mut best_t = t_max;
    for (i, t) in tris.iter().enumerate() {
        if let Some(t) = ray.intersect(t[0] * scale, t[1] * scale, t[2] * scale, best_t) {
            best_t = t;
            best = Hit { t, triangle: i as u32 };
        }
    }
    best
}

/// `n` triangles with corners within `size` of centres in [-1, 1]^3.
pub(crate) fn random_soup(rng: &mut Rng, n: usize, size: f32) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = rng.vec(-1.0, 1.0);
            [0; 3].map(|_| c + rng.vec(-size, size))
        })
        .collect()
}
