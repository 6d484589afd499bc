//! SH integration on the GPU: `ShTransferPass` runs `wgsl/sh_transfer.wgsl`,
//! the twin of `Prt::sh_transfer`, over masks rasterised on the CPU
//! (`Prt::frame_masks`).
//!
//! Like the other passes it follows glyphon's split: `ShTransferPass::new`
//! builds its pipeline (or takes it from the context's cache) and uploads
//! one mesh's tables, `prepare` writes a batch of vertices into buffers it
//! keeps, `record` only records into the caller's encoder. `GpuTransfer`
//! runs a whole frame in batches that fit the device (`gpu::batch`).
//!
//! The masks are not rasterised on the GPU: on lavapipe the "GPU" is the
//! same two cores, and the rasteriser's cost is the per-vertex gather and
//! transform of blockers (hierarchy, culling groups), which would have to be
//! uploaded per vertex (about 100 triangles x 36 bytes x 1369 vertices per
//! cloth frame) to save an AND/OR loop that already runs at ~10 ns a
//! triangle on the CPU.

use std::ops::Range;
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::pipeline::Prt;
use super::transfer::{Brdf, Integration};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::gpu::batch::{BatchPass, BatchPlan, fit_items, readback_buffer, run_batches};
use crate::gpu::buffers::{GrowingBuffer, KeptGroup, storage_buffer};
use crate::gpu::kernels::{Kernels, PipelineLog, Pipelines, compute_pipelines, record_dispatch};
use crate::gpu::layout::{Io, bind_group, io_layout, layout, storage_entry};
use crate::gpu::timer::PassTimer;
use crate::gpu::wgsl::Composition;
use crate::progress::Bar;

/// A form of `sh_transfer.wgsl`: its module and the sizes of its workgroup
/// arrays (the constants its first file sets). Each vertex's arithmetic is
/// the same in every form; only how many vertices share a workgroup differs.
#[derive(Debug, Clone, Copy)]
pub struct ShTransferForm {
    /// The WGSL module of this form (portable or wide).
    pub module: Composition,
    /// Most vertices per workgroup (`MAX_VERTS`); fewer for 64x64 masks,
    /// whose words and cells must fit the staged arrays.
    pub max_vertices: u32,
    /// Entries of the staged masks and cells (`STAGED`).
    pub staged: u32,
}

impl ShTransferForm {
    /// Within WebGPU's portable limits (16 KiB of workgroup memory).
    pub const PORTABLE: ShTransferForm = ShTransferForm {
        module: crate::gpu::wgsl::SH_TRANSFER_PORTABLE_MODULE,
        max_vertices: 8,
        staged: 512,
    };

    /// Twice the vertices a workgroup (32 KiB of workgroup memory).
    pub const WIDE: ShTransferForm = ShTransferForm {
        module: crate::gpu::wgsl::SH_TRANSFER_MODULE,
        max_vertices: 16,
        staged: 1024,
    };

    /// The widest form `limits` allow.
    pub fn for_limits(limits: &wgpu::Limits) -> ShTransferForm {
        match Self::WIDE.module.fits(limits) {
            true => Self::WIDE,
            false => Self::PORTABLE,
        }
    }

    /// Vertices per workgroup for masks of `words32` u32 words and `cells`
    /// 4x4 cells.
    fn vertices_per_group(&self, words32: usize, cells: usize) -> u32 {
        self.max_vertices
            .min(self.staged / words32 as u32)
            .min(self.staged / cells as u32)
    }
}

/// Largest SH order the kernel's workgroup arrays hold (`MAX_COEFFS` = 64).
pub const MAX_GPU_BANDS: usize = 8;
/// Vertex batches are multiples of this (whole workgroups).
const BATCH_QUANTUM: u64 = 64;

/// The kernel's uniform (`ShTransferUniforms` in the WGSL).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct ShTransferUniforms {
    counts: [u32; 4],
    shape: [u32; 4],
    grid: [u32; 4],
    phong: [f32; 4],
    eye: [f32; 4],
    tables_a: [u32; 4],
    tables_b: [u32; 4],
}

/// A batch's io: params, masks (u32 words), vertices (position, normal),
/// transfer (`coeffs` per vertex), radiance (3 per vertex).
const FRAME_IO: &[Io] = &[
    Io::Uniform(
        0,
        "sh_transfer params",
        std::mem::size_of::<ShTransferUniforms>() as u64,
    ),
    Io::In(1, "sh_transfer masks"),
    Io::In(2, "sh_transfer vertices"),
    Io::Out(3, "sh_transfer transfer"),
    Io::Out(4, "sh_transfer radiance"),
];

/// The layouts and pipeline of `sh_transfer.wgsl` for one device, in the
/// widest form its limits allow.
pub struct ShTransferKernels {
    /// Bind group 0: the mesh's packed tables, the lighting and the
    /// per-cell basis integrals (read-only storage).
    pub tables_layout: wgpu::BindGroupLayout,
    /// Bind group 1: one batch's uniform, masks, vertices, transfer and
    /// radiance.
    pub frame_layout: wgpu::BindGroupLayout,
    /// The form built for this device's limits.
    pub form: ShTransferForm,
    pipeline: Pipelines,
}

impl Kernels for ShTransferKernels {
    fn build(device: &wgpu::Device, log: &Arc<PipelineLog>) -> ShTransferKernels {
        let tables_layout = layout(
            device,
            "sh_transfer tables",
            &[storage_entry(0, true), storage_entry(1, true), storage_entry(2, true)],
        );
        let frame_layout = io_layout(device, "sh_transfer frame", FRAME_IO);
        let form = ShTransferForm::for_limits(&device.limits());
        let pipeline = compute_pipelines(
            device,
            &form.module,
            &[&tables_layout, &frame_layout],
            &["sh_transfer"],
            log,
        );
        ShTransferKernels {
            tables_layout,
            frame_layout,
            form,
            pipeline,
        }
    }
}

/// The SH transfer pass of one mesh: its tables on the device, and the
/// buffers of one batch of vertices.
pub struct ShTransferPass {
    kernels: Arc<ShTransferKernels>,
    tables_group: wgpu::BindGroup,
    lighting: wgpu::Buffer,
    /// The batch's buffers (`FRAME_IO`).
    frame: KeptGroup,
    /// The uniform without the batch's vertex count, grid and eye.
    base: ShTransferUniforms,
    verts_per_group: u32,
    coeffs: usize,
    words32: usize,
    batch_vertices: u64,
    grid: (u32, u32),
}

impl ShTransferPass {
    /// Builds the kernels for `device` and uploads `prt`'s tables.
    pub fn new(device: &wgpu::Device, prt: &Prt) -> Result<ShTransferPass> {
        Self::with_kernels(device, Arc::new(ShTransferKernels::build(device, &Arc::default())), prt)
    }

    /// As `new`, with kernels built before (e.g. `ShTransferKernels::cached`).
    pub fn with_kernels(device: &wgpu::Device, kernels: Arc<ShTransferKernels>, prt: &Prt) -> Result<ShTransferPass> {
        let settings = &prt.settings;
        if settings.bands > MAX_GPU_BANDS {
            return Err(Error::param(
                "bands",
                format!(
                    "the GPU kernel integrates up to {MAX_GPU_BANDS} bands, got {}; use `device` cpu",
                    settings.bands
                ),
            ));
        }
        let t = &prt.tables;
        let n = t.coeffs;
        let words32 = prt.grid.words * 2;

        // Tables, packed one after another (offsets in the uniform).
        let mut packed: Vec<f32> = Vec::new();
        let mut push = |data: &[f32]| {
            let at = packed.len() as u32;
            packed.extend_from_slice(data);
            at
        };
        let off_nibble = push(bytemuck::cast_slice(&t.nibble));
        let dirs: Vec<f32> = t.dirs.iter().flat_map(|d| [d.x, d.y, d.z, 0.0]).collect();
        let off_dirs = push(&dirs);
        let off_unoccluded = push(&t.unoccluded);
        let off_area = push(&t.area);
        let off_pixel = push(&t.pixel_basis);
        let off_x90 = push(&prt.rotation.x90_packed_f32());
        let tables = storage_buffer(device, "sh_transfer tables", bytemuck::cast_slice(&packed))?;
        let lighting = storage_buffer(
            device,
            "sh_transfer lighting",
            bytemuck::cast_slice(&vec![0.0f32; 3 * n]),
        )?;
        // (B_ck, A_c g_ck) interleaved per cell and coefficient.
        let cell_basis: Vec<[f32; 4]> = (0..t.cells)
            .flat_map(|c| {
                (0..n).map(move |k| {
                    [
                        t.basis[c * n + k],
                        t.gradient[2 * c * n + k],
                        t.gradient[(2 * c + 1) * n + k],
                        0.0,
                    ]
                })
            })
            .collect();
        let cell_basis = storage_buffer(device, "sh_transfer cell basis", bytemuck::cast_slice(&cell_basis))?;
        let tables_group = bind_group(
            device,
            "sh_transfer tables",
            &kernels.tables_layout,
            &[(0, &tables), (1, &lighting), (2, &cell_basis)],
        );
        let (brdf, phong) = match settings.brdf {
            Brdf::Diffuse => (0, [0.0; 4]),
            Brdf::Phong { shininess, specular } => (1, [shininess, specular, 0.0, 0.0]),
        };
        let integration = match t.integration {
            Integration::Cells => 0,
            Integration::CellsLinear => 1,
            Integration::Pixels => 2,
        };
        let cells = (t.side / 4) * (t.side / 4);
        let verts_per_group = kernels.form.vertices_per_group(words32, cells);
        let base = ShTransferUniforms {
            counts: [0, n as u32, settings.bands as u32, prt.grid.side as u32],
            shape: [t.side as u32 / 4, words32 as u32, integration, brdf],
            grid: [0, verts_per_group, 0, 0],
            phong,
            eye: [0.0; 4],
            tables_a: [0, 0, off_nibble, off_dirs],
            tables_b: [off_unoccluded, off_area, off_pixel, off_x90],
        };
        Ok(ShTransferPass {
            tables_group,
            lighting,
            frame: KeptGroup::for_io(device, "sh_transfer frame", FRAME_IO),
            base,
            verts_per_group,
            coeffs: n,
            words32,
            batch_vertices: 0,
            grid: (0, 0),
            kernels,
        })
    }

    /// Bytes per vertex of the batch buffers: mask, vertex, transfer, radiance.
    fn per_vertex(&self) -> [u64; 4] {
        [self.words32 as u64 * 4, 32, self.coeffs as u64 * 4, 12]
    }

    /// Uploads one batch of vertices (`frame` holds just them).
    pub fn prepare(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, frame: &FrameInputs) -> Result<()> {
        let FrameInputs {
            masks,
            positions,
            normals,
            eye,
            lighting,
        } = *frame;
        let nv = positions.len();
        if masks.len() * 2 != nv * self.words32 || normals.len() != nv || lighting.len() != 3 * self.coeffs {
            return Err(Error::internal(format!(
                "GPU transfer inputs for {nv} vertices: {} mask words, {} normals, {} lighting values",
                masks.len(),
                normals.len(),
                lighting.len()
            )));
        }
        let verts: Vec<[f32; 4]> = positions
            .iter()
            .zip(normals)
            .flat_map(|(p, n)| [p.extend(0.0).to_array(), n.extend(0.0).to_array()])
            .collect();
        let groups = (nv as u32).div_ceil(self.verts_per_group).max(1);
        let gx = groups.min(device.limits().max_compute_workgroups_per_dimension);
        let mut params = self.base;
        params.counts[0] = nv as u32;
        params.grid[0] = gx;
        params.eye = eye.map_or([0.0; 4], |e| [e.x, e.y, e.z, 1.0]);
        let per_vertex = self.per_vertex();
        let io = &mut self.frame;
        io.write(device, queue, 0, bytemuck::bytes_of(&params))?;
        io.write(device, queue, 1, bytemuck::cast_slice(masks))?;
        io.write(device, queue, 2, bytemuck::cast_slice(&verts))?;
        io.reserve(device, 3, per_vertex[2] * nv as u64)?;
        io.reserve(device, 4, per_vertex[3] * nv as u64)?;
        io.update(device, &self.kernels.frame_layout);
        queue.write_buffer(&self.lighting, 0, bytemuck::cast_slice(lighting));
        self.batch_vertices = nv as u64;
        self.grid = (gx, groups.div_ceil(gx));
        Ok(())
    }

    /// Records the kernel over the prepared batch.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let groups = [&self.tables_group, self.frame.group()];
        record_dispatch(
            encoder,
            "sh_transfer",
            timestamp_writes,
            self.kernels.pipeline.get(0),
            &groups,
            self.grid,
        );
    }

    /// The kernel's form on this device, and how many vertices share a
    /// workgroup for this mesh's masks.
    pub fn workgroups(&self) -> (ShTransferForm, u32) {
        (self.kernels.form, self.verts_per_group)
    }

    /// World-space transfer vectors of the prepared batch, `coeffs` per vertex.
    pub fn transfer(&self) -> &wgpu::Buffer {
        self.frame.buffer(3)
    }

    /// Exitant radiance of the prepared batch, 3 f32 per vertex.
    pub fn radiance(&self) -> &wgpu::Buffer {
        self.frame.buffer(4)
    }
}

/// What a frame of the kernel reads: per vertex its mask (`Prt::frame_masks`,
/// u64 words), position and shading normal; the eye and the planar RGB
/// lighting (`3 x coeffs`).
#[derive(Debug, Clone, Copy)]
pub struct FrameInputs<'a> {
    /// Visibility masks, `MaskGrid::words` u64 per vertex, vertex order.
    pub masks: &'a [u64],
    /// World-space vertex positions.
    pub positions: &'a [Vec3],
    /// Shading normals (`Prt::shading_normals`; zero: no normal, transfer and radiance zero).
    pub normals: &'a [Vec3],
    /// World-space eye position, for the Phong lobe's reflected view;
    /// `None`: the lobe points along the normal.
    pub eye: Option<Vec3>,
    /// Lighting SH coefficients, planar RGB: `coeffs` red, then green, then
    /// blue.
    pub lighting: &'a [f32],
}

impl<'a> FrameInputs<'a> {
    /// The inputs of vertices `range` (masks of `words` u64 each).
    fn slice(&self, range: Range<usize>, words: usize) -> FrameInputs<'a> {
        FrameInputs {
            masks: &self.masks[range.start * words..range.end * words],
            positions: &self.positions[range.clone()],
            normals: &self.normals[range],
            ..*self
        }
    }
}

/// One frame's GPU results.
#[derive(Debug, Clone, Default)]
pub struct GpuFrame {
    /// World-space transfer vectors, `coeffs` per vertex.
    pub transfer: Vec<f32>,
    /// Exitant radiance per vertex (linear RGB).
    pub radiance: Vec<[f32; 3]>,
    /// Kernel time from timestamps, where the device has them.
    pub kernel_ms: Option<f64>,
}

/// One mesh's transfer on a device: the pass, its batch size and the kept
/// read-back buffer.
pub struct GpuTransfer {
    /// The pass holding the mesh's tables and the current batch.
    pub pass: ShTransferPass,
    readback: GrowingBuffer,
    vertex_count: usize,
    batch: usize,
}

impl GpuTransfer {
    /// Uploads `prt`'s tables (kernels cached on `ctx`).
    pub fn new(ctx: &GpuContext, prt: &Prt) -> Result<GpuTransfer> {
        Self::with_batch_limit(ctx, prt, u64::MAX)
    }

    /// As `new`, with at most `max_batch` vertices per dispatch (rounded up to
    /// 64); larger meshes are always split to fit the device's binding size.
    pub fn with_batch_limit(ctx: &GpuContext, prt: &Prt, max_batch: u64) -> Result<GpuTransfer> {
        let pass = ShTransferPass::with_kernels(&ctx.device, ShTransferKernels::cached(ctx), prt)?;
        let per_vertex = pass.per_vertex();
        let fit = fit_items(&ctx.device, &per_vertex, per_vertex[2] + per_vertex[3]) as u64;
        let batch = (fit.min(max_batch) / BATCH_QUANTUM * BATCH_QUANTUM).max(BATCH_QUANTUM);
        Ok(GpuTransfer {
            pass,
            readback: readback_buffer(),
            vertex_count: prt.vertex_count,
            batch: batch as usize,
        })
    }

    /// Dispatches per frame (one per batch).
    pub fn batch_count(&self) -> usize {
        self.vertex_count.div_ceil(self.batch)
    }

    /// Upload, integrate, read back (blocking).
    pub fn run_frame(&mut self, ctx: &GpuContext, frame: &FrameInputs) -> Result<GpuFrame> {
        let FrameInputs {
            masks,
            positions,
            normals,
            ..
        } = *frame;
        let nv = self.vertex_count;
        if positions.len() != nv || normals.len() != nv || masks.len() * 2 != nv * self.pass.words32 {
            return Err(Error::internal(format!(
                "GPU transfer inputs for {nv} vertices: {} mask words, {} positions, {} normals",
                masks.len(),
                positions.len(),
                normals.len()
            )));
        }
        let n = self.pass.coeffs;
        let mut transfer = Vec::with_capacity(nv * n);
        let mut radiance = Vec::with_capacity(nv);
        let mut batch = VertexBatch {
            pass: &mut self.pass,
            frame,
        };
        let plan = BatchPlan::new(nv, self.batch, 1);
        let kernel_ms = run_batches(
            ctx,
            &mut batch,
            &mut self.readback,
            plan,
            &Bar::hidden(),
            |items, v: &[f32]| {
                let k = items.len() * n;
                transfer.extend_from_slice(&v[..k]);
                radiance.extend(v[k..k + 3 * items.len()].chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
                Ok(())
            },
        )?;
        Ok(GpuFrame {
            transfer,
            radiance,
            kernel_ms,
        })
    }
}

struct VertexBatch<'a> {
    pass: &'a mut ShTransferPass,
    frame: &'a FrameInputs<'a>,
}

impl BatchPass for VertexBatch<'_> {
    fn prepare(&mut self, ctx: &GpuContext, items: Range<usize>) -> Result<()> {
        let frame = self.frame.slice(items, self.pass.words32 / 2);
        self.pass.prepare(&ctx.device, &ctx.queue, &frame)
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &mut Option<PassTimer>) {
        self.pass.record(encoder, timer.as_mut().and_then(|t| t.next_pass()));
    }

    fn results(&self) -> Vec<(&wgpu::Buffer, u64)> {
        let [_, _, t, r] = self.pass.per_vertex();
        let nv = self.pass.batch_vertices;
        vec![(self.pass.transfer(), t * nv), (self.pass.radiance(), r * nv)]
    }
}

#[cfg(test)]
mod tests {
    use super::ShTransferForm;

    /// The constant `name` as the form's first WGSL file sets it.
    fn constant(form: &ShTransferForm, name: &str) -> u32 {
        let prefix = format!("const {name}: u32 = ");
        let line = form.module.parts[0].text.lines().find_map(|l| l.strip_prefix(&prefix));
        line.and_then(|v| v.strip_suffix("u;")).unwrap().parse().unwrap()
    }

    #[test]
    fn forms_match_their_wgsl_and_fit_their_limits() {
        let portable = wgpu::Limits::default();
        let wide = wgpu::Limits {
            max_compute_workgroup_storage_size: 32 << 10,
            ..portable.clone()
        };
        for form in [ShTransferForm::PORTABLE, ShTransferForm::WIDE] {
            assert_eq!(constant(&form, "MAX_VERTS"), form.max_vertices, "{}", form.module.name);
            assert_eq!(constant(&form, "STAGED"), form.staged, "{}", form.module.name);
            // 64x64 masks: 128 words and 256 cells a vertex.
            assert!(form.vertices_per_group(128, 256) >= 1);
        }
        assert_eq!(ShTransferForm::for_limits(&portable).max_vertices, 8);
        assert_eq!(ShTransferForm::for_limits(&wide).max_vertices, 16);
        let bytes = ShTransferForm::WIDE.module.resources().unwrap().entries[0].workgroup_bytes;
        assert_eq!(bytes, 29_696);
    }
}
