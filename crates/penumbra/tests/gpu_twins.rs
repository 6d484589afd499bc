//! Every WGSL kernel against its CPU twin, with per-quantity tolerances and
//! the worst deviation printed.
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
//! * interpolate: radiance per channel within 1e-5 x the cell's largest
//!   corner value for every pixel (the same products and sums; a GPU
//!   compiler may fuse them); the bounded renderer interpolates the same
//!   pixels on either device, within the same tolerance.
//! * whitted_trees: the same ray-tree topology for >= 99.5% of rays, the
//!   same occluders, radiance within the whitted tolerance, node
//!   coordinates within 1e-3 x max(1, |x|) (errors grow down refraction chains).

mod common;

use common::{Rng, asset, data_model, gpu};
use glam::Vec3;
use penumbra::accel::Accel;
use penumbra::accel::kdtree::gpu::{GpuKdTree, TraceMode, TraceRaysBatches, trace_rays};
use penumbra::accel::kdtree::{KdTree, KdTreeParams};
use penumbra::geom::ray::Ray;
use penumbra::gpu::GpuContext;
use penumbra::progress::Bar;
use penumbra::raycast::ao_rays::{ao_rays, ao_samples};
use penumbra::raycast::gpu::{AoRaysBatches, RAYS_PER_BATCH, ray_samples_gpu};
use penumbra::raycast::points::vertex_points;
use penumbra::raycast::{AoPoint, AoSettings};
use penumbra::scene::procedural::all_scenes;
use penumbra::scene::{Camera, Mesh, load_obj};

fn compare_traces(ctx: &GpuContext, name: &str, mesh: &Mesh, rays: &[Ray]) {
    let tree = KdTree::build(mesh, &KdTreeParams::default()).unwrap();
    let gpu_tree = GpuKdTree::upload(&ctx.device, &tree).unwrap();
    let gpu = trace_rays(ctx, &gpu_tree, rays, TraceMode::ClosestCounted, f32::INFINITY).unwrap();
    let any = trace_rays(ctx, &gpu_tree, rays, TraceMode::Any, f32::INFINITY).unwrap();
    let counts = gpu.counts.unwrap();
    let (mut disagree, mut worst_t, mut count_diff, mut any_wrong) = (0usize, 0f32, 0usize, 0usize);
    let (cpu_hits, cpu_counts) = tree.trace_closest_counted(rays);
    let cpu_any = tree.trace_any(rays);
    for i in 0..rays.len() {
        let (cpu, g) = (cpu_hits[i], gpu.hits[i]);
        if cpu.is_hit() != g.is_hit() {
            disagree += 1;
        } else if cpu.is_hit() {
            worst_t = worst_t.max((g.t - cpu.t).abs() / cpu.t);
        }
        if cpu_counts[i] != counts[i] {
            count_diff += 1;
        }
        if any.hits[i].is_hit() != cpu_any[i] {
            any_wrong += 1;
        }
    }
    let n = rays.len() as f64;
    println!(
        "{name}: {} rays, hit/miss disagreements {disagree} ({:.4}%), worst relative t difference {worst_t:.3e}, \
         rays with different traversal counts {count_diff}, any-hit disagreements {any_wrong}",
        rays.len(),
        100.0 * disagree as f64 / n
    );
    assert!(disagree as f64 <= 1e-4 * n, "{name}: hit/miss disagreement above 0.01%");
    assert!(any_wrong as f64 <= 1e-4 * n, "{name}: any-hit disagreement above 0.01%");
    assert!(worst_t <= 1e-5, "{name}: t differs by {worst_t}");
    assert!(
        count_diff as f64 <= 1e-3 * n,
        "{name}: traversal differs for {count_diff} rays"
    );
}

fn random_rays(mesh: &Mesh, n: usize, seed: u64) -> Vec<Ray> {
    let b = mesh.bounds();
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let o = b.center() + (rng.vec3(-1.5, 1.5)) * b.extent();
            let target = b.min + rng.vec3(0.0, 1.0) * b.extent();
            Ray::new(o, target - o)
        })
        .collect()
}

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
    let mut rng = Rng(3);
    let mut points: Vec<AoPoint> = (0..200)
        .map(|i| AoPoint::new(rng.vec3(-1.0, 1.0), rng.vec3(-1.0, 1.0).normalize(), i * 7919))
        .collect();
    // Normals where the frame construction has special cases.
    for (k, n) in [
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        Vec3::new(0.0, 1.0, -0.0),
        Vec3::new(1e-30, 0.0, -1.0),
    ]
    .into_iter()
    .enumerate()
    {
        points.push(AoPoint::new(Vec3::ZERO, n, 1000 + k as u32));
    }
    let settings = AoSettings {
        rays_per_point: 67,
        radius: f32::INFINITY,
        seed: 99,
    };
    let gpu = ray_samples_gpu(&ctx, &points, &settings).unwrap();
    let cpu = ao_samples(&points, &settings);
    let (mut uv_diff, mut worst_dir) = (0usize, 0f32);
    for ((uv, dir), (cpu_uv, cpu_dir)) in gpu.iter().zip(&cpu) {
        if uv != cpu_uv {
            uv_diff += 1;
        }
        worst_dir = worst_dir.max(
            (Vec3::from_array(*dir) - Vec3::from_array(*cpu_dir))
                .abs()
                .max_element(),
        );
    }
    println!(
        "ao samples: {} rays, sample points differing {uv_diff}, worst direction difference {worst_dir:.3e}",
        gpu.len()
    );
    assert_eq!(uv_diff, 0, "the sequence must be bit-identical on the GPU");
    assert!(worst_dir <= 1e-5);
}

fn compare_ao(ctx: &GpuContext, name: &str, mesh: &Mesh, rays_per_point: u32) {
    let accel = Accel::new(KdTree::build(mesh, &KdTreeParams::default()).unwrap());
    let gpu_tree = GpuKdTree::upload(&ctx.device, accel.kdtree()).unwrap();
    let points = vertex_points(mesh);
    let settings = AoSettings {
        rays_per_point,
        radius: f32::INFINITY,
        seed: 1,
    };
    let cpu = ao_rays(&accel, &points, &settings, &Bar::hidden());
    let (gpu, _) = AoRaysBatches::new(ctx)
        .visibility(ctx, &gpu_tree, &points, &settings, &Bar::hidden(), RAYS_PER_BATCH)
        .unwrap();
    let total = points.len() as u64 * rays_per_point as u64;
    let differing = cpu.differing_rays(&gpu);
    let worst_ao = cpu
        .accessibility()
        .iter()
        .zip(gpu.accessibility())
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    println!(
        "{name}: {total} AO rays, {differing} differ ({:.5}%), worst per-vertex AO difference {worst_ao}",
        100.0 * differing as f64 / total as f64
    );
    assert!(
        differing as f64 <= 1e-3 * total as f64,
        "{name}: more than 0.1% of AO rays differ"
    );
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
    let tree = KdTree::build(&mesh, &KdTreeParams::default()).unwrap();
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
    let tree = KdTree::build(&mesh, &KdTreeParams::default()).unwrap();
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

fn compare_whitted(ctx: &GpuContext, name: &str, scene: &penumbra::scene::Scene, camera: &Camera) {
    use penumbra::gpu::device::Device;
    use penumbra::progress::Reporter;
    use penumbra::whitted::{LightingOptions, RenderScene, WhittedRenderer, WhittedSettings};
    let (w, h) = (160, 120);
    let render = |device: &Device, settings: &WhittedSettings| {
        let rs = RenderScene::new(scene, 0, &LightingOptions::default()).unwrap();
        let mut r = WhittedRenderer::new(device, rs, &Reporter::silent()).unwrap();
        r.render(camera, w, h, settings, &Bar::hidden()).unwrap()
    };
    for settings in [
        WhittedSettings::default(),
        WhittedSettings {
            spp: 4,
            fresnel: true,
            ..WhittedSettings::default()
        },
    ] {
        let cpu = render(&Device::cpu(), &settings);
        let gpu = render(&Device::gpu(ctx.clone()), &settings);
        let (mut worst, mut over, mut signatures) = (0f32, 0usize, 0usize);
        for (a, b) in cpu.pixels.iter().zip(&gpu.pixels) {
            let (la, lb) = (Vec3::from_array(a.radiance), Vec3::from_array(b.radiance));
            let d = ((la - lb).abs() / la.abs().max(Vec3::ONE)).max_element();
            worst = worst.max(d);
            over += (d > 1e-3) as usize;
            signatures += (a.signature != b.signature) as usize;
        }
        let n = cpu.pixels.len();
        let (rc, rg) = (cpu.stats.rays, gpu.stats.rays);
        println!(
            "whitted {name} (spp {}, fresnel {}): worst relative radiance difference {worst:.2e}, \
             {over} of {n} pixels above 1e-3, {signatures} ray-tree signatures differ; rays cpu {rc:?} gpu {rg:?}",
            settings.spp, settings.fresnel
        );
        assert!(over * 1000 <= n, "{name}: {over} pixels differ");
        assert!(signatures * 200 <= n, "{name}: {signatures} signatures differ");
        for (a, b) in [
            (rc.primary, rg.primary),
            (rc.shadow, rg.shadow),
            (rc.reflection, rg.reflection),
            (rc.refraction, rg.refraction),
        ] {
            assert!(a.abs_diff(b) * 1000 <= a.max(1), "{name}: ray counts {rc:?} and {rg:?}");
        }
    }
}

#[test]
fn whitted_kernel_equals_cpu_on_every_shipped_scene_and_the_cornell_box() {
    let Some(ctx) = gpu() else { return };
    for s in penumbra::whitted::scenes::shipped_scenes() {
        let scene = penumbra::scene::load_scene_shaded(&asset("raytrace").join(s.scene_file())).unwrap();
        compare_whitted(&ctx, s.name, &scene, &scene.camera.unwrap());
    }
    if let Some(path) = common::data_scene("CornellBox-Original.obj") {
        let obj = penumbra::scene::load_obj_file(&path).unwrap();
        let scene = penumbra::scene::Scene::from_obj_file("cornell", &path, obj);
        let camera = Camera {
            eye: Vec3::new(0.0, 1.0, 3.5),
            target: Vec3::new(0.0, 1.0, 0.0),
            fov_degrees: 40.0,
        };
        compare_whitted(&ctx, "CornellBox-Original", &scene, &camera);
    }
}

#[test]
fn interpolate_kernel_equals_cpu_twin_across_batches() {
    use penumbra::bounded::gpu::{InterpolatePass, JOBS_PER_BATCH};
    use penumbra::bounded::interpolate::{PixelJob, interpolate_pixels};
    use penumbra::gpu::batch::Batched;
    let Some(ctx) = gpu() else { return };
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let cells = 500;
    // Radiances over six decades, as a scene's are.
    let corners: Vec<[f32; 4]> = (0..cells * 16)
        .map(|_| {
            let scale = 10f32.powf(rng.f32() * 6.0 - 4.0);
            [rng.f32() * scale, rng.f32() * scale, rng.f32() * scale, 0.0]
        })
        .collect();
    // Every third job textured: its slot's radiance plus a texture factor
    // times the next slot's (a textured cell's two tables).
    let jobs: Vec<PixelJob> = (0..JOBS_PER_BATCH + 12_345)
        .map(|i| PixelJob {
            slot: (rng.f32() * (cells - 1) as f32) as u32 % (cells - 1) as u32,
            pixel: i as u32,
            textured: (i % 3 == 0) as u32,
            local: [rng.f32(), rng.f32(), rng.f32(), rng.f32()],
            texture: [rng.f32(), rng.f32(), rng.f32(), 0.0],
            ..Default::default()
        })
        .collect();
    let cpu = interpolate_pixels(&corners, &jobs);
    let mut pass = Batched::<InterpolatePass>::new(&ctx);
    let (gpu_out, _) = pass.interpolate(&ctx, &corners, &jobs).unwrap();
    assert_eq!(gpu_out.len(), cpu.len());
    let mut worst = 0f32;
    for ((a, b), job) in cpu.iter().zip(&gpu_out).zip(&jobs) {
        let base = job.slot as usize * 16;
        let scale = corners[base..base + 32]
            .iter()
            .flat_map(|c| c[..3].iter().copied())
            .fold(0f32, f32::max);
        for c in 0..3 {
            worst = worst.max((a[c] - b[c]).abs() / scale);
        }
    }
    println!(
        "interpolate: {} pixels in 2 batches, worst difference {worst:.2e} of the cell's largest corner",
        jobs.len()
    );
    assert!(worst <= 1e-5, "worst {worst}");
}

#[test]
fn whitted_listed_kernel_renders_the_image_pixels_it_is_given() {
    use penumbra::gpu::device::Device;
    use penumbra::progress::Reporter;
    use penumbra::whitted::gpu::PIXELS_PER_BATCH;
    use penumbra::whitted::{LightingOptions, Packets, RenderScene, WhittedRenderer, WhittedSettings};
    let scene = penumbra::scene::load_scene_shaded(&asset("raytrace").join("cornell-mirror-glass.json")).unwrap();
    let camera = scene.camera.unwrap();
    let (w, h) = (320, 240);
    // Every pixel once, scrambled, then some twice: more than one batch.
    let n = w * h;
    let mut list: Vec<u32> = (0..n).map(|i| (i * 7_919) % n).collect();
    list.extend((0..n).step_by(13));
    assert!(list.len() > PIXELS_PER_BATCH);
    let settings = WhittedSettings {
        packets: Packets::Off,
        ..WhittedSettings::default()
    };
    let compare = |device: &Device| {
        let rs = RenderScene::new(&scene, 0, &LightingOptions::default()).unwrap();
        let mut r = WhittedRenderer::new(device, rs, &Reporter::silent()).unwrap();
        let image = r.render(&camera, w, h, &settings, &Bar::hidden()).unwrap();
        let params = r.params(&camera, w, h, &settings).unwrap();
        let listed = r.render_listed(&params, &list, &Bar::hidden()).unwrap().value;
        assert_eq!(listed.len(), list.len());
        let differ = list
            .iter()
            .zip(&listed)
            .filter(|&(&i, p)| bytemuck::bytes_of(p) != bytemuck::bytes_of(&image.pixels[i as usize]))
            .count();
        println!(
            "whitted_listed on {}: {} listed pixels, {differ} differ from the image's",
            image.stats.path,
            list.len()
        );
        assert_eq!(differ, 0);
        // Outside the image: an error, not a read out of bounds.
        assert!(r.render_listed(&params, &[n], &Bar::hidden()).is_err());
    };
    compare(&Device::cpu());
    if let Some(ctx) = gpu() {
        compare(&Device::gpu(ctx));
    }
}

#[test]
fn bounded_renderer_interpolates_alike_on_gpu_and_cpu() {
    use penumbra::bounded::{BoundedRenderer, BoundedSettings, PixelPath, SlowPath};
    use penumbra::gpu::device::Device;
    use penumbra::progress::Reporter;
    use penumbra::whitted::{LightingOptions, RenderScene, WhittedRenderer};
    let Some(ctx) = gpu() else { return };
    let scene = penumbra::scene::load_scene_shaded(&asset("raytrace").join("checker-spheres.json")).unwrap();
    let camera = scene.camera.unwrap();
    let render = |device: &Device| {
        let rs = RenderScene::new(&scene, 0, &LightingOptions::default()).unwrap();
        let w = WhittedRenderer::new(device, rs, &Reporter::silent()).unwrap();
        // `auto` keeps the slow path on the CPU on a software adapter.
        let auto = BoundedRenderer::new(w, BoundedSettings::default()).unwrap();
        let software = auto.whitted.context().is_some_and(|c| c.is_software());
        assert_eq!(auto.slow_path_on_gpu(), device.is_gpu() && !software);
        let settings = BoundedSettings {
            slow_path: SlowPath::Device,
            ..BoundedSettings::default()
        };
        let mut b = BoundedRenderer::new(auto.whitted, settings).unwrap();
        assert_eq!(b.slow_path_on_gpu(), device.is_gpu());
        // The second frame reprojects the first's cells.
        let frames = [
            b.render(&camera, 320, 240).unwrap(),
            b.render(&camera, 320, 240).unwrap(),
        ];
        // The extremal rays go through `whitted_trees` on the GPU too.
        for f in &frames {
            let on_gpu = if device.is_gpu() {
                f.stats.extremal_rays_traced
            } else {
                0
            };
            assert_eq!(f.stats.extremal_rays_on_gpu, on_gpu);
        }
        assert!(frames[0].stats.extremal_rays_traced > 0);
        let settings = BoundedSettings::default().whitted;
        let exact = b.whitted.render(&camera, 320, 240, &settings, &Bar::hidden()).unwrap();
        (frames, exact.radiance())
    };
    let ((cpu, _), (gpu_frames, gpu_exact)) = (render(&Device::cpu()), render(&Device::gpu(ctx)));
    let (mut worst, mut interpolated) = (0f32, 0);
    let (mut traced, mut traced_off, mut traced_worst) = (0, 0, 0f32);
    for (cpu, gpu_frame) in cpu.iter().zip(&gpu_frames) {
        assert_eq!(cpu.paths, gpu_frame.paths);
        for (i, ((a, b), path)) in cpu.radiance.iter().zip(&gpu_frame.radiance).zip(&cpu.paths).enumerate() {
            let d = ((*a - *b).abs() / a.abs().max(Vec3::splat(1e-3))).max_element();
            match path {
                PixelPath::Interpolated | PixelPath::Reprojected => {
                    interpolated += 1;
                    worst = worst.max(d);
                }
                // The slow path on a GPU is the Whitted kernel: its pixels
                // are the GPU's exact image's, bit for bit, and the CPU's
                // within the Whitted kernel's tolerance.
                PixelPath::Traced(_) => {
                    traced += 1;
                    assert_eq!(*b, gpu_exact[i], "traced pixel {i}");
                    traced_worst = traced_worst.max(d);
                    traced_off += (((*a - *b).abs() / a.abs().max(Vec3::ONE)).max_element() > 1e-3) as usize;
                }
                _ => {}
            }
        }
    }
    println!(
        "bounded: {interpolated} interpolated pixels, worst relative difference GPU-CPU {worst:.2e}; \
         {traced} traced pixels (the GPU's identical to its Whitted image), worst GPU-CPU {traced_worst:.2e}, \
         {traced_off} above 1e-3"
    );
    assert!(interpolated > 500, "only {interpolated} pixels interpolated");
    assert!(worst <= 1e-5, "worst {worst}");
    assert!(traced > 500, "only {traced} pixels traced");
    assert!(
        traced_off * 1000 <= traced,
        "{traced_off} of {traced} traced pixels differ"
    );
}

/// `whitted_trees` against its twin (`Whitted::trace_tree`, the bounded
/// renderer's extremal rays on the CPU): rays from a sphere around each
/// shipped scene into its box, each from the root hit the CPU finds. The
/// same topology (objects, faces, surfaces, light codes, children) for
/// at least 99.5% of the rays and the same occluders; where it is the
/// same, radiance and the root's diffuse terms per channel within 1e-3 x
/// max(1, abs(L)) (the Whitted kernel's tolerance), and every node's origin,
/// direction, weight, t and point within 1e-3 x max(1, |x|) (as radiance:
/// rounding differences grow down chains of refractions).
#[test]
fn whitted_trees_kernel_records_the_twins_ray_trees() {
    use penumbra::gpu::device::Device;
    use penumbra::progress::Reporter;
    use penumbra::whitted::ray_tree::RayTree;
    use penumbra::whitted::scene::MISS;
    use penumbra::whitted::tree_records::TreeRay;
    use penumbra::whitted::{LightingOptions, RenderScene, WhittedRenderer, WhittedSettings};
    let Some(ctx) = gpu() else { return };
    let close = |a: Vec3, b: Vec3, tol: f32| ((a - b).abs() / a.abs().max(Vec3::ONE)).max_element() <= tol;
    for name in [
        "checker-spheres",
        "checker-spheres-tessellated",
        "cornell-mirror-glass",
        "tir-block",
        "grazing",
    ] {
        let scene = penumbra::scene::load_scene_shaded(&asset("raytrace").join(format!("{name}.json"))).unwrap();
        let camera = scene.camera.unwrap();
        let rs = RenderScene::new(&scene, 0, &LightingOptions::default()).unwrap();
        let mut r = WhittedRenderer::new(&Device::gpu(ctx.clone()), rs, &Reporter::silent()).unwrap();
        let params = r.params(&camera, 64, 64, &WhittedSettings::default()).unwrap();
        let (lo, hi) = (r.bounds().min, r.bounds().max);
        let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).length());
        let mut rng = Rng(0x7ee5);
        let twin = r.twin(&params);
        let rays: Vec<TreeRay> = (0..4000)
            .map(|_| {
                let u = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
                let o = centre + radius * u.normalize_or(Vec3::Y);
                // Half into the whole box, half into its middle fifth, where
                // the balls and blocks are: deeper trees.
                let spread = if rng.f32() < 0.5 { 1.0 } else { 0.2 };
                let u = Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5;
                let target = centre + (hi - lo) * spread * u;
                let d = (target - o).normalize();
                let (t, primitive) = twin.closest(o, d, f32::INFINITY, None).unwrap_or((0.0, MISS));
                TreeRay {
                    origin: o.to_array(),
                    root_t: t,
                    dir: d.to_array(),
                    root_primitive: primitive,
                }
            })
            .collect();
        let cpu: Vec<_> = rays.iter().map(|ray| twin.trace_tree(ray)).collect();
        let gpu = r.trace_trees(&params, &rays).unwrap().expect("a GPU renderer");
        assert_eq!(gpu.len(), rays.len());
        let (mut topology, mut overflow, mut nodes, mut worst_l, mut worst_x) = (0, 0, 0, 0f32, 0f32);
        let deepest = cpu.iter().map(|(_, t)| t.nodes.len()).max().unwrap_or(0);
        for ((out, tree), g) in cpu.iter().zip(&gpu) {
            let Some(g) = g else {
                overflow += 1;
                continue;
            };
            let (radiance, diffuse, g) = (&g.radiance, &g.diffuse, &g.tree);
            if !tree.same_topology(g) {
                topology += 1;
                continue;
            }
            let occluders = |t: &RayTree| t.nodes.iter().map(|n| n.occluders.clone()).collect::<Vec<_>>();
            assert_eq!(occluders(tree), occluders(g), "{name}: occluders");
            for (l, gl) in [(out.radiance, *radiance), (out.diffuse, *diffuse)] {
                let d = ((l - gl).abs() / l.abs().max(Vec3::ONE)).max_element();
                worst_l = worst_l.max(d);
            }
            for (a, b) in tree.nodes.iter().zip(&g.nodes) {
                nodes += 1;
                let mut pairs = vec![(a.origin, b.origin), (a.dir, b.dir), (a.weight, b.weight)];
                if let (Some(ha), Some(hb)) = (a.hit, b.hit) {
                    pairs.push((ha.point, hb.point));
                    pairs.push((Vec3::splat(ha.t), Vec3::splat(hb.t)));
                }
                for (x, y) in pairs {
                    worst_x = worst_x.max(((x - y).abs() / x.abs().max(Vec3::ONE)).max_element());
                    assert!(close(x, y, 1e-3) || x.is_nan(), "{name}: {x} against {y}");
                }
            }
        }
        println!(
            "whitted_trees on {name}: {} rays, {nodes} nodes compared, {topology} differ in topology, {overflow} \
             overflowed, largest tree {deepest} nodes; worst relative radiance difference {worst_l:.2e}, worst node \
             coordinate {worst_x:.2e}",
            rays.len()
        );
        assert_eq!(overflow, 0, "{name}");
        assert!(topology * 200 <= rays.len(), "{name}: {topology} trees differ");
        assert!(worst_l <= 1e-3, "{name}: radiance differs by {worst_l}");
    }
}
