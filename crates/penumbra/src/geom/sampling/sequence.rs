//! A deterministic low-discrepancy sequence with a seed: the first two Sobol
//! dimensions with hash-based nested uniform (Owen) scrambling and index
//! shuffling, after Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4),
//! 2020. Everything is 32-bit integer arithmetic, which WGSL reproduces
//! exactly, so a ray's direction depends only on (seed, point, sample index).

/// One stream of 2D points: a seed and a point index (a vertex, a pixel)
/// select an independent scramble of the same Sobol points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SampleSequence {
    /// The seed every stream's scramble is hashed from.
    pub seed: u32,
}

impl SampleSequence {
    /// The sequence of `seed` (`DEFAULT_SEED` unless a method is told).
    pub fn new(seed: u32) -> Self {
        SampleSequence { seed }
    }

    /// Scramble seed of one point's stream.
    #[inline]
    pub fn stream_seed(&self, point: u32) -> u32 {
        hash_u32(self.seed ^ hash_u32(point.wrapping_add(0x9e37_79b9)))
    }

    /// Sample `index` of stream `point`, as two 32-bit fixed-point numbers.
    #[inline]
    pub fn sample_bits(&self, point: u32, index: u32) -> [u32; 2] {
        owen_sobol_2d(index, self.stream_seed(point))
    }

    /// Stream `point` with its seeds hashed once, for drawing many of its
    /// samples (an AO point's rays): the same samples as `sample`.
    #[inline]
    pub fn stream(&self, point: u32) -> StreamSampler {
        StreamSampler::new(self.stream_seed(point))
    }

    /// Sample `index` of stream `point`, in `[0, 1)^2`.
    #[inline]
    pub fn sample(&self, point: u32, index: u32) -> [f32; 2] {
        self.sample_bits(point, index).map(unit_float)
    }

    /// A third dimension for sample `index` of stream `point`, padded to the
    /// 2D points (pbrt's "padding"): the scrambled van der Corput value of
    /// the index under an independent Owen shuffle. The first 2^k values of
    /// a stream are stratified (one per 1/2^k interval) and paired with the
    /// 2D points in an independent random order. Returned as the centre of
    /// its 2^-24 cell, so it is never 0 or 1 (a radius r = R xi^(1/3) must
    /// not be 0).
    #[inline]
    pub fn padded_1d(&self, point: u32, index: u32) -> f32 {
        let seed = hash_u32(self.stream_seed(point) ^ 0x2f0e_1d3b);
        let shuffled = nested_uniform_scramble(index, seed);
        let bits = nested_uniform_scramble(shuffled.reverse_bits(), hash_u32(seed ^ 0x1b87_3593));
        ((bits >> 8) as f32 + 0.5) * (1.0 / 16_777_216.0)
    }
}

/// Integer hash ("lowbias32", Chris Wellons' hash-prospector).
#[inline]
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The top 24 bits as a float in [0, 1): exact, so identical on every device.
#[inline]
pub fn unit_float(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Laine–Karras style permutation that scrambles bits only upward, which on
/// bit-reversed input is a nested uniform scramble (Burley 2020, listing 2).
#[inline]
fn laine_karras_permutation(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

#[inline]
fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// Sobol dimension 0 (van der Corput) and 1, as 32-bit fractions, bit by
/// bit: the definition `SOBOL1_REVERSED` is checked against.
#[cfg(test)]
fn sobol_2d(index: u32) -> [u32; 2] {
    let x = index.reverse_bits();
    // Dimension 1: generator matrix columns v_k = v_{k-1} ^ (v_{k-1} >> 1),
    // starting from 1 << 31.
    let mut y = 0u32;
    let mut v = 1u32 << 31;
    let mut i = index;
    while i != 0 {
        if i & 1 != 0 {
            y ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    [x, y]
}

/// Sobol dimension 1 with its bits reversed, one table per byte of the
/// index: the dimension is linear over XOR in the index's bits, and so is
/// bit reversal, so XOR-ing the four bytes' entries gives it exactly. The
/// bit loop over a scrambled (full 32-bit) index, with a data-dependent
/// branch per bit, was about a third of an AO direction's cost.
static SOBOL1_REVERSED: [[u32; 256]; 4] = sobol1_reversed_tables();

const fn sobol1_reversed_tables() -> [[u32; 256]; 4] {
    // Column k of the generator matrix: v_0 = 1 << 31, v_k = v_{k-1} ^ (v_{k-1} >> 1).
    let mut columns = [0u32; 32];
    let mut v = 1u32 << 31;
    let mut k = 0;
    while k < 32 {
        columns[k] = v.reverse_bits();
        v ^= v >> 1;
        k += 1;
    }
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut byte = 0;
        while byte < 256 {
            let mut y = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if byte & (1 << bit) != 0 {
                    y ^= columns[8 * b + bit];
                }
                bit += 1;
            }
            t[b][byte] = y;
            byte += 1;
        }
        b += 1;
    }
    t
}

/// Sobol dimension 1 of `index`, bit-reversed.
#[inline(always)]
fn sobol1_reversed(index: u32) -> u32 {
    let t = &SOBOL1_REVERSED;
    t[0][(index & 0xff) as usize]
        ^ t[1][((index >> 8) & 0xff) as usize]
        ^ t[2][((index >> 16) & 0xff) as usize]
        ^ t[3][(index >> 24) as usize]
}

/// Burley's shuffled, scrambled Sobol 2D point.
#[inline]
pub fn owen_sobol_2d(index: u32, seed: u32) -> [u32; 2] {
    StreamSampler::new(seed).sample_bits(index)
}

/// One stream's scramble seeds, hashed once (`SampleSequence::stream`).
///
/// `owen_sobol_2d` spelled out with fewer bit reversals, each step exact:
/// with `nus(x, s) = rev(lk(rev(x), s))` (the nested uniform scramble),
/// the shuffled index is `i' = rev(lk(rev(i), s))`; dimension 0 of it is
/// `rev(i') = lk(rev(i), s)`, so its scramble `nus(rev(i'), sx)` is
/// `rev(lk(i', sx))`; dimension 1 enters `nus` reversed, which the table
/// gives directly. Four reversals per sample instead of six, and no bit loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StreamSampler {
    shuffle: u32,
    x: u32,
    y: u32,
}

impl StreamSampler {
    /// The stream whose scramble seed is `seed`
    /// (`SampleSequence::stream_seed`).
    #[inline]
    pub fn new(seed: u32) -> Self {
        StreamSampler {
            shuffle: seed,
            x: hash_u32(seed ^ 0xa511_e9b3),
            y: hash_u32(seed ^ 0x63d8_3595),
        }
    }

    /// Sample `index`, as two 32-bit fixed-point numbers.
    #[inline]
    pub fn sample_bits(&self, index: u32) -> [u32; 2] {
        let shuffled = laine_karras_permutation(index.reverse_bits(), self.shuffle).reverse_bits();
        [
            laine_karras_permutation(shuffled, self.x).reverse_bits(),
            laine_karras_permutation(sobol1_reversed(shuffled), self.y).reverse_bits(),
        ]
    }

    /// Sample `index` in `[0, 1)^2`.
    #[inline]
    pub fn sample(&self, index: u32) -> [f32; 2] {
        self.sample_bits(index).map(unit_float)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unscrambled_sobol_is_the_known_sequence() {
        // First points of Sobol dims 0 and 1: (0,0) (.5,.5) (.25,.75) (.75,.25).
        let expect = [[0.0, 0.0], [0.5, 0.5], [0.25, 0.75], [0.75, 0.25]];
        for (i, e) in expect.iter().enumerate() {
            let p = sobol_2d(i as u32).map(unit_float);
            assert_eq!(p, *e);
        }
    }

    #[test]
    fn scrambled_points_are_stratified() {
        // Any 2^k consecutive-from-zero points of a (0,2)-sequence put exactly
        // one point in each cell of every 2^a x 2^b elementary grid, a+b = k.
        let seq = SampleSequence::new(7);
        let n = 256u32;
        for (a, b) in [(8, 0), (4, 4), (0, 8), (3, 5)] {
            let mut seen = vec![false; n as usize];
            for i in 0..n {
                let [x, y] = seq.sample_bits(12345, i);
                // The top a bits of x and the top b bits of y (a shift by 32
                // is not zero in Rust, hence the checked shifts).
                let top = |v: u32, bits: u32| v.checked_shr(32 - bits).unwrap_or(0);
                let cell = (top(x, a) << b) | top(y, b);
                assert!(!std::mem::replace(&mut seen[cell as usize], true), "grid {a}x{b}");
            }
        }
    }

    #[test]
    fn padded_dimension_is_stratified_and_decorrelated() {
        let seq = SampleSequence::new(3);
        let n = 256u32;
        let mut seen = vec![false; n as usize];
        let mut corr = 0.0f64;
        for i in 0..n {
            let z = seq.padded_1d(77, i);
            assert!(z > 0.0 && z < 1.0);
            assert!(!std::mem::replace(&mut seen[(z * n as f32) as usize], true));
            corr += (z as f64 - 0.5) * (seq.sample(77, i)[0] as f64 - 0.5);
        }
        // Independent pairing: the covariance with dimension 0 is small
        // (1/12 = 0.083 would be perfect correlation; independent pairs
        // give a standard deviation of 1/(12 sqrt(256)) = 0.005).
        assert!((corr / n as f64).abs() < 0.025, "{}", corr / n as f64);
    }

    /// `owen_sobol_2d` as first written: three nested scrambles around
    /// the bit-by-bit Sobol point.
    fn owen_sobol_2d_reference(index: u32, seed: u32) -> [u32; 2] {
        let shuffled = nested_uniform_scramble(index, seed);
        let [x, y] = sobol_2d(shuffled);
        [
            nested_uniform_scramble(x, hash_u32(seed ^ 0xa511_e9b3)),
            nested_uniform_scramble(y, hash_u32(seed ^ 0x63d8_3595)),
        ]
    }

    #[test]
    fn fast_samples_equal_the_definition_bit_for_bit() {
        let mut state = 0x1234_5678u32;
        for seed in (0..64).map(|s| hash_u32(s * 7919)).chain([0, u32::MAX]) {
            let stream = StreamSampler::new(seed);
            for index in (0..1024).chain((0..256).map(|_| {
                state = hash_u32(state);
                state
            })) {
                let expect = owen_sobol_2d_reference(index, seed);
                assert_eq!(owen_sobol_2d(index, seed), expect, "seed {seed} index {index}");
                assert_eq!(stream.sample_bits(index), expect);
            }
        }
        let seq = SampleSequence::new(5);
        assert_eq!(seq.stream(17).sample(40), seq.sample(17, 40));
    }

    #[test]
    fn seeds_and_streams_differ_and_repeat() {
        let a = SampleSequence::new(1);
        let b = SampleSequence::new(2);
        assert_eq!(a.sample(3, 5), a.sample(3, 5));
        assert_ne!(a.sample(3, 5), b.sample(3, 5));
        assert_ne!(a.sample(3, 5), a.sample(4, 5));
        for i in 0..1000 {
            let [x, y] = a.sample(9, i);
            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
        }
    }
}
