//! AO sample points as the command-line contract defines them.

use super::AoPoint;
use crate::geom::ray::{Hit, Ray};
use crate::scene::Mesh;

/// One point per vertex of `mesh`: origin = vertex + 1e-4 * diagonal * n with
/// n the area-weighted vertex normal; stream = vertex index. Vertices without
/// a normal (used by no triangle, or only by zero-area ones) get a zero
/// normal, i.e. no rays.
pub fn vertex_points(mesh: &Mesh) -> Vec<AoPoint> {
    let offset = mesh.origin_offset();
    mesh.vertex_normals()
        .iter()
        .zip(&mesh.positions)
        .enumerate()
        .map(|(i, (&n, &p))| AoPoint::new(p + offset * n, n, i as u32))
        .collect()
}

/// One point per pixel whose primary ray hit: origin = hit point offset along
/// the hit triangle's normal turned towards the camera; stream = pixel index.
/// `offset` is absolute (callers use the scene's `Mesh::origin_offset`).
/// Hits on zero-area triangles get no hemisphere.
pub fn hit_points(mesh: &Mesh, rays: &[Ray], hits: &[Hit], offset: f32) -> Vec<AoPoint> {
    rays.iter()
        .zip(hits)
        .enumerate()
        .filter(|(_, (_, h))| h.is_hit())
        .map(|(pixel, (ray, hit))| {
            let p = ray.o() + hit.t * ray.d();
            let mut n = mesh.unit_face_normal(hit.triangle as usize);
            if n.dot(ray.d()) > 0.0 {
                n = -n;
            }
            AoPoint::new(p + offset * n, n, pixel as u32)
        })
        .collect()
}

/// Number of points that cast no rays.
pub fn points_without_hemisphere(points: &[AoPoint]) -> usize {
    points.iter().filter(|p| !p.has_hemisphere()).count()
}
