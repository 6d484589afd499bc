//! `penumbra raytrace`: Whitted ray tracing of an OBJ's MTL materials or a
//! scene file (`raytrace::runner`), one image or an animation along a
//! camera path; images as tone-mapped PNG or linear EXR/PFM radiance.

use std::path::PathBuf;

use serde_json::{Value, json};

use crate::args::{CameraArgs, CameraChoice, Common, check_output, load_shaded_input};
use crate::io::{merged, warn};
use crate::options::bounded::BoundedOptions;
use crate::options::raytrace::{RaytraceOptions, WhittedOptions};
use crate::shard::Mode;
use penumbra::error::{Error, Result};
use penumbra::io::image::ImageFormat;
use penumbra::io::output::frame_path;
use penumbra::scene::{Camera, CameraPath};
pub use penumbra::whitted::report::RaytraceMethod as Method;
use penumbra::whitted::report::{FrameImages, RenderReport};
use penumbra::whitted::{RenderScene, WhittedRenderer, WhittedSettings};

#[derive(clap::Args)]
pub struct RaytraceArgs {
    /// Mesh with its materials: OBJ + MTL (emissive Ke faces light it), glTF, or PLY.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh (meshes, materials, spheres, lights, camera).
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub size: crate::options::ImageSize,
    #[command(flatten)]
    pub knobs: RaytraceOptions,
    #[command(flatten)]
    pub whitted: WhittedOptions,
    #[command(flatten)]
    pub bounded: BoundedOptions,
    /// bounded: image of why each pixel was traced (the paper's section 8.2 colours).
    #[arg(long)]
    pub error_image: Option<PathBuf>,
    /// Camera path: one keyframe a line, "EX,EY,EZ TX,TY,TZ FOV".
    #[arg(long)]
    pub path: Option<PathBuf>,
    /// Image: .png (tone-mapped sRGB), .exr or .pfm (linear float radiance);
    /// with --frames, the last frame, or every frame where the name holds
    /// `{}` (or `{:04}`, zero-padded).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub choice: CameraChoice,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
    #[command(flatten)]
    pub shard: crate::shard::ShardArgs,
}

/// What both methods start from.
pub(super) struct Setup {
    pub device: penumbra::gpu::device::Device,
    pub threads: usize,
    pub settings: WhittedSettings,
    pub base: Camera,
    pub path: CameraPath,
    pub images: FrameImages,
    pub load_warnings: usize,
}

impl Setup {
    /// The fields every report of the command has.
    pub fn report(&self, args: &RaytraceArgs, renderer: &WhittedRenderer, camera: Camera) -> Result<Value> {
        let size = ((args.size.width, args.size.height), args.knobs.frames);
        let fields = RenderReport::new(
            args.knobs.method,
            renderer,
            &self.settings,
            size,
            camera,
            self.load_warnings,
        );
        merged(args.common.report(&self.device, self.threads), fields)
    }
}

fn setup(args: &RaytraceArgs) -> Result<(Setup, WhittedRenderer)> {
    let threads = args.common.init_threads()?;
    let settings = args.whitted.settings(args.common.seed)?;
    penumbra::scene::check_image_size(args.size.width, args.size.height)?;
    args.knobs.validate()?;
    if let Some(p) = &args.out {
        ImageFormat::check(p, "--out")?;
        check_output(p, "--out")?;
    }
    args.error_image
        .as_deref()
        .map(|p| ImageFormat::check_png(p, "--error-image"))
        .transpose()?;
    let mut scene = load_shaded_input(args.mesh.as_deref(), args.scene.as_deref())?;
    args.choice.choose(&mut scene)?;
    let path = scene.camera_path(args.path.as_deref())?;
    warn(&scene.warnings);
    let render_scene = RenderScene::new(&scene, 0, &args.whitted.lighting())?;
    warn(&render_scene.warnings);
    let device = args.common.open_device()?;
    let renderer = WhittedRenderer::new(&device, render_scene, &crate::progress::stderr())?;
    let base = scene.camera_in(&args.camera.spec(), &renderer.bounds())?;
    let spec = args.camera.spec();
    if scene.camera.is_none() && spec.eye.is_none() && path.is_none() {
        // The default camera frames the bounds from outside: right for an
        // object, not for a room, whose walls it sees from behind.
        let (hits, backs) = renderer.back_faces(&base, args.size.width, args.size.height)?;
        if backs * 2 > hits {
            warn(&[format!(
                "the default camera frames the scene from outside, and {backs} of {hits} sampled primary rays meet the back of a face (the outside of a room's walls?); place the camera with --eye and --target"
            )]);
        }
    }
    let setup = Setup {
        device,
        threads,
        settings,
        base,
        path: path.unwrap_or(CameraPath::Walk(base)),
        images: FrameImages {
            out: args.out.clone(),
            size: (args.size.width, args.size.height),
            exposure: args.knobs.exposure,
        },
        load_warnings: scene.warnings.len(),
    };
    Ok((setup, renderer))
}

pub fn run(args: &RaytraceArgs) -> Result<Value> {
    let mode = args.shard.mode()?;
    if !matches!(mode, Mode::Whole) {
        check_split(args)?;
    }
    let (setup, renderer) = setup(args)?;
    match (args.knobs.method, mode) {
        (Method::Whitted, Mode::Whole) => whitted(args, setup, renderer),
        (Method::Whitted, Mode::Part(shard)) if args.knobs.frames == 1 => {
            crate::raytrace_tiles::part(args, setup, renderer, shard)
        }
        (Method::Whitted, Mode::Merge(parts)) if args.knobs.frames == 1 => {
            crate::raytrace_tiles::merge(args, setup, renderer, &parts)
        }
        (Method::Whitted, Mode::Part(shard)) => crate::raytrace_frames::part(args, setup, renderer, shard),
        (Method::Whitted, Mode::Merge(parts)) => crate::raytrace_frames::merge(args, setup, renderer, &parts),
        (Method::Bounded, _) => crate::raytrace_bounded::run(args, setup, renderer),
    }
}

/// What a sharded run needs: one image (its rows are split), or the
/// frames of a whitted walk, each written to its own file; each rendered
/// once.
fn check_split(args: &RaytraceArgs) -> Result<()> {
    if args.knobs.method == Method::Bounded {
        let problem = "splits --method whitted's frames; --method bounded is not split (give --method whitted, or run it as one process)";
        return Err(Error::param("--shard", problem));
    }
    let pattern = args.out.as_deref().is_some_and(|p| frame_path(p, 0).is_some());
    if args.out.is_none() || (args.knobs.frames > 1 && !pattern) {
        let problem = "splits one image's rows (--out IMG) or the frames of a walk (--frames N and an --out name \
                       holding {} or {:04}, every frame its own file)";
        return Err(Error::param("--shard", problem));
    }
    let runs = args.common.runs.runs(1)?;
    if runs.warmup + runs.repeat > 1 {
        let problem = "renders each frame once; leave out --warmup and --repeat";
        return Err(Error::param("--shard", problem));
    }
    Ok(())
}

fn whitted(args: &RaytraceArgs, setup: Setup, mut renderer: WhittedRenderer) -> Result<Value> {
    let (size, frames) = ((args.size.width, args.size.height), args.knobs.frames);
    let runs = args.common.runs.runs(1)?;
    let pixels = (runs.warmup + runs.repeat) as u64 * frames as u64 * size.0 as u64 * size.1 as u64;
    let progress = crate::progress::stderr().bar(pixels, "ray tracing");
    let once = || {
        renderer.render_sequence(
            frames,
            |f| setup.path.at(f, frames),
            size,
            &setup.settings,
            &progress,
            |f, image| setup.images.frame((f, frames), &image.radiance()),
        )
    };
    let ((sequence, last), times) = runs.run("render_ms", once, |(s, _)| s.render_ms)?;
    progress.finish();
    let mut report = merged(setup.report(args, &renderer, last.camera)?, &sequence)?;
    report["timing"] = json!(last.stats.timing);
    report["path"] = json!(last.stats.path);
    report["runs"] = json!(times);
    if let Some(pixel) = args.knobs.ray_tree {
        report["ray_tree"] = json!(renderer.pixel_tree_report(&setup.base, size, &setup.settings, pixel)?);
    }
    Ok(report)
}
