//! The examples a host engine author copies, run as they are: each builds
//! its own wgpu device, so without an adapter they say they skipped.
//!
//! * `host_ao`: per-vertex AO of a mesh in at most 30 lines of code; the
//!   CPU and the GPU give the same AO, ray for ray.
//! * `host_ssao`: the host's own G-buffer pass and penumbra's SSAO in the
//!   host's encoder; the AO equals the CPU twin run on the host's G-buffer
//!   (within 1e-4 per pixel; the twins are bit-identical on lavapipe).
//! * `host_prt`: the host's deforming mesh, radiance per vertex every frame
//!   on the host's GPU; the last frame equals the CPU runner's (within 1e-4
//!   relative) and is within 3% of Monte Carlo ray tracing.
//! * `host_field`: field AO of a ball the host moves over its floor, every
//!   frame recorded into the host's encoder; each frame's rays are the CPU
//!   twin's (`field::field_ao`, the same rays through the same field) but
//!   for at most 0.2% of them and 3/64 of a vertex's (the twin tests'
//!   tolerances for 8-bit maps, whose filtered lookups round on the
//!   texture unit), and the floor under the ball darkens as the ball comes
//!   near.
//! * `host_whitted`: a shipped scene ray traced into the host's own
//!   `rgba32float` texture; its texels are the CPU renderer's radiance
//!   within 1e-3 x max(1, |L|) per channel for >= 99.9% of pixels (the
//!   Whitted twin tests' tolerance), alpha 1.

#[path = "../examples/host_ao.rs"]
#[allow(dead_code)]
mod host_ao;

#[path = "../examples/host_ssao.rs"]
#[allow(dead_code)]
mod host_ssao;

#[path = "../examples/host_prt.rs"]
#[allow(dead_code)]
mod host_prt;

#[path = "../examples/host_field.rs"]
#[allow(dead_code)]
mod host_field;

#[path = "../examples/host_whitted.rs"]
#[allow(dead_code)]
mod host_whitted;

mod common;

use common::TempDir;
use glam::Vec3;
use penumbra::field::{FieldCaster, NO_OWNER, Positional, field_ao};
use penumbra::gpu::device::Device;
use penumbra::progress::Bar;
use penumbra::prt::pipeline::FrameOutput;
use penumbra::prt::runner::{PrtRunner, RayTraced, Shadows};
use penumbra::ssao::gbuffer::{GBuffer, ScreenView};
use penumbra::ssao::{final_ao, run_cpu};
use penumbra::whitted::{WhittedRenderer, WhittedSettings};

#[test]
fn host_ssao_example_equals_the_cpu_twin_on_the_hosts_gbuffer() {
    let dir = TempDir::new("host-ssao");
    let out = dir.0.join("host-ssao.png");
    let Some(frame) = host_ssao::run(&out).unwrap() else {
        return common::skip_gpu("host_ssao", &"the example found none");
    };
    let (w, h) = (host_ssao::WIDTH, host_ssao::HEIGHT);
    let gb = GBuffer {
        width: w,
        height: h,
        geometry: frame.geometry.clone(),
        shade: frame.shade.clone(),
    };
    let view = ScreenView::new(&frame.camera, w, h);
    let cpu = run_cpu(&gb, &view, &frame.settings, None).unwrap();
    let gpu = final_ao(&gb, &frame.ao);
    let worst = gpu
        .iter()
        .zip(&cpu.ao)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    let surface: Vec<f32> = (0..gb.pixels()).filter(|&i| gb.is_surface(i)).map(|i| gpu[i]).collect();
    let mean = surface.iter().sum::<f32>() / surface.len() as f32;
    let darkest = surface.iter().copied().fold(1.0f32, f32::min);
    println!(
        "host_ssao on {}: {} surface pixels, mean AO {mean:.3}, darkest {darkest:.3}, worst |GPU - CPU| {worst:.2e}",
        frame.adapter,
        surface.len()
    );
    assert!(
        worst <= 1e-4,
        "the host-embedded pass differs from its CPU twin by {worst}"
    );
    assert!(
        surface.len() > (w * h / 4) as usize,
        "the host's scene covers the image"
    );
    assert!(
        darkest < 0.6 && (0.7..0.99).contains(&mean),
        "contact shadows darken, open floor does not"
    );
    assert_eq!(image::open(&out).unwrap().to_rgb8().dimensions(), (w, h));
}

#[test]
fn host_prt_example_equals_the_cpu_runner_and_ray_tracing() {
    let dir = TempDir::new("host-prt");
    let out = dir.0.join("host-prt.png");
    let Some(report) = host_prt::run(&out).unwrap() else {
        return common::skip_gpu("host_prt", &"the example found none");
    };
    let settings = host_prt::settings();
    let reference = RayTraced { rays: 64, seed: 7 };
    let rest = host_prt::positions_at(0.0);
    let triangles = host_prt::triangles();
    let mut cpu = PrtRunner::new(&Device::cpu(), &rest, &triangles, &settings, Shadows::On, reference).unwrap();
    let lighting = host_prt::lighting(settings.bands).unwrap();
    let mut frame = FrameOutput::default();
    let eye = Some(host_prt::camera().eye);
    cpu.frame(&report.positions, eye, &lighting, false, &mut frame).unwrap();
    let worst = frame
        .radiance
        .iter()
        .flatten()
        .zip(report.radiance.iter().flatten())
        .map(|(a, b)| (a - b).abs() / (a.abs() + 1e-2))
        .fold(0.0f32, f32::max);
    println!(
        "host_prt on {}: {} frames, {} vertices, worst radiance |GPU - CPU| / |CPU| {worst:.2e}, transfer error {:.2}%",
        report.adapter,
        host_prt::FRAMES,
        report.positions.len(),
        100.0 * report.transfer_error
    );
    assert!(
        worst <= 1e-4,
        "the host's GPU frame differs from the CPU runner by {worst}"
    );
    assert!(report.transfer_error < 0.03, "transfer error {}", report.transfer_error);
    assert_eq!(image::open(&out).unwrap().to_rgb8().dimensions(), (320, 240));
}

/// Lines of code of an example: not blank, not a comment.
fn code_lines(example: &str) -> usize {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(example);
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with("//"))
        .count()
}

#[test]
fn host_ao_example_is_short_and_the_gpu_gives_the_cpus_ao() {
    let lines = code_lines("host_ao.rs");
    println!("host_ao: {lines} lines of code");
    assert!(lines <= 30, "host_ao.rs has {lines} lines of code, more than 30");
    let mesh = common::asset("sphere-on-plane.obj");
    let cpu = host_ao::vertex_ao(&Device::cpu(), &mesh).unwrap();
    let n = penumbra::Mesh::load(&mesh).unwrap().positions.len();
    assert_eq!(cpu.ao.len(), n);
    let mean = cpu.mean();
    let darkest = cpu.ao.iter().copied().fold(1.0f32, f32::min);
    println!("host_ao on the CPU: {n} vertices, mean AO {mean:.4}, darkest {darkest:.4}");
    assert!(
        (0.5..0.99).contains(&mean) && darkest < 0.5,
        "the sphere darkens the plane under it"
    );
    let Some(gpu) = common::gpu() else {
        return;
    };
    let on_gpu = host_ao::vertex_ao(&Device::gpu(gpu), &mesh).unwrap();
    let worst = cpu
        .ao
        .iter()
        .zip(&on_gpu.ao)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    println!("host_ao: worst |GPU - CPU| per vertex {worst:.2e} (tolerance 0: the same rays escape)");
    assert_eq!(on_gpu.ao, cpu.ao, "the GPU's AO differs from the CPU twin's");
}

#[test]
fn host_field_example_equals_the_cpu_twin_every_frame_and_follows_the_ball() {
    let Some(report) = host_field::run().unwrap() else {
        return common::skip_gpu("host_field", &"the example found none");
    };
    let owners = vec![NO_OWNER; report.points.len()];
    let rays = report.points.len() as u64 * report.settings.rays_per_point as u64;
    let (mut worst_fraction, mut worst_vertex) = (0.0f64, 0.0f32);
    for (f, frame) in report.frames.iter().enumerate() {
        let casters = [FieldCaster {
            field: &report.field,
            transform: frame.transform,
            instance: 0,
        }];
        let (cpu, _) = field_ao(
            &casters,
            &report.points,
            &owners,
            &report.settings,
            Positional::Bilinear,
            &Bar::hidden(),
        );
        let differ = cpu.differing_rays(&frame.masks);
        let vertex = cpu
            .accessibility()
            .iter()
            .zip(&frame.ao)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        println!(
            "host_field frame {f}: {differ} of {rays} rays differ from the CPU twin, worst per-vertex |GPU - CPU| {vertex:.4}, {:.1} ms",
            frame.ms
        );
        worst_fraction = worst_fraction.max(differ as f64 / rays as f64);
        worst_vertex = worst_vertex.max(vertex);
    }
    println!(
        "host_field on {}: {} frames of {} vertices, field built in {:.0} ms; worst fraction of rays differing {worst_fraction:.1e} (tolerance 2e-3), worst per-vertex AO difference {worst_vertex:.4} (tolerance 3/64)",
        report.adapter,
        report.frames.len(),
        report.points.len(),
        report.build_ms
    );
    assert!(
        worst_fraction <= 2e-3,
        "the host-recorded pass differs from its CPU twin in {worst_fraction} of the rays"
    );
    assert!(
        worst_vertex <= 3.0 / 64.0,
        "a vertex's AO differs from the CPU twin's by {worst_vertex}"
    );
    // The vertex under the ball's first position is darker in the first
    // frame than in the last, and the one under its last position darker in
    // the last.
    let floor = host_field::floor();
    let under = |t: &penumbra::scene::Transform| {
        let below = Vec3::new(t.translation.x, 0.0, t.translation.z);
        (0..floor.positions.len())
            .min_by(|&a, &b| {
                let d = |i: usize| floor.positions[i].distance(below);
                d(a).total_cmp(&d(b))
            })
            .unwrap()
    };
    let (first, last) = (&report.frames[0], &report.frames[report.frames.len() - 1]);
    let (a, b) = (under(&first.transform), under(&last.transform));
    println!(
        "under the ball's first place: AO {:.3} then {:.3}; under its last: {:.3} then {:.3}",
        first.ao[a], last.ao[a], first.ao[b], last.ao[b]
    );
    assert!(
        first.ao[a] + 0.1 < last.ao[a],
        "the ball leaving does not lighten the floor"
    );
    assert!(
        last.ao[b] + 0.1 < first.ao[b],
        "the ball arriving does not darken the floor"
    );
}

#[test]
fn host_whitted_example_draws_the_cpu_renderers_image_into_the_hosts_texture() {
    let dir = TempDir::new("host-whitted");
    let out = dir.0.join("host-whitted.png");
    let scene_file = common::asset("raytrace").join("checker-spheres.json");
    let Some(report) = host_whitted::run(&scene_file, &out).unwrap() else {
        return common::skip_gpu("host_whitted", &"the example found none");
    };
    let (w, h) = (host_whitted::WIDTH, host_whitted::HEIGHT);
    let scene = penumbra::scene::load_scene_shaded(&scene_file).unwrap();
    let mut cpu = WhittedRenderer::for_scene(&Device::cpu(), &scene).unwrap();
    assert_eq!(report.settings, WhittedSettings::default());
    let rendered = cpu.image(&report.camera, w, h, &report.settings).unwrap();
    assert_eq!(report.texels.len(), rendered.pixels.len());
    let (mut worst, mut over) = (0f32, 0usize);
    for (texel, pixel) in report.texels.iter().zip(&rendered.pixels) {
        let (gpu, cpu) = (
            Vec3::new(texel[0], texel[1], texel[2]),
            Vec3::from_array(pixel.radiance),
        );
        let d = ((gpu - cpu).abs() / cpu.abs().max(Vec3::ONE)).max_element();
        worst = worst.max(d);
        over += (d > 1e-3) as usize;
        assert_eq!(texel[3], 1.0, "alpha");
    }
    let n = report.texels.len();
    println!(
        "host_whitted on {}: {w}x{h} in {:.1} ms; worst per-channel |texture - CPU| / max(1, |CPU|) {worst:.2e}, {over} of {n} pixels above 1e-3 (tolerance 0.1%)",
        report.adapter, report.ms
    );
    assert!(over * 1000 <= n, "{over} of {n} pixels differ from the CPU renderer");
    assert_eq!(image::open(&out).unwrap().to_rgb8().dimensions(), (w, h));
}
