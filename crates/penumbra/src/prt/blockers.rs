//! Other objects as blockers: approximate inter-object shadows for scenes of
//! several independently moving objects (Kautz, Lehtinen and Aila 2004,
//! section 4.1, "Scalability").
//!
//! The paper keeps each object's cost unchanged by "projecting coarse
//! approximations of the other shadow-casting objects onto the lighting
//! environment used by the object receiving the shadow". One lighting per
//! receiving object darkens all its vertices alike, though: a chessboard
//! would be dimmed evenly instead of shadowed under each piece. Here the
//! coarse approximations are rasterised into each receiving *vertex's* mask
//! instead, after the vertex's own blockers (occluder fusion makes the
//! order irrelevant), culled conservatively so that the per-object cost
//! grows only with the other objects' coarse triangles above the vertex's
//! horizon:
//!
//! * **The coarse approximation** of an object is its own hierarchy's far
//!   level (`Hierarchy::far`: the coarse mesh, or the whole mesh where it
//!   has none), placed by the object's current pose, in the hierarchy's
//!   culling groups.
//! * **Object culling.** An object whose bounding sphere (centre of its
//!   box, radius to its farthest far-level vertex) lies wholly below the
//!   vertex's tangent plane is skipped, and so is one too far to cover
//!   more than one mask pixel: a spherical cap of angular radius `α`
//!   projects onto the unit disk (orthographic projection contracts
//!   distances) within a circle of radius `α`, which holds at most one
//!   pixel centre of the `2/S` grid while `α < 1/S`.
//! * **Group culling** as in section 3.2: a group whose box lies below the
//!   tangent plane is skipped.
//! * **Refinement near contact.** Where a group's coarse triangles stray
//!   from the fine surface by `d` (the proxy check's deviation, `proxy`)
//!   and the vertex is closer to the group's box than `d / tolerance` (so
//!   the deviation subtends more than the hierarchy's `tolerance` there),
//!   the group's fine triangles (the clusters of its coarse triangles) are
//!   drawn instead: a piece standing on a board shadows the squares next to
//!   its base with its real base, not a simplified one.
//!
//! Back-face culling follows the receiving mesh's decision (`sides`): other
//! objects are assumed closed where the receiver is.

use std::ops::Range;
use std::sync::Arc;

use glam::{Mat3, Vec3};

use super::geometry::point_triangle_distance_sq;
use super::hierarchy::Hierarchy;
use super::pipeline::{emit, to_local};
use super::raster::TriangleBatch;

/// How other objects shadow a receiving object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum InterObject {
    /// Self-shadowing only.
    Off,
    /// Other objects' coarse levels, refined near contact (section 4.1).
    Coarse,
    /// Other objects' full meshes (exact, for comparison; slow).
    Fine,
}

/// An object's triangles in spatially compact chunks, each with the
/// object vertices it uses (local `u16` indices into them).
#[derive(Debug, Clone, Default)]
pub struct Chunks {
    verts: Vec<u32>,
    tris: Vec<[u16; 3]>,
    ranges: Vec<(Range<u32>, Range<u32>)>,
}

impl Chunks {
    /// The far level of `h` in its culling groups.
    pub fn far_level(h: &Hierarchy) -> Chunks {
        Chunks {
            verts: h.group_verts.clone(),
            tris: h.far_local.clone(),
            ranges: h.groups.iter().map(|g| (g.verts.clone(), g.far.clone())).collect(),
        }
    }

    /// The full mesh of `h` (vertices at `rest`), chunk g holding what its
    /// far group g stands for: the clusters of its coarse triangles, and
    /// the fine triangles of other clusters that lie within `grow[g]` (its
    /// deviation) of one of them. Clusters follow the nearest coarse
    /// triangle with a compatible normal, not the groups' borders: without
    /// those strays a refined group drawn next to coarse ones would leave
    /// holes where its coarse triangles reached over a neighbour's clusters.
    pub fn fine_of_groups(h: &Hierarchy, rest: &[Vec3], grow: &[f32]) -> Chunks {
        let mut of_group = vec![0u32; h.far.len()];
        for (g, group) in h.groups.iter().enumerate() {
            of_group[group.far.start as usize..group.far.end as usize].fill(g as u32);
        }
        let corners = |t: &[u32; 3]| t.map(|v| rest[v as usize]);
        let mut lists: Vec<Vec<[u32; 3]>> = vec![Vec::new(); h.groups.len()];
        for (t, &c) in h.fine.iter().zip(&h.cluster_of_fine) {
            let own = of_group[c as usize] as usize;
            lists[own].push(*t);
            if !h.coarse {
                continue;
            }
            let p = corners(t);
            let centroid = (p[0] + p[1] + p[2]) / 3.0;
            // Half the longest edge: a straddling triangle counts.
            let half = 0.5
                * (p[0] - p[1])
                    .length()
                    .max((p[1] - p[2]).length())
                    .max((p[2] - p[0]).length());
            for (g, group) in h.groups.iter().enumerate().filter(|&(g, _)| g != own && grow[g] > 0.0) {
                let reach = (grow[g] + half).powi(2);
                let far = &h.far[group.far.start as usize..group.far.end as usize];
                if far
                    .iter()
                    .any(|f| point_triangle_distance_sq(centroid, &corners(f)) <= reach)
                {
                    lists[g].push(*t);
                }
            }
        }
        let mut out = Chunks::default();
        for list in lists {
            let (v0, t0) = (out.verts.len() as u32, out.tris.len() as u32);
            let mut local = std::collections::HashMap::new();
            for t in list {
                let l = t.map(|v| {
                    let next = (out.verts.len() as u32 - v0) as u16;
                    *local.entry(v).or_insert_with(|| {
                        out.verts.push(v);
                        next
                    })
                });
                out.tris.push(l);
            }
            out.ranges.push((v0..out.verts.len() as u32, t0..out.tris.len() as u32));
        }
        out
    }

    /// Triangles in all chunks.
    pub fn triangles(&self) -> usize {
        self.tris.len()
    }

    /// Each chunk's largest vertex count fits the `u16` local indices.
    pub fn fits(&self) -> bool {
        self.ranges.iter().all(|(v, _)| v.end - v.start <= u16::MAX as u32 + 1)
    }
}

/// An object's blocker topology, built once: its far level, its fine
/// triangles chunked alike, and each chunk's deviation (proxy check).
#[derive(Debug, Clone)]
pub struct BlockerTopology {
    /// The far level in its culling groups (`Chunks::far_level`): what
    /// [`InterObject::Coarse`] draws.
    pub coarse: Arc<Chunks>,
    /// The full mesh chunked by the same groups (`Chunks::fine_of_groups`):
    /// what [`InterObject::Fine`] draws, and what refinement near contact
    /// draws in place of a group.
    pub fine: Arc<Chunks>,
    /// Per chunk: the largest deviation of its coarse triangles from the
    /// fine surface (0 without a coarse level, without the proxy check, or
    /// below `DEVIATION_FLOOR`).
    pub deviation: Vec<f32>,
}

/// Deviations below this share of an object's size are taken as none:
/// a flat board's coarse top strays from its fine one by rounding only.
pub const DEVIATION_FLOOR: f32 = 1e-3;

impl BlockerTopology {
    /// From the object's hierarchy and its first pose.
    pub fn new(h: &Hierarchy, rest: &[Vec3]) -> BlockerTopology {
        let floor = DEVIATION_FLOOR * crate::scene::used_bounds(rest, &h.fine).diagonal();
        let deviation: Vec<f32> = h
            .groups
            .iter()
            .map(|g| {
                let d = h
                    .deviation
                    .get(g.far.start as usize..g.far.end as usize)
                    .map_or(0.0, |d| d.iter().copied().fold(0.0, f32::max));
                if d > floor { d } else { 0.0 }
            })
            .collect();
        BlockerTopology {
            coarse: Arc::new(Chunks::far_level(h)),
            fine: Arc::new(Chunks::fine_of_groups(h, rest, &deviation)),
            deviation,
        }
    }
}

/// Chunks placed by a pose: boxes (centre, half extent) and vertex
/// coordinates (structure of arrays, `Chunks::verts` order).
#[derive(Debug, Clone)]
struct Placed {
    chunks: Arc<Chunks>,
    boxes: Vec<(Vec3, Vec3)>,
    xyz: [Vec<f32>; 3],
}

impl Placed {
    fn new(chunks: &Arc<Chunks>, positions: &[Vec3]) -> Placed {
        let mut xyz: [Vec<f32>; 3] = Default::default();
        for (axis, a) in xyz.iter_mut().enumerate() {
            a.extend(chunks.verts.iter().map(|&v| positions[v as usize][axis]));
        }
        let boxes = chunks
            .ranges
            .iter()
            .map(|(v, _)| {
                let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                for &q in &chunks.verts[v.start as usize..v.end as usize] {
                    lo = lo.min(positions[q as usize]);
                    hi = hi.max(positions[q as usize]);
                }
                ((lo + hi) * 0.5, (hi - lo) * 0.5)
            })
            .collect();
        Placed {
            chunks: chunks.clone(),
            boxes,
            xyz,
        }
    }
}

/// One object's blockers in a frame.
#[derive(Debug, Clone)]
struct PlacedObject {
    id: usize,
    centre: Vec3,
    radius: f32,
    /// What is drawn by default: the far level (`Coarse`) or the fine mesh.
    drawn: Placed,
    /// The fine chunks for refinement near contact (`Coarse` with deviations).
    fine: Option<Placed>,
    deviation: Vec<f32>,
}

/// Counts of other objects' blockers, summed over vertices.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OtherStats {
    /// Triangles of the other objects' approximations, before culling.
    pub candidates: u64,
    /// Skipped with their whole object (below the horizon, under a pixel).
    pub object_culled: u64,
    /// Skipped with their culling group.
    pub group_culled: u64,
    /// Coarse triangles replaced by fine ones near contact.
    pub refined: u64,
    /// Fine triangles drawn for them.
    pub refined_fine: u64,
    /// Triangles gathered wholly below the horizon.
    pub below_horizon: u64,
    /// Triangles passed to the rasteriser (before back-face culling).
    pub gathered: u64,
}

impl std::ops::AddAssign<&OtherStats> for OtherStats {
    fn add_assign(&mut self, s: &OtherStats) {
        self.candidates += s.candidates;
        self.object_culled += s.object_culled;
        self.group_culled += s.group_culled;
        self.refined += s.refined;
        self.refined_fine += s.refined_fine;
        self.below_horizon += s.below_horizon;
        self.gathered += s.gathered;
    }
}

/// The blockers every object of a scene casts in one frame.
#[derive(Debug, Clone, Default)]
pub struct SceneBlockers {
    objects: Vec<PlacedObject>,
    /// `tolerance` of the proxy check (radians; 0: no refinement).
    tolerance: f32,
}

/// What a receiving vertex needs to gather others' blockers.
pub(super) struct Receiver<'a> {
    pub blockers: &'a SceneBlockers,
    /// The receiving object (its own blockers are not drawn twice).
    pub id: usize,
    /// `1 / S`: the angular radius below which an object is culled.
    pub pixel: f32,
}

impl SceneBlockers {
    /// Places every casting object (`(id, topology, positions)`) for this
    /// frame in `mode` (`Off`: none).
    pub fn place(objects: &[(usize, &BlockerTopology, &[Vec3])], mode: InterObject, tolerance: f32) -> SceneBlockers {
        if mode == InterObject::Off {
            return SceneBlockers::default();
        }
        let objects = objects
            .iter()
            .map(|&(id, topo, positions)| {
                let chunks = match mode {
                    InterObject::Fine => &topo.fine,
                    _ => &topo.coarse,
                };
                let drawn = Placed::new(chunks, positions);
                let refine = mode == InterObject::Coarse && tolerance > 0.0 && topo.deviation.iter().any(|&d| d > 0.0);
                let (lo, hi) = drawn.boxes.iter().fold(
                    (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                    |(lo, hi), (c, e)| (lo.min(*c - *e), hi.max(*c + *e)),
                );
                let centre = (lo + hi) * 0.5;
                let fine = refine.then(|| Placed::new(&topo.fine, positions));
                // Every drawn vertex is inside; refinement's fine vertices
                // lie within the deviation of the coarse surface.
                let spread = |p: &Placed| {
                    (0..p.xyz[0].len())
                        .map(|i| (Vec3::new(p.xyz[0][i], p.xyz[1][i], p.xyz[2][i]) - centre).length())
                        .fold(0.0f32, f32::max)
                };
                let radius = spread(&drawn).max(fine.as_ref().map_or(0.0, spread));
                PlacedObject {
                    id,
                    centre,
                    radius,
                    drawn,
                    fine,
                    deviation: topo.deviation.clone(),
                }
            })
            .filter(|o| o.radius.is_finite())
            .collect();
        SceneBlockers { objects, tolerance }
    }

    /// True when no object casts: inter-object shadows off, or no caster
    /// with finite coordinates.
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// The other objects' triangles above the horizon of a vertex (at
    /// `origin`, with `normal` and tangent `frame`, coordinates scaled by
    /// `inv`) appended to `tris`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn gather(
        &self,
        r: &Receiver,
        origin: Vec3,
        normal: Vec3,
        frame: Mat3,
        inv: f32,
        local: &mut [Vec<f32>; 3],
        tris: &mut TriangleBatch,
        counts: &mut OtherStats,
    ) {
        let (rt, rb, rn) = (frame.x_axis * inv, frame.y_axis * inv, frame.z_axis * inv);
        for o in self.objects.iter().filter(|o| o.id != r.id) {
            let all = o.drawn.chunks.triangles() as u64;
            counts.candidates += all;
            let to_centre = o.centre - origin;
            let d = to_centre.length();
            let below = normal.dot(to_centre) + o.radius <= 0.0;
            let under_pixel = d > o.radius && (o.radius / d).asin() < r.pixel;
            if below || under_pixel {
                counts.object_culled += all;
                continue;
            }
            for (g, &(c, e)) in o.drawn.boxes.iter().enumerate() {
                let n = o.drawn.chunks.ranges[g].1.len() as u64;
                let below = |(c, e): (Vec3, Vec3)| normal.dot(c - origin) + normal.abs().dot(e) <= 0.0;
                if below((c, e)) && o.fine.as_ref().is_none_or(|f| below(f.boxes[g])) {
                    counts.group_culled += n;
                    continue;
                }
                let near = |dev: f32| ((origin - c).abs() - e).max(Vec3::ZERO).length() * self.tolerance < dev;
                let placed = match &o.fine {
                    Some(f) if o.deviation[g] > 0.0 && near(o.deviation[g]) => {
                        counts.refined += n;
                        f
                    }
                    _ => &o.drawn,
                };
                let (v, t) = placed.chunks.ranges[g].clone();
                let (v, t) = (v.start as usize..v.end as usize, t.start as usize..t.end as usize);
                let [x, y, z] = &placed.xyz;
                to_local(&x[v.clone()], &y[v.clone()], &z[v], origin, rt, rb, rn, local);
                tris.reserve(tris.len + t.len());
                let mut kept = 0;
                for &l in &placed.chunks.tris[t.clone()] {
                    kept += emit(local, l, tris) as u64;
                }
                if !std::ptr::eq(placed, &o.drawn) {
                    counts.refined_fine += t.len() as u64;
                }
                counts.below_horizon += t.len() as u64 - kept;
                counts.gathered += kept;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prt::hierarchy::HierarchySettings;

    /// The chunks' triangles, back in the object's vertex numbering, sorted.
    fn global(c: &Chunks) -> Vec<[u32; 3]> {
        let mut out = Vec::new();
        for (v, t) in &c.ranges {
            let verts = &c.verts[v.start as usize..v.end as usize];
            out.extend(
                c.tris[t.start as usize..t.end as usize]
                    .iter()
                    .map(|l| l.map(|i| verts[i as usize])),
            );
        }
        out.sort_unstable();
        out
    }

    #[test]
    fn fine_chunks_hold_every_fine_triangle_and_far_chunks_the_far_level() {
        let mesh = crate::scene::procedural::uv_sphere("ball", glam::Vec3::ZERO, 1.0, 64, 32);
        let h = Hierarchy::build(&mesh.positions, &mesh.triangles, &HierarchySettings::default()).unwrap();
        assert!(h.coarse);
        let topo = BlockerTopology::new(&h, &mesh.positions);
        // Every fine triangle, strays in several chunks.
        let mut fine = mesh.triangles.clone();
        fine.sort_unstable();
        let mut held = global(&topo.fine);
        assert!(topo.deviation.iter().any(|&d| d > 0.0));
        assert!(held.len() > fine.len(), "strays are shared");
        held.dedup();
        assert_eq!(held, fine);
        let mut far = h.far.clone();
        far.sort_unstable();
        assert_eq!(global(&topo.coarse), far);
        assert_eq!(topo.coarse.ranges.len(), topo.fine.ranges.len());
    }
}
