//! The PRT runner: per-frame transfer and radiance of a deforming mesh on
//! any device (the masks are rasterised on the CPU; integration, rotation
//! and shading run in `sh_transfer.wgsl` on a GPU or in their CPU twin),
//! with the Monte Carlo ray-traced reference for checks. `PrtRunner::frame`
//! is what a host calls every frame with its own vertex positions;
//! `animate` is the command line's loop over a scene mesh's animation.

use std::ops::Range;
use std::time::Instant;

use glam::{DMat3, Vec3};
use serde::{Deserialize, Serialize};

use super::blockers::SceneBlockers;
use super::gpu::{FrameInputs, GpuTransfer, MAX_GPU_BANDS};
use super::hierarchy::NearField;
use super::pipeline::{FrameOutput, FrameStats, Prt, PrtSettings};
use super::reference::{reference_transfer, relative_l2_error};
use super::selfcheck::{SelfCheck, SelfCheckReport};
use super::sides::Sides;
use super::transfer::{Brdf, Integration, radiance};
use crate::accel::Accel;
use crate::accel::kdtree::{KdTree, KdTreeSettings};
use crate::error::{Error, Result};
use crate::gpu::device::{Device, OnDevice, elapsed_ms};
use crate::progress::Reporter;
use crate::report::repeats::{Repeats, RunTimes};
use crate::scene::deform::{AnimationSource, Clip};
use crate::scene::{EnvironmentMap, Mesh, SceneMesh};
use crate::sh::window::{Deringing, nonnegative};
use crate::sh::{ShRgb, ShRotation, coefficient_count, project_environment};

/// Where a frame's visibility comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Shadows {
    /// Hemispherical rasterisation.
    On,
    /// No visibility (unshadowed transfer).
    Off,
    /// Monte Carlo ray-traced visibility (the reference's rays per vertex; slow).
    Raytraced,
}

/// The Monte Carlo ray-traced reference: rays per vertex and the sequence's seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RayTraced {
    /// Cosine-distributed rays per vertex (the command line's default: 4096).
    pub rays: u32,
    /// Seed of the scrambled Sobol sequence the directions come from.
    pub seed: u32,
}

/// Transfer of one mesh, frame after frame, on a device.
pub struct PrtRunner {
    prt: Prt,
    triangles: Vec<[u32; 3]>,
    shadows: Shadows,
    reference: RayTraced,
    device: Device,
    gpu: OnDevice<GpuTransfer>,
    notes: Vec<String>,
}

impl PrtRunner {
    /// Precomputed radiance transfer of `mesh` on `device` with `settings`
    /// (shadows by hemispherical rasterisation when `settings.shadows`,
    /// Kautz, Lehtinen and Aila 2004): the tables and hierarchy are built
    /// from `mesh` as the rest pose, then `frame` shades any pose of it
    /// under SH lighting.
    ///
    /// ```
    /// use glam::Vec3;
    /// use penumbra::{Device, PrtRunner, PrtSettings};
    /// use penumbra::prt::pipeline::FrameOutput;
    /// use penumbra::scene::procedural::sphere_on_plane;
    ///
    /// let mesh = sphere_on_plane();
    /// let settings = PrtSettings { bands: 3, ..Default::default() };
    /// let mut prt = PrtRunner::for_mesh(&Device::cpu(), &mesh, &settings)?;
    /// // Constant white light: only the first SH coefficient of each channel.
    /// let coeffs = prt.prt().coeffs();
    /// let mut lighting = vec![0.0; 3 * coeffs];
    /// for c in 0..3 {
    ///     lighting[c * coeffs] = 1.0;
    /// }
    /// let mut out = FrameOutput::default();
    /// prt.frame(&mesh.positions, Some(Vec3::new(0.0, 3.0, 5.0)), &lighting, false, &mut out)?;
    /// assert_eq!(out.radiance.len(), mesh.positions.len());
    /// # Ok::<(), penumbra::Error>(())
    /// ```
    pub fn for_mesh(device: &Device, mesh: &Mesh, settings: &PrtSettings) -> Result<PrtRunner> {
        let shadows = if settings.shadows { Shadows::On } else { Shadows::Off };
        // The command line's `--reference-rays` default.
        let reference = RayTraced {
            rays: 4096,
            seed: crate::geom::sampling::DEFAULT_SEED,
        };
        PrtRunner::new(device, &mesh.positions, &mesh.triangles, settings, shadows, reference)
    }

    /// Builds the tables and hierarchy of the mesh from its rest pose and,
    /// on a GPU, uploads them. A device chosen automatically runs what its
    /// GPU kernel cannot (more than `MAX_GPU_BANDS` bands) on the CPU, with
    /// a note; a GPU asked for explicitly is an error then.
    pub fn new(
        device: &Device,
        rest: &[Vec3],
        triangles: &[[u32; 3]],
        settings: &PrtSettings,
        shadows: Shadows,
        reference: RayTraced,
    ) -> Result<PrtRunner> {
        Self::build(device, &[rest], triangles, settings, (shadows, reference))
    }

    /// `new` for an animated mesh: `poses[0]` is the rest pose, the others
    /// poses its coarse level is checked on too (`Playback::poses`).
    pub fn new_posed(
        device: &Device,
        poses: &[Vec<Vec3>],
        triangles: &[[u32; 3]],
        settings: &PrtSettings,
        shadows: Shadows,
        reference: RayTraced,
    ) -> Result<PrtRunner> {
        let poses: Vec<&[Vec3]> = poses.iter().map(Vec::as_slice).collect();
        Self::build(device, &poses, triangles, settings, (shadows, reference))
    }

    fn build(
        device: &Device,
        poses: &[&[Vec3]],
        triangles: &[[u32; 3]],
        settings: &PrtSettings,
        (shadows, reference): (Shadows, RayTraced),
    ) -> Result<PrtRunner> {
        let settings = PrtSettings {
            shadows: shadows == Shadows::On,
            ..settings.clone()
        };
        settings.validate()?;
        let mut notes = Vec::new();
        let mut device = device.clone();
        if device.is_gpu() && settings.bands > MAX_GPU_BANDS && device.is_automatic() {
            notes.push(format!(
                "the GPU kernel integrates up to {MAX_GPU_BANDS} SH bands; `bands` {} runs on the CPU",
                settings.bands
            ));
            device = device.cpu_instead();
        }
        let prt = Prt::new_posed(poses, triangles, &settings)?;
        // Ray-traced shadows need no kernel: the GPU integrates masks only.
        let gpu = match shadows {
            Shadows::Raytraced => OnDevice::Cpu,
            _ => device.prepare(|ctx| GpuTransfer::new(ctx, &prt))?,
        };
        Ok(PrtRunner {
            prt,
            triangles: triangles.to_vec(),
            shadows,
            reference,
            device,
            gpu,
            notes,
        })
    }

    /// The tables, hierarchy and CPU pipeline the runner computes with.
    pub fn prt(&self) -> &Prt {
        &self.prt
    }

    /// The device the runner computes on (the CPU where it fell back).
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// What the runner chose on its own (e.g. falling back to the CPU).
    pub fn notes(&self) -> &[String] {
        &self.notes
    }

    /// Replaces the hierarchy's blocker lists by potentially visible sets
    /// gathered from sampled poses (positions per pose).
    pub fn use_pvs(&mut self, poses: &[Vec<Vec3>]) -> Result<()> {
        let pvs = super::pvs::build_pvs(&self.prt, poses)?;
        self.prt.set_pvs(Some(pvs));
        Ok(())
    }

    /// One frame: transfer, radiance and shading normals at every vertex
    /// for `positions` (the mesh's current pose), seen from `eye` (two-sided
    /// meshes, glossy BRDFs), under planar RGB SH `lighting` (`3 x coeffs`).
    /// Returns the GPU kernel's time where there is one.
    pub fn frame(
        &mut self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        lighting: &[f32],
        profile: bool,
        out: &mut FrameOutput,
    ) -> Result<Option<f64>> {
        self.frame_with(positions, eye, lighting, profile, None, out)
    }

    /// `frame` of object `id` of a scene, with the other objects'
    /// `blockers` in its masks (`blockers`; on a GPU too: the masks are
    /// the CPU's). Ray-traced shadows here are the mesh's own.
    pub fn frame_with(
        &mut self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        lighting: &[f32],
        profile: bool,
        others: Option<(&SceneBlockers, usize)>,
        out: &mut FrameOutput,
    ) -> Result<Option<f64>> {
        let prt = &self.prt;
        match (self.shadows, &mut self.gpu) {
            (Shadows::Raytraced, _) => {
                prt.shading_normals(positions, eye, &mut out.normals);
                out.transfer = self.reference_transfer(positions, &out.normals, eye)?;
                out.radiance = out
                    .transfer
                    .chunks(prt.coeffs())
                    .map(|t| radiance(lighting, t))
                    .collect();
                out.stats = FrameStats::default();
                Ok(None)
            }
            (_, OnDevice::Gpu { ctx, state }) => {
                prt.frame_masks_with(positions, eye, profile, others, out)?;
                let inputs = FrameInputs {
                    masks: &out.masks,
                    positions,
                    normals: &out.normals,
                    eye,
                    lighting,
                };
                let g = state.run_frame(ctx, &inputs)?;
                out.transfer = g.transfer;
                out.radiance = g.radiance;
                Ok(g.kernel_ms)
            }
            (_, OnDevice::Cpu) => {
                prt.frame_with(positions, eye, lighting, (profile, false), others, out)?;
                Ok(None)
            }
        }
    }

    /// Monte Carlo ray-traced transfer of a pose (kd-tree of the full mesh)
    /// for the given shading normals.
    pub fn reference_transfer(&self, positions: &[Vec3], normals: &[Vec3], eye: Option<Vec3>) -> Result<Vec<f32>> {
        let soup: Vec<[Vec3; 3]> = self
            .triangles
            .iter()
            .map(|t| t.map(|i| positions[i as usize]))
            .collect();
        let tree = Accel::new(KdTree::from_triangles(soup, &KdTreeSettings::default())?);
        let s = &self.prt.settings;
        let RayTraced { rays, seed } = self.reference;
        Ok(reference_transfer(
            &tree,
            positions,
            normals,
            self.prt.scale,
            s.bands,
            &s.brdf,
            eye,
            rays,
            seed,
        ))
    }

    /// The self-check's estimate of the transfer error on `poses` (frame
    /// index and positions each), from a sample of vertices (`selfcheck`).
    pub fn self_check(
        &self,
        poses: &[(usize, Vec<Vec3>)],
        eye: Option<Vec3>,
        check: &SelfCheck,
    ) -> Result<SelfCheckReport> {
        super::selfcheck::estimate(&self.prt, &self.triangles, poses, eye, check, self.reference.seed)
    }

    /// The frame's mean relative L2 transfer error against ray tracing:
    /// (error, vertices counted, vertices skipped as nearly dark).
    pub fn transfer_error(
        &self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        frame: &FrameOutput,
    ) -> Result<(f64, usize, usize)> {
        // Ray-traced shadows already are the reference: no second trace.
        let reference = match self.shadows {
            Shadows::Raytraced => frame.transfer.clone(),
            _ => self.reference_transfer(positions, &frame.normals, eye)?,
        };
        let t = &self.prt.tables;
        let unoccluded = t.unoccluded.iter().map(|v| v * v).sum::<f32>().sqrt();
        Ok(relative_l2_error(
            &frame.transfer,
            &reference,
            t.coeffs,
            0.01 * unoccluded,
        ))
    }
}

/// How an animation is played: frames, time, lighting spin, PVS, checks.
#[derive(Debug, Clone, PartialEq)]
pub struct Playback {
    /// Frames played (at least 1).
    pub frames: usize,
    /// Animation time of the first frame, seconds.
    pub start: f32,
    /// Animation time between frames, seconds.
    pub dt: f32,
    /// Turn the lighting about +y by this many degrees per frame.
    pub env_spin: f32,
    /// Gather a potentially visible set from sampled poses before the
    /// first frame and use it instead of the hierarchy (section 3.2, "PVS");
    /// `None`: no PVS.
    pub pvs: Option<PvsSampling>,
    /// Frames compared with ray tracing, evenly spread (0: none).
    pub check_frames: usize,
    /// Per-phase times (the paper's Table 2).
    pub profile: bool,
    /// The ray-traced error estimate at setup (`selfcheck`; None: none).
    pub self_check: Option<SelfCheck>,
    /// Progress of the PVS, the self-check and the frames (with their checks).
    pub bars: Reporter,
}

/// Poses a PVS is gathered from: `frames` over `span` seconds from the
/// start (default: the frames' span, at least 2 s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PvsSampling {
    /// Poses sampled, evenly over the span, first and last included (at
    /// least 1).
    pub frames: usize,
    /// Animation seconds the poses span from `Playback::start`; `None`:
    /// the played frames' span, at least 2 s.
    pub span: Option<f32>,
}

impl Playback {
    /// Checks for at least one frame (and one PVS pose), finite times and
    /// spin, and a valid self-check; an error naming the setting otherwise.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("frames", self.frames),
            ("pvs_frames", self.pvs.map_or(1, |p| p.frames)),
        ] {
            if v == 0 {
                return Err(Error::param(name, format!("must be positive, got {v}")));
            }
        }
        if !(self.dt.is_finite() && self.start.is_finite() && self.env_spin.is_finite()) {
            return Err(Error::param("dt/start/env_spin", "must be finite"));
        }
        if let Some(c) = &self.self_check {
            c.validate()?;
        }
        Ok(())
    }

    /// Plays a user's animation `clip` (a sequence, a glTF clip): `start`
    /// counts from the clip's start; without `frames_given` every frame of
    /// the clip is played (at `dt` where given, else at the clip's rate);
    /// without `dt_given` the frames sample the clip evenly, first and last
    /// keyframes included.
    pub fn fit_clip(&mut self, clip: Option<Clip>, frames_given: bool, dt_given: bool) -> Result<()> {
        let Some(clip) = clip else {
            return Ok(());
        };
        self.start += clip.start;
        if !frames_given {
            self.frames = match dt_given {
                true if self.dt > 0.0 => (clip.duration / self.dt).floor() as usize + 1,
                _ => clip.frames,
            };
        }
        if !dt_given {
            self.dt = clip.spacing(self.frames);
        }
        self.validate()
    }

    pub(crate) fn time(&self, frame: usize) -> f32 {
        self.start + frame as f32 * self.dt
    }

    /// The frames checked against ray tracing.
    pub(crate) fn checked(&self) -> Vec<usize> {
        self.spread(self.check_frames)
    }

    /// The poses a runner for `mesh` is built on: the first frame's (the
    /// rest pose), then, for an animated mesh, those of `k` frames spread
    /// over the playback, the rest pose's repeat left out.
    pub fn poses(&self, mesh: &SceneMesh, k: usize) -> Vec<Vec<Vec3>> {
        let at = |f: usize| {
            let mut p = Vec::new();
            mesh.positions_at(self.time(f), &mut p);
            p
        };
        let mut poses = vec![at(0)];
        if mesh.animation.is_some() {
            poses.extend(self.spread(k).into_iter().filter(|&f| f > 0).map(at));
        }
        poses
    }

    /// `k` frames evenly spread over the run (fewer if there are fewer).
    pub(crate) fn spread(&self, k: usize) -> Vec<usize> {
        let k = k.min(self.frames);
        (0..k)
            .map(|i| if k == 1 { 0 } else { i * (self.frames - 1) / (k - 1) })
            .collect()
    }
}

/// `animate` played `runs.warmup` untimed times, then `runs.repeat`
/// measured times (each play's measure: the sum of its frame times, setup
/// and checks apart); `on_frame` sees only the last play's frames, and the
/// report is the last play's.
pub fn animate_runs(
    runner: &mut PrtRunner,
    (mesh, env): (&SceneMesh, &EnvironmentMap),
    eye: Option<Vec3>,
    animation: &Playback,
    runs: Repeats,
    mut on_frame: impl FnMut(usize, &[Vec3], &FrameOutput) -> Result<()>,
) -> Result<(PrtReport, RunTimes)> {
    let (plays, mut play) = (runs.warmup + runs.repeat, 0);
    let once = || {
        play += 1;
        let last = play == plays;
        animate(runner, mesh, env, eye, animation, |f, positions, out| match last {
            true => on_frame(f, positions, out),
            false => Ok(()),
        })
    };
    runs.run("animation_ms", once, |r| r.frame_ms.mean * r.frames as f64)
}

/// Runs `animation` of `mesh` under `env`, seen from `eye`, calling
/// `on_frame` with each frame's index, pose and results, and reports what
/// it measured. The probe is projected onto the runner's bands and windowed
/// to stay non-negative (`sh::window`); the PVS and the self-check, where
/// asked for, are made before the first frame.
pub fn animate(
    runner: &mut PrtRunner,
    mesh: &SceneMesh,
    env: &EnvironmentMap,
    eye: Option<Vec3>,
    animation: &Playback,
    on_frame: impl FnMut(usize, &[Vec3], &FrameOutput) -> Result<()>,
) -> Result<PrtReport> {
    let played = Animation::prepare(runner, (mesh, env, eye), animation, true)?;
    let mut records = Vec::with_capacity(animation.frames);
    played.play(runner, 0..animation.frames, on_frame, |r| {
        records.push(r.clone());
        Ok(())
    })?;
    Ok(played.report(runner, &records))
}

/// An animation ready to play: the lighting, and the PVS and self-check
/// made before its first frame. Every frame depends on these and on its
/// index only, so any range of the frames can be played on its own (a
/// shard of them) with the pixels of a whole run.
pub struct Animation<'a> {
    mesh: &'a SceneMesh,
    eye: Option<Vec3>,
    playback: &'a Playback,
    lighting_world: ShRgb,
    rotation: ShRotation,
    deringing: Deringing,
    pvs: Option<PvsReport>,
    self_check: Option<SelfCheckReport>,
}

/// What one frame measured (`Animation::play`): the report of a run is
/// made from its frames' records (`Animation::report`), which a shard of
/// the frames stores for a merge (serde).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct FrameRecord {
    /// The frame's index in the playback.
    pub frame: usize,
    /// The whole frame: pose, lighting, masks, transfer and shading, ms.
    pub ms: f64,
    /// The SH transfer kernel's time from GPU timestamps, where there is one.
    pub gpu_ms: Option<f64>,
    /// The frame's phases (`output` is the host's `on_frame`).
    pub phases: FramePhases,
    /// The frame's counts.
    pub stats: FrameStats,
    /// The comparison with ray tracing, on a checked frame.
    pub check: Option<FrameCheck>,
}

/// A checked frame's comparison with ray tracing (`PrtRunner::transfer_error`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct FrameCheck {
    /// Mean relative L2 transfer error.
    pub error: f64,
    /// Vertices compared.
    pub vertices: usize,
    /// Vertices skipped as nearly dark.
    pub skipped_dark: usize,
}

impl<'a> Animation<'a> {
    /// Checks `playback`, projects and windows the lighting, gathers the
    /// PVS where asked for (onto `runner`) and, with `self_check`, runs the
    /// self-check where asked for (it only reports: a shard of the frames
    /// may leave it to the merge).
    pub fn prepare(
        runner: &mut PrtRunner,
        (mesh, env, eye): (&'a SceneMesh, &EnvironmentMap, Option<Vec3>),
        playback: &'a Playback,
        self_check: bool,
    ) -> Result<Animation<'a>> {
        playback.validate()?;
        let bands = runner.prt.settings.bands;
        // Non-negative lighting, so that no visibility shades below zero
        // (`sh::window`).
        let (lighting_world, deringing) = nonnegative(&project_environment(env, bands));
        let rotation = ShRotation::new(bands);
        let bars = &playback.bars;
        let pvs = match playback.pvs {
            Some(sampling) => {
                let _shown = bars.spinner("gathering the PVS");
                Some(gather_pvs(runner, mesh, playback, sampling)?)
            }
            None => None,
        };
        let self_check = match playback.self_check {
            Some(c) if self_check && runner.shadows == Shadows::On => {
                let _shown = bars.spinner("self-check");
                Some(self_check_poses(runner, mesh, eye, playback, &c)?)
            }
            _ => None,
        };
        Ok(Animation {
            mesh,
            eye,
            playback,
            lighting_world,
            rotation,
            deringing,
            pvs,
            self_check,
        })
    }

    /// Frame `f`'s pose into `positions` and its results into `out`, not
    /// checked nor timed (e.g. the first frame, whose radiance sets an
    /// image's exposure, for a shard that does not play it).
    pub fn frame(
        &self,
        runner: &mut PrtRunner,
        f: usize,
        positions: &mut Vec<Vec3>,
        out: &mut FrameOutput,
    ) -> Result<Option<f64>> {
        let animation = self.playback;
        self.mesh.positions_at(animation.time(f), positions);
        let lighting = spun(&self.lighting_world, &self.rotation, animation.env_spin * f as f32).to_f32_planar();
        runner.frame(positions, self.eye, &lighting, animation.profile, out)
    }

    /// Plays the frames `frames` of the playback (a range of `0..frames`),
    /// calling `on_frame` with each frame's index, pose and results, then
    /// `on_record` with what the frame measured.
    pub fn play(
        &self,
        runner: &mut PrtRunner,
        frames: Range<usize>,
        mut on_frame: impl FnMut(usize, &[Vec3], &FrameOutput) -> Result<()>,
        mut on_record: impl FnMut(&FrameRecord) -> Result<()>,
    ) -> Result<()> {
        let animation = self.playback;
        if frames.end > animation.frames {
            let problem = format!("{frames:?} is past the {} frames played", animation.frames);
            return Err(Error::param("frames", problem));
        }
        let checked = animation.checked();
        let label = if checked.is_empty() {
            "frames"
        } else {
            "frames (ray-traced checks)"
        };
        let progress = animation.bars.bar(frames.len() as u64, label);
        let mut out = FrameOutput::default();
        let mut positions = Vec::new();
        for f in frames {
            // The whole frame is timed: the pose, the
            // lighting's rotation, then masks, transfer and shading; checks and
            // the host's output (`on_frame`) are not.
            let start = Instant::now();
            self.mesh.positions_at(animation.time(f), &mut positions);
            let posed = Instant::now();
            let lighting = spun(&self.lighting_world, &self.rotation, animation.env_spin * f as f32).to_f32_planar();
            let lit = Instant::now();
            let gpu_ms = runner.frame(&positions, self.eye, &lighting, animation.profile, &mut out)?;
            let done = Instant::now();
            let mut record = FrameRecord {
                frame: f,
                ms: ms_between(start, done),
                gpu_ms,
                phases: FramePhases {
                    animate: ms_between(start, posed),
                    lighting: ms_between(posed, lit),
                    transfer: ms_between(lit, done),
                    output: 0.0,
                },
                stats: out.stats.clone(),
                check: None,
            };
            progress.inc(1);
            if checked.contains(&f) {
                let (error, vertices, skipped_dark) = runner.transfer_error(&positions, self.eye, &out)?;
                record.check = Some(FrameCheck {
                    error,
                    vertices,
                    skipped_dark,
                });
            }
            let output = Instant::now();
            on_frame(f, &positions, &out)?;
            record.phases.output = elapsed_ms(output);
            on_record(&record)?;
        }
        Ok(())
    }

    /// The report of the frames `records` (in frame order): a whole run's
    /// where they are every frame of the playback.
    pub fn report(&self, runner: &PrtRunner, records: &[FrameRecord]) -> PrtReport {
        let frame_ms: Vec<f64> = records.iter().map(|r| r.ms).collect();
        let gpu_ms: Vec<f64> = records.iter().filter_map(|r| r.gpu_ms).collect();
        let (mut sum, mut phases) = (FrameStats::default(), FramePhases::default());
        for r in records {
            sum += &r.stats;
            phases.animate += r.phases.animate;
            phases.lighting += r.phases.lighting;
            phases.transfer += r.phases.transfer;
            phases.output += r.phases.output;
        }
        let checks: Vec<(usize, FrameCheck)> = records.iter().filter_map(|r| Some((r.frame, r.check?))).collect();
        let check = (!checks.is_empty()).then(|| CheckReport {
            rays: runner.reference.rays,
            frames: checks.iter().map(|c| c.0).collect(),
            per_frame: checks.iter().map(|c| c.1.error).collect(),
            vertices: checks.iter().map(|c| c.1.vertices).sum(),
            skipped_dark: checks.iter().map(|c| c.1.skipped_dark).sum(),
            seed: runner.reference.seed,
        });
        PrtReport::new(runner, self.playback, &frame_ms, &gpu_ms, &sum, self.pvs, check)
            .with_setup(self.self_check.clone(), self.deringing.clone())
            .with_frames(phases, self.mesh)
    }
}

pub(crate) fn ms_between(a: Instant, b: Instant) -> f64 {
    (b - a).as_secs_f64() * 1e3
}

/// The self-check on the poses `--check` would compare (the default four
/// frames; one pose for a static mesh).
fn self_check_poses(
    runner: &PrtRunner,
    mesh: &SceneMesh,
    eye: Option<Vec3>,
    animation: &Playback,
    check: &SelfCheck,
) -> Result<SelfCheckReport> {
    let frames = match (&mesh.animation, animation.check_frames) {
        (None, _) => vec![0],
        (Some(_), 0) => animation.spread(4),
        (Some(_), k) => animation.spread(k),
    };
    let poses: Vec<(usize, Vec<Vec3>)> = frames
        .into_iter()
        .map(|f| {
            let mut p = Vec::new();
            mesh.positions_at(animation.time(f), &mut p);
            (f, p)
        })
        .collect();
    runner.self_check(&poses, eye, check)
}

fn gather_pvs(
    runner: &mut PrtRunner,
    mesh: &SceneMesh,
    animation: &Playback,
    sampling: PvsSampling,
) -> Result<PvsReport> {
    let start = Instant::now();
    let span = sampling
        .span
        .unwrap_or(((animation.frames - 1) as f32 * animation.dt).max(2.0));
    let poses: Vec<Vec<Vec3>> = (0..sampling.frames)
        .map(|k| {
            let mut p = Vec::new();
            let time = animation.start + span * k as f32 / (sampling.frames.max(2) - 1) as f32;
            mesh.positions_at(time, &mut p);
            p
        })
        .collect();
    runner.use_pvs(&poses)?;
    let prt = &runner.prt;
    let size = prt.pvs().map_or(0, |p| p.items.len());
    Ok(PvsReport {
        frames: sampling.frames,
        build_ms: elapsed_ms(start),
        avg_size: size as f64 / prt.vertex_count.max(1) as f64,
    })
}

/// `lighting` turned about +y by `degrees`.
pub fn spun(lighting: &ShRgb, rotation: &ShRotation, degrees: f32) -> ShRgb {
    if degrees == 0.0 {
        return lighting.clone();
    }
    lighting.rotated(rotation, DMat3::from_rotation_y((degrees as f64).to_radians()))
}

/// What a run measured, with the settings it ran with (`prt --json`).
#[derive(Debug, Clone, Serialize)]
pub struct PrtReport {
    /// Vertices of the mesh.
    pub vertices: usize,
    /// Triangles of the full-resolution mesh.
    pub triangles: usize,
    /// Blockers rasterised per vertex (after every culling; see `blockers_per_vertex`).
    pub avg_blockers_per_vertex: f64,
    /// Blockers per vertex before and after culling (the paper's Table 1 counts before).
    pub blockers_per_vertex: BlockerCounts,
    /// Frames per second of whole frames: animation, lighting, transfer and
    /// shading (`phases_ms`); not checks, images or CSV rows.
    pub fps: f64,
    /// Frames per second of the fastest whole frame.
    pub fps_best: f64,
    /// Milliseconds per frame by phase, averaged, and over the run.
    pub phases_ms: Option<PhaseReport>,
    /// Where the animation comes from (None: a static mesh).
    pub animation: Option<AnimationSource>,
    /// Animation time of the first frame, seconds.
    pub start: f32,
    /// Animation time between frames, seconds.
    pub dt: f32,
    /// Mean relative L2 error of the transfer against ray tracing (checks only).
    pub transfer_l2_error: Option<f64>,
    /// Frames played.
    pub frames: usize,
    /// Whole frames (as `fps`).
    pub frame_ms: FrameTimes,
    /// Milliseconds of the SH transfer kernel per frame, on average, from
    /// GPU timestamps; `None` on the CPU, with ray-traced shadows, or where
    /// the device has no timestamps.
    pub gpu_ms_per_frame: Option<f64>,
    /// SH bands (`PrtSettings::bands`; 5 is the paper's 25-term basis).
    pub order: usize,
    /// SH coefficients per transfer vector, `order²`.
    pub coefficients: usize,
    /// Mask side S in pixels (S x S masks).
    pub mask: usize,
    /// How masks were integrated against the basis.
    pub integration: Integration,
    /// The plane LUT.
    pub lut: LutReport,
    /// The BRDF integrated into the transfer.
    pub brdf: Brdf,
    /// Where visibility came from.
    pub shadows: Shadows,
    /// The two-level mesh hierarchy and culling groups.
    pub hierarchy: HierarchyReport,
    /// Whether blockers facing away from the vertex were culled.
    pub backface_culling: bool,
    /// Whether each vertex was shaded on the side facing the eye.
    pub two_sided: bool,
    /// How culling and sidedness were decided (`prt::sides`).
    pub sides: Sides,
    /// The potentially visible set gathered before the first frame (`None`:
    /// none, the hierarchy's lists were used).
    pub pvs: Option<PvsReport>,
    /// Blockers per vertex before culling (= `blockers_per_vertex.before_culling`).
    pub avg_candidates_per_vertex: f64,
    /// Blockers culled per vertex, by reason.
    pub culling_per_vertex: CullingReport,
    /// Vertices without a normal (no triangle of non-zero area uses them)
    /// per frame, the mean rounded down: their transfer and radiance are
    /// zero.
    pub without_normal: u64,
    /// The paper's Table 2: share of frame time per phase (with profiling
    /// only; `None` otherwise).
    pub phases: Option<Phases>,
    /// Milliseconds building the tables, LUT and hierarchy (wall clock;
    /// not the GPU upload, the PVS or the self-check).
    pub setup_ms: f64,
    /// The comparison with ray tracing on the checked frames (`None`: no
    /// frame checked).
    pub check: Option<CheckReport>,
    /// The ray-traced estimate of the error made at setup (`prt::selfcheck`).
    pub self_check: Option<SelfCheckReport>,
    /// How the lighting was windowed to keep it non-negative (`sh::window`).
    pub lighting: Option<Deringing>,
}

/// Blockers per vertex: candidates from the hierarchy (or PVS) lists, and
/// those rasterised after group, horizon, back-face and edge-on culling.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct BlockerCounts {
    /// Candidates per vertex with a normal, averaged over the frames
    /// (culling groups' triangles included).
    pub before_culling: f64,
    /// Blockers rasterised per vertex with a normal, averaged over the
    /// frames.
    pub after_culling: f64,
}

/// Time of each phase of a frame, summed over the frames.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct FramePhases {
    /// The pose: the animation's positions (sequence interpolation, skinning).
    pub animate: f64,
    /// The probe's SH lighting turned by `env_spin`.
    pub lighting: f64,
    /// Visibility masks, transfer, rotation and shading (one pass per
    /// vertex on the CPU; uploads, kernel and readback on a GPU).
    pub transfer: f64,
    /// The host's work per frame (images, CSV rows): not in `fps`.
    pub output: f64,
}

/// `phases_ms`: per frame on average and over the run, ms.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PhaseReport {
    /// Each phase's mean over the frames, ms.
    pub per_frame: FramePhases,
    /// Each phase summed over the run, ms.
    pub total: FramePhases,
}

/// Wall-clock milliseconds of whole frames, as the report's `fps` counts
/// them (not checks or the host's output).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct FrameTimes {
    /// Total over the frames divided by their number.
    pub mean: f64,
    /// The middle frame time (the upper of the two middle ones for an even
    /// count).
    pub median: f64,
    /// The fastest frame.
    pub best: f64,
}

/// The plane LUT of section 3.1.1.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct LutReport {
    /// Cells per cube-face side (`PrtSettings::lut_size`; the paper's 128).
    pub size: usize,
    /// Bytes of the table as stored (three faces).
    pub bytes: usize,
    /// The paper's six-face layout (we store three faces and complement).
    pub paper_layout_bytes: usize,
    /// Milliseconds building the table (wall clock).
    pub build_ms: f64,
}

/// The two-level mesh hierarchy and culling groups (section 3.2) as built.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct HierarchyReport {
    /// Whether the two-level hierarchy was asked for.
    pub enabled: bool,
    /// Which fine triangles are drawn near a vertex.
    pub near: NearField,
    /// The k of the k-ring drawn at full resolution (1 or 2).
    pub ring: usize,
    /// Triangles of the coarse level; `None` where there is none (the far
    /// blockers are the whole mesh).
    pub low_res_triangles: Option<usize>,
    /// `HierarchySettings::tolerance`, radians (0: no refinement).
    pub tolerance: f32,
    /// Coarse triangles' deviation from the fine surface (`prt::proxy`),
    /// relative to the rest pose's bounding-box diagonal: mean and largest.
    pub deviation_mean: Option<f64>,
    /// The largest such deviation, relative likewise; `None` without a
    /// coarse level or refinement.
    pub deviation_max: Option<f64>,
    /// Per vertex, on average: fine triangles drawn near it and coarse
    /// triangles they replace (the near field, refinement included).
    pub near_triangles_per_vertex: f64,
    /// Far triangles skipped per vertex on average, in place of its near
    /// field.
    pub replaced_per_vertex: f64,
    /// Culling groups of the far triangles.
    pub groups: usize,
    /// Whether groups below a vertex's tangent plane were skipped.
    pub group_culling: bool,
}

/// The potentially visible set gathered from sampled poses (section 3.2).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PvsReport {
    /// Poses it was gathered from.
    pub frames: usize,
    /// Milliseconds posing the mesh and building the sets (wall clock).
    pub build_ms: f64,
    /// Blockers per vertex in the sets, on average.
    pub avg_size: f64,
}

/// Blockers culled per vertex, by reason.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct CullingReport {
    /// Skipped with their culling group (box below the tangent plane).
    pub groups: f64,
    /// No vertex above the tangent plane.
    pub below_horizon: f64,
    /// Facing away from the vertex (back-face culling on).
    pub back_facing: f64,
    /// Seen edge-on (zero solid angle), zero-area triangles included.
    pub edge_on: f64,
}

/// Share of frame time per phase (the paper's Table 2) and ms per frame.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Phases {
    /// Share of tangent frames, group culling, blockers into the frame and
    /// horizon culling, in [0, 1].
    pub transform: f64,
    /// Share of edge planes, back-face and edge-on tests, LUT fetches and
    /// AND/OR, in [0, 1].
    pub rasterization: f64,
    /// Share of downsampling, SH integration and rotation to world space
    /// (on a GPU: the kernel's time), in [0, 1].
    pub integration: f64,
    /// Share of the rest: normals, group boxes, shading, bookkeeping (on a
    /// GPU: uploads, readback and waits), in [0, 1].
    pub other: f64,
    /// Milliseconds per frame of transform, rasterisation, integration and
    /// other: CPU phases summed over threads and divided by their number
    /// (on a GPU, integration and other as above).
    pub ms_per_frame: [f64; 4],
}

/// The transfer of the checked frames compared with Monte Carlo ray tracing
/// of the full mesh (the paper's Table 1 error: mean relative L2 error).
#[derive(Debug, Clone, Serialize)]
pub struct CheckReport {
    /// Rays per vertex of the reference.
    pub rays: u32,
    /// The frames checked, evenly spread over the run.
    pub frames: Vec<usize>,
    /// Each checked frame's mean relative L2 transfer error, `frames` order.
    pub per_frame: Vec<f64>,
    /// Vertices compared, summed over the checked frames.
    pub vertices: usize,
    /// Vertices skipped as nearly dark (a reference transfer of at most 1%
    /// of the unoccluded transfer's length), summed over the checked frames.
    pub skipped_dark: usize,
    /// Seed of the reference's ray directions.
    pub seed: u32,
}

impl PrtReport {
    fn new(
        runner: &PrtRunner,
        animation: &Playback,
        frame_ms: &[f64],
        gpu_ms: &[f64],
        sum: &FrameStats,
        pvs: Option<PvsReport>,
        check: Option<CheckReport>,
    ) -> PrtReport {
        let prt = &runner.prt;
        let s = &prt.settings;
        let nf = frame_ms.len().max(1) as f64;
        let verts = sum.vertices.max(1) as f64;
        let total_ms: f64 = frame_ms.iter().sum();
        let best = frame_ms.iter().cloned().fold(f64::INFINITY, f64::min);
        let mut sorted = frame_ms.to_vec();
        sorted.sort_by(f64::total_cmp);
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let gpu_ms_per_frame = (!gpu_ms.is_empty()).then(|| mean(gpu_ms));
        let phases = animation.profile.then(|| {
            // CPU phases are summed over threads; per frame they are divided
            // by the thread count. On the GPU path integration is the
            // kernel's time and "other" the rest of the frame (uploads,
            // readback, waits).
            let threads = rayon::current_num_threads() as f64;
            let mut ms = sum.phase_ns.map(|n| n as f64 * 1e-6 / nf / threads);
            if let Some(kernel) = gpu_ms_per_frame {
                ms[2] = kernel;
                ms[3] = (total_ms / nf - ms[0] - ms[1] - ms[2]).max(0.0);
            }
            let total: f64 = ms.iter().sum::<f64>().max(1e-12);
            Phases {
                transform: ms[0] / total,
                rasterization: ms[1] / total,
                integration: ms[2] / total,
                other: ms[3] / total,
                ms_per_frame: ms,
            }
        });
        let h = &prt.hierarchy;
        PrtReport {
            vertices: prt.vertex_count,
            triangles: runner.triangles.len(),
            avg_blockers_per_vertex: sum.drawn as f64 / verts,
            blockers_per_vertex: BlockerCounts {
                before_culling: sum.candidates as f64 / verts,
                after_culling: sum.drawn as f64 / verts,
            },
            phases_ms: None,
            animation: None,
            start: animation.start,
            dt: animation.dt,
            fps: 1e3 * nf / total_ms.max(1e-9),
            fps_best: 1e3 / best.max(1e-9),
            transfer_l2_error: check.as_ref().map(|c| mean(&c.per_frame)),
            frames: frame_ms.len(),
            frame_ms: FrameTimes {
                mean: total_ms / nf,
                median: sorted.get(sorted.len() / 2).copied().unwrap_or(0.0),
                best,
            },
            gpu_ms_per_frame,
            order: s.bands,
            coefficients: coefficient_count(s.bands),
            mask: s.mask_side,
            integration: s.integration,
            lut: LutReport {
                size: s.lut_size,
                bytes: prt.lut.bytes(),
                paper_layout_bytes: prt.lut.six_face_bytes(),
                build_ms: prt.lut_ms,
            },
            brdf: s.brdf,
            shadows: runner.shadows,
            hierarchy: HierarchyReport {
                enabled: s.hierarchy.enabled,
                near: s.hierarchy.near,
                ring: s.hierarchy.ring,
                low_res_triangles: h.coarse.then_some(h.far.len()),
                tolerance: s.hierarchy.tolerance,
                deviation_mean: (!h.deviation.is_empty()).then(|| {
                    h.deviation.iter().map(|&d| d as f64).sum::<f64>() / h.deviation.len() as f64 / prt.scale as f64
                }),
                deviation_max: h
                    .deviation
                    .iter()
                    .copied()
                    .reduce(f32::max)
                    .map(|d| d as f64 / prt.scale as f64),
                near_triangles_per_vertex: h.near.items.len() as f64 / prt.vertex_count.max(1) as f64,
                replaced_per_vertex: h.excluded.items.len() as f64 / prt.vertex_count.max(1) as f64,
                groups: h.groups.len(),
                group_culling: s.group_culling,
            },
            backface_culling: prt.cull_backfaces,
            two_sided: prt.two_sided,
            sides: prt.sides,
            pvs,
            avg_candidates_per_vertex: sum.candidates as f64 / verts,
            culling_per_vertex: CullingReport {
                groups: sum.group_culled as f64 / verts,
                below_horizon: sum.below_horizon as f64 / verts,
                back_facing: sum.back_facing as f64 / verts,
                edge_on: sum.edge_on as f64 / verts,
            },
            without_normal: sum.without_normal / frame_ms.len().max(1) as u64,
            phases,
            setup_ms: prt.setup_ms,
            check,
            self_check: None,
            lighting: None,
        }
    }

    /// With the frames' phase times and the animation's source.
    fn with_frames(self, phases: FramePhases, mesh: &SceneMesh) -> PrtReport {
        let n = self.frames.max(1) as f64;
        let per_frame = FramePhases {
            animate: phases.animate / n,
            lighting: phases.lighting / n,
            transfer: phases.transfer / n,
            output: phases.output / n,
        };
        PrtReport {
            phases_ms: Some(PhaseReport {
                per_frame,
                total: phases,
            }),
            animation: mesh.animation.as_ref().map(|a| a.source()),
            ..self
        }
    }

    /// The self-check's warning, if it has one.
    pub fn warnings(&self) -> Vec<String> {
        let lighting = self.lighting.iter().flat_map(|l| l.warning());
        self.self_check
            .iter()
            .flat_map(|c| c.warning())
            .chain(lighting)
            .collect()
    }

    /// With what was decided and measured before the first frame.
    fn with_setup(self, self_check: Option<SelfCheckReport>, lighting: Deringing) -> PrtReport {
        PrtReport {
            self_check,
            lighting: Some(lighting),
            ..self
        }
    }
}
