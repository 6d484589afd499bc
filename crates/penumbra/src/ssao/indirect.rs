//! Indirect light (section 2) and the shaded image (`ssao_indirect`,
//! `ssao_compose` here and in `wgsl/ssao_indirect.wgsl`).
//!
//! The irradiance from nearby surfaces, I = (1/pi) int (1 - mu(D)) L(o) cos+ dw,
//! becomes I ~ L~ (1 - O) once the occluders' radiance L(o) is replaced by
//! L~, the average radiance of nearby surface points. L~ is gathered from
//! the G-buffer at the pixels the estimator's own sample points project to
//! (for base-disk, the disk points at the shaded depth): a pixel counts when
//! its surface point o lies within R of s, in front of s's tangent plane
//! ((o - s) . N > 0), and faces s (N_o . (s - o) > 0), "by inspecting the
//! camera-space normal, we can also check whether the surface is oriented
//! toward the shaded point, and ignore it in the average otherwise"
//! (section 3.1). No such pixel: L~ = 0.
//!
//! The image is the direct light of the G-buffer plus the paper's
//! a (La O + I): the constant ambient term of local illumination replaced
//! by occluded ambient light and local interreflection.

use glam::Vec3;
use rayon::prelude::*;

use super::estimators::{Family, SsaoUniforms, shaded_point};
use super::gbuffer::{GBuffer, unpack_albedo, valid_depth};
use crate::geom::sampling::Frame;

/// CPU twin of `ssao_indirect`: per pixel (L~.r, L~.g, L~.b, pixels averaged).
pub fn ssao_indirect(gb: &GBuffer, params: &SsaoUniforms, table: &[[f32; 4]], family: Family) -> Vec<[f32; 4]> {
    let sc = params.screen();
    let w = params.width;
    let r2 = params.radius * params.radius;
    (0..gb.pixels() as u32)
        .into_par_iter()
        .with_min_len(64)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let Some((s, n)) = shaded_point(gb, &sc, x, y) else {
                return [0.0; 4];
            };
            let f = Frame::from_normal(n);
            let base = (params.pattern_index(x, y) * params.samples) as usize;
            let mut sum = Vec3::ZERO;
            let mut count = 0u32;
            for q in &table[base..base + params.samples as usize] {
                let p = if family.table_kind() == 1 {
                    s + params.radius * Vec3::new(q[0], q[1], 0.0)
                } else {
                    s + params.radius * (f.t * q[0] + f.b * q[1] + f.n * q[2])
                };
                let Some((px, py)) = sc.project(p) else { continue };
                let j = (py * w + px) as usize;
                let g = gb.geometry[j];
                if !valid_depth(g[3]) {
                    continue;
                }
                let o = sc.cam_point(px, py, g[3]);
                let d = o - s;
                let no = Vec3::new(g[0], g[1], g[2]);
                // The GPU reads the normal only after the distance tests.
                if d.dot(d) < r2 && d.dot(n) > 0.0 && no.dot(d) < 0.0 {
                    let l = gb.shade[j];
                    sum += Vec3::new(l[0], l[1], l[2]);
                    count += 1;
                }
            }
            if count == 0 {
                return [0.0; 4];
            }
            let l = sum * (1.0 / count as f32);
            [l.x, l.y, l.z, count as f32]
        })
        .collect()
}

/// CPU twin of `ssao_compose`: linear RGBA, direct + a (La O + L~ (1 - O)),
/// O clamped to [0, 1]; background transparent black.
pub fn ssao_compose(gb: &GBuffer, params: &SsaoUniforms, ao: &[f32], indirect: &[[f32; 4]]) -> Vec<[f32; 4]> {
    (0..gb.pixels())
        .into_par_iter()
        .with_min_len(256)
        .map(|i| {
            if !valid_depth(gb.geometry[i][3]) {
                return [0.0; 4];
            }
            let sh = gb.shade[i];
            let o = ao[i].clamp(0.0, 1.0);
            let l = Vec3::new(indirect[i][0], indirect[i][1], indirect[i][2]);
            let a = unpack_albedo(sh[3]);
            let c = Vec3::new(sh[0], sh[1], sh[2]) + a * (Vec3::splat(params.ambient * o) + l * (1.0 - o));
            [c.x, c.y, c.z, 1.0]
        })
        .collect()
}
