//! The `interpolate.wgsl` pass: the fast path's per-pixel interpolation on
//! the GPU, over a table of accepted cells' corner radiances. It follows
//! glyphon's split as every pass does: `InterpolatePass::new` (or
//! `for_context`) builds or borrows the pipeline, `prepare` writes a batch
//! into buffers it keeps, `record` only records into the caller's encoder.
//!
//! Only the interpolation runs here. The linetrees and the predicate stay
//! on the CPU (the paper's design), and so does each pixel's position in its
//! cell: it comes from f64 line coordinates (see the kernel's header).

use std::ops::Range;
use std::sync::Arc;

use super::interpolate::PixelJob;
use crate::error::{Error, Result};
use crate::gpu::batch::{BatchPass, BatchPlan, Batched, Pass, run_batches};
use crate::gpu::buffers::KeptGroup;
use crate::gpu::kernels::{Kernels, PipelineLog, Pipelines, compute_pipelines, record_dispatch};
use crate::gpu::layout::{Io, io_layout};
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, dispatch_grid};
use crate::progress::Bar;

/// The kernel's uniform (`InterpolateParams`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct InterpolateUniforms {
    job_count: u32,
    row_pitch: u32,
    _pad: [u32; 2],
}

const INTERPOLATE_IO: &[Io] = &[
    Io::Uniform(
        0,
        "interpolate params",
        std::mem::size_of::<InterpolateUniforms>() as u64,
    ),
    Io::In(1, "interpolate corners"),
    Io::In(2, "interpolate jobs"),
    Io::Out(3, "interpolate radiance"),
];

/// Pixels per dispatch (64 bytes each, in and out).
pub const JOBS_PER_BATCH: usize = 1 << 18;

/// The `interpolate` kernel's pipeline and bind-group layout, built once
/// per device (cached on its context) and shared by its passes.
pub struct InterpolateKernels {
    layout: wgpu::BindGroupLayout,
    pipeline: Pipelines,
}

impl Kernels for InterpolateKernels {
    fn build(device: &wgpu::Device, log: &Arc<PipelineLog>) -> InterpolateKernels {
        let layout = io_layout(device, "interpolate", INTERPOLATE_IO);
        let module = &crate::gpu::wgsl::INTERPOLATE_MODULE;
        let pipeline = compute_pipelines(device, module, &[&layout], &["interpolate"], log);
        InterpolateKernels { layout, pipeline }
    }
}

/// The pass with its kept buffers: the corner table of a frame and one
/// batch of jobs.
pub struct InterpolatePass {
    kernels: Arc<InterpolateKernels>,
    io: KeptGroup,
    grid: (u32, u32),
    jobs: u64,
}

impl Pass for InterpolatePass {
    type Kernels = InterpolateKernels;
    fn with_kernels(device: &wgpu::Device, kernels: Arc<InterpolateKernels>) -> InterpolatePass {
        InterpolatePass {
            kernels,
            io: KeptGroup::for_io(device, "interpolate", INTERPOLATE_IO),
            grid: (0, 0),
            jobs: 0,
        }
    }
}

impl InterpolatePass {
    /// Uploads the corner table (16 `[r, g, b, _]` per cell slot).
    pub fn prepare_corners(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, corners: &[[f32; 4]]) -> Result<()> {
        let bytes: &[u8] = if corners.is_empty() {
            &[0; 16]
        } else {
            bytemuck::cast_slice(corners)
        };
        self.io.write(device, queue, 1, bytes)
    }

    /// Uploads a batch of jobs.
    pub fn prepare(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, jobs: &[PixelJob]) -> Result<()> {
        let n = jobs.len() as u32;
        let (gx, gy, pitch) = dispatch_grid(n, device.limits().max_compute_workgroups_per_dimension);
        let params = InterpolateUniforms {
            job_count: n,
            row_pitch: pitch,
            _pad: [0; 2],
        };
        self.io.write(device, queue, 0, bytemuck::bytes_of(&params))?;
        let bytes: &[u8] = if jobs.is_empty() {
            &[0; 32]
        } else {
            bytemuck::cast_slice(jobs)
        };
        self.io.write(device, queue, 2, bytes)?;
        self.io.reserve(device, 3, (n as u64 * 16).max(16))?;
        self.io.update(device, &self.kernels.layout);
        self.grid = (gx, gy);
        self.jobs = n as u64;
        Ok(())
    }

    /// Records the kernel over the prepared batch.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        record_dispatch(
            encoder,
            "interpolate",
            timestamp_writes,
            self.kernels.pipeline.get(0),
            &[self.io.group()],
            self.grid,
        );
    }

    /// The prepared batch's radiance (`[r, g, b, 0]` per job).
    pub fn radiance(&self) -> &wgpu::Buffer {
        self.io.buffer(3)
    }
}

/// A request's jobs as batches of the pass.
struct JobBatches<'a> {
    pass: &'a mut InterpolatePass,
    jobs: &'a [PixelJob],
}

impl BatchPass for JobBatches<'_> {
    fn prepare(&mut self, ctx: &GpuContext, items: Range<usize>) -> Result<()> {
        self.pass.prepare(&ctx.device, &ctx.queue, &self.jobs[items])
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &mut Option<PassTimer>) {
        self.pass.record(encoder, timer.as_mut().and_then(|t| t.next_pass()));
    }

    fn results(&self) -> Vec<(&wgpu::Buffer, u64)> {
        vec![(self.pass.radiance(), self.pass.jobs * 16)]
    }
}

impl Batched<InterpolatePass> {
    /// Every job's radiance (blocking), in batches, and the kernels' time
    /// where the device has timestamps.
    pub fn interpolate(
        &mut self,
        ctx: &GpuContext,
        corners: &[[f32; 4]],
        jobs: &[PixelJob],
    ) -> Result<(Vec<[f32; 4]>, Option<f64>)> {
        self.pass.prepare_corners(&ctx.device, &ctx.queue, corners)?;
        let mut out = Vec::with_capacity(jobs.len());
        let plan = BatchPlan::new(jobs.len(), JOBS_PER_BATCH, 1);
        let mut batches = JobBatches {
            pass: &mut self.pass,
            jobs,
        };
        let take = |items: Range<usize>, values: &[[f32; 4]]| {
            out.extend_from_slice(&values[..items.len()]);
            Ok(())
        };
        let gpu_ms = run_batches(ctx, &mut batches, &mut self.readback, plan, &Bar::hidden(), take)?;
        if out.len() != jobs.len() {
            return Err(Error::internal(
                "the interpolate kernel returned the wrong number of pixels",
            ));
        }
        Ok((out, gpu_ms))
    }
}
