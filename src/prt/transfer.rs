//! Transfer vectors from visibility masks (equation 3 and section 3.2):
//! the CPU twin of `wgsl/sh_transfer.wgsl`.
//!
//! In the tangent frame, with the Nusselt projection `dA = cos θ dω`,
//! equation 3 becomes an integral over the unit disk:
//!
//! ```text
//! V*_i = ∫_Ω b_i(s) V(s) f_r(s → v) max(0, n·s) ds = ∫_disk b_i(s(x, y)) V f_r dA.
//! ```
//!
//! The mask is downsampled in 4x4 blocks ("cells") to grey levels
//! (section 3.2). Cell c keeps its exact basis integral
//! `B_ci = ∫_{cell ∩ disk} b_i dA` and area `A_c`; its occluded fraction
//! `o_c = Σ_{occluded p in c} A_p / A_c` weighs each pixel by its exact area
//! inside the disk (rim pixels are partial). Then, with `ρ_c = π f_r(d_c)` at
//! the cell's mean direction d_c,
//!
//! ```text
//! V*_i ≈ (1/π) Σ_c (1 - o_c) ρ_c B_ci.
//! ```
//!
//! For the diffuse BRDF (albedo 1, f_r = 1/π, ρ = 1) this is the unoccluded
//! transfer minus the occluded cells, `V*_i = T_i - (1/π) Σ_c o_c B_ci`, and
//! only cells with occluded pixels cost anything; the unoccluded `T` has the
//! clamped cosine's zonal coefficients `h_l / π` on m = 0 (exact up to the
//! f32 tables).
//!
//! **Glossy BRDF.** We use the paper's view-dependent transfer *vector*
//! (section 2.1, equation 2 with `V*_p(v)`), not a transfer matrix: it is
//! recomputed every frame anyway, so the view direction is known. The BRDF
//! is a normalised Phong lobe mixed with a diffuse base,
//! `f_r = (1 - k_s)/π + k_s (e + 2)/(2π) max(0, r·s)^e`, with r the view
//! direction reflected about the normal; ρ_c is evaluated at each cell's
//! mean direction, so the lobe is sampled at the cell resolution (8x8 cells
//! for 32x32 masks).
//!
//! The result is rotated from the tangent frame `Rz(α) Ry(β)` to world
//! space (`ShRotation::frame_to_world`) and dotted with the lighting
//! (equation 2).

use glam::Vec3;

use super::mask::{CELL, MaskGrid, disk_rect_quadrature};
use crate::sh::{ShBasis, ShRotation, coefficient_count};

/// The BRDF of the transfer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Brdf {
    /// Lambertian, albedo 1 (colour is applied at shading).
    Diffuse,
    /// Diffuse base plus a normalised Phong lobe about the reflected view
    /// direction; view-dependent.
    Phong { shininess: f32, specular: f32 },
}

impl Brdf {
    /// `π f_r` for a local direction `d` and local reflected view `r`.
    #[inline(always)]
    pub fn rho(&self, d: Vec3, r: Vec3) -> f32 {
        match *self {
            Brdf::Diffuse => 1.0,
            Brdf::Phong { shininess, specular } => {
                let c = d.dot(r).max(0.0);
                (1.0 - specular) + specular * 0.5 * (shininess + 2.0) * c.powf(shininess)
            }
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Brdf::Diffuse => "diffuse",
            Brdf::Phong { .. } => "phong",
        }
    }
}

/// Per-cell integrals for one mask grid and number of bands.
#[derive(Debug, Clone)]
pub struct CellTables {
    pub side: usize,
    pub bands: usize,
    pub coeffs: usize,
    pub cells: usize,
    /// `B_ci / π`, cell-major (`cells x coeffs`).
    pub basis: Vec<f32>,
    /// Cell areas A_c.
    pub area: Vec<f32>,
    /// Per pixel, `A_p / A_cell(p)` (0 outside the disk).
    pub pixel_fraction: Vec<f32>,
    /// Per cell and row k of its 4 rows, the occluded fraction for each of
    /// the 16 nibble values (`cells x 4 x 16`).
    pub nibble: Vec<f32>,
    /// Mean direction of each cell (for ρ_c).
    pub dirs: Vec<Vec3>,
    /// The unoccluded diffuse transfer `(1/π) Σ_c B_ci` (local frame).
    pub unoccluded: Vec<f32>,
}

impl CellTables {
    pub fn new(grid: &MaskGrid, bands: usize) -> CellTables {
        let basis_fn = ShBasis::new(bands);
        let n = coefficient_count(bands);
        let cps = grid.cells_per_side();
        let cells = grid.cell_count();
        let mut basis = vec![0.0f32; cells * n];
        let mut area = vec![0.0f32; cells];
        let mut dirs = vec![Vec3::Z; cells];
        let mut unoccluded = vec![0.0f64; n];
        let mut y = vec![0.0f64; n];
        let q = (bands + 4).max(12);
        for cr in 0..cps {
            for cc in 0..cps {
                let c = cr * cps + cc;
                let [x0, x1, y0, y1] = grid.cell_rect(cr, cc);
                let mut b = vec![0.0f64; n];
                let (mut a, mut mean) = (0.0, glam::DVec3::ZERO);
                disk_rect_quadrature(x0, x1, y0, y1, q, q, |d, w| {
                    basis_fn.eval_f64(d, &mut y);
                    for (bi, yi) in b.iter_mut().zip(&y) {
                        *bi += w * yi;
                    }
                    a += w;
                    mean += w * d;
                });
                for i in 0..n {
                    basis[c * n + i] = (b[i] / std::f64::consts::PI) as f32;
                    unoccluded[i] += b[i] / std::f64::consts::PI;
                }
                area[c] = a as f32;
                if a > 0.0 {
                    dirs[c] = mean.normalize().as_vec3();
                }
            }
        }
        let side = grid.side;
        let mut pixel_fraction = vec![0.0f32; side * side];
        for r in 0..side {
            for col in 0..side {
                let c = (r / CELL) * cps + col / CELL;
                let p = r * side + col;
                let cell_area: f64 = (0..CELL)
                    .flat_map(|i| (0..CELL).map(move |j| (i, j)))
                    .map(|(i, j)| grid.areas[((r / CELL) * CELL + i) * side + (col / CELL) * CELL + j])
                    .sum();
                if cell_area > 0.0 {
                    pixel_fraction[p] = (grid.areas[p] / cell_area) as f32;
                }
                let _ = c;
            }
        }
        let mut nibble = vec![0.0f32; cells * 4 * 16];
        for cr in 0..cps {
            for cc in 0..cps {
                let c = cr * cps + cc;
                for k in 0..CELL {
                    for bits in 0..16usize {
                        let mut f = 0.0f32;
                        for j in 0..CELL {
                            if bits >> j & 1 == 1 {
                                f += pixel_fraction[(cr * CELL + k) * side + cc * CELL + j];
                            }
                        }
                        nibble[(c * 4 + k) * 16 + bits] = f;
                    }
                }
            }
        }
        CellTables {
            side,
            bands,
            coeffs: n,
            cells,
            basis,
            area,
            pixel_fraction,
            nibble,
            dirs,
            unoccluded: unoccluded.iter().map(|&v| v as f32).collect(),
        }
    }

    /// The S bits of mask row `r` (S <= 64).
    #[inline(always)]
    fn row_bits(&self, mask: &[u64], r: usize) -> u64 {
        let s = self.side;
        let bit = r * s;
        let w = mask[bit / 64] >> (bit % 64);
        if s == 64 { w } else { w & ((1u64 << s) - 1) }
    }

    /// Local-frame transfer of one mask into `out` (`coeffs` values).
    /// `reflected` is the local reflected view direction (Phong only).
    #[inline]
    pub fn integrate(&self, mask: &[u64], brdf: &Brdf, reflected: Vec3, out: &mut [f32]) {
        let n = self.coeffs;
        let cps = self.side / CELL;
        match brdf {
            Brdf::Diffuse => {
                out.copy_from_slice(&self.unoccluded);
                for cr in 0..cps {
                    let rows = [0, 1, 2, 3].map(|k| self.row_bits(mask, cr * CELL + k));
                    if rows == [0; 4] {
                        continue;
                    }
                    for cc in 0..cps {
                        let nib = rows.map(|r| (r >> (cc * CELL)) as usize & 15);
                        if nib == [0; 4] {
                            continue;
                        }
                        let c = cr * cps + cc;
                        let t = &self.nibble[c * 64..c * 64 + 64];
                        let o = t[nib[0]] + t[16 + nib[1]] + t[32 + nib[2]] + t[48 + nib[3]];
                        let b = &self.basis[c * n..c * n + n];
                        for (o_i, b_i) in out.iter_mut().zip(b) {
                            *o_i -= o * b_i;
                        }
                    }
                }
            }
            Brdf::Phong { .. } => {
                out.fill(0.0);
                for cr in 0..cps {
                    let rows = [0, 1, 2, 3].map(|k| self.row_bits(mask, cr * CELL + k));
                    for cc in 0..cps {
                        let c = cr * cps + cc;
                        if self.area[c] == 0.0 {
                            continue;
                        }
                        let nib = rows.map(|r| (r >> (cc * CELL)) as usize & 15);
                        let t = &self.nibble[c * 64..c * 64 + 64];
                        let o = t[nib[0]] + t[16 + nib[1]] + t[32 + nib[2]] + t[48 + nib[3]];
                        let w = (1.0 - o) * brdf.rho(self.dirs[c], reflected);
                        let b = &self.basis[c * n..c * n + n];
                        for (o_i, b_i) in out.iter_mut().zip(b) {
                            *o_i += w * b_i;
                        }
                    }
                }
            }
        }
    }
}

/// Everything after rasterisation for one vertex: integrate in the tangent
/// frame, rotate to world space, dot with the lighting. `lighting` is
/// planar RGB (`3 x coeffs`). Returns the exitant radiance.
#[inline]
pub fn shade_vertex(
    tables: &CellTables,
    rot: &ShRotation,
    mask: &[u64],
    normal: Vec3,
    brdf: &Brdf,
    reflected_local: Vec3,
    lighting: &[f32],
    transfer: &mut [f32],
) -> [f32; 3] {
    tables.integrate(mask, brdf, reflected_local, transfer);
    rot.frame_to_world(normal, transfer);
    radiance(lighting, transfer)
}

/// `L · V*` per colour channel (equation 2).
#[inline]
pub fn radiance(lighting: &[f32], transfer: &[f32]) -> [f32; 3] {
    let n = transfer.len();
    let mut out = [0.0f32; 3];
    for (k, o) in out.iter_mut().enumerate() {
        *o = lighting[k * n..(k + 1) * n].iter().zip(transfer).map(|(l, t)| l * t).sum();
    }
    out
}
