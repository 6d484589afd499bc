//! How a displacement field stores its normalised distances D in [0, 1]
//! (hit distance / 2R, 1 = no hit): section 4 of the paper ("Storage and
//! Error Considerations", "Further Memory Optimization").
//!
//! - 32-bit float: D as is.
//! - 8-bit: round(255 D) ("one byte per ray direction").
//! - 1-bit: hit or miss per direction, plus one distance per map, "the
//!   average distance of the sample points towards the object": the mean D
//!   of the map's texels that hit. A lookup returns that mean for a hit.

use serde::Serialize;

use super::directions::DirectionMapping;
use super::positions::OctahedralGrid;
use crate::error::{Error, Result};

/// Bits per direction of a field's maps (section 4 of the paper).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Storage {
    /// 32-bit float: D as is.
    F32,
    /// 8 bits: round(255 D), one byte per direction (the default).
    U8,
    /// 1 bit: hit or miss per direction, plus per map the mean D of its texels
    /// that hit, which every hit reads.
    Bit1,
}

impl Storage {
    /// 32, 8 or 1.
    pub fn bits(self) -> u32 {
        match self {
            Storage::F32 => 32,
            Storage::U8 => 8,
            Storage::Bit1 => 1,
        }
    }

    /// The storage of `bits` per direction; None unless 32, 8 or 1.
    pub fn from_bits(bits: u32) -> Option<Storage> {
        match bits {
            32 => Some(Storage::F32),
            8 => Some(Storage::U8),
            1 => Some(Storage::Bit1),
            _ => None,
        }
    }
}

/// The sampling and storage choices of a field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldSampling {
    /// The positional samples on the bounding sphere.
    pub grid: OctahedralGrid,
    /// Each map is `res x res` texels.
    pub res: u32,
    /// Bits per direction.
    pub storage: Storage,
    /// How each map's texels cover the hemisphere.
    pub directions: DirectionMapping,
}

/// Largest map side accepted (a 512 x 512 map is already 1 MiB at 32 bits).
pub const MAX_RES: u32 = 512;
/// Largest positional grid side accepted (16,384 maps).
pub const MAX_GRID_SIDE: u32 = 128;

impl FieldSampling {
    /// The parameters as users give them: a number of positional samples
    /// (the octahedral grid takes the nearest square), the map side, bits
    /// per direction (32, 8 or 1) and the direction mapping; checked.
    pub fn new(positions: i64, res: i64, bits: i64, directions: DirectionMapping) -> Result<FieldSampling> {
        if positions < 1 {
            return Err(Error::param(
                "positions",
                format!("must be at least 1, got {positions}"),
            ));
        }
        let storage = u32::try_from(bits)
            .ok()
            .and_then(Storage::from_bits)
            .ok_or_else(|| Error::param("bits", format!("must be 32, 8 or 1, got {bits}")))?;
        let res = u32::try_from(res)
            .map_err(|_| Error::param("res", format!("must be between 2 and {MAX_RES}, got {res}")))?;
        let params = FieldSampling {
            grid: OctahedralGrid::with_count(positions.min(u32::MAX as i64) as u32),
            res,
            storage,
            directions,
        };
        params.validate()?;
        Ok(params)
    }

    /// Checks the grid side (1 to `MAX_GRID_SIDE`) and the map side
    /// (2 to `MAX_RES`).
    pub fn validate(&self) -> Result<()> {
        if self.grid.side == 0 || self.grid.side > MAX_GRID_SIDE {
            return Err(Error::param(
                "positions",
                format!(
                    "must give between 1 and {} positional samples (a {MAX_GRID_SIDE} x {MAX_GRID_SIDE} grid), got a {} x {} grid",
                    MAX_GRID_SIDE * MAX_GRID_SIDE,
                    self.grid.side,
                    self.grid.side
                ),
            ));
        }
        if self.res < 2 || self.res > MAX_RES {
            return Err(Error::param(
                "res",
                format!("must be between 2 and {MAX_RES}, got {}", self.res),
            ));
        }
        Ok(())
    }

    /// Texels (directions) per map: `res` squared.
    pub fn texels_per_map(&self) -> usize {
        self.res as usize * self.res as usize
    }

    /// Maps: one per positional sample.
    pub fn maps(&self) -> usize {
        self.grid.count() as usize
    }

    /// 32-bit words per map in 1-bit storage.
    pub fn words_per_map(&self) -> usize {
        self.texels_per_map().div_ceil(32)
    }
}

/// The maps' contents: map m's texel (a, b) (a along s, b along t) is entry
/// m * res^2 + b * res + a.
#[derive(Debug, Clone, PartialEq)]
pub enum FieldData {
    /// 32-bit storage: D per texel.
    F32(Vec<f32>),
    /// 8-bit storage: round(255 D) per texel, 255 a miss.
    U8(Vec<u8>),
    /// Bit set = the direction hits; `mean[m]` = map m's mean hit distance.
    Bits {
        /// `words_per_map` words per map, texel i at bit i % 32 of word i / 32.
        words: Vec<u32>,
        /// Per map, the mean D of its texels that hit (1 if none does).
        mean: Vec<f32>,
    },
}

impl FieldData {
    /// Quantises the float maps `d` (each entry in [0, 1]).
    pub fn from_distances(params: &FieldSampling, d: &[f32]) -> FieldData {
        match params.storage {
            Storage::F32 => FieldData::F32(d.to_vec()),
            Storage::U8 => FieldData::U8(d.iter().map(|&x| quantise_u8(x)).collect()),
            Storage::Bit1 => {
                let texels = params.texels_per_map();
                let wpm = params.words_per_map();
                let mut words = vec![0u32; params.maps() * wpm];
                let mut mean = Vec::with_capacity(params.maps());
                for (m, map) in d.chunks_exact(texels).enumerate() {
                    let (mut sum, mut hits) = (0.0f64, 0u32);
                    for (i, &x) in map.iter().enumerate() {
                        if x < 1.0 {
                            words[m * wpm + i / 32] |= 1 << (i % 32);
                            sum += x as f64;
                            hits += 1;
                        }
                    }
                    mean.push(if hits == 0 { 1.0 } else { (sum / hits as f64) as f32 });
                }
                FieldData::Bits { words, mean }
            }
        }
    }

    /// Texel `i` of map `m` as a normalised distance.
    #[inline]
    pub fn value(&self, params: &FieldSampling, m: usize, i: usize) -> f32 {
        match self {
            FieldData::F32(v) => v[m * params.texels_per_map() + i],
            FieldData::U8(v) => v[m * params.texels_per_map() + i] as f32 / 255.0,
            FieldData::Bits { words, mean } => {
                if words[m * params.words_per_map() + i / 32] >> (i % 32) & 1 == 1 {
                    mean[m]
                } else {
                    1.0
                }
            }
        }
    }

    /// Bytes of map data (what the GPU holds).
    pub fn bytes(&self) -> usize {
        match self {
            FieldData::F32(v) => v.len() * 4,
            FieldData::U8(v) => v.len(),
            FieldData::Bits { words, mean } => words.len() * 4 + mean.len() * 4,
        }
    }
}

/// 8-bit storage of a normalised distance.
#[inline]
pub fn quantise_u8(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}
