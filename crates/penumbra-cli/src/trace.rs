//! `penumbra trace`: primary rays (and optionally shadow rays) from a camera,
//! with the MLRTA paper's per-packet statistics (`mlrta::runner`).

use std::path::PathBuf;

use serde_json::Value;

use crate::args::{CameraArgs, CameraChoice, Common, check_outputs, load_input};
use crate::options::mlrta::TraceOptions;
use penumbra::error::Result;
use penumbra::io::image::{Background, GreyStyle, ImageFormat, PngBits};
use penumbra::mlrta::images::TraceImages;
use penumbra::mlrta::runner::trace_view;
use penumbra::scene::View;

#[derive(clap::Args)]
pub struct TraceArgs {
    /// Mesh: OBJ, PLY (ASCII or binary) or glTF 2.0 (.gltf/.glb).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh (its camera is the default).
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub size: crate::options::ImageSize,
    #[command(flatten)]
    pub knobs: TraceOptions,
    /// Image: |cos| between the ray and the hit triangle (shadowed hits at
    /// a quarter): .png (linear grey), .exr or .pfm.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// --out and --aa-image: what shows where no surface is (black: opaque;
    /// transparent: alpha 0, PNG and EXR).
    #[arg(long, value_enum, default_value_t = Background::Black)]
    pub background: Background,
    /// Map of the final tiles: brightness = entry point's subtree size (log),
    /// red = diverging tile, blue = the search stopped at an occluder.
    #[arg(long)]
    pub tiles_image: Option<PathBuf>,
    /// Where anti-aliasing put its rays: brightness = rays per pixel (.png, .exr or .pfm).
    #[arg(long)]
    pub aa_image: Option<PathBuf>,
    /// Write the primary rays traced, in the RAYS.f32 format of trace-rays
    /// (so that another tracer can run exactly the same rays).
    #[arg(long)]
    pub dump_rays: Option<PathBuf>,
    #[command(flatten)]
    pub choice: CameraChoice,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

pub fn run(args: &TraceArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let view = View::new(args.camera.spec(), args.size.width, args.size.height)?;
    let mut request = args.knobs.request(view)?;
    let o = check_outputs(&[
        (&args.out, "--out"),
        (&args.tiles_image, "--tiles-image"),
        (&args.aa_image, "--aa-image"),
        (&args.dump_rays, "--dump-rays"),
    ])?;
    let style = GreyStyle {
        bits: PngBits::Eight,
        background: args.background,
    };
    o[0].map(|p| style.check(p, "--out")).transpose()?;
    o[2].map(|p| style.check(p, "--aa-image")).transpose()?;
    o[1].map(|p| ImageFormat::check_png(p, "--tiles-image")).transpose()?;
    let mut scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
    args.choice.choose(&mut scene)?;
    let mesh = scene.world_mesh(|_| true);
    request.view.camera = scene.complete_camera(&request.view.camera, &mesh.bounds())?;
    let device = args.common.open_device()?;
    let runs = args.common.runs.runs(1)?;
    let once = || trace_view(&device, &mesh, None, &request, &crate::progress::stderr());
    let (image, times) = runs.run("trace_ms", once, |i| i.stats.trace_ms)?;
    let images = TraceImages {
        shading: o[0],
        tiles: o[1],
        aa_rays: o[2],
        rays: o[3],
        background: args.background,
    };
    images.write(&image, &mesh)?;
    let report = crate::io::merged(args.common.report(&device, threads), &image.stats)?;
    crate::io::merged(report, serde_json::json!({ "runs": times }))
}
