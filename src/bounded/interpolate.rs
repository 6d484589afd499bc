//! Quadrilinear interpolation of a cell's 16 extremal radiances (the
//! paper's section 4.2): the CPU twin of `wgsl/interpolate.wgsl`, with the
//! same data layout (`PixelJob`s over a table of 16 corners per cell slot).

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use rayon::prelude::*;

/// One pixel to interpolate: its cell's slot in the corner table and the
/// pixel's line in the cell, each coordinate in [0, 1].
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct PixelJob {
    pub slot: u32,
    pub pixel: u32,
    pub _pad: [u32; 2],
    pub local: [f32; 4],
}

/// Quadrilinear interpolation of 16 corner values at `local` in [0, 1]^4
/// (corner k: bit i of k is the high end of coordinate i): the weights are
/// products over the coordinates in order, summed over corners in order,
/// as `interpolate_corners` in the kernel does.
pub fn interpolate(corners: &[Vec3; 16], local: [f32; 4]) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for (k, corner) in corners.iter().enumerate() {
        let mut w = 1.0;
        for (i, &u) in local.iter().enumerate() {
            w *= if k >> i & 1 == 1 { u } else { 1.0 - u };
        }
        sum += *corner * w;
    }
    sum
}

/// Every job's radiance (`w` 0), from `corners` (16 per slot, `w` unused):
/// the twin of the `interpolate` kernel.
pub fn interpolate_pixels(corners: &[[f32; 4]], jobs: &[PixelJob]) -> Vec<[f32; 4]> {
    jobs.par_iter()
        .with_min_len(1024)
        .map(|job| {
            let base = job.slot as usize * 16;
            let cell: [Vec3; 16] = std::array::from_fn(|k| Vec3::from_slice(&corners[base + k][..3]));
            interpolate(&cell, job.local).extend(0.0).to_array()
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
