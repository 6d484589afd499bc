//! `ssao --max-error E`: the fastest estimator and sample count whose
//! RMSE against the ray-traced truth (the `rmse_vs_raytraced` of a full
//! run) is within E at 95% confidence, estimated on a random sample of the
//! image's surface pixels. The sample's truth is the full truth's values at
//! those pixels (`truth::raytraced_at`: the same rays), so the estimate is
//! an unbiased sample of the figure `--truth-rays` reports; each candidate
//! runs on the whole G-buffer, on the device, and is timed there.

use super::gbuffer::{GBuffer, ScreenView, gbuffer};
use super::gpu::{GBufferSource, run_frame};
use super::runner::SsaoRequest;
use super::truth::raytraced_at;
use super::{Estimator, MeasureKind, SsaoSettings, run_cpu};
use crate::accel::Accel;
use crate::accel::kdtree::KdTreeParams;
use crate::error::{Error, Result};
use crate::geom::sampling::hash_u32;
use crate::gpu::device::{Device, GpuOutput, elapsed_ms};
use crate::progress::Reporter;
use crate::raycast::tracer::build_tree;
use crate::scene::Scene;
use crate::sweep::Setting;
use crate::sweep::budget::{Candidate, Choice, ErrorBudget, SampleError, cached};

/// Surface pixels the error is estimated on.
pub const SAMPLE_PIXELS: usize = 2048;
/// Sample counts tried when `--spp` is not given.
pub const SPP_CANDIDATES: [u32; 5] = [4, 8, 16, 32, 64];

/// What the budget may change: the estimator and/or the sample count (the
/// ones the user fixed stay).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Free {
    pub estimator: bool,
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

/// Up to `n` surface pixels, spread by a hash of the seed (deterministic).
fn sample_pixels(gb: &GBuffer, n: usize, seed: u32) -> Vec<u32> {
    let mut surface: Vec<u32> = (0..gb.pixels() as u32).filter(|&i| gb.is_surface(i as usize)).collect();
    surface.sort_by_key(|&i| hash_u32(i ^ seed.rotate_left(16)));
    surface.truncate(n);
    surface
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
) -> Result<Choice> {
    if !(max_error > 0.0 && max_error.is_finite()) {
        return Err(Error::param("max_error", format!("must be positive, got {max_error}")));
    }
    let start = std::time::Instant::now();
    let base = request.settings;
    let mesh = scene.world_mesh(|_| true);
    let camera = scene.camera_in(&request.view.camera, &mesh.bounds())?;
    let (w, h) = (request.view.width, request.view.height);
    let view = ScreenView::new(&camera, w, h);
    let tree = Accel::new(build_tree(&mesh, &KdTreeParams::for_cpu(), bars, "ssao")?);
    let gb = gbuffer(tree.kdtree(), &mesh, &camera, &scene.lights, w, h);
    // The truth: only casters occlude, as in the full run.
    let occluders = scene.occluders();
    let caster_tree = if occluders.triangles.len() == mesh.triangles.len() {
        None
    } else {
        Some(Accel::new(build_tree(
            &occluders,
            &KdTreeParams::for_cpu(),
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
    let rays = request.truth_rays.max(64);
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
    let tried = candidates(&base, free, kind);
    let progress = bars.bar(tried.len() as u64, "max-error check");
    let mut out = Vec::with_capacity(tried.len());
    for settings in tried {
        let (ao, time_ms) = frame(device, &gb, &view, &settings)?;
        let squares: Vec<f64> = pixels
            .iter()
            .zip(&truth)
            .map(|(&p, &t)| ((ao[p as usize] - t) as f64).powi(2))
            .collect();
        out.push(Candidate {
            knobs: knobs(&settings),
            time_ms,
            error: SampleError::rms(&squares),
            within: false,
        });
        progress.inc(1);
    }
    progress.finish();
    let measure = format!("RMSE vs ray-traced AO ({rays} rays per pixel) over surface pixels");
    Choice::pick(max_error, &measure, out, elapsed_ms(start)).ok_or_else(|| Error::internal("no SSAO candidate"))
}

/// The candidate's knobs as they are spelled on the command line.
fn knobs(s: &SsaoSettings) -> Setting {
    let mut k = Setting::default();
    k.0.insert("estimator".into(), crate::choice::Choice::name(s.estimator).to_string());
    k.0.insert("spp".into(), s.spp.to_string());
    k
}

/// One frame of `settings` on the G-buffer: AO per pixel and its time.
fn frame(device: &Device, gb: &GBuffer, view: &ScreenView, settings: &SsaoSettings) -> Result<(Vec<f32>, f64)> {
    let timed = device.run(
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
/// `choose` through the `--max-error` cache (`sweep::budget::cached`, keyed
/// on `files`' contents and every option that changes the answer), applied
/// to `request`.
pub fn choose_cached(
    device: &Device,
    (scene, files): (&Scene, &[&std::path::Path]),
    request: &mut SsaoRequest,
    (kind, free): (MeasureKind, Free),
    budget: &ErrorBudget,
    bars: &Reporter,
) -> Result<Choice> {
    let max_error = budget.max_error;
    let options = format!("{max_error}|{free:?}|{:?}|{}", request, device.kind());
    let choice = cached("ssao", (&options, files), budget, bars, || {
        choose(device, scene, request, kind, free, max_error, bars)
    })?;
    let k = &choice.chosen;
    request.settings.estimator = k.get_enum("estimator")?.unwrap_or(request.settings.estimator);
    request.settings.spp = k.get("spp")?.unwrap_or(request.settings.spp);
    Ok(choice)
}
