//! PRT's knobs, tuned two ways (`crate::tune`).
//!
//! `sweep prt` ([`PrtSweep`]): hemispherical rasterisation's knobs against
//! Monte Carlo ray-traced visibility of the same vertices and shading
//! normals (the truth of `prt --check`), traced once per band count and
//! normals. The error is the transfer's mean relative L2 error, which does
//! not depend on the lighting, so no probe is needed.
//!
//! `prt --max-error E` ([`PrtBudget`]): the fastest mask size and hierarchy
//! whose transfer error (the mean relative L2 error `--check` reports) is
//! within E at 95% confidence, estimated per candidate by the self-check
//! (`selfcheck::estimate`: a weighted sample of vertices traced with the
//! reference's rays, the figure `--check` reports, noise included). Each
//! candidate's time is one frame of its transfer on the device, on the
//! rest pose; its setup (LUT, hierarchy) is reported, not compared.

use std::time::Instant;

use glam::Vec3;
use serde_json::{Value, json};

use super::hierarchy::{HierarchySettings, NearField};
use super::pipeline::{FrameOutput, PrtSettings, Toggle};
use super::reference::relative_l2_error;
use super::runner::{PrtRunner, RayTraced, Shadows};
use super::selfcheck::{SelfCheck, estimate};
use super::transfer::Integration;
use crate::error::Result;
use crate::gpu::device::{Device, elapsed_ms};
use crate::progress::Reporter;
use crate::tune::{self, Budgeted, ErrorBudget, Knob, Pick, Run, SampleError, Setting, Sweep, Tunable, budget::Z95};

/// PRT's knobs.
pub const KNOBS: &[Knob] = &[
    Knob::new::<usize>("mask", "visibility mask side: 16, 32 or 64", &["16", "32", "64"]),
    Knob::new::<bool>("hierarchy", "two-level mesh hierarchy (on/off)", &["on", "off"]),
    Knob::new::<usize>("order", "SH bands", &[]),
    Knob::new::<usize>("lut", "plane LUT cells per cube-face side", &[]),
    Knob::new::<Integration>("integration", "cells, cells-linear or pixels", &[]),
    Knob::new::<NearField>("near", "near field: clusters or rings", &[]),
    Knob::new::<usize>("ring", "rings drawn at full resolution: 1 or 2", &[]),
    Knob::new::<usize>("coarse", "coarse triangles to aim for", &[]),
    Knob::new::<f32>(
        "coarse-tolerance",
        "angle (rad) a coarse triangle may deviate before fine ones are drawn",
        &[],
    ),
    Knob::new::<usize>("group-size", "far triangles per culling group", &[]),
    Knob::new::<bool>("group-culling", "skip groups below the tangent plane (on/off)", &[]),
    Knob::new::<Toggle>("backface", "cull back-facing blockers: auto, on, off", &[]),
    Knob::new::<Toggle>("two-sided", "shade the side facing the eye: auto, on, off", &[]),
];

/// What the truth depends on: the bands and the shading normals.
type TruthKey = (usize, Vec<Vec3>);

/// The PRT sweep of one static pose.
pub struct PrtSweep {
    device: Device,
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    eye: Vec3,
    reference: RayTraced,
    /// Truths traced so far: (bands, shading normals) and the transfer.
    truths: Vec<(TruthKey, Vec<f32>)>,
    /// The runner of the last settings (repeats reuse it) and its setup time.
    runner: Option<(PrtSettings, PrtRunner, f64)>,
}

impl PrtSweep {
    /// The sweep of the mesh `triangles` posed at `positions`, seen from
    /// `eye`, against `reference`'s rays.
    pub fn new(
        device: Device,
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        eye: Vec3,
        reference: RayTraced,
    ) -> Self {
        PrtSweep {
            device,
            positions,
            triangles,
            eye,
            reference,
            truths: Vec::new(),
            runner: None,
        }
    }

    pub(crate) fn settings(s: &Setting) -> Result<PrtSettings> {
        let (base, h) = (PrtSettings::default(), HierarchySettings::default());
        let settings = PrtSettings {
            mask_side: s.get("mask").unwrap_or(base.mask_side),
            lut_size: s.get("lut").unwrap_or(base.lut_size),
            bands: s.get("order").unwrap_or(base.bands),
            integration: s.get("integration").unwrap_or(base.integration),
            hierarchy: HierarchySettings {
                enabled: s.get("hierarchy").unwrap_or(h.enabled),
                near: s.get("near").unwrap_or(h.near),
                ring: s.get("ring").unwrap_or(h.ring),
                coarse_triangles: s.get("coarse").or(h.coarse_triangles),
                group_size: s.get("group-size").unwrap_or(h.group_size),
                tolerance: s.get("coarse-tolerance").unwrap_or(h.tolerance),
                poses: h.poses,
            },
            group_culling: s.get("group-culling").unwrap_or(base.group_culling),
            backface: s.get("backface").unwrap_or(base.backface),
            two_sided: s.get("two-sided").unwrap_or(base.two_sided),
            ..base
        };
        settings.validate()?;
        Ok(settings)
    }

    /// Builds the runner of `settings` unless the last run's was the same.
    fn ensure_runner(&mut self, settings: PrtSettings) -> Result<()> {
        if !matches!(&self.runner, Some((s, _, _)) if *s == settings) {
            self.runner = None;
            let start = Instant::now();
            let runner = PrtRunner::new(
                &self.device,
                &self.positions,
                &self.triangles,
                &settings,
                Shadows::On,
                self.reference,
            )?;
            self.runner = Some((settings, runner, elapsed_ms(start)));
        }
        Ok(())
    }
}

impl Tunable for PrtSweep {
    fn name(&self) -> &'static str {
        "prt"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }
}

impl Sweep for PrtSweep {
    fn time_measure(&self) -> &'static str {
        "one frame's transfer at every vertex"
    }

    fn error_measure(&self) -> &'static str {
        "mean relative L2 transfer error vs ray tracing"
    }

    fn check(&self, setting: &Setting) -> Result<()> {
        Self::settings(setting).map(|_| ())
    }

    fn truth(&mut self, _bars: &Reporter) -> Result<Value> {
        // The truth depends on the bands and the shading normals, which the
        // settings decide: it is traced on each one's first run.
        Ok(json!({
            "what": "Monte Carlo ray-traced visibility of the same vertices and normals",
            "rays_per_vertex": self.reference.rays,
            "vertices": self.positions.len(),
            "triangles": self.triangles.len(),
        }))
    }

    fn run(&mut self, setting: &Setting) -> Result<Run> {
        let settings = Self::settings(setting)?;
        let (positions, eye) = (self.positions.clone(), Some(self.eye));
        self.ensure_runner(settings)?;
        let (_, runner, setup_ms) = self.runner.as_mut().expect("built above");
        let setup_ms = *setup_ms;
        let coeffs = runner.prt().coeffs();
        let lighting = vec![0.0; 3 * coeffs];
        let mut out = FrameOutput::default();
        let start = Instant::now();
        runner.frame(&positions, eye, &lighting, false, &mut out)?;
        let time_ms = elapsed_ms(start);
        let key = (runner.prt().settings.bands, out.normals.clone());
        let t = &runner.prt().tables;
        let floor = 0.01 * t.unoccluded.iter().map(|v| v * v).sum::<f32>().sqrt();
        let truth = match self.truths.iter().position(|(k, _)| *k == key) {
            Some(i) => &self.truths[i].1,
            None => {
                let traced = runner.reference_transfer(&positions, &out.normals, eye)?;
                self.truths.push((key, traced));
                &self.truths.last().expect("just pushed").1
            }
        };
        let (error, _, _) = relative_l2_error(&out.transfer, truth, coeffs, floor);
        Ok(Run {
            time_ms,
            error,
            memory_bytes: None,
            phases: vec![
                ("setup_ms", setup_ms),
                (
                    "drawn_per_vertex",
                    out.stats.drawn as f64 / out.stats.vertices.max(1) as f64,
                ),
            ],
        })
    }
}

/// (mask side, hierarchy) tried.
pub const CANDIDATES: [(usize, bool); 6] = [
    (16, true),
    (32, true),
    (64, true),
    (16, false),
    (32, false),
    (64, false),
];

/// `settings` with the mask side and hierarchy `chosen` sets.
fn apply(chosen: &Setting, settings: &mut PrtSettings) {
    settings.mask_side = chosen.get("mask").unwrap_or(settings.mask_side);
    settings.hierarchy.enabled = chosen.get("hierarchy").unwrap_or(settings.hierarchy.enabled);
}

/// PRT's `--max-error` search on one pose: every (mask, hierarchy) of
/// [`CANDIDATES`], each set up, one frame timed, its error estimated by the
/// self-check.
pub struct PrtBudget<'a> {
    device: &'a Device,
    rest: &'a [Vec3],
    triangles: &'a [[u32; 3]],
    settings: PrtSettings,
    eye: Option<Vec3>,
    check: SelfCheck,
    seed: u32,
}

impl<'a> PrtBudget<'a> {
    /// The search for `settings` (others as given) on the pose `rest` of
    /// the mesh `triangles`, seen from `eye`, estimated by `check`.
    pub fn new(
        device: &'a Device,
        (rest, triangles): (&'a [Vec3], &'a [[u32; 3]]),
        settings: &PrtSettings,
        eye: Option<Vec3>,
        check: SelfCheck,
        seed: u32,
    ) -> Self {
        PrtBudget {
            device,
            rest,
            triangles,
            settings: settings.clone(),
            eye,
            check,
            seed,
        }
    }
}

impl Tunable for PrtBudget<'_> {
    fn name(&self) -> &'static str {
        "prt"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }
}

impl Budgeted for PrtBudget<'_> {
    fn measure(&self) -> String {
        format!(
            "mean relative L2 transfer error vs ray tracing ({} rays per vertex), as --check",
            self.check.rays
        )
    }

    /// The self-check traces each candidate's own sample: nothing shared.
    fn sample_truth(&mut self, _bars: &Reporter) -> Result<()> {
        Ok(())
    }

    fn candidates(&self) -> Vec<Setting> {
        CANDIDATES
            .iter()
            .map(|&(mask, hierarchy)| Setting::default().with("mask", mask).with("hierarchy", hierarchy))
            .collect()
    }

    fn try_candidate(&mut self, setting: &Setting) -> Result<(f64, SampleError)> {
        let mut s = self.settings.clone();
        apply(setting, &mut s);
        let (rest, triangles, eye, seed) = (self.rest, self.triangles, self.eye, self.seed);
        let reference = RayTraced {
            rays: self.check.rays,
            seed,
        };
        let mut runner = PrtRunner::new(self.device, rest, triangles, &s, Shadows::On, reference)?;
        let lighting = vec![0.0; 3 * runner.prt().coeffs()];
        let mut out = FrameOutput::default();
        let frame = Instant::now();
        runner.frame(rest, eye, &lighting, false, &mut out)?;
        let time_ms = elapsed_ms(frame);
        let e = estimate(runner.prt(), triangles, &[(0, rest.to_vec())], eye, &self.check, seed)?;
        let error = SampleError {
            estimate: e.estimate,
            upper: e.estimate + Z95 * e.uncertainty,
            samples: e.vertices,
        };
        Ok((time_ms, error))
    }
}

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
) -> Result<Pick> {
    let mut budget = PrtBudget::new(device, (rest, triangles), settings, eye, *check, seed);
    tune::choose(&mut budget, max_error, bars)
}

/// [`choose`] through the budget's cache (`tune::choose_cached`), keyed on
/// `files`' contents, `source` (what else names the mesh, e.g. a built-in
/// animation) and every option that changes the answer; the pick is
/// applied to `settings`.
#[allow(clippy::too_many_arguments)]
pub fn choose_cached(
    device: &Device,
    pose: (&[Vec3], &[[u32; 3]]),
    settings: &mut PrtSettings,
    eye: Vec3,
    (source, files): (&str, &[&std::path::Path]),
    seed: u32,
    budget: &ErrorBudget,
    bars: &Reporter,
) -> Result<Pick> {
    let options = format!("{}|{source}|{settings:?}|{eye}|{}", budget.max_error, device.kind());
    let mut search = PrtBudget::new(device, pose, settings, Some(eye), SelfCheck::default(), seed);
    let pick = tune::choose_cached(&mut search, (&options, files), budget, bars)?;
    apply(&pick.chosen, settings);
    Ok(pick)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_default_grid_and_candidate_is_a_valid_setting() {
        let grid = tune::Grid::parse(&[], KNOBS).unwrap();
        assert_eq!(grid.len(), 3 * 2);
        for s in grid.settings() {
            PrtSweep::settings(&s).unwrap();
        }
        for (mask, hierarchy) in CANDIDATES {
            let mut s = PrtSettings::default();
            apply(
                &Setting::default().with("mask", mask).with("hierarchy", hierarchy),
                &mut s,
            );
            assert_eq!((s.mask_side, s.hierarchy.enabled), (mask, hierarchy));
            s.validate().unwrap();
        }
    }
}
