//! Second-order jets over a linetree cell: a sharper bound on the error of
//! quadrilinear interpolation than affine arithmetic's remainder.
//!
//! Quadrilinear interpolation is the tensor product of four linear ones,
//! each of sup-norm 1, so for a function `s` that is C^2 along every
//! coordinate, `|I s - s| <= sum_i h_i^2 / 8 * max |d^2 s / dx_i^2|`
//! (the one-dimensional bound applied one coordinate at a time). Over the
//! cell's symbols `e_i` in [-1, 1] (`h = 2`) that is
//! `sum_i 1/2 max |d^2 s / de_i^2|`: only the pure second derivatives
//! count, where affine arithmetic's remainder also carries every cross
//! term `e_i e_j`, which interpolation reproduces exactly. This is the
//! paper's idea (section 5.2: the error is the second-order term) made a
//! bound by enclosing the derivatives over the whole cell.
//!
//! A quantity is carried as `s + p`: `s` smooth, with interval enclosures
//! of its first and pure second derivatives, and `p` anything with
//! `|p| <= P` (a kink such as `max(x, 0)` across 0, a quantity known only
//! as an interval). Interpolating `s + p` is off by at most
//! `sum_i 1/2 max |s_ii| + 2 P`.

// Named methods, as `affine`'s forms: the chains read like its own.
#![allow(clippy::should_implement_trait)]

use crate::bounded::affine::SYMBOLS;

/// A closed interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iv {
    pub lo: f64,
    pub hi: f64,
}

impl Iv {
    pub const ZERO: Iv = Iv { lo: 0.0, hi: 0.0 };

    pub fn point(x: f64) -> Iv {
        Iv { lo: x, hi: x }
    }

    /// The interval between two values in either order.
    pub fn span(a: f64, b: f64) -> Iv {
        Iv {
            lo: a.min(b),
            hi: a.max(b),
        }
    }

    pub fn add(self, o: Iv) -> Iv {
        Iv {
            lo: self.lo + o.lo,
            hi: self.hi + o.hi,
        }
    }

    pub fn scale(self, k: f64) -> Iv {
        Iv::span(self.lo * k, self.hi * k)
    }

    pub fn mul(self, o: Iv) -> Iv {
        let p = [self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi];
        Iv {
            lo: p.iter().copied().fold(f64::INFINITY, f64::min),
            hi: p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }

    /// `x^2` (not `x * x`, which forgets that both factors are one value).
    pub fn square(self) -> Iv {
        let (a, b) = (self.lo * self.lo, self.hi * self.hi);
        if self.lo <= 0.0 && self.hi >= 0.0 {
            Iv { lo: 0.0, hi: a.max(b) }
        } else {
            Iv::span(a, b)
        }
    }

    /// The largest magnitude.
    pub fn mag(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }
}

/// The derivative part of a quantity `s + p` (see the module's comment).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jet {
    /// `d s / d e_i` over the cell.
    pub d: [Iv; SYMBOLS],
    /// `d^2 s / d e_i^2` over the cell.
    pub dd: [Iv; SYMBOLS],
    /// The bound `P` on `|p|`.
    pub p: f64,
    /// Whether the quantity was derived from the cell's coordinates or an
    /// interval; a constant's jet (and a shaft cull's, `Aff::plain`) is
    /// not computed at all: the shaft culls do most of the arithmetic and
    /// need only the ranges.
    pub live: bool,
}

impl Jet {
    pub const ZERO: Jet = Jet {
        d: [Iv::ZERO; SYMBOLS],
        dd: [Iv::ZERO; SYMBOLS],
        p: 0.0,
        live: false,
    };

    /// The cell coordinate `i` of half-width `half`.
    pub fn coordinate(i: usize, half: f64) -> Jet {
        let mut j = Jet::ZERO;
        j.d[i] = Iv::point(half);
        j.live = true;
        j
    }

    /// A value known only to lie within `radius` of a constant.
    pub fn perturbation(radius: f64) -> Jet {
        Jet {
            p: radius,
            live: true,
            ..Jet::ZERO
        }
    }

    pub fn add(self, o: Jet) -> Jet {
        if !o.live {
            return self;
        }
        if !self.live {
            return o;
        }
        Jet {
            d: std::array::from_fn(|i| self.d[i].add(o.d[i])),
            dd: std::array::from_fn(|i| self.dd[i].add(o.dd[i])),
            p: self.p + o.p,
            live: true,
        }
    }

    pub fn scale(self, k: f64) -> Jet {
        if !self.live {
            return self;
        }
        Jet {
            d: self.d.map(|x| x.scale(k)),
            dd: self.dd.map(|x| x.scale(k)),
            p: self.p * k.abs(),
            live: true,
        }
    }

    /// The product of `a` and `b`, whose smooth parts range over `ra` and
    /// `rb`: `s_a s_b` smooth (Leibniz), `s_a p_b + p_a s_b + p_a p_b`
    /// perturbation.
    pub fn mul(a: &Jet, ra: Iv, b: &Jet, rb: Iv) -> Jet {
        if !a.live && !b.live {
            return Jet::ZERO;
        }
        Jet {
            d: std::array::from_fn(|i| a.d[i].mul(rb).add(ra.mul(b.d[i]))),
            dd: std::array::from_fn(|i| a.dd[i].mul(rb).add(a.d[i].mul(b.d[i]).scale(2.0)).add(ra.mul(b.dd[i]))),
            p: ra.mag() * b.p + a.p * rb.mag() + a.p * b.p,
            live: true,
        }
    }

    /// `g(s + p)` for `g` C^2 over every value `s` and `s + p` take, with
    /// `g'` in `g1` and `g''` in `g2` there: `g(s)` smooth (chain rule),
    /// `g(s + p) - g(s)` (at most `max |g'| P`) perturbation.
    pub fn smooth(u: &Jet, g1: Iv, g2: Iv) -> Jet {
        if !u.live {
            return Jet::ZERO;
        }
        Jet {
            d: u.d.map(|x| g1.mul(x)),
            dd: std::array::from_fn(|i| g2.mul(u.d[i].square()).add(g1.mul(u.dd[i]))),
            p: g1.mag() * u.p,
            live: true,
        }
    }

    /// The interpolation error bound: `sum_i 1/2 max |s_ii| + 2 P`.
    pub fn error(&self) -> f64 {
        0.5 * self.dd.iter().map(|x| x.mag()).sum::<f64>() + 2.0 * self.p
    }
}
