//! Axis-aligned bounding boxes.

use glam::Vec3;

/// A closed axis-aligned box `[min, max]`. The empty box has `min > max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The smallest corner (least x, y and z).
    pub min: Vec3,
    /// The largest corner (greatest x, y and z).
    pub max: Vec3,
}

impl Aabb {
    /// The empty box, `min = +inf` and `max = -inf`: the identity of
    /// `grow` and `union`.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box with corners `min` and `max`, taken as given (not sorted).
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    /// The smallest box holding every point; `EMPTY` for none.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Self {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.grow(*p))
    }

    /// Whether `min > max` on some axis. A flat box (`min == max` on an
    /// axis) or a single point is not empty.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// The smallest box holding `self` and `p`.
    #[must_use]
    pub fn grow(self, p: Vec3) -> Self {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box holding both boxes.
    #[must_use]
    pub fn union(self, o: Aabb) -> Self {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// The points both boxes hold; empty (`min > max` somewhere) where
    /// they do not overlap.
    #[must_use]
    pub fn intersection(self, o: Aabb) -> Self {
        Aabb {
            min: self.min.max(o.min),
            max: self.max.min(o.max),
        }
    }

    /// `max - min`: the edge lengths (negative on an empty box's axes).
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// The midpoint of `min` and `max`.
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// The diagonal's length, summed in f64: in f32 the squares underflow
    /// for boxes of 1e-19 (and overflow for 1e19), making the length of a
    /// tiny box inexact and scale-dependent.
    pub fn diagonal(&self) -> f32 {
        self.extent().as_dvec3().length() as f32
    }

    /// Surface area; a flat (2D) box has the area of both of its faces.
    pub fn surface_area(&self) -> f32 {
        let e = self.extent().max(Vec3::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Surface area of the box scaled by `k` (a power of two, so that the
    /// SAH of a tiny or huge scene neither underflows nor overflows).
    pub fn surface_area_in(&self, k: f32) -> f32 {
        let e = self.extent().max(Vec3::ZERO) * k;
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// The volume, 0 for a flat or empty box.
    pub fn volume(&self) -> f32 {
        let e = self.extent().max(Vec3::ZERO);
        e.x * e.y * e.z
    }

    /// Whether `p` is in the closed box (boundary included).
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Parametric interval `[t0, t1]` where the ray `o + t d` is inside the box,
    /// or `None`. Directions with zero components are handled: the ray is then
    /// inside the slab for all t or for none.
    #[inline]
    pub fn clip_ray(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        if d.cmpne(Vec3::ZERO).all() {
            // All slabs restrict t: three lanes at once, no NaN possible
            // (finite box and origin, non-zero direction).
            let inv = d.recip();
            let a = (self.min - o) * inv;
            let b = (self.max - o) * inv;
            let t0 = a.min(b).max_element().max(t_min);
            let t1 = a.max(b).min_element().min(t_max);
            return (t0 <= t1).then_some((t0, t1));
        }
        self.clip_ray_axis_parallel(o, d, t_min, t_max)
    }

    /// `clip_ray` with the interval widened by a relative `slack` before it
    /// is tested: `[t0 (1 - slack), t1 (1 + slack)]`. A ray that grazes an
    /// edge or corner of the box, where rounding puts its entry a few ulps
    /// past its exit, is then inside, as it is for boxes padded by the same
    /// slack (the wide BVH's) and for the triangles on that boundary.
    #[inline]
    pub fn clip_ray_widened(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32, slack: f32) -> Option<(f32, f32)> {
        let (t0, t1) = if d.cmpne(Vec3::ZERO).all() {
            let inv = d.recip();
            let a = (self.min - o) * inv;
            let b = (self.max - o) * inv;
            (a.min(b).max_element().max(t_min), a.max(b).min_element().min(t_max))
        } else {
            self.slabs_axis_parallel(o, d, t_min, t_max)?
        };
        let (t0, t1) = (t0 * (1.0 - slack), t1 * (1.0 + slack));
        (t0 <= t1).then_some((t0, t1))
    }

    /// The slabs' interval for directions with zero components, possibly
    /// empty (`t0 > t1`); `None` where the ray lies outside a slab it is
    /// parallel to.
    fn slabs_axis_parallel(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let mut t0 = t_min;
        let mut t1 = t_max;
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < self.min[a] || o[a] > self.max[a] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d[a];
            let near = (self.min[a] - o[a]) * inv;
            let far = (self.max[a] - o[a]) * inv;
            t0 = t0.max(near.min(far));
            t1 = t1.min(near.max(far));
        }
        Some((t0, t1))
    }

    /// `clip_ray` for directions with zero components.
    fn clip_ray_axis_parallel(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let mut t0 = t_min;
        let mut t1 = t_max;
        for a in 0..3 {
            let inv = 1.0 / d[a];
            let mut near = (self.min[a] - o[a]) * inv;
            let mut far = (self.max[a] - o[a]) * inv;
            if near > far {
                std::mem::swap(&mut near, &mut far);
            }
            // NaN arises for a zero direction component with the origin on the
            // slab boundary: the ray lies in the boundary plane, which the
            // closed box contains, so the slab does not restrict t.
            if near.is_nan() || far.is_nan() {
                if o[a] < self.min[a] || o[a] > self.max[a] {
                    return None;
                }
                continue;
            }
            t0 = t0.max(near);
            t1 = t1.min(far);
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clip_ray_handles_axis_parallel_rays() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        // Parallel to x, inside the y and z slabs.
        let r = b.clip_ray(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 0.0, f32::INFINITY);
        assert_eq!(r, Some((1.0, 2.0)));
        // Parallel to x, outside the y slab.
        assert_eq!(b.clip_ray(Vec3::new(-1.0, 2.0, 0.5), Vec3::X, 0.0, f32::INFINITY), None);
        // Lying in the boundary plane y = 1.
        let r = b.clip_ray(Vec3::new(-1.0, 1.0, 0.5), Vec3::X, 0.0, f32::INFINITY);
        assert_eq!(r, Some((1.0, 2.0)));
    }

    #[test]
    fn flat_box_has_area_but_no_volume() {
        let b = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(b.volume(), 0.0);
        assert_eq!(b.surface_area(), 2.0);
    }
}
