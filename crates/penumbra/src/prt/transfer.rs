//! Transfer vectors from visibility masks (equation 3 and section 3.2):
//! the tables and integration behind `Prt::sh_transfer`, the CPU twin of
//! `wgsl/sh_transfer.wgsl`.
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
use crate::sh::{ShBasis, coefficient_count};

/// The BRDF of the transfer.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Brdf {
    /// Lambertian, albedo 1 (colour is applied at shading).
    Diffuse,
    /// Diffuse base plus a normalised Phong lobe about the reflected view
    /// direction; view-dependent.
    Phong {
        /// The lobe's exponent e, in [0, 10000].
        shininess: f32,
        /// The lobe's weight k_s, in [0, 1]; the diffuse base has 1 - k_s.
        specular: f32,
    },
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

    /// `kind` with the Phong lobe's exponent and weight (unused for diffuse).
    pub fn new(kind: BrdfKind, shininess: f32, specular: f32) -> Brdf {
        match kind {
            BrdfKind::Diffuse => Brdf::Diffuse,
            BrdfKind::Phong => Brdf::Phong { shininess, specular },
        }
    }

    /// `"diffuse"` or `"phong"`, as reports and the command line name it.
    pub fn name(&self) -> &'static str {
        match self {
            Brdf::Diffuse => "diffuse",
            Brdf::Phong { .. } => "phong",
        }
    }
}

/// Which BRDF, without its parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum BrdfKind {
    /// Lambertian.
    Diffuse,
    /// Diffuse base plus a normalised Phong lobe (view-dependent transfer vector).
    Phong,
}

/// How a mask is integrated against the basis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Integration {
    /// The paper's 4x4 grey levels: each cell's occluded fraction times the
    /// cell's mean basis values.
    Cells,
    /// 4x4 cells with first moments: the grey level plus the offset of the
    /// occluded pixels' centroid from the cell's, against a least-squares
    /// linear fit of each basis function over the cell (default).
    CellsLinear,
    /// Every pixel with its own basis integral (no downsampling).
    Pixels,
}

crate::choice!(Integration { Cells = "cells", CellsLinear = "cells-linear", Pixels = "pixels" });

impl Integration {
    /// `"cells"`, `"cells-linear"` or `"pixels"`, as reports and the
    /// command line name it.
    pub fn name(self) -> &'static str {
        match self {
            Integration::Cells => "cells",
            Integration::CellsLinear => "cells-linear",
            Integration::Pixels => "pixels",
        }
    }
}

/// Per-cell (and per-pixel) integrals for one mask grid and number of bands.
///
/// For cell c (its part inside the disk: area A_c, centroid r̄_c) and basis
/// function i: `B_ci = ∫ Y_i dA`, and the least-squares linear fit
/// `Y_i ≈ B_ci / A_c + g_ci · (r - r̄_c)` with `g_ci = C_c^-1 ∫ Y_i (r - r̄_c) dA`
/// (C_c the cell's second-moment matrix). For the occluded pixels O of the
/// cell, `∫_O Y_i dA ≈ o B_ci + μ · (A_c g_ci)`, where `o = A_O / A_c` is the
/// grey level and `μ = ∫_O (r - r̄_c) dA / A_c` the first moment, both sums of
/// per-pixel values looked up four pixels (one nibble of a row) at a time.
#[derive(Debug, Clone)]
pub struct CellTables {
    /// Mask side S in pixels.
    pub side: usize,
    /// SH bands.
    pub bands: usize,
    /// SH coefficients, `bands²`.
    pub coeffs: usize,
    /// Cells of 4x4 pixels, `(S / 4)²`.
    pub cells: usize,
    /// How [`CellTables::integrate`] uses the tables (all of them are built
    /// whatever this is).
    pub integration: Integration,
    /// `B_ci / π`, cell-major (`cells x coeffs`).
    pub basis: Vec<f32>,
    /// `A_c g_ci / π`: x then y components, cell-major (`cells x 2 x coeffs`).
    pub gradient: Vec<f32>,
    /// Per pixel, `∫_pixel Y_i dA / π` (`side² x coeffs`).
    pub pixel_basis: Vec<f32>,
    /// Cell areas A_c.
    pub area: Vec<f32>,
    /// Per pixel, `A_p / A_c` with c the pixel's cell (0 outside the disk).
    /// The WGSL kernel's layout.
    pub pixel_fraction: Vec<f32>,
    /// Per pixel, its first moments about its cell's centroid,
    /// `[∫_p (x - x̄_c) dA / A_c, ∫_p (y - ȳ_c) dA / A_c]` (0 outside the disk).
    pub pixel_moment: Vec<[f32; 2]>,
    /// Per cell and row k of its 4 rows, for each of the 16 nibble values:
    /// occluded fraction and first moments (`cells x 4 x 16 x [o, μx, μy]`).
    pub nibble: Vec<[f32; 4]>,
    /// Mean direction of each cell (for ρ_c).
    pub dirs: Vec<Vec3>,
    /// The unoccluded diffuse transfer `(1/π) Σ_c B_ci` (local frame).
    pub unoccluded: Vec<f32>,
}

impl CellTables {
    /// The tables for [`Integration::CellsLinear`], the default.
    pub fn new(grid: &MaskGrid, bands: usize) -> CellTables {
        Self::with_integration(grid, bands, Integration::CellsLinear)
    }

    /// The tables of `grid` and `bands` bands, integrated once by
    /// `disk_rect_quadrature` to rounding, for `integration`.
    pub fn with_integration(grid: &MaskGrid, bands: usize, integration: Integration) -> CellTables {
        let basis_fn = ShBasis::new(bands);
        let n = coefficient_count(bands);
        let cps = grid.cells_per_side();
        let cells = grid.cell_count();
        let side = grid.side;
        let pi = std::f64::consts::PI;
        let q = (bands + 4).max(12);
        let mut y = vec![0.0f64; n];
        // Per pixel: area, first moments about the origin, basis integrals.
        let mut pixel_basis = vec![0.0f32; side * side * n];
        let mut pix_area = vec![0.0f64; side * side];
        let mut pix_m = vec![[0.0f64; 2]; side * side];
        let h = 2.0 / side as f64;
        for r in 0..side {
            for c in 0..side {
                let p = r * side + c;
                let (x0, y0) = (-1.0 + c as f64 * h, -1.0 + r as f64 * h);
                let mut b = vec![0.0f64; n];
                disk_rect_quadrature(x0, x0 + h, y0, y0 + h, 8, 8, |d, w| {
                    basis_fn.eval_f64(d, &mut y);
                    for (bi, yi) in b.iter_mut().zip(&y) {
                        *bi += w * yi;
                    }
                    pix_area[p] += w;
                    pix_m[p][0] += w * d.x;
                    pix_m[p][1] += w * d.y;
                });
                for i in 0..n {
                    pixel_basis[p * n + i] = (b[i] / pi) as f32;
                }
            }
        }
        let mut basis = vec![0.0f32; cells * n];
        let mut gradient = vec![0.0f32; cells * 2 * n];
        let mut area = vec![0.0f32; cells];
        let mut dirs = vec![Vec3::Z; cells];
        let mut centroid = vec![[0.0f64; 2]; cells];
        let mut unoccluded = vec![0.0f64; n];
        for cr in 0..cps {
            for cc in 0..cps {
                let c = cr * cps + cc;
                let [x0, x1, y0, y1] = grid.cell_rect(cr, cc);
                // First pass: area, centroid, basis integrals; second: moments.
                let mut b = vec![0.0f64; n];
                let (mut a, mut mean, mut m1) = (0.0, glam::DVec3::ZERO, [0.0f64; 2]);
                disk_rect_quadrature(x0, x1, y0, y1, q, q, |d, w| {
                    basis_fn.eval_f64(d, &mut y);
                    for (bi, yi) in b.iter_mut().zip(&y) {
                        *bi += w * yi;
                    }
                    a += w;
                    mean += w * d;
                    m1[0] += w * d.x;
                    m1[1] += w * d.y;
                });
                if a <= 0.0 {
                    continue;
                }
                let rb = [m1[0] / a, m1[1] / a];
                let mut cov = [[0.0f64; 2]; 2];
                let mut cross = vec![[0.0f64; 2]; n];
                disk_rect_quadrature(x0, x1, y0, y1, q, q, |d, w| {
                    basis_fn.eval_f64(d, &mut y);
                    let dr = [d.x - rb[0], d.y - rb[1]];
                    for (k, row) in cov.iter_mut().enumerate() {
                        row[0] += w * dr[k] * dr[0];
                        row[1] += w * dr[k] * dr[1];
                    }
                    for (ci, yi) in cross.iter_mut().zip(&y) {
                        ci[0] += w * yi * dr[0];
                        ci[1] += w * yi * dr[1];
                    }
                });
                let det = cov[0][0] * cov[1][1] - cov[0][1] * cov[1][0];
                let inv = if det > 1e-12 * a * a * a * a {
                    [[cov[1][1] / det, -cov[0][1] / det], [-cov[1][0] / det, cov[0][0] / det]]
                } else {
                    [[0.0; 2]; 2]
                };
                for i in 0..n {
                    basis[c * n + i] = (b[i] / pi) as f32;
                    unoccluded[i] += b[i] / pi;
                    let g = [
                        inv[0][0] * cross[i][0] + inv[0][1] * cross[i][1],
                        inv[1][0] * cross[i][0] + inv[1][1] * cross[i][1],
                    ];
                    gradient[(c * 2) * n + i] = (a * g[0] / pi) as f32;
                    gradient[(c * 2 + 1) * n + i] = (a * g[1] / pi) as f32;
                }
                area[c] = a as f32;
                centroid[c] = rb;
                dirs[c] = mean.normalize().as_vec3();
            }
        }
        let cell_of = |r: usize, col: usize| (r / CELL) * cps + col / CELL;
        let mut pixel_fraction = vec![0.0f32; side * side];
        let mut pixel_moment = vec![[0.0f32; 2]; side * side];
        for r in 0..side {
            for col in 0..side {
                let p = r * side + col;
                let c = cell_of(r, col);
                let a = area[c] as f64;
                if a > 0.0 && pix_area[p] > 0.0 {
                    pixel_fraction[p] = (pix_area[p] / a) as f32;
                    pixel_moment[p] = [
                        ((pix_m[p][0] - pix_area[p] * centroid[c][0]) / a) as f32,
                        ((pix_m[p][1] - pix_area[p] * centroid[c][1]) / a) as f32,
                    ];
                }
            }
        }
        let mut nibble = vec![[0.0f32; 4]; cells * 4 * 16];
        for cr in 0..cps {
            for cc in 0..cps {
                let c = cr * cps + cc;
                for k in 0..CELL {
                    for bits in 0..16usize {
                        let mut f = [0.0f32; 4];
                        for j in 0..CELL {
                            if bits >> j & 1 == 1 {
                                let p = (cr * CELL + k) * side + cc * CELL + j;
                                f[0] += pixel_fraction[p];
                                f[1] += pixel_moment[p][0];
                                f[2] += pixel_moment[p][1];
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
            integration,
            basis,
            gradient,
            pixel_basis,
            area,
            pixel_fraction,
            pixel_moment,
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

    /// Occluded fraction and first moments of cell c from its 4 row nibbles.
    #[inline(always)]
    fn cell_moments(&self, c: usize, nib: [usize; 4]) -> [f32; 4] {
        let t = &self.nibble[c * 64..c * 64 + 64];
        let (a, b, d, e) = (t[nib[0]], t[16 + nib[1]], t[32 + nib[2]], t[48 + nib[3]]);
        [
            a[0] + b[0] + d[0] + e[0],
            a[1] + b[1] + d[1] + e[1],
            a[2] + b[2] + d[2] + e[2],
            0.0,
        ]
    }

    /// Local-frame transfer of one mask into `out` (`coeffs` values).
    /// `reflected` is the local reflected view direction (Phong only).
    #[inline]
    pub fn integrate(&self, mask: &[u64], brdf: &Brdf, reflected: Vec3, out: &mut [f32]) {
        let n = self.coeffs;
        let cps = self.side / CELL;
        let diffuse = matches!(brdf, Brdf::Diffuse);
        if self.integration == Integration::Pixels && diffuse {
            out.copy_from_slice(&self.unoccluded);
            for (w, &word) in mask.iter().enumerate() {
                let mut bits = word;
                while bits != 0 {
                    let p = w * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let b = &self.pixel_basis[p * n..p * n + n];
                    for (o, bi) in out.iter_mut().zip(b) {
                        *o -= bi;
                    }
                }
            }
            return;
        }
        // Diffuse: unoccluded minus the occluded cells. Glossy: every cell,
        // visible part weighted by ρ_c.
        if diffuse {
            out.copy_from_slice(&self.unoccluded);
        } else {
            out.fill(0.0);
        }
        for cr in 0..cps {
            let rows = [0, 1, 2, 3].map(|k| self.row_bits(mask, cr * CELL + k));
            if diffuse && rows == [0; 4] {
                continue;
            }
            for cc in 0..cps {
                let c = cr * cps + cc;
                let nib = rows.map(|r| (r >> (cc * CELL)) as usize & 15);
                if diffuse && nib == [0; 4] {
                    continue;
                }
                if !diffuse && self.area[c] == 0.0 {
                    continue;
                }
                let b = &self.basis[c * n..c * n + n];
                let g = &self.gradient[c * 2 * n..(c * 2 + 2) * n];
                let (gx, gy) = g.split_at(n);
                let [o, mx, my, _] = self.cell_moments(c, nib);
                let (mx, my) = if self.integration == Integration::Cells {
                    (0.0, 0.0)
                } else {
                    (mx, my)
                };
                if diffuse {
                    for i in 0..n {
                        out[i] -= o * b[i] + mx * gx[i] + my * gy[i];
                    }
                } else if self.integration == Integration::Pixels {
                    let rho = brdf.rho(self.dirs[c], reflected);
                    // Visible pixels of the cell, each with its own integral.
                    for (k, &row) in nib.iter().enumerate() {
                        for j in 0..CELL {
                            if row >> j & 1 == 0 {
                                let p = (cr * CELL + k) * self.side + cc * CELL + j;
                                let pb = &self.pixel_basis[p * n..p * n + n];
                                for i in 0..n {
                                    out[i] += rho * pb[i];
                                }
                            }
                        }
                    }
                } else {
                    let rho = brdf.rho(self.dirs[c], reflected);
                    for i in 0..n {
                        out[i] += rho * ((1.0 - o) * b[i] - mx * gx[i] - my * gy[i]);
                    }
                }
            }
        }
    }
}

/// `L · V*` per colour channel (equation 2).
#[inline]
pub fn radiance(lighting: &[f32], transfer: &[f32]) -> [f32; 3] {
    let n = transfer.len();
    let mut out = [0.0f32; 3];
    for (k, o) in out.iter_mut().enumerate() {
        *o = lighting[k * n..(k + 1) * n]
            .iter()
            .zip(transfer)
            .map(|(l, t)| l * t)
            .sum();
    }
    out
}
