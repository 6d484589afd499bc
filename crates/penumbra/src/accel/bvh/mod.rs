//! A wide bounding volume hierarchy for the CPU's rays: eight children per node, their boxes tested at once in one
//! AVX2 register (or eight scalar lanes), leaves of up to four triangles in
//! the kd-tree's SoA blocks (`kdtree::leaf_blocks`) and tested with its
//! watertight arithmetic, in its frame.
//!
//! Why a second structure: a random ray walks about 42 interior kd-tree
//! nodes on the bunny, a chain of dependent loads and mispredicted branches
//! one split plane at a time, where a wide BVH decides between eight
//! children per load (docs/results/tracing.md measured both). It came to
//! serve the CPU's coherent rays too, faster than the kd-tree's packets:
//! AO rays (`occlusion`) and, with `trace --accel bvh`, a camera's 4x4
//! packets (`packet`). The kd-tree stays the structure of MLRTA, of the
//! GPU kernels and of the Whitted tracer's CPU twin.
//!
//! The build splits objects by the SAH and, where long thin triangles
//! make the two sides' boxes overlap, space as well (`spatial`, knobs in
//! `BvhSettings`): a triangle may then sit in several leaves.
//!
//! Hits are the kd-tree's: the same triangle test in the same frame gives
//! bit-identical t, and the closest hit is the smallest t; where two
//! triangles are hit at exactly the same t (a ray through a shared edge or
//! vertex) the one of smaller index is reported, which the kd-tree, going by
//! its cells, does not always do (`tests/bvh.rs` holds the two to it). A hit
//! at a contact (`Bvh8::contact`) is the kd-tree's answer. Any-hit packets
//! of rays sharing an origin (AO) are `occlusion`, closest-hit packets
//! `packet`. The BVH is built on first
//! use and kept beside the kd-tree in `Accel` (`Accel::bvh`), whose
//! single-ray queries walk it with `Structure::Bvh`.

mod build;
pub(crate) mod occlusion;
pub mod packet;
mod spatial;
#[cfg(test)]
mod tests;
mod traverse;

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::kdtree::KdTree;
use crate::accel::kdtree::leaf_blocks::{BLOCK, LeafBlock};
use crate::geom::aabb::Aabb;
use crate::geom::ray::{Hit, Ray};

/// Children per node.
pub const WIDTH: usize = 8;
/// Most triangles in a leaf: one block of the kd-tree's leaf test.
pub const MAX_LEAF: usize = BLOCK;
/// A child word with this bit set is a leaf: the rest is its block's index.
pub const LEAF_BIT: u32 = 1 << 31;
/// An unused child slot (its box is empty, so no ray enters it).
pub const EMPTY_CHILD: u32 = u32::MAX;

/// Eight children's boxes, each plane as a row of eight lanes:
/// `planes[axis]` the minima, `planes[3 + axis]` the maxima.
#[repr(C, align(64))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Node8 {
    /// The children's boxes in world units (unscaled, unlike the leaf
    /// blocks), widened by a few ulps of the scene's largest coordinate;
    /// lane `i` is child `i`'s. An empty slot's box is empty.
    pub planes: [[f32; WIDTH]; 6],
    /// Per slot: an interior child's node index, or `LEAF_BIT` with the
    /// index of its leaf block in `Bvh8::blocks`, or `EMPTY_CHILD`.
    pub child: [u32; WIDTH],
    /// Bit i set where slot i holds a child. The walks keep only these
    /// bits of a box test's mask: an empty slot's box stops a ray only
    /// through its arithmetic, and a NaN slab (a NaN direction, or an
    /// infinite origin against an infinite plane) keeps every interval,
    /// which would enter the slot and read `EMPTY_CHILD` as a leaf.
    pub used: u32,
}

impl Node8 {
    /// No children: every box empty (min +inf, max -inf), so no ray's slab
    /// interval is ever non-empty.
    pub const EMPTY: Node8 = Node8 {
        planes: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [EMPTY_CHILD; WIDTH],
        used: 0,
    };
}

/// Knobs of the BVH's build (`Bvh8::build`, `Accel::bvh_with`). `Default`
/// gives the settings docs/results' numbers were measured with.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhSettings {
    /// How many triangle references spatial splits (`spatial`) may add, as
    /// a share of the triangles; 0 builds by object splits alone. 0.3: the
    /// kitchen's primary-ray packets walk 7.5 nodes instead of 10.0 (0.1
    /// gave 7.6, 1.0 the same as 0.3 with 9% more blocks); its build takes
    /// about twice as long (one thread: 33 -> 58 ms).
    pub spatial_split_budget: f32,
    /// An axis of a node is tried for spatial splits only if some
    /// reference spans this share of the node's box along it: where every
    /// triangle is small beside the node, a plane saves little over the
    /// object split. 0.25 (8 of the 32 bins): scanned meshes build as fast
    /// as without spatial splits (one thread: bunny 71 -> 38 ms, no split
    /// made; dragon100k 127 -> 71 ms, 4.04 instead of 3.83 nodes a packet,
    /// whose packets were 3-4% faster: 32.5 against 33.5-34.6 ms) while the
    /// kitchen keeps every split that pays (7.46 nodes a packet either
    /// way; 0.0625 or 0.125 built slower for little, 0.5 lost some: 7.56).
    /// 0 tries every node.
    pub spatial_min_span: f32,
    /// Spatial splits are tried at a node whose best object split leaves
    /// its two children overlapping by more than this share of the scene
    /// box's area (the paper's alpha). 1e-3, not the paper's 1e-5: the
    /// same packets' walks (kitchen 7.46 against 7.49 nodes), a quarter
    /// less build time.
    pub spatial_alpha: f32,
}

impl Default for BvhSettings {
    fn default() -> Self {
        BvhSettings {
            spatial_split_budget: 0.3,
            spatial_alpha: 1e-3,
            spatial_min_span: 0.25,
        }
    }
}

/// Relative widening of every interval of the walks.
pub(crate) const SLACK: f32 = 2e-6;

/// The hierarchy over a triangle soup (a kd-tree's `triangles`, whose
/// indices hits report).
#[derive(Debug, Clone)]
pub struct Bvh8 {
    /// Node 0 is the root.
    pub nodes: Vec<Node8>,
    /// The leaves' triangles, vertices times `frame_scale`.
    pub blocks: Vec<LeafBlock>,
    /// All triangles' bounds.
    pub bounds: Aabb,
    /// The intersection test's frame (`watertight::ShearedRay`).
    pub frame_scale: f32,
    /// Distance along a ray below which a hit is a contact: 1e-6 of the
    /// scene's diagonal. A ray that starts in the plane of a triangle gets
    /// t = 0 rounded into a t of about 1e-11 by the watertight test, and
    /// whether that triangle is tested at all depends on the structure:
    /// the kd-tree's cells (flat in that plane, or ending at it, entered
    /// from the direction's side) and the BVH's padded boxes decide
    /// differently (911 of the `corner` scene's 130,680 AO rays). A ray
    /// whose hit is a contact is therefore traced again through the
    /// kd-tree, whose answer it gets; every other hit the BVH finds, the
    /// kd-tree finds too (its cells lie within the boxes), so the answers
    /// are the kd-tree's. Legitimate hits that close cost a second trace.
    pub contact: f32,
}

impl Bvh8 {
    /// The hierarchy over a kd-tree's triangles, in its frame, so that hits
    /// compare bit for bit (the tree validated the triangles: non-empty,
    /// finite).
    pub fn from_tree(tree: &KdTree) -> Bvh8 {
        Bvh8::build(tree, &BvhSettings::default())
    }

    /// The hierarchy over a kd-tree's triangles with the builder's knobs.
    pub fn build(tree: &KdTree, params: &BvhSettings) -> Bvh8 {
        build::build(&tree.triangles, tree.frame_scale, params)
    }

    /// Levels of nodes from the root to the deepest leaf (the root alone
    /// is 1); the builder keeps it under 81, so the traversal stack of
    /// 1,024 entries (at most seven pushed per level) cannot overflow.
    pub fn depth(&self) -> usize {
        fn below(nodes: &[Node8], i: usize) -> usize {
            1 + nodes[i]
                .child
                .iter()
                .filter(|&&c| c & LEAF_BIT == 0)
                .map(|&c| below(nodes, c as usize))
                .max()
                .unwrap_or(0)
        }
        below(&self.nodes, 0)
    }

    /// Triangle references in the leaves: the triangles, plus the copies
    /// spatial splits made.
    pub fn references(&self) -> usize {
        self.blocks
            .iter()
            .map(|b| b.triangles.iter().filter(|&&t| t != u32::MAX).count())
            .sum()
    }

    /// Bytes of nodes and blocks.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice()) + std::mem::size_of_val(self.blocks.as_slice())
    }

    /// Closest hits (or with `ANY` any hit, its triangle) of `rays` with
    /// `0 < t < t_max` into `hits`. `tree` is the kd-tree this BVH was
    /// built from: a hit at a contact (closer than `contact` along the
    /// ray) is the tree's answer, see `contact`.
    pub(crate) fn trace_into<const ANY: bool>(&self, tree: &KdTree, rays: &[Ray], t_max: f32, hits: &mut [Hit]) {
        traverse::dispatch::<ANY>(self, tree, rays, t_max, hits);
    }

    /// The closest hit of one ray with `0 < t < t_max` (ties to the
    /// smaller triangle index); `tree` as in `trace_into`.
    pub(crate) fn closest_hit(&self, tree: &KdTree, origin: Vec3, dir: Vec3, t_max: f32) -> Hit {
        let mut hit = [Hit::MISS];
        self.trace_into::<false>(tree, &[Ray::new(origin, dir)], t_max, &mut hit);
        hit[0]
    }

    /// Whether one ray hits anything with `0 < t < t_max`; `tree` as in
    /// `trace_into`.
    pub(crate) fn any_hit(&self, tree: &KdTree, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let mut hit = [Hit::MISS];
        self.trace_into::<true>(tree, &[Ray::new(origin, dir)], t_max, &mut hit);
        hit[0].is_hit()
    }

    /// Closest hits of a batch of rays into `hits` (same length), on the
    /// calling thread; `tree` as in `trace_into`.
    pub(crate) fn closest_hits(&self, tree: &KdTree, rays: &[Ray], hits: &mut [Hit]) {
        self.trace_into::<false>(tree, rays, f32::INFINITY, hits);
    }

    /// `closest_hits` in parallel, the rays in their order (the BVH's
    /// nodes stay in cache: sorting them gains nothing).
    pub(crate) fn trace_closest(&self, tree: &KdTree, rays: &[Ray]) -> Vec<Hit> {
        let mut hits = vec![Hit::MISS; rays.len()];
        hits.par_chunks_mut(1024)
            .zip(rays.par_chunks(1024))
            .for_each(|(h, r)| self.closest_hits(tree, r, h));
        hits
    }
}
