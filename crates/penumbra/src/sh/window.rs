//! Windowing SH lighting so that what it reconstructs is never negative.
//!
//! A probe truncated to a few bands rings: around the bright windows of the
//! Grace cathedral probe, five bands reconstruct radiance down to -0.51 (red)
//! where the map's mean is +0.27. Exitant radiance is the lighting dotted
//! with the transfer, `L · T = ∫ L̃(s) V(s) ρ max(0, n·s) ds` with L̃ the
//! band-limited lighting (equation 2; the product of a band-limited function
//! with any function integrates to the dot product of their coefficients).
//! Where a vertex sees only directions in which L̃ < 0 — a vertex in a
//! crevice looking sideways — its radiance is negative however exact its
//! transfer: the character's neck and hip under Grace shade to red and green
//! below zero with blue still positive (navy blotches), and black ones under other probes and orders.
//!
//! The fix is at the lighting: if L̃ >= 0 everywhere then `L · T >= 0` for
//! every visibility. Scaling band l by a window `σ_l` (Sloan, "Stupid
//! Spherical Harmonics (SH) Tricks", GDC 2008, "windowing") trades ringing
//! for blur: it convolves the lighting with the zonal kernel whose Legendre
//! coefficients are the `σ_l`. We use the kernel `((1 + cos γ) / 2)^s`,
//! whose coefficients are `σ_l(s) = Π_{k=1..l} (s - k + 1) / (s + k + 1)`
//! (Funk–Hecke; σ_0 = 1 keeps the mean). It is non-negative for every s,
//! and for s = bands - 1 it is a polynomial of degree bands - 1: the
//! windowed coefficients are then exactly those of the map convolved with
//! a non-negative kernel, non-negative wherever the map is, whatever the
//! probe. Larger s blurs less (σ_l -> 1 as s grows) but the kernel's higher
//! bands are cut, so non-negativity must be checked. `nonnegative` takes the
//! largest s (least blur) for which the reconstruction is non-negative on a
//! fine grid of directions, and leaves lighting that is already
//! non-negative untouched. (A Hann window, the usual choice, needs width
//! 1.97 on Grace at five bands — bands 2 to 4 gone — where this kernel keeps
//! them at s >= 4.)

use glam::DVec3;

use super::ShRgb;
use super::basis::ShBasis;

/// The window `σ_l(s)` of the kernel `((1 + cos γ) / 2)^s` for `bands` bands.
pub fn cosine_power(bands: usize, s: f64) -> Vec<f64> {
    let mut sigma = Vec::with_capacity(bands);
    let mut v = 1.0;
    for l in 0..bands {
        if l > 0 {
            let k = l as f64;
            v *= ((s - k + 1.0) / (s + k + 1.0)).max(0.0);
        }
        sigma.push(v);
    }
    sigma
}

/// The lighting with band l scaled by `window[l]`.
pub fn windowed(light: &ShRgb, window: &[f64]) -> ShRgb {
    let mut out = light.clone();
    for (l, w) in window.iter().enumerate().take(light.bands) {
        for c in &mut out.rgb[l * l..(l + 1) * (l + 1)] {
            for v in c.iter_mut() {
                *v *= w;
            }
        }
    }
    out
}

/// Per direction of a grid fine enough for `bands` bands (a few samples
/// per half-wavelength of the highest band) and per band, the band's
/// contribution to the reconstructed RGB radiance.
fn band_sums(light: &ShRgb) -> Vec<Vec<[f64; 3]>> {
    let bands = light.bands;
    let basis = ShBasis::new(bands);
    let rows = 8 * bands + 8;
    let cols = 2 * rows;
    let mut y = vec![0.0; bands * bands];
    let mut out = Vec::with_capacity(rows * cols + 2);
    let mut push = |d: DVec3, y: &mut Vec<f64>| {
        basis.eval_f64(d, y);
        out.push(
            (0..bands)
                .map(|l| {
                    let mut s = [0.0; 3];
                    let band = l * l..(l + 1) * (l + 1);
                    for (yi, c) in y[band.clone()].iter().zip(&light.rgb[band]) {
                        for (sk, ck) in s.iter_mut().zip(c) {
                            *sk += yi * ck;
                        }
                    }
                    s
                })
                .collect(),
        );
    };
    push(DVec3::Z, &mut y);
    push(DVec3::NEG_Z, &mut y);
    for r in 0..rows {
        let theta = std::f64::consts::PI * (r as f64 + 0.5) / rows as f64;
        for c in 0..cols {
            let phi = std::f64::consts::TAU * c as f64 / cols as f64;
            let d = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            push(d, &mut y);
        }
    }
    out
}

/// The least reconstructed value of any channel over the grid, windowed.
fn least(sums: &[Vec<[f64; 3]>], window: &[f64]) -> f64 {
    sums.iter()
        .map(|bands| {
            (0..3)
                .map(|k| bands.iter().zip(window).map(|(s, w)| s[k] * w).sum::<f64>())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(f64::INFINITY, f64::min)
}

/// What `nonnegative` did: whether it windowed the lighting, the kernel's
/// exponent s and the window applied, and the least reconstructed radiance
/// before and after, relative to the mean radiance (`lighting` in the PRT
/// report). Every field is a value: no window is `windowed` false, an
/// exponent of 0 and a window of ones (what was applied), so that a
/// script never reads "not computed" where nothing was needed.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Deringing {
    /// Whether a window was applied: false when the lighting was already
    /// non-negative, has one band (`--order 1`), or is black.
    pub windowed: bool,
    /// The exponent s of the kernel `((1 + cos γ) / 2)^s`, at least
    /// `bands - 1`; 0 when no window was applied.
    pub exponent: f64,
    /// The per-band factors `σ_l(s)` applied, band 0 first (`σ_0` = 1);
    /// all 1 when no window was applied.
    pub window: Vec<f64>,
    /// The lighting is zero (a black probe): every image is black, and no
    /// window is needed (`warning` says so).
    pub black: bool,
    /// The least reconstructed radiance of any channel over the grid of
    /// directions, divided by the mean radiance, before windowing
    /// (negative: the lighting rang).
    pub least_before: f64,
    /// The same after windowing (equal to `least_before` when unwindowed).
    pub least_after: f64,
}

impl Deringing {
    /// What a user should know: a black probe lights nothing.
    pub fn warning(&self) -> Option<String> {
        self.black.then(|| {
            "the environment map is black (all its SH coefficients are 0): every image is black; \
             no window is needed (lighting.windowed false)"
                .to_string()
        })
    }
}

/// The lighting windowed as little as keeps its reconstruction
/// non-negative (see the module doc).
pub fn nonnegative(light: &ShRgb) -> (ShRgb, Deringing) {
    let sums = band_sums(light);
    let bands = light.bands;
    // The mean radiance: Y_00 = 1 / sqrt(4 pi), over the channels.
    let mean = light.rgb[0].iter().sum::<f64>() / 3.0 / (4.0 * std::f64::consts::PI).sqrt();
    let scale = mean.abs().max(f64::MIN_POSITIVE);
    let before = least(&sums, &vec![1.0; bands]);
    let black = light.rgb.iter().all(|c| c.iter().all(|&x| x == 0.0));
    if before >= 0.0 || bands == 1 {
        let d = Deringing {
            windowed: false,
            exponent: 0.0,
            window: vec![1.0; bands],
            black,
            least_before: before / scale,
            least_after: before / scale,
        };
        return (light.clone(), d);
    }
    // Bisect on 1/s in (0, 1/(bands - 1)]: s = bands - 1 is non-negative
    // for any non-negative map; the largest s that works is at 1/`hi`.
    let (mut lo, mut hi) = (0.0f64, 1.0 / (bands - 1) as f64);
    if least(&sums, &cosine_power(bands, 1.0 / hi)) >= 0.0 {
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if least(&sums, &cosine_power(bands, 1.0 / mid)) >= 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
    }
    let window = cosine_power(bands, 1.0 / hi);
    let after = least(&sums, &window);
    let d = Deringing {
        windowed: true,
        exponent: 1.0 / hi,
        window: window.clone(),
        black,
        least_before: before / scale,
        least_after: after / scale,
    };
    (windowed(light, &window), d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::coefficient_count;

    /// The kernel's coefficients: (1 + t)/2 squared is 1/3 + t/2 + t²/6
    /// in Legendre terms (1/3) P0 + (1/2) P1 + (1/6)(2/3) P2 ... normalised
    /// by its mean: σ = [1, 1/2, 1/10] for s = 2.
    #[test]
    fn cosine_power_window_matches_funk_hecke() {
        let w = cosine_power(4, 2.0);
        for (a, b) in w.iter().zip([1.0, 0.5, 0.1, 0.0]) {
            assert!((a - b).abs() < 1e-12, "{w:?}");
        }
    }

    /// A narrow bright lobe rings negative; the window removes it, keeps the
    /// mean, and leaves an already non-negative function alone.
    #[test]
    fn windowing_removes_ringing_and_keeps_the_mean() {
        let bands = 5;
        let basis = ShBasis::new(bands);
        // A delta towards +z projected onto 5 bands: Y_i(z).
        let y = basis.at(DVec3::Z);
        let light = ShRgb {
            bands,
            rgb: y.iter().map(|&v| [v, v, v]).collect(),
        };
        let (fixed, d) = nonnegative(&light);
        assert!(d.least_before < -0.1, "{d:?}");
        assert!(d.windowed && d.exponent >= (bands - 1) as f64, "{d:?}");
        assert!(least(&band_sums(&fixed), &vec![1.0; bands]) >= 0.0);
        assert_eq!(fixed.rgb[0], light.rgb[0], "the mean is kept");
        // A constant plus a weak first band is non-negative: untouched.
        let mut calm = ShRgb::zeros(bands);
        calm.rgb[0] = [1.0; 3];
        calm.rgb[2] = [0.3; 3];
        assert_eq!(calm.rgb.len(), coefficient_count(bands));
        let (same, d) = nonnegative(&calm);
        assert_eq!(same, calm);
        assert!(!d.windowed && !d.black, "{d:?}");
        assert_eq!((d.exponent, d.window), (0.0, vec![1.0; bands]));
        let (dark, d) = nonnegative(&ShRgb::zeros(bands));
        assert_eq!(dark, ShRgb::zeros(bands));
        assert!(d.black && !d.windowed && d.warning().is_some(), "{d:?}");
    }
}
