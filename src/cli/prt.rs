//! `penumbra prt`: self-shadowed rendering under an environment map with
//! transfer recomputed every frame by hemispherical rasterisation (Kautz,
//! Lehtinen and Aila 2004), on a mesh or one of the built-in animations
//! (`prt::runner`).

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde_json::{Value, json};

use super::args::{CameraArgs, Common, OnOff, check_outputs, parse_vec3, positive};
use crate::error::{Error, Result};
use crate::image_out::{ImageFormat, write_radiance};
use crate::output::frame_path;
use crate::progress::Bars;
use crate::prt::budget::choose_cached;
use crate::prt::options::{AnimationOptions, PrtOptions};
use crate::prt::pipeline::PrtSettings;
use crate::prt::render::{auto_exposure, render_radiance};
use crate::prt::runner::{Playback, PrtRunner, PvsSampling, RayTraced, Shadows, animate};
use crate::prt::selfcheck::SelfCheck;
use crate::prt::sh_out::write_sh_json;
use crate::scene::{EnvironmentMap, View, used_bounds};

#[derive(clap::Args)]
pub struct PrtArgs {
    /// Mesh: OBJ, PLY or glTF (static: the transfer is still recomputed every frame).
    #[arg(long, required_unless_present_any = ["animated", "mesh_sequence"])]
    pub mesh: Option<PathBuf>,
    /// A built-in animation instead of --mesh: cloth or character.
    #[arg(long, conflicts_with = "mesh")]
    pub animated: Option<String>,
    /// Radiance .hdr latitude-longitude light probe.
    #[arg(long)]
    pub env: PathBuf,
    /// Frames to compute [default: 1; an animation's own frames].
    #[arg(long, allow_negative_numbers = true)]
    pub frames: Option<i64>,
    /// Animation time of the first frame, seconds.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub start: f32,
    /// Animation time between frames, seconds [default: 1/30; a clip's span / (--frames - 1)].
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f32>,
    /// Potentially visible sets from sampled animation frames.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub pvs: OnOff,
    /// Animation frames sampled for the PVS (spread over --pvs-span seconds).
    #[arg(long, default_value_t = 8, allow_negative_numbers = true)]
    pub pvs_frames: i64,
    /// Animation time the PVS samples, seconds from --start [default: the frames' span, at least 2 s].
    #[arg(long, allow_negative_numbers = true)]
    pub pvs_span: Option<f32>,
    #[command(flatten)]
    pub knobs: PrtOptions,
    #[command(flatten)]
    pub motion: AnimationOptions,
    /// Where visibility comes from.
    #[arg(long, value_enum, default_value_t = Shadows::On)]
    pub shadows: Shadows,
    /// Compare the transfer with Monte Carlo ray-traced visibility.
    #[arg(long)]
    pub check: bool,
    /// Rays per vertex of the reference.
    #[arg(long, default_value_t = 4096, allow_negative_numbers = true)]
    pub check_rays: i64,
    /// Frames compared (evenly spread over the frames computed).
    #[arg(long, default_value_t = 4, allow_negative_numbers = true)]
    pub check_frames: i64,
    /// Estimate the transfer error at setup by ray tracing a sample of vertices (`self_check` in --json).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub self_check: OnOff,
    /// Warn on stderr when the self-check's estimated error exceeds this.
    #[arg(long, default_value_t = 0.03, allow_negative_numbers = true)]
    pub self_check_threshold: f64,
    /// The fastest --mask and --hierarchy whose transfer error, estimated by
    /// the self-check, is within this at 95% confidence (cached per mesh).
    #[arg(long, allow_negative_numbers = true, conflicts_with_all = ["mask", "hierarchy"])]
    pub max_error: Option<f64>,
    /// Per-phase times (the paper's Table 2); adds a little overhead.
    #[arg(long)]
    pub profile: bool,
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
    /// Image width in pixels.
    #[arg(long, default_value_t = 640, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 480, allow_negative_numbers = true)]
    pub height: u32,
    /// Exposure multiplier [default: mean vertex luminance of the first frame to 0.45].
    #[arg(long, allow_negative_numbers = true)]
    pub exposure: Option<f32>,
    /// Surface colour "R,G,B".
    #[arg(long, value_parser = parse_vec3, default_value = "0.8,0.8,0.8")]
    pub albedo: Vec3,
    /// Turn the lighting about +y by this many degrees per frame.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub env_spin: f32,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

/// The checked knobs: the method's settings, how the animation is played,
/// the reference's rays.
fn knobs(a: &PrtArgs) -> Result<(PrtSettings, Playback, RayTraced)> {
    let frames = positive("--frames", a.frames.unwrap_or(1))?;
    let check_rays = positive("--check-rays", a.check_rays)?;
    let check_frames = positive("--check-frames", a.check_frames)?;
    let pvs_frames = positive("--pvs-frames", a.pvs_frames)?;
    let playback = Playback {
        frames,
        start: a.start,
        dt: a.dt.unwrap_or(1.0 / 30.0),
        env_spin: a.env_spin,
        pvs: a.pvs.on().then_some(PvsSampling {
            frames: pvs_frames,
            span: a.pvs_span,
        }),
        check_frames: if a.check { check_frames } else { 0 },
        profile: a.profile,
        self_check: a.self_check.on().then_some(SelfCheck {
            threshold: a.self_check_threshold,
            ..SelfCheck::default()
        }),
    };
    playback.validate()?;
    if let Some(e) = a.exposure
        && !(e.is_finite() && e > 0.0)
    {
        return Err(Error::param("--exposure", format!("must be positive, got {e}")));
    }
    if a.albedo.min_element() < 0.0 {
        return Err(Error::param("--albedo", "must be non-negative"));
    }
    let rays = u32::try_from(check_rays).map_err(|_| Error::param("--check-rays", "is too large"))?;
    let settings = a.knobs.settings(a.shadows == Shadows::On)?;
    let reference = RayTraced {
        rays,
        seed: a.common.seed,
    };
    Ok((settings, playback, reference))
}

pub fn run(args: &PrtArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let (mut settings, mut playback, reference) = knobs(args)?;
    let view = View::new(args.camera.spec(), args.width, args.height)?;
    let out_png = checked_outputs(args)?;
    settings.validate()?;
    // Inputs: the probe first (a bad file fails before any work).
    let env = EnvironmentMap::load(&args.env)?;
    let scene = args.motion.scene(args.mesh.as_deref(), args.animated.as_deref())?;
    playback.fit_clip(scene.meshes[0].clip(), args.frames.is_some(), args.dt.is_some())?;
    scene.warnings.iter().for_each(|w| super::io::note(w));
    let device = args.common.open_device()?;
    let mesh = &scene.meshes[0];
    let triangles = &mesh.mesh.triangles;
    let mut rest = Vec::new();
    mesh.positions_at(playback.start, &mut rest);
    // Camera: the animation's, else the contract's default; options override.
    let camera = view.camera.resolve(scene.camera, &used_bounds(&rest, triangles))?;
    let choice = match args.max_error {
        Some(e) => {
            let files: Vec<&Path> = args.mesh.iter().map(PathBuf::as_path).collect();
            // The rest pose itself keys the cache: sequences and clips have no one file.
            let pose_crc = crc32fast::hash(bytemuck::cast_slice(&rest));
            let source = (&*format!("{:?}|{pose_crc:08x}", args.animated), &files[..]);
            let (seed, pose) = (args.common.seed, (&rest[..], &triangles[..]));
            let choice = choose_cached(&device, pose, &mut settings, camera.eye, source, seed, e, Bars::Stderr)?;
            super::io::note_choice(&choice);
            Some(choice)
        }
        None => None,
    };
    let mut runner = PrtRunner::new(&device, &rest, triangles, &settings, args.shadows, reference)?;
    runner.notes().iter().for_each(|n| super::io::note(n));
    let transfer = args.per_vertex_transfer as usize * crate::sh::coefficient_count(settings.bands);
    let mut csv = args
        .per_vertex
        .as_deref()
        .map(|p| crate::vertex_out::PrtVertexCsv::create(p, transfer))
        .transpose()?;
    let (mut exposure, mut images) = (args.exposure, 0usize);
    let report = animate(
        &mut runner,
        mesh,
        &env,
        Some(camera.eye),
        &playback,
        |f, positions, out| {
            if let Some(csv) = csv.as_mut() {
                csv.frame(f, &out.radiance, args.albedo.to_array(), &out.transfer)?;
            }
            let last = f + 1 == playback.frames;
            let paths = [
                args.out_frames.as_ref().map(|d| d.join(format!("frame-{f:04}.png"))),
                out_png.and_then(|p| frame_path(p, f as u32).or_else(|| last.then(|| p.to_path_buf()))),
            ];
            if paths.iter().all(Option::is_none) {
                return Ok(());
            }
            let exp = *exposure.get_or_insert_with(|| auto_exposure(&out.radiance, args.albedo));
            let (w, h) = (args.width, args.height);
            let image = render_radiance(
                positions,
                triangles,
                &out.radiance,
                args.albedo,
                Some(&env),
                &camera,
                w,
                h,
            )?;
            for path in paths.iter().flatten() {
                write_radiance(path, w, h, &image, exp)?;
                images += 1;
            }
            Ok(())
        },
    )?;
    if let Some(w) = report.self_check.as_ref().and_then(|c| c.warning()) {
        super::io::note(&w);
    }
    csv.map(|c| c.finish()).transpose()?;
    if let Some(p) = &args.sh_out {
        write_sh_json(p, &env, &args.env, settings.bands, args.env_spin)?;
    }
    let head = json!({ "scene": mesh.name, "images": images, "exposure": exposure, "camera": camera, "max_error": choice,
                 "sh_out": args.sh_out, "per_vertex": args.per_vertex });
    let report = super::io::merged(head, &report)?;
    super::io::merged(report, args.common.report(runner.device(), threads))
}

/// The checked `--out` (its image format too), `--sh-out`, `--per-vertex`
/// and `--out-frames` folder, before any work; `--out`'s path.
fn checked_outputs(args: &PrtArgs) -> Result<Option<&Path>> {
    let outputs = [
        (&args.out, "--out"),
        (&args.sh_out, "--sh-out"),
        (&args.per_vertex, "--per-vertex"),
    ];
    let out = check_outputs(&outputs)?[0];
    out.map(|p| ImageFormat::check(p, "--out")).transpose()?;
    if let Some(dir) = &args.out_frames
        && !dir.is_dir()
    {
        return Err(Error::param(
            "--out-frames",
            format!("{} is not a folder", dir.display()),
        ));
    }
    Ok(out)
}
