//! `penumbra ssao`: screen-space ambient occlusion with one of the paper's
//! estimators, measured against world-space ray-traced AO and against a
//! dense quadrature over the same depth buffer (`ssao::runner`).

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::args::{CameraArgs, CameraChoice, Common, check_outputs, load_shaded_input};
use crate::io::note_choice;
use crate::options::GreyImageOptions;
use crate::options::ssao::{SsaoOptions, SsaoRunOptions};
use penumbra::error::{Error, Result};
use penumbra::io::image::ImageFormat;
use penumbra::scene::View;
use penumbra::ssao::runner::{SsaoRequest, run as run_ssao};
use penumbra::ssao::tune::choose_cached;

#[derive(clap::Args)]
pub struct SsaoArgs {
    /// Mesh: OBJ, PLY (ASCII or binary) or glTF 2.0 (.gltf/.glb).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh (its camera and lights are the defaults).
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub knobs: SsaoOptions,
    #[command(flatten)]
    pub size: crate::options::ImageSize,
    /// Accessibility per pixel: .png (linear grey), .exr or .pfm (float).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub grey: GreyImageOptions,
    /// The shaded image, direct + a (La O + I) with the indirect light
    /// I = L~ (1 - O): .png (sRGB), .exr or .pfm (linear radiance).
    #[arg(long)]
    pub image: Option<PathBuf>,
    #[command(flatten)]
    pub run: SsaoRunOptions,
    #[command(flatten)]
    pub choice: CameraChoice,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

/// The request with `scene_radius` the radius without --radius.
fn request(a: &SsaoArgs, scene_radius: f32) -> Result<SsaoRequest> {
    let view = View::new(a.camera.spec(), a.size.width, a.size.height)?;
    let (settings, runs) = (a.knobs.settings(a.common.seed, scene_radius)?, a.common.runs.runs(1)?);
    a.run.request(settings, view, (a.image.is_some(), runs))
}

pub fn run(args: &SsaoArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    // The knobs are checked before the scene is read (a unit radius stands
    // in for the scene's until then), so a bad option is named first.
    let mut request = request(args, 1.0)?;
    if args.out.is_none() && args.image.is_none() {
        return Err(Error::param(
            "--out",
            "give an output: --out AO.png and/or --image IMG.png",
        ));
    }
    let outputs = check_outputs(&[(&args.out, "--out"), (&args.image, "--image")])?;
    outputs[0].map(|p| args.grey.style().check(p, "--out")).transpose()?;
    outputs[1].map(|p| ImageFormat::check(p, "--image")).transpose()?;
    let (mesh, scene) = (args.mesh.as_deref(), args.scene.as_deref());
    // The materials give the shaded image its colours and maps, and every
    // G-buffer the cut-outs' holes.
    let mut scene = load_shaded_input(mesh, scene)?;
    args.choice.choose(&mut scene)?;
    crate::io::warn(&scene.warnings);
    penumbra::ssao::gbuffer::validate_lights(&scene.lights)?;
    if args.knobs.radius.is_none() {
        request = self::request(args, penumbra::ssao::suggested_radius(&scene))?;
    }
    let bounds = scene.world_mesh(|_| true).bounds();
    request.view.camera = scene.complete_camera(&request.view.camera, &bounds)?;
    let device = args.common.open_device_for(&penumbra::gpu::device::Needs::SSAO)?;
    let choice = match args.knobs.max_error {
        Some(e) => {
            let files: Vec<&Path> = args.mesh.iter().chain(&args.scene).map(PathBuf::as_path).collect();
            let free = (args.knobs.measure, args.knobs.free());
            let choice = choose_cached(
                &device,
                (&scene, &files),
                &mut request,
                free,
                &crate::args::error_budget(e),
                &crate::progress::stderr(),
            )?;
            note_choice(&choice);
            Some(choice)
        }
        None => None,
    };
    let ssao = run_ssao(&device, &scene, &request, &crate::progress::stderr())?;
    crate::io::warn(&ssao.warnings);
    ssao.write_images(outputs[0], outputs[1], args.grey.style())?;
    let report = crate::io::merged(args.common.report(&device, threads), &ssao.report)?;
    crate::io::merged(report, serde_json::json!({ "max_error": choice }))
}
