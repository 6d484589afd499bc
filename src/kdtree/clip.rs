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
pub fn clip_triangle(tri: &[Vec3; 3], cell: &Aabb) -> ClippedPolygon {
    let mut poly = ClippedPolygon {
        vertices: [Vec3::ZERO; 9],
        len: 3,
    };
    poly.vertices[..3].copy_from_slice(tri);
    let mut scratch = [Vec3::ZERO; 9];
    for axis in 0..3 {
        for (plane, keep_below) in [(cell.min[axis], false), (cell.max[axis], true)] {
            if poly.len == 0 {
                return poly;
            }
            let inside = |p: Vec3| if keep_below { p[axis] <= plane } else { p[axis] >= plane };
            // Most planes of a cell do not cut a triangle that straddles one
            // of them: skip those without rebuilding the polygon.
            let kept = poly.vertices[..poly.len].iter().filter(|&&p| inside(p)).count();
            if kept == poly.len {
                continue;
            }
            if kept == 0 {
                poly.len = 0;
                return poly;
            }
            let mut n = 0;
            for i in 0..poly.len {
                let a = poly.vertices[i];
                let b = poly.vertices[(i + 1) % poly.len];
                let (ia, ib) = (inside(a), inside(b));
                if ia {
                    scratch[n] = a;
                    n += 1;
                }
                if ia != ib {
                    // Intersection with the plane; the coordinate on the plane
                    // is set exactly so the piece lies in the closed cell.
                    let s = (plane - a[axis]) / (b[axis] - a[axis]);
                    let mut p = a + (b - a) * s;
                    p[axis] = plane;
                    scratch[n] = p;
                    n += 1;
                }
            }
            poly.vertices[..n].copy_from_slice(&scratch[..n]);
            poly.len = n;
        }
    }
    poly
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
