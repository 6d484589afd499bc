//! GPU plumbing shared by every pass: the device context, bind-group
//! layouts, buffers kept and grown between calls, the one batch loop,
//! timestamp timing and the per-device pipeline cache.
//!
//! Passes (e.g. `kdtree::gpu::TraceRaysPass`) follow the glyphon / egui-wgpu
//! pattern: `new(device)` builds their bind group layouts and pipelines,
//! `prepare(device, queue, ...)` uploads into buffers they keep (grown, not
//! reallocated, per call), `record(encoder, ...)` only records into a
//! caller's `CommandEncoder`, so a host engine can embed them. `GpuContext`
//! adds the convenience of a headless device and the blocking helpers
//! (`batch::run_batches`) used by the method runners, the CLI and tests.

pub mod batch;
pub mod buffers;
pub(crate) mod capabilities;
mod context;
pub mod device;
pub mod kernels;
pub(crate) mod layout;
pub(crate) mod timer;
pub mod wgsl;

pub use context::{AdapterKinds, AdapterSettings, AdapterSummary, GpuContext, LimitsChoice, enumerate_adapters};

/// Workgroup size of every 1D kernel in `wgsl/`.
pub const WORKGROUP_SIZE: u32 = 64;

/// A 2D dispatch grid covering `invocations` threads of `WORKGROUP_SIZE`,
/// within the device's per-dimension workgroup limit. Returns
/// `(groups_x, groups_y, row_pitch)` where `row_pitch` is the number of
/// invocations per grid row (kernels compute `gid.x + gid.y * row_pitch`).
pub fn dispatch_grid(invocations: u32, max_per_dimension: u32) -> (u32, u32, u32) {
    let groups = invocations.div_ceil(WORKGROUP_SIZE).max(1);
    let x = groups.min(max_per_dimension);
    let y = groups.div_ceil(x);
    (x, y, x * WORKGROUP_SIZE)
}

#[cfg(test)]
mod tests {
    #[test]
    fn dispatch_grid_covers_and_respects_limits() {
        for n in [1u32, 63, 64, 65, 65535 * 64, 65535 * 64 + 1, 10_000_000] {
            let (x, y, pitch) = super::dispatch_grid(n, 65535);
            assert!(x <= 65535 && y <= 65535);
            assert!(x as u64 * y as u64 * 64 >= n as u64);
            assert_eq!(pitch, x * 64);
        }
    }
}
