//! `sweep ssao`: the paper's estimators and their knobs against world-space
//! ray-traced AO of the same fuzzy measure at the same pixels (the truth of
//! `penumbra ssao`'s `rmse_vs_raytraced`), traced once per measure.

use serde_json::{Value, json};

use super::{Knob, Run, Setting, SweepMethod};
use crate::error::{Error, Result};
use crate::gpu::device::Device;
use crate::progress::Reporter;
use crate::scene::{Scene, View};
use crate::ssao::runner::{SsaoRequest, run};
use crate::ssao::truth::Estimate;
use crate::ssao::{Estimator, Measure, MeasureKind, Resolution, SsaoSettings, rmse};

const KNOBS: &[Knob] = &[
    Knob {
        name: "estimator",
        help: "the paper's estimator",
        default_grid: &[
            "raymarch",
            "sphere",
            "hemisphere",
            "importance",
            "tangent-sphere",
            "base-disk",
        ],
    },
    Knob {
        name: "spp",
        help: "samples per pixel",
        default_grid: &["4", "8", "16", "32"],
    },
    Knob {
        name: "steps",
        help: "steps per ray of raymarch",
        default_grid: &[],
    },
    Knob {
        name: "interleave",
        help: "interleaved 4x4 sample patterns (on/off)",
        default_grid: &[],
    },
    Knob {
        name: "filter",
        help: "depth-aware 4x4 low-pass filter (on/off)",
        default_grid: &[],
    },
    Knob {
        name: "filter-depth",
        help: "the filter's depth limit, scene units",
        default_grid: &[],
    },
    Knob {
        name: "bias",
        help: "depth bias in pixel footprints",
        default_grid: &[],
    },
    Knob {
        name: "calibrate",
        help: "unoccluded points get exactly 1 (on/off)",
        default_grid: &[],
    },
    Knob {
        name: "resolution",
        help: "estimation grid full/half (half: upsampled depth-aware)",
        default_grid: &[],
    },
    Knob {
        name: "radius",
        help: "neighbourhood radius R (changes the truth)",
        default_grid: &[],
    },
    Knob {
        name: "measure",
        help: "fuzzy measure step/exp/poly4 (changes the truth)",
        default_grid: &[],
    },
    Knob {
        name: "sigma",
        help: "extinction of measure exp (changes the truth)",
        default_grid: &[],
    },
];

/// The SSAO sweep of one scene and view.
pub struct SsaoSweep {
    device: Device,
    scene: Scene,
    view: View,
    base: SsaoSettings,
    truth_rays: u32,
    /// Truths traced so far, by (measure, radius).
    truths: Vec<((Measure, f32), Estimate)>,
}

impl SsaoSweep {
    /// `radius`: R where the grid does not set it.
    pub fn new(device: Device, scene: Scene, view: View, radius: f32, truth_rays: u32, seed: u32) -> Result<Self> {
        let base = SsaoSettings {
            estimator: Estimator::Importance,
            spp: 16,
            radius,
            measure: Measure::new(MeasureKind::Poly4, None, radius)?,
            steps: 4,
            interleave: true,
            filter: true,
            filter_depth: None,
            bias_px: crate::ssao::DEFAULT_BIAS_PX,
            calibrate: true,
            resolution: Resolution::Full,
            seed,
        };
        base.validate()?;
        if truth_rays == 0 {
            return Err(Error::param("reference_rays", "must be at least 1"));
        }
        Ok(SsaoSweep {
            device,
            scene,
            view,
            base,
            truth_rays,
            truths: Vec::new(),
        })
    }

    fn settings(&self, s: &Setting) -> Result<SsaoSettings> {
        let b = &self.base;
        let radius = s.get("radius")?.unwrap_or(b.radius);
        let kind = s.get_enum("measure")?.unwrap_or(MeasureKind::Poly4);
        let settings = SsaoSettings {
            estimator: s.get_enum("estimator")?.unwrap_or(b.estimator),
            spp: s.get("spp")?.unwrap_or(b.spp),
            radius,
            measure: Measure::new(kind, s.get("sigma")?, radius)?,
            steps: s.get("steps")?.unwrap_or(b.steps),
            interleave: s.get_on_off("interleave")?.unwrap_or(b.interleave),
            filter: s.get_on_off("filter")?.unwrap_or(b.filter),
            filter_depth: s.get("filter-depth")?.or(b.filter_depth),
            bias_px: s.get("bias")?.unwrap_or(b.bias_px),
            calibrate: s.get_on_off("calibrate")?.unwrap_or(b.calibrate),
            resolution: s.get_enum("resolution")?.unwrap_or(b.resolution),
            seed: b.seed,
        };
        settings.validate()?;
        Ok(settings)
    }

    fn request(&self, settings: SsaoSettings, truth_rays: u32) -> SsaoRequest {
        SsaoRequest {
            settings,
            view: self.view,
            shade: None,
            truth_rays,
            reference_spp: 0,
            runs: Default::default(),
        }
    }

    /// The truth of `settings`' measure, traced on first use.
    fn truth_of(&mut self, settings: SsaoSettings, bars: &Reporter) -> Result<&Estimate> {
        let key = (settings.measure, settings.radius);
        if let Some(i) = self.truths.iter().position(|(k, _)| *k == key) {
            return Ok(&self.truths[i].1);
        }
        let traced = run(
            &self.device,
            &self.scene,
            &self.request(settings, self.truth_rays),
            bars,
        )?;
        let truth = traced.truth.expect("truth rays were asked for");
        self.truths.push((key, truth));
        Ok(&self.truths.last().expect("just pushed").1)
    }
}

impl SweepMethod for SsaoSweep {
    fn name(&self) -> &'static str {
        "ssao"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }

    fn time_measure(&self) -> &'static str {
        "estimate + filter, ao_ms"
    }

    fn error_measure(&self) -> &'static str {
        "RMSE vs ray-traced AO over surface pixels"
    }

    fn check(&self, setting: &Setting) -> Result<()> {
        self.settings(setting).map(|_| ())
    }

    fn truth(&mut self, bars: &Reporter) -> Result<Value> {
        let truth = self.truth_of(self.base, bars)?;
        Ok(json!({
            "what": "world-space ray-traced AO of the same measure at the same pixels",
            "rays_per_pixel": truth.samples,
            "noise_rms": truth.noise_rms,
            "ms": truth.ms,
            "width": self.view.width,
            "height": self.view.height,
            "radius": self.base.radius,
        }))
    }

    fn run(&mut self, setting: &Setting) -> Result<Run> {
        let settings = self.settings(setting)?;
        // Measures the grid adds get their truth here, outside the timing.
        self.truth_of(settings, &Reporter::silent())?;
        let frame = run(
            &self.device,
            &self.scene,
            &self.request(settings, 0),
            &Reporter::silent(),
        )?;
        let truth = self.truth_of(settings, &Reporter::silent())?;
        let r = &frame.report;
        Ok(Run {
            time_ms: r.ao_ms,
            error: rmse(&frame.gbuffer, &frame.frame.ao, &truth.values),
            memory_bytes: None,
            phases: vec![
                ("gbuffer_ms", r.gbuffer_ms),
                ("estimate_ms", r.estimate_ms),
                ("filter_ms", r.filter_ms),
            ],
        })
    }
}
