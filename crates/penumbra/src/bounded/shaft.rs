//! Shaft culling (Haines and Wallace, "Shaft culling for efficient
//! ray-traced radiosity", 1991; the bounded-error paper's sections 5.1 and
//! 6.1.2) for a whole family of rays at once: may any ray `o + t d` of a
//! cell, `0 < t < t_end`, meet a primitive the ray tree does not name?
//!
//! The family is given as affine forms over the cell (`affine`), so the
//! test is conservative by construction: candidates are the primitives
//! whose kd-tree leaves overlap the box the segments sweep; a triangle is
//! cleared only if, for every ray, its plane is crossed outside the
//! segment or the crossing lies outside one of its edges; a sphere only if
//! every line passes farther from its centre than its radius. Anything
//! else counts as an occluder.

use glam::DVec3;

use crate::accel::kdtree::KdTree;
use crate::bounded::affine::{AVec3, Aff};
use crate::bounded::geometry::{SceneGeometry, Surface, triangles_in_box};
use crate::whitted::RenderScene;

/// What a shaft may touch without counting: the surfaces its segments
/// start or end on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exclude {
    None,
    /// Triangles in this plane (a flat face the segments end or start on:
    /// they cannot cross it in between).
    Plane(DVec3, f64),
    /// One primitive (a sphere, or a smooth triangle).
    Primitive(u32),
    /// Triangles wholly in `n . x < w`, where no segment goes: the far side
    /// of an emitter's plane for its shadow rays, which run on the emitting
    /// side from a light point lifted off it.
    Behind(DVec3, f64),
}

/// The end of a family's segments.
#[derive(Debug, Clone, Copy)]
pub enum End {
    /// `t` up to this form (its every value).
    At(Aff),
    /// No end: rays towards a directional light or leaving the scene.
    Infinite,
}

/// The scene as shafts see it.
pub struct Shafts<'a> {
    pub scene: &'a RenderScene,
    pub tree: &'a KdTree,
    pub geometry: &'a SceneGeometry,
}

impl Shafts<'_> {
    /// Whether no primitive but the excluded ones can meet a segment
    /// `o + t d`, `0 < t < end`, of the family.
    pub fn clear(&self, o: &AVec3, d: &AVec3, end: End, exclude: &[Exclude]) -> bool {
        self.clear_but(o, d, end, exclude, &[])
    }

    /// `clear`, with the triangles `also` (ascending) excluded as well: a
    /// smooth patch's pieces, which a reprojected cell's eye shaft may
    /// cross (its lines' first hits are on one of them, whichever).
    pub fn clear_but(&self, o: &AVec3, d: &AVec3, end: End, exclude: &[Exclude], also: &[u32]) -> bool {
        // Ranges are all a cull needs: the interpolation-error jets stay
        // behind (their arithmetic was most of a cull's).
        let (o, d) = (&o.plain(), &d.plain());
        let end = match end {
            End::At(t) => End::At(t.plain()),
            End::Infinite => End::Infinite,
        };
        let (lo, hi) = self.swept_box(o, d, end);
        if !(lo.is_finite() && hi.is_finite()) {
            return false;
        }
        let mut candidates = Vec::new();
        triangles_in_box(self.tree, lo, hi, &mut candidates);
        for &t in &candidates {
            if self.excluded(t, exclude) || also.binary_search(&t).is_ok() {
                continue;
            }
            let polygon = match self.geometry.surface(self.scene, t) {
                Surface::Flat(p) => p,
                Surface::Smooth { polygon, .. } => polygon,
                Surface::Sphere { .. } => unreachable!("a triangle"),
            };
            // The triangle itself, not its whole face: a leaf holds
            // triangles.
            let v = self.tree.triangles[t as usize].map(|x| x.as_dvec3());
            if !triangle_clear(o, d, end, polygon.normal, v) {
                return false;
            }
        }
        let first_sphere = self.geometry.triangle_count() as u32;
        for (k, &(center, radius)) in self.geometry.spheres.iter().enumerate() {
            let id = first_sphere + k as u32;
            if exclude.contains(&Exclude::Primitive(id)) {
                continue;
            }
            let behind = exclude
                .iter()
                .any(|e| matches!(*e, Exclude::Behind(n, w) if n.dot(center) + radius < w));
            if behind {
                continue;
            }
            let r = DVec3::splat(radius);
            if (center - r).cmpgt(hi).any() || (center + r).cmplt(lo).any() {
                continue;
            }
            if !sphere_clear(o, d, end, center, radius) {
                return false;
            }
        }
        true
    }

    fn excluded(&self, t: u32, exclude: &[Exclude]) -> bool {
        exclude.iter().any(|e| match *e {
            Exclude::None => false,
            Exclude::Primitive(p) => p == t,
            Exclude::Plane(n, w) => {
                let v = self.tree.triangles[t as usize].map(|x| x.as_dvec3());
                let scale = v
                    .iter()
                    .map(|x| x.abs().max_element())
                    .fold(w.abs(), f64::max)
                    .max(1e-300);
                v.iter().all(|x| (n.dot(*x) - w).abs() <= 1e-9 * scale)
            }
            Exclude::Behind(n, w) => {
                let v = self.tree.triangles[t as usize].map(|x| x.as_dvec3());
                v.iter().all(|x| n.dot(*x) < w)
            }
        })
    }

    /// The box of all points `o + t d`, `0 <= t <= end` (clipped to the
    /// scene for an infinite end).
    fn swept_box(&self, o: &AVec3, d: &AVec3, end: End) -> (DVec3, DVec3) {
        let (olo, ohi) = o.bounds();
        let (dlo, dhi) = d.bounds();
        let scene = &self.tree.bounds;
        let t_hi = match end {
            End::At(t) => t.hi().max(0.0),
            End::Infinite => {
                // Far enough to leave the scene's box from any origin.
                let far = (scene.max.as_dvec3() - scene.min.as_dvec3()).length()
                    + (ohi - olo).length()
                    + (olo - scene.min.as_dvec3()).abs().max_element()
                    + (ohi - scene.max.as_dvec3()).abs().max_element();
                // The slowest certain speed along any axis bounds the time.
                let min_speed = (0..3)
                    .map(|i| {
                        if dlo[i] > 0.0 || dhi[i] < 0.0 {
                            dlo[i].abs().min(dhi[i].abs())
                        } else {
                            0.0
                        }
                    })
                    .fold(0.0, f64::max);
                if min_speed <= 0.0 {
                    // No axis is certain to be left: the whole scene.
                    let lo = olo.min(scene.min.as_dvec3());
                    let hi = ohi.max(scene.max.as_dvec3());
                    return (lo, hi);
                }
                far / min_speed
            }
        };
        let mut lo = olo;
        let mut hi = ohi;
        for i in 0..3 {
            for t in [0.0, t_hi] {
                for dv in [dlo[i], dhi[i]] {
                    for ov in [olo[i], ohi[i]] {
                        let x = ov + t * dv;
                        lo[i] = lo[i].min(x);
                        hi[i] = hi[i].max(x);
                    }
                }
            }
        }
        (lo, hi)
    }
}

/// Whether no segment of the family meets the triangle `v` (unit normal
/// `n`).
fn triangle_clear(o: &AVec3, d: &AVec3, end: End, n: DVec3, v: [DVec3; 3]) -> bool {
    let denom = d.dot_const(n);
    let Some(inv) = denom.recip() else {
        // Some rays run parallel to the plane: no proof.
        return false;
    };
    let t = Aff::constant(n.dot(v[0])).sub(o.dot_const(n)).mul(inv);
    if t.hi() <= 0.0 {
        return true;
    }
    if let End::At(t_end) = end
        && t.sub(t_end).lo() >= 0.0
    {
        return true;
    }
    // Where the rays cross the plane: outside one edge for all of them?
    let x = o.add(d.times(t));
    for k in 0..3 {
        let (a, b) = (v[k], v[(k + 1) % 3]);
        let m = n.cross(b - a);
        // Inside is m . (x - a) >= 0 for a counter-clockwise triangle
        // about n; n is the triangle's own normal, so all three agree.
        if x.add_const(-a).dot_const(m).hi() < 0.0 {
            return true;
        }
    }
    false
}

/// Whether no segment of the family meets the sphere.
fn sphere_clear(o: &AVec3, d: &AVec3, end: End, center: DVec3, radius: f64) -> bool {
    let f = o.add_const(-center);
    let dd = d.dot(*d);
    let fd = f.dot(*d);
    let Some(inv) = dd.recip() else {
        return false;
    };
    // Squared distance of the centre from each line.
    let dist2 = f.dot(f).sub(fd.mul(fd).mul(inv));
    if dist2.lo() > radius * radius {
        return true;
    }
    // Or the sphere lies wholly behind the origins or beyond the ends:
    // the whole sphere spans t within [tc - r/|d|, tc + r/|d|].
    let tc = fd.neg().mul(inv);
    let Some(reach) = dd.rsqrt().map(|x| x.scale(radius)) else {
        return false;
    };
    if tc.add(reach).hi() <= 0.0 {
        return true;
    }
    if let End::At(t_end) = end {
        return tc.sub(reach).sub(t_end).lo() >= 0.0;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    fn family(o: DVec3, spread: f64, d: DVec3) -> (AVec3, AVec3) {
        let origin = AVec3::new(
            Aff::coordinate(0, o.x, spread),
            Aff::coordinate(1, o.y, spread),
            Aff::constant(o.z),
        );
        (origin, AVec3::constant(d))
    }

    #[test]
    fn triangles_and_spheres_in_and_out_of_the_way() {
        let tri = [
            DVec3::new(-1.0, -1.0, 5.0),
            DVec3::new(1.0, -1.0, 5.0),
            DVec3::new(0.0, 1.0, 5.0),
        ];
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        let (o, d) = family(DVec3::ZERO, 0.1, DVec3::Z);
        assert!(
            !triangle_clear(&o, &d, End::At(Aff::constant(10.0)), n, tri),
            "in the way"
        );
        assert!(
            triangle_clear(&o, &d, End::At(Aff::constant(4.0)), n, tri),
            "beyond the end"
        );
        let (o2, _) = family(DVec3::new(3.0, 0.0, 0.0), 0.1, DVec3::Z);
        assert!(triangle_clear(&o2, &d, End::Infinite, n, tri), "beside it");
        let (o3, _) = family(DVec3::new(0.9, 0.0, 0.0), 0.3, DVec3::Z);
        assert!(
            !triangle_clear(&o3, &d, End::Infinite, n, tri),
            "across an edge: no proof"
        );
        let c = DVec3::new(0.0, 0.0, 5.0);
        assert!(!sphere_clear(&o, &d, End::Infinite, c, 0.5));
        assert!(sphere_clear(&o2, &d, End::Infinite, c, 0.5));
        assert!(sphere_clear(&o, &d, End::At(Aff::constant(4.0)), c, 0.5), "before it");
        let behind = DVec3::new(0.0, 0.0, -5.0);
        assert!(sphere_clear(&o, &d, End::Infinite, behind, 0.5), "behind the origins");
    }
}
