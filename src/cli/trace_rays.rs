//! `penumbra trace-rays`: closest hits of rays read from a file.

use std::path::PathBuf;

use serde_json::{Value, json};

use super::args::{Common, check_output};
use crate::error::Result;
use crate::mlrta::runner::mrays_per_s;
use crate::progress::Bars;
use crate::ray_file::{read_rays_in, write_hits};
use crate::scene::load_mesh;
use crate::tracer::{Accel, Tracer};

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
    #[arg(long, value_enum, default_value_t = Accel::Bvh)]
    pub accel: Accel,
    #[command(flatten)]
    pub common: Common,
}

pub fn run(args: &TraceRaysArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let out = check_output(&args.out, "--out")?;
    let mesh = load_mesh(&args.mesh)?;
    let rays = read_rays_in(&args.rays, mesh.origin)?;
    let device = args.common.open_device()?;
    let mut tracer = Tracer::build(&device, &mesh, Bars::Stderr, "trace-rays")?.with_accel(args.accel);
    let progress = Bars::Stderr.spinner(&format!("tracing {} rays", rays.len()));
    let runs = args.common.runs.runs(1)?;
    let (traced, times) = runs.run("trace_ms", || tracer.closest_incoherent(&rays), |t| t.ms)?;
    progress.finish();
    write_hits(out, &traced.value)?;
    let (stats, bvh) = (&tracer.tree().stats, tracer.bvh_stats());
    let report = json!({
        "rays": rays.len(),
        "hits": traced.value.iter().filter(|h| h.is_hit()).count(),
        "build_ms": stats.build_ms,
        "trace_ms": traced.ms,
        "mrays_per_s": mrays_per_s(rays.len(), traced.ms),
        "timing": traced.timing,
        "kdtree": stats,
        "bvh": bvh,
        "runs": times,
    });
    super::io::merged(report, args.common.report(&device, threads))
}
