//! Rays through alpha cut-outs: a hit on a cut-out triangle where its map
//! has a hole does not count, and the ray goes on from just past it
//! (`scene::cutouts`), at most `MAX_HOLE_CROSSINGS` times. The CPU side of
//! every ray-casting method that honours cut-outs; `cutout_closest` in
//! `wgsl/ao_rays.wgsl` is its twin.

use glam::Vec3;

use crate::geom::ray::Hit;
use crate::scene::cutouts::{Cutouts, MAX_HOLE_CROSSINGS, past_hole};

/// The closest hit with `0 < t < t_max` of the ray from `origin` along `dir`
/// that is not in a cut-out's hole, `closest` finding each candidate and
/// `triangles` holding the traced mesh's corners; `t` is counted from
/// `origin`. After `MAX_HOLE_CROSSINGS` holes the next hit counts, hole or
/// not.
pub fn closest_past_holes(
    cutouts: &Cutouts,
    triangles: &[[Vec3; 3]],
    origin: Vec3,
    dir: Vec3,
    t_max: f32,
    closest: impl Fn(Vec3, Vec3, f32) -> Hit,
) -> Hit {
    let (mut o, mut travelled, mut left) = (origin, 0.0f32, t_max);
    let scale = 1.0 / dir.length_squared();
    for crossed in 0..=MAX_HOLE_CROSSINGS {
        let hit = closest(o, dir, left);
        if !hit.is_hit() {
            return Hit::MISS;
        }
        let v = triangles[hit.triangle as usize];
        let p = o + dir * hit.t;
        if crossed == MAX_HOLE_CROSSINGS || !cutouts.is_hole(hit.triangle, v, p) {
            return Hit {
                t: travelled + hit.t,
                triangle: hit.triangle,
            };
        }
        let next = past_hole(v, p, dir);
        let step = (next - o).dot(dir) * scale;
        travelled += step;
        left -= step;
        o = next;
        if left <= 0.0 {
            break;
        }
    }
    Hit::MISS
}
