//! Images of shaded frames: primary rays against a kd-tree of the frame's
//! triangles, per-vertex exitant radiance interpolated barycentrically at
//! the hit (Gouraud shading, as the paper's hardware rendering does), the
//! environment behind, an exposure and the sRGB curve.

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::kdtree::{KdTree, KdTreeSettings};
use crate::error::Result;
use crate::geom::color::srgb8;
use crate::scene::{Camera, EnvironmentMap};

/// Renders one frame; returns 8-bit sRGB pixels, row 0 at the top.
#[allow(clippy::too_many_arguments)]
pub fn render(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    radiance: &[[f32; 3]],
    albedo: Vec3,
    env: Option<&EnvironmentMap>,
    camera: &Camera,
    width: u32,
    height: u32,
    exposure: f32,
) -> Result<Vec<[u8; 3]>> {
    let image = render_radiance(positions, triangles, radiance, albedo, env, camera, width, height)?;
    Ok(image.iter().map(|c| (*c * exposure).to_array().map(srgb8)).collect())
}

/// Renders one frame as linear radiance (no exposure), row 0 at the top:
/// what `render` tone-maps, and what `.exr`/`.pfm` outputs hold.
#[allow(clippy::too_many_arguments)]
pub fn render_radiance(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    radiance: &[[f32; 3]],
    albedo: Vec3,
    env: Option<&EnvironmentMap>,
    camera: &Camera,
    width: u32,
    height: u32,
) -> Result<Vec<Vec3>> {
    let soup: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|i| positions[i as usize])).collect();
    let tree = KdTree::from_triangles(soup, &KdTreeSettings::default())?;
    let rays = camera.primary_rays(width, height);
    Ok(rays
        .par_iter()
        .map(|ray| {
            let (o, d) = (ray.o(), ray.d());
            let hit = tree.closest_hit(o, d, f32::INFINITY);
            if hit.is_hit() {
                let t = triangles[hit.triangle as usize];
                let [a, b, c] = t.map(|i| positions[i as usize]);
                let p = o + d * hit.t;
                let w = barycentric(p, a, b, c);
                let rad = |k: usize| {
                    w.x * radiance[t[0] as usize][k]
                        + w.y * radiance[t[1] as usize][k]
                        + w.z * radiance[t[2] as usize][k]
                };
                Vec3::new(rad(0), rad(1), rad(2)) * albedo
            } else if let Some(env) = env {
                Vec3::from_array(env.lookup(d.normalize()))
            } else {
                Vec3::ZERO
            }
        })
        .collect())
}

/// Barycentric coordinates of p (on the plane of abc).
/// The edges are brought near unit length by a power of two first (exact):
/// `denom` is quartic in them and would underflow for triangles of 1e-10
/// and below, or overflow for ones of 1e10 and above.
pub fn barycentric(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (v0, v1, v2) = (b - a, c - a, p - a);
    let k = crate::accel::kdtree::watertight::frame_scale(v0.abs().max_element().max(v1.abs().max_element()));
    let (v0, v1, v2) = (v0 * k, v1 * k, v2 * k);
    let (d00, d01, d11) = (v0.dot(v0), v0.dot(v1), v1.dot(v1));
    let (d20, d21) = (v2.dot(v0), v2.dot(v1));
    let denom = d00 * d11 - d01 * d01;
    if denom.abs() < f32::MIN_POSITIVE {
        return Vec3::new(1.0, 0.0, 0.0);
    }
    let v = (d11 * d20 - d01 * d21) / denom;
    let w = (d00 * d21 - d01 * d20) / denom;
    Vec3::new(1.0 - v - w, v, w).clamp(Vec3::ZERO, Vec3::ONE)
}

/// The exposure that maps the mean luminance of the shaded vertices to 0.45.
pub fn auto_exposure(radiance: &[[f32; 3]], albedo: Vec3) -> f32 {
    let lum: Vec<f32> = radiance
        .iter()
        .map(|r| 0.2126 * r[0] * albedo.x + 0.7152 * r[1] * albedo.y + 0.0722 * r[2] * albedo.z)
        .filter(|l| *l > 0.0)
        .collect();
    if lum.is_empty() {
        return 1.0;
    }
    let mean = lum.iter().sum::<f32>() / lum.len() as f32;
    0.45 / mean.max(1e-12)
}
