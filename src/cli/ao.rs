//! `penumbra ao`: ambient accessibility per vertex (CSV) and per pixel (PNG),
//! by ray casting (`ao::runner`) or through displacement fields
//! (`field::runner`).

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use serde_json::{Value, json};

use super::args::{CameraArgs, Common, check_outputs, load_input};
use crate::ao::AoSettings;
use crate::ao::runner::{AoRequest, PixelAo, VertexAo, mean, near_zero_warning, raycast, write_vertex_ao};
use crate::error::{Error, Result};
use crate::field::Positional;
use crate::field::budget::{self as field_budget, Fixed};
use crate::field::options::FieldOptions;
use crate::field::reach::Reach;
use crate::field::runner::{FieldAo, MAX_FRAMES};
use crate::image_out::{GreyImageOptions, write_grey};
use crate::progress::Bars;
use crate::scene::{Role, Scene, SceneMesh, View, load_mesh};
use crate::sweep::budget::{Choice, cached};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Reference: cast the rays against the casters' kd-tree.
    Raycast,
    /// Displacement fields of the casters (needs --receiver or --scene).
    Field,
}

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
    /// How rays find occluders.
    #[arg(long, value_enum)]
    pub method: Method,
    /// Rays per point.
    #[arg(long, allow_negative_numbers = true)]
    pub rays: u32,
    /// Occluders beyond this distance do not count (default: infinite).
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Per-vertex output: `index,ao` lines, or for a .ply name the mesh with AO as vertex colours.
    #[arg(long)]
    pub per_vertex: Option<PathBuf>,
    /// Per-pixel output: AO at the primary hits, .png (linear grey), .exr or .pfm (float).
    #[arg(long)]
    pub image: Option<PathBuf>,
    #[command(flatten)]
    pub grey: GreyImageOptions,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512, allow_negative_numbers = true)]
    pub height: u32,
    /// --method field: the caster's precomputed field (else it is built
    /// with --positions/--res/--bits/--directions).
    #[arg(long)]
    pub field: Option<PathBuf>,
    #[command(flatten)]
    pub field_options: FieldOptions,
    /// --method field: interpolate between the positional samples around a
    /// ray's entry point, or read the nearest (the paper).
    #[arg(long, value_enum, default_value_t = Positional::Bilinear)]
    pub positional: Positional,
    /// --method field: animation frames; instances with a "motion" in the
    /// scene file move between them, fields are reused. CSV and image show
    /// the last frame.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub frames: i64,
    /// --method field: also cast the same rays against the casters' geometry
    /// and report the field's error (per vertex and per ray).
    #[arg(long)]
    pub reference: bool,
    /// --method field: the cheapest --positions/--res/--bits whose AO error
    /// against ray casting, estimated on 4096 vertices, is within this at
    /// 95% confidence (cached per scene).
    #[arg(long, allow_negative_numbers = true, conflicts_with_all = ["field", "positions", "res", "bits"])]
    pub max_error: Option<f64>,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

/// The scene the options describe: `--mesh` alone is caster and receiver;
/// with `--receiver` the mesh only casts and the receiver only receives.
fn scene_of(args: &AoArgs) -> Result<Scene> {
    let scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
    match &args.receiver {
        Some(receiver) => with_receiver(scene, receiver),
        None => Ok(scene),
    }
}

/// The one-mesh `scene` made a caster onto the mesh at `receiver`.
pub(super) fn with_receiver(scene: Scene, receiver: &Path) -> Result<Scene> {
    Ok(scene.with_receiver(SceneMesh::new("receiver", receiver, load_mesh(receiver)?)))
}

pub fn run(args: &AoArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let settings = AoSettings {
        rays_per_point: args.rays,
        radius: args.radius.unwrap_or(f32::INFINITY),
        seed: args.common.seed,
    };
    settings.validate()?;
    if args.method == Method::Field {
        return field(args, settings, threads);
    }
    let (csv, png, request) = request(args, settings)?;
    let scene = scene_of(args)?;
    let device = args.common.open_device()?;
    let ao = raycast(&device, &scene, &request, Bars::Stderr)?;
    let mut report = json!({
        "method": "raycast",
        "rays_per_point": settings.rays_per_point,
        "radius": args.radius,
        "seed": settings.seed,
        "build_ms": ao.build_ms,
        "casters": { "triangles": ao.caster_triangles },
        "points": ao.points(),
        "ao_ms": ao.ao_ms(),
        "mrays_per_s": ao.points() as f64 * settings.rays_per_point as f64 / (ao.ao_ms().max(1e-9) * 1e3),
    });
    if let (Some(csv), Some(v)) = (csv, &ao.vertices) {
        report["per_vertex"] = vertex_report(args, csv, v, (&scene, 0))?;
        report["per_vertex"]["ao_ms"] = json!(v.ms);
    }
    if let (Some(png), Some(image)) = (png, &ao.image) {
        report["image"] = image_report(args, png, image, &scene)?;
        let c = image.camera;
        report["image"]["eye"] = json!(c.eye.to_array());
        report["image"]["target"] = json!(c.target.to_array());
        report["image"]["fov"] = json!(c.fov_degrees);
    }
    super::io::merged(report, args.common.report(&device, threads))
}

/// The checked `--per-vertex` and `--image` paths (at least one), and what
/// they ask of a runner.
fn request(args: &AoArgs, settings: AoSettings) -> Result<(Option<&Path>, Option<&Path>, AoRequest)> {
    if args.per_vertex.is_none() && args.image.is_none() {
        return Err(Error::param("--per-vertex/--image", "give at least one output"));
    }
    let outputs = check_outputs(&[(&args.per_vertex, "--per-vertex"), (&args.image, "--image")])?;
    if let Some(p) = outputs[1] {
        args.grey.style().check(p, "--image")?;
    }
    let image = match outputs[1] {
        Some(_) => Some(View::new(args.camera.spec(), args.width, args.height)?),
        None => None,
    };
    let request = AoRequest {
        settings,
        vertices: outputs[0].is_some(),
        image,
    };
    Ok((outputs[0], outputs[1], request))
}

/// Writes the CSV or PLY (of the receivers at `frame`); the report's `per_vertex`.
fn vertex_report(args: &AoArgs, csv: &Path, v: &VertexAo, (scene, frame): (&Scene, u32)) -> Result<Value> {
    if v.without_normal > 0 {
        super::io::note(&format!(
            "{} vertices are used by no triangle of non-zero area; they have no normal, cast no rays and are \
             reported as ao = 1",
            v.without_normal
        ));
    }
    near_zero_warning(&v.ao, args.radius, scene)
        .iter()
        .for_each(|w| super::io::note(w));
    write_vertex_ao(csv, scene, frame, &v.ao)?;
    Ok(json!({
        "file": csv.display().to_string(),
        "vertices": v.ao.len(),
        "without_normal": v.without_normal,
        "mean_ao": mean(&v.ao),
    }))
}

/// Writes the image; the report's `image`.
fn image_report(args: &AoArgs, png: &Path, image: &PixelAo, scene: &Scene) -> Result<Value> {
    let values: Vec<f32> = image.values.iter().flatten().copied().collect();
    near_zero_warning(&values, args.radius, scene)
        .iter()
        .for_each(|w| super::io::note(w));
    write_grey(png, image.width, image.height, &image.values, args.grey.style())?;
    Ok(json!({
        "file": png.display().to_string(),
        "width": image.width,
        "height": image.height,
        "pixels_hit": image.hit(),
        "mean_ao": image.mean(),
        "ao_ms": image.ms,
    }))
}

/// `--method field`: Algorithm 2 of the displacement-field paper.
fn field(args: &AoArgs, settings: AoSettings, threads: usize) -> Result<Value> {
    if args.mesh.is_some() && args.receiver.is_none() {
        return Err(Error::param(
            "--method field",
            "needs --receiver (or --scene with receivers): a field answers for rays from outside its \
             object, so it cannot shade the object's own vertices",
        ));
    }
    if args.field.is_some() && args.scene.is_some() {
        return Err(Error::param(
            "--field",
            "goes with --mesh/--receiver; a scene file names its fields in \"fields\"",
        ));
    }
    if !(1..=MAX_FRAMES as i64).contains(&args.frames) {
        let problem = format!("must be between 1 and {MAX_FRAMES}, got {}", args.frames);
        return Err(Error::param("--frames", problem));
    }
    let params = args.field_options.params()?;
    let (csv, png, request) = request(args, settings)?;
    let mut scene = scene_of(args)?;
    if let Some(file) = &args.field {
        scene.fields.insert(0, file.clone());
    }
    let device = args.common.open_device()?;
    let reach = Reach {
        radius: settings.radius,
        frames: args.frames as u32,
    };
    let (mut fields, choice) = match args.max_error {
        Some(e) => field_choice(args, &device, &scene, &request, reach, e)?,
        None => {
            let mut fields = FieldAo::new(&scene, &params, args.positional, reach, Bars::Stderr)?;
            fields.upload(&device)?;
            (fields, None)
        }
    };
    let run = fields.run(&request, args.frames as u32, args.reference)?;
    let frame_ms = &run.frame_ao_ms;
    let last_ms = frame_ms.last().copied().unwrap_or(0.0);
    let mut report = json!({
        "method": "field",
        "rays_per_point": settings.rays_per_point,
        "radius": args.radius,
        "seed": settings.seed,
        "positional": args.positional,
        "build_ms": fields.reports().iter().filter_map(|f| f.build_ms).sum::<f64>(),
        "self_occlusion_ms": run.self_occlusion_ms,
        "fields": fields.reports(),
        "skipped": fields.skipped(),
        "casters": {
            "instances": scene.instances.iter().filter(|i| i.role.casts()).count(),
            "triangles": scene.world_mesh(Role::casts).triangles.len(),
        },
        "frames": frame_ms.len(),
        "frame_ao_ms": frame_ms,
        "ao_ms": last_ms,
        "ao_ms_mean": frame_ms.iter().sum::<f64>() / frame_ms.len() as f64,
        "rays_inside_sphere": run.rays_inside_sphere,
        "rays_hidden": run.rays_hidden,
        "points": run.points,
        "mrays_per_s": run.points as f64 * settings.rays_per_point as f64 / (last_ms.max(1e-9) * 1e3),
        "reference": run.reference,
        "max_error": choice,
    });
    if let (Some(csv), Some(v)) = (csv, &run.vertices) {
        report["per_vertex"] = vertex_report(args, csv, v, (&scene, args.frames as u32 - 1))?;
        report["per_vertex"].as_object_mut().map(|o| o.remove("without_normal"));
    }
    if let (Some(png), Some(image)) = (png, &run.image) {
        report["image"] = image_report(args, png, image, &scene)?;
    }
    for absent in ["reference", "max_error"] {
        if report[absent].is_null() {
            report.as_object_mut().map(|o| o.remove(absent));
        }
    }
    super::io::merged(report, args.common.report(&device, threads))
}

/// `--max-error`: the fields of the cached or checked choice.
fn field_choice<'s>(
    args: &AoArgs,
    device: &crate::device::Device,
    scene: &'s Scene,
    request: &AoRequest,
    reach: Reach,
    max_error: f64,
) -> Result<(FieldAo<'s>, Option<Choice>)> {
    if !scene.fields.is_empty() {
        let problem = "does not apply: the scene names its field files, whose parameters are fixed";
        return Err(Error::param("--max-error", problem));
    }
    let fixed = Fixed {
        directions: args.field_options.directions,
        positional: args.positional,
        reach,
    };
    let files: Vec<&Path> = [&args.mesh, &args.receiver, &args.scene]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .collect();
    let options = format!(
        "{max_error}|{:?}|{:?}|{:?}|{}",
        fixed.directions,
        fixed.positional,
        request.settings,
        device.kind()
    );
    let mut checked = None;
    let choice = cached("field", &options, &files, || {
        let (choice, fields) = field_budget::choose(device, scene, request, fixed, max_error, Bars::Stderr)?;
        checked = Some(fields);
        Ok(choice)
    })?;
    super::io::note_choice(&choice);
    let fields = match checked {
        Some(f) => f,
        None => field_budget::fields_of(scene, &choice.chosen, fixed, device)?,
    };
    Ok((fields, Some(choice)))
}
