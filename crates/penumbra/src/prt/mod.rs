//! Precomputation-free radiance transfer by hemispherical rasterisation
//! (Kautz, Lehtinen and Aila 2004): per-vertex visibility masks built every
//! frame by rasterising blocker triangles onto the unit disk through a
//! plane-bitmask LUT, integrated against spherical harmonics and the BRDF
//! into transfer vectors, dotted with the lighting's SH coefficients.
//!
//! * `mask` — the disk grid, pixel areas and directions (section 3.1)
//! * `lut` — the plane LUT with its cube-map index (3.1.1)
//! * `clip` — blockers against the horizon (3.1.1)
//! * `raster` — spherical rasterisation (CPU only; see `gpu`)
//! * `transfer` — cells, integration, rotation, shading, twin of `wgsl/sh_transfer.wgsl` (3, 3.2)
//! * `hierarchy` — two-level mesh and culling groups (3.2)
//! * `level` — the coarse level: simplification, clusters, proxy check, size
//! * `clusters` — each fine triangle's coarse triangle
//! * `proxy` — the coarse level checked against the fine one, refined per vertex (3.2)
//! * `sides` — back-face culling and two-sided shading decided from the mesh
//! * `geometry` — welding and point-triangle distances
//! * `pvs` — potentially visible sets from sampled frames (3.2)
//! * `pipeline` — the per-frame loop on the CPU
//! * `reference` — Monte Carlo ray-traced transfer (the error measure of Table 1)
//! * `selfcheck` — the ray-traced error estimate made at setup
//! * `probe` — mask side, hierarchy and near field chosen per mesh by error and counted cost
//! * `gpu` — the WGSL passes
//! * `runner` — per-frame transfer of a deforming mesh on any device, with checks
//! * `blockers` — other objects' coarse levels as blockers (section 4.1)
//! * `objects` — several independently moving objects: transfer and whole-scene checks
//! * `scene_play` — a scene of objects played frame by frame, with its report

pub mod blockers;
pub mod clip;
pub(crate) mod clusters;
pub(crate) mod geometry;
pub mod gpu;
pub mod hierarchy;
pub mod images;
pub(crate) mod level;
pub mod lut;
pub mod mask;
pub mod objects;
pub mod pipeline;
pub mod probe;
pub(crate) mod proxy;
pub(crate) mod pvs;
pub mod raster;
pub mod reference;
pub mod render;
pub mod runner;
pub mod scene_play;
pub mod selfcheck;
pub mod sh_out;
pub(crate) mod sides;
pub mod transfer;
pub mod tune;

/// Compressed lists: `items[offsets[i]..offsets[i+1]]` is list i.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Csr {
    /// Start of each list in `items`, plus the end of the last: one more
    /// than the number of lists, non-decreasing, from 0.
    pub offsets: Vec<u32>,
    /// The lists' items, one list after another.
    pub items: Vec<u32>,
}

impl Csr {
    /// The lists `lists`, in order.
    pub fn from_vecs(lists: &[Vec<u32>]) -> Csr {
        let mut offsets = Vec::with_capacity(lists.len() + 1);
        let mut items = Vec::with_capacity(lists.iter().map(Vec::len).sum());
        offsets.push(0);
        for l in lists {
            items.extend_from_slice(l);
            offsets.push(items.len() as u32);
        }
        Csr { offsets, items }
    }

    /// Lists of `n` keys from (key, item) pairs, items in pair order.
    pub fn from_lists(n: usize, pairs: impl Iterator<Item = (usize, u32)> + Clone) -> Csr {
        let mut counts = vec![0u32; n + 1];
        for (k, _) in pairs.clone() {
            counts[k + 1] += 1;
        }
        for i in 0..n {
            counts[i + 1] += counts[i];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; counts[n] as usize];
        for (k, item) in pairs {
            items[fill[k] as usize] = item;
            fill[k] += 1;
        }
        Csr { offsets: counts, items }
    }

    /// List `i` (panics past the last).
    #[inline]
    pub fn get(&self, i: usize) -> &[u32] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Number of lists.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True when there are no lists (empty lists count as lists).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Each list merged with `other`'s, sorted and without repeats.
    pub fn union(&self, other: &Csr) -> Csr {
        let lists: Vec<Vec<u32>> = (0..self.len().max(other.len()))
            .map(|i| {
                let of = |c: &Csr| if i < c.len() { c.get(i).to_vec() } else { Vec::new() };
                let mut l = of(self);
                l.extend(of(other));
                l.sort_unstable();
                l.dedup();
                l
            })
            .collect();
        Csr::from_vecs(&lists)
    }
}

#[cfg(test)]
mod tests {
    use super::Csr;

    #[test]
    fn union_merges_each_list_sorted_without_repeats() {
        let a = Csr::from_vecs(&[vec![1, 4], vec![], vec![7]]);
        let b = Csr::from_vecs(&[vec![4, 2], vec![3], vec![7], vec![9]]);
        let u = a.union(&b);
        let lists: Vec<&[u32]> = (0..u.len()).map(|i| u.get(i)).collect();
        assert_eq!(lists, [&[1, 2, 4][..], &[3], &[7], &[9]]);
    }
}
