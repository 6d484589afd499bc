//! Potentially visible sets from sampled animation frames (section 3.2,
//! "PVS"): when the animation is known beforehand, each vertex only needs the
//! blockers it can ever see.
//!
//! For each sampled frame, a kd-tree of the full mesh is built and, from
//! every vertex, one ray per mask pixel (the pixel's direction in the
//! vertex's tangent frame; both hemispheres on two-sided meshes) finds the
//! first fine triangle hit. The blocker standing for that triangle joins the
//! vertex's static PVS: the fine triangle itself if the vertex draws it at
//! full resolution (its near field), otherwise the far (coarse) triangle of
//! its cluster. Blockers hidden behind others in every sampled frame — the
//! depth complexity the rasteriser otherwise pays for — drop out; blockers
//! that become visible only in unsampled frames are missed, which is the
//! PVS's error (measured in Table 1).

use glam::Vec3;
use rayon::prelude::*;

use super::Csr;
use super::pipeline::Prt;
use crate::accel::kdtree::{KdTree, KdTreeSettings};
use crate::error::Result;
use crate::scene::{ORIGIN_OFFSET, vertex_normals};
use crate::sh::tangent_frame;

/// Builds a static PVS from the given frames (positions per frame).
pub fn build_pvs(prt: &Prt, frames: &[Vec<Vec3>]) -> Result<Csr> {
    let h = &prt.hierarchy;
    let nv = prt.vertex_count;
    let far = h.far.len() as u32;
    let dirs: Vec<Vec3> = prt
        .grid
        .dirs
        .iter()
        .enumerate()
        .filter(|(p, _)| prt.grid.inside[p / 64] >> (p % 64) & 1 == 1)
        .map(|(_, d)| *d)
        .collect();
    let mut sets: Vec<Vec<u32>> = vec![Vec::new(); nv];
    let mut normals = Vec::new();
    for positions in frames {
        let soup: Vec<[Vec3; 3]> = h.fine.iter().map(|t| t.map(|i| positions[i as usize])).collect();
        let tree = KdTree::from_triangles(soup, &KdTreeSettings::default())?;
        vertex_normals(positions, &h.fine, &mut normals);
        let sides: &[f32] = if prt.two_sided { &[1.0, -1.0] } else { &[1.0] };
        sets.par_iter_mut().enumerate().with_min_len(8).for_each(|(v, set)| {
            let n0 = normals[v];
            if n0 == Vec3::ZERO {
                return;
            }
            let near = h.near.get(v);
            for &side in sides {
                let n = n0 * side;
                let frame = tangent_frame(n);
                let origin = positions[v] + n * (ORIGIN_OFFSET * prt.scale);
                for d in &dirs {
                    let hit = tree.closest_hit(origin, frame * *d, f32::INFINITY);
                    if !hit.is_hit() {
                        continue;
                    }
                    let f = hit.triangle;
                    if near.binary_search(&f).is_ok() {
                        set.push(far + f);
                    }
                    if h.coarse {
                        let c = h.cluster_of_fine[f as usize];
                        if h.excluded.get(v).binary_search(&c).is_err() {
                            set.push(c);
                        }
                    } else {
                        set.push(h.cluster_of_fine[f as usize]);
                    }
                }
            }
            set.sort_unstable();
            set.dedup();
        });
    }
    Ok(Csr::from_vecs(&sets))
}
