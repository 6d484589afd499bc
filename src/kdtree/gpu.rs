//! The kd-tree on the GPU: its three arrays uploaded as they are, and the
//! `trace_rays.wgsl` pass (closest hit, any hit, closest hit with counters).

use std::time::Instant;

use bytemuck::{Pod, Zeroable};

use super::KdTree;
use crate::error::{Error, Result};
use crate::gpu::buffers::{read_back, storage_buffer, uniform_buffer, zeroed_buffer};
use crate::gpu::kernels::record_dispatch;
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, dispatch_grid};
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

pub(crate) fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Layout of bind group 0 of every kernel that traverses the tree. Layouts
/// with equal entries are interchangeable, so any pass's copy will do.
pub fn kdtree_bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("kd-tree"),
        entries: &[
            storage_entry(0, true),
            storage_entry(1, true),
            storage_entry(2, true),
            uniform_entry(3),
        ],
    })
}

pub(crate) fn bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<_> = buffers
        .iter()
        .map(|&(binding, b)| wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
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
        let layout = kdtree_bind_group_layout(device);
        let bind_group = bind_group(
            device,
            "kd-tree",
            &layout,
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

/// The ray-tracing pass: layouts and pipelines for one device.
pub struct TraceRaysPass {
    pub io_layout: wgpu::BindGroupLayout,
    closest: wgpu::ComputePipeline,
    any: wgpu::ComputePipeline,
    counted: wgpu::ComputePipeline,
}

impl TraceRaysPass {
    pub fn new(device: &wgpu::Device) -> TraceRaysPass {
        let scene_layout = kdtree_bind_group_layout(device);
        // rays (read), hits (write), params (uniform), counts (write)
        let io_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("trace rays io"),
            entries: &[
                storage_entry(0, true),
                storage_entry(1, false),
                uniform_entry(2),
                storage_entry(3, false),
            ],
        });
        let pipelines = crate::gpu::kernels::compute_pipelines(
            device,
            &crate::wgsl::TRACE_RAYS_MODULE,
            &[&scene_layout, &io_layout],
            &["trace_closest", "trace_any", "trace_closest_counted"],
        );
        let [closest, any, counted] = pipelines.try_into().expect("three entry points");
        TraceRaysPass {
            io_layout,
            closest,
            any,
            counted,
        }
    }

    /// Bind group 1: rays (6 f32 each), hits (2 u32 each), params, counts.
    pub fn io_bind_group(
        &self,
        device: &wgpu::Device,
        rays: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        params: &wgpu::Buffer,
        counts: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        bind_group(
            device,
            "trace rays io",
            &self.io_layout,
            &[(0, rays), (1, hits), (2, params), (3, counts)],
        )
    }

    /// Records one dispatch over `params.ray_count` rays into the caller's
    /// encoder. `grid` comes from `dispatch_grid` (its row pitch must be in
    /// the params).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
        tree: &GpuKdTree,
        io: &wgpu::BindGroup,
        mode: TraceMode,
        grid: (u32, u32),
    ) {
        let pipeline = match mode {
            TraceMode::Closest => &self.closest,
            TraceMode::Any => &self.any,
            TraceMode::ClosestCounted => &self.counted,
        };
        record_dispatch(
            encoder,
            "trace rays",
            timestamp_writes,
            pipeline,
            &[&tree.bind_group, io],
            grid,
        );
    }
}

/// What a blocking GPU trace returns.
pub struct GpuTrace {
    pub hits: Vec<Hit>,
    /// Per ray (traversal steps, intersection tests), in `ClosestCounted` mode.
    pub counts: Option<Vec<[u32; 2]>>,
    /// Kernel time from timestamp queries, where supported.
    pub gpu_ms: Option<f64>,
    /// Wall time of upload, kernels and readback.
    pub wall_ms: f64,
}

/// Largest batch of rays per dispatch: the device's storage-binding limit for
/// the rays, and a cap that keeps a single dispatch short.
fn batch_size(device: &wgpu::Device) -> usize {
    let limits = device.limits();
    let max_binding = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
    ((max_binding / 24) as usize).clamp(1, 1 << 22)
}

/// Traces `rays` on the GPU (blocking), splitting them into batches that fit
/// the device. Directions need not be normalised; hits are in t units of the
/// given direction, with `0 < t < t_max`.
pub fn trace_rays(ctx: &GpuContext, tree: &GpuKdTree, rays: &[Ray], mode: TraceMode, t_max: f32) -> Result<GpuTrace> {
    trace_rays_batched(ctx, tree, rays, mode, t_max, batch_size(&ctx.device))
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
    let start = Instant::now();
    let device = &ctx.device;
    let pass = ctx.kernels.get_or_insert(|| TraceRaysPass::new(device));
    let batch = max_batch.clamp(1, batch_size(device)).min(rays.len().max(1));
    let batches = rays.len().div_ceil(batch);
    let counted = mode == TraceMode::ClosestCounted;
    let ray_buf = zeroed_buffer(
        device,
        "rays",
        (batch * 24) as u64,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
    );
    let hit_buf = zeroed_buffer(
        device,
        "hits",
        (batch * 8) as u64,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    let count_bytes = if counted { (batch * 8) as u64 } else { 8 };
    let count_buf = zeroed_buffer(
        device,
        "trace counts",
        count_bytes,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    let readback = zeroed_buffer(
        device,
        "hits readback",
        (batch * 8) as u64 + if counted { count_bytes } else { 0 },
        wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
    );
    let params_buf = uniform_buffer(device, "trace params", &TraceParams::zeroed());
    let io = pass.io_bind_group(device, &ray_buf, &hit_buf, &params_buf, &count_buf);
    let mut timer = PassTimer::new(ctx, batches as u32);
    let max_dim = device.limits().max_compute_workgroups_per_dimension;
    let t_max = if t_max.is_finite() { t_max } else { f32::MAX };

    let mut hits = Vec::with_capacity(rays.len());
    let mut counts = counted.then(|| Vec::with_capacity(rays.len()));
    for chunk in rays.chunks(batch) {
        let n = chunk.len();
        let (gx, gy, pitch) = dispatch_grid(n as u32, max_dim);
        ctx.queue.write_buffer(&ray_buf, 0, bytemuck::cast_slice(chunk));
        let params = TraceParams {
            ray_count: n as u32,
            row_pitch: pitch,
            t_max,
            _pad: 0,
        };
        ctx.queue.write_buffer(&params_buf, 0, bytemuck::bytes_of(&params));
        let mut encoder = device.create_command_encoder(&Default::default());
        pass.record(
            &mut encoder,
            timer.as_mut().and_then(|t| t.next_pass()),
            tree,
            &io,
            mode,
            (gx, gy),
        );
        encoder.copy_buffer_to_buffer(&hit_buf, 0, &readback, 0, (n * 8) as u64);
        if counted {
            encoder.copy_buffer_to_buffer(&count_buf, 0, &readback, (batch * 8) as u64, (n * 8) as u64);
        }
        ctx.queue.submit([encoder.finish()]);
        let words: Vec<[u32; 2]> = read_back(device, &readback, batch + if counted { n } else { 0 })?;
        hits.extend(words[..n].iter().map(|&[t, triangle]| Hit {
            t: f32::from_bits(t),
            triangle,
        }));
        if let Some(c) = counts.as_mut() {
            c.extend_from_slice(&words[batch..batch + n]);
        }
    }
    let gpu_ms = PassTimer::finish(timer, ctx)?;
    if hits.len() != rays.len() {
        return Err(Error::internal("GPU trace returned the wrong number of hits"));
    }
    Ok(GpuTrace {
        hits,
        counts,
        gpu_ms,
        wall_ms: start.elapsed().as_secs_f64() * 1e3,
    })
}
