//! `penumbra trace-rays`: closest hits of rays read from a file.

use std::path::PathBuf;

use serde_json::Value;

use crate::args::{Common, check_output};
use penumbra::accel::Structure;
use penumbra::error::Result;
use penumbra::io::rays::{read_rays_in, write_hits};
use penumbra::raycast::tracer::trace_ray_file;
use penumbra::scene::load_mesh;

#[derive(clap::Args)]
pub struct TraceRaysArgs {
    /// Mesh: OBJ, PLY (ASCII or binary) or glTF 2.0 (.gltf/.glb).
    #[arg(long)]
    pub mesh: PathBuf,
    /// Rays: 6 little-endian f32 per ray (origin, direction).
    #[arg(long)]
    pub rays: PathBuf,
    /// Hits: (f32 t, u32 triangle) per ray; a miss is (+inf, 0xFFFFFFFF).
    #[arg(long)]
    pub out: PathBuf,
    /// What the rays walk on the CPU (the GPU walks the kd-tree).
    #[arg(long, value_enum, default_value_t = Structure::Bvh)]
    pub accel: Structure,
    #[command(flatten)]
    pub common: Common,
}

pub fn run(args: &TraceRaysArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let out = check_output(&args.out, "--out")?;
    let mesh = load_mesh(&args.mesh)?;
    let rays = read_rays_in(&args.rays, mesh.origin)?;
    let device = args.common.open_device()?;
    let runs = args.common.runs.runs(1)?;
    let (hits, report) = trace_ray_file(&device, &mesh, &rays, args.accel, &runs, &crate::progress::stderr())?;
    write_hits(out, &hits)?;
    crate::io::merged(args.common.report(&device, threads), report)
}
