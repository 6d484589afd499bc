//! GPU time of compute passes from timestamp queries, where the device has
//! them (lavapipe does); callers fall back to wall-clock time otherwise.

use crate::error::Result;
use crate::gpu::buffers::read_back;

/// Brackets compute passes with timestamps: pass `n` writes queries 2n, 2n+1.
pub struct PassTimer {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    capacity: u32,
    used: u32,
    period_ns: f32,
}

impl PassTimer {
    /// A timer for up to `passes` passes, or `None` without timestamp support.
    pub fn new(ctx: &crate::gpu::GpuContext, passes: u32) -> Option<PassTimer> {
        if !ctx.timestamps || passes == 0 {
            return None;
        }
        let count = 2 * passes;
        let bytes = count as u64 * 8;
        Some(PassTimer {
            query_set: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("penumbra pass timer"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolve: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp readback"),
                size: bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            capacity: passes,
            used: 0,
            period_ns: ctx.queue.get_timestamp_period(),
        })
    }

    /// Timestamp writes for the next pass (None once full).
    pub fn next_pass(&mut self) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        if self.used == self.capacity {
            return None;
        }
        let i = self.used;
        self.used += 1;
        Some(wgpu::ComputePassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(2 * i),
            end_of_pass_write_index: Some(2 * i + 1),
        })
    }

    /// Timestamp writes for the next render pass (None once full).
    pub fn next_render_pass(&mut self) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let w = self.next_pass()?;
        Some(wgpu::RenderPassTimestampWrites {
            query_set: w.query_set,
            beginning_of_pass_write_index: w.beginning_of_pass_write_index,
            end_of_pass_write_index: w.end_of_pass_write_index,
        })
    }

    /// Duration of each pass so far in milliseconds (after submission and
    /// `resolve`).
    pub fn pass_ms(&self, device: &wgpu::Device) -> Result<Vec<f64>> {
        let stamps: Vec<u64> = read_back(device, &self.readback, 2 * self.used as usize)?;
        Ok(stamps
            .chunks(2)
            .map(|p| p[1].saturating_sub(p[0]) as f64 * self.period_ns as f64 * 1e-6)
            .collect())
    }

    /// Starts over at the first pass, the earlier ones read (`total_ms`):
    /// a timer of one batch's passes serves every batch.
    pub fn restart(&mut self) {
        self.used = 0;
    }

    /// Records the resolve and copy; call once after the last pass.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        if self.used == 0 {
            return;
        }
        encoder.resolve_query_set(&self.query_set, 0..2 * self.used, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, self.used as u64 * 16);
    }

    /// Resolves the queries in a submission of their own and returns the
    /// passes' total in milliseconds; `None` without a timer.
    pub fn finish(timer: Option<PassTimer>, ctx: &crate::gpu::GpuContext) -> Result<Option<f64>> {
        let Some(timer) = timer else { return Ok(None) };
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        timer.resolve(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        timer.total_ms(&ctx.device).map(Some)
    }

    /// Sum of the passes' durations in milliseconds (after submission).
    pub fn total_ms(&self, device: &wgpu::Device) -> Result<f64> {
        if self.used == 0 {
            return Ok(0.0);
        }
        let stamps: Vec<u64> = read_back(device, &self.readback, 2 * self.used as usize)?;
        let ticks: u64 = stamps.chunks(2).map(|p| p[1].saturating_sub(p[0])).sum();
        Ok(ticks as f64 * self.period_ns as f64 * 1e-6)
    }
}
