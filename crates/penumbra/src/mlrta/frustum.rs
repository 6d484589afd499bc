//! What MLRTA knows about a group of rays: condition (3) of section 4.1.
//!
//! A group has a common origin `o` and directions whose components share
//! their signs axis by axis. On the axis-aligned plane `x_a = s` a ray of the
//! group crosses at `x_b = o_b + (s - o_a) * d_b / d_a`, so the interval of
//! slopes `d_b / d_a` over the group bounds the crossing rectangle exactly
//! (condition 3: "a rectangle inside this plane which contains all possible
//! ray/plane intersection points"); the interval of `1 / d_a` bounds the
//! parameter `t` of the crossings. Everything MLRTA decides for the group is
//! derived from these intervals, never from particular rays (section 3.3), so
//! it holds for every ray of the group whether or not it is known yet.
//!
//! Every interval is widened by `SLACK` (relative) so that decisions made with
//! it enclose what each ray's own arithmetic computes: the packet then visits
//! a superset of the cells each of its rays would.

use glam::{Vec3, Vec3A};

use crate::accel::kdtree::TRAVERSAL_SLACK;
use crate::geom::aabb::Aabb;

/// Relative widening of the group's intervals.
pub const SLACK: f32 = 4.0 * TRAVERSAL_SLACK;

/// `x` moved towards minus infinity by `SLACK` of its magnitude.
#[inline]
pub fn down(x: f32) -> f32 {
    x - x.abs() * SLACK
}

/// `x` moved towards plus infinity by `SLACK` of its magnitude.
#[inline]
pub fn up(x: f32) -> f32 {
    x + x.abs() * SLACK
}

/// A closed interval `[lo, hi]` of f32.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower end.
    pub lo: f32,
    /// Upper end; below `lo` for an empty interval.
    pub hi: f32,
}

impl Interval {
    /// The empty interval `[+inf, -inf]`, the start of a running hull
    /// (`include`, `hull`).
    pub const EMPTY: Interval = Interval {
        lo: f32::INFINITY,
        hi: f32::NEG_INFINITY,
    };

    /// Grows the interval to hold `x`.
    pub fn include(&mut self, x: f32) {
        self.lo = self.lo.min(x);
        self.hi = self.hi.max(x);
    }

    /// `self * s` for a scalar `s` (the ends swap when `s < 0`).
    #[inline]
    pub fn scale(self, s: f32) -> Interval {
        let (a, b) = (self.lo * s, self.hi * s);
        if a <= b {
            Interval { lo: a, hi: b }
        } else {
            Interval { lo: b, hi: a }
        }
    }

    /// `self + x`: both ends moved by `x`.
    #[inline]
    pub fn offset(self, x: f32) -> Interval {
        Interval {
            lo: self.lo + x,
            hi: self.hi + x,
        }
    }

    /// The smallest interval holding both.
    #[inline]
    pub fn hull(self, o: Interval) -> Interval {
        Interval {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    /// Widened by `SLACK` relative to its magnitude.
    pub fn widened(self) -> Interval {
        Interval {
            lo: down(self.lo),
            hi: up(self.hi),
        }
    }
}

/// Which children of an interior node a group may enter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Children {
    /// The child on the low side of the split plane (`x_axis <= split`).
    pub below: bool,
    /// The child on the high side of the split plane (`x_axis >= split`).
    pub above: bool,
}

/// Accumulates a group's intervals ray by ray (SIMD min/max over the three
/// axes at once; this runs for every ray of every tile and packet).
pub struct FrustumBounds {
    class: Option<u32>,
    inv_lo: Vec3A,
    inv_hi: Vec3A,
    /// `slope_lo[a]`: per b, the minimum of `d_b / d_a` (a = b unused).
    slope_lo: [Vec3A; 3],
    slope_hi: [Vec3A; 3],
}

impl Default for FrustumBounds {
    fn default() -> Self {
        FrustumBounds {
            class: None,
            inv_lo: Vec3A::INFINITY,
            inv_hi: Vec3A::NEG_INFINITY,
            slope_lo: [Vec3A::INFINITY; 3],
            slope_hi: [Vec3A::NEG_INFINITY; 3],
        }
    }
}

impl FrustumBounds {
    /// Adds direction `d` with its reciprocal `inv`; `None` if it has a zero
    /// component or another sign class than the rays before it.
    #[inline]
    pub fn add(&mut self, d: Vec3, inv: Vec3) -> Option<()> {
        let (d, inv) = (Vec3A::from(d), Vec3A::from(inv));
        if d.cmpeq(Vec3A::ZERO).any() || !d.is_finite() {
            return None;
        }
        let class = d.is_negative_bitmask();
        if *self.class.get_or_insert(class) != class {
            return None;
        }
        self.inv_lo = self.inv_lo.min(inv);
        self.inv_hi = self.inv_hi.max(inv);
        // Slopes as d_b * (1 / d_a): the intervals are widened anyway.
        for a in 0..3 {
            let s = d * inv[a];
            self.slope_lo[a] = self.slope_lo[a].min(s);
            self.slope_hi[a] = self.slope_hi[a].max(s);
        }
        Some(())
    }

    /// Bounds already reduced over a group's rays (by `Packet::new_in`, in
    /// SIMD lanes): sign class `class` (bit a set when component a is
    /// negative), the extremes of `1 / d_a` and, per a, of `d_b * (1 / d_a)`,
    /// exactly as `add` accumulates them ray by ray.
    pub fn from_extremes(class: u32, inv: [[f32; 3]; 2], slope_lo: [[f32; 3]; 3], slope_hi: [[f32; 3]; 3]) -> Self {
        FrustumBounds {
            class: Some(class),
            inv_lo: Vec3A::from_array(inv[0]),
            inv_hi: Vec3A::from_array(inv[1]),
            slope_lo: [
                Vec3A::from_array(slope_lo[0]),
                Vec3A::from_array(slope_lo[1]),
                Vec3A::from_array(slope_lo[2]),
            ],
            slope_hi: [
                Vec3A::from_array(slope_hi[0]),
                Vec3A::from_array(slope_hi[1]),
                Vec3A::from_array(slope_hi[2]),
            ],
        }
    }

    /// The frustum of the rays added, from `origin` and ending at `t_max`,
    /// its intervals widened by `SLACK`; `None` if no ray was added.
    pub fn finish(self, origin: Vec3, t_max: f32) -> Option<Frustum> {
        let class = self.class?;
        let interval = |lo: f32, hi: f32| Interval { lo, hi }.widened();
        Some(Frustum {
            origin,
            positive: [class & 1 == 0, class & 2 == 0, class & 4 == 0],
            inv: std::array::from_fn(|a| interval(self.inv_lo[a], self.inv_hi[a])),
            // `d_a / d_a` is 1 (and unused): not reduced (`Packet::new_in`).
            slope: std::array::from_fn(|a| {
                std::array::from_fn(|b| {
                    if a == b {
                        Interval { lo: 1.0, hi: 1.0 }
                    } else {
                        interval(self.slope_lo[a][b], self.slope_hi[a][b])
                    }
                })
            }),
            t_max,
        })
    }
}

/// A group of rays with a common origin and same-sign directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frustum {
    /// The rays' common origin.
    pub origin: Vec3,
    /// Per axis, whether the directions' components are positive.
    pub positive: [bool; 3],
    /// Per axis, the interval of `1 / d_a` (widened).
    pub inv: [Interval; 3],
    /// `slope[a][b]`: the interval of `d_b / d_a` (widened); exactly 1 for
    /// a = b, where it is unused.
    pub slope: [[Interval; 3]; 3],
    /// Rays end at `t_max` (in units of their directions).
    pub t_max: f32,
}

/// The sign class of a direction: bit a set when component a is negative;
/// `None` when a component is zero (or not finite) and the ray can join no
/// group.
#[inline]
pub fn sign_class(d: Vec3) -> Option<u8> {
    // On the bits, without a branch per component (this runs for every ray
    // of every packet): a component is usable when its magnitude bits are
    // neither zero (either zero) nor those of an infinity or a NaN.
    let mut usable = true;
    let mut class = 0u8;
    for (a, c) in d.to_array().into_iter().enumerate() {
        let bits = c.to_bits();
        let magnitude = bits & 0x7fff_ffff;
        usable &= magnitude != 0 && magnitude < 0x7f80_0000;
        class |= ((bits >> 31) as u8) << a;
    }
    usable.then_some(class)
}

impl Frustum {
    /// The group of rays from `origin` along `dirs`, or `None` if the
    /// directions do not all share one sign class (a diverging group).
    pub fn new(origin: Vec3, dirs: impl IntoIterator<Item = Vec3>, t_max: f32) -> Option<Frustum> {
        let mut bounds = FrustumBounds::default();
        for d in dirs {
            bounds.add(d, d.recip())?;
        }
        bounds.finish(origin, t_max)
    }

    /// The group of a pinhole camera's rays through a rectangle of pixels,
    /// from its four corner rays (unit directions, as `Camera` makes them).
    ///
    /// A direction is linear in the pixel up to its normalisation, so each
    /// slope `d_b / d_a` is a linear-fractional function of the pixel and
    /// takes its extremes at the corners. `|1 / d_a|` of a unit direction,
    /// `sqrt(1 + sum_b (d_b / d_a)^2)`, is largest at a corner too, but
    /// smallest where the rays come closest to axis a, which may lie on an
    /// edge of the rectangle: there a ray crosses the planes `x_a = s`
    /// sooner than any corner ray (a 32x32 tile at the top of a 1024x1024
    /// image, `corner_frusta_hold_every_ray_of_their_tile`: by 1.8e-6
    /// relative beyond the frustum's slack). The least `|1 / d_a|` is
    /// bounded from below by each slope's least magnitude instead.
    pub fn from_corners(origin: Vec3, corners: [Vec3; 4], t_max: f32) -> Option<Frustum> {
        let mut f = Frustum::new(origin, corners, t_max)?;
        for a in 0..3 {
            let mut sum = 1.0f32;
            for b in (0..3).filter(|&b| b != a) {
                let s = f.slope[a][b];
                let least = if s.lo <= 0.0 && s.hi >= 0.0 {
                    0.0
                } else {
                    s.lo.abs().min(s.hi.abs())
                };
                sum += least * least;
            }
            // Twice the slack: the sum and the root round (by 1e-7).
            let least = down(down(sum.sqrt()));
            let inv = &mut f.inv[a];
            if f.positive[a] {
                inv.lo = inv.lo.min(least);
            } else {
                inv.hi = inv.hi.max(-least);
            }
        }
        Some(f)
    }

    /// The interval of `t` at which the group crosses the plane `x_a = s`.
    #[inline]
    pub fn plane_t(&self, a: usize, s: f32) -> Interval {
        self.inv[a].scale(s - self.origin[a])
    }

    /// The interval of coordinate `b` where the group crosses `x_a = s`.
    #[inline]
    pub fn crossing(&self, a: usize, s: f32, b: usize) -> Interval {
        self.slope[a][b].scale(s - self.origin[a]).offset(self.origin[b])
    }

    /// Inverse frustum culling at an interior node (section 3.3, assessment
    /// (1)): which children of `cell`, split at `x_axis = split`, the group
    /// may enter, given that it may enter `cell`.
    ///
    /// The group crosses the split plane inside the rectangle of `crossing`.
    /// Where that rectangle lies entirely beyond the cell in another axis b,
    /// the rays cross outside the cell; moving along `d_b` they were even
    /// farther out before the crossing, or get farther out after it, so the
    /// child on that side of the plane cannot be entered. Rays that do not
    /// reach the plane (behind the origin, or beyond `t_max`) stay on the
    /// origin's side.
    pub fn split_children(&self, axis: usize, split: f32, cell: &Aabb) -> Children {
        let o = self.origin[axis];
        let pos = self.positive[axis];
        // Side the rays start on ("near") and the side they cross into.
        let near_below = o < split || (o == split && !pos);
        let side = |near: bool| {
            if near == near_below {
                Children {
                    below: true,
                    above: false,
                }
            } else {
                Children {
                    below: false,
                    above: true,
                }
            }
        };
        let t = self.plane_t(axis, split);
        if t.hi <= 0.0 || t.lo > self.t_max * (1.0 + SLACK) {
            return side(true);
        }
        let (mut near, mut far) = (true, true);
        for b in [(axis + 1) % 3, (axis + 2) % 3] {
            let r = self.crossing(axis, split, b);
            if r.hi < cell.min[b] {
                // Crosses below the cell in b.
                if self.positive[b] { near = false } else { far = false }
            } else if r.lo > cell.max[b] {
                if self.positive[b] { far = false } else { near = false }
            }
        }
        let n = side(true);
        let f = side(false);
        Children {
            below: (near && n.below) || (far && f.below),
            above: (near && n.above) || (far && f.above),
        }
    }

    /// Per axis, the intervals of `t` at which the group enters and leaves
    /// the slab of `b` along that axis.
    #[inline]
    fn slabs(&self, b: &Aabb) -> ([Interval; 3], [Interval; 3]) {
        let mut entry = [Interval::EMPTY; 3];
        let mut exit = [Interval::EMPTY; 3];
        for a in 0..3 {
            let (near, far) = if self.positive[a] {
                (b.min[a], b.max[a])
            } else {
                (b.max[a], b.min[a])
            };
            entry[a] = self.plane_t(a, near);
            exit[a] = self.plane_t(a, far);
        }
        (entry, exit)
    }

    /// Whether any ray of the group may pass through the box (section 3.3,
    /// equation (2), for all three pairs of axes at once, and the group's
    /// range of `t`): false when every ray enters some slab only after it
    /// has left another one.
    pub fn may_hit_box(&self, b: &Aabb) -> bool {
        let (latest_entry, earliest_exit) = self.box_interval(b);
        down(latest_entry) <= up(earliest_exit) && up(earliest_exit) >= 0.0
    }

    /// `(latest entry, earliest exit)` of the box over the group: a lower
    /// bound of every ray's entry and an upper bound of every ray's exit
    /// (capped at `t_max`).
    pub fn box_interval(&self, b: &Aabb) -> (f32, f32) {
        let (entry, exit) = self.slabs(b);
        let latest_entry = entry[0].lo.max(entry[1].lo).max(entry[2].lo);
        let earliest_exit = exit[0].hi.min(exit[1].hi).min(exit[2].hi).min(self.t_max);
        (latest_entry, earliest_exit)
    }

    /// Whether every ray of the group passes through the box before `t_max`:
    /// some face of the box facing the group contains the whole crossing
    /// rectangle of its plane, ahead of the origin.
    pub fn all_enter_box(&self, b: &Aabb) -> bool {
        (0..3).any(|a| {
            let s = if self.positive[a] { b.min[a] } else { b.max[a] };
            self.all_cross_rectangle(a, s, b)
        })
    }

    /// The four extreme directions of the group: the corners of its box of
    /// slopes relative to its dominant axis. Every direction of the group is a
    /// convex combination of them (up to scale), so a convex target that all
    /// four hit from the origin is hit by every ray of the group.
    pub fn corner_directions(&self) -> [Vec3; 4] {
        let a = self.dominant_axis();
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let s = if self.positive[a] { 1.0 } else { -1.0 };
        let corner = |kb: f32, kc: f32| {
            let mut d = Vec3::ZERO;
            d[a] = s;
            d[b] = kb * s;
            d[c] = kc * s;
            d
        };
        let (sb, sc) = (self.slope[a][b], self.slope[a][c]);
        [
            corner(sb.lo, sc.lo),
            corner(sb.lo, sc.hi),
            corner(sb.hi, sc.lo),
            corner(sb.hi, sc.hi),
        ]
    }

    /// A corner direction's `t` is in its own units, where its component on
    /// the dominant axis a is 1: it is the hit's offset from the origin along
    /// a. Over the group that offset is largest at a corner, so a ray of the
    /// group (whose direction has any length) reaches a hit at offset `t` by
    /// `t * max |1 / d_a|`.
    pub fn corner_t_to_ray_t(&self, t: f32) -> f32 {
        let a = self.dominant_axis();
        up(t * self.inv[a].lo.abs().max(self.inv[a].hi.abs()))
    }

    /// The dominant axis: the narrowest interval of 1/d.
    fn dominant_axis(&self) -> usize {
        (0..3)
            .min_by(|&x, &y| {
                let w = |i: usize| self.inv[i].lo.abs().min(self.inv[i].hi.abs());
                w(x).total_cmp(&w(y))
            })
            .unwrap_or(0)
    }

    /// Whether every ray crosses the plane `x_a = s` inside the rectangle of
    /// `b` in the two other axes, at `0 < t < t_max`.
    pub fn all_cross_rectangle(&self, a: usize, s: f32, b: &Aabb) -> bool {
        let t = self.plane_t(a, s);
        if !(t.lo > 0.0 && t.hi < self.t_max) {
            return false;
        }
        [(a + 1) % 3, (a + 2) % 3].iter().all(|&c| {
            let r = self.crossing(a, s, c);
            r.lo >= b.min[c] && r.hi <= b.max[c]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;

    /// A pinhole camera's tile, bounded by its four corner rays, holds every
    /// ray of the tile: slopes and reciprocals (the least `|1 / d_a|` can be
    /// a ray's on the tile's edge, not a corner's: the test failed so
    /// before `from_corners` bounded it from the slopes).
    #[test]
    fn corner_frusta_hold_every_ray_of_their_tile() {
        let (size, tile) = (1024u32, 32u32);
        let mut checked = 0;
        for (eye, target) in [
            (Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO),
            // The z axis near the image's centre (tiles it passes through
            // diverge; their neighbours' rays come close to it).
            (Vec3::new(0.0, 0.0, 3.0), Vec3::new(0.0371, -0.0219, 0.0)),
            (Vec3::new(-2.0, 0.5, 0.25), Vec3::new(1.0, 0.5, 0.25)),
            (Vec3::new(0.3, 4.0, 0.2), Vec3::new(0.3, -1.0, 0.2)),
            (Vec3::new(1.0, 2.0, 3.0), Vec3::new(-0.2, 0.1, -0.4)),
        ] {
            let camera = Camera {
                eye,
                target,
                fov_degrees: 60.0,
            };
            let rays = camera.primary_rays(size, size);
            for ty in (0..size).step_by(tile as usize) {
                for tx in (0..size).step_by(tile as usize) {
                    let (x1, y1) = (tx + tile - 1, ty + tile - 1);
                    let corners =
                        [(tx, ty), (x1, ty), (tx, y1), (x1, y1)].map(|(x, y)| rays[(y * size + x) as usize].d());
                    let Some(f) = Frustum::from_corners(eye, corners, f32::INFINITY) else {
                        continue;
                    };
                    for y in ty..=y1 {
                        for x in tx..=x1 {
                            let d = rays[(y * size + x) as usize].d();
                            for a in 0..3 {
                                let inv = f.inv[a];
                                assert!(
                                    inv.lo <= 1.0 / d[a] && 1.0 / d[a] <= inv.hi,
                                    "tile ({tx}, {ty}) of the camera at {eye}: 1/d{a} of pixel ({x}, {y}) is {} outside {inv:?}",
                                    1.0 / d[a]
                                );
                                for b in (0..3).filter(|&b| b != a) {
                                    let s = f.slope[a][b];
                                    assert!(
                                        s.lo <= d[b] / d[a] && d[b] / d[a] <= s.hi,
                                        "slope {a}{b} of pixel ({x}, {y})"
                                    );
                                }
                            }
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 4_000_000, "{checked} rays checked");
    }

    #[test]
    fn sign_class_on_the_bits_is_the_definition() {
        let values = crate::accel::kdtree::test_rng::SPECIAL_F32;
        for &x in &values {
            for &y in &values {
                for &z in &values {
                    let d = Vec3::new(x, y, z);
                    let usable = d.to_array().iter().all(|&c| c != 0.0 && c.is_finite());
                    let class = (x < 0.0) as u8 | ((y < 0.0) as u8) << 1 | ((z < 0.0) as u8) << 2;
                    assert_eq!(sign_class(d), usable.then_some(class), "{d:?}");
                }
            }
        }
    }

    fn grid_dirs(center: Vec3, spread: f32, n: usize) -> Vec<Vec3> {
        let mut v = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let u = (i as f32 / (n - 1) as f32 - 0.5) * spread;
                let w = (j as f32 / (n - 1) as f32 - 0.5) * spread;
                v.push(center + Vec3::new(u, w, 0.37 * u));
            }
        }
        v
    }

    #[test]
    fn diverging_groups_are_refused() {
        let o = Vec3::ZERO;
        assert!(Frustum::new(o, [Vec3::new(1.0, 1.0, 1.0), Vec3::new(-1.0, 1.0, 1.0)], 1.0).is_none());
        assert!(Frustum::new(o, [Vec3::new(1.0, 0.0, 1.0)], 1.0).is_none());
        let f = Frustum::new(o, [Vec3::new(-1.0, 2.0, -3.0), Vec3::new(-2.0, 1.0, -1.0)], 1.0).unwrap();
        assert_eq!(f.positive, [false, true, false]);
    }

    /// Everything the frustum claims must hold for each ray, tested by
    /// clipping each ray against random boxes and split planes.
    #[test]
    fn decisions_are_conservative_for_every_ray() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut culled_boxes, mut culled_children, mut all_enter) = (0, 0, 0);
        for _ in 0..300 {
            let origin = Vec3::new(rnd(), rnd(), rnd()) * 4.0 - 2.0;
            let center = Vec3::new(rnd() + 0.2, rnd() + 0.2, rnd() + 0.2) * Vec3::new(1.0, -1.0, 1.0);
            let dirs = grid_dirs(center, rnd() * 0.3, 5);
            let Some(f) = Frustum::new(origin, dirs.iter().copied(), 10.0) else {
                continue;
            };
            for _ in 0..50 {
                let lo = Vec3::new(rnd(), rnd(), rnd()) * 6.0 - 3.0;
                let cell = Aabb::new(lo, lo + Vec3::new(rnd(), rnd(), rnd()) * 3.0 + Vec3::splat(0.01));
                let hits = |b: &Aabb| dirs.iter().any(|&d| b.clip_ray(origin, d, 0.0, 10.0).is_some());
                if !f.may_hit_box(&cell) {
                    culled_boxes += 1;
                }
                if hits(&cell) {
                    assert!(f.may_hit_box(&cell), "culled a box a ray passes through");
                    let axis = (rnd() * 3.0) as usize % 3;
                    let split = cell.min[axis] + rnd() * (cell.max[axis] - cell.min[axis]);
                    let mut below = cell;
                    below.max[axis] = split;
                    let mut above = cell;
                    above.min[axis] = split;
                    let c = f.split_children(axis, split, &cell);
                    if !(c.below && c.above) {
                        culled_children += 1;
                    }
                    assert!(c.below || !hits(&below), "a ray enters the culled child below");
                    assert!(c.above || !hits(&above), "a ray enters the culled child above");
                }
                if f.all_enter_box(&cell) {
                    all_enter += 1;
                    for &d in &dirs {
                        assert!(cell.clip_ray(origin, d, 0.0, 10.0).is_some(), "claimed all rays enter");
                    }
                }
            }
        }
        // The test only means something if the frustum decides things.
        println!("culled boxes {culled_boxes}, culled children {culled_children}, all-enter {all_enter}");
        assert!(culled_boxes > 100 && culled_children > 100 && all_enter > 10);
    }
}
