//! A host engine's frames with penumbra's displacement-field AO in them: a
//! ball the host rolls across its floor, and the floor's ambient occlusion
//! every frame.
//!
//! The host owns its wgpu device and queue, its meshes (a floor that
//! receives AO, a ball that casts it) and the ball's motion. penumbra builds
//! the ball's displacement field once, on the CPU (from points around the
//! ball, the distance to its surface along each inward direction: Gaitatzes
//! et al.), and uploads it to the host's device; one field serves every
//! rigid motion of the ball. Every frame the host hands penumbra the ball's
//! transform and the floor's AO points, records `FieldAoPass` into its own
//! encoder followed by its own copy of the occlusion masks, submits, and
//! reads per-vertex AO from them.
//!
//! ```sh
//! cargo run --release --example host_field
//! ```

use std::error::Error;
use std::time::Instant;

use glam::{Quat, Vec3};
use penumbra::field::gpu::{FieldAoPass, FieldGroup, GpuField, GpuInstance};
use penumbra::field::{DirectionMapping, DisplacementField, FieldSampling, NO_OWNER, Positional};
use penumbra::gpu::batch::Pass;
use penumbra::gpu::buffers::read_back;
use penumbra::progress::Bar;
use penumbra::raycast::points::vertex_points;
use penumbra::raycast::{AoPoint, AoSettings, VisibilityMasks};
use penumbra::scene::procedural::uv_sphere;
use penumbra::scene::{Mesh, Transform};

pub const FRAMES: usize = 5;
/// Vertices per side of the host's floor.
const GRID: usize = 33;
const BALL_RADIUS: f32 = 0.5;

/// One frame: the host's transform of the ball and penumbra's AO.
pub struct Frame {
    pub transform: Transform,
    /// Per ray of every floor vertex, whether it escaped.
    pub masks: VisibilityMasks,
    /// Per floor vertex, the fraction of its rays that escaped.
    pub ao: Vec<f32>,
    /// The host's frame: prepare, record, submit and read back.
    pub ms: f64,
}

/// What the run produced.
pub struct Report {
    pub adapter: String,
    /// The ball's field, as built on the CPU and uploaded.
    pub field: DisplacementField,
    pub build_ms: f64,
    /// The floor's AO points, one per vertex.
    pub points: Vec<AoPoint>,
    pub settings: AoSettings,
    pub frames: Vec<Frame>,
}

fn main() {
    match run() {
        Ok(Some(r)) => {
            println!(
                "ball's field built in {:.0} ms; floor of {} vertices on {}",
                r.build_ms,
                r.points.len(),
                r.adapter
            );
            for (f, frame) in r.frames.iter().enumerate() {
                let mean = frame.ao.iter().sum::<f32>() / frame.ao.len() as f32;
                let darkest = (0..frame.ao.len()).min_by(|&a, &b| frame.ao[a].total_cmp(&frame.ao[b]));
                let at = floor().positions[darkest.unwrap_or(0)];
                println!(
                    "frame {f}: ball at x = {:+.2}, mean AO {mean:.3}, darkest at ({:+.2}, {:+.2}), {:.1} ms",
                    frame.transform.translation.x, at.x, at.z, frame.ms
                );
            }
        }
        Ok(None) => println!("no GPU adapter: host_field skipped"),
        Err(e) => {
            eprintln!("host_field: {e}");
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

/// The host's floor: a 4 x 4 square at y = 0 on a 33 x 33 vertex grid,
/// facing up.
pub fn floor() -> Mesh {
    let positions = (0..GRID * GRID)
        .map(|k| {
            let (i, j) = ((k % GRID) as f32, (k / GRID) as f32);
            let step = 4.0 / (GRID - 1) as f32;
            Vec3::new(-2.0 + i * step, 0.0, -2.0 + j * step)
        })
        .collect();
    let n = GRID as u32;
    let mut triangles = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            triangles.push([a, a + n, a + n + 1]);
            triangles.push([a, a + n + 1, a + 1]);
        }
    }
    Mesh::new(positions, triangles).expect("the floor is a valid mesh")
}

/// The host's ball, in its own space (centred on the origin).
pub fn ball() -> Mesh {
    uv_sphere("ball", Vec3::ZERO, BALL_RADIUS, 24, 12)
}

/// The host's animation: the ball rolls along x, 0.1 above the floor.
pub fn ball_at(frame: usize) -> Transform {
    let x = -1.5 + 3.0 * frame as f32 / (FRAMES - 1) as f32;
    Transform {
        translation: Vec3::new(x, BALL_RADIUS + 0.1, 0.0),
        rotation: Quat::from_rotation_z(-x / BALL_RADIUS),
        scale: 1.0,
    }
}

/// Runs the animation on the host's GPU; `None` without an adapter.
pub fn run() -> Result<Option<Report>, Box<dyn Error>> {
    let Some((device, queue, adapter)) = host_device() else {
        return Ok(None);
    };
    let floor = floor();
    let settings = AoSettings {
        rays_per_point: 128,
        ..Default::default()
    };

    // penumbra, once: the ball's field, small (64 points around it, maps
    // of 16 x 16 directions at 8 bits), built on the CPU and uploaded to
    // the host's device as a 3D texture; the pass, built for that device.
    let sampling = FieldSampling::new(66, 16, 8, DirectionMapping::Concentric)?;
    let (field, stats) = DisplacementField::build(&ball(), &sampling, "ball", &Bar::hidden())?;
    let gpu_field = GpuField::upload(&device, &queue, &field, Positional::Bilinear)?;
    let mut pass = FieldAoPass::new(&device);
    // The floor's AO points: one per vertex, lifted off the floor. The
    // floor is no caster, so no point skips a field (`NO_OWNER`).
    let points = vertex_points(&floor);
    let owners = vec![NO_OWNER; points.len()];

    // The host's read-back buffer: one occlusion mask per point.
    let mask_bytes = (points.len() * settings.words_per_point() as usize * 4) as u64;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("host readback"),
        size: mask_bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });

    let mut frames = Vec::new();
    for f in 0..FRAMES {
        let start = Instant::now();
        // The host moves the ball; penumbra gets the move as the field's
        // one instance.
        let transform = ball_at(f);
        let groups = [FieldGroup {
            field: &gpu_field,
            instances: vec![GpuInstance::new(&transform, 0)],
        }];
        pass.prepare(&device, &queue, &groups, &points, &owners, &settings)?;

        // The host's frame: penumbra's pass, then the host's copy.
        let mut encoder = device.create_command_encoder(&Default::default());
        pass.record(&device, &mut encoder, None, &groups);
        encoder.copy_buffer_to_buffer(pass.classes(), 0, &readback, 0, pass.mask_bytes());
        queue.submit([encoder.finish()]);

        // Occluded rays' bits back, turned into escaped rays: AO per vertex.
        let occluded: Vec<u32> = read_back(&device, &readback, (pass.mask_bytes() / 4) as usize)?;
        let masks = VisibilityMasks::from_occluded(&occluded, &settings);
        frames.push(Frame {
            transform,
            ao: masks.accessibility(),
            masks,
            ms: start.elapsed().as_secs_f64() * 1e3,
        });
    }
    Ok(Some(Report {
        adapter,
        field,
        build_ms: stats.build_ms,
        points,
        settings,
        frames,
    }))
}
