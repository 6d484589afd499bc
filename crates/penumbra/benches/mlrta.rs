//! Criterion benchmarks of multi-level ray tracing (Reshetov et al. 2005):
//! 4x4 packets with and without entry-point search, against the single-ray
//! traversal, on the CPU and the GPU.
//!
//! `cargo bench --bench mlrta` (optionally `-- <filter>`, e.g. `-- mlrta_cpu`).
//!
//! Models as in `benches/trace.rs`: `$PENUMBRA_DATA/models/{stanford-bunny,
//! dragon100k,kitchen}.obj`, or the procedural assets without it.
//!
//! Groups (throughput in rays, so criterion reports rays/s):
//! - `mlrta_prepare/<model>`: `Prepared::new` (occluders, closed surfaces).
//! - `mlrta_cpu_1thread/<model>/<mode>` and `mlrta_cpu_2threads/...`:
//!   1024x1024 primary rays of the default camera through
//!   `mlrta::trace_image` in a rayon pool of that many threads; modes
//!   `single-ray` (the kd-tree's closest hit per ray, in the same pool),
//!   `packets` (`--mlrta off`), `mlrta` (`--mlrta on`), `mlrta-camera`
//!   (`mlrta::trace_camera_into`: whole squares make their directions from
//!   the camera instead of reading the image of rays, as `penumbra trace`
//!   does), `mlrta-min-tile-8` (`--min-tile 8`: fewest traversal steps) and `mlrta+shadows`
//!   (plus a shadow ray per hit to the CLI's default light; the rays counted
//!   are the primary ones).
//! - `mlrta_gpu/<model>/<mode>/<W>x<H>`: `mlrta::gpu::PacketBatches::trace_image`
//!   (wall time: CPU tiles and entry points, upload, kernel, readback), only
//!   with a GPU adapter; 512x512 on a software adapter.

mod common;

use std::hint::black_box;
use std::time::Duration;

use common::{CPU_IMAGE, Model, gpu_image_size, load_models, primary_rays};
use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use penumbra::accel::kdtree::gpu::GpuKdTree;
use penumbra::geom::ray::{Hit, Ray};
use penumbra::gpu::GpuContext;
use penumbra::mlrta::gpu::PacketBatches;
use penumbra::mlrta::tiles::DEFAULT_MIN_TILE;
use penumbra::mlrta::{ImageBuffers, MlrtaSettings, Prepared, trace_camera_into, trace_image};
use penumbra::scene::{Camera, CameraRays};
use rayon::prelude::*;

/// The CLI's default light: above the scene, one diagonal away.
fn default_light(m: &Model) -> Vec3 {
    let b = m.mesh.bounds();
    b.center() + Vec3::new(-0.4, 1.0, 0.3).normalize() * b.diagonal()
}

fn params(entry_points: bool, min_tile: u32) -> MlrtaSettings {
    MlrtaSettings {
        entry_points,
        min_tile,
        corner_frusta: true,
        ..MlrtaSettings::default()
    }
}

fn configure(group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>) {
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
}

fn bench_prepare(c: &mut Criterion, models: &[Model]) {
    let mut group = c.benchmark_group("mlrta_prepare");
    configure(&mut group);
    for m in models {
        group.throughput(Throughput::Elements(m.mesh.triangles.len() as u64));
        group.bench_function(m.name.as_str(), |b| {
            b.iter(|| Prepared::new(black_box(m.tree()), &m.mesh).1)
        });
    }
    group.finish();
}

fn single_rays(m: &Model, rays: &[Ray]) -> Vec<Hit> {
    rays.par_chunks(4096)
        .flat_map_iter(|chunk| chunk.iter().map(|r| m.tree().closest_hit(r.o(), r.d(), f32::INFINITY)))
        .collect()
}

fn bench_cpu(c: &mut Criterion, models: &[Model], threads: usize) {
    let pool = common::thread_pool(threads);
    let name = if threads == 1 {
        "mlrta_cpu_1thread".to_string()
    } else {
        format!("mlrta_cpu_{threads}threads")
    };
    let mut group = c.benchmark_group(&name);
    configure(&mut group);
    for m in models {
        let (prepared, _) = Prepared::new(m.tree(), &m.mesh);
        let rays = primary_rays(&m.mesh, CPU_IMAGE);
        let light = default_light(m);
        // Once untimed: the packets' hits must be the single rays'.
        let reference = pool.install(|| single_rays(m, &rays));
        let traced = pool
            .install(|| {
                trace_image(
                    &prepared,
                    &rays,
                    CPU_IMAGE,
                    CPU_IMAGE,
                    &params(true, DEFAULT_MIN_TILE),
                    None,
                )
            })
            .expect("trace_image");
        let differ = traced.hits.iter().zip(&reference).filter(|(a, b)| a != b).count();
        eprintln!(
            "{name}/{}: {CPU_IMAGE}x{CPU_IMAGE}, {differ} of {} packet hits differ from single rays",
            m.name,
            rays.len()
        );
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.bench_function(BenchmarkId::new(m.name.as_str(), "single-ray"), |b| {
            b.iter(|| pool.install(|| single_rays(m, black_box(&rays))))
        });
        let modes = [
            ("packets", false, DEFAULT_MIN_TILE, None),
            ("mlrta", true, DEFAULT_MIN_TILE, None),
            ("mlrta-min-tile-8", true, 8, None),
            ("mlrta+shadows", true, DEFAULT_MIN_TILE, Some(light)),
        ];
        let camera = CameraRays::new(&Camera::default_for(&m.mesh.bounds()), CPU_IMAGE, CPU_IMAGE);
        let p = params(true, DEFAULT_MIN_TILE);
        // Fresh pixel storage each frame, as `trace_image` in the modes below.
        group.bench_function(BenchmarkId::new(m.name.as_str(), "mlrta-camera"), |b| {
            b.iter(|| {
                pool.install(|| trace_camera_into(&prepared, black_box(&camera), &p, None, ImageBuffers::default()))
                    .expect("trace_camera_into")
                    .hits
            })
        });
        for (mode, entry_points, min_tile, light) in modes {
            let p = params(entry_points, min_tile);
            group.bench_function(BenchmarkId::new(m.name.as_str(), mode), |b| {
                b.iter(|| {
                    pool.install(|| trace_image(&prepared, black_box(&rays), CPU_IMAGE, CPU_IMAGE, &p, light))
                        .expect("trace_image")
                        .hits
                })
            });
        }
    }
    group.finish();
}

fn bench_gpu(c: &mut Criterion, models: &[Model]) {
    let ctx = match GpuContext::headless() {
        Ok(ctx) => ctx,
        Err(e) => {
            eprintln!("mlrta_gpu: skipped, no GPU adapter ({e})");
            return;
        }
    };
    let size = gpu_image_size(&ctx);
    eprintln!("mlrta_gpu: adapter {}; {size}x{size} primary rays", ctx.name);
    let mut group = c.benchmark_group("mlrta_gpu");
    configure(&mut group);
    for m in models {
        let (prepared, _) = Prepared::new(m.tree(), &m.mesh);
        let gpu_tree = GpuKdTree::upload(&ctx.device, m.tree()).expect("uploading the kd-tree");
        let rays = primary_rays(&m.mesh, size);
        group.throughput(Throughput::Elements(rays.len() as u64));
        let modes = [
            ("packets", false, DEFAULT_MIN_TILE),
            ("mlrta", true, DEFAULT_MIN_TILE),
            ("mlrta-min-tile-8", true, 8),
        ];
        let mut packets = PacketBatches::new(&ctx);
        for (mode, entry_points, min_tile) in modes {
            let p = params(entry_points, min_tile);
            let first = packets
                .trace_image(&ctx, &gpu_tree, &prepared, &rays, size, size, &p, None)
                .expect("GPU packets");
            eprintln!(
                "mlrta_gpu/{}/{mode}: wall {:.1} ms (CPU part {:.1} ms), kernel {}",
                m.name,
                first.wall_ms,
                first.cpu_ms,
                first.gpu_ms.map_or("n/a".to_string(), |ms| format!(
                    "{ms:.1} ms ({:.3} Mrays/s)",
                    rays.len() as f64 / (ms * 1e3)
                ))
            );
            let id = BenchmarkId::new(format!("{}/{mode}", m.name), format!("{size}x{size}"));
            group.bench_function(id, |b| {
                b.iter(|| {
                    packets
                        .trace_image(&ctx, &gpu_tree, &prepared, black_box(&rays), size, size, &p, None)
                        .expect("GPU packets")
                        .image
                        .hits
                })
            });
        }
    }
    group.finish();
}

fn all(c: &mut Criterion) {
    let models = load_models();
    bench_prepare(c, &models);
    bench_cpu(c, &models, 1);
    bench_cpu(c, &models, 2);
    bench_gpu(c, &models);
}

criterion_group!(benches, all);
criterion_main!(benches);
