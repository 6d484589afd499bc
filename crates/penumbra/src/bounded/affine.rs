//! Affine arithmetic over a linetree cell: the bound behind the error
//! predicate.
//!
//! A quantity that depends on the ray of a cell is written as
//! `x0 + x1 e1 + x2 e2 + x3 e3 + x4 e4 + r e`, where `e1..e4` in [-1, 1]
//! are the cell's four line coordinates (a, b, c, d) rescaled to the cell,
//! and `e` in [-1, 1] an unknown collecting everything nonlinear (de
//! Figueiredo and Stolfi, "Affine arithmetic: concepts and applications",
//! 2004). Sums and scalings are exact; a product or a nonlinear function
//! (reciprocal, square root, power...) is replaced by its best affine
//! approximation over the operand's range plus a radius that bounds the
//! difference, so the form always encloses every value the quantity takes
//! over the cell.
//!
//! Why this and not the paper's second-order estimate: quadrilinear
//! interpolation reproduces the affine part `x0 + sum xi ei` exactly, so if
//! the radiance's form has remainder `r`, interpolating the 16 corner
//! samples is off by at most `2 r` anywhere in the cell. That is the
//! paper's idea (constant and linear terms interpolate well, the rest is the
//! error), made a bound for every operation of the shading instead of an
//! estimate of its quadratic term.
//!
//! Arithmetic is in f64; its rounding (1e-16 relative) is far below the
//! f32 renderer's, which the predicate allows for separately.

// Named methods rather than operator traits: `recip`, `div` and `sqrt`
// return `Option` (an operand that may be zero or negative), and the
// chains read in the order the paper's formulas do.
#![allow(clippy::should_implement_trait)]

use crate::bounded::jet::{Iv, Jet};

/// The number of cell coordinates.
pub const SYMBOLS: usize = 4;

/// An affine form `c + sum l[i] e_i + r e`, `r >= 0`, and alongside it the
/// quantity's second-order jet (`jet`), a second, often much sharper bound
/// on its interpolation error: `interp_error` takes the smaller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aff {
    pub c: f64,
    pub l: [f64; SYMBOLS],
    pub r: f64,
    pub jet: Jet,
}

impl Aff {
    pub const ZERO: Aff = Aff::constant(0.0);

    pub const fn constant(c: f64) -> Aff {
        Aff {
            c,
            l: [0.0; SYMBOLS],
            r: 0.0,
            jet: Jet::ZERO,
        }
    }

    /// Coordinate `i` of the cell, ranging over `[mid - half, mid + half]`.
    pub fn coordinate(i: usize, mid: f64, half: f64) -> Aff {
        let mut l = [0.0; SYMBOLS];
        l[i] = half;
        Aff {
            c: mid,
            l,
            r: 0.0,
            jet: Jet::coordinate(i, half),
        }
    }

    /// Any value in `[lo, hi]`, with no known dependence on the cell.
    pub fn interval(lo: f64, hi: f64) -> Aff {
        let r = 0.5 * (hi - lo).abs();
        Aff {
            c: 0.5 * (lo + hi),
            l: [0.0; SYMBOLS],
            r,
            jet: Jet::perturbation(r),
        }
    }

    /// The half-width of the range: the linear part's and the remainder.
    pub fn radius(&self) -> f64 {
        self.l.iter().map(|x| x.abs()).sum::<f64>() + self.r
    }

    pub fn lo(&self) -> f64 {
        self.c - self.radius()
    }

    pub fn hi(&self) -> f64 {
        self.c + self.radius()
    }

    pub fn is_finite(&self) -> bool {
        self.c.is_finite() && self.r.is_finite() && self.l.iter().all(|x| x.is_finite())
    }

    pub fn add(self, o: Aff) -> Aff {
        let mut l = self.l;
        for (x, y) in l.iter_mut().zip(o.l) {
            *x += y;
        }
        Aff {
            c: self.c + o.c,
            l,
            r: self.r + o.r,
            jet: self.jet.add(o.jet),
        }
    }

    pub fn sub(self, o: Aff) -> Aff {
        self.add(o.neg())
    }

    pub fn neg(self) -> Aff {
        self.scale(-1.0)
    }

    pub fn scale(self, k: f64) -> Aff {
        Aff {
            c: self.c * k,
            l: self.l.map(|x| x * k),
            r: self.r * k.abs(),
            jet: self.jet.scale(k),
        }
    }

    pub fn add_const(self, k: f64) -> Aff {
        Aff { c: self.c + k, ..self }
    }

    /// The product: the linear terms of each times the other's centre, and
    /// the product of the two radii as remainder.
    pub fn mul(self, o: Aff) -> Aff {
        let mut l = [0.0; SYMBOLS];
        for (i, x) in l.iter_mut().enumerate() {
            *x = self.c * o.l[i] + o.c * self.l[i];
        }
        let linear = |a: &Aff| a.l.iter().map(|x| x.abs()).sum::<f64>();
        let r = self.c.abs() * o.r + o.c.abs() * self.r + (linear(&self) + self.r) * (linear(&o) + o.r);
        let jet = Jet::mul(&self.jet, self.smooth_range(), &o.jet, o.smooth_range());
        Aff {
            c: self.c * o.c,
            l,
            r,
            jet,
        }
    }

    /// Where the smooth part `s` of `s + p` may lie: this form's range
    /// widened by `P`.
    fn smooth_range(&self) -> Iv {
        Iv {
            lo: self.lo() - self.jet.p,
            hi: self.hi() + self.jet.p,
        }
    }

    /// The bound on the error of interpolating the quantity over the cell
    /// from its 16 corner values: `2 r` (the affine part is reproduced
    /// exactly) or the jet's, whichever is smaller (both hold).
    pub fn interp_error(&self) -> f64 {
        let jet = self.jet.error();
        if self.jet.live && jet.is_finite() {
            (2.0 * self.r).min(jet)
        } else {
            2.0 * self.r
        }
    }

    /// The same form without its jet (a shaft cull's: only ranges count).
    pub fn plain(self) -> Aff {
        Aff { jet: Jet::ZERO, ..self }
    }

    /// This form's result `out` of a function `g` that is C^2 over the
    /// smooth part's range `u`, with `g'` and `g''` monotone there
    /// (`g1`, `g2` evaluate them): its jet by the chain rule.
    fn with_smooth_jet(&self, mut out: Aff, u: Iv, g1: impl Fn(f64) -> f64, g2: impl Fn(f64) -> f64) -> Aff {
        let (a, b) = (Iv::span(g1(u.lo), g1(u.hi)), Iv::span(g2(u.lo), g2(u.hi)));
        out.jet = Jet::smooth(&self.jet, a, b);
        out
    }

    /// `alpha x + zeta`, with radius `delta` added: the result of an
    /// affine approximation of a function over this form's range.
    fn approximated(self, alpha: f64, zeta: f64, delta: f64) -> Aff {
        // The jet: alpha s smooth, alpha p + the approximation's error
        // a perturbation.
        let mut out = self.scale(alpha).add_const(zeta);
        out.r += delta;
        if out.jet.live {
            out.jet.p += delta;
        }
        out
    }

    /// `f` approximated by slope `alpha`: where `f(x) - alpha x` is
    /// monotone over `[lo, hi]` (alpha = f' at one end for a convex or
    /// concave f), its extremes are the ends.
    fn min_range(self, f: impl Fn(f64) -> f64, alpha: f64) -> Aff {
        let (lo, hi) = (self.lo(), self.hi());
        if hi - lo <= 0.0 {
            return Aff::constant(f(self.c));
        }
        let (dlo, dhi) = (f(lo) - alpha * lo, f(hi) - alpha * hi);
        self.approximated(alpha, 0.5 * (dlo + dhi), 0.5 * (dlo - dhi).abs())
    }

    /// `1 / x`; `None` where the range contains 0.
    pub fn recip(self) -> Option<Aff> {
        let (lo, hi) = (self.lo(), self.hi());
        if lo <= 0.0 && hi >= 0.0 {
            return None;
        }
        // Convex (x > 0) or concave (x < 0): the slope at the end nearer 0
        // in |f'|, i.e. the end farther from 0.
        let far = if lo > 0.0 { hi } else { lo };
        let out = self.min_range(|x| 1.0 / x, -1.0 / (far * far));
        let u = self.smooth_range();
        if u.lo <= 0.0 && u.hi >= 0.0 {
            return Some(out);
        }
        Some(self.with_smooth_jet(out, u, |x| -1.0 / (x * x), |x| 2.0 / (x * x * x)))
    }

    /// `self / o`; `None` where `o`'s range contains 0.
    pub fn div(self, o: Aff) -> Option<Aff> {
        Some(self.mul(o.recip()?))
    }

    /// `sqrt(x)`; `None` unless the range is positive.
    pub fn sqrt(self) -> Option<Aff> {
        let (lo, hi) = (self.lo(), self.hi());
        if lo <= 0.0 {
            return None;
        }
        let out = self.min_range(f64::sqrt, 0.5 / hi.sqrt());
        let u = self.smooth_range();
        if u.lo <= 0.0 {
            return Some(out);
        }
        Some(self.with_smooth_jet(out, u, |x| 0.5 / x.sqrt(), |x| -0.25 / (x * x.sqrt())))
    }

    /// `1 / sqrt(x)`; `None` unless the range is positive.
    pub fn rsqrt(self) -> Option<Aff> {
        let (lo, hi) = (self.lo(), self.hi());
        if lo <= 0.0 {
            return None;
        }
        let out = self.min_range(|x| 1.0 / x.sqrt(), -0.5 / (hi * hi.sqrt()));
        let u = self.smooth_range();
        if u.lo <= 0.0 {
            return Some(out);
        }
        Some(self.with_smooth_jet(out, u, |x| -0.5 / (x * x.sqrt()), |x| 0.75 / (x * x * x.sqrt())))
    }

    /// `x^n` for `x >= 0` (a Phong lobe); `n >= 0`.
    pub fn powf(self, n: f64) -> Option<Aff> {
        let lo = self.lo().max(0.0);
        let hi = self.hi();
        // (A NaN exponent is refused too.)
        if self.lo() < 0.0 || n.is_nan() || n < 0.0 {
            return None;
        }
        if n == 0.0 {
            return Some(Aff::constant(1.0));
        }
        if n == 1.0 {
            return Some(self);
        }
        let f = |x: f64| x.max(0.0).powf(n);
        // Convex for n > 1 (slope at the low end), concave below.
        let at = if n > 1.0 { lo } else { hi };
        let alpha = if at > 0.0 { n * at.powf(n - 1.0) } else { 0.0 };
        let out = self.min_range(f, alpha);
        // max(x, 0)^n: C^2 for x > 0, and with a bounded second derivative
        // through 0 when n >= 2 (enough for the interpolation bound).
        let mut u = self.smooth_range();
        if u.lo <= 0.0 && n < 2.0 {
            return Some(out);
        }
        u.lo = u.lo.max(0.0);
        Some(self.with_smooth_jet(out, u, |x| n * x.powf(n - 1.0), |x| n * (n - 1.0) * x.powf(n - 2.0)))
    }

    /// `max(x, 0)`: the chord between the ends where the range crosses 0.
    pub fn relu(self) -> Aff {
        let (lo, hi) = (self.lo(), self.hi());
        if lo >= 0.0 {
            return self;
        }
        if hi <= 0.0 {
            return Aff::ZERO;
        }
        let alpha = hi / (hi - lo);
        // f(x) - alpha x is -alpha lo at lo, (1 - alpha) hi at hi, 0 at 0:
        // its range is [min, max] of these.
        let values = [-alpha * lo, (1.0 - alpha) * hi, 0.0];
        let (mn, mx) = (
            values.iter().copied().fold(f64::INFINITY, f64::min),
            values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        );
        self.approximated(alpha, 0.5 * (mn + mx), 0.5 * (mx - mn))
    }

    /// `min(x, 1)`.
    pub fn min_one(self) -> Aff {
        self.neg().add_const(1.0).relu().neg().add_const(1.0)
    }

    /// Where all of the range is `> 0`, `< 0`, or neither.
    pub fn sign(&self) -> Option<bool> {
        if self.lo() > 0.0 {
            Some(true)
        } else if self.hi() < 0.0 {
            Some(false)
        } else {
            None
        }
    }
}

/// A vector of affine forms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AVec3 {
    pub x: Aff,
    pub y: Aff,
    pub z: Aff,
}

impl AVec3 {
    pub fn new(x: Aff, y: Aff, z: Aff) -> AVec3 {
        AVec3 { x, y, z }
    }

    pub fn constant(v: glam::DVec3) -> AVec3 {
        AVec3::new(Aff::constant(v.x), Aff::constant(v.y), Aff::constant(v.z))
    }

    /// Any point of the box `[lo, hi]`.
    pub fn boxed(lo: glam::DVec3, hi: glam::DVec3) -> AVec3 {
        AVec3::new(
            Aff::interval(lo.x, hi.x),
            Aff::interval(lo.y, hi.y),
            Aff::interval(lo.z, hi.z),
        )
    }

    pub fn axes(&self) -> [Aff; 3] {
        [self.x, self.y, self.z]
    }

    pub fn map(self, f: impl Fn(Aff) -> Aff) -> AVec3 {
        AVec3::new(f(self.x), f(self.y), f(self.z))
    }

    pub fn add(self, o: AVec3) -> AVec3 {
        AVec3::new(self.x.add(o.x), self.y.add(o.y), self.z.add(o.z))
    }

    pub fn sub(self, o: AVec3) -> AVec3 {
        AVec3::new(self.x.sub(o.x), self.y.sub(o.y), self.z.sub(o.z))
    }

    pub fn scale(self, k: f64) -> AVec3 {
        self.map(|a| a.scale(k))
    }

    /// Each component times the form `k`.
    pub fn times(self, k: Aff) -> AVec3 {
        self.map(|a| a.mul(k))
    }

    pub fn dot(self, o: AVec3) -> Aff {
        self.x.mul(o.x).add(self.y.mul(o.y)).add(self.z.mul(o.z))
    }

    /// Dot with a constant vector (exact).
    pub fn dot_const(self, v: glam::DVec3) -> Aff {
        self.x.scale(v.x).add(self.y.scale(v.y)).add(self.z.scale(v.z))
    }

    pub fn add_const(self, v: glam::DVec3) -> AVec3 {
        AVec3::new(self.x.add_const(v.x), self.y.add_const(v.y), self.z.add_const(v.z))
    }

    /// `self / |self|`; `None` where the length may be 0.
    pub fn normalize(self) -> Option<AVec3> {
        Some(self.times(self.dot(self).rsqrt()?))
    }

    /// The centre of each component.
    pub fn centre(&self) -> glam::DVec3 {
        glam::DVec3::new(self.x.c, self.y.c, self.z.c)
    }

    /// The box the forms range over.
    pub fn bounds(&self) -> (glam::DVec3, glam::DVec3) {
        (
            glam::DVec3::new(self.x.lo(), self.y.lo(), self.z.lo()),
            glam::DVec3::new(self.x.hi(), self.y.hi(), self.z.hi()),
        )
    }

    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }

    /// Without the jets (`Aff::plain`).
    pub fn plain(self) -> AVec3 {
        self.map(Aff::plain)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every value of `f` over a grid of the cell lies in its form.
    fn encloses(form: Aff, f: impl Fn([f64; 4]) -> f64) {
        let steps: u32 = 6;
        for i in 0..=steps.pow(4) - 1 {
            let e = [0, 1, 2, 3].map(|k| ((i / steps.pow(k)) % steps) as f64 / (steps - 1) as f64 * 2.0 - 1.0);
            let v = f(e);
            let linear = form.c + (0..4).map(|k| form.l[k] * e[k]).sum::<f64>();
            assert!(
                (v - linear).abs() <= form.r * (1.0 + 1e-12) + 1e-12,
                "{v} vs {linear} +- {}",
                form.r
            );
        }
    }

    #[test]
    fn operations_enclose_what_they_approximate() {
        let a = Aff::coordinate(0, 2.0, 0.5);
        let b = Aff::coordinate(1, -1.0, 0.3);
        let c = Aff::coordinate(2, 0.7, 0.2);
        let x = |e: [f64; 4]| 2.0 + 0.5 * e[0];
        let y = |e: [f64; 4]| -1.0 + 0.3 * e[1];
        let z = |e: [f64; 4]| 0.7 + 0.2 * e[2];
        encloses(a.add(b), |e| x(e) + y(e));
        encloses(a.mul(b), |e| x(e) * y(e));
        encloses(a.mul(b).mul(c), |e| x(e) * y(e) * z(e));
        encloses(a.recip().unwrap(), |e| 1.0 / x(e));
        encloses(b.recip().unwrap(), |e| 1.0 / y(e));
        encloses(a.sqrt().unwrap(), |e| x(e).sqrt());
        encloses(a.rsqrt().unwrap(), |e| 1.0 / x(e).sqrt());
        encloses(c.powf(60.0).unwrap(), |e| z(e).powf(60.0));
        encloses(c.powf(0.5).unwrap(), |e| z(e).sqrt());
        encloses(a.add(b).add_const(-0.9).relu(), |e| (x(e) + y(e) - 0.9).max(0.0));
        encloses(a.sub(c).min_one(), |e| (x(e) - z(e)).min(1.0));
        assert!(b.sqrt().is_none() && a.sub(a.add_const(0.0)).recip().is_none());
        let v = AVec3::new(a, b, c);
        let n = v.normalize().unwrap();
        encloses(n.x, |e| x(e) / (x(e) * x(e) + y(e) * y(e) + z(e) * z(e)).sqrt());
    }

    /// Quadrilinear interpolation of `f` from the cell's 16 corners stays
    /// within the form's `interp_error` of `f` over a grid of the cell;
    /// returns the largest error seen.
    fn interpolates_within(form: Aff, f: impl Fn([f64; 4]) -> f64) -> f64 {
        let corners: Vec<f64> = (0..16)
            .map(|k| f([0, 1, 2, 3].map(|i| if k >> i & 1 == 1 { 1.0 } else { -1.0 })))
            .collect();
        let steps: u32 = 7;
        let mut worst = 0.0f64;
        for i in 0..steps.pow(4) {
            let e = [0, 1, 2, 3].map(|k| ((i / steps.pow(k)) % steps) as f64 / (steps - 1) as f64 * 2.0 - 1.0);
            let interp: f64 = (0..16)
                .map(|k| {
                    let w: f64 = (0..4)
                        .map(|a| {
                            if k >> a & 1 == 1 {
                                0.5 * (1.0 + e[a])
                            } else {
                                0.5 * (1.0 - e[a])
                            }
                        })
                        .product();
                    w * corners[k]
                })
                .sum();
            let err = (interp - f(e)).abs();
            assert!(
                err <= form.interp_error() * (1.0 + 1e-9) + 1e-12,
                "{err} > {}",
                form.interp_error()
            );
            worst = worst.max(err);
        }
        worst
    }

    #[test]
    fn jets_bound_the_interpolation_error_and_beat_the_remainder_on_products() {
        let a = Aff::coordinate(0, 2.0, 0.5).add(Aff::coordinate(1, 0.0, 0.4));
        let b = Aff::coordinate(2, -1.0, 0.3).add(Aff::coordinate(3, 0.0, 0.2));
        let x = |e: [f64; 4]| 2.0 + 0.5 * e[0] + 0.4 * e[1];
        let y = |e: [f64; 4]| -1.0 + 0.3 * e[2] + 0.2 * e[3];
        // A product of forms in different coordinates is multilinear:
        // interpolated exactly, and the jet knows it (the remainder does not).
        let p = a.mul(b);
        assert_eq!(p.jet.error(), 0.0);
        assert!(p.r > 0.4);
        interpolates_within(p, |e| x(e) * y(e));
        // A square has pure second derivatives: a bound of 1/2 sum_i 2 l_i^2.
        let sq = a.mul(a);
        assert!(
            (sq.interp_error() - (0.25 + 0.16)).abs() < 1e-12,
            "{}",
            sq.interp_error()
        );
        let worst = interpolates_within(sq, |e| x(e) * x(e));
        assert!(
            worst > 0.5 * sq.interp_error(),
            "the bound is near what it bounds: {worst}"
        );
        // Smooth functions, a kink (relu across 0), an unknown interval.
        interpolates_within(a.recip().unwrap(), |e| 1.0 / x(e));
        interpolates_within(a.rsqrt().unwrap(), |e| 1.0 / x(e).sqrt());
        interpolates_within(a.sqrt().unwrap().mul(b), |e| x(e).sqrt() * y(e));
        let v = AVec3::new(a, b, Aff::coordinate(1, 1.0, 0.1));
        interpolates_within(v.normalize().unwrap().x, |e| {
            let z = 1.0 + 0.1 * e[1];
            x(e) / (x(e) * x(e) + y(e) * y(e) + z * z).sqrt()
        });
        let c = Aff::coordinate(0, 0.1, 0.3).add(Aff::coordinate(2, 0.0, 0.1));
        let z = |e: [f64; 4]| 0.1 + 0.3 * e[0] + 0.1 * e[2];
        let w = Aff::coordinate(0, 0.5, 0.3).add(Aff::coordinate(3, 0.0, 0.15));
        let wf = |e: [f64; 4]| 0.5 + 0.3 * e[0] + 0.15 * e[3];
        interpolates_within(w.powf(1.5).unwrap(), |e| wf(e).powf(1.5));
        interpolates_within(w.powf(40.0).unwrap(), |e| wf(e).powf(40.0));
        interpolates_within(c.relu().mul(a), |e| z(e).max(0.0) * x(e));
        let unknown = Aff::interval(0.0, 1.0);
        interpolates_within(a.mul(unknown), |e| x(e) * (e[3] > 0.2) as u8 as f64);
    }

    #[test]
    fn affine_parts_are_exact_and_remainders_shrink_quadratically() {
        // A linear function has no remainder at all.
        let lin = Aff::coordinate(0, 1.0, 0.1)
            .scale(3.0)
            .add(Aff::coordinate(3, 0.0, 0.2));
        assert_eq!(lin.r, 0.0);
        // 1/x over a cell of half-width h: remainder ~ h^2.
        let r = |h: f64| Aff::coordinate(0, 2.0, h).recip().unwrap().r;
        let ratio = r(0.1) / r(0.05);
        assert!((3.5..4.5).contains(&ratio), "{ratio}");
    }
}
