//! A Whitted animation: the frames of a camera path rendered in order,
//! with sums over them. What `raytrace --method whitted --frames N`
//! reports, and what a host engine calls to play a path.

use serde::Serialize;

use super::runner::{RayCounts, Rendered, WhittedRenderer, WhittedSettings};
use crate::error::{Error, Result};
use crate::progress::Bar;
use crate::scene::Camera;

/// Sums over the frames of a sequence.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SequenceReport {
    pub rays: RayCounts,
    pub render_ms: f64,
    pub frame_ms: Vec<f64>,
    /// All rays per second of `render_ms`.
    pub mrays_per_s: f64,
}

impl RayCounts {
    fn add(&mut self, other: &RayCounts) {
        self.primary += other.primary;
        self.shadow += other.shadow;
        self.reflection += other.reflection;
        self.refraction += other.refraction;
    }
}

impl WhittedRenderer {
    /// Renders `frames` frames of `width` x `height`, frame `f` through
    /// `camera(f)`; `on_frame` sees each frame (to write it); `progress`
    /// counts pixels. Returns the sums and the last frame.
    pub fn render_sequence(
        &mut self,
        frames: u32,
        camera: impl Fn(u32) -> Camera,
        (width, height): (u32, u32),
        settings: &WhittedSettings,
        progress: &Bar,
        mut on_frame: impl FnMut(u32, &Rendered) -> Result<()>,
    ) -> Result<(SequenceReport, Rendered)> {
        let mut report = SequenceReport::default();
        let mut last = None;
        for f in 0..frames {
            let image = self.render(&camera(f), width, height, settings, progress)?;
            if !self.is_gpu() {
                // The GPU pass advances the bar per batch; the CPU twin does not.
                progress.inc(width as u64 * height as u64);
            }
            report.render_ms += image.stats.render_ms;
            report.rays.add(&image.stats.rays);
            report.frame_ms.push(image.stats.render_ms);
            on_frame(f, &image)?;
            last = Some(image);
        }
        let last = last.ok_or_else(|| Error::param("frames", "must be at least 1"))?;
        report.mrays_per_s = crate::report::mrays_per_s(report.rays.total() as usize, report.render_ms);
        Ok((report, last))
    }
}
