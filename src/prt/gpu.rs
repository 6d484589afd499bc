//! SH integration on the GPU: `ShTransferPass` runs `wgsl/sh_transfer.wgsl`,
//! the twin of `CellTables::integrate` + `ShRotation::frame_to_world` +
//! `radiance`, over masks rasterised on the CPU (`Prt::frame_masks`).
//!
//! Like the other passes it is built once for a host's `&wgpu::Device` and
//! records into the host's `CommandEncoder`. `GpuTransfer` holds what one
//! mesh needs on the device (tables, per-frame buffers, bind groups) and
//! `run_frame` is the blocking convenience for the CLI and tests.
//!
//! The masks are not rasterised on the GPU: on lavapipe the "GPU" is the
//! same two cores, and the rasteriser's cost is the per-vertex gather and
//! transform of blockers (hierarchy, culling groups), which would have to be
//! uploaded per vertex (about 100 triangles x 36 bytes x 1369 vertices per
//! cloth frame) to save an AND/OR loop that already runs at ~10 ns a
//! triangle on the CPU.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::pipeline::Prt;
use super::transfer::{Brdf, Integration};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::gpu::buffers::{read_back, storage_buffer, zeroed_buffer};
use crate::gpu::timer::PassTimer;
use crate::kdtree::gpu::{bind_group, storage_entry, uniform_entry};

/// Most vertices per workgroup (`MAX_VERTS` in the kernel); fewer for 64x64
/// masks, whose words and cells must fit the 1024-entry workgroup arrays.
pub const MAX_VERTICES_PER_WORKGROUP: u32 = 16;
/// Largest SH order the kernel's workgroup arrays hold (`MAX_COEFFS` = 64).
pub const MAX_GPU_BANDS: usize = 8;
/// Vertex batches are multiples of this, which keeps every buffer offset a
/// multiple of 256 bytes (the storage offset alignment).
const BATCH_QUANTUM: u64 = 64;

/// The kernel's uniform (`Params` in the WGSL).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Params {
    counts: [u32; 4],
    shape: [u32; 4],
    grid: [u32; 4],
    phong: [f32; 4],
    eye: [f32; 4],
    tables_a: [u32; 4],
    tables_b: [u32; 4],
}

/// Layouts and pipeline, built once per device.
pub struct ShTransferPass {
    pub tables_layout: wgpu::BindGroupLayout,
    pub frame_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl ShTransferPass {
    pub fn new(device: &wgpu::Device) -> ShTransferPass {
        let tables_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sh_transfer tables"),
            entries: &[storage_entry(0, true), storage_entry(1, true), storage_entry(2, true)],
        });
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sh_transfer frame"),
            entries: &[
                uniform_entry(0),
                storage_entry(1, true),
                storage_entry(2, true),
                storage_entry(3, false),
                storage_entry(4, false),
            ],
        });
        let pipeline = crate::gpu::kernels::compute_pipelines(
            device,
            &crate::wgsl::SH_TRANSFER_MODULE,
            &[&tables_layout, &frame_layout],
            &["sh_transfer"],
        )
        .remove(0);
        ShTransferPass {
            tables_layout,
            frame_layout,
            pipeline,
        }
    }

    /// The pass cached on `ctx`.
    pub fn cached(ctx: &GpuContext) -> Arc<ShTransferPass> {
        ctx.kernels.get_or_insert(|| ShTransferPass::new(&ctx.device))
    }

    /// Records the kernel for every batch of `gpu` into `encoder`.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        gpu: &GpuTransfer,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("sh_transfer"),
            timestamp_writes,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &gpu.tables_group, &[]);
        for batch in &gpu.batches {
            pass.set_bind_group(1, &batch.group, &[]);
            pass.dispatch_workgroups(batch.grid.0, batch.grid.1, 1);
        }
    }
}

struct Batch {
    group: wgpu::BindGroup,
    params: wgpu::Buffer,
    base: Params,
    grid: (u32, u32),
}

/// One mesh's tables and per-frame buffers on a device.
pub struct GpuTransfer {
    vertex_count: usize,
    coeffs: usize,
    words32: usize,
    lighting: wgpu::Buffer,
    masks: wgpu::Buffer,
    vertices: wgpu::Buffer,
    transfer: wgpu::Buffer,
    radiance: wgpu::Buffer,
    readback: wgpu::Buffer,
    tables_group: wgpu::BindGroup,
    batches: Vec<Batch>,
}

/// One frame's GPU results.
#[derive(Debug, Clone, Default)]
pub struct GpuFrame {
    pub transfer: Vec<f32>,
    pub radiance: Vec<[f32; 3]>,
    /// Kernel time from timestamps, where the device has them.
    pub kernel_ms: Option<f64>,
}

impl GpuTransfer {
    /// Uploads `prt`'s tables; buffers for its vertex count.
    pub fn new(ctx: &GpuContext, pass: &ShTransferPass, prt: &Prt) -> Result<GpuTransfer> {
        Self::with_batch_limit(ctx, pass, prt, u64::MAX)
    }

    /// As `new`, with at most `max_batch` vertices per dispatch (rounded up to
    /// 64); larger meshes are always split to fit the device's binding size.
    pub fn with_batch_limit(ctx: &GpuContext, pass: &ShTransferPass, prt: &Prt, max_batch: u64) -> Result<GpuTransfer> {
        let settings = &prt.settings;
        if settings.bands > MAX_GPU_BANDS {
            return Err(Error::param(
                "--order",
                format!(
                    "the GPU kernel integrates up to {MAX_GPU_BANDS} bands, got {}; use --device cpu",
                    settings.bands
                ),
            ));
        }
        let device = &ctx.device;
        let t = &prt.tables;
        let n = t.coeffs;
        let nv = prt.vertex_count;
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
            &pass.tables_layout,
            &[(0, &tables), (1, &lighting), (2, &cell_basis)],
        );

        // Per-vertex buffers, bound batch by batch.
        let per_vertex = [words32 as u64 * 4, 32, n as u64 * 4, 12];
        let limits = device.limits();
        let max_binding = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
        let fit = max_binding / per_vertex.iter().max().copied().unwrap_or(1);
        let batch = (fit.min(max_batch) / BATCH_QUANTUM * BATCH_QUANTUM).max(BATCH_QUANTUM);
        let total = |i: usize| (per_vertex[i] * nv.max(1) as u64).next_multiple_of(256);
        for (i, what) in ["masks", "vertices", "transfer", "radiance"].iter().enumerate() {
            if total(i) > limits.max_buffer_size {
                return Err(Error::Device(format!(
                    "the {what} of {nv} vertices need {:.1} MiB; this device allows {:.1} MiB per buffer",
                    total(i) as f64 / 1048576.0,
                    limits.max_buffer_size as f64 / 1048576.0
                )));
            }
        }
        let copy_dst = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let copy_src = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let masks = zeroed_buffer(device, "sh_transfer masks", total(0), copy_dst);
        let vertices = zeroed_buffer(device, "sh_transfer vertices", total(1), copy_dst);
        let transfer = zeroed_buffer(device, "sh_transfer transfer", total(2), copy_src);
        let radiance = zeroed_buffer(device, "sh_transfer radiance", total(3), copy_src);
        let readback = zeroed_buffer(
            device,
            "sh_transfer readback",
            total(2) + total(3),
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
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
        let max_groups = limits.max_compute_workgroups_per_dimension;
        let cells = (t.side / 4) * (t.side / 4);
        let verts = MAX_VERTICES_PER_WORKGROUP
            .min(1024 / words32 as u32)
            .min(1024 / cells as u32);
        let mut batches = Vec::new();
        let mut first = 0u64;
        while first < nv as u64 {
            let count = batch.min(nv as u64 - first);
            let groups = (count as u32).div_ceil(verts);
            let gx = groups.min(max_groups);
            let grid = (gx, groups.div_ceil(gx));
            let base = Params {
                counts: [count as u32, n as u32, settings.bands as u32, prt.grid.side as u32],
                shape: [t.side as u32 / 4, words32 as u32, integration, brdf],
                grid: [gx, verts, 0, 0],
                phong,
                eye: [0.0; 4],
                tables_a: [0, 0, off_nibble, off_dirs],
                tables_b: [off_unoccluded, off_area, off_pixel, off_x90],
            };
            let params = zeroed_buffer(
                device,
                "sh_transfer params",
                std::mem::size_of::<Params>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            );
            fn slice<'a>(
                buffer: &'a wgpu::Buffer,
                i: usize,
                first: u64,
                count: u64,
                per_vertex: &[u64; 4],
            ) -> wgpu::BindGroupEntry<'a> {
                wgpu::BindGroupEntry {
                    binding: i as u32 + 1,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer,
                        offset: first * per_vertex[i],
                        size: wgpu::BufferSize::new(count * per_vertex[i]),
                    }),
                }
            }
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("sh_transfer frame"),
                layout: &pass.frame_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: params.as_entire_binding(),
                    },
                    slice(&masks, 0, first, count, &per_vertex),
                    slice(&vertices, 1, first, count, &per_vertex),
                    slice(&transfer, 2, first, count, &per_vertex),
                    slice(&radiance, 3, first, count, &per_vertex),
                ],
            });
            batches.push(Batch {
                group,
                params,
                base,
                grid,
            });
            first += count;
        }
        Ok(GpuTransfer {
            vertex_count: nv,
            coeffs: n,
            words32,
            lighting,
            masks,
            vertices,
            transfer,
            radiance,
            readback,
            tables_group,
            batches,
        })
    }

    /// Dispatches per frame (one per batch).
    pub fn batch_count(&self) -> usize {
        self.batches.len()
    }

    /// Writes one frame's inputs: masks (`Prt::frame_masks`, u64 words per
    /// vertex), positions, shading normals, eye and planar RGB lighting.
    pub fn upload(
        &self,
        queue: &wgpu::Queue,
        masks: &[u64],
        positions: &[Vec3],
        normals: &[Vec3],
        eye: Option<Vec3>,
        lighting: &[f32],
    ) -> Result<()> {
        let nv = self.vertex_count;
        if masks.len() * 2 != nv * self.words32
            || positions.len() != nv
            || normals.len() != nv
            || lighting.len() != 3 * self.coeffs
        {
            return Err(Error::internal(format!(
                "GPU transfer inputs for {nv} vertices: {} mask words, {} positions, {} normals, {} lighting values",
                masks.len(),
                positions.len(),
                normals.len(),
                lighting.len()
            )));
        }
        if nv == 0 {
            return Ok(());
        }
        queue.write_buffer(&self.masks, 0, bytemuck::cast_slice(masks));
        let verts: Vec<[f32; 4]> = positions
            .iter()
            .zip(normals)
            .flat_map(|(p, n)| [p.extend(0.0).to_array(), n.extend(0.0).to_array()])
            .collect();
        queue.write_buffer(&self.vertices, 0, bytemuck::cast_slice(&verts));
        queue.write_buffer(&self.lighting, 0, bytemuck::cast_slice(lighting));
        let eye = eye.map_or([0.0; 4], |e| [e.x, e.y, e.z, 1.0]);
        for b in &self.batches {
            queue.write_buffer(&b.params, 0, bytemuck::bytes_of(&Params { eye, ..b.base }));
        }
        Ok(())
    }

    /// Records the copies of the results into the readback buffer.
    pub fn record_readback(&self, encoder: &mut wgpu::CommandEncoder) {
        let t = self.transfer.size();
        encoder.copy_buffer_to_buffer(&self.transfer, 0, &self.readback, 0, t);
        encoder.copy_buffer_to_buffer(&self.radiance, 0, &self.readback, t, self.radiance.size());
    }

    /// Reads the results back (after `record_readback` was submitted).
    pub fn read(&self, device: &wgpu::Device) -> Result<(Vec<f32>, Vec<[f32; 3]>)> {
        let all: Vec<f32> = read_back(device, &self.readback, (self.readback.size() / 4) as usize)?;
        let t = (self.transfer.size() / 4) as usize;
        let transfer = all[..self.vertex_count * self.coeffs].to_vec();
        let radiance = all[t..t + 3 * self.vertex_count]
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        Ok((transfer, radiance))
    }

    /// Upload, integrate, read back (blocking).
    #[allow(clippy::too_many_arguments)]
    pub fn run_frame(
        &self,
        ctx: &GpuContext,
        pass: &ShTransferPass,
        masks: &[u64],
        positions: &[Vec3],
        normals: &[Vec3],
        eye: Option<Vec3>,
        lighting: &[f32],
    ) -> Result<GpuFrame> {
        self.upload(&ctx.queue, masks, positions, normals, eye, lighting)?;
        if self.vertex_count == 0 {
            return Ok(GpuFrame::default());
        }
        let mut timer = PassTimer::new(ctx, 1);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        pass.record(&mut encoder, self, timer.as_mut().and_then(|t| t.next_pass()));
        self.record_readback(&mut encoder);
        if let Some(t) = &timer {
            t.resolve(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        let (transfer, radiance) = self.read(&ctx.device)?;
        let kernel_ms = match &timer {
            Some(t) => Some(t.total_ms(&ctx.device)?),
            None => None,
        };
        Ok(GpuFrame {
            transfer,
            radiance,
            kernel_ms,
        })
    }
}
