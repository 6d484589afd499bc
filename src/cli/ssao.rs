//! `penumbra ssao`: screen-space ambient occlusion with one of the paper's
//! estimators, measured against world-space ray-traced AO and against a
//! dense quadrature over the same depth buffer.

use std::path::PathBuf;

use clap::ValueEnum;
use serde_json::{Value, json};

use super::Device;
use super::args::{CameraArgs, Common, build_tree, check_image_size, check_output, load_input};
use super::io::{write_grey_png, write_rgb_png};
use crate::error::{Error, Result};
use crate::ssao::gbuffer::{ScreenView, render_cpu, validate_lights};
use crate::ssao::gpu::{GBufferSource, run_frame};
use crate::ssao::truth::{raytraced, screen_reference};
use crate::ssao::{Estimator, Measure, ShadeSettings, SsaoSettings, rmse, run_cpu};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EstimatorArg {
    /// N rays x M steps (section 3.2), the baseline.
    Raymarch,
    /// Uniform points in the neighbourhood sphere (4.1).
    Sphere,
    /// Uniform points in the half sphere above the surface (4.2).
    Hemisphere,
    /// Cosine directions, r = mu^-1(xi) (4.3).
    Importance,
    /// Uniform points in the tangent sphere (4.4).
    TangentSphere,
    /// Pipes through the base disk, analytic line integral (4.5; poly4 only).
    BaseDisk,
}

impl EstimatorArg {
    fn estimator(self) -> Estimator {
        match self {
            EstimatorArg::Raymarch => Estimator::Raymarch,
            EstimatorArg::Sphere => Estimator::Sphere,
            EstimatorArg::Hemisphere => Estimator::Hemisphere,
            EstimatorArg::Importance => Estimator::Importance,
            EstimatorArg::TangentSphere => Estimator::TangentSphere,
            EstimatorArg::BaseDisk => Estimator::BaseDisk,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MeasureArg {
    /// mu = 0 below R, 1 beyond: classical AO with a maximum distance.
    Step,
    /// 1 - exp(-sigma r), truncated at R and renormalised.
    Exp,
    /// (r/R)^4.
    Poly4,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Switch {
    On,
    Off,
}

#[derive(clap::Args)]
pub struct SsaoArgs {
    /// Wavefront OBJ mesh.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh (its camera and lights are the defaults).
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    #[arg(long, value_enum)]
    pub estimator: EstimatorArg,
    /// Samples (depth-buffer tests) per pixel.
    #[arg(long, allow_negative_numbers = true)]
    pub spp: u32,
    /// Neighbourhood radius R (scene units).
    #[arg(long, allow_negative_numbers = true)]
    pub radius: f32,
    #[arg(long, default_value_t = 800, allow_negative_numbers = true)]
    pub width: u32,
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
    #[arg(long, value_enum, default_value_t = MeasureArg::Poly4)]
    pub measure: MeasureArg,
    /// Extinction sigma of --measure exp, inverse scene units [default: 3 / R].
    #[arg(long, allow_negative_numbers = true)]
    pub sigma: Option<f32>,
    /// Steps per ray of raymarch (rays = spp / steps).
    #[arg(long, default_value_t = 4, allow_negative_numbers = true)]
    pub steps: u32,
    /// Interleaved sampling over 4x4 pixel patterns.
    #[arg(long, value_enum, default_value_t = Switch::On)]
    pub interleave: Switch,
    /// Depth-aware 4x4 low-pass filter.
    #[arg(long, value_enum, default_value_t = Switch::On)]
    pub filter: Switch,
    /// The filter's depth limit (scene units) [default: R / 2].
    #[arg(long, allow_negative_numbers = true)]
    pub filter_depth: Option<f32>,
    /// Depth bias of the visibility test, in pixel footprints.
    #[arg(long, default_value_t = crate::ssao::DEFAULT_BIAS_PX, allow_negative_numbers = true)]
    pub bias: f32,
    /// Scale each pixel's sample weights so an unoccluded point gets exactly 1
    /// (off: the paper's formulas as written).
    #[arg(long, value_enum, default_value_t = Switch::On)]
    pub calibrate: Switch,
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

fn settings_of(a: &SsaoArgs) -> Result<SsaoSettings> {
    let measure = match a.measure {
        MeasureArg::Step => Measure::Step,
        MeasureArg::Poly4 => Measure::Poly4,
        MeasureArg::Exp => Measure::Exp {
            sigma: a.sigma.unwrap_or(3.0 / a.radius),
        },
    };
    if a.sigma.is_some() && a.measure != MeasureArg::Exp {
        return Err(Error::param("--sigma", "only applies to --measure exp"));
    }
    let s = SsaoSettings {
        estimator: a.estimator.estimator(),
        spp: a.spp,
        radius: a.radius,
        measure,
        steps: a.steps,
        interleave: a.interleave == Switch::On,
        filter: a.filter == Switch::On,
        filter_depth: a.filter_depth,
        bias_px: a.bias,
        calibrate: a.calibrate == Switch::On,
        seed: a.common.seed,
    };
    s.validate()?;
    Ok(s)
}

pub fn run(args: &SsaoArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let settings = settings_of(args)?;
    check_image_size(args.width, args.height)?;
    if !(args.ambient >= 0.0 && args.ambient.is_finite()) {
        return Err(Error::param(
            "--ambient",
            format!("must be >= 0 and finite, got {}", args.ambient),
        ));
    }
    if args.repeat == 0 || args.repeat > 1000 {
        return Err(Error::param("--repeat", "must be between 1 and 1000"));
    }
    if args.out.is_none() && args.image.is_none() {
        return Err(Error::param(
            "--out",
            "give an output: --out AO.png and/or --image IMG.png",
        ));
    }
    if let Some(p) = &args.out {
        check_output(p, "--out")?;
    }
    if let Some(p) = &args.image {
        check_output(p, "--image")?;
    }
    let scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
    validate_lights(&scene.lights)?;
    let mesh = scene.world_mesh(|_| true);
    let occluders = scene.occluders();
    let camera = args.camera.camera(scene.camera, &mesh.bounds())?;
    let view = ScreenView::new(&camera, args.width, args.height);
    let shade = (args.indirect || args.image.is_some()).then_some(ShadeSettings { ambient: args.ambient });
    let device = Device::open(args.common.device)?;
    let tree = build_tree(&mesh, "ssao")?;

    let (gbuffer, frame) = match &device {
        Device::Gpu(ctx) => {
            let source = GBufferSource::Render {
                mesh: &mesh,
                camera: &camera,
                lights: &scene.lights,
            };
            let f = run_frame(ctx, source, &view, &settings, shade.as_ref(), args.repeat)?;
            (f.gbuffer, f.frame)
        }
        Device::Cpu => {
            let start = std::time::Instant::now();
            let gb = render_cpu(&tree, &mesh, &camera, &scene.lights, args.width, args.height);
            let gbuffer_ms = start.elapsed().as_secs_f64() * 1e3;
            let mut frame = run_cpu(&gb, &view, &settings, shade.as_ref())?;
            frame.timings.gbuffer_ms = gbuffer_ms;
            (gb, frame)
        }
    };
    let t = frame.timings;
    let surface = gbuffer.surface_pixels();
    let mean_ao = (0..gbuffer.pixels())
        .filter(|&i| gbuffer.is_surface(i))
        .map(|i| frame.ao[i] as f64)
        .sum::<f64>()
        / surface.max(1) as f64;

    // Ground truth: only casters occlude.
    let truth = if args.truth_rays > 0 {
        let caster_tree;
        let occ_tree = if occluders.triangles.len() == mesh.triangles.len() {
            &tree
        } else if occluders.triangles.is_empty() {
            return Err(Error::param("--scene", "no instance is a caster: nothing occludes"));
        } else {
            caster_tree = build_tree(&occluders, "casters")?;
            &caster_tree
        };
        Some(raytraced(
            occ_tree,
            &camera,
            &view,
            &gbuffer,
            settings.measure,
            settings.radius,
            args.truth_rays,
            settings.seed,
        ))
    } else {
        None
    };
    let reference = (args.reference_spp > 0).then(|| screen_reference(&gbuffer, &view, &settings, args.reference_spp));

    if let Some(p) = &args.out {
        let values: Vec<Option<f32>> = (0..gbuffer.pixels())
            .map(|i| gbuffer.is_surface(i).then_some(frame.ao[i]))
            .collect();
        write_grey_png(p, args.width, args.height, &values)?;
    }
    if let (Some(p), Some(image)) = (&args.image, &frame.image) {
        let pixels: Vec<[u8; 3]> = image.iter().map(|c| [c[0], c[1], c[2]].map(srgb8)).collect();
        write_rgb_png(p, args.width, args.height, &pixels)?;
    }
    let estimate_json = |e: &Option<crate::ssao::truth::Estimate>| {
        e.as_ref()
            .map(|e| json!({ "samples": e.samples, "noise_rms": e.noise_rms, "ms": e.ms }))
    };
    let mut report = json!({
        "estimator": settings.estimator.name(),
        "spp": settings.spp,
        "ao_ms": t.ao_ms(),
        "rmse_vs_raytraced": truth.as_ref().map(|e| rmse(&gbuffer, &frame.ao, &e.values)),
        "rmse_vs_screen_reference": reference.as_ref().map(|e| rmse(&gbuffer, &frame.ao, &e.values)),
        "device": device.kind(),
        "adapter": device.adapter(),
        "threads": threads,
        "timing": t.timing,
        "gbuffer_ms": t.gbuffer_ms,
        "estimate_ms": t.estimate_ms,
        "filter_ms": t.filter_ms,
        "indirect_ms": t.indirect_ms,
        "compose_ms": t.compose_ms,
        "frame_ms": t.frame_ms(),
        "radius": settings.radius,
        "measure": settings.measure.name(),
        "sigma": match settings.measure { Measure::Exp { sigma } => json!(sigma), _ => Value::Null },
        "steps": (settings.estimator == Estimator::Raymarch).then_some(settings.steps),
        "interleave": settings.interleave,
        "filter": settings.filter,
        "filter_depth": settings.filter_depth(),
        "bias_px": settings.bias_px,
        "calibrate": settings.calibrate,
        "seed": settings.seed,
        "width": args.width,
        "height": args.height,
        "surface_pixels": surface,
        "mean_ao": mean_ao,
        "truth": estimate_json(&truth),
        "reference": estimate_json(&reference),
        "build_ms": tree.stats.build_ms,
        "camera": { "eye": camera.eye.to_array(), "target": camera.target.to_array(), "fov": camera.fov_degrees },
    });
    if let Some(r) = &reference {
        report["rmse_reference_vs_raytraced"] = truth.as_ref().map(|t| rmse(&gbuffer, &r.values, &t.values)).into();
    }
    Ok(report)
}

/// Linear [0, 1] to an 8-bit sRGB value.
fn srgb8(c: f32) -> u8 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    let s = if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}
