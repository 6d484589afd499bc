//! `penumbra raytrace`: Whitted ray tracing of an OBJ's MTL materials or a
//! scene file (`raytrace::runner`), one image or an animation along a
//! camera path; images as tone-mapped PNG or linear EXR/PFM radiance.

use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use super::args::{CameraArgs, Common, check_output, stem};
use super::io::note;
use crate::bounded::options::BoundedOptions;
use crate::error::{Error, Result};
use crate::image_out::{ImageFormat, write_radiance};
use crate::progress::Bars;
use crate::raytrace::options::WhittedOptions;
use crate::raytrace::{RenderScene, WhittedRenderer, WhittedSettings};
use crate::scene::{Camera, CameraPath, Scene, load_mesh_file, load_scene_shaded};

/// Which ray tracer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Exact Whitted ray tracing (section 3 of the bounded-error paper).
    Whitted,
    /// Radiance interpolants within a relative error bound (--epsilon).
    Bounded,
}

#[derive(clap::Args)]
pub struct RaytraceArgs {
    #[arg(long, value_enum)]
    pub method: Method,
    /// Mesh with its materials: OBJ + MTL (emissive Ke faces light it), glTF, or PLY.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh (meshes, materials, spheres, lights, camera).
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    /// Image width in pixels.
    #[arg(long, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, allow_negative_numbers = true)]
    pub height: u32,
    #[command(flatten)]
    pub whitted: WhittedOptions,
    /// PNG only: radiance is multiplied by this before clamping to [0, 1].
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub exposure: f32,
    #[command(flatten)]
    pub bounded: BoundedOptions,
    /// bounded: also render every frame exactly and report the error and the speed-up.
    #[arg(long)]
    pub reference: bool,
    /// bounded: trace K random lines in every accepted cell a frame uses and count violations.
    #[arg(long, allow_negative_numbers = true)]
    pub check: Option<u32>,
    /// bounded: image of why each pixel was traced (the paper's section 8.2 colours).
    #[arg(long)]
    pub error_image: Option<PathBuf>,
    /// Render this many frames along --path (or the built-in walk from the camera without one).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub frames: u32,
    /// Camera path: one keyframe a line, "EX,EY,EZ TX,TY,TZ FOV".
    #[arg(long)]
    pub path: Option<PathBuf>,
    /// Adds the ray tree of pixel "X,Y" (first sample, first frame) to the JSON.
    #[arg(long, value_parser = parse_pixel)]
    pub ray_tree: Option<(u32, u32)>,
    /// Image: .png (tone-mapped sRGB), .exr or .pfm (linear float radiance);
    /// with --frames, the last frame, or every frame where the name holds
    /// `{}` (or `{:04}`, zero-padded).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

fn parse_pixel(s: &str) -> std::result::Result<(u32, u32), String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    match parts[..] {
        [x, y] => match (x.parse(), y.parse()) {
            (Ok(x), Ok(y)) => Ok((x, y)),
            _ => Err(format!("'{s}' is not two pixel coordinates X,Y")),
        },
        _ => Err(format!("expected X,Y, got '{s}'")),
    }
}

fn load(args: &RaytraceArgs) -> Result<Scene> {
    match (&args.mesh, &args.scene) {
        (Some(m), None) => Ok(Scene::from_obj_file(&stem(m), m, load_mesh_file(m)?)),
        (None, Some(s)) => load_scene_shaded(s),
        _ => Err(Error::param(
            "--mesh",
            "a mesh (--mesh FILE.obj) or a scene (--scene FILE.json) is required",
        )),
    }
}

/// What both methods start from.
pub(super) struct Setup<'a> {
    pub device: crate::device::Device,
    pub threads: usize,
    pub settings: WhittedSettings,
    pub base: Camera,
    pub path: CameraPath,
    pub out: Option<&'a Path>,
    pub load_warnings: usize,
}

impl Setup<'_> {
    /// The camera of frame `f`.
    pub fn camera(&self, f: u32, frames: u32) -> Camera {
        if frames == 1 {
            self.base
        } else {
            self.path.at(f, frames)
        }
    }

    /// Writes frame `f` where `--out` asks for every frame.
    pub fn write_frame(&self, f: u32, w: u32, h: u32, radiance: &[glam::Vec3], exposure: f32) -> Result<()> {
        if let Some(template) = self.out
            && let Some(p) = crate::output::frame_path(template, f)
        {
            write_radiance(&p, w, h, radiance, exposure)?;
        }
        Ok(())
    }

    /// Writes the last frame where `--out` names one file.
    pub fn write_last(&self, w: u32, h: u32, radiance: &[glam::Vec3], exposure: f32) -> Result<()> {
        if let Some(p) = self.out.filter(|p| crate::output::frame_path(p, 0).is_none()) {
            write_radiance(p, w, h, radiance, exposure)?;
        }
        Ok(())
    }

    /// The fields every report of the command has.
    pub fn report(&self, args: &RaytraceArgs, renderer: &WhittedRenderer, camera: &Camera) -> Value {
        let scene = renderer.scene();
        let mut report = args.common.report(&self.device, self.threads);
        let fields = json!({
            "method": args.method,
            "width": args.width,
            "height": args.height,
            "frames": args.frames,
            "max_depth": self.settings.max_depth,
            "spp": self.settings.spp,
            "fresnel": self.settings.fresnel,
            "build_ms": renderer.build_ms,
            "prepare_ms": renderer.prepare_ms,
            "triangles": scene.mesh.triangles.len(),
            "spheres": scene.spheres.len(),
            "lights": scene.lights.len(),
            "emitters": scene.emitters,
            "camera": camera,
            "warnings": self.load_warnings + scene.warnings.len(),
        });
        if let (Value::Object(a), Value::Object(b)) = (&mut report, fields) {
            a.extend(b);
        }
        report
    }
}

fn setup(args: &RaytraceArgs) -> Result<(Setup<'_>, WhittedRenderer)> {
    let threads = args.common.init_threads()?;
    let settings = args.whitted.settings(args.common.seed)?;
    crate::scene::check_image_size(args.width, args.height)?;
    if args.frames == 0 {
        return Err(Error::param("--frames", "must be at least 1"));
    }
    if !(args.exposure > 0.0 && args.exposure.is_finite()) {
        return Err(Error::param(
            "--exposure",
            format!("must be positive, got {}", args.exposure),
        ));
    }
    let out = match &args.out {
        Some(p) => {
            ImageFormat::check(p, "--out")?;
            Some(check_output(p, "--out")?)
        }
        None => None,
    };
    args.error_image
        .as_deref()
        .map(|p| ImageFormat::check_png(p, "--error-image"))
        .transpose()?;
    let path = args.path.as_deref().map(CameraPath::load).transpose()?;
    let scene = load(args)?;
    let load_warnings = scene.warnings.len();
    for w in &scene.warnings {
        note(&format!("warning: {w}"));
    }
    let render_scene = RenderScene::new(&scene, 0, &args.whitted.lighting())?;
    for w in &render_scene.warnings {
        note(&format!("warning: {w}"));
    }
    let device = args.common.open_device()?;
    let renderer = WhittedRenderer::new(&device, render_scene, Bars::Stderr)?;
    let base = args.camera.spec().resolve(scene.camera, &renderer.bounds())?;
    let setup = Setup {
        device,
        threads,
        settings,
        base,
        path: path.unwrap_or(CameraPath::Walk(base)),
        out,
        load_warnings,
    };
    Ok((setup, renderer))
}

pub fn run(args: &RaytraceArgs) -> Result<Value> {
    let (setup, renderer) = setup(args)?;
    match args.method {
        Method::Whitted => whitted(args, setup, renderer),
        Method::Bounded => super::raytrace_bounded::run(args, setup, renderer),
    }
}

fn whitted(args: &RaytraceArgs, setup: Setup, mut renderer: WhittedRenderer) -> Result<Value> {
    let (w, h) = (args.width, args.height);
    let progress = Bars::Stderr.bar(args.frames as u64 * w as u64 * h as u64, "ray tracing");
    let (sequence, last) = renderer.render_sequence(
        args.frames,
        |f| setup.camera(f, args.frames),
        (w, h),
        &setup.settings,
        &progress,
        |f, image| setup.write_frame(f, w, h, &image.radiance(), args.exposure),
    )?;
    progress.finish();
    setup.write_last(w, h, &last.radiance(), args.exposure)?;
    let mut report = super::io::merged(setup.report(args, &renderer, &last.camera), &sequence)?;
    report["timing"] = json!(last.stats.timing);
    report["path"] = json!(last.stats.path);
    if let Some((x, y)) = args.ray_tree {
        let (radiance, tree) = renderer.pixel_tree(&setup.base, (w, h), &setup.settings, (x, y, 0))?;
        let scene = renderer.scene();
        report["ray_tree"] = json!({
            "pixel": [x, y],
            "radiance": radiance.to_array(),
            "signature": tree.signature(),
            "objects": tree.objects().iter().map(|&o| scene.objects.get(o as usize)).collect::<Vec<_>>(),
            "nodes": tree.nodes,
        });
    }
    Ok(report)
}
