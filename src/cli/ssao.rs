//! `penumbra ssao`: screen-space ambient occlusion with one of the paper's
//! estimators, measured against world-space ray-traced AO and against a
//! dense quadrature over the same depth buffer (`ssao::runner`).

use std::path::{Path, PathBuf};

use serde_json::Value;

use super::args::{CameraArgs, Common, check_outputs, load_input, load_shaded_input};
use super::io::note_choice;
use crate::error::{Error, Result};
use crate::image_out::{GreyImageOptions, ImageFormat, write_grey, write_radiance};
use crate::progress::Bars;
use crate::scene::View;
use crate::ssao::budget::choose_cached;
use crate::ssao::options::{SsaoOptions, SsaoRunOptions};
use crate::ssao::runner::{SsaoRequest, run as run_ssao};

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
    /// Image width in pixels.
    #[arg(long, default_value_t = 800, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 600, allow_negative_numbers = true)]
    pub height: u32,
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
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

fn request(a: &SsaoArgs) -> Result<SsaoRequest> {
    let view = View::new(a.camera.spec(), a.width, a.height)?;
    a.run.request(
        a.knobs.settings(a.common.seed)?,
        view,
        (a.image.is_some(), a.common.runs.runs(1)?),
    )
}

pub fn run(args: &SsaoArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let mut request = request(args)?;
    if args.out.is_none() && args.image.is_none() {
        return Err(Error::param(
            "--out",
            "give an output: --out AO.png and/or --image IMG.png",
        ));
    }
    let outputs = check_outputs(&[(&args.out, "--out"), (&args.image, "--image")])?;
    outputs[0].map(|p| args.grey.style().check(p, "--out")).transpose()?;
    outputs[1].map(|p| ImageFormat::check(p, "--image")).transpose()?;
    let load = if args.image.is_some() {
        load_shaded_input
    } else {
        load_input
    };
    let scene = load(args.mesh.as_deref(), args.scene.as_deref())?;
    scene
        .warnings
        .iter()
        .for_each(|w| super::io::note(&format!("warning: {w}")));
    crate::ssao::gbuffer::validate_lights(&scene.lights)?;
    let bounds = scene.world_mesh(|_| true).bounds();
    request.view.camera = request.view.camera.resolve(scene.camera, &bounds)?.into();
    let device = args.common.open_device()?;
    let choice = match args.knobs.max_error {
        Some(e) => {
            let files: Vec<&Path> = args.mesh.iter().chain(&args.scene).map(PathBuf::as_path).collect();
            let free = (args.knobs.measure, args.knobs.free());
            let choice = choose_cached(&device, (&scene, &files), &mut request, free, e, Bars::Stderr)?;
            note_choice(&choice);
            Some(choice)
        }
        None => None,
    };
    let ssao = run_ssao(&device, &scene, &request, Bars::Stderr)?;
    let (w, h) = (args.width, args.height);
    if let Some(p) = outputs[0] {
        write_grey(p, w, h, &ssao.ao_image(), args.grey.style())?;
    }
    if let (Some(p), Some(image)) = (outputs[1], &ssao.frame.image) {
        let radiance: Vec<glam::Vec3> = image.iter().map(|c| glam::Vec3::new(c[0], c[1], c[2])).collect();
        write_radiance(p, w, h, &radiance, 1.0)?;
    }
    let report = super::io::merged(args.common.report(&device, threads), &ssao.report)?;
    super::io::merged(report, serde_json::json!({ "max_error": choice }))
}
