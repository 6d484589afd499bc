//! A host engine's frame with penumbra's Whitted ray tracer drawing into a
//! texture the host owns.
//!
//! The host owns its wgpu device and queue and an `rgba32float` texture
//! (a storage binding, which a compute pass may write; a copy source, to
//! read it back; a texture binding, to sample or blit it as an engine
//! would). penumbra builds the scene's kd-tree on the CPU and uploads it
//! with the scene's shading data to the host's device, once. For the frame
//! the host prepares penumbra's two passes, `WhittedPass` (a ray tree per
//! pixel) and `WhittedImagePass` (each pixel's linear radiance into the
//! host's texture, alpha 1), records both into its own encoder followed by
//! its own copy of the texture, submits, and writes the image as a PNG.
//!
//! ```sh
//! cargo run --release --example host_whitted -- assets/raytrace/checker-spheres.json host-whitted.png
//! ```

use std::error::Error;
use std::path::Path;
use std::time::Instant;

use penumbra::accel::kdtree::gpu::GpuKdTree;
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::geom::color::srgb8;
use penumbra::gpu::batch::Pass;
use penumbra::gpu::buffers::read_back;
use penumbra::scene::{Camera, load_scene_shaded};
use penumbra::whitted::gpu::WhittedPass;
use penumbra::whitted::texture::{IMAGE_FORMAT, WhittedImagePass};
use penumbra::whitted::{LightingSettings, RenderScene, WhittedSettings};

pub const WIDTH: u32 = 160;
pub const HEIGHT: u32 = 120;

/// What the frame produced.
pub struct Report {
    pub adapter: String,
    pub camera: Camera,
    pub settings: WhittedSettings,
    /// The host's texture, read back: linear RGBA per pixel, row-major
    /// from the top left.
    pub texels: Vec<[f32; 4]>,
    /// The host's frame: prepare, record, submit and read back (the
    /// pipelines compile on this first use).
    pub ms: f64,
}

fn main() {
    let mut args = std::env::args().skip(1);
    let scene = args
        .next()
        .unwrap_or_else(|| "assets/raytrace/checker-spheres.json".into());
    let out = args.next().unwrap_or_else(|| "host-whitted.png".into());
    match run(Path::new(&scene), Path::new(&out)) {
        Ok(Some(r)) => println!("{out}: {WIDTH}x{HEIGHT} on {}, {:.1} ms", r.adapter, r.ms),
        Ok(None) => println!("no GPU adapter: host_whitted skipped"),
        Err(e) => {
            eprintln!("host_whitted: {e}");
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

/// Renders the scene file `scene_file` from its camera into the host's
/// texture and writes it to `out` (sRGB, clamped); `None` without an
/// adapter.
pub fn run(scene_file: &Path, out: &Path) -> Result<Option<Report>, Box<dyn Error>> {
    let Some((device, queue, adapter)) = host_device() else {
        return Ok(None);
    };
    let scene = load_scene_shaded(scene_file)?;
    let camera = scene.camera.ok_or("the scene file names no camera")?;
    let settings = WhittedSettings::default();

    // The host's texture.
    let extent = wgpu::Extent3d {
        width: WIDTH,
        height: HEIGHT,
        depth_or_array_layers: 1,
    };
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("host image"),
        size: extent,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: IMAGE_FORMAT,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let view = texture.create_view(&Default::default());

    // penumbra, once: the scene's shading data and kd-tree on the host's
    // device, and the passes built for it.
    let scene = RenderScene::new(&scene, 0, &LightingSettings::default())?;
    let tree = KdTree::build(&scene.mesh, &KdTreeSettings::default())?;
    let gpu_tree = GpuKdTree::upload(&device, &tree)?;
    let mut whitted = WhittedPass::new(&device);
    whitted.prepare_scene(&device, &queue, &scene)?;
    let mut to_texture = WhittedImagePass::new(&device);

    // penumbra, per frame: the camera's pixels, and the texture they go to.
    let start = Instant::now();
    let params = scene.params(&camera, WIDTH, HEIGHT, &settings)?;
    whitted.prepare(&device, &queue, &params)?;
    to_texture.prepare(&device, &queue, &params, whitted.pixels(), &view)?;

    // The host's frame: penumbra's two passes, then its own copy of its
    // texture (rows padded to WebGPU's copy alignment).
    let row_bytes = (WIDTH * 16).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("host readback"),
        size: (row_bytes * HEIGHT) as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    whitted.record(&mut encoder, None, &gpu_tree);
    to_texture.record(&mut encoder, None);
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row_bytes),
                rows_per_image: Some(HEIGHT),
            },
        },
        extent,
    );
    queue.submit([encoder.finish()]);
    let padded: Vec<[f32; 4]> = read_back(&device, &readback, (row_bytes / 16 * HEIGHT) as usize)?;
    let texels: Vec<[f32; 4]> = padded
        .chunks_exact((row_bytes / 16) as usize)
        .flat_map(|row| &row[..WIDTH as usize])
        .copied()
        .collect();
    let ms = start.elapsed().as_secs_f64() * 1e3;

    let png = image::RgbImage::from_fn(WIDTH, HEIGHT, |x, y| {
        let [r, g, b, _] = texels[(y * WIDTH + x) as usize];
        image::Rgb([r, g, b].map(srgb8))
    });
    png.save(out)?;
    Ok(Some(Report {
        adapter,
        camera,
        settings,
        texels,
        ms,
    }))
}
