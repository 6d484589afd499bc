//! Visibility masks on the unit disk (section 3.1 of Kautz, Lehtinen and
//! Aila 2004, "Hemispherical Rasterization for Self-Shadowing of Dynamic
//! Objects").
//!
//! The hemisphere above a vertex, in its tangent frame (normal = +z), is
//! projected onto the unit disk by dropping z (the Nusselt analog). The disk
//! area element is `dA = cos θ dω`, so integrals of the form
//! `∫ g(s) max(0, n·s) ds` (equation 3 with a diffuse BRDF) become plain
//! area integrals `∫_disk g dA`: the projection importance-samples the cosine.
//!
//! A mask is an S x S bit grid over [-1, 1]²: pixel (r, c) covers
//! `x ∈ [-1 + 2c/S, -1 + 2(c+1)/S]`, `y ∈ [-1 + 2r/S, -1 + 2(r+1)/S]`. Bit
//! index `r S + c` in a little-endian bit stream (u64 words on the CPU, u32
//! words in WGSL: the same bytes). A set bit means *occluded*.
//!
//! Pixels on the rim are only partly inside the disk. Each pixel gets the
//! exact area `A_p` of pixel ∩ disk and, as the direction its bit stands
//! for, the normalised mean direction over that area. Integrals over pixels
//! and cells are computed once, to rounding, by `disk_rect_quadrature`.

use glam::{DVec3, Vec3};

use crate::error::{Error, Result};
use crate::sh::quadrature::gauss_legendre_on;

/// Mask sides penumbra supports (a power of two, a multiple of the 4x4
/// downsampling, and a whole number of u64 words).
pub const MASK_SIDES: [usize; 3] = [16, 32, 64];

/// Pixels per side of a downsampled cell (section 3.2: 4x4 blocks).
pub const CELL: usize = 4;

/// The geometry of an S x S mask: pixel directions and areas, and the cells.
#[derive(Debug, Clone)]
pub struct MaskGrid {
    /// Pixels per side, S (one of [`MASK_SIDES`]).
    pub side: usize,
    /// u64 words per mask.
    pub words: usize,
    /// Direction each pixel's bit stands for (unit, z >= 0).
    pub dirs: Vec<Vec3>,
    /// Area of pixel ∩ disk (the disk has area π).
    pub areas: Vec<f64>,
    /// Bits of the pixels that overlap the disk.
    pub inside: Vec<u64>,
}

impl MaskGrid {
    /// The grid of an S x S mask, pixel directions and areas integrated
    /// over pixel ∩ disk; an error unless `side` is one of [`MASK_SIDES`].
    pub fn new(side: usize) -> Result<MaskGrid> {
        if !MASK_SIDES.contains(&side) {
            return Err(Error::param(
                "mask_side",
                format!("mask side {side} is not supported; use 16, 32 or 64"),
            ));
        }
        let mut dirs = Vec::with_capacity(side * side);
        let mut areas = Vec::with_capacity(side * side);
        let mut inside = vec![0u64; side * side / 64];
        let h = 2.0 / side as f64;
        for r in 0..side {
            for c in 0..side {
                let (x0, y0) = (-1.0 + c as f64 * h, -1.0 + r as f64 * h);
                let mut area = 0.0;
                let mut mean = DVec3::ZERO;
                disk_rect_quadrature(x0, x0 + h, y0, y0 + h, 8, 8, |d, w| {
                    area += w;
                    mean += w * d;
                });
                let dir = if area > 1e-14 {
                    mean.normalize()
                } else {
                    DVec3::new(x0 + 0.5 * h, y0 + 0.5 * h, 0.0).normalize()
                };
                if area > 1e-14 {
                    let bit = r * side + c;
                    inside[bit / 64] |= 1 << (bit % 64);
                }
                dirs.push(dir.as_vec3());
                areas.push(area);
            }
        }
        Ok(MaskGrid {
            side,
            words: side * side / 64,
            dirs,
            areas,
            inside,
        })
    }

    /// Cells per side after 4x4 downsampling.
    pub fn cells_per_side(&self) -> usize {
        self.side / CELL
    }

    /// Number of downsampled cells, `(S / 4)²`.
    pub fn cell_count(&self) -> usize {
        self.cells_per_side() * self.cells_per_side()
    }

    /// The rectangle [x0, x1] x [y0, y1] of cell (row R, column C).
    pub fn cell_rect(&self, row: usize, col: usize) -> [f64; 4] {
        let h = 2.0 * CELL as f64 / self.side as f64;
        [
            -1.0 + col as f64 * h,
            -1.0 + (col + 1) as f64 * h,
            -1.0 + row as f64 * h,
            -1.0 + (row + 1) as f64 * h,
        ]
    }

    /// Pixels overlapping the disk.
    pub fn inside_count(&self) -> usize {
        self.inside.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The bit of pixel (r, c) in `mask`.
    #[inline]
    pub fn get(&self, mask: &[u64], r: usize, c: usize) -> bool {
        let bit = r * self.side + c;
        mask[bit / 64] >> (bit % 64) & 1 == 1
    }

    /// Occluded area of a mask (the disk has area π).
    pub fn occluded_area(&self, mask: &[u64]) -> f64 {
        (0..self.side * self.side)
            .filter(|&b| mask[b / 64] >> (b % 64) & 1 == 1)
            .map(|b| self.areas[b])
            .sum()
    }
}

/// Quadrature over the part of the rectangle [x0, x1] x [y0, y1] inside the
/// unit disk, lifted to the hemisphere: calls `f(direction, dA)` at each
/// node. The rectangle must lie in one closed quadrant (every pixel and cell
/// of a mask does: grid lines pass through 0).
///
/// In polar coordinates on the disk with r = sin θ, `dA = r dr dφ =
/// sin θ cos θ dθ dφ`, and the integrand (any polynomial in the direction)
/// is smooth in θ, whereas in x, y it has a square-root rim. For each φ the
/// ray from the origin meets the rectangle in [t0(φ), t1(φ)]; we integrate θ
/// from asin(t0) to asin(min(t1, 1)). t0, t1 and the clipping at 1 have
/// kinks at the corner angles and where the circle crosses an edge; the φ
/// range is split there, so every piece is smooth and Gauss–Legendre
/// converges exponentially.
pub fn disk_rect_quadrature(
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    nphi: usize,
    ntheta: usize,
    mut f: impl FnMut(DVec3, f64),
) {
    let sx = if x0 + x1 >= 0.0 { 1.0 } else { -1.0 };
    let sy = if y0 + y1 >= 0.0 { 1.0 } else { -1.0 };
    let (a0, a1) = (x0.abs().min(x1.abs()), x0.abs().max(x1.abs()));
    let (b0, b1) = (y0.abs().min(y1.abs()), y0.abs().max(y1.abs()));
    if a0 >= 1.0 || b0 >= 1.0 || a0 * a0 + b0 * b0 >= 1.0 {
        return;
    }
    let phi_lo = b0.atan2(a1);
    let phi_hi = b1.atan2(a0);
    let mut cuts = vec![phi_lo, phi_hi, b0.atan2(a0), b1.atan2(a1)];
    for a in [a0, a1] {
        if a < 1.0 {
            cuts.push(a.acos());
        }
    }
    for b in [b0, b1] {
        if b < 1.0 {
            cuts.push(b.asin());
        }
    }
    cuts.retain(|p| *p >= phi_lo && *p <= phi_hi);
    cuts.sort_by(|a, b| a.total_cmp(b));
    cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-15);
    // Distance along the ray (cos φ, sin φ) at which it crosses x = a (or y = b).
    let reach = |a: f64, c: f64| {
        if a == 0.0 {
            0.0
        } else if c <= 0.0 {
            f64::INFINITY
        } else {
            a / c
        }
    };
    for piece in cuts.windows(2) {
        for (phi, wphi) in gauss_legendre_on(nphi, piece[0], piece[1]) {
            let (s, c) = phi.sin_cos();
            let t0 = reach(a0, c).max(reach(b0, s));
            let t1 = reach(a1, c).min(reach(b1, s)).min(1.0);
            if t1 <= t0 {
                continue;
            }
            for (theta, wt) in gauss_legendre_on(ntheta, t0.asin(), t1.asin()) {
                let (st, ct) = theta.sin_cos();
                f(DVec3::new(sx * st * c, sy * st * s, ct), wphi * wt * st * ct);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_areas_sum_to_the_disk() {
        for side in MASK_SIDES {
            let g = MaskGrid::new(side).unwrap();
            let total: f64 = g.areas.iter().sum();
            assert!((total - std::f64::consts::PI).abs() < 1e-11, "{side}: {total}");
            // Interior pixels have the full area (2/S)².
            let full = (2.0 / side as f64).powi(2);
            let mid = side / 2 * side + side / 2;
            assert!((g.areas[mid] - full).abs() < 1e-13);
            assert!(g.dirs.iter().all(|d| d.z >= 0.0 && (d.length() - 1.0).abs() < 1e-5));
        }
        assert!(MaskGrid::new(24).is_err());
    }

    #[test]
    fn quadrature_integrates_the_cosine_lobe() {
        // ∫_disk z dA = ∫ cos²θ dω over the hemisphere = 2π/3, summed over
        // the four quadrant rectangles.
        let mut total = 0.0;
        for (x0, x1, y0, y1) in [
            (0.0, 1.0, 0.0, 1.0),
            (-1.0, 0.0, 0.0, 1.0),
            (0.0, 1.0, -1.0, 0.0),
            (-1.0, 0.0, -1.0, 0.0),
        ] {
            disk_rect_quadrature(x0, x1, y0, y1, 16, 16, |d, w| total += w * d.z);
        }
        assert!((total - 2.0 * std::f64::consts::PI / 3.0).abs() < 1e-12, "{total}");
    }
}
