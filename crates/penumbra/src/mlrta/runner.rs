//! The trace runner (`penumbra trace`): a camera's primary rays through a
//! mesh one ray at a time (the foundation's path, for comparison) or as
//! 4x4 packets with multi-level ray tracing, optionally shadow rays to a
//! point light and anti-aliasing, on the CPU or with the packets in WGSL;
//! with the per-packet statistics of the MLRTA paper's Tables 2 and 3.

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use serde_json::Value;

use super::aa::{self, AaMode};
use super::gpu::PacketBatches;
use super::packet::MlrtaCounts;
use super::prepared::{Prepared, PreparedStats};
use super::tiles::{ImageBuffers, ImageTrace, MlrtaSettings, SHADOW_EPSILON, TileReport, trace_camera_into};
use crate::accel::bvh::packet::PacketCounts;
use crate::accel::kdtree::gpu::GpuKdTree;
use crate::accel::kdtree::{BuildStats, KdTree};
use crate::accel::{Accel, BvhStats, Structure};
use crate::error::Result;
use crate::geom::aabb::Aabb;
use crate::geom::ray::{Hit, Ray};
use crate::gpu::device::{Device, GpuOutput, Timing, elapsed_ms};
use crate::progress::Reporter;
use crate::raycast::tracer::{Tracer, build_tree, tree_params};
use crate::scene::{Camera, CameraRays, Mesh, View};

/// Rays per side of a packet in the statistics.
const PACKET: u32 = 4;

/// Where shadow rays go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShadowLight {
    /// No shadow rays.
    None,
    /// A point light one scene diagonal above the scene, slightly off-axis.
    AboveScene,
    /// World coordinates, in f64 (`scene::frame`).
    At(glam::DVec3),
}

impl ShadowLight {
    /// The light in the frame of a mesh whose origin is `origin` and
    /// bounds (in that frame) `bounds`.
    pub fn position(self, bounds: &Aabb, origin: glam::DVec3) -> Option<Vec3> {
        match self {
            ShadowLight::None => None,
            ShadowLight::AboveScene => {
                Some(bounds.center() + Vec3::new(-0.4, 1.0, 0.3).normalize() * bounds.diagonal())
            }
            ShadowLight::At(p) => Some(crate::scene::frame::to_local(origin, p)),
        }
    }
}

/// Anti-aliasing and its measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AaRequest {
    /// Where extra rays go (`AaMode::None`: no anti-aliasing, one ray per
    /// pixel).
    pub mode: AaMode,
    /// Rays per pixel where it applies (a square, 4 to 64).
    pub samples: u32,
    /// Also render 16 rays per pixel everywhere and report the edge error.
    pub reference: bool,
}

/// One image to trace.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceRequest {
    /// The camera (resolved against the scene's) and the image size.
    pub view: View,
    /// One ray at a time instead of packets.
    pub single_ray: bool,
    /// What rays walk on the CPU: single rays the BVH or the kd-tree;
    /// packets the kd-tree with MLRTA (`params`) or, with
    /// `Structure::Bvh`, the BVH from its root (`bvh::packet`; no tiles or
    /// anti-aliasing). The GPU walks the kd-tree.
    pub accel: Structure,
    /// Packets: entry points on or off, tile sizes.
    pub params: MlrtaSettings,
    /// Where shadow rays go, one from the light to each primary hit.
    pub light: ShadowLight,
    /// Anti-aliasing (packets through the kd-tree only).
    pub aa: AaRequest,
}

impl TraceRequest {
    /// Checks the image size, that anti-aliasing has MLRTA's tiles to
    /// follow (not BVH packets), the tile knobs
    /// (`MlrtaSettings::validate`) and the anti-aliasing sample count (a
    /// square from 4 to 64, checked whatever the mode).
    pub fn validate(&self) -> Result<()> {
        crate::scene::check_image_size(self.view.width, self.view.height)?;
        if !self.single_ray && self.accel == Structure::Bvh && self.aa.mode != AaMode::None {
            return Err(crate::error::Error::param(
                "aa",
                "anti-aliasing follows MLRTA's tiles: it needs packets through the kd-tree, not the BVH",
            ));
        }
        self.params.validate()?;
        aa::validate_samples(self.aa.samples)
    }
}

/// A traced image: its rays, hits and shadows, and what it cost.
pub struct TracedImage {
    /// The camera the view resolved to, in the mesh's frame (`Mesh::origin`
    /// subtracted).
    pub camera: Camera,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The primary rays, one per pixel, row-major from the top left, in the
    /// mesh's frame.
    pub rays: Vec<Ray>,
    /// Per ray, its closest hit (`Hit::MISS` where it hits nothing).
    pub hits: Vec<Hit>,
    /// Per pixel, whether the hit is in shadow (with a light).
    pub shadowed: Option<Vec<bool>>,
    /// The point light the shadow rays start from, in the mesh's frame;
    /// `None` without shadows.
    pub light: Option<Vec3>,
    /// Final tiles (packets only).
    pub tiles: Vec<TileReport>,
    /// The anti-aliased image and where its rays went (with AA).
    pub aa: Option<aa::AaResult>,
    /// What it cost, as `penumbra trace --json` reports it.
    pub stats: TraceStats,
}

/// What `penumbra trace --json` reports, by the paper's Tables 2 and 3.
#[derive(Debug, Clone, Serialize)]
pub struct TraceStats {
    /// Primary rays: one per pixel.
    pub rays: usize,
    /// Primary rays that hit a triangle.
    pub hits: usize,
    /// Wall-clock milliseconds of the kd-tree's build (`kdtree.build_ms`).
    pub build_ms: f64,
    /// The kd-tree built for the mesh (every mode builds it).
    pub kdtree: BuildStats,
    /// The camera in world (file) coordinates, where the user's scene is.
    pub camera: Camera,
    /// "single-ray", MLRTA "on"/"off", or "bvh-packets".
    pub mlrta: &'static str,
    /// On the CPU, the structure rays walked, and the BVH's cost when it
    /// was that (single rays' traversal counts are the kd-tree's walk of
    /// the same rays either way).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accel: Option<Structure>,
    /// The BVH's cost, when rays walked it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bvh: Option<BvhStats>,
    /// BVH packets: what the walk did (rays that went one by one included).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bvh_packets: Option<PacketCounts>,
    /// How `trace_ms` was measured.
    pub timing: Timing,
    /// Primary (and shadow) rays' time: kernel time on a GPU with timestamps.
    pub trace_ms: f64,
    /// Millions of rays per second over `trace_ms`: the primary rays, and
    /// with a light one shadow ray per hit.
    pub mrays_per_s: f64,
    /// Traversal steps (entry-point and packet steps together) per 4x4 packet.
    pub cells_per_packet: f64,
    /// Triangle tests per 4x4 packet of the image (Table 2's intersection
    /// tests: a triangle tested against any of a packet's rays counts once;
    /// single rays' tests each count).
    pub isects_per_packet: f64,
    /// Packets through the kd-tree: their counts, preparation and tiles
    /// (flattened into the report); `None` for single rays and BVH packets.
    #[serde(flatten)]
    pub packets: Option<PacketStats>,
    /// Shadow rays, with a light.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadows: Option<ShadowStats>,
    /// The anti-aliasing report (`AaResult::report`), with anti-aliasing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub aa: Option<Value>,
}

/// Statistics of packets with or without entry points.
#[derive(Debug, Clone, Serialize)]
pub struct PacketStats {
    /// Nodes the primary rays' entry-point searches visited, per 4x4 packet
    /// of the image.
    pub ep_steps_per_packet: f64,
    /// The primary rays' statistics, summed over the image.
    pub counts: MlrtaCounts,
    /// Wall-clock milliseconds of preparing the kd-tree for MLRTA
    /// (subtree sizes, occluders); not part of `trace_ms`.
    pub prepare_ms: f64,
    /// What the preparation found.
    pub prepared: PreparedStats,
    /// The tile knobs and the tiles they made.
    pub tiles: TileStats,
    /// GPU: CPU time of tiles, entry points and packet records.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cpu_ms: Option<f64>,
    /// GPU: wall-clock milliseconds of the whole image, CPU work, uploads
    /// and read-backs included.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_ms: Option<f64>,
}

/// Tile splitting of the primary rays (section 4.2): the knobs and the
/// final tiles they made.
#[derive(Debug, Clone, Serialize)]
pub struct TileStats {
    /// Initial tile side in pixels (ITS, `MlrtaSettings::initial_tile`).
    pub initial: u32,
    /// Minimum tile side in pixels (MTS, `MlrtaSettings::min_tile`).
    pub min: u32,
    /// Pieces a tile is split into (SF).
    pub split_factor: u32,
    /// Final tiles (reported as `final`).
    #[serde(rename = "final")]
    pub final_tiles: usize,
    /// Final tiles whose rays' directions differ in sign (no entry point).
    pub diverging: usize,
    /// Final tiles whose entry-point search stopped at an occluder
    /// (stopping rule (4)).
    pub stopped_at_occluder: usize,
}

/// Shadow rays: primary + shadow statistics (packets only), and results.
#[derive(Debug, Clone, Serialize)]
pub struct ShadowStats {
    /// The point light, in the mesh's frame.
    pub light: [f32; 3],
    /// Traversal steps of primary and shadow rays together per 4x4 packet
    /// (Table 3); kd-tree packets only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cells_per_packet: Option<f64>,
    /// Triangle tests of primary and shadow rays together per 4x4 packet;
    /// kd-tree packets only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub isects_per_packet: Option<f64>,
    /// Entry-point search steps of primary and shadow rays together per 4x4
    /// packet; kd-tree packets only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ep_steps_per_packet: Option<f64>,
    /// The shadow rays' own statistics; kd-tree packets only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub counts: Option<MlrtaCounts>,
    /// Shadow rays traced: one per primary hit.
    pub shadow_rays: usize,
    /// Primary hits whose shadow ray is blocked.
    pub shadowed_hits: usize,
}

impl ShadowStats {
    /// Shadow rays to `light` without traversal statistics of their own
    /// (single rays, BVH packets); the ray counts are filled in later.
    fn uncounted(light: Vec3) -> ShadowStats {
        ShadowStats {
            light: light.to_array(),
            cells_per_packet: None,
            isects_per_packet: None,
            ep_steps_per_packet: None,
            counts: None,
            shadow_rays: 0,
            shadowed_hits: 0,
        }
    }
}

/// What a traversal mode traced, before the statistics every mode shares.
struct Traced {
    hits: Vec<Hit>,
    shadowed: Option<Vec<bool>>,
    tiles: Vec<TileReport>,
    aa: Option<aa::AaResult>,
    mlrta: &'static str,
    accel: Option<Structure>,
    bvh: Option<BvhStats>,
    bvh_packets: Option<PacketCounts>,
    timing: Timing,
    trace_ms: f64,
    /// Traversal steps and intersection tests over the image.
    cells: f64,
    isects: f64,
    packets: Option<PacketStats>,
    shadows: Option<ShadowStats>,
    aa_report: Option<Value>,
}

/// Traces `request`'s image of `mesh` (the scene at one moment; its camera,
/// if any, is `scene_camera`) on `device`.
pub fn trace_view(
    device: &Device,
    mesh: &Mesh,
    scene_camera: Option<Camera>,
    request: &TraceRequest,
    bars: &Reporter,
) -> Result<TracedImage> {
    request.validate()?;
    let (width, height) = (request.view.width, request.view.height);
    let bounds = mesh.bounds();
    let camera = request.view.camera.resolve(scene_camera, &bounds, mesh.origin)?;
    let light = request.light.position(&bounds, mesh.origin);
    let tree = build_tree(mesh, &tree_params(device), bars, "trace")?;
    let camera_rays = CameraRays::new(&camera, width, height);
    let rays = camera_rays.rays();
    let packets = (width.div_ceil(PACKET) as u64 * height.div_ceil(PACKET) as u64) as f64;
    let progress = bars.spinner(&format!("tracing {width}x{height} primary rays"));
    let kdtree = tree.stats.clone();
    let mut t = if request.single_ray {
        single_ray(device, tree, rays, light, request.accel)?
    } else if request.accel == Structure::Bvh && !device.is_gpu() {
        bvh_packets(Accel::new(tree), rays, (width, height), light)
    } else {
        packet_image(device, &tree, mesh, &camera, &camera_rays, request, light, packets)?
    };
    progress.finish();
    let hits = t.hits.iter().filter(|h| h.is_hit()).count();
    if let (Some(stats), Some(shadowed)) = (t.shadows.as_mut(), &t.shadowed) {
        stats.shadow_rays = hits;
        stats.shadowed_hits = shadowed.iter().filter(|&&x| x).count();
    }
    // With a light, every hit also sends a shadow ray within the timed work.
    let traced = rays.len() + if light.is_some() { hits } else { 0 };
    let stats = TraceStats {
        rays: rays.len(),
        hits,
        build_ms: kdtree.build_ms,
        kdtree,
        // Reported where the user's scene is, not in its frame.
        camera: camera.in_world(mesh.origin),
        mlrta: t.mlrta,
        accel: t.accel,
        bvh: t.bvh,
        bvh_packets: t.bvh_packets,
        timing: t.timing,
        trace_ms: t.trace_ms,
        mrays_per_s: crate::report::mrays_per_s(traced, t.trace_ms),
        cells_per_packet: t.cells / packets,
        isects_per_packet: t.isects / packets,
        packets: t.packets,
        shadows: t.shadows,
        aa: t.aa_report,
    };
    Ok(TracedImage {
        camera,
        width,
        height,
        rays: camera_rays.into_rays(),
        hits: t.hits,
        shadowed: t.shadowed,
        light,
        tiles: t.tiles,
        aa: t.aa,
        stats,
    })
}

/// The foundation's single-ray path (statistics summed over all rays: the
/// kd-tree's walk of the rays, whichever structure traced them); shadow
/// rays on the CPU, timed into the trace.
fn single_ray(
    device: &Device,
    tree: KdTree,
    rays: &[Ray],
    light: Option<Vec3>,
    structure: Structure,
) -> Result<Traced> {
    let mut tracer = Tracer::from_tree(device, tree)?.with_structure(structure);
    let traced = tracer.closest(rays)?;
    let counts = tracer.traversal_counts(rays)?;
    let hits = traced.value;
    let mut trace_ms = traced.ms;
    let shadowed = light.map(|l| {
        let any_hit = tracer.any_hit_fn();
        let start = std::time::Instant::now();
        let shadow: Vec<bool> = rays
            .par_iter()
            .zip(&hits)
            .map(|(r, h)| h.is_hit() && any_hit(l, r.o() + h.t * r.d() - l, 1.0 - SHADOW_EPSILON))
            .collect();
        trace_ms += elapsed_ms(start);
        shadow
    });
    let shadows = light.map(ShadowStats::uncounted);
    Ok(Traced {
        hits,
        shadowed,
        tiles: Vec::new(),
        aa: None,
        mlrta: "single-ray",
        accel: (!device.is_gpu()).then_some(structure),
        bvh: tracer.bvh_stats().cloned(),
        bvh_packets: None,
        timing: traced.timing,
        trace_ms,
        cells: counts.cells as f64,
        isects: counts.intersections as f64,
        packets: None,
        shadows,
        aa_report: None,
    })
}

fn cells(c: &MlrtaCounts) -> f64 {
    (c.ep_steps + c.xp_cells + c.single_cells) as f64
}

fn isects(c: &MlrtaCounts) -> f64 {
    (c.isects + c.single_isects) as f64
}

/// 4x4 packets through the wide BVH on the CPU (`bvh::packet`): no tiles
/// or entry points, each block of the image from the root; shadow rays as
/// any-hit packets from the light to each block's hits. Statistics: BVH
/// nodes and leaves visited, and triangle tests, per packet.
fn bvh_packets(accel: Accel, rays: &[Ray], (width, height): (u32, u32), light: Option<Vec3>) -> Traced {
    use crate::accel::bvh::packet;
    let bvh = accel.bvh_stats();
    let (wide, tree) = (accel.bvh(), accel.kdtree());
    let isa = crate::geom::simd::Isa::best();
    let start = std::time::Instant::now();
    let (hits, c) = packet::trace_image(wide, tree, rays, width, height, isa);
    let shadowed = light.map(|l| packet::shadows(wide, tree, rays, &hits, width, l, SHADOW_EPSILON, isa));
    let trace_ms = elapsed_ms(start);
    Traced {
        hits,
        shadowed,
        tiles: Vec::new(),
        aa: None,
        mlrta: "bvh-packets",
        accel: Some(Structure::Bvh),
        bvh: Some(bvh),
        bvh_packets: Some(c),
        timing: Timing::Wall,
        trace_ms,
        cells: (c.nodes + c.leaves) as f64,
        isects: c.triangle_tests as f64,
        packets: None,
        shadows: light.map(ShadowStats::uncounted),
        aa_report: None,
    }
}

/// 4x4 packets, with or without entry points, on the device; AA on the CPU.
#[allow(clippy::too_many_arguments)]
fn packet_image(
    device: &Device,
    tree: &KdTree,
    mesh: &Mesh,
    camera: &Camera,
    camera_rays: &CameraRays,
    request: &TraceRequest,
    light: Option<Vec3>,
    packets: f64,
) -> Result<Traced> {
    let (w, h) = (request.view.width, request.view.height);
    let rays = camera_rays.rays();
    let params = &request.params;
    let prepare = std::time::Instant::now();
    let (prepared, prepared_stats) = Prepared::new(tree, mesh);
    let prepare_ms = elapsed_ms(prepare);
    let mut gpu = device.prepare(|ctx| Ok((GpuKdTree::upload(&ctx.device, tree)?, PacketBatches::new(ctx))))?;
    // The CPU path traces into storage made before the clock starts, as
    // a host's next frame would (`ImageBuffers`).
    let buffers = (!device.is_gpu()).then(|| ImageBuffers::new(rays.len(), light.is_some()));
    let (mut cpu_ms, mut wall_ms) = (None, None);
    let traced = gpu.run(
        |ctx, (gpu_tree, batches)| {
            let t = batches.trace_image(ctx, gpu_tree, &prepared, rays, w, h, params, light)?;
            (cpu_ms, wall_ms) = (Some(t.cpu_ms), Some(t.wall_ms));
            Ok(GpuOutput {
                value: t.image,
                gpu_ms: t.gpu_ms,
            })
        },
        || trace_camera_into(&prepared, camera_rays, params, light, buffers.unwrap_or_default()),
    )?;
    let ImageTrace {
        hits,
        shadowed,
        counts: c,
        shadow_counts: s,
        tiles,
    } = traced.value;
    let packet_stats = PacketStats {
        ep_steps_per_packet: c.ep_steps as f64 / packets,
        counts: c,
        prepare_ms,
        prepared: prepared_stats,
        tiles: TileStats {
            initial: params.initial_tile,
            min: params.min_tile,
            split_factor: params.split_factor,
            final_tiles: tiles.len(),
            diverging: tiles.iter().filter(|t| t.diverging).count(),
            stopped_at_occluder: tiles.iter().filter(|t| t.stopped).count(),
        },
        cpu_ms,
        wall_ms,
    };
    let shadows = light.map(|l| ShadowStats {
        light: l.to_array(),
        cells_per_packet: Some((cells(&c) + cells(&s)) / packets),
        isects_per_packet: Some((isects(&c) + isects(&s)) / packets),
        ep_steps_per_packet: Some((c.ep_steps + s.ep_steps) as f64 / packets),
        counts: Some(s),
        shadow_rays: 0,
        shadowed_hits: 0,
    });
    let (aa, aa_report) = match request.aa.mode {
        AaMode::None => (None, None),
        mode => {
            let samples = request.aa.samples;
            let result = aa::render(&prepared, camera, w, h, params, mode, samples, &tiles)?;
            let reference = if request.aa.reference {
                let mut r = aa::reference(&prepared, camera, w, h);
                if mode == AaMode::Adaptive {
                    r.uniform = Some(aa::render(
                        &prepared,
                        camera,
                        w,
                        h,
                        params,
                        AaMode::Uniform,
                        samples,
                        &tiles,
                    )?);
                }
                Some(r)
            } else {
                None
            };
            let report = result.report(reference);
            (Some(result), Some(report))
        }
    };
    Ok(Traced {
        hits,
        shadowed,
        tiles,
        aa,
        mlrta: if params.entry_points { "on" } else { "off" },
        accel: None,
        bvh: None,
        bvh_packets: None,
        timing: traced.timing,
        trace_ms: traced.ms,
        cells: cells(&c),
        isects: isects(&c),
        packets: Some(packet_stats),
        shadows,
        aa_report,
    })
}

impl TracedImage {
    /// The shaded image: |cos| between the ray and the hit triangle, shadowed
    /// hits at a quarter, `None` where nothing is hit; the anti-aliased
    /// image when there is one.
    pub fn shading(&self, mesh: &Mesh) -> Vec<Option<f32>> {
        if let Some(aa) = &self.aa {
            return aa.image.iter().map(|&x| Some(x)).collect();
        }
        let shadowed = self.shadowed.as_deref();
        self.rays
            .iter()
            .zip(&self.hits)
            .enumerate()
            .map(|(i, (r, h))| {
                h.is_hit().then(|| {
                    let n = mesh.unit_face_normal(h.triangle as usize);
                    let lit = n.dot(r.d().normalize()).abs();
                    if shadowed.is_some_and(|s| s[i]) {
                        0.25 * lit
                    } else {
                        lit
                    }
                })
            })
            .collect()
    }

    /// Where anti-aliasing put its rays: rays per pixel over the most (AA only).
    pub fn aa_rays(&self) -> Option<Vec<Option<f32>>> {
        self.aa.as_ref().map(|aa| {
            let max = aa.spp.iter().copied().max().unwrap_or(1).max(1) as f32;
            aa.spp.iter().map(|&n| Some(n as f32 / max)).collect()
        })
    }

    /// Figure 7 of the paper, with complexity: each final tile's brightness
    /// is log2 of its entry point's subtree size (relative to the largest);
    /// red marks diverging tiles, blue tiles whose search stopped at an
    /// occluder; tile borders are dark. RGB per pixel.
    pub fn tile_map(&self) -> Vec<[u8; 3]> {
        let width = self.width;
        let mut img = vec![[0u8; 3]; width as usize * self.height as usize];
        let max = self.tiles.iter().map(|t| t.complexity).max().unwrap_or(1).max(2) as f32;
        for t in &self.tiles {
            let level = if t.complexity == 0 {
                0.0
            } else {
                (t.complexity as f32).log2() / max.log2()
            };
            let g = (40.0 + 215.0 * level) as u8;
            let color = if t.diverging {
                [220, 40, 40]
            } else if t.stopped {
                [g / 2, g / 2, g]
            } else {
                [g, g, g]
            };
            let r = t.rect;
            for y in r.y..r.y + r.h {
                for x in r.x..r.x + r.w {
                    let border = x == r.x || y == r.y;
                    img[(y * width + x) as usize] = if border { [0, 0, 0] } else { color };
                }
            }
        }
        img
    }
}
