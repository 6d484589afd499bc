//! Criterion benchmarks of displacement fields: building a field (kd-tree
//! rays from the bounding sphere), and AO of the corner's 3267 vertices (256
//! rays each) through the field on the CPU and the GPU, against ray casting
//! the same rays.
//!
//! `cargo bench --bench field` (needs `PENUMBRA_DATA` for the models; without
//! it the procedural cube-with-hole stands in).
//!
//! Groups:
//! - `field_build/<model>`: 1089 maps of 32x32, 8-bit (all cores).
//! - `field_ao_cpu/<model>` and `raycast_ao_cpu/<model>`: the corner's AO,
//!   caster scaled into the corner, all cores.
//! - `field_ao_gpu/<model>`: the `field_ao` kernel (wall time, blocking),
//!   only with an adapter.

mod common;

use std::hint::black_box;
use std::time::Duration;

use common::{Model, load_models_named};
use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use glam::{Quat, Vec3};
use penumbra::accel::Accel;
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::field::gpu::{FieldAoBatches, FieldGroup, GpuField, GpuInstance};
use penumbra::field::{
    DirectionMapping, DisplacementField, FieldCaster, FieldSampling, NO_OWNER, OctahedralGrid, Positional, Storage,
    field_ao,
};
use penumbra::gpu::GpuContext;
use penumbra::progress::Bar;
use penumbra::raycast::ao_rays::ao_rays;
use penumbra::raycast::points::vertex_points;
use penumbra::raycast::{AoPoint, AoSettings};
use penumbra::scene::Transform;
use penumbra::scene::procedural::corner;

const SETTINGS: AoSettings = AoSettings {
    rays_per_point: 256,
    radius: f32::INFINITY,
    seed: 0,
};

fn params(side: u32) -> FieldSampling {
    FieldSampling {
        grid: OctahedralGrid { side },
        res: 32,
        storage: Storage::U8,
        directions: DirectionMapping::Concentric,
    }
}

/// The model scaled to 0.45 and set on the corner's floor.
fn placement(m: &Model) -> Transform {
    let b = m.mesh.bounds();
    let scale = 0.45 / (b.max - b.min).max_element();
    let c = b.center();
    Transform {
        translation: Vec3::new(0.35, 0.004, 0.35) - Vec3::new(c.x, b.min.y, c.z) * scale,
        rotation: Quat::IDENTITY,
        scale,
    }
}

fn configure(group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>) {
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
}

fn all(c: &mut Criterion) {
    let models = load_models_named(&["stanford-bunny", "cow", "dragon100k"]);
    let points: Vec<AoPoint> = vertex_points(&corner());
    let owners = vec![NO_OWNER; points.len()];
    let rays = (points.len() as u64) * SETTINGS.rays_per_point as u64;

    let mut build = c.benchmark_group("field_build");
    configure(&mut build);
    for m in &models {
        build.throughput(Throughput::Elements(params(33).maps() as u64 * 1024));
        build.bench_function(m.name.as_str(), |b| {
            b.iter(|| DisplacementField::build(black_box(&m.mesh), &params(33), "model", &Bar::hidden()).unwrap())
        });
    }
    build.finish();

    let fields: Vec<DisplacementField> = models
        .iter()
        .map(|m| {
            DisplacementField::build(&m.mesh, &params(65), "model", &Bar::hidden())
                .unwrap()
                .0
        })
        .collect();
    let mut cpu = c.benchmark_group("field_ao_cpu");
    configure(&mut cpu);
    cpu.throughput(Throughput::Elements(rays));
    for (m, field) in models.iter().zip(&fields) {
        let casters = [FieldCaster {
            field,
            transform: placement(m),
            instance: 0,
        }];
        cpu.bench_function(m.name.as_str(), |b| {
            b.iter(|| {
                field_ao(
                    &casters,
                    black_box(&points),
                    &owners,
                    &SETTINGS,
                    Positional::Bilinear,
                    &Bar::hidden(),
                )
            })
        });
    }
    cpu.finish();

    let mut raycast = c.benchmark_group("raycast_ao_cpu");
    configure(&mut raycast);
    raycast.throughput(Throughput::Elements(rays));
    for m in &models {
        let t = placement(m);
        let tree =
            Accel::new(KdTree::build(&m.mesh.map_positions(|p| t.apply_point(p)), &KdTreeSettings::default()).unwrap());
        raycast.bench_function(m.name.as_str(), |b| {
            b.iter(|| ao_rays(&tree, black_box(&points), &SETTINGS, &Bar::hidden()))
        });
    }
    raycast.finish();

    let Ok(ctx) = GpuContext::headless() else {
        eprintln!("field_ao_gpu: skipped, no GPU adapter");
        return;
    };
    let mut gpu = c.benchmark_group("field_ao_gpu");
    configure(&mut gpu);
    gpu.throughput(Throughput::Elements(rays));
    for (m, field) in models.iter().zip(&fields) {
        let g = GpuField::upload(&ctx.device, &ctx.queue, field, Positional::Bilinear).unwrap();
        let groups = [FieldGroup {
            field: &g,
            instances: vec![GpuInstance::new(&placement(m), 0)],
        }];
        let mut batches = FieldAoBatches::new(&ctx);
        gpu.bench_function(m.name.as_str(), |b| {
            b.iter(|| {
                batches
                    .visibility(&ctx, &groups, black_box(&points), &owners, &SETTINGS, &Bar::hidden())
                    .unwrap()
            })
        });
    }
    gpu.finish();
}

criterion_group!(benches, all);
criterion_main!(benches);
