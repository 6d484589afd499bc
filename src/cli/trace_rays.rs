//! `penumbra trace-rays`: closest hits of rays read from a file.

use std::path::PathBuf;
use std::time::Instant;

use serde_json::{Value, json};

use super::Device;
use super::args::{Common, build_tree, check_output};
use super::io::{read_rays, write_hits};
use crate::error::Result;
use crate::kdtree::gpu::{GpuKdTree, TraceMode, trace_rays};
use crate::progress::Progress;
use crate::scene::load_obj;

#[derive(clap::Args)]
pub struct TraceRaysArgs {
    /// Wavefront OBJ mesh.
    #[arg(long)]
    pub mesh: PathBuf,
    /// Rays: 6 little-endian f32 per ray (origin, direction).
    #[arg(long)]
    pub rays: PathBuf,
    /// Hits: (f32 t, u32 triangle) per ray; a miss is (+inf, 0xFFFFFFFF).
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub common: Common,
}

pub fn run(args: &TraceRaysArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let out = check_output(&args.out, "--out")?;
    let mesh = load_obj(&args.mesh)?;
    let rays = read_rays(&args.rays)?;
    let device = Device::open(args.common.device)?;
    let tree = build_tree(&mesh, "trace-rays")?;

    let progress = Progress::spinner(&format!("tracing {} rays", rays.len()));
    let (hits, trace_ms, timing) = match &device {
        Device::Cpu => {
            let start = Instant::now();
            let hits = tree.trace_closest(&rays);
            (hits, start.elapsed().as_secs_f64() * 1e3, "wall")
        }
        Device::Gpu(ctx) => {
            let gpu_tree = GpuKdTree::upload(&ctx.device, &tree)?;
            let traced = trace_rays(ctx, &gpu_tree, &rays, TraceMode::Closest, f32::INFINITY)?;
            match traced.gpu_ms {
                Some(ms) => (traced.hits, ms, "gpu-timestamps"),
                None => (traced.hits, traced.wall_ms, "wall"),
            }
        }
    };
    progress.finish();
    write_hits(&out, &hits)?;
    let hit_count = hits.iter().filter(|h| h.is_hit()).count();
    Ok(json!({
        "rays": rays.len(),
        "hits": hit_count,
        "build_ms": tree.stats.build_ms,
        "trace_ms": trace_ms,
        "mrays_per_s": mrays_per_s(rays.len(), trace_ms),
        "device": device.kind(),
        "adapter": device.adapter(),
        "threads": threads,
        "timing": timing,
        "kdtree": tree.stats,
    }))
}

pub fn mrays_per_s(rays: usize, ms: f64) -> f64 {
    if ms > 0.0 { rays as f64 / (ms * 1e3) } else { 0.0 }
}
