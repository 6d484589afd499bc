//! `penumbra trace`: primary rays from a camera, with the MLRTA paper's
//! per-packet statistics (Table 2): traversal steps and intersection tests
//! summed over the 16 rays of each 4x4 pixel block, averaged over blocks.

use std::path::PathBuf;
use std::time::Instant;

use clap::ValueEnum;
use rayon::prelude::*;
use serde_json::{Value, json};

use super::Device;
use super::args::{CameraArgs, Common, build_tree, check_image_size, check_output, load_input};
use super::io::write_grey_png;
use super::trace_rays::mrays_per_s;
use crate::error::{Error, Result};
use crate::kdtree::gpu::{GpuKdTree, TraceMode, trace_rays};
use crate::kdtree::{KdTree, TraversalCounts};
use crate::progress::Progress;
use crate::ray::{Hit, Ray};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Mlrta {
    On,
    Off,
}

#[derive(clap::Args)]
pub struct TraceArgs {
    /// Wavefront OBJ mesh.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh (its camera is the default).
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    #[arg(long, allow_negative_numbers = true)]
    pub width: u32,
    #[arg(long, allow_negative_numbers = true)]
    pub height: u32,
    /// Multi-level ray tracing (entry-point search with 4x4 packets).
    #[arg(long, value_enum, default_value_t = Mlrta::Off)]
    pub mlrta: Mlrta,
    /// Optional image: |cos| between the ray and the hit triangle, grey PNG.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

/// Rays per side of a packet in the statistics.
const PACKET: u32 = 4;

pub fn run(args: &TraceArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    check_image_size(args.width, args.height)?;
    if args.mlrta == Mlrta::On {
        return Err(Error::param(
            "--mlrta",
            "packet traversal with entry-point search is not available in this version; use --mlrta off",
        ));
    }
    let out = args.out.as_ref().map(|p| check_output(p, "--out")).transpose()?;
    let scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
    let mesh = scene.world_mesh(|_| true);
    let camera = args.camera.camera(scene.camera, &mesh.bounds())?;
    let device = Device::open(args.common.device)?;
    let tree = build_tree(&mesh, "trace")?;
    let rays = camera.primary_rays(args.width, args.height);

    // Timed run without counters, then a counted run for the statistics.
    let progress = Progress::spinner(&format!("tracing {}x{} primary rays", args.width, args.height));
    let (hits, trace_ms, timing, counts) = match &device {
        Device::Cpu => {
            let start = Instant::now();
            let hits = tree.trace_closest(&rays);
            let ms = start.elapsed().as_secs_f64() * 1e3;
            (hits, ms, "wall", cpu_counts(&tree, &rays))
        }
        Device::Gpu(ctx) => {
            let gpu_tree = GpuKdTree::upload(&ctx.device, &tree)?;
            let timed = trace_rays(ctx, &gpu_tree, &rays, TraceMode::Closest, f32::INFINITY)?;
            let counted = trace_rays(ctx, &gpu_tree, &rays, TraceMode::ClosestCounted, f32::INFINITY)?;
            let counts = counted
                .counts
                .unwrap_or_default()
                .iter()
                .fold(TraversalCounts::default(), |mut acc, c| {
                    acc.cells += c[0] as u64;
                    acc.intersections += c[1] as u64;
                    acc
                });
            let (ms, timing) = match timed.gpu_ms {
                Some(ms) => (ms, "gpu-timestamps"),
                None => (timed.wall_ms, "wall"),
            };
            (timed.hits, ms, timing, counts)
        }
    };
    progress.finish();
    let packets = (args.width.div_ceil(PACKET) as u64 * args.height.div_ceil(PACKET) as u64) as f64;
    if let Some(out) = &out {
        write_grey_png(out, args.width, args.height, &shading(&mesh, &rays, &hits))?;
    }
    Ok(json!({
        "mrays_per_s": mrays_per_s(rays.len(), trace_ms),
        "trace_ms": trace_ms,
        "cells_per_packet": counts.cells as f64 / packets,
        "isects_per_packet": counts.intersections as f64 / packets,
        "device": device.kind(),
        "adapter": device.adapter(),
        "threads": threads,
        "timing": timing,
        "mlrta": "off",
        "rays": rays.len(),
        "hits": hits.iter().filter(|h| h.is_hit()).count(),
        "build_ms": tree.stats.build_ms,
        "kdtree": tree.stats,
        "camera": { "eye": camera.eye.to_array(), "target": camera.target.to_array(), "fov": camera.fov_degrees },
    }))
}

fn cpu_counts(tree: &KdTree, rays: &[Ray]) -> TraversalCounts {
    rays.par_iter()
        .with_min_len(1024)
        .map(|r| {
            let mut c = TraversalCounts::default();
            tree.closest_hit_counted(r.o(), r.d(), f32::INFINITY, &mut c);
            c
        })
        .reduce(TraversalCounts::default, |mut a, b| {
            a += b;
            a
        })
}

fn shading(mesh: &crate::scene::Mesh, rays: &[Ray], hits: &[Hit]) -> Vec<Option<f32>> {
    rays.iter()
        .zip(hits)
        .map(|(r, h)| {
            h.is_hit().then(|| {
                let n = mesh.face_normal(h.triangle as usize).normalize_or_zero();
                n.dot(r.d().normalize()).abs()
            })
        })
        .collect()
}
