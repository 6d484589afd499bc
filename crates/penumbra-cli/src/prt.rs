//! `penumbra prt`: self-shadowed rendering under an environment map with
//! transfer recomputed every frame by hemispherical rasterisation (Kautz,
//! Lehtinen and Aila 2004), on a mesh or one of the built-in animations
//! (`prt::runner`).

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde_json::{Value, json};

use crate::args::{CameraArgs, CameraChoice, Common, check_outputs, parse_vec3};
use crate::options::prt::{AnimationOptions, PlaybackOptions, PrtOptions};
use crate::shard::Mode;
use penumbra::error::Result;
use penumbra::gpu::device::Device;
use penumbra::io::image::ImageFormat;
use penumbra::prt::blockers::InterObject;
use penumbra::prt::images::FrameImages;
use penumbra::prt::objects::{ObjectsRunner, shaded_pose};
use penumbra::prt::pipeline::{FrameOutput, PrtSettings};
use penumbra::prt::probe::{Probe, ProbeReport, probe};
use penumbra::prt::runner::{Playback, PrtRunner, RayTraced, Shadows, animate_runs};
use penumbra::prt::scene_play::play_scene_runs;
use penumbra::prt::sh_out::write_sh_json;
use penumbra::prt::tune::choose_cached;
use penumbra::report::repeats::RunTimes;
use penumbra::scene::{EnvironmentMap, View, file_stem, load_scene_in, used_bounds};
use penumbra::tune::Pick;

#[derive(clap::Args)]
pub struct PrtArgs {
    /// Mesh: OBJ, PLY or glTF (static: the transfer is still recomputed every frame).
    #[arg(long, required_unless_present_any = ["animated", "mesh_sequence", "scene"])]
    pub mesh: Option<PathBuf>,
    /// A scene file of several objects, each self-shadowed and shadowing the others; instances' `motion` moves them per frame.
    #[arg(long, conflicts_with_all = ["mesh", "animated", "mesh_sequence", "max_error"])]
    pub scene: Option<PathBuf>,
    /// How the other objects of a --scene shadow each one.
    #[arg(long, value_enum, default_value_t = InterObject::Coarse)]
    pub inter_object: InterObject,
    /// A built-in animation instead of --mesh: cloth or character.
    #[arg(long, conflicts_with = "mesh")]
    pub animated: Option<String>,
    /// Radiance .hdr latitude-longitude light probe.
    #[arg(long)]
    pub env: PathBuf,
    #[command(flatten)]
    pub knobs: PrtOptions,
    #[command(flatten)]
    pub motion: AnimationOptions,
    #[command(flatten)]
    pub play: PlaybackOptions,
    /// The fastest --mask and --hierarchy whose transfer error, estimated by
    /// the self-check, is within this at 95% confidence (cached per mesh).
    #[arg(long, allow_negative_numbers = true, conflicts_with_all = ["mask", "hierarchy"])]
    pub max_error: Option<f64>,
    /// Image of the last frame, or of every frame where the name holds `{}`
    /// (or `{:04}`): .png (sRGB), .exr or .pfm (linear radiance).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The probe's SH coefficients per colour channel, with their convention (JSON).
    #[arg(long)]
    pub sh_out: Option<PathBuf>,
    /// Radiance per frame and vertex: CSV `frame,vertex,r,g,b` with a header row.
    #[arg(long)]
    pub per_vertex: Option<PathBuf>,
    /// Add each vertex's transfer vector (t0, t1, ...) to the --per-vertex rows.
    #[arg(long)]
    pub per_vertex_transfer: bool,
    /// Folder for every frame's image (frame-0000.png, ...).
    #[arg(long)]
    pub out_frames: Option<PathBuf>,
    #[command(flatten)]
    pub size: crate::options::ImageSize,
    /// Exposure multiplier [default: mean vertex luminance of the first frame to 0.45].
    #[arg(long, allow_negative_numbers = true)]
    pub exposure: Option<f32>,
    /// Surface colour "R,G,B".
    #[arg(long, value_parser = parse_vec3, default_value = "0.8,0.8,0.8")]
    pub albedo: Vec3,
    #[command(flatten)]
    pub choice: CameraChoice,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
    #[command(flatten)]
    pub shard: crate::shard::ShardArgs,
}

/// The checked knobs: the method's settings, how the animation is played,
/// the reference's rays.
fn knobs(a: &PrtArgs) -> Result<(PrtSettings, Playback, RayTraced)> {
    let (playback, reference) = a.play.playback(a.common.seed)?;
    FrameImages::check(a.exposure, a.albedo, a.out_frames.as_deref())?;
    Ok((a.knobs.settings(a.play.shadows == Shadows::On)?, playback, reference))
}

pub fn run(args: &PrtArgs) -> Result<Value> {
    let mode = args.shard.mode()?;
    if !matches!(mode, Mode::Whole) {
        crate::prt_frames::check_split(args)?;
    }
    let threads = args.common.init_threads()?;
    let (mut settings, mut playback, reference) = knobs(args)?;
    let view = View::new(args.camera.spec(), args.size.width, args.size.height)?;
    let out_png = checked_outputs(args)?;
    settings.validate()?;
    // Inputs: the probe first (a bad file fails before any work).
    let env = EnvironmentMap::load(&args.env)?;
    let mut scene = match &args.scene {
        Some(path) => load_scene_in(path, crate::args::data_dir().as_deref())?,
        None => args.motion.scene(args.mesh.as_deref(), args.animated.as_deref())?,
    };
    args.choice.choose(&mut scene)?;
    let (frames_given, dt_given) = (args.play.frames.is_some(), args.play.dt.is_some());
    playback.fit_clip(scene.meshes[0].clip(), frames_given, dt_given)?;
    scene.warnings.iter().for_each(|w| crate::io::note(w));
    let device = args.common.open_device()?;
    let mesh = &scene.meshes[0];
    // What is shaded: the mesh's first pose, or the scene's shaded instances.
    let (rest, triangles) = shaded_pose(args.scene.is_some(), &scene, playback.start);
    // Camera: the animation's, else the contract's default; options override.
    let camera = scene.camera_in(&view.camera, &used_bounds(&rest, &triangles))?;
    let choice = match args.max_error {
        Some(e) => Some(max_error_choice(
            args,
            &device,
            (&rest, &triangles),
            &mut settings,
            camera.eye,
            e,
        )?),
        None => None,
    };
    let probed = match (args.max_error, args.knobs.probe(), &args.scene, args.play.shadows) {
        (None, Some(p), None, Shadows::On) => {
            Some(probe_choice(args, (&rest, &triangles), &mut settings, camera.eye, &p)?)
        }
        _ => None,
    };
    let transfer = args.per_vertex_transfer as usize * penumbra::sh::coefficient_count(settings.bands);
    let mut csv = args
        .per_vertex
        .as_deref()
        .map(|p| penumbra::io::vertex::PrtVertexCsv::create(p, transfer))
        .transpose()?;
    let size = (args.size.width, args.size.height);
    let files = (args.out_frames.as_deref(), out_png);
    let mut images = FrameImages::new(files, size, args.albedo, args.exposure, &env, camera);
    let (runs, eye) = (args.common.runs.runs(1)?, Some(camera.eye));
    let visibility = (args.play.shadows, reference);
    playback.bars = crate::progress::stderr();
    let name = args.scene.as_ref().map_or(mesh.name.clone(), |p| file_stem(p));
    let head = |written: usize, exposure: Option<f32>, times: Option<RunTimes>| {
        json!({ "scene": name, "images": written, "exposure": exposure, "camera": camera, "max_error": choice, "probe": probed,
                "sh_out": args.sh_out, "per_vertex": args.per_vertex, "runs": times })
    };
    if !matches!(mode, Mode::Whole) {
        let (mut mesh_runner, mut scene_runner);
        let runner = match &args.scene {
            Some(_) => {
                scene_runner = ObjectsRunner::for_scene(&device, &scene, &settings, visibility, args.inter_object)?;
                crate::io::notes(&scene_runner.notes());
                crate::prt_frames::Runner::Scene(&mut scene_runner, &scene)
            }
            None => {
                let poses = playback.poses(mesh, settings.hierarchy.poses);
                mesh_runner = PrtRunner::new_posed(&device, &poses, &triangles, &settings, visibility.0, reference)?;
                crate::io::notes(mesh_runner.notes());
                crate::prt_frames::Runner::Mesh(&mut mesh_runner, mesh)
            }
        };
        let used = match &runner {
            crate::prt_frames::Runner::Mesh(r, _) => r.device().clone(),
            crate::prt_frames::Runner::Scene(r, _) => r.device().clone(),
        };
        let play = crate::prt_frames::Play {
            runner,
            env: &env,
            eye,
            playback: &playback,
            triangles: &triangles,
        };
        let report_of = |p: &crate::prt_frames::Played| -> Result<Value> {
            crate::io::notes(&p.warnings);
            let report = crate::io::merged(head(p.images, p.exposure, p.runs.clone()), &p.report)?;
            crate::io::merged(report, args.common.report(&used, threads))
        };
        return match mode {
            Mode::Part(shard) => {
                let (played, writer) = crate::prt_frames::part(args, play, images, shard)?;
                crate::shard::finish_part(writer, report_of(&played)?)
            }
            Mode::Merge(parts) => {
                let played = crate::prt_frames::merge(args, play, &parts)?;
                if let Some(p) = &args.sh_out {
                    write_sh_json(p, &env, &args.env, settings.bands, args.play.env_spin)?;
                }
                report_of(&played)
            }
            Mode::Whole => unreachable!("a split run's mode"),
        };
    }
    let on_frame = |f: usize, positions: &[Vec3], out: &FrameOutput| {
        if let Some(csv) = csv.as_mut() {
            csv.frame(f, &out.radiance, args.albedo.to_array(), &out.transfer)?;
        }
        images.frame((f, playback.frames), (positions, &triangles), &out.radiance)
    };
    let (report, times, used) = match &args.scene {
        Some(_) => {
            let mut r = ObjectsRunner::for_scene(&device, &scene, &settings, visibility, args.inter_object)?;
            crate::io::notes(&r.notes());
            let (report, times) = play_scene_runs(&mut r, &scene, (&env, eye), &playback, runs, on_frame)?;
            crate::io::notes(&report.warnings());
            (crate::io::merged(json!({}), &report)?, times, r.device().clone())
        }
        None => {
            let poses = playback.poses(mesh, settings.hierarchy.poses);
            let mut r = PrtRunner::new_posed(&device, &poses, &triangles, &settings, visibility.0, reference)?;
            crate::io::notes(r.notes());
            let (report, times) = animate_runs(&mut r, (mesh, &env), eye, &playback, runs, on_frame)?;
            crate::io::notes(&report.warnings());
            (crate::io::merged(json!({}), &report)?, times, r.device().clone())
        }
    };
    csv.map(|c| c.finish()).transpose()?;
    if let Some(p) = &args.sh_out {
        write_sh_json(p, &env, &args.env, settings.bands, args.play.env_spin)?;
    }
    let report = crate::io::merged(head(images.written, images.exposure, Some(times)), &report)?;
    crate::io::merged(report, args.common.report(&used, threads))
}

/// `--max-error`'s choice of `settings` for the rest pose, cached per pose.
fn max_error_choice(
    args: &PrtArgs,
    device: &Device,
    (rest, triangles): (&[Vec3], &[[u32; 3]]),
    settings: &mut PrtSettings,
    eye: Vec3,
    max_error: f64,
) -> Result<Pick> {
    let files: Vec<&Path> = args.mesh.iter().map(PathBuf::as_path).collect();
    // The rest pose itself keys the cache: sequences and clips have no one file.
    let pose_crc = crc32fast::hash(bytemuck::cast_slice(rest));
    let source = (&*format!("{:?}|{pose_crc:08x}", args.animated), &files[..]);
    let budget = crate::args::error_budget(max_error);
    let progress = crate::progress::stderr();
    let choice = choose_cached(
        device,
        (rest, triangles),
        settings,
        eye,
        source,
        args.common.seed,
        &budget,
        &progress,
    )?;
    crate::io::note_choice(&choice);
    Ok(choice)
}

/// The probe's choice of the knobs not given, applied to `settings`, and
/// said on stderr.
fn probe_choice(
    args: &PrtArgs,
    (rest, triangles): (&[Vec3], &[[u32; 3]]),
    settings: &mut PrtSettings,
    eye: Vec3,
    p: &Probe,
) -> Result<ProbeReport> {
    let report = probe(rest, triangles, settings, Some(eye), p, args.common.seed)?;
    report.apply(settings);
    let c = report.choice();
    crate::io::note(&format!(
        "probe: {} ({}: estimated error {:.2}%, 95% bound {:.2}%; {} of {} settings estimated in {:.2} s)",
        report.options(),
        report.rule,
        100.0 * c.error.unwrap_or(f64::NAN),
        100.0 * c.upper.unwrap_or(f64::NAN),
        report.rows.iter().filter(|r| r.error.is_some()).count(),
        report.rows.len(),
        report.ms / 1000.0
    ));
    Ok(report)
}

/// The checked `--out` (its image format too), `--sh-out`, `--per-vertex`
/// before any work; `--out`'s path.
fn checked_outputs(args: &PrtArgs) -> Result<Option<&Path>> {
    let outputs = [
        (&args.out, "--out"),
        (&args.sh_out, "--sh-out"),
        (&args.per_vertex, "--per-vertex"),
    ];
    let out = check_outputs(&outputs)?[0];
    out.map(|p| ImageFormat::check(p, "--out")).transpose()?;
    Ok(out)
}
