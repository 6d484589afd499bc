//! Fuzzy measures mu(r) (paper, section 2): how strongly a direction whose
//! first occluder lies at distance r belongs to the open directions. They
//! are non-negative, increase monotonically from mu(0) = 0 and reach 1 at the
//! neighbourhood radius R, so only occluders inside the neighbourhood sphere
//! count.
//!
//! Everything here is written in the radius-normalised variable rho = r / R,
//! with m(rho) = mu(R rho), m'(rho) = R dmu/dr: the estimators' weights are
//! then dimensionless (see `estimators`), and one sample table serves every R.
//!
//! * `Step`: mu = 0 below R, 1 from R on: classical ambient occlusion with a
//!   maximum distance. Its derivative is a Dirac delta at R, so it has no
//!   density for the estimators that draw r uniformly in a volume (4.1, 4.2,
//!   4.4); importance sampling (4.3) draws r = mu^-1(xi) = R.
//! * `Exp { sigma }`: the participating-medium measure 1 - exp(-sigma r) of
//!   section 2, truncated at R and renormalised so that it reaches 1 there,
//!   as the paper requires of a practical measure: with s = sigma R,
//!   m(rho) = (1 - e^{-s rho}) / (1 - e^{-s}) for rho < 1. It tends to the
//!   linear measure rho as s -> 0.
//! * `Poly4`: mu = (r/R)^4, the paper's choice for section 4.5 because
//!   (dmu/dr) / r = 4 r^2 / R^4 is a polynomial of r^2.

use crate::error::{Error, Result};

/// A fuzzy measure mu(r) (section 2): how much a direction whose first occluder
/// lies at distance r counts as open, rising from mu(0) = 0 to 1 at the
/// neighbourhood radius R.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Measure {
    /// mu = 0 below R, 1 from R on: classical ambient occlusion with a maximum
    /// distance. Its derivative is a Dirac delta at R, so the estimators that
    /// weight by dmu/dr cannot use it.
    Step,
    /// The participating-medium measure 1 - exp(-sigma r) of section 2,
    /// truncated at R and renormalised to reach 1 there.
    Exp {
        /// Extinction coefficient sigma, in inverse scene units
        /// (`Measure::new` defaults it to 3 / R).
        sigma: f32,
    },
    /// mu = (r/R)^4, the paper's choice for section 4.5: (dmu/dr) / r is a
    /// polynomial of r^2.
    Poly4,
}

/// Which measure, without its parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum MeasureKind {
    /// mu = 0 below R, 1 beyond: classical AO with a maximum distance.
    Step,
    /// 1 - exp(-sigma r), truncated at R and renormalised.
    Exp,
    /// (r/R)^4.
    Poly4,
}

crate::choice!(MeasureKind { Step = "step", Exp = "exp", Poly4 = "poly4" });

impl Measure {
    /// `kind` for neighbourhood radius `radius`; `sigma` (exp only) defaults
    /// to 3 / R.
    pub fn new(kind: MeasureKind, sigma: Option<f32>, radius: f32) -> Result<Measure> {
        if sigma.is_some() && kind != MeasureKind::Exp {
            return Err(Error::param("sigma", "only applies to `measure` exp"));
        }
        Ok(match kind {
            MeasureKind::Step => Measure::Step,
            MeasureKind::Poly4 => Measure::Poly4,
            MeasureKind::Exp => Measure::Exp {
                sigma: sigma.unwrap_or(3.0 / radius),
            },
        })
    }

    /// The name the command line and reports use: `step`, `exp` or `poly4`.
    pub fn name(&self) -> &'static str {
        match self {
            Measure::Step => "step",
            Measure::Exp { .. } => "exp",
            Measure::Poly4 => "poly4",
        }
    }

    /// Checks the exponential measure's sigma: positive and finite.
    pub fn validate(&self) -> Result<()> {
        if let Measure::Exp { sigma } = *self
            && !(sigma > 0.0 && sigma.is_finite())
        {
            return Err(Error::param(
                "sigma",
                format!("must be positive and finite, got {sigma}"),
            ));
        }
        Ok(())
    }

    /// s = sigma R of the exponential measure (clamped away from 0 so the
    /// normalisation 1 - e^{-s} stays representable).
    fn s(sigma: f32, radius: f32) -> f64 {
        (sigma as f64 * radius as f64).max(1e-6)
    }

    /// m(rho) = mu(R rho); 1 for rho >= 1.
    pub fn m(&self, rho: f64, radius: f32) -> f64 {
        if rho >= 1.0 {
            return 1.0;
        }
        let rho = rho.max(0.0);
        match *self {
            Measure::Step => 0.0,
            Measure::Exp { sigma } => {
                let s = Self::s(sigma, radius);
                -(-s * rho).exp_m1() / -(-s).exp_m1()
            }
            Measure::Poly4 => rho.powi(4),
        }
    }

    /// m'(rho) = R dmu/dr at r = R rho, for 0 < rho < 1 (the step measure
    /// has none: 0 here, and the volume estimators reject it).
    pub fn dm(&self, rho: f64, radius: f32) -> f64 {
        if !(0.0..1.0).contains(&rho) {
            return 0.0;
        }
        match *self {
            Measure::Step => 0.0,
            Measure::Exp { sigma } => {
                let s = Self::s(sigma, radius);
                s * (-s * rho).exp() / -(-s).exp_m1()
            }
            Measure::Poly4 => 4.0 * rho.powi(3),
        }
    }

    /// m^-1(xi): the radius, in units of R, drawn with density m' (section
    /// 4.3) from xi in (0, 1).
    ///
    /// * step: the whole probability sits at rho = 1.
    /// * exp: xi = (1 - e^{-s rho}) / (1 - e^{-s})  =>  rho = -ln(1 - xi (1 - e^{-s})) / s.
    /// * poly4: xi = rho^4  =>  rho = xi^{1/4}.
    pub fn inverse(&self, xi: f64, radius: f32) -> f64 {
        let xi = xi.clamp(0.0, 1.0);
        match *self {
            Measure::Step => 1.0,
            Measure::Exp { sigma } => {
                let s = Self::s(sigma, radius);
                (-(xi * -(-s).exp_m1())).ln_1p() / -s
            }
            Measure::Poly4 => xi.sqrt().sqrt(),
        }
    }

    /// Whether dmu/dr is a density (not a Dirac delta): the uniform-volume
    /// estimators (sections 4.1, 4.2, 4.4) need one.
    pub fn has_density(&self) -> bool {
        !matches!(self, Measure::Step)
    }

    /// What the tangent-sphere estimator (section 4.4) returns at a point
    /// with no occluder at all: (1/pi) * integral over the hemisphere of
    /// mu(R cos theta) dw = 2 * integral_0^1 m(c) dc (dw = 2 pi dc with
    /// c = cos theta).
    ///
    /// Derivation. Section 4.4 replaces the cosine factor of equation (1),
    /// (1/pi) int_Omega int_0^R mu'(r) cos(theta) v dr dw, by shrinking the
    /// radial range to R cos(theta): (1/pi) int_Omega int_0^{R cos} mu'(r) v dr dw,
    /// which is the volume integral over the tangent sphere T of radius R/2
    /// (Figure 5; dV = r^2 dr dw). The two agree when mu'(r) v is constant
    /// along r, i.e. for the linear measure; with v = 1 the shrunk integral is
    /// (1/pi) int_Omega mu(R cos theta) dw, which is 1 for mu = r/R but
    /// 2 int_0^1 c^4 dc = 2/5 for (r/R)^4, and
    /// 2 (1 - (1 - e^{-s}) / s) / (1 - e^{-s}) for the truncated exponential.
    /// `estimators` divides by this constant so that an open point is 1;
    /// the approximation's remaining bias (partially occluded points) is
    /// measured in docs/results/ssao.md.
    pub fn tangent_sphere_open_value(&self, radius: f32) -> f64 {
        match *self {
            Measure::Step => 0.0,
            Measure::Exp { sigma } => {
                let s = Self::s(sigma, radius);
                let one_minus = -(-s).exp_m1();
                2.0 * (1.0 - one_minus / s) / one_minus
            }
            Measure::Poly4 => 0.4,
        }
    }

    /// mu(D) for an occluder at distance `d` (infinite for none).
    pub fn mu(&self, d: f32, radius: f32) -> f32 {
        if d.is_nan() || d >= radius {
            return 1.0;
        }
        self.m(d as f64 / radius as f64, radius) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MEASURES: [Measure; 3] = [Measure::Step, Measure::Exp { sigma: 3.0 }, Measure::Poly4];

    #[test]
    fn measures_rise_from_zero_to_one_at_r() {
        for m in MEASURES {
            assert_eq!(m.m(0.0, 1.0), 0.0, "{m:?}");
            assert_eq!(m.m(1.0, 1.0), 1.0, "{m:?}");
            assert_eq!(m.mu(f32::INFINITY, 2.0), 1.0);
            let mut last = 0.0;
            for i in 0..=100 {
                let v = m.m(i as f64 / 100.0, 1.0);
                assert!(v >= last && (0.0..=1.0).contains(&v), "{m:?}");
                last = v;
            }
        }
    }

    #[test]
    fn inverse_inverts_and_derivative_integrates() {
        for m in [
            Measure::Exp { sigma: 3.0 },
            Measure::Exp { sigma: 1e-9 },
            Measure::Poly4,
        ] {
            for i in 1..100 {
                let xi = i as f64 / 100.0;
                let rho = m.inverse(xi, 1.0);
                assert!((m.m(rho, 1.0) - xi).abs() < 1e-9, "{m:?} {xi}");
            }
            // integral_0^1 m' = m(1) - m(0) = 1 (midpoint rule).
            let n = 100_000;
            let total: f64 = (0..n).map(|i| m.dm((i as f64 + 0.5) / n as f64, 1.0)).sum::<f64>() / n as f64;
            assert!((total - 1.0).abs() < 1e-6, "{m:?}: {total}");
        }
    }

    #[test]
    fn tangent_sphere_open_value_is_the_cosine_shrunk_integral() {
        for m in [
            Measure::Exp { sigma: 3.0 },
            Measure::Exp { sigma: 40.0 },
            Measure::Poly4,
        ] {
            let n = 100_000;
            let direct: f64 = 2.0 * (0..n).map(|i| m.m((i as f64 + 0.5) / n as f64, 1.0)).sum::<f64>() / n as f64;
            let closed = m.tangent_sphere_open_value(1.0);
            assert!((direct - closed).abs() < 1e-6, "{m:?}: {direct} vs {closed}");
        }
    }

    #[test]
    fn rejects_bad_sigma() {
        for s in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(Measure::Exp { sigma: s }.validate().is_err());
        }
    }
}
