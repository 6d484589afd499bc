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
//! - `bvh_build_1thread/<model>/{spatial,objects}`: the wide BVH over the
//!   kd-tree's triangles on a one-thread pool, with the default
//!   `BvhSettings` (spatial splits where they pay) and with object splits
//!   alone (`spatial_split_budget` 0): what the splits cost.
//! - `packets_cpu_1thread/<view>/{spatial,objects}`: 1024x1024 primary rays
//!   as 4x4 packets through each of those two BVHs (`bvh::packet::
//!   trace_image`, one-thread pool), on the default camera of every model
//!   and the kitchen from inside (`kitchen-interior`, the Embree table's
//!   view): what the splits buy.
//! - `trace_cpu_1thread/<model>/{kdtree,bvh}`: 1024x1024 primary rays of the
//!   contract's default camera, closest hit, in a plain sequential loop on
//!   the bench thread (truly one thread), through the kd-tree's single-ray
//!   walk and through the BVH. Throughput is in rays, so criterion reports
//!   rays/s ("elem/s").
//! - `random_cpu_1thread/<model>/{kdtree,bvh}`: 1,000,000 random rays
//!   (origins in a box three times the model's, aimed at points of its
//!   box, as `embree_bench --gen-rays`), as `trace-rays` traces them on one
//!   thread: the kd-tree's sorted order (`trace_closest_incoherent`), the
//!   BVH's as they come.
//! - `trace_gpu/<model>/<W>x<H>`: the same camera through
//!   `tracer::Tracer::closest` on the GPU (wall time of upload, kernel and readback),
//!   only if a GPU adapter exists. On a software adapter (lavapipe) the image
//!   is 512x512 instead of 1024x1024, as the id says;
//!   `PENUMBRA_BENCH_GPU_SIZE=N` forces NxN.

mod common;

use std::hint::black_box;

use common::{CPU_IMAGE, Model, gpu_image_size, is_software, load_models, primary_rays};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use penumbra::accel::bvh::{Bvh8, BvhSettings, packet};
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::accel::{Accel, Structure};
use penumbra::geom::ray::{Hit, Ray};
use penumbra::geom::simd::Isa;
use penumbra::gpu::GpuContext;
use penumbra::gpu::device::{Device, Timing};
use penumbra::raycast::tracer::Tracer;
use penumbra::scene::Camera;

fn trace_sequential(tree: &KdTree, rays: &[Ray]) -> Vec<Hit> {
    rays.iter()
        .map(|r| tree.closest_hit(r.o(), r.d(), f32::INFINITY))
        .collect()
}

fn bench_build(c: &mut Criterion, models: &[Model]) {
    let mut group = common::flat_group(c, "kdtree_build", 5);
    eprintln!("kdtree_build: rayon pool of {} threads", rayon::current_num_threads());
    for m in models {
        group.throughput(Throughput::Elements(m.mesh.triangles.len() as u64));
        group.bench_function(m.name.as_str(), |b| {
            b.iter(|| KdTree::build(black_box(&m.mesh), &KdTreeSettings::default()).unwrap())
        });
    }
    group.finish();
}

fn bvh_sequential(accel: &Accel, rays: &[Ray]) -> Vec<Hit> {
    let mut hits = vec![Hit::MISS; rays.len()];
    accel.closest_hits(Structure::Bvh, rays, &mut hits);
    hits
}

/// `n` random rays: origins in a box three times the model's, aimed at
/// uniform points of its box (xorshift, fixed seed).
fn random_rays(tree: &KdTree, n: usize) -> Vec<Ray> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut unit = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let (lo, hi) = (tree.bounds.min, tree.bounds.max);
    let (c, e) = ((lo + hi) * 0.5, hi - lo);
    let mut point = |scale: f32| c + e * scale * (glam::Vec3::new(unit(), unit(), unit()) - 0.5);
    (0..n)
        .map(|_| {
            let o = point(3.0);
            Ray::new(o, point(1.0) - o)
        })
        .collect()
}

/// The BVH's knobs without spatial splits.
fn objects_only() -> BvhSettings {
    BvhSettings {
        spatial_split_budget: 0.0,
        ..BvhSettings::default()
    }
}

fn bench_bvh(c: &mut Criterion, models: &[Model]) {
    let pool = common::thread_pool(1);
    let mut group = common::flat_group(c, "bvh_build_1thread", 3);
    for m in models {
        group.throughput(Throughput::Elements(m.mesh.triangles.len() as u64));
        for (id, params) in [("spatial", BvhSettings::default()), ("objects", objects_only())] {
            group.bench_function(BenchmarkId::new(m.name.as_str(), id), |b| {
                b.iter(|| pool.install(|| Bvh8::build(black_box(m.tree()), &params)))
            });
        }
    }
    group.finish();
    let mut group = common::flat_group(c, "random_cpu_1thread", 5);
    for m in models {
        m.accel.bvh();
        let rays = random_rays(m.tree(), 1_000_000);
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.bench_function(BenchmarkId::new(m.name.as_str(), "kdtree"), |b| {
            b.iter(|| pool.install(|| m.tree().trace_closest_incoherent(black_box(&rays))))
        });
        group.bench_function(BenchmarkId::new(m.name.as_str(), "bvh"), |b| {
            b.iter(|| bvh_sequential(black_box(&m.accel), black_box(&rays)))
        });
    }
    group.finish();
}

/// The primary-ray packets through a BVH with and without spatial splits.
fn bench_packets(c: &mut Criterion, models: &[Model]) {
    let pool = common::thread_pool(1);
    let mut group = common::flat_group(c, "packets_cpu_1thread", 5);
    for m in models {
        let objects = KdTree::build(&m.mesh, &KdTreeSettings::default()).expect("the model built once already");
        let objects = Accel::new(objects);
        objects.bvh_with(&objects_only());
        m.accel.bvh();
        let mut views = vec![(m.name.clone(), primary_rays(&m.mesh, CPU_IMAGE))];
        if m.name == "kitchen" {
            let inside = Camera {
                eye: Vec3::new(3.2, 1.6, 2.2),
                target: Vec3::new(-1.0, 0.9, -1.5),
                fov_degrees: 60.0,
            };
            views.push(("kitchen-interior".into(), inside.primary_rays(CPU_IMAGE, CPU_IMAGE)));
        }
        for (view, rays) in &views {
            group.throughput(Throughput::Elements(rays.len() as u64));
            for (id, accel) in [("spatial", &m.accel), ("objects", &objects)] {
                let (bvh, tree) = (accel.bvh(), accel.kdtree());
                group.bench_function(BenchmarkId::new(view.as_str(), id), |b| {
                    b.iter(|| {
                        pool.install(|| {
                            let (bvh, tree, rays) = (black_box(bvh), black_box(tree), black_box(rays));
                            packet::trace_image(bvh, tree, rays, CPU_IMAGE, CPU_IMAGE, Isa::best())
                        })
                    })
                });
            }
        }
    }
    group.finish();
}

fn bench_cpu(c: &mut Criterion, models: &[Model]) {
    let mut group = common::flat_group(c, "trace_cpu_1thread", 5);
    for m in models {
        let rays = primary_rays(&m.mesh, CPU_IMAGE);
        let hits = trace_sequential(m.tree(), &rays).iter().filter(|h| h.is_hit()).count();
        eprintln!(
            "trace_cpu_1thread/{}: {CPU_IMAGE}x{CPU_IMAGE} primary rays, {hits} hits",
            m.name
        );
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.bench_function(BenchmarkId::new(m.name.as_str(), "kdtree"), |b| {
            b.iter(|| trace_sequential(black_box(m.tree()), black_box(&rays)))
        });
        m.accel.bvh();
        group.bench_function(BenchmarkId::new(m.name.as_str(), "bvh"), |b| {
            b.iter(|| bvh_sequential(black_box(&m.accel), black_box(&rays)))
        });
    }
    group.finish();
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
    let size = gpu_image_size(&ctx);
    eprintln!(
        "trace_gpu: adapter {}{}; {size}x{size} primary rays; timestamps {}",
        ctx.name,
        if software { " (software)" } else { "" },
        if ctx.timestamps { "available" } else { "unavailable" }
    );
    let mut group = common::flat_group(c, "trace_gpu", 4);
    for m in models {
        let device = Device::gpu(ctx.clone());
        let mut tracer = Tracer::from_tree(&device, m.tree().clone()).expect("uploading the kd-tree");
        let rays = primary_rays(&m.mesh, size);
        // One untimed run: compiles the pipeline, checks against the CPU, and
        // reports the kernel-only time where timestamps exist.
        let start = std::time::Instant::now();
        let first = tracer.closest(&rays).expect("GPU trace");
        let wall_ms = penumbra::gpu::device::elapsed_ms(start);
        let cpu = trace_sequential(m.tree(), &rays);
        let differ = first.value.iter().zip(&cpu).filter(|(g, c)| g != c).count();
        let kernel = match first.timing {
            Timing::GpuTimestamps => format!(
                "{:.1} ms ({:.3} Mrays/s)",
                first.ms,
                rays.len() as f64 / (first.ms * 1e3)
            ),
            Timing::Wall => "n/a".to_string(),
        };
        eprintln!(
            "trace_gpu/{}/{size}x{size}: wall {wall_ms:.1} ms, kernel {kernel}; {differ} of {} hits differ from the CPU",
            m.name,
            rays.len()
        );
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.bench_function(BenchmarkId::new(m.name.as_str(), format!("{size}x{size}")), |b| {
            b.iter(|| tracer.closest(black_box(&rays)).expect("GPU trace").value)
        });
    }
    group.finish();
}

fn all(c: &mut Criterion) {
    let models = load_models();
    bench_build(c, &models);
    bench_cpu(c, &models);
    bench_bvh(c, &models);
    bench_packets(c, &models);
    bench_gpu(c, &models);
}

criterion_group!(benches, all);
criterion_main!(benches);
