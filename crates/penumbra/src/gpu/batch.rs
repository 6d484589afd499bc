//! The one batch loop of every pass whose work can exceed what a device
//! takes at once (a storage binding, a dispatch grid, a dispatch short
//! enough for a software rasteriser): the items are split into batches, and
//! each batch is prepared (uploaded into the pass's kept buffers), recorded,
//! copied into a kept read-back buffer, submitted and read.

use std::ops::Range;
use std::sync::Arc;
use std::time::{Duration, Instant};

use bytemuck::Pod;

use crate::error::Result;
use crate::gpu::GpuContext;
use crate::gpu::buffers::{GrowingBuffer, read_back};
use crate::gpu::kernels::Kernels;
use crate::gpu::timer::PassTimer;
use crate::progress::Bar;

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
    /// Items of the whole request.
    pub items: usize,
    /// Most items in one batch (at least 1).
    pub per_batch: usize,
    /// Timed passes each batch records: the timestamp pairs its timer holds.
    pub dispatches: u32,
}

impl BatchPlan {
    /// A plan; a `per_batch` of 0 is taken as 1.
    pub fn new(items: usize, per_batch: usize, dispatches: u32) -> BatchPlan {
        BatchPlan {
            items,
            per_batch: per_batch.max(1),
            dispatches,
        }
    }
}

/// The most items one batch may hold on `device`: for each storage
/// binding of a batch, `per_item` bytes an item, within one binding; and
/// `read_back` bytes an item (its results, read back together) within one
/// buffer. At least one.
pub fn fit_items(device: &wgpu::Device, per_item: &[u64], read_back: u64) -> usize {
    let limits = device.limits();
    let binding = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
    let largest = per_item.iter().copied().max().unwrap_or(1).max(1);
    (binding / largest)
        .min(limits.max_buffer_size / read_back.max(1))
        .max(1) as usize
}

/// A kept read-back buffer for `run_batches`.
pub fn readback_buffer() -> GrowingBuffer {
    GrowingBuffer::new("readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST)
}

/// A pass built from kernels that are cached per device: `new` for a
/// host's device, `for_context` from a context's cache.
pub trait Pass: Sized {
    /// The pass's pipelines and layouts, built once per device.
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
    /// The pass itself, for a caller that records it into its own encoder.
    pub pass: P,
    pub(crate) readback: GrowingBuffer,
}

impl<P> Batched<P> {
    /// `pass` with an empty read-back buffer.
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

/// Runs `pass` over the plan's items, handing each batch's results (as
/// `T`, the result buffers one after another) to `take` with the batch's
/// item range, and advancing `progress` by the batch's items. Batches are
/// sized by `BatchSizer` (never above the plan's `per_batch`), so a progress
/// bar moves a few times a second even where one full batch takes seconds
/// (a software rasteriser). Returns the passes' total time from timestamp
/// queries, where the device has them.
pub fn run_batches<T: Pod>(
    ctx: &GpuContext,
    pass: &mut impl BatchPass,
    readback: &mut GrowingBuffer,
    plan: BatchPlan,
    progress: &Bar,
    mut take: impl FnMut(Range<usize>, &[T]) -> Result<()>,
) -> Result<Option<f64>> {
    // One batch's passes at a time: the timer is read with each batch, so
    // its query set never runs out however many batches the sizer makes.
    let mut timer = PassTimer::new(ctx, plan.dispatches);
    let mut gpu_ms = 0.0;
    let mut sizer = BatchSizer::new(plan.per_batch);
    let mut start = 0;
    while start < plan.items {
        let items = start..(start + sizer.next_size()).min(plan.items);
        let began = Instant::now();
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
        if let Some(timer) = &timer {
            timer.resolve(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        let len = total as usize / std::mem::size_of::<T>();
        let values: Vec<T> = read_back(&ctx.device, readback.get(), len)?;
        if let Some(timer) = &mut timer {
            gpu_ms += timer.total_ms(&ctx.device)?;
            timer.restart();
        }
        sizer.observe(items.len(), began.elapsed());
        progress.inc(items.len() as u64);
        start = items.end;
        take(items, &values)?;
    }
    Ok(timer.map(|_| gpu_ms))
}

/// Sizes batches by time: the first is a 64th of the largest the device
/// takes, and each next one aims at `TARGET` from the items per second seen
/// so far (growing at most 4 times a step), capped at the largest. Which
/// items go together never changes a result; it only decides how often a
/// progress bar moves and how long one dispatch may run.
#[derive(Debug, Clone)]
pub struct BatchSizer {
    largest: usize,
    size: usize,
}

impl BatchSizer {
    /// About how long one batch should take.
    pub const TARGET: Duration = Duration::from_millis(250);

    /// A sizer whose batches never exceed `largest` items (at least 1).
    pub fn new(largest: usize) -> BatchSizer {
        let largest = largest.max(1);
        BatchSizer {
            largest,
            size: largest.div_ceil(64),
        }
    }

    /// How many items the next batch takes.
    pub fn next_size(&self) -> usize {
        self.size
    }

    /// Learns from a batch of `items` that took `took`.
    pub fn observe(&mut self, items: usize, took: Duration) {
        let secs = took.as_secs_f64().max(1e-6);
        let wanted = items as f64 * Self::TARGET.as_secs_f64() / secs;
        let grown = (self.size as f64 * 4.0).min(wanted);
        self.size = (grown as usize).clamp(1, self.largest);
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::BatchSizer;

    /// Runs the sizer over `items` as `run_batches` does, each item taking
    /// `per_item`; returns the batch sizes.
    fn sizes(items: usize, largest: usize, per_item: Duration) -> Vec<usize> {
        let mut sizer = BatchSizer::new(largest);
        let mut start = 0;
        let mut out = Vec::new();
        while start < items {
            let n = sizer.next_size().min(items - start);
            sizer.observe(n, per_item * n as u32);
            out.push(n);
            start += n;
        }
        out
    }

    #[test]
    fn batches_cover_every_item_once_within_the_largest() {
        for (items, largest) in [(0, 5), (1, 5), (10, 5), (11, 5), (7, 100), (100_000, 16_384)] {
            for per_item in [Duration::ZERO, Duration::from_micros(50), Duration::from_secs(1)] {
                let sizes = sizes(items, largest, per_item);
                assert_eq!(sizes.iter().sum::<usize>(), items);
                assert!(sizes.iter().all(|&n| (1..=largest).contains(&n)), "{sizes:?}");
            }
        }
    }

    #[test]
    fn slow_items_make_small_batches_and_fast_ones_the_largest() {
        // 1 ms an item: a quarter-second batch is 250 items, not 16,384.
        let slow = sizes(20_000, 16_384, Duration::from_millis(1));
        assert_eq!(slow[0], 256);
        assert!(slow[1..slow.len() - 1].iter().all(|&n| n == 250), "{slow:?}");
        // 1 us an item: the batches grow fourfold to the device's largest.
        let fast = sizes(100_000, 16_384, Duration::from_micros(1));
        assert_eq!(&fast[..4], &[256, 1024, 4096, 16_384]);
    }
}
