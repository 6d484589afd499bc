//! `penumbra raytrace --method bounded`: the bounded-error renderer
//! (`bounded::runner`) over the frames of a camera path, with the exact
//! reference, the random-line check and the error image.

use serde_json::{Value, json};

use super::args::check_output;
use super::io::write_rgb_png;
use super::raytrace::{RaytraceArgs, Setup};
use crate::bounded::measure::{CheckStats, ErrorStats, compare, path_colour};
use crate::bounded::{BoundedRenderer, BoundedSettings, SplitKind};
use crate::error::{Error, Result};
use crate::progress::{Bars, Progress};
use crate::raytrace::WhittedRenderer;

fn settings(args: &RaytraceArgs, setup: &Setup) -> Result<BoundedSettings> {
    let s = BoundedSettings {
        epsilon: args.epsilon,
        floor: args.floor,
        bound: args.bound,
        split: if args.split == "4" {
            SplitKind::Four
        } else {
            SplitKind::Sixteen
        },
        reproject: args.reproject.on(),
        span: args.span.on(),
        memory_mb: args.memory_mb,
        min_pixels: args.min_pixels,
        whitted: setup.settings,
    };
    s.validate()?;
    if args.check == Some(0) {
        return Err(Error::param("--check", "must be at least 1 line per cell"));
    }
    Ok(s)
}

pub(super) fn run(args: &RaytraceArgs, setup: Setup, whitted: WhittedRenderer) -> Result<Value> {
    let settings = settings(args, &setup)?;
    let error_image = args
        .error_image
        .as_deref()
        .map(|p| check_output(p, "--error-image"))
        .transpose()?;
    let (w, h) = (args.width, args.height);
    let mut bounded = BoundedRenderer::new(whitted, settings)?;
    let progress = Bars::Stderr.bar(args.frames as u64, "bounded-error frames");
    let mut frames = Vec::new();
    let mut totals = Totals::default();
    let mut last = None;
    for f in 0..args.frames {
        let camera = setup.camera(f, args.frames);
        let frame = bounded.render(&camera, w, h)?;
        let mut entry = serde_json::to_value(&frame.stats).map_err(|e| Error::internal(e.to_string()))?;
        totals.add_frame(&frame.stats);
        if args.reference {
            let exact = bounded
                .whitted
                .render(&camera, w, h, &settings.whitted, &Progress::hidden())?;
            let error = compare(&frame, &exact.radiance(), settings.epsilon, settings.floor);
            entry["reference_ms"] = json!(exact.stats.render_ms);
            entry["speedup"] = json!(exact.stats.render_ms / frame.stats.frame_ms);
            entry["error"] = json!(error);
            totals.add_reference(exact.stats.render_ms, &error);
        }
        if let Some(k) = args.check {
            let params = bounded.whitted.params(&camera, w, h, &settings.whitted)?;
            let check = bounded.check(&params, k, args.common.seed ^ f);
            entry["check"] = json!(check);
            totals.add_check(&check);
        }
        setup.write_frame(f, w, h, &frame.radiance, args.exposure)?;
        frames.push(entry);
        progress.inc(1);
        last = Some(frame);
    }
    progress.finish();
    let last = last.ok_or_else(|| Error::internal("no frame rendered"))?;
    setup.write_last(w, h, &last.radiance, args.exposure)?;
    if let Some(path) = error_image {
        let colours: Vec<[u8; 3]> = last.paths.iter().map(|&p| path_colour(p)).collect();
        write_rgb_png(path, w, h, &colours)?;
    }
    let mut report = setup.report(args, &bounded.whitted, &last.camera);
    report["epsilon"] = json!(settings.epsilon);
    report["bounded"] = json!(settings);
    report["render_ms"] = json!(totals.frame_ms);
    report["frame_ms"] = json!(frames.iter().map(|f| f["frame_ms"].clone()).collect::<Vec<_>>());
    report["pixels"] = json!(totals.pixels);
    report["success_rate"] = json!(totals.success_rate());
    report["extremal_rays_requested"] = json!(totals.requested);
    report["extremal_rays_traced"] = json!(totals.traced);
    report["memory_peak_bytes"] = json!(bounded.trees.peak_bytes);
    let (cells, leaves, valid) = bounded.trees.counts();
    report["cells"] = json!(cells);
    report["leaves"] = json!(leaves);
    report["valid_cells"] = json!(valid);
    report["rays"] = json!({ "slow_path": totals.slow_rays, "extremal": totals.traced });
    report["mrays_per_s"] = json!(crate::mlrta::runner::mrays_per_s(
        (totals.slow_rays + totals.traced) as usize,
        totals.frame_ms
    ));
    if args.reference {
        report["reference_ms"] = json!(totals.reference_ms);
        report["speedup"] = json!(totals.reference_ms / totals.frame_ms);
        report["error"] = json!(totals.error);
    }
    if args.check.is_some() {
        report["check"] = json!(totals.check);
    }
    report["per_frame"] = json!(frames);
    Ok(report)
}

/// Sums over the frames.
#[derive(Default)]
struct Totals {
    frame_ms: f64,
    reference_ms: f64,
    pixels: std::collections::BTreeMap<String, u64>,
    surfaces: u64,
    interpolated: u64,
    requested: u64,
    traced: u64,
    slow_rays: u64,
    error: ErrorStats,
    error_frames: u64,
    check: CheckStats,
}

impl Totals {
    fn add_frame(&mut self, s: &crate::bounded::FrameStats) {
        self.frame_ms += s.frame_ms;
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
        let all = p.reprojected + p.span_filled + p.interpolated + p.background + p.traced;
        self.surfaces += all - p.background;
        self.interpolated += p.reprojected + p.span_filled + p.interpolated;
        self.requested += s.extremal_rays_requested;
        self.traced += s.extremal_rays_traced;
        self.slow_rays += s.rays_traced_slow_path;
    }

    fn add_reference(&mut self, ms: f64, e: &ErrorStats) {
        self.reference_ms += ms;
        let t = &mut self.error;
        t.max_rel = t.max_rel.max(e.max_rel);
        t.mean_rel = (t.mean_rel * self.error_frames as f64 + e.mean_rel) / (self.error_frames + 1) as f64;
        t.violations += e.violations;
        t.span_violations += e.span_violations;
        t.traced_differ += e.traced_differ;
        self.error_frames += 1;
    }

    fn add_check(&mut self, c: &CheckStats) {
        let t = &mut self.check;
        t.cells += c.cells;
        t.lines += c.lines;
        t.skipped += c.skipped;
        t.violations += c.violations;
        t.max_rel = t.max_rel.max(c.max_rel);
    }

    fn success_rate(&self) -> f64 {
        if self.surfaces == 0 {
            0.0
        } else {
            self.interpolated as f64 / self.surfaces as f64
        }
    }
}
