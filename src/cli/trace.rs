//! `penumbra trace`: primary rays (and optionally shadow rays) from a camera,
//! with the MLRTA paper's per-packet statistics (Tables 2 and 3): traversal
//! steps (entry-point and intersection searches together) and intersection
//! tests per 4x4 packet, entry-point steps per packet.

use std::path::PathBuf;
use std::time::Instant;

use clap::ValueEnum;
use glam::Vec3;
use rayon::prelude::*;
use serde_json::{Value, json};

use super::Device;
use super::args::{CameraArgs, Common, build_tree, check_image_size, check_output, load_input, parse_vec3};
use super::io::{write_grey_png, write_rgb_png};
use super::trace_rays::mrays_per_s;
use crate::error::Result;
use crate::kdtree::gpu::{GpuKdTree, TraceMode, trace_rays};
use crate::kdtree::{KdTree, TraversalCounts};
use crate::mlrta::aa::{self, AaMode};
use crate::mlrta::gpu::trace_image_gpu;
use crate::mlrta::tiles::{DEFAULT_MIN_TILE, SHADOW_EPSILON, TileReport};
use crate::mlrta::{MlrtaCounts, MlrtaParams, Prepared, trace_image};
use crate::progress::Progress;
use crate::ray::{Hit, Ray};
use crate::scene::Mesh;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Mlrta {
    /// Entry-point search and tile splitting (the paper's MLRT rows).
    On,
    /// 4x4 packets traversed from the root (the paper's "no MLRT" rows).
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
    /// Multi-level ray tracing: entry-point search with tile splitting.
    #[arg(long, value_enum, default_value_t = Mlrta::On)]
    pub mlrta: Mlrta,
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

/// Rays per side of a packet in the statistics.
const PACKET: u32 = 4;

pub fn run(args: &TraceArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    check_image_size(args.width, args.height)?;
    let params = MlrtaParams {
        entry_points: args.mlrta == Mlrta::On,
        initial_tile: args.tile,
        min_tile: args.min_tile.unwrap_or(DEFAULT_MIN_TILE.min(args.tile)),
        split_factor: args.split_factor,
        // The rays are the camera's.
        corner_frusta: true,
    };
    params.validate()?;
    aa::validate_samples(args.aa_samples)?;
    let outputs = [
        (&args.out, "--out"),
        (&args.tiles_image, "--tiles-image"),
        (&args.aa_image, "--aa-image"),
        (&args.dump_rays, "--dump-rays"),
    ];
    for (path, option) in outputs {
        if let Some(p) = path {
            check_output(p, option)?;
        }
    }
    let scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
    let mesh = scene.world_mesh(|_| true);
    let bounds = mesh.bounds();
    let camera = args.camera.camera(scene.camera, &bounds)?;
    let light = args.light.or_else(|| {
        args.shadows
            .then(|| bounds.center() + Vec3::new(-0.4, 1.0, 0.3).normalize() * bounds.diagonal())
    });
    let device = Device::open(args.common.device)?;
    let tree = build_tree(&mesh, "trace")?;
    let rays = camera.primary_rays(args.width, args.height);
    if let Some(path) = &args.dump_rays {
        super::io::write_rays(path, &rays)?;
    }
    let packets = (args.width.div_ceil(PACKET) as u64 * args.height.div_ceil(PACKET) as u64) as f64;

    let mut report = json!({
        "device": device.kind(),
        "adapter": device.adapter(),
        "threads": threads,
        "rays": rays.len(),
        "build_ms": tree.stats.build_ms,
        "kdtree": tree.stats,
        "camera": { "eye": camera.eye.to_array(), "target": camera.target.to_array(), "fov": camera.fov_degrees },
    });
    let progress = Progress::spinner(&format!("tracing {}x{} primary rays", args.width, args.height));
    let (hits, shadowed) = if args.single_ray {
        report["mlrta"] = json!("single-ray");
        single_ray(&device, &tree, &rays, light, packets, &mut report)?
    } else {
        let prepare = Instant::now();
        let (prepared, prepared_stats) = Prepared::new(&tree, &mesh);
        report["mlrta"] = json!(if params.entry_points { "on" } else { "off" });
        report["prepare_ms"] = json!(prepare.elapsed().as_secs_f64() * 1e3);
        report["prepared"] = json!(prepared_stats);
        report["tiles"] = json!({
            "initial": params.initial_tile, "min": params.min_tile, "split_factor": params.split_factor,
        });
        let traced = match &device {
            Device::Cpu => {
                let start = Instant::now();
                let t = trace_image(&prepared, &rays, args.width, args.height, &params, light)?;
                report["timing"] = json!("wall");
                report["trace_ms"] = json!(start.elapsed().as_secs_f64() * 1e3);
                t
            }
            Device::Gpu(ctx) => {
                let gpu_tree = GpuKdTree::upload(&ctx.device, &tree)?;
                let t = trace_image_gpu(
                    ctx,
                    &gpu_tree,
                    &prepared,
                    &rays,
                    args.width,
                    args.height,
                    &params,
                    light,
                )?;
                // The kernel's time; tiles and entry points ran on the CPU.
                report["timing"] = json!(if t.gpu_ms.is_some() { "gpu-timestamps" } else { "wall" });
                report["trace_ms"] = json!(t.gpu_ms.unwrap_or(t.wall_ms));
                report["cpu_ms"] = json!(t.cpu_ms);
                report["wall_ms"] = json!(t.wall_ms);
                t.image
            }
        };
        let c = traced.counts;
        report["cells_per_packet"] = json!(cells(&c) / packets);
        report["isects_per_packet"] = json!(isects(&c) / packets);
        report["ep_steps_per_packet"] = json!(c.ep_steps as f64 / packets);
        report["counts"] = json!(c);
        let final_tiles = &traced.tiles;
        report["tiles"]["final"] = json!(final_tiles.len());
        report["tiles"]["diverging"] = json!(final_tiles.iter().filter(|t| t.diverging).count());
        report["tiles"]["stopped_at_occluder"] = json!(final_tiles.iter().filter(|t| t.stopped).count());
        if let Some(l) = light {
            let s = traced.shadow_counts;
            report["shadows"] = json!({
                "light": l.to_array(),
                "cells_per_packet": (cells(&c) + cells(&s)) / packets,
                "isects_per_packet": (isects(&c) + isects(&s)) / packets,
                "ep_steps_per_packet": (c.ep_steps + s.ep_steps) as f64 / packets,
                "counts": s,
            });
        }
        if let Some(path) = &args.tiles_image {
            write_rgb_png(
                path,
                args.width,
                args.height,
                &tile_map(final_tiles, args.width, args.height),
            )?;
        }
        if args.aa != AaMode::None {
            let (w, h) = (args.width, args.height);
            let result = aa::render(&prepared, &camera, w, h, &params, args.aa, args.aa_samples, final_tiles)?;
            let reference = if args.aa_reference {
                let mut r = aa::reference(&prepared, &camera, w, h);
                if args.aa == AaMode::Adaptive {
                    r.uniform = Some(aa::render(
                        &prepared,
                        &camera,
                        w,
                        h,
                        &params,
                        AaMode::Uniform,
                        args.aa_samples,
                        final_tiles,
                    )?);
                }
                Some(r)
            } else {
                None
            };
            report["aa"] = result.report(reference);
            if let Some(path) = &args.aa_image {
                let max = result.spp.iter().copied().max().unwrap_or(1).max(1) as f32;
                let v: Vec<Option<f32>> = result.spp.iter().map(|&n| Some(n as f32 / max)).collect();
                write_grey_png(path, args.width, args.height, &v)?;
            }
            if let Some(path) = &args.out {
                let v: Vec<Option<f32>> = result.image.iter().map(|&x| Some(x)).collect();
                write_grey_png(path, args.width, args.height, &v)?;
            }
        }
        (traced.hits, traced.shadowed)
    };
    progress.finish();
    let trace_ms = report["trace_ms"].as_f64().unwrap_or(0.0);
    let hit_count = hits.iter().filter(|h| h.is_hit()).count();
    // With a light, every hit also sends a shadow ray within the timed work.
    let traced_rays = rays.len() + if light.is_some() { hit_count } else { 0 };
    report["mrays_per_s"] = json!(mrays_per_s(traced_rays, trace_ms));
    report["hits"] = json!(hit_count);
    if let Some(s) = &shadowed {
        report["shadows"]["shadow_rays"] = json!(hit_count);
        report["shadows"]["shadowed_hits"] = json!(s.iter().filter(|&&x| x).count());
    }
    if let Some(out) = &args.out
        && args.aa == AaMode::None
    {
        write_grey_png(
            out,
            args.width,
            args.height,
            &shading(&mesh, &rays, &hits, shadowed.as_deref()),
        )?;
    }
    Ok(report)
}

fn cells(c: &MlrtaCounts) -> f64 {
    (c.ep_steps + c.xp_cells + c.single_cells) as f64
}

fn isects(c: &MlrtaCounts) -> f64 {
    (c.isects + c.single_isects) as f64
}

/// The foundation's single-ray path; statistics summed over the 16 rays of
/// each 4x4 block.
fn single_ray(
    device: &Device,
    tree: &KdTree,
    rays: &[Ray],
    light: Option<Vec3>,
    packets: f64,
    report: &mut Value,
) -> Result<(Vec<Hit>, Option<Vec<bool>>)> {
    let (hits, counts) = match device {
        Device::Cpu => {
            let start = Instant::now();
            let hits = tree.trace_closest(rays);
            report["timing"] = json!("wall");
            report["trace_ms"] = json!(start.elapsed().as_secs_f64() * 1e3);
            (hits, cpu_counts(tree, rays))
        }
        Device::Gpu(ctx) => {
            let gpu_tree = GpuKdTree::upload(&ctx.device, tree)?;
            let timed = trace_rays(ctx, &gpu_tree, rays, TraceMode::Closest, f32::INFINITY)?;
            let counted = trace_rays(ctx, &gpu_tree, rays, TraceMode::ClosestCounted, f32::INFINITY)?;
            let counts = counted
                .counts
                .unwrap_or_default()
                .iter()
                .fold(TraversalCounts::default(), |mut acc, c| {
                    acc.cells += c[0] as u64;
                    acc.intersections += c[1] as u64;
                    acc
                });
            report["timing"] = json!(if timed.gpu_ms.is_some() {
                "gpu-timestamps"
            } else {
                "wall"
            });
            report["trace_ms"] = json!(timed.gpu_ms.unwrap_or(timed.wall_ms));
            (timed.hits, counts)
        }
    };
    report["cells_per_packet"] = json!(counts.cells as f64 / packets);
    report["isects_per_packet"] = json!(counts.intersections as f64 / packets);
    // Shadow rays on the CPU, timed into the trace.
    let shadowed = light.map(|l| {
        let start = Instant::now();
        let shadow: Vec<bool> = rays
            .par_iter()
            .zip(&hits)
            .map(|(r, h)| h.is_hit() && tree.any_hit(l, r.o() + h.t * r.d() - l, 1.0 - SHADOW_EPSILON))
            .collect();
        let ms = report["trace_ms"].as_f64().unwrap_or(0.0) + start.elapsed().as_secs_f64() * 1e3;
        report["trace_ms"] = json!(ms);
        report["shadows"] = json!({ "light": l.to_array() });
        shadow
    });
    Ok((hits, shadowed))
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

fn shading(mesh: &Mesh, rays: &[Ray], hits: &[Hit], shadowed: Option<&[bool]>) -> Vec<Option<f32>> {
    rays.iter()
        .zip(hits)
        .enumerate()
        .map(|(i, (r, h))| {
            h.is_hit().then(|| {
                let n = mesh.face_normal(h.triangle as usize).normalize_or_zero();
                let lit = n.dot(r.d().normalize()).abs();
                if shadowed.is_some_and(|s| s[i]) {
                    0.25 * lit
                } else {
                    lit
                }
            })
        })
        .collect()
}

/// Figure 7 of the paper, with complexity: each final tile's brightness is
/// log2 of its entry point's subtree size (relative to the largest); red
/// marks diverging tiles, blue tiles whose search stopped at an occluder;
/// tile borders are dark.
fn tile_map(tiles: &[TileReport], width: u32, height: u32) -> Vec<[u8; 3]> {
    let mut img = vec![[0u8; 3]; width as usize * height as usize];
    let max = tiles.iter().map(|t| t.complexity).max().unwrap_or(1).max(2) as f32;
    for t in tiles {
        let level = if t.complexity == 0 {
            0.0
        } else {
            (t.complexity as f32).log2() / max.log2()
        };
        let g = (40.0 + 215.0 * level) as u8;
        let color = if t.diverging {
            [220, 40, 40]
        } else if t.stopped {
            [g / 2, g / 2, g]
        } else {
            [g, g, g]
        };
        let r = t.rect;
        for y in r.y..r.y + r.h {
            for x in r.x..r.x + r.w {
                let border = x == r.x || y == r.y;
                img[(y * width + x) as usize] = if border { [0, 0, 0] } else { color };
            }
        }
    }
    img
}
