//! Which sample set each pixel uses: interleaved sampling (Keller and
//! Heidrich 2001; the paper's section 5) or a set of its own.
//!
//! * Interleaved: the pixels of every 4x4 block use 16 different sets, the
//!   same 16 in every block. Pixel k = (x mod 4) + 4 (y mod 4) takes samples
//!   k n .. k n + n - 1 of one Owen-scrambled Sobol stream, so each pixel's
//!   set is stratified on its own and the 16 sets of a block together are
//!   the first 16 n points of the sequence: the 4x4 low-pass filter
//!   (`filter`) then averages a well-stratified set of 16 n samples.
//! * Not interleaved ("different random numbers in neighbouring pixels"):
//!   every pixel of a 64x64 tile has its own stream (index 0 .. n - 1), and
//!   the tile repeats; the side shrinks for huge sample counts so the table
//!   stays within 2^21 entries.
//!
//! Either way the sets are a table (`estimators::SampleTable`) indexed by
//! `pattern_index(x, y) * n + j`, built once on the CPU and read by both
//! twins, so the GPU and CPU use the very same samples.

use crate::geom::sampling::SampleSequence;

/// Side of the interleaving pattern (the paper's 4x4).
pub const INTERLEAVE_SIDE: u32 = 4;
/// Side of the tile of independent sets without interleaving.
pub const INDEPENDENT_SIDE: u32 = 64;
/// Largest table (entries of 16 bytes).
pub const MAX_TABLE_ENTRIES: u64 = 1 << 21;

/// The pixel-to-sample-set assignment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Patterns {
    pub interleave: bool,
    /// Pattern side P: pixel (x, y) uses set (x mod P) + P (y mod P).
    pub side: u32,
}

impl Patterns {
    /// `per_pattern`: table entries per set.
    pub fn new(interleave: bool, per_pattern: u32) -> Patterns {
        let side = if interleave {
            INTERLEAVE_SIDE
        } else {
            let mut side = INDEPENDENT_SIDE;
            while side > INTERLEAVE_SIDE && (side * side) as u64 * per_pattern as u64 > MAX_TABLE_ENTRIES {
                side /= 2;
            }
            side
        };
        Patterns { interleave, side }
    }

    pub fn count(&self) -> u32 {
        self.side * self.side
    }

    /// `pattern_index` in `wgsl/ssao_common.wgsl`.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> u32 {
        (x % self.side) + self.side * (y % self.side)
    }

    /// Sample j (of `count` per set) of set `pattern`: two Sobol
    /// dimensions and a padded third, in [0, 1)^2 x (0, 1).
    pub fn sample(&self, seq: &SampleSequence, pattern: u32, count: u32, j: u32) -> [f32; 3] {
        let (stream, index) = if self.interleave {
            (0, pattern * count + j)
        } else {
            (pattern, j)
        };
        let [u, v] = seq.sample(stream, index);
        [u, v, seq.padded_1d(stream, index)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interleaved_block_is_the_prefix_of_one_stratified_stream() {
        // 16 pixels x 4 samples = the first 64 Sobol points: one per cell of
        // an 8x8 grid.
        let p = Patterns::new(true, 4);
        let seq = SampleSequence::new(9);
        let mut seen = [false; 64];
        for y in 0..4 {
            for x in 0..4 {
                for j in 0..4 {
                    let [u, v, _] = p.sample(&seq, p.index(x, y), 4, j);
                    let cell = (u * 8.0) as usize + 8 * (v * 8.0) as usize;
                    assert!(!std::mem::replace(&mut seen[cell], true));
                }
            }
        }
        // The pattern repeats every 4 pixels.
        assert_eq!(p.index(1, 2), p.index(5, 6));
    }

    #[test]
    fn independent_sets_shrink_for_big_counts() {
        assert_eq!(Patterns::new(false, 32).side, 64);
        let big = Patterns::new(false, 4096);
        assert!((big.count() as u64 * 4096) <= MAX_TABLE_ENTRIES && big.side >= 4);
        let p = Patterns::new(false, 4);
        let seq = SampleSequence::new(1);
        assert_ne!(p.sample(&seq, 0, 4, 0), p.sample(&seq, 1, 4, 0));
    }
}
