//! Rotation of SH coefficient vectors.
//!
//! `D(R)` acts on coefficients so that the rotated function is
//! `g(s) = f(R^-1 s)`; `D(AB) = D(A) D(B)`. Rotations about z are cheap
//! (each pair (m, -m) turns by the angle m alpha). Any rotation is
//! `R = Rz(alpha) Ry(beta) Rz(gamma)` and `Ry(beta) = Rx(-90°) Rz(beta) Rx(90°)`,
//! so `D(R)` needs only the fixed matrices of `Rx(±90°)` per band (the "zxzxz"
//! factorisation of Kautz, Sloan and Snyder 2002). Those are computed once by
//! projection with an exact product quadrature (`quadrature`): entry
//! `X^l_ij = ∫ Y_i(s) Y_j(Rx(90°)^-1 s) ds`, exact to rounding because the
//! integrand is a polynomial of degree 2l.
//!
//! The transfer of a vertex is integrated in its tangent frame. Choosing that
//! frame as `Rz(alpha) Ry(beta)` (alpha, beta the spherical angles of the
//! normal) makes the frame-to-world rotation two z-turns and two fixed
//! x-turns, with cos/sin of alpha and beta read off the normal directly — no
//! trigonometric calls per vertex (`tangent_frame`, `ShRotation::frame_to_world`).

use glam::{DMat3, DVec3, Mat3, Vec3};

use super::basis::ShBasis;
use super::coefficient_count;
use super::quadrature::SphereQuadrature;

/// The fixed per-band matrices for rotating SH vectors of `bands` bands.
#[derive(Debug, Clone)]
pub struct ShRotation {
    bands: usize,
    /// Per band l, the (2l+1)² matrix of D(Rx(90°)), row-major.
    x90: Vec<Vec<f64>>,
    x90_32: Vec<Vec<f32>>,
}

impl ShRotation {
    /// The D(Rx(90°)) matrices of `bands` bands (at least one), projected
    /// with an exact product quadrature.
    pub fn new(bands: usize) -> ShRotation {
        let basis = ShBasis::new(bands);
        let q = SphereQuadrature::for_degree(2 * (bands - 1));
        let rx = DMat3::from_rotation_x(std::f64::consts::FRAC_PI_2);
        let inv = rx.transpose();
        let n = coefficient_count(bands);
        let mut x90: Vec<Vec<f64>> = (0..bands).map(|l| vec![0.0; (2 * l + 1) * (2 * l + 1)]).collect();
        let mut y = vec![0.0; n];
        let mut yr = vec![0.0; n];
        for (p, w) in q.points.iter().zip(&q.weights) {
            basis.eval_f64(*p, &mut y);
            basis.eval_f64(inv * *p, &mut yr);
            for (l, m) in x90.iter_mut().enumerate() {
                let base = l * l;
                let size = 2 * l + 1;
                for i in 0..size {
                    for j in 0..size {
                        m[i * size + j] += w * y[base + i] * yr[base + j];
                    }
                }
            }
        }
        let x90_32 = x90.iter().map(|m| m.iter().map(|&v| v as f32).collect()).collect();
        ShRotation { bands, x90, x90_32 }
    }

    /// Number of bands the matrices cover.
    pub fn bands(&self) -> usize {
        self.bands
    }

    /// D(Rx(90°)) of band l, row-major (2l+1)².
    pub fn x90_band(&self, l: usize) -> &[f64] {
        &self.x90[l]
    }

    /// All bands of D(Rx(90°)) in single precision, concatenated band by band
    /// (the layout the WGSL kernel reads).
    pub fn x90_packed_f32(&self) -> Vec<f32> {
        self.x90_32.iter().flatten().copied().collect()
    }

    /// `coeffs <- D(Rx(±90°)) coeffs` (`inverse` = -90°: the transpose).
    pub fn apply_x90(&self, coeffs: &mut [f64], inverse: bool) {
        let mut tmp = [0.0f64; 64];
        for l in 0..self.bands {
            let size = 2 * l + 1;
            let base = l * l;
            let m = &self.x90[l];
            for i in 0..size {
                let mut acc = 0.0;
                for j in 0..size {
                    let e = if inverse { m[j * size + i] } else { m[i * size + j] };
                    acc += e * coeffs[base + j];
                }
                tmp[i] = acc;
            }
            coeffs[base..base + size].copy_from_slice(&tmp[..size]);
        }
    }

    /// Single-precision `apply_x90` for the hot path.
    pub fn apply_x90_f32(&self, coeffs: &mut [f32], inverse: bool) {
        let mut tmp = [0.0f32; 64];
        for l in 0..self.bands {
            let size = 2 * l + 1;
            let base = l * l;
            let m = &self.x90_32[l];
            let band = &coeffs[base..base + size];
            if inverse {
                tmp[..size].fill(0.0);
                for (j, &c) in band.iter().enumerate() {
                    let row = &m[j * size..(j + 1) * size];
                    for (t, e) in tmp[..size].iter_mut().zip(row) {
                        *t += e * c;
                    }
                }
            } else {
                for (i, t) in tmp[..size].iter_mut().enumerate() {
                    let row = &m[i * size..(i + 1) * size];
                    *t = row.iter().zip(band).map(|(e, c)| e * c).sum();
                }
            }
            coeffs[base..base + size].copy_from_slice(&tmp[..size]);
        }
    }

    /// `coeffs <- D(R) coeffs` for any rotation matrix R (double precision).
    pub fn rotate(&self, r: DMat3, coeffs: &mut [f64]) {
        let (alpha, beta, gamma) = zyz_angles(r);
        rotate_z(coeffs, self.bands, gamma.cos(), gamma.sin());
        self.apply_x90(coeffs, false);
        rotate_z(coeffs, self.bands, beta.cos(), beta.sin());
        self.apply_x90(coeffs, true);
        rotate_z(coeffs, self.bands, alpha.cos(), alpha.sin());
    }

    /// `coeffs <- D(F) coeffs` where F = [t b n] = Rz(alpha) Ry(beta) is the
    /// tangent frame of `tangent_frame(n)`: takes a vector integrated in that
    /// frame to world space.
    pub fn frame_to_world(&self, n: Vec3, coeffs: &mut [f32]) {
        let (ca, sa, cb, sb) = frame_angles(n);
        self.apply_x90_f32(coeffs, false);
        rotate_z(coeffs, self.bands, cb, sb);
        self.apply_x90_f32(coeffs, true);
        rotate_z(coeffs, self.bands, ca, sa);
    }
}

/// Note the band count limit of the fixed scratch arrays above.
pub const MAX_ROTATION_BANDS: usize = 32;

/// cos/sin of the spherical angles (alpha = azimuth, beta = polar angle) of a
/// unit normal; alpha = 0 at the poles, where any azimuth is a valid frame.
#[inline]
pub fn frame_angles(n: Vec3) -> (f32, f32, f32, f32) {
    let sb = (n.x * n.x + n.y * n.y).sqrt();
    let cb = n.z;
    if sb > 1e-12 {
        (n.x / sb, n.y / sb, cb, sb)
    } else {
        (1.0, 0.0, cb.signum(), 0.0)
    }
}

/// The tangent frame (t, b, n) = columns of Rz(alpha) Ry(beta) for a unit
/// normal n: t = (cos b cos a, cos b sin a, -sin b), b = (-sin a, cos a, 0).
/// Visibility masks are rasterised in this frame so that `frame_to_world`
/// rotates their transfer exactly.
#[inline]
pub fn tangent_frame(n: Vec3) -> Mat3 {
    let (ca, sa, cb, sb) = frame_angles(n);
    Mat3::from_cols(
        Vec3::new(cb * ca, cb * sa, -sb),
        Vec3::new(-sa, ca, 0.0),
        Vec3::new(sb * ca, sb * sa, cb),
    )
}

/// `coeffs <- D(Rz(theta)) coeffs` given cos/sin of theta, in f64 or f32.
pub fn rotate_z<T>(coeffs: &mut [T], bands: usize, c: T, s: T)
where
    T: Copy + From<f32> + std::ops::Mul<Output = T> + std::ops::Add<Output = T> + std::ops::Sub<Output = T>,
{
    let (mut cm, mut sm) = (T::from(1.0), T::from(0.0));
    for m in 1..bands {
        let next = cm * c - sm * s;
        sm = sm * c + cm * s;
        cm = next;
        for l in m..bands {
            let ip = l * (l + 1) + m;
            let im = l * (l + 1) - m;
            let (a, b) = (coeffs[ip], coeffs[im]);
            coeffs[ip] = a * cm - b * sm;
            coeffs[im] = a * sm + b * cm;
        }
    }
}

/// Z-Y-Z Euler angles with R = Rz(alpha) Ry(beta) Rz(gamma). Alpha and beta
/// come from R's third column (R z); gamma from the remaining z-rotation
/// Ry(beta)^T Rz(alpha)^T R, which stays well conditioned when sin(beta) -> 0
/// (where alpha and gamma are not separately defined).
pub fn zyz_angles(r: DMat3) -> (f64, f64, f64) {
    let z = r.z_axis;
    let beta = (z.x.hypot(z.y)).atan2(z.z);
    let alpha = if z.x.hypot(z.y) > 1e-300 { z.y.atan2(z.x) } else { 0.0 };
    let rest = DMat3::from_rotation_y(beta).transpose() * DMat3::from_rotation_z(alpha).transpose() * r;
    let gamma = rest.x_axis.y.atan2(rest.x_axis.x);
    (alpha, beta, gamma)
}

/// Band energies: the squared norm of each band's coefficients (invariant
/// under rotation).
pub fn band_energies(coeffs: &[f64], bands: usize) -> Vec<f64> {
    (0..bands)
        .map(|l| coeffs[l * l..(l + 1) * (l + 1)].iter().map(|c| c * c).sum())
        .collect()
}

/// The direction `R^-1 s` helper for tests of `D(R)`: evaluate `f` (given by
/// coefficients) at `s`.
pub fn evaluate(basis: &ShBasis, coeffs: &[f64], s: DVec3) -> f64 {
    basis.at(s).iter().zip(coeffs).map(|(y, c)| y * c).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zyz_round_trips() {
        for (a, b, g) in [
            (0.3, 1.1, -2.0),
            (0.0, 0.0, 0.7),
            (1.0, std::f64::consts::PI, 0.2),
            (-2.5, 1e-9, 1.0),
        ] {
            let r = DMat3::from_rotation_z(a) * DMat3::from_rotation_y(b) * DMat3::from_rotation_z(g);
            let (a2, b2, g2) = zyz_angles(r);
            let r2 = DMat3::from_rotation_z(a2) * DMat3::from_rotation_y(b2) * DMat3::from_rotation_z(g2);
            assert!((r - r2).abs().to_cols_array().iter().all(|e| *e < 1e-12), "{a} {b} {g}");
        }
    }

    #[test]
    fn tangent_frame_is_rz_ry() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.4, 0.2).normalize()] {
            let f = tangent_frame(n);
            assert!((f.z_axis - n).length() < 1e-6);
            assert!((f.determinant() - 1.0).abs() < 1e-5);
            assert!((f.x_axis.dot(f.y_axis)).abs() < 1e-6);
        }
    }
}
