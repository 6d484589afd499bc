//! Building the wide BVH: a binary tree by binned SAH (Wald 2007, "On fast
//! construction of SAH-based bounding volume hierarchies"), collapsed into
//! nodes of up to eight children by opening the largest child first (the
//! way Embree's BVH8 builder widens its binary tree).

use glam::Vec3;
use rayon::prelude::*;

use super::spatial;
use super::{Bvh8, BvhSettings, EMPTY_CHILD, LEAF_BIT, MAX_LEAF, Node8, WIDTH};
use crate::accel::kdtree::leaf_blocks::{BLOCK, LeafBlock};
use crate::accel::kdtree::watertight::has_area;
use crate::geom::aabb::Aabb;

/// Centroid bins per axis of the SAH sweep.
const BINS: usize = 16;
/// Below this many triangles a subtree is built on the calling thread.
const PARALLEL_MIN: usize = 4096;
/// Past this depth a node splits at the object median, which bounds the
/// depth of any input (and so the traversal stack) by this plus log2(n).
const SAH_DEPTH: usize = 48;

/// A reference to a triangle: its box (the part of the triangle in the
/// node's region, after spatial splits), that box's centroid (twice the
/// box centre: no halving) and the triangle's index.
#[derive(Clone, Copy)]
pub(super) struct Prim {
    pub bounds: Aabb,
    pub centroid: Vec3,
    pub index: u32,
}

impl Prim {
    pub fn new(bounds: Aabb, index: u32) -> Prim {
        Prim {
            bounds,
            centroid: bounds.min + bounds.max,
            index,
        }
    }
}

/// The SAH's count term of a side: its blocks of four (the leaves' test
/// unit).
fn blocks_cost(n: u32) -> f32 {
    n.div_ceil(BLOCK as u32) as f32
}

/// The binary tree before widening; a leaf holds its triangles' indices,
/// ascending.
enum Bvh2 {
    Leaf { bounds: Aabb, ids: Vec<u32> },
    Inner { bounds: Aabb, children: Box<[Bvh2; 2]> },
}

impl Bvh2 {
    fn bounds(&self) -> Aabb {
        match self {
            Bvh2::Leaf { bounds, .. } | Bvh2::Inner { bounds, .. } => *bounds,
        }
    }
}

/// What every node of one build shares.
struct Ctx<'a> {
    triangles: &'a [[Vec3; 3]],
    /// Spatial splits are tried where the object split's children overlap
    /// by more than this area (`BvhSettings::spatial_alpha` of the scene's);
    /// infinite when spatial splits are off.
    overlap_min: f32,
    /// `BvhSettings::spatial_min_span`.
    min_span: f32,
}

/// The whole build: binary tree, widening, leaf blocks in the frame.
pub(super) fn build(triangles: &[[Vec3; 3]], frame_scale: f32, params: &BvhSettings) -> Bvh8 {
    // Triangles without area are left out, as the kd-tree leaves them out.
    let prims: Vec<Prim> = triangles
        .par_iter()
        .enumerate()
        .filter(|(_, t)| has_area(t))
        .map(|(i, t)| Prim::new(Aabb::from_points(t.iter()), i as u32))
        .collect();
    let scene = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds));
    let budget = (triangles.len() as f64 * f64::from(params.spatial_split_budget.max(0.0))) as usize;
    let ctx = Ctx {
        triangles,
        overlap_min: if budget > 0 {
            params.spatial_alpha * scene.surface_area()
        } else {
            f32::INFINITY
        },
        min_span: params.spatial_min_span,
    };
    let root = build_binary(prims, 0, budget, &ctx);
    let bounds = root.bounds();
    // Boxes are widened by a few ulps of the scene's largest coordinate, so
    // that a hit the watertight test accepts (in the sheared frame, with its
    // own rounding) is never in a box the slab test rounds away.
    let largest = bounds.min.abs().max(bounds.max.abs()).max_element();
    let pad = largest * (8.0 * f32::EPSILON) + f32::MIN_POSITIVE;
    let mut out = Bvh8 {
        nodes: Vec::new(),
        blocks: Vec::new(),
        bounds,
        frame_scale,
        contact: 1e-6 * bounds.diagonal(),
    };
    let mut widen = Widen {
        triangles,
        pad,
        out: &mut out,
    };
    match &root {
        Bvh2::Leaf { .. } => {
            out_root_leaf(&mut widen, &root);
        }
        Bvh2::Inner { .. } => {
            widen.node(&root);
        }
    }
    out
}

/// A tree of one leaf: a root node with that leaf as its only child.
fn out_root_leaf(widen: &mut Widen, leaf: &Bvh2) {
    widen.out.nodes.push(Node8::EMPTY);
    let child = widen.child(leaf);
    widen.set_slot(0, 0, leaf.bounds(), child);
}

/// The binary tree over `prims`, which spatial splits may grow by up to
/// `budget` references.
fn build_binary(prims: Vec<Prim>, depth: usize, budget: usize, ctx: &Ctx) -> Bvh2 {
    let bounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds));
    if prims.len() <= MAX_LEAF {
        let mut ids: Vec<u32> = prims.iter().map(|p| p.index).collect();
        ids.sort_unstable();
        ids.dedup();
        return Bvh2::Leaf { bounds, ids };
    }
    let n = prims.len();
    let (below, above) = split(prims, bounds, depth, budget, ctx);
    // A spatial split whose clipped side came out empty leaves one side
    // with fewer references than the node: go on with that side alone.
    if below.is_empty() || above.is_empty() {
        let rest = if below.is_empty() { above } else { below };
        return build_binary(rest, depth + 1, budget, ctx);
    }
    let (nb, na) = (below.len(), above.len());
    let rest = budget.saturating_sub((nb + na).saturating_sub(n));
    let budget_below = rest * nb / (nb + na);
    let recurse = |side, budget| build_binary(side, depth + 1, budget, ctx);
    let (a, b) = if nb + na >= PARALLEL_MIN {
        rayon::join(|| recurse(below, budget_below), || recurse(above, rest - budget_below))
    } else {
        (recurse(below, budget_below), recurse(above, rest - budget_below))
    };
    Bvh2::Inner {
        bounds,
        children: Box::new([a, b]),
    }
}

/// The two sides of a node: by the SAH's best object split, or its best
/// spatial split where that is cheaper and fits the budget, or past
/// `SAH_DEPTH` (or without an object split) at the median.
fn split(mut prims: Vec<Prim>, bounds: Aabb, depth: usize, budget: usize, ctx: &Ctx) -> (Vec<Prim>, Vec<Prim>) {
    if depth >= SAH_DEPTH {
        let mid = median_partition(&mut prims);
        let above = prims.split_off(mid);
        return (prims, above);
    }
    let object = best_object_split(&prims);
    let overlap = object.map_or(bounds.surface_area(), |o| o.below.intersection(o.above).surface_area());
    if budget > 0 && overlap > ctx.overlap_min && prims.len() >= spatial::MIN_REFERENCES {
        let spatial = spatial::best(&prims, bounds, ctx.min_span)
            .filter(|s| object.is_none_or(|o| s.cost < o.cost))
            .filter(|s| spatial::fits(&prims, *s, budget));
        if let Some(s) = spatial {
            return spatial::partition(prims, s, ctx.triangles);
        }
    }
    let mid = match object {
        Some(o) => partition(&mut prims, |p| o.bin(p) < o.boundary),
        None => median_partition(&mut prims),
    };
    let mid = if mid == 0 || mid == prims.len() {
        median_partition(&mut prims)
    } else {
        mid
    };
    let above = prims.split_off(mid);
    (prims, above)
}

/// An object split: the prims whose centroid bin is below `boundary` on
/// `axis` go below.
#[derive(Clone, Copy)]
struct ObjectSplit {
    cost: f32,
    axis: usize,
    boundary: usize,
    origin: f32,
    scale: f32,
    below: Aabb,
    above: Aabb,
}

impl ObjectSplit {
    fn bin(&self, p: &Prim) -> usize {
        (((p.centroid[self.axis] - self.origin) * self.scale) as u32 as usize).min(BINS - 1)
    }
}

/// The SAH's best bin boundary over all three axes (Wald 2007), or `None`
/// when the centroids do not spread.
fn best_object_split(prims: &[Prim]) -> Option<ObjectSplit> {
    let centroids = prims.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.centroid));
    let extent = centroids.extent();
    let mut best: Option<ObjectSplit> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let mut split = ObjectSplit {
            cost: f32::INFINITY,
            axis,
            boundary: 0,
            origin: centroids.min[axis],
            scale: BINS as f32 * (1.0 - f32::EPSILON) / extent[axis],
            below: Aabb::EMPTY,
            above: Aabb::EMPTY,
        };
        let mut counts = [0u32; BINS];
        let mut boxes = [Aabb::EMPTY; BINS];
        for p in prims.iter() {
            let b = split.bin(p);
            counts[b] += 1;
            boxes[b] = boxes[b].union(p.bounds);
        }
        sweep(&boxes, &counts, &counts, |b, cost, below, above, n| {
            if n as usize != prims.len() && best.is_none_or(|o| cost < o.cost) {
                split.cost = cost;
                split.boundary = b;
                split.below = below;
                split.above = above;
                best = Some(split);
            }
        });
    }
    best
}

/// The SAH's sweep over `N` bins: for each boundary `b` between bins
/// `b - 1` and `b`, the references entering a bin before it (`enter`) on
/// one side, those leaving at or after it (`leave`) on the other (for an
/// object split both are the bins' counts), each side's area times its
/// blocks, swept from the right then from the left. `visit(b, cost, below,
/// above, n_below)` sees every boundary with references below it; an
/// empty side above costs infinity.
pub(super) fn sweep<const N: usize>(
    boxes: &[Aabb; N],
    enter: &[u32; N],
    leave: &[u32; N],
    mut visit: impl FnMut(usize, f32, Aabb, Aabb, u32),
) {
    let mut right = [(f32::INFINITY, Aabb::EMPTY); N];
    let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
    for b in (1..N).rev() {
        acc = acc.union(boxes[b]);
        n += leave[b];
        if n > 0 {
            right[b] = (acc.surface_area() * blocks_cost(n), acc);
        }
    }
    let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
    for b in 1..N {
        acc = acc.union(boxes[b - 1]);
        n += enter[b - 1];
        if n > 0 {
            visit(b, acc.surface_area() * blocks_cost(n) + right[b].0, acc, right[b].1, n);
        }
    }
}

/// Splits at the median centroid along the widest axis of the centroids.
fn median_partition(prims: &mut [Prim]) -> usize {
    let centroids = prims.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.centroid));
    let axis = centroids.extent().max_position();
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    mid
}

/// Moves the prims for which `below` holds to the front; their count.
fn partition(prims: &mut [Prim], below: impl Fn(&Prim) -> bool) -> usize {
    let mut mid = 0;
    for i in 0..prims.len() {
        if below(&prims[i]) {
            prims.swap(i, mid);
            mid += 1;
        }
    }
    mid
}

/// Widening state: the nodes and blocks being written.
struct Widen<'a> {
    triangles: &'a [[Vec3; 3]],
    pad: f32,
    out: &'a mut Bvh8,
}

impl Widen<'_> {
    /// Writes an eight-wide node for the binary node `inner` and its
    /// subtrees (depth first, the node before its children); its index.
    fn node(&mut self, inner: &Bvh2) -> u32 {
        let index = self.out.nodes.len() as u32;
        self.out.nodes.push(Node8::EMPTY);
        let Bvh2::Inner { children, .. } = inner else {
            unreachable!("node() is called on inner nodes")
        };
        let mut kids: Vec<&Bvh2> = children.iter().collect();
        // Open the child of largest area until eight or only leaves remain.
        while kids.len() < WIDTH {
            let open = kids
                .iter()
                .enumerate()
                .filter(|(_, k)| matches!(k, Bvh2::Inner { .. }))
                .max_by(|a, b| a.1.bounds().surface_area().total_cmp(&b.1.bounds().surface_area()))
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let Bvh2::Inner { children, .. } = kids.swap_remove(i) else {
                unreachable!()
            };
            kids.extend(children.iter());
        }
        for (slot, kid) in kids.into_iter().enumerate() {
            let child = self.child(kid);
            self.set_slot(index, slot, kid.bounds(), child);
        }
        index
    }

    /// The child word of a binary node: a leaf's block, or a new node.
    fn child(&mut self, kid: &Bvh2) -> u32 {
        match kid {
            Bvh2::Leaf { ids, .. } => LEAF_BIT | self.block(ids),
            Bvh2::Inner { .. } => self.node(kid),
        }
    }

    /// Writes the block of a leaf's triangles (in ascending index, the
    /// order ties are broken in) and returns its index.
    fn block(&mut self, ids: &[u32]) -> u32 {
        let mut block = LeafBlock {
            v: [[0.0; BLOCK]; 9],
            triangles: [u32::MAX; BLOCK],
        };
        for (lane, &t) in ids.iter().enumerate() {
            for (vertex, p) in self.triangles[t as usize].iter().enumerate() {
                for axis in 0..3 {
                    block.v[3 * vertex + axis][lane] = p[axis] * self.out.frame_scale;
                }
            }
            block.triangles[lane] = t;
        }
        self.out.blocks.push(block);
        (self.out.blocks.len() - 1) as u32
    }

    fn set_slot(&mut self, node: u32, slot: usize, bounds: Aabb, child: u32) {
        debug_assert!(child != EMPTY_CHILD);
        let n = &mut self.out.nodes[node as usize];
        for axis in 0..3 {
            n.planes[axis][slot] = bounds.min[axis] - self.pad;
            n.planes[axis + 3][slot] = bounds.max[axis] + self.pad;
        }
        n.child[slot] = child;
        n.used |= 1 << slot;
    }
}
