//! `penumbra trace`: primary rays (and optionally shadow rays) from a camera,
//! with the MLRTA paper's per-packet statistics (`mlrta::runner`).

use std::path::PathBuf;

use glam::Vec3;
use serde_json::Value;

use super::args::{CameraArgs, Common, OnOff, check_outputs, load_input, parse_vec3};
use super::io::{write_grey_png, write_rgb_png};
use crate::error::Result;
use crate::mlrta::MlrtaParams;
use crate::mlrta::aa::AaMode;
use crate::mlrta::runner::{AaRequest, ShadowLight, TraceRequest, trace_view};
use crate::mlrta::tiles::DEFAULT_MIN_TILE;
use crate::progress::Bars;
use crate::ray_file::write_rays;
use crate::scene::View;

#[derive(clap::Args)]
pub struct TraceArgs {
    /// Wavefront OBJ mesh.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh (its camera is the default).
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    /// Image width in pixels.
    #[arg(long, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, allow_negative_numbers = true)]
    pub height: u32,
    /// Multi-level ray tracing: entry-point search with tile splitting
    /// (off: every 4x4 packet from the root, the paper's "no MLRT" rows).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub mlrta: OnOff,
    /// Trace rays one by one instead of in packets (the foundation's path).
    #[arg(long, conflicts_with = "mlrta")]
    pub single_ray: bool,
    /// Initial tile side in pixels (the paper's ITS).
    #[arg(long, default_value_t = 128, allow_negative_numbers = true)]
    pub tile: u32,
    /// Tiles no larger than this are not split (MTS) [default: 32, or --tile
    /// if smaller]. 8 traverses fewer cells; 32 is faster on the CPU.
    #[arg(long, allow_negative_numbers = true)]
    pub min_tile: Option<u32>,
    /// Pieces a tile is split into (SF): 4, 16, 64...
    #[arg(long, default_value_t = 16, allow_negative_numbers = true)]
    pub split_factor: u32,
    /// Point light "X,Y,Z": adds a shadow ray per hit (Table 3's statistics).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub light: Option<Vec3>,
    /// Shadow rays to the default light (above the scene) when --light is not given.
    #[arg(long)]
    pub shadows: bool,
    /// Anti-aliasing: extra rays in tiles whose entry point shows complex geometry.
    #[arg(long, value_enum, default_value_t = AaMode::None)]
    pub aa: AaMode,
    /// Rays per pixel where anti-aliasing applies (a square: 4, 16).
    #[arg(long, default_value_t = 4, allow_negative_numbers = true)]
    pub aa_samples: u32,
    /// Measure the anti-aliased image's error on edge pixels against 16 rays
    /// per pixel everywhere, and the rays uniform supersampling would use.
    #[arg(long)]
    pub aa_reference: bool,
    /// Image: |cos| between the ray and the hit triangle (shadowed hits at
    /// a quarter), grey PNG.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Map of the final tiles: brightness = entry point's subtree size (log),
    /// red = diverging tile, blue = the search stopped at an occluder.
    #[arg(long)]
    pub tiles_image: Option<PathBuf>,
    /// Where anti-aliasing put its rays: brightness = rays per pixel.
    #[arg(long)]
    pub aa_image: Option<PathBuf>,
    /// Write the primary rays traced, in the RAYS.f32 format of trace-rays
    /// (so that another tracer can run exactly the same rays).
    #[arg(long)]
    pub dump_rays: Option<PathBuf>,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

pub fn run(args: &TraceArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let mut request = TraceRequest {
        view: View::new(args.camera.spec(), args.width, args.height)?,
        single_ray: args.single_ray,
        params: MlrtaParams {
            entry_points: args.mlrta.on(),
            initial_tile: args.tile,
            min_tile: args.min_tile.unwrap_or(DEFAULT_MIN_TILE.min(args.tile)),
            split_factor: args.split_factor,
            // The rays are the camera's.
            corner_frusta: true,
        },
        light: match (args.light, args.shadows) {
            (Some(p), _) => ShadowLight::At(p),
            (None, true) => ShadowLight::AboveScene,
            (None, false) => ShadowLight::None,
        },
        aa: AaRequest {
            mode: args.aa,
            samples: args.aa_samples,
            reference: args.aa_reference,
        },
    };
    request.validate()?;
    let [out, tiles, aa, dump] = check_outputs(&[
        (&args.out, "--out"),
        (&args.tiles_image, "--tiles-image"),
        (&args.aa_image, "--aa-image"),
        (&args.dump_rays, "--dump-rays"),
    ])?[..] else {
        unreachable!("four outputs")
    };
    let scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
    let mesh = scene.world_mesh(|_| true);
    request.view.camera = request.view.camera.resolve(scene.camera, &mesh.bounds())?.into();
    let device = args.common.open_device()?;
    let image = trace_view(&device, &mesh, None, &request, Bars::Stderr)?;
    let (w, h) = (image.width, image.height);
    if let Some(path) = dump {
        write_rays(path, &image.rays)?;
    }
    if let Some(path) = tiles.filter(|_| !args.single_ray) {
        write_rgb_png(path, w, h, &image.tile_map())?;
    }
    if let (Some(path), Some(rays)) = (aa, image.aa_rays()) {
        write_grey_png(path, w, h, &rays)?;
    }
    if let Some(path) = out {
        write_grey_png(path, w, h, &image.shading(&mesh))?;
    }
    super::io::merged(args.common.report(&device, threads), &image.stats)
}
