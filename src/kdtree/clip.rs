//! Clipping triangles to cells ("perfect splits", Havran 2000, section 4.5):
//! a triangle that straddles a split plane is given, in each child, the bounds
//! of its part inside the child rather than its whole bounding box. This keeps
//! large triangles out of cells they only pass near.

use glam::Vec3;

use crate::aabb::Aabb;

/// The polygon of a triangle clipped to a box: at most 3 + 6 vertices.
pub struct ClippedPolygon {
    pub vertices: [Vec3; 9],
    pub len: usize,
}

/// Sutherland–Hodgman clipping of triangle `tri` against the closed box `cell`.
/// The polygon goes back and forth between two buffers (no copy per plane)
/// and an edge's end is found without a division, in the order the vertices
/// always had.
pub fn clip_triangle(tri: &[Vec3; 3], cell: &Aabb) -> ClippedPolygon {
    let mut bufs = [[[0.0f32; 3]; 9]; 2];
    for (v, p) in bufs[0].iter_mut().zip(tri) {
        *v = p.to_array();
    }
    let (mut cur, mut len) = (0, 3);
    for axis in 0..3 {
        for (plane, keep_below) in [(cell.min[axis], false), (cell.max[axis], true)] {
            let inside = |p: &[f32; 3]| if keep_below { p[axis] <= plane } else { p[axis] >= plane };
            let (first, second) = bufs.split_at_mut(1);
            let (from, to) = if cur == 0 {
                (&first[0], &mut second[0])
            } else {
                (&second[0], &mut first[0])
            };
            // Most planes of a cell do not cut a triangle that straddles one
            // of them: skip those without rebuilding the polygon.
            let kept = from[..len].iter().filter(|p| inside(p)).count();
            if kept == len {
                continue;
            }
            if kept == 0 {
                return ClippedPolygon {
                    vertices: [Vec3::ZERO; 9],
                    len: 0,
                };
            }
            len = clip_to_plane(&from[..len], to, axis, plane, inside);
            cur = 1 - cur;
        }
    }
    let mut vertices = [Vec3::ZERO; 9];
    for (v, p) in vertices.iter_mut().zip(&bufs[cur][..len]) {
        *v = Vec3::from_array(*p);
    }
    ClippedPolygon { vertices, len }
}

/// One Sutherland–Hodgman step: the part of polygon `from` on the `inside`
/// of the plane `p[axis] = plane`, written to `to`; returns its length.
#[inline(always)]
fn clip_to_plane(
    from: &[[f32; 3]],
    to: &mut [[f32; 3]; 9],
    axis: usize,
    plane: f32,
    inside: impl Fn(&[f32; 3]) -> bool,
) -> usize {
    let mut n = 0;
    for i in 0..from.len() {
        let a = from[i];
        let b = from[if i + 1 == from.len() { 0 } else { i + 1 }];
        let (ia, ib) = (inside(&a), inside(&b));
        if ia {
            to[n] = a;
            n += 1;
        }
        if ia != ib {
            // Intersection with the plane; the coordinate on the plane
            // is set exactly so the piece lies in the closed cell.
            let s = (plane - a[axis]) / (b[axis] - a[axis]);
            let mut p = [0.0; 3];
            for c in 0..3 {
                p[c] = a[c] + (b[c] - a[c]) * s;
            }
            p[axis] = plane;
            to[n] = p;
            n += 1;
        }
    }
    n
}

impl ClippedPolygon {
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.vertices[..self.len])
    }

    /// Area of the (planar, convex) polygon.
    pub fn area(&self) -> f32 {
        self.area_in(1.0)
    }

    /// Area of the polygon scaled by `k` (a power of two: exact), so that
    /// the cross products neither underflow nor overflow at extreme sizes.
    pub fn area_in(&self, k: f32) -> f32 {
        let mut sum = Vec3::ZERO;
        let v0 = self.vertices[0] * k;
        for i in 1..self.len.saturating_sub(1) {
            sum += (self.vertices[i] * k - v0).cross(self.vertices[i + 1] * k - v0);
        }
        0.5 * sum.length()
    }
}

/// Bounds of the part of `tri` inside `cell`, grown by a few ulps and kept
/// inside the cell. Interpolated intersection points are rounded; growing the
/// bounds makes the rounding err on the side of keeping a triangle in a cell,
/// which costs an intersection test, never a missed hit.
pub fn clipped_bounds(tri: &[Vec3; 3], cell: &Aabb) -> Aabb {
    let poly = clip_triangle(tri, cell);
    if poly.len == 0 {
        return Aabb::EMPTY;
    }
    let b = poly.bounds();
    let slack = (b.min.abs().max(b.max.abs()) + cell.extent()) * 4.0 * f32::EPSILON;
    Aabb::new(b.min - slack, b.max + slack).intersection(*cell)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_a_triangle_to_half_its_box() {
        let tri = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
        let cell = Aabb::new(Vec3::new(1.0, -1.0, -1.0), Vec3::new(3.0, 3.0, 1.0));
        let poly = clip_triangle(&tri, &cell);
        let b = poly.bounds();
        assert_eq!(b.min.x, 1.0);
        assert!((b.max.y - 1.0).abs() < 1e-6);
        assert!((poly.area() - 0.5).abs() < 1e-6);
    }

    #[test]
    fn a_triangle_outside_the_cell_clips_to_nothing() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let cell = Aabb::new(Vec3::splat(2.0), Vec3::splat(3.0));
        assert_eq!(clip_triangle(&tri, &cell).len, 0);
        assert!(clipped_bounds(&tri, &cell).is_empty());
    }
}
