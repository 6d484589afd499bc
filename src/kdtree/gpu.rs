//! The kd-tree on the GPU: its three arrays uploaded as they are, and the
//! `trace_rays.wgsl` pass (closest hit, any hit, closest hit with counters).
//!
//! `TraceRaysPass` follows glyphon's split: `new(device)` builds its layouts
//! and pipelines, `prepare` uploads rays into buffers it keeps (and grows
//! when a request is larger), `record` only records into the caller's
//! encoder. `trace_rays` is the blocking convenience that splits a large
//! request into batches the device takes (`gpu::batch`).

use std::ops::Range;
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::KdTree;
use crate::error::{Error, Result};
use crate::gpu::batch::{BatchPass, BatchPlan, readback_buffer, run_batches};
use crate::gpu::buffers::{GrowingBuffer, storage_buffer, uniform_buffer};
use crate::gpu::kernels::{compute_pipelines, record_dispatch};
use crate::gpu::layout::{bind_group, layout, storage_entry, uniform_entry};
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, dispatch_grid};
use crate::progress::Progress;
use crate::ray::{Hit, Ray};

/// `KdScene` in `wgsl/kdtree_traverse.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct KdSceneUniform {
    bounds_min: [f32; 3],
    node_count: u32,
    bounds_max: [f32; 3],
    triangle_count: u32,
}

/// Layout of bind group 0 of every kernel that traverses the tree. Layouts
/// with equal entries are interchangeable, so any pass's copy will do.
pub fn kdtree_bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    layout(
        device,
        "kd-tree",
        &[
            storage_entry(0, true),
            storage_entry(1, true),
            storage_entry(2, true),
            uniform_entry(3),
        ],
    )
}

/// A kd-tree resident on a device (bind group 0 of the traversal kernels).
pub struct GpuKdTree {
    pub nodes: wgpu::Buffer,
    pub leaf_triangles: wgpu::Buffer,
    pub triangles: wgpu::Buffer,
    pub scene: wgpu::Buffer,
    pub bind_group: wgpu::BindGroup,
    pub bytes: u64,
}

impl GpuKdTree {
    /// Uploads the tree. Fails with a device error if an array exceeds the
    /// device's storage-binding limit.
    pub fn upload(device: &wgpu::Device, tree: &KdTree) -> Result<GpuKdTree> {
        let nodes = storage_buffer(device, "kd-tree nodes", bytemuck::cast_slice(&tree.nodes))?;
        let leaf_triangles = storage_buffer(
            device,
            "kd-tree leaf triangles",
            bytemuck::cast_slice(&tree.leaf_triangles),
        )?;
        let triangles = storage_buffer(device, "kd-tree triangles", bytemuck::cast_slice(&tree.triangles))?;
        let scene = uniform_buffer(
            device,
            "kd-tree scene",
            &KdSceneUniform {
                bounds_min: tree.bounds.min.to_array(),
                node_count: tree.nodes.len() as u32,
                bounds_max: tree.bounds.max.to_array(),
                triangle_count: tree.triangles.len() as u32,
            },
        );
        let bind_group = bind_group(
            device,
            "kd-tree",
            &kdtree_bind_group_layout(device),
            &[(0, &nodes), (1, &leaf_triangles), (2, &triangles), (3, &scene)],
        );
        let bytes = nodes.size() + leaf_triangles.size() + triangles.size();
        Ok(GpuKdTree {
            nodes,
            leaf_triangles,
            triangles,
            scene,
            bind_group,
            bytes,
        })
    }
}

/// `TraceParams` in `wgsl/trace_rays.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct TraceParams {
    pub ray_count: u32,
    pub row_pitch: u32,
    pub t_max: f32,
    pub _pad: u32,
}

/// Which entry point of `trace_rays.wgsl` to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TraceMode {
    Closest,
    Any,
    /// Closest hit, also writing (traversal steps, intersection tests) per ray.
    ClosestCounted,
}

/// The layouts and pipelines of `trace_rays.wgsl` for one device.
pub struct TraceRaysKernels {
    pub io_layout: wgpu::BindGroupLayout,
    closest: wgpu::ComputePipeline,
    any: wgpu::ComputePipeline,
    counted: wgpu::ComputePipeline,
}

impl TraceRaysKernels {
    pub fn new(device: &wgpu::Device) -> TraceRaysKernels {
        // rays (read), hits (write), params (uniform), counts (write)
        let io_layout = layout(
            device,
            "trace rays io",
            &[
                storage_entry(0, true),
                storage_entry(1, false),
                uniform_entry(2),
                storage_entry(3, false),
            ],
        );
        let pipelines = compute_pipelines(
            device,
            &crate::wgsl::TRACE_RAYS_MODULE,
            &[&kdtree_bind_group_layout(device), &io_layout],
            &["trace_closest", "trace_any", "trace_closest_counted"],
        );
        let [closest, any, counted] = pipelines.try_into().expect("three entry points");
        TraceRaysKernels {
            io_layout,
            closest,
            any,
            counted,
        }
    }

    /// The kernels cached on `ctx`.
    pub fn cached(ctx: &GpuContext) -> Arc<TraceRaysKernels> {
        ctx.kernels.get_or_insert(|| TraceRaysKernels::new(&ctx.device))
    }
}

/// The ray-tracing pass: kernels and the buffers of one batch of rays.
pub struct TraceRaysPass {
    kernels: Arc<TraceRaysKernels>,
    rays: GrowingBuffer,
    hits: GrowingBuffer,
    counts: GrowingBuffer,
    params: wgpu::Buffer,
    io: Option<wgpu::BindGroup>,
    mode: TraceMode,
    ray_count: u32,
    grid: (u32, u32),
}

const STORAGE_IN: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST);
/// Results: copied out, and clearable by a host.
const STORAGE_OUT: wgpu::BufferUsages = STORAGE_IN.union(wgpu::BufferUsages::COPY_SRC);

impl TraceRaysPass {
    /// Builds the kernels for `device`.
    pub fn new(device: &wgpu::Device) -> TraceRaysPass {
        Self::with_kernels(device, Arc::new(TraceRaysKernels::new(device)))
    }

    /// A pass with kernels built before (e.g. `TraceRaysKernels::cached`).
    pub fn with_kernels(device: &wgpu::Device, kernels: Arc<TraceRaysKernels>) -> TraceRaysPass {
        TraceRaysPass {
            kernels,
            rays: GrowingBuffer::new("rays", STORAGE_IN),
            hits: GrowingBuffer::new("hits", STORAGE_OUT),
            counts: GrowingBuffer::new("trace counts", STORAGE_OUT),
            params: uniform_buffer(device, "trace params", &TraceParams::zeroed()),
            io: None,
            mode: TraceMode::Closest,
            ray_count: 0,
            grid: (0, 0),
        }
    }

    /// Uploads `rays` (at most what one storage binding holds) for `mode`,
    /// hits within `0 < t < t_max` in units of each ray's direction.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        rays: &[Ray],
        mode: TraceMode,
        t_max: f32,
    ) -> Result<()> {
        let n = rays.len();
        let mut grown = self.rays.write(device, queue, bytemuck::cast_slice(rays))?;
        grown |= self.hits.reserve(device, n as u64 * 8)?;
        let count_bytes = if mode == TraceMode::ClosestCounted {
            n as u64 * 8
        } else {
            8
        };
        grown |= self.counts.reserve(device, count_bytes)?;
        if grown || self.io.is_none() {
            self.io = Some(bind_group(
                device,
                "trace rays io",
                &self.kernels.io_layout,
                &[
                    (0, self.rays.get()),
                    (1, self.hits.get()),
                    (2, &self.params),
                    (3, self.counts.get()),
                ],
            ));
        }
        let (gx, gy, pitch) = dispatch_grid(n as u32, device.limits().max_compute_workgroups_per_dimension);
        let params = TraceParams {
            ray_count: n as u32,
            row_pitch: pitch,
            t_max: if t_max.is_finite() { t_max } else { f32::MAX },
            _pad: 0,
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        self.mode = mode;
        self.ray_count = n as u32;
        self.grid = (gx, gy);
        Ok(())
    }

    /// Records the dispatch over the prepared rays into the caller's encoder.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
        tree: &GpuKdTree,
    ) {
        let k = &self.kernels;
        let pipeline = match self.mode {
            TraceMode::Closest => &k.closest,
            TraceMode::Any => &k.any,
            TraceMode::ClosestCounted => &k.counted,
        };
        let io = self.io.as_ref().expect("TraceRaysPass::record before prepare");
        record_dispatch(
            encoder,
            "trace rays",
            timestamp_writes,
            pipeline,
            &[&tree.bind_group, io],
            self.grid,
        );
    }

    /// (t bits, triangle) per prepared ray, after the recorded dispatch.
    pub fn hits(&self) -> &wgpu::Buffer {
        self.hits.get()
    }

    /// (traversal steps, intersection tests) per ray in `ClosestCounted` mode.
    pub fn counts(&self) -> &wgpu::Buffer {
        self.counts.get()
    }
}

/// What a blocking GPU trace returns.
pub struct GpuTrace {
    pub hits: Vec<Hit>,
    /// Per ray (traversal steps, intersection tests), in `ClosestCounted` mode.
    pub counts: Option<Vec<[u32; 2]>>,
    /// Kernel time from timestamp queries, where supported.
    pub gpu_ms: Option<f64>,
}

/// Largest batch of rays per dispatch: the device's storage-binding limit for
/// the rays, and a cap that keeps a single dispatch short.
fn batch_size(device: &wgpu::Device) -> usize {
    let limits = device.limits();
    let max_binding = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
    ((max_binding / 24) as usize).clamp(1, 1 << 22)
}

/// A pass and the kept read-back buffer of its batches: what a runner
/// keeps on a device to trace many requests without reallocating.
pub struct TraceRaysBatches {
    pub pass: TraceRaysPass,
    readback: GrowingBuffer,
}

impl TraceRaysBatches {
    pub fn new(ctx: &GpuContext) -> TraceRaysBatches {
        TraceRaysBatches {
            pass: TraceRaysPass::with_kernels(&ctx.device, TraceRaysKernels::cached(ctx)),
            readback: readback_buffer(),
        }
    }

    /// Traces `rays` (blocking), at most `max_batch` per dispatch (clamped to
    /// what the device allows).
    #[allow(clippy::too_many_arguments)]
    pub fn trace(
        &mut self,
        ctx: &GpuContext,
        tree: &GpuKdTree,
        rays: &[Ray],
        mode: TraceMode,
        t_max: f32,
        max_batch: usize,
    ) -> Result<GpuTrace> {
        let counted = mode == TraceMode::ClosestCounted;
        let mut hits = Vec::with_capacity(rays.len());
        let mut counts = counted.then(|| Vec::with_capacity(rays.len()));
        let plan = BatchPlan::new(rays.len(), max_batch.clamp(1, batch_size(&ctx.device)), 1);
        let mut batch = RayBatch {
            pass: &mut self.pass,
            tree,
            rays,
            mode,
            t_max,
        };
        let gpu_ms = run_batches(
            ctx,
            &mut batch,
            &mut self.readback,
            plan,
            &Progress::hidden(),
            |items, words: &[[u32; 2]]| {
                let n = items.len();
                hits.extend(words[..n].iter().map(|&[t, triangle]| Hit {
                    t: f32::from_bits(t),
                    triangle,
                }));
                if let Some(c) = counts.as_mut() {
                    c.extend_from_slice(&words[n..2 * n]);
                }
                Ok(())
            },
        )?;
        if hits.len() != rays.len() {
            return Err(Error::internal("GPU trace returned the wrong number of hits"));
        }
        Ok(GpuTrace { hits, counts, gpu_ms })
    }
}

/// One request of rays as a `BatchPass`.
struct RayBatch<'a> {
    pass: &'a mut TraceRaysPass,
    tree: &'a GpuKdTree,
    rays: &'a [Ray],
    mode: TraceMode,
    t_max: f32,
}

impl BatchPass for RayBatch<'_> {
    fn prepare(&mut self, ctx: &GpuContext, items: Range<usize>) -> Result<()> {
        self.pass
            .prepare(&ctx.device, &ctx.queue, &self.rays[items], self.mode, self.t_max)
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &mut Option<PassTimer>) {
        self.pass
            .record(encoder, timer.as_mut().and_then(|t| t.next_pass()), self.tree);
    }

    fn results(&self) -> Vec<(&wgpu::Buffer, u64)> {
        let bytes = self.pass.ray_count as u64 * 8;
        let mut out = vec![(self.pass.hits(), bytes)];
        if self.mode == TraceMode::ClosestCounted {
            out.push((self.pass.counts(), bytes));
        }
        out
    }
}

/// Traces `rays` on the GPU (blocking), splitting them into batches that fit
/// the device. Directions need not be normalised; hits are in t units of the
/// given direction, with `0 < t < t_max`.
pub fn trace_rays(ctx: &GpuContext, tree: &GpuKdTree, rays: &[Ray], mode: TraceMode, t_max: f32) -> Result<GpuTrace> {
    trace_rays_batched(ctx, tree, rays, mode, t_max, usize::MAX)
}

/// `trace_rays` with at most `max_batch` rays per dispatch (clamped to what
/// the device allows), for hosts that want to bound the memory it takes.
pub fn trace_rays_batched(
    ctx: &GpuContext,
    tree: &GpuKdTree,
    rays: &[Ray],
    mode: TraceMode,
    t_max: f32,
    max_batch: usize,
) -> Result<GpuTrace> {
    TraceRaysBatches::new(ctx).trace(ctx, tree, rays, mode, t_max, max_batch)
}
