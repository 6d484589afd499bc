//! `penumbra ssao`: screen-space ambient occlusion with one of the paper's
//! estimators, measured against world-space ray-traced AO and against a
//! dense quadrature over the same depth buffer (`ssao::runner`).

use std::path::PathBuf;

use serde_json::Value;

use super::args::{CameraArgs, Common, OnOff, check_outputs, load_input};
use super::io::{write_grey_png, write_rgb_png};
use crate::color::srgb8;
use crate::error::{Error, Result};
use crate::progress::Bars;
use crate::scene::View;
use crate::ssao::budget::{Free, choose as choose_knobs};
use crate::ssao::runner::{SsaoRequest, run as run_ssao};
use crate::ssao::{Estimator, Measure, MeasureKind, ShadeSettings, SsaoSettings};
use crate::sweep::budget::{Choice, cached};

#[derive(clap::Args)]
pub struct SsaoArgs {
    /// Wavefront OBJ mesh.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh (its camera and lights are the defaults).
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    /// The estimator of the paper (with --max-error: fixed, else chosen).
    #[arg(long, value_enum, required_unless_present = "max_error")]
    pub estimator: Option<Estimator>,
    /// Samples (depth-buffer tests) per pixel (with --max-error: fixed, else chosen).
    #[arg(long, allow_negative_numbers = true, required_unless_present = "max_error")]
    pub spp: Option<u32>,
    /// The fastest estimator and spp whose RMSE against the ray-traced truth,
    /// estimated on 2048 pixels, is within this at 95% confidence (cached per scene).
    #[arg(long, allow_negative_numbers = true)]
    pub max_error: Option<f64>,
    /// Neighbourhood radius R (scene units).
    #[arg(long, allow_negative_numbers = true)]
    pub radius: f32,
    /// Image width in pixels.
    #[arg(long, default_value_t = 800, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 600, allow_negative_numbers = true)]
    pub height: u32,
    /// Accessibility per pixel, grey PNG (linear), background transparent.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The shaded image, direct + a (La O + I) with the indirect light
    /// I = L~ (1 - O), RGB PNG (sRGB).
    #[arg(long)]
    pub image: Option<PathBuf>,
    /// Compute the indirect light and image even without --image (timed).
    #[arg(long)]
    pub indirect: bool,
    /// Fuzzy measure mu(r).
    #[arg(long, value_enum, default_value_t = MeasureKind::Poly4)]
    pub measure: MeasureKind,
    /// Extinction sigma of --measure exp, inverse scene units [default: 3 / R].
    #[arg(long, allow_negative_numbers = true)]
    pub sigma: Option<f32>,
    /// Steps per ray of raymarch (rays = spp / steps).
    #[arg(long, default_value_t = 4, allow_negative_numbers = true)]
    pub steps: u32,
    /// Interleaved sampling over 4x4 pixel patterns.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub interleave: OnOff,
    /// Depth-aware 4x4 low-pass filter.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub filter: OnOff,
    /// The filter's depth limit (scene units) [default: R / 2].
    #[arg(long, allow_negative_numbers = true)]
    pub filter_depth: Option<f32>,
    /// Depth bias of the visibility test, in pixel footprints.
    #[arg(long, default_value_t = crate::ssao::DEFAULT_BIAS_PX, allow_negative_numbers = true)]
    pub bias: f32,
    /// Scale each pixel's sample weights so an unoccluded point gets exactly 1
    /// (off: the paper's formulas as written).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub calibrate: OnOff,
    /// Ambient radiance La of the shaded image.
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub ambient: f32,
    /// Rays per pixel of the ray-traced truth (0: skip it, rmse_vs_raytraced is null).
    #[arg(long, default_value_t = 256, allow_negative_numbers = true)]
    pub truth_rays: u32,
    /// Samples per pixel of the screen-space reference (0: skip it).
    #[arg(long, default_value_t = 1024, allow_negative_numbers = true)]
    pub reference_spp: u32,
    /// Run the GPU passes this many times and report each one's fastest.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub repeat: u32,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

fn request(a: &SsaoArgs) -> Result<SsaoRequest> {
    let settings = SsaoSettings {
        estimator: a.estimator.unwrap_or(Estimator::Importance),
        spp: a.spp.unwrap_or(16),
        radius: a.radius,
        measure: Measure::new(a.measure, a.sigma, a.radius)?,
        steps: a.steps,
        interleave: a.interleave.on(),
        filter: a.filter.on(),
        filter_depth: a.filter_depth,
        bias_px: a.bias,
        calibrate: a.calibrate.on(),
        seed: a.common.seed,
    };
    let shade = ShadeSettings { ambient: a.ambient };
    let request = SsaoRequest {
        settings,
        view: View {
            camera: a.camera.spec(),
            width: a.width,
            height: a.height,
        },
        shade: (a.indirect || a.image.is_some()).then_some(shade),
        truth_rays: a.truth_rays,
        reference_spp: a.reference_spp,
        repeat: a.repeat,
    };
    settings.validate()?;
    crate::scene::check_image_size(a.width, a.height)?;
    shade.validate()?;
    request.validate()?;
    Ok(request)
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
    let scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
    crate::ssao::gbuffer::validate_lights(&scene.lights)?;
    let bounds = scene.world_mesh(|_| true).bounds();
    request.view.camera = request.view.camera.resolve(scene.camera, &bounds)?.into();
    let device = args.common.open_device()?;
    let choice = match args.max_error {
        Some(e) => Some(choose(args, &device, &scene, &mut request, e)?),
        None => None,
    };
    let ssao = run_ssao(&device, &scene, &request, Bars::Stderr)?;
    let (w, h) = (args.width, args.height);
    if let Some(p) = outputs[0] {
        write_grey_png(p, w, h, &ssao.ao_image())?;
    }
    if let (Some(p), Some(image)) = (outputs[1], &ssao.frame.image) {
        let pixels: Vec<[u8; 3]> = image.iter().map(|c| [c[0], c[1], c[2]].map(srgb8)).collect();
        write_rgb_png(p, w, h, &pixels)?;
    }
    let report = super::io::merged(args.common.report(&device, threads), &ssao.report)?;
    super::io::merged(report, serde_json::json!({ "max_error": choice }))
}

/// `--max-error`: the choice, from the cache or checked (and cached).
fn choose(
    args: &SsaoArgs,
    device: &crate::device::Device,
    scene: &crate::scene::Scene,
    request: &mut SsaoRequest,
    max_error: f64,
) -> Result<Choice> {
    let free = Free {
        estimator: args.estimator.is_none(),
        spp: args.spp.is_none(),
    };
    let files: Vec<&std::path::Path> = args.mesh.iter().chain(&args.scene).map(PathBuf::as_path).collect();
    let options = format!("{max_error}|{free:?}|{:?}|{}", request, device.kind());
    let choice = cached("ssao", &options, &files, || {
        choose_knobs(device, scene, request, args.measure, free, max_error, Bars::Stderr)
    })?;
    super::io::note_choice(&choice);
    let k = &choice.chosen;
    request.settings.estimator = k.get_enum("estimator")?.unwrap_or(request.settings.estimator);
    request.settings.spp = k.get("spp")?.unwrap_or(request.settings.spp);
    Ok(choice)
}
