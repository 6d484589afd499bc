//! AO by ray casting on the GPU: the `ao_rays.wgsl` pass over a `GpuKdTree`.

use std::time::Instant;

use bytemuck::{Pod, Zeroable};

use super::{AoPoint, AoSettings, VisibilityMasks};
use crate::error::Result;
use crate::gpu::buffers::{check_storage_size, read_back, storage_buffer, uniform_buffer, zeroed_buffer};
use crate::gpu::kernels::record_dispatch;
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, dispatch_grid};
use crate::kdtree::gpu::{GpuKdTree, bind_group, kdtree_bind_group_layout, storage_entry, uniform_entry};
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

/// The AO-ray pass: layouts and pipelines for one device.
pub struct AoRaysPass {
    pub io_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    samples_pipeline: wgpu::ComputePipeline,
}

impl AoRaysPass {
    pub fn new(device: &wgpu::Device) -> AoRaysPass {
        let scene_layout = kdtree_bind_group_layout(device);
        // points (read), visible (read-write atomics), params (uniform),
        // samples (written by the `ao_samples` check only)
        let io_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ao rays io"),
            entries: &[
                storage_entry(0, true),
                storage_entry(1, false),
                uniform_entry(2),
                storage_entry(3, false),
            ],
        });
        let pipelines = crate::gpu::kernels::compute_pipelines(
            device,
            &crate::wgsl::AO_RAYS_MODULE,
            &[&scene_layout, &io_layout],
            &["ao_rays", "ao_samples"],
        );
        let [pipeline, samples_pipeline] = pipelines.try_into().expect("two entry points");
        AoRaysPass {
            io_layout,
            pipeline,
            samples_pipeline,
        }
    }

    /// Bind group 1. `samples` is only written by `ao_samples`; other
    /// dispatches may bind any small buffer there.
    pub fn io_bind_group(
        &self,
        device: &wgpu::Device,
        points: &wgpu::Buffer,
        visible: &wgpu::Buffer,
        params: &wgpu::Buffer,
        samples: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        bind_group(
            device,
            "ao rays io",
            &self.io_layout,
            &[(0, points), (1, visible), (2, params), (3, samples)],
        )
    }

    /// Records one dispatch of `point_count * rays_per_point` invocations.
    /// The `visible` buffer must be zeroed first (the kernel ORs bits in).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
        tree: &GpuKdTree,
        io: &wgpu::BindGroup,
        grid: (u32, u32),
    ) {
        record_dispatch(
            encoder,
            "ao rays",
            timestamp_writes,
            &self.pipeline,
            &[&tree.bind_group, io],
            grid,
        );
    }
}

/// Result of `visibility_gpu`.
pub struct GpuAo {
    pub masks: VisibilityMasks,
    pub gpu_ms: Option<f64>,
    pub wall_ms: f64,
}

/// Rays per dispatch: keeps one dispatch short on a software rasteriser.
pub const RAYS_PER_BATCH: u64 = 1 << 22;

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
    settings.validate()?;
    let start = Instant::now();
    let device = &ctx.device;
    let pass = ctx.kernels.get_or_insert(|| AoRaysPass::new(device));
    let words = settings.words_per_point() as usize;
    let n = settings.rays_per_point as u64;
    let batch_points = ((rays_per_batch / n).max(1) as usize).min(points.len().max(1));
    check_storage_size(device, "AO points", (batch_points * 32) as u64)?;
    check_storage_size(device, "AO visibility masks", (batch_points * words * 4) as u64)?;
    let point_buf = zeroed_buffer(
        device,
        "ao points",
        (batch_points * 32) as u64,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
    );
    let visible_buf = zeroed_buffer(
        device,
        "ao visible",
        (batch_points * words * 4) as u64,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    );
    let readback = zeroed_buffer(
        device,
        "ao readback",
        (batch_points * words * 4) as u64,
        wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
    );
    let params_buf = uniform_buffer(device, "ao params", &AoParams::zeroed());
    let unused_samples = zeroed_buffer(device, "ao samples (unused)", 16, wgpu::BufferUsages::STORAGE);
    let io = pass.io_bind_group(device, &point_buf, &visible_buf, &params_buf, &unused_samples);
    let batches = points.len().div_ceil(batch_points);
    let mut timer = PassTimer::new(ctx, batches as u32);
    let max_dim = device.limits().max_compute_workgroups_per_dimension;

    let mut bits = Vec::with_capacity(points.len() * words);
    for chunk in points.chunks(batch_points) {
        let invocations = (chunk.len() as u64 * n) as u32;
        let (gx, gy, pitch) = dispatch_grid(invocations, max_dim);
        ctx.queue.write_buffer(&point_buf, 0, bytemuck::cast_slice(chunk));
        let params = AoParams {
            point_count: chunk.len() as u32,
            rays_per_point: settings.rays_per_point,
            words_per_point: words as u32,
            seed: settings.seed,
            row_pitch: pitch,
            radius: if settings.radius.is_finite() {
                settings.radius
            } else {
                f32::MAX
            },
            _pad: [0; 2],
        };
        ctx.queue.write_buffer(&params_buf, 0, bytemuck::bytes_of(&params));
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&visible_buf, 0, None);
        pass.record(
            &mut encoder,
            timer.as_mut().and_then(|t| t.next_pass()),
            tree,
            &io,
            (gx, gy),
        );
        let bytes = (chunk.len() * words * 4) as u64;
        encoder.copy_buffer_to_buffer(&visible_buf, 0, &readback, 0, bytes);
        ctx.queue.submit([encoder.finish()]);
        bits.extend(read_back::<u32>(device, &readback, chunk.len() * words)?);
        progress.inc(chunk.len() as u64);
    }
    let gpu_ms = PassTimer::finish(timer, ctx)?;
    Ok(GpuAo {
        masks: VisibilityMasks {
            rays_per_point: settings.rays_per_point,
            words_per_point: words as u32,
            bits,
        },
        gpu_ms,
        wall_ms: start.elapsed().as_secs_f64() * 1e3,
    })
}

/// The sample point and direction of every AO ray, as the kernel computes
/// them (`ao_samples`): the check that the GPU's sequence and hemisphere
/// mapping are the CPU's. Returns per ray `([u, v], direction)`.
pub fn ray_samples_gpu(
    ctx: &GpuContext,
    points: &[AoPoint],
    settings: &AoSettings,
) -> Result<Vec<([f32; 2], [f32; 3])>> {
    settings.validate()?;
    let device = &ctx.device;
    let pass = ctx.kernels.get_or_insert(|| AoRaysPass::new(device));
    let rays = points.len() * settings.rays_per_point as usize;
    check_storage_size(device, "AO ray samples", rays as u64 * 32)?;
    let point_buf = storage_buffer(device, "ao points", bytemuck::cast_slice(points))?;
    let unused_visible = zeroed_buffer(device, "ao visible (unused)", 4, wgpu::BufferUsages::STORAGE);
    let samples = zeroed_buffer(
        device,
        "ao samples",
        rays as u64 * 32,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    let readback = zeroed_buffer(
        device,
        "ao samples readback",
        rays as u64 * 32,
        wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
    );
    let (gx, gy, pitch) = dispatch_grid(rays as u32, device.limits().max_compute_workgroups_per_dimension);
    let params = AoParams {
        point_count: points.len() as u32,
        rays_per_point: settings.rays_per_point,
        words_per_point: settings.words_per_point(),
        seed: settings.seed,
        row_pitch: pitch,
        radius: f32::MAX,
        _pad: [0; 2],
    };
    let params_buf = uniform_buffer(device, "ao params", &params);
    let io = pass.io_bind_group(device, &point_buf, &unused_visible, &params_buf, &samples);
    let tree = placeholder_tree(device)?;
    let mut encoder = device.create_command_encoder(&Default::default());
    let groups = [&tree.bind_group, &io];
    record_dispatch(
        &mut encoder,
        "ao samples",
        None,
        &pass.samples_pipeline,
        &groups,
        (gx, gy),
    );
    encoder.copy_buffer_to_buffer(&samples, 0, &readback, 0, rays as u64 * 32);
    ctx.queue.submit([encoder.finish()]);
    let raw: Vec<[f32; 8]> = read_back(device, &readback, rays)?;
    Ok(raw.iter().map(|r| ([r[0], r[1]], [r[4], r[5], r[6]])).collect())
}

/// `ao_samples` traces nothing, but its pipeline layout includes the tree.
fn placeholder_tree(device: &wgpu::Device) -> Result<GpuKdTree> {
    let tree = crate::kdtree::KdTree::from_triangles(
        vec![[glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y]],
        &Default::default(),
    )?;
    GpuKdTree::upload(device, &tree)
}
