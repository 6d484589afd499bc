//! Directional samples: how the (s, t) texels of a displacement map cover
//! the hemisphere of inward directions (section 3.4 of the paper, its
//! Figures 3 and 5), each with its inverse for the lookup.
//!
//! Directions are local to a positional sample, +z along the inward normal
//! (towards the sphere's centre). (s, t) are continuous texel coordinates in
//! [0, 1]^2; texel (a, b) of an S x S map is centred at ((a + 0.5)/S,
//! (b + 0.5)/S).
//!
//! - `Concentric` (default): Shirley and Chiu's concentric map of the square
//!   to the disk, lifted to the hemisphere by Malley's method. Equal-area
//!   texels in the cosine-weighted measure, low distortion, continuous.
//! - `Polar`: s = theta / (pi/2), t = phi / (2 pi). Texels crowd at the pole
//!   (the row s = 0 is one direction) and t wraps around.
//! - `Rejection`: the square [-1, 1]^2 itself, texels outside the unit disk
//!   unused (21.5% of them), the rest lifted by Malley's method. Unused texels
//!   are filled with the value of the grazing direction at the disk's rim in
//!   their direction, so that bilinear filtering near the rim stays sane.

use std::f32::consts::{FRAC_PI_2, TAU};

use glam::Vec3;
use serde::Serialize;

use crate::geom::sampling::{concentric_disk, concentric_square};

/// How the texels of a displacement map cover the hemisphere of directions
/// towards the sphere's centre (section 3.4 of the paper, Figures 3 and 5). A
/// map point (s, t) lies in [0, 1]^2; directions are local to the positional
/// sample, +z along the inward normal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum DirectionMapping {
    /// Equal-area texels, low distortion, continuous (the default).
    ///
    /// Shirley and Chiu's concentric map of the square to the disk, lifted to
    /// the hemisphere by Malley's method: texels of equal area in the
    /// cosine-weighted measure.
    Concentric,
    /// Polar angles: texels crowd at the pole.
    ///
    /// s = theta / (pi/2), t = phi / (2 pi): the row s = 0 is a single
    /// direction and t wraps around.
    Polar,
    /// The square lifted by Malley's method; 21.5% of texels unused.
    ///
    /// The texels of [-1, 1]^2 outside the unit disk (1 - pi/4, about 21.5%)
    /// hold the value of the grazing direction at the rim, so that bilinear
    /// filtering near the rim stays sane.
    Rejection,
}

crate::choice!(DirectionMapping { Concentric = "concentric", Polar = "polar", Rejection = "rejection" });

impl DirectionMapping {
    /// Every mapping, in the order of their codes.
    pub const ALL: [DirectionMapping; 3] = [Self::Concentric, Self::Polar, Self::Rejection];

    /// The code stored in `.dfield` files and passed to the GPU.
    pub fn code(self) -> u32 {
        match self {
            Self::Concentric => 0,
            Self::Polar => 1,
            Self::Rejection => 2,
        }
    }

    /// The mapping whose `code` is `code`, or None for an unknown code.
    pub fn from_code(code: u32) -> Option<DirectionMapping> {
        Self::ALL.into_iter().find(|m| m.code() == code)
    }

    /// The name the command line and reports use: `concentric`, `polar` or
    /// `rejection`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Concentric => "concentric",
            Self::Polar => "polar",
            Self::Rejection => "rejection",
        }
    }

    /// The local direction of the map point (s, t), and whether the texel is
    /// a real sample (false for rejection's texels outside the disk, whose
    /// direction is then the rim's).
    pub fn direction(self, s: f32, t: f32) -> (Vec3, bool) {
        match self {
            Self::Concentric => {
                let [x, y] = concentric_disk(s, t);
                (lift(x, y), true)
            }
            Self::Polar => {
                let (theta, phi) = (s * FRAC_PI_2, t * TAU);
                let (st, ct) = theta.sin_cos();
                let (sp, cp) = phi.sin_cos();
                (Vec3::new(st * cp, st * sp, ct), true)
            }
            Self::Rejection => {
                let (x, y) = (2.0 * s - 1.0, 2.0 * t - 1.0);
                let r2 = x * x + y * y;
                if r2 <= 1.0 {
                    (lift(x, y), true)
                } else {
                    let r = r2.sqrt();
                    (Vec3::new(x / r, y / r, 0.0), false)
                }
            }
        }
    }

    /// The map point (s, t) of a local direction (z >= 0; a direction below
    /// the horizon is taken at the horizon).
    pub fn locate(self, d: Vec3) -> [f32; 2] {
        match self {
            Self::Concentric => {
                let [x, y] = rim_clamp(d.x, d.y);
                concentric_square(x, y)
            }
            Self::Polar => {
                let theta = d.z.clamp(0.0, 1.0).acos();
                let mut phi = d.y.atan2(d.x);
                if phi < 0.0 {
                    phi += TAU;
                }
                [theta / FRAC_PI_2, phi / TAU]
            }
            Self::Rejection => {
                let [x, y] = rim_clamp(d.x, d.y);
                [(x + 1.0) * 0.5, (y + 1.0) * 0.5]
            }
        }
    }

    /// Whether t wraps around (polar's phi).
    pub fn wraps_t(self) -> bool {
        self == Self::Polar
    }
}

/// Malley's lift of a disk point to the hemisphere.
fn lift(x: f32, y: f32) -> Vec3 {
    Vec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt())
}

/// A direction's disk point, pulled onto the unit disk if rounding (or a
/// direction slightly below the horizon) put it outside. The square root
/// is taken either way (a select, which `field::batch` vectorises).
#[inline(always)]
pub(super) fn rim_clamp(x: f32, y: f32) -> [f32; 2] {
    let r2 = x * x + y * y;
    let r = r2.sqrt();
    if r2 > 1.0 { [x / r, y / r] } else { [x, y] }
}

/// Fraction of a rejection map's texels that are unused: 1 - pi/4 in the
/// limit.
#[cfg(test)]
pub fn rejection_unused_fraction(res: u32) -> f64 {
    let mut unused = 0u64;
    for b in 0..res {
        for a in 0..res {
            let (s, t) = ((a as f32 + 0.5) / res as f32, (b as f32 + 0.5) / res as f32);
            unused += !DirectionMapping::Rejection.direction(s, t).1 as u64;
        }
    }
    unused as f64 / (res as f64 * res as f64)
}

/// pi, for the limit quoted in the docs.
#[cfg(test)]
pub const REJECTION_UNUSED_LIMIT: f64 = 1.0 - std::f64::consts::PI / 4.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_mapping_inverts_at_texel_centres() {
        for m in DirectionMapping::ALL {
            let n = 32;
            let mut worst = 0.0f32;
            for b in 0..n {
                for a in 0..n {
                    let (s, t) = ((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                    let (d, real) = m.direction(s, t);
                    assert!((d.length() - 1.0).abs() < 1e-5 && d.z >= 0.0, "{m:?} ({s}, {t}) -> {d}");
                    if real {
                        let [s2, t2] = m.locate(d);
                        worst = worst.max((s - s2).abs()).max((t - t2).abs());
                    }
                }
            }
            assert!(worst < 1e-4, "{m:?}: worst round trip {worst}");
        }
    }

    #[test]
    fn seams_centre_and_horizon() {
        let c = DirectionMapping::Concentric;
        assert_eq!(c.locate(Vec3::Z), [0.5, 0.5]);
        // The concentric map's seams (|a| = |b|) and the horizon stay inside the square.
        for d in [
            Vec3::new(1.0, 1.0, 0.0).normalize(),
            Vec3::new(-1.0, 1.0, 1e-7).normalize(),
            Vec3::X,
        ] {
            for m in DirectionMapping::ALL {
                let [s, t] = m.locate(d);
                assert!(
                    (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t),
                    "{m:?} {d}: ({s}, {t})"
                );
            }
        }
        // Below the horizon: taken at the horizon, never NaN.
        for m in DirectionMapping::ALL {
            let [s, t] = m.locate(Vec3::new(0.6, 0.0, -0.8));
            assert!(s.is_finite() && t.is_finite(), "{m:?}");
        }
    }

    #[test]
    fn rejection_wastes_a_fifth() {
        let f = rejection_unused_fraction(64);
        assert!((f - REJECTION_UNUSED_LIMIT).abs() < 0.01, "{f}");
    }
}
