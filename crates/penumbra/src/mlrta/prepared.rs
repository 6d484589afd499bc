//! The kd-tree prepared for multi-level ray tracing: subtree sizes (the
//! geometric complexity of section 4.2) and occluder leaves (the stopping
//! rules (4) of section 4.1).
//!
//! Two kinds of leaf end every ray of a group that passes through them:
//!
//! * a **covered plane**: a flat (2D) leaf whose coplanar triangles cover its
//!   whole rectangle, as rule 2 of the build creates them (coverage judged by
//!   clipped area, like the build rule);
//! * an **empty occluder**: an empty leaf inside a closed (watertight,
//!   consistently oriented) object. A ray reaching it from outside must have
//!   crossed the object's surface first. It is inside when the closest hit
//!   from its centre is a back face of that object (front faces point out: the
//!   orientation comes from the object's signed volume).
//!
//! Occluders merge upwards: an interior node is a covered plane when it is
//! flat and both children are covered planes (a wall split in its own plane
//! into several leaves), and an empty occluder when both children are empty
//! occluders of the same object (the inside of a closed object, carved into
//! many empty leaves). A group's whole frustum fits such a merged occluder far
//! more often than one of its leaves.
//!
//! Either judgement can only be wrong at measure-zero boundaries, and a wrong
//! one never costs a hit: rays that find no hit below an entry point reached
//! by a stopping rule are traced again from the root (see `entry_point`).

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::kdtree::{KdNode, KdTree};
use crate::geom::aabb::Aabb;
use crate::gpu::device::elapsed_ms;
use crate::scene::Mesh;

/// What kind of occluder a leaf is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Occluder {
    None,
    /// Flat leaf on `axis`, covered by coplanar triangles.
    CoveredPlane {
        axis: u8,
    },
    /// Empty leaf inside closed object `object`.
    Inside {
        object: u32,
    },
}

/// A kd-tree with what MLRTA needs on top of it.
pub struct Prepared<'a> {
    /// The kd-tree, built from the mesh `new` was given.
    pub tree: &'a KdTree,
    /// One past the last node of each node's subtree (depth-first layout).
    pub subtree_end: Vec<u32>,
    /// Per node (leaves and merged interior nodes).
    pub occluders: Vec<Occluder>,
    /// Per triangle, the closed object it belongs to (or `u32::MAX`).
    pub closed_object_of: Vec<u32>,
    /// Per closed object, +1 if its faces point outwards, -1 if inwards.
    orientation: Vec<f32>,
}

/// What `Prepared` adds to its tree, apart from the tree: a renderer that
/// traces many images of one tree keeps it between them (`into_tables`,
/// `from_tables`) instead of preparing again (38 ms for kitchen).
pub struct PreparedTables {
    subtree_end: Vec<u32>,
    occluders: Vec<Occluder>,
    closed_object_of: Vec<u32>,
    orientation: Vec<f32>,
}

/// Statistics of the preparation, for reports.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct PreparedStats {
    pub closed_objects: usize,
    pub covered_plane_leaves: usize,
    pub empty_occluder_leaves: usize,
    /// Interior nodes whose whole subtree is one occluder.
    pub merged_occluders: usize,
    pub prepare_ms: f64,
}

impl<'a> Prepared<'a> {
    /// The tables, to keep while the tree is borrowed elsewhere.
    pub fn into_tables(self) -> PreparedTables {
        PreparedTables {
            subtree_end: self.subtree_end,
            occluders: self.occluders,
            closed_object_of: self.closed_object_of,
            orientation: self.orientation,
        }
    }

    /// `tree` with the tables prepared for it before.
    pub fn from_tables(tree: &'a KdTree, t: PreparedTables) -> Prepared<'a> {
        Prepared {
            tree,
            subtree_end: t.subtree_end,
            occluders: t.occluders,
            closed_object_of: t.closed_object_of,
            orientation: t.orientation,
        }
    }

    /// Prepares `tree`, built from `mesh` (whose objects tell which triangles
    /// form closed surfaces).
    pub fn new(tree: &'a KdTree, mesh: &Mesh) -> (Prepared<'a>, PreparedStats) {
        let start = std::time::Instant::now();
        let subtree_end = subtree_ends(tree);
        let (closed_object_of, orientation) = closed_objects(mesh);
        let mut prepared = Prepared {
            tree,
            subtree_end,
            occluders: vec![Occluder::None; tree.nodes.len()],
            closed_object_of,
            orientation,
        };
        // Only empty leaves (when there is a closed object) and flat leaves
        // can be occluders; the others are not listed (213K leaves on the
        // bunny, none of them either).
        let closed = !prepared.orientation.is_empty();
        let leaves = leaf_cells_where(tree, |node, cell| {
            if node.leaf_range().is_empty() {
                closed
            } else {
                let e = cell.extent();
                e.x == 0.0 || e.y == 0.0 || e.z == 0.0
            }
        });
        let found: Vec<(u32, Occluder)> = leaves
            .par_iter()
            .filter_map(|&(node, cell)| {
                let kind = prepared.classify_leaf(node, &cell);
                (kind != Occluder::None).then_some((node, kind))
            })
            .collect();
        let mut stats = PreparedStats {
            closed_objects: prepared.orientation.len(),
            ..Default::default()
        };
        for (node, kind) in found {
            match kind {
                Occluder::CoveredPlane { .. } => stats.covered_plane_leaves += 1,
                Occluder::Inside { .. } => stats.empty_occluder_leaves += 1,
                Occluder::None => {}
            }
            prepared.occluders[node as usize] = kind;
        }
        // Merge upwards; children come after their parent in the layout.
        for i in (0..tree.nodes.len()).rev() {
            let node = tree.nodes[i];
            if node.is_leaf() {
                continue;
            }
            let below = prepared.occluders[i + 1];
            let above = prepared.occluders[node.above_child() as usize];
            let merged = match (below, above) {
                (Occluder::CoveredPlane { axis: a }, Occluder::CoveredPlane { axis: b })
                    if a == b && node.axis() != a as usize =>
                {
                    Occluder::CoveredPlane { axis: a }
                }
                (Occluder::Inside { object: a }, Occluder::Inside { object: b }) if a == b => {
                    Occluder::Inside { object: a }
                }
                _ => Occluder::None,
            };
            if merged != Occluder::None {
                stats.merged_occluders += 1;
            }
            prepared.occluders[i] = merged;
        }
        stats.prepare_ms = elapsed_ms(start);
        (prepared, stats)
    }

    /// Nodes in the subtree of `node`, itself included.
    pub fn subtree_size(&self, node: u32) -> u32 {
        self.subtree_end[node as usize] - node
    }

    fn classify_leaf(&self, node: u32, cell: &Aabb) -> Occluder {
        let tree = self.tree;
        let range = tree.nodes[node as usize].leaf_range();
        let tris = &tree.leaf_triangles[range];
        if tris.is_empty() {
            if self.orientation.is_empty() {
                return Occluder::None;
            }
            return match self.inside_object(cell.center()) {
                Some(object) => Occluder::Inside { object },
                None => Occluder::None,
            };
        }
        let extent = cell.extent();
        let Some(axis) = (0..3).find(|&a| extent[a] == 0.0) else {
            return Occluder::None;
        };
        let s = cell.min[axis];
        let coplanar = tris
            .iter()
            .all(|&t| tree.triangles[t as usize].iter().all(|v| v[axis] == s));
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let cross_section = extent[u] * extent[v];
        if !coplanar || cross_section <= 0.0 {
            return Occluder::None;
        }
        let area: f32 = tris
            .iter()
            .map(|&t| crate::accel::kdtree::clip::clip_triangle(&tree.triangles[t as usize], cell).area())
            .sum();
        if area >= cross_section * (1.0 - 1e-4) {
            Occluder::CoveredPlane { axis: axis as u8 }
        } else {
            Occluder::None
        }
    }

    /// The closed object whose inside contains `p`, judged by the closest
    /// surface seen from `p` along a fixed skew direction.
    pub fn inside_object(&self, p: Vec3) -> Option<u32> {
        if self.orientation.is_empty() {
            return None;
        }
        let dir = Vec3::new(0.5773, 0.6201, 0.5313);
        let hit = self.tree.closest_hit(p, dir, f32::INFINITY);
        if !hit.is_hit() {
            return None;
        }
        let object = self.closed_object_of[hit.triangle as usize];
        if object == u32::MAX {
            return None;
        }
        let [a, b, c] = self.tree.triangles[hit.triangle as usize];
        let facing = (b - a).cross(c - a).dot(dir) * self.orientation[object as usize];
        (facing > 0.0).then_some(object)
    }
}

/// `subtree_end[i]`: one past the last node of node i's subtree.
fn subtree_ends(tree: &KdTree) -> Vec<u32> {
    let n = tree.nodes.len();
    let mut end = vec![0u32; n];
    // Nodes in reverse order: children come after their parent.
    for i in (0..n).rev() {
        let node = tree.nodes[i];
        end[i] = if node.is_leaf() {
            i as u32 + 1
        } else {
            end[node.above_child() as usize]
        };
    }
    end
}

/// Every leaf with its cell.
#[cfg(test)]
pub fn leaf_cells(tree: &KdTree) -> Vec<(u32, Aabb)> {
    leaf_cells_where(tree, |_, _| true)
}

/// The leaves for which `wanted(leaf, cell)` holds, with their cells.
fn leaf_cells_where(tree: &KdTree, wanted: impl Fn(&KdNode, &Aabb) -> bool) -> Vec<(u32, Aabb)> {
    let mut out = Vec::new();
    let mut stack = Vec::with_capacity(2 * tree.stats.depth + 2);
    stack.push((0u32, tree.bounds));
    while let Some((i, cell)) = stack.pop() {
        let node = tree.nodes[i as usize];
        if node.is_leaf() {
            if wanted(&node, &cell) {
                out.push((i, cell));
            }
            continue;
        }
        let (axis, split) = (node.axis(), node.split());
        let mut below = cell;
        below.max[axis] = split;
        let mut above = cell;
        above.min[axis] = split;
        stack.push((node.above_child(), above));
        stack.push((i + 1, below));
    }
    out
}

/// Which triangles form closed surfaces. Triangles are grouped into
/// connected surfaces through shared edges (vertices welded by position, so
/// objects split across OBJ groups or with duplicated vertices still join); a
/// surface is closed when every edge is used by exactly two triangles, once
/// in each direction. Returns per triangle its closed surface's index, and per
/// closed surface the sign of its signed volume (+1: faces point out).
///
/// Sorting instead of hashing: welded vertex ids come from sorting the
/// positions, edges from sorting (vertex, vertex) pairs.
fn closed_objects(mesh: &Mesh) -> (Vec<u32>, Vec<f32>) {
    let n = mesh.triangles.len();
    // Weld: vertices with bit-identical positions get one id.
    let mut order: Vec<([u32; 3], u32)> = (mesh.positions.iter().enumerate())
        .map(|(v, p)| (p.to_array().map(f32::to_bits), v as u32))
        .collect();
    order.sort_unstable();
    let mut weld = vec![0u32; mesh.positions.len()];
    let mut id = 0u32;
    for w in 0..order.len() {
        if w > 0 && order[w].0 != order[w - 1].0 {
            id += 1;
        }
        weld[order[w].1 as usize] = id;
    }
    let edges = sorted_edges(mesh, &weld, id as usize + 1);
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    let mut open_triangles = Vec::new();
    for group in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let (x, y) = (
            root(&mut parent, group[0].3),
            root(&mut parent, group[group.len() - 1].3),
        );
        parent[x as usize] = y;
        let manifold = group.len() == 2 && group[0].2 != group[1].2;
        if !manifold {
            open_triangles.extend(group.iter().map(|e| e.3));
        }
    }
    let mut open = vec![false; n];
    for t in open_triangles {
        let r = root(&mut parent, t);
        open[r as usize] = true;
    }
    let mut volume = vec![0.0f64; n];
    for t in 0..n {
        let r = root(&mut parent, t as u32) as usize;
        if !open[r] {
            let [a, b, c] = mesh.triangle(t).map(|v| v.as_dvec3());
            volume[r] += a.dot(b.cross(c)) / 6.0;
        }
    }
    let mut id_of = vec![u32::MAX; n];
    let mut orientation = Vec::new();
    let mut object_of = vec![u32::MAX; n];
    for (t, slot) in object_of.iter_mut().enumerate() {
        let r = root(&mut parent, t as u32) as usize;
        if open[r] || volume[r] == 0.0 {
            continue;
        }
        if id_of[r] == u32::MAX {
            id_of[r] = orientation.len() as u32;
            orientation.push(volume[r].signum() as f32);
        }
        *slot = id_of[r];
    }
    (object_of, orientation)
}

/// Every triangle's edges as (low vertex, high vertex, forward?, triangle)
/// in sorted order, by a counting sort on the low vertex (welded ids
/// `0..vertices`) and a sort of each vertex's few edges: a sort of all
/// the edges (208K on the bunny) took a third of `prepare`.
fn sorted_edges(mesh: &Mesh, weld: &[u32], vertices: usize) -> Vec<(u32, u32, bool, u32)> {
    let edge = |t: usize, i: usize| {
        let tri = mesh.triangles[t];
        let (p, q) = (weld[tri[i] as usize], weld[tri[(i + 1) % 3] as usize]);
        (p.min(q), p.max(q), p < q)
    };
    let mut start = vec![0u32; vertices + 1];
    for t in 0..mesh.triangles.len() {
        for i in 0..3 {
            start[edge(t, i).0 as usize + 1] += 1;
        }
    }
    for v in 0..vertices {
        start[v + 1] += start[v];
    }
    // (high vertex, forward?, triangle) packed so that their order is the
    // tuple's.
    let mut packed = vec![0u64; 3 * mesh.triangles.len()];
    let mut next = start.clone();
    for t in 0..mesh.triangles.len() {
        for i in 0..3 {
            let (lo, hi, forward) = edge(t, i);
            packed[next[lo as usize] as usize] = (hi as u64) << 33 | (forward as u64) << 32 | t as u64;
            next[lo as usize] += 1;
        }
    }
    let mut edges = Vec::with_capacity(packed.len());
    for lo in 0..vertices {
        let bucket = &mut packed[start[lo] as usize..start[lo + 1] as usize];
        bucket.sort_unstable();
        edges.extend(
            bucket
                .iter()
                .map(|&e| (lo as u32, (e >> 33) as u32, e >> 32 & 1 == 1, e as u32)),
        );
    }
    edges
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::kdtree::KdTreeSettings;
    use crate::scene::procedural::{closed_box, cube_with_hole, open_plane};

    #[test]
    fn subtree_ends_cover_the_tree() {
        let mesh = cube_with_hole();
        let tree = KdTree::build(&mesh, &KdTreeSettings::default()).unwrap();
        let (p, _) = Prepared::new(&tree, &mesh);
        assert_eq!(p.subtree_size(0) as usize, tree.nodes.len());
        for (i, n) in tree.nodes.iter().enumerate() {
            if n.is_leaf() {
                assert_eq!(p.subtree_size(i as u32), 1);
            } else {
                let below = p.subtree_size(i as u32 + 1);
                let above = p.subtree_size(n.above_child());
                assert_eq!(p.subtree_size(i as u32), 1 + below + above);
            }
        }
    }

    #[test]
    fn edges_come_sorted_like_a_plain_sort() {
        let mesh = cube_with_hole();
        let weld: Vec<u32> = (0..mesh.positions.len() as u32).collect();
        let mut plain = Vec::new();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = *tri;
            for (p, q) in [(a, b), (b, c), (c, a)] {
                plain.push((p.min(q), p.max(q), p < q, t as u32));
            }
        }
        plain.sort_unstable();
        assert_eq!(sorted_edges(&mesh, &weld, weld.len()), plain);
    }

    #[test]
    fn closed_objects_and_their_inside() {
        // The cube with a hole is closed with outward faces; its solid part is
        // inside, the hole and the surroundings are not.
        let mesh = cube_with_hole();
        let tree = KdTree::build(&mesh, &KdTreeSettings::default()).unwrap();
        let (p, stats) = Prepared::new(&tree, &mesh);
        assert_eq!(stats.closed_objects, 1);
        assert_eq!(p.inside_object(Vec3::new(0.7, 0.1, 0.2)), Some(0));
        assert_eq!(p.inside_object(Vec3::new(0.0, 0.0, 0.0)), None, "in the hole");
        assert_eq!(p.inside_object(Vec3::new(3.0, 0.0, 0.0)), None, "outside");
        // The closed box has inward faces (negative volume): its inside is
        // still its inside.
        let boxed = closed_box(1.0);
        let tree = KdTree::build(&boxed, &KdTreeSettings::default()).unwrap();
        let (p, _) = Prepared::new(&tree, &boxed);
        assert_eq!(p.inside_object(Vec3::splat(0.5)), Some(0));
        assert_eq!(p.inside_object(Vec3::splat(1.5)), None);
        // An open plane is no closed object.
        let plane = open_plane(10.0);
        let tree = KdTree::build(&plane, &KdTreeSettings::default()).unwrap();
        assert_eq!(Prepared::new(&tree, &plane).1.closed_objects, 0);
    }

    #[test]
    fn occluder_leaves_are_found() {
        let mesh = cube_with_hole();
        let tree = KdTree::build(&mesh, &KdTreeSettings::default()).unwrap();
        let (p, stats) = Prepared::new(&tree, &mesh);
        println!("{stats:?}");
        assert!(stats.empty_occluder_leaves > 0, "the solid part has empty inner leaves");
        for (node, cell) in leaf_cells(&tree) {
            match p.occluders[node as usize] {
                Occluder::Inside { .. } => assert!(p.inside_object(cell.center()).is_some()),
                Occluder::CoveredPlane { axis } => assert_eq!(cell.extent()[axis as usize], 0.0),
                Occluder::None => {}
            }
        }
    }
}
