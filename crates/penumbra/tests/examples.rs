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

#[path = "../examples/host_ao.rs"]
#[allow(dead_code)]
mod host_ao;

#[path = "../examples/host_ssao.rs"]
#[allow(dead_code)]
mod host_ssao;

#[path = "../examples/host_prt.rs"]
#[allow(dead_code)]
mod host_prt;

mod common;

use common::TempDir;
use penumbra::gpu::device::Device;
use penumbra::prt::pipeline::FrameOutput;
use penumbra::prt::runner::{PrtRunner, RayTraced, Shadows};
use penumbra::ssao::gbuffer::{GBuffer, ScreenView};
use penumbra::ssao::{final_ao, run_cpu};

#[test]
fn host_ssao_example_equals_the_cpu_twin_on_the_hosts_gbuffer() {
    let dir = TempDir::new("host-ssao");
    let out = dir.0.join("host-ssao.png");
    let Some(frame) = host_ssao::run(&out).unwrap() else {
        println!("no GPU adapter: host_ssao skipped");
        return;
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
        println!("no GPU adapter: host_prt skipped");
        return;
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
