//! Playing a scene of several objects (`objects`): per frame the instances'
//! poses, the lighting, the other objects' blockers, then every shaded
//! object's transfer; on the checked frames the whole scene is ray traced
//! and the transfer compared, with the inter-object shadows off, coarse
//! (section 4.1) and exact (the other objects' full meshes) side by side,
//! so that the report says what the approximation costs and what it buys.

use std::ops::Range;
use std::time::Instant;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::blockers::{InterObject, OtherStats, SceneBlockers};
use super::objects::{ObjectErrors, ObjectsRunner, instance_positions, pooled};
use super::pipeline::{FrameOutput, FrameStats};
use super::runner::{FrameTimes, Phases, Playback, Shadows, ms_between, spun};
use super::selfcheck::SelfCheckReport;
use crate::error::{Error, Result};
use crate::gpu::device::elapsed_ms;
use crate::scene::{EnvironmentMap, Role, Scene};
use crate::sh::window::{Deringing, nonnegative};
use crate::sh::{ShRgb, ShRotation, coefficient_count, project_environment};

/// What playing a scene measured (`prt --scene --json`).
#[derive(Debug, Clone, Serialize)]
pub struct SceneReport {
    /// Every object of the scene, in instance order.
    pub objects: Vec<ObjectReport>,
    /// Over the shaded objects.
    pub vertices: usize,
    /// Every object's triangles, shaded or casting.
    pub triangles: usize,
    /// How other objects shadowed each shaded one.
    pub inter_object: InterObject,
    /// Where visibility came from.
    pub shadows: Shadows,
    /// Frames per second of whole frames: poses, lighting, blockers,
    /// transfer and shading of every object (`phases_ms`); not checks or output.
    pub fps: f64,
    /// Frames per second of the fastest whole frame.
    pub fps_best: f64,
    /// Whole frames (as `fps`).
    pub frame_ms: FrameTimes,
    /// Milliseconds of each phase of a frame, averaged over the frames.
    pub phases_ms: ScenePhases,
    /// With `--profile`: shares of the per-vertex time over every object
    /// (the paper's Table 2) and ms per frame (`runner::Phases`).
    pub phases: Option<Phases>,
    /// Milliseconds of the SH transfer kernels per frame (every object's
    /// summed), on average, from GPU timestamps; `None` on the CPU, with
    /// ray-traced shadows, or where the device has no timestamps.
    pub gpu_ms_per_frame: Option<f64>,
    /// Frames played.
    pub frames: usize,
    /// Blockers per shaded vertex, over the scene.
    pub blockers_per_vertex: BlockersPerVertex,
    /// Mean relative L2 error of the transfer against ray tracing of the
    /// whole scene, over the checked frames and every shaded vertex.
    pub transfer_l2_error: Option<f64>,
    /// The same error with the other objects' shadows off, coarse and
    /// exact (checks with `--shadows on` only).
    pub errors_by_inter_object: Option<ModeErrors>,
    /// What the coarse approximation costs against the other objects' full
    /// meshes (coarse - fine), and what inter-object shadows buy (off - coarse).
    pub inter_object_cost: Option<f64>,
    /// What inter-object shadows buy: the error with them off minus the
    /// error with the coarse approximation (checks with `--shadows on`
    /// only).
    pub inter_object_gain: Option<f64>,
    /// The comparison with ray tracing on the checked frames (`None`: no
    /// frame checked).
    pub check: Option<SceneCheck>,
    /// SH bands (`PrtSettings::bands`).
    pub order: usize,
    /// SH coefficients per transfer vector, `order²`.
    pub coefficients: usize,
    /// Mask side S in pixels.
    pub mask: usize,
    /// Milliseconds building every object's tables, LUT and hierarchy,
    /// summed (wall clock).
    pub setup_ms: f64,
    /// How the lighting was windowed to keep it non-negative (`sh::window`).
    pub lighting: Deringing,
}

/// One object of the report.
#[derive(Debug, Clone, Serialize)]
pub struct ObjectReport {
    /// The instance's name.
    pub name: String,
    /// Whether it casts, is shaded, or both.
    pub role: Role,
    /// Its mesh's vertices.
    pub vertices: usize,
    /// Its mesh's triangles.
    pub triangles: usize,
    /// Triangles of the approximation other objects draw (its far level).
    pub coarse_triangles: usize,
    /// Blockers per vertex of this object (`None`: it is not shaded).
    pub blockers_per_vertex: Option<BlockersPerVertex>,
    /// Its mean relative L2 transfer error against ray tracing of the whole
    /// scene, over the checked frames (shaded objects with checks only).
    pub transfer_l2_error: Option<f64>,
    /// The same error by inter-object mode (shaded objects, checks with
    /// `--shadows on` only).
    pub errors_by_inter_object: Option<ModeErrors>,
    /// Whether blockers facing away from its vertices were culled.
    pub backface_culling: bool,
    /// Whether its vertices were shaded on the side facing the eye.
    pub two_sided: bool,
    /// The self-check of the object alone (self-shadowing; `selfcheck`).
    pub self_check: Option<SelfCheckReport>,
}

/// Blockers per shaded vertex per frame: the object's own before culling,
/// the other objects' (`OtherStats`, per vertex), and what was rasterised
/// after every culling, own and others together.
#[derive(Debug, Clone, Serialize)]
pub struct BlockersPerVertex {
    /// The object's own candidates (hierarchy lists), before any culling.
    pub own_before_culling: f64,
    /// The other objects' blockers, by what happened to them.
    pub others: OtherPerVertex,
    /// Blockers rasterised, own and others', after every culling.
    pub drawn: f64,
}

/// `OtherStats` per vertex.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct OtherPerVertex {
    /// Triangles of the other objects' approximations, before culling.
    pub before_culling: f64,
    /// Skipped with their whole object (below the horizon, under a pixel).
    pub object_culled: f64,
    /// Skipped with their culling group.
    pub group_culled: f64,
    /// Coarse triangles replaced by fine ones near contact.
    pub refined: f64,
    /// Fine triangles drawn in their place.
    pub refined_fine: f64,
    /// Gathered triangles wholly below the horizon.
    pub below_horizon: f64,
    /// Triangles passed to the rasteriser (before back-face culling).
    pub gathered: f64,
}

/// Error against ray tracing of the whole scene by inter-object mode.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct ModeErrors {
    /// Self-shadowing only ([`InterObject::Off`]).
    pub off: f64,
    /// Other objects' coarse levels ([`InterObject::Coarse`]).
    pub coarse: f64,
    /// Other objects' full meshes ([`InterObject::Fine`]).
    pub fine: f64,
}

/// Milliseconds of each phase of a frame, averaged over the frames.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct ScenePhases {
    /// The instances' poses.
    pub pose: f64,
    /// The probe's SH lighting turned by `env_spin`.
    pub lighting: f64,
    /// The other objects' approximations placed and bounded.
    pub blockers: f64,
    /// Masks, transfer, rotation and shading of every shaded object.
    pub transfer: f64,
    /// The host's work per frame (images, CSV rows): not in `fps`.
    pub output: f64,
}

/// The scene's transfer on the checked frames compared with Monte Carlo ray
/// tracing of the whole scene at full resolution.
#[derive(Debug, Clone, Serialize)]
pub struct SceneCheck {
    /// Rays per vertex of the reference.
    pub rays: u32,
    /// The frames checked, evenly spread over the run.
    pub frames: Vec<usize>,
    /// The error of each checked frame (mode in use).
    pub per_frame: Vec<f64>,
    /// Shaded vertices compared, summed over the checked frames.
    pub vertices: usize,
    /// Vertices skipped as nearly dark (a reference transfer of at most 1%
    /// of the unoccluded transfer's length), summed over the checked frames.
    pub skipped_dark: usize,
    /// Seed of the reference's ray directions.
    pub seed: u32,
}

/// Sums of (error x vertices, vertices) per object and mode, over checks.
#[derive(Default, Clone)]
struct Tally {
    by_object: Vec<[(f64, usize); 3]>,
}

impl Tally {
    fn add(&mut self, mode: usize, errors: &ObjectErrors) {
        self.by_object.resize(errors.len(), Default::default());
        for (t, e) in self.by_object.iter_mut().zip(errors) {
            if let Some((e, n, _)) = e {
                t[mode].0 += e * *n as f64;
                t[mode].1 += n;
            }
        }
    }

    /// Adds another tally's sums (a frame's), object by object.
    fn sum(&mut self, by_object: &[[(f64, usize); 3]]) {
        if self.by_object.len() < by_object.len() {
            self.by_object.resize(by_object.len(), Default::default());
        }
        for (t, o) in self.by_object.iter_mut().zip(by_object) {
            for (t, o) in t.iter_mut().zip(o) {
                t.0 += o.0;
                t.1 += o.1;
            }
        }
    }

    fn mean(&self, object: Option<usize>, mode: usize) -> f64 {
        let (s, n) = self
            .by_object
            .iter()
            .enumerate()
            .filter(|(k, _)| object.is_none_or(|o| o == *k))
            .fold((0.0, 0), |(s, n), (_, t)| (s + t[mode].0, n + t[mode].1));
        if n == 0 { 0.0 } else { s / n as f64 }
    }

    fn modes(&self, object: Option<usize>) -> ModeErrors {
        ModeErrors {
            off: self.mean(object, 0),
            coarse: self.mean(object, 1),
            fine: self.mean(object, 2),
        }
    }
}

fn mode_index(m: InterObject) -> usize {
    match m {
        InterObject::Off => 0,
        InterObject::Coarse => 1,
        InterObject::Fine => 2,
    }
}

/// Plays `scene`'s instances (their `motion` per frame) under `env`, seen
/// from `eye`, calling `on_frame` with each frame's index and the shaded
/// objects' positions and results merged (`ObjectsRunner::merge`).
pub fn play_scene(
    runner: &mut ObjectsRunner,
    scene: &Scene,
    lit: (&EnvironmentMap, Option<Vec3>),
    animation: &Playback,
    on_frame: impl FnMut(usize, &[Vec3], &FrameOutput) -> Result<()>,
) -> Result<SceneReport> {
    let play = ScenePlay::prepare(runner, scene, lit, animation, true)?;
    let mut records = Vec::with_capacity(animation.frames);
    play.play(runner, 0..animation.frames, on_frame, |r| {
        records.push(r.clone());
        Ok(())
    })?;
    Ok(play.report(runner, &records))
}

/// A scene ready to play: the lighting and the objects' self-checks.
/// Every frame depends on these and on its index only, so any range of the
/// frames can be played on its own (a shard of them) with the pixels of a
/// whole run.
pub struct ScenePlay<'a> {
    scene: &'a Scene,
    eye: Option<Vec3>,
    playback: &'a Playback,
    lighting_world: ShRgb,
    rotation: ShRotation,
    deringing: Deringing,
    self_checks: Vec<Option<SelfCheckReport>>,
}

/// What one frame of a scene measured (`ScenePlay::play`); a run's report
/// is made from its frames' records (`ScenePlay::report`).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SceneFrameRecord {
    /// The frame's index in the playback.
    pub frame: usize,
    /// The whole frame (as `fps`), ms.
    pub ms: f64,
    /// The SH transfer kernels' time from GPU timestamps, where there is one.
    pub gpu_ms: Option<f64>,
    /// The frame's phases.
    pub phases: ScenePhases,
    /// Each object's counts, in instance order.
    pub stats: Vec<FrameStats>,
    /// The comparison with ray tracing, on a checked frame.
    pub check: Option<SceneFrameCheck>,
}

/// A checked frame of a scene compared with ray tracing of the whole scene.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SceneFrameCheck {
    /// The pooled error of the mode in use.
    pub error: f64,
    /// Vertices skipped as nearly dark.
    pub skipped_dark: usize,
    /// Per object and mode (off, coarse, fine): error times vertices, and
    /// vertices.
    pub by_object: Vec<[(f64, usize); 3]>,
}

impl<'a> ScenePlay<'a> {
    /// Checks `animation` against the runner, projects and windows the
    /// lighting and, with `self_check`, runs the objects' self-checks where
    /// asked for (they only report: a shard of the frames may leave them to
    /// the merge).
    pub fn prepare(
        runner: &ObjectsRunner,
        scene: &'a Scene,
        (env, eye): (&EnvironmentMap, Option<Vec3>),
        animation: &'a Playback,
        self_check: bool,
    ) -> Result<ScenePlay<'a>> {
        animation.validate()?;
        if animation.pvs.is_some() {
            return Err(Error::param("pvs", "does not apply to a scene of several objects"));
        }
        if scene.instances.len() != runner.len() {
            return Err(Error::input(
                "scene",
                "has another number of instances than the runner objects",
            ));
        }
        let bands = runner.object(0).2.prt().settings.bands;
        let (lighting_world, deringing) = nonnegative(&project_environment(env, bands));
        let rotation = ShRotation::new(bands);
        let self_checks = match self_check {
            true => self_checks(runner, scene, eye, animation)?,
            false => vec![None; runner.len()],
        };
        Ok(ScenePlay {
            scene,
            eye,
            playback: animation,
            lighting_world,
            rotation,
            deringing,
            self_checks,
        })
    }

    fn poses(&self, f: usize) -> Vec<Vec<Vec3>> {
        let scene = self.scene;
        scene
            .instances
            .iter()
            .map(|i| instance_positions(scene, i, f as u32))
            .collect()
    }

    fn lighting(&self, f: usize) -> Vec<f32> {
        let degrees = self.playback.env_spin * f as f32;
        spun(&self.lighting_world, &self.rotation, degrees).to_f32_planar()
    }

    /// Frame `f`'s shaded objects' positions and results, merged
    /// (`ObjectsRunner::merge`), not checked nor timed (e.g. the first
    /// frame, whose radiance sets an image's exposure, for a shard that
    /// does not play it).
    pub fn frame(
        &self,
        runner: &mut ObjectsRunner,
        f: usize,
        positions: &mut Vec<Vec3>,
        out: &mut FrameOutput,
    ) -> Result<()> {
        let poses = self.poses(f);
        let blockers = runner.blockers(&poses, runner.inter_object());
        let mut outs = Vec::new();
        let profile = self.playback.profile;
        runner.frame_with(&poses, self.eye, &self.lighting(f), profile, &blockers, &mut outs)?;
        runner.merge(&poses, &outs, positions, out);
        Ok(())
    }

    /// Plays the frames `frames` of the playback (a range of `0..frames`),
    /// calling `on_frame` with each frame's index and merged results, then
    /// `on_record` with what the frame measured.
    pub fn play(
        &self,
        runner: &mut ObjectsRunner,
        frames: Range<usize>,
        mut on_frame: impl FnMut(usize, &[Vec3], &FrameOutput) -> Result<()>,
        mut on_record: impl FnMut(&SceneFrameRecord) -> Result<()>,
    ) -> Result<()> {
        let animation = self.playback;
        if frames.end > animation.frames {
            let problem = format!("{frames:?} is past the {} frames played", animation.frames);
            return Err(Error::param("frames", problem));
        }
        let checked = animation.checked();
        let progress = animation.bars.bar(frames.len() as u64, "frames");
        let (mut outs, mut merged, mut merged_pos) = (Vec::new(), FrameOutput::default(), Vec::new());
        for f in frames {
            let start = Instant::now();
            let poses = self.poses(f);
            let posed = Instant::now();
            let lighting = self.lighting(f);
            let lit = Instant::now();
            let blockers = runner.blockers(&poses, runner.inter_object());
            let placed = Instant::now();
            let gpu_ms = runner.frame_with(&poses, self.eye, &lighting, animation.profile, &blockers, &mut outs)?;
            let done = Instant::now();
            let mut record = SceneFrameRecord {
                frame: f,
                ms: ms_between(start, done),
                gpu_ms,
                phases: ScenePhases {
                    pose: ms_between(start, posed),
                    lighting: ms_between(posed, lit),
                    blockers: ms_between(lit, placed),
                    transfer: ms_between(placed, done),
                    output: 0.0,
                },
                stats: outs.iter().map(|o| o.stats.clone()).collect(),
                check: None,
            };
            progress.inc(1);
            if checked.contains(&f) {
                let mut tally = Tally::default();
                let errors = check_frame(runner, &poses, self.eye, &lighting, &mut outs, &mut tally)?;
                let (error, _, skipped_dark) = pooled(&errors);
                record.check = Some(SceneFrameCheck {
                    error,
                    skipped_dark,
                    by_object: tally.by_object,
                });
            }
            let output = Instant::now();
            runner.merge(&poses, &outs, &mut merged_pos, &mut merged);
            on_frame(f, &merged_pos, &merged)?;
            record.phases.output = elapsed_ms(output);
            on_record(&record)?;
        }
        Ok(())
    }

    /// The report of the frames `records` (in frame order): a whole run's
    /// where they are every frame of the playback.
    pub fn report(&self, runner: &ObjectsRunner, records: &[SceneFrameRecord]) -> SceneReport {
        let mut sums = vec![FrameStats::default(); runner.len()];
        let mut phases = ScenePhases::default();
        let (mut tally, mut frames, mut per_frame, mut skipped) = (Tally::default(), Vec::new(), Vec::new(), 0);
        for r in records {
            for (s, o) in sums.iter_mut().zip(&r.stats) {
                *s += o;
            }
            phases.pose += r.phases.pose;
            phases.lighting += r.phases.lighting;
            phases.blockers += r.phases.blockers;
            phases.transfer += r.phases.transfer;
            phases.output += r.phases.output;
            if let Some(c) = &r.check {
                tally.sum(&c.by_object);
                frames.push(r.frame);
                per_frame.push(c.error);
                skipped += c.skipped_dark;
            }
        }
        let check = (!frames.is_empty()).then(|| SceneCheck {
            rays: runner.reference().rays,
            frames,
            per_frame,
            vertices: tally.by_object.iter().map(|t| t[0].1.max(t[1].1).max(t[2].1)).sum(),
            skipped_dark: skipped,
            seed: runner.reference().seed,
        });
        let timing = Timing {
            frame_ms: records.iter().map(|r| r.ms).collect(),
            gpu_ms: records.iter().filter_map(|r| r.gpu_ms).collect(),
            phases,
            profile: self.playback.profile,
        };
        report(
            runner,
            &sums,
            timing,
            check.map(|c| (c, tally)),
            self.self_checks.clone(),
            self.deringing.clone(),
        )
    }
}

/// The checked frame's errors against the whole scene ray traced: the mode
/// in use (already in `outs`), and with `--shadows on` the two others (the
/// tally's three modes). Returns the errors of the mode in use.
fn check_frame(
    runner: &mut ObjectsRunner,
    poses: &[Vec<Vec3>],
    eye: Option<Vec3>,
    lighting: &[f32],
    outs: &mut [FrameOutput],
    tally: &mut Tally,
) -> Result<ObjectErrors> {
    let normals: Vec<Vec<Vec3>> = outs.iter().map(|o| o.normals.clone()).collect();
    let reference = match runner.shadows() {
        Shadows::Raytraced => outs.iter().map(|o| o.transfer.clone()).collect(),
        _ => runner.reference_transfer(poses, &normals, eye)?,
    };
    let in_use = runner.errors(outs, &reference);
    let mode = runner.inter_object();
    tally.add(mode_index(mode), &in_use);
    if runner.shadows() == Shadows::On {
        let mut other = Vec::new();
        for m in [InterObject::Off, InterObject::Coarse, InterObject::Fine] {
            if m == mode {
                continue;
            }
            let blockers = match m {
                InterObject::Off => SceneBlockers::default(),
                _ => runner.blockers(poses, m),
            };
            runner.frame_with(poses, eye, lighting, false, &blockers, &mut other)?;
            tally.add(mode_index(m), &runner.errors(&other, &reference));
        }
    }
    Ok(in_use)
}

struct Timing {
    frame_ms: Vec<f64>,
    gpu_ms: Vec<f64>,
    phases: ScenePhases,
    profile: bool,
}

/// Table 2's shares from the CPU phases summed over threads and objects
/// (per frame: divided by the thread count). On a GPU the integration is
/// the kernels' time and "other" the rest of the frame.
fn table_two(all: &FrameStats, t: &Timing, gpu_ms: Option<f64>) -> Phases {
    let nf = t.frame_ms.len().max(1) as f64;
    let threads = rayon::current_num_threads() as f64;
    let mut ms = all.phase_ns.map(|n| n as f64 * 1e-6 / nf / threads);
    if let Some(kernel) = gpu_ms {
        ms[2] = kernel;
        ms[3] = (t.frame_ms.iter().sum::<f64>() / nf - ms[0] - ms[1] - ms[2]).max(0.0);
    }
    let total: f64 = ms.iter().sum::<f64>().max(1e-12);
    Phases {
        transform: ms[0] / total,
        rasterization: ms[1] / total,
        integration: ms[2] / total,
        other: ms[3] / total,
        ms_per_frame: ms,
    }
}

/// Each shaded, self-shadowed object's self-check on its first pose.
fn self_checks(
    runner: &ObjectsRunner,
    scene: &Scene,
    eye: Option<Vec3>,
    animation: &Playback,
) -> Result<Vec<Option<SelfCheckReport>>> {
    let Some(check) = animation.self_check.filter(|_| runner.shadows() == Shadows::On) else {
        return Ok(vec![None; runner.len()]);
    };
    let _shown = animation.bars.spinner("self-check");
    (0..runner.len())
        .map(|k| {
            let (_, role, r) = runner.object(k);
            if role != Role::Both {
                return Ok(None);
            }
            let pose = instance_positions(scene, &scene.instances[k], 0);
            r.self_check(&[(0, pose)], eye, &check).map(Some)
        })
        .collect()
}

fn per_vertex(s: &FrameStats) -> BlockersPerVertex {
    let n = s.vertices.max(1) as f64;
    let o: &OtherStats = &s.others;
    BlockersPerVertex {
        own_before_culling: s.candidates as f64 / n,
        others: OtherPerVertex {
            before_culling: o.candidates as f64 / n,
            object_culled: o.object_culled as f64 / n,
            group_culled: o.group_culled as f64 / n,
            refined: o.refined as f64 / n,
            refined_fine: o.refined_fine as f64 / n,
            below_horizon: o.below_horizon as f64 / n,
            gathered: o.gathered as f64 / n,
        },
        drawn: s.drawn as f64 / n,
    }
}

fn report(
    runner: &ObjectsRunner,
    sums: &[FrameStats],
    t: Timing,
    check: Option<(SceneCheck, Tally)>,
    self_checks: Vec<Option<SelfCheckReport>>,
    lighting: Deringing,
) -> SceneReport {
    let nf = t.frame_ms.len().max(1) as f64;
    let total_ms: f64 = t.frame_ms.iter().sum();
    let best = t.frame_ms.iter().copied().fold(f64::INFINITY, f64::min);
    let mut sorted = t.frame_ms.clone();
    sorted.sort_by(f64::total_cmp);
    let by_mode = |o: Option<usize>, tally: &Tally| (runner.shadows() == Shadows::On).then(|| tally.modes(o));
    let in_use = mode_index(runner.inter_object());
    let tally = check.as_ref().map(|(_, t)| t);
    let mut all = FrameStats::default();
    sums.iter().for_each(|s| all += s);
    let objects: Vec<ObjectReport> = (0..runner.len())
        .zip(self_checks)
        .map(|(k, self_check)| {
            let (name, role, r) = runner.object(k);
            let prt = r.prt();
            ObjectReport {
                name: name.to_string(),
                role,
                vertices: prt.vertex_count,
                triangles: runner.triangles(k).len(),
                coarse_triangles: runner.approximation(k).0,
                blockers_per_vertex: role.receives().then(|| per_vertex(&sums[k])),
                transfer_l2_error: tally.filter(|_| role.receives()).map(|t| t.mean(Some(k), in_use)),
                errors_by_inter_object: tally.filter(|_| role.receives()).and_then(|t| by_mode(Some(k), t)),
                backface_culling: prt.cull_backfaces,
                two_sided: prt.two_sided,
                self_check,
            }
        })
        .collect();
    let p = t.phases;
    let modes = tally.and_then(|t| by_mode(None, t));
    let gpu_ms = (!t.gpu_ms.is_empty()).then(|| t.gpu_ms.iter().sum::<f64>() / t.gpu_ms.len() as f64);
    let prt = runner.object(0).2.prt();
    SceneReport {
        vertices: objects.iter().filter(|o| o.role.receives()).map(|o| o.vertices).sum(),
        triangles: objects.iter().map(|o| o.triangles).sum(),
        objects,
        inter_object: runner.inter_object(),
        shadows: runner.shadows(),
        fps: 1e3 * nf / total_ms.max(1e-9),
        fps_best: 1e3 / best.max(1e-9),
        frame_ms: FrameTimes {
            mean: total_ms / nf,
            median: sorted.get(sorted.len() / 2).copied().unwrap_or(0.0),
            best,
        },
        phases_ms: ScenePhases {
            pose: p.pose / nf,
            lighting: p.lighting / nf,
            blockers: p.blockers / nf,
            transfer: p.transfer / nf,
            output: p.output / nf,
        },
        phases: t.profile.then(|| table_two(&all, &t, gpu_ms)),
        gpu_ms_per_frame: gpu_ms,
        frames: t.frame_ms.len(),
        blockers_per_vertex: per_vertex(&all),
        transfer_l2_error: tally.map(|t| t.mean(None, in_use)),
        errors_by_inter_object: modes,
        inter_object_cost: modes.map(|m| m.coarse - m.fine),
        inter_object_gain: modes.map(|m| m.off - m.coarse),
        check: check.map(|(c, _)| c),
        order: prt.settings.bands,
        coefficients: coefficient_count(prt.settings.bands),
        mask: prt.settings.mask_side,
        setup_ms: (0..runner.len()).map(|k| runner.object(k).2.prt().setup_ms).sum(),
        lighting,
    }
}

/// `play_scene` played `runs.warmup` untimed times, then `runs.repeat`
/// measured times (`runner::animate_runs`); `on_frame` sees only the last
/// play's frames, and the report is the last play's.
pub fn play_scene_runs(
    runner: &mut ObjectsRunner,
    scene: &Scene,
    lit: (&EnvironmentMap, Option<Vec3>),
    animation: &Playback,
    runs: crate::report::repeats::Repeats,
    mut on_frame: impl FnMut(usize, &[Vec3], &FrameOutput) -> Result<()>,
) -> Result<(SceneReport, crate::report::repeats::RunTimes)> {
    let (plays, mut play) = (runs.warmup + runs.repeat.max(1), 0);
    let once = || {
        play += 1;
        let last = play == plays;
        play_scene(runner, scene, lit, animation, |f, positions, out| match last {
            true => on_frame(f, positions, out),
            false => Ok(()),
        })
    };
    runs.run("animation_ms", once, |r| r.frame_ms.mean * r.frames as f64)
}

impl SceneReport {
    /// The objects' self-check warnings, each naming its object, and the
    /// lighting's (`Deringing::warning`).
    pub fn warnings(&self) -> Vec<String> {
        self.objects
            .iter()
            .filter_map(|o| {
                let w = o.self_check.as_ref()?.warning()?;
                Some(format!("{}: {w}", o.name))
            })
            .chain(self.lighting.warning())
            .collect()
    }
}
