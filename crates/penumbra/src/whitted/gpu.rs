//! The `whitted.wgsl` pass: the scene's shading data uploaded once
//! (`prepare_scene`), then a batch of pixels at a time (`prepare` for a
//! range of the image, `prepare_listed` for a list of pixels; `record`),
//! over the kd-tree's bind group. Follows glyphon's split as every kd-tree
//! pass does (`kdtree::pass`).

use std::ops::Range;

use super::scene::RenderScene;
use super::tree_records::{TreeLayout, TreeRay};
use super::whitted::{PixelOut, WhittedUniforms};
use crate::error::{Error, Result};
use crate::gpu::batch::{BatchPlan, Batched, run_batches};
use std::sync::Arc;

use crate::accel::kdtree::gpu::GpuKdTree;
use crate::accel::kdtree::pass::{Dispatch, TreeBatch, TreeKernelSet, TreeKernels, TreePass};
use crate::gpu::kernels::{Kernels, PipelineLog};
use crate::gpu::layout::Io;
use crate::gpu::{GpuContext, dispatch_grid};
use crate::progress::Bar;

/// The pass's io: params, per-triangle shading (two words4), shading
/// normals, the scene's records (surfaces, lights, spheres), pixels out
/// (or `whitted_trees`' slots), and the pixels `whitted_listed` renders
/// (or `whitted_trees`' rays). Eight storage bindings with the kd-tree's,
/// WebGPU's default limit, so its outputs and inputs share two.
const WHITTED_IO: &[Io] = &[
    Io::Uniform(0, "whitted params", std::mem::size_of::<WhittedUniforms>() as u64),
    Io::In(1, "triangle shading"),
    Io::In(2, "shading normals"),
    Io::In(3, "scene records"),
    Io::Out(4, "pixels"),
    Io::In(5, "pixel list"),
];

/// The kernel's entry points, in `WhittedKernels`' order.
const RANGE_ENTRY: usize = 0;
const LISTED_ENTRY: usize = 1;
const TREES_ENTRY: usize = 2;

/// Bytes of one pixel's output (`PixelOut`).
const PIXEL_BYTES: u64 = std::mem::size_of::<PixelOut>() as u64;

/// Pixels per dispatch: short dispatches on a software rasteriser, and far
/// below any device's limits (32 bytes a pixel).
pub const PIXELS_PER_BATCH: usize = 1 << 16;

/// Bytes of ray-tree slots per `whitted_trees` dispatch at most (a slot of
/// a depth-5 tree with one light is 7 KB, mostly unused; a device with
/// gigabyte bindings need not read back gigabytes at once).
pub const TREES_BATCH_BYTES: u64 = 64 << 20;

/// The pipeline of `whitted.wgsl` for one device.
pub struct WhittedKernels(TreeKernels);

impl Kernels for WhittedKernels {
    fn build(device: &wgpu::Device, log: &Arc<PipelineLog>) -> WhittedKernels {
        let mut kernels = TreeKernels::build(
            device,
            &crate::gpu::wgsl::WHITTED_MODULE,
            WHITTED_IO,
            &["whitted", "whitted_listed", "whitted_trees"],
            log,
        );
        // Only `whitted_trees` records trees: with the recording compiled
        // into the pixel entries (even behind a pipeline-overridable
        // constant set to false), lavapipe ran them 18 times slower.
        kernels
            .pipelines
            .set_variant(TREES_ENTRY, crate::gpu::wgsl::WHITTED_TREES_MODULE);
        WhittedKernels(kernels)
    }
}

impl TreeKernelSet for WhittedKernels {
    const IO: &'static [Io] = WHITTED_IO;
    const LABEL: &'static str = "whitted";
    fn tree_kernels(&self) -> &TreeKernels {
        &self.0
    }
}

/// The ray-tracing pass: its kernel and the buffers of one scene and batch.
pub type WhittedPass = TreePass<WhittedKernels>;

/// Where the parts of the scene's records start, in words4.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordsAt {
    /// The lights (the surfaces start at 0).
    pub lights: u32,
    /// The spheres.
    pub spheres: u32,
    /// The sRGB table, then the texture maps and their texels.
    pub maps: u32,
}

/// The scene's records as the kernel reads them: surfaces, lights,
/// spheres, the sRGB table, the texture maps (their texels' first word
/// made absolute) and the texels.
pub fn scene_records(scene: &RenderScene) -> (Vec<u8>, RecordsAt) {
    let mut records: Vec<u8> = bytemuck::cast_slice(&scene.surfaces).to_vec();
    let lights = (records.len() / 16) as u32;
    records.extend_from_slice(bytemuck::cast_slice(&scene.lights));
    let spheres = (records.len() / 16) as u32;
    records.extend_from_slice(bytemuck::cast_slice(&scene.spheres));
    let maps = (records.len() / 16) as u32;
    let table = &scene.textures;
    records.extend_from_slice(bytemuck::cast_slice(&table.srgb));
    let texels_at = (records.len() / 4
        + table.maps.len() * std::mem::size_of::<crate::scene::texture_table::MapRecord>() / 4)
        as u32;
    for m in &table.maps {
        let m = crate::scene::texture_table::MapRecord {
            texels_at: texels_at + m.texels_at,
            ..*m
        };
        records.extend_from_slice(bytemuck::bytes_of(&m));
    }
    records.extend_from_slice(bytemuck::cast_slice(&table.texels));
    // Whole words4.
    records.resize(records.len().div_ceil(16) * 16, 0);
    (records, RecordsAt { lights, spheres, maps })
}

/// At least one words4, so an empty array still binds.
fn non_empty(bytes: &[u8]) -> &[u8] {
    if bytes.is_empty() { &[0; 16] } else { bytes }
}

impl TreePass<WhittedKernels> {
    /// Uploads what the kernel reads of `scene` besides its tree.
    pub fn prepare_scene(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &RenderScene) -> Result<()> {
        let (records, _) = scene_records(scene);
        let io = self.io();
        io.write(device, queue, 1, non_empty(bytemuck::cast_slice(&scene.triangles)))?;
        io.write(device, queue, 2, non_empty(bytemuck::cast_slice(&scene.normals)))?;
        io.write(device, queue, 3, non_empty(&records))?;
        // Bound by both entry points; `prepare_listed` grows it.
        io.reserve(device, 5, 16)
    }

    /// Prepares the pixels `params.first_pixel ..+ params.pixel_count`
    /// (`row_pitch` is set here).
    pub fn prepare(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, params: &WhittedUniforms) -> Result<()> {
        self.prepare_entry(device, queue, params, RANGE_ENTRY, PIXEL_BYTES)
    }

    /// Prepares the pixels `list` of the image `params` describes (its
    /// `first_pixel` and `pixel_count` are set here): the outputs come in
    /// the list's order.
    pub fn prepare_listed(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        params: &WhittedUniforms,
        list: &[u32],
    ) -> Result<()> {
        super::whitted::check_pixels(params, list)?;
        self.io()
            .write(device, queue, 5, non_empty(bytemuck::cast_slice(list)))?;
        let params = WhittedUniforms {
            first_pixel: 0,
            pixel_count: list.len() as u32,
            ..*params
        };
        self.prepare_entry(device, queue, &params, LISTED_ENTRY, PIXEL_BYTES)
    }

    /// Prepares the rays `rays` of `whitted_trees`, each tree written into
    /// a slot of `layout` (`params`' pixel range is set here).
    pub fn prepare_trees(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        params: &WhittedUniforms,
        layout: &TreeLayout,
        rays: &[TreeRay],
    ) -> Result<()> {
        self.io()
            .write(device, queue, 5, non_empty(bytemuck::cast_slice(rays)))?;
        let params = WhittedUniforms {
            first_pixel: 0,
            pixel_count: rays.len() as u32,
            tree_capacity: layout.capacity,
            tree_stride: layout.stride,
            ..*params
        };
        self.prepare_entry(device, queue, &params, TREES_ENTRY, 16 * layout.slot_words4() as u64)
    }

    /// Prepares entry `entry` over `params.pixel_count` items, each
    /// writing `item_bytes` of output.
    fn prepare_entry(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        params: &WhittedUniforms,
        entry: usize,
        item_bytes: u64,
    ) -> Result<()> {
        let n = params.pixel_count;
        let (gx, gy, pitch) = dispatch_grid(n, device.limits().max_compute_workgroups_per_dimension);
        let params = WhittedUniforms {
            row_pitch: pitch,
            ..*params
        };
        let bytes = n as u64 * item_bytes;
        let io = self.io();
        io.write(device, queue, 0, bytemuck::bytes_of(&params))?;
        io.reserve(device, 4, bytes.max(32))?;
        self.set_dispatch(
            device,
            Dispatch {
                entry,
                grid: (gx, gy),
                clear: None,
                results: vec![(4, bytes)],
            },
        );
        Ok(())
    }

    /// The prepared batch's pixels, after the recorded dispatch.
    pub fn pixels(&self) -> &wgpu::Buffer {
        self.buffer(4)
    }
}

/// The pass with its read-back buffer, as a renderer keeps it.
pub type WhittedBatches = Batched<WhittedPass>;

impl Batched<WhittedPass> {
    /// Renders the pixels `params.first_pixel ..+ params.pixel_count`
    /// (blocking; every pixel of the image for 0 and all), in batches: the pixels
    /// and the kernels' time where the device has timestamps. The scene
    /// must have been prepared (`prepare_scene`).
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        tree: &GpuKdTree,
        params: &WhittedUniforms,
        progress: &Bar,
    ) -> Result<(Vec<PixelOut>, Option<f64>)> {
        let total = params.pixel_count as usize;
        self.render_batches(ctx, tree, total, progress, |pass, ctx, items| {
            let batch = WhittedUniforms {
                first_pixel: params.first_pixel + items.start as u32,
                pixel_count: items.len() as u32,
                ..*params
            };
            pass.prepare(&ctx.device, &ctx.queue, &batch)
        })
    }

    /// Renders the pixels `list` of the image `params` describes
    /// (blocking), in batches, in the list's order; the kernels' time where
    /// the device has timestamps. Each pixel is the one `render` gives, bit
    /// for bit (the same kernel code).
    pub fn render_listed(
        &mut self,
        ctx: &GpuContext,
        tree: &GpuKdTree,
        params: &WhittedUniforms,
        list: &[u32],
        progress: &Bar,
    ) -> Result<(Vec<PixelOut>, Option<f64>)> {
        self.render_batches(ctx, tree, list.len(), progress, |pass, ctx, items| {
            pass.prepare_listed(&ctx.device, &ctx.queue, params, &list[items])
        })
    }

    /// Traces `rays` (blocking) in batches that keep a batch's slots under
    /// half the device's largest storage binding and `TREES_BATCH_BYTES`
    /// (the slots are read back whole): each ray's slot of
    /// `layout` (`tree_records::decode` reads it) in the rays' order, and
    /// the kernels' time.
    pub fn trace_trees(
        &mut self,
        ctx: &GpuContext,
        tree: &GpuKdTree,
        params: &WhittedUniforms,
        layout: &TreeLayout,
        rays: &[TreeRay],
        progress: &Bar,
    ) -> Result<(Vec<[u32; 4]>, Option<f64>)> {
        let slot_bytes = 16 * layout.slot_words4() as u64;
        let largest = (ctx.device.limits().max_storage_buffer_binding_size / 2).min(TREES_BATCH_BYTES);
        let per_batch = (largest / slot_bytes).clamp(1, PIXELS_PER_BATCH as u64) as usize;
        let mut slots = Vec::with_capacity(rays.len() * layout.slot_words4());
        let plan = BatchPlan::new(rays.len(), per_batch, 1);
        let mut batch = TreeBatch {
            pass: &mut self.pass,
            tree,
            prepare: |pass: &mut WhittedPass, ctx: &GpuContext, items: Range<usize>| {
                pass.prepare_trees(&ctx.device, &ctx.queue, params, layout, &rays[items])
            },
        };
        let take = |items: Range<usize>, out: &[[u32; 4]]| {
            slots.extend_from_slice(&out[..items.len() * layout.slot_words4()]);
            Ok(())
        };
        let gpu_ms = run_batches(ctx, &mut batch, &mut self.readback, plan, progress, take)?;
        if slots.len() != rays.len() * layout.slot_words4() {
            return Err(Error::internal(
                "the whitted kernel returned the wrong number of ray trees",
            ));
        }
        Ok((slots, gpu_ms))
    }

    /// `count` pixels in batches, each batch's range of them uploaded by
    /// `prepare`; the pixels in order and the kernels' time.
    fn render_batches(
        &mut self,
        ctx: &GpuContext,
        tree: &GpuKdTree,
        count: usize,
        progress: &Bar,
        prepare: impl FnMut(&mut WhittedPass, &GpuContext, Range<usize>) -> Result<()>,
    ) -> Result<(Vec<PixelOut>, Option<f64>)> {
        let mut pixels = Vec::with_capacity(count);
        let plan = BatchPlan::new(count, PIXELS_PER_BATCH, 1);
        let mut batch = TreeBatch {
            pass: &mut self.pass,
            tree,
            prepare,
        };
        let take = |items: Range<usize>, out: &[PixelOut]| {
            pixels.extend_from_slice(&out[..items.len()]);
            Ok(())
        };
        let gpu_ms = run_batches(ctx, &mut batch, &mut self.readback, plan, progress, take)?;
        if pixels.len() != count {
            return Err(Error::internal(
                "the whitted kernel returned the wrong number of pixels",
            ));
        }
        Ok((pixels, gpu_ms))
    }
}
