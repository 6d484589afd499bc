//! The kd-tree on the GPU: its three arrays uploaded as they are, and the
//! `trace_rays.wgsl` pass (closest hit, any hit, closest hit with counters).
//!
//! `TraceRaysPass` follows glyphon's split: `new(device)` builds its layouts
//! and pipelines, `prepare` uploads rays into buffers it keeps (and grows
//! when a request is larger), `record` only records into the caller's
//! encoder. `TraceRaysBatches::trace` is the blocking convenience that
//! splits a large request into batches the device takes (`gpu::batch`).

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::KdTree;
use super::pass::{Dispatch, TreeBatch, TreeKernelSet, TreeKernels, TreePass};
use crate::error::{Error, Result};
use crate::gpu::batch::{BatchPlan, Batched, fit_items, run_batches};
use crate::gpu::buffers::{storage_buffer, uniform_buffer};
use std::sync::Arc;

use crate::geom::ray::{Hit, Ray};
use crate::gpu::kernels::{Kernels, PipelineLog};
use crate::gpu::layout::{Io, bind_group, layout, storage_entry, uniform_entry};
use crate::gpu::{GpuContext, dispatch_grid};
use crate::progress::Bar;

/// `KdScene` in `wgsl/kdtree_traverse.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct KdSceneUniform {
    bounds_min: [f32; 3],
    node_count: u32,
    bounds_max: [f32; 3],
    triangle_count: u32,
    frame_scale: f32,
    inv_frame_scale: f32,
    pad: [u32; 2],
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
    /// `KdTree::nodes`, 8 bytes each (binding 0).
    pub nodes: wgpu::Buffer,
    /// `KdTree::leaf_triangles` (binding 1).
    pub leaf_triangles: wgpu::Buffer,
    /// `KdTree::triangles`, nine f32 each, in world units (binding 2).
    pub triangles: wgpu::Buffer,
    /// The `KdScene` uniform: bounds, node and triangle counts and the
    /// frame scale (binding 3).
    pub scene: wgpu::Buffer,
    /// Bind group 0 of the traversal kernels, over the four buffers.
    pub bind_group: wgpu::BindGroup,
    /// Bytes of the three storage arrays (the uniform not counted).
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
                frame_scale: tree.frame_scale,
                inv_frame_scale: 1.0 / tree.frame_scale,
                pad: [0; 2],
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

/// `TraceRaysUniforms` in `wgsl/trace_rays.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct TraceRaysUniforms {
    pub ray_count: u32,
    pub row_pitch: u32,
    pub t_max: f32,
    pub _pad: u32,
}

/// Which entry point of `trace_rays.wgsl` to run (in `TraceRaysKernels`' order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TraceMode {
    /// The closest hit of each ray.
    Closest,
    /// Any hit: the first the walk finds, not necessarily the closest.
    Any,
    /// Closest hit, also writing (traversal steps, intersection tests) per ray.
    ClosestCounted,
}

/// The trace pass's io: rays (6 f32 each), hits (t bits, triangle), params,
/// counts (traversal steps, intersection tests; `ClosestCounted` only).
const TRACE_IO: &[Io] = &[
    Io::In(0, "rays"),
    Io::Out(1, "hits"),
    Io::Uniform(2, "trace params", std::mem::size_of::<TraceRaysUniforms>() as u64),
    Io::Out(3, "trace counts"),
];

/// The pipelines of `trace_rays.wgsl` for one device, in `TraceMode` order.
pub struct TraceRaysKernels(TreeKernels);

impl Kernels for TraceRaysKernels {
    fn build(device: &wgpu::Device, log: &Arc<PipelineLog>) -> TraceRaysKernels {
        let entries = ["trace_closest", "trace_any", "trace_closest_counted"];
        let module = &crate::gpu::wgsl::TRACE_RAYS_MODULE;
        TraceRaysKernels(TreeKernels::build(device, module, TRACE_IO, &entries, log))
    }
}

impl TreeKernelSet for TraceRaysKernels {
    const IO: &'static [Io] = TRACE_IO;
    const LABEL: &'static str = "trace rays";
    fn tree_kernels(&self) -> &TreeKernels {
        &self.0
    }
}

/// The ray-tracing pass: kernels and the buffers of one batch of rays.
pub type TraceRaysPass = TreePass<TraceRaysKernels>;

impl TreePass<TraceRaysKernels> {
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
        let n = rays.len() as u64;
        let (gx, gy, pitch) = dispatch_grid(n as u32, device.limits().max_compute_workgroups_per_dimension);
        let params = TraceRaysUniforms {
            ray_count: n as u32,
            row_pitch: pitch,
            t_max: if t_max.is_finite() { t_max } else { f32::MAX },
            _pad: 0,
        };
        let counted = mode == TraceMode::ClosestCounted;
        let io = self.io();
        io.write(device, queue, 0, bytemuck::cast_slice(rays))?;
        io.reserve(device, 1, n * 8)?;
        io.write(device, queue, 2, bytemuck::bytes_of(&params))?;
        io.reserve(device, 3, if counted { n * 8 } else { 8 })?;
        let mut results = vec![(1, n * 8)];
        if counted {
            results.push((3, n * 8));
        }
        let dispatch = Dispatch {
            entry: mode as usize,
            grid: (gx, gy),
            clear: None,
            results,
        };
        self.set_dispatch(device, dispatch);
        Ok(())
    }

    /// (t bits, triangle) per prepared ray, after the recorded dispatch.
    pub fn hits(&self) -> &wgpu::Buffer {
        self.buffer(1)
    }

    /// (traversal steps, intersection tests) per ray in `ClosestCounted` mode.
    pub fn counts(&self) -> &wgpu::Buffer {
        self.buffer(3)
    }
}

/// What a blocking GPU trace returns.
pub struct GpuTrace {
    /// One per ray, in order; `Hit::MISS` where a ray hits nothing.
    pub hits: Vec<Hit>,
    /// Per ray (traversal steps, intersection tests), in `ClosestCounted` mode.
    pub counts: Option<Vec<[u32; 2]>>,
    /// Kernel time from timestamp queries, where supported.
    pub gpu_ms: Option<f64>,
}

/// Largest batch of rays per dispatch: what the device's bindings hold (a
/// ray's 24 bytes, its hit and counts, 8 bytes each, read back together),
/// and a cap that keeps a single dispatch short.
fn batch_size(device: &wgpu::Device) -> usize {
    fit_items(device, &[24, 8, 8], 16).clamp(1, 1 << 22)
}

/// The pass with its read-back buffer, as a runner keeps it on a device.
pub type TraceRaysBatches = Batched<TraceRaysPass>;

impl Batched<TraceRaysPass> {
    /// Traces `rays` (blocking), at most `max_batch` per dispatch (clamped to
    /// what the device allows). Directions need not be normalised; hits are
    /// in t units of the given direction, with `0 < t < t_max`.
    pub fn trace(
        &mut self,
        ctx: &GpuContext,
        tree: &GpuKdTree,
        rays: &[Ray],
        mode: TraceMode,
        t_max: f32,
        max_batch: usize,
    ) -> Result<GpuTrace> {
        let mut hits = Vec::with_capacity(rays.len());
        let mut counts = (mode == TraceMode::ClosestCounted).then(|| Vec::with_capacity(rays.len()));
        let plan = BatchPlan::new(rays.len(), max_batch.clamp(1, batch_size(&ctx.device)), 1);
        let mut batch = TreeBatch {
            pass: &mut self.pass,
            tree,
            prepare: |pass: &mut TraceRaysPass, ctx: &GpuContext, items: Range<usize>| {
                pass.prepare(&ctx.device, &ctx.queue, &rays[items], mode, t_max)
            },
        };
        let progress = Bar::hidden();
        let take = |items: Range<usize>, w: &[[u32; 2]]| {
            let n = items.len();
            hits.extend(w[..n].iter().map(|&[t, triangle]| Hit {
                t: f32::from_bits(t),
                triangle,
            }));
            if let Some(c) = counts.as_mut() {
                c.extend_from_slice(&w[n..2 * n]);
            }
            Ok(())
        };
        let gpu_ms = run_batches(ctx, &mut batch, &mut self.readback, plan, &progress, take)?;
        if hits.len() != rays.len() {
            return Err(Error::internal("GPU trace returned the wrong number of hits"));
        }
        Ok(GpuTrace { hits, counts, gpu_ms })
    }
}

/// Traces `rays` on the GPU (blocking) with a pass made for this call,
/// splitting them into batches that fit the device.
pub fn trace_rays(ctx: &GpuContext, tree: &GpuKdTree, rays: &[Ray], mode: TraceMode, t_max: f32) -> Result<GpuTrace> {
    TraceRaysBatches::new(ctx).trace(ctx, tree, rays, mode, t_max, usize::MAX)
}
