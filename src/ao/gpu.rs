//! AO by ray casting on the GPU: the `ao_rays.wgsl` pass over a `GpuKdTree`,
//! built once per device (`new`), fed by `prepare` into buffers it keeps,
//! recorded into the caller's encoder by `record`; `visibility_gpu` is the
//! blocking convenience that splits large requests into batches.

use std::ops::Range;
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::{AoPoint, AoSettings, VisibilityMasks};
use crate::error::Result;
use crate::gpu::batch::{BatchPass, BatchPlan, readback_buffer, run_batches};
use crate::gpu::buffers::{GrowingBuffer, read_buffer, uniform_buffer};
use crate::gpu::kernels::{compute_pipelines, record_dispatch};
use crate::gpu::layout::{bind_group, layout, storage_entry, uniform_entry};
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, dispatch_grid};
use crate::kdtree::gpu::{GpuKdTree, kdtree_bind_group_layout};
use crate::progress::Progress;

/// `AoParams` in `wgsl/ao_rays.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct AoParams {
    pub point_count: u32,
    pub rays_per_point: u32,
    pub words_per_point: u32,
    pub seed: u32,
    pub row_pitch: u32,
    pub radius: f32,
    pub _pad: [u32; 2],
}

/// The layouts and pipelines of `ao_rays.wgsl` for one device.
pub struct AoRaysKernels {
    pub io_layout: wgpu::BindGroupLayout,
    ao_rays: wgpu::ComputePipeline,
    ao_samples: wgpu::ComputePipeline,
}

impl AoRaysKernels {
    pub fn new(device: &wgpu::Device) -> AoRaysKernels {
        // points (read), visible (read-write atomics), params (uniform),
        // samples (written by the `ao_samples` check only)
        let io_layout = layout(
            device,
            "ao rays io",
            &[
                storage_entry(0, true),
                storage_entry(1, false),
                uniform_entry(2),
                storage_entry(3, false),
            ],
        );
        let pipelines = compute_pipelines(
            device,
            &crate::wgsl::AO_RAYS_MODULE,
            &[&kdtree_bind_group_layout(device), &io_layout],
            &["ao_rays", "ao_samples"],
        );
        let [ao_rays, ao_samples] = pipelines.try_into().expect("two entry points");
        AoRaysKernels {
            io_layout,
            ao_rays,
            ao_samples,
        }
    }

    /// The kernels cached on `ctx`.
    pub fn cached(ctx: &GpuContext) -> Arc<AoRaysKernels> {
        ctx.kernels.get_or_insert(|| AoRaysKernels::new(&ctx.device))
    }
}

/// The AO-ray pass: kernels and the buffers of one batch of points.
pub struct AoRaysPass {
    kernels: Arc<AoRaysKernels>,
    points: GrowingBuffer,
    visible: GrowingBuffer,
    samples: GrowingBuffer,
    params: wgpu::Buffer,
    io: Option<wgpu::BindGroup>,
    words: u64,
    grid: (u32, u32),
}

impl AoRaysPass {
    /// Builds the kernels for `device`.
    pub fn new(device: &wgpu::Device) -> AoRaysPass {
        Self::with_kernels(device, Arc::new(AoRaysKernels::new(device)))
    }

    /// A pass with kernels built before (e.g. `AoRaysKernels::cached`).
    pub fn with_kernels(device: &wgpu::Device, kernels: Arc<AoRaysKernels>) -> AoRaysPass {
        let rw = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        AoRaysPass {
            kernels,
            points: GrowingBuffer::new("ao points", wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST),
            visible: GrowingBuffer::new("ao visible", rw),
            samples: GrowingBuffer::new("ao samples", rw),
            params: uniform_buffer(device, "ao params", &AoParams::zeroed()),
            io: None,
            words: 0,
            grid: (0, 0),
        }
    }

    /// Uploads `points` (whole points, at most what the bindings hold) for
    /// `settings`; with `samples` the pass writes every ray's sample point
    /// and direction instead of tracing (the `ao_samples` check).
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        points: &[AoPoint],
        settings: &AoSettings,
        samples: bool,
    ) -> Result<()> {
        settings.validate()?;
        let words = (points.len() * settings.words_per_point() as usize) as u64;
        let rays = points.len() as u64 * settings.rays_per_point as u64;
        let mut grown = self.points.write(device, queue, bytemuck::cast_slice(points))?;
        grown |= self.visible.reserve(device, words * 4)?;
        grown |= self.samples.reserve(device, if samples { rays * 32 } else { 16 })?;
        if grown || self.io.is_none() {
            self.io = Some(bind_group(
                device,
                "ao rays io",
                &self.kernels.io_layout,
                &[
                    (0, self.points.get()),
                    (1, self.visible.get()),
                    (2, &self.params),
                    (3, self.samples.get()),
                ],
            ));
        }
        let (gx, gy, pitch) = dispatch_grid(rays as u32, device.limits().max_compute_workgroups_per_dimension);
        let params = AoParams {
            point_count: points.len() as u32,
            rays_per_point: settings.rays_per_point,
            words_per_point: settings.words_per_point(),
            seed: settings.seed,
            row_pitch: pitch,
            radius: if settings.radius.is_finite() && !samples {
                settings.radius
            } else {
                f32::MAX
            },
            _pad: [0; 2],
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        self.words = words;
        self.grid = (gx, gy);
        Ok(())
    }

    /// Records the prepared rays: clears the masks (the kernel ORs bits in)
    /// and dispatches one invocation per ray.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
        tree: &GpuKdTree,
    ) {
        encoder.clear_buffer(self.visible.get(), 0, None);
        let io = self.io.as_ref().expect("AoRaysPass::record before prepare");
        let pipeline = &self.kernels.ao_rays;
        record_dispatch(
            encoder,
            "ao rays",
            timestamp_writes,
            pipeline,
            &[&tree.bind_group, io],
            self.grid,
        );
    }

    /// `words_per_point` visibility words per prepared point.
    pub fn visible(&self) -> &wgpu::Buffer {
        self.visible.get()
    }
}

/// Rays per dispatch: keeps one dispatch short on a software rasteriser.
pub const RAYS_PER_BATCH: u64 = 1 << 22;

/// The pass and its read-back buffer, as a runner keeps them on a device.
pub struct AoRaysBatches {
    pub pass: AoRaysPass,
    readback: GrowingBuffer,
}

impl AoRaysBatches {
    pub fn new(ctx: &GpuContext) -> AoRaysBatches {
        AoRaysBatches {
            pass: AoRaysPass::with_kernels(&ctx.device, AoRaysKernels::cached(ctx)),
            readback: readback_buffer(),
        }
    }

    /// Casts the AO rays of `points` (blocking), about `rays_per_batch` rays
    /// per dispatch (whole points, at least one per batch).
    pub fn visibility(
        &mut self,
        ctx: &GpuContext,
        tree: &GpuKdTree,
        points: &[AoPoint],
        settings: &AoSettings,
        progress: &Progress,
        rays_per_batch: u64,
    ) -> Result<(VisibilityMasks, Option<f64>)> {
        settings.validate()?;
        let words = settings.words_per_point() as usize;
        let per_batch = (rays_per_batch / settings.rays_per_point as u64).max(1) as usize;
        let mut bits = Vec::with_capacity(points.len() * words);
        let mut batch = PointBatch {
            pass: &mut self.pass,
            tree,
            points,
            settings,
        };
        let plan = BatchPlan::new(points.len(), per_batch, 1);
        let gpu_ms = run_batches(ctx, &mut batch, &mut self.readback, plan, progress, |_, w: &[u32]| {
            bits.extend_from_slice(w);
            Ok(())
        })?;
        let masks = VisibilityMasks {
            rays_per_point: settings.rays_per_point,
            words_per_point: words as u32,
            bits,
        };
        Ok((masks, gpu_ms))
    }
}

struct PointBatch<'a> {
    pass: &'a mut AoRaysPass,
    tree: &'a GpuKdTree,
    points: &'a [AoPoint],
    settings: &'a AoSettings,
}

impl BatchPass for PointBatch<'_> {
    fn prepare(&mut self, ctx: &GpuContext, items: Range<usize>) -> Result<()> {
        self.pass
            .prepare(&ctx.device, &ctx.queue, &self.points[items], self.settings, false)
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &mut Option<PassTimer>) {
        self.pass
            .record(encoder, timer.as_mut().and_then(|t| t.next_pass()), self.tree);
    }

    fn results(&self) -> Vec<(&wgpu::Buffer, u64)> {
        vec![(self.pass.visible(), self.pass.words * 4)]
    }
}

/// Result of `visibility_gpu`.
pub struct GpuAo {
    pub masks: VisibilityMasks,
    pub gpu_ms: Option<f64>,
}

/// Casts the AO rays on the GPU (blocking), in batches of whole points.
pub fn visibility_gpu(
    ctx: &GpuContext,
    tree: &GpuKdTree,
    points: &[AoPoint],
    settings: &AoSettings,
    progress: &Progress,
) -> Result<GpuAo> {
    visibility_gpu_batched(ctx, tree, points, settings, progress, RAYS_PER_BATCH)
}

/// `visibility_gpu` with about `rays_per_batch` rays per dispatch (whole
/// points, at least one per batch).
pub fn visibility_gpu_batched(
    ctx: &GpuContext,
    tree: &GpuKdTree,
    points: &[AoPoint],
    settings: &AoSettings,
    progress: &Progress,
    rays_per_batch: u64,
) -> Result<GpuAo> {
    let (masks, gpu_ms) = AoRaysBatches::new(ctx).visibility(ctx, tree, points, settings, progress, rays_per_batch)?;
    Ok(GpuAo { masks, gpu_ms })
}

/// The sample point and direction of every AO ray, as the kernel computes
/// them (`ao_samples`): the check that the GPU's sequence and hemisphere
/// mapping are the CPU's. Returns per ray `([u, v], direction)`.
pub fn ray_samples_gpu(
    ctx: &GpuContext,
    points: &[AoPoint],
    settings: &AoSettings,
) -> Result<Vec<([f32; 2], [f32; 3])>> {
    let mut pass = AoRaysPass::with_kernels(&ctx.device, AoRaysKernels::cached(ctx));
    pass.prepare(&ctx.device, &ctx.queue, points, settings, true)?;
    // `ao_samples` traces nothing, but its pipeline layout includes a tree.
    let tree = placeholder_tree(&ctx.device)?;
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    let io = pass.io.as_ref().expect("prepared");
    let pipeline = &pass.kernels.ao_samples;
    record_dispatch(
        &mut encoder,
        "ao samples",
        None,
        pipeline,
        &[&tree.bind_group, io],
        pass.grid,
    );
    ctx.queue.submit([encoder.finish()]);
    let rays = points.len() * settings.rays_per_point as usize;
    let raw: Vec<[f32; 8]> = read_buffer(ctx, pass.samples.get(), rays)?;
    Ok(raw.iter().map(|r| ([r[0], r[1]], [r[4], r[5], r[6]])).collect())
}

fn placeholder_tree(device: &wgpu::Device) -> Result<GpuKdTree> {
    let tree = crate::kdtree::KdTree::from_triangles(
        vec![[glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y]],
        &Default::default(),
    )?;
    GpuKdTree::upload(device, &tree)
}
