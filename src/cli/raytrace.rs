//! `penumbra raytrace`: Whitted ray tracing of an OBJ's MTL materials or a
//! scene file (`raytrace::runner`), one image or an animation along a
//! camera path; images as tone-mapped PNG or linear EXR/PFM radiance.

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde_json::{Value, json};

use super::args::{CameraArgs, Common, OnOff, check_output, parse_vec3, stem};
use super::io::note;
use crate::error::{Error, Result};
use crate::progress::Bars;
use crate::raytrace::image::{RadianceFormat, write_radiance};
use crate::raytrace::{LightingOptions, RenderScene, WhittedRenderer, WhittedSettings};
use crate::scene::{CameraPath, Scene, load_obj_file, load_scene_shaded};

/// Which ray tracer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Exact Whitted ray tracing (section 3 of the bounded-error paper).
    Whitted,
}

#[derive(clap::Args)]
pub struct RaytraceArgs {
    #[arg(long, value_enum)]
    pub method: Method,
    /// Wavefront OBJ with its MTL materials (emissive Ke faces light it).
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
    /// Deepest reflection/refraction (0: primary and shadow rays only).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true)]
    pub max_depth: u32,
    /// Samples per pixel: 1 through the pixel centre, more jittered (anti-aliasing).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub spp: u32,
    /// Fresnel-weighted (Schlick) reflection and transmission instead of
    /// the materials' constant coefficients.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub fresnel: OnOff,
    /// Point lights per emissive polygon (1: at its centroid; more soften shadows).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub light_samples: u32,
    /// Ambient light "R,G,B" (over the scene file's; default 0.05 grey).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub ambient: Option<Vec3>,
    /// Radiance "R,G,B" of rays that leave the scene (over the scene file's; default black).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub background: Option<Vec3>,
    /// PNG only: radiance is multiplied by this before clamping to [0, 1].
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// CPU path: primary and shadow rays as MLRTA packets (off: every ray alone).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub packets: OnOff,
    /// Render this many frames along --path (or orbiting the camera without one).
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

/// The output file of frame `frame`: the template with `{}` or `{:0N}`
/// replaced by the frame number, if it holds one.
fn frame_path(template: &Path, frame: u32) -> Option<PathBuf> {
    let text = template.to_string_lossy();
    let open = text.find('{')?;
    let close = open + text[open..].find('}')?;
    let spec = &text[open + 1..close];
    let number = match spec.strip_prefix(":0").map(str::parse::<usize>) {
        Some(Ok(width)) => format!("{frame:0width$}"),
        _ if spec.is_empty() => frame.to_string(),
        _ => return None,
    };
    Some(PathBuf::from(format!(
        "{}{number}{}",
        &text[..open],
        &text[close + 1..]
    )))
}

fn load(args: &RaytraceArgs) -> Result<Scene> {
    match (&args.mesh, &args.scene) {
        (Some(m), None) => Ok(Scene::from_obj_file(&stem(m), m, load_obj_file(m)?)),
        (None, Some(s)) => load_scene_shaded(s),
        _ => Err(Error::param(
            "--mesh",
            "a mesh (--mesh FILE.obj) or a scene (--scene FILE.json) is required",
        )),
    }
}

pub fn run(args: &RaytraceArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let settings = WhittedSettings {
        max_depth: args.max_depth,
        spp: args.spp,
        seed: args.common.seed,
        fresnel: args.fresnel.on(),
        packets: args.packets.on(),
    };
    settings.validate()?;
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
            RadianceFormat::of(p).map_err(|e| e.with_names(|_| Some("--out")))?;
            Some(check_output(p, "--out")?)
        }
        None => None,
    };
    let path = args.path.as_deref().map(CameraPath::load).transpose()?;
    let scene = load(args)?;
    let load_warnings = scene.warnings.len();
    for w in &scene.warnings {
        note(&format!("warning: {w}"));
    }
    let options = LightingOptions {
        light_samples: args.light_samples,
        ambient: args.ambient,
        background: args.background,
    };
    let render_scene = RenderScene::new(&scene, 0, &options)?;
    for w in &render_scene.warnings {
        note(&format!("warning: {w}"));
    }
    let device = args.common.open_device()?;
    let mut renderer = WhittedRenderer::new(&device, render_scene, Bars::Stderr)?;
    let base = args.camera.spec().resolve(scene.camera, &renderer.bounds())?;
    let path = path.unwrap_or(CameraPath::Orbit(base));
    let (w, h) = (args.width, args.height);
    let bars = Bars::Stderr;
    let progress = bars.bar(args.frames as u64 * w as u64 * h as u64, "ray tracing");
    let mut total = (0.0, crate::raytrace::RayCounts::default());
    let mut frame_ms = Vec::new();
    let mut last = None;
    for f in 0..args.frames {
        let camera = if args.frames == 1 {
            base
        } else {
            path.at(f, args.frames)
        };
        let image = renderer.render(&camera, w, h, &settings, &progress)?;
        if !renderer.is_gpu() {
            progress.inc(w as u64 * h as u64);
        }
        total.0 += image.stats.render_ms;
        let r = image.stats.rays;
        total.1.primary += r.primary;
        total.1.shadow += r.shadow;
        total.1.reflection += r.reflection;
        total.1.refraction += r.refraction;
        frame_ms.push(image.stats.render_ms);
        if let Some(template) = out
            && let Some(p) = frame_path(template, f)
        {
            write_radiance(&p, w, h, &image.radiance(), args.exposure)?;
        }
        last = Some(image);
    }
    progress.finish();
    let last = last.ok_or_else(|| Error::internal("no frame rendered"))?;
    if let Some(p) = out.filter(|p| frame_path(p, 0).is_none()) {
        write_radiance(p, w, h, &last.radiance(), args.exposure)?;
    }
    let scene = renderer.scene();
    let mut report = args.common.report(&device, threads);
    let fields = json!({
        "method": args.method,
        "width": w,
        "height": h,
        "frames": args.frames,
        "rays": total.1,
        "render_ms": total.0,
        "frame_ms": frame_ms,
        "mrays_per_s": crate::mlrta::runner::mrays_per_s(total.1.total() as usize, total.0),
        "timing": last.stats.timing,
        "path": last.stats.path,
        "max_depth": settings.max_depth,
        "spp": settings.spp,
        "fresnel": settings.fresnel,
        "build_ms": renderer.build_ms,
        "prepare_ms": renderer.prepare_ms,
        "triangles": scene.mesh.triangles.len(),
        "spheres": scene.spheres.len(),
        "lights": scene.lights.len(),
        "emitters": scene.emitters,
        "camera": last.camera,
        "warnings": load_warnings + scene.warnings.len(),
    });
    if let (Value::Object(a), Value::Object(b)) = (&mut report, fields) {
        a.extend(b);
    }
    if let Some((x, y)) = args.ray_tree {
        let (radiance, tree) = renderer.pixel_tree(&base, (w, h), &settings, (x, y, 0))?;
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
