//! The exact SAH sweep of one axis of a cell (Wald and Havran 2006): the
//! events (triangle bounds) a cell's split is chosen among, counted on each
//! side of every event when there are few, swept in sorted order otherwise,
//! both choosing the same plane; and the SAH itself with its constants
//! hoisted.

use super::Prim;

/// The SAH of one cell and axis with its constants hoisted.
pub(super) struct Sah {
    pub(super) lo: f32,
    pub(super) hi: f32,
    pub(super) constant: f32,
    pub(super) per_length: f32,
    pub(super) traversal: f32,
    pub(super) intersection: f32,
    pub(super) empty_factor: f32,
}

impl Sah {
    #[inline]
    pub(super) fn cost(&self, pos: f32, n_below: usize, n_above: usize) -> f32 {
        // Through u32 (counts of a cell's triangles fit): usize -> f32 is a
        // branchy sequence on x86-64, u32 -> f32 one instruction; same value.
        self.cost_of_counts(pos, n_below as u32 as f32, n_above as u32 as f32)
    }

    /// `cost` with the counts as floats (exact below 2^24), branch-free
    /// for the counted sweep's vector lanes.
    #[inline(always)]
    fn cost_of_counts(&self, pos: f32, n_below: f32, n_above: f32) -> f32 {
        let p_below = self.constant + self.per_length * (pos - self.lo);
        let p_above = self.constant + self.per_length * (self.hi - pos);
        let factor = if n_below == 0.0 || n_above == 0.0 {
            self.empty_factor
        } else {
            1.0
        };
        self.traversal + self.intersection * factor * (p_below * n_below + p_above * n_above)
    }
}

/// The events an exact sweep looks at: all, or those in bins `first..=last`
/// of the binning `binned_split` left in `Events::bins`, with the
/// below/above counts of the triangles left of them.
#[derive(Clone, Copy)]
pub(super) struct Window {
    pub(super) bins: Option<(u8, u8)>,
    pub(super) counts_before: (usize, usize),
}

impl Window {
    /// Every event of a cell of `n` triangles.
    pub(super) fn all(n: usize) -> Window {
        Window {
            bins: None,
            counts_before: (0, n),
        }
    }
}

/// Up to this many events, `swept_split` counts the triangles on each side
/// of every event (O(n^2), branch-free, vectorised) instead of sorting them:
/// cells of up to 16 triangles have at most 32 events. Sorting them (mostly
/// insertion sort) and sweeping was 25% of the bunny's build.
pub(super) const COUNTED_EVENTS: usize = 32;

/// One axis's events in a cell, as order-preserving integer keys (`key`),
/// by kind, reused from cell to cell. For the counted sweep each list is
/// padded with `i32::MAX` (no position's key) to a multiple of `LANES`.
#[derive(Default)]
pub(super) struct Events {
    starts: Vec<i32>,
    ends: Vec<i32>,
    planar: Vec<i32>,
    /// The lists' lengths without the padding.
    pub(super) lens: [usize; 3],
    /// Each triangle's bins of its low and high bound (`binned_split`).
    pub(super) bins: Vec<[u8; 2]>,
    /// Candidate planes of `counted_best_lanes`, padded like the lists.
    candidates: Vec<i32>,
    sorted: Vec<u64>,
}

/// The best plane of a sweep: position, planar triangles below, cost.
pub(super) type Best = Option<(f32, bool, f32)>;

/// Width of the counted sweep's comparisons.
const LANES: usize = 8;

impl Events {
    pub(super) fn len(&self) -> usize {
        self.lens.iter().sum()
    }

    pub(super) fn gather(&mut self, prims: &[Prim], axis: usize, window: &Window) {
        self.starts.clear();
        self.ends.clear();
        self.planar.clear();
        match window.bins {
            None => {
                for p in prims {
                    let (lo, hi) = (p.bounds.min[axis], p.bounds.max[axis]);
                    if lo == hi {
                        self.planar.push(key(lo));
                    } else {
                        self.starts.push(key(lo));
                        self.ends.push(key(hi));
                    }
                }
            }
            Some((first, last)) => {
                let inside = |b: u8| b >= first && b <= last;
                for (p, &[b0, b1]) in prims.iter().zip(&self.bins) {
                    let (lo, hi) = (p.bounds.min[axis], p.bounds.max[axis]);
                    if lo == hi {
                        if inside(b0) {
                            self.planar.push(key(lo));
                        }
                    } else {
                        if inside(b0) {
                            self.starts.push(key(lo));
                        }
                        if inside(b1) {
                            self.ends.push(key(hi));
                        }
                    }
                }
            }
        }
        self.lens = [self.starts.len(), self.ends.len(), self.planar.len()];
    }

    pub(super) fn pad(&mut self) {
        for list in [&mut self.starts, &mut self.ends, &mut self.planar] {
            list.resize(list.len().next_multiple_of(LANES), i32::MAX);
        }
    }

    /// At each event position p: triangles starting (or planar) before p
    /// are below, those ending (or planar) at or before p are not above,
    /// those planar at p go to either side. `before`: the counts left of
    /// the window.
    pub(super) fn counted_best(&self, sah: &Sah, (lo, hi): (f32, f32), before: (usize, usize)) -> Best {
        let [ns, ne, np] = self.lens;
        let candidates = self.starts[..ns]
            .iter()
            .chain(&self.ends[..ne])
            .chain(&self.planar[..np]);
        // (key, planar below, cost); a cost of infinity is never chosen.
        let mut best = (i32::MAX, true, f32::INFINITY);
        for &p in candidates {
            let pos = from_key(p);
            if !(pos > lo && pos < hi) {
                continue;
            }
            let mut n_below = before.0 + count(&self.starts, |k| k < p);
            let mut n_above = before.1 - count(&self.ends, |k| k <= p);
            let mut planar = 0;
            if np > 0 {
                n_below += count(&self.planar, |k| k < p);
                n_above -= count(&self.planar, |k| k <= p);
                planar = count(&self.planar, |k| k == p);
            }
            for planar_below in [true, false] {
                let cost = if planar_below {
                    sah.cost(pos, n_below + planar, n_above)
                } else {
                    sah.cost(pos, n_below, n_above + planar)
                };
                // The sweep's choice: lowest cost, then lowest position,
                // then planar triangles below.
                let (bp, bb, bc) = best;
                if cost < bc || (cost == bc && (p < bp || (p == bp && planar_below && !bb))) {
                    best = (p, planar_below, cost);
                }
                if planar == 0 {
                    break;
                }
            }
        }
        (best.2 < f32::INFINITY).then(|| (from_key(best.0), best.1, best.2))
    }

    /// `counted_best` without planar triangles, `LANES` candidate planes at
    /// a time and without a branch: the counts of the candidates of a lane
    /// group, their costs (infinite outside the open cell, as padding is),
    /// then the lowest cost and its lowest position.
    pub(super) fn counted_best_lanes(&mut self, sah: &Sah, before: (usize, usize)) -> Best {
        let [ns, ne, _] = self.lens;
        let (starts, ends) = (&self.starts, &self.ends);
        let candidates = &mut self.candidates;
        candidates.clear();
        candidates.extend_from_slice(&starts[..ns]);
        candidates.extend_from_slice(&ends[..ne]);
        candidates.resize(candidates.len().next_multiple_of(LANES), i32::MAX);
        let mut best = (f32::INFINITY, i32::MAX);
        for group in candidates.chunks_exact(LANES) {
            let keys: [i32; LANES] = std::array::from_fn(|j| group[j]);
            let mut below = [0i32; LANES];
            let mut ended = [0i32; LANES];
            for &k in starts {
                for j in 0..LANES {
                    below[j] += (k < keys[j]) as i32;
                }
            }
            for &k in ends {
                for j in 0..LANES {
                    ended[j] += (k <= keys[j]) as i32;
                }
            }
            let cost: [f32; LANES] = std::array::from_fn(|j| {
                let pos = from_key(keys[j]);
                let n_below = (before.0 as i32).wrapping_add(below[j]) as f32;
                let n_above = (before.1 as i32).wrapping_sub(ended[j]) as f32;
                let c = sah.cost_of_counts(pos, n_below, n_above);
                if pos > sah.lo && pos < sah.hi { c } else { f32::INFINITY }
            });
            for j in 0..LANES {
                if cost[j] < best.0 || (cost[j] == best.0 && keys[j] < best.1) {
                    best = (cost[j], keys[j]);
                }
            }
        }
        (best.0 < f32::INFINITY).then(|| (from_key(best.1), true, best.0))
    }

    /// The sweep of the events sorted by position (Wald and Havran 2006).
    pub(super) fn sorted_best(&mut self, sah: &Sah, (lo, hi): (f32, f32), before: (usize, usize)) -> Best {
        const END: u64 = 0;
        const PLANAR: u64 = 1;
        const START: u64 = 2;
        let wide = |k: i32| ((k as u32) ^ 0x8000_0000) as u64;
        let events = &mut self.sorted;
        events.clear();
        let [ns, ne, np] = self.lens;
        events.extend(self.ends[..ne].iter().map(|&k| wide(k) << 2 | END));
        events.extend(self.planar[..np].iter().map(|&k| wide(k) << 2 | PLANAR));
        events.extend(self.starts[..ns].iter().map(|&k| wide(k) << 2 | START));
        events.sort_unstable();
        let mut best: Best = None;
        let (mut n_below, mut n_above) = before;
        let mut i = 0;
        while i < events.len() {
            let k = events[i] >> 2;
            let pos = from_key((k as u32 ^ 0x8000_0000) as i32);
            let mut count = [0usize; 3];
            while i < events.len() && events[i] >> 2 == k {
                count[(events[i] & 3) as usize] += 1;
                i += 1;
            }
            let (ends, planar, starts) = (count[0], count[1], count[2]);
            n_above -= planar + ends;
            if pos > lo && pos < hi {
                for planar_below in [true, false] {
                    let cost = if planar_below {
                        sah.cost(pos, n_below + planar, n_above)
                    } else {
                        sah.cost(pos, n_below, n_above + planar)
                    };
                    if best.is_none_or(|(_, _, c)| cost < c) {
                        best = Some((pos, planar_below, cost));
                    }
                    if planar == 0 {
                        break;
                    }
                }
            }
            n_below += starts + planar;
        }
        best
    }
}

/// How many of `keys` (a multiple of `LANES` long) satisfy `pred`, in
/// whole vectors: the lists are too short for the compiler's own
/// vectorisation of a loop of any length to reach its vector part.
#[inline(always)]
fn count(keys: &[i32], pred: impl Fn(i32) -> bool) -> usize {
    let mut acc = [0u32; LANES];
    for chunk in keys.chunks_exact(LANES) {
        for (a, &k) in acc.iter_mut().zip(chunk) {
            *a += pred(k) as u32;
        }
    }
    acc.iter().sum::<u32>() as usize
}

/// Maps an f32 to an i32 whose order is the float order (-0 < +0), so
/// that event positions compare as integers (vectorised, and -0 and +0
/// stay two positions as in a sort).
fn key(x: f32) -> i32 {
    let bits = x.to_bits() as i32;
    bits ^ (((bits >> 31) as u32) >> 1) as i32
}

fn from_key(k: i32) -> f32 {
    f32::from_bits((k ^ (((k >> 31) as u32) >> 1) as i32) as u32)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::geom::aabb::Aabb;

    #[test]
    fn keys_order_like_floats() {
        let xs = [-f32::INFINITY, -2.5, -1e-30, -0.0, 0.0, 1e-30, 3.0, f32::INFINITY];
        for w in xs.windows(2) {
            assert!(key(w[0]) < key(w[1]), "{} {}", w[0], w[1]);
        }
        for x in xs {
            assert_eq!(from_key(key(x)).to_bits(), x.to_bits());
        }
    }

    /// The counted sweeps choose the plane the sorted sweep chooses, cost
    /// ties (repeated positions on a coarse grid) and planar triangles
    /// included.
    #[test]
    fn counted_sweeps_agree_with_the_sorted_sweep() {
        let mut rng = crate::accel::kdtree::test_rng::Rng(0x9e37_79b9_7f4a_7c15);
        let mut next = |m: u32| (rng.next_u64() % m as u64) as f32;
        let sah = Sah {
            lo: 0.0,
            hi: 16.0,
            constant: 0.3,
            per_length: 0.05,
            traversal: 1.0,
            intersection: 1.5,
            empty_factor: 0.8,
        };
        let window = Window::all;
        for case in 0..2000 {
            let n = 1 + case % 16;
            let prims: Vec<Prim> = (0..n)
                .map(|i| {
                    let (a, b) = (next(17), next(17));
                    let planar = case % 3 == 0 && next(4) == 0.0;
                    let (lo, hi) = if planar { (a, a) } else { (a.min(b), a.max(b) + 1.0) };
                    let bounds = Aabb::new(Vec3::new(lo, 0.0, 0.0), Vec3::new(hi.min(16.0), 1.0, 1.0));
                    Prim { bounds, tri: i as u32 }
                })
                .collect();
            let mut events = Events::default();
            events.gather(&prims, 0, &window(n));
            let sorted = events.sorted_best(&sah, (0.0, 16.0), (0, n));
            events.pad();
            let counted = events.counted_best(&sah, (0.0, 16.0), (0, n));
            assert_eq!(counted, sorted, "case {case}");
            if events.lens[2] == 0 {
                assert_eq!(events.counted_best_lanes(&sah, (0, n)), sorted, "case {case}");
            }
        }
    }
}
