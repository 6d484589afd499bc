//! The two-level mesh hierarchy and hierarchical culling of section 3.2.
//!
//! **Two levels.** Near a vertex, blockers come from the full-resolution
//! mesh; elsewhere from a coarse mesh made once from the rest pose with
//! meshoptimizer's edge-collapse simplifier (`meshopt::simplify`). The
//! coarse triangles index the *same* vertex array as the fine mesh (the
//! simplifier only collapses vertices), so the coarse mesh deforms with the
//! animation for free.
//!
//! **What "near" means.** The paper uses the one- or two-ring of the full
//! mesh near the vertex and the coarse mesh for everything, overlaps
//! included. Rasterising a coarse triangle that passes right by the vertex
//! is harmless on closed meshes with back-face culling (a chord above the
//! vertex faces away from it) but not on two-sided cloth, where a chord
//! just above the vertex covers half its hemisphere. So by default
//! (`NearField::Clusters`) every fine triangle is assigned, in the rest
//! pose, to the nearest coarse triangle with a compatible normal (its
//! *cluster*); the clusters touched by the vertex's k-ring are drawn at full
//! resolution and their coarse triangles skipped. The surface is thus
//! covered once, finely near the vertex and coarsely elsewhere.
//! `NearField::Rings` is the paper's literal variant (k-ring + every coarse
//! triangle), kept to measure the difference.
//!
//! **Culling groups.** The far triangles (coarse, or all fine ones without
//! the hierarchy) are split once into spatially compact groups (median
//! splits of rest-pose centroids). Every frame each group's bounding box is
//! recomputed from the animated vertices; a group whose box lies wholly
//! below a vertex's tangent plane is skipped with all its triangles
//! ("Hierarchical Culling", section 3.2).

use std::collections::HashMap;

use glam::Vec3;

use super::Csr;
use crate::error::{Error, Result};
use crate::scene::used_bounds;

/// Which fine triangles are drawn near a vertex.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum NearField {
    /// Whole clusters of the k-ring's triangles, their coarse triangles skipped.
    Clusters,
    /// The k-ring alone, every coarse triangle drawn (the paper's text).
    Rings,
}

#[derive(Debug, Clone, PartialEq)]
pub struct HierarchySettings {
    /// Use the two-level hierarchy (off: every fine triangle is a far blocker).
    pub enabled: bool,
    pub near: NearField,
    /// 1 or 2: the ring of the full mesh around the vertex.
    pub ring: usize,
    /// Coarse triangles to aim for (default: a sixteenth of the mesh, as the
    /// paper's cloth, 2560 -> 160).
    pub coarse_triangles: Option<usize>,
    /// Far triangles per culling group, 1..=4096.
    pub group_size: usize,
}

impl Default for HierarchySettings {
    fn default() -> Self {
        HierarchySettings {
            enabled: true,
            near: NearField::Clusters,
            ring: 1,
            coarse_triangles: None,
            group_size: 16,
        }
    }
}

/// A culling group: a contiguous range of far triangles and the vertices
/// they use.
#[derive(Debug, Clone)]
pub struct Group {
    pub far: std::ops::Range<u32>,
    pub verts: std::ops::Range<u32>,
}

#[derive(Debug, Clone)]
pub struct Hierarchy {
    /// The full mesh.
    pub fine: Vec<[u32; 3]>,
    /// Far blockers (coarse triangles, or all fine ones), sorted by group.
    pub far: Vec<[u32; 3]>,
    /// Far triangles as indices into their group's vertex range.
    pub far_local: Vec<[u16; 3]>,
    /// The vertices of each group, concatenated (`Group::verts` ranges).
    pub group_verts: Vec<u32>,
    pub groups: Vec<Group>,
    /// Whether `far` is a coarse mesh.
    pub coarse: bool,
    /// Fine triangle -> far triangle of its cluster (coarse far set), or
    /// -> its own place in `far` (no coarse mesh).
    pub cluster_of_fine: Vec<u32>,
    /// Per vertex: fine triangles drawn at full resolution.
    pub near: Csr,
    /// Per vertex: far triangles not drawn (sorted).
    pub excluded: Csr,
    /// Per vertex: the triangles using it (the 1-ring).
    pub vertex_triangles: Csr,
}

impl Hierarchy {
    /// Builds the hierarchy from the rest pose.
    pub fn build(rest: &[Vec3], triangles: &[[u32; 3]], s: &HierarchySettings) -> Result<Hierarchy> {
        if !(1..=2).contains(&s.ring) {
            return Err(Error::param("ring", format!("must be 1 or 2, got {}", s.ring)));
        }
        if !(1..=4096).contains(&s.group_size) {
            return Err(Error::param(
                "group_size",
                format!("must be between 1 and 4096, got {}", s.group_size),
            ));
        }
        if s.coarse_triangles == Some(0) {
            return Err(Error::param("coarse_triangles", "must be at least 1"));
        }
        // The simplifier's quadrics are quartic in the coordinates and the
        // clusters' distances quadratic: in f32 they underflow for models
        // of 1e-18 and overflow near 1e10. Work on the rest pose brought to
        // unit size by a power of two (exact; what is built is topology).
        let extent = used_bounds(rest, triangles);
        let k = crate::kdtree::watertight::frame_scale((extent.max - extent.min).max_element());
        let unit_rest: Vec<Vec3> = rest.iter().map(|p| *p * k).collect();
        let rest = unit_rest.as_slice();
        let nv = rest.len();
        let vertex_triangles = Csr::from_lists(
            nv,
            triangles
                .iter()
                .enumerate()
                .flat_map(|(t, tri)| tri.map(|v| (v as usize, t as u32))),
        );
        let (far_unsorted, coarse) = if s.enabled {
            let target = s.coarse_triangles.unwrap_or((triangles.len() / 16).max(1));
            let c = simplify(rest, triangles, target);
            if c.is_empty() || c.len() >= triangles.len() {
                (triangles.to_vec(), false)
            } else {
                (c, true)
            }
        } else {
            (triangles.to_vec(), false)
        };
        // Culling groups by median splits of rest-pose centroids.
        let centroid = |t: &[u32; 3]| (rest[t[0] as usize] + rest[t[1] as usize] + rest[t[2] as usize]) / 3.0;
        let mut order: Vec<u32> = (0..far_unsorted.len() as u32).collect();
        let group_size = s.group_size;
        let mut ranges = Vec::new();
        split_groups(
            &mut order,
            0,
            &|i| centroid(&far_unsorted[i as usize]),
            group_size,
            &mut ranges,
        );
        let far: Vec<[u32; 3]> = order.iter().map(|&i| far_unsorted[i as usize]).collect();
        let mut rank = vec![0u32; far.len()];
        for (new, &old) in order.iter().enumerate() {
            rank[old as usize] = new as u32;
        }
        let mut groups = Vec::with_capacity(ranges.len());
        let mut group_verts = Vec::new();
        let mut far_local = vec![[0u16; 3]; far.len()];
        for r in ranges {
            let v0 = group_verts.len() as u32;
            let mut local: HashMap<u32, u16> = HashMap::new();
            for t in r.clone() {
                for k in 0..3 {
                    let v = far[t][k];
                    let next = local.len() as u16;
                    let l = *local.entry(v).or_insert_with(|| {
                        group_verts.push(v);
                        next
                    });
                    far_local[t][k] = l;
                }
            }
            groups.push(Group {
                far: r.start as u32..r.end as u32,
                verts: v0..group_verts.len() as u32,
            });
        }

        // Near field per vertex.
        let rings = |v: usize| -> Vec<u32> {
            let mut tris: Vec<u32> = vertex_triangles.get(v).to_vec();
            if s.ring == 2 {
                let mut more = Vec::new();
                for &t in &tris {
                    for u in triangles[t as usize] {
                        more.extend_from_slice(vertex_triangles.get(u as usize));
                    }
                }
                tris.extend(more);
                tris.sort_unstable();
                tris.dedup();
            }
            tris
        };
        let (cluster_of_fine, near, excluded) = if coarse {
            let cluster_of_fine: Vec<u32> = assign_clusters(rest, triangles, &far_unsorted)
                .into_iter()
                .map(|c| rank[c as usize])
                .collect();
            let mut members = vec![Vec::new(); far.len()];
            for (f, &c) in cluster_of_fine.iter().enumerate() {
                members[c as usize].push(f as u32);
            }
            let mut near = Vec::with_capacity(nv);
            let mut excluded = Vec::with_capacity(nv);
            for v in 0..nv {
                let ring = rings(v);
                match s.near {
                    NearField::Rings => {
                        near.push(ring);
                        excluded.push(Vec::new());
                    }
                    NearField::Clusters => {
                        let mut cl: Vec<u32> = ring.iter().map(|&t| cluster_of_fine[t as usize]).collect();
                        cl.sort_unstable();
                        cl.dedup();
                        let mut fine: Vec<u32> = cl.iter().flat_map(|&c| members[c as usize].iter().copied()).collect();
                        fine.sort_unstable();
                        near.push(fine);
                        excluded.push(cl);
                    }
                }
            }
            (cluster_of_fine, Csr::from_vecs(&near), Csr::from_vecs(&excluded))
        } else {
            // Far = the fine triangles, permuted by group.
            (
                rank.clone(),
                Csr::from_vecs(&vec![Vec::new(); nv]),
                Csr::from_vecs(&vec![Vec::new(); nv]),
            )
        };
        Ok(Hierarchy {
            fine: triangles.to_vec(),
            far,
            far_local,
            group_verts,
            groups,
            coarse,
            cluster_of_fine,
            near,
            excluded,
            vertex_triangles,
        })
    }

    /// Axis-aligned boxes (centre, half extent) of every group for the
    /// current positions.
    pub fn group_boxes(&self, positions: &[Vec3], out: &mut Vec<(Vec3, Vec3)>) {
        out.clear();
        for g in &self.groups {
            let mut lo = Vec3::splat(f32::INFINITY);
            let mut hi = Vec3::splat(f32::NEG_INFINITY);
            for &v in &self.group_verts[g.verts.start as usize..g.verts.end as usize] {
                let p = positions[v as usize];
                lo = lo.min(p);
                hi = hi.max(p);
            }
            out.push(((lo + hi) * 0.5, (hi - lo) * 0.5));
        }
    }

    /// Candidate blockers of a vertex before any culling.
    pub fn candidates(&self, v: usize) -> usize {
        self.far.len() - self.excluded.get(v).len() + self.near.get(v).len()
    }
}

/// Splits `order[..]` (starting at `offset` in the full order) into ranges of
/// at most `size` by median splits along the longest axis of the centroids.
fn split_groups(
    order: &mut [u32],
    offset: usize,
    centroid: &dyn Fn(u32) -> Vec3,
    size: usize,
    out: &mut Vec<std::ops::Range<usize>>,
) {
    if order.len() <= size.max(1) {
        if !order.is_empty() {
            out.push(offset..offset + order.len());
        }
        return;
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &i in order.iter() {
        lo = lo.min(centroid(i));
        hi = hi.max(centroid(i));
    }
    let e = hi - lo;
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |a, b| {
        centroid(*a)[axis].total_cmp(&centroid(*b)[axis]).then(a.cmp(b))
    });
    let (left, right) = order.split_at_mut(mid);
    split_groups(left, offset, centroid, size, out);
    split_groups(right, offset + mid, centroid, size, out);
}

/// The coarse mesh: meshoptimizer's simplifier on the rest pose, aiming at
/// `target` triangles with no error bound (it stops earlier only where the
/// topology forbids collapses).
fn simplify(rest: &[Vec3], triangles: &[[u32; 3]], target: usize) -> Vec<[u32; 3]> {
    let positions: Vec<[f32; 3]> = rest.iter().map(|p| p.to_array()).collect();
    let Ok(adapter) = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&positions), 12, 0) else {
        return Vec::new();
    };
    let indices: Vec<u32> = triangles.iter().flatten().copied().collect();
    let out = meshopt::simplify(
        &indices,
        &adapter,
        target * 3,
        1.0,
        meshopt::SimplifyOptions::None,
        None,
    );
    out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Each fine triangle's cluster: the coarse triangle nearest to its centroid
/// (point-triangle distance) among those whose normal is within 90 degrees
/// of its own, or the nearest of all when none is.
fn assign_clusters(rest: &[Vec3], fine: &[[u32; 3]], coarse: &[[u32; 3]]) -> Vec<u32> {
    use rayon::prelude::*;
    let tri = |t: &[u32; 3]| [rest[t[0] as usize], rest[t[1] as usize], rest[t[2] as usize]];
    let normal = |p: &[Vec3; 3]| (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
    let coarse_pts: Vec<[Vec3; 3]> = coarse.iter().map(tri).collect();
    let coarse_n: Vec<Vec3> = coarse_pts.iter().map(normal).collect();
    fine.par_iter()
        .map(|t| {
            let p = tri(t);
            let c = (p[0] + p[1] + p[2]) / 3.0;
            let n = normal(&p);
            let mut best = (f32::INFINITY, 0u32);
            let mut best_any = (f32::INFINITY, 0u32);
            for (i, (q, qn)) in coarse_pts.iter().zip(&coarse_n).enumerate() {
                let d = point_triangle_distance_sq(c, q);
                if d < best_any.0 {
                    best_any = (d, i as u32);
                }
                if n.dot(*qn) > 0.0 && d < best.0 {
                    best = (d, i as u32);
                }
            }
            if best.0.is_finite() { best.1 } else { best_any.1 }
        })
        .collect()
}

/// Squared distance from p to triangle t (Ericson, Real-Time Collision
/// Detection, 5.1.5).
pub fn point_triangle_distance_sq(p: Vec3, t: &[Vec3; 3]) -> f32 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (p - (a + ab * v)).length_squared();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (p - (a + ac * w)).length_squared();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).length_squared();
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (p - (a + ab * v + ac * w)).length_squared()
}

/// Whether the mesh is closed and consistently oriented: every edge is used
/// by exactly two triangles, once in each direction. Then every ray that
/// hits it hits a front face first, and back-facing blockers can be culled.
pub fn is_closed(triangles: &[[u32; 3]]) -> bool {
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for t in triangles {
        if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let e = edges.entry((a.min(b), a.max(b))).or_default();
            if a < b {
                e.0 += 1;
            } else {
                e.1 += 1;
            }
        }
    }
    !edges.is_empty() && edges.values().all(|&(f, b)| f == 1 && b == 1)
}
