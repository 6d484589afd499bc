//! Building the wide BVH: a binary tree by binned SAH (Wald 2007, "On fast
//! construction of SAH-based bounding volume hierarchies"), collapsed into
//! nodes of up to eight children by opening the largest child first (the
//! way Embree's BVH8 builder widens its binary tree).

use glam::Vec3;
use rayon::prelude::*;

use super::{Bvh8, EMPTY_CHILD, LEAF_BIT, MAX_LEAF, Node8, WIDTH};
use crate::aabb::Aabb;
use crate::kdtree::leaf_blocks::{BLOCK, LeafBlock};

/// Centroid bins per axis of the SAH sweep.
const BINS: usize = 16;
/// Below this many triangles a subtree is built on the calling thread.
const PARALLEL_MIN: usize = 4096;
/// Past this depth a node splits at the object median, which bounds the
/// depth of any input (and so the traversal stack) by this plus log2(n).
const SAH_DEPTH: usize = 48;

/// A triangle's bounds and centroid (twice the box centre: no halving).
#[derive(Clone, Copy)]
struct Prim {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

/// The binary tree before widening; a leaf holds `prims[first..first + len]`.
enum Bvh2 {
    Leaf { bounds: Aabb, first: usize, len: usize },
    Inner { bounds: Aabb, children: Box<[Bvh2; 2]> },
}

impl Bvh2 {
    fn bounds(&self) -> Aabb {
        match self {
            Bvh2::Leaf { bounds, .. } | Bvh2::Inner { bounds, .. } => *bounds,
        }
    }
}

/// The whole build: binary tree, widening, leaf blocks in the frame.
pub(super) fn build(triangles: &[[Vec3; 3]], frame_scale: f32) -> Bvh8 {
    let mut prims: Vec<Prim> = triangles
        .par_iter()
        .enumerate()
        .map(|(i, t)| {
            let bounds = Aabb::from_points(t.iter());
            Prim {
                bounds,
                centroid: bounds.min + bounds.max,
                index: i as u32,
            }
        })
        .collect();
    let root = build_binary(&mut prims, 0, 0);
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
        prims: &prims,
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

/// The binary tree over `prims` (reordered in place; `offset` is the
/// slice's start in the whole array, which leaves record).
fn build_binary(prims: &mut [Prim], offset: usize, depth: usize) -> Bvh2 {
    let bounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds));
    if prims.len() <= MAX_LEAF {
        return Bvh2::Leaf {
            bounds,
            first: offset,
            len: prims.len(),
        };
    }
    let mid = if depth < SAH_DEPTH { sah_partition(prims) } else { None }.unwrap_or_else(|| median_partition(prims));
    let (below, above) = prims.split_at_mut(mid);
    let (a, b) = if below.len() + above.len() >= PARALLEL_MIN {
        rayon::join(
            || build_binary(below, offset, depth + 1),
            || build_binary(above, offset + mid, depth + 1),
        )
    } else {
        (
            build_binary(below, offset, depth + 1),
            build_binary(above, offset + mid, depth + 1),
        )
    };
    Bvh2::Inner {
        bounds,
        children: Box::new([a, b]),
    }
}

/// Splits at the SAH's best bin boundary over all three axes; the index of
/// the first triangle above it, or `None` when the centroids do not spread.
fn sah_partition(prims: &mut [Prim]) -> Option<usize> {
    let centroids = prims.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.centroid));
    let extent = centroids.extent();
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 * (1.0 - f32::EPSILON) / extent[axis];
        let bin_of = |p: &Prim| (((p.centroid[axis] - centroids.min[axis]) * scale) as u32 as usize).min(BINS - 1);
        let mut counts = [0u32; BINS];
        let mut boxes = [Aabb::EMPTY; BINS];
        for p in prims.iter() {
            let b = bin_of(p);
            counts[b] += 1;
            boxes[b] = boxes[b].union(p.bounds);
        }
        // Cost of a side: its area times its blocks of four (the leaves'
        // test unit), swept from the right then from the left.
        let side = |n: u32| n.div_ceil(BLOCK as u32) as f32;
        let mut right_cost = [0.0f32; BINS];
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for b in (1..BINS).rev() {
            acc = acc.union(boxes[b]);
            n += counts[b];
            right_cost[b] = if n == 0 {
                f32::INFINITY
            } else {
                acc.surface_area() * side(n)
            };
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for b in 1..BINS {
            acc = acc.union(boxes[b - 1]);
            n += counts[b - 1];
            if n == 0 || n as usize == prims.len() {
                continue;
            }
            let cost = acc.surface_area() * side(n) + right_cost[b];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    let (_, axis, boundary) = best?;
    let scale = BINS as f32 * (1.0 - f32::EPSILON) / extent[axis];
    let below =
        |p: &Prim| ((((p.centroid[axis] - centroids.min[axis]) * scale) as u32 as usize).min(BINS - 1)) < boundary;
    let mid = partition(prims, below);
    (mid > 0 && mid < prims.len()).then_some(mid)
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
    prims: &'a [Prim],
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
            Bvh2::Leaf { first, len, .. } => LEAF_BIT | self.block(&self.prims[*first..first + len]),
            Bvh2::Inner { .. } => self.node(kid),
        }
    }

    /// Writes the block of a leaf's triangles (in ascending index, the
    /// order ties are broken in) and returns its index.
    fn block(&mut self, prims: &[Prim]) -> u32 {
        let mut ids: Vec<u32> = prims.iter().map(|p| p.index).collect();
        ids.sort_unstable();
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
    }
}
