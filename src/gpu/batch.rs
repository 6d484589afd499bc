//! The one batch loop of every pass whose work can exceed what a device
//! takes at once (a storage binding, a dispatch grid, a dispatch short
//! enough for a software rasteriser): the items are split into batches, and
//! each batch is prepared (uploaded into the pass's kept buffers), recorded,
//! copied into a kept read-back buffer, submitted and read.

use std::ops::Range;
use std::sync::Arc;

use bytemuck::Pod;

use crate::error::Result;
use crate::gpu::GpuContext;
use crate::gpu::buffers::{GrowingBuffer, read_back};
use crate::gpu::kernels::Kernels;
use crate::gpu::timer::PassTimer;
use crate::progress::Progress;

/// A pass that runs over a request's items a batch at a time.
pub trait BatchPass {
    /// Uploads the inputs of `items` (a range of the whole request) into the
    /// pass's kept buffers.
    fn prepare(&mut self, ctx: &GpuContext, items: Range<usize>) -> Result<()>;

    /// Records the batch's dispatches, each with the next timestamp writes
    /// of `timer`.
    fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &mut Option<PassTimer>);

    /// The buffers holding the batch's results and how many bytes of each,
    /// read back one after another.
    fn results(&self) -> Vec<(&wgpu::Buffer, u64)>;
}

/// How a request is split: `items` in batches of at most `per_batch`, each
/// batch recording `dispatches` timed passes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BatchPlan {
    pub items: usize,
    pub per_batch: usize,
    pub dispatches: u32,
}

impl BatchPlan {
    pub fn new(items: usize, per_batch: usize, dispatches: u32) -> BatchPlan {
        BatchPlan {
            items,
            per_batch: per_batch.max(1),
            dispatches,
        }
    }

    pub fn batches(&self) -> usize {
        self.items.div_ceil(self.per_batch)
    }

    fn ranges(&self) -> impl Iterator<Item = Range<usize>> + '_ {
        (0..self.batches()).map(|b| b * self.per_batch..((b + 1) * self.per_batch).min(self.items))
    }
}

/// A kept read-back buffer for `run_batches`.
pub fn readback_buffer() -> GrowingBuffer {
    GrowingBuffer::new("readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST)
}

/// A pass built from kernels that are cached per device: `new` for a
/// host's device, `for_context` from a context's cache.
pub trait Pass: Sized {
    type Kernels: Kernels;

    /// A pass (with empty kept buffers) over kernels built before.
    fn with_kernels(device: &wgpu::Device, kernels: Arc<Self::Kernels>) -> Self;

    /// Builds the kernels for `device` (a host's: what they compile is
    /// logged nowhere; use `with_kernels` and `Kernels::build` to see it).
    fn new(device: &wgpu::Device) -> Self {
        let log = Arc::default();
        Self::with_kernels(device, Arc::new(Self::Kernels::build(device, &log)))
    }

    /// A pass over the kernels cached on `ctx`.
    fn for_context(ctx: &GpuContext) -> Self {
        Self::with_kernels(&ctx.device, Self::Kernels::cached(ctx))
    }
}

/// A pass with the read-back buffer of its batches: what a runner keeps on
/// a device to serve many requests without reallocating.
pub struct Batched<P> {
    pub pass: P,
    pub(crate) readback: GrowingBuffer,
}

impl<P> Batched<P> {
    pub fn with_pass(pass: P) -> Batched<P> {
        Batched {
            pass,
            readback: readback_buffer(),
        }
    }
}

impl<P: Pass> Batched<P> {
    /// The pass over the kernels cached on `ctx`.
    pub fn new(ctx: &GpuContext) -> Batched<P> {
        Self::with_pass(P::for_context(ctx))
    }
}

/// Runs `pass` over the plan's batches, handing each batch's results (as
/// `T`, the result buffers one after another) to `take` with the batch's
/// item range, and advancing `progress` by the batch's items. Returns the
/// passes' total time from timestamp queries, where the device has them.
pub fn run_batches<T: Pod>(
    ctx: &GpuContext,
    pass: &mut impl BatchPass,
    readback: &mut GrowingBuffer,
    plan: BatchPlan,
    progress: &Progress,
    mut take: impl FnMut(Range<usize>, &[T]) -> Result<()>,
) -> Result<Option<f64>> {
    let mut timer = PassTimer::new(ctx, plan.batches() as u32 * plan.dispatches);
    for items in plan.ranges() {
        pass.prepare(ctx, items.clone())?;
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        pass.record(&mut encoder, &mut timer);
        let results = pass.results();
        let total: u64 = results.iter().map(|(_, bytes)| bytes).sum();
        readback.reserve(&ctx.device, total)?;
        let mut at = 0;
        for (buffer, bytes) in results {
            encoder.copy_buffer_to_buffer(buffer, 0, readback.get(), at, bytes);
            at += bytes;
        }
        ctx.queue.submit([encoder.finish()]);
        let len = total as usize / std::mem::size_of::<T>();
        let values: Vec<T> = read_back(&ctx.device, readback.get(), len)?;
        progress.inc(items.len() as u64);
        take(items, &values)?;
    }
    PassTimer::finish(timer, ctx)
}

#[cfg(test)]
mod tests {
    use super::BatchPlan;

    #[test]
    fn plans_cover_every_item_once() {
        for (items, per) in [(0, 5), (1, 5), (10, 5), (11, 5), (7, 100)] {
            let plan = BatchPlan::new(items, per, 1);
            let ranges: Vec<_> = plan.ranges().collect();
            assert_eq!(ranges.len(), plan.batches());
            let covered: Vec<usize> = ranges.into_iter().flatten().collect();
            assert_eq!(covered, (0..items).collect::<Vec<_>>());
        }
    }
}
