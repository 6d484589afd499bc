//! Which sides of a mesh matter: back-face culling of blockers and two-sided
//! shading, decided from the mesh when they are `auto`.
//!
//! The paper's test models are closed characters and a cloth; users bring
//! scanned meshes with holes (the Stanford bunny is open at its base), models
//! cut into unwelded patches (the Utah teapot, whose spout and handle also
//! end inside the body) and real sheets. "Any boundary edge = open" calls the
//! bunny a cloth: two-sided shading then turns every vertex facing away from
//! the camera inwards, culling goes off, blockers double and the error
//! grows. What each setting needs is not a topological property
//! but a visibility one, so it is measured with rays on the rest pose:
//!
//! * **Two-sided shading** is for surfaces whose back is seen from outside.
//!   Lines through the mesh's bounding sphere (uniform in the space of
//!   lines: a uniform point on the sphere and a cosine-distributed inward
//!   direction) are traced; `back_exposure` is the share of those that hit
//!   the mesh whose first hit is a back face. The cloth shows its
//!   underside to 30% of them, a curtain to 70%, a closed mesh to none, the
//!   bunny through the holes in its base to 1.1%.
//! * **Back-face culling** is exact when every ray from the shaded side of
//!   a vertex that hits the mesh hits a front face (then a ray is blocked iff
//!   it meets a front face, and back faces can be skipped). From a sample
//!   of vertices, cosine-distributed rays are traced once with every face
//!   and once through back faces; rays blocked only by back faces are the
//!   light culling would let in. `culling_error` is their share relative to
//!   each vertex's open share, averaged like the transfer error (vertices
//!   under 1% open skipped): what culling would add to the error. It is
//!   43% on the teapot, whose spout and handle ends lie inside the body
//!   (the old rule culled there: 45% error), 0.3% on the bunny.
//!
//! A watertight, consistently oriented mesh (after welding vertices at equal
//! positions) needs no rays: culling on, one side.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use super::geometry::weld;
use crate::accel::kdtree::{KdTree, KdTreeSettings};
use crate::error::Result;
use crate::geom::sampling::{Frame, SampleSequence, cosine_hemisphere};
use crate::scene::{ORIGIN_OFFSET, used_bounds, vertex_normals};

/// Two-sided shading above this share of back faces seen from outside.
pub const MAX_BACK_EXPOSURE: f64 = 0.1;
/// Back-face culling while it costs at most this much transfer error.
pub const MAX_CULLING_ERROR: f64 = 0.005;
/// Lines traced from outside.
const EXPOSURE_LINES: u32 = 8192;
/// Vertices sampled and rays per vertex for the culling error.
const CULLING_VERTICES: usize = 4096;
const CULLING_RAYS: u32 = 64;

/// Edge counts after welding.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Topology {
    pub edges: usize,
    /// Used by one triangle.
    pub boundary_edges: usize,
    /// Used by more than two.
    pub nonmanifold_edges: usize,
    /// Used twice in the same direction (neighbours facing opposite ways).
    pub misoriented_edges: usize,
}

impl Topology {
    /// Of the triangles (vertices already welded: `canon[v]`).
    pub fn of(triangles: &[[u32; 3]], canon: impl Fn(u32) -> u32) -> Topology {
        let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
        for t in triangles {
            let t = t.map(&canon);
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
        let mut top = Topology {
            edges: edges.len(),
            ..Topology::default()
        };
        for &(f, b) in edges.values() {
            match f + b {
                1 => top.boundary_edges += 1,
                2 if f != 1 => top.misoriented_edges += 1,
                2 => {}
                _ => top.nonmanifold_edges += 1,
            }
        }
        top
    }

    /// Watertight and consistently oriented.
    pub fn closed(&self) -> bool {
        self.edges > 0 && self.boundary_edges + self.nonmanifold_edges + self.misoriented_edges == 0
    }
}

/// Whether the mesh is closed and consistently oriented by its indices
/// alone: every edge used by exactly two triangles, once in each direction.
#[cfg(test)]
pub fn is_closed(triangles: &[[u32; 3]]) -> bool {
    Topology::of(triangles, |v| v).closed()
}

/// What was measured and decided (`sides` in the report).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sides {
    pub topology: Topology,
    /// Share of outside lines hitting the mesh whose first hit is a back face.
    pub back_exposure: Option<f64>,
    /// Transfer error back-face culling would add (see the module doc).
    pub culling_error: Option<f64>,
    pub backface_culling: bool,
    pub two_sided: bool,
}

/// Decides culling and sidedness for the rest pose; `Some` forces a choice.
pub fn decide(rest: &[Vec3], triangles: &[[u32; 3]], backface: Option<bool>, two_sided: Option<bool>) -> Result<Sides> {
    let canon = weld(rest);
    let topology = Topology::of(triangles, |v| canon[v as usize]);
    let mut sides = Sides {
        topology,
        back_exposure: None,
        culling_error: None,
        backface_culling: true,
        two_sided: false,
    };
    let needs_rays = !topology.closed() && (two_sided.is_none() || (backface.is_none() && two_sided != Some(true)));
    let tree = if needs_rays {
        let soup: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|i| rest[i as usize])).collect();
        Some(KdTree::from_triangles(soup, &KdTreeSettings::for_cpu())?)
    } else {
        None
    };
    sides.two_sided = match (two_sided, &tree) {
        (Some(s), _) => s,
        (None, Some(tree)) => {
            let e = back_exposure(tree, rest, triangles);
            sides.back_exposure = Some(e);
            e > MAX_BACK_EXPOSURE
        }
        (None, None) => false,
    };
    sides.backface_culling = match (backface, &tree) {
        (Some(b), _) => b,
        // Seen from either side, every face is a back face somewhere.
        _ if sides.two_sided => false,
        (None, Some(tree)) => {
            let e = culling_error(tree, rest, triangles);
            sides.culling_error = Some(e);
            e <= MAX_CULLING_ERROR
        }
        (None, None) => true,
    };
    Ok(sides)
}

/// Unnormalised normal of triangle `i` of the tree (its winding).
fn face_normal(tree: &KdTree, i: u32) -> Vec3 {
    let [a, b, c] = tree.triangles[i as usize];
    (b - a).cross(c - a)
}

/// See the module doc.
fn back_exposure(tree: &KdTree, rest: &[Vec3], triangles: &[[u32; 3]]) -> f64 {
    let bounds = used_bounds(rest, triangles);
    let centre = (bounds.min + bounds.max) * 0.5;
    let radius = 0.5 * (bounds.max - bounds.min).length() * 1.01 + f32::MIN_POSITIVE;
    let seq = SampleSequence::new(0x5eed_0b0e);
    let (hits, back) = (0..EXPOSURE_LINES)
        .into_par_iter()
        .with_min_len(64)
        .map(|i| {
            let [u, v] = seq.sample(i, 0);
            let z = 1.0 - 2.0 * u;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * v;
            let out = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let [a, b] = seq.sample(i, 1);
            let d = Frame::from_normal(-out).to_world(cosine_hemisphere(a, b)).normalize();
            let hit = tree.closest_hit(centre + out * radius, d, f32::INFINITY);
            if !hit.is_hit() {
                return (0u32, 0u32);
            }
            (1, (face_normal(tree, hit.triangle).dot(d) > 0.0) as u32)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if hits == 0 { 0.0 } else { back as f64 / hits as f64 }
}

/// Whether the ray meets a front face (a face whose normal opposes it)
/// beyond the back face it hit at `t`, passing through back faces.
fn front_hit(tree: &KdTree, mut origin: Vec3, d: Vec3, t: f32, step: f32) -> bool {
    origin += d * (t + step);
    // Each pass moves past one back face; a few dozen are plenty.
    for _ in 0..64 {
        let hit = tree.closest_hit(origin, d, f32::INFINITY);
        if !hit.is_hit() {
            return false;
        }
        if face_normal(tree, hit.triangle).dot(d) < 0.0 {
            return true;
        }
        origin += d * (hit.t + step);
    }
    true
}

/// See the module doc.
fn culling_error(tree: &KdTree, rest: &[Vec3], triangles: &[[u32; 3]]) -> f64 {
    let mut normals = Vec::new();
    vertex_normals(rest, triangles, &mut normals);
    let scale = used_bounds(rest, triangles).diagonal().max(f32::MIN_POSITIVE);
    let with_normal: Vec<usize> = (0..rest.len()).filter(|&v| normals[v] != Vec3::ZERO).collect();
    let stride = with_normal.len().div_ceil(CULLING_VERTICES).max(1);
    let seq = SampleSequence::new(0xc0ff_ee11);
    let step = ORIGIN_OFFSET * scale;
    let (sum, counted) = with_normal
        .par_iter()
        .step_by(stride)
        .map(|&v| {
            let n = normals[v];
            let origin = rest[v] + n * (ORIGIN_OFFSET * scale);
            let frame = Frame::from_normal(n);
            let (mut open, mut leaked) = (0u32, 0u32);
            for j in 0..CULLING_RAYS {
                let [a, b] = seq.sample(v as u32, j);
                let d = frame.to_world(cosine_hemisphere(a, b)).normalize();
                let hit = tree.closest_hit(origin, d, f32::INFINITY);
                if !hit.is_hit() {
                    open += 1;
                } else if face_normal(tree, hit.triangle).dot(d) > 0.0 && !front_hit(tree, origin, d, hit.t, step) {
                    leaked += 1;
                }
            }
            let open = open as f64 / CULLING_RAYS as f64;
            if open < 0.01 {
                return (0.0, 0u32);
            }
            ((leaked as f64 / CULLING_RAYS as f64) / open, 1)
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if counted == 0 { 0.0 } else { sum / counted as f64 }
}
