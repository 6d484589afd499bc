//! Spatial splits (Stich, Friedrich and Dietrich 2009, "Spatial splits in
//! bounding volume hierarchies", section 3): where the best object split
//! leaves its two children's boxes overlapping, a node may instead split
//! space at a plane, a triangle crossing it going to both sides with its
//! box cut to each. Long thin triangles (a kitchen's walls, shelves and
//! cables) otherwise give boxes that are mostly empty and overlap their
//! neighbours, and a ray walks them all.
//!
//! Hits do not change: a triangle is referenced by every leaf whose region
//! it crosses, each reference's box holds that part of the triangle (the
//! clip is widened by a few ulps of the triangle's coordinates, then cut
//! with the box it had), and a ray tests a triangle twice only to find the
//! same t.

use glam::Vec3;

use super::build::{Prim, sweep};
use crate::geom::aabb::Aabb;

/// Bins across the node's box on each axis (the paper uses as many as the
/// object split's; 32 resolves a kitchen's shelves better than 16).
const BINS: usize = 32;
/// Nodes of fewer references are split by objects only: below it a
/// spatial split's sweep costs more than it gains (kitchen 7.49 nodes a
/// packet with every node tried, 7.46 from 64; build 98 -> 84 ms, one
/// thread).
pub(super) const MIN_REFERENCES: usize = 64;

/// A split plane and the cost the SAH gives it.
#[derive(Clone, Copy, Debug)]
pub(super) struct SpatialSplit {
    pub cost: f32,
    pub axis: usize,
    pub plane: f32,
}

/// The bounds of the parts of `tri` on either side of the plane
/// `p[axis] = plane` (empty where it does not reach that side), as the
/// paper's reference split: each vertex grows its side's box, each edge
/// crossing the plane grows both with its crossing point.
fn halves(tri: &[Vec3; 3], axis: usize, plane: f32) -> (Aabb, Aabb) {
    let (mut below, mut above) = (Aabb::EMPTY, Aabb::EMPTY);
    for i in 0..3 {
        let (a, c) = (tri[i], tri[(i + 1) % 3]);
        if a[axis] <= plane {
            below = below.grow(a);
        }
        if a[axis] >= plane {
            above = above.grow(a);
        }
        if (a[axis] < plane && c[axis] > plane) || (a[axis] > plane && c[axis] < plane) {
            let mut p = a + (c - a) * ((plane - a[axis]) / (c[axis] - a[axis]));
            p[axis] = plane;
            below = below.grow(p);
            above = above.grow(p);
        }
    }
    (below, above)
}

/// `part` (a box from `halves`) made conservative for the traversal: the
/// crossing points are rounded, so it is widened by a few ulps of the
/// triangle's largest coordinate, then cut with the reference's box
/// `within` and the side's half space; empty stays empty.
fn conservative(part: Aabb, tri: &[Vec3; 3], within: Aabb, axis: usize, lo: f32, hi: f32) -> Aabb {
    if part.is_empty() {
        return part;
    }
    let largest = tri.iter().fold(0.0f32, |m, v| m.max(v.abs().max_element()));
    let ulps = Vec3::splat(largest * (4.0 * f32::EPSILON));
    let mut out = Aabb::new(part.min - ulps, part.max + ulps).intersection(within);
    out.min[axis] = out.min[axis].max(lo);
    out.max[axis] = out.max[axis].min(hi);
    if out.is_empty() { Aabb::EMPTY } else { out }
}

/// The cheapest spatial split of `prims` (whose boxes' union is `bounds`)
/// over the three axes, by the SAH over `BINS` slabs per axis, each axis
/// only if some reference spans `min_span` of the box along it
/// (`BvhSettings::spatial_min_span`); `None` where no axis qualifies.
pub(super) fn best(prims: &[Prim], bounds: Aabb, min_span: f32) -> Option<SpatialSplit> {
    let mut best: Option<SpatialSplit> = None;
    let extent = bounds.extent();
    let widest = prims.iter().fold(Vec3::ZERO, |m, p| m.max(p.bounds.extent()));
    for axis in 0..3 {
        if extent[axis] <= 0.0 || widest[axis] < min_span * extent[axis] {
            continue;
        }
        let width = extent[axis] / BINS as f32;
        let plane = |b: usize| {
            if b == BINS {
                bounds.max[axis]
            } else {
                bounds.min[axis] + b as f32 * width
            }
        };
        let bin_of = |x: f32| (((x - bounds.min[axis]) / width) as usize).min(BINS - 1);
        let mut boxes = [Aabb::EMPTY; BINS];
        let mut entries = [0u32; BINS];
        let mut exits = [0u32; BINS];
        for p in prims {
            let (first, last) = (bin_of(p.bounds.min[axis]), bin_of(p.bounds.max[axis]));
            entries[first] += 1;
            exits[last] += 1;
            // Chop the reference's box at each plane it crosses: the
            // estimate the paper makes with the triangle itself, from its
            // box instead, which cost a third of the build time (kitchen
            // 60 ms, 2 threads, against 137) for the same tree quality
            // (7.49 against 7.50 nodes a packet); the partition below cuts
            // the triangle itself.
            let mut rest = p.bounds;
            for (b, bin) in boxes.iter_mut().enumerate().take(last).skip(first) {
                let mut piece = rest;
                piece.max[axis] = piece.max[axis].min(plane(b + 1));
                *bin = bin.union(piece);
                rest.min[axis] = rest.min[axis].max(plane(b + 1));
            }
            boxes[last] = boxes[last].union(rest);
        }
        // A plane between bins b - 1 and b has below it every reference
        // entering before b, above it every one leaving at or after b.
        sweep(&boxes, &entries, &exits, |b, cost, _, _, _| {
            if best.is_none_or(|s| cost < s.cost) {
                best = Some(SpatialSplit {
                    cost,
                    axis,
                    plane: plane(b),
                });
            }
        });
    }
    best
}

/// The references left and right of `split`: a triangle crossing the
/// plane goes to both, each side's box clipped to its half space.
pub(super) fn partition(prims: Vec<Prim>, split: SpatialSplit, triangles: &[[Vec3; 3]]) -> (Vec<Prim>, Vec<Prim>) {
    let (axis, plane) = (split.axis, split.plane);
    let mut left = Vec::with_capacity(prims.len());
    let mut right = Vec::with_capacity(prims.len());
    for p in prims {
        if p.bounds.max[axis] <= plane {
            left.push(p);
        } else if p.bounds.min[axis] >= plane {
            right.push(p);
        } else {
            let tri = &triangles[p.index as usize];
            let (below, above) = halves(tri, axis, plane);
            let below = conservative(below, tri, p.bounds, axis, f32::NEG_INFINITY, plane);
            let above = conservative(above, tri, p.bounds, axis, plane, f32::INFINITY);
            if !below.is_empty() {
                left.push(Prim::new(below, p.index));
            }
            if !above.is_empty() {
                right.push(Prim::new(above, p.index));
            }
        }
    }
    (left, right)
}

/// Whether `split` makes progress and fits `budget`: each side gets fewer
/// references than the node, and the triangles crossing the plane (each
/// a new reference) are at most `budget`.
pub(super) fn fits(prims: &[Prim], split: SpatialSplit, budget: usize) -> bool {
    let (axis, plane) = (split.axis, split.plane);
    let below = prims.iter().filter(|p| p.bounds.max[axis] <= plane).count();
    let above = prims.iter().filter(|p| p.bounds.min[axis] >= plane).count();
    let crossing = prims.len() - below - above;
    below + crossing < prims.len() && above + crossing < prims.len() && crossing <= budget
}
