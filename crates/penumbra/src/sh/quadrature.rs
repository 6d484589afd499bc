//! Gauss–Legendre rules and a product rule on the sphere that integrates
//! every spherical harmonic product of a given number of bands exactly
//! (up to rounding). Used to build tables once (rotation matrices, cell
//! integrals, tests), never per frame.

use glam::DVec3;

/// Nodes and weights of the `n`-point Gauss–Legendre rule on [-1, 1]
/// (exact for polynomials of degree 2n - 1), by Newton's method on P_n with
/// the usual initial guesses cos(pi (i + 3/4) / (n + 1/2)).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n > 0, "a Gauss–Legendre rule needs at least one node");
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 1 { x } else { p1 };
            let pn1 = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (x * pn - pn1) / (x * x - 1.0);
            let dx = pn / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[i] = -x;
        nodes[n - 1 - i] = x;
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    (nodes, weights)
}

/// Gauss–Legendre nodes and weights mapped to [a, b].
pub fn gauss_legendre_on(n: usize, a: f64, b: f64) -> Vec<(f64, f64)> {
    let (x, w) = gauss_legendre(n);
    let half = 0.5 * (b - a);
    x.iter()
        .zip(&w)
        .map(|(&x, &w)| (a + half * (x + 1.0), half * w))
        .collect()
}

/// A product rule on the unit sphere: Gauss–Legendre in z = cos(theta) times
/// equally spaced azimuths. With `nz` nodes in z and `nphi` azimuths it
/// integrates exactly every polynomial of degree <= min(2 nz - 1, nphi - 1)
/// in (x, y, z); `for_degree(d)` picks the smallest such rule.
#[derive(Debug, Clone)]
pub struct SphereQuadrature {
    /// The nodes, unit directions, `nphi` azimuths per z node.
    pub points: Vec<DVec3>,
    /// Each node's weight (solid angle, steradians): they sum to 4π.
    pub weights: Vec<f64>,
}

impl SphereQuadrature {
    /// The rule of `nz` Gauss–Legendre nodes in z and `nphi` azimuths at
    /// (k + ½) 2π / `nphi`: `nz · nphi` points.
    pub fn new(nz: usize, nphi: usize) -> SphereQuadrature {
        let (z, wz) = gauss_legendre(nz);
        let mut points = Vec::with_capacity(nz * nphi);
        let mut weights = Vec::with_capacity(nz * nphi);
        let dphi = std::f64::consts::TAU / nphi as f64;
        for (zi, wi) in z.iter().zip(&wz) {
            let r = (1.0 - zi * zi).max(0.0).sqrt();
            for k in 0..nphi {
                let phi = (k as f64 + 0.5) * dphi;
                points.push(DVec3::new(r * phi.cos(), r * phi.sin(), *zi));
                weights.push(wi * dphi);
            }
        }
        SphereQuadrature { points, weights }
    }

    /// Exact for polynomials of total degree <= `degree` on the sphere.
    pub fn for_degree(degree: usize) -> SphereQuadrature {
        Self::new(degree / 2 + 1, degree + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in 1..=20 {
            let (x, w) = gauss_legendre(n);
            assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-13, "n = {n}");
            for k in 0..2 * n {
                let approx: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
                let exact = if k % 2 == 1 { 0.0 } else { 2.0 / (k as f64 + 1.0) };
                assert!((approx - exact).abs() < 1e-13, "n = {n}, x^{k}: {approx} vs {exact}");
            }
        }
    }

    #[test]
    fn sphere_rule_integrates_monomials() {
        let q = SphereQuadrature::for_degree(8);
        let total: f64 = q.weights.iter().sum();
        assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-12);
        // Integral of z^2 over the sphere is 4 pi / 3; of x^2 y^2 z^4 it is 4 pi / 315... check x^2 z^2 = 4 pi / 15.
        let z2: f64 = q.points.iter().zip(&q.weights).map(|(p, w)| w * p.z * p.z).sum();
        assert!((z2 - 4.0 * std::f64::consts::PI / 3.0).abs() < 1e-12);
        let x2z2: f64 = q
            .points
            .iter()
            .zip(&q.weights)
            .map(|(p, w)| w * p.x * p.x * p.z * p.z)
            .sum();
        assert!((x2z2 - 4.0 * std::f64::consts::PI / 15.0).abs() < 1e-12);
    }
}
