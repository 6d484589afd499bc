//! A per-device cache of passes (their layouts and pipelines), so that
//! repeated calls on one `GpuContext` compile each kernel once, and the
//! pipelines themselves compiled only when a pass first records them: a
//! kernel set declares every entry point of its modules, a run pays only for
//! the ones it uses, and the context's `PipelineLog` says which those were
//! and what compiling them cost (apart from the passes' own timings).
//!
//! Creating a pipeline may return before the driver compiles it (lavapipe
//! builds its machine code at the first dispatch): on a context that owns
//! its queue (`GpuContext::headless`), each pipeline's first
//! `record_dispatch` also submits an empty dispatch of it over the same
//! bind groups and waits for it, so that cost lands in `compile_ms` and not
//! in the first timed pass.

use std::any::{Any, TypeId};
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use serde::Serialize;

use crate::gpu::wgsl::Composition;

#[derive(Default)]
pub(crate) struct KernelCache {
    passes: Mutex<HashMap<TypeId, Arc<dyn Any + Send + Sync>>>,
    pub(crate) log: Arc<PipelineLog>,
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
/// on a context (`cached`) for every later pass. `log` records which of
/// its pipelines get compiled (they compile on first use, see `Pipelines`).
pub trait Kernels: Any + Send + Sync + Sized {
    /// Builds the set's layouts and declares its pipelines on `device`;
    /// `log` records which of them get compiled (on first use).
    fn build(device: &wgpu::Device, log: &Arc<PipelineLog>) -> Self;

    /// The kernels cached on `ctx`, built on first use.
    fn cached(ctx: &crate::gpu::GpuContext) -> Arc<Self> {
        ctx.kernels.get_or_insert(|| Self::build(&ctx.device, &ctx.kernels.log))
    }
}

/// Which pipelines a device's kernel sets declared, which were compiled and
/// what each cost (shader module and pipeline creation, wall clock: on a
/// Vulkan driver this is where SPIR-V becomes machine code).
#[derive(Default)]
pub struct PipelineLog {
    entries: Mutex<Vec<LogEntry>>,
    /// The queue empty warm-up dispatches are submitted to; unset for a
    /// host's device, whose queue penumbra must not stall.
    warm_up: OnceLock<wgpu::Queue>,
}

struct LogEntry {
    name: String,
    compile_ms: Option<f64>,
}

/// What `PipelineLog::report` says (`pipelines` in the CLI's `--json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PipelineReport {
    /// Sum of the compiled pipelines' times.
    pub compile_ms: f64,
    /// The pipelines compiled, in the order their kernel sets declared them.
    pub compiled: Vec<CompiledPipeline>,
    /// Declared by a kernel set the run used, never needed.
    pub skipped: Vec<String>,
}

/// One compiled pipeline of a `PipelineReport`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CompiledPipeline {
    /// `module.entry_point`.
    pub name: String,
    /// Wall-clock milliseconds of creating the pipeline, and the shader
    /// module where this entry point was the first of its module to need
    /// it (or has a variant of its own), and of its empty warm-up dispatch
    /// where the context owns its queue (the driver's compile).
    pub ms: f64,
}

impl PipelineLog {
    /// Registers a pipeline (once per name); its index for `compiled`.
    fn declare(&self, name: String) -> usize {
        let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        match entries.iter().position(|e| e.name == name) {
            Some(i) => i,
            None => {
                entries.push(LogEntry { name, compile_ms: None });
                entries.len() - 1
            }
        }
    }

    /// Dispatches each pipeline once (empty) on `queue` before its first
    /// use, counting what the driver spends in `compile_ms`.
    pub(crate) fn warm_up_on(&self, queue: &wgpu::Queue) {
        let _ = self.warm_up.set(queue.clone());
    }

    fn compiled(&self, index: usize, ms: f64) {
        let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        let entry = &mut entries[index];
        entry.compile_ms = Some(entry.compile_ms.unwrap_or(0.0) + ms);
    }

    /// What was declared and compiled so far.
    pub fn report(&self) -> PipelineReport {
        let entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        let compiled: Vec<CompiledPipeline> = entries
            .iter()
            .filter_map(|e| {
                e.compile_ms.map(|ms| CompiledPipeline {
                    name: e.name.clone(),
                    ms,
                })
            })
            .collect();
        PipelineReport {
            compile_ms: compiled.iter().map(|c| c.ms).sum(),
            compiled,
            skipped: entries
                .iter()
                .filter(|e| e.compile_ms.is_none())
                .map(|e| e.name.clone())
                .collect(),
        }
    }
}

/// The compute pipelines of entry points of one composed WGSL module over
/// one pipeline layout (bind groups 0, 1, ...), each compiled on first
/// `get`: a frame that never runs a kernel never pays for it.
pub struct Pipelines {
    device: wgpu::Device,
    module: Composition,
    layout: wgpu::PipelineLayout,
    shader: OnceLock<wgpu::ShaderModule>,
    entries: Vec<(&'static str, usize, OnceLock<wgpu::ComputePipeline>)>,
    /// Per entry point, whether its empty warm-up dispatch has run.
    warmed: Vec<OnceLock<()>>,
    /// Per entry point, the variant of the module it is compiled from,
    /// where it has its own.
    variants: Vec<Option<Composition>>,
    log: Arc<PipelineLog>,
}

/// One entry point of a `Pipelines`, as `record_dispatch` records it.
#[derive(Clone, Copy)]
pub struct Kernel<'a> {
    pipelines: &'a Pipelines,
    index: usize,
}

impl<'a> Kernel<'a> {
    /// The compute pipeline, compiled now if it was not yet.
    pub fn pipeline(&self) -> &'a wgpu::ComputePipeline {
        self.pipelines.pipeline(self.index)
    }

    /// Submits an empty dispatch of the pipeline over `bind_groups` and
    /// waits for it, once per entry point, where the log has a queue: the
    /// driver's own compile then happens here, timed into `compile_ms`.
    fn warm_up(&self, bind_groups: &[&wgpu::BindGroup]) {
        let p = self.pipelines;
        let Some(queue) = p.log.warm_up.get() else {
            return;
        };
        p.warmed[self.index].get_or_init(|| {
            let pipeline = self.pipeline();
            let start = Instant::now();
            let mut encoder = p.device.create_command_encoder(&Default::default());
            record_pass(&mut encoder, "warm-up", None, pipeline, bind_groups, (0, 0));
            queue.submit([encoder.finish()]);
            // A failed wait shows up again, and is reported, at the real
            // dispatch's read-back.
            let _ = p.device.poll(wgpu::PollType::wait_indefinitely());
            p.log
                .compiled(p.entries[self.index].1, crate::gpu::device::elapsed_ms(start));
        });
    }
}

impl Pipelines {
    /// Entry point `i` (in the order given to `compute_pipelines`), for
    /// `record_dispatch`.
    pub fn get(&self, i: usize) -> Kernel<'_> {
        Kernel {
            pipelines: self,
            index: i,
        }
    }

    /// The pipeline of entry point `i`, compiled now if it was not yet.
    pub fn pipeline(&self, i: usize) -> &wgpu::ComputePipeline {
        let (entry, logged, cell) = &self.entries[i];
        cell.get_or_init(|| {
            let start = Instant::now();
            let compile = |m: &Composition| {
                self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(m.name),
                    source: wgpu::ShaderSource::Wgsl(m.source().into()),
                })
            };
            let own = self.variants[i].as_ref().map(compile);
            let shader = own
                .as_ref()
                .unwrap_or_else(|| self.shader.get_or_init(|| compile(&self.module)));
            let pipeline = self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&self.layout),
                module: shader,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
            self.log.compiled(*logged, crate::gpu::device::elapsed_ms(start));
            pipeline
        })
    }

    /// Compiles entry point `i` from `variant` (the same bindings) instead
    /// of the module (before its first `get`): where one entry needs code
    /// the others must not carry.
    pub fn set_variant(&mut self, i: usize, variant: Composition) {
        debug_assert!(!self.is_compiled(i));
        self.variants[i] = Some(variant);
    }

    /// Whether entry point `i` has been compiled.
    pub fn is_compiled(&self, i: usize) -> bool {
        self.entries[i].2.get().is_some()
    }
}

/// Declares one compute pipeline per entry point of a composed WGSL module,
/// sharing a pipeline layout made of `layouts` (bind groups 0, 1, ...);
/// each compiles on its first use (`Pipelines::get`).
pub fn compute_pipelines(
    device: &wgpu::Device,
    module: &Composition,
    layouts: &[&wgpu::BindGroupLayout],
    entry_points: &[&'static str],
    log: &Arc<PipelineLog>,
) -> Pipelines {
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(|l| Some(*l)).collect();
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(module.name),
        bind_group_layouts: &layouts,
        immediate_size: 0,
    });
    let entries = entry_points
        .iter()
        .map(|&e| (e, log.declare(format!("{}.{e}", module.name)), OnceLock::new()))
        .collect();
    Pipelines {
        device: device.clone(),
        module: *module,
        layout,
        shader: OnceLock::new(),
        variants: vec![None; entry_points.len()],
        warmed: entry_points.iter().map(|_| OnceLock::new()).collect(),
        entries,
        log: Arc::clone(log),
    }
}

/// Records one compute pass: `kernel` with bind groups 0, 1, ... over a
/// 2D grid of workgroups (from `gpu::dispatch_grid`). A kernel's first
/// dispatch on a headless context is preceded by its warm-up (see the
/// module's doc), submitted and waited for apart from `encoder`.
pub fn record_dispatch(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    kernel: Kernel<'_>,
    bind_groups: &[&wgpu::BindGroup],
    grid: (u32, u32),
) {
    kernel.warm_up(bind_groups);
    record_pass(encoder, label, timestamp_writes, kernel.pipeline(), bind_groups, grid);
}

fn record_pass(
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
