//! The one shape of every pass that traverses the kd-tree (`trace_rays`,
//! `ao_rays`, `packet_traverse`): kernels over bind group 0 (the tree) and
//! one io bind group of buffers the pass keeps between calls; each
//! `prepare` writes a batch's inputs, picks the entry point and grid, and
//! says which bindings hold the results; `record` only records.

use std::ops::Range;
use std::sync::Arc;

use super::gpu::{GpuKdTree, kdtree_bind_group_layout};
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::gpu::batch::{BatchPass, Pass};
use crate::gpu::buffers::KeptGroup;
use crate::gpu::kernels::{Kernels, PipelineLog, Pipelines, compute_pipelines, record_dispatch};
use crate::gpu::layout::{Io, io_layout};
use crate::gpu::timer::PassTimer;
use crate::gpu::wgsl::Composition;

/// Pipelines over the kd-tree (bind group 0) with one io bind group (1).
pub struct TreeKernels {
    pub io_layout: wgpu::BindGroupLayout,
    pub pipelines: Pipelines,
}

impl TreeKernels {
    /// The pipelines of `entry_points` of `module`, with bind group 1 laid
    /// out as `io`.
    pub fn build(
        device: &wgpu::Device,
        module: &Composition,
        io: &[Io],
        entry_points: &[&'static str],
        log: &Arc<PipelineLog>,
    ) -> TreeKernels {
        let io_layout = io_layout(device, module.name, io);
        let layouts = [&kdtree_bind_group_layout(device), &io_layout];
        let pipelines = compute_pipelines(device, module, &layouts, entry_points, log);
        TreeKernels { io_layout, pipelines }
    }
}

/// One WGSL module's tree kernels: its io bind group and entry points.
pub trait TreeKernelSet: Kernels {
    const IO: &'static [Io];
    /// Names the io group and the dispatches.
    const LABEL: &'static str;
    fn tree_kernels(&self) -> &TreeKernels;
}

/// A pass of a `TreeKernelSet`: its kernels and the kept buffers of one batch.
pub struct TreePass<K> {
    kernels: Arc<K>,
    io: KeptGroup,
    entry: usize,
    grid: (u32, u32),
    /// A binding the kernel ORs into, cleared before the dispatch.
    clear: Option<u32>,
    /// The bindings holding the batch's results, and their bytes.
    results: Vec<(u32, u64)>,
}

impl<K: TreeKernelSet> Pass for TreePass<K> {
    type Kernels = K;

    fn with_kernels(device: &wgpu::Device, kernels: Arc<K>) -> TreePass<K> {
        TreePass {
            kernels,
            io: KeptGroup::for_io(device, K::LABEL, K::IO),
            entry: 0,
            grid: (0, 0),
            clear: None,
            results: Vec::new(),
        }
    }
}

/// What a prepared batch dispatches.
pub(crate) struct Dispatch {
    /// Index of the entry point in the kernel set.
    pub entry: usize,
    pub grid: (u32, u32),
    pub clear: Option<u32>,
    pub results: Vec<(u32, u64)>,
}

impl<K: TreeKernelSet> TreePass<K> {
    /// The io buffers, for a `prepare` to write.
    pub(crate) fn io(&mut self) -> &mut KeptGroup {
        &mut self.io
    }

    /// Ends a `prepare`: rebuilds the bind group if a buffer grew and
    /// remembers what to dispatch.
    pub(crate) fn set_dispatch(&mut self, device: &wgpu::Device, d: Dispatch) {
        self.io.update(device, &self.kernels.tree_kernels().io_layout);
        self.entry = d.entry;
        self.grid = d.grid;
        self.clear = d.clear;
        self.results = d.results;
    }

    /// Records the prepared dispatch into the caller's encoder.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
        tree: &GpuKdTree,
    ) {
        if let Some(b) = self.clear {
            encoder.clear_buffer(self.io.buffer(b), 0, None);
        }
        let pipeline = self.kernels.tree_kernels().pipelines.get(self.entry);
        let groups = [&tree.bind_group, self.io.group()];
        record_dispatch(encoder, K::LABEL, timestamp_writes, pipeline, &groups, self.grid);
    }

    /// The buffer of io binding `binding`.
    pub fn buffer(&self, binding: u32) -> &wgpu::Buffer {
        self.io.buffer(binding)
    }

    /// The prepared batch's result buffers and their bytes.
    pub fn results(&self) -> Vec<(&wgpu::Buffer, u64)> {
        self.results
            .iter()
            .map(|&(b, bytes)| (self.io.buffer(b), bytes))
            .collect()
    }
}

/// A request over a tree pass, a batch at a time: `prepare` uploads a
/// batch's items into the pass.
pub(crate) struct TreeBatch<'a, K, F> {
    pub pass: &'a mut TreePass<K>,
    pub tree: &'a GpuKdTree,
    pub prepare: F,
}

impl<K, F> BatchPass for TreeBatch<'_, K, F>
where
    K: TreeKernelSet,
    F: FnMut(&mut TreePass<K>, &GpuContext, Range<usize>) -> Result<()>,
{
    fn prepare(&mut self, ctx: &GpuContext, items: Range<usize>) -> Result<()> {
        (self.prepare)(self.pass, ctx, items)
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &mut Option<PassTimer>) {
        self.pass
            .record(encoder, timer.as_mut().and_then(|t| t.next_pass()), self.tree);
    }

    fn results(&self) -> Vec<(&wgpu::Buffer, u64)> {
        self.pass.results()
    }
}
