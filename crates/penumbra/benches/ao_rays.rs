//! Criterion benchmarks of the CPU's AO rays (the reference AO, and the
//! ground truth of fields, SSAO and PRT checks): 256 cosine rays per vertex
//! of the cow and the bunny, one thread, one ray at a time against the
//! shared-origin packets in each instruction set this CPU has, through the
//! kd-tree and through its wide BVH (built before the clock).
//!
//! `cargo bench --bench ao_rays` (optionally `-- <filter>`, e.g. `-- Avx512`).
//! Without `PENUMBRA_DATA` the procedural scenes stand in (their numbers
//! are not comparable with the real models').
//!
//! Group `ao_rays_1thread/<model>/<casting>`: throughput in rays, so
//! criterion reports rays/s ("elem/s"); the directions are generated inside
//! the timed loop, as `penumbra ao` does.

mod common;

use std::hint::black_box;
use std::time::Duration;

use common::load_models_named;
use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use penumbra::accel::Structure;
use penumbra::geom::simd::Isa;
use penumbra::progress::Bar;
use penumbra::raycast::AoSettings;
use penumbra::raycast::ao_rays::{Casting, ao_rays_by};
use penumbra::raycast::points::vertex_points;

const SETTINGS: AoSettings = AoSettings {
    rays_per_point: 256,
    radius: f32::INFINITY,
    seed: 24301,
};

fn all(c: &mut Criterion) {
    let models = load_models_named(&["cow", "stanford-bunny"]);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let mut group = c.benchmark_group("ao_rays_1thread");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    for m in &models {
        m.accel.bvh();
        let castings = std::iter::once(Casting::Single)
            .chain(
                Isa::available()
                    .into_iter()
                    .map(|isa| Casting::Packets(Structure::Kdtree, isa)),
            )
            .chain(
                Isa::available()
                    .into_iter()
                    .map(|isa| Casting::Packets(Structure::Bvh, isa)),
            );
        let castings: Vec<Casting> = castings.collect();
        let points = vertex_points(&m.mesh);
        let rays = points.iter().filter(|p| p.has_hemisphere()).count() as u64 * SETTINGS.rays_per_point as u64;
        group.throughput(Throughput::Elements(rays));
        for &casting in &castings {
            let id = match casting {
                Casting::Single => "single-ray".to_string(),
                Casting::Packets(Structure::Kdtree, isa) => format!("packets-{isa:?}"),
                Casting::Packets(Structure::Bvh, isa) => format!("bvh-packets-{isa:?}"),
            };
            group.bench_function(BenchmarkId::new(m.name.as_str(), id), |b| {
                b.iter(|| pool.install(|| ao_rays_by(&m.accel, black_box(&points), &SETTINGS, &Bar::hidden(), casting)))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, all);
criterion_main!(benches);
