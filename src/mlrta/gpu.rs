//! MLRTA on the GPU: the CPU splits tiles and searches entry points (cheap,
//! branchy work), the `packet_traverse.wgsl` kernel traces the packets (a
//! workgroup per 4x4 packet, the packet's entry node and frustum shared by its
//! lanes). Hits equal the CPU packets' and the single-ray path's.

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use rayon::prelude::*;

use crate::error::Result;
use crate::gpu::GpuContext;
use crate::gpu::buffers::{check_storage_size, read_back, storage_buffer, uniform_buffer, zeroed_buffer};
use crate::gpu::kernels::record_dispatch;
use crate::gpu::timer::PassTimer;
use crate::kdtree::gpu::{GpuKdTree, bind_group, kdtree_bind_group_layout, storage_entry, uniform_entry};
use crate::mlrta::entry_point::EntryPoint;
use crate::mlrta::frustum::sign_class;
use crate::mlrta::packet::{MlrtaCounts, PACKET, Packet};
use crate::mlrta::prepared::Prepared;
use crate::mlrta::tiles::{
    Ctx, ImageTrace, MlrtaParams, Rect, SHADOW_EPSILON, ShadowRays, TileOut, block_rects, pixels, search_below,
    shadow_tile_entry, split_tiles,
};
use crate::ray::{Hit, Ray};

/// `PacketRecord` in `wgsl/packet_traverse.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct PacketRecord {
    pub origin: [f32; 3],
    pub t_max: f32,
    pub inv_lo: [f32; 3],
    pub entry_node: u32,
    pub inv_hi: [f32; 3],
    pub first_ray: u32,
    pub cell_min: [f32; 3],
    pub ray_count: u32,
    pub cell_max: [f32; 3],
    pub flags: u32,
    /// `EntryPoint::t_limit` (at most `t_max`).
    pub t_limit: f32,
    pub _pad: [f32; 3],
}

/// Packets in one workgroup of the kernel.
const PACKETS_PER_WORKGROUP: u32 = 4;
const FLAG_SPECULATIVE: u32 = 8;
const FLAG_ANY_HIT: u32 = 16;
const FLAG_SINGLE: u32 = 32;

/// `PacketParams` in the kernel.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct PacketParams {
    packet_count: u32,
    row_pitch: u32,
    _pad: [u32; 2],
}

/// The packet pass: layouts and pipeline for one device.
pub struct PacketPass {
    pub io_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl PacketPass {
    pub fn new(device: &wgpu::Device) -> PacketPass {
        let scene_layout = kdtree_bind_group_layout(device);
        // packets, directions, hits, params, counts
        let io_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("packets io"),
            entries: &[
                storage_entry(0, true),
                storage_entry(1, true),
                storage_entry(2, false),
                uniform_entry(3),
                storage_entry(4, false),
            ],
        });
        let pipeline = crate::gpu::kernels::compute_pipelines(
            device,
            &crate::wgsl::PACKET_TRAVERSE_MODULE,
            &[&scene_layout, &io_layout],
            &["trace_packets"],
        )
        .remove(0);
        PacketPass { io_layout, pipeline }
    }

    /// Records one dispatch: a workgroup per `PACKETS_PER_WORKGROUP` packets
    /// over a 2D grid whose rows hold `row_pitch` workgroups (in the params).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
        tree: &GpuKdTree,
        io: &wgpu::BindGroup,
        grid: (u32, u32),
    ) {
        record_dispatch(
            encoder,
            "packets",
            timestamp_writes,
            &self.pipeline,
            &[&tree.bind_group, io],
            grid,
        );
    }
}

/// Packets ready for the GPU: records, the directions of their rays in
/// record order, and which result each ray fills.
#[derive(Default)]
struct Batch {
    records: Vec<PacketRecord>,
    dirs: Vec<f32>,
    targets: Vec<u32>,
}

impl Batch {
    /// Adds a group of up to 16 rays from `origin`: same-sign sub-groups as
    /// packets from `start` (or from their own entry points, with `search`),
    /// rays with a zero direction component as single rays. Entry-point
    /// searches are counted in `counts`; groups without potential hits add
    /// nothing (their rays miss).
    #[allow(clippy::too_many_arguments)]
    fn add_group(
        &mut self,
        p: &Prepared,
        origin: Vec3,
        dirs: &[Vec3],
        targets: &[u32],
        t_max: f32,
        any_hit: bool,
        start: &EntryPoint,
        search: Option<Option<u32>>,
        counts: &mut MlrtaCounts,
    ) {
        let t_max_gpu = if t_max.is_finite() { t_max } else { f32::MAX };
        let any = if any_hit { FLAG_ANY_HIT } else { 0 };
        let push = |record: PacketRecord, lanes: &[usize], batch: &mut Batch| {
            let first = batch.targets.len() as u32;
            for &k in lanes {
                batch.dirs.extend_from_slice(&dirs[k].to_array());
                batch.targets.push(targets[k]);
            }
            batch.records.push(PacketRecord {
                first_ray: first,
                ray_count: lanes.len() as u32,
                ..record
            });
        };
        let mut classes: [Vec<usize>; 9] = Default::default();
        for (k, &d) in dirs.iter().enumerate() {
            classes[sign_class(d).map_or(8, |c| c as usize)].push(k);
        }
        for (class, lanes) in classes.iter().enumerate().filter(|(_, l)| !l.is_empty()) {
            if class == 8 {
                for &k in lanes {
                    let single = PacketRecord {
                        origin: origin.to_array(),
                        t_max: t_max_gpu,
                        t_limit: t_max_gpu,
                        flags: FLAG_SINGLE | any,
                        ..Zeroable::zeroed()
                    };
                    push(single, &[k], self);
                }
                continue;
            }
            let group: Vec<Vec3> = lanes.iter().map(|&k| dirs[k]).collect();
            let packet = Packet::new(origin, &group, t_max).expect("one sign class");
            let f = &packet.frustum;
            let entry = match search {
                None => Some(*start),
                Some(inside) => {
                    counts.ep_searches += 1;
                    search_below(p, f, start, inside, &mut counts.ep_steps)
                }
            };
            let Some(entry) = entry else { continue };
            let positive = (0..3).fold(0, |bits, a| bits | ((f.positive[a] as u32) << a));
            let limit = t_max.min(entry.t_limit);
            let record = PacketRecord {
                origin: origin.to_array(),
                t_max: t_max_gpu,
                t_limit: if limit.is_finite() { limit } else { f32::MAX },
                inv_lo: std::array::from_fn(|a| f.inv[a].lo),
                entry_node: entry.node,
                inv_hi: std::array::from_fn(|a| f.inv[a].hi),
                cell_min: entry.cell.min.to_array(),
                cell_max: entry.cell.max.to_array(),
                flags: positive | any | if entry.speculative { FLAG_SPECULATIVE } else { 0 },
                ..Zeroable::zeroed()
            };
            push(record, lanes, self);
        }
    }
}

/// What `trace_image_gpu` returns besides the image.
pub struct GpuImageTrace {
    pub image: ImageTrace,
    /// Kernel time of the packet passes (timestamps), where supported.
    pub gpu_ms: Option<f64>,
    /// CPU time spent on tiles, entry points and packet records.
    pub cpu_ms: f64,
    pub wall_ms: f64,
}

/// `tiles::trace_image` with the packets traced on the GPU.
#[allow(clippy::too_many_arguments)]
pub fn trace_image_gpu(
    ctx: &GpuContext,
    gpu_tree: &GpuKdTree,
    p: &Prepared,
    rays: &[Ray],
    width: u32,
    height: u32,
    params: &MlrtaParams,
    light: Option<Vec3>,
) -> Result<GpuImageTrace> {
    let start = Instant::now();
    let c = Ctx::new(p, rays, width, height, params, light)?;
    // Tiles and entry points on the CPU; each final block becomes packets.
    let parts: Vec<(TileOut, Batch)> = c
        .initial_tiles(height)
        .par_iter()
        .map(|&rect| {
            let mut out = TileOut::default();
            let mut batch = Batch::default();
            let mut emit = |entry: &EntryPoint, block: Rect, out: &mut TileOut| {
                let ids: Vec<u32> = pixels(block, width).collect();
                let dirs: Vec<Vec3> = ids.iter().map(|&i| rays[i as usize].d()).collect();
                batch.add_group(
                    p,
                    c.origin,
                    &dirs,
                    &ids,
                    f32::INFINITY,
                    false,
                    entry,
                    None,
                    &mut out.counts,
                );
            };
            split_tiles(&c, rect, c.root(), 0, &mut out, &mut emit);
            (out, batch)
        })
        .collect();
    let mut batch = Batch::default();
    let mut outs = Vec::new();
    for (out, b) in parts {
        merge(&mut batch, b);
        outs.push(out);
    }
    let mut cpu_ms = start.elapsed().as_secs_f64() * 1e3;
    let mut image = c.gather(outs, height);
    let PacketOutput {
        hits,
        counts,
        mut gpu_ms,
    } = run_packets(ctx, gpu_tree, &batch)?;
    image.hits = vec![Hit::MISS; rays.len()];
    scatter(&batch, &hits, &counts, &mut image.hits, &mut image.counts);

    if let Some(light) = light {
        let cpu_start = Instant::now();
        let mut shadow = Batch::default();
        let mut shadow_counts = MlrtaCounts::default();
        // As on the CPU: an entry point per final tile, packets from it.
        let hit = |i: u32| image.hits[i as usize];
        for tile in image.tiles.iter().filter(|t| t.entry.is_some()) {
            let Some(start) = shadow_tile_entry(&c, light, tile.rect, hit, &mut shadow_counts) else {
                continue;
            };
            for block in block_rects(tile.rect) {
                let rays = ShadowRays::new(&c, light, block, hit);
                if rays.len == 0 {
                    continue;
                }
                shadow.add_group(
                    p,
                    light,
                    &rays.to_points[..rays.len],
                    &rays.pixels[..rays.len],
                    1.0 - SHADOW_EPSILON,
                    true,
                    &start,
                    None,
                    &mut shadow_counts,
                );
            }
        }
        cpu_ms += cpu_start.elapsed().as_secs_f64() * 1e3;
        let PacketOutput {
            hits: blocked,
            counts,
            gpu_ms: ms,
        } = run_packets(ctx, gpu_tree, &shadow)?;
        let mut shadow_hits = vec![Hit::MISS; rays.len()];
        scatter(&shadow, &blocked, &counts, &mut shadow_hits, &mut shadow_counts);
        shadow_counts.packets = image.counts.packets;
        image.shadowed = Some(shadow_hits.iter().map(Hit::is_hit).collect());
        image.shadow_counts = shadow_counts;
        gpu_ms = match (gpu_ms, ms) {
            (Some(a), Some(b)) => Some(a + b),
            _ => None,
        };
    }
    Ok(GpuImageTrace {
        image,
        gpu_ms,
        cpu_ms,
        wall_ms: start.elapsed().as_secs_f64() * 1e3,
    })
}

fn merge(into: &mut Batch, b: Batch) {
    let offset = into.targets.len() as u32;
    into.records.extend(b.records.into_iter().map(|r| PacketRecord {
        first_ray: r.first_ray + offset,
        ..r
    }));
    into.dirs.extend(b.dirs);
    into.targets.extend(b.targets);
}

/// Hits into their targets; per packet, traversal steps and intersection
/// tests are the most any of its lanes did (the packet as a whole does what
/// its longest-running lane does).
fn scatter(batch: &Batch, hits: &[Hit], lane_counts: &[[u32; 2]], out: &mut [Hit], counts: &mut MlrtaCounts) {
    for (i, &t) in batch.targets.iter().enumerate() {
        out[t as usize] = hits[i];
    }
    for r in &batch.records {
        let lanes = &lane_counts[r.first_ray as usize..(r.first_ray + r.ray_count) as usize];
        let cells = lanes.iter().map(|c| c[0] as u64).max().unwrap_or(0);
        let isects = lanes.iter().map(|c| c[1] as u64).max().unwrap_or(0);
        if r.flags & FLAG_SINGLE != 0 {
            counts.single_rays += 1;
            counts.single_cells += cells;
            counts.single_isects += isects;
        } else {
            counts.xp_cells += cells;
            counts.isects += isects;
        }
    }
}

/// Packets per dispatch: a dispatch's grid and the storage bindings bound it.
const PACKETS_PER_BATCH: usize = 1 << 16;

/// What one batch of packets gives back: a hit per ray, the ray's
/// (cells, intersections) counts, and the kernel time when timed.
struct PacketOutput {
    hits: Vec<Hit>,
    counts: Vec<[u32; 2]>,
    gpu_ms: Option<f64>,
}

fn run_packets(ctx: &GpuContext, tree: &GpuKdTree, batch: &Batch) -> Result<PacketOutput> {
    let n_rays = batch.targets.len();
    if batch.records.is_empty() {
        return Ok(PacketOutput {
            hits: Vec::new(),
            counts: Vec::new(),
            gpu_ms: Some(0.0),
        });
    }
    let device = &ctx.device;
    let pass = ctx.kernels.get_or_insert(|| PacketPass::new(device));
    check_storage_size(device, "packet directions", batch.dirs.len() as u64 * 4)?;
    let dirs = storage_buffer(device, "packet directions", bytemuck::cast_slice(&batch.dirs))?;
    let hits_buf = zeroed_buffer(
        device,
        "packet hits",
        n_rays as u64 * 8,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    let counts_buf = zeroed_buffer(
        device,
        "packet counts",
        n_rays as u64 * 8,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    let readback = zeroed_buffer(
        device,
        "packet readback",
        n_rays as u64 * 16,
        wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
    );
    let chunks: Vec<&[PacketRecord]> = batch.records.chunks(PACKETS_PER_BATCH).collect();
    let mut timer = PassTimer::new(ctx, chunks.len() as u32);
    let max_dim = device.limits().max_compute_workgroups_per_dimension;
    let mut encoder = device.create_command_encoder(&Default::default());
    let mut keep = Vec::new();
    for chunk in &chunks {
        let records = storage_buffer(device, "packet records", bytemuck::cast_slice(chunk))?;
        let n = chunk.len() as u32;
        let groups = n.div_ceil(PACKETS_PER_WORKGROUP);
        let x = groups.min(max_dim);
        let params = uniform_buffer(
            device,
            "packet params",
            &PacketParams {
                packet_count: n,
                row_pitch: x,
                _pad: [0; 2],
            },
        );
        let io = bind_group(
            device,
            "packets io",
            &pass.io_layout,
            &[
                (0, &records),
                (1, &dirs),
                (2, &hits_buf),
                (3, &params),
                (4, &counts_buf),
            ],
        );
        let grid = (x, groups.div_ceil(x));
        pass.record(
            &mut encoder,
            timer.as_mut().and_then(|t| t.next_pass()),
            tree,
            &io,
            grid,
        );
        keep.push((records, params, io));
    }
    encoder.copy_buffer_to_buffer(&hits_buf, 0, &readback, 0, n_rays as u64 * 8);
    encoder.copy_buffer_to_buffer(&counts_buf, 0, &readback, n_rays as u64 * 8, n_rays as u64 * 8);
    ctx.queue.submit([encoder.finish()]);
    let words: Vec<[u32; 2]> = read_back(device, &readback, 2 * n_rays)?;
    drop(keep);
    let hits = words[..n_rays]
        .iter()
        .map(|&[t, triangle]| Hit {
            t: f32::from_bits(t),
            triangle,
        })
        .collect();
    let gpu_ms = PassTimer::finish(timer, ctx)?;
    Ok(PacketOutput {
        hits,
        counts: words[n_rays..].to_vec(),
        gpu_ms,
    })
}

const _: () = assert!(std::mem::size_of::<PacketRecord>() == 96 && PACKET == 16);
