//! Any-hit packets of up to 16 rays sharing an origin through the wide
//! BVH (AO rays): which of them hit something with `0 < t < t_max`.
//!
//! Embree's `rtcOccluded16` in our terms: the packet enters a node with a
//! mask of lanes still looking; each of the node's eight boxes is clipped
//! against all those lanes at once (the origin is shared, so a plane's
//! distance from it is one scalar per child, multiplied by each lane's
//! reciprocal direction), the children some lane enters are visited
//! nearest box first with the lanes that enter them, and a leaf's
//! triangles are tested in all its lanes with the kd-tree packets' lane
//! arithmetic (`kdtree::occlusion::Shear::hits`, the watertight test's
//! operations in the same order). Whether a ray hits anything does not
//! depend on the order its candidates are tested in, and no box is missed
//! that holds a hit (the single-ray walk's slack and padding), so each
//! lane's answer is its single ray's (`KdTree::any_hit`), bit for bit.
//! `Accel::occluded` and `Accel::occluded_in` with `Structure::Bvh` walk
//! these packets.

use std::mem::MaybeUninit;

use glam::Vec3;

use super::traverse::is_contact;
use super::{Bvh8, EMPTY_CHILD, LEAF_BIT, SLACK, WIDTH};
use crate::accel::kdtree::KdTree;
use crate::accel::kdtree::leaf_blocks::LeafBlock;
use crate::accel::kdtree::occlusion::{LANES, Rays, common_axes};
use crate::geom::ray::flush_subnormals;
use crate::geom::simd::{Isa, Kernel, Lanes, Mask, dispatch};

/// Stack entries: as the single-ray walk's, at most seven per level.
const STACK_SIZE: usize = 1024;
const STACK_MASK: usize = STACK_SIZE - 1;

/// `occluded_in` dispatched to `isa` (one this CPU lacks is replaced by
/// the best it has), as one kernel of its own (see `Accel::occluded`).
pub(crate) fn occluded(bvh: &Bvh8, tree: &KdTree, origin: Vec3, dirs: &[Vec3], t_max: f32, isa: Isa) -> u16 {
    struct One<'a> {
        bvh: &'a Bvh8,
        tree: &'a KdTree,
        origin: Vec3,
        dirs: &'a [Vec3],
        t_max: f32,
    }
    impl Kernel for One<'_> {
        type Out = u16;
        #[inline(always)]
        fn run<V: Lanes>(self) -> u16 {
            occluded_in::<V>(self.bvh, self.tree, self.origin, self.dirs, self.t_max)
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

/// Which of the rays `dirs` (at most 16) from `origin` hit a triangle with
/// `0 < t < t_max` (bit r for `dirs[r]`, equal to `KdTree::any_hit` ray for
/// ray), in lanes `V`. `tree` is the kd-tree `bvh` was built from: a lane
/// whose hit is a contact (`Bvh8::contact`) gets its answer.
#[inline(always)]
pub(crate) fn occluded_in<V: Lanes>(bvh: &Bvh8, tree: &KdTree, origin: Vec3, dirs: &[Vec3], t_max: f32) -> u16 {
    assert!(dirs.len() <= LANES, "at most {LANES} rays per packet");
    if dirs.is_empty() {
        return 0;
    }
    let mut flushed = [Vec3::ZERO; LANES];
    let n = flush_subnormals(dirs, &mut flushed);
    let dirs = &flushed[..n];
    match Rays::<V>::new(&tree.bounds, bvh.frame_scale, origin, dirs, t_max) {
        Some(rays) if rays.live == 0 => 0,
        Some(rays) => traverse(bvh, tree, &rays, dirs),
        // A zero direction component: its slabs need the NaN rules of the
        // single-ray walk, which takes such packets ray by ray.
        None => dirs.iter().enumerate().fold(0, |bits, (r, &d)| {
            bits | (bvh.any_hit(tree, origin, d, t_max) as u16) << r
        }),
    }
}

/// The packet's walk (no direction component is zero: every product of a
/// plane's distance and a reciprocal is a number or an infinity).
#[inline(always)]
fn traverse<V: Lanes>(bvh: &Bvh8, tree: &KdTree, rays: &Rays<V>, dirs: &[Vec3]) -> u16 {
    let o = rays.origin.to_array();
    let fo = rays.frame_origin.to_array();
    let inv = rays.inv;
    let common = common_axes(&rays.shear, rays.live);
    let (zero, t_limit) = (V::splat(0.0), V::splat(rays.t_max));
    let (lo_slack, hi_slack) = (V::splat(1.0 - SLACK), V::splat(1.0 + SLACK));
    let mut alive = rays.live;
    // Lanes whose contact hit the kd-tree did not confirm: they escape.
    let mut cleared = 0u16;
    let mut stack = [const { MaybeUninit::<(u32, u16)>::uninit() }; STACK_SIZE];
    let mut sp = 0usize;
    let (mut current, mut mask) = (0u32, rays.live);
    loop {
        if current & LEAF_BIT == 0 {
            let node = &bvh.nodes[current as usize];
            // Each child's lanes, and its box's squared distance from the
            // origin (the visiting order: the box holding the origin first).
            let mut entered = [(0.0f32, 0u32, 0u16); WIDTH];
            let mut n = 0;
            let active = V::M::from_bits(mask);
            for c in 0..WIDTH {
                let child = node.child[c];
                if child == EMPTY_CHILD {
                    continue;
                }
                let (mut near, mut far) = (zero, t_limit);
                let mut gap = 0.0f32;
                for a in 0..3 {
                    let (lo, hi) = (node.planes[a][c] - o[a], node.planes[a + 3][c] - o[a]);
                    let (p, q) = (V::splat(lo).mul(inv[a]), V::splat(hi).mul(inv[a]));
                    near = near.max(p.min(q));
                    far = far.min(p.max(q));
                    let outside = lo.max(-hi).max(0.0);
                    gap += outside * outside;
                }
                let lanes = active.and(near.mul(lo_slack).le(far.mul(hi_slack))).bits();
                if lanes != 0 {
                    // Insertion by distance, nearest last.
                    let mut j = n;
                    while j > 0 && entered[j - 1].0 < gap {
                        entered[j] = entered[j - 1];
                        j -= 1;
                    }
                    entered[j] = (gap, child, lanes);
                    n += 1;
                }
            }
            if n > 0 {
                for &(_, child, lanes) in &entered[..n - 1] {
                    stack[sp & STACK_MASK].write((child, lanes));
                    sp += 1;
                }
                (_, current, mask) = entered[n - 1];
                continue;
            }
        } else {
            let block = &bvh.blocks[(current & !LEAF_BIT) as usize];
            let mut active = V::M::from_bits(mask);
            for (lane, &triangle) in block.triangles.iter().enumerate() {
                if triangle == u32::MAX {
                    break;
                }
                let (a, b, c) = (
                    corner(block, lane, 0, fo),
                    corner(block, lane, 1, fo),
                    corner(block, lane, 2, fo),
                );
                let (hit, t) = rays.shear.hits(a, b, c, active, common);
                let hit = hit.bits();
                if hit != 0 {
                    cleared |= unconfirmed_contacts(bvh, tree, rays, dirs, hit, t);
                    alive &= !hit;
                    if alive == 0 {
                        return rays.live & !cleared;
                    }
                    active = active.and_not(V::M::from_bits(hit));
                    if !active.any() {
                        break;
                    }
                }
            }
        }
        // The next deferred child with lanes still looking.
        loop {
            if sp == 0 {
                return rays.live & !alive & !cleared;
            }
            sp -= 1;
            // SAFETY: slot `sp` was written by the push that raised `sp`
            // above it.
            let (child, lanes) = unsafe { stack[sp & STACK_MASK].assume_init() };
            if lanes & alive != 0 {
                (current, mask) = (child, lanes & alive);
                break;
            }
        }
    }
}

/// Vertex `k` of a block's triangle `lane`, relative to the frame's origin
/// (a function, not a closure: see `kdtree::occlusion`'s helpers).
#[inline(always)]
pub(super) fn corner(block: &LeafBlock, lane: usize, k: usize, fo: [f32; 3]) -> [f32; 3] {
    [
        block.v[3 * k][lane] - fo[0],
        block.v[3 * k + 1][lane] - fo[1],
        block.v[3 * k + 2][lane] - fo[2],
    ]
}

/// Of the lanes of `hit` (t in the frame), those whose hit is a contact
/// (`Bvh8::contact`) and which the kd-tree's single ray finds unoccluded.
#[inline(always)]
fn unconfirmed_contacts<V: Lanes>(bvh: &Bvh8, tree: &KdTree, rays: &Rays<V>, dirs: &[Vec3], hit: u16, t: V) -> u16 {
    let t = t.to_array();
    let inv_scale = 1.0 / rays.scale;
    let (mut bits, mut cleared) = (hit, 0u16);
    while bits != 0 {
        let r = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        if is_contact(bvh, t[r] * inv_scale, dirs[r]) && !tree.any_hit(rays.origin, dirs[r], rays.t_max) {
            cleared |= 1 << r;
        }
    }
    cleared
}
