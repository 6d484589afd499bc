//! Every GPU kernel against its CPU twin on a given device, each with its
//! per-quantity tolerance (in its doc) and printing its worst deviation.
//! The twin tests (`gpu_twins.rs`, `field.rs`, `ssao.rs`, `prt.rs`,
//! `mlrta.rs`) run them on the default device, which has the adapter's own
//! limits; `portable_limits.rs` runs them all, on small inputs, on a device
//! with WebGPU's portable limits.
#![allow(dead_code)]

use crate::common::{Rng, asset};
use glam::{Quat, Vec3};
use penumbra::accel::Accel;
use penumbra::accel::kdtree::gpu::{GpuKdTree, TraceMode, trace_rays};
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::field::gpu::{FieldAoBatches, FieldGroup, GpuField, GpuInstance, probe_gpu};
use penumbra::field::{
    DirectionMapping, DisplacementField, FieldCaster, FieldSampling, NO_OWNER, OctahedralGrid, Positional, Storage,
    field_ao, field_probe,
};
use penumbra::geom::ray::{Hit, Ray};
use penumbra::gpu::GpuContext;
use penumbra::gpu::device::Device;
use penumbra::mlrta::tiles::DEFAULT_MIN_TILE;
use penumbra::mlrta::{MlrtaSettings, Prepared, trace_image};
use penumbra::progress::Bar;
use penumbra::prt::gpu::{FrameInputs, GpuFrame, GpuTransfer};
use penumbra::prt::pipeline::{FrameOutput, Prt, PrtSettings};
use penumbra::prt::transfer::{Brdf, Integration};
use penumbra::raycast::ao_rays::{ao_rays, ao_samples};
use penumbra::raycast::gpu::{AoRaysBatches, RAYS_PER_BATCH, ray_samples_gpu};
use penumbra::raycast::points::vertex_points;
use penumbra::raycast::{AoPoint, AoSettings};
use penumbra::scene::animated::{AnimatedScene, Animation};
use penumbra::scene::procedural::corner;
use penumbra::scene::{Camera, Mesh, Transform, load_obj};
use penumbra::sh::coefficient_count;
use penumbra::ssao::gbuffer::{GBuffer, ScreenView, gbuffer};
use penumbra::ssao::gpu::{GBufferSource, run_frame};
use penumbra::ssao::{Estimator, Resolution, ShadeSettings, SsaoSettings, run_cpu};

// Ray casting and ray tracing.

/// trace_rays against `KdTree::trace_closest_counted` and `trace_any`:
/// hit/miss identical for >= 99.99% of rays; where both hit,
/// |t_gpu - t_cpu| <= 1e-5 t; traversal counts identical for >= 99.9%.
/// (The kernel does the CPU's arithmetic; differences come only from a GPU
/// compiler fusing multiply-adds, which moves results by an ulp.)
pub fn compare_traces(ctx: &GpuContext, name: &str, mesh: &Mesh, rays: &[Ray]) {
    let tree = KdTree::build(mesh, &KdTreeSettings::default()).unwrap();
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

/// `n` rays from a box three times the mesh's around it, aimed into it.
pub fn random_rays(mesh: &Mesh, n: usize, seed: u64) -> Vec<Ray> {
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

/// ao_samples against `ao_samples`: the sample points bit-identical
/// (integer arithmetic); directions within 1e-5 (sin/cos of the GPU differ
/// by ulps). `points` random points and five normals where the frame
/// construction has special cases.
pub fn compare_ao_samples(ctx: &GpuContext, points: usize) {
    let mut rng = Rng(3);
    let mut points: Vec<AoPoint> = (0..points as u32)
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
    let gpu = ray_samples_gpu(ctx, &points, &settings).unwrap();
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

/// ao_rays against `ao_rays`, the mesh's vertices as points: >= 99.9% of
/// individual ray results identical.
pub fn compare_ao(ctx: &GpuContext, name: &str, mesh: &Mesh, rays_per_point: u32) {
    let accel = Accel::new(KdTree::build(mesh, &KdTreeSettings::default()).unwrap());
    let gpu_tree = GpuKdTree::upload(&ctx.device, accel.kdtree()).unwrap();
    let points = vertex_points(mesh);
    let settings = AoSettings {
        rays_per_point,
        radius: f32::INFINITY,
        seed: 1,
    };
    let cpu = ao_rays(&accel, &points, &settings, &Bar::hidden());
    let (gpu, _) = AoRaysBatches::new(ctx)
        .visibility(ctx, &gpu_tree, None, &points, &settings, &Bar::hidden(), RAYS_PER_BATCH)
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

/// whitted (`render` on either device, `size` pixels, 1 sample and 4 with
/// Fresnel): radiance per channel within 1e-3 x max(1, |L|) for >= 99.9%
/// of pixels, ray-tree signatures equal for >= 99.5%, rays of each kind
/// within 0.1%. (A ray that rounds onto another triangle at an edge changes
/// its pixel's tree; everything else is the same arithmetic.)
pub fn compare_whitted(
    ctx: &GpuContext,
    name: &str,
    scene: &penumbra::scene::Scene,
    camera: &Camera,
    (w, h): (u32, u32),
) {
    use penumbra::progress::Reporter;
    use penumbra::whitted::{LightingSettings, RenderScene, WhittedRenderer, WhittedSettings};
    let render = |device: &Device, settings: &WhittedSettings| {
        let rs = RenderScene::new(scene, 0, &LightingSettings::default()).unwrap();
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

/// interpolate against `interpolate_pixels` over `jobs` random jobs (every
/// third textured) on 500 cells whose radiances span six decades: radiance
/// per channel within 1e-5 x the cell's largest corner value for every
/// pixel (the same products and sums; a GPU compiler may fuse them).
pub fn compare_interpolate(ctx: &GpuContext, jobs: usize) {
    use penumbra::bounded::gpu::{InterpolatePass, JOBS_PER_BATCH};
    use penumbra::bounded::interpolate::{PixelJob, interpolate_pixels};
    use penumbra::gpu::batch::Batched;
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
    let jobs: Vec<PixelJob> = (0..jobs)
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
    let mut pass = Batched::<InterpolatePass>::new(ctx);
    let (gpu_out, _) = pass.interpolate(ctx, &corners, &jobs).unwrap();
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
        "interpolate: {} pixels in {} batches, worst difference {worst:.2e} of the cell's largest corner",
        jobs.len(),
        jobs.len().div_ceil(JOBS_PER_BATCH)
    );
    assert!(worst <= 1e-5, "worst {worst}");
}

/// whitted_listed: the pixels of `w x h` listed scrambled, then every 13th
/// again, bit-identical to the same pixels of the device's whole-image
/// render (the same kernel code, on either device). Returns how many
/// pixels were listed.
pub fn compare_whitted_listed(device: &Device, (w, h): (u32, u32)) -> usize {
    use penumbra::progress::Reporter;
    use penumbra::whitted::{LightingSettings, Packets, RenderScene, WhittedRenderer, WhittedSettings};
    let scene = penumbra::scene::load_scene_shaded(&asset("raytrace").join("cornell-mirror-glass.json")).unwrap();
    let camera = scene.camera.unwrap();
    // Every pixel once, scrambled, then some twice: more than one batch.
    let n = w * h;
    let mut list: Vec<u32> = (0..n).map(|i| (i * 7_919) % n).collect();
    list.extend((0..n).step_by(13));
    let settings = WhittedSettings {
        packets: Packets::Off,
        ..WhittedSettings::default()
    };
    // The image through packets: on the CPU, where the listed pixels are
    // single rays, an independent path (packets equal single rays bit for
    // bit, tests/raytrace.rs), not the same call twice.
    let image_settings = WhittedSettings {
        packets: Packets::On,
        ..WhittedSettings::default()
    };
    let compare = |device: &Device| {
        let rs = RenderScene::new(&scene, 0, &LightingSettings::default()).unwrap();
        let mut r = WhittedRenderer::new(device, rs, &Reporter::silent()).unwrap();
        let image = r.render(&camera, w, h, &image_settings, &Bar::hidden()).unwrap();
        if !device.is_gpu() {
            assert_eq!(image.stats.path, "cpu-packets");
        }
        let params = r.params(&camera, w, h, &settings).unwrap();
        let listed = r.render_listed(&params, &list, &Bar::hidden()).unwrap().value;
        assert_eq!(listed.len(), list.len());
        let differ = list
            .iter()
            .zip(&listed)
            .filter(|&(&i, p)| bytemuck::bytes_of(p) != bytemuck::bytes_of(&image.pixels[i as usize]))
            .count();
        println!(
            "whitted_listed: {} listed pixels, {differ} differ from the image's ({})",
            list.len(),
            image.stats.path
        );
        assert_eq!(differ, 0);
        // Outside the image: an error, not a read out of bounds.
        assert!(r.render_listed(&params, &[n], &Bar::hidden()).is_err());
    };
    compare(device);
    list.len()
}

/// whitted_image: random pixels (radiance over six decades, some zero) of
/// a `w x h` image in two batches, the second starting mid-row, written
/// into one `rgba32float` texture by `WhittedImagePass`, bit-identical to
/// the CPU twin `whitted_image` (a copy: the same floats, alpha 1).
pub fn compare_whitted_image(ctx: &GpuContext, (w, h): (u32, u32)) {
    use penumbra::gpu::batch::Pass;
    use penumbra::gpu::buffers::{read_back, storage_buffer};
    use penumbra::whitted::texture::{IMAGE_FORMAT, WhittedImagePass, WhittedImageUniforms, whitted_image};
    use penumbra::whitted::{PixelOut, WhittedUniforms};
    let (device, queue) = (&ctx.device, &ctx.queue);
    let mut rng = Rng(0x51ed_2701_3c4b_8a9d);
    let n = (w * h) as usize;
    let pixels: Vec<PixelOut> = (0..n)
        .map(|i| {
            let scale = if i % 7 == 0 {
                0.0
            } else {
                10f32.powf(rng.f32() * 6.0 - 4.0)
            };
            PixelOut {
                radiance: [rng.f32() * scale, rng.f32() * scale, rng.f32() * scale],
                signature: i as u32,
                rays: [1, 2, 3, 4],
            }
        })
        .collect();
    let extent = wgpu::Extent3d {
        width: w,
        height: h,
        depth_or_array_layers: 1,
    };
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("twin image"),
        size: extent,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: IMAGE_FORMAT,
        usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let view = texture.create_view(&Default::default());
    let mut pass = WhittedImagePass::new(device);
    let mut cpu = vec![[0.0f32; 4]; n];
    let split = (n / 2 + w as usize / 3) as u32;
    for (first, count) in [(0, split), (split, n as u32 - split)] {
        let params = WhittedUniforms {
            width: w,
            height: h,
            first_pixel: first,
            pixel_count: count,
            ..bytemuck::Zeroable::zeroed()
        };
        let batch = &pixels[first as usize..(first + count) as usize];
        let buffer = storage_buffer(device, "twin pixels", bytemuck::cast_slice(batch)).unwrap();
        pass.prepare(device, queue, &params, &buffer, &view).unwrap();
        let mut encoder = device.create_command_encoder(&Default::default());
        pass.record(&mut encoder, None);
        queue.submit([encoder.finish()]);
        whitted_image(&WhittedImageUniforms::of(&params), batch, &mut cpu);
    }
    let row = (w * 16).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("twin readback"),
        size: (row * h) as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(h),
            },
        },
        extent,
    );
    queue.submit([encoder.finish()]);
    let padded: Vec<[f32; 4]> = read_back(device, &readback, (row / 16 * h) as usize).unwrap();
    let gpu: Vec<[f32; 4]> = padded
        .chunks_exact((row / 16) as usize)
        .flat_map(|r| &r[..w as usize])
        .copied()
        .collect();
    let differ = gpu
        .iter()
        .zip(&cpu)
        .filter(|(a, b)| bytemuck::bytes_of(*a) != bytemuck::bytes_of(*b))
        .count();
    println!("whitted_image {w}x{h} in two batches: {differ} of {n} texels differ from the twin's bits");
    assert_eq!(differ, 0);
    // A texture of another format is refused before anything is recorded.
    let other = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("twin image rgba8"),
        size: extent,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::STORAGE_BINDING,
        view_formats: &[],
    });
    let params = WhittedUniforms {
        width: w,
        height: h,
        pixel_count: w * h,
        ..bytemuck::Zeroable::zeroed()
    };
    let buffer = storage_buffer(device, "twin pixels", bytemuck::cast_slice(&pixels)).unwrap();
    let refused = pass.prepare(device, queue, &params, &buffer, &other.create_view(&Default::default()));
    assert!(refused.is_err());
}

/// The bounded renderer on checker-spheres, two `width x height` frames (the second
/// reprojects the first's cells) with the slow path on the device: the
/// same pixel paths on either device; interpolated and reprojected pixels
/// within 1e-5 relative (the interpolate kernel's tolerance); traced
/// pixels the device's own Whitted image's bit for bit and the CPU's
/// within the Whitted tolerance for >= 99.9% of them.
pub fn compare_bounded(ctx: &GpuContext, (width, height): (u32, u32)) {
    use penumbra::bounded::{BoundedRenderer, BoundedSettings, PixelPath, SlowPath};
    use penumbra::progress::Reporter;
    use penumbra::whitted::{LightingSettings, RenderScene, WhittedRenderer};
    let scene = penumbra::scene::load_scene_shaded(&asset("raytrace").join("checker-spheres.json")).unwrap();
    let camera = scene.camera.unwrap();
    let render = |device: &Device| {
        let rs = RenderScene::new(&scene, 0, &LightingSettings::default()).unwrap();
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
            b.render(&camera, width, height).unwrap(),
            b.render(&camera, width, height).unwrap(),
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
        let exact = b
            .whitted
            .render(&camera, width, height, &settings, &Bar::hidden())
            .unwrap();
        (frames, exact.radiance())
    };
    let ((cpu, _), (gpu_frames, gpu_exact)) = (render(&Device::cpu()), render(&Device::gpu(ctx.clone())));
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
/// renderer's extremal rays on the CPU): `rays` rays from a sphere around each
/// shipped scene into its box, each from the root hit the CPU finds. The
/// same topology (objects, faces, surfaces, light codes, children) for
/// at least 99.5% of the rays and the same occluders; where it is the
/// same, radiance and the root's diffuse terms per channel within 1e-3 x
/// max(1, abs(L)) (the Whitted kernel's tolerance), and every node's origin,
/// direction, weight, t and point within 1e-3 x max(1, |x|) (as radiance:
/// rounding differences grow down chains of refractions).
pub fn compare_whitted_trees(ctx: &GpuContext, scenes: &[&str], rays: usize) {
    use penumbra::progress::Reporter;
    use penumbra::whitted::ray_tree::RayTree;
    use penumbra::whitted::scene::MISS;
    use penumbra::whitted::tree_records::TreeRay;
    use penumbra::whitted::{LightingSettings, RenderScene, WhittedRenderer, WhittedSettings};
    let close = |a: Vec3, b: Vec3, tol: f32| ((a - b).abs() / a.abs().max(Vec3::ONE)).max_element() <= tol;
    for &name in scenes {
        let scene = penumbra::scene::load_scene_shaded(&asset("raytrace").join(format!("{name}.json"))).unwrap();
        let camera = scene.camera.unwrap();
        let rs = RenderScene::new(&scene, 0, &LightingSettings::default()).unwrap();
        let mut r = WhittedRenderer::new(&Device::gpu(ctx.clone()), rs, &Reporter::silent()).unwrap();
        let params = r.params(&camera, 64, 64, &WhittedSettings::default()).unwrap();
        let (lo, hi) = (r.bounds().min, r.bounds().max);
        let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).length());
        let mut rng = Rng(0x7ee5);
        let twin = r.twin(&params);
        let tree_rays: Vec<TreeRay> = (0..rays)
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
        let cpu: Vec<_> = tree_rays.iter().map(|ray| twin.trace_tree(ray)).collect();
        let gpu = r.trace_trees(&params, &tree_rays).unwrap().expect("a GPU renderer");
        assert_eq!(gpu.len(), tree_rays.len());
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
            tree_rays.len()
        );
        assert_eq!(overflow, 0, "{name}");
        assert!(topology * 200 <= tree_rays.len(), "{name}: {topology} trees differ");
        assert!(worst_l <= 1e-3, "{name}: radiance differs by {worst_l}");
    }
}

// Displacement fields.

/// Field parameters.
pub fn field_params(side: u32, res: u32, storage: Storage, directions: DirectionMapping) -> FieldSampling {
    FieldSampling {
        grid: OctahedralGrid { side },
        res,
        storage,
        directions,
    }
}

/// The field of `mesh`.
pub fn build_field(mesh: &Mesh, p: FieldSampling) -> DisplacementField {
    DisplacementField::build(mesh, &p, "test mesh", &Bar::hidden())
        .unwrap()
        .0
}

/// Rays from a box `spread` sphere radii wide around the field's centre,
/// aimed at points inside the sphere.
pub fn field_rays(field: &DisplacementField, n: usize, spread: f32, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let o = field.center + rng.vec3(-0.5, 0.5) * spread * field.radius;
            let target = field.center + rng.vec3(-0.5, 0.5) * field.radius;
            (o, (target - o).normalize())
        })
        .collect()
}

/// Field lookups (`field_lookup`, `field_trace` through `field_probe`)
/// against the CPU's (`field_probe`), on cube-with-hole's fields of `side x
/// side` maps of `res x res` texels in every storage and direction mapping,
/// `rays` random rays each: 1-bit maps within 1e-4; 8-bit maps, read through
/// the texture unit, within 1/255 but for the few lookups where lavapipe's
/// fixed-point filter weights add up to more (never beyond 2/255).
pub fn compare_field_lookup(ctx: &GpuContext, side: u32, res: u32, rays: usize) {
    let mesh = load_obj(&asset("cube-with-hole.obj")).unwrap();
    let cases = [
        (Storage::U8, 1.0 / 255.0, 2.0 / 255.0, 1e-3),
        (Storage::F32, 1e-4, 1e-4, 0.0),
        (Storage::Bit1, 1e-4, 1e-4, 0.0),
    ];
    for (storage, tolerance, bound, allowed) in cases {
        for m in [DirectionMapping::Concentric, DirectionMapping::Rejection] {
            let field = build_field(&mesh, field_params(side, res, storage, m));
            let rays = field_rays(&field, rays, 4.0, 3);
            let g = GpuField::upload(&ctx.device, &ctx.queue, &field, Positional::Bilinear).unwrap();
            let out = probe_gpu(ctx, &g, &rays).unwrap();
            let cpu_out = field_probe(&field, &rays, Positional::Bilinear);
            let (mut worst, mut over, mut n, mut flips) = (0.0f32, 0, 0, 0);
            for (cpu, r) in cpu_out.iter().zip(&out) {
                assert!(r.iter().all(|x| x.is_finite()), "NaN from the GPU: {r:?}");
                let Some(cpu) = cpu else {
                    assert_eq!(r[0] as u32 % 4, 0, "the CPU says the ray misses the sphere");
                    continue;
                };
                let diff = (cpu.coverage - r[2]).abs().max((cpu.weighted_distance - r[3]).abs());
                worst = worst.max(diff);
                over += (diff > tolerance) as usize;
                flips += ((cpu.coverage >= 0.5) != (r[2] >= 0.5)) as usize;
                n += 1;
            }
            let tiles = g
                .layout
                .map_or("bits".to_string(), |l| format!("{}x{} tiles", l.tiles_x, l.tiles_y));
            println!(
                "{storage:?} {m:?} ({side}x{side} maps, {tiles}): {n} lookups, worst |GPU - CPU| = {worst:.2e}, {over} over {tolerance:.1e}, {flips} hit/miss votes flipped"
            );
            assert!(worst <= bound, "{storage:?} {m:?}: worst {worst}");
            assert!(
                over as f64 <= allowed * n as f64,
                "{storage:?} {m:?}: {over} of {n} over {tolerance}"
            );
        }
    }
}

/// A corner with a caster: AO through the field (`field_ao`) on the GPU
/// against the CPU twin, ray for ray, for a field of `side x side` maps of
/// `res x res` texels in each storage: at most 0.2% of the rays and 3 of a
/// vertex's 64 differ; the inside-sphere classes are identical.
pub fn compare_field_ao(ctx: &GpuContext, side: u32, res: u32) {
    let caster = load_obj(&asset("cube-with-hole.obj")).unwrap();
    let receiver = corner();
    let transform = Transform {
        translation: Vec3::new(0.4, 0.2, 0.4),
        rotation: Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.6),
        scale: 0.15,
    };
    let settings = AoSettings {
        rays_per_point: 64,
        radius: f32::INFINITY,
        seed: 9,
    };
    let points = vertex_points(&receiver);
    let owners = vec![NO_OWNER; points.len()];
    for storage in [Storage::U8, Storage::F32, Storage::Bit1] {
        let field = build_field(&caster, field_params(side, res, storage, DirectionMapping::Concentric));
        let casters = [FieldCaster {
            field: &field,
            transform,
            instance: 1,
        }];
        let (cpu, cpu_classes) = field_ao(
            &casters,
            &points,
            &owners,
            &settings,
            Positional::Bilinear,
            &Bar::hidden(),
        );
        let g = GpuField::upload(&ctx.device, &ctx.queue, &field, Positional::Bilinear).unwrap();
        let groups = [FieldGroup {
            field: &g,
            instances: vec![GpuInstance::new(&transform, 1)],
        }];
        let gpu_ao = FieldAoBatches::new(ctx)
            .visibility(ctx, &groups, &points, &owners, &settings, &Bar::hidden())
            .unwrap();
        let differ = cpu.differing_rays(&gpu_ao.masks);
        let total = (points.len() * 64) as u64;
        let worst = cpu
            .accessibility()
            .iter()
            .zip(gpu_ao.masks.accessibility())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        println!("{storage:?}: {differ} of {total} rays differ, worst accessibility difference {worst:.4}");
        assert!(differ as f64 <= 2e-3 * total as f64, "{storage:?}");
        assert!(worst <= 3.0 / 64.0, "{storage:?}");
        assert_eq!(
            cpu_classes.inside, gpu_ao.classes.inside,
            "{storage:?}: inside-sphere classes"
        );
    }
}

// SSAO.

/// The G-buffer of kd-tree primary rays (the CPU twin of the G-buffer pass).
pub fn cpu_gbuffer(mesh: &Mesh, camera: &Camera, w: u32, h: u32) -> GBuffer {
    let tree = KdTree::build(mesh, &KdTreeSettings::default()).unwrap();
    gbuffer(&tree, mesh, camera, &[], w, h)
}

/// Whether CPU texels a and b agree as the issue asks.
pub fn texels_agree(a: [f32; 4], b: [f32; 4]) -> bool {
    if (a[3] > 0.0) != (b[3] > 0.0) {
        return false;
    }
    if a[3] <= 0.0 {
        return true;
    }
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let zero = |t: [f32; 4]| t[0] == 0.0 && t[1] == 0.0 && t[2] == 0.0;
    (b[3] - a[3]).abs() <= 1e-3 * a[3] && (dot >= 0.999 || (zero(a) && zero(b)))
}

/// The rasterised G-buffer (`gbuffer.wgsl`) against kd-tree primary rays at
/// `w x h`: >= 99% of pixels agree (same coverage, depth within 1e-3
/// relative, normals within 0.999 dot); every other pixel is a silhouette
/// pixel (a 3x3 neighbour differs from it in the CPU G-buffer by the same
/// thresholds, or is background); radiance of agreeing pixels on the same
/// facet within 1e-4; at most 0.5% of agreeing pixels show another object's
/// albedo (coplanar overlaps).
pub fn compare_gbuffers(ctx: &GpuContext, name: &str, mesh: &Mesh, camera: &Camera, (w, h): (u32, u32)) {
    let view = ScreenView::new(camera, w, h);
    let cpu = cpu_gbuffer(mesh, camera, w, h);
    let settings = SsaoSettings::new(Estimator::Importance, 4, 0.1);
    let source = GBufferSource::Render {
        mesh,
        camera,
        lights: &[],
        surfaces: None,
    };
    let gpu = run_frame(ctx, source, &view, &settings, None, 1).unwrap().gbuffer;
    let (mut agree, mut not_silhouette, mut worst_z, mut worst_dot) = (0usize, 0usize, 0f32, 1f32);
    let (mut radiance_worst, mut albedo_differs) = (0f32, 0usize);
    for y in 0..h as i32 {
        for x in 0..w as i32 {
            let i = (y * w as i32 + x) as usize;
            let (c, g) = (cpu.geometry[i], gpu.geometry[i]);
            if texels_agree(c, g) {
                agree += 1;
                if c[3] > 0.0 {
                    worst_z = worst_z.max((g[3] - c[3]).abs() / c[3]);
                    worst_dot = worst_dot.min(c[0] * g[0] + c[1] * g[1] + c[2] * g[2]);
                    // Same facet (neighbouring facets of a tessellated
                    // surface also agree within 0.999): same radiance.
                    if c[0] * g[0] + c[1] * g[1] + c[2] * g[2] > 0.999999 && cpu.shade[i][3] == gpu.shade[i][3] {
                        for k in 0..3 {
                            radiance_worst = radiance_worst.max((cpu.shade[i][k] - gpu.shade[i][k]).abs());
                        }
                    }
                    // Coplanar overlapping objects (kitchen) may show either albedo.
                    albedo_differs += (cpu.shade[i][3] != gpu.shade[i][3]) as usize;
                }
                continue;
            }
            let silhouette = (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (qx, qy) = (x + dx, y + dy);
                    (0..w as i32).contains(&qx)
                        && (0..h as i32).contains(&qy)
                        && !texels_agree(c, cpu.geometry[(qy * w as i32 + qx) as usize])
                })
            });
            if !silhouette {
                not_silhouette += 1;
                println!("{name}: pixel {x},{y} differs inside a surface: cpu {c:?} gpu {g:?}");
            }
        }
    }
    let n = (w * h) as f64;
    println!(
        "{name}: {:.3}% of pixels agree, worst relative depth {worst_z:.2e}, worst normal dot {worst_dot:.6}, \
         worst radiance difference {radiance_worst:.2e}, {not_silhouette} non-silhouette disagreements, \
         {albedo_differs} agreeing pixels of another object (coplanar overlap)",
        100.0 * agree as f64 / n
    );
    assert!(
        albedo_differs as f64 <= 0.005 * n,
        "{name}: {albedo_differs} pixels show another object"
    );
    assert!(agree as f64 >= 0.99 * n, "{name}: only {agree} of {n} pixels agree");
    assert_eq!(not_silhouette, 0, "{name}: disagreements away from silhouettes");
    assert!(radiance_worst < 1e-4, "{name}: radiance differs by {radiance_worst}");
}

pub fn max_diff(a: &[f32], b: &[f32]) -> (f32, usize) {
    a.iter()
        .zip(b)
        .enumerate()
        .map(|(i, (x, y))| ((x - y).abs(), i))
        .fold((0.0, 0), |m, v| if v.0 > m.0 { v } else { m })
}

pub fn flat(v: &[[f32; 4]]) -> Vec<f32> {
    v.iter().flatten().copied().collect()
}

/// Every SSAO kernel (`ssao_estimate`, `ssao_filter`, `ssao_indirect`) on
/// the GPU against its CPU twin, same G-buffer and samples: every estimator,
/// interleave and filter on and off, full and half resolution; every pixel
/// within 1e-4 (AO before and after the filter, L~, the image).
pub fn compare_ssao_kernels(ctx: &GpuContext, name: &str, gb: &GBuffer, view: &ScreenView, radius: f32) {
    let shade = ShadeSettings::default();
    for estimator in Estimator::ALL {
        let (full, half) = (Resolution::Full, Resolution::Half);
        for (interleave, filter, resolution) in [
            (true, true, full),
            (false, false, full),
            (true, true, half),
            (true, false, half),
        ] {
            let mut s = SsaoSettings::new(estimator, 16, radius);
            s.interleave = interleave;
            s.filter = filter;
            s.resolution = resolution;
            let cpu = run_cpu(gb, view, &s, Some(&shade)).unwrap();
            let g = run_frame(ctx, GBufferSource::Upload(gb), view, &s, Some(&shade), 1).unwrap();
            assert_eq!(&g.gbuffer, gb, "the uploaded G-buffer reads back unchanged");
            let gpu = g.frame;
            let checks = [
                ("ao (raw)", max_diff(&cpu.ao_raw, &gpu.ao_raw)),
                ("ao (final)", max_diff(&cpu.ao, &gpu.ao)),
                (
                    "indirect",
                    max_diff(
                        &flat(cpu.indirect.as_ref().unwrap()),
                        &flat(gpu.indirect.as_ref().unwrap()),
                    ),
                ),
                (
                    "image",
                    max_diff(&flat(cpu.image.as_ref().unwrap()), &flat(gpu.image.as_ref().unwrap())),
                ),
            ];
            let label = format!(
                "{name} {} interleave={interleave} filter={filter} resolution={}",
                estimator.name(),
                resolution.name()
            );
            println!("{label}: worst |gpu - cpu| {checks:?}");
            for (what, (d, at)) in checks {
                assert!(d <= 1e-4, "{label}: {what} differs by {d} at element {at}");
            }
        }
    }
}

// PRT.

/// An animation of `AnimatedScene`'s built-ins.
pub fn animation(name: &str) -> Animation {
    AnimatedScene::parse(name).unwrap().build()
}

/// Random planar RGB lighting of `bands` bands.
pub fn lighting(bands: usize, seed: u64) -> Vec<f32> {
    let mut rng = Rng(seed);
    (0..3 * coefficient_count(bands))
        .map(|_| rng.f32() * 2.0 - 0.5)
        .collect()
}

/// A case of `compare_transfer`: (scene, time, brdf, integration, bands,
/// mask side, batch limit).
pub type TransferCase = (&'static str, f32, Brdf, Integration, usize, usize, u64);

/// The SH transfer kernel (`sh_transfer.wgsl`, in the form the device's
/// limits allow) against `Prt::frame` on one frame: per coefficient,
/// |gpu - cpu| <= 1e-4 |T_unoccluded| (the norm of the unshadowed transfer,
/// ~0.9); radiance within 1e-4 relative (+1e-6 absolute). Both sides do the
/// same f32 arithmetic; only the summation order of the cell loop and fused
/// multiply-adds differ. A batch limit below the mesh splits it. Returns
/// the GPU's frame.
pub fn compare_transfer(
    ctx: &GpuContext,
    (scene, time, brdf, integration, bands, side, batch): TransferCase,
) -> GpuFrame {
    let anim = animation(scene);
    let mut pos = Vec::new();
    anim.positions_at(time, &mut pos);
    let settings = PrtSettings {
        brdf,
        integration,
        bands,
        mask_side: side,
        ..PrtSettings::default()
    };
    let prt = Prt::new(&pos, &anim.triangles, &settings).unwrap();
    let eye = Some(anim.camera.expect("built-in animations have a camera").0);
    let light = lighting(bands, 7 + bands as u64);
    let mut cpu = FrameOutput::default();
    prt.frame(&pos, eye, &light, false, true, &mut cpu).unwrap();
    let mut masks = FrameOutput::default();
    prt.frame_masks(&pos, eye, false, &mut masks).unwrap();
    assert_eq!(masks.masks, cpu.masks, "frame_masks rasterises what frame does");
    let mut gpu_transfer = GpuTransfer::with_batch_limit(ctx, &prt, batch).unwrap();
    let inputs = FrameInputs {
        masks: &masks.masks,
        positions: &pos,
        normals: &masks.normals,
        eye,
        lighting: &light,
    };
    let g = gpu_transfer.run_frame(ctx, &inputs).unwrap();
    let (form, vertices) = gpu_transfer.pass.workgroups();
    let n = prt.coeffs();
    let scale = prt.tables.unoccluded.iter().map(|v| v * v).sum::<f32>().sqrt();
    let worst_t = cpu
        .transfer
        .iter()
        .zip(&g.transfer)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max)
        / scale;
    let worst_r = cpu
        .radiance
        .iter()
        .flatten()
        .zip(g.radiance.iter().flatten())
        .map(|(a, b)| (a - b).abs() / (a.abs() + 1e-2))
        .fold(0.0f32, f32::max);
    let zero = cpu.normals.iter().filter(|n| **n == Vec3::ZERO).count();
    println!(
        "{scene} t={time} {} {} bands {bands} mask {side}: {} vertices x {n} coefficients in {} batches, {vertices} vertices a workgroup ({}), worst |dT|/|T0| = {worst_t:.2e}, worst radiance rel = {worst_r:.2e} ({zero} without normal), kernel {:?} ms",
        brdf.name(),
        integration.name(),
        prt.vertex_count,
        gpu_transfer.batch_count(),
        form.module.name,
        g.kernel_ms
    );
    assert!(worst_t <= 1e-4, "{scene}: transfer differs by {worst_t:e}");
    assert!(worst_r <= 1e-4, "{scene}: radiance differs by {worst_r:e}");
    if batch != u64::MAX {
        assert!(gpu_transfer.batch_count() > 1, "the batch limit splits the mesh");
    }
    g
}

// MLRTA packets.

/// How two traces of the same rays agree.
pub struct Agreement {
    pub rays: usize,
    pub disagree: usize,
    pub worst_t: f32,
    pub triangle_ties: usize,
}

/// Hit/miss disagreements, the worst relative t difference where both hit,
/// and triangle ties.
pub fn agreement(a: &[Hit], b: &[Hit]) -> Agreement {
    let mut r = Agreement {
        rays: a.len(),
        disagree: 0,
        worst_t: 0.0,
        triangle_ties: 0,
    };
    for (x, y) in a.iter().zip(b) {
        if x.is_hit() != y.is_hit() {
            r.disagree += 1;
        } else if x.is_hit() {
            r.worst_t = r.worst_t.max((x.t - y.t).abs() / y.t);
            r.triangle_ties += (x.triangle != y.triangle) as usize;
        }
    }
    r
}

/// Hit/miss identical for >= 99.99% of rays; where both hit,
/// |t - t_other| <= 1e-5 t.
pub fn check(name: &str, a: &Agreement) {
    println!(
        "{name}: {} rays, {} hit/miss disagreements, worst relative t difference {:.2e}, {} triangle ties",
        a.rays, a.disagree, a.worst_t, a.triangle_ties
    );
    assert!(
        a.disagree as f64 <= 1e-4 * a.rays as f64,
        "{name}: hit/miss disagreement"
    );
    assert!(a.worst_t <= 1e-5, "{name}: t differs");
}

/// The GPU packet kernel (`packet_traverse.wgsl`) against the CPU: hits
/// against single rays (`check`), shadows against the CPU packets' (at most
/// 0.01% differ), ray for ray, on a `size x size` camera image without entry
/// points and with them at two minimum tiles.
pub fn compare_packets(ctx: &GpuContext, name: &str, mesh: &Mesh, camera: &Camera, size: u32) {
    use penumbra::mlrta::gpu::PacketBatches;
    let tree = KdTree::build(mesh, &KdTreeSettings::default()).unwrap();
    let (prepared, _) = Prepared::new(&tree, mesh);
    let gpu_tree = GpuKdTree::upload(&ctx.device, &tree).unwrap();
    let rays = camera.primary_rays(size, size);
    let b = mesh.bounds();
    let light = b.center() + Vec3::new(-0.4, 1.0, 0.3).normalize() * b.diagonal();
    let single: Vec<Hit> = rays
        .iter()
        .map(|r| tree.closest_hit(r.o(), r.d(), f32::INFINITY))
        .collect();
    // Without entry points, and with them at the default and the smallest
    // practical minimum tile (deeper splits, more stopping rules).
    for (entry_points, min_tile) in [(false, DEFAULT_MIN_TILE), (true, DEFAULT_MIN_TILE), (true, 8)] {
        let params = MlrtaSettings {
            entry_points,
            min_tile,
            corner_frusta: true,
            ..Default::default()
        };
        let cpu = trace_image(&prepared, &rays, size, size, &params, Some(light)).unwrap();
        let gpu = PacketBatches::new(ctx)
            .trace_image(ctx, &gpu_tree, &prepared, &rays, size, size, &params, Some(light))
            .unwrap();
        check(
            &format!("{name} GPU packets, entry points {entry_points}, min tile {min_tile}"),
            &agreement(&gpu.image.hits, &single),
        );
        let shadows_differ = cpu
            .shadowed
            .unwrap()
            .iter()
            .zip(gpu.image.shadowed.unwrap())
            .filter(|(a, b)| **a != *b)
            .count();
        println!(
            "{name} GPU shadows, entry points {entry_points}, min tile {min_tile}: {shadows_differ} differ from the CPU"
        );
        assert!(shadows_differ as f64 <= 1e-4 * rays.len() as f64);
    }
}
