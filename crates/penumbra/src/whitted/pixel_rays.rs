//! Camera rays of many pixels of one image (`whitted::pixel_ray`), with
//! the per-column and per-row work done once.

use glam::Vec3;

use super::whitted::{WhittedUniforms, pixel_ray};

/// `pixel_ray(params, pixel, 0)` for many pixels of one image: with one
/// sample per pixel a pixel's screen coordinates depend on its column or
/// its row alone, so they are computed once per column and per row, by
/// the same operations (the same bits); the direction is then
/// `pixel_ray`'s sum and normalisation. (With several samples the first is
/// jittered per pixel, and `ray` calls `pixel_ray`.)
pub struct PixelRays {
    params: WhittedUniforms,
    /// Per column and per row; empty when `spp > 1`.
    sx: Vec<f32>,
    sy: Vec<f32>,
}

impl PixelRays {
    pub fn new(params: &WhittedUniforms) -> PixelRays {
        let (sx, sy) = if params.spp == 1 {
            (
                (0..params.width)
                    .map(|x| 2.0 * (x as f32 + 0.5) / params.width as f32 - 1.0)
                    .collect(),
                (0..params.height)
                    .map(|y| 1.0 - 2.0 * (y as f32 + 0.5) / params.height as f32)
                    .collect(),
            )
        } else {
            (Vec::new(), Vec::new())
        };
        PixelRays {
            params: *params,
            sx,
            sy,
        }
    }

    /// `pixel_ray(params, pixel, 0)`.
    #[inline]
    pub fn ray(&self, pixel: u32) -> (Vec3, Vec3) {
        if self.sx.is_empty() {
            return pixel_ray(&self.params, pixel, 0);
        }
        let p = &self.params;
        let (x, y) = (pixel % p.width, pixel / p.width);
        let (sx, sy) = (self.sx[x as usize], self.sy[y as usize]);
        let d = Vec3::from_array(p.forward) + sx * Vec3::from_array(p.right) + sy * Vec3::from_array(p.up);
        (Vec3::from_array(p.eye), d.normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pixel's ray is `pixel_ray`'s bit for bit: odd and even sizes,
    /// a skewed camera frame, one sample (tabulated) and two (jittered).
    #[test]
    fn rays_are_pixel_ray_bit_for_bit() {
        for (width, height, spp) in [(7, 5, 1), (64, 48, 1), (33, 17, 2)] {
            let mut params: WhittedUniforms = bytemuck::Zeroable::zeroed();
            params.eye = [0.3, -1.7, 4.1];
            params.forward = [0.11, -0.23, -0.97];
            params.right = [0.713, 0.02, 0.081];
            params.up = [-0.05, 0.391, -0.09];
            (params.width, params.height, params.spp, params.seed) = (width, height, spp, 24301);
            let rays = PixelRays::new(&params);
            for pixel in 0..width * height {
                let (a, b) = (rays.ray(pixel), pixel_ray(&params, pixel, 0));
                assert_eq!(
                    (a.0.to_array().map(f32::to_bits), a.1.to_array().map(f32::to_bits)),
                    (b.0.to_array().map(f32::to_bits), b.1.to_array().map(f32::to_bits)),
                    "{width}x{height}, {spp} spp, pixel {pixel}"
                );
            }
        }
    }
}
