//! `penumbra ao`: ambient accessibility per vertex (CSV) and per pixel (PNG),
//! by ray casting (`ao::runner`) or through displacement fields
//! (`field::runner`).

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::args::{CameraArgs, CameraChoice, Common, check_outputs, load_shaded_input};
use crate::io::{merged, note, note_choice};
use crate::options::GreyImageOptions;
pub use crate::options::ao::AoMethod as Method;
use crate::options::ao::AoOptions;
use crate::options::field::FieldOptions;
use penumbra::error::{Error, Result};
use penumbra::field::reach::Reach;
use penumbra::field::report::FieldRunReport;
use penumbra::field::tune::{Fixed, fields_for};
use penumbra::raycast::report::{AoOutputs, RaycastReport};
use penumbra::raycast::runner::{AoRequest, raycast};
use penumbra::scene::{Scene, View};
use penumbra::{AmbientOcclusion, Device};

use crate::shard::Mode;

#[derive(clap::Args)]
pub struct AoArgs {
    /// The occluding mesh; without --receiver it also receives (self-occlusion).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// AO at this mesh's vertices, occluded by --mesh only.
    #[arg(long, requires = "mesh")]
    pub receiver: Option<PathBuf>,
    /// A scene file instead of --mesh: receivers get AO, casters occlude.
    #[arg(long, conflicts_with_all = ["mesh", "receiver"])]
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub knobs: AoOptions,
    /// Per-vertex output: `index,ao` lines, or for a .ply name the mesh with AO as vertex colours.
    #[arg(long)]
    pub per_vertex: Option<PathBuf>,
    /// Per-pixel output: AO at the primary hits, .png (linear grey), .exr or .pfm (float).
    #[arg(long)]
    pub image: Option<PathBuf>,
    #[command(flatten)]
    pub grey: GreyImageOptions,
    #[command(flatten)]
    pub size: crate::options::ImageSize,
    /// --method field: the caster's precomputed field (else it is built
    /// with --positions/--res/--bits/--directions).
    #[arg(long, conflicts_with = "max_error")]
    pub field: Option<PathBuf>,
    #[command(flatten)]
    pub field_options: FieldOptions,
    #[command(flatten)]
    pub choice: CameraChoice,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
    #[command(flatten)]
    pub shard: crate::shard::ShardArgs,
}

/// The scene the options describe: `--mesh` alone is caster and receiver;
/// with `--receiver` the mesh only casts and the receiver only receives.
/// Materials are kept for their alpha cut-outs, holes for every ray.
fn scene_of(args: &AoArgs) -> Result<Scene> {
    let mut scene = load_shaded_input(args.mesh.as_deref(), args.scene.as_deref())?;
    args.choice.choose(&mut scene)?;
    match &args.receiver {
        Some(receiver) => scene.with_receiver_file(receiver),
        None => Ok(scene),
    }
}

pub fn run(args: &AoArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let settings = args.knobs.settings(args.common.seed)?;
    let (outputs, request) = request(args, settings)?;
    if args.knobs.method == Method::Field {
        return field(args, outputs, &request, threads);
    }
    let scene = scene_of(args)?;
    let device = args.common.open_device()?;
    match args.shard.mode()? {
        Mode::Whole => {}
        Mode::Part(shard) => return part(args, (&scene, &device), outputs, &request, shard, threads),
        Mode::Merge(parts) => return merge(args, (&scene, &device), outputs, &request, &parts, threads),
    }
    let runs = args.common.runs.runs(1)?;
    let once = || raycast(&device, &scene, &request, &crate::progress::stderr());
    let (ao, times) = runs.run("ao_ms", once, |ao| ao.ao_ms())?;
    crate::io::warn(&ao.warnings);
    let written = outputs.write(&scene, 0, settings.radius, ao.vertices.as_ref(), ao.image.as_ref())?;
    written.notes.iter().for_each(|n| note(n));
    let report = RaycastReport::new(&ao, &settings, written).with_runs(times);
    merged(args.common.report(&device, threads), report)
}

/// The checked `--per-vertex` and `--image` paths (at least one), and what
/// they ask of a runner.
fn request(args: &AoArgs, settings: penumbra::raycast::AoSettings) -> Result<(AoOutputs<'_>, AoRequest)> {
    if args.per_vertex.is_none() && args.image.is_none() {
        return Err(Error::param("--per-vertex/--image", "give at least one output"));
    }
    let outputs = check_outputs(&[(&args.per_vertex, "--per-vertex"), (&args.image, "--image")])?;
    let style = args.grey.style();
    outputs[1].map(|p| style.check(p, "--image")).transpose()?;
    let image = match outputs[1] {
        Some(_) => Some(View::new(args.camera.spec(), args.size.width, args.size.height)?),
        None => None,
    };
    let vertices = outputs[0].is_some();
    let outputs = AoOutputs {
        per_vertex: outputs[0],
        image: outputs[1],
        style,
    };
    Ok((
        outputs,
        AoRequest {
            settings,
            vertices,
            image,
        },
    ))
}

/// `--method field`: Algorithm 2 of the displacement-field paper.
fn field(args: &AoArgs, outputs: AoOutputs, request: &AoRequest, threads: usize) -> Result<Value> {
    let mode = args.shard.mode()?;
    if !matches!(mode, Mode::Whole) {
        crate::ao_frames::check_split(args, &outputs)?;
    }
    if args.mesh.is_some() && args.receiver.is_none() {
        return Err(Error::param(
            "--method field",
            "needs --receiver (or --scene with receivers): a field answers for rays from outside its \
             object, so it cannot shade the object's own vertices",
        ));
    }
    if args.field.is_some() && args.scene.is_some() {
        let problem = "goes with --mesh/--receiver; a scene file names its fields in \"fields\"";
        return Err(Error::param("--field", problem));
    }
    let frames = args.knobs.frames()?;
    let params = args.field_options.params()?;
    let mut scene = scene_of(args)?;
    if let Some(file) = &args.field {
        scene.fields.insert(0, file.clone());
    }
    let device = args.common.open_device()?;
    let reach = Reach {
        radius: request.settings.radius,
        frames,
    };
    let fixed = Fixed {
        directions: args.field_options.directions,
        positional: args.knobs.positional,
        reach,
    };
    let files: Vec<&Path> = [&args.mesh, &args.receiver, &args.scene]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .collect();
    let inputs = (&scene, &files[..]);
    let (mut fields, choice) = fields_for(
        &device,
        inputs,
        request,
        (fixed, &params),
        args.knobs.max_error.map(crate::args::error_budget).as_ref(),
        &crate::progress::stderr(),
    )?;
    choice.iter().for_each(note_choice);
    let run = (&scene, &mut fields, frames);
    match mode {
        Mode::Whole => {}
        Mode::Part(shard) => {
            return crate::ao_frames::part(args, (outputs, request), run, shard, (&device, threads));
        }
        Mode::Merge(parts) => {
            let mut report = crate::ao_frames::merge(args, (outputs, request), run, &parts)?;
            report.max_error = choice;
            return merged(args.common.report(&device, threads), report);
        }
    }
    let runs = args.common.runs.runs(1)?;
    let radius = request.settings.radius;
    let mut write = |f, v: Option<&_>, i: Option<&_>| outputs.write_frame(&scene, (f, false), radius, v, i).map(drop);
    let mut once = || {
        fields.run_frames(
            request,
            frames,
            args.knobs.reference,
            outputs.per_frame().then_some(&mut write),
        )
    };
    let (run, times) = runs.run("ao_ms", &mut once, |r| r.frame_ao_ms.last().copied().unwrap_or(0.0))?;
    let (vertices, image) = (run.vertices.as_ref(), run.image.as_ref());
    let written = outputs.write_frame(&scene, (frames - 1, true), radius, vertices, image)?;
    written.notes.iter().for_each(|n| note(n));
    let mut report = FieldRunReport::new(&fields, run, &request.settings, written);
    report.max_error = choice;
    report.ao.runs = Some(times);
    merged(args.common.report(&device, threads), report)
}

/// Vertices (or pixels) per record of a part: what a shard killed part-way
/// computes again at most.
const PIECE: usize = 4096;

/// The one output a sharded run splits, and its items: the receivers'
/// vertices, or the image's pixels row by row.
fn split<'a>(outputs: &AoOutputs<'a>, request: &AoRequest, ao: &AmbientOcclusion) -> Result<(&'a Path, usize)> {
    crate::shard::one_output(&[("--per-vertex", request.vertices), ("--image", request.image.is_some())])?;
    match (outputs.per_vertex, &request.image) {
        (Some(p), _) => Ok((p, ao.vertex_count()?)),
        (None, Some(view)) => Ok((
            outputs.image.expect("checked with the view"),
            (view.width * view.height) as usize,
        )),
        (None, None) => unreachable!("request checks that an output is given"),
    }
}

/// A record: the vertices without a hemisphere (u32), then each item's AO
/// (f32, NaN for a pixel whose primary ray missed).
fn encode(without_normal: usize, values: impl Iterator<Item = Option<f32>>) -> Vec<u8> {
    let mut bytes = (without_normal as u32).to_le_bytes().to_vec();
    values.for_each(|v| bytes.extend_from_slice(&v.unwrap_or(f32::NAN).to_le_bytes()));
    bytes
}

/// `--shard I/N`: AO of this shard's items, recorded piece by piece in the
/// part of the output.
fn part(
    args: &AoArgs,
    (scene, device): (&Scene, &Device),
    outputs: AoOutputs,
    request: &AoRequest,
    shard: penumbra::io::shard::Shard,
    threads: usize,
) -> Result<Value> {
    let mut ao = AmbientOcclusion::for_scene(device, scene)?.with_progress(crate::progress::stderr());
    let (target, total) = split(&outputs, request, &ao)?;
    let mut writer = crate::shard::open_part(target, shard, total)?;
    let mut ms = 0.0;
    for piece in writer.todo(PIECE) {
        let bytes = match &request.image {
            Some(view) if !request.vertices => {
                let image = ao.image_in(view, &request.settings, piece.clone())?;
                ms += image.ms;
                encode(0, image.values[piece.clone()].iter().copied())
            }
            _ => {
                let v = ao.vertices_in(piece.clone(), &request.settings)?;
                ms += v.ms;
                encode(v.without_normal, v.ao.iter().map(|&a| Some(a)))
            }
        };
        writer.record(piece, &bytes)?;
    }
    crate::io::warn(ao.warnings());
    let report = merged(
        args.common.report(device, threads),
        serde_json::json!({ "ao_ms": ms, "caster_triangles": ao.caster_triangles() }),
    )?;
    crate::shard::finish_part(writer, report)
}

/// `penumbra merge`: the items read from the parts, written and reported as
/// one process does.
fn merge(
    args: &AoArgs,
    (scene, device): (&Scene, &Device),
    outputs: AoOutputs,
    request: &AoRequest,
    parts: &penumbra::io::shard::Parts,
    threads: usize,
) -> Result<Value> {
    let mut ao = AmbientOcclusion::for_scene(device, scene)?;
    let (target, total) = split(&outputs, request, &ao)?;
    if total != parts.total_items() {
        let problem = format!("the parts hold {} items, the inputs give {total}", parts.total_items());
        return Err(Error::file(target, "", problem));
    }
    let mut without_normal = 0;
    let mut values = Vec::with_capacity(total);
    for (_, bytes) in parts.records()? {
        let words = penumbra::io::shard::f32s(&bytes, target)?;
        without_normal += words.first().map_or(0, |w| w.to_bits() as usize);
        values.extend(words[1..].iter().map(|v| (!v.is_nan()).then_some(*v)));
    }
    let ms: f64 = parts.sidecars.iter().filter_map(|s| s.report["ao_ms"].as_f64()).sum();
    let (vertices, image) = match &request.image {
        Some(view) if !request.vertices => {
            let mut image = ao.image_in(view, &request.settings, 0..0)?;
            image.values = values;
            image.ms = ms;
            (None, Some(image))
        }
        _ => {
            ao.prepare()?;
            let ao = values.into_iter().map(|v| v.unwrap_or(f32::NAN)).collect();
            let v = penumbra::raycast::runner::VertexAo { ao, without_normal, ms };
            (Some(v), None)
        }
    };
    let result = penumbra::raycast::runner::RaycastAo::of(&ao, vertices, image);
    crate::io::warn(&result.warnings);
    let radius = request.settings.radius;
    let written = outputs.write(scene, 0, radius, result.vertices.as_ref(), result.image.as_ref())?;
    written.notes.iter().for_each(|n| note(n));
    let report = RaycastReport::new(&result, &request.settings, written);
    merged(args.common.report(device, threads), report)
}
