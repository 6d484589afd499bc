//! One point's AO rays in packets of 16: they share the origin, so they go
//! through `kdtree::occlusion` together. Rays are grouped by where their
//! sample lies in the square (a 4x4 grid in Morton order, which the concentric
//! map turns into neighbouring patches of the hemisphere), so a packet's
//! rays leave in similar directions; with 256 rays the (0,2)-net property
//! of the scrambled Sobol points puts exactly 16 in each cell. The grouping
//! only changes which rays travel together: each ray's answer is its single
//! ray's (`KdTree::any_hit`).

use glam::Vec3;

use super::PointDirections;
use crate::kdtree::KdTree;
use crate::kdtree::occlusion::{LANES, occluded};
use crate::simd::Isa;

/// Cells of the grid the rays are grouped by.
const CELLS: usize = 16;

/// Sets bit j of `mask` for each of the `n` rays of `dirs` that escapes
/// (hits nothing with `0 < t < t_max` from `origin`).
pub fn point_visibility(
    tree: &KdTree,
    origin: Vec3,
    dirs: &PointDirections,
    n: u32,
    t_max: f32,
    isa: Isa,
    mask: &mut [u32],
) {
    // Directions and grid cells, then the rays' order by cell (a counting
    // sort: stable, so each cell keeps the sequence's order).
    let mut rays: Vec<(Vec3, u8)> = (0..n).map(|j| dirs.direction_and_cell(j)).collect();
    let mut start = [0u32; CELLS + 1];
    for &(_, c) in &rays {
        start[c as usize + 1] += 1;
    }
    for c in 0..CELLS {
        start[c + 1] += start[c];
    }
    let mut order = vec![0u32; n as usize];
    for (j, &(_, c)) in rays.iter().enumerate() {
        order[start[c as usize] as usize] = j as u32;
        start[c as usize] += 1;
    }
    let sorted: Vec<Vec3> = order.iter().map(|&j| rays[j as usize].0).collect();
    rays.clear();
    for (chunk, dirs) in order.chunks(LANES).zip(sorted.chunks(LANES)) {
        let hit = occluded(tree, origin, dirs, t_max, isa);
        for (k, &j) in chunk.iter().enumerate() {
            if hit & (1 << k) == 0 {
                mask[(j / 32) as usize] |= 1 << (j % 32);
            }
        }
    }
}
