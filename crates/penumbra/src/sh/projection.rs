//! Projection of a latitude-longitude environment map onto the SH basis.
//!
//! Each texel is taken as constant radiance over its solid angle, and the
//! basis is integrated over the texel exactly: `L_i = Σ_texels L_texel
//! ∫_texel Y_i(s) ds`. The texel's solid angle `Δφ (cos θ0 - cos θ1)` is thus
//! built in (a constant map projects to the DC term alone, to rounding).
//!
//! The integral separates in the map's own spherical coordinates (polar
//! axis = world +y, see `EnvironmentMap`): `Y_lm = N_l^m(cos θ) sin^m θ
//! {cos mφ, sin mφ}`, so per row we integrate `N_l^m(cos θ) sin^m θ sin θ`
//! over the row's θ-range (Gauss–Legendre in θ, smooth there) and per column
//! `cos mφ`, `sin mφ` in closed form. The coefficients so obtained are in the
//! map frame (x_m = -z, y_m = -x, z_m = +y in world terms); `ShRotation`
//! takes them to world space.

use glam::{DMat3, DVec3};

use super::basis::ShBasis;
use super::coefficient_count;
use super::quadrature::gauss_legendre_on;
use super::rotation::ShRotation;
use crate::scene::EnvironmentMap;

/// SH coefficients of RGB radiance: `rgb[i]` is coefficient i of (r, g, b).
#[derive(Debug, Clone, PartialEq)]
pub struct ShRgb {
    /// Number of bands; `rgb` holds `bands²` coefficients.
    pub bands: usize,
    /// Coefficient `l (l + 1) + m` of red, green and blue (the order of the
    /// module documentation of `sh`).
    pub rgb: Vec<[f64; 3]>,
}

impl ShRgb {
    /// All `bands²` coefficients zero: no light.
    pub fn zeros(bands: usize) -> ShRgb {
        ShRgb {
            bands,
            rgb: vec![[0.0; 3]; coefficient_count(bands)],
        }
    }

    /// One colour channel's coefficients.
    pub fn channel(&self, c: usize) -> Vec<f64> {
        self.rgb.iter().map(|v| v[c]).collect()
    }

    /// Radiance in direction `d` reconstructed from the coefficients.
    pub fn evaluate(&self, basis: &ShBasis, d: DVec3) -> [f64; 3] {
        let y = basis.at(d);
        let mut out = [0.0; 3];
        for (yi, c) in y.iter().zip(&self.rgb) {
            for k in 0..3 {
                out[k] += yi * c[k];
            }
        }
        out
    }

    /// The coefficients of the lighting rotated by `r` (`g(s) = f(r^-1 s)`).
    pub fn rotated(&self, rot: &ShRotation, r: DMat3) -> ShRgb {
        let mut out = self.clone();
        for c in 0..3 {
            let mut ch = self.channel(c);
            rot.rotate(r, &mut ch);
            for (o, v) in out.rgb.iter_mut().zip(&ch) {
                o[c] = *v;
            }
        }
        out
    }

    /// The first `bands` bands.
    pub fn truncated(&self, bands: usize) -> ShRgb {
        ShRgb {
            bands,
            rgb: self.rgb[..coefficient_count(bands)].to_vec(),
        }
    }

    /// Packed as f32, channel-major: r coefficients, then g, then b.
    pub fn to_f32_planar(&self) -> Vec<f32> {
        (0..3).flat_map(|c| self.rgb.iter().map(move |v| v[c] as f32)).collect()
    }
}

/// The rotation from the map frame (polar axis +y) to world coordinates:
/// columns are the map axes in world terms, (-z, -x, +y).
pub fn map_frame() -> DMat3 {
    DMat3::from_cols(DVec3::NEG_Z, DVec3::NEG_X, DVec3::Y)
}

/// Gauss points per texel row for the θ-integrals (the integrand is a
/// trigonometric polynomial of degree <= 2 bands; rows are narrow).
const ROW_POINTS: usize = 12;

/// Projects `map` onto `bands` bands, in world space.
pub fn project_environment(map: &EnvironmentMap, bands: usize) -> ShRgb {
    let basis = ShBasis::new(bands);
    let (w, h) = (map.width as usize, map.height as usize);
    let n = coefficient_count(bands);
    let pi = std::f64::consts::PI;

    // Per column c: ∫ cos(mφ) and ∫ sin(mφ) over φ in [φa, φb], with the
    // map-frame azimuth φ = π (1 - 2u), u = column / width.
    let mut phi_cos = vec![0.0f64; w * bands];
    let mut phi_sin = vec![0.0f64; w * bands];
    for c in 0..w {
        let phi_b = pi * (1.0 - 2.0 * c as f64 / w as f64);
        let phi_a = pi * (1.0 - 2.0 * (c + 1) as f64 / w as f64);
        for m in 0..bands {
            if m == 0 {
                phi_cos[c * bands] = phi_b - phi_a;
            } else {
                let mf = m as f64;
                phi_cos[c * bands + m] = ((mf * phi_b).sin() - (mf * phi_a).sin()) / mf;
                phi_sin[c * bands + m] = ((mf * phi_a).cos() - (mf * phi_b).cos()) / mf;
            }
        }
    }

    let mut map_coeffs = ShRgb::zeros(bands);
    let mut y = vec![0.0f64; n];
    let mut row_basis = vec![0.0f64; n]; // ∫ over the row's θ of the polar part
    for r in 0..h {
        let theta0 = pi * r as f64 / h as f64;
        let theta1 = pi * (r + 1) as f64 / h as f64;
        row_basis.fill(0.0);
        for (theta, wt) in gauss_legendre_on(ROW_POINTS, theta0, theta1) {
            // The polar part of Y_lm at φ = 0 is Y_lm(sinθ, 0, cosθ) for
            // m >= 0 (C_m = sin^m θ, S_m = 0); sin θ is the area element.
            basis.eval_f64(DVec3::new(theta.sin(), 0.0, theta.cos()), &mut y);
            for l in 0..bands {
                for m in 0..=l {
                    row_basis[l * (l + 1) + m] += wt * theta.sin() * y[l * (l + 1) + m];
                }
            }
        }
        // Column sums of radiance times the azimuthal integrals.
        let mut sums_cos = vec![[0.0f64; 3]; bands];
        let mut sums_sin = vec![[0.0f64; 3]; bands];
        for c in 0..w {
            let t = map.texels[r * w + c];
            for m in 0..bands {
                let (pc, ps) = (phi_cos[c * bands + m], phi_sin[c * bands + m]);
                for k in 0..3 {
                    sums_cos[m][k] += t[k] as f64 * pc;
                    sums_sin[m][k] += t[k] as f64 * ps;
                }
            }
        }
        for l in 0..bands {
            for m in 0..=l {
                // row_basis holds sqrt(2) N sin^m (times the area element)
                // for m > 0: Y_l,m = sqrt2 N C_m and Y_l,-m = sqrt2 N S_m
                // share it.
                let p = row_basis[l * (l + 1) + m];
                for k in 0..3 {
                    map_coeffs.rgb[l * (l + 1) + m][k] += p * sums_cos[m][k];
                    if m > 0 {
                        map_coeffs.rgb[l * (l + 1) - m][k] += p * sums_sin[m][k];
                    }
                }
            }
        }
    }
    map_coeffs.rotated(&ShRotation::new(bands), map_frame())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_frame_is_a_rotation() {
        assert!((map_frame().determinant() - 1.0).abs() < 1e-15);
    }
}
