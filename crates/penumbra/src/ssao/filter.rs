//! The depth-aware 4x4 low-pass filter of section 5 and the upsampling of
//! half-resolution AO (`ssao_filter_ao_rows`, `ssao_filter_ao_columns`,
//! `ssao_upsample`, `ssao_filter_indirect` here and in
//! `wgsl/ssao_filter.wgsl`).
//!
//! Each surface pixel averages the pixels of the 4x4 window with offsets
//! -2..=1 in x and y (any such window holds each of the 16 interleaved
//! sample sets once) that are surfaces and whose depth differs from its own
//! by at most `filter_depth`: "if the depth difference between the current
//! and neighbouring pixels exceeds a given limit, we do not include the
//! neighbouring pixels in the averaging". The pixel itself always counts.
//! Background pixels are passed through.
//!
//! The indirect light is filtered so, in one pass. The AO is filtered in
//! two (separable: 4 + 4 taps instead of 16): each cell first sums its row
//! window (neighbours within `filter_depth` of the cell), then adds up the
//! row sums and counts of its column window's cells that are within
//! `filter_depth` of the centre. A neighbour (x + dx, y + dy) thus counts
//! when it is near (x, y + dy) in depth and (x, y + dy) is near (x, y), not
//! when it is near (x, y) itself: on one surface the same thing, across a
//! depth edge or next to background slightly different (the RMSE against
//! both references moves by less than 0.0001, `docs/results/ssao.md`). The
//! AO filter works on the estimation grid (every pixel, or every other one
//! at half resolution, `SsaoUniforms::scale`), with the depths of the cells'
//! pixels.

use rayon::prelude::*;

use super::estimators::SsaoUniforms;
use super::gbuffer::{GBuffer, valid_depth};

/// Window offsets of the 4x4 filter.
pub const FILTER_OFFSETS: std::ops::RangeInclusive<i32> = -2..=1;

fn filter<T: Copy + Send + Sync>(
    gb: &GBuffer,
    params: &SsaoUniforms,
    input: &[T],
    zero: T,
    add: impl Fn(T, T) -> T + Sync,
    scale: impl Fn(T, f32) -> T + Sync,
) -> Vec<T> {
    let (w, h) = (params.width as i32, params.height as i32);
    (0..gb.pixels())
        .into_par_iter()
        .with_min_len(256)
        .map(|i| {
            let c = gb.geometry[i][3];
            if !valid_depth(c) {
                return input[i];
            }
            let (x, y) = (i as i32 % w, i as i32 / w);
            let mut sum = zero;
            let mut count = 0u32;
            for dy in FILTER_OFFSETS {
                for dx in FILTER_OFFSETS {
                    let (qx, qy) = (x + dx, y + dy);
                    if qx < 0 || qy < 0 || qx >= w || qy >= h {
                        continue;
                    }
                    let q = (qy * w + qx) as usize;
                    let d = gb.geometry[q][3];
                    if valid_depth(d) && (d - c).abs() <= params.filter_depth {
                        sum = add(sum, input[q]);
                        count += 1;
                    }
                }
            }
            scale(sum, 1.0 / count as f32)
        })
        .collect()
}

/// The AO after the filter (if `filter`) and the upsampling (at half
/// resolution), per pixel, from the estimator's output per grid cell: the
/// kernels as `gpu::SsaoPass::record` dispatches them.
pub fn filter_ao(gb: &GBuffer, params: &SsaoUniforms, filter: bool, ao: &[f32]) -> Vec<f32> {
    let grid = match filter {
        true => ssao_filter_ao_columns(gb, params, &ssao_filter_ao_rows(gb, params, ao)),
        false => ao.to_vec(),
    };
    match params.scale {
        1 => grid,
        _ => ssao_upsample(gb, params, &grid),
    }
}

/// Whether depth d is a surface within `filter_depth` of depth c.
#[inline]
fn near(params: &SsaoUniforms, c: f32, d: f32) -> bool {
    valid_depth(d) && (d - c).abs() <= params.filter_depth
}

/// CPU twin of `ssao_filter_ao_rows`: per grid cell, the sum and count of
/// the row window's cells near it in depth (background: its own value, 1).
pub fn ssao_filter_ao_rows(gb: &GBuffer, params: &SsaoUniforms, ao: &[f32]) -> Vec<[f32; 2]> {
    let w = params.lo_width;
    (0..params.cells() as u32)
        .into_par_iter()
        .with_min_len(256)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let c = params.grid_depth(gb, x, y);
            if !valid_depth(c) {
                return [ao[i as usize], 1.0];
            }
            let (mut sum, mut count) = (0.0f32, 0.0f32);
            for dx in FILTER_OFFSETS {
                let qx = x as i32 + dx;
                if qx < 0 || qx >= w as i32 {
                    continue;
                }
                if near(params, c, params.grid_depth(gb, qx as u32, y)) {
                    sum += ao[(y * w + qx as u32) as usize];
                    count += 1.0;
                }
            }
            [sum, count]
        })
        .collect()
}

/// CPU twin of `ssao_filter_ao_columns`: per grid cell, the filtered AO
/// (the GPU writes it to `ao_out` at full resolution, to the scratch
/// buffer's filtered grid at half).
pub fn ssao_filter_ao_columns(gb: &GBuffer, params: &SsaoUniforms, rows: &[[f32; 2]]) -> Vec<f32> {
    let (w, h) = (params.lo_width, params.lo_height);
    (0..params.cells() as u32)
        .into_par_iter()
        .with_min_len(256)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let c = params.grid_depth(gb, x, y);
            if !valid_depth(c) {
                return rows[i as usize][0];
            }
            let (mut sum, mut count) = (0.0f32, 0.0f32);
            for dy in FILTER_OFFSETS {
                let qy = y as i32 + dy;
                if qy < 0 || qy >= h as i32 {
                    continue;
                }
                if near(params, c, params.grid_depth(gb, x, qy as u32)) {
                    let q = rows[(qy as u32 * w + x) as usize];
                    sum += q[0];
                    count += q[1];
                }
            }
            sum * (1.0 / count)
        })
        .collect()
}

/// CPU twin of `ssao_upsample`: the AO of every pixel from the filtered
/// grid. A surface pixel averages the cells around it that are near it in
/// depth: its cell (X, Y) = (x, y) / scale and, where x (y) is not a
/// multiple of the scale, the next cell in x (y) too (at scale 2 the pixel
/// lies halfway between the cells' pixels: equal weights). None near: the
/// value of the cell among the 3x3 around (X, Y) nearest in depth (the
/// first on a tie, rows first), 1 if none is a surface. Background: 1.
/// (The GPU runs one invocation per cell for its 2x2 pixels, which share
/// the four cells they read; the rule per pixel is this.)
pub fn ssao_upsample(gb: &GBuffer, params: &SsaoUniforms, grid: &[f32]) -> Vec<f32> {
    let (w, s) = (params.width, params.scale);
    let (lw, lh) = (params.lo_width, params.lo_height);
    (0..gb.pixels() as u32)
        .into_par_iter()
        .with_min_len(256)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let c = gb.geometry[i as usize][3];
            if !valid_depth(c) {
                return 1.0;
            }
            let (x0, y0) = (x / s, y / s);
            let x1 = if x % s != 0 && x0 + 1 < lw { x0 + 1 } else { x0 };
            let y1 = if y % s != 0 && y0 + 1 < lh { y0 + 1 } else { y0 };
            let (mut sum, mut count) = (0.0f32, 0u32);
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    if near(params, c, params.grid_depth(gb, cx, cy)) {
                        sum += grid[(cy * lw + cx) as usize];
                        count += 1;
                    }
                }
            }
            if count > 0 {
                return sum * (1.0 / count as f32);
            }
            let mut best: Option<f32> = None;
            let mut value = 1.0;
            for cy in y0.max(1) - 1..=(y0 + 1).min(lh - 1) {
                for cx in x0.max(1) - 1..=(x0 + 1).min(lw - 1) {
                    let d = params.grid_depth(gb, cx, cy);
                    if valid_depth(d) && best.is_none_or(|b| (d - c).abs() < b) {
                        best = Some((d - c).abs());
                        value = grid[(cy * lw + cx) as usize];
                    }
                }
            }
            value
        })
        .collect()
}

/// CPU twin of `ssao_filter_indirect` (all four channels).
pub fn ssao_filter_indirect(gb: &GBuffer, params: &SsaoUniforms, l: &[[f32; 4]]) -> Vec<[f32; 4]> {
    filter(
        gb,
        params,
        l,
        [0.0; 4],
        |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]],
        |a, s| a.map(|c| c * s),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;
    use crate::ssao::gbuffer::ScreenView;
    use crate::ssao::{Estimator, Resolution, SampleTable, ShadeSettings, SsaoSettings};

    /// A W x H G-buffer facing the camera with depth `z(x, y)` (0 = background).
    fn gbuffer(w: u32, h: u32, z: impl Fn(u32, u32) -> f32) -> GBuffer {
        let geometry = (0..w * h).map(|i| [0.0, 0.0, -1.0, z(i % w, i / w)]).collect();
        GBuffer {
            width: w,
            height: h,
            geometry,
            shade: vec![[0.0; 4]; (w * h) as usize],
        }
    }

    fn params(w: u32, h: u32, resolution: Resolution) -> SsaoUniforms {
        let mut s = SsaoSettings::new(Estimator::Importance, 4, 1.0);
        s.resolution = resolution;
        let camera = Camera {
            eye: glam::Vec3::ZERO,
            target: glam::Vec3::Z,
            fov_degrees: 60.0,
        };
        let view = ScreenView::new(&camera, w, h);
        SsaoUniforms::new(&view, &s, &SampleTable::build(&s).unwrap(), ShadeSettings::default())
    }

    /// Left of column 7 at depth 1, right of it at depth 5 (filter_depth
    /// 0.5).
    fn step(x: u32, _: u32) -> f32 {
        if x < 7 { 1.0 } else { 5.0 }
    }

    /// `step` with a background hole at (3, 2).
    fn holed(x: u32, y: u32) -> f32 {
        if (x, y) == (3, 2) { 0.0 } else { step(x, y) }
    }

    #[test]
    fn separable_filter_is_the_square_filter_without_background() {
        // Equal on each plane and across the step (each side keeps its own).
        let (w, h) = (13, 9);
        let p = params(w, h, Resolution::Full);
        let ao: Vec<f32> = (0..w * h).map(|i| ((i * 37) % 11) as f32 / 10.0).collect();
        let gb = gbuffer(w, h, step);
        let square = filter(&gb, &p, &ao, 0.0, |a, b| a + b, |a, s| a * s);
        let separable = filter_ao(&gb, &p, true, &ao);
        for i in 0..(w * h) as usize {
            assert!(
                (square[i] - separable[i]).abs() <= 1e-6,
                "pixel {i}: {} {}",
                square[i],
                separable[i]
            );
        }
        // Background passes through; a row whose centre column is
        // background drops out of its column neighbours' sums.
        let separable = filter_ao(&gb_holed(w, h), &p, true, &ao);
        let at = |x: u32, y: u32| (y * w + x) as usize;
        assert_eq!(separable[at(3, 2)], ao[at(3, 2)]);
        let rows = [1u32, 3, 4].map(|y| (1..=4).map(|x| ao[at(x, y)]).sum::<f32>());
        assert!((separable[at(3, 3)] - (rows[0] + rows[1] + rows[2]) / 12.0).abs() <= 1e-6);
    }

    fn gb_holed(w: u32, h: u32) -> GBuffer {
        gbuffer(w, h, holed)
    }

    #[test]
    fn upsampling_keeps_each_side_of_a_depth_step() {
        let (w, h) = (15, 9);
        let p = params(w, h, Resolution::Half);
        assert_eq!((p.lo_width, p.lo_height, p.scale), (8, 5, 2));
        let gb = gbuffer(w, h, holed);
        // Grid cells left of the step 0.25, right 0.75 (by their pixel's depth).
        let grid: Vec<f32> = (0..p.cells() as u32)
            .map(|i| {
                if p.grid_depth(&gb, i % 8, i / 8) < 3.0 {
                    0.25
                } else {
                    0.75
                }
            })
            .collect();
        let up = ssao_upsample(&gb, &p, &grid);
        for y in 0..h {
            for x in 0..w {
                let want = match holed(x, y) {
                    0.0 => 1.0,
                    1.0 => 0.25,
                    _ => 0.75,
                };
                assert_eq!(up[(y * w + x) as usize], want, "pixel {x},{y}");
            }
        }
        // A pixel on a cell's own pixel takes that cell's value.
        let ramp: Vec<f32> = (0..p.cells()).map(|i| i as f32 / 40.0).collect();
        let up = ssao_upsample(&gb, &p, &ramp);
        assert_eq!(up[(4 * w + 2) as usize], ramp[2 * 8 + 1]);
        // Halfway between two near cells: their mean.
        assert_eq!(up[(4 * w + 3) as usize], 0.5 * (ramp[2 * 8 + 1] + ramp[2 * 8 + 2]));
    }

    #[test]
    fn upsampling_falls_back_to_the_nearest_cell_in_depth() {
        // A one-pixel-wide sliver at depth 3 on odd columns: no cell lies
        // on it, so it takes the nearest cell in depth among the 3x3.
        let (w, h) = (8, 6);
        let p = params(w, h, Resolution::Half);
        let gb = gbuffer(w, h, |x, _| match x {
            5 => 3.0,
            _ if x < 5 => 1.0,
            _ => 4.0,
        });
        let grid: Vec<f32> = (0..p.cells() as u32).map(|i| (i % p.lo_width) as f32).collect();
        let up = ssao_upsample(&gb, &p, &grid);
        // Cells at x = 4 (depth 1) and x = 6 (depth 4): depth 4 is nearer to 3.
        for y in 0..h {
            assert_eq!(up[(y * w + 5) as usize], 3.0, "row {y}");
        }
    }
}
