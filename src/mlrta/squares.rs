//! A final tile's primary rays on the CPU, as squares of 4x4 packets that
//! walk the kd-tree together (`packet::trace_packets_lanes`): one interval
//! traversal of the hull of their frusta, each packet's own lanes tested
//! at the leaves. Neighbouring packets from one entry point cross mostly
//! the same cells; walked alone, each paid for every step (the bunny's
//! 1024x1024 primary packets took 15.1 steps each, 5.6 walked four at a
//! time).

use glam::Vec3;

use crate::mlrta::entry_point::EntryPoint;
use crate::mlrta::packet::{MlrtaCounts, PACKET, Packet, trace_packets_lanes};
use crate::mlrta::prepared::Prepared;
use crate::mlrta::tiles::{Ctx, Rect, TileOut, block_rects, pixels, single_ray, trace_block};
use crate::ray::Hit;
use crate::simd::{Isa, Kernel, Lanes, dispatch};

/// Traces a final tile's primary rays on the CPU: its 16x16 squares as
/// sixteen packets walked together, where that fails (the image's edges,
/// a sign change in the square) its 8x8 squares as four, and where that
/// fails block by block. In-process, 1024x1024 primary rays, one thread,
/// best of 15 over four alternated rounds (ms): the bunny 25.0-25.1 with
/// one packet a walk, 21.7-22.5 with four, 21.6-22.0 with sixteen;
/// dragon100k 25.0-25.5, 22.5-23.2, 22.9-23.2; the kitchen interior
/// 35.6-36.0, 30.9-32.1, 29.2-30.1.
pub(crate) fn trace_tile(ctx: &Ctx, rect: Rect, entry: &EntryPoint, out: &mut TileOut) {
    for square in squares(rect, 16) {
        if square.w == 16 && square.h == 16 && trace_square::<4, 16>(ctx, square, entry, out) {
            continue;
        }
        for quad in squares(square, 8) {
            if quad.w == 8 && quad.h == 8 && trace_square::<2, 4>(ctx, quad, entry, out) {
                continue;
            }
            for block in block_rects(quad) {
                trace_block(ctx, block, entry, out);
            }
        }
    }
}

/// `rect` cut into squares of `side` pixels (smaller at its far edges).
fn squares(rect: Rect, side: u32) -> impl Iterator<Item = Rect> {
    (rect.y..rect.y + rect.h).step_by(side as usize).flat_map(move |y| {
        (rect.x..rect.x + rect.w).step_by(side as usize).map(move |x| Rect {
            x,
            y,
            w: side.min(rect.x + rect.w - x),
            h: side.min(rect.y + rect.h - y),
        })
    })
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

/// Traces a square of SIDE x SIDE blocks as 4x4 packets walked together, when all are
/// whole packets of one sign class; false (nothing traced) otherwise.
fn trace_square<const SIDE: usize, const SQUARE: usize>(
    ctx: &Ctx,
    square: Rect,
    entry: &EntryPoint,
    out: &mut TileOut,
) -> bool {
    debug_assert_eq!(SIDE * SIDE, SQUARE);
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
    struct Square<'a, const SQUARE: usize> {
        p: &'a Prepared<'a>,
        origin: Vec3,
        dirs: &'a [[Vec3; PACKET]; SQUARE],
        entry: &'a EntryPoint,
        counts: &'a mut MlrtaCounts,
    }
    impl<const SQUARE: usize> Kernel for Square<'_, SQUARE> {
        type Out = Option<[[Hit; PACKET]; SQUARE]>;
        #[inline(always)]
        fn run<V: Lanes>(self) -> Self::Out {
            let mut packets = [const { std::mem::MaybeUninit::<Packet>::uninit() }; SQUARE];
            for (packet, dirs) in packets.iter_mut().zip(self.dirs) {
                packet.write(Packet::new(self.origin, dirs, f32::INFINITY)?);
            }
            // SAFETY: the loop wrote every element (or returned).
            // (`MaybeUninit<T>` has `T`'s layout, so the arrays' layouts agree.)
            let packets: [Packet; SQUARE] = unsafe { (&raw const packets).cast::<[Packet; SQUARE]>().read() };
            // One walk needs one sign class (each packet has one).
            let mut refs = [&packets[0]; SQUARE];
            for (r, packet) in refs.iter_mut().zip(&packets) {
                if packet.frustum.positive != packets[0].frustum.positive {
                    return None;
                }
                *r = packet;
            }
            Some(trace_packets_lanes::<V, SQUARE>(
                self.p,
                refs,
                self.entry,
                false,
                self.counts,
            ))
        }
    }
    let Some(hits) = dispatch(
        Isa::best(),
        Square {
            p: ctx.p,
            origin: ctx.origin,
            dirs: &dirs,
            entry,
            counts: &mut out.counts,
        },
    ) else {
        return false;
    };
    let r = out.rect;
    for (q, block_hits) in hits.iter().enumerate() {
        let block = square_block(square, SIDE, q);
        let x = (block.x - r.x) as usize;
        for row in 0..4 {
            let line = &mut out.hits[(block.y - r.y) as usize + row][x..x + 4];
            for (k, h) in line.iter_mut().enumerate() {
                let hit = block_hits[row * 4 + k];
                *h = if entry.speculative && !hit.is_hit() {
                    single_ray(ctx.p, ctx.origin, dirs[q][row * 4 + k], f32::INFINITY, &mut out.counts)
                } else {
                    hit
                };
            }
        }
    }
    true
}
