//! The SSAO frame on the GPU: `GBufferPass` (render pipeline of
//! `wgsl/gbuffer.wgsl`) and `SsaoPass` (the compute kernels of
//! `wgsl/ssao_estimate.wgsl`, `ssao_filter.wgsl`, `ssao_indirect.wgsl`).
//!
//! Like the other passes they are built once for a host's `&wgpu::Device`
//! and record into the host's `CommandEncoder`; a host with its own
//! G-buffer binds its textures with `SsaoPass::gbuffer_bind_group` (two
//! `Rgba32Float` textures in the layout of `gbuffer`). `run_frame` is the
//! blocking convenience for the CLI, tests and benches.

use std::sync::Arc;
use std::time::Instant;

use bytemuck::{Pod, Zeroable};

use super::estimators::{Family, SampleTable, SsaoUniforms};
use super::gbuffer::{GBuffer, ScreenView, ViewUniform};
use super::surfaces::GBufferSurfaces;
use super::{ShadeSettings, SsaoFrame, SsaoSettings, Timings, final_ao};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::gpu::batch::Pass;
use crate::gpu::buffers::{
    KeptGroup, check_buffer_size, check_storage_size, read_back, read_buffer, storage_buffer, uniform_buffer,
    zeroed_buffer,
};
use crate::gpu::device::Timing;
use crate::gpu::device::elapsed_ms;
use crate::gpu::kernels::{Kernels, PipelineLog, Pipelines, compute_pipelines, record_dispatch};
use crate::gpu::layout::{Io, io_layout, layout, storage_entry, texture_entry, uniform_entry_for};
use crate::gpu::timer::PassTimer;
use crate::scene::{Camera, Light, Mesh};

/// Format of both G-buffer colour targets.
pub const GBUFFER_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Workgroup side of the per-pixel kernels (8 x 8).
pub const TILE: u32 = 8;

/// One vertex of the G-buffer's vertex buffer (three per triangle).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct GBufferVertex {
    /// World-space position.
    pub position: [f32; 3],
    /// Unit world face normal of its triangle (zero for a degenerate one).
    pub normal: [f32; 3],
    /// Packed albedo of its triangle (`gbuffer::pack_albedo`).
    pub albedo: f32,
}

/// A mesh as the G-buffer pass draws it: unindexed, with the unit face
/// normal and packed albedo on every vertex.
pub struct SceneVertices {
    /// The vertex buffer: `GBufferVertex`es, three per triangle.
    pub buffer: wgpu::Buffer,
    /// Vertices in it: three per triangle.
    pub vertex_count: u32,
}

impl SceneVertices {
    /// Uploads `mesh` (world space) with one packed albedo per triangle
    /// (`GBufferSurfaces::albedos`); fails on an
    /// invalid mesh or one beyond the device's largest buffer.
    pub fn upload(device: &wgpu::Device, mesh: &Mesh, albedos: &[f32]) -> Result<SceneVertices> {
        mesh.validate()?;
        if albedos.len() != mesh.triangles.len() {
            return Err(Error::internal("one albedo per triangle"));
        }
        let mut vertices = Vec::with_capacity(mesh.triangles.len() * 3);
        for (t, &albedo) in albedos.iter().enumerate() {
            let n = mesh.unit_face_normal(t).to_array();
            for p in mesh.triangle(t) {
                vertices.push(GBufferVertex {
                    position: p.to_array(),
                    normal: n,
                    albedo,
                });
            }
        }
        let bytes: &[u8] = bytemuck::cast_slice(&vertices);
        if bytes.len() as u64 > device.limits().max_buffer_size {
            return Err(Error::Device(format!(
                "the G-buffer's vertex buffer needs {:.1} MiB; this device allows {:.1} MiB per buffer",
                bytes.len() as f64 / 1048576.0,
                device.limits().max_buffer_size as f64 / 1048576.0
            )));
        }
        use wgpu::util::DeviceExt;
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("g-buffer vertices"),
            contents: bytes,
            usage: wgpu::BufferUsages::VERTEX,
        });
        Ok(SceneVertices {
            buffer,
            vertex_count: vertices.len() as u32,
        })
    }
}

/// The G-buffer's textures: geometry and shade (`Rgba32Float`, the layout
/// of `gbuffer`), and the depth attachment of the z-test.
pub struct GBufferTargets {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Camera-space normal and depth per pixel.
    pub geometry: wgpu::Texture,
    /// Direct radiance and packed albedo per pixel.
    pub shade: wgpu::Texture,
    /// The z-test's attachment (`Depth32Float`, reversed Z: nearer is larger).
    pub depth: wgpu::Texture,
}

impl GBufferTargets {
    /// Targets of `width` x `height` pixels; fails where the device's textures
    /// or read-back buffers cannot hold them.
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Result<GBufferTargets> {
        let max = device.limits().max_texture_dimension_2d;
        if width > max || height > max {
            return Err(Error::Device(format!(
                "{width}x{height} exceeds this device's largest texture side, {max}"
            )));
        }
        let texture = |label: &str, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        // A texture's rows, padded, are read back through one buffer.
        let padded_row = (16 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) as u64;
        check_buffer_size(device, "the G-buffer's read-back", padded_row * height as u64)?;
        let color = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST;
        Ok(GBufferTargets {
            width,
            height,
            geometry: texture("g-buffer geometry", GBUFFER_FORMAT, color),
            shade: texture("g-buffer shade", GBUFFER_FORMAT, color),
            depth: texture("g-buffer depth", DEPTH_FORMAT, wgpu::TextureUsages::RENDER_ATTACHMENT),
        })
    }

    /// Writes a CPU G-buffer into the textures (to run the kernels on it).
    pub fn upload(&self, queue: &wgpu::Queue, gb: &GBuffer) {
        for (texture, data) in [(&self.geometry, &gb.geometry), (&self.shade, &gb.shade)] {
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(data),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(16 * self.width),
                    rows_per_image: Some(self.height),
                },
                self.extent(),
            );
        }
    }

    fn extent(&self) -> wgpu::Extent3d {
        wgpu::Extent3d {
            width: self.width,
            height: self.height,
            depth_or_array_layers: 1,
        }
    }

    /// Bytes per row of a readback (rows padded to 256 bytes).
    fn padded_row(&self) -> u32 {
        (16 * self.width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
    }

    /// Reads both textures back (blocking), each through its own buffer
    /// (`new` checked that one fits: both together need not).
    pub fn read(&self, ctx: &GpuContext) -> Result<GBuffer> {
        let row = self.padded_row() as u64;
        let bytes = row * self.height as u64;
        let per_row = (row / 16) as usize;
        let read = |texture: &wgpu::Texture| -> Result<Vec<[f32; 4]>> {
            let readback = zeroed_buffer(
                &ctx.device,
                "g-buffer readback",
                bytes,
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            );
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            encoder.copy_texture_to_buffer(
                wgpu::TexelCopyTextureInfo {
                    texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::TexelCopyBufferInfo {
                    buffer: &readback,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row as u32),
                        rows_per_image: Some(self.height),
                    },
                },
                self.extent(),
            );
            ctx.queue.submit([encoder.finish()]);
            let raw: Vec<[f32; 4]> = read_back(&ctx.device, &readback, (bytes / 16) as usize)?;
            Ok((0..self.height as usize)
                .flat_map(|y| raw[y * per_row..y * per_row + self.width as usize].iter().copied())
                .collect())
        };
        Ok(GBuffer {
            width: self.width,
            height: self.height,
            geometry: read(&self.geometry)?,
            shade: read(&self.shade)?,
        })
    }
}

/// The G-buffer render pipeline: `new`, colours per triangle
/// (`wgsl/gbuffer.wgsl`); `textured`, colour maps and cut-outs read per
/// pixel (`wgsl/gbuffer_textured.wgsl`, which also binds the surfaces'
/// words).
pub struct GBufferPass {
    /// Bind group 0 of the render pipeline: one `ViewUniform` buffer, and
    /// for the textured pipeline the words of `GBufferSurfaces::words`.
    pub view_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    textured: bool,
}

/// The textured `GBufferPass`, cached on a context apart from the plain one.
struct TexturedGBufferPass(GBufferPass);

impl GBufferPass {
    /// Builds the render pipeline of `wgsl/gbuffer.wgsl` for `device`.
    pub fn new(device: &wgpu::Device) -> GBufferPass {
        GBufferPass::build(device, false)
    }

    /// Builds the render pipeline of `wgsl/gbuffer_textured.wgsl` for
    /// `device`: what scenes with colour maps or cut-outs are drawn with.
    pub fn textured(device: &wgpu::Device) -> GBufferPass {
        GBufferPass::build(device, true)
    }

    fn build(device: &wgpu::Device, textured: bool) -> GBufferPass {
        let mut entries = vec![uniform_entry_for(0, wgpu::ShaderStages::VERTEX_FRAGMENT)];
        if textured {
            entries.push(wgpu::BindGroupLayoutEntry {
                visibility: wgpu::ShaderStages::FRAGMENT,
                ..storage_entry(1, true)
            });
        }
        let view_layout = layout(device, "g-buffer view", &entries);
        let (module, vs, fs) = if textured {
            (
                &crate::gpu::wgsl::GBUFFER_TEXTURED_MODULE,
                "gbuffer_textured_vs",
                "gbuffer_textured_fs",
            )
        } else {
            (&crate::gpu::wgsl::GBUFFER_MODULE, "gbuffer_vs", "gbuffer_fs")
        };
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(module.name),
            source: wgpu::ShaderSource::Wgsl(module.source().into()),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("g-buffer"),
            bind_group_layouts: &[Some(&view_layout)],
            immediate_size: 0,
        });
        let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32];
        let target = Some(wgpu::ColorTargetState {
            format: GBUFFER_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("g-buffer"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some(vs),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<GBufferVertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attributes,
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                // Both sides: meshes have inconsistent winding.
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some(fs),
                compilation_options: Default::default(),
                targets: &[target.clone(), target],
            }),
            multiview_mask: None,
            cache: None,
        });
        GBufferPass {
            view_layout,
            pipeline,
            textured,
        }
    }

    /// Whether this is the textured pipeline (`textured`).
    pub fn is_textured(&self) -> bool {
        self.textured
    }

    /// Bind group of a `ViewUniform` buffer, and for the textured pipeline
    /// of a storage buffer of `GBufferSurfaces::words` (`surfaces`; the
    /// plain pipeline binds none).
    pub fn view_bind_group(
        &self,
        device: &wgpu::Device,
        view: &wgpu::Buffer,
        surfaces: Option<&wgpu::Buffer>,
    ) -> Result<wgpu::BindGroup> {
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: view.as_entire_binding(),
        }];
        match (self.textured, surfaces) {
            (true, Some(words)) => entries.push(wgpu::BindGroupEntry {
                binding: 1,
                resource: words.as_entire_binding(),
            }),
            (false, None) => {}
            _ => {
                return Err(Error::internal(
                    "the textured G-buffer pipeline, and only it, binds the surfaces",
                ));
            }
        }
        Ok(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("g-buffer view"),
            layout: &self.view_layout,
            entries: &entries,
        }))
    }

    /// Records the render pass: clears the targets and draws the mesh.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
        vertices: &SceneVertices,
        targets: &GBufferTargets,
        view: &wgpu::BindGroup,
    ) {
        let geometry = targets.geometry.create_view(&Default::default());
        let shade = targets.shade.create_view(&Default::default());
        let depth = targets.depth.create_view(&Default::default());
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
            label: Some("g-buffer"),
            color_attachments: &[clear(&geometry), clear(&shade)],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, view, &[]);
        pass.set_vertex_buffer(0, vertices.buffer.slice(..));
        pass.draw(0..vertices.vertex_count, 0..1);
    }
}

/// The SSAO kernels (one entry point each).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SsaoKernel {
    PackDepth,
    Points,
    March,
    Disk,
    Indirect,
    FilterAoRows,
    FilterAoColumns,
    Upsample,
    FilterIndirect,
    Compose,
}

impl SsaoKernel {
    fn estimator(family: Family) -> SsaoKernel {
        match family {
            Family::Points => SsaoKernel::Points,
            Family::March => SsaoKernel::March,
            Family::Disk => SsaoKernel::Disk,
        }
    }
}

/// The SSAO io bind group: params, sample table, raw and filtered AO, raw
/// and filtered indirect light, image, packed depth, the AO filter's
/// scratch (see `wgsl/ssao_common.wgsl`).
const SSAO_IO: &[Io] = &[
    Io::Uniform(0, "ssao params", std::mem::size_of::<SsaoUniforms>() as u64),
    Io::In(1, "ssao sample table"),
    Io::Out(2, "ssao ao"),
    Io::Out(3, "ssao ao filtered"),
    Io::Out(4, "ssao indirect"),
    Io::Out(5, "ssao indirect filtered"),
    Io::Out(6, "ssao image"),
    Io::Out(7, "ssao depth"),
    Io::Out(8, "ssao filter scratch"),
];

/// The layouts and pipelines of the SSAO kernels for one device.
pub struct SsaoKernels {
    /// Bind group 0 of every SSAO kernel: the geometry and shade textures
    /// (`SsaoPass::gbuffer_bind_group`).
    pub gbuffer_layout: wgpu::BindGroupLayout,
    /// Bind group 1: parameters, sample table and the frame's buffers.
    pub io_layout: wgpu::BindGroupLayout,
    /// By module: estimate (pack depth, points, march, disk), indirect
    /// (indirect, compose), filter (ao rows, ao columns, upsample, indirect).
    estimate: Pipelines,
    indirect: Pipelines,
    filter: Pipelines,
}

impl Kernels for SsaoKernels {
    fn build(device: &wgpu::Device, log: &Arc<PipelineLog>) -> SsaoKernels {
        let texture = |binding| texture_entry(binding, wgpu::TextureViewDimension::D2, false);
        let gbuffer_layout = layout(device, "ssao g-buffer", &[texture(0), texture(1)]);
        let io_layout = io_layout(device, "ssao io", SSAO_IO);
        let layouts = [&gbuffer_layout, &io_layout];
        let build = |module, entries: &[&'static str]| compute_pipelines(device, module, &layouts, entries, log);
        let estimate = ["ssao_pack_depth", "ssao_points", "ssao_march", "ssao_disk"];
        let filters = [
            "ssao_filter_ao_rows",
            "ssao_filter_ao_columns",
            "ssao_upsample",
            "ssao_filter_indirect",
        ];
        SsaoKernels {
            estimate: build(&crate::gpu::wgsl::SSAO_ESTIMATE_MODULE, &estimate),
            indirect: build(
                &crate::gpu::wgsl::SSAO_INDIRECT_MODULE,
                &["ssao_indirect", "ssao_compose"],
            ),
            filter: build(&crate::gpu::wgsl::SSAO_FILTER_MODULE, &filters),
            gbuffer_layout,
            io_layout,
        }
    }
}

impl SsaoKernels {
    /// The pipeline of `kernel`, compiled on first use.
    fn pipeline(&self, kernel: SsaoKernel) -> crate::gpu::kernels::Kernel<'_> {
        use SsaoKernel::*;
        match kernel {
            PackDepth => self.estimate.get(0),
            Points => self.estimate.get(1),
            March => self.estimate.get(2),
            Disk => self.estimate.get(3),
            Indirect => self.indirect.get(0),
            Compose => self.indirect.get(1),
            FilterAoRows => self.filter.get(0),
            FilterAoColumns => self.filter.get(1),
            Upsample => self.filter.get(2),
            FilterIndirect => self.filter.get(3),
        }
    }
}

/// What `SsaoPass::record` records, in order.
enum Action {
    /// A kernel over every pixel (true) or the estimation grid.
    Run(SsaoKernel, SsaoStep, bool),
    /// Binding to binding at a byte offset, that many bytes or all (a
    /// filter turned off).
    Copy(u32, u32, u64, Option<u64>),
}

/// A step of a frame, as timings split it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SsaoStep {
    /// Rasterising the G-buffer and packing its depths.
    GBuffer,
    /// The estimator.
    Estimate,
    /// The AO filter's two passes and, at half resolution, the upsampling.
    Filter,
    /// The indirect light and its filter.
    Indirect,
    /// Composing the shaded image.
    Compose,
}

/// The SSAO compute pass over a G-buffer (two `Rgba32Float` textures in
/// the layout of `gbuffer`): `prepare` uploads a frame's parameters and
/// sample table into buffers it keeps, `record` records the frame's kernels
/// into the caller's encoder, whose G-buffer the host may render itself.
pub struct SsaoPass {
    kernels: Arc<SsaoKernels>,
    io: KeptGroup,
    size: (u32, u32),
    /// The estimation grid (`SsaoUniforms::lo_width`, `lo_height`) and its scale.
    grid: (u32, u32),
    scale: u32,
    family: Family,
    filter: bool,
    shade: bool,
}

impl Pass for SsaoPass {
    type Kernels = SsaoKernels;

    fn with_kernels(device: &wgpu::Device, kernels: Arc<SsaoKernels>) -> SsaoPass {
        SsaoPass {
            kernels,
            io: KeptGroup::for_io(device, "ssao io", SSAO_IO),
            size: (0, 0),
            grid: (0, 0),
            scale: 1,
            family: Family::Points,
            filter: false,
            shade: false,
        }
    }
}

impl SsaoPass {
    /// Uploads one frame's parameters and sample table for a `view` of the
    /// G-buffer; with `shade`, the indirect light and shaded image too.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        view: &ScreenView,
        settings: &SsaoSettings,
        shade: Option<&ShadeSettings>,
    ) -> Result<()> {
        settings.validate()?;
        let (w, h) = (view.width, view.height);
        let max_groups = device.limits().max_compute_workgroups_per_dimension;
        if w.div_ceil(TILE) > max_groups || h.div_ceil(TILE) > max_groups {
            return Err(Error::Device(format!(
                "{w}x{h} needs more workgroups than this device allows"
            )));
        }
        let pixels = w as u64 * h as u64;
        check_storage_size(device, "SSAO pixels", pixels * 16)?;
        let table = SampleTable::build(settings)?;
        let params = SsaoUniforms::new(view, settings, &table, shade.copied().unwrap_or_default());
        let rgba = if shade.is_some() { pixels * 16 } else { 16 };
        let cells = params.cells() as u64;
        let io = &mut self.io;
        io.write(device, queue, 0, bytemuck::bytes_of(&params))?;
        io.write(device, queue, 1, bytemuck::cast_slice(&table.entries))?;
        for (binding, bytes) in [
            (2, cells * 4),
            (3, pixels * 4),
            (4, rgba),
            (5, rgba),
            (6, rgba),
            (7, pixels * 4),
            (8, cells * 12),
        ] {
            io.reserve(device, binding, bytes)?;
        }
        io.update(device, &self.kernels.io_layout);
        self.size = (w, h);
        self.grid = (params.lo_width, params.lo_height);
        self.scale = params.scale;
        self.family = table.family;
        self.filter = settings.filter;
        self.shade = shade.is_some();
        Ok(())
    }

    /// Bind group 0: the two G-buffer textures (`Rgba32Float`).
    pub fn gbuffer_bind_group(
        &self,
        device: &wgpu::Device,
        geometry: &wgpu::TextureView,
        shade: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("ssao g-buffer"),
            layout: &self.kernels.gbuffer_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(geometry),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(shade),
                },
            ],
        })
    }

    /// Records the prepared frame after its G-buffer: packed depth,
    /// estimator, AO filter (and at half resolution the upsampling) and,
    /// with shading, the indirect light and image; each kernel gets the
    /// next timestamps of `timer`. Returns the step each timed kernel
    /// belongs to.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        gbuffer: &wgpu::BindGroup,
        mut timer: Option<&mut PassTimer>,
    ) -> Vec<SsaoStep> {
        use Action::{Copy, Run};
        use SsaoKernel::*;
        let (pixels, grid, filter) = (true, false, SsaoStep::Filter);
        let mut actions = vec![
            // The packed depth is part of the G-buffer's cost.
            Run(PackDepth, SsaoStep::GBuffer, pixels),
            Run(SsaoKernel::estimator(self.family), SsaoStep::Estimate, grid),
        ];
        // The filtered grid: `ao_out` at full resolution, else the
        // scratch buffer's third part (the upsampling's input).
        let (to, offset) = match self.scale {
            1 => (3, 0),
            _ => (8, 8 * self.grid.0 as u64 * self.grid.1 as u64),
        };
        match self.filter {
            true => actions.extend([Run(FilterAoRows, filter, grid), Run(FilterAoColumns, filter, grid)]),
            false => actions.push(Copy(2, to, offset, Some(4 * self.grid.0 as u64 * self.grid.1 as u64))),
        }
        if self.scale != 1 {
            // One invocation per cell, for its 2x2 pixels.
            actions.push(Run(Upsample, filter, grid));
        }
        if self.shade {
            actions.extend([
                Run(Indirect, SsaoStep::Indirect, pixels),
                match self.filter {
                    true => Run(FilterIndirect, SsaoStep::Indirect, pixels),
                    false => Copy(4, 5, 0, None),
                },
                Run(Compose, SsaoStep::Compose, pixels),
            ]);
        }
        let mut steps = Vec::new();
        for action in actions {
            match action {
                Run(kernel, step, every_pixel) => {
                    let (w, h) = if every_pixel { self.size } else { self.grid };
                    let writes = timer.as_mut().and_then(|t| t.next_pass());
                    let pipeline = self.kernels.pipeline(kernel);
                    let groups = (w.div_ceil(TILE), h.div_ceil(TILE));
                    record_dispatch(encoder, "ssao", writes, pipeline, &[gbuffer, self.io.group()], groups);
                    steps.push(step);
                }
                Copy(from, to, offset, bytes) => {
                    encoder.copy_buffer_to_buffer(self.io.buffer(from), 0, self.io.buffer(to), offset, bytes)
                }
            }
        }
        steps
    }

    /// The estimator's output per cell of the estimation grid, before
    /// filtering (f32; `SsaoUniforms::cells` of them).
    pub fn raw_ao(&self) -> &wgpu::Buffer {
        self.io.buffer(2)
    }

    /// Accessibility per pixel after the filter (f32; clamp to [0, 1] and
    /// ignore background pixels, as `final_ao` does).
    pub fn ao(&self) -> &wgpu::Buffer {
        self.io.buffer(3)
    }

    /// Filtered indirect light L~ per pixel (rgb, count), with shading.
    pub fn indirect(&self) -> &wgpu::Buffer {
        self.io.buffer(5)
    }

    /// Linear RGBA of the shaded image, with shading.
    pub fn image(&self) -> &wgpu::Buffer {
        self.io.buffer(6)
    }
}

/// Where the G-buffer of `run_frame` comes from.
pub enum GBufferSource<'a> {
    /// Rasterise a mesh (every triangle occludes and receives).
    Render {
        /// The mesh drawn, world space.
        mesh: &'a Mesh,
        /// The camera it is seen through.
        camera: &'a Camera,
        /// The direct term's lights (at most `gbuffer::MAX_LIGHTS`; none: a
        /// default directional light).
        lights: &'a [Light],
        /// What the mesh's surfaces show (`GBufferSurfaces::of_scene`):
        /// colours, colour maps, cut-outs; `None`: the palette
        /// (`GBufferSurfaces::palette`).
        surfaces: Option<&'a GBufferSurfaces>,
    },
    /// Upload a G-buffer made elsewhere (the CPU twin's, for the twin tests).
    Upload(&'a GBuffer),
}

/// A cached G-buffer pipeline, plain or textured.
enum GBufferPassRef {
    Plain(Arc<GBufferPass>),
    Textured(Arc<TexturedGBufferPass>),
}

impl GBufferPassRef {
    fn get(&self) -> &GBufferPass {
        match self {
            GBufferPassRef::Plain(p) => p,
            GBufferPassRef::Textured(p) => &p.0,
        }
    }
}

/// Result of `run_frame`: the G-buffer the kernels saw (read back) and the frame.
pub struct GpuFrame {
    /// The G-buffer the kernels read, read back.
    pub gbuffer: GBuffer,
    /// The frame's outputs (the last run's) and timings.
    pub frame: SsaoFrame,
    /// Each run's time: its passes' sum (timestamps) or its wall time.
    pub runs_ms: Vec<f64>,
}

/// Runs one SSAO frame on the GPU (blocking): G-buffer, estimator, filter,
/// and with `shade` the indirect light and image. `repeat` runs the
/// passes that many times (one submission each) and reports each pass's
/// fastest time; outputs are the last run's. Pipelines are cached per context.
pub fn run_frame(
    ctx: &GpuContext,
    source: GBufferSource<'_>,
    view: &ScreenView,
    settings: &SsaoSettings,
    shade: Option<&ShadeSettings>,
    repeat: u32,
) -> Result<GpuFrame> {
    let device = &ctx.device;
    let (w, h) = (view.width, view.height);
    let mut ssao = SsaoPass::for_context(ctx);
    ssao.prepare(device, &ctx.queue, view, settings, shade)?;
    let targets = GBufferTargets::new(device, w, h)?;
    let gb_group = ssao.gbuffer_bind_group(
        device,
        &targets.geometry.create_view(&Default::default()),
        &targets.shade.create_view(&Default::default()),
    );
    let render = match source {
        GBufferSource::Render {
            mesh,
            camera,
            lights,
            surfaces,
        } => {
            super::gbuffer::validate_lights(lights)?;
            let palette;
            let surfaces = match surfaces {
                Some(s) => s,
                None => {
                    palette = GBufferSurfaces::palette(mesh);
                    &palette
                }
            };
            let (pass, words) = if surfaces.is_textured() {
                let pass = ctx
                    .kernels
                    .get_or_insert(|| TexturedGBufferPass(GBufferPass::textured(device)));
                let words = storage_buffer(
                    device,
                    "the G-buffer's texture maps",
                    bytemuck::cast_slice(&surfaces.words()),
                )?;
                (GBufferPassRef::Textured(pass), Some(words))
            } else {
                (
                    GBufferPassRef::Plain(ctx.kernels.get_or_insert(|| GBufferPass::new(device))),
                    None,
                )
            };
            let vertices = SceneVertices::upload(device, mesh, &surfaces.albedos)?;
            let b = mesh.bounds();
            let near = 1e-6 * ((camera.eye - b.center()).length() + b.diagonal());
            let uniform = uniform_buffer(device, "g-buffer view", &ViewUniform::new(camera, view, lights, near));
            let group = pass.get().view_bind_group(device, &uniform, words.as_ref())?;
            Some((pass, vertices, group, (uniform, words)))
        }
        GBufferSource::Upload(gb) => {
            if gb.width != w || gb.height != h {
                return Err(Error::input(
                    "G-buffer",
                    format!("is {}x{}, the view {w}x{h}", gb.width, gb.height),
                ));
            }
            targets.upload(&ctx.queue, gb);
            None
        }
    };
    let start = Instant::now();
    let mut best: Option<Vec<f64>> = None;
    let mut runs_ms = Vec::new();
    for _ in 0..repeat.max(1) {
        let run_start = Instant::now();
        let mut timer = PassTimer::new(ctx, 12);
        let mut encoder = device.create_command_encoder(&Default::default());
        let mut kinds = Vec::new();
        if let Some((pass, vertices, group, _)) = &render {
            pass.get().record(
                &mut encoder,
                timer.as_mut().and_then(|t| t.next_render_pass()),
                vertices,
                &targets,
                group,
            );
            kinds.push(SsaoStep::GBuffer as usize);
        }
        kinds.extend(
            ssao.record(&mut encoder, &gb_group, timer.as_mut())
                .into_iter()
                .map(|s| s as usize),
        );
        if let Some(t) = &timer {
            t.resolve(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.wait()?;
        let per_kind = match &timer {
            Some(t) => {
                let mut v = vec![0.0; 5];
                for (ms, kind) in t.pass_ms(device)?.into_iter().zip(&kinds) {
                    v[*kind] += ms;
                }
                v
            }
            None => vec![0.0; 5],
        };
        runs_ms.push(match &timer {
            Some(_) => per_kind.iter().sum(),
            None => elapsed_ms(run_start),
        });
        best = Some(match best {
            None => per_kind,
            Some(b) => b.iter().zip(&per_kind).map(|(a, c)| a.min(*c)).collect(),
        });
    }
    let wall_ms = elapsed_ms(start) / repeat.max(1) as f64;
    let best = best.unwrap_or_default();
    let timings = if ctx.timestamps {
        Timings {
            gbuffer_ms: best[0],
            estimate_ms: best[1],
            filter_ms: best[2],
            indirect_ms: best[3],
            compose_ms: best[4],
            timing: Timing::GpuTimestamps,
        }
    } else {
        Timings {
            estimate_ms: wall_ms,
            timing: Timing::Wall,
            ..Default::default()
        }
    };
    let gbuffer = targets.read(ctx)?;
    let pixels = (w * h) as usize;
    let ao_raw: Vec<f32> = read_buffer(ctx, ssao.raw_ao(), (ssao.grid.0 * ssao.grid.1) as usize)?;
    let ao_out: Vec<f32> = read_buffer(ctx, ssao.ao(), pixels)?;
    let (indirect, image) = if shade.is_some() {
        (
            Some(read_buffer::<[f32; 4]>(ctx, ssao.indirect(), pixels)?),
            Some(read_buffer::<[f32; 4]>(ctx, ssao.image(), pixels)?),
        )
    } else {
        (None, None)
    };
    let ao = final_ao(&gbuffer, &ao_out);
    Ok(GpuFrame {
        frame: SsaoFrame {
            ao_raw,
            ao,
            indirect,
            image,
            timings,
        },
        gbuffer,
        runs_ms,
    })
}
