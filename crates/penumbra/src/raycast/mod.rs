//! Reference ambient occlusion by ray casting.
//!
//! Ambient accessibility at a point x with normal n is
//! A(x) = (1/pi) * integral over the hemisphere of V(x, w) cos(theta) dw,
//! with V = 1 when no surface is hit within the radius. Sampling w with
//! density cos(theta)/pi (Malley's method) makes the estimator the fraction of
//! unoccluded rays. Ray j of point i follows sample j of stream i of the
//! seeded sequence, on the CPU (`raycast`) and in WGSL (`gpu`) alike, and both
//! return the per-ray results as bit masks so they can be compared ray by ray.

pub mod ao_rays;
mod entry;
pub mod gpu;
pub mod holes;
pub(crate) mod packets;
pub mod points;
pub mod report;
pub mod runner;
pub mod tracer;

pub use entry::AmbientOcclusion;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::error::{Error, Result};
use crate::geom::sampling::concentric::concentric_polar;
use crate::geom::sampling::hemisphere::malley_lift;
use crate::geom::sampling::{Frame, SampleSequence, StreamSampler, cosine_hemisphere, unit_float};

/// The most rays per point (and per pixel for SSAO's ray-traced references).
pub const MAX_RAYS_PER_POINT: u32 = 1 << 20;

/// Where AO is estimated: the ray origin (already offset from the surface),
/// the unit normal of the hemisphere, and the index of the point's stream in
/// the sample sequence (a vertex or pixel index, so results do not depend on
/// how points are batched). A zero normal means "no hemisphere": no rays are
/// cast and the point counts as open. Same layout as the GPU's `points`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct AoPoint {
    /// The rays' origin, in the mesh's coordinates, already offset from the
    /// surface along the normal.
    pub origin: [f32; 3],
    /// The point's stream in the sample sequence.
    pub stream: u32,
    /// The hemisphere's unit normal; zero for none.
    pub normal: [f32; 3],
    /// Padding to the GPU's 8 words; always 0.
    pub _pad: u32,
}

impl AoPoint {
    /// A point at `origin` (already offset) with hemisphere `normal` (unit,
    /// or zero for none) and sample stream `stream`.
    pub fn new(origin: Vec3, normal: Vec3, stream: u32) -> Self {
        AoPoint {
            origin: origin.to_array(),
            stream,
            normal: normal.to_array(),
            _pad: 0,
        }
    }

    /// Whether rays are cast from the point (its normal is not zero).
    pub fn has_hemisphere(&self) -> bool {
        self.normal != [0.0; 3]
    }
}

// The WGSL kernel reads 8 words per point.
const _: () = assert!(std::mem::size_of::<AoPoint>() == 32);

/// How many rays, how far, which sample sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AoSettings {
    /// Rays per point; AO is the fraction that escape (default 256).
    pub rays_per_point: u32,
    /// Occluders farther than this do not count; `f32::INFINITY` for none
    /// (the default).
    pub radius: f32,
    /// The sample sequence's seed: the same seed gives the same rays, bit
    /// for bit, on one device (default [`DEFAULT_SEED`](crate::geom::sampling::DEFAULT_SEED)).
    pub seed: u32,
}

impl Default for AoSettings {
    fn default() -> Self {
        AoSettings {
            rays_per_point: 256,
            radius: f32::INFINITY,
            seed: crate::geom::sampling::DEFAULT_SEED,
        }
    }
}

impl AoSettings {
    /// `Ok`, or a parameter error: `rays_per_point` must be in
    /// 1..=`MAX_RAYS_PER_POINT` and `radius` positive (infinity allowed).
    pub fn validate(&self) -> Result<()> {
        if self.rays_per_point == 0 {
            return Err(Error::param("rays_per_point", "must be at least 1"));
        }
        if self.rays_per_point > MAX_RAYS_PER_POINT {
            return Err(Error::param("rays_per_point", "must be at most 1048576 per point"));
        }
        if self.radius.is_nan() || self.radius <= 0.0 {
            return Err(Error::param("radius", format!("must be positive, got {}", self.radius)));
        }
        Ok(())
    }

    /// 32-bit words of a point's visibility mask: one bit per ray.
    pub fn words_per_point(&self) -> u32 {
        self.rays_per_point.div_ceil(32)
    }
}

/// Direction of ray `j` of the point with stream index `point`: sample j of
/// the point's stream, mapped to the cosine-weighted hemisphere about `normal`.
#[inline]
pub fn ray_direction(seq: &SampleSequence, point: u32, j: u32, normal: Vec3) -> Vec3 {
    PointDirections::new(seq, point, normal).direction(j)
}

/// The AO ray directions of one point, with what all of them share (the
/// stream's scramble seeds, the tangent frame) made once: `direction(j)` is
/// `ray_direction(seq, point, j, normal)` bit for bit.
#[derive(Debug, Clone, Copy)]
pub struct PointDirections {
    stream: StreamSampler,
    frame: Frame,
}

impl PointDirections {
    /// The directions of stream `point` of `seq` about the unit `normal`.
    #[inline]
    pub fn new(seq: &SampleSequence, point: u32, normal: Vec3) -> Self {
        PointDirections {
            stream: seq.stream(point),
            frame: Frame::from_normal(normal),
        }
    }

    /// Ray `j`'s unit direction, in world space.
    #[inline]
    pub fn direction(&self, j: u32) -> Vec3 {
        let [u, v] = self.stream.sample(j);
        self.frame.to_world(cosine_hemisphere(u, v))
    }

    /// Rays 0..`out.len()`: each one's direction and the cell of its sample in the
    /// square's 4x4 grid, in Morton order (`packets` groups rays by it).
    /// Sixteen rays at a time, each block in passes so that only libm's
    /// sine and cosine run one ray at a time: the samples' integer
    /// arithmetic, the concentric map's (r, phi), then the lift to the
    /// hemisphere and world, all vectorised. The seeds and frame are local
    /// copies and the samples go to a local array: written straight into
    /// `bits` through `self`, the compiler (once this is inlined into a
    /// kernel) may reload the seeds per sample, unable to rule out
    /// aliasing, and leave the loop scalar, 4 to 5 times slower.
    /// (Plain loops over slices: iterator adaptors compiled out of line
    /// would not see the caller's `target_feature`.)
    #[inline(always)]
    pub fn directions_and_cells(&self, bits: &mut [[u32; 2]], out: &mut [(Vec3, u8)]) {
        const BLOCK: usize = 16;
        let (stream, frame) = (self.stream, self.frame);
        for (k, (outs, bs)) in out.chunks_mut(BLOCK).zip(bits.chunks_mut(BLOCK)).enumerate() {
            // A whole block's samples even in a short last block (the
            // extra ones are never read): a fixed trip count vectorises.
            let mut block = [[0u32; 2]; BLOCK];
            for (i, b) in block.iter_mut().enumerate() {
                *b = stream.sample_bits((k * BLOCK + i) as u32);
            }
            let n = bs.len();
            bs.copy_from_slice(&block[..n]);
            let mut polar = [[0.0f32; 2]; BLOCK];
            for (p, b) in polar.iter_mut().zip(&block) {
                *p = concentric_polar(unit_float(b[0]), unit_float(b[1]));
            }
            let mut sin_cos = [(0.0f32, 0.0f32); BLOCK];
            for (sc, p) in sin_cos.iter_mut().zip(&polar).take(n) {
                *sc = p[1].sin_cos();
            }
            for ((o, b), (&[r, _], &(s, c))) in outs.iter_mut().zip(&block).zip(polar.iter().zip(&sin_cos)) {
                let [x, y] = b.map(|b| (b >> 30) as u8);
                let cell = (x & 1) | (y & 1) << 1 | (x >> 1) << 2 | (y >> 1) << 3;
                *o = (frame.to_world(malley_lift(r * c, r * s)), cell);
            }
        }
    }
}

/// Per-ray results: bit j of point i's `words_per_point` words is set when
/// ray j escaped.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VisibilityMasks {
    /// Rays cast from each point.
    pub rays_per_point: u32,
    /// Words of each point's mask: `rays_per_point` rounded up to 32 bits.
    pub words_per_point: u32,
    /// The masks, point after point; the bits past `rays_per_point` in a
    /// point's last word are 0.
    pub bits: Vec<u32>,
}

impl VisibilityMasks {
    /// The masks of rays whose occlusion `occluded` holds in this layout
    /// (bit j of a point's words set when ray j was blocked, as
    /// `field::gpu::FieldAoPass` writes them): every bit flipped, but the
    /// bits past `settings.rays_per_point` in a point's last word, which
    /// stay clear.
    pub fn from_occluded(occluded: &[u32], settings: &AoSettings) -> VisibilityMasks {
        let words = settings.words_per_point() as usize;
        let valid: Vec<u32> = (0..words)
            .map(|w| {
                let rays = (settings.rays_per_point as usize).saturating_sub(32 * w).min(32);
                if rays == 32 { u32::MAX } else { (1u32 << rays) - 1 }
            })
            .collect();
        VisibilityMasks {
            rays_per_point: settings.rays_per_point,
            words_per_point: words as u32,
            bits: occluded
                .iter()
                .enumerate()
                .map(|(i, &o)| !o & valid[i % words])
                .collect(),
        }
    }

    /// How many points the masks are of.
    pub fn points(&self) -> usize {
        self.bits.len() / self.words_per_point as usize
    }

    /// Point `point`'s mask: `words_per_point` words, bit j of word j / 32
    /// (counting from the least significant) set when ray j escaped.
    pub fn mask(&self, point: usize) -> &[u32] {
        let w = self.words_per_point as usize;
        &self.bits[point * w..(point + 1) * w]
    }

    /// Fraction of unoccluded rays per point.
    pub fn accessibility(&self) -> Vec<f32> {
        (0..self.points())
            .map(|p| {
                let visible: u32 = self.mask(p).iter().map(|w| w.count_ones()).sum();
                visible as f32 / self.rays_per_point as f32
            })
            .collect()
    }

    /// Number of rays whose result differs between two runs. Masks of
    /// another shape (points, rays per point) differ in every ray of the
    /// larger: pairing words would let a run that lost points compare equal.
    pub fn differing_rays(&self, other: &VisibilityMasks) -> u64 {
        if self.bits.len() != other.bits.len() || self.rays_per_point != other.rays_per_point {
            let rays = |m: &VisibilityMasks| m.points() as u64 * m.rays_per_point as u64;
            return rays(self).max(rays(other)).max(1);
        }
        self.bits
            .iter()
            .zip(&other.bits)
            .map(|(a, b)| (a ^ b).count_ones() as u64)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The batched passes (blocks of sixteen, the polar map apart from
    /// libm's sine and cosine) give `direction(j)` bit for bit, for counts
    /// that fill blocks exactly and that leave a remainder, and the cell is
    /// the sample's 4x4 grid cell in Morton order.
    #[test]
    fn batched_directions_equal_one_at_a_time() {
        let seq = SampleSequence::new(0x5eed);
        let normals = [Vec3::Z, -Vec3::Z, Vec3::new(0.3, -0.8, 0.52).normalize(), Vec3::X];
        for (p, &normal) in normals.iter().enumerate() {
            for n in [1usize, 15, 16, 17, 256, 301] {
                let dirs = PointDirections::new(&seq, p as u32 * 977, normal);
                let (mut bits, mut out) = (vec![[0u32; 2]; n], vec![(Vec3::ZERO, 0u8); n]);
                dirs.directions_and_cells(&mut bits, &mut out);
                for (j, &(d, cell)) in out.iter().enumerate() {
                    let one = dirs.direction(j as u32);
                    assert_eq!(
                        d.to_array().map(f32::to_bits),
                        one.to_array().map(f32::to_bits),
                        "ray {j} of {n}"
                    );
                    let [u, v] = dirs.stream.sample(j as u32).map(|x| (x * 4.0) as u8);
                    assert_eq!(cell, (u & 1) | (v & 1) << 1 | (u >> 1) << 2 | (v >> 1) << 3);
                }
            }
        }
    }
}
