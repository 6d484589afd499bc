//! Criterion benchmarks of the Whitted ray tracer (`src/raytrace`): whole
//! renders (primary, shadow, reflection and refraction rays) of every
//! shipped scene on the CPU, with and without MLRTA packets, and on the GPU.
//!
//! `cargo bench --bench whitted` (optionally `-- <filter>`, e.g.
//! `-- --quick whitted_cpu_1thread/checker-spheres`).
//!
//! Scenes: every scene of `penumbra_assets::raytrace::shipped_scenes()`
//! (`assets/raytrace/NAME.json`, its own camera), and
//! `$PENUMBRA_DATA/scenes/CornellBox-Original.obj` (eye (0, 1, 3.5), target
//! (0, 1, 0), 40 degrees) when `PENUMBRA_DATA` is set. Each renderer (its
//! kd-tree, on a GPU its uploads) is built once per scene, outside the
//! timed renders; `WhittedSettings::default()` (max depth 5, 1 sample per
//! pixel), 512x512.
//!
//! Groups (throughput in rays of one render, all kinds, so criterion
//! reports rays/s):
//! - `whitted_cpu_1thread/<scene>/<packets|single>` and
//!   `whitted_cpu_2threads/...`: `WhittedRenderer::render` on the CPU in a
//!   rayon pool of that many threads; `packets`: MLRTA packets for primary
//!   and point lights' shadow rays (the default), `single`: every ray alone.
//! - `whitted_gpu/<scene>`: the WGSL kernel (the time of a render call:
//!   dispatch, kernels and read-back), only with a GPU adapter.
//!
//! `benches/whitted_table.rs` splits the rates by kind of ray.

mod common;

use common::raytrace::{BenchScene, load_scenes};
use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use penumbra::gpu::GpuContext;
use penumbra::gpu::device::Device;
use penumbra::progress::{Bar, Reporter};
use penumbra::whitted::{LightingSettings, Packets, RenderScene, WhittedRenderer, WhittedSettings};

/// Side of the images.
const SIZE: u32 = 512;

fn renderer(device: &Device, s: &BenchScene) -> WhittedRenderer {
    let scene = RenderScene::new(&s.scene, 0, &LightingSettings::default())
        .unwrap_or_else(|e| panic!("preparing {}: {e}", s.name));
    WhittedRenderer::new(device, scene, &Reporter::silent()).unwrap_or_else(|e| panic!("building {}: {e}", s.name))
}

fn configure(group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>) {
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
}

/// A scene's CPU renderer and the rays of one render.
struct Prepared<'a> {
    scene: &'a BenchScene,
    renderer: WhittedRenderer,
    rays: u64,
}

fn bench_cpu(c: &mut Criterion, prepared: &mut [Prepared<'_>], threads: usize) {
    let pool = common::thread_pool(threads);
    let name = if threads == 1 {
        "whitted_cpu_1thread".to_string()
    } else {
        format!("whitted_cpu_{threads}threads")
    };
    let mut group = c.benchmark_group(&name);
    configure(&mut group);
    let progress = Bar::hidden();
    for p in prepared.iter_mut() {
        group.throughput(Throughput::Elements(p.rays));
        for (mode, packets) in [("packets", Packets::On), ("single", Packets::Off)] {
            let settings = WhittedSettings {
                packets,
                ..WhittedSettings::default()
            };
            let (renderer, camera) = (&mut p.renderer, &p.scene.camera);
            group.bench_function(BenchmarkId::new(p.scene.name.as_str(), mode), |b| {
                b.iter(|| {
                    pool.install(|| renderer.render(black_box(camera), SIZE, SIZE, &settings, &progress))
                        .expect("render")
                        .pixels
                })
            });
        }
    }
    group.finish();
}

fn bench_gpu(c: &mut Criterion, scenes: &[BenchScene]) {
    let ctx = match GpuContext::headless() {
        Ok(ctx) => ctx,
        Err(e) => {
            eprintln!("whitted_gpu: skipped, no GPU adapter ({e})");
            return;
        }
    };
    eprintln!("whitted_gpu: adapter {}; {SIZE}x{SIZE}", ctx.name);
    let device = Device::gpu(ctx);
    let mut group = c.benchmark_group("whitted_gpu");
    configure(&mut group);
    let progress = Bar::hidden();
    let settings = WhittedSettings::default();
    for s in scenes {
        let mut renderer = renderer(&device, s);
        // Once untimed: pipelines compiled, and the rays counted.
        let first = match renderer.render(&s.camera, SIZE, SIZE, &settings, &progress) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("whitted_gpu/{}: skipped, the render failed ({e})", s.name);
                continue;
            }
        };
        let st = &first.stats;
        eprintln!(
            "whitted_gpu/{}: {:?} rays, {} in {:.1} ms ({:?}), {:.2} Mrays/s",
            s.name,
            st.rays,
            st.rays.total(),
            st.render_ms,
            st.timing,
            st.mrays_per_s
        );
        group.throughput(Throughput::Elements(st.rays.total()));
        group.bench_function(s.name.as_str(), |b| {
            b.iter(|| {
                renderer
                    .render(black_box(&s.camera), SIZE, SIZE, &settings, &progress)
                    .expect("GPU render")
                    .pixels
            })
        });
    }
    group.finish();
}

fn all(c: &mut Criterion) {
    let scenes = load_scenes();
    let cpu = Device::cpu();
    let progress = Bar::hidden();
    // The renderers and their ray counts (the same with and without
    // packets) once, for both CPU groups.
    let mut prepared: Vec<Prepared<'_>> = scenes
        .iter()
        .map(|s| {
            let mut renderer = renderer(&cpu, s);
            let first = renderer
                .render(&s.camera, SIZE, SIZE, &WhittedSettings::default(), &progress)
                .expect("render");
            let st = &first.stats;
            eprintln!(
                "whitted_cpu/{}: {} triangles, {} spheres, {} lights; {SIZE}x{SIZE}: {:?}, {} rays",
                s.name,
                renderer.scene().mesh.triangles.len(),
                renderer.scene().spheres.len(),
                renderer.scene().lights.len(),
                st.rays,
                st.rays.total()
            );
            Prepared {
                scene: s,
                renderer,
                rays: st.rays.total(),
            }
        })
        .collect();
    bench_cpu(c, &mut prepared, 1);
    bench_cpu(c, &mut prepared, 2);
    bench_gpu(c, &scenes);
}

criterion_group!(benches, all);
criterion_main!(benches);
