//! `prt --max-error E`: the fastest mask size and hierarchy whose transfer
//! error (the mean relative L2 error `--check` reports) is within E at 95%
//! confidence, estimated per candidate by the self-check
//! (`selfcheck::estimate`: a weighted sample of vertices traced with the
//! reference's rays, the figure `--check` reports, noise included). Each
//! candidate's time is one frame of its transfer on the device, on the
//! rest pose; its setup (LUT, hierarchy) is reported, not compared.

use std::time::Instant;

use glam::Vec3;

use super::pipeline::{FrameOutput, PrtSettings};
use super::runner::{PrtRunner, RayTraced, Shadows};
use super::selfcheck::{SelfCheck, estimate};
use crate::error::{Error, Result};
use crate::gpu::device::{Device, elapsed_ms};
use crate::progress::Reporter;
use crate::sweep::Setting;
use crate::sweep::budget::{Candidate, Choice, ErrorBudget, SampleError, cached};

/// (mask side, hierarchy) tried.
pub const CANDIDATES: [(usize, bool); 6] = [
    (16, true),
    (32, true),
    (64, true),
    (16, false),
    (32, false),
    (64, false),
];

/// The one-sided 95% normal quantile (as `sweep::budget`).
const Z95: f64 = 1.645;

/// Chooses `--mask` and `--hierarchy` for `settings` (others as given) on
/// the pose `rest` of the mesh `triangles`, seen from `eye`.
#[allow(clippy::too_many_arguments)]
pub fn choose(
    device: &Device,
    rest: &[Vec3],
    triangles: &[[u32; 3]],
    settings: &PrtSettings,
    eye: Option<Vec3>,
    check: &SelfCheck,
    seed: u32,
    max_error: f64,
    bars: &Reporter,
) -> Result<Choice> {
    if !(max_error > 0.0 && max_error.is_finite()) {
        return Err(Error::param("max_error", format!("must be positive, got {max_error}")));
    }
    let start = Instant::now();
    let progress = bars.bar(CANDIDATES.len() as u64, "max-error check");
    let mut tried = Vec::with_capacity(CANDIDATES.len());
    for (mask, hierarchy) in CANDIDATES {
        let mut s = settings.clone();
        s.mask_side = mask;
        s.hierarchy.enabled = hierarchy;
        let reference = RayTraced { rays: check.rays, seed };
        let mut runner = PrtRunner::new(device, rest, triangles, &s, Shadows::On, reference)?;
        let lighting = vec![0.0; 3 * runner.prt().coeffs()];
        let mut out = FrameOutput::default();
        let frame = Instant::now();
        runner.frame(rest, eye, &lighting, false, &mut out)?;
        let time_ms = elapsed_ms(frame);
        let e = estimate(runner.prt(), triangles, &[(0, rest.to_vec())], eye, check, seed)?;
        let mut knobs = Setting::default();
        knobs.0.insert("mask".into(), mask.to_string());
        knobs
            .0
            .insert("hierarchy".into(), if hierarchy { "on" } else { "off" }.into());
        tried.push(Candidate {
            knobs,
            time_ms,
            error: SampleError {
                estimate: e.estimate,
                upper: e.estimate + Z95 * e.uncertainty,
                samples: e.vertices,
            },
            within: false,
        });
        progress.inc(1);
    }
    progress.finish();
    let measure = format!(
        "mean relative L2 transfer error vs ray tracing ({} rays per vertex), as --check",
        check.rays
    );
    Choice::pick(max_error, &measure, tried, elapsed_ms(start)).ok_or_else(|| Error::internal("no PRT candidate"))
}

/// `choose` through the `--max-error` cache (`sweep::budget::cached`),
/// keyed on `files`' contents, `source` (what else names the mesh, e.g. a
/// built-in animation) and every option that changes the answer; the
/// choice is applied to `settings`.
#[allow(clippy::too_many_arguments)]
pub fn choose_cached(
    device: &Device,
    (rest, triangles): (&[Vec3], &[[u32; 3]]),
    settings: &mut PrtSettings,
    eye: Vec3,
    (source, files): (&str, &[&std::path::Path]),
    seed: u32,
    budget: &ErrorBudget,
    bars: &Reporter,
) -> Result<Choice> {
    let max_error = budget.max_error;
    let check = SelfCheck::default();
    let options = format!("{max_error}|{source}|{settings:?}|{eye}|{}", device.kind());
    let choice = cached("prt", (&options, files), budget, bars, || {
        choose(
            device,
            rest,
            triangles,
            settings,
            Some(eye),
            &check,
            seed,
            max_error,
            bars,
        )
    })?;
    settings.mask_side = choice.chosen.get("mask")?.unwrap_or(settings.mask_side);
    settings.hierarchy.enabled = choice
        .chosen
        .get_on_off("hierarchy")?
        .unwrap_or(settings.hierarchy.enabled);
    Ok(choice)
}
