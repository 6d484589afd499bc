//! Single-ray kd-tree traversal (closest hit and any hit), the CPU twin of
//! `wgsl/kdtree_traverse.wgsl`.
//!
//! The classic recursive ray traversal (Havran 2000, "TA_B^rec"; Wald 2004)
//! with an explicit stack: at an interior node the ray's parametric interval
//! `[t_min, t_max]` in the cell is compared with the distance to the split
//! plane to visit the near child, the far child, or both (far one pushed).
//! Leaves test all their triangles; a hit inside the current cell ends the
//! search, since every cell still on the stack lies farther along the ray.

use std::mem::MaybeUninit;

use glam::Vec3;

use super::KdTree;
use super::node::{KdNode, MAX_TREE_DEPTH};
use super::watertight::ShearedRay;
use crate::geom::ray::{Hit, flush_subnormal};

/// Receives traversal events; the statistics of `penumbra trace` count them,
/// the fast path compiles them away.
pub trait Counters {
    /// A traversal step: one cell (interior or leaf) visited.
    fn cell(&mut self);
    /// One ray–triangle test.
    fn intersection(&mut self);
}

/// Counts nothing.
pub struct NoCounts;

impl Counters for NoCounts {
    #[inline(always)]
    fn cell(&mut self) {}
    #[inline(always)]
    fn intersection(&mut self) {}
}

/// Traversal steps (interior and leaf cells visited) and ray–triangle tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TraversalCounts {
    /// Cells visited, interior and leaf.
    pub cells: u64,
    /// Ray–triangle tests.
    pub intersections: u64,
}

impl Counters for TraversalCounts {
    #[inline(always)]
    fn cell(&mut self) {
        self.cells += 1;
    }
    #[inline(always)]
    fn intersection(&mut self) {
        self.intersections += 1;
    }
}

impl std::ops::AddAssign for TraversalCounts {
    fn add_assign(&mut self, o: Self) {
        self.cells += o.cells;
        self.intersections += o.intersections;
    }
}

/// Relative slack of every cell interval. Rounding in the distance to a split
/// plane is a few ulps; a ray through a point where cells meet (a vertex on
/// two split planes, say) may touch the cell holding the triangle that
/// accepts the hit only at that point, and rounding could exclude it. Cells
/// are therefore entered when the ray comes within this relative distance of
/// them. Termination compares hits with the unwidened exit distance, so the
/// closest hit stays exact.
pub const TRAVERSAL_SLACK: f32 = 1e-6;

/// Traversal stack: a power of two at least `MAX_TREE_DEPTH`.
const STACK_SIZE: usize = MAX_TREE_DEPTH.next_power_of_two();
const STACK_MASK: usize = STACK_SIZE - 1;

/// What the traversal keeps of a ray: per-axis origin, inverse direction
/// and first child on a split plane in 4-element arrays, indexed by `word1
/// & 3` (the compiler sees that is below 4: no bounds checks, and no match
/// as glam's run-time indexing has; which child comes first when the origin
/// lies on the split plane depends only on the direction's sign), and the
/// sheared ray of the intersection test.
pub(crate) struct SingleRay {
    pub o4: [f32; 4],
    pub inv4: [f32; 4],
    pub below_on_plane: [bool; 4],
    pub ray: ShearedRay,
}

impl SingleRay {
    #[inline(always)]
    pub fn new(origin: Vec3, dir: Vec3, frame_scale: f32) -> Self {
        let quad = |v: Vec3| [v.x, v.y, v.z, 0.0];
        SingleRay {
            o4: quad(origin),
            inv4: quad(dir.recip()),
            below_on_plane: [dir.x <= 0.0, dir.y <= 0.0, dir.z <= 0.0, false],
            ray: ShearedRay::in_frame(origin, dir, frame_scale),
        }
    }
}

impl KdTree {
    /// Closest hit with `0 < t < t_max`, or `Hit::MISS`.
    #[inline]
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Hit {
        self.traverse::<false, _>(origin, dir, t_max, &mut NoCounts)
    }

    /// Closest hit, counting traversal steps and intersection tests.
    pub fn closest_hit_counted(&self, origin: Vec3, dir: Vec3, t_max: f32, counts: &mut TraversalCounts) -> Hit {
        self.traverse::<false, _>(origin, dir, t_max, counts)
    }

    /// Whether anything is hit with `0 < t < t_max` (occlusion / shadow rays).
    #[inline]
    pub fn any_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        self.traverse::<true, _>(origin, dir, t_max, &mut NoCounts).is_hit()
    }

    #[inline(always)]
    fn traverse<const ANY: bool, C: Counters>(&self, origin: Vec3, dir: Vec3, t_max: f32, counts: &mut C) -> Hit {
        let dir = flush_subnormal(dir);
        let Some((t0, t1)) = self.bounds.clip_ray_widened(origin, dir, 0.0, t_max, TRAVERSAL_SLACK) else {
            return Hit::MISS;
        };
        let ray = SingleRay::new(origin, dir, self.frame_scale);
        self.walk::<ANY, true, C>(&ray, 0, t0, t1, t_max, counts)
    }

    /// The traversal of node `node_index`'s subtree with the ray's interval
    /// `[t_min, t_cell_max]` in its cell: from the root, the whole search;
    /// from inside, the rest of a search a packet began
    /// (`occlusion`, which hands a ray its lanes no longer share).
    /// `BLOCKS` reads the nodes and leaves of `leaf_blocks` (four triangles
    /// tested at once); without it, `nodes` and `leaf_vertices`, which a
    /// packet's lane should go on with: they are the arrays the packet
    /// itself has in cache (reading the block copy there made the bunny's
    /// AO rays 10% slower).
    #[inline(always)]
    pub(crate) fn walk<const ANY: bool, const BLOCKS: bool, C: Counters>(
        &self,
        r: &SingleRay,
        mut node_index: u32,
        mut t_min: f32,
        mut t_cell_max: f32,
        t_max: f32,
        counts: &mut C,
    ) -> Hit {
        let (ray, o4, inv4, below_on_plane) = (&r.ray, r.o4, r.inv4, r.below_on_plane);
        // The stack never holds more entries than the tree is deep (at most
        // MAX_TREE_DEPTH); indexing with `sp & STACK_MASK` lets the compiler
        // drop the bounds checks without changing any index. It is left
        // uninitialised: zeroing 768 bytes per ray was a tenth of the time of
        // a primary ray. Slots below `sp` are always written before they are
        // read.
        let mut stack = [const { MaybeUninit::<(u32, f32, f32)>::uninit() }; STACK_SIZE];
        let mut sp = 0usize;
        let mut best = Hit {
            t: t_max,
            triangle: Hit::MISS_INDEX,
        };
        loop {
            counts.cell();
            let node = if BLOCKS {
                self.leaf_blocks.nodes[node_index as usize]
            } else {
                self.nodes[node_index as usize]
            };
            if !node.is_leaf() {
                let axis = (node.word1 & 3) as usize;
                let split = node.split();
                let o = o4[axis];
                let t_plane = (split - o) * inv4[axis];
                let below_first = o < split || (o == split && below_on_plane[axis]);
                let (first, second) = if below_first {
                    (node_index + 1, node.above_child())
                } else {
                    (node.above_child(), node_index + 1)
                };
                if t_plane <= 0.0 || t_plane * (1.0 - TRAVERSAL_SLACK) > t_cell_max {
                    node_index = first;
                } else if t_plane * (1.0 + TRAVERSAL_SLACK) < t_min {
                    node_index = second;
                } else {
                    // Both children. A NaN t_plane means the ray lies in the
                    // split plane: both children keep the whole interval.
                    if t_plane.is_nan() {
                        stack[sp & STACK_MASK].write((second, t_min, t_cell_max));
                    } else {
                        let far_entry = t_min.max(t_plane * (1.0 - TRAVERSAL_SLACK));
                        stack[sp & STACK_MASK].write((second, far_entry, t_cell_max));
                        t_cell_max = t_cell_max.min(t_plane * (1.0 + TRAVERSAL_SLACK));
                    }
                    sp += 1;
                    node_index = first;
                }
                continue;
            }

            if self.test_leaf::<ANY, BLOCKS, C>(ray, node, &mut best, counts) {
                return best;
            }
            // A hit inside this cell is the closest: the remaining cells lie
            // beyond its exit. (A hit beyond it may still be beaten by a
            // triangle in a later cell, so the search goes on.)
            if best.is_hit() && best.t * (1.0 + TRAVERSAL_SLACK) <= t_cell_max {
                return best;
            }
            loop {
                if sp == 0 {
                    return if best.is_hit() { best } else { Hit::MISS };
                }
                sp -= 1;
                // SAFETY: entry `sp` was written by the push that raised the
                // stack pointer above it, and entries are never read twice.
                (node_index, t_min, t_cell_max) = unsafe { stack[sp & STACK_MASK].assume_init() };
                if t_min <= best.t {
                    break;
                }
            }
        }
    }

    /// Tests the triangles of leaf `node` (of `leaf_blocks.nodes` with
    /// `BLOCKS`, else of `nodes`), lowering `best`; true when `ANY` and one
    /// was hit (the search is over).
    #[inline(always)]
    fn test_leaf<const ANY: bool, const BLOCKS: bool, C: Counters>(
        &self,
        ray: &ShearedRay,
        node: KdNode,
        best: &mut Hit,
        counts: &mut C,
    ) -> bool {
        if !BLOCKS {
            let range = node.leaf_range();
            for (&triangle, &[v0, v1, v2]) in self.leaf_triangles[range.clone()]
                .iter()
                .zip(&self.leaf_vertices[range])
            {
                counts.intersection();
                if let Some(t) = ray.intersect(v0, v1, v2, best.t) {
                    *best = Hit { t, triangle };
                    if ANY {
                        return true;
                    }
                }
            }
            return false;
        }
        for block in self.leaf_blocks.of_leaf(node) {
            let t = ray.intersect_block(block);
            // In the leaf's order, as one test after the other would: a
            // lane replaces the best hit only if strictly closer.
            for (&t, &triangle) in t.iter().zip(&block.triangles) {
                if triangle == Hit::MISS_INDEX {
                    break;
                }
                counts.intersection();
                if t > 0.0 && t < best.t * ray.scale {
                    *best = Hit {
                        t: t * ray.inv_scale,
                        triangle,
                    };
                    if ANY {
                        return true;
                    }
                }
            }
        }
        false
    }
}
