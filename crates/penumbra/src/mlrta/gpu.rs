//! MLRTA on the GPU: the CPU splits tiles and searches entry points (cheap,
//! branchy work), the `packet_traverse.wgsl` kernel traces the packets (a
//! workgroup per 4x4 packet, the packet's entry node and frustum shared by its
//! lanes). Hits equal the CPU packets' and the single-ray path's.

use std::ops::Range;
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use rayon::prelude::*;

use crate::error::Result;
use crate::gpu::GpuContext;
use crate::gpu::batch::{BatchPlan, Batched, run_batches};
use crate::gpu::device::elapsed_ms;
use std::sync::Arc;

use crate::accel::kdtree::gpu::GpuKdTree;
use crate::accel::kdtree::pass::{Dispatch, TreeBatch, TreeKernelSet, TreeKernels, TreePass};
use crate::geom::ray::{Hit, Ray};
use crate::gpu::kernels::{Kernels, PipelineLog};
use crate::gpu::layout::Io;
use crate::mlrta::entry_point::EntryPoint;
use crate::mlrta::frustum::sign_class;
use crate::mlrta::packet::{MlrtaCounts, PACKET, Packet};
use crate::mlrta::prepared::Prepared;
use crate::mlrta::tiles::{
    Ctx, DEFAULT_EP_BUDGET, ImageTrace, MlrtaSettings, Rect, SHADOW_EPSILON, ShadowRays, TileOut, TileSummary,
    block_rects, pixels, search_below, shadow_tile_entry, split_tiles, stray_origin,
};
use crate::progress::Bar;

/// One packet for the kernel (up to 16 rays with a common origin, or one
/// ray traced alone); mirrors `PacketRecord` in `wgsl/packet_traverse.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct PacketRecord {
    /// The rays' common origin.
    pub origin: [f32; 3],
    /// Rays end at this `t` (in units of their directions); `f32::MAX` for
    /// none. Re-traces from the root use it.
    pub t_max: f32,
    /// Per axis, the lower end of the packet's widened interval of `1 / d`
    /// (`Frustum::inv`).
    pub inv_lo: [f32; 3],
    /// `EntryPoint::node`: the kd-tree node the traversal starts at.
    pub entry_node: u32,
    /// Per axis, the upper end of the widened interval of `1 / d`.
    pub inv_hi: [f32; 3],
    /// Index of the packet's first ray in the directions and hits buffers;
    /// its rays follow it.
    pub first_ray: u32,
    /// Lower corner of the entry point's cell (`EntryPoint::cell`).
    pub cell_min: [f32; 3],
    /// Rays in the packet, 1 to 16.
    pub ray_count: u32,
    /// Upper corner of the entry point's cell.
    pub cell_max: [f32; 3],
    /// Bits 0 to 2: the directions' x, y, z components are positive; 8:
    /// the entry point is speculative (rays that miss are traced again from
    /// the root); 16: any hit will do (shadow rays); 32: a single ray
    /// traced from the root (a zero direction component), no frustum.
    pub flags: u32,
    /// `EntryPoint::t_limit` (at most `t_max`): the packet traversal stops
    /// there.
    pub t_limit: f32,
    /// Padding to the WGSL struct's 16-byte size multiple.
    pub _pad: [f32; 3],
}

/// Packets in one workgroup of the kernel.
const PACKETS_PER_WORKGROUP: u32 = 4;
const FLAG_SPECULATIVE: u32 = 8;
const FLAG_ANY_HIT: u32 = 16;
const FLAG_SINGLE: u32 = 32;

/// `PacketUniforms` in the kernel.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct PacketUniforms {
    packet_count: u32,
    row_pitch: u32,
    _pad: [u32; 2],
}

/// The packet pass's io: records, directions (3 f32 per ray), hits,
/// params, counts (per ray).
const PACKET_IO: &[Io] = &[
    Io::In(0, "packet records"),
    Io::In(1, "packet directions"),
    Io::Out(2, "packet hits"),
    Io::Uniform(3, "packet params", std::mem::size_of::<PacketUniforms>() as u64),
    Io::Out(4, "packet counts"),
];

/// The pipeline of `packet_traverse.wgsl` for one device.
pub struct PacketKernels(TreeKernels);

impl Kernels for PacketKernels {
    fn build(device: &wgpu::Device, log: &Arc<PipelineLog>) -> PacketKernels {
        let module = &crate::gpu::wgsl::PACKET_TRAVERSE_MODULE;
        PacketKernels(TreeKernels::build(device, module, PACKET_IO, &["trace_packet"], log))
    }
}

impl TreeKernelSet for PacketKernels {
    const IO: &'static [Io] = PACKET_IO;
    const LABEL: &'static str = "packets";
    fn tree_kernels(&self) -> &TreeKernels {
        &self.0
    }
}

/// The packet pass: kernels and the buffers of one batch of packets.
pub type PacketPass = TreePass<PacketKernels>;

impl TreePass<PacketKernels> {
    /// Uploads packets whose rays' directions are `dirs` (3 f32 each, in
    /// the order of the records' `first_ray`): a workgroup per
    /// `PACKETS_PER_WORKGROUP` packets.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        records: &[PacketRecord],
        dirs: &[f32],
    ) -> Result<()> {
        let rays = dirs.len() as u64 / 3;
        let n = records.len() as u32;
        let groups = n.div_ceil(PACKETS_PER_WORKGROUP).max(1);
        let x = groups.min(device.limits().max_compute_workgroups_per_dimension);
        let params = PacketUniforms {
            packet_count: n,
            row_pitch: x,
            _pad: [0; 2],
        };
        let io = self.io();
        io.write(device, queue, 0, bytemuck::cast_slice(records))?;
        io.write(device, queue, 1, bytemuck::cast_slice(dirs))?;
        io.reserve(device, 2, rays * 8)?;
        io.write(device, queue, 3, bytemuck::bytes_of(&params))?;
        io.reserve(device, 4, rays * 8)?;
        let dispatch = Dispatch {
            entry: 0,
            grid: (x, groups.div_ceil(x)),
            clear: None,
            results: vec![(2, rays * 8), (4, rays * 8)],
        };
        self.set_dispatch(device, dispatch);
        Ok(())
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
                    search_below(p, f, start, inside, DEFAULT_EP_BUDGET, &mut counts.ep_steps)
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

/// An image traced with its packets on the GPU
/// (`PacketBatches::trace_image`), and where its time went.
pub struct GpuImageTrace {
    /// Hits, shadow flags, counts and tiles, as the CPU path returns them.
    pub image: ImageTrace,
    /// Kernel time of the packet passes (timestamps), where supported.
    pub gpu_ms: Option<f64>,
    /// CPU time spent on tiles, entry points and packet records.
    pub cpu_ms: f64,
    /// Wall-clock milliseconds of the whole call, uploads and read-backs
    /// included.
    pub wall_ms: f64,
}

/// The packet pass with its read-back buffer, as a runner keeps it on a
/// device between images.
pub type PacketBatches = Batched<PacketPass>;

impl Batched<PacketPass> {
    /// `tiles::trace_image` with the packets traced on the GPU.
    #[allow(clippy::too_many_arguments)]
    pub fn trace_image(
        &mut self,
        ctx: &GpuContext,
        gpu_tree: &GpuKdTree,
        p: &Prepared,
        rays: &[Ray],
        width: u32,
        height: u32,
        params: &MlrtaSettings,
        light: Option<Vec3>,
    ) -> Result<GpuImageTrace> {
        let start = Instant::now();
        let c = Ctx::new(p, rays, width, height, params, light, None)?;
        // Tiles and entry points on the CPU; each final block becomes packets.
        let parts: Vec<(TileOut, Batch)> = c
            .initial_tiles(height)
            .par_iter()
            .map(|&rect| {
                let mut out = TileOut::default();
                let mut batch = Batch::default();
                let mut emit = |entry: &EntryPoint, rect: Rect, out: &mut TileOut| {
                    for block in block_rects(rect) {
                        let ids: Vec<u32> = pixels(block, width).collect();
                        let dirs: Vec<Vec3> = ids.iter().map(|&i| rays[i as usize].d()).collect();
                        // As `tiles::trace_block` checks it on the CPU.
                        out.stray_origin |= ids.iter().any(|&i| rays[i as usize].o() != c.origin);
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
                    }
                };
                split_tiles(&c, rect, c.root(), 0, &mut out, &mut emit);
                (out, batch)
            })
            .collect();
        if parts.iter().any(|(out, _)| out.stray_origin) {
            return Err(stray_origin());
        }
        let mut batch = Batch::default();
        let mut outs = Vec::new();
        for (out, b) in parts {
            merge(&mut batch, b);
            outs.push(out);
        }
        let mut cpu_ms = elapsed_ms(start);
        let mut image = c.image(Vec::new(), None, TileSummary::of(outs), height);
        let PacketOutput {
            hits,
            counts,
            mut gpu_ms,
        } = self.run_packets(ctx, gpu_tree, &batch)?;
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
            cpu_ms += elapsed_ms(cpu_start);
            let PacketOutput {
                hits: blocked,
                counts,
                gpu_ms: ms,
            } = self.run_packets(ctx, gpu_tree, &shadow)?;
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
            wall_ms: elapsed_ms(start),
        })
    }

    fn run_packets(&mut self, ctx: &GpuContext, tree: &GpuKdTree, batch: &Batch) -> Result<PacketOutput> {
        if batch.records.is_empty() {
            return Ok(PacketOutput {
                hits: Vec::new(),
                counts: Vec::new(),
                gpu_ms: Some(0.0),
            });
        }
        let n_rays = batch.targets.len();
        let mut hits = Vec::with_capacity(n_rays);
        let mut counts = Vec::with_capacity(n_rays);
        let mut packets = TreeBatch {
            pass: &mut self.pass,
            tree,
            prepare: |pass: &mut PacketPass, ctx: &GpuContext, items: Range<usize>| {
                let (records, dirs) = batch.slice(items);
                pass.prepare(&ctx.device, &ctx.queue, &records, dirs)
            },
        };
        let plan = BatchPlan::new(batch.records.len(), PACKETS_PER_BATCH, 1);
        let progress = Bar::hidden();
        let gpu_ms = run_batches(
            ctx,
            &mut packets,
            &mut self.readback,
            plan,
            &progress,
            |_, w: &[[u32; 2]]| {
                let n = w.len() / 2;
                hits.extend(w[..n].iter().map(|&[t, triangle]| Hit {
                    t: f32::from_bits(t),
                    triangle,
                }));
                counts.extend_from_slice(&w[n..]);
                Ok(())
            },
        )?;
        Ok(PacketOutput { hits, counts, gpu_ms })
    }
}

impl Batch {
    /// Records `items` with `first_ray` made relative to them, and the
    /// directions of their rays.
    fn slice(&self, items: Range<usize>) -> (Vec<PacketRecord>, &[f32]) {
        let r = &self.records[items];
        let (first, last) = (&r[0], &r[r.len() - 1]);
        let rays = first.first_ray as usize..(last.first_ray + last.ray_count) as usize;
        let records = r
            .iter()
            .map(|p| PacketRecord {
                first_ray: p.first_ray - first.first_ray,
                ..*p
            })
            .collect();
        (records, &self.dirs[3 * rays.start..3 * rays.end])
    }
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
            counts.walks += 1;
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

const _: () = assert!(std::mem::size_of::<PacketRecord>() == 96 && PACKET == 16);
