//! Field lookups sixteen rays at a time: `FieldQuery::trace` for the rays of
//! one point (same origin), written as branch-free passes over the rays so
//! that the compiler turns each pass into vector instructions of whatever
//! instruction set `Isa::best()` names, and so that the sixteen rays' 256
//! texel reads are issued together instead of each ray waiting for its own
//! (the maps miss the caches). The caller compiles the passes in an
//! instruction set by calling them inside a `simd::dispatch` kernel.
//!
//! Every lane computes exactly what the scalar lookup computes for its ray
//! (`lookup::trace_in`, 8-bit maps and concentric directions, the
//! defaults, with either positional interpolation): the same IEEE operations in the same order,
//! a branch turned into computing both sides and selecting one. Rust never
//! fuses a multiply and an add, so vector lanes round as the scalar code
//! does; `tests` hold every lane to the scalar answer bit for bit. Other
//! storages and mappings keep the scalar path (`Batchable::of`).

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

use glam::Vec3;

use super::directions::DirectionMapping;
use super::lookup::{FieldTrace, Positional};
use super::query::FieldQuery;
use super::storage::FieldData;
use crate::sampling::Frame;
use crate::sampling::atan::atan_unit;

/// Rays per batch.
pub const LANES: usize = 16;

/// Unit directions of up to `LANES` rays, one array per coordinate.
#[derive(Debug, Clone, Copy, Default)]
pub struct Directions {
    pub x: [f32; LANES],
    pub y: [f32; LANES],
    pub z: [f32; LANES],
}

/// What a batch of rays found, lane by lane (bit i = lane i).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Traces {
    /// The line misses the sphere, or the sphere lies behind the origin.
    pub outside: u16,
    /// The origin lies inside the sphere (lanes not `outside`).
    pub inside: u16,
    /// A surface ahead of the origin, at `t`.
    pub hit: u16,
    /// The estimated surface lies behind the origin.
    pub hidden: u16,
    pub t: [f32; LANES],
}

impl Traces {
    /// Lane i as the scalar lookup reports it.
    pub fn lane(&self, i: usize) -> FieldTrace {
        let bit = |m: u16| m >> i & 1 == 1;
        if bit(self.outside) {
            FieldTrace::Outside
        } else if bit(self.hit) {
            FieldTrace::Hit {
                t: self.t[i],
                inside: bit(self.inside),
            }
        } else {
            FieldTrace::Miss {
                inside: bit(self.inside),
                hidden: bit(self.hidden),
            }
        }
    }
}

/// A field whose lookups the batch path computes: 8-bit maps (the default
/// storage) and concentric directions (the default mapping), either
/// positional interpolation.
pub struct Batchable<'q, 'f> {
    query: &'q FieldQuery<'f>,
    maps: &'f [u8],
    positional: Positional,
}

impl<'q, 'f> Batchable<'q, 'f> {
    pub fn of(query: &'q FieldQuery<'f>, positional: Positional) -> Option<Self> {
        let field = query.field;
        match &field.data {
            FieldData::U8(maps)
                if field.params.directions == DirectionMapping::Concentric
                    && maps.len() == field.params.maps() * field.params.texels_per_map()
                    && query.frames().len() == field.params.maps() =>
            {
                Some(Batchable {
                    query,
                    maps,
                    positional,
                })
            }
            _ => None,
        }
    }

    /// The lanes whose rays from `o` along `d` enter the sphere ahead of
    /// the origin (those `trace` does not call `outside`): the rays worth
    /// a batch, most of a point's rays missing a small caster's sphere.
    #[inline(always)]
    pub fn enters(&self, o: Vec3, d: &Directions) -> u16 {
        let field = self.query.field;
        let oc = o - field.center;
        let mut mask = 0u16;
        for i in 0..LANES {
            let [_, s1, disc] = interval(oc, field.radius, d.x[i], d.y[i], d.z[i]);
            mask |= u16::from(!(disc < 0.0 || s1 <= 0.0)) << i;
        }
        mask
    }

    /// The rays from `o` (object space) along `d` (unit, object space).
    /// `#[inline(always)]`, so that it compiles in its caller's instruction
    /// set: call it inside a `simd::dispatch` kernel.
    #[inline(always)]
    pub fn trace(&self, o: Vec3, d: &Directions) -> Traces {
        let field = self.query.field;
        let entry = Entry::of(field.center, field.radius, o, d);
        let side = field.params.grid.side;
        let corners = match self.positional {
            Positional::Bilinear => Corners::bilinear(side, &entry),
            Positional::Nearest => Corners::nearest(side, &entry),
        };
        let mut coverage = [0.0f32; LANES];
        let mut weighted = [0.0f32; LANES];
        let used = corners.maps.iter().zip(&corners.weights).take(corners.used);
        for (maps, weights) in used {
            let taps = Taps::of(self.query.frames(), field.params.res, maps, d);
            let texels = field.params.texels_per_map();
            let mut map_coverage = [0.0f32; LANES];
            let mut map_weighted = [0.0f32; LANES];
            // `read_taps`: a tap votes with its weight where its texel hits.
            for (index, weight) in taps.index.iter().zip(&taps.weight) {
                for i in 0..LANES {
                    let at = maps[i] as usize * texels + index[i] as usize;
                    debug_assert!(at < self.maps.len());
                    // SAFETY: `wrap` clamps the map below the grid's count,
                    // `Taps::of` the texel below res^2, and the field holds
                    // count * res^2 bytes (checked when it was made or read).
                    // Unchecked, the loop has no exit and vectorises.
                    let q = unsafe { *self.maps.get_unchecked(at) };
                    let w = if q < 255 { weight[i] } else { 0.0 };
                    map_coverage[i] += w;
                    // `U8_DISTANCE[q]`, computed: the same quotient, and no table
                    // lookup in the vector loop.
                    map_weighted[i] += w * (q as f32 / 255.0);
                }
            }
            // `Sample::add`; a map of weight 0 (which the scalar lookup
            // skips) adds +0, which leaves the sums as they were.
            for i in 0..LANES {
                coverage[i] += weights[i] * map_coverage[i];
                weighted[i] += weights[i] * map_weighted[i];
            }
        }
        entry.classify(field.radius, &coverage, &weighted)
    }
}

/// Where each ray enters the sphere (`DisplacementField::entry`).
struct Entry {
    s0: [f32; LANES],
    s1: [f32; LANES],
    /// Unit entry point relative to the centre.
    p: Directions,
    outside: [bool; LANES],
}

impl Entry {
    #[inline(always)]
    fn of(center: Vec3, radius: f32, o: Vec3, d: &Directions) -> Entry {
        let oc = o - center;
        let mut e = Entry {
            s0: [0.0; LANES],
            s1: [0.0; LANES],
            p: Directions::default(),
            outside: [false; LANES],
        };
        for i in 0..LANES {
            let (x, y, z) = (d.x[i], d.y[i], d.z[i]);
            let [s0, s1, disc] = interval(oc, radius, x, y, z);
            e.outside[i] = disc < 0.0 || s1 <= 0.0;
            e.s0[i] = s0;
            e.s1[i] = s1;
            let px = (o.x + s0 * x - center.x) / radius;
            let py = (o.y + s0 * y - center.y) / radius;
            let pz = (o.z + s0 * z - center.z) / radius;
            let len = (px * px + py * py + pz * pz).sqrt();
            let inv = 1.0 / len;
            let some = len > 0.0;
            e.p.x[i] = if some { px * inv } else { 0.0 };
            e.p.y[i] = if some { py * inv } else { 0.0 };
            e.p.z[i] = if some { pz * inv } else { 1.0 };
        }
        e
    }

    /// `trace_in`'s verdict from the votes.
    #[inline(always)]
    fn classify(&self, radius: f32, coverage: &[f32; LANES], weighted: &[f32; LANES]) -> Traces {
        let mut out = Traces::default();
        for i in 0..LANES {
            let t = self.s0[i] + weighted[i] / coverage[i] * 2.0 * radius;
            let votes = coverage[i] >= 0.5;
            let hit = votes && t < self.s1[i] && t > 0.0;
            let hidden = votes && t < self.s1[i] && t <= 0.0;
            let bit = 1u16 << i;
            if self.outside[i] {
                out.outside |= bit;
                continue;
            }
            if self.s0[i] < 0.0 {
                out.inside |= bit;
            }
            if hit {
                out.hit |= bit;
                out.t[i] = t;
            }
            if hidden {
                out.hidden |= bit;
            }
        }
        out
    }
}

/// The positional samples read for each entry point, and their weights:
/// the first `used` of four.
struct Corners {
    maps: [[u32; LANES]; 4],
    weights: [[f32; LANES]; 4],
    used: usize,
}

impl Corners {
    /// The nearest sample, weight 1 (`OctahedralGrid::nearest`; the scalar
    /// lookup takes its map's sample as it is, and 0 + 1 x is x).
    #[inline(always)]
    fn nearest(side: u32, entry: &Entry) -> Corners {
        let mut c = Corners {
            maps: [[0; LANES]; 4],
            weights: [[0.0; LANES]; 4],
            used: 1,
        };
        let n = side as f32;
        let last = side as i32 - 1;
        for i in 0..LANES {
            let [u, v] = sphere_to_square(entry.p.x[i], entry.p.y[i], entry.p.z[i]);
            let gx = (u + 1.0) * 0.5 * n - 0.5;
            let gy = (v + 1.0) * 0.5 * n - 0.5;
            let a = (floor(gx + 0.5) as i32).clamp(0, last) as u32;
            let b = (floor(gy + 0.5) as i32).clamp(0, last) as u32;
            c.maps[0][i] = a + b * side;
            c.weights[0][i] = 1.0;
        }
        c
    }

    /// The four samples around each entry point, bilinearly weighted
    /// (`OctahedralGrid::bilinear`).
    #[inline(always)]
    fn bilinear(side: u32, entry: &Entry) -> Corners {
        let mut c = Corners {
            maps: [[0; LANES]; 4],
            weights: [[0.0; LANES]; 4],
            used: 4,
        };
        let n = side as f32;
        for i in 0..LANES {
            let [u, v] = sphere_to_square(entry.p.x[i], entry.p.y[i], entry.p.z[i]);
            let gx = (u + 1.0) * 0.5 * n - 0.5;
            let gy = (v + 1.0) * 0.5 * n - 0.5;
            let (x0, y0) = (floor(gx), floor(gy));
            let (fx, fy) = (gx - x0, gy - y0);
            let (a, b) = (x0 as i32, y0 as i32);
            let n = side as i32;
            c.maps[0][i] = wrap(n, a, b);
            c.maps[1][i] = wrap(n, a + 1, b);
            c.maps[2][i] = wrap(n, a, b + 1);
            c.maps[3][i] = wrap(n, a + 1, b + 1);
            c.weights[0][i] = (1.0 - fx) * (1.0 - fy);
            c.weights[1][i] = fx * (1.0 - fy);
            c.weights[2][i] = (1.0 - fx) * fy;
            c.weights[3][i] = fx * fy;
        }
        c
    }
}

/// One map's four texels around each ray's local direction, and their
/// bilinear weights (`map_taps` of `locate`).
struct Taps {
    index: [[u32; LANES]; 4],
    weight: [[f32; LANES]; 4],
}

impl Taps {
    // The lanes index the frames through `maps` and four arrays in step.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn of(frames: &[Frame], res: u32, maps: &[u32; LANES], d: &Directions) -> Taps {
        let mut taps = Taps {
            index: [[0; LANES]; 4],
            weight: [[0.0; LANES]; 4],
        };
        let r = res as f32;
        for i in 0..LANES {
            debug_assert!((maps[i] as usize) < frames.len());
            // SAFETY: `wrap` clamps every map below the grid's count, the
            // frames' length (`FieldQuery::new`). Unchecked, as above.
            let f = unsafe { frames.get_unchecked(maps[i] as usize) };
            let dir = Vec3::new(d.x[i], d.y[i], d.z[i]);
            let [x, y] = rim_clamp(dir.dot(f.t), dir.dot(f.b));
            let [s, t] = concentric_square(x, y);
            let x = clamp(s * r - 0.5, r - 1.0);
            let y = clamp(t * r - 0.5, r - 1.0);
            let (a0, b0) = (x as u32, y as u32);
            let (fx, fy) = (x - a0 as f32, y - b0 as f32);
            let (a1, b1) = ((a0 + 1).min(res - 1), (b0 + 1).min(res - 1));
            taps.index[0][i] = b0 * res + a0;
            taps.index[1][i] = b0 * res + a1;
            taps.index[2][i] = b1 * res + a0;
            taps.index[3][i] = b1 * res + a1;
            taps.weight[0][i] = (1.0 - fx) * (1.0 - fy);
            taps.weight[1][i] = fx * (1.0 - fy);
            taps.weight[2][i] = (1.0 - fx) * fy;
            taps.weight[3][i] = fx * fy;
        }
        taps
    }
}

// The scalar functions below are those of `positions`, `directions` and
// `sampling::concentric` with their branches written as selects.

/// `lookup::sphere_interval` of the ray from `centre + oc` along (x, y, z):
/// [s_entry, s_exit, discriminant], the line missing the sphere where the
/// discriminant is negative.
#[inline(always)]
fn interval(oc: Vec3, radius: f32, x: f32, y: f32, z: f32) -> [f32; 3] {
    let b = oc.x * x + oc.y * y + oc.z * z;
    let (hx, hy, hz) = (oc.x - b * x, oc.y - b * y, oc.z - b * z);
    let disc = radius * radius - (hx * hx + hy * hy + hz * hz);
    let q = disc.max(0.0).sqrt();
    [-b - q, -b + q, disc]
}

/// `positions::sphere_to_square`.
#[inline(always)]
fn sphere_to_square(dx: f32, dy: f32, dz: f32) -> [f32; 2] {
    let (x, y) = (dx.abs(), dy.abs());
    let r = (1.0 - dz.abs()).max(0.0).sqrt();
    // One ratio, one arctangent: both sides of the branch evaluate the
    // polynomial at the ratio they would pick.
    let x_major = x >= y;
    let angle = atan_unit(if x_major { y / x } else { x / y }) / FRAC_PI_2;
    let phi = if x == 0.0 && y == 0.0 {
        0.0
    } else if x_major {
        angle
    } else {
        1.0 - angle
    };
    let v = phi * r;
    let u = r - v;
    let below = dz < 0.0;
    let (u, v) = (if below { 1.0 - v } else { u }, if below { 1.0 - u } else { v });
    [u.copysign(dx), v.copysign(dy)]
}

/// `x.clamp(0.0, hi)` (hi >= 0) without its assertion, which would keep
/// the loop from vectorising: NaN stays NaN as there.
#[inline(always)]
fn clamp(x: f32, hi: f32) -> f32 {
    if x < 0.0 {
        0.0
    } else if x > hi {
        hi
    } else {
        x
    }
}

/// `positions::floor`.
#[inline(always)]
fn floor(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t > x { t - 1.0 } else { t }
}

/// `OctahedralGrid::wrap`.
#[inline(always)]
fn wrap(n: i32, i: i32, j: i32) -> u32 {
    let (i, j) = if i < 0 {
        (-i - 1, n - 1 - j)
    } else if i >= n {
        (2 * n - 1 - i, n - 1 - j)
    } else {
        (i, j)
    };
    let (i, j) = if j < 0 {
        (n - 1 - i, -j - 1)
    } else if j >= n {
        (n - 1 - i, 2 * n - 1 - j)
    } else {
        (i, j)
    };
    (i.clamp(0, n - 1) + j.clamp(0, n - 1) * n) as u32
}

/// `directions::rim_clamp`.
#[inline(always)]
fn rim_clamp(x: f32, y: f32) -> [f32; 2] {
    let r2 = x * x + y * y;
    let r = r2.sqrt();
    if r2 > 1.0 { [x / r, y / r] } else { [x, y] }
}

/// `sampling::concentric_square`.
#[inline(always)]
fn concentric_square(x: f32, y: f32) -> [f32; 2] {
    let r = (x * x + y * y).sqrt();
    let ax = r.copysign(x);
    let by = r.copysign(y);
    let x_major = x.abs() >= y.abs();
    let angle = atan_unit(if x_major { y / x } else { x / y });
    let (a, b) = if x_major {
        (ax, ax * angle / FRAC_PI_4)
    } else {
        (by * angle / FRAC_PI_4, by)
    };
    if r == 0.0 {
        [0.5, 0.5]
    } else {
        [(a + 1.0) * 0.5, (b + 1.0) * 0.5]
    }
}

#[cfg(test)]
mod tests;
