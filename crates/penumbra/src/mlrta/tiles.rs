//! Tile splitting, section 4.2: primary rays are grouped by image tiles; each
//! tile searches its entry point (starting from its parent tile's) and is
//! split into `split_factor` pieces until it is no larger than `min_tile` or
//! its entry point is a leaf; the 4x4 packets of a final tile are traced from
//! its entry point. Tiles whose rays do not share their directions' signs
//! ("diverging", red in the paper's Figure 7) are split without a search until
//! they reach the minimum size; the packets of a diverging final tile are
//! traced in same-sign sub-groups from the tile's start.
//!
//! Shadow rays go from a point light to the primary hits (section 6: "tracing
//! them from the light sources to the hit points"), so that each packet's
//! shadow rays share an origin too and use the same machinery; each final
//! tile's shadow rays get one entry point.

use glam::Vec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::geom::ray::{Hit, Ray};
use crate::geom::simd::{Isa, Kernel, Lanes, dispatch};
use crate::mlrta::entry_point::{EntryPoint, entry_point};
use crate::mlrta::frustum::{Frustum, sign_class};
use crate::mlrta::packet::{MlrtaCounts, PACKET, Packet, trace_packet_lanes};
use crate::mlrta::prepared::Prepared;
use crate::mlrta::squares::{trace_shadow_tile, trace_tile};
use crate::mlrta::tile_rows::tile_rows;
use crate::scene::{CameraRays, PixelDirections};

/// `MlrtaSettings::min_tile` unless chosen.
pub const DEFAULT_MIN_TILE: u32 = 32;

/// The knobs of section 4.2.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MlrtaSettings {
    /// Entry-point search on (MLRTA) or off (every packet from the root: the
    /// paper's "no MLRT" rows).
    pub entry_points: bool,
    /// Initial tile side in pixels (ITS); the paper's best: 128.
    pub initial_tile: u32,
    /// Tiles no larger than this are not split (MTS). The paper tested 4 to
    /// 64 without fixing one. 32 is the fastest here (CPU, 1024x1024, one
    /// thread: bunny 12.8 Mrays/s against 9.2 with 8, dragon 12.4 against
    /// 9.8, kitchen 26.8 against 25.1) and keeps adaptive anti-aliasing at
    /// uniform supersampling's edge error; 8 traverses the fewest cells
    /// (kitchen 4.50 per packet against 5.71) and is faster for the
    /// lavapipe kernel, whose tiles and entry points are CPU work apart.
    pub min_tile: u32,
    /// Pieces a tile is split into (SF), a square: 4 (2x2), 16 (4x4), 64 (8x8).
    pub split_factor: u32,
    /// The rays are a pinhole camera's image (like `Camera::primary_rays`):
    /// a tile's frustum then comes from its four corner rays instead of all
    /// its rays. Directions are linear in the pixel position up to
    /// normalisation, so each component's sign, and each slope d_b / d_a (a
    /// linear-fractional function), is extreme at the corners; the least
    /// `|1 / d_a|` is bounded from the slopes (`Frustum::from_corners`;
    /// the directions must be of unit length, as the camera's are). Wrong
    /// for other ray images, hence off by default. With it, that the rays share
    /// one origin is checked ray by ray as their blocks are traced, not in
    /// a pass over the whole image first (rays in tiles the entry points
    /// cull are not read at all).
    pub corner_frusta: bool,
    /// Nodes the entry-point search visits in a far subtree before it
    /// counts the subtree as one with potential hits and moves the entry
    /// point up to its bifurcation (`entry_point`); 0 searches every far
    /// subtree to the end, as the paper. The exhaustive search spent 70% of
    /// its steps there, at about 40 ns a step (a packet walk's step costs a
    /// quarter of that, shared by 16 packets), mostly to learn that a
    /// closed mesh's far side has triangles too. With 2 the bunny's 1024^2
    /// primary rays take 23,693 search steps instead of 46,722 and their
    /// walks 183,327 cells instead of 179,017, the same triangle tests;
    /// in-process, one thread, best of three alternated rounds (ms):
    /// exhaustive 15.6 / 18.1 / 20.5 (bunny / dragon100k / kitchen
    /// interior), 1: 14.9 / 16.2 / 19.4, 2: 14.4 / 15.9 / 19.6, 4: 14.6 /
    /// 16.5 / 19.3, 6: 16.0 / 17.2 / 20.3.
    pub ep_budget: u32,
}

/// `MlrtaSettings::ep_budget` unless chosen.
pub const DEFAULT_EP_BUDGET: u32 = 2;

impl Default for MlrtaSettings {
    fn default() -> Self {
        MlrtaSettings {
            entry_points: true,
            initial_tile: 128,
            min_tile: DEFAULT_MIN_TILE,
            split_factor: 16,
            corner_frusta: false,
            ep_budget: DEFAULT_EP_BUDGET,
        }
    }
}

impl MlrtaSettings {
    /// Checks that `split_factor` is a square of at least 4 and that
    /// 4 <= `min_tile` <= `initial_tile`.
    pub fn validate(&self) -> Result<()> {
        let side = (self.split_factor as f64).sqrt() as u32;
        if self.split_factor < 4 || side * side != self.split_factor {
            return Err(Error::param(
                "split_factor",
                format!(
                    "must be a square of at least 4 (4, 16, 64...), got {}",
                    self.split_factor
                ),
            ));
        }
        if self.min_tile < 4 || self.initial_tile < self.min_tile {
            return Err(Error::param(
                "initial_tile/min_tile",
                format!(
                    "need 4 <= min tile <= initial tile, got {} and {}",
                    self.min_tile, self.initial_tile
                ),
            ));
        }
        Ok(())
    }
}

/// A pixel rectangle.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Rect {
    /// Column of its left edge, from the image's left.
    pub x: u32,
    /// Row of its top edge, from the image's top.
    pub y: u32,
    /// Width in pixels.
    pub w: u32,
    /// Height in pixels.
    pub h: u32,
}

/// What happened to one final tile (for the complexity map and Figure 7).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TileReport {
    /// The tile's pixels.
    pub rect: Rect,
    /// Splitting level (0 = initial tile).
    pub level: u32,
    /// Entry point node; `None` when the tile can hit nothing.
    pub entry: Option<u32>,
    /// Nodes in the entry point's subtree: the geometric complexity of the
    /// tile's view (section 4.2); 0 when it hits nothing.
    pub complexity: u32,
    /// Directions of different signs: no entry-point search.
    pub diverging: bool,
    /// The search stopped at an occluder (stopping rule (4)).
    pub stopped: bool,
}

/// The result of tracing an image of rays.
pub struct ImageTrace {
    /// Per ray, row-major, its closest hit (`Hit::MISS` where it hits
    /// nothing).
    pub hits: Vec<Hit>,
    /// Per pixel, whether the primary hit is in shadow (with a light).
    pub shadowed: Option<Vec<bool>>,
    /// The primary rays' statistics, summed over the image.
    pub counts: MlrtaCounts,
    /// The shadow rays' statistics (zero without a light).
    pub shadow_counts: MlrtaCounts,
    /// Every final tile of the image.
    pub tiles: Vec<TileReport>,
}

impl ImageTrace {
    /// The image's pixel storage, for the next frame (`trace_image_into`).
    pub fn into_buffers(self) -> ImageBuffers {
        ImageBuffers {
            hits: self.hits,
            shadowed: self.shadowed.unwrap_or_default(),
        }
    }
}

/// Pixel storage an image is traced into: a host that traces frame after
/// frame keeps it (`ImageTrace::into_buffers`), so that a frame neither
/// allocates its 8 MB of hits (a 1024^2 image) nor touches them for the
/// first time. On this 2-core VM a fresh buffer's page faults and fill took
/// 2.5-2.9 ms of a 19 ms frame (bunny, one thread), a kept one's fill 0.3-0.9
/// ms; Embree's stream fills a ray buffer it allocated once, too.
#[derive(Default)]
pub struct ImageBuffers {
    hits: Vec<Hit>,
    shadowed: Vec<bool>,
}

impl ImageBuffers {
    /// Storage for `pixels` hits (and shadow flags with `shadows`), its
    /// memory touched now rather than in the first frame traced into it.
    pub fn new(pixels: usize, shadows: bool) -> ImageBuffers {
        ImageBuffers {
            hits: vec![Hit::MISS; pixels],
            shadowed: vec![false; if shadows { pixels } else { 0 }],
        }
    }

    /// `pixels` misses (and, with `shadows`, unshadowed flags): the kept
    /// storage cleared in parallel, grown where it is too small.
    fn blank(mut self, pixels: usize, shadows: bool) -> (Vec<Hit>, Option<Vec<bool>>) {
        self.hits.resize(pixels, Hit::MISS);
        self.hits.par_chunks_mut(1 << 16).for_each(|c| c.fill(Hit::MISS));
        let shadowed = shadows.then(|| {
            self.shadowed.resize(pixels, false);
            self.shadowed.par_chunks_mut(1 << 16).for_each(|c| c.fill(false));
            self.shadowed
        });
        (self.hits, shadowed)
    }
}

/// Shadow rays end this far (relative) before the shaded point.
pub const SHADOW_EPSILON: f32 = 1e-4;

pub(crate) struct Ctx<'p, 'a> {
    pub p: &'p Prepared<'a>,
    pub params: &'p MlrtaSettings,
    pub origin: Vec3,
    pub rays: &'p [Ray],
    /// The directions `rays` were made from, when they are a camera's
    /// (`trace_camera_into`): whole squares of packets then remake their
    /// directions in registers instead of reading them.
    pub pinhole: Option<&'p PixelDirections>,
    pub width: u32,
    pub light: Option<Vec3>,
    pub origin_inside: Option<u32>,
    pub light_inside: Option<u32>,
}

/// Output of one initial tile: its rows of the image's hits and shadow
/// flags, written in place (`tile_rows`; none where the GPU traces the
/// pixels, and no shadow rows without a light), and statistics.
#[derive(Default)]
pub(crate) struct TileOut<'img> {
    pub rect: Rect,
    pub hits: Vec<&'img mut [Hit]>,
    pub shadowed: Vec<&'img mut [bool]>,
    pub counts: MlrtaCounts,
    pub shadow_counts: MlrtaCounts,
    pub tiles: Vec<TileReport>,
    /// A gathered ray did not start at the image's origin.
    pub stray_origin: bool,
}

/// What the tiles found besides their pixels.
pub(crate) struct TileSummary {
    pub counts: MlrtaCounts,
    pub shadow_counts: MlrtaCounts,
    pub tiles: Vec<TileReport>,
    pub stray_origin: bool,
}

impl TileSummary {
    pub(crate) fn of(outs: Vec<TileOut>) -> TileSummary {
        let mut stats = TileSummary {
            counts: MlrtaCounts::default(),
            shadow_counts: MlrtaCounts::default(),
            tiles: Vec::new(),
            stray_origin: false,
        };
        for out in outs {
            stats.counts += out.counts;
            stats.shadow_counts += out.shadow_counts;
            stats.tiles.extend(out.tiles);
            stats.stray_origin |= out.stray_origin;
        }
        stats
    }
}

/// Traces a `width x height` image of rays (row-major) that share their
/// origin, e.g. a camera's primary rays, with MLRTA; with a `light`, also the
/// shadow rays from the light to every hit. Tiles run in parallel on the
/// current rayon pool.
pub fn trace_image(
    p: &Prepared,
    rays: &[Ray],
    width: u32,
    height: u32,
    params: &MlrtaSettings,
    light: Option<Vec3>,
) -> Result<ImageTrace> {
    trace_image_into(p, rays, width, height, params, light, ImageBuffers::default())
}

/// `trace_image` into `buffers` (every pixel written; they are grown where
/// too small): a host tracing frame after frame passes the last frame's
/// (`ImageTrace::into_buffers`) and allocates nothing per frame.
pub fn trace_image_into(
    p: &Prepared,
    rays: &[Ray],
    width: u32,
    height: u32,
    params: &MlrtaSettings,
    light: Option<Vec3>,
    buffers: ImageBuffers,
) -> Result<ImageTrace> {
    let ctx = Ctx::new(p, rays, width, height, params, light, None)?;
    trace_tiles(&ctx, &ctx.initial_tiles(height), height, buffers)
}

/// `trace_image_into` of a camera's primary rays. The same hits, shadows
/// and counts; whole 16x16 and 8x8 squares of pixels make their rays'
/// directions from the camera's tables, in the instruction set the walk
/// runs in, rather than read them from the image of rays: the kitchen
/// interior's packets read all 24 MB of its 1024^2 rays each frame.
pub fn trace_camera_into(
    p: &Prepared,
    camera: &CameraRays,
    params: &MlrtaSettings,
    light: Option<Vec3>,
    buffers: ImageBuffers,
) -> Result<ImageTrace> {
    let dirs = camera.directions();
    let (width, height) = (dirs.width(), dirs.height());
    let ctx = Ctx::new(p, camera.rays(), width, height, params, light, Some(dirs))?;
    trace_tiles(&ctx, &ctx.initial_tiles(height), height, buffers)
}

/// Splits and traces `rects` (which must not overlap) as tiles in
/// parallel, each writing its pixels into the image in place, with shadow
/// rays when the context has a light.
fn trace_tiles(ctx: &Ctx, rects: &[Rect], height: u32, buffers: ImageBuffers) -> Result<ImageTrace> {
    let (n, width) = (ctx.rays.len(), ctx.width as usize);
    let (mut hits, mut shadowed) = buffers.blank(n, ctx.light.is_some());
    let hit_rows = tile_rows(&mut hits, width, rects)?;
    let shadow_rows = match &mut shadowed {
        Some(flags) => tile_rows(flags, width, rects)?,
        None => rects.iter().map(|_| Vec::new()).collect(),
    };
    let outs: Vec<TileOut> = rects
        .par_iter()
        .zip(hit_rows)
        .zip(shadow_rows)
        .map(|((&rect, hits), shadowed)| {
            let mut out = TileOut {
                rect,
                hits,
                shadowed,
                ..TileOut::default()
            };
            let mut emit = |entry: &EntryPoint, rect: Rect, out: &mut TileOut| trace_tile(ctx, rect, entry, out);
            split_tiles(ctx, rect, ctx.root(), 0, &mut out, &mut emit);
            if let Some(light) = ctx.light {
                trace_shadows(ctx, light, &mut out);
            }
            out
        })
        .collect();
    let stats = TileSummary::of(outs);
    if stats.stray_origin {
        return Err(stray_origin());
    }
    Ok(ctx.image(hits, shadowed, stats, height))
}

/// The error of an image whose rays do not share one origin.
pub(crate) fn stray_origin() -> Error {
    Error::input("rays", "MLRTA image tracing needs one common origin (a pinhole camera)")
}

/// `trace_image` restricted to some rectangles of the image (their pixels'
/// hits; the others stay `Hit::MISS`): how adaptive anti-aliasing traces its
/// extra samples only where the geometry is complex. Rectangles that
/// overlap or leave the image are an error.
pub fn trace_rects(
    p: &Prepared,
    rays: &[Ray],
    width: u32,
    height: u32,
    params: &MlrtaSettings,
    rects: &[Rect],
) -> Result<ImageTrace> {
    let ctx = Ctx::new(p, rays, width, height, params, None, None)?;
    trace_tiles(&ctx, rects, height, ImageBuffers::default())
}

impl<'p, 'a> Ctx<'p, 'a> {
    pub(crate) fn new(
        p: &'p Prepared<'a>,
        rays: &'p [Ray],
        width: u32,
        height: u32,
        params: &'p MlrtaSettings,
        light: Option<Vec3>,
        pinhole: Option<&'p PixelDirections>,
    ) -> Result<Ctx<'p, 'a>> {
        params.validate()?;
        if rays.len() != width as usize * height as usize || rays.is_empty() {
            return Err(Error::input("rays", "must be a non-empty width x height image"));
        }
        let origin = rays[0].o();
        // With corner frusta the caller vouches for a pinhole camera's image
        // (`MlrtaSettings::corner_frusta`); each ray is then checked when its
        // block is gathered (`trace_block`: the same cache line as its
        // direction), not in a pass of its own over the image's rays (2.6
        // ms of a 1024^2 frame on one thread, memory-bound). Rays of tiles
        // that the entry points cull are not read, as their directions are
        // not either.
        // A camera's rays (`pinhole`) were all made from its eye.
        if pinhole.is_none()
            && !params.corner_frusta
            && rays.par_chunks(1 << 14).any(|c| c.iter().any(|r| r.o() != origin))
        {
            return Err(stray_origin());
        }
        Ok(Ctx {
            p,
            params,
            origin,
            rays,
            pinhole,
            width,
            light,
            origin_inside: p.inside_object(origin),
            light_inside: light.and_then(|l| p.inside_object(l)),
        })
    }

    pub(crate) fn root(&self) -> EntryPoint {
        EntryPoint::root(self.p)
    }

    pub(crate) fn initial_tiles(&self, height: u32) -> Vec<Rect> {
        let its = self.params.initial_tile;
        let mut initial = Vec::new();
        for y in (0..height).step_by(its as usize) {
            for x in (0..self.width).step_by(its as usize) {
                initial.push(Rect {
                    x,
                    y,
                    w: its.min(self.width - x),
                    h: its.min(height - y),
                });
            }
        }
        initial
    }

    /// The traced image: its pixels and what its tiles found. The tiles
    /// wrote into `hits` and `shadowed` in place (`tile_rows`), so nothing
    /// is copied here.
    pub(crate) fn image(
        &self,
        hits: Vec<Hit>,
        shadowed: Option<Vec<bool>>,
        stats: TileSummary,
        height: u32,
    ) -> ImageTrace {
        let TileSummary {
            mut counts,
            mut shadow_counts,
            tiles,
            ..
        } = stats;
        let packets = self.width.div_ceil(4) as u64 * height.div_ceil(4) as u64;
        counts.packets = packets;
        shadow_counts.packets = packets;
        ImageTrace {
            hits,
            shadowed,
            counts,
            shadow_counts,
            tiles,
        }
    }
}

pub(crate) fn pixels(rect: Rect, width: u32) -> impl Iterator<Item = u32> {
    (rect.y..rect.y + rect.h).flat_map(move |y| (rect.x..rect.x + rect.w).map(move |x| y * width + x))
}

/// Splits a rectangle into `k x k` pieces aligned to 4-pixel packets.
fn split(rect: Rect, k: u32) -> Vec<Rect> {
    let step = |len: u32| len.div_ceil(k).next_multiple_of(4).max(4);
    let (sx, sy) = (step(rect.w), step(rect.h));
    let mut out = Vec::new();
    for y in (rect.y..rect.y + rect.h).step_by(sy as usize) {
        for x in (rect.x..rect.x + rect.w).step_by(sx as usize) {
            out.push(Rect {
                x,
                y,
                w: sx.min(rect.x + rect.w - x),
                h: sy.min(rect.y + rect.h - y),
            });
        }
    }
    out
}

/// The emitter gets each final tile with the entry point to trace it from.
pub(crate) type Emit<'e> = dyn FnMut(&EntryPoint, Rect, &mut TileOut) + 'e;

/// Section 4.2's recursion: entry point of the tile, split or emit the final tile.
pub(crate) fn split_tiles(ctx: &Ctx, rect: Rect, start: EntryPoint, level: u32, out: &mut TileOut, emit: &mut Emit) {
    let p = ctx.p;
    let frustum = if ctx.params.corner_frusta {
        let (x1, y1) = (rect.x + rect.w - 1, rect.y + rect.h - 1);
        let corners = [(rect.x, rect.y), (x1, rect.y), (rect.x, y1), (x1, y1)];
        let dirs = corners.map(|(x, y)| ctx.rays[(y * ctx.width + x) as usize].d());
        Frustum::from_corners(ctx.origin, dirs, f32::INFINITY)
    } else {
        let dirs = pixels(rect, ctx.width).map(|i| ctx.rays[i as usize].d());
        Frustum::new(ctx.origin, dirs, f32::INFINITY)
    };
    let report = |entry: Option<&EntryPoint>, diverging| TileReport {
        rect,
        level,
        entry: entry.map(|e| e.node),
        complexity: entry.map_or(0, |e| p.subtree_size(e.node)),
        diverging,
        stopped: entry.is_some_and(|e| e.speculative),
    };
    let k = (ctx.params.split_factor as f64).sqrt() as u32;
    let splittable = ctx.params.entry_points && rect.w.max(rect.h) > ctx.params.min_tile;
    let Some(frustum) = frustum else {
        // Diverging: split down to the minimum tile size, so that only the
        // tiles the sign change runs through stay without an entry point.
        if splittable {
            for sub in split(rect, k) {
                split_tiles(ctx, sub, start, level + 1, out, emit);
            }
            return;
        }
        out.tiles.push(report(Some(&start), true));
        emit(&start, rect, out);
        return;
    };
    let entry = if ctx.params.entry_points {
        out.counts.ep_searches += 1;
        match search_below(
            p,
            &frustum,
            &start,
            ctx.origin_inside,
            ctx.params.ep_budget,
            &mut out.counts.ep_steps,
        ) {
            Some(e) => e,
            None => {
                // Its pixels stay misses.
                out.tiles.push(report(None, false));
                return;
            }
        }
    } else {
        start
    };
    let is_leaf = p.tree.nodes[entry.node as usize].is_leaf();
    if splittable && !is_leaf {
        for sub in split(rect, k) {
            split_tiles(ctx, sub, entry, level + 1, out, emit);
        }
        return;
    }
    out.tiles.push(report(Some(&entry), false));
    emit(&entry, rect, out);
}

/// The 4x4 blocks of a final tile (smaller at the image's edges).
pub(crate) fn block_rects(rect: Rect) -> impl Iterator<Item = Rect> {
    squares(rect, 4)
}

/// `rect` cut into squares of `side` pixels (smaller at its far edges).
pub(crate) fn squares(rect: Rect, side: u32) -> impl Iterator<Item = Rect> {
    (rect.y..rect.y + rect.h).step_by(side as usize).flat_map(move |y| {
        (rect.x..rect.x + rect.w).step_by(side as usize).map(move |x| Rect {
            x,
            y,
            w: side.min(rect.x + rect.w - x),
            h: side.min(rect.y + rect.h - y),
        })
    })
}

impl Rect {
    /// Row and column of pixel `i` of a `width`-wide image in this
    /// rectangle.
    fn local(&self, i: u32, width: u32) -> (usize, usize) {
        let (x, y) = (i % width, i / width);
        ((y - self.y) as usize, (x - self.x) as usize)
    }
}

/// Traces one 4x4 block of primary rays on the CPU: same-sign sub-groups
/// (one, unless the tile diverges) as packets, rays with a zero direction
/// component alone.
pub(crate) fn trace_block(ctx: &Ctx, block: Rect, entry: &EntryPoint, out: &mut TileOut) {
    let mut dirs = [Vec3::ZERO; PACKET];
    let mut m = 0;
    let mut stray = false;
    for i in pixels(block, ctx.width) {
        let ray = &ctx.rays[i as usize];
        dirs[m] = ray.d();
        stray |= ray.o() != ctx.origin;
        m += 1;
    }
    if stray {
        out.stray_origin = true;
        return;
    }
    let group = Group {
        origin: ctx.origin,
        dirs: &dirs[..m],
        t_max: f32::INFINITY,
        any_hit: false,
    };
    let hits = trace_group(ctx.p, &group, entry, None, &mut out.counts);
    // The block's rows in the tile's rows of the image.
    let (r, w) = (out.rect, block.w as usize);
    let x = (block.x - r.x) as usize;
    for (row, y) in (block.y..block.y + block.h).enumerate() {
        out.hits[(y - r.y) as usize][x..x + w].copy_from_slice(&hits[row * w..(row + 1) * w]);
    }
}

/// The shadow rays of one 4x4 block: from the light towards each hit,
/// ending just before it (directions unnormalised, `t` up to
/// `1 - SHADOW_EPSILON`).
pub(crate) struct ShadowRays {
    pub pixels: [u32; PACKET],
    pub to_points: [Vec3; PACKET],
    pub len: usize,
}

impl ShadowRays {
    pub(crate) fn new(ctx: &Ctx, light: Vec3, block: Rect, hit: impl Fn(u32) -> Hit) -> ShadowRays {
        let mut s = ShadowRays {
            pixels: [0; PACKET],
            to_points: [Vec3::ZERO; PACKET],
            len: 0,
        };
        for i in pixels(block, ctx.width) {
            let h = hit(i);
            if h.is_hit() {
                s.pixels[s.len] = i;
                s.to_points[s.len] = ctx.origin + h.t * ctx.rays[i as usize].d() - light;
                s.len += 1;
            }
        }
        s
    }
}

/// Where the shadow rays of a final tile start: with entry points on, the
/// entry point of the group of all of them (section 4.1 applied to the
/// group from the light to the tile's hits), from which its packets then
/// traverse; the root when they diverge or the search is off. `None`:
/// nothing can block any of them.
///
/// One search per tile, not per packet: searches from the light per 4x4
/// packet cost more steps than they save (bunny, primary + shadow cells
/// per packet: 81.7 with a search per packet below the tile's entry point,
/// 79.6 with one per packet from the root, 63.2 with this; kitchen 5.8, 7.8
/// and 5.5). The primary rays' tiles are the shadow rays' tiles: their hits
/// are where the primary search found one surface region.
pub(crate) fn shadow_tile_entry(
    ctx: &Ctx,
    light: Vec3,
    rect: Rect,
    hit: impl Fn(u32) -> Hit,
    counts: &mut MlrtaCounts,
) -> Option<EntryPoint> {
    let root = ctx.root();
    if !ctx.params.entry_points {
        return Some(root);
    }
    let to_points = block_rects(rect).flat_map(|b| {
        let s = ShadowRays::new(ctx, light, b, &hit);
        s.to_points.into_iter().take(s.len)
    });
    match Frustum::new(light, to_points, 1.0 - SHADOW_EPSILON) {
        Some(f) => {
            counts.ep_searches += 1;
            search_below(
                ctx.p,
                &f,
                &root,
                ctx.light_inside,
                ctx.params.ep_budget,
                &mut counts.ep_steps,
            )
        }
        None => Some(root),
    }
}

/// The shadow rays of one initial tile's hits, final tile by final tile
/// (tiles that hit nothing have none).
fn trace_shadows(ctx: &Ctx, light: Vec3, out: &mut TileOut) {
    let finals: Vec<Rect> = out.tiles.iter().filter(|t| t.entry.is_some()).map(|t| t.rect).collect();
    let mut counts = MlrtaCounts::default();
    let (tile, hits, shadowed) = (out.rect, &out.hits, &mut out.shadowed);
    for rect in finals {
        let hit = |i: u32| {
            let (row, col) = tile.local(i, ctx.width);
            hits[row][col]
        };
        let Some(start) = shadow_tile_entry(ctx, light, rect, hit, &mut counts) else {
            continue;
        };
        let mut mark = |i: u32, blocked: bool| {
            let (row, col) = tile.local(i, ctx.width);
            shadowed[row][col] = blocked;
        };
        trace_shadow_tile(ctx, light, rect, &start, &hit, &mut mark, &mut counts);
    }
    out.shadow_counts += counts;
}

/// Up to 16 rays from one origin.
pub struct Group<'a> {
    /// The rays' common origin.
    pub origin: Vec3,
    /// Their directions, at most 16.
    pub dirs: &'a [Vec3],
    /// Rays end at this `t`, in units of their directions.
    pub t_max: f32,
    /// Any hit before `t_max` will do (shadow rays); otherwise the
    /// closest.
    pub any_hit: bool,
}

/// Traces a group of up to 16 rays: same-sign sub-groups as packets from
/// `start` (or, with `search = Some(origin_inside)`, from each sub-group's own
/// entry point searched below `start`); rays with a zero direction component
/// alone from the root. Rays that a speculative entry point found nothing for
/// are traced again from the root.
pub fn trace_group(
    p: &Prepared,
    g: &Group,
    start: &EntryPoint,
    search: Option<Option<u32>>,
    counts: &mut MlrtaCounts,
) -> [Hit; PACKET] {
    // The whole group in one instruction set: the packets' set-up (signs,
    // reciprocals, frustum bounds, shear constants) is loops over lanes
    // that the compiler vectorises only with the wider registers enabled.
    struct TraceGroup<'a> {
        p: &'a Prepared<'a>,
        g: &'a Group<'a>,
        start: &'a EntryPoint,
        search: Option<Option<u32>>,
        counts: &'a mut MlrtaCounts,
    }
    impl Kernel for TraceGroup<'_> {
        type Out = [Hit; PACKET];
        #[inline(always)]
        fn run<V: Lanes>(self) -> [Hit; PACKET] {
            trace_group_in::<V>(self.p, self.g, self.start, self.search, self.counts)
        }
    }
    dispatch(
        Isa::best(),
        TraceGroup {
            p,
            g,
            start,
            search,
            counts,
        },
    )
}

/// `trace_group` in lanes `V`.
#[inline(always)]
fn trace_group_in<V: Lanes>(
    p: &Prepared,
    g: &Group,
    start: &EntryPoint,
    search: Option<Option<u32>>,
    counts: &mut MlrtaCounts,
) -> [Hit; PACKET] {
    let mut result = [Hit::MISS; PACKET];
    // Lanes by sign class (8 = a zero component); most groups have one class.
    let mut class_of = [8u8; PACKET];
    let mut present = 0u16;
    for (k, &d) in g.dirs.iter().enumerate() {
        class_of[k] = sign_class(d).unwrap_or(8);
        present |= 1 << class_of[k];
    }
    for class in (0..9u8).filter(|c| present & (1 << c) != 0) {
        let mut lanes = [0usize; PACKET];
        let mut dirs = [Vec3::ZERO; PACKET];
        let mut m = 0;
        for k in (0..g.dirs.len()).filter(|&k| class_of[k] == class) {
            lanes[m] = k;
            dirs[m] = g.dirs[k];
            m += 1;
        }
        let lanes = &lanes[..m];
        let single = |k: usize, counts: &mut MlrtaCounts| single_ray(p, g.origin, g.dirs[k], g.t_max, counts);
        if class == 8 {
            for &k in lanes {
                result[k] = single(k, counts);
            }
            continue;
        }
        let packet = Packet::new_in::<V>(g.origin, &dirs[..m], g.t_max).expect("one sign class");
        let entry = match search {
            None => Some(*start),
            Some(inside) => {
                counts.ep_searches += 1;
                search_below(
                    p,
                    &packet.frustum,
                    start,
                    inside,
                    DEFAULT_EP_BUDGET,
                    &mut counts.ep_steps,
                )
            }
        };
        let Some(entry) = entry else { continue };
        let h = trace_packet_lanes::<V>(p, &packet, &entry, g.any_hit, counts);
        for (j, &k) in lanes.iter().enumerate() {
            result[k] = if entry.speculative && !h[j].is_hit() {
                single(k, counts)
            } else {
                h[j]
            };
        }
    }
    result
}

/// One ray from the root, counted. (Closest hit serves any-hit queries too:
/// the path is rare.)
pub(crate) fn single_ray(p: &Prepared, origin: Vec3, dir: Vec3, t_max: f32, counts: &mut MlrtaCounts) -> Hit {
    let mut c = crate::accel::kdtree::TraversalCounts::default();
    let hit = p.tree.closest_hit_counted(origin, dir, t_max, &mut c);
    counts.single_rays += 1;
    counts.single_cells += c.cells;
    counts.single_isects += c.intersections;
    hit
}

/// The entry point of a group below `start`, an entry point of a group that
/// contains it: the sub-group inherits what is known of its parent (its rays
/// end by the parent's `t_limit`; a speculative parent makes it speculative).
pub(crate) fn search_below(
    p: &Prepared,
    f: &crate::mlrta::frustum::Frustum,
    start: &EntryPoint,
    origin_inside: Option<u32>,
    far_budget: u32,
    steps: &mut u64,
) -> Option<EntryPoint> {
    let mut f = *f;
    f.t_max = f.t_max.min(start.t_limit);
    entry_point(p, &f, (start.node, start.cell), origin_inside, far_budget, steps).map(|e| EntryPoint {
        speculative: e.speculative || start.speculative,
        covered: e.covered || start.covered,
        ..e
    })
}
