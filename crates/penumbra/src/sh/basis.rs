//! Real spherical harmonics of any number of bands, evaluated as polynomials
//! in the unit direction (x, y, z) by stable, fully normalised recurrences.
//!
//! Conventions (see the module documentation of `sh` for the full list):
//! coefficient `l (l + 1) + m` for band `l`, order `-l <= m <= l`;
//! orthonormal over the sphere; **no Condon–Shortley phase**, so
//! `Y_1,-1 = +c y`, `Y_1,0 = +c z`, `Y_1,1 = +c x` with `c = sqrt(3 / 4pi)`.
//!
//! With `N_l^m(z) = K_l^m P_l^m(z) / sin^m(theta)` (a polynomial in z) and
//! `C_m + i S_m = (x + i y)^m = sin^m(theta) e^{i m phi}`:
//!
//! ```text
//! Y_l,0  = N_l^0(z)
//! Y_l,m  = sqrt(2) N_l^m(z) C_m(x, y)      m > 0
//! Y_l,-m = sqrt(2) N_l^m(z) S_m(x, y)      m > 0
//! N_0^0 = 1 / sqrt(4 pi)
//! N_m^m = sqrt((2m + 1) / (2m)) N_{m-1}^{m-1}
//! N_{m+1}^m = sqrt(2m + 3) z N_m^m
//! N_l^m = a_l^m (z N_{l-1}^m - b_l^m N_{l-2}^m),
//!   a_l^m = sqrt((4l^2 - 1) / (l^2 - m^2)),  b_l^m = sqrt(((l-1)^2 - m^2) / (4 (l-1)^2 - 1))
//! C_m = x C_{m-1} - y S_{m-1},  S_m = x S_{m-1} + y C_{m-1}
//! ```
//!
//! Every quantity stays O(1) (no factorials, no powers of sin(theta), no
//! trigonometric calls), which is what keeps order 15 free of overflow and
//! cancellation in single precision.

use glam::{DVec3, Vec3};

use super::coefficient_count;

/// Recurrence constants for `bands` bands, built once.
#[derive(Debug, Clone)]
pub struct ShBasis {
    bands: usize,
    /// N_m^m / N_{m-1}^{m-1} for m >= 1 (index m).
    diag: Vec<f64>,
    /// (a_l^m, b_l^m) for l >= m + 2, packed by m then l.
    ab: Vec<(f64, f64)>,
    /// diag and ab in single precision for the hot path.
    diag32: Vec<f32>,
    ab32: Vec<(f32, f32)>,
}

impl ShBasis {
    /// `bands` >= 1 (25 coefficients for 5 bands).
    pub fn new(bands: usize) -> ShBasis {
        assert!(bands >= 1, "spherical harmonics need at least one band");
        let mut diag = vec![0.0; bands];
        for (m, d) in diag.iter_mut().enumerate().skip(1) {
            *d = ((2 * m + 1) as f64 / (2 * m) as f64).sqrt();
        }
        let mut ab = Vec::new();
        for m in 0..bands {
            for l in m + 2..bands {
                let (lf, mf) = (l as f64, m as f64);
                let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
                let b = (((lf - 1.0) * (lf - 1.0) - mf * mf) / (4.0 * (lf - 1.0) * (lf - 1.0) - 1.0)).sqrt();
                ab.push((a, b));
            }
        }
        ShBasis {
            bands,
            diag32: diag.iter().map(|&d| d as f32).collect(),
            ab32: ab.iter().map(|&(a, b)| (a as f32, b as f32)).collect(),
            diag,
            ab,
        }
    }

    /// Number of bands: l = 0..bands - 1.
    pub fn bands(&self) -> usize {
        self.bands
    }

    /// Number of basis functions, `bands²`.
    pub fn len(&self) -> usize {
        coefficient_count(self.bands)
    }

    /// Always false: a basis has at least one band.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// All `bands²` basis functions at the unit direction `d` (double
    /// precision, for tables and references). `out.len()` must be `len()`.
    pub fn eval_f64(&self, d: DVec3, out: &mut [f64]) {
        eval_generic(self.bands, &self.diag, &self.ab, [d.x, d.y, d.z], out);
    }

    /// All basis functions at `d` in single precision (the hot path and the
    /// twin of the WGSL code).
    pub fn eval(&self, d: Vec3, out: &mut [f32]) {
        eval_generic(self.bands, &self.diag32, &self.ab32, [d.x, d.y, d.z], out);
    }

    /// Convenience: a new vector of the basis at `d`.
    pub fn at(&self, d: DVec3) -> Vec<f64> {
        let mut v = vec![0.0; self.len()];
        self.eval_f64(d, &mut v);
        v
    }
}

/// Float operations the recurrence needs, for f32 and f64.
trait Real: Copy + std::ops::Mul<Output = Self> + std::ops::Sub<Output = Self> + std::ops::Add<Output = Self> {
    fn from_f64(v: f64) -> Self;
}
impl Real for f32 {
    fn from_f64(v: f64) -> Self {
        v as f32
    }
}
impl Real for f64 {
    fn from_f64(v: f64) -> Self {
        v
    }
}

fn eval_generic<T: Real>(bands: usize, diag: &[T], ab: &[(T, T)], [x, y, z]: [T; 3], out: &mut [T]) {
    assert_eq!(out.len(), bands * bands, "output length must be bands²");
    let sqrt2 = T::from_f64(std::f64::consts::SQRT_2);
    let mut nmm = T::from_f64(0.5 / std::f64::consts::PI.sqrt()); // N_0^0
    let (mut c, mut s) = (T::from_f64(1.0), T::from_f64(0.0)); // C_0, S_0
    let mut k = 0; // index into ab
    for m in 0..bands {
        if m > 0 {
            nmm = nmm * diag[m];
            let c_next = x * c - y * s;
            s = x * s + y * c;
            c = c_next;
        }
        let put = |out: &mut [T], l: usize, n: T| {
            if m == 0 {
                out[l * (l + 1)] = n;
            } else {
                out[l * (l + 1) + m] = sqrt2 * n * c;
                out[l * (l + 1) - m] = sqrt2 * n * s;
            }
        };
        put(out, m, nmm);
        if m + 1 < bands {
            let mut n_prev = nmm; // N_{l-2}^m
            let mut n_cur = T::from_f64(((2 * m + 3) as f64).sqrt()) * z * nmm; // N_{m+1}^m
            put(out, m + 1, n_cur);
            for l in m + 2..bands {
                let (a, b) = ab[k];
                k += 1;
                let n_next = a * (z * n_cur - b * n_prev);
                put(out, l, n_next);
                n_prev = n_cur;
                n_cur = n_next;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn low_bands_match_the_closed_forms() {
        let basis = ShBasis::new(3);
        let d = DVec3::new(0.3, -0.5, 0.2).normalize();
        let y = basis.at(d);
        let pi = std::f64::consts::PI;
        let expect = [
            0.5 / pi.sqrt(),
            (3.0 / (4.0 * pi)).sqrt() * d.y,
            (3.0 / (4.0 * pi)).sqrt() * d.z,
            (3.0 / (4.0 * pi)).sqrt() * d.x,
            0.5 * (15.0 / pi).sqrt() * d.x * d.y,
            0.5 * (15.0 / pi).sqrt() * d.y * d.z,
            0.25 * (5.0 / pi).sqrt() * (3.0 * d.z * d.z - 1.0),
            0.5 * (15.0 / pi).sqrt() * d.x * d.z,
            0.25 * (15.0 / pi).sqrt() * (d.x * d.x - d.y * d.y),
        ];
        for (i, (a, b)) in y.iter().zip(&expect).enumerate() {
            assert!((a - b).abs() < 1e-14, "coefficient {i}: {a} vs {b}");
        }
    }
}
