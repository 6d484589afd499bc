//! Closest-hit packets of up to 16 rays sharing an origin through the wide
//! BVH: a camera's 4x4 pixel blocks (`trace --accel bvh`).
//!
//! The walk of `occlusion` with a best hit per lane instead of a flag: the
//! packet enters a node with a mask of lanes, each of the eight boxes is
//! clipped against all of them at once (the plane's distance from the
//! shared origin is one scalar per child, times each lane's reciprocal
//! direction), up to each lane's best t so far; the children some lane
//! enters are visited nearest box first, each with its lanes and their
//! entry distances, which a popped entry compares again with the lanes'
//! best (they may have shrunk meanwhile). Leaves test their triangles in
//! all active lanes with the kd-tree packets' lane arithmetic
//! (`kdtree::occlusion::Shear`), and a lane keeps a triangle under the
//! single ray's rule: a smaller t, or the same t and a smaller index.
//!
//! Each lane's answer is its single ray's (`Accel::closest_hit` with
//! `Structure::Bvh`), bit
//! for bit: the box test is the single ray's arithmetic with the same
//! slack, a lane enters every box its single ray enters (its best is never
//! below the single ray's final hit, which lies in all of them), and the
//! closest hit does not depend on the order candidates are met in. A hit
//! closer than `Bvh8::contact` is the kd-tree's answer, as for single rays.

use std::mem::MaybeUninit;

use glam::Vec3;
use rayon::prelude::*;

use super::occlusion::corner;
use super::traverse::{entered, is_contact, narrow};
use super::{Bvh8, LEAF_BIT, Node8, SLACK, WIDTH};
use crate::accel::kdtree::KdTree;
use crate::accel::kdtree::occlusion::{LANES, Rays, common_axes};
use crate::geom::ray::{Hit, Ray, flush_subnormal};
use crate::geom::simd::{Isa, Kernel, Lanes, Mask, dispatch, set_lanes};

/// Stack entries: as the single-ray walk's, at most seven per level.
const STACK_SIZE: usize = 1024;
const STACK_MASK: usize = STACK_SIZE - 1;

/// What a packet walk did, summed over packets: the figures `trace` reports
/// per 4x4 packet.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct PacketCounts {
    /// Packets traced.
    pub packets: u64,
    /// Interior nodes visited (each tests eight boxes against the lanes).
    pub nodes: u64,
    /// Leaves visited.
    pub leaves: u64,
    /// Triangle tests (one triangle against any number of lanes counts once).
    pub triangle_tests: u64,
    /// Rays traced one by one: packets with a zero direction component or
    /// without a common origin, and contacts handed to the kd-tree.
    pub single_rays: u64,
}

impl std::ops::AddAssign for PacketCounts {
    fn add_assign(&mut self, o: Self) {
        self.packets += o.packets;
        self.nodes += o.nodes;
        self.leaves += o.leaves;
        self.triangle_tests += o.triangle_tests;
        self.single_rays += o.single_rays;
    }
}

/// The closest hits with `0 < t < t_max` of the rays `dirs` (at most 16)
/// from `origin`, in lanes `V`: `hits[r]` for `dirs[r]`, equal to the
/// single ray's closest hit through `bvh` (`Accel::closest_hit` with
/// `Structure::Bvh`). `tree` is the kd-tree `bvh` was built from: a hit
/// at a contact (`Bvh8::contact`) is its answer.
#[inline(always)]
pub fn closest_in<V: Lanes>(
    bvh: &Bvh8,
    tree: &KdTree,
    origin: Vec3,
    dirs: &[Vec3],
    t_max: f32,
    counts: &mut PacketCounts,
) -> [Hit; LANES] {
    assert!(dirs.len() <= LANES, "at most {LANES} rays per packet");
    if dirs.is_empty() {
        return [Hit::MISS; LANES];
    }
    let mut columns = Columns::new();
    for d in dirs {
        columns.push(flush_subnormal(*d).to_array());
    }
    columns.repeat_last();
    closest_columns::<V>(bvh, tree, origin, &columns, t_max, counts)
}

/// Up to 16 directions as three columns (component a of ray r at
/// `d[a][r]`), the way the lanes load them; lanes from `n` on repeat the
/// last ray.
struct Columns {
    d: [[f32; LANES]; 3],
    n: usize,
}

impl Columns {
    #[inline(always)]
    fn new() -> Self {
        Columns {
            d: [[0.0; LANES]; 3],
            n: 0,
        }
    }

    /// Adds a ray's direction as the next lane.
    #[inline(always)]
    fn push(&mut self, d: [f32; 3]) {
        let r = self.n;
        (self.d[0][r], self.d[1][r], self.d[2][r]) = (d[0], d[1], d[2]);
        self.n += 1;
    }

    /// Lanes `n..16` copy lane `n - 1` (`Rays::new`'s padding).
    #[inline(always)]
    fn repeat_last(&mut self) {
        let last = self.n - 1;
        for c in &mut self.d {
            let x = c[last];
            c[self.n..].fill(x);
        }
    }

    #[inline(always)]
    fn dir(&self, r: usize) -> Vec3 {
        Vec3::new(self.d[0][r], self.d[1][r], self.d[2][r])
    }

    #[inline(always)]
    fn lanes<V: Lanes>(&self) -> [V; 3] {
        [
            V::from_array(self.d[0]),
            V::from_array(self.d[1]),
            V::from_array(self.d[2]),
        ]
    }
}

/// `closest_in` for directions already in columns (`n >= 1`).
#[inline(always)]
fn closest_columns<V: Lanes>(
    bvh: &Bvh8,
    tree: &KdTree,
    origin: Vec3,
    columns: &Columns,
    t_max: f32,
    counts: &mut PacketCounts,
) -> [Hit; LANES] {
    let mut hits = [Hit::MISS; LANES];
    let n = columns.n;
    counts.packets += 1;
    let d = columns.lanes::<V>();
    let zero = V::splat(0.0);
    // Written out, not a closure (see `kdtree::occlusion`'s helpers).
    let unusable = (d[0].eq(zero).or(d[0].ne(d[0])))
        .or(d[1].eq(zero).or(d[1].ne(d[1])))
        .or(d[2].eq(zero).or(d[2].ne(d[2])));
    if unusable.any() {
        // A zero direction component: its slabs need the NaN rules of the
        // single-ray walk, which takes such packets ray by ray (as it takes
        // NaN directions).
        for (r, h) in hits[..n].iter_mut().enumerate() {
            *h = bvh.closest_hit(tree, origin, columns.dir(r), t_max);
        }
        counts.single_rays += n as u64;
        return hits;
    }
    // The root's boxes first, before the lanes' reciprocals and shear
    // constants are made: a packet that misses them all (the background
    // around an object) is done here.
    let frustum = Frustum::of_directions(origin, &d);
    let root = frustum.enters::<V>(&bvh.nodes[0], t_max);
    if root.0 == 0 {
        counts.nodes += 1;
        return hits;
    }
    let mut rays = Rays::<V>::from_columns(&tree.bounds, bvh.frame_scale, origin, d, n, t_max)
        .expect("no direction component is zero");
    // Every lane walks from the root, as its single ray does: the root's
    // boxes (padded) decide, not the scene's unpadded bounds; a lane those
    // bounds reject (`Rays`'s clip, the kd-tree's) misses, as its single
    // ray does (`traverse::dispatch`).
    let clipped = rays.live;
    rays.live = ((1u32 << n) - 1) as u16;
    walk(bvh, &rays, &frustum, root, &mut hits, counts);
    for (r, h) in hits[..n].iter_mut().enumerate() {
        if clipped & (1 << r) == 0 {
            *h = Hit::MISS;
        } else if h.is_hit() && is_contact(bvh, h.t, columns.dir(r)) {
            *h = tree.closest_hit(origin, columns.dir(r), t_max);
            counts.single_rays += 1;
        }
    }
    hits
}

/// The packet's walk (no direction component is zero: every product of a
/// plane's distance and a reciprocal is a number or an infinity).
#[inline(always)]
fn walk<V: Lanes>(
    bvh: &Bvh8,
    rays: &Rays<V>,
    frustum: &Frustum,
    root: (u32, [f32; WIDTH]),
    hits: &mut [Hit; LANES],
    counts: &mut PacketCounts,
) {
    let o = rays.origin.to_array();
    let inv = rays.inv;
    let fo = rays.frame_origin.to_array();
    let common = common_axes(&rays.shear, rays.live);
    let zero = V::splat(0.0);
    let (lo_slack, hi_slack) = (V::splat(1.0 - SLACK), V::splat(1.0 + SLACK));
    let inv_scale = V::splat(1.0 / rays.scale);
    // Each lane's best t, in the triangle test's frame and along the ray
    // (the frame's scale is a power of two: one is the other exactly), and
    // the latest over the lanes, which bounds the boxes worth entering.
    let live = V::M::from_bits(rays.live);
    let unused = V::splat(f32::NEG_INFINITY);
    let mut best_frame = V::select(live, V::splat(rays.t_max * rays.scale), unused);
    let mut best_t = V::select(live, V::splat(rays.t_max), unused);
    let mut latest = rays.t_max;
    let mut triangle = [Hit::MISS_INDEX; LANES];
    let mut found = 0u16;
    let mut stack = [const { MaybeUninit::<(u32, u16, f32)>::uninit() }; STACK_SIZE];
    let mut sp = 0usize;
    let (mut current, mut mask) = (0u32, rays.live);
    let mut root_test = Some(root);
    // The entered children of a node, by entry (made once, not per node).
    let mut order = [(0.0f32, 0u32, 0u16); WIDTH];
    loop {
        if current & LEAF_BIT == 0 {
            counts.nodes += 1;
            let node = &bvh.nodes[current as usize];
            // The frustum first (all eight boxes at once), then each box it
            // enters against the lanes, each up to its own best.
            // The root's test was made before the packet's set-up.
            let (mut candidates, near) = match root_test.take() {
                Some(test) => test,
                None => frustum.enters::<V>(node, latest),
            };
            let active = V::M::from_bits(mask);
            let mut n = 0;
            while candidates != 0 {
                let c = candidates.trailing_zeros() as usize;
                candidates &= candidates - 1;
                let (mut t0, mut t1) = (zero, best_t);
                for a in 0..3 {
                    let (dn, df) = (
                        node.planes[frustum.near[a]][c] - o[a],
                        node.planes[frustum.far[a]][c] - o[a],
                    );
                    let (p, q) = (V::splat(dn).mul(inv[a]), V::splat(df).mul(inv[a]));
                    if frustum.signed[a] {
                        // Every lane enters by the near row: p <= q.
                        t0 = t0.max(p);
                        t1 = t1.min(q);
                    } else {
                        t0 = t0.max(p.min(q));
                        t1 = t1.min(p.max(q));
                    }
                }
                let lanes = active.and(t0.mul(lo_slack).le(t1.mul(hi_slack))).bits();
                if lanes == 0 {
                    continue;
                }
                // Nearest entry last.
                let mut j = n;
                while j > 0 && order[j - 1].0 < near[c] {
                    order[j] = order[j - 1];
                    j -= 1;
                }
                order[j] = (near[c], node.child[c], lanes);
                n += 1;
            }
            if n > 0 {
                for &(entry, child, lanes) in &order[..n - 1] {
                    stack[sp & STACK_MASK].write((child, lanes, entry));
                    sp += 1;
                }
                (_, current, mask) = order[n - 1];
                continue;
            }
        } else {
            counts.leaves += 1;
            let block = &bvh.blocks[(current & !LEAF_BIT) as usize];
            let mut improved = false;
            for (lane, &index) in block.triangles.iter().enumerate() {
                if index == Hit::MISS_INDEX {
                    break;
                }
                counts.triangle_tests += 1;
                let (a, b, c) = (
                    corner(block, lane, 0, fo),
                    corner(block, lane, 1, fo),
                    corner(block, lane, 2, fo),
                );
                let (cross, t) = rays.shear.crossings(a, b, c, V::M::from_bits(mask), common);
                let ahead = cross.and(t.gt(zero));
                if !ahead.any() {
                    continue;
                }
                // The single ray's rule: closer, or as close with a smaller
                // index (never a t equal to t_max itself).
                let mut take = ahead.and(t.lt(best_frame)).bits();
                let mut ties = ahead.and(t.eq(best_frame)).bits() & found;
                while ties != 0 {
                    let r = ties.trailing_zeros() as usize;
                    ties &= ties - 1;
                    take |= ((index < triangle[r]) as u16) << r;
                }
                if take != 0 {
                    best_frame = V::select(V::M::from_bits(take), t, best_frame);
                    found |= take;
                    improved = true;
                    set_lanes(&mut triangle, take, index);
                }
            }
            if improved {
                best_t = best_frame.mul(inv_scale);
                // Unused lanes hold -inf.
                latest = best_t.max_lane();
            }
        }
        // The next deferred child that begins before some lane's best.
        loop {
            if sp == 0 {
                let t = best_t.to_array();
                for r in 0..LANES {
                    if found & (1 << r) != 0 {
                        hits[r] = Hit {
                            t: t[r],
                            triangle: triangle[r],
                        };
                    }
                }
                return;
            }
            sp -= 1;
            // SAFETY: slot `sp` was written by the push that raised `sp`
            // above it.
            let (child, lanes, entry) = unsafe { stack[sp & STACK_MASK].assume_init() };
            // `entry` is at most each of its lanes' own.
            let open = V::M::from_bits(lanes).and(V::splat(entry).mul(lo_slack).le(best_t.mul(hi_slack)));
            if open.any() {
                (current, mask) = (child, open.bits());
                break;
            }
        }
    }
}

/// The packet as one frustum for the box tests: per axis the interval of
/// its reciprocal directions (all of one sign), which plane row it enters
/// by, and the shared origin. A box is entered unless the earliest any lane
/// could enter it lies beyond the latest any lane could leave it.
///
/// Each bound is one of the lanes' own products rounded: with `inv_lo <=
/// 1/d <= inv_hi` and rounding monotonic, `min(x inv_lo, x inv_hi)` is
/// at most every lane's rounded `x / d`, the same operation the single ray
/// computes; so a box some lane's single-ray test enters (`traverse`,
/// the same slack) is never rejected. An axis whose lanes' signs differ
/// constrains nothing (reciprocals from -inf to +inf).
pub(super) struct Frustum {
    o: [f32; 3],
    inv_lo: [f32; 3],
    inv_hi: [f32; 3],
    near: [usize; 3],
    far: [usize; 3],
    /// Per axis: every lane's direction has one sign (the axis is not
    /// open), so each lane enters a box by row `near` and leaves by `far`.
    signed: [bool; 3],
}

impl Frustum {
    /// The frustum of the rays from `origin` along the lanes' directions
    /// `d` (no component zero or NaN; lanes past the packet's rays repeat
    /// one of them). On an axis whose components share a sign the
    /// reciprocals lie in `[1 / d_max, 1 / d_min]`, and these bounds are
    /// the extreme lanes' own reciprocals: division rounds monotonically.
    #[inline(always)]
    pub(super) fn of_directions<V: Lanes>(origin: Vec3, d: &[V; 3]) -> Frustum {
        let mut f = Frustum {
            o: origin.to_array(),
            inv_lo: [f32::NEG_INFINITY; 3],
            inv_hi: [f32::INFINITY; 3],
            near: [0, 1, 2],
            far: [3, 4, 5],
            signed: [true; 3],
        };
        for (a, c) in d.iter().enumerate() {
            let (d_min, d_max) = (c.min_lane(), c.max_lane());
            if d_min > 0.0 || d_max < 0.0 {
                // 1/d falls as d rises on either side of zero.
                (f.inv_lo[a], f.inv_hi[a]) = (1.0 / d_max, 1.0 / d_min);
                if d_max < 0.0 {
                    (f.near[a], f.far[a]) = (a + 3, a);
                }
            } else {
                f.signed[a] = false;
            }
        }
        f
    }

    /// The interval of each axis's reciprocals (`-inf..inf` where open).
    #[cfg(test)]
    pub(super) fn reciprocals(&self) -> ([f32; 3], [f32; 3]) {
        (self.inv_lo, self.inv_hi)
    }

    /// Whether some axis is open (its lanes' signs differ).
    #[cfg(test)]
    pub(super) fn straddles(&self) -> bool {
        self.signed.contains(&false)
    }

    /// Which of `node`'s children some lane may enter before `latest`, and
    /// the earliest entry into each (in one AVX register where the lanes
    /// `V` have AVX2; the same numbers either way).
    #[inline(always)]
    fn enters<V: Lanes>(&self, node: &Node8, latest: f32) -> (u32, [f32; WIDTH]) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `V::AVX2` says the CPU has AVX2 here.
        let (mask, near) = if V::AVX2 {
            unsafe { self.enters_avx(node, latest) }
        } else {
            self.enters_lanes(node, latest)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (mask, near) = self.enters_lanes(node, latest);
        // Unused slots' empty boxes stop no lane when every axis is open
        // or a slab is NaN (`Node8::used`).
        (mask & node.used, near)
    }

    #[inline(always)]
    pub(super) fn enters_lanes(&self, node: &Node8, latest: f32) -> (u32, [f32; WIDTH]) {
        let mut near = [0.0f32; WIDTH];
        let mut far = [latest; WIDTH];
        for a in 0..3 {
            let (o, lo, hi) = (self.o[a], self.inv_lo[a], self.inv_hi[a]);
            let (pn, pf) = (&node.planes[self.near[a]], &node.planes[self.far[a]]);
            for l in 0..WIDTH {
                let (dn, df) = (pn[l] - o, pf[l] - o);
                let (n0, n1) = (dn * lo, dn * hi);
                let (f0, f1) = (df * lo, df * hi);
                // 0 x inf on an open axis is NaN: the interval stays.
                let tn = if n0 < n1 { n0 } else { n1 };
                let tf = if f0 > f1 { f0 } else { f1 };
                narrow(&mut near, &mut far, l, tn, tf);
            }
        }
        (entered(&near, &far), near)
    }

    /// `enters_lanes` in AVX: `min_ps(a, b)` is `a < b ? a : b` and
    /// `max_ps(a, b)` is `a > b ? a : b` (the second operand on NaN or
    /// equal), the scalar code's selections, so the numbers are the same.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(super) unsafe fn enters_avx(&self, node: &Node8, latest: f32) -> (u32, [f32; WIDTH]) {
        use std::arch::x86_64::*;
        // SAFETY: the caller checked AVX2; each plane row is 32 bytes at a
        // 32-byte boundary (`Node8` is `align(64)`).
        unsafe {
            let mut near = _mm256_setzero_ps();
            let mut far = _mm256_set1_ps(latest);
            for a in 0..3 {
                let o = _mm256_set1_ps(self.o[a]);
                let (lo, hi) = (_mm256_set1_ps(self.inv_lo[a]), _mm256_set1_ps(self.inv_hi[a]));
                let dn = _mm256_sub_ps(_mm256_load_ps(node.planes[self.near[a]].as_ptr()), o);
                let df = _mm256_sub_ps(_mm256_load_ps(node.planes[self.far[a]].as_ptr()), o);
                let tn = _mm256_min_ps(_mm256_mul_ps(dn, lo), _mm256_mul_ps(dn, hi));
                let tf = _mm256_max_ps(_mm256_mul_ps(df, lo), _mm256_mul_ps(df, hi));
                // `narrow`: a NaN bound keeps the interval.
                near = _mm256_max_ps(tn, near);
                far = _mm256_min_ps(tf, far);
            }
            super::traverse::entered_avx(near, far)
        }
    }
}

/// `closest_in` dispatched to `isa` (one this CPU lacks is replaced by the
/// best it has).
pub fn closest(bvh: &Bvh8, tree: &KdTree, origin: Vec3, dirs: &[Vec3], t_max: f32, isa: Isa) -> [Hit; LANES] {
    struct One<'a> {
        bvh: &'a Bvh8,
        tree: &'a KdTree,
        origin: Vec3,
        dirs: &'a [Vec3],
        t_max: f32,
    }
    impl Kernel for One<'_> {
        type Out = [Hit; LANES];
        #[inline(always)]
        fn run<V: Lanes>(self) -> [Hit; LANES] {
            closest_in::<V>(
                self.bvh,
                self.tree,
                self.origin,
                self.dirs,
                self.t_max,
                &mut PacketCounts::default(),
            )
        }
    }
    dispatch(
        isa,
        One {
            bvh,
            tree,
            origin,
            dirs,
            t_max,
        },
    )
}

/// Closest hits of a `width x height` image of rays (row-major) as 4x4
/// packets, rows of packets in parallel on the current rayon pool. A
/// block whose rays do not share one origin is traced ray by ray, so any
/// image of rays is valid; a camera's blocks all go as packets. `tree` is
/// the kd-tree `bvh` was built from (`closest_in`).
pub fn trace_image(
    bvh: &Bvh8,
    tree: &KdTree,
    rays: &[Ray],
    width: u32,
    height: u32,
    isa: Isa,
) -> (Vec<Hit>, PacketCounts) {
    let (w, h) = (width as usize, height as usize);
    assert_eq!(rays.len(), w * h, "a width x height image of rays");
    let mut hits = vec![Hit::MISS; rays.len()];
    if w == 0 {
        return (hits, PacketCounts::default());
    }
    let counts = hits
        .par_chunks_mut(4 * w)
        .zip(rays.par_chunks(4 * w))
        .map(|(out, band)| {
            dispatch(
                isa,
                Band {
                    bvh,
                    tree,
                    band,
                    out,
                    width: w,
                },
            )
        })
        .reduce(PacketCounts::default, |mut a, b| {
            a += b;
            a
        });
    (hits, counts)
}

/// Up to four rows of the image: its 4x4 blocks, left to right.
struct Band<'a> {
    bvh: &'a Bvh8,
    tree: &'a KdTree,
    band: &'a [Ray],
    out: &'a mut [Hit],
    width: usize,
}

impl Kernel for Band<'_> {
    type Out = PacketCounts;
    #[inline(always)]
    fn run<V: Lanes>(self) -> PacketCounts {
        let Band {
            bvh,
            tree,
            band,
            out,
            width,
        } = self;
        let rows = band.len() / width;
        let mut counts = PacketCounts::default();
        for x0 in (0..width).step_by(4) {
            // The block's rows as slices of the band (one bounds check a
            // row), its rays' directions straight into lane columns.
            let x1 = (x0 + 4).min(width);
            let row = |y: usize| y * width + x0..y * width + x1;
            let origin = band[x0].origin;
            let bits = origin.map(f32::to_bits);
            let mut columns = Columns::new();
            // Origins compared as bits (integer work, no flags): equal bits
            // are equal numbers unless NaN, checked below; a -0 beside a +0
            // only sends the block ray by ray.
            let mut differ = 0u32;
            for y in 0..rows {
                for ray in &band[row(y)] {
                    let [ox, oy, oz] = ray.origin.map(f32::to_bits);
                    differ |= (ox ^ bits[0]) | (oy ^ bits[1]) | (oz ^ bits[2]);
                    columns.push(flush_subnormal(Vec3::from_array(ray.dir)).to_array());
                }
            }
            if differ == 0 && !origin.iter().any(|x| x.is_nan()) {
                columns.repeat_last();
                let origin = Vec3::from_array(origin);
                let hits = closest_columns::<V>(bvh, tree, origin, &columns, f32::INFINITY, &mut counts);
                for (y, hits) in (0..rows).zip(hits.chunks(x1 - x0)) {
                    out[row(y)].copy_from_slice(hits);
                }
            } else {
                for y in 0..rows {
                    for (h, ray) in out[row(y)].iter_mut().zip(&band[row(y)]) {
                        *h = bvh.closest_hit(tree, ray.o(), ray.d(), f32::INFINITY);
                    }
                }
                counts.single_rays += columns.n as u64;
            }
        }
        counts
    }
}

/// The pixels of the 4x4 block at column `x0` of a band of `rows` rows
/// (fewer at the image's right edge), row by row, as indices into the band.
#[inline(always)]
fn block_pixels(x0: usize, rows: usize, width: usize) -> impl Iterator<Item = usize> {
    (0..rows).flat_map(move |y| (x0..(x0 + 4).min(width)).map(move |x| y * width + x))
}

/// Whether each hit of an image traced by `trace_image` is in shadow of
/// `light`: per 4x4 block, the segments from the light to its hits (ending
/// `1 - shadow_epsilon` along them) as one any-hit packet through the BVH
/// (`occlusion`), which answers as `tree.any_hit` would ray by ray.
/// `tree` is the kd-tree `bvh` was built from (`closest_in`).
#[allow(clippy::too_many_arguments)]
pub fn shadows(
    bvh: &Bvh8,
    tree: &KdTree,
    rays: &[Ray],
    hits: &[Hit],
    width: u32,
    light: Vec3,
    shadow_epsilon: f32,
    isa: Isa,
) -> Vec<bool> {
    let w = width as usize;
    let mut shadowed = vec![false; hits.len()];
    shadowed
        .par_chunks_mut(4 * w)
        .zip(hits.par_chunks(4 * w).zip(rays.par_chunks(4 * w)))
        .for_each(|(out, (hits, rays))| {
            for x0 in (0..w).step_by(4) {
                let (mut to, mut at, mut m) = ([Vec3::ZERO; LANES], [0usize; LANES], 0);
                for i in block_pixels(x0, hits.len() / w, w).filter(|&i| hits[i].is_hit()) {
                    (to[m], at[m]) = (rays[i].o() + hits[i].t * rays[i].d() - light, i);
                    m += 1;
                }
                let blocked = super::occlusion::occluded(bvh, tree, light, &to[..m], 1.0 - shadow_epsilon, isa);
                for (j, &i) in at[..m].iter().enumerate() {
                    out[i] = blocked & (1 << j) != 0;
                }
            }
        });
    shadowed
}
