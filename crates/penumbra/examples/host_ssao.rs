//! A host engine's frame with penumbra's screen-space AO in it.
//!
//! The host owns everything but the AO: its wgpu device and queue, its
//! scene and vertex buffer, its G-buffer render pass and shader (a usual
//! view and projection matrix, written into penumbra's G-buffer layout:
//! camera-space normal and depth, radiance and packed albedo). penumbra's
//! `SsaoPass` is built once for the host's device, prepared with the view
//! and the settings, and recorded into the host's encoder right after the
//! host's render pass; the host copies the AO out and shades with it, here
//! into a PNG.
//!
//! ```sh
//! cargo run --release --example host_ssao -- host-ssao.png
//! ```

use std::error::Error;
use std::path::Path;

use glam::Vec3;
use glam::camera::rh::{proj, view};
use penumbra::geom::color::srgb8;
use penumbra::gpu::batch::Pass;
use penumbra::scene::Camera;
use penumbra::ssao::gbuffer::{ScreenView, pack_albedo};
use penumbra::ssao::gpu::{GBUFFER_FORMAT, SsaoPass};
use penumbra::ssao::{Estimator, SsaoSettings};
use wgpu::util::DeviceExt;

pub const WIDTH: u32 = 320;
pub const HEIGHT: u32 = 240;

/// What the frame produced: the host's G-buffer and penumbra's AO.
pub struct Frame {
    pub adapter: String,
    pub camera: Camera,
    pub settings: SsaoSettings,
    pub geometry: Vec<[f32; 4]>,
    pub shade: Vec<[f32; 4]>,
    /// Filtered accessibility per pixel (background pixels hold no value).
    pub ao: Vec<f32>,
}

fn main() {
    let out = std::env::args().nth(1).unwrap_or_else(|| "host-ssao.png".into());
    match run(Path::new(&out)) {
        Ok(Some(f)) => {
            let surface: Vec<f32> = (0..f.ao.len())
                .filter(|&i| f.geometry[i][3] > 0.0)
                .map(|i| f.ao[i])
                .collect();
            let mean = surface.iter().sum::<f32>() / surface.len().max(1) as f32;
            println!(
                "{out}: {WIDTH}x{HEIGHT} on {}, mean AO {mean:.3} over {} pixels",
                f.adapter,
                surface.len()
            );
        }
        Ok(None) => println!("no GPU adapter: host_ssao skipped"),
        Err(e) => {
            eprintln!("host_ssao: {e}");
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

/// The host's vertex: position, normal, albedo packed as penumbra reads it.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    albedo: f32,
}

/// The host's scene: a floor and three boxes standing on it.
fn scene() -> Vec<Vertex> {
    let mut v = Vec::new();
    let mut quad = |corners: [Vec3; 4], rgb: [u8; 3]| {
        let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]).normalize();
        for i in [0, 1, 2, 0, 2, 3] {
            v.push(Vertex {
                position: corners[i].to_array(),
                normal: n.to_array(),
                albedo: pack_albedo(rgb),
            });
        }
    };
    let s = 3.0;
    quad(
        [
            Vec3::new(-s, 0.0, -s),
            Vec3::new(-s, 0.0, s),
            Vec3::new(s, 0.0, s),
            Vec3::new(s, 0.0, -s),
        ],
        [200, 200, 190],
    );
    for (c, h, rgb) in [
        (Vec3::new(-0.8, 0.0, 0.0), 1.2, [190, 70, 60]),
        (Vec3::new(0.5, 0.0, -0.6), 0.7, [70, 120, 190]),
        (Vec3::new(0.7, 0.0, 0.8), 0.4, [90, 170, 90]),
    ] {
        let (lo, hi) = (c - Vec3::new(0.35, 0.0, 0.35), c + Vec3::new(0.35, h, 0.35));
        let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        quad(
            [
                p(lo.x, hi.y, lo.z),
                p(lo.x, hi.y, hi.z),
                p(hi.x, hi.y, hi.z),
                p(hi.x, hi.y, lo.z),
            ],
            rgb,
        );
        quad(
            [
                p(lo.x, lo.y, hi.z),
                p(hi.x, lo.y, hi.z),
                p(hi.x, hi.y, hi.z),
                p(lo.x, hi.y, hi.z),
            ],
            rgb,
        );
        quad(
            [
                p(hi.x, lo.y, lo.z),
                p(lo.x, lo.y, lo.z),
                p(lo.x, hi.y, lo.z),
                p(hi.x, hi.y, lo.z),
            ],
            rgb,
        );
        quad(
            [
                p(lo.x, lo.y, lo.z),
                p(lo.x, lo.y, hi.z),
                p(lo.x, hi.y, hi.z),
                p(lo.x, hi.y, lo.z),
            ],
            rgb,
        );
        quad(
            [
                p(hi.x, lo.y, hi.z),
                p(hi.x, lo.y, lo.z),
                p(hi.x, hi.y, lo.z),
                p(hi.x, hi.y, hi.z),
            ],
            rgb,
        );
    }
    v
}

/// The host's G-buffer shader. penumbra's camera space looks down +z (x
/// right, y up); the host's view space looks down -z, so z flips.
const HOST_SHADER: &str = r#"
struct Host { view: mat4x4<f32>, proj: mat4x4<f32>, light: vec4<f32> }
@group(0) @binding(0) var<uniform> host: Host;

struct In { @location(0) p: vec3<f32>, @location(1) n: vec3<f32>, @location(2) albedo: f32 }
struct Out {
    @builtin(position) clip: vec4<f32>,
    @location(0) view_pos: vec3<f32>,
    @location(1) @interpolate(flat) view_n: vec3<f32>,
    @location(2) @interpolate(flat) world_n: vec3<f32>,
    @location(3) @interpolate(flat) albedo: f32,
}

@vertex
fn vs(v: In) -> Out {
    let vp = host.view * vec4<f32>(v.p, 1.0);
    var o: Out;
    o.clip = host.proj * vp;
    o.view_pos = vp.xyz;
    o.view_n = (host.view * vec4<f32>(v.n, 0.0)).xyz;
    o.world_n = v.n;
    o.albedo = v.albedo;
    return o;
}

struct GBuffer { @location(0) geometry: vec4<f32>, @location(1) shade: vec4<f32> }

@fragment
fn fs(i: Out) -> GBuffer {
    let p = vec3<f32>(i.view_pos.xy, -i.view_pos.z);
    var n = normalize(vec3<f32>(i.view_n.xy, -i.view_n.z));
    var world_n = i.world_n;
    if (dot(n, p) > 0.0) {
        n = -n;
        world_n = -world_n;
    }
    let b = u32(i.albedo);
    let albedo = vec3<f32>(f32(b & 255u), f32((b >> 8u) & 255u), f32((b >> 16u) & 255u)) / 255.0;
    let lit = albedo * (0.3 + 0.7 * max(dot(world_n, host.light.xyz), 0.0));
    return GBuffer(vec4<f32>(n, p.z), vec4<f32>(lit, i.albedo));
}
"#;

/// The host's uniform.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct HostUniform {
    view: [f32; 16],
    proj: [f32; 16],
    light: [f32; 4],
}

/// Renders the host's frame with penumbra's SSAO recorded into it and
/// writes the AO to `out` (grey, background transparent); `None` without
/// an adapter.
pub fn run(out: &Path) -> Result<Option<Frame>, Box<dyn Error>> {
    let Some((device, queue, adapter)) = host_device() else {
        return Ok(None);
    };
    let camera = Camera {
        eye: Vec3::new(2.6, 2.4, 3.6),
        target: Vec3::new(0.0, 0.3, 0.0),
        fov_degrees: 45.0,
    };
    let targets = HostTargets::new(&device);
    let vertices = scene();
    let draw = HostDraw::new(&device, &camera, &vertices);

    // penumbra: built once for the host's device, prepared per frame.
    let settings = SsaoSettings::new(Estimator::Importance, 16, 0.6);
    let mut ssao = SsaoPass::new(&device);
    ssao.prepare(
        &device,
        &queue,
        &ScreenView::new(&camera, WIDTH, HEIGHT),
        &settings,
        None,
    )?;
    let gbuffer = ssao.gbuffer_bind_group(&device, &targets.geometry_view, &targets.shade_view);

    // The host's frame: its render pass, penumbra's kernels, its copies.
    let mut encoder = device.create_command_encoder(&Default::default());
    draw.record(&mut encoder, &targets);
    ssao.record(&mut encoder, &gbuffer, None);
    let pixels = (WIDTH * HEIGHT) as u64;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("host readback"),
        size: pixels * 36,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    encoder.copy_buffer_to_buffer(ssao.ao(), 0, &readback, 0, pixels * 4);
    for (k, texture) in [&targets.geometry, &targets.shade].into_iter().enumerate() {
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: pixels * 4 + k as u64 * pixels * 16,
                    bytes_per_row: Some(WIDTH * 16),
                    rows_per_image: Some(HEIGHT),
                },
            },
            targets.extent,
        );
    }
    queue.submit([encoder.finish()]);
    let words: Vec<f32> = penumbra::gpu::buffers::read_back(&device, &readback, (pixels * 9) as usize)?;
    let (ao, rest) = words.split_at(pixels as usize);
    let (geometry, shade) = rest.split_at(4 * pixels as usize);
    let frame = Frame {
        adapter,
        camera,
        settings,
        geometry: bytemuck::cast_slice(geometry).to_vec(),
        shade: bytemuck::cast_slice(shade).to_vec(),
        ao: ao.to_vec(),
    };
    write_png(out, &frame)?;
    Ok(Some(frame))
}

/// The host's shading times the AO, as an sRGB PNG (background sky blue).
fn write_png(out: &Path, f: &Frame) -> Result<(), Box<dyn Error>> {
    let mut img = image::RgbImage::new(WIDTH, HEIGHT);
    for (i, p) in img.pixels_mut().enumerate() {
        let rgb = if f.geometry[i][3] > 0.0 {
            let ao = f.ao[i].clamp(0.0, 1.0);
            [0, 1, 2].map(|c| f.shade[i][c] * ao)
        } else {
            [0.45, 0.6, 0.8]
        };
        *p = image::Rgb(rgb.map(srgb8));
    }
    img.save(out)?;
    Ok(())
}

/// The host's render targets: penumbra's G-buffer layout and a depth buffer.
struct HostTargets {
    extent: wgpu::Extent3d,
    geometry: wgpu::Texture,
    shade: wgpu::Texture,
    geometry_view: wgpu::TextureView,
    shade_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
}

impl HostTargets {
    fn new(device: &wgpu::Device) -> HostTargets {
        let extent = wgpu::Extent3d {
            width: WIDTH,
            height: HEIGHT,
            depth_or_array_layers: 1,
        };
        let texture = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: extent,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let color = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let geometry = texture("host geometry", GBUFFER_FORMAT, color);
        let shade = texture("host shade", GBUFFER_FORMAT, color);
        let depth = texture(
            "host depth",
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        HostTargets {
            extent,
            geometry_view: geometry.create_view(&Default::default()),
            shade_view: shade.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            geometry,
            shade,
        }
    }
}

/// The host's draw: pipeline, vertex buffer, uniform.
struct HostDraw {
    pipeline: wgpu::RenderPipeline,
    vertices: wgpu::Buffer,
    count: u32,
    group: wgpu::BindGroup,
}

impl HostDraw {
    fn new(device: &wgpu::Device, camera: &Camera, vertices: &[Vertex]) -> HostDraw {
        let aspect = WIDTH as f32 / HEIGHT as f32;
        let uniform = HostUniform {
            view: view::look_at_mat4(camera.eye, camera.target, Vec3::Y).to_cols_array(),
            // WebGPU's clip space: z in [0, 1], y up.
            proj: proj::directx::perspective(camera.fov_degrees.to_radians(), aspect, 0.05, 50.0).to_cols_array(),
            light: Vec3::new(0.4, 1.0, 0.3).normalize().extend(0.0).to_array(),
        };
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let uniform = init(
            "host uniform",
            bytemuck::bytes_of(&uniform),
            wgpu::BufferUsages::UNIFORM,
        );
        let vertex_buffer = init(
            "host vertices",
            bytemuck::cast_slice(vertices),
            wgpu::BufferUsages::VERTEX,
        );
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("host g-buffer"),
            source: wgpu::ShaderSource::Wgsl(HOST_SHADER.into()),
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("host g-buffer"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<Vertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32],
                })],
            },
            primitive: Default::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(GBUFFER_FORMAT.into()), Some(GBUFFER_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("host uniform"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            }],
        });
        HostDraw {
            pipeline,
            vertices: vertex_buffer,
            count: vertices.len() as u32,
            group,
        }
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, t: &HostTargets) {
        let clear = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("host g-buffer"),
            color_attachments: &[clear(&t.geometry_view), clear(&t.shade_view)],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &t.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.draw(0..self.count, 0..1);
    }
}
