//! The Whitted image in a texture the host owns: `whitted_image.wgsl`
//! writes the pixels the Whitted pass rendered (`gpu::WhittedPass::pixels`)
//! into an [`IMAGE_FORMAT`] storage texture, each pixel's linear radiance
//! with alpha 1, so that a host samples, blits or tone-maps the image
//! itself. `WhittedImagePass` follows `new` / `prepare` / `record` and
//! records only into the host's encoder, after the Whitted pass;
//! [`whitted_image`] is its CPU twin.

use std::sync::Arc;

use super::whitted::{PixelOut, WhittedUniforms};
use crate::error::{Error, Result};
use crate::gpu::batch::Pass;
use crate::gpu::buffers::zeroed_buffer;
use crate::gpu::dispatch_grid;
use crate::gpu::kernels::{Kernels, PipelineLog, Pipelines, compute_pipelines, record_dispatch};
use crate::gpu::layout::{layout, storage_entry, storage_texture_entry, uniform_entry};

/// The format of the texture `WhittedImagePass` writes: linear radiance in
/// red, green and blue, alpha 1. WebGPU writes it as a storage texture
/// without any optional feature.
pub const IMAGE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// `WhittedImageUniforms` in `wgsl/whitted_image.wgsl`: which pixels of
/// the image a batch holds.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WhittedImageUniforms {
    /// The image's width in pixels.
    pub width: u32,
    /// The batch's first pixel, row-major from the top left.
    pub first_pixel: u32,
    /// The batch's pixels.
    pub pixel_count: u32,
    /// Invocations per row of the 2D dispatch grid (`prepare` sets it).
    pub row_pitch: u32,
}

impl WhittedImageUniforms {
    /// The pixels of the Whitted batch `params` describes (as
    /// `WhittedPass::prepare` renders them), with no row pitch yet.
    pub fn of(params: &WhittedUniforms) -> WhittedImageUniforms {
        WhittedImageUniforms {
            width: params.width,
            first_pixel: params.first_pixel,
            pixel_count: params.pixel_count,
            row_pitch: 0,
        }
    }
}

/// The CPU twin of `whitted_image`: the batch's `pixels` (the Whitted
/// pass's outputs, in order) into `image`, the row-major image
/// `params.width` pixels wide, each pixel's radiance with alpha 1.
///
/// # Panics
/// If `pixels` has fewer than `params.pixel_count` pixels or `image` ends
/// before the batch's last pixel.
pub fn whitted_image(params: &WhittedImageUniforms, pixels: &[PixelOut], image: &mut [[f32; 4]]) {
    let (first, count) = (params.first_pixel as usize, params.pixel_count as usize);
    for (out, p) in image[first..first + count].iter_mut().zip(&pixels[..count]) {
        let [r, g, b] = p.radiance;
        *out = [r, g, b, 1.0];
    }
}

/// The layout and pipeline of `whitted_image.wgsl` for one device.
pub struct WhittedImageKernels {
    layout: wgpu::BindGroupLayout,
    pipelines: Pipelines,
}

impl Kernels for WhittedImageKernels {
    fn build(device: &wgpu::Device, log: &Arc<PipelineLog>) -> WhittedImageKernels {
        let entries = [
            uniform_entry(0),
            storage_entry(1, true),
            storage_texture_entry(2, IMAGE_FORMAT),
        ];
        let layout = layout(device, "whitted image", &entries);
        let module = &crate::gpu::wgsl::WHITTED_IMAGE_MODULE;
        let pipelines = compute_pipelines(device, module, &[&layout], &["whitted_image"], log);
        WhittedImageKernels { layout, pipelines }
    }
}

/// Writes the Whitted pass's pixels into the host's texture: its uniform
/// and the bind group of the last `prepare` (the host's pixel buffer and
/// texture view).
pub struct WhittedImagePass {
    kernels: Arc<WhittedImageKernels>,
    params: wgpu::Buffer,
    group: Option<wgpu::BindGroup>,
    grid: (u32, u32),
}

impl Pass for WhittedImagePass {
    type Kernels = WhittedImageKernels;

    fn with_kernels(device: &wgpu::Device, kernels: Arc<WhittedImageKernels>) -> WhittedImagePass {
        let params = zeroed_buffer(
            device,
            "whitted image params",
            std::mem::size_of::<WhittedImageUniforms>() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        WhittedImagePass {
            kernels,
            params,
            group: None,
            grid: (0, 0),
        }
    }
}

impl WhittedImagePass {
    /// Prepares writing the Whitted batch `params` describes (the one
    /// `WhittedPass::prepare` was given: a range of the image's pixels)
    /// from `pixels` (that pass's `pixels()`, after that `prepare`) into
    /// `target`: a 2D view of a texture of [`IMAGE_FORMAT`] with
    /// `STORAGE_BINDING` usage, at least the image's width and height.
    /// Texels outside the batch are left as they are.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        params: &WhittedUniforms,
        pixels: &wgpu::Buffer,
        target: &wgpu::TextureView,
    ) -> Result<()> {
        let texture = target.texture();
        if texture.format() != IMAGE_FORMAT {
            return Err(Error::input(
                "texture",
                format!(
                    "is {:?}; the Whitted image is written as {IMAGE_FORMAT:?}",
                    texture.format()
                ),
            ));
        }
        if !texture.usage().contains(wgpu::TextureUsages::STORAGE_BINDING) {
            return Err(Error::input("texture", "needs STORAGE_BINDING usage"));
        }
        if texture.width() < params.width || texture.height() < params.height {
            return Err(Error::input(
                "texture",
                format!(
                    "is {}x{}, smaller than the {}x{} image",
                    texture.width(),
                    texture.height(),
                    params.width,
                    params.height
                ),
            ));
        }
        let end = params.first_pixel as u64 + params.pixel_count as u64;
        if end > params.width as u64 * params.height as u64 {
            return Err(Error::input("pixels", "the batch ends past the image's last pixel"));
        }
        let bytes = params.pixel_count as u64 * std::mem::size_of::<PixelOut>() as u64;
        if pixels.size() < bytes {
            return Err(Error::input(
                "pixels",
                format!("holds {} bytes, fewer than the batch's {bytes}", pixels.size()),
            ));
        }
        let (gx, gy, pitch) = dispatch_grid(params.pixel_count, device.limits().max_compute_workgroups_per_dimension);
        let uniforms = WhittedImageUniforms {
            row_pitch: pitch,
            ..WhittedImageUniforms::of(params)
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&uniforms));
        // Rebuilt every time: the host may hand another buffer or view.
        self.group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("whitted image"),
            layout: &self.kernels.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: pixels.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(target),
                },
            ],
        }));
        self.grid = (gx, gy);
        Ok(())
    }

    /// Records the prepared writes into the caller's encoder, after the
    /// Whitted pass's `record` (with `timestamp_writes` if given).
    ///
    /// # Panics
    /// Before the first `prepare`.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let group = self.group.as_ref().expect("WhittedImagePass::record before prepare");
        record_dispatch(
            encoder,
            "whitted image",
            timestamp_writes,
            self.kernels.pipelines.get(0),
            &[group],
            self.grid,
        );
    }
}
