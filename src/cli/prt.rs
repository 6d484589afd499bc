//! `penumbra prt`: self-shadowed rendering under an environment map with
//! transfer recomputed every frame by hemispherical rasterisation (Kautz,
//! Lehtinen and Aila 2004), on a mesh or one of the built-in animations
//! (`prt::runner`).

use std::path::PathBuf;

use glam::Vec3;
use serde_json::{Value, json};

use super::args::{CameraArgs, Common, OnOff, check_output, parse_vec3, positive, stem};
use super::io::write_rgb_png;
use crate::error::{Error, Result};
use crate::prt::hierarchy::{HierarchySettings, NearField};
use crate::prt::pipeline::{PrtSettings, Toggle};
use crate::prt::render::{auto_exposure, render};
use crate::prt::runner::{Playback, PrtRunner, PvsSampling, RayTraced, Shadows, animate};
use crate::prt::selfcheck::SelfCheck;
use crate::prt::transfer::{Brdf, BrdfKind, Integration};
use crate::scene::animated::AnimatedScene;
use crate::scene::{EnvironmentMap, Scene, View, load_obj, used_bounds};

#[derive(clap::Args)]
pub struct PrtArgs {
    /// Wavefront OBJ mesh (static: the transfer is still recomputed every frame).
    #[arg(long, required_unless_present = "animated")]
    pub mesh: Option<PathBuf>,
    /// A built-in animation instead of --mesh: cloth or character.
    #[arg(long, conflicts_with = "mesh")]
    pub animated: Option<String>,
    /// Radiance .hdr latitude-longitude light probe.
    #[arg(long)]
    pub env: PathBuf,
    /// Frames to compute.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub frames: i64,
    /// Animation time of the first frame, seconds.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub start: f32,
    /// Animation time between frames, seconds.
    #[arg(long, default_value_t = 1.0 / 30.0, allow_negative_numbers = true)]
    pub dt: f32,
    /// SH bands (5 = 25 coefficients).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true)]
    pub order: i64,
    /// Visibility mask side in pixels: 16, 32 or 64.
    #[arg(long, default_value_t = 32, allow_negative_numbers = true)]
    pub mask: i64,
    /// Plane LUT cells per cube-face side (the paper: 128).
    #[arg(long, default_value_t = 128, allow_negative_numbers = true)]
    pub lut: i64,
    /// BRDF of the transfer.
    #[arg(long, value_enum, default_value_t = BrdfKind::Diffuse)]
    pub brdf: BrdfKind,
    /// Phong exponent.
    #[arg(long, default_value_t = 16.0, allow_negative_numbers = true)]
    pub shininess: f32,
    /// Phong lobe weight k_s in [0, 1] (the rest is diffuse).
    #[arg(long, default_value_t = 0.4, allow_negative_numbers = true)]
    pub specular: f32,
    /// Mask integration: 4x4 grey levels (the paper), grey levels with first
    /// moments, or every pixel.
    #[arg(long, value_enum, default_value_t = Integration::CellsLinear)]
    pub integration: Integration,
    /// Two-level mesh hierarchy (coarse mesh for distant blockers).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub hierarchy: OnOff,
    /// Fine triangles drawn near a vertex.
    #[arg(long, value_enum, default_value_t = NearField::Clusters)]
    pub near: NearField,
    /// Ring of the full mesh drawn at full resolution: 1 or 2.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub ring: i64,
    /// Coarse triangles to aim for [default: triangles / 16, at most 8 sqrt(triangles) unless refinement outweighs it].
    #[arg(long, allow_negative_numbers = true)]
    pub coarse: Option<i64>,
    /// Angle (radians) a coarse triangle's distance from the fine surface may subtend at a vertex before the vertex draws the fine triangles instead (0: the paper's plain two levels).
    #[arg(long, default_value_t = crate::prt::hierarchy::DEFAULT_TOLERANCE, allow_negative_numbers = true)]
    pub coarse_tolerance: f32,
    /// Far triangles per culling group.
    #[arg(long, default_value_t = 16, allow_negative_numbers = true)]
    pub group_size: i64,
    /// Skip culling groups below the tangent plane.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub group_culling: OnOff,
    /// Potentially visible sets from sampled animation frames.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub pvs: OnOff,
    /// Animation frames sampled for the PVS (spread over --pvs-span seconds).
    #[arg(long, default_value_t = 8, allow_negative_numbers = true)]
    pub pvs_frames: i64,
    /// Animation time the PVS samples, seconds from --start [default: the frames' span, at least 2 s].
    #[arg(long, allow_negative_numbers = true)]
    pub pvs_span: Option<f32>,
    /// Cull blockers facing away from the vertex (auto: where rays find it costs no accuracy).
    #[arg(long, value_enum, default_value_t = Toggle::Auto)]
    pub backface: Toggle,
    /// Shade each vertex's side facing the camera (auto: where the mesh's back is seen from outside).
    #[arg(long, value_enum, default_value_t = Toggle::Auto)]
    pub two_sided: Toggle,
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
    /// Per-phase times (the paper's Table 2); adds a little overhead.
    #[arg(long)]
    pub profile: bool,
    /// Image of the last frame.
    #[arg(long)]
    pub out: Option<PathBuf>,
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
    let frames = positive("--frames", a.frames)?;
    let bands = positive("--order", a.order)?;
    let mask_side = positive("--mask", a.mask)?;
    let lut_size = positive("--lut", a.lut)?;
    let ring = positive("--ring", a.ring)?;
    let group_size = positive("--group-size", a.group_size)?;
    let check_rays = positive("--check-rays", a.check_rays)?;
    let check_frames = positive("--check-frames", a.check_frames)?;
    let pvs_frames = positive("--pvs-frames", a.pvs_frames)?;
    let coarse_triangles = a.coarse.map(|c| positive("--coarse", c)).transpose()?;
    let playback = Playback {
        frames,
        start: a.start,
        dt: a.dt,
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
    let settings = PrtSettings {
        mask_side,
        lut_size,
        bands,
        brdf: Brdf::new(a.brdf, a.shininess, a.specular),
        integration: a.integration,
        hierarchy: HierarchySettings {
            enabled: a.hierarchy.on(),
            near: a.near,
            ring,
            coarse_triangles,
            group_size,
            tolerance: a.coarse_tolerance,
        },
        group_culling: a.group_culling.on(),
        backface: a.backface,
        two_sided: a.two_sided,
        shadows: a.shadows == Shadows::On,
    };
    let reference = RayTraced {
        rays,
        seed: a.common.seed,
    };
    Ok((settings, playback, reference))
}

pub fn run(args: &PrtArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let (settings, playback, reference) = knobs(args)?;
    let view = View::new(args.camera.spec(), args.width, args.height)?;
    let out_png = args.out.as_deref().map(|p| check_output(p, "--out")).transpose()?;
    if let Some(dir) = &args.out_frames
        && !dir.is_dir()
    {
        return Err(Error::param(
            "--out-frames",
            format!("{} is not a folder", dir.display()),
        ));
    }
    settings.validate()?;
    // Inputs: the probe first (a bad file fails before any work).
    let env = EnvironmentMap::load(&args.env)?;
    let scene = match (&args.mesh, &args.animated) {
        (Some(path), None) => Scene::from_mesh(&stem(path), path, load_obj(path)?),
        (None, Some(name)) => Scene::from_animation(AnimatedScene::parse(name)?.build()),
        _ => return Err(Error::param("--mesh", "give --mesh FILE or --animated cloth|character")),
    };
    let device = args.common.open_device()?;
    let mesh = &scene.meshes[0];
    let triangles = &mesh.mesh.triangles;
    let mut rest = Vec::new();
    mesh.positions_at(playback.start, &mut rest);
    let mut runner = PrtRunner::new(&device, &rest, triangles, &settings, args.shadows, reference)?;
    runner.notes().iter().for_each(|n| super::io::note(n));
    // Camera: the animation's, else the contract's default; options override.
    let camera = view.camera.resolve(scene.camera, &used_bounds(&rest, triangles))?;
    let (mut exposure, mut images) = (args.exposure, 0usize);
    let report = animate(
        &mut runner,
        mesh,
        &env,
        Some(camera.eye),
        &playback,
        |f, positions, out| {
            let last = f + 1 == playback.frames;
            if args.out_frames.is_none() && !(last && out_png.is_some()) {
                return Ok(());
            }
            let exp = *exposure.get_or_insert_with(|| auto_exposure(&out.radiance, args.albedo));
            let (w, h) = (args.width, args.height);
            let pixels = render(
                positions,
                triangles,
                &out.radiance,
                args.albedo,
                Some(&env),
                &camera,
                w,
                h,
                exp,
            )?;
            let paths = [
                args.out_frames.as_ref().map(|d| d.join(format!("frame-{f:04}.png"))),
                out_png.filter(|_| last).map(PathBuf::from),
            ];
            for path in paths.iter().flatten() {
                write_rgb_png(path, w, h, &pixels)?;
                images += 1;
            }
            Ok(())
        },
    )?;
    if let Some(w) = report.self_check.as_ref().and_then(|c| c.warning()) {
        super::io::note(&w);
    }
    let head = json!({ "scene": mesh.name, "images": images, "exposure": exposure, "camera": camera });
    let report = super::io::merged(head, &report)?;
    super::io::merged(report, args.common.report(runner.device(), threads))
}
