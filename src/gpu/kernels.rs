//! A per-device cache of passes (their layouts and pipelines), so that
//! repeated calls on one `GpuContext` compile each kernel once.

use std::any::{Any, TypeId};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

#[derive(Default)]
pub(crate) struct KernelCache {
    passes: Mutex<HashMap<TypeId, Arc<dyn Any + Send + Sync>>>,
}

impl KernelCache {
    /// The cached `T`, built with `make` on first use.
    pub(crate) fn get_or_insert<T: Any + Send + Sync>(&self, make: impl FnOnce() -> T) -> Arc<T> {
        let mut passes = self.passes.lock().unwrap_or_else(|e| e.into_inner());
        let entry = passes
            .entry(TypeId::of::<T>())
            .or_insert_with(|| Arc::new(make()) as Arc<dyn Any + Send + Sync>);
        Arc::clone(entry)
            .downcast::<T>()
            .expect("cache entry has the type of its key")
    }
}

/// A set of layouts and pipelines for one device, built once and cached
/// on a context (`cached`) for every later pass.
pub trait Kernels: Any + Send + Sync + Sized {
    fn build(device: &wgpu::Device) -> Self;

    /// The kernels cached on `ctx`, built on first use.
    fn cached(ctx: &crate::gpu::GpuContext) -> Arc<Self> {
        ctx.kernels.get_or_insert(|| Self::build(&ctx.device))
    }
}

/// Builds one compute pipeline per entry point of a composed WGSL module,
/// sharing a pipeline layout made of `layouts` (bind groups 0, 1, ...).
pub fn compute_pipelines(
    device: &wgpu::Device,
    module: &crate::wgsl::Composition,
    layouts: &[&wgpu::BindGroupLayout],
    entry_points: &[&str],
) -> Vec<wgpu::ComputePipeline> {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(module.name),
        source: wgpu::ShaderSource::Wgsl(module.source().into()),
    });
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(|l| Some(*l)).collect();
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(module.name),
        bind_group_layouts: &layouts,
        immediate_size: 0,
    });
    entry_points
        .iter()
        .map(|entry| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&layout),
                module: &shader,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        })
        .collect()
}

/// Records one compute pass: `pipeline` with bind groups 0, 1, ... over a
/// 2D grid of workgroups (from `gpu::dispatch_grid`).
pub fn record_dispatch(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    pipeline: &wgpu::ComputePipeline,
    bind_groups: &[&wgpu::BindGroup],
    grid: (u32, u32),
) {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes,
    });
    pass.set_pipeline(pipeline);
    for (i, group) in bind_groups.iter().enumerate() {
        pass.set_bind_group(i as u32, *group, &[]);
    }
    pass.dispatch_workgroups(grid.0, grid.1, 1);
}
