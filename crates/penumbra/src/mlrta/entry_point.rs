//! Entry-point (EP) search, section 4.1 of the MLRTA paper.
//!
//! A depth-first walk of the cells the group may enter (inverse frustum
//! culling, `Frustum::split_children`), nearest child first, that keeps the
//! "bifurcation" nodes (both children entered) on a stack:
//!
//! 1. until the first leaf with potential intersections (triangles, and the
//!    group's frustum may enter the leaf's box: equation (2)) is found, which
//!    becomes the candidate entry point;
//! 2. then each bifurcation node is taken from the stack and its far subtree
//!    searched for another leaf with potential intersections; if there is
//!    one, that node becomes the candidate and the rest of its subtree is
//!    abandoned (it cannot move the entry point lower). A search that has
//!    visited `far_budget` nodes of a far subtree without an answer counts
//!    it as having one (`MlrtaSettings::ep_budget`): the entry point can
//!    only move up, to a node whose subtree holds every leaf the exhaustive
//!    search would allow for;
//! 3. the search ends, returning the candidate, when the stack is empty or
//!    when every ray of the group must end in the current leaf (stopping rule
//!    (4)): a covered plane all rays cross, or an empty leaf inside a closed
//!    object that all rays enter (the "empty occluder").
//!
//! Every leaf with potential intersections lies in the candidate's subtree,
//! except behind an occluder that stopped the search. Such an entry point is
//! *speculative*: rays that find no hit in its subtree are traced again from
//! the root, so a coverage judgement that is wrong at some seam, or an origin
//! inside an object, costs time, never a hit.

use crate::accel::kdtree::watertight::ShearedRay;
use crate::geom::aabb::Aabb;
use crate::mlrta::frustum::Frustum;
use crate::mlrta::prepared::{Occluder, Prepared};

/// Where a group starts its traversal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EntryPoint {
    /// Index of the node in the kd-tree's `nodes` (0: the root).
    pub node: u32,
    /// The node's cell: the tree's bounds cut by the splits above it.
    pub cell: Aabb,
    /// Reached through a stopping rule: see the module documentation.
    pub speculative: bool,
    /// Every ray of the group ends by this distance (a triangle all of them
    /// hit was found): the packets need not look further.
    pub t_limit: f32,
    /// Whether `t_limit` comes from one triangle (or covered plane) that
    /// every ray of the group hits.
    pub covered: bool,
}

impl EntryPoint {
    /// The root of the tree, for groups that search no entry point.
    pub fn root(p: &Prepared) -> EntryPoint {
        EntryPoint {
            node: 0,
            cell: p.tree.bounds,
            speculative: false,
            t_limit: f32::INFINITY,
            covered: false,
        }
    }
}

/// The two children of interior node `i` of cell `cell`: (below, above).
#[inline]
pub fn children(p: &Prepared, i: u32, cell: &Aabb) -> ((u32, Aabb), (u32, Aabb)) {
    let node = p.tree.nodes[i as usize];
    let (axis, split) = (node.axis(), node.split());
    let mut below = *cell;
    below.max[axis] = split;
    let mut above = *cell;
    above.min[axis] = split;
    ((i + 1, below), (node.above_child(), above))
}

/// The children of interior node `i` the group may enter, nearest first.
fn entered_children(p: &Prepared, f: &Frustum, i: u32, cell: &Aabb) -> [Option<(u32, Aabb)>; 2] {
    let node = p.tree.nodes[i as usize];
    let (axis, split) = (node.axis(), node.split());
    let c = f.split_children(axis, split, cell);
    let (below, above) = children(p, i, cell);
    let o = f.origin[axis];
    let near_below = o < split || (o == split && !f.positive[axis]);
    let (below, above) = (c.below.then_some(below), c.above.then_some(above));
    if near_below { [below, above] } else { [above, below] }
}

/// What the search knows about one leaf.
enum Leaf {
    /// No triangle the group may hit.
    Nothing,
    /// Triangles the group may hit.
    Potential,
    /// Every ray of the group ends here (stopping rule (4)); `potential`
    /// says whether it is a leaf with triangles.
    Ends { potential: bool },
}

/// Leaves with more triangles than this are not checked for one that ends
/// every ray (the check is four ray tests per triangle).
const MAX_OCCLUDER_CANDIDATES: usize = 8;

/// Stopping rule (4), first case, generalised: "the leaf has some objects,
/// and all rays ... intersect one of these objects". The directions from the
/// origin that hit a triangle form a convex set, so if the group's four
/// corner directions hit one of the leaf's triangles before `t_max`, every
/// ray of the group does; and along rays hitting a plane, t is a
/// linear-fractional function of the direction, extreme at the corners.
/// Returns the largest corner hit distance: every ray of the group ends by
/// it, so the search may shorten the group to it, and what lies beyond (the
/// far subtrees of the bifurcation stack, behind the triangle) is culled.
fn covering_distance(p: &Prepared, f: &Frustum, corners: &[ShearedRay; 4], i: u32) -> Option<f32> {
    let range = p.tree.nodes[i as usize].leaf_range();
    if range.len() > MAX_OCCLUDER_CANDIDATES {
        return None;
    }
    p.tree.leaf_vertices[range]
        .iter()
        .filter_map(|&[a, b, c]| {
            corners
                .iter()
                .map(|ray| ray.intersect(a, b, c, f32::INFINITY))
                .try_fold(0.0f32, |far, t| t.map(|t| far.max(t)))
        })
        .map(|t| f.corner_t_to_ray_t(t))
        .filter(|&t| t < f.t_max)
        .min_by(f32::total_cmp)
}

/// Stopping rule (4) at an interior node whose subtree is one merged
/// occluder: `Some(potential)` if every ray of the group ends in it.
fn subtree_ends_all_rays(p: &Prepared, f: &Frustum, i: u32, cell: &Aabb, origin_inside: Option<u32>) -> Option<bool> {
    match p.occluders[i as usize] {
        Occluder::CoveredPlane { axis } => {
            let a = axis as usize;
            f.all_cross_rectangle(a, cell.min[a], cell).then_some(true)
        }
        Occluder::Inside { object } if origin_inside != Some(object) => f.all_enter_box(cell).then_some(false),
        _ => None,
    }
}

fn classify_leaf(p: &Prepared, f: &Frustum, i: u32, cell: &Aabb, origin_inside: Option<u32>) -> Leaf {
    let node = p.tree.nodes[i as usize];
    let has_triangles = !node.leaf_range().is_empty();
    match p.occluders[i as usize] {
        Occluder::CoveredPlane { axis } if f.may_hit_box(cell) => {
            let a = axis as usize;
            if f.all_cross_rectangle(a, cell.min[a], cell) {
                Leaf::Ends { potential: true }
            } else {
                Leaf::Potential
            }
        }
        Occluder::Inside { object } if origin_inside != Some(object) && f.all_enter_box(cell) => {
            Leaf::Ends { potential: false }
        }
        _ if has_triangles && f.may_hit_box(cell) => Leaf::Potential,
        _ => Leaf::Nothing,
    }
}

/// Searches the entry point of the group `f`, starting at `start` (the root,
/// or the entry point of an enclosing tile). `origin_inside` is the closed
/// object containing the group's origin, if any (its empty occluders do not
/// apply). A far subtree is searched for at most `far_budget` nodes (0: to
/// the end, as the paper). Counts visited nodes in `steps`. `None`: the
/// group can hit nothing.
pub fn entry_point(
    p: &Prepared,
    f: &Frustum,
    start: (u32, Aabb),
    origin_inside: Option<u32>,
    far_budget: u32,
    steps: &mut u64,
) -> Option<EntryPoint> {
    if !f.may_hit_box(&start.1) {
        return None;
    }
    // The group, shortened whenever a triangle that ends all its rays is found.
    let mut f = *f;
    let mut speculative = false;
    let mut covered = false;
    // The corner rays, for covering triangles (shortening the group does
    // not move them).
    let corners = f
        .corner_directions()
        .map(|d| ShearedRay::in_frame(f.origin, d, p.tree.frame_scale));
    let mut at_potential_leaf = |i: u32, f: &mut Frustum| {
        if let Some(t) = covering_distance(p, f, &corners, i) {
            f.t_max = t;
            speculative = true;
            covered = true;
        }
    };
    // Phase 1: nearest-first descent to the first leaf with potential hits.
    let mut bifurcations: Vec<((u32, Aabb), (u32, Aabb))> = Vec::new();
    let mut current = Some(start);
    let mut candidate = loop {
        let Some((i, cell)) = current.take() else {
            // Dead end: continue in the far child of the last bifurcation
            // (which, having nothing on its near side, is no longer one).
            match bifurcations.pop() {
                Some((_, far)) => {
                    current = Some(far);
                    continue;
                }
                None => return None,
            }
        };
        *steps += 1;
        if p.tree.nodes[i as usize].is_leaf() {
            match classify_leaf(p, &f, i, &cell, origin_inside) {
                Leaf::Nothing | Leaf::Ends { potential: false } => continue,
                Leaf::Potential => {
                    at_potential_leaf(i, &mut f);
                    break (i, cell);
                }
                Leaf::Ends { potential: true } => {
                    return Some(EntryPoint {
                        node: i,
                        cell,
                        speculative: true,
                        t_limit: f.t_max,
                        covered: true,
                    });
                }
            }
        }
        // Every ray ends in this subtree, and nothing before it has potential
        // hits: it is the entry point. (The inside of an object reached before
        // any surface means the origin is inside after all: no rule then.)
        if subtree_ends_all_rays(p, &f, i, &cell, origin_inside) == Some(true) {
            return Some(EntryPoint {
                node: i,
                cell,
                speculative: true,
                t_limit: f.t_max,
                covered: true,
            });
        }
        match entered_children(p, &f, i, &cell) {
            [Some(near), Some(far)] => {
                bifurcations.push(((i, cell), far));
                current = Some(near);
            }
            [Some(only), None] | [None, Some(only)] => current = Some(only),
            [None, None] => {}
        }
    };
    // Phase 2: each bifurcation's far subtree, until one potential leaf.
    let mut local: Vec<(u32, Aabb)> = Vec::new();
    'bifurcations: while let Some((node, far)) = bifurcations.pop() {
        // Beyond the (possibly shortened) group: nothing to find there.
        if !f.may_hit_box(&far.1) {
            continue;
        }
        local.clear();
        local.push(far);
        let mut budget = if far_budget == 0 { u32::MAX } else { far_budget };
        while let Some((i, cell)) = local.pop() {
            if budget == 0 {
                // Not known within the budget: as if it had potential hits.
                candidate = node;
                continue 'bifurcations;
            }
            budget -= 1;
            *steps += 1;
            if p.tree.nodes[i as usize].is_leaf() {
                match classify_leaf(p, &f, i, &cell, origin_inside) {
                    Leaf::Nothing => continue,
                    Leaf::Potential => {
                        candidate = node;
                        at_potential_leaf(i, &mut f);
                        continue 'bifurcations;
                    }
                    Leaf::Ends { potential } => {
                        if potential {
                            candidate = node;
                        }
                        speculative = true;
                        covered |= potential;
                        break 'bifurcations;
                    }
                }
            }
            if let Some(potential) = subtree_ends_all_rays(p, &f, i, &cell, origin_inside) {
                if potential {
                    candidate = node;
                }
                speculative = true;
                covered |= potential;
                break 'bifurcations;
            }
            let [near, far] = entered_children(p, &f, i, &cell);
            local.extend(far);
            local.extend(near);
        }
    }
    Some(EntryPoint {
        node: candidate.0,
        cell: candidate.1,
        speculative,
        t_limit: f.t_max,
        covered,
    })
}
