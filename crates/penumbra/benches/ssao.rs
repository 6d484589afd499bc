//! Criterion bench of one SSAO frame at 800x600, 16 spp, interleave +
//! filter, on the CPU twin and (where there is an adapter) the GPU, for
//! each estimator: stanford-bunny with `PENUMBRA_DATA`, else the shipped
//! sphere-on-plane. GPU figures include submission and readback (wall
//! clock); `penumbra ssao --json` and `ssao_table` report kernel time.

use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::gpu::GpuContext;
use penumbra::scene::{Camera, load_obj};
use penumbra::ssao::gbuffer::{ScreenView, gbuffer};
use penumbra::ssao::gpu::{GBufferSource, run_frame};
use penumbra::ssao::{Estimator, SsaoSettings, run_cpu};

fn model() -> (PathBuf, f32) {
    match std::env::var_os("PENUMBRA_DATA") {
        Some(d) => (
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../..")
                .join(d)
                .join("models/stanford-bunny.obj"),
            0.02,
        ),
        None => (
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/sphere-on-plane.obj"),
            0.5,
        ),
    }
}

fn bench(c: &mut Criterion) {
    let (path, radius) = model();
    let mesh = load_obj(&path).unwrap();
    let tree = KdTree::build(&mesh, &KdTreeSettings::default()).unwrap();
    let camera = Camera::default_for(&mesh.bounds());
    let view = ScreenView::new(&camera, 800, 600);
    let gb = gbuffer(&tree, &mesh, &camera, &[], 800, 600);
    let gpu = GpuContext::headless().ok();
    let mut group = c.benchmark_group("ssao_800x600_16spp");
    group.sample_size(10);
    for estimator in Estimator::ALL {
        let s = SsaoSettings::new(estimator, 16, radius);
        group.bench_function(format!("cpu/{}", estimator.name()), |b| {
            b.iter(|| run_cpu(&gb, &view, &s, None).unwrap())
        });
        if let Some(ctx) = &gpu {
            group.bench_function(format!("gpu/{}", estimator.name()), |b| {
                b.iter(|| run_frame(ctx, GBufferSource::Upload(&gb), &view, &s, None, 1).unwrap())
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
