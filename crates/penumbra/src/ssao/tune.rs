//! SSAO's knobs, tuned two ways (`crate::tune`).
//!
//! `sweep ssao` ([`SsaoSweep`]): the paper's estimators and their knobs
//! against world-space ray-traced AO of the same fuzzy measure at the same
//! pixels (the truth of `penumbra ssao`'s `rmse_vs_raytraced`), traced
//! once per measure.
//!
//! `ssao --max-error E` ([`SsaoBudget`]): the fastest estimator and sample
//! count whose RMSE against the ray-traced truth (the `rmse_vs_raytraced`
//! of a full run) is within E at 95% confidence, estimated on a random
//! sample of the image's surface pixels. The sample's truth is the full
//! truth's values at those pixels (`truth::raytraced_at`: the same rays),
//! so the estimate is an unbiased sample of the figure `--truth-rays`
//! reports; each candidate runs on the whole G-buffer, on the device, and
//! is timed there.

use serde_json::{Value, json};

use super::gbuffer::{GBuffer, ScreenView, gbuffer_with};
use super::gpu::{GBufferSource, run_frame};
use super::runner::{SsaoRequest, run};
use super::surfaces::GBufferSurfaces;
use super::truth::{Estimate, raytraced_at};
use super::{Estimator, Measure, MeasureKind, Resolution, SsaoSettings, rmse, run_cpu};
use crate::accel::Accel;
use crate::accel::kdtree::KdTreeSettings;
use crate::error::{Error, Result};
use crate::geom::sampling::hash_u32;
use crate::gpu::device::{Device, GpuOutput};
use crate::progress::Reporter;
use crate::raycast::tracer::build_tree;
use crate::scene::texture_table::DEFAULT_TEXTURE_BYTES;
use crate::scene::{Scene, View};
use crate::tune::{self, Budgeted, ErrorBudget, Knob, Pick, Run, SampleError, Setting, Sweep, Tunable};

/// SSAO's knobs.
pub const KNOBS: &[Knob] = &[
    Knob::new::<Estimator>(
        "estimator",
        "the paper's estimator",
        &[
            "raymarch",
            "sphere",
            "hemisphere",
            "importance",
            "tangent-sphere",
            "base-disk",
        ],
    ),
    Knob::new::<u32>("spp", "samples per pixel", &["4", "8", "16", "32"]),
    Knob::new::<u32>("steps", "steps per ray of raymarch", &[]),
    Knob::new::<bool>("interleave", "interleaved 4x4 sample patterns (on/off)", &[]),
    Knob::new::<bool>("filter", "depth-aware 4x4 low-pass filter (on/off)", &[]),
    Knob::new::<f32>("filter-depth", "the filter's depth limit, scene units", &[]),
    Knob::new::<f32>("bias", "depth bias in pixel footprints", &[]),
    Knob::new::<bool>("calibrate", "unoccluded points get exactly 1 (on/off)", &[]),
    Knob::new::<Resolution>(
        "resolution",
        "estimation grid full/half (half: upsampled depth-aware)",
        &[],
    ),
    Knob::new::<f32>("radius", "neighbourhood radius R (changes the truth)", &[]),
    Knob::new::<MeasureKind>("measure", "fuzzy measure step/exp/poly4 (changes the truth)", &[]),
    Knob::new::<f32>("sigma", "extinction of measure exp (changes the truth)", &[]),
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
    /// The sweep of `scene` seen as `view`, the truth traced with
    /// `truth_rays` per pixel; `radius`: R where the grid does not set it.
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
        let radius = s.get("radius").unwrap_or(b.radius);
        let kind = s.get("measure").unwrap_or(MeasureKind::Poly4);
        let settings = SsaoSettings {
            estimator: s.get("estimator").unwrap_or(b.estimator),
            spp: s.get("spp").unwrap_or(b.spp),
            radius,
            measure: Measure::new(kind, s.get("sigma"), radius)?,
            steps: s.get("steps").unwrap_or(b.steps),
            interleave: s.get("interleave").unwrap_or(b.interleave),
            filter: s.get("filter").unwrap_or(b.filter),
            filter_depth: s.get("filter-depth").or(b.filter_depth),
            bias_px: s.get("bias").unwrap_or(b.bias_px),
            calibrate: s.get("calibrate").unwrap_or(b.calibrate),
            resolution: s.get("resolution").unwrap_or(b.resolution),
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

impl Tunable for SsaoSweep {
    fn name(&self) -> &'static str {
        "ssao"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }
}

impl Sweep for SsaoSweep {
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

/// Surface pixels the error is estimated on.
pub const SAMPLE_PIXELS: usize = 2048;
/// Sample counts tried when `--spp` is not given.
pub const SPP_CANDIDATES: [u32; 5] = [4, 8, 16, 32, 64];

/// What the budget may change: the estimator and/or the sample count (the
/// ones the user fixed stay).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Free {
    /// The budget chooses the estimator.
    pub estimator: bool,
    /// The budget chooses the sample count.
    pub spp: bool,
}

/// The candidates: every free estimator (base-disk only with poly4, which
/// it requires) times every free sample count.
fn candidates(base: &SsaoSettings, free: Free, kind: MeasureKind) -> Vec<SsaoSettings> {
    let estimators: Vec<Estimator> = if free.estimator {
        Estimator::ALL
            .into_iter()
            .filter(|e| *e != Estimator::BaseDisk || kind == MeasureKind::Poly4)
            .collect()
    } else {
        vec![base.estimator]
    };
    let spps: Vec<u32> = if free.spp {
        SPP_CANDIDATES.to_vec()
    } else {
        vec![base.spp]
    };
    estimators
        .iter()
        .flat_map(|&estimator| {
            spps.iter().map(move |&spp| SsaoSettings {
                estimator,
                spp,
                ..*base
            })
        })
        .filter(|s| s.validate().is_ok())
        .collect()
}

/// `settings` with the estimator and sample count `chosen` sets.
fn apply(chosen: &Setting, settings: &mut SsaoSettings) {
    settings.estimator = chosen.get("estimator").unwrap_or(settings.estimator);
    settings.spp = chosen.get("spp").unwrap_or(settings.spp);
}

/// Up to `n` surface pixels, spread by a hash of the seed (deterministic).
fn sample_pixels(gb: &GBuffer, n: usize, seed: u32) -> Vec<u32> {
    let mut surface: Vec<u32> = (0..gb.pixels() as u32).filter(|&i| gb.is_surface(i as usize)).collect();
    surface.sort_by_key(|&i| hash_u32(i ^ seed.rotate_left(16)));
    surface.truncate(n);
    surface
}

/// What a budget's candidates run on: the frame's G-buffer, and the
/// sampled pixels with their ray-traced truth.
struct Sample {
    gb: GBuffer,
    view: ScreenView,
    pixels: Vec<u32>,
    truth: Vec<f32>,
}

/// SSAO's `--max-error` search for one frame: every free estimator and
/// sample count, each run on the frame's G-buffer and timed, its error
/// estimated on [`SAMPLE_PIXELS`] surface pixels.
pub struct SsaoBudget<'a> {
    device: &'a Device,
    scene: &'a Scene,
    request: SsaoRequest,
    kind: MeasureKind,
    free: Free,
    sample: Option<Sample>,
}

impl<'a> SsaoBudget<'a> {
    /// The search for `request` (its other knobs as given) with the
    /// measure `kind`; the truth has `request.truth_rays` rays per pixel
    /// (at least 64).
    pub fn new(device: &'a Device, scene: &'a Scene, request: &SsaoRequest, kind: MeasureKind, free: Free) -> Self {
        SsaoBudget {
            device,
            scene,
            request: request.clone(),
            kind,
            free,
            sample: None,
        }
    }

    /// One frame of `settings` on the G-buffer: AO per pixel and its time.
    fn frame(&self, settings: &SsaoSettings) -> Result<(Vec<f32>, f64)> {
        let sample = self.sample.as_ref().expect("the sample is taken before any candidate");
        let (gb, view) = (&sample.gb, &sample.view);
        let timed = self.device.run(
            |ctx| {
                let f = run_frame(ctx, GBufferSource::Upload(gb), view, settings, None, 1)?;
                Ok(GpuOutput {
                    value: f.frame,
                    gpu_ms: None,
                })
            },
            || run_cpu(gb, view, settings, None),
        )?;
        let ms = timed.value.timings.ao_ms();
        Ok((timed.value.ao, ms))
    }
}

impl Tunable for SsaoBudget<'_> {
    fn name(&self) -> &'static str {
        "ssao"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }
}

impl Budgeted for SsaoBudget<'_> {
    fn measure(&self) -> String {
        let rays = self.request.truth_rays.max(64);
        format!("RMSE vs ray-traced AO ({rays} rays per pixel) over surface pixels")
    }

    fn sample_truth(&mut self, bars: &Reporter) -> Result<()> {
        let (scene, base) = (self.scene, self.request.settings);
        let mesh = scene.world_mesh(|_| true);
        let camera = scene.camera_in(&self.request.view.camera, &mesh.bounds())?;
        let (w, h) = (self.request.view.width, self.request.view.height);
        let view = ScreenView::new(&camera, w, h);
        let tree = Accel::new(build_tree(&mesh, &KdTreeSettings::for_cpu(), bars, "ssao")?);
        // The run's G-buffer: cut-outs' holes show what lies behind (its
        // warnings are the run's too, given there).
        let surfaces = GBufferSurfaces::of_scene(scene, DEFAULT_TEXTURE_BYTES, &mut Vec::new());
        let gb = gbuffer_with(tree.kdtree(), &mesh, &surfaces, &camera, &scene.lights, (w, h));
        // The truth: only casters occlude, as in the full run.
        let occluders = scene.occluders();
        let caster_tree = if occluders.triangles.len() == mesh.triangles.len() {
            None
        } else {
            Some(Accel::new(build_tree(
                &occluders,
                &KdTreeSettings::for_cpu(),
                bars,
                "casters",
            )?))
        };
        let pixels = sample_pixels(&gb, SAMPLE_PIXELS, base.seed);
        if pixels.is_empty() {
            return Err(Error::param(
                "scene",
                "no surface pixel in view: nothing to estimate the error on",
            ));
        }
        let rays = self.request.truth_rays.max(64);
        let truth_tree = caster_tree.as_ref().unwrap_or(&tree);
        let truth = raytraced_at(
            truth_tree,
            &camera,
            &view,
            &gb,
            base.measure,
            base.radius,
            rays,
            base.seed,
            &pixels,
        );
        self.sample = Some(Sample {
            gb,
            view,
            pixels,
            truth,
        });
        Ok(())
    }

    fn candidates(&self) -> Vec<Setting> {
        candidates(&self.request.settings, self.free, self.kind)
            .iter()
            .map(|s| Setting::default().with("estimator", s.estimator).with("spp", s.spp))
            .collect()
    }

    fn try_candidate(&mut self, setting: &Setting) -> Result<(f64, SampleError)> {
        let mut settings = self.request.settings;
        apply(setting, &mut settings);
        let (ao, time_ms) = self.frame(&settings)?;
        let sample = self.sample.as_ref().expect("the sample is taken before any candidate");
        let squares: Vec<f64> = sample
            .pixels
            .iter()
            .zip(&sample.truth)
            .map(|(&p, &t)| ((ao[p as usize] - t) as f64).powi(2))
            .collect();
        Ok((time_ms, SampleError::rms(&squares)))
    }
}

/// Chooses the knobs of `request` (others as given) for `max_error`; the
/// truth has `request.truth_rays` rays per pixel (at least 64).
pub fn choose(
    device: &Device,
    scene: &Scene,
    request: &SsaoRequest,
    kind: MeasureKind,
    free: Free,
    max_error: f64,
    bars: &Reporter,
) -> Result<Pick> {
    tune::choose(
        &mut SsaoBudget::new(device, scene, request, kind, free),
        max_error,
        bars,
    )
}

/// [`choose`] through the budget's cache (`tune::choose_cached`, keyed on
/// `files`' contents and every option that changes the answer), applied
/// to `request`.
pub fn choose_cached(
    device: &Device,
    (scene, files): (&Scene, &[&std::path::Path]),
    request: &mut SsaoRequest,
    (kind, free): (MeasureKind, Free),
    budget: &ErrorBudget,
    bars: &Reporter,
) -> Result<Pick> {
    let options = format!("{}|{free:?}|{:?}|{}", budget.max_error, request, device.kind());
    let mut search = SsaoBudget::new(device, scene, request, kind, free);
    let pick = tune::choose_cached(&mut search, (&options, files), budget, bars)?;
    apply(&pick.chosen, &mut request.settings);
    Ok(pick)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_default_grid_reads_as_its_knob() {
        let grid = tune::Grid::parse(&[], KNOBS).unwrap();
        assert_eq!(grid.len(), 6 * 4);
        for s in grid.settings() {
            assert!(s.get::<Estimator>("estimator").is_some() && s.get::<u32>("spp").is_some());
        }
    }

    #[test]
    fn candidates_cross_the_free_knobs_and_leave_the_fixed_ones() {
        let base = SsaoSettings::new(Estimator::Sphere, 12, 0.5);
        let both = Free {
            estimator: true,
            spp: true,
        };
        let all = candidates(&base, both, MeasureKind::Poly4);
        assert!(all.len() > SPP_CANDIDATES.len());
        assert!(all.iter().any(|s| s.estimator == Estimator::BaseDisk));
        let step = candidates(&base, both, MeasureKind::Step);
        assert!(step.iter().all(|s| s.estimator != Estimator::BaseDisk));
        let spp_only = Free {
            estimator: false,
            spp: true,
        };
        let mut s = base;
        for c in candidates(&base, spp_only, MeasureKind::Poly4) {
            assert_eq!(c.estimator, Estimator::Sphere);
            let knobs = Setting::default().with("estimator", c.estimator).with("spp", c.spp);
            apply(&knobs, &mut s);
            assert_eq!(s, c);
        }
    }
}
