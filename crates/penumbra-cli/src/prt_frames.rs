//! `prt --frames N --out 'f-{}.png' --shard I/N` (or `--out-frames DIR`):
//! a shard plays its contiguous range of the frames of a mesh
//! (`prt::runner::Animation`) or of a `--scene` (`prt::scene_play::ScenePlay`):
//! every frame depends on its index and on what is made before the first
//! frame, the lighting and the PVS, which every shard makes alike; writing
//! each frame's image under its final name, then recording what the frame
//! measured in the part of the output (the `--out` name as typed, pattern
//! included, or the `--out-frames` folder). Without `--exposure` the first
//! frame's radiance sets every image's exposure, so a shard that does not
//! play frame 0 computes it first. The self-check only reports: `penumbra
//! merge` runs it, checks that every frame's file is there, and reports as
//! one process does from the frames' records (times are each shard's own).

use std::cell::Cell;
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::prt::PrtArgs;
use penumbra::error::{Error, Result};
use penumbra::io::output::{frame_output, frame_path};
use penumbra::io::shard::{PartWriter, Parts, Shard};
use penumbra::prt::images::FrameImages;
use penumbra::prt::objects::ObjectsRunner;
use penumbra::prt::pipeline::FrameOutput;
use penumbra::prt::render::auto_exposure;
use penumbra::prt::runner::{Animation, FrameRecord, Playback, PrtRunner};
use penumbra::prt::scene_play::{SceneFrameRecord, ScenePlay};
use penumbra::report::repeats::RunTimes;
use penumbra::scene::{EnvironmentMap, Scene, SceneMesh};
use serde_json::{Value, json};

/// What a sharded run needs, known from the options alone: each frame's
/// image its own file, each frame played once, and nothing
/// chosen by timing this machine.
pub fn check_split(args: &PrtArgs) -> Result<()> {
    let refuse = |problem: &str| Err(Error::param("--shard", problem));
    if args.max_error.is_some() {
        return refuse(
            "cannot split --max-error: it picks the fastest settings by timing them on each machine, so shards \
             could shade with different ones; run it once, then give the --mask and --hierarchy it chose",
        );
    }
    if args.per_vertex.is_some() {
        return refuse(
            "splits frames into image files; --per-vertex writes every frame's rows into one CSV, leave it out",
        );
    }
    let given = [
        ("--out", args.out.is_some()),
        ("--out-frames", args.out_frames.is_some()),
    ];
    crate::shard::one_output(&given)?;
    let pattern = args.out.as_deref().is_some_and(|p| frame_path(p, 0).is_some());
    if !(pattern || args.out_frames.is_some()) {
        return refuse(
            "splits the frames of an animation: give --frames N (N > 1) and an --out name holding {} (or {:04}) \
             or --out-frames DIR, every frame its own file",
        );
    }
    let runs = args.common.runs.runs(1)?;
    if runs.warmup + runs.repeat > 1 {
        return refuse("plays each frame once; leave out --warmup and --repeat");
    }
    Ok(())
}

/// The output a part belongs to: the `--out` template or the `--out-frames` folder.
pub fn template(args: &PrtArgs) -> &Path {
    args.out
        .as_deref()
        .or(args.out_frames.as_deref())
        .expect("a split run's output is checked")
}

/// Frame `f`'s image of `frames`.
fn frame_file(args: &PrtArgs, f: usize, frames: usize) -> PathBuf {
    match &args.out {
        Some(out) => frame_output(out, f as u32, f + 1 == frames).expect("the template holds {}"),
        None => template(args).join(format!("frame-{f:04}.png")),
    }
}

/// What is played: one mesh, or a scene of several objects.
pub enum Runner<'a, 'r> {
    /// `--mesh`, `--animated` or `--mesh-sequence`.
    Mesh(&'r mut PrtRunner, &'a SceneMesh),
    /// `--scene`.
    Scene(&'r mut ObjectsRunner, &'a Scene),
}

/// What is played, how, and the triangles its images are drawn with.
pub struct Play<'a, 'r> {
    pub runner: Runner<'a, 'r>,
    pub env: &'a EnvironmentMap,
    pub eye: Option<Vec3>,
    pub playback: &'a Playback,
    pub triangles: &'a [[u32; 3]],
}

/// The animation or scene ready to play.
enum Prepared<'a> {
    Mesh(Animation<'a>),
    Scene(ScenePlay<'a>),
}

/// What a frame measured, of a mesh or of a scene.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
enum Measured {
    Mesh(FrameRecord),
    Scene(SceneFrameRecord),
}

impl Measured {
    fn ms(&self) -> f64 {
        match self {
            Measured::Mesh(r) => r.ms,
            Measured::Scene(r) => r.ms,
        }
    }
}

impl<'a> Play<'a, '_> {
    /// What every frame depends on; `self_check`: with the self-check,
    /// which only reports.
    fn prepare(&mut self, self_check: bool) -> Result<Prepared<'a>> {
        let lit = (self.env, self.eye);
        Ok(match &mut self.runner {
            Runner::Mesh(r, mesh) => {
                Prepared::Mesh(Animation::prepare(r, (*mesh, lit.0, lit.1), self.playback, self_check)?)
            }
            Runner::Scene(r, scene) => Prepared::Scene(ScenePlay::prepare(r, scene, lit, self.playback, self_check)?),
        })
    }

    /// Frame 0's radiance (merged over a scene's shaded objects).
    fn first_radiance(&mut self, prepared: &Prepared) -> Result<Vec<[f32; 3]>> {
        let (mut positions, mut out) = (Vec::new(), FrameOutput::default());
        match (&mut self.runner, prepared) {
            (Runner::Mesh(r, _), Prepared::Mesh(a)) => a.frame(r, 0, &mut positions, &mut out).map(|_| ())?,
            (Runner::Scene(r, _), Prepared::Scene(p)) => p.frame(r, 0, &mut positions, &mut out)?,
            _ => unreachable!("prepared for its runner"),
        }
        Ok(out.radiance)
    }

    /// The frames `range` played, `on_frame` then `on_record` each.
    fn play(
        &mut self,
        prepared: &Prepared,
        range: Range<usize>,
        on_frame: impl FnMut(usize, &[Vec3], &FrameOutput) -> Result<()>,
        mut on_record: impl FnMut(Measured) -> Result<()>,
    ) -> Result<()> {
        match (&mut self.runner, prepared) {
            (Runner::Mesh(r, _), Prepared::Mesh(a)) => {
                a.play(r, range, on_frame, |m| on_record(Measured::Mesh(m.clone())))
            }
            (Runner::Scene(r, _), Prepared::Scene(p)) => {
                p.play(r, range, on_frame, |m| on_record(Measured::Scene(m.clone())))
            }
            _ => unreachable!("prepared for its runner"),
        }
    }

    /// The report of `records`' frames and its warnings.
    fn report(&self, prepared: &Prepared, records: &[Measured], out: &Path) -> Result<(Value, Vec<String>)> {
        let wrong = || {
            Error::file(
                out,
                "",
                "its parts' records are of another kind of run (a mesh's, a scene's)",
            )
        };
        match (&self.runner, prepared) {
            (Runner::Mesh(r, _), Prepared::Mesh(a)) => {
                let frames: Vec<FrameRecord> = records
                    .iter()
                    .map(|m| match m {
                        Measured::Mesh(f) => Ok(f.clone()),
                        Measured::Scene(_) => Err(wrong()),
                    })
                    .collect::<Result<_>>()?;
                let report = a.report(r, &frames);
                Ok((crate::io::merged(json!({}), &report)?, report.warnings()))
            }
            (Runner::Scene(r, _), Prepared::Scene(p)) => {
                let frames: Vec<SceneFrameRecord> = records
                    .iter()
                    .map(|m| match m {
                        Measured::Scene(f) => Ok(f.clone()),
                        Measured::Mesh(_) => Err(wrong()),
                    })
                    .collect::<Result<_>>()?;
                let report = p.report(r, &frames);
                Ok((crate::io::merged(json!({}), &report)?, report.warnings()))
            }
            _ => unreachable!("prepared for its runner"),
        }
    }
}

/// One frame's record in a part: what the frame measured, the exposure its
/// images were written with and how many were.
#[derive(serde::Serialize, serde::Deserialize)]
struct Record {
    measured: Measured,
    exposure: Option<f32>,
    images: usize,
}

/// What the report says of the frames, as one process's `prt` report does.
pub struct Played {
    /// The method's report (`PrtReport` or `SceneReport`).
    pub report: Value,
    pub warnings: Vec<String>,
    pub images: usize,
    pub exposure: Option<f32>,
    pub runs: Option<RunTimes>,
}

/// A shard's finished frames and its part, still open
/// (`shard::finish_part`).
pub type Part = (Played, PartWriter);

/// `--shard I/N`: the shard's frames played, written and recorded one by
/// one (a frame's images are in place before its record), so a shard
/// killed part-way plays again only the frames whose record is missing.
pub fn part(args: &PrtArgs, mut play: Play, mut images: FrameImages, shard: Shard) -> Result<Part> {
    let frames = play.playback.frames;
    check_frames(frames)?;
    let mut writer = crate::shard::open_part(template(args), shard, frames)?;
    let todo = contiguous(writer.todo(1));
    let prepared = play.prepare(false)?;
    if images.exposure.is_none() && todo.first().is_some_and(|r| r.start > 0) {
        // The first frame's radiance sets the exposure of every frame.
        images.exposure = Some(auto_exposure(&play.first_radiance(&prepared)?, images.albedo));
    }
    let triangles = play.triangles;
    for range in todo {
        // The images of the frame, then its record: the exposure the first
        // frame drawn sets and how many images were written.
        let (written, exposure) = (Cell::new(0), Cell::new(images.exposure));
        let on_frame = |f: usize, positions: &[Vec3], out: &FrameOutput| {
            let before = images.written;
            images.frame((f, frames), (positions, triangles), &out.radiance)?;
            written.set(images.written - before);
            exposure.set(images.exposure);
            Ok(())
        };
        let on_record = |measured: Measured| {
            let frame = match &measured {
                Measured::Mesh(r) => r.frame,
                Measured::Scene(r) => r.frame,
            };
            let record = Record {
                measured,
                exposure: exposure.get(),
                images: written.get(),
            };
            let bytes = serde_json::to_vec(&record).map_err(|e| Error::internal(e.to_string()))?;
            writer.record(frame..frame + 1, &bytes)
        };
        play.play(&prepared, range, on_frame, on_record)?;
    }
    let records = read(&writer.records(), template(args))?;
    let played = played(&play, &prepared, &records, template(args), false)?;
    Ok((played, writer))
}

/// `penumbra merge`: every frame's image checked, the self-check run, the
/// report made from every frame's record as one process makes it.
pub fn merge(args: &PrtArgs, mut play: Play, parts: &Parts) -> Result<Played> {
    let frames = play.playback.frames;
    let out = template(args);
    let records = crate::shard::frame_records(parts, out, frames, |f| frame_file(args, f, frames))?;
    let records = read(&records, out)?;
    let prepared = play.prepare(true)?;
    played(&play, &prepared, &records, out, true)
}

/// A split run's frame count, checked once the animation has set it.
fn check_frames(frames: usize) -> Result<()> {
    if frames < 2 {
        let problem = format!("splits the frames of an animation; this one plays {frames} (give --frames N, N > 1)");
        return Err(Error::param("--shard", problem));
    }
    Ok(())
}

/// Adjacent ranges joined.
fn contiguous(pieces: Vec<Range<usize>>) -> Vec<Range<usize>> {
    let mut out: Vec<Range<usize>> = Vec::new();
    for p in pieces {
        match out.last_mut() {
            Some(last) if last.end == p.start => last.end = p.end,
            _ => out.push(p),
        }
    }
    out
}

/// The parts' records, in frame order; an error naming `out` and the frame
/// whose record does not read.
fn read<B: AsRef<[u8]>>(records: &[(Range<usize>, B)], out: &Path) -> Result<Vec<Record>> {
    records
        .iter()
        .map(|(items, bytes)| {
            serde_json::from_slice(bytes.as_ref()).map_err(|e| {
                let problem = format!("frame {}'s record: {e}", items.start);
                Error::file(out, "", problem)
            })
        })
        .collect()
}

/// The report of `records`' frames; `whole`: every frame of the run, whose
/// measure (`runs`) is the sum of the frame times, as one process's.
fn played(play: &Play, prepared: &Prepared, records: &[Record], out: &Path, whole: bool) -> Result<Played> {
    let measured: Vec<Measured> = records.iter().map(|r| r.measured.clone()).collect();
    let (report, warnings) = play.report(prepared, &measured, out)?;
    let ms: f64 = measured.iter().map(Measured::ms).sum();
    Ok(Played {
        report,
        warnings,
        images: records.iter().map(|r| r.images).sum(),
        exposure: records.iter().find_map(|r| r.exposure),
        runs: whole.then(|| RunTimes::of("animation_ms", 0, vec![ms])),
    })
}
