//! Zonal functions: the clamped cosine and irradiance.
//!
//! A function of the polar angle alone has only m = 0 coefficients `h_l`.
//! Convolving a function f with it (Funk–Hecke) scales each band:
//! `(h * f)_lm = sqrt(4π / (2l + 1)) h_l f_lm`. Irradiance is the lighting
//! convolved with the clamped cosine `max(0, cos θ)`, whose zonal
//! coefficients are `sqrt(π)/2 = 0.886227`, `sqrt(π/3) = 1.023328`,
//! `sqrt(5π)/8 = 0.495416`, 0 for odd l > 1 (Ramamoorthi and Hanrahan 2001).

use glam::DVec3;

use super::basis::ShBasis;
use super::projection::ShRgb;
use super::quadrature::gauss_legendre_on;
use crate::scene::EnvironmentMap;

/// Zonal coefficients `h_l = 2π ∫_0^{π/2} Y_l0(θ) cos θ sin θ dθ` of the
/// clamped cosine for bands `0..bands`, by Gauss–Legendre in z = cos θ
/// (the integrand is a polynomial of degree l + 1 in z: exact).
pub fn clamped_cosine_zonal(bands: usize) -> Vec<f64> {
    let basis = ShBasis::new(bands);
    let mut out = vec![0.0; bands];
    let mut y = vec![0.0; basis.len()];
    for (z, w) in gauss_legendre_on(bands + 2, 0.0, 1.0) {
        basis.eval_f64(DVec3::new((1.0 - z * z).sqrt(), 0.0, z), &mut y);
        for (l, o) in out.iter_mut().enumerate() {
            *o += std::f64::consts::TAU * w * z * y[l * (l + 1)];
        }
    }
    out
}

/// `sqrt(4π / (2l + 1)) h_l`: the factor by which convolution with the
/// zonal function h scales band l.
pub fn convolution_factors(zonal: &[f64]) -> Vec<f64> {
    zonal
        .iter()
        .enumerate()
        .map(|(l, h)| (4.0 * std::f64::consts::PI / (2 * l + 1) as f64).sqrt() * h)
        .collect()
}

/// Irradiance `E(n) = ∫ L(s) max(0, n·s) ds` from the first 9 coefficients
/// (3 bands) of the lighting, for a unit normal n.
pub fn irradiance(lighting: &ShRgb, n: DVec3) -> [f64; 3] {
    irradiance_bands(lighting, n, 3)
}

/// Irradiance from the first `bands` bands of the lighting (the clamped
/// cosine's coefficients fall off as l^-5/2, so this converges to the exact
/// irradiance as bands grow).
pub fn irradiance_bands(lighting: &ShRgb, n: DVec3, bands: usize) -> [f64; 3] {
    let bands = lighting.bands.min(bands);
    let basis = ShBasis::new(bands);
    let factors = convolution_factors(&clamped_cosine_zonal(bands));
    let y = basis.at(n);
    let mut e = [0.0; 3];
    for (l, f) in factors.iter().enumerate().take(bands) {
        let band = l * l..(l + 1) * (l + 1);
        for (yi, rgb) in y[band.clone()].iter().zip(&lighting.rgb[band]) {
            for (ek, c) in e.iter_mut().zip(rgb) {
                *ek += f * c * yi;
            }
        }
    }
    e
}

/// Irradiance by brute force over the texels of `map` for each normal:
/// each texel's radiance times the integral of the clamped cosine over it,
/// by `sub`² sample points per texel, each weighted by its exact solid angle.
pub fn irradiance_brute_force(map: &EnvironmentMap, normals: &[DVec3], sub: usize) -> Vec<[f64; 3]> {
    let (w, h) = (map.width as usize, map.height as usize);
    // Sample directions and radiance x solid angle, computed once.
    let mut samples = Vec::with_capacity(w * h * sub * sub);
    for r in 0..h {
        for su in 0..sub {
            let v = (r as f64 + (su as f64 + 0.5) / sub as f64) / h as f64;
            let theta0 = std::f64::consts::PI * (r as f64 + su as f64 / sub as f64) / h as f64;
            let theta1 = std::f64::consts::PI * (r as f64 + (su + 1) as f64 / sub as f64) / h as f64;
            let area = (theta0.cos() - theta1.cos()) * std::f64::consts::TAU / (w * sub) as f64;
            for c in 0..w {
                let t = map.texels[r * w + c];
                for sv in 0..sub {
                    let u = (c as f64 + (sv as f64 + 0.5) / sub as f64) / w as f64;
                    let d = EnvironmentMap::direction_f64(u, v);
                    samples.push((d, [t[0] as f64 * area, t[1] as f64 * area, t[2] as f64 * area]));
                }
            }
        }
    }
    normals
        .iter()
        .map(|n| {
            let mut e = [0.0; 3];
            for (d, l) in &samples {
                let c = n.dot(*d);
                if c > 0.0 {
                    for k in 0..3 {
                        e[k] += l[k] * c;
                    }
                }
            }
            e
        })
        .collect()
}
