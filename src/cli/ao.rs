//! `penumbra ao`: ambient accessibility per vertex (CSV) and per pixel (PNG).

use std::path::PathBuf;
use std::time::Instant;

use clap::ValueEnum;
use serde_json::{Value, json};

use super::Device;
use super::args::{CameraArgs, Common, build_tree, check_image_size, check_output, load_input};
use super::field::FieldOptions;
use super::io::{write_grey_png, write_vertex_csv};
use crate::ao::gpu::visibility_gpu;
use crate::ao::points::{ORIGIN_OFFSET, hit_points, points_without_hemisphere, vertex_points};
use crate::ao::raycast::visibility_cpu;
use crate::ao::{AoPoint, AoSettings, VisibilityMasks};
use crate::error::{Error, Result};
use crate::field::Positional;
use crate::kdtree::KdTree;
use crate::kdtree::gpu::{GpuKdTree, TraceMode, trace_rays};
use crate::progress::Progress;
use crate::ray::Hit;
use crate::scene::{Instance, Role, Scene, Transform, load_obj};

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
    #[arg(long, value_enum)]
    pub method: Method,
    /// Rays per point.
    #[arg(long, allow_negative_numbers = true)]
    pub rays: u32,
    /// Occluders beyond this distance do not count (default: infinite).
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Per-vertex output: `index,ao` lines.
    #[arg(long)]
    pub per_vertex: Option<PathBuf>,
    /// Per-pixel output: AO at the primary hits, grey PNG (linear), background transparent.
    #[arg(long)]
    pub image: Option<PathBuf>,
    #[arg(long, default_value_t = 512, allow_negative_numbers = true)]
    pub width: u32,
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
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

/// The scene the options describe: `--mesh` alone is caster and receiver;
/// with `--receiver` the mesh only casts and the receiver only receives.
pub(super) fn scene_of(args: &AoArgs) -> Result<Scene> {
    let mut scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
    if let Some(receiver) = &args.receiver {
        scene.instances[0].role = Role::Caster;
        scene.meshes.push(crate::scene::SceneMesh {
            name: "receiver".into(),
            path: receiver.clone(),
            mesh: load_obj(receiver)?,
        });
        scene.instances.push(Instance {
            name: "receiver".into(),
            mesh: 1,
            role: Role::Receiver,
            transform: Transform::default(),
            motion: None,
        });
    }
    Ok(scene)
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
        return super::ao_field::run(args, &settings, threads);
    }
    let (csv, png) = outputs(args)?;
    let scene = scene_of(args)?;
    let occluders = scene.occluders();
    if occluders.triangles.is_empty() {
        return Err(Error::param("--scene", "no instance is a caster: nothing occludes"));
    }
    let device = Device::open(args.common.device)?;
    let tree = build_tree(&occluders, "casters")?;
    let gpu_tree = match &device {
        Device::Gpu(ctx) => Some(GpuKdTree::upload(&ctx.device, &tree)?),
        Device::Cpu => None,
    };

    let mut report = json!({
        "method": "raycast",
        "rays_per_point": settings.rays_per_point,
        "radius": args.radius,
        "seed": settings.seed,
        "build_ms": tree.stats.build_ms,
        "device": device.kind(),
        "adapter": device.adapter(),
        "threads": threads,
        "casters": { "triangles": occluders.triangles.len() },
    });
    let mut ao_ms = 0.0;
    let mut points_total = 0usize;

    if let Some(csv) = &csv {
        let receivers = scene.receivers();
        if receivers.triangles.is_empty() {
            return Err(Error::param(
                "--scene",
                "no instance is a receiver: no vertices to shade",
            ));
        }
        let points = vertex_points(&receivers);
        let without = points_without_hemisphere(&points);
        if without > 0 {
            eprintln!(
                "penumbra: {without} vertices are used by no triangle of non-zero area; they have no \
                 normal, cast no rays and are reported as ao = 1"
            );
        }
        let (masks, ms) = visibility(&device, &tree, gpu_tree.as_ref(), &points, &settings, "AO vertices")?;
        let ao = masks.accessibility();
        write_vertex_csv(csv, &ao)?;
        ao_ms += ms;
        points_total += points.len();
        report["per_vertex"] = json!({
            "file": csv.display().to_string(),
            "vertices": points.len(),
            "without_normal": without,
            "mean_ao": mean(&ao),
            "ao_ms": ms,
        });
    }

    if let Some(png) = &png {
        let everything = scene.world_mesh(|_| true);
        let camera = args.camera.camera(scene.camera, &everything.bounds())?;
        let rays = camera.primary_rays(args.width, args.height);
        // Primary visibility sees every instance; only casters occlude.
        let all_tree;
        let primary_tree = if everything.triangles.len() == occluders.triangles.len() {
            &tree
        } else {
            all_tree = build_tree(&everything, "all instances")?;
            &all_tree
        };
        let hits: Vec<Hit> = match &device {
            Device::Gpu(ctx) => {
                let t = GpuKdTree::upload(&ctx.device, primary_tree)?;
                trace_rays(ctx, &t, &rays, TraceMode::Closest, f32::INFINITY)?.hits
            }
            Device::Cpu => primary_tree.trace_closest(&rays),
        };
        let offset = ORIGIN_OFFSET * everything.bounds().diagonal();
        let points = hit_points(&everything, &rays, &hits, offset);
        let (masks, ms) = visibility(&device, &tree, gpu_tree.as_ref(), &points, &settings, "AO pixels")?;
        let ao = masks.accessibility();
        let mut pixels = vec![None; rays.len()];
        for (p, a) in points.iter().zip(&ao) {
            pixels[p.stream as usize] = Some(*a);
        }
        write_grey_png(png, args.width, args.height, &pixels)?;
        ao_ms += ms;
        points_total += points.len();
        report["image"] = json!({
            "file": png.display().to_string(),
            "width": args.width,
            "height": args.height,
            "pixels_hit": points.len(),
            "mean_ao": mean(&ao),
            "ao_ms": ms,
            "eye": camera.eye.to_array(),
            "target": camera.target.to_array(),
            "fov": camera.fov_degrees,
        });
    }
    report["points"] = json!(points_total);
    report["ao_ms"] = json!(ao_ms);
    report["mrays_per_s"] = json!(points_total as f64 * settings.rays_per_point as f64 / (ao_ms.max(1e-9) * 1e3));
    Ok(report)
}

/// The checked `--per-vertex` and `--image` paths (at least one).
pub(super) fn outputs(args: &AoArgs) -> Result<(Option<PathBuf>, Option<PathBuf>)> {
    if args.per_vertex.is_none() && args.image.is_none() {
        return Err(Error::param("--per-vertex/--image", "give at least one output"));
    }
    let csv = args
        .per_vertex
        .as_ref()
        .map(|p| check_output(p, "--per-vertex"))
        .transpose()?;
    let png = args.image.as_ref().map(|p| check_output(p, "--image")).transpose()?;
    if png.is_some() {
        check_image_size(args.width, args.height)?;
    }
    Ok((csv, png))
}

/// AO rays on the chosen device; returns the masks and the time in ms
/// (GPU kernel time where timestamps exist).
pub(super) fn visibility(
    device: &Device,
    tree: &KdTree,
    gpu_tree: Option<&GpuKdTree>,
    points: &[AoPoint],
    settings: &AoSettings,
    label: &str,
) -> Result<(VisibilityMasks, f64)> {
    let progress = Progress::bar(points.len() as u64, label);
    match (device, gpu_tree) {
        (Device::Gpu(ctx), Some(gpu_tree)) => {
            let r = visibility_gpu(ctx, gpu_tree, points, settings, &progress)?;
            Ok((r.masks, r.gpu_ms.unwrap_or(r.wall_ms)))
        }
        _ => {
            let start = Instant::now();
            let masks = visibility_cpu(tree, points, settings, &progress);
            Ok((masks, start.elapsed().as_secs_f64() * 1e3))
        }
    }
}

pub(super) fn mean(v: &[f32]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}
