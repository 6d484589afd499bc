//! A final tile's primary rays on the CPU, as squares of 4x4 packets that
//! walk the kd-tree together (`packet::trace_packets_lanes`): one interval
//! traversal of the hull of their frusta, each packet's own lanes tested
//! at the leaves. Neighbouring packets from one entry point cross mostly
//! the same cells; walked alone, each paid for every step (the bunny's
//! 1024x1024 primary packets: 15.1 steps each alone, 5.6 by 8x8 squares,
//! 2.7 by 16x16 squares).

use glam::Vec3;

use crate::geom::ray::Hit;
use crate::geom::simd::{Isa, Kernel, Lanes, dispatch};
use crate::mlrta::entry_point::EntryPoint;
use crate::mlrta::packet::{MlrtaCounts, PACKET, Packet, trace_packets_lanes};
use crate::mlrta::prepared::Prepared;
use crate::mlrta::tiles::{
    Ctx, Group, Rect, SHADOW_EPSILON, ShadowRays, TileOut, block_rects, pixels, single_ray, squares, trace_block,
    trace_group,
};
use crate::scene::PixelDirections;

/// Traces a final tile's primary rays on the CPU: its 16x16 squares as
/// sixteen packets walked together, where that fails (the image's edges,
/// a sign change in the square) its 8x8 squares as four, and where that
/// fails block by block. In-process, 1024x1024 primary rays, one thread,
/// best of 15 over four alternated rounds (ms): the bunny 25.0-25.1 with
/// one packet a walk, 21.7-22.5 with four, 21.6-22.0 with sixteen;
/// dragon100k 25.0-25.5, 22.5-23.2, 22.9-23.2; the kitchen interior
/// 35.6-36.0, 30.9-32.1, 29.2-30.1.
pub(crate) fn trace_tile(ctx: &Ctx, rect: Rect, entry: &EntryPoint, out: &mut TileOut) {
    by_squares(rect, &mut PrimaryTile { ctx, entry, out });
}

/// Rays of a final tile traced by squares of 4x4 blocks walked together.
trait SquareTracer {
    /// Walks the packets of a whole square of `SIDE x SIDE` blocks
    /// together; false (nothing traced) when they cannot be.
    fn square<const SIDE: usize, const SQUARE: usize>(&mut self, square: Rect) -> bool;
    /// Traces one block (of at most 4x4 pixels) alone.
    fn block(&mut self, block: Rect);
    /// Asks for the memory `square` will read to be fetched meanwhile.
    fn prefetch(&self, _square: Rect) {}
}

/// A final tile's 16x16 squares, where that fails (the image's edges, a
/// sign change, pixels without rays) its 8x8 squares, and where that fails
/// its blocks one by one.
fn by_squares(rect: Rect, tracer: &mut impl SquareTracer) {
    let mut all = squares(rect, 16).peekable();
    while let Some(square) = all.next() {
        if let Some(&next) = all.peek() {
            tracer.prefetch(next);
        }
        if square.w == 16 && square.h == 16 && tracer.square::<4, 16>(square) {
            continue;
        }
        for quad in squares(square, 8) {
            if quad.w == 8 && quad.h == 8 && tracer.square::<2, 4>(quad) {
                continue;
            }
            for block in block_rects(quad) {
                tracer.block(block);
            }
        }
    }
}

/// A final tile's primary rays.
struct PrimaryTile<'a, 'o, 'c, 'p, 'q> {
    ctx: &'a Ctx<'p, 'q>,
    entry: &'a EntryPoint,
    out: &'o mut TileOut<'c>,
}

impl SquareTracer for PrimaryTile<'_, '_, '_, '_, '_> {
    fn square<const SIDE: usize, const SQUARE: usize>(&mut self, square: Rect) -> bool {
        trace_square::<SIDE, SQUARE>(self.ctx, square, self.entry, self.out)
    }

    fn block(&mut self, block: Rect) {
        trace_block(self.ctx, block, self.entry, self.out);
    }

    /// The square's rays: 16 rows of 384 bytes, 24 KB apart in a 1024-wide
    /// image, which the hardware's stream prefetchers did not fetch ahead
    /// (the kitchen interior reads all 24 MB of its 1024^2 rays), unless
    /// the square will make its rays from the camera.
    fn prefetch(&self, square: Rect) {
        if self.ctx.pinhole.is_some() {
            // Whole squares make their directions from the camera; the
            // blocks of those that cannot be walked whole are few.
            return;
        }
        let width = self.ctx.width as usize;
        for y in square.y as usize..(square.y + square.h) as usize {
            let first = y * width + square.x as usize;
            prefetch(&self.ctx.rays[first..first + square.w as usize]);
        }
    }
}

/// Asks for the cache lines of `items` to be fetched (a hint; nothing on
/// targets without the instruction).
fn prefetch<T>(items: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let (start, bytes) = (items.as_ptr() as *const i8, std::mem::size_of_val(items));
        for offset in (0..bytes).step_by(64).chain(std::iter::once(bytes.saturating_sub(1))) {
            // SAFETY: a prefetch is a hint that never faults; the address
            // lies inside `items` anyway.
            unsafe { _mm_prefetch(start.wrapping_add(offset), _MM_HINT_T0) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = items;
}

/// The 4x4 block `q` of a square of `side` blocks a side (row by row).
fn square_block(square: Rect, side: usize, q: usize) -> Rect {
    Rect {
        x: square.x + 4 * (q % side) as u32,
        y: square.y + 4 * (q / side) as u32,
        w: 4,
        h: 4,
    }
}

/// Traces a square of `SIDE x SIDE` blocks of primary rays as 4x4 packets
/// walked together, when all are whole packets of one sign class; false
/// (nothing traced) otherwise.
fn trace_square<const SIDE: usize, const SQUARE: usize>(
    ctx: &Ctx,
    square: Rect,
    entry: &EntryPoint,
    out: &mut TileOut,
) -> bool {
    debug_assert_eq!(SIDE * SIDE, SQUARE);
    let dirs = match ctx.pinhole {
        Some(camera) => camera_square::<SIDE, SQUARE>(Isa::best(), camera, square),
        None => {
            let mut dirs = [[Vec3::ZERO; PACKET]; SQUARE];
            let mut stray = false;
            for (q, d) in dirs.iter_mut().enumerate() {
                for (m, i) in pixels(square_block(square, SIDE, q), ctx.width).enumerate() {
                    let ray = &ctx.rays[i as usize];
                    d[m] = ray.d();
                    stray |= ray.o() != ctx.origin;
                }
            }
            if stray {
                out.stray_origin = true;
                return true;
            }
            dirs
        }
    };
    let rays = SquareRays {
        origin: ctx.origin,
        dirs: &dirs,
        t_max: f32::INFINITY,
        any_hit: false,
    };
    let Some(hits) = walk_square(ctx.p, &rays, entry, &mut out.counts) else {
        return false;
    };
    let r = out.rect;
    for (q, block_hits) in hits.iter().enumerate() {
        let block = square_block(square, SIDE, q);
        let x = (block.x - r.x) as usize;
        for row in 0..4 {
            let line = &mut out.hits[(block.y - r.y) as usize + row][x..x + 4];
            line.copy_from_slice(&block_hits[row * 4..row * 4 + 4]);
        }
    }
    true
}

/// The directions of a square's blocks (row by row, each block's pixels
/// row by row) made from a camera's tables, as `PixelDirections::at` makes
/// them: the same operations in the same order, lane by lane, so the same
/// bits. Run in the walk's instruction set, where sixteen pixels'
/// square roots and divisions are one instruction each.
fn camera_square<const SIDE: usize, const SQUARE: usize>(
    isa: Isa,
    camera: &PixelDirections,
    square: Rect,
) -> [[Vec3; PACKET]; SQUARE] {
    struct Make<'a, const SIDE: usize, const SQUARE: usize> {
        camera: &'a PixelDirections,
        square: Rect,
    }
    impl<const SIDE: usize, const SQUARE: usize> Kernel for Make<'_, SIDE, SQUARE> {
        type Out = [[Vec3; PACKET]; SQUARE];
        #[inline(always)]
        fn run<V: Lanes>(self) -> Self::Out {
            let c = self.camera;
            let (f, r, u) = (c.forward, c.right, c.up);
            let mut dirs = [[Vec3::ZERO; PACKET]; SQUARE];
            for (q, block) in dirs.iter_mut().enumerate() {
                let b = square_block(self.square, SIDE, q);
                let px: &[f32; 4] = c.px[b.x as usize..][..4].try_into().expect("a whole block");
                let py: &[f32; 4] = c.py[b.y as usize..][..4].try_into().expect("a whole block");
                let sx = V::from_array(std::array::from_fn(|m| px[m % 4]));
                let sy = V::from_array(std::array::from_fn(|m| py[m / 4]));
                // (forward + px * right + py * up).normalize(), as glam
                // evaluates it: ((f + px r) + py u) * (1 / sqrt(dot)).
                let axis = |a: usize| {
                    let along = V::splat(f[a]).add(sx.mul(V::splat(r[a])));
                    along.add(sy.mul(V::splat(u[a])))
                };
                let (x, y, z) = (axis(0), axis(1), axis(2));
                let dot = x.mul(x).add(y.mul(y)).add(z.mul(z));
                let recip = V::splat(1.0).div(dot.sqrt());
                let (x, y, z) = (
                    x.mul(recip).to_array(),
                    y.mul(recip).to_array(),
                    z.mul(recip).to_array(),
                );
                for (m, d) in block.iter_mut().enumerate() {
                    *d = Vec3::new(x[m], y[m], z[m]);
                }
            }
            dirs
        }
    }
    dispatch(isa, Make::<SIDE, SQUARE> { camera, square })
}

/// The shadow rays of a final tile (from `light` to its pixels' `hit`s,
/// `shadowed` set for those blocked), walked as the primary rays are: by
/// squares of 16x16 and 8x8 pixels where all their pixels hit, else block
/// by block.
pub(crate) fn trace_shadow_tile(
    ctx: &Ctx,
    light: Vec3,
    rect: Rect,
    start: &EntryPoint,
    hit: &dyn Fn(u32) -> Hit,
    shadowed: &mut dyn FnMut(u32, bool),
    counts: &mut MlrtaCounts,
) {
    let mut tile = ShadowTile {
        ctx,
        light,
        start,
        hit,
        shadowed,
        counts,
    };
    by_squares(rect, &mut tile);
}

struct ShadowTile<'a, 'c, 'p, 'q> {
    ctx: &'a Ctx<'p, 'q>,
    light: Vec3,
    start: &'a EntryPoint,
    hit: &'a dyn Fn(u32) -> Hit,
    shadowed: &'a mut dyn FnMut(u32, bool),
    counts: &'c mut MlrtaCounts,
}

impl SquareTracer for ShadowTile<'_, '_, '_, '_> {
    /// One 4x4 block's shadow rays (those of its pixels that hit).
    fn block(&mut self, block: Rect) {
        let rays = ShadowRays::new(self.ctx, self.light, block, self.hit);
        if rays.len == 0 {
            return;
        }
        let group = Group {
            origin: self.light,
            dirs: &rays.to_points[..rays.len],
            t_max: 1.0 - SHADOW_EPSILON,
            any_hit: true,
        };
        let blocked = trace_group(self.ctx.p, &group, self.start, None, self.counts);
        for (j, &i) in rays.pixels[..rays.len].iter().enumerate() {
            (self.shadowed)(i, blocked[j].is_hit());
        }
    }

    /// A square of `SIDE x SIDE` blocks walked together when every pixel
    /// hits (whole packets) and the rays share a sign class; false
    /// (nothing traced) otherwise.
    fn square<const SIDE: usize, const SQUARE: usize>(&mut self, square: Rect) -> bool {
        // Whole packets only: every pixel hits (looked up before any ray is
        // made, as the smaller squares and blocks look again).
        if !pixels(square, self.ctx.width).all(|i| (self.hit)(i).is_hit()) {
            return false;
        }
        let mut dirs = [[Vec3::ZERO; PACKET]; SQUARE];
        let mut ids = [[0u32; PACKET]; SQUARE];
        for q in 0..SQUARE {
            let rays = ShadowRays::new(self.ctx, self.light, square_block(square, SIDE, q), self.hit);
            (dirs[q], ids[q]) = (rays.to_points, rays.pixels);
        }
        let rays = SquareRays {
            origin: self.light,
            dirs: &dirs,
            t_max: 1.0 - SHADOW_EPSILON,
            any_hit: true,
        };
        let Some(blocked) = walk_square(self.ctx.p, &rays, self.start, self.counts) else {
            return false;
        };
        for (ids, blocked) in ids.iter().zip(&blocked) {
            for (&i, b) in ids.iter().zip(blocked) {
                (self.shadowed)(i, b.is_hit());
            }
        }
        true
    }
}

/// Rays of one origin, in `SQUARE` whole packets.
struct SquareRays<'a, const SQUARE: usize> {
    origin: Vec3,
    dirs: &'a [[Vec3; PACKET]; SQUARE],
    t_max: f32,
    any_hit: bool,
}

/// The packets of `rays` walked together from `entry` (`None` when they do
/// not share one sign class); rays that a speculative entry point found
/// nothing for are traced again from the root, as `tiles::trace_group` does.
fn walk_square<const SQUARE: usize>(
    p: &Prepared,
    rays: &SquareRays<SQUARE>,
    entry: &EntryPoint,
    counts: &mut MlrtaCounts,
) -> Option<[[Hit; PACKET]; SQUARE]> {
    struct Walk<'a, const SQUARE: usize> {
        p: &'a Prepared<'a>,
        rays: &'a SquareRays<'a, SQUARE>,
        entry: &'a EntryPoint,
        counts: &'a mut MlrtaCounts,
    }
    impl<const SQUARE: usize> Kernel for Walk<'_, SQUARE> {
        type Out = Option<[[Hit; PACKET]; SQUARE]>;
        #[inline(always)]
        fn run<V: Lanes>(self) -> Self::Out {
            let r = self.rays;
            let mut packets = [const { std::mem::MaybeUninit::<Packet>::uninit() }; SQUARE];
            for (packet, dirs) in packets.iter_mut().zip(r.dirs) {
                packet.write(Packet::new_in::<V>(r.origin, dirs, r.t_max)?);
            }
            // SAFETY: the loop wrote every element (or returned). Read in
            // place rather than copied out (sixteen packets are 10 KB).
            let first = unsafe { packets[0].assume_init_ref() };
            // One walk needs one sign class (each packet has one).
            let mut refs = [first; SQUARE];
            for (r, packet) in refs.iter_mut().zip(&packets) {
                // SAFETY: as above.
                let packet = unsafe { packet.assume_init_ref() };
                if packet.frustum.positive != first.frustum.positive {
                    return None;
                }
                *r = packet;
            }
            Some(trace_packets_lanes::<V, SQUARE>(
                self.p,
                refs,
                self.entry,
                r.any_hit,
                self.counts,
            ))
        }
    }
    let walk = Walk { p, rays, entry, counts };
    let mut hits = dispatch(Isa::best(), walk)?;
    if entry.speculative {
        for (block_hits, dirs) in hits.iter_mut().zip(rays.dirs) {
            for (h, &d) in block_hits.iter_mut().zip(dirs) {
                if !h.is_hit() {
                    *h = single_ray(p, rays.origin, d, rays.t_max, counts);
                }
            }
        }
    }
    Some(hits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;

    /// The lanes make each pixel's direction bit for bit as the camera's
    /// rays have it, in every instruction set, for views of every kind.
    #[test]
    fn squares_make_the_directions_of_the_cameras_rays() {
        let views = [
            (Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 45.0, 64, 48),
            (Vec3::new(3.2, 1.6, 2.2), Vec3::new(-1.0, 0.9, -1.5), 60.0, 40, 40),
            (Vec3::new(1e-3, 7.0, 0.0), Vec3::new(0.0, -2.0, 0.0), 120.0, 32, 16),
            (Vec3::new(-1e4, 3e3, 2e4), Vec3::new(17.0, -0.25, 3.0), 5.0, 48, 32),
        ];
        for (eye, target, fov, width, height) in views {
            let camera = Camera {
                eye,
                target,
                fov_degrees: fov,
            };
            let dirs = camera.pixel_directions(width, height);
            let rays = camera.primary_rays(width, height);
            for isa in Isa::available() {
                for y in (0..height).step_by(8) {
                    for x in (0..width).step_by(8) {
                        let square = Rect { x, y, w: 8, h: 8 };
                        let made = camera_square::<2, 4>(isa, &dirs, square);
                        for (q, block) in made.iter().enumerate() {
                            let b = square_block(square, 2, q);
                            for (m, d) in block.iter().enumerate() {
                                let i = (b.y + m as u32 / 4) * width + b.x + m as u32 % 4;
                                let want = rays[i as usize].d();
                                assert_eq!(
                                    d.to_array().map(f32::to_bits),
                                    want.to_array().map(f32::to_bits),
                                    "{isa:?}, pixel {i} of {width}x{height}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}
