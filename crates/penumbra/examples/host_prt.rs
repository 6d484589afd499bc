//! A host engine that owns a deforming mesh and asks penumbra for its
//! self-shadowed radiance every frame.
//!
//! The host has its own wgpu device and its own animation (here a
//! corrugated sheet whose waves travel, the kind of surface a cloth or
//! water simulation hands over every frame). It adopts its device and
//! queue into a `penumbra::gpu::device::Device`, builds one `PrtRunner` from the
//! rest pose, and every frame passes its new vertex positions: penumbra
//! rasterises the visibility masks on the CPU and integrates, rotates and
//! shades them on the host's GPU (`sh_transfer.wgsl`), returning radiance
//! per vertex for the host's own shading. The last frame is written as a
//! PNG, ray cast with the per-vertex radiance interpolated.
//!
//! ```sh
//! cargo run --release --example host_prt -- host-prt.png
//! ```

use std::error::Error;
use std::path::Path;

use glam::Vec3;
use penumbra::gpu::device::Device;
use penumbra::prt::pipeline::{FrameOutput, PrtSettings};
use penumbra::prt::render::{auto_exposure, render};
use penumbra::prt::runner::{PrtRunner, RayTraced, Shadows};
use penumbra::scene::{Camera, EnvironmentMap};
use penumbra::sh::project_environment;
use penumbra::sh::window::nonnegative;

pub const FRAMES: usize = 24;
const GRID: usize = 33;
const ALBEDO: Vec3 = Vec3::new(0.8, 0.75, 0.7);

/// What the run produced.
pub struct Report {
    pub adapter: String,
    /// The last frame's pose and penumbra's radiance per vertex.
    pub positions: Vec<Vec3>,
    pub radiance: Vec<[f32; 3]>,
    /// The SH transfer kernel's time per frame, where timestamps exist.
    pub kernel_ms: Vec<f64>,
    /// Mean relative L2 error of the last frame's transfer against
    /// Monte Carlo ray tracing (the runner's own check).
    pub transfer_error: f64,
}

fn main() {
    let out = std::env::args().nth(1).unwrap_or_else(|| "host-prt.png".into());
    match run(Path::new(&out)) {
        Ok(Some(r)) => {
            let ms = match r.kernel_ms.len() {
                0 => "n/a (no timestamp queries)".to_string(),
                n => format!("{:.2} ms", r.kernel_ms.iter().sum::<f64>() / n as f64),
            };
            println!(
                "{out}: {FRAMES} frames of {} vertices on {}, kernel {ms} per frame, transfer error {:.2}%",
                r.positions.len(),
                r.adapter,
                100.0 * r.transfer_error
            );
        }
        Ok(None) => println!("no GPU adapter: host_prt skipped"),
        Err(e) => {
            eprintln!("host_prt: {e}");
            std::process::exit(1);
        }
    }
}

/// The host's device: any adapter but OpenGL (its compute support varies).
fn host_device() -> Option<(wgpu::Device, wgpu::Queue, String)> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::all() - wgpu::Backends::GL,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default())).ok()?;
    let name = adapter.get_info().name;
    let (device, queue) = pollster::block_on(adapter.request_device(&Default::default())).ok()?;
    Some((device, queue, name))
}

/// The host's mesh: a 2 x 2 sheet on a 33 x 33 grid.
pub fn triangles() -> Vec<[u32; 3]> {
    let n = GRID as u32;
    let mut t = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            t.push([a, a + n, a + n + 1]);
            t.push([a, a + n + 1, a + 1]);
        }
    }
    t
}

/// The host's animation: corrugations travelling across the sheet while
/// it rolls up at one end.
pub fn positions_at(time: f32) -> Vec<Vec3> {
    (0..GRID * GRID)
        .map(|k| {
            let (u, v) = (
                (k % GRID) as f32 / (GRID - 1) as f32,
                (k / GRID) as f32 / (GRID - 1) as f32,
            );
            let (x, z) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            let wave = 0.16 * (7.0 * x - 2.5 * time).sin() * (0.6 + 0.4 * (3.0 * z + time).cos());
            let lift = 0.2 * (1.0 + x).powi(2) * (0.5 + 0.5 * (1.3 * time).sin());
            Vec3::new(x, wave + lift, z)
        })
        .collect()
}

/// The host's sky: a blue gradient and a soft sun.
pub fn sky() -> Result<EnvironmentMap, penumbra::Error> {
    let sun = Vec3::new(0.5, 0.6, 0.35).normalize();
    EnvironmentMap::from_fn(64, |d| {
        let sky = 0.15 + 0.35 * d.y.max(0.0);
        let glow = 6.0 * d.dot(sun).max(0.0).powi(24);
        [sky * 0.8 + glow, sky * 0.9 + glow, sky * 1.2 + 0.9 * glow]
    })
}

/// The sky's SH coefficients (planar RGB), windowed so that they
/// reconstruct no negative radiance (`sh::window`): a truncated probe rings,
/// and a vertex seeing only a negative lobe would shade below zero.
pub fn lighting(bands: usize) -> Result<Vec<f32>, Box<dyn Error>> {
    let (windowed, _) = nonnegative(&project_environment(&sky()?, bands));
    Ok(windowed.to_f32_planar())
}

/// The runner's settings: the defaults with the full mesh blocking every
/// vertex. On a mesh this small the two-level hierarchy's coarse level
/// costs accuracy for little speed: 3.1% transfer error against ray
/// tracing on the last frame instead of 1.4% (the coarse level is checked
/// against the fine one on the rest pose only, and this sheet's waves
/// travel; before that check, 5%).
pub fn settings() -> PrtSettings {
    let mut settings = PrtSettings::default();
    settings.hierarchy.enabled = false;
    settings
}

pub fn camera() -> Camera {
    Camera {
        eye: Vec3::new(0.9, 3.2, 2.4),
        target: Vec3::new(0.0, 0.2, 0.0),
        fov_degrees: 45.0,
    }
}

/// Runs the animation on the host's GPU and writes the last frame to
/// `out`; `None` without an adapter.
pub fn run(out: &Path) -> Result<Option<Report>, Box<dyn Error>> {
    let Some((wgpu_device, queue, adapter)) = host_device() else {
        return Ok(None);
    };
    let device = Device::from_host(&wgpu_device, &queue);
    let settings = settings();
    let reference = RayTraced { rays: 512, seed: 7 };
    let mut runner = PrtRunner::new(
        &device,
        &positions_at(0.0),
        &triangles(),
        &settings,
        Shadows::On,
        reference,
    )?;
    let env = sky()?;
    let lighting = lighting(settings.bands)?;
    let eye = camera().eye;
    let (mut frame, mut kernel_ms, mut positions) = (FrameOutput::default(), Vec::new(), Vec::new());
    for f in 0..FRAMES {
        positions = positions_at(f as f32 / 30.0);
        kernel_ms.extend(runner.frame(&positions, Some(eye), &lighting, false, &mut frame)?);
    }
    let (transfer_error, _, _) = runner.transfer_error(&positions, Some(eye), &frame)?;
    let exposure = auto_exposure(&frame.radiance, ALBEDO);
    let (w, h) = (320, 240);
    let pixels = render(
        &positions,
        &triangles(),
        &frame.radiance,
        ALBEDO,
        Some(&env),
        &camera(),
        w,
        h,
        exposure,
    )?;
    image::RgbImage::from_fn(w, h, |x, y| image::Rgb(pixels[(y * w + x) as usize])).save(out)?;
    Ok(Some(Report {
        adapter,
        positions,
        radiance: frame.radiance,
        kernel_ms,
        transfer_error,
    }))
}
