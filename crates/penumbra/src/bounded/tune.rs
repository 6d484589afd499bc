//! `sweep bounded` ([`BoundedSweep`], `crate::tune`): the bounded-error
//! renderer's epsilon, split and bound against exact Whitted ray tracing
//! of the same camera (the truth of `raytrace --method bounded
//! --reference`), rendered once. Each setting renders one frame from empty
//! linetrees, so its time includes building the cells it uses.

use serde_json::{Value, json};

use super::measure::compare;
use super::{BoundKind, BoundedRenderer, BoundedSettings, SplitKind};
use crate::error::{Error, Result};
use crate::progress::Reporter;
use crate::scene::Camera;
use crate::tune::{Knob, Run, Setting, Sweep, Tunable};
use crate::whitted::{WhittedRenderer, WhittedSettings};

/// The bounded-error renderer's knobs.
pub const KNOBS: &[Knob] = &[
    Knob::new::<f32>(
        "epsilon",
        "relative error bound",
        &["0.01", "0.02", "0.05", "0.1", "0.2"],
    ),
    Knob::new::<u32>("split", "children of a failed cell: 16 or 4", &["16", "4"]),
    Knob::new::<BoundKind>("bound", "non-linearity bound: conservative or paper", &[]),
    Knob::new::<u32>("min-pixels", "pixels per child a split needs", &[]),
    Knob::new::<f32>("floor", "radiance below which the bound is absolute", &[]),
];

/// The bounded-error sweep of one scene and camera.
pub struct BoundedSweep {
    /// The exact renderer; lent to each setting's bounded renderer.
    whitted: Option<WhittedRenderer>,
    camera: Camera,
    size: (u32, u32),
    whitted_settings: WhittedSettings,
    exact: Vec<glam::Vec3>,
}

impl BoundedSweep {
    /// The sweep of `whitted`'s scene seen by `camera` at `size` pixels,
    /// the truth and every setting traced with `settings`.
    pub fn new(whitted: WhittedRenderer, camera: Camera, size: (u32, u32), settings: WhittedSettings) -> Self {
        BoundedSweep {
            whitted: Some(whitted),
            camera,
            size,
            whitted_settings: settings,
            exact: Vec::new(),
        }
    }

    fn settings(&self, s: &Setting) -> Result<BoundedSettings> {
        let base = BoundedSettings::default();
        let split = match s.get::<u32>("split") {
            None | Some(16) => SplitKind::Sixteen,
            Some(4) => SplitKind::Four,
            Some(n) => return Err(Error::param("grid", format!("split={n}: must be 16 or 4"))),
        };
        let settings = BoundedSettings {
            epsilon: s.get("epsilon").unwrap_or(base.epsilon),
            floor: s.get("floor").unwrap_or(base.floor),
            bound: s.get("bound").unwrap_or(BoundKind::Conservative),
            split,
            min_pixels: s.get("min-pixels").unwrap_or(base.min_pixels),
            whitted: self.whitted_settings,
            ..base
        };
        settings.validate()?;
        Ok(settings)
    }
}

impl Tunable for BoundedSweep {
    fn name(&self) -> &'static str {
        "bounded"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }
}

impl Sweep for BoundedSweep {
    fn time_measure(&self) -> &'static str {
        "one frame from empty linetrees, frame_ms"
    }

    fn error_measure(&self) -> &'static str {
        "largest relative error vs exact Whitted, max_rel"
    }

    fn check(&self, setting: &Setting) -> Result<()> {
        self.settings(setting).map(|_| ())
    }

    fn truth(&mut self, bars: &Reporter) -> Result<Value> {
        let whitted = self.whitted.as_mut().expect("the renderer is home between runs");
        let (w, h) = self.size;
        let progress = bars.bar(w as u64 * h as u64, "exact Whitted");
        let exact = whitted.render(&self.camera, w, h, &self.whitted_settings, &progress)?;
        progress.finish();
        self.exact = exact.radiance();
        Ok(json!({
            "what": "exact Whitted ray tracing of the same camera",
            "width": w,
            "height": h,
            "ms": exact.stats.render_ms,
            "rays": exact.stats.rays.total(),
        }))
    }

    fn run(&mut self, setting: &Setting) -> Result<Run> {
        let settings = self.settings(setting)?;
        let whitted = self.whitted.take().expect("the renderer is home between runs");
        let mut bounded = BoundedRenderer::new(whitted, settings)?;
        let (w, h) = self.size;
        let frame = bounded.render(&self.camera, w, h);
        self.whitted = Some(bounded.whitted);
        let frame = frame?;
        let errors = compare(&frame, &self.exact, settings.epsilon, settings.floor);
        let s = &frame.stats;
        Ok(Run {
            time_ms: s.frame_ms,
            error: errors.max_rel,
            memory_bytes: Some(s.memory_peak_bytes as u64),
            phases: vec![
                ("mean_rel", errors.mean_rel),
                ("violations", errors.violations as f64),
                ("success_rate", s.success_rate),
                ("build_ms", s.build_ms),
                ("trace_ms", s.trace_ms),
            ],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_default_grid_reads_as_its_knob() {
        let grid = crate::tune::Grid::parse(&[], KNOBS).unwrap();
        assert_eq!(grid.len(), 5 * 2);
        for s in grid.settings() {
            assert!(s.get::<f32>("epsilon").is_some());
            assert!(matches!(s.get::<u32>("split"), Some(4 | 16)));
        }
    }
}
