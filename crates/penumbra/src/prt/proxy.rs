//! Checking the coarse level of the two-level hierarchy against the fine
//! mesh, and refining it per vertex where it fails.
//!
//! Section 3.2 of the paper ("Mesh Hierarchy") draws distant blockers from
//! a low-resolution mesh because "in smooth lighting environments blockers
//! cast soft shadows unless they are close to the receiver", and warns that
//! "mismatches between the hierarchies may produce shading artifacts in
//! regions where small features [...] the lower-resolution mesh cannot
//! faithfully represent"; its "Accuracy of Local Geometry" paragraph names
//! the one- or two-ring near field a heuristic. What makes a coarse
//! triangle harmless is not how many edges away it is but the *angle* its
//! error subtends: a coarse triangle that strays `d` from the fine surface
//! it replaces moves shadow edges by about `d / r` radians at a receiver
//! `r` away. A chord of a curved sheet passing `d` above a vertex covers
//! its whole hemisphere (`r ≈ d`); the same chord seen from across the
//! model is a fraction of a mask pixel.
//!
//! So each coarse triangle C gets a **deviation**, measured on the rest pose
//! both ways:
//! * coarse -> fine: points of C (a barycentric grid) to the nearest fine
//!   triangle of C's cluster or of the clusters of its neighbours (coarse
//!   triangles sharing a vertex). C covering space where the fine mesh has
//!   nothing — a chord across a concavity, a bridge over a gap — is what
//!   makes coarse triangles shadow what the fine mesh does not;
//! * fine -> coarse: the vertices of C's cluster to the nearest of C and its
//!   neighbours: fine features the coarse mesh dropped (fins, spikes, ears)
//!   are what makes it miss shadows.
//!
//! The deviation is kept where it is, not only how large: at the points of
//! a barycentric grid on C (thirds) and at each fine vertex. A vertex v then
//! draws what C stands for at full resolution instead of C (its cluster,
//! and the fine triangles of neighbouring clusters that lie nearer to C
//! than to their own coarse triangle, `stand_ins`) when C strays by
//! more than `tolerance` radians as seen from v: `d / max(r - d, 0) >
//! tolerance`, i.e. `r < d (1 + 1/tolerance)`, either for the point y of C
//! nearest to v (r = |v - y|, d the largest deviation at the grid points
//! around y) or for a fine vertex x of the cluster (r = |v - x|). The
//! nearest point matters most: a long coarse sliver passing a few ten
//! thousandths from a vertex of a folded sheet lies within its fine surface's
//! deviation there and still covers the vertex's whole hemisphere (the
//! curtain of `tests/prt_defaults.rs`), while its far corners, sampled
//! alone, deviate too little to notice. The k-ring near field of the paper
//! is kept as well; this widens it where the proxy strays from the surface
//! it stands for.

use glam::Vec3;
use rayon::prelude::*;

use super::Csr;
use super::geometry::{closest_barycentric, point_triangle_distance_sq};

/// The level-3 barycentric grid on a coarse triangle, in thirds.
const GRID: [[u8; 3]; 10] = [
    [3, 0, 0],
    [0, 3, 0],
    [0, 0, 3],
    [2, 1, 0],
    [1, 2, 0],
    [0, 2, 1],
    [0, 1, 2],
    [1, 0, 2],
    [2, 0, 1],
    [1, 1, 1],
];

/// Where a coarse triangle strays from the fine surface it replaces.
#[derive(Debug, Clone, Default)]
pub struct Deviation {
    /// Coarse -> fine: at each `GRID` point, the distance to the fine surface.
    pub grid: [f32; 10],
    /// Fine -> coarse: vertices of the cluster with their distance to the
    /// coarse surface (those under a thousandth of the largest dropped to
    /// keep the list short: they reach a thousandth as far).
    pub fine: Vec<(Vec3, f32)>,
    /// The largest of all (0: the coarse triangle lies on the fine surface).
    pub max: f32,
    /// (neighbour, fine triangle): members of this cluster with a vertex
    /// nearer to that neighbouring coarse triangle than to this one.
    pub orphans: Vec<(u32, u32)>,
}

impl Deviation {
    /// The coarse -> fine deviation around barycentric point `w`: the
    /// largest at the grid points within one grid step (a bound on the
    /// field between samples that a linear blend would not give).
    fn around(&self, w: [f32; 3]) -> f32 {
        GRID.iter()
            .zip(&self.grid)
            .filter(|(g, _)| (0..3).all(|k| (g[k] as f32 - 3.0 * w[k]).abs() <= 1.0))
            .map(|(_, d)| *d)
            .fold(0.0, f32::max)
    }
}

/// Each coarse triangle's deviation from the fine surface it replaces
/// (rest pose; same units as `rest`).
///
/// `coarse[c]` are coarse triangles (indices into `rest`), `members` the fine
/// triangles of each coarse triangle's cluster.
pub fn deviations(rest: &[Vec3], fine: &[[u32; 3]], coarse: &[[u32; 3]], members: &Csr) -> Vec<Deviation> {
    let tri = |t: &[u32; 3]| t.map(|i| rest[i as usize]);
    // Coarse neighbours: coarse triangles sharing a vertex.
    let by_vertex = Csr::from_lists(
        rest.len(),
        coarse
            .iter()
            .enumerate()
            .flat_map(|(c, t)| t.map(|v| (v as usize, c as u32))),
    );
    (0..coarse.len())
        .into_par_iter()
        .with_min_len(16)
        .map(|c| {
            let mut around: Vec<u32> = coarse[c]
                .iter()
                .flat_map(|&v| by_vertex.get(v as usize).iter().copied())
                .collect();
            around.sort_unstable();
            around.dedup();
            let near_coarse: Vec<[Vec3; 3]> = around.iter().map(|&a| tri(&coarse[a as usize])).collect();
            let near_fine: Vec<[Vec3; 3]> = around
                .iter()
                .flat_map(|&a| members.get(a as usize).iter())
                .map(|&f| tri(&fine[f as usize]))
                .collect();
            let q = tri(&coarse[c]);
            let grid = GRID.map(|g| {
                let x = (q[0] * g[0] as f32 + q[1] * g[1] as f32 + q[2] * g[2] as f32) / 3.0;
                nearest_sq(x, &near_fine).sqrt()
            });
            let mut verts: Vec<u32> = members.get(c).iter().flat_map(|&f| fine[f as usize]).collect();
            verts.sort_unstable();
            verts.dedup();
            // Fine -> coarse, noting which neighbour stands in for each vertex.
            let mut stands_in = vec![u32::MAX; verts.len()];
            let mut fine_points: Vec<(Vec3, f32)> = verts
                .iter()
                .zip(&mut stands_in)
                .map(|(&v, by)| {
                    let x = rest[v as usize];
                    let (d, k) = nearest(x, &near_coarse);
                    *by = around.get(k).copied().unwrap_or(c as u32);
                    (x, d.sqrt())
                })
                .collect();
            // Members with a vertex nearer to a neighbour than to C are, there,
            // shadowed by that neighbour's coarse triangle.
            let mut orphans: Vec<(u32, u32)> = Vec::new();
            for &f in members.get(c) {
                for v in fine[f as usize] {
                    let by = stands_in[verts.binary_search(&v).unwrap_or(0)];
                    if by != c as u32 {
                        orphans.push((by, f));
                    }
                }
            }
            orphans.sort_unstable();
            orphans.dedup();
            let max = fine_points.iter().map(|p| p.1).chain(grid).fold(0.0f32, f32::max);
            fine_points.retain(|p| p.1 > 1e-3 * max);
            Deviation {
                grid,
                fine: fine_points,
                max,
                orphans,
            }
        })
        .collect()
}

/// Squared distance from `x` to the nearest of `tris`, and its index
/// (infinite and 0 if none).
fn nearest(x: Vec3, tris: &[[Vec3; 3]]) -> (f32, usize) {
    tris.iter()
        .enumerate()
        .map(|(i, t)| (point_triangle_distance_sq(x, t), i))
        .fold((f32::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a })
}

fn nearest_sq(x: Vec3, tris: &[[Vec3; 3]]) -> f32 {
    nearest(x, tris).0
}

/// Per coarse triangle, the fine triangles drawn when it is not: its own
/// cluster, and the fine triangles of other clusters that lie nearer to it
/// than to their own coarse triangle (`Deviation::orphans`). Without the
/// latter, replacing a coarse triangle by its cluster opens a hole wherever
/// it also stood in for a neighbour's stray fine triangles (a fold of a
/// curtain assigned to the coarse triangle of the next fold).
pub fn stand_ins(members: &Csr, deviation: &[Deviation]) -> Csr {
    let mut lists: Vec<Vec<u32>> = (0..members.len()).map(|c| members.get(c).to_vec()).collect();
    for &(by, f) in deviation.iter().flat_map(|d| &d.orphans) {
        lists[by as usize].push(f);
    }
    // Sorted and without repeats, as the near field expects.
    for l in &mut lists {
        l.sort_unstable();
        l.dedup();
    }
    Csr::from_vecs(&lists)
}

/// Per vertex, the coarse triangles whose deviation subtends more than
/// `tolerance` radians there (see the module doc), sorted.
pub fn too_coarse(rest: &[Vec3], coarse: &[[u32; 3]], deviation: &[Deviation], tolerance: f32) -> Csr {
    let reach = 1.0 + 1.0 / tolerance;
    let pairs: Vec<Vec<(usize, u32)>> = coarse
        .par_iter()
        .zip(deviation)
        .enumerate()
        .with_min_len(8)
        .map(|(c, (t, dev))| {
            if dev.max <= 0.0 {
                return Vec::new();
            }
            let q = t.map(|i| rest[i as usize]);
            // A bounding sphere of the triangle and its cluster grown by the
            // largest reach first: most vertices are far from most coarse
            // triangles.
            let centre = (q[0] + q[1] + q[2]) / 3.0;
            let radius = dev
                .fine
                .iter()
                .map(|(x, _)| *x)
                .chain(q)
                .map(|x| (x - centre).length())
                .fold(0.0f32, f32::max);
            let bound = (radius + dev.max * reach).powi(2);
            rest.iter()
                .enumerate()
                .filter(|(_, p)| (**p - centre).length_squared() <= bound)
                .filter(|(_, p)| strays(**p, &q, dev, reach))
                .map(|(v, _)| (v, c as u32))
                .collect()
        })
        .collect();
    Csr::from_lists(rest.len(), pairs.into_iter().flatten())
}

/// Whether coarse triangle `q` strays by more than the tolerance as seen
/// from `p`: its nearest point to p deviates by d with `|p - y| < d reach`,
/// or a fine vertex of its cluster does.
fn strays(p: Vec3, q: &[Vec3; 3], dev: &Deviation, reach: f32) -> bool {
    let w = closest_barycentric(p, q);
    let y = q[0] * w[0] + q[1] * w[1] + q[2] * w[2];
    let d = dev.around(w);
    (p - y).length_squared() < (d * reach).powi(2)
        || dev
            .fine
            .iter()
            .any(|(x, d)| (p - *x).length_squared() < (d * reach).powi(2))
}
