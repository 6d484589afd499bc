//! Closest-hit and any-hit traversal of the wide BVH: at each node the ray
//! is clipped against all eight children's boxes at once (the slab test,
//! Kay and Kajiya 1986), the nearest child entered is visited next and the
//! others are pushed farthest first; a popped entry whose box starts beyond
//! the best hit is dropped.
//!
//! The slab test is conservative: NaN slabs (a zero direction component
//! with the origin on a plane) do not restrict the interval, and the
//! interval is widened by `SLACK` relatively (Ize 2013, "Robust BVH ray
//! traversal", bounds the rounding at 2 gamma_3, about 4e-7), on top of the
//! boxes' padding by the builder: a box is never missed by a ray the
//! triangle test inside it would accept.

use std::mem::MaybeUninit;

use glam::Vec3;

use super::{Bvh8, LEAF_BIT, Node8, SLACK, WIDTH};
use crate::accel::kdtree::KdTree;
use crate::accel::kdtree::leaf_blocks::BLOCK;
use crate::accel::kdtree::watertight::ShearedRay;
use crate::geom::ray::{Hit, Ray, flush_subnormal};

/// Stack entries: the builder bounds the binary tree's depth by 48 + 32
/// levels, and each level pushes at most seven children.
const STACK_SIZE: usize = 1024;
const STACK_MASK: usize = STACK_SIZE - 1;

/// What the box test keeps of a ray: origin and reciprocal direction, and
/// per axis which plane row (`Node8::planes`) the ray enters and leaves by.
pub(super) struct BoxRay {
    pub o: [f32; 3],
    pub inv: [f32; 3],
    pub near: [usize; 3],
    pub far: [usize; 3],
}

impl BoxRay {
    #[inline(always)]
    pub fn new(origin: Vec3, dir: Vec3) -> BoxRay {
        let inv = dir.recip().to_array();
        // The sign bit decides (a -0 direction has a -inf reciprocal, and
        // enters by the maximum plane).
        let near = [0, 1, 2].map(|a| if inv[a].is_sign_negative() { a + 3 } else { a });
        BoxRay {
            o: origin.to_array(),
            inv,
            near,
            far: near.map(|p| (p + 3) % 6),
        }
    }
}

/// The eight-lane box test in one instruction set.
pub(super) trait BoxTest {
    /// Which children `ray` enters before `t_far` (bit i for child i), and
    /// the entry distance of each.
    fn test(node: &Node8, ray: &BoxRay, t_far: f32) -> (u32, [f32; WIDTH]);

    /// `nearest_first` in this instruction set.
    #[inline(always)]
    fn nearest_first(
        node: &Node8,
        mask: u32,
        near: &[f32; WIDTH],
        stack: &mut [MaybeUninit<(u32, f32)>; STACK_SIZE],
        sp: &mut usize,
    ) -> u32 {
        nearest_first(node, mask, near, stack, sp)
    }
}

/// The box test in plain lanes (any CPU).
pub(super) struct Lanes8;

impl BoxTest for Lanes8 {
    #[inline(always)]
    fn test(node: &Node8, ray: &BoxRay, t_far: f32) -> (u32, [f32; WIDTH]) {
        let mut near = [0.0f32; WIDTH];
        let mut far = [t_far; WIDTH];
        for axis in 0..3 {
            let (o, inv) = (ray.o[axis], ray.inv[axis]);
            let (pn, pf) = (&node.planes[ray.near[axis]], &node.planes[ray.far[axis]]);
            for l in 0..WIDTH {
                narrow(&mut near, &mut far, l, (pn[l] - o) * inv, (pf[l] - o) * inv);
            }
        }
        (entered(&near, &far), near)
    }
}

/// Narrows lane `l`'s interval by `[tn, tf]`. Comparisons are false on
/// NaN: a NaN bound (a zero direction component with the origin on a
/// plane, or 0 x inf) keeps the interval.
#[inline(always)]
pub(super) fn narrow(near: &mut [f32; WIDTH], far: &mut [f32; WIDTH], l: usize, tn: f32, tf: f32) {
    if tn > near[l] {
        near[l] = tn;
    }
    if tf < far[l] {
        far[l] = tf;
    }
}

/// The lanes whose interval, widened by `SLACK`, is not empty (bit l).
#[inline(always)]
pub(super) fn entered(near: &[f32; WIDTH], far: &[f32; WIDTH]) -> u32 {
    let mut mask = 0;
    for l in 0..WIDTH {
        mask |= ((near[l] * (1.0 - SLACK) <= far[l] * (1.0 + SLACK)) as u32) << l;
    }
    mask
}

/// The box test in one AVX register.
#[cfg(target_arch = "x86_64")]
pub(super) struct Avx8;

#[cfg(target_arch = "x86_64")]
impl BoxTest for Avx8 {
    #[inline(always)]
    fn test(node: &Node8, ray: &BoxRay, t_far: f32) -> (u32, [f32; WIDTH]) {
        use std::arch::x86_64::*;
        // SAFETY: only compiled into `closest_avx2`, which requires AVX2;
        // each plane row is 32 bytes at a 32-byte boundary (`Node8` is
        // `align(64)`, rows 32 bytes).
        unsafe {
            let mut near = _mm256_setzero_ps();
            let mut far = _mm256_set1_ps(t_far);
            for axis in 0..3 {
                let o = _mm256_set1_ps(ray.o[axis]);
                let inv = _mm256_set1_ps(ray.inv[axis]);
                let pn = _mm256_load_ps(node.planes[ray.near[axis]].as_ptr());
                let pf = _mm256_load_ps(node.planes[ray.far[axis]].as_ptr());
                // max/min return their second operand when either is NaN:
                // the running interval, so a NaN slab keeps it.
                near = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(pn, o), inv), near);
                far = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(pf, o), inv), far);
            }
            entered_avx(near, far)
        }
    }

    /// The entered children's order by rank, without the insertion sort's
    /// branches: a child's rank is the number of entered children whose key
    /// is smaller, the key its distance's bits with the slot in the three
    /// lowest (distances are not negative, so their bits order as they do;
    /// the slot makes the keys distinct). Keys distinct and totally ordered
    /// make the ranks the places 0..n once each: every pushed slot is
    /// written.
    #[inline(always)]
    fn nearest_first(
        node: &Node8,
        mask: u32,
        near: &[f32; WIDTH],
        stack: &mut [MaybeUninit<(u32, f32)>; STACK_SIZE],
        sp: &mut usize,
    ) -> u32 {
        use std::arch::x86_64::*;
        // SAFETY: only compiled into `trace_avx2`, which requires AVX2.
        let rank = unsafe {
            let bits = _mm256_castps_si256(_mm256_loadu_ps(near.as_ptr()));
            let key = _mm256_or_si256(
                _mm256_and_si256(bits, _mm256_set1_epi32(!7)),
                _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
            );
            let mut keys = [0i32; WIDTH];
            _mm256_storeu_si256(keys.as_mut_ptr().cast(), key);
            let mut rank = _mm256_setzero_si256();
            let mut rest = mask;
            while rest != 0 {
                let j = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                // Lanes whose key is above child j's count it.
                rank = _mm256_sub_epi32(rank, _mm256_cmpgt_epi32(key, _mm256_set1_epi32(keys[j])));
            }
            let mut out = [0u32; WIDTH];
            _mm256_storeu_si256(out.as_mut_ptr().cast(), rank);
            out
        };
        // Rank r goes to sp + n - 1 - r: the farthest lowest, the nearest
        // just above the entries pushed (a scratch slot, read back at once).
        let top = *sp + mask.count_ones() as usize - 1;
        let mut rest = mask;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            stack[(top - rank[i] as usize) & STACK_MASK].write((node.child[i], near[i]));
        }
        *sp = top;
        // SAFETY: the rank-0 child was written at `top` just above.
        unsafe { stack[top & STACK_MASK].assume_init() }.0
    }
}

/// `entered` of eight intervals in AVX registers, and the entries.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) unsafe fn entered_avx(
    near: std::arch::x86_64::__m256,
    far: std::arch::x86_64::__m256,
) -> (u32, [f32; WIDTH]) {
    use std::arch::x86_64::*;
    // SAFETY: the caller checked AVX2.
    unsafe {
        let enter = _mm256_cmp_ps::<_CMP_LE_OQ>(
            _mm256_mul_ps(near, _mm256_set1_ps(1.0 - SLACK)),
            _mm256_mul_ps(far, _mm256_set1_ps(1.0 + SLACK)),
        );
        let mut out = [0.0f32; WIDTH];
        _mm256_storeu_ps(out.as_mut_ptr(), near);
        (_mm256_movemask_ps(enter) as u32, out)
    }
}

/// Traces `rays` into `hits` with the widest box test the CPU has; a ray
/// whose hit is a contact (`Bvh8::contact`) gets `tree`'s answer.
pub(super) fn dispatch<const ANY: bool>(bvh: &Bvh8, tree: &KdTree, rays: &[Ray], t_max: f32, hits: &mut [Hit]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2.
        unsafe { trace_avx2::<ANY>(bvh, rays, t_max, hits) };
    } else {
        trace::<ANY, Lanes8>(bvh, rays, t_max, hits);
    }
    #[cfg(not(target_arch = "x86_64"))]
    trace::<ANY, Lanes8>(bvh, rays, t_max, hits);
    for (r, h) in rays.iter().zip(hits) {
        if h.is_hit() && is_contact(bvh, h.t, r.d()) {
            *h = if ANY {
                match tree.any_hit(r.o(), r.d(), t_max) {
                    true => *h,
                    false => Hit::MISS,
                }
            } else {
                tree.closest_hit(r.o(), r.d(), t_max)
            };
        }
    }
}

/// Whether a hit at `t` along `dir` is closer than the contact distance.
#[inline(always)]
pub(super) fn is_contact(bvh: &Bvh8, t: f32, dir: Vec3) -> bool {
    t * t * dir.length_squared() < bvh.contact * bvh.contact
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn trace_avx2<const ANY: bool>(bvh: &Bvh8, rays: &[Ray], t_max: f32, hits: &mut [Hit]) {
    trace::<ANY, Avx8>(bvh, rays, t_max, hits);
}

/// Rays walked at once by `trace`, taking turns node by node.
const INTERLEAVE: usize = 4;

/// Traces `rays` with `INTERLEAVE` walks taking turns: after each step of
/// one walk the node or leaf it goes to next is prefetched, and the other
/// walks' steps run while it arrives. Random rays spend most of their time
/// waiting for nodes and leaf blocks that are not in the caches (the walk
/// decides where to go only once a node has arrived), and each ray's walk
/// is its own: the hits are those of walking the rays one by one.
#[inline(always)]
fn trace<const ANY: bool, T: BoxTest>(bvh: &Bvh8, rays: &[Ray], t_max: f32, hits: &mut [Hit]) {
    let ray_count = rays.len().min(hits.len());
    if ray_count < INTERLEAVE {
        let mut walk = Walk::new();
        for (r, h) in rays.iter().zip(hits) {
            walk.start(bvh, r, t_max);
            while !walk.step::<ANY, T>(bvh) {}
            *h = walk.hit();
        }
        return;
    }
    let mut walks: [Walk; INTERLEAVE] = std::array::from_fn(|_| Walk::new());
    // The ray each walk traces; `usize::MAX` once the rays ran out.
    let mut tracing = [usize::MAX; INTERLEAVE];
    for (k, walk) in walks.iter_mut().enumerate() {
        walk.start(bvh, &rays[k], t_max);
        tracing[k] = k;
    }
    let mut next = INTERLEAVE;
    let mut live = INTERLEAVE;
    while live > 0 {
        for (walk, ray) in walks.iter_mut().zip(&mut tracing) {
            if *ray == usize::MAX {
                continue;
            }
            if !walk.step::<ANY, T>(bvh) {
                prefetch(bvh, walk.current);
                continue;
            }
            hits[*ray] = walk.hit();
            if next < ray_count {
                walk.start(bvh, &rays[next], t_max);
                *ray = next;
                next += 1;
            } else {
                *ray = usize::MAX;
                live -= 1;
            }
        }
    }
}

/// One ray's traversal, a step at a time.
struct Walk {
    sheared: ShearedRay,
    ray: BoxRay,
    /// The closest hit so far (`t` the ray's `t_max` while there is none).
    best: Hit,
    /// The best t in the triangle test's frame (a power of two times
    /// `best.t`).
    best_frame: f32,
    /// The node or leaf (a child word) the next step visits.
    current: u32,
    /// Children deferred, with the distance their box begins at; every
    /// slot below `sp` was written by its push.
    stack: [MaybeUninit<(u32, f32)>; STACK_SIZE],
    sp: usize,
}

impl Walk {
    /// A walk to be `start`ed.
    #[inline(always)]
    fn new() -> Walk {
        Walk {
            sheared: ShearedRay::new(Vec3::ZERO, Vec3::Z),
            ray: BoxRay::new(Vec3::ZERO, Vec3::Z),
            best: Hit::MISS,
            best_frame: 0.0,
            current: 0,
            stack: [const { MaybeUninit::uninit() }; STACK_SIZE],
            sp: 0,
        }
    }

    /// Begins the walk of `r` (0 < t < `t_max`) at the root.
    #[inline(always)]
    fn start(&mut self, bvh: &Bvh8, r: &Ray, t_max: f32) {
        let (origin, dir) = (r.o(), flush_subnormal(r.d()));
        self.sheared = ShearedRay::in_frame(origin, dir, bvh.frame_scale);
        self.ray = BoxRay::new(origin, dir);
        self.best = Hit {
            t: t_max,
            triangle: Hit::MISS_INDEX,
        };
        self.best_frame = t_max * self.sheared.scale;
        self.current = 0;
        self.sp = 0;
    }

    /// The walk's answer once `step` returned true.
    #[inline(always)]
    fn hit(&self) -> Hit {
        if self.best.is_hit() { self.best } else { Hit::MISS }
    }

    /// Visits the current node or leaf and moves on to the next; true when
    /// the walk is over (with `ANY`, at the first hit).
    #[inline(always)]
    fn step<const ANY: bool, T: BoxTest>(&mut self, bvh: &Bvh8) -> bool {
        if self.current & LEAF_BIT == 0 {
            let node = &bvh.nodes[self.current as usize];
            let (mask, near) = T::test(node, &self.ray, self.best.t);
            let mask = mask & node.used;
            if mask != 0 {
                let first = mask.trailing_zeros() as usize;
                let rest = mask & (mask - 1);
                if rest == 0 {
                    self.current = node.child[first];
                    return false;
                }
                if rest & (rest - 1) == 0 {
                    // Two children, the most common fork: the farther is
                    // pushed, the nearer entered, without a sort.
                    let second = rest.trailing_zeros() as usize;
                    let (d0, d1) = (near[first], near[second]);
                    let (c0, c1) = (node.child[first], node.child[second]);
                    let swap = d1 < d0;
                    let (far_child, far_d) = if swap { (c0, d0) } else { (c1, d1) };
                    self.current = if swap { c1 } else { c0 };
                    self.stack[self.sp & STACK_MASK].write((far_child, far_d));
                    self.sp += 1;
                } else {
                    self.current = T::nearest_first(node, mask, &near, &mut self.stack, &mut self.sp);
                }
                prefetch_pushed(bvh, &self.stack, self.sp);
                return false;
            }
        } else {
            let sheared = &self.sheared;
            let block = &bvh.blocks[(self.current & !LEAF_BIT) as usize];
            let t = sheared.intersect_block(block);
            // Most blocks hold no lane as close as the best hit: one
            // mask of the lanes that may be, instead of a branch per
            // lane.
            let mut lanes = candidates(&t, self.best_frame);
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let (t, triangle) = (t[lane], block.triangles[lane]);
                // Closest first; at an equal t the smaller index (never
                // a t equal to t_max itself). Unused lanes are zero
                // triangles, whose t is NaN: never a candidate.
                let closer = t < self.best_frame
                    || (t == self.best_frame && self.best.is_hit() && triangle < self.best.triangle);
                if closer {
                    self.best_frame = t;
                    self.best = Hit {
                        t: t * sheared.inv_scale,
                        triangle,
                    };
                    if ANY {
                        return true;
                    }
                }
            }
        }
        // Pop the next child whose box begins before the best hit.
        loop {
            if self.sp == 0 {
                return true;
            }
            self.sp -= 1;
            // SAFETY: slot `sp` was written by the push that raised `sp`
            // above it.
            let (child, near) = unsafe { self.stack[self.sp & STACK_MASK].assume_init() };
            if near * (1.0 - SLACK) <= self.best.t * (1.0 + SLACK) {
                self.current = child;
                return false;
            }
        }
    }
}

/// The lanes of a block's t (NaN where a lane misses) with
/// `0 < t <= best`: bit l for lane l.
#[inline(always)]
fn candidates(t: &[f32; BLOCK], best: f32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86-64; the comparisons are ordered
        // (false on NaN), as Rust's.
        unsafe {
            let t = _mm_loadu_ps(t.as_ptr());
            let keep = _mm_and_ps(_mm_cmpgt_ps(t, _mm_setzero_ps()), _mm_cmple_ps(t, _mm_set1_ps(best)));
            _mm_movemask_ps(keep) as u32
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut mask = 0;
        for (l, &t) in t.iter().enumerate() {
            mask |= ((t > 0.0 && t <= best) as u32) << l;
        }
        mask
    }
}

/// Pushes the entered children of `node` but the nearest, farthest first,
/// and returns the nearest.
#[inline(always)]
fn nearest_first(
    node: &Node8,
    mut mask: u32,
    near: &[f32; WIDTH],
    stack: &mut [MaybeUninit<(u32, f32)>; STACK_SIZE],
    sp: &mut usize,
) -> u32 {
    // Insertion sort of at most eight (distance, child), nearest last.
    let mut order = [(0.0f32, 0u32); WIDTH];
    let mut n = 0;
    while mask != 0 {
        let i = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        let entry = (near[i], node.child[i]);
        let mut j = n;
        while j > 0 && order[j - 1].0 < entry.0 {
            order[j] = order[j - 1];
            j -= 1;
        }
        order[j] = entry;
        n += 1;
    }
    for &(d, child) in &order[..n - 1] {
        stack[*sp & STACK_MASK].write((child, d));
        *sp += 1;
    }
    order[n - 1].1
}

/// Asks for the node or block on top of the stack ahead of its pop.
#[inline(always)]
fn prefetch_pushed(bvh: &Bvh8, stack: &[MaybeUninit<(u32, f32)>; STACK_SIZE], sp: usize) {
    // SAFETY: slot sp - 1 was just written (sp >= 1 after a push).
    let (child, _) = unsafe { stack[(sp - 1) & STACK_MASK].assume_init() };
    prefetch(bvh, child);
}

/// Asks for the first four cache lines of the node or leaf block of child
/// word `child`.
#[inline(always)]
fn prefetch(bvh: &Bvh8, child: u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let p: *const i8 = if child & LEAF_BIT == 0 {
            bvh.nodes.as_ptr().wrapping_add(child as usize).cast()
        } else {
            bvh.blocks.as_ptr().wrapping_add((child & !LEAF_BIT) as usize).cast()
        };
        // SAFETY: a prefetch never faults.
        unsafe {
            for line in 0..4 {
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64 * line));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (bvh, child);
}
