//! Quadrilinear interpolation of a cell's 16 extremal radiances (the
//! paper's section 4.2): the CPU twin of `wgsl/interpolate.wgsl`, with the
//! same data layout (`PixelJob`s over a table of 16 corners per cell slot).

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use rayon::prelude::*;

/// One pixel to interpolate: its cell's slot in the corner table and the
/// pixel's line in the cell, each coordinate in [0, 1]; on a textured
/// surface (`textured` 1) also the diffuse table in the next slot and the
/// texture factor at the pixel's hit: radiance `B + texture x A`. Mirrors
/// the WGSL struct of the same name (48 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct PixelJob {
    /// The cell's slot: its 16 corners are entries `16 slot ..16 slot + 16`
    /// of the corner table.
    pub slot: u32,
    /// The pixel's row-major index in the image, where its result goes
    /// (the kernel writes results in job order and does not read it).
    pub pixel: u32,
    /// 1 on a textured surface (the diffuse table in slot `slot + 1`), else 0.
    pub textured: u32,
    /// Padding to the WGSL struct's 16-byte alignment.
    pub _pad: u32,
    /// The pixel's line in the cell: (a, b, c, d), each in [0, 1] from the
    /// cell's low to its high end.
    pub local: [f32; 4],
    /// The texture factor (xyz; w unused) where `textured` is 1.
    pub texture: [f32; 4],
}

/// The 16 corners' weights at `local` in [0, 1]^4 (corner k: bit i of k
/// is the high end of coordinate i): products over the coordinates in
/// order, as `corner_weights` in the kernel computes them.
pub fn weights(local: [f32; 4]) -> [f32; 16] {
    std::array::from_fn(|k| {
        let mut w = 1.0;
        for (i, &u) in local.iter().enumerate() {
            w *= if k >> i & 1 == 1 { u } else { 1.0 - u };
        }
        w
    })
}

/// The sum of 16 values by their weights, in corner order.
pub fn weighted(values: impl Iterator<Item = Vec3>, w: &[f32; 16]) -> Vec3 {
    values.zip(w).fold(Vec3::ZERO, |sum, (v, &w)| sum + v * w)
}

/// Quadrilinear interpolation of 16 corner values at `local` in [0, 1]^4.
pub fn interpolate(corners: &[Vec3; 16], local: [f32; 4]) -> Vec3 {
    weighted(corners.iter().copied(), &weights(local))
}

/// Every job's radiance (`w` 0), from `corners` (16 per slot, `w` unused):
/// the twin of the `interpolate` kernel.
pub fn interpolate_pixels(corners: &[[f32; 4]], jobs: &[PixelJob]) -> Vec<[f32; 4]> {
    jobs.par_iter()
        .with_min_len(1024)
        .map(|job| {
            let w = weights(job.local);
            let table = |slot: u32| {
                let base = slot as usize * 16;
                corners[base..base + 16].iter().map(|c| Vec3::from_slice(&c[..3]))
            };
            let mut r = weighted(table(job.slot), &w);
            if job.textured != 0 {
                r += Vec3::from_slice(&job.texture[..3]) * weighted(table(job.slot + 1), &w);
            }
            r.extend(0.0).to_array()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_reproduces_corners_and_affine_functions() {
        let f = |u: [f32; 4]| Vec3::new(1.0 + 2.0 * u[0] - u[3], u[1] * 0.5 + u[2], 3.0);
        let corners: [Vec3; 16] = std::array::from_fn(|k| f([0, 1, 2, 3].map(|i| (k >> i & 1) as f32)));
        for k in 0..16 {
            let at = [0, 1, 2, 3].map(|i| (k >> i & 1) as f32);
            assert_eq!(interpolate(&corners, at), corners[k]);
        }
        let at = [0.25, 0.5, 0.75, 0.1];
        assert!((interpolate(&corners, at) - f(at)).abs().max_element() < 1e-6);
    }

    #[test]
    fn a_textured_job_adds_its_texture_times_the_next_slot() {
        let mut corners = vec![[1.0, 2.0, 3.0, 0.0]; 16];
        corners.extend(vec![[0.5, 0.25, 2.0, 0.0]; 16]);
        let job = PixelJob {
            slot: 0,
            textured: 1,
            local: [0.3, 0.6, 0.1, 0.9],
            texture: [2.0, 4.0, 0.5, 0.0],
            ..Default::default()
        };
        let out = interpolate_pixels(&corners, &[job]);
        let want = Vec3::new(1.0 + 1.0, 2.0 + 1.0, 3.0 + 1.0);
        assert!(
            (Vec3::from_slice(&out[0][..3]) - want).abs().max_element() < 1e-5,
            "{:?}",
            out[0]
        );
    }

    #[test]
    fn jobs_read_their_own_slot() {
        let mut corners = vec![[1.0, 2.0, 3.0, 0.0]; 16];
        corners.extend(vec![[5.0, 6.0, 7.0, 0.0]; 16]);
        let job = |slot| PixelJob {
            slot,
            local: [0.3, 0.6, 0.1, 0.9],
            ..Default::default()
        };
        let out = interpolate_pixels(&corners, &[job(1), job(0)]);
        assert!(
            (Vec3::from_slice(&out[0][..3]) - Vec3::new(5.0, 6.0, 7.0))
                .abs()
                .max_element()
                < 1e-5
        );
        assert!(
            (Vec3::from_slice(&out[1][..3]) - Vec3::new(1.0, 2.0, 3.0))
                .abs()
                .max_element()
                < 1e-5
        );
    }
}
