//! The depth-aware 4x4 low-pass filter of section 5 (`ssao_filter_ao`,
//! `ssao_filter_indirect` here and in `wgsl/ssao_filter.wgsl`).
//!
//! Each surface pixel averages the pixels of the 4x4 window with offsets
//! -2..=1 in x and y (any such window holds each of the 16 interleaved
//! sample sets once) that are surfaces and whose depth differs from its own
//! by at most `filter_depth`: "if the depth difference between the current
//! and neighbouring pixels exceeds a given limit, we do not include the
//! neighbouring pixels in the averaging". The pixel itself always counts.
//! Background pixels are passed through.

use rayon::prelude::*;

use super::estimators::SsaoParams;
use super::gbuffer::{GBuffer, valid_depth};

/// Window offsets of the 4x4 filter.
pub const FILTER_OFFSETS: std::ops::RangeInclusive<i32> = -2..=1;

fn filter<T: Copy + Send + Sync>(
    gb: &GBuffer,
    params: &SsaoParams,
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

/// CPU twin of `ssao_filter_ao`.
pub fn ssao_filter_ao(gb: &GBuffer, params: &SsaoParams, ao: &[f32]) -> Vec<f32> {
    filter(gb, params, ao, 0.0, |a, b| a + b, |a, s| a * s)
}

/// CPU twin of `ssao_filter_indirect` (all four channels).
pub fn ssao_filter_indirect(gb: &GBuffer, params: &SsaoParams, l: &[[f32; 4]]) -> Vec<[f32; 4]> {
    filter(
        gb,
        params,
        l,
        [0.0; 4],
        |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]],
        |a, s| a.map(|c| c * s),
    )
}
