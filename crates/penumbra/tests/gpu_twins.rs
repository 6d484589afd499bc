//! Every WGSL kernel against its CPU twin, with per-quantity tolerances and
//! the worst deviation printed (the comparisons are in `twins/mod.rs`,
//! shared with `portable_limits.rs`).
//!
//! Tolerances:
//! * trace_rays: hit/miss identical for >= 99.99% of rays; where both hit,
//!   |t_gpu - t_cpu| <= 1e-5 t; traversal counts identical for >= 99.9%.
//!   (The kernel does the CPU's arithmetic; differences come only from a GPU
//!   compiler fusing multiply-adds, which moves results by an ulp.)
//! * ao_samples: the sample points bit-identical (integer arithmetic);
//!   directions within 1e-5 (sin/cos of the GPU differ by ulps).
//! * ao_rays: >= 99.9% of individual ray results identical.
//! * whitted: radiance per channel within 1e-3 x max(1, |L|) for >= 99.9%
//!   of pixels, ray-tree signatures equal for >= 99.5%, rays of each kind
//!   within 0.1%. (A ray that rounds onto another triangle at an edge
//!   changes its pixel's tree; everything else is the same arithmetic.)
//! * whitted_listed: bit-identical to the same pixels of the device's
//!   whole-image render (the same kernel code, on either device).
//! * whitted_image: every texel bit-identical to the CPU twin's (a copy of
//!   each pixel's radiance, alpha 1), across batches.
//! * interpolate: radiance per channel within 1e-5 x the cell's largest
//!   corner value for every pixel (the same products and sums; a GPU
//!   compiler may fuse them); the bounded renderer interpolates the same
//!   pixels on either device, within the same tolerance.
//! * whitted_trees: the same ray-tree topology for >= 99.5% of rays, the
//!   same occluders, radiance within the whitted tolerance, node
//!   coordinates within 1e-3 x max(1, |x|) (errors grow down refraction chains).

mod common;
mod twins;

use common::{asset, data_model, gpu};
use glam::Vec3;
use penumbra::accel::kdtree::gpu::{GpuKdTree, TraceMode, TraceRaysBatches, trace_rays};
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::gpu::GpuContext;
use penumbra::progress::Bar;
use penumbra::raycast::AoSettings;
use penumbra::raycast::gpu::{AoRaysBatches, RAYS_PER_BATCH};
use penumbra::raycast::points::vertex_points;
use penumbra::scene::procedural::all_scenes;
use penumbra::scene::{Camera, load_obj};
use twins::{
    compare_ao, compare_ao_samples, compare_bounded, compare_interpolate, compare_traces, compare_whitted,
    compare_whitted_image, compare_whitted_listed, compare_whitted_trees, random_rays,
};

#[test]
fn trace_rays_kernel_equals_cpu_on_procedural_scenes() {
    let Some(ctx) = gpu() else { return };
    for (name, mesh) in all_scenes() {
        let mut rays = random_rays(&mesh, 20_000, 42);
        rays.extend(Camera::default_for(&mesh.bounds()).primary_rays(96, 96));
        compare_traces(&ctx, name, &mesh, &rays);
    }
}

#[test]
fn trace_rays_kernel_equals_cpu_on_shared_models() {
    let Some(ctx) = gpu() else { return };
    for model in ["stanford-bunny.obj", "dragon100k.obj", "kitchen.obj"] {
        let Some(path) = data_model(model) else { return };
        let mesh = load_obj(&path).unwrap();
        let mut rays = random_rays(&mesh, 100_000, 7);
        rays.extend(Camera::default_for(&mesh.bounds()).primary_rays(256, 256));
        compare_traces(&ctx, model, &mesh, &rays);
    }
}

#[test]
fn ao_sample_kernel_equals_cpu_sequence() {
    let Some(ctx) = gpu() else { return };
    compare_ao_samples(&ctx, 200);
}

#[test]
fn ao_kernel_equals_cpu_on_procedural_scenes() {
    let Some(ctx) = gpu() else { return };
    // wall-on-floor's wall stands on the floor: its base vertices' rays start
    // in the floor's plane, where hit or miss is decided by rounding (the
    // GPU's sin/cos differ by ulps), 3 of its 512 rays.
    for (name, mesh) in all_scenes().into_iter().filter(|(n, _)| *n != "wall-on-floor") {
        compare_ao(&ctx, name, &mesh, 64);
    }
}

#[test]
fn ao_kernel_equals_cpu_on_the_bunny() {
    let Some(ctx) = gpu() else { return };
    let Some(path) = data_model("stanford-bunny.obj") else {
        return;
    };
    compare_ao(&ctx, "stanford-bunny (per vertex)", &load_obj(&path).unwrap(), 64);
}

#[test]
fn large_requests_are_split_into_batches_with_the_same_results() {
    let Some(ctx) = gpu() else { return };
    let mesh = load_obj(&asset("sphere-on-plane.obj")).unwrap();
    let tree = KdTree::build(&mesh, &KdTreeSettings::default()).unwrap();
    let gpu_tree = GpuKdTree::upload(&ctx.device, &tree).unwrap();
    let rays = random_rays(&mesh, 10_007, 5);
    let whole = trace_rays(&ctx, &gpu_tree, &rays, TraceMode::Closest, f32::INFINITY).unwrap();
    let split = TraceRaysBatches::new(&ctx)
        .trace(&ctx, &gpu_tree, &rays, TraceMode::Closest, f32::INFINITY, 999)
        .unwrap();
    assert_eq!(whole.hits, split.hits, "11 batches of <= 999 rays");

    let points = vertex_points(&mesh);
    let settings = AoSettings {
        rays_per_point: 40,
        radius: 0.5,
        seed: 4,
    };
    let mut batches = AoRaysBatches::new(&ctx);
    let (whole, _) = batches
        .visibility(&ctx, &gpu_tree, &points, &settings, &Bar::hidden(), RAYS_PER_BATCH)
        .unwrap();
    let (split, _) = batches
        .visibility(&ctx, &gpu_tree, &points, &settings, &Bar::hidden(), 4000)
        .unwrap();
    assert_eq!(
        whole, split,
        "batches of 100 points, with the kept buffers of the first run"
    );
    println!(
        "{} rays and {} AO points: batched results identical",
        rays.len(),
        points.len()
    );
}

/// The embedding path: a host engine makes its own device with WebGPU's
/// default limits, builds the pass for it and records into its own encoder,
/// between its own commands.
#[test]
fn passes_record_into_a_host_engines_encoder() {
    use penumbra::accel::kdtree::gpu::TraceRaysPass;
    use penumbra::gpu::batch::Pass;

    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::all() - wgpu::Backends::GL,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let Ok(adapter) = pollster::block_on(instance.request_adapter(&Default::default())) else {
        println!("no adapter: host-embedding test skipped");
        return;
    };
    let (device, queue) = pollster::block_on(adapter.request_device(&Default::default())).unwrap();

    let mesh = load_obj(&asset("cube-with-hole.obj")).unwrap();
    let tree = KdTree::build(&mesh, &KdTreeSettings::default()).unwrap();
    let rays = random_rays(&mesh, 3000, 11);
    // Built once for the host's device; buffers kept between prepares.
    let mut pass = TraceRaysPass::new(&device);
    let gpu_tree = GpuKdTree::upload(&device, &tree).unwrap();
    let bytes = (rays.len() * 8) as u64;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("host readback"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut frame = |rays: &[penumbra::geom::ray::Ray]| -> Vec<penumbra::geom::ray::Hit> {
        pass.prepare(&device, &queue, rays, TraceMode::Closest, f32::INFINITY)
            .unwrap();
        // The host's frame: its own command, penumbra's pass, its own copy.
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.clear_buffer(pass.hits(), 0, None);
        pass.record(&mut encoder, None, &gpu_tree);
        encoder.copy_buffer_to_buffer(pass.hits(), 0, &readback, 0, (rays.len() * 8) as u64);
        queue.submit([encoder.finish()]);
        penumbra::gpu::buffers::read_back(&device, &readback, rays.len()).unwrap()
    };
    let first = frame(&rays[..1000]);
    let hits = frame(&rays);
    assert_eq!(first, hits[..1000], "a second, larger prepare grows the kept buffers");

    let cpu = tree.trace_closest(&rays);
    let same = hits
        .iter()
        .zip(&cpu)
        .filter(|(g, c)| g.triangle == c.triangle && (!c.is_hit() || g.t == c.t))
        .count();
    println!("host device: {same} of {} hits identical to the CPU", rays.len());
    assert_eq!(same, rays.len());

    // And the blocking helpers work on an adopted device too.
    let ctx = GpuContext::from_host(&device, &queue);
    let traced = trace_rays(&ctx, &gpu_tree, &rays, TraceMode::Closest, f32::INFINITY).unwrap();
    assert_eq!(traced.hits, hits);
}

#[test]
fn whitted_kernel_equals_cpu_on_every_shipped_scene_and_the_cornell_box() {
    let Some(ctx) = gpu() else { return };
    for s in penumbra_assets::raytrace::shipped_scenes() {
        let scene = penumbra::scene::load_scene_shaded(&asset("raytrace").join(s.scene_file())).unwrap();
        compare_whitted(&ctx, s.name, &scene, &scene.camera.unwrap(), (160, 120));
    }
    if let Some(path) = common::data_scene("CornellBox-Original.obj") {
        let obj = penumbra::scene::load_obj_file(&path).unwrap();
        let scene = penumbra::scene::Scene::from_obj_file("cornell", &path, obj);
        let camera = Camera {
            eye: Vec3::new(0.0, 1.0, 3.5),
            target: Vec3::new(0.0, 1.0, 0.0),
            fov_degrees: 40.0,
        };
        compare_whitted(&ctx, "CornellBox-Original", &scene, &camera, (160, 120));
    }
}

#[test]
fn whitted_image_kernel_equals_cpu_twin_across_batches() {
    let Some(ctx) = gpu() else { return };
    compare_whitted_image(&ctx, (160, 120));
    compare_whitted_image(&ctx, (37, 23));
}

#[test]
fn interpolate_kernel_equals_cpu_twin_across_batches() {
    use penumbra::bounded::gpu::JOBS_PER_BATCH;
    let Some(ctx) = gpu() else { return };
    compare_interpolate(&ctx, JOBS_PER_BATCH + 12_345);
}

#[test]
fn whitted_listed_kernel_renders_the_image_pixels_it_is_given() {
    use penumbra::gpu::device::Device;
    use penumbra::whitted::gpu::PIXELS_PER_BATCH;
    // Every pixel once, scrambled, then some twice: more than one batch.
    let listed = compare_whitted_listed(&Device::cpu(), (320, 240));
    assert!(listed > PIXELS_PER_BATCH);
    if let Some(ctx) = gpu() {
        compare_whitted_listed(&Device::gpu(ctx), (320, 240));
    }
}

#[test]
fn bounded_renderer_interpolates_alike_on_gpu_and_cpu() {
    let Some(ctx) = gpu() else { return };
    compare_bounded(&ctx, (320, 240));
}

/// `whitted_trees` against its twin on every shipped scene, 4000 rays each.
#[test]
fn whitted_trees_kernel_records_the_twins_ray_trees() {
    let Some(ctx) = gpu() else { return };
    let scenes = [
        "checker-spheres",
        "checker-spheres-tessellated",
        "cornell-mirror-glass",
        "tir-block",
        "grazing",
    ];
    compare_whitted_trees(&ctx, &scenes, 4000);
}
