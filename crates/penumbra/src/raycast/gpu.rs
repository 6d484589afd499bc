//! AO by ray casting on the GPU: the `ao_rays.wgsl` pass over a `GpuKdTree`,
//! built once per device (`new`), fed by `prepare` into buffers it keeps,
//! recorded into the caller's encoder by `record`; `AoRaysBatches` is the
//! blocking convenience that splits large requests into batches.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::{AoPoint, AoSettings, VisibilityMasks};
use crate::error::Result;
use crate::gpu::batch::{BatchPlan, Batched, Pass, fit_items, run_batches};
use crate::gpu::buffers::read_buffer;
use std::sync::Arc;

use crate::accel::kdtree::gpu::GpuKdTree;
use crate::accel::kdtree::pass::{Dispatch, TreeBatch, TreeKernelSet, TreeKernels, TreePass};
use crate::gpu::kernels::{Kernels, PipelineLog};
use crate::gpu::layout::Io;
use crate::gpu::{GpuContext, dispatch_grid};
use crate::progress::Bar;

/// The AO rays of a batch of points, as `wgsl/ao_rays.wgsl`'s `AoRaysUniforms`
/// and `wgsl/field_ao.wgsl`'s `FieldAoUniforms` begin.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct AoRays {
    /// Points in the batch.
    pub point_count: u32,
    /// Rays cast from each point (`AoSettings::rays_per_point`).
    pub rays_per_point: u32,
    /// Words of each point's visibility mask (`AoSettings::words_per_point`).
    pub words_per_point: u32,
    /// The sample sequence's seed (`AoSettings::seed`).
    pub seed: u32,
    /// Invocations per row of the 2D dispatch grid.
    pub row_pitch: u32,
    /// `f32::MAX` for an infinite radius (WGSL may assume no infinities).
    pub radius: f32,
}

impl AoRays {
    /// The rays of `points` points cast as `settings` says (an infinite
    /// radius as `f32::MAX`), on a dispatch grid of `row_pitch` invocations
    /// a row.
    pub fn new(points: usize, settings: &AoSettings, row_pitch: u32) -> AoRays {
        AoRays {
            point_count: points as u32,
            rays_per_point: settings.rays_per_point,
            words_per_point: settings.words_per_point(),
            seed: settings.seed,
            row_pitch,
            radius: if settings.radius.is_finite() {
                settings.radius
            } else {
                f32::MAX
            },
        }
    }
}

/// `AoRaysUniforms` in `wgsl/ao_rays.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct AoRaysUniforms {
    pub rays: AoRays,
    /// 1 where binding 4 holds the traced mesh's cut-outs.
    pub has_cutouts: u32,
    pub _pad: u32,
}

/// The AO pass's io: points (8 words each), visibility masks (read-write
/// atomics), params, samples (written by the `ao_samples` check only), the
/// traced mesh's cut-outs (`Cutouts::words`).
const AO_IO: &[Io] = &[
    Io::In(0, "ao points"),
    Io::Out(1, "ao visible"),
    Io::Uniform(2, "ao params", std::mem::size_of::<AoRaysUniforms>() as u64),
    Io::Out(3, "ao samples"),
    Io::In(4, "ao cutouts"),
];

/// The pipelines of `ao_rays.wgsl` for one device (`ao_rays`, `ao_samples`).
pub struct AoRaysKernels(TreeKernels);

impl Kernels for AoRaysKernels {
    fn build(device: &wgpu::Device, log: &Arc<PipelineLog>) -> AoRaysKernels {
        let module = &crate::gpu::wgsl::AO_RAYS_MODULE;
        AoRaysKernels(TreeKernels::build(
            device,
            module,
            AO_IO,
            &["ao_rays", "ao_samples"],
            log,
        ))
    }
}

impl TreeKernelSet for AoRaysKernels {
    const IO: &'static [Io] = AO_IO;
    const LABEL: &'static str = "ao rays";
    fn tree_kernels(&self) -> &TreeKernels {
        &self.0
    }
}

/// The AO-ray pass: kernels and the buffers of one batch of points.
pub type AoRaysPass = TreePass<AoRaysKernels>;

impl TreePass<AoRaysKernels> {
    /// Uploads the traced mesh's cut-outs (`Cutouts::words`), or none:
    /// rays then stop at the first triangle they hit.
    pub fn prepare_cutouts(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, words: Option<&[u32]>) -> Result<()> {
        let io = self.io();
        match words {
            Some(w) => io.write(device, queue, 4, bytemuck::cast_slice(w)),
            None => io.reserve(device, 4, 16),
        }
    }

    /// Uploads `points` (whole points, at most what the bindings hold) for
    /// `settings`; with `samples` the pass writes every ray's sample point
    /// and direction instead of tracing (the `ao_samples` check); with
    /// `cutouts` rays pass the holes `prepare_cutouts` uploaded.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        points: &[AoPoint],
        settings: &AoSettings,
        samples: bool,
        cutouts: bool,
    ) -> Result<()> {
        settings.validate()?;
        let words = (points.len() * settings.words_per_point() as usize) as u64;
        let rays = points.len() as u64 * settings.rays_per_point as u64;
        let (gx, gy, pitch) = dispatch_grid(rays as u32, device.limits().max_compute_workgroups_per_dimension);
        let mut ao = AoRays::new(points.len(), settings, pitch);
        if samples {
            ao.radius = f32::MAX;
        }
        let params = AoRaysUniforms {
            rays: ao,
            has_cutouts: cutouts as u32,
            _pad: 0,
        };
        let io = self.io();
        io.reserve(device, 4, 16)?;
        io.write(device, queue, 0, bytemuck::cast_slice(points))?;
        io.reserve(device, 1, words * 4)?;
        io.write(device, queue, 2, bytemuck::bytes_of(&params))?;
        io.reserve(device, 3, if samples { rays * 32 } else { 16 })?;
        // `ao_rays` ORs bits into the masks; `ao_samples` writes samples.
        let dispatch = match samples {
            false => Dispatch {
                entry: 0,
                grid: (gx, gy),
                clear: Some(1),
                results: vec![(1, words * 4)],
            },
            true => Dispatch {
                entry: 1,
                grid: (gx, gy),
                clear: None,
                results: vec![(3, rays * 32)],
            },
        };
        self.set_dispatch(device, dispatch);
        Ok(())
    }

    /// `words_per_point` visibility words per prepared point.
    pub fn visible(&self) -> &wgpu::Buffer {
        self.buffer(1)
    }
}

/// Rays per dispatch: keeps one dispatch short on a software rasteriser.
pub const RAYS_PER_BATCH: u64 = 1 << 22;

/// Bytes of one point in the points binding.
pub(crate) const AO_POINT_BYTES: u64 = std::mem::size_of::<AoPoint>() as u64;

/// The pass with its read-back buffer, as a runner keeps it on a device.
pub type AoRaysBatches = Batched<AoRaysPass>;

impl Batched<AoRaysPass> {
    /// Casts the AO rays of `points` (blocking), about `rays_per_batch` rays
    /// per dispatch (whole points, at least one per batch, no more than the
    /// device's bindings hold), through the holes of `cutouts`
    /// (`Cutouts::words` of the tree's mesh) if given; returns the masks
    /// and the kernels' time where timestamps exist.
    #[allow(clippy::too_many_arguments)]
    pub fn visibility(
        &mut self,
        ctx: &GpuContext,
        tree: &GpuKdTree,
        cutouts: Option<&[u32]>,
        points: &[AoPoint],
        settings: &AoSettings,
        progress: &Bar,
        rays_per_batch: u64,
    ) -> Result<(VisibilityMasks, Option<f64>)> {
        settings.validate()?;
        let words = settings.words_per_point() as usize;
        let mask_bytes = 4 * words as u64;
        let fit = fit_items(&ctx.device, &[AO_POINT_BYTES, mask_bytes], mask_bytes);
        let per_batch = ((rays_per_batch / settings.rays_per_point as u64).max(1) as usize).min(fit);
        let mut bits = Vec::with_capacity(points.len() * words);
        self.pass.prepare_cutouts(&ctx.device, &ctx.queue, cutouts)?;
        let mut batch = TreeBatch {
            pass: &mut self.pass,
            tree,
            prepare: |pass: &mut AoRaysPass, ctx: &GpuContext, items: Range<usize>| {
                pass.prepare(
                    &ctx.device,
                    &ctx.queue,
                    &points[items],
                    settings,
                    false,
                    cutouts.is_some(),
                )
            },
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

/// The sample point and direction of every AO ray, as the kernel computes
/// them (`ao_samples`): the check that the GPU's sequence and hemisphere
/// mapping are the CPU's. Returns per ray `([u, v], direction)`.
pub fn ray_samples_gpu(
    ctx: &GpuContext,
    points: &[AoPoint],
    settings: &AoSettings,
) -> Result<Vec<([f32; 2], [f32; 3])>> {
    let mut pass = AoRaysPass::for_context(ctx);
    pass.prepare(&ctx.device, &ctx.queue, points, settings, true, false)?;
    // `ao_samples` traces nothing, but its pipeline layout includes a tree.
    let tree = placeholder_tree(&ctx.device)?;
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    pass.record(&mut encoder, None, &tree);
    ctx.queue.submit([encoder.finish()]);
    let rays = points.len() * settings.rays_per_point as usize;
    let raw: Vec<[f32; 8]> = read_buffer(ctx, pass.buffer(3), rays)?;
    Ok(raw.iter().map(|r| ([r[0], r[1]], [r[4], r[5], r[6]])).collect())
}

fn placeholder_tree(device: &wgpu::Device) -> Result<GpuKdTree> {
    let tree = crate::accel::kdtree::KdTree::from_triangles(
        vec![[glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y]],
        &Default::default(),
    )?;
    GpuKdTree::upload(device, &tree)
}
