//! Criterion benchmarks: kd-tree build, single-threaded CPU closest-hit
//! traversal of primary rays, and the GPU trace kernel.
//!
//! `cargo bench --bench trace` (optionally `-- <filter>`, e.g. `-- trace_cpu`).
//!
//! Models: `$PENUMBRA_DATA/models/{stanford-bunny,dragon100k,kitchen}.obj`.
//! Without `PENUMBRA_DATA` the bench falls back to the crate's procedural
//! scenes in `assets/` so that it always runs (their numbers are not
//! comparable with the real models').
//!
//! Groups:
//! - `kdtree_build/<model>`: `KdTree::build` with default parameters, on the
//!   global rayon pool (all cores; the build recurses with `rayon::join`).
//! - `trace_cpu_1thread/<model>`: 1024x1024 primary rays of the contract's
//!   default camera, closest hit, in a plain sequential loop on the bench
//!   thread (truly one thread). Throughput is in rays, so criterion reports
//!   rays/s ("elem/s").
//! - `trace_gpu/<model>/<W>x<H>`: the same camera through
//!   `kdtree::gpu::trace_rays` (wall time of upload, kernel and readback),
//!   only if a GPU adapter exists. On a software adapter (lavapipe) the image
//!   is 512x512 instead of 1024x1024, as the id says;
//!   `PENUMBRA_BENCH_GPU_SIZE=N` forces NxN.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use penumbra::gpu::{GpuContext, enumerate_adapters};
use penumbra::kdtree::gpu::{GpuKdTree, TraceMode, trace_rays};
use penumbra::kdtree::{KdTree, KdTreeParams};
use penumbra::ray::{Hit, Ray};
use penumbra::scene::{Camera, Mesh, load_obj};

const DATA_MODELS: [&str; 3] = ["stanford-bunny", "dragon100k", "kitchen"];
const FALLBACK_MODELS: [&str; 3] = ["sphere-on-plane", "corner", "cube-with-hole"];
const CPU_IMAGE: u32 = 1024;
const GPU_IMAGE_HARDWARE: u32 = 1024;
const GPU_IMAGE_SOFTWARE: u32 = 512;

struct Model {
    name: String,
    mesh: Mesh,
    tree: KdTree,
}

fn model_paths() -> Vec<(String, PathBuf)> {
    match std::env::var_os("PENUMBRA_DATA") {
        Some(data) => {
            let dir = Path::new(&data).join("models");
            DATA_MODELS
                .iter()
                .filter_map(|m| {
                    let path = dir.join(format!("{m}.obj"));
                    if path.is_file() {
                        Some((m.to_string(), path))
                    } else {
                        eprintln!("note: {} not found; skipping {m}", path.display());
                        None
                    }
                })
                .collect()
        }
        None => {
            let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
            eprintln!(
                "note: PENUMBRA_DATA is not set; benchmarking the procedural scenes in {} \
                 ({}) instead of {}. Set PENUMBRA_DATA to the folder holding models/ for real numbers.",
                dir.display(),
                FALLBACK_MODELS.join(", "),
                DATA_MODELS.join(", ")
            );
            FALLBACK_MODELS
                .iter()
                .map(|m| (m.to_string(), dir.join(format!("{m}.obj"))))
                .collect()
        }
    }
}

fn load_models() -> Vec<Model> {
    model_paths()
        .into_iter()
        .map(|(name, path)| {
            let mesh = load_obj(&path).unwrap_or_else(|e| panic!("loading {}: {e}", path.display()));
            let tree = KdTree::build(&mesh, &KdTreeParams::default())
                .unwrap_or_else(|e| panic!("building the kd-tree of {}: {e}", path.display()));
            eprintln!(
                "{name}: {} triangles, kd-tree {} nodes, depth {}, built in {:.1} ms",
                mesh.triangles.len(),
                tree.stats.nodes,
                tree.stats.depth,
                tree.stats.build_ms
            );
            Model { name, mesh, tree }
        })
        .collect()
}

fn primary_rays(mesh: &Mesh, size: u32) -> Vec<Ray> {
    Camera::default_for(&mesh.bounds()).primary_rays(size, size)
}

fn trace_sequential(tree: &KdTree, rays: &[Ray]) -> Vec<Hit> {
    rays.iter()
        .map(|r| tree.closest_hit(r.o(), r.d(), f32::INFINITY))
        .collect()
}

fn bench_build(c: &mut Criterion, models: &[Model]) {
    let mut group = c.benchmark_group("kdtree_build");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    eprintln!("kdtree_build: rayon pool of {} threads", rayon::current_num_threads());
    for m in models {
        group.throughput(Throughput::Elements(m.mesh.triangles.len() as u64));
        group.bench_function(m.name.as_str(), |b| {
            b.iter(|| KdTree::build(black_box(&m.mesh), &KdTreeParams::default()).unwrap())
        });
    }
    group.finish();
}

fn bench_cpu(c: &mut Criterion, models: &[Model]) {
    let mut group = c.benchmark_group("trace_cpu_1thread");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    for m in models {
        let rays = primary_rays(&m.mesh, CPU_IMAGE);
        let hits = trace_sequential(&m.tree, &rays).iter().filter(|h| h.is_hit()).count();
        eprintln!(
            "trace_cpu_1thread/{}: {CPU_IMAGE}x{CPU_IMAGE} primary rays, {hits} hits",
            m.name
        );
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.bench_function(m.name.as_str(), |b| {
            b.iter(|| trace_sequential(black_box(&m.tree), black_box(&rays)))
        });
    }
    group.finish();
}

/// Whether the adapter the context was created on is a software rasteriser.
fn is_software(ctx: &GpuContext) -> bool {
    let name = ctx.name.to_lowercase();
    name.contains("llvmpipe")
        || name.contains("lavapipe")
        || name.contains("swiftshader")
        || enumerate_adapters()
            .iter()
            .any(|a| a.name == ctx.name && a.device_type == "cpu")
}

fn bench_gpu(c: &mut Criterion, models: &[Model]) {
    let ctx = match GpuContext::headless() {
        Ok(ctx) => ctx,
        Err(e) => {
            eprintln!("trace_gpu: skipped, no GPU adapter ({e})");
            return;
        }
    };
    let software = is_software(&ctx);
    let size = std::env::var("PENUMBRA_BENCH_GPU_SIZE")
        .ok()
        .and_then(|s| s.parse::<u32>().ok())
        .filter(|&n| n > 0)
        .unwrap_or(if software {
            GPU_IMAGE_SOFTWARE
        } else {
            GPU_IMAGE_HARDWARE
        });
    eprintln!(
        "trace_gpu: adapter {}{}; {size}x{size} primary rays; timestamps {}",
        ctx.name,
        if software { " (software)" } else { "" },
        if ctx.timestamps { "available" } else { "unavailable" }
    );
    let mut group = c.benchmark_group("trace_gpu");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    for m in models {
        let gpu_tree = GpuKdTree::upload(&ctx.device, &m.tree).expect("uploading the kd-tree");
        let rays = primary_rays(&m.mesh, size);
        // One untimed run: compiles the pipeline, checks against the CPU, and
        // reports the kernel-only time where timestamps exist.
        let first = trace_rays(&ctx, &gpu_tree, &rays, TraceMode::Closest, f32::INFINITY).expect("GPU trace");
        let cpu = trace_sequential(&m.tree, &rays);
        let differ = first.hits.iter().zip(&cpu).filter(|(g, c)| g != c).count();
        eprintln!(
            "trace_gpu/{}/{size}x{size}: wall {:.1} ms, kernel {}; {differ} of {} hits differ from the CPU",
            m.name,
            first.wall_ms,
            first.gpu_ms.map_or("n/a".to_string(), |ms| format!(
                "{ms:.1} ms ({:.3} Mrays/s)",
                rays.len() as f64 / (ms * 1e3)
            )),
            rays.len()
        );
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.bench_function(BenchmarkId::new(m.name.as_str(), format!("{size}x{size}")), |b| {
            b.iter(|| {
                trace_rays(&ctx, &gpu_tree, black_box(&rays), TraceMode::Closest, f32::INFINITY)
                    .expect("GPU trace")
                    .hits
            })
        });
    }
    group.finish();
}

fn all(c: &mut Criterion) {
    let models = load_models();
    bench_build(c, &models);
    bench_cpu(c, &models);
    bench_gpu(c, &models);
}

criterion_group!(benches, all);
criterion_main!(benches);
