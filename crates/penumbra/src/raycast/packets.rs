//! One point's AO rays in packets of 16: they share the origin, so they go
//! through `Accel::occluded_in` (the kd-tree's or the BVH's packets)
//! together. Rays are grouped by where their sample lies in the square (a
//! 4x4 grid in Morton order, which the concentric map turns into
//! neighbouring patches of the hemisphere), so a packet's
//! rays leave in similar directions; with 256 rays the (0,2)-net property
//! of the scrambled Sobol points puts exactly 16 in each cell. The grouping
//! only changes which rays travel together: each ray's answer is its single
//! ray's (`KdTree::any_hit`).

use glam::Vec3;

use super::PointDirections;
use crate::accel::kdtree::occlusion::LANES;
use crate::accel::{Accel, Structure};
use crate::geom::simd::{Isa, Kernel, Lanes, dispatch};

/// Cells of the grid the rays are grouped by.
const CELLS: usize = 16;

/// Sets bit j of `mask` for each of the `n` rays of `dirs` that escapes
/// (hits nothing with `0 < t < t_max` from `origin`), walking `structure`
/// in lanes of `isa`.
pub fn point_visibility(
    (accel, structure): (&Accel, Structure),
    origin: Vec3,
    dirs: &PointDirections,
    n: u32,
    t_max: f32,
    isa: Isa,
    mask: &mut [u32],
) {
    // One kernel per structure (see `Accel::occluded`).
    match structure {
        Structure::Kdtree => dispatch(
            isa,
            Point::<false> {
                accel,
                origin,
                dirs,
                n,
                t_max,
                mask,
            },
        ),
        Structure::Bvh => dispatch(
            isa,
            Point::<true> {
                accel,
                origin,
                dirs,
                n,
                t_max,
                mask,
            },
        ),
    }
}

/// One point's rays as a kernel: directions, grouping and packets all in
/// the dispatched instruction set.
struct Point<'a, const BVH: bool> {
    accel: &'a Accel,
    origin: Vec3,
    dirs: &'a PointDirections,
    n: u32,
    t_max: f32,
    mask: &'a mut [u32],
}

impl<const BVH: bool> Kernel for Point<'_, BVH> {
    type Out = ();

    #[inline(always)]
    fn run<V: Lanes>(self) {
        let n = self.n as usize;
        // Directions and grid cells, then the rays' order by cell (a
        // counting sort: stable, so each cell keeps the sequence's order).
        let (mut bits, mut rays) = (vec![[0u32; 2]; n], vec![(Vec3::ZERO, 0u8); n]);
        self.dirs.directions_and_cells(&mut bits, &mut rays);
        let mut start = [0u32; CELLS + 1];
        for &(_, c) in &rays {
            start[c as usize + 1] += 1;
        }
        for c in 0..CELLS {
            start[c + 1] += start[c];
        }
        let mut order = vec![0u32; n];
        let mut sorted = vec![Vec3::ZERO; n];
        for (j, &(d, c)) in rays.iter().enumerate() {
            let at = start[c as usize] as usize;
            (order[at], sorted[at]) = (j as u32, d);
            start[c as usize] += 1;
        }
        for (chunk, dirs) in order.chunks(LANES).zip(sorted.chunks(LANES)) {
            let hit = self.accel.occluded_in::<V, BVH>(self.origin, dirs, self.t_max);
            for (k, &j) in chunk.iter().enumerate() {
                if hit & (1 << k) == 0 {
                    self.mask[(j / 32) as usize] |= 1 << (j % 32);
                }
            }
        }
    }
}
