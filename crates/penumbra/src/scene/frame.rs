//! The canonical frame of a model far from the origin.
//!
//! f32 holds 24 bits: a model 1e6 times its size away from the origin
//! keeps only about 4 bits of its own detail (the sphere-on-plane moved by
//! 1e6 gave AO 0.663 instead of 0.629). Readers therefore parse positions
//! in f64 and subtract an origin before rounding to f32; the origin is a
//! multiple of a power of two at least the model's extent, so it is exact
//! in f64 and a model moved by a multiple of that grid lands on exactly the
//! coordinates it had unmoved (same hits, same AO, bit for bit). Every
//! world-space input (camera, rays, lights, scene transforms) is moved by
//! the same origin (`to_local`) and every world-space output moved back
//! (`to_world`); distances, t and AO are unchanged by a translation.
//!
//! A model whose centre lies within `NEAR` grid steps of the origin keeps
//! origin zero: its coordinates are what they always were.

use glam::{DVec3, Vec3};

/// How many grid steps (powers of two >= the extent) a model's centre may
/// lie from the origin before it is recentred: within 8, f32 loses at most
/// 4 bits of the model's detail, and ordinary models (centred or sitting on
/// a floor) keep the coordinates they have always had.
const NEAR: f64 = 8.0;

/// The origin of the frame a model spanning `lo..hi` (file coordinates) is
/// kept in: zero near the origin, else its centre rounded to the grid of
/// the smallest power of two at least its extent.
pub fn origin_for(lo: DVec3, hi: DVec3) -> DVec3 {
    let extent = (hi - lo).max_element();
    let centre = 0.5 * lo + 0.5 * hi;
    if !(extent > 0.0 && extent.is_finite() && centre.is_finite()) {
        return DVec3::ZERO;
    }
    let grid = 2f64.powi(extent.log2().ceil() as i32);
    if centre.abs().max_element() <= NEAR * grid {
        return DVec3::ZERO;
    }
    (centre / grid).round() * grid
}

/// Points read in f64 (file coordinates) as f32 relative to `origin_for`
/// their bounds; returns the origin and the points.
pub fn recentre(points: &[DVec3]) -> (DVec3, Vec<Vec3>) {
    let (lo, hi) = points
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let origin = origin_for(lo, hi);
    (origin, points.iter().map(|&p| to_local(origin, p)).collect())
}

/// A world-space point in the frame whose origin is `origin`.
pub fn to_local(origin: DVec3, p: DVec3) -> Vec3 {
    (p - origin).as_vec3()
}

/// A point of the frame whose origin is `origin`, in world space.
pub fn to_world(origin: DVec3, p: Vec3) -> DVec3 {
    p.as_dvec3() + origin
}

/// A point or vector written "X,Y,Z" read in f64 (a camera's eye at 1e6
/// keeps its digits), finite and within f32's range.
pub fn parse_point(s: &str) -> std::result::Result<DVec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected X,Y,Z, got '{s}'"));
    }
    let mut v = [0.0f64; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse().map_err(|_| format!("'{p}' is not a number"))?;
        if !(*slot as f32).is_finite() {
            return Err(format!("'{p}' is not finite in f32 (at most 3.4e38)"));
        }
    }
    Ok(DVec3::from_array(v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_near_the_origin_keep_their_coordinates() {
        let o = origin_for(DVec3::new(-1.0, 0.0, -1.0), DVec3::new(1.0, 1.0, 1.0));
        assert_eq!(o, DVec3::ZERO);
        // A model on a floor 5 sizes up: still near.
        assert_eq!(origin_for(DVec3::splat(10.0), DVec3::splat(12.0)), DVec3::ZERO);
    }

    #[test]
    fn a_far_model_moved_by_the_grid_lands_on_its_own_coordinates() {
        let model = [
            DVec3::new(-0.7, 0.1, 0.3),
            DVec3::new(0.9, 1.3, -0.2),
            DVec3::new(0.123456789, 0.5, 0.1),
        ];
        let f32_model: Vec<DVec3> = model.iter().map(|p| p.as_vec3().as_dvec3()).collect();
        // The extent is 1.2: the grid 2; 2^21 * 2 is about 1.7e6 sizes away.
        let offset = DVec3::new(2f64.powi(22), -3.0 * 2f64.powi(21), 2f64.powi(22));
        let moved: Vec<DVec3> = f32_model.iter().map(|&p| p + offset).collect();
        let (origin, local) = recentre(&moved);
        assert_eq!(origin, offset);
        let unmoved: Vec<Vec3> = f32_model.iter().map(|p| p.as_vec3()).collect();
        assert_eq!(local, unmoved);
        assert_eq!(to_world(origin, local[2]), moved[2]);
    }

    #[test]
    fn a_decimal_offset_keeps_the_detail_f32_would_lose() {
        let p = DVec3::new(0.123456789, 0.5, 0.25);
        let moved = p + DVec3::splat(2.0e6);
        let (origin, local) = recentre(&[moved, moved + DVec3::ONE]);
        let back = to_world(origin, local[0]) - DVec3::splat(2.0e6);
        assert!((back - p).abs().max_element() < 1e-6, "{back}");
        // What a plain f32 parse keeps: 0.125 of 1.
        assert!((moved.as_vec3().as_dvec3() - moved).abs().max_element() > 1e-3);
    }

    #[test]
    fn points_parse_in_f64_and_refuse_what_f32_cannot_hold() {
        assert_eq!(
            parse_point("2000000.125, 1, -2").unwrap(),
            DVec3::new(2000000.125, 1.0, -2.0)
        );
        assert!(parse_point("1e39,0,0").unwrap_err().contains("not finite"));
        assert!(parse_point("1,2").is_err());
    }
}
