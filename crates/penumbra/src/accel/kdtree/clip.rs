//! Clipping triangles to cells ("perfect splits", Havran 2000, section 4.5):
//! a triangle that straddles a split plane is given, in each child, the bounds
//! of its part inside the child rather than its whole bounding box. This keeps
//! large triangles out of cells they only pass near.

use glam::Vec3;

use crate::geom::aabb::Aabb;

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
    #[cfg(test)]
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
/// which costs an intersection test, never a missed hit. (The builder uses
/// `split_clipped_bounds`; this is its reference in tests.)
#[cfg(test)]
pub fn clipped_bounds(tri: &[Vec3; 3], cell: &Aabb) -> Aabb {
    let poly = clip_triangle(tri, cell);
    if poly.len == 0 {
        return Aabb::EMPTY;
    }
    grown_within(poly.bounds(), cell)
}

/// `clipped_bounds` of `tri` in the two children of `cell` split at `pos` on
/// `axis` (below, above). The triangle is clipped to the cell once and the
/// polygon cut at the plane: the vertices on each side and the points where
/// edges cross it. Clipping it to each child from scratch was 16% of the
/// bunny's build; this is the same polygon up to rounding, which the slack
/// covers.
pub fn split_clipped_bounds(tri: &[Vec3; 3], cell: &Aabb, axis: usize, pos: f32) -> (Aabb, Aabb) {
    let poly = clip_triangle(tri, cell);
    let v = &poly.vertices[..poly.len];
    let (mut below, mut above) = (Aabb::EMPTY, Aabb::EMPTY);
    for i in 0..v.len() {
        let (a, b) = (v[i], v[if i + 1 == v.len() { 0 } else { i + 1 }]);
        if a[axis] <= pos {
            below = below.grow(a);
        }
        if a[axis] >= pos {
            above = above.grow(a);
        }
        if (a[axis] < pos && b[axis] > pos) || (a[axis] > pos && b[axis] < pos) {
            let s = (pos - a[axis]) / (b[axis] - a[axis]);
            let mut p = a + (b - a) * s;
            p[axis] = pos;
            below = below.grow(p);
            above = above.grow(p);
        }
    }
    let (mut below_cell, mut above_cell) = (*cell, *cell);
    below_cell.max[axis] = pos;
    above_cell.min[axis] = pos;
    let grown = |b: Aabb, cell: &Aabb| {
        if b.is_empty() {
            Aabb::EMPTY
        } else {
            grown_within(b, cell)
        }
    };
    (grown(below, &below_cell), grown(above, &above_cell))
}

/// `b` grown by a few ulps of its coordinates and of the cell's extent,
/// then kept inside `cell`.
fn grown_within(b: Aabb, cell: &Aabb) -> Aabb {
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

    /// Splitting the polygon clipped to the cell gives the bounds clipping
    /// to each child gives, up to rounding: crossing points of edges nearly
    /// parallel to a plane differ by a few ulps of the cell's extent (1.2e-6
    /// in a cell of extent 2 here), in either way of computing them.
    #[test]
    fn split_bounds_match_clipping_to_each_child() {
        let mut rng = crate::accel::kdtree::test_rng::Rng(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.next_f32() * 4.0 - 2.0;
        let cell = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        for case in 0..5000 {
            let tri = [0; 3].map(|_| Vec3::new(next(), next(), next()));
            let (axis, pos) = (case % 3, next() * 0.45);
            let (mut below_cell, mut above_cell) = (cell, cell);
            below_cell.max[axis] = pos;
            above_cell.min[axis] = pos;
            let (below, above) = split_clipped_bounds(&tri, &cell, axis, pos);
            for (split, child) in [(below, below_cell), (above, above_cell)] {
                let exact = clipped_bounds(&tri, &child);
                assert_eq!(split.is_empty(), exact.is_empty(), "case {case}");
                if !exact.is_empty() {
                    assert!((split.min - exact.min).abs().max_element() < 1e-5, "case {case}");
                    assert!((split.max - exact.max).abs().max_element() < 1e-5, "case {case}");
                }
            }
        }
    }
}
