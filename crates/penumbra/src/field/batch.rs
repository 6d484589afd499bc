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
//! defaults, with either positional interpolation), through the very same
//! functions (`sphere_to_square`, `OctahedralGrid::bilinear`, `rim_clamp`,
//! `concentric_square`, `texel_taps`), which are written without early
//! exits so that they vectorise. Rust never fuses a multiply and an add,
//! so vector lanes round as the scalar code does; `tests` hold every lane to the scalar answer bit for bit. Other
//! storages and mappings keep the scalar path (`Batchable::of`).

use glam::Vec3;

use super::directions::{DirectionMapping, rim_clamp};
use super::lookup::{Positional, interval, texel_taps, unit_entry};
use super::positions::OctahedralGrid;
use super::query::FieldQuery;
use super::storage::FieldData;
use crate::geom::sampling::{Frame, concentric_square};

/// Rays per batch.
pub const LANES: usize = 16;

/// Unit directions of up to `LANES` rays, one array per coordinate.
#[derive(Debug, Clone, Copy, Default)]
pub struct Directions {
    pub x: [f32; LANES],
    pub y: [f32; LANES],
    pub z: [f32; LANES],
}

impl Directions {
    /// Lane i as a vector.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }
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
    #[cfg(test)]
    pub fn lane(&self, i: usize) -> super::lookup::FieldTrace {
        use super::lookup::FieldTrace;
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
            let [_, s1, disc] = interval(oc, field.radius, d.lane(i));
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
        let grid = &field.params.grid;
        let corners = match self.positional {
            Positional::Bilinear => Corners::bilinear(grid, &entry),
            Positional::Nearest => Corners::nearest(grid, &entry),
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
            let [s0, s1, disc] = interval(oc, radius, d.lane(i));
            e.outside[i] = disc < 0.0 || s1 <= 0.0;
            e.s0[i] = s0;
            e.s1[i] = s1;
            let p = unit_entry(center, radius, o, d.lane(i), s0);
            (e.p.x[i], e.p.y[i], e.p.z[i]) = (p.x, p.y, p.z);
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
    fn nearest(grid: &OctahedralGrid, entry: &Entry) -> Corners {
        let mut c = Corners {
            maps: [[0; LANES]; 4],
            weights: [[0.0; LANES]; 4],
            used: 1,
        };
        for i in 0..LANES {
            c.maps[0][i] = grid.nearest(entry.p.lane(i));
            c.weights[0][i] = 1.0;
        }
        c
    }

    /// The four samples around each entry point, bilinearly weighted
    /// (`OctahedralGrid::bilinear`).
    #[inline(always)]
    fn bilinear(grid: &OctahedralGrid, entry: &Entry) -> Corners {
        let mut c = Corners {
            maps: [[0; LANES]; 4],
            weights: [[0.0; LANES]; 4],
            used: 4,
        };
        for i in 0..LANES {
            for (k, (m, w)) in grid.bilinear(entry.p.lane(i)).into_iter().enumerate() {
                c.maps[k][i] = m;
                c.weights[k][i] = w;
            }
        }
        c
    }
}

/// One map's four texels around each ray's local direction, and their
/// bilinear weights (`map_taps` of `locate` for concentric maps).
struct Taps {
    index: [[u32; LANES]; 4],
    weight: [[f32; LANES]; 4],
}

impl Taps {
    #[inline(always)]
    fn of(frames: &[Frame], res: u32, maps: &[u32; LANES], d: &Directions) -> Taps {
        let mut taps = Taps {
            index: [[0; LANES]; 4],
            weight: [[0.0; LANES]; 4],
        };
        for (i, &m) in maps.iter().enumerate() {
            debug_assert!((m as usize) < frames.len());
            // SAFETY: `wrap` and `nearest` clamp every map below the grid's
            // count, the frames' length (`FieldQuery::new`). Unchecked, the
            // loop has no exit and vectorises.
            let f = unsafe { frames.get_unchecked(m as usize) };
            let dir = d.lane(i);
            let [x, y] = rim_clamp(dir.dot(f.t), dir.dot(f.b));
            for (k, (index, weight)) in texel_taps(concentric_square(x, y), res).into_iter().enumerate() {
                taps.index[k][i] = index;
                taps.weight[k][i] = weight;
            }
        }
        taps
    }
}

#[cfg(test)]
mod tests;
