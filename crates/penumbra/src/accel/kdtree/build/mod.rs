//! SAH kd-tree construction with the MLRTA paper's three rules
//! (Reshetov, Soupikov and Hurley 2005, section 3.1).
//!
//! The cost of a split is the surface-area heuristic of MacDonald and Booth:
//! `C = C_trav + C_isect * (SA(below)/SA(cell) * N_below + SA(above)/SA(cell) * N_above)`,
//! and a cell becomes a leaf when no split is cheaper than `C_isect * N`. On
//! top of it, applied in order at every cell:
//!
//! 1. **Empty cells**: if the triangles leave an empty slab at one side of the
//!    cell whose volume is more than `empty_cell_volume` (10%) of the cell's,
//!    cut it off first, whatever the SAH says.
//! 2. **Covered planes**: if an axis-aligned plane through the cell is covered
//!    entirely by triangles lying in it, split there and put those triangles
//!    in the smaller child. A plane on the cell's boundary yields a 2D (flat)
//!    cell holding them.
//! 3. **No tiny cells**: a cell whose surface area is below `min_cell_area`
//!    times the scene box's is not split further.
//!
//! Candidate planes come from the triangles' bounds clipped to the cell
//! ("perfect splits"; a straddling triangle is clipped to the cell once and
//! the polygon cut at the plane, `clip::split_clipped_bounds`). Cells with
//! more than a few triangles evaluate the SAH on a binned grid of planes
//! (O(N) per cell) and then sweep exactly only the events in the two bins
//! around the best boundary; the smallest cells sweep every event exactly
//! (Wald and Havran 2006). Up to 32 events the exact sweep counts the
//! triangles on each side of every event, eight events at a time, instead
//! of sorting them; it picks the plane the sorted sweep picks (a unit test
//! compares them). The rules above come first and are not binned. The two
//! children of large cells are built in parallel with rayon (in place on a
//! one-thread pool); a split allocates only its above side (the below side
//! is compacted in place, an empty cut moves the whole vector) and the
//! sweep's events live in a reused scratch.
//!
//! The build's speed against Embree's high-quality BVH build is in
//! docs/results/tracing.md ("Build"), with the command that measures it.

use glam::Vec3;

mod events;

use self::events::{COUNTED_EVENTS, Events, Sah, Window};
use super::clip::{clip_triangle, split_clipped_bounds};
use super::node::{KdNode, MAX_LEAF_TRIANGLES, MAX_TREE_DEPTH};
use super::watertight::has_area;
use crate::geom::aabb::Aabb;
use crate::progress::Bar;

/// Knobs of the builder. `Default` gives the settings the GPU's trees are
/// built with; `for_cpu` the CPU's (fewer, larger leaves for its vector
/// lanes).
#[derive(Debug, Clone, PartialEq)]
pub struct KdTreeSettings {
    /// Cost of one traversal step, relative to `intersection_cost`.
    pub traversal_cost: f32,
    /// Cost of one ray–triangle test, relative to a traversal step: 1.0,
    /// since the watertight test of one triangle costs about one traversal
    /// step when a leaf's triangles are tested in vector lanes; the cheaper
    /// test gives shallower trees with fewer references.
    pub intersection_cost: f32,
    /// SAH discount for splits with an empty child (0 = none). 0.5: fewer
    /// nodes and references and a faster build, at some cost to single
    /// rays in bigger leaves; a trade measured in docs/results/tracing.md
    /// ("Build").
    pub empty_bonus: f32,
    /// Rule 1: cut off an empty slab larger than this fraction of the cell's
    /// volume. Values >= 1 disable the rule.
    pub empty_cell_volume: f32,
    /// Rule 2: split on planes covered by coplanar triangles.
    pub coplanar_rule: bool,
    /// Rule 3: do not split cells with a surface area below this fraction of
    /// the scene box's. 0 disables the rule.
    pub min_cell_area: f32,
    /// Maximum depth; `None` picks `8 + 1.3 log2(N)` (capped at
    /// `MAX_TREE_DEPTH`, the traversal stack size).
    pub max_depth: Option<usize>,
    /// Cells with more triangles than this use binned SAH refined by an
    /// exact sweep of the two bins around the best boundary; smaller cells
    /// sweep all their events. 16 with 32 bins builds the bunny about 10%
    /// faster (304 -> 273 ms, one thread) than sweeping every cell of up to
    /// 1024 triangles, with the same trace speed (bunny and dragon100k
    /// primary rays within noise); 2 or 6 was slower than 16. Up to 32
    /// events (all cells of up to 16 triangles) the sweep counts instead of
    /// sorting (`COUNTED_EVENTS`).
    pub exact_sah_below: usize,
    /// Number of bins per axis for binned SAH (2 to `MAX_BINS`).
    pub bins: usize,
}

impl Default for KdTreeSettings {
    fn default() -> Self {
        KdTreeSettings {
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            empty_bonus: 0.5,
            empty_cell_volume: 0.1,
            coplanar_rule: true,
            min_cell_area: 1e-7,
            max_depth: None,
            exact_sah_below: 16,
            bins: 32,
        }
    }
}

impl KdTreeSettings {
    /// The settings for a tree walked on the CPU: `Default` with
    /// `traversal_cost` 4. The CPU tests a leaf's triangles several at a time
    /// in vector lanes (four a block for single rays, sixteen lanes for
    /// MLRTA's packets), so a traversal step costs several triangle tests
    /// there, and fewer, larger leaves pay: the bunny's tree has 78,619
    /// nodes instead of 224,185, builds in about two thirds of the time
    /// (build 186-210 -> 122-144 ms, `prepare` 12-16 -> 9 ms, one thread,
    /// three alternated rounds), and one
    /// thread traces 1024^2 MLRTA packets 10-13% faster on the bunny and
    /// dragon100k (the kitchen interior the same), the kd-tree's single
    /// rays as fast or faster and 1M random dragon100k rays 14% faster. On
    /// lavapipe the GPU kernels were 10-20% slower with it, one ray per
    /// invocation walking the nodes, so GPU trees keep `Default`
    /// (docs/results/tracing.md, "A tree for each device"). 2 gave about
    /// half the packets' gain, 3 most of it; 6 and 8 the same as 4 on the
    /// bunny and dragon100k, and 6 was 5% slower on the kitchen.
    pub fn for_cpu() -> KdTreeSettings {
        KdTreeSettings {
            traversal_cost: 4.0,
            ..KdTreeSettings::default()
        }
    }

    /// The depth at which a tree of `triangles` triangles stops splitting:
    /// `max_depth`, or `8 + 1.3 log2(N)` rounded, within 1..=`MAX_TREE_DEPTH`.
    pub fn depth_limit(&self, triangles: usize) -> usize {
        let auto = (8.0 + 1.3 * (triangles.max(1) as f32).log2()).round() as usize;
        self.max_depth.unwrap_or(auto).clamp(1, MAX_TREE_DEPTH)
    }
}

/// A triangle reference in a cell: its index and its bounds clipped to the cell.
#[derive(Clone, Copy)]
struct Prim {
    bounds: Aabb,
    tri: u32,
}

/// Why a cell was split, for the build statistics.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum SplitKind {
    Sah,
    EmptyCut,
    CoveredPlane,
}

/// Why a cell became a leaf, for the build statistics.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum LeafReason {
    Empty,
    Cost,
    SmallCell,
    DepthLimit,
    /// The tree's references reached `MAX_REFERENCES_PER_TRIANGLE`.
    ReferenceBudget,
}

/// Leaf references a subtree may hold per triangle of the root. Well-behaved
/// meshes use 2-6 (bunny 5.0); 50,000 overlapping tetrahedra used 368,
/// i.e. 73.6M references, 3.1 GB and 43 s. The budget is shared out down
/// the tree in proportion to the children's triangle counts, so a subtree
/// that duplicates a lot runs out where it duplicates (its cells become
/// leaves) while the rest of the tree is built as usual: memory and time
/// stay bounded, and only traversal through the overlap gets slower.
pub const MAX_REFERENCES_PER_TRIANGLE: usize = 16;

/// Below this many references per triangle in the whole tree the budget is
/// not enforced at all, so well-behaved meshes (bunny 5.0, kitchen 2.6)
/// get exactly the tree they always had; above `HARD_REFERENCES_PER_TRIANGLE`
/// every cell still to be built becomes a leaf.
const SOFT_REFERENCES_PER_TRIANGLE: usize = 8;
const HARD_REFERENCES_PER_TRIANGLE: usize = 32;

/// The flat arrays being built, with their statistics. Subtrees built in
/// parallel get their own `Output` and are appended with their indices moved.
#[derive(Default)]
pub(super) struct Output {
    pub nodes: Vec<KdNode>,
    pub leaf_triangles: Vec<u32>,
    pub stats: BuildStats,
    /// Scratch for the SAH sweep's events, reused from cell to cell.
    events: Events,
    /// Progress not yet reported (`Builder::leaf`).
    pending_progress: u64,
}

impl Output {
    fn push_leaf(&mut self, prims: &[Prim], reason: LeafReason, depth: usize) {
        let s = &mut self.stats;
        s.depth = s.depth.max(depth);
        s.leaves += 1;
        match reason {
            _ if prims.is_empty() => s.empty_leaves += 1,
            LeafReason::SmallCell => s.small_cell_leaves += 1,
            LeafReason::DepthLimit => s.depth_limited_leaves += 1,
            LeafReason::ReferenceBudget => s.budget_leaves += 1,
            LeafReason::Empty | LeafReason::Cost => {}
        }
        s.max_triangles_per_leaf = s.max_triangles_per_leaf.max(prims.len());
        self.nodes
            .push(KdNode::leaf(self.leaf_triangles.len() as u32, prims.len() as u32));
        self.leaf_triangles.extend(prims.iter().map(|p| p.tri));
    }

    fn count_split(&mut self, kind: SplitKind, depth: usize) {
        self.stats.depth = self.stats.depth.max(depth);
        match kind {
            SplitKind::EmptyCut => self.stats.empty_cuts += 1,
            SplitKind::CoveredPlane => self.stats.covered_plane_splits += 1,
            SplitKind::Sah => {}
        }
    }

    /// Appends a subtree built separately, moving its child and leaf indices.
    fn append(&mut self, sub: Output) {
        let node_base = self.nodes.len() as u32;
        let leaf_base = self.leaf_triangles.len() as u32;
        self.nodes.extend(sub.nodes.into_iter().map(|n| {
            if n.is_leaf() {
                KdNode {
                    word0: n.word0 + leaf_base,
                    ..n
                }
            } else {
                KdNode {
                    word1: n.word1 + (node_base << 2),
                    ..n
                }
            }
        }));
        self.leaf_triangles.extend(sub.leaf_triangles);
        let (s, t) = (&mut self.stats, sub.stats);
        s.depth = s.depth.max(t.depth);
        s.leaves += t.leaves;
        s.empty_leaves += t.empty_leaves;
        s.small_cell_leaves += t.small_cell_leaves;
        s.depth_limited_leaves += t.depth_limited_leaves;
        s.budget_leaves += t.budget_leaves;
        s.max_triangles_per_leaf = s.max_triangles_per_leaf.max(t.max_triangles_per_leaf);
        s.empty_cuts += t.empty_cuts;
        s.covered_plane_splits += t.covered_plane_splits;
    }
}

/// Most bins `binned_split` uses (the counts live on the stack).
pub const MAX_BINS: usize = 256;

#[derive(Clone, Copy, Debug)]
struct Split {
    axis: usize,
    pos: f32,
    /// Where triangles lying in the split plane go.
    planar_below: bool,
    kind: SplitKind,
    cost: f32,
}

pub(super) struct Builder<'a> {
    triangles: &'a [[Vec3; 3]],
    params: &'a KdTreeSettings,
    max_depth: usize,
    /// Leaf references made so far in the whole tree (triangles plus the
    /// duplicates splits made), and the soft and hard limits on them.
    references: std::sync::atomic::AtomicUsize,
    soft_references: usize,
    hard_references: usize,
    /// The power of two areas are measured in (`watertight::frame_scale`):
    /// in world units the areas of cells of a 1e-19 scene underflow and the
    /// SAH degenerates (469 nodes for the bunny instead of 426,541).
    frame: f32,
    scene_area: f32,
    /// Advanced by each leaf's share of the triangles (`build_cell`).
    progress: &'a Bar,
    progress_step: u64,
    /// Whether subtrees are built in parallel (the pool has several
    /// threads); on one thread they are built in place, saving the copies
    /// of their nodes into the parent's arrays.
    parallel: bool,
}

/// Cells with more triangles than this build their children in parallel.
const PARALLEL_BELOW: usize = 2048;

impl<'a> Builder<'a> {
    /// `frame`: the tree's `frame_scale`, in which areas are measured.
    /// `progress`: a bar of `triangles.len()` steps, full when the tree is.
    pub fn new(
        triangles: &'a [[Vec3; 3]],
        params: &'a KdTreeSettings,
        (bounds, frame): (&Aabb, f32),
        progress: &'a Bar,
    ) -> Self {
        Builder {
            triangles,
            params,
            max_depth: params.depth_limit(triangles.len()),
            references: std::sync::atomic::AtomicUsize::new(triangles.len()),
            soft_references: triangles.len().saturating_mul(SOFT_REFERENCES_PER_TRIANGLE),
            hard_references: triangles.len().saturating_mul(HARD_REFERENCES_PER_TRIANGLE),
            frame,
            scene_area: bounds.surface_area_in(frame),
            progress,
            progress_step: (triangles.len() as u64 / 1024).max(1),
            parallel: rayon::current_num_threads() > 1,
        }
    }

    pub fn build(&self, bounds: Aabb) -> Output {
        let prims: Vec<Prim> = self
            .triangles
            .iter()
            .enumerate()
            .filter(|(_, t)| has_area(t))
            .map(|(i, t)| Prim {
                bounds: Aabb::from_points(t),
                tri: i as u32,
            })
            .collect();
        let mut out = Output::default();
        let budget = prims.len().saturating_mul(MAX_REFERENCES_PER_TRIANGLE);
        let share = prims.len() as u64;
        self.build_cell(prims, bounds, (0, budget, share), &mut out);
        self.flush_progress(&mut out);
        out
    }

    /// `at`: the cell's depth, the leaf references its subtree may hold,
    /// and its share of the progress bar: the root's is every triangle,
    /// shared out like the budget, so the bar is full exactly when the last
    /// leaf is made and moves with each leaf, not only with the top splits.
    fn build_cell(&self, prims: Vec<Prim>, cell: Aabb, at: (usize, usize, u64), out: &mut Output) {
        let (depth, budget, share) = at;
        if prims.is_empty() {
            return self.leaf(out, &prims, LeafReason::Empty, (depth, share));
        }
        if depth >= self.max_depth {
            return self.leaf(out, &prims, LeafReason::DepthLimit, (depth, share));
        }
        let made = self.references.load(std::sync::atomic::Ordering::Relaxed);
        // A cell whose share would leave a split's children less than their
        // own triangles, once the tree as a whole duplicates a lot.
        let spent = prims.len() * 2 > budget && made > self.soft_references;
        if spent || made > self.hard_references {
            return self.leaf(out, &prims, LeafReason::ReferenceBudget, (depth, share));
        }
        if cell.surface_area_in(self.frame) < self.params.min_cell_area * self.scene_area {
            return self.leaf(out, &prims, LeafReason::SmallCell, (depth, share));
        }
        let (used, planar) = extent_and_planar_axes(&prims);
        let split = self
            .empty_cut(&used, &cell)
            .or_else(|| self.covered_plane(&prims, &cell, planar))
            .or_else(|| self.best_sah_split(&prims, &cell, &mut out.events));
        let leaf_cost = self.params.intersection_cost * prims.len() as f32;
        match split.filter(|s| s.kind != SplitKind::Sah || s.cost < leaf_cost) {
            Some(split) => self.split_cell(prims, cell, at, split, out),
            // Unreachable in practice (2^30 triangles in one cell): split at
            // the middle rather than overflow the leaf's count field.
            None if prims.len() as u32 > MAX_LEAF_TRIANGLES => {
                let split = self.midpoint_split(&cell, cell.extent().max_position());
                self.split_cell(prims, cell, at, split, out)
            }
            None => self.leaf(out, &prims, LeafReason::Cost, (depth, share)),
        }
    }

    /// The bar advances in steps of at least `progress_step`: a step per
    /// leaf (213K on the bunny) read the clock and took a lock each time.
    fn leaf(&self, out: &mut Output, prims: &[Prim], reason: LeafReason, (depth, share): (usize, u64)) {
        out.push_leaf(prims, reason, depth);
        out.pending_progress += share;
        if out.pending_progress >= self.progress_step {
            self.flush_progress(out);
        }
    }

    fn flush_progress(&self, out: &mut Output) {
        self.progress.inc(out.pending_progress);
        out.pending_progress = 0;
    }

    fn split_cell(
        &self,
        prims: Vec<Prim>,
        cell: Aabb,
        (depth, budget, share): (usize, usize, u64),
        split: Split,
        out: &mut Output,
    ) {
        let n = prims.len();
        let (below, below_cell, above, above_cell) = self.partition(prims, &cell, &split);
        let duplicated = (below.len() + above.len()).saturating_sub(n);
        self.references
            .fetch_add(duplicated, std::sync::atomic::Ordering::Relaxed);
        // The budget follows the references: a child gets its share of them.
        let total = (below.len() + above.len()).max(1);
        let below_budget = (budget as u128 * below.len() as u128 / total as u128) as usize;
        let below_share = (share as u128 * below.len() as u128 / total as u128) as u64;
        let below_at = (depth + 1, below_budget, below_share);
        let above_at = (depth + 1, budget - below_budget, share - below_share);
        out.count_split(split.kind, depth);
        let index = out.nodes.len();
        out.nodes.push(KdNode::leaf(0, 0)); // replaced below
        if n > PARALLEL_BELOW && self.parallel {
            let build = |prims, cell, at| {
                let mut sub = Output::default();
                self.build_cell(prims, cell, at, &mut sub);
                self.flush_progress(&mut sub);
                sub
            };
            let (b, a) = rayon::join(
                || build(below, below_cell, below_at),
                || build(above, above_cell, above_at),
            );
            out.append(b);
            let above_index = out.nodes.len() as u32;
            out.append(a);
            out.nodes[index] = KdNode::interior(split.axis, split.pos, above_index);
        } else {
            self.build_cell(below, below_cell, below_at, out);
            let above_index = out.nodes.len() as u32;
            self.build_cell(above, above_cell, above_at, out);
            out.nodes[index] = KdNode::interior(split.axis, split.pos, above_index);
        }
    }

    fn midpoint_split(&self, cell: &Aabb, axis: usize) -> Split {
        Split {
            axis,
            pos: cell.center()[axis],
            planar_below: true,
            kind: SplitKind::Sah,
            cost: 0.0,
        }
    }

    /// Rule 1: the largest empty slab at a side of the cell, if it exceeds the
    /// volume threshold. For a flat cell the volume ratio is measured on the
    /// cell's non-degenerate extent, which is the same ratio.
    /// `used`: the box of the cell's triangles (clipped to it).
    fn empty_cut(&self, used: &Aabb, cell: &Aabb) -> Option<Split> {
        let extent = cell.extent();
        let mut best: Option<(f32, Split)> = None;
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                continue;
            }
            for (gap, pos, planar_below) in [
                (used.min[axis] - cell.min[axis], used.min[axis], false),
                (cell.max[axis] - used.max[axis], used.max[axis], true),
            ] {
                let ratio = gap / extent[axis];
                if ratio > self.params.empty_cell_volume && best.is_none_or(|(r, _)| ratio > r) {
                    let split = Split {
                        axis,
                        pos,
                        planar_below,
                        kind: SplitKind::EmptyCut,
                        cost: 0.0,
                    };
                    best = Some((ratio, split));
                }
            }
        }
        best.map(|(_, s)| s)
    }

    /// Rule 2: a plane entirely covered by triangles lying in it. Coverage is
    /// judged by area: the coplanar triangles' areas inside the cell add up to
    /// the cell's cross-section (a mesh's triangles do not overlap).
    /// `planar[axis]`: whether any triangle is flat along `axis`.
    fn covered_plane(&self, prims: &[Prim], cell: &Aabb, planar: [bool; 3]) -> Option<Split> {
        if !self.params.coplanar_rule {
            return None;
        }
        let extent = cell.extent() * self.frame;
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                continue;
            }
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let cross_section = extent[u] * extent[v];
            if cross_section <= 0.0 {
                continue;
            }
            if !planar[axis] {
                continue;
            }
            let is_planar = |p: &&Prim| p.bounds.min[axis] == p.bounds.max[axis];
            let mut planar: Vec<(f32, u32)> = prims
                .iter()
                .filter(is_planar)
                .map(|p| (p.bounds.min[axis], p.tri))
                .collect();
            planar.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
            for group in planar.chunk_by(|a, b| a.0 == b.0) {
                let pos = group[0].0;
                let area: f32 = group
                    .iter()
                    .map(|&(_, t)| clip_triangle(&self.triangles[t as usize], cell).area_in(self.frame))
                    .sum();
                if area >= cross_section * (1.0 - 1e-4) {
                    let below_volume = pos - cell.min[axis];
                    let above_volume = cell.max[axis] - pos;
                    // A covered plane on the boundary with nothing else in the
                    // cell would split off an identical flat cell forever.
                    if group.len() == prims.len() && (below_volume == 0.0 || above_volume == 0.0) {
                        continue;
                    }
                    return Some(Split {
                        axis,
                        pos,
                        planar_below: below_volume <= above_volume,
                        kind: SplitKind::CoveredPlane,
                        cost: 0.0,
                    });
                }
            }
        }
        None
    }

    fn sah(&self, cell: &Aabb, axis: usize) -> Sah {
        let k = self.frame;
        let e = cell.extent() * k;
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let inv_area = 1.0 / cell.surface_area_in(k);
        Sah {
            lo: cell.min[axis],
            hi: cell.max[axis],
            // SA(child) / SA(cell) = (2 e_u e_v + 2 len (e_u + e_v)) / SA(cell),
            // in the frame (a world length times k).
            constant: 2.0 * e[u] * e[v] * inv_area,
            per_length: 2.0 * (e[u] + e[v]) * k * inv_area,
            traversal: self.params.traversal_cost,
            intersection: self.params.intersection_cost,
            empty_factor: 1.0 - self.params.empty_bonus,
        }
    }

    fn best_sah_split(&self, prims: &[Prim], cell: &Aabb, events: &mut Events) -> Option<Split> {
        if cell.surface_area_in(self.frame) <= 0.0 {
            return None;
        }
        (0..3)
            .filter(|&axis| cell.extent()[axis] > 0.0)
            .filter_map(|axis| {
                if prims.len() > self.params.exact_sah_below {
                    self.binned_split(prims, cell, axis, events)
                } else {
                    self.swept_split(prims, cell, axis, events, Window::all(prims.len()))
                }
            })
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
    }

    /// Exact SAH over the start, end and planar events of one axis that fall
    /// in `window` (all of them, or those of a few bins, see `binned_split`):
    /// counted at each event when there are few of them, swept in sorted
    /// order otherwise. Both give the same plane (the lowest of the
    /// cheapest, planar triangles below before above).
    fn swept_split(
        &self,
        prims: &[Prim],
        cell: &Aabb,
        axis: usize,
        events: &mut Events,
        window: Window,
    ) -> Option<Split> {
        events.gather(prims, axis, &window);
        let sah = self.sah(cell, axis);
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        let best = if events.len() <= COUNTED_EVENTS && events.lens[2] == 0 {
            events.pad();
            events.counted_best_lanes(&sah, window.counts_before)
        } else if events.len() <= COUNTED_EVENTS {
            events.pad();
            events.counted_best(&sah, (lo, hi), window.counts_before)
        } else {
            events.sorted_best(&sah, (lo, hi), window.counts_before)
        };
        best.map(|(pos, planar_below, cost)| Split {
            axis,
            pos,
            planar_below,
            kind: SplitKind::Sah,
            cost,
        })
    }

    /// Binned SAH over `bins` evenly spaced planes (O(N), Wald 2007), then an
    /// exact sweep of the events inside the two bins around the best
    /// boundary, so that the chosen plane is a triangle's bound as in the
    /// exact sweep (Wald and Havran 2006) at the cost of sorting a few events
    /// instead of all of them. The partition that follows is exact, so
    /// binning only affects which plane is chosen.
    fn binned_split(&self, prims: &[Prim], cell: &Aabb, axis: usize, events: &mut Events) -> Option<Split> {
        let bins = self.params.bins.clamp(2, MAX_BINS);
        let (lo, extent) = (cell.min[axis], cell.extent()[axis]);
        let scale = bins as f32 / extent;
        // Monotone in x, so the events of a run of bins are a run of
        // positions. A planar triangle counts as a start and an end in its bin.
        // Each triangle's bins are kept for the sweep's window.
        // Through u32: a saturating f32 -> usize conversion is a dozen
        // instructions on x86-64 (no unsigned 64-bit convert below
        // AVX-512), and it was a third of this loop; the bins are the same.
        let bin = |x: f32| (((x - lo) * scale) as u32).min(bins as u32 - 1) as usize;
        let mut starts = [0u32; MAX_BINS];
        let mut ends = [0u32; MAX_BINS];
        events.bins.clear();
        for p in prims {
            let (b0, b1) = (bin(p.bounds.min[axis]), bin(p.bounds.max[axis]));
            starts[b0] += 1;
            ends[b1] += 1;
            events.bins.push([b0 as u8, b1 as u8]);
        }
        let sah = self.sah(cell, axis);
        let mut best: Option<(usize, Split)> = None;
        let mut n_below = starts[0] as usize;
        let mut n_above = prims.len();
        for k in 1..bins {
            n_above -= ends[k - 1] as usize;
            let pos = lo + extent * (k as f32 / bins as f32);
            let cost = sah.cost(pos, n_below, n_above);
            if best.is_none_or(|(_, b)| cost < b.cost) {
                let split = Split {
                    axis,
                    pos,
                    planar_below: true,
                    kind: SplitKind::Sah,
                    cost,
                };
                best = Some((k, split));
            }
            n_below += starts[k] as usize;
        }
        let (k, binned) = best?;
        // Bins k-1 and k, and the counts of the triangles left of them.
        let first = k - 1;
        let counts_before = (
            starts[..first].iter().sum::<u32>() as usize,
            prims.len() - ends[..first].iter().sum::<u32>() as usize,
        );
        let window = Window {
            bins: Some((first as u8, k as u8)),
            counts_before,
        };
        let swept = self.swept_split(prims, cell, axis, events, window);
        match swept {
            Some(s) if s.cost <= binned.cost => Some(s),
            _ => Some(binned),
        }
    }

    /// Sends each triangle to the children it overlaps, clipping the bounds of
    /// those that straddle the plane. The below side is compacted in place in
    /// `prims` (each triangle read yields at most one below), so a split
    /// allocates only the above side's vector.
    fn partition(&self, mut prims: Vec<Prim>, cell: &Aabb, s: &Split) -> (Vec<Prim>, Aabb, Vec<Prim>, Aabb) {
        let (a, pos) = (s.axis, s.pos);
        let mut below_cell = *cell;
        below_cell.max[a] = pos;
        let mut above_cell = *cell;
        above_cell.min[a] = pos;
        if s.kind == SplitKind::EmptyCut {
            // Rule 1 cuts at the triangles' own bound: all of them go to the
            // other side (planar ones at the bound with them), unchanged.
            return if s.planar_below {
                (prims, below_cell, Vec::new(), above_cell)
            } else {
                (Vec::new(), below_cell, prims, above_cell)
            };
        }
        // Room for all: counting first was a pass of its own over the cell,
        // and memory past what is written is never touched.
        let mut above = Vec::with_capacity(prims.len());
        let mut kept = 0;
        for i in 0..prims.len() {
            let p = prims[i];
            let (lo, hi) = (p.bounds.min[a], p.bounds.max[a]);
            let below = if lo == pos && hi == pos {
                if s.planar_below {
                    Some(p)
                } else {
                    above.push(p);
                    None
                }
            } else if hi <= pos {
                Some(p)
            } else if lo >= pos {
                above.push(p);
                None
            } else {
                let tri = &self.triangles[p.tri as usize];
                let (below, bounds) = split_clipped_bounds(tri, cell, a, pos);
                if !bounds.is_empty() {
                    above.push(Prim { bounds, tri: p.tri });
                }
                (!below.is_empty()).then_some(Prim {
                    bounds: below,
                    tri: p.tri,
                })
            };
            if let Some(b) = below {
                prims[kept] = b;
                kept += 1;
            }
        }
        prims.truncate(kept);
        (prims, below_cell, above, above_cell)
    }
}

/// The box of a cell's triangles and, per axis, whether any is flat along
/// it: rules 1 and 2 need both, in one pass over the cell.
fn extent_and_planar_axes(prims: &[Prim]) -> (Aabb, [bool; 3]) {
    let mut used = Aabb::EMPTY;
    let mut planar = [false; 3];
    for p in prims {
        used = used.union(p.bounds);
        for (axis, flat) in planar.iter_mut().enumerate() {
            *flat |= p.bounds.min[axis] == p.bounds.max[axis];
        }
    }
    (used, planar)
}

/// Statistics of a built tree, as `penumbra trace --json` reports them.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct BuildStats {
    /// Triangles given to the build, those without area (which no leaf
    /// holds) included.
    pub triangles: usize,
    /// Nodes, interior and leaves.
    pub nodes: usize,
    /// Leaves, empty ones included.
    pub leaves: usize,
    /// Leaves that hold no triangle.
    pub empty_leaves: usize,
    /// Splits from the root (depth 0) to the deepest leaf.
    pub depth: usize,
    /// The depth no cell was split beyond (`KdTreeSettings::depth_limit`).
    pub depth_limit: usize,
    /// Triangle references in leaves (a triangle may be in several).
    pub leaf_references: usize,
    /// Triangles in the fullest leaf.
    pub max_triangles_per_leaf: usize,
    /// Mean over non-empty leaves.
    pub mean_triangles_per_leaf: f64,
    /// Splits that cut off an empty slab (rule 1).
    pub empty_cuts: usize,
    /// Splits on a plane covered by triangles lying in it (rule 2).
    pub covered_plane_splits: usize,
    /// Non-empty leaves made because the cell was too small to split
    /// (rule 3, `min_cell_area`).
    pub small_cell_leaves: usize,
    /// Non-empty leaves made at the depth limit.
    pub depth_limited_leaves: usize,
    /// Leaves made because the reference budget was spent (overlapping
    /// geometry; see `MAX_REFERENCES_PER_TRIANGLE`).
    pub budget_leaves: usize,
    /// The builder's `traversal_cost` (4 for the CPU's trees, 1 for the
    /// GPU's: `KdTreeSettings::for_cpu`).
    pub traversal_cost: f32,
    /// Wall-clock milliseconds of the build, the leaves' vertex blocks
    /// included (the input's checks not).
    pub build_ms: f64,
}

/// Fills in the statistics that need the whole tree.
pub(super) fn finish_stats(out: &mut Output) {
    let s = &mut out.stats;
    let non_empty = s.leaves - s.empty_leaves;
    s.nodes = out.nodes.len();
    s.leaf_references = out.leaf_triangles.len();
    s.mean_triangles_per_leaf = if non_empty > 0 {
        out.leaf_triangles.len() as f64 / non_empty as f64
    } else {
        0.0
    };
}
