//! A bounded-error animation: the frames of a camera path rendered in
//! order (so each reprojects the last one's cells, the paper's section 6),
//! each optionally measured against the exact Whitted frame and against
//! random lines in its cells. What `raytrace --method bounded` reports,
//! and what a host engine calls to play a path.

use std::collections::BTreeMap;

use serde::Serialize;

use super::frame::{BoundedFrame, FrameStats};
use super::measure::{CheckStats, ErrorStats, compare};
use super::runner::BoundedRenderer;
use crate::error::{Error, Result};
use crate::progress::Bar;
use crate::scene::Camera;

/// What to measure on every frame besides rendering it.
#[derive(Debug, Clone, Copy, Default)]
pub struct Measures {
    /// Render every frame exactly too: error and speed-up.
    pub reference: bool,
    /// Random lines traced per accepted cell a frame uses (`None`: no check).
    pub check_lines: Option<u32>,
    /// Seed of the check's lines (xor-ed with the frame number).
    pub seed: u32,
}

/// What `Measures` asked for, of one frame or summed over a sequence
/// (absent fields were not asked for).
#[derive(Debug, Clone, Default, Serialize)]
pub struct Measured {
    /// The exact (Whitted) renders' time in milliseconds, each the
    /// renderer's own `render_ms`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_ms: Option<f64>,
    /// `reference_ms` over the bounded renders' time: how many times
    /// faster the bounded frames were.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speedup: Option<f64>,
    /// Over a sequence: the worst frame (`mean_rel`: mean of the frames' means).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<ErrorStats>,
    /// The random lines' check (`Measures::check_lines`); over a sequence,
    /// summed (`max_rel`: the worst frame's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub check: Option<CheckStats>,
}

/// One frame's statistics and measures.
#[derive(Debug, Clone, Serialize)]
pub struct FrameReport {
    /// What the frame did and cost.
    #[serde(flatten)]
    pub stats: FrameStats,
    /// What was measured of it.
    #[serde(flatten)]
    pub measured: Measured,
}

/// Rays by kind over the sequence.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SequenceRays {
    /// Rays the slow path traced: every ray of each traced pixel's ray
    /// tree (primary, shadow, reflected and refracted).
    pub slow_path: u64,
    /// Extremal rays traced (each counted once, not its ray tree's rays).
    pub extremal: u64,
    /// Extremal rays whose trees the Whitted kernel traced (`whitted_trees`).
    pub extremal_on_gpu: u64,
    /// Where the slow path traced: "gpu" (the Whitted kernel) or "cpu"
    /// (`SlowPath` resolved for the renderer's device).
    pub slow_path_on: &'static str,
}

/// Sums over the frames of a sequence.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SequenceReport {
    /// The frames' `frame_ms` summed: wall-clock milliseconds of rendering,
    /// measures and writing left out.
    pub render_ms: f64,
    /// Each frame's `frame_ms`, in order.
    pub frame_ms: Vec<f64>,
    /// Pixels by path (`traced_<reason>` for each reason a pixel was traced).
    pub pixels: BTreeMap<String, u64>,
    /// Interpolated (built, reprojected or span-filled) pixels among those
    /// that hit a surface.
    pub success_rate: f64,
    /// The frames' `FrameStats::extremal_rays_requested` summed.
    pub extremal_rays_requested: u64,
    /// The frames' `FrameStats::extremal_rays_traced` summed.
    pub extremal_rays_traced: u64,
    /// The frames' `FrameStats::extremal_rays_on_gpu` summed.
    pub extremal_rays_on_gpu: u64,
    /// The most bytes the linetrees' cells and samples took at once.
    pub memory_peak_bytes: usize,
    /// Linetree cells after the last frame (the trees persist across
    /// frames).
    pub cells: usize,
    /// Leaves among them (cells not split) after the last frame.
    pub leaves: usize,
    /// Accepted leaves after the last frame.
    pub valid_cells: usize,
    /// Rays by kind.
    pub rays: SequenceRays,
    /// Slow-path and extremal rays per second of `render_ms`, in millions.
    pub mrays_per_s: f64,
    /// The measures over the sequence: total reference time, overall
    /// speed-up, worst error, summed check.
    #[serde(flatten)]
    pub measured: Measured,
    /// Every frame's own report, in order.
    pub per_frame: Vec<FrameReport>,
    #[serde(skip)]
    surfaces: u64,
    #[serde(skip)]
    interpolated: u64,
}

impl BoundedRenderer {
    /// Renders `frames` frames of `width` x `height`, frame `f` through
    /// `camera(f)`, measuring what `measures` asks; `on_frame` sees each
    /// frame (to write it); one `progress` step a frame. Returns the sums
    /// and the last frame.
    pub fn render_sequence(
        &mut self,
        frames: u32,
        camera: impl Fn(u32) -> Camera,
        (width, height): (u32, u32),
        measures: Measures,
        progress: &Bar,
        mut on_frame: impl FnMut(u32, &BoundedFrame) -> Result<()>,
    ) -> Result<(SequenceReport, BoundedFrame)> {
        let mut report = SequenceReport::default();
        let mut last = None;
        for f in 0..frames {
            let frame = self.render(&camera(f), width, height)?;
            let entry = self.measure(&frame, measures, f)?;
            report.add(&entry);
            on_frame(f, &frame)?;
            progress.inc(1);
            last = Some(frame);
        }
        let last = last.ok_or_else(|| Error::param("frames", "must be at least 1"))?;
        report.finish(self, measures.check_lines.is_some());
        Ok((report, last))
    }

    /// The reference and the check of one frame.
    fn measure(&mut self, frame: &BoundedFrame, measures: Measures, f: u32) -> Result<FrameReport> {
        let mut entry = FrameReport {
            stats: frame.stats.clone(),
            measured: Measured::default(),
        };
        let m = &mut entry.measured;
        let settings = &self.settings;
        let (w, h) = (frame.width, frame.height);
        if measures.reference {
            let exact = self
                .whitted
                .render(&frame.camera, w, h, &settings.whitted, &Bar::hidden())?;
            m.reference_ms = Some(exact.stats.render_ms);
            m.speedup = Some(exact.stats.render_ms / frame.stats.frame_ms);
            m.error = Some(compare(frame, &exact.radiance(), settings.epsilon, settings.floor));
        }
        if let Some(k) = measures.check_lines {
            let params = self.whitted.params(&frame.camera, w, h, &settings.whitted)?;
            m.check = Some(self.check(&params, k, measures.seed ^ f));
        }
        Ok(entry)
    }
}

impl SequenceReport {
    fn add(&mut self, entry: &FrameReport) {
        let s = &entry.stats;
        self.render_ms += s.frame_ms;
        self.frame_ms.push(s.frame_ms);
        let p = &s.pixels;
        for (k, v) in [
            ("reprojected", p.reprojected),
            ("span_filled", p.span_filled),
            ("interpolated", p.interpolated),
            ("background", p.background),
            ("traced", p.traced),
        ] {
            *self.pixels.entry(k.into()).or_default() += v;
        }
        for (k, v) in &p.traced_by {
            *self.pixels.entry(format!("traced_{k}")).or_default() += v;
        }
        self.surfaces += p.reprojected + p.span_filled + p.interpolated + p.traced;
        self.interpolated += p.reprojected + p.span_filled + p.interpolated;
        self.extremal_rays_requested += s.extremal_rays_requested;
        self.extremal_rays_traced += s.extremal_rays_traced;
        self.extremal_rays_on_gpu += s.extremal_rays_on_gpu;
        self.rays.slow_path += s.rays_traced_slow_path;
        if let (Some(ms), Some(e)) = (entry.measured.reference_ms, &entry.measured.error) {
            self.add_reference(ms, e);
        }
        if let Some(c) = &entry.measured.check {
            self.add_check(c);
        }
        self.per_frame.push(entry.clone());
    }

    fn add_reference(&mut self, ms: f64, e: &ErrorStats) {
        let frames = self.per_frame.iter().filter(|f| f.measured.error.is_some()).count() as f64;
        *self.measured.reference_ms.get_or_insert(0.0) += ms;
        let t = self.measured.error.get_or_insert_with(ErrorStats::default);
        t.max_rel = t.max_rel.max(e.max_rel);
        t.mean_rel = (t.mean_rel * frames + e.mean_rel) / (frames + 1.0);
        t.violations += e.violations;
        t.span_violations += e.span_violations;
        t.traced_differ += e.traced_differ;
    }

    fn add_check(&mut self, c: &CheckStats) {
        let t = self.measured.check.get_or_insert_with(CheckStats::default);
        t.cells += c.cells;
        t.lines += c.lines;
        t.skipped += c.skipped;
        t.violations += c.violations;
        t.max_rel = t.max_rel.max(c.max_rel);
    }

    fn finish(&mut self, renderer: &BoundedRenderer, checked: bool) {
        self.rays.extremal = self.extremal_rays_traced;
        self.rays.extremal_on_gpu = self.extremal_rays_on_gpu;
        self.rays.slow_path_on = if renderer.slow_path_on_gpu() { "gpu" } else { "cpu" };
        self.success_rate = if self.surfaces == 0 {
            0.0
        } else {
            self.interpolated as f64 / self.surfaces as f64
        };
        self.memory_peak_bytes = renderer.trees.peak_bytes;
        (self.cells, self.leaves, self.valid_cells) = renderer.trees.counts();
        self.mrays_per_s =
            crate::report::mrays_per_s((self.rays.slow_path + self.rays.extremal) as usize, self.render_ms);
        self.measured.speedup = self.measured.reference_ms.map(|r| r / self.render_ms);
        if checked && self.measured.check.is_none() {
            self.measured.check = Some(CheckStats::default());
        }
    }
}
