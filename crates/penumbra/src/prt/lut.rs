//! The plane look-up table of section 3.1.1: for a discrete set of planes
//! through the origin, the bitmask of mask pixels above each plane.
//!
//! Planes are indexed by their normal with a cube-map parameterisation: the
//! normal's major axis picks a face, the other two components divided by the
//! major one give (u, v) ∈ [-1, 1]², quantised to n x n cells. The paper
//! stores 6 faces (6 x 128 x 128 x 32x32 bits = 12 MB). A plane with normal
//! -m has exactly the complementary mask of m (up to pixels lying on the
//! plane, a set of measure zero), so we store the three positive faces and
//! complement the fetched mask when the major component is negative: half
//! the memory (6 MB at 128) and half the cache footprint, for one XOR.
//!
//! Entry (axis, iv, iu) holds the mask of the normal at the cell centre,
//! `e_axis + u_c e_u + v_c e_v`; bit p is set when `d_p · m > 0` for the
//! pixel direction d_p of `MaskGrid`. (u, v) are the components that follow
//! the axis cyclically: (y, z) for x, (z, x) for y, (x, y) for z.

use glam::Vec3;
use rayon::prelude::*;

use super::mask::MaskGrid;
use crate::error::{Error, Result};

/// 64 bytes, cache-line aligned storage for masks.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Line(pub [u64; 8]);

/// Largest LUT, in bytes (a 6 x 512 x 512 table of 32x32 masks is 100 MB).
pub const MAX_LUT_BYTES: usize = 1 << 30;

/// The table for one mask grid.
#[derive(Clone)]
pub struct PlaneLut {
    /// Cells per cube-face side.
    pub n: usize,
    /// u64 words per mask.
    pub words: usize,
    lines: Vec<Line>,
}

impl std::fmt::Debug for PlaneLut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlaneLut")
            .field("n", &self.n)
            .field("words", &self.words)
            .finish()
    }
}

/// Where a plane's mask is: entry index and whether to complement it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LutRef {
    /// Index of the stored mask: `(axis · n + iv) · n + iu`, axis 0, 1, 2
    /// for a major component along x, y, z.
    pub entry: u32,
    /// The major component is negative: the plane's mask is the complement
    /// of the stored one.
    pub complement: bool,
}

impl PlaneLut {
    /// Builds the table for `grid` with `n` x `n` cells per face.
    pub fn build(grid: &MaskGrid, n: usize) -> Result<PlaneLut> {
        if n == 0 {
            return Err(Error::param("lut_size", "must be at least 1"));
        }
        let words = grid.words;
        let bytes = 3 * n * n * words * 8;
        if bytes > MAX_LUT_BYTES {
            return Err(Error::param(
                "lut_size",
                format!(
                    "a 6 x {n} x {n} table of {s}x{s} masks needs {} MiB (limit {} MiB)",
                    bytes >> 20,
                    MAX_LUT_BYTES >> 20,
                    s = grid.side
                ),
            ));
        }
        let mut words_vec = vec![0u64; 3 * n * n * words];
        words_vec.par_chunks_mut(words).enumerate().for_each(|(entry, mask)| {
            let m = Self::cell_normal(n, entry);
            for (p, d) in grid.dirs.iter().enumerate() {
                if d.dot(m) > 0.0 {
                    mask[p / 64] |= 1 << (p % 64);
                }
            }
        });
        let mut lines = vec![Line([0; 8]); words_vec.len().div_ceil(8)];
        bytemuck::cast_slice_mut::<Line, u64>(&mut lines)[..words_vec.len()].copy_from_slice(&words_vec);
        Ok(PlaneLut { n, words, lines })
    }

    /// The plane normal entry `entry` stands for (cell centre).
    pub fn cell_normal(n: usize, entry: usize) -> Vec3 {
        let axis = entry / (n * n);
        let iv = entry / n % n;
        let iu = entry % n;
        let u = (iu as f32 + 0.5) * 2.0 / n as f32 - 1.0;
        let v = (iv as f32 + 0.5) * 2.0 / n as f32 - 1.0;
        match axis {
            0 => Vec3::new(1.0, u, v),
            1 => Vec3::new(v, 1.0, u),
            _ => Vec3::new(u, v, 1.0),
        }
    }

    /// The entry of the plane with normal `m` (any length); `None` for the
    /// zero vector. (Masks are rasterised on the CPU only: see `prt::gpu`.)
    #[inline(always)]
    pub fn lookup(&self, m: Vec3) -> Option<LutRef> {
        lut_index(self.n as u32, m)
    }

    /// All words of the table.
    pub fn words_slice(&self) -> &[u64] {
        &bytemuck::cast_slice::<Line, u64>(&self.lines)[..3 * self.n * self.n * self.words]
    }

    /// The mask of entry `e`.
    #[inline(always)]
    pub fn mask(&self, e: u32) -> &[u64] {
        let w = self.words;
        let all = bytemuck::cast_slice::<Line, u64>(&self.lines);
        &all[e as usize * w..e as usize * w + w]
    }

    /// Table size in bytes.
    pub fn bytes(&self) -> usize {
        3 * self.n * self.n * self.words * 8
    }

    /// The size the paper's six-face table would have.
    pub fn six_face_bytes(&self) -> usize {
        2 * self.bytes()
    }
}

/// Cube-map index of a plane normal (see the module docs).
#[inline(always)]
pub fn lut_index(n: u32, m: Vec3) -> Option<LutRef> {
    let a = m.abs();
    let (axis, major, u, v) = if a.x >= a.y && a.x >= a.z {
        (0, m.x, m.y, m.z)
    } else if a.y >= a.z {
        (1, m.y, m.z, m.x)
    } else {
        (2, m.z, m.x, m.y)
    };
    if major == 0.0 {
        return None;
    }
    let inv = 1.0 / major;
    let nf = n as f32;
    let iu = (((u * inv + 1.0) * 0.5 * nf) as i32).clamp(0, n as i32 - 1) as u32;
    let iv = (((v * inv + 1.0) * 0.5 * nf) as i32).clamp(0, n as i32 - 1) as u32;
    Some(LutRef {
        entry: (axis * n + iv) * n + iu,
        complement: major < 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookup_inverts_cell_normals() {
        let n = 16;
        for entry in 0..3 * n * n {
            let m = PlaneLut::cell_normal(n, entry);
            let r = lut_index(n as u32, m).unwrap();
            assert_eq!(
                r,
                LutRef {
                    entry: entry as u32,
                    complement: false
                }
            );
            let r = lut_index(n as u32, -2.0 * m).unwrap();
            assert_eq!(
                r,
                LutRef {
                    entry: entry as u32,
                    complement: true
                }
            );
        }
        assert!(lut_index(4, Vec3::ZERO).is_none());
    }

    #[test]
    fn masks_are_half_spaces() {
        let grid = MaskGrid::new(16).unwrap();
        let lut = PlaneLut::build(&grid, 8).unwrap();
        // The plane z = 0 seen from above lands in a cell whose normal is
        // tilted by half a cell; bit p must be exactly `d_p · m > 0` for that
        // cell normal, and every pixel higher than the tilt is set.
        let up = lut.lookup(Vec3::Z).unwrap();
        let m = PlaneLut::cell_normal(8, up.entry as usize);
        let tilt = (m.truncate().length() / m.length()).asin();
        let mask = lut.mask(up.entry);
        let mut high = 0;
        for (p, d) in grid.dirs.iter().enumerate() {
            let bit = mask[p / 64] >> (p % 64) & 1 == 1;
            let inside = grid.inside[p / 64] >> (p % 64) & 1 == 1;
            if inside {
                assert_eq!(bit, d.dot(m) > 0.0, "pixel {p}");
            }
            if inside && d.z > tilt.sin() {
                assert!(bit, "pixel {p} at z = {} is above the tilted plane", d.z);
                high += 1;
            }
        }
        assert!(high > grid.inside_count() / 2);
        assert_eq!(lut.bytes(), 3 * 64 * 32);
    }
}
