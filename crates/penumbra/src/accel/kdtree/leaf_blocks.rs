//! The CPU's copy of the leaves: each leaf's triangles in blocks of four,
//! coordinates laid out lane by lane (SoA), so that the single-ray
//! traversal tests four triangles with one set of vector operations instead
//! of one triangle at a time with a branch after each early exit (on 1M
//! random rays against the bunny, +9%; on the cow, whose tree stays in
//! cache, +18%).
//!
//! `nodes` is `KdTree::nodes` with each leaf's first entry replaced by the
//! index of its first block; interior nodes, and so every node index, are
//! unchanged (the packet traversals hand node indices of `KdTree::nodes` to
//! the single-ray walk). The GPU keeps the original layout.
//!
//! The price is memory: a block is 160 bytes whatever its triangle count,
//! and most leaves hold one or two, about 100 bytes per leaf reference on
//! top of `leaf_vertices` (bunny `trace-rays`: peak 96 -> 132 MB).

use glam::Vec3;

use super::node::KdNode;
use super::watertight::ShearedRay;

/// Triangles of one leaf per block.
pub const BLOCK: usize = 4;

/// Four triangles of a leaf: `v[3 * vertex + axis][lane]`, vertices
/// multiplied by the tree's `frame_scale` (as `KdTree::leaf_vertices`),
/// and their indices in the mesh. Lanes past the leaf's end are zero
/// triangles (degenerate: never hit) and `u32::MAX`.
#[repr(C, align(16))]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeafBlock {
    /// Coordinate `axis` of vertex `vertex` of the lane's triangle, at
    /// `v[3 * vertex + axis][lane]`, in the tree's frame.
    pub v: [[f32; BLOCK]; 9],
    /// Each lane's triangle index in the mesh; `u32::MAX` in unused lanes.
    pub triangles: [u32; BLOCK],
}

/// `KdTree::nodes` pointing into `blocks`, see the module's doc.
#[derive(Debug, Clone)]
pub struct LeafBlocks {
    /// `KdTree::nodes`, each leaf's word 0 the index of its first block
    /// in `blocks` (its triangle count still in word 1).
    pub nodes: Vec<KdNode>,
    /// Every leaf's blocks, leaf after leaf; a leaf of `n` triangles has
    /// `n.div_ceil(4)` of them.
    pub blocks: Vec<LeafBlock>,
}

impl LeafBlocks {
    /// The blocks of a tree's leaves; `leaf_vertices` (scaled) and
    /// `leaf_triangles` are indexed by the leaves' ranges in `nodes`.
    pub fn new(nodes: &[KdNode], leaf_triangles: &[u32], leaf_vertices: &[[Vec3; 3]]) -> LeafBlocks {
        let mut blocks = Vec::new();
        let nodes = nodes
            .iter()
            .map(|&node| {
                if !node.is_leaf() {
                    return node;
                }
                let range = node.leaf_range();
                let first_block = blocks.len() as u32;
                for start in range.clone().step_by(BLOCK) {
                    let mut block = LeafBlock {
                        v: [[0.0; BLOCK]; 9],
                        triangles: [u32::MAX; BLOCK],
                    };
                    for (lane, i) in (start..range.end.min(start + BLOCK)).enumerate() {
                        for (vertex, p) in leaf_vertices[i].iter().enumerate() {
                            for axis in 0..3 {
                                block.v[3 * vertex + axis][lane] = p[axis];
                            }
                        }
                        block.triangles[lane] = leaf_triangles[i];
                    }
                    blocks.push(block);
                }
                KdNode::leaf(first_block, range.len() as u32)
            })
            .collect();
        LeafBlocks { nodes, blocks }
    }

    /// The blocks of leaf `node` (a node of `self.nodes`).
    #[inline(always)]
    pub fn of_leaf(&self, node: KdNode) -> &[LeafBlock] {
        let first = node.word0 as usize;
        let count = (node.word1 >> 2) as usize;
        &self.blocks[first..first + count.div_ceil(BLOCK)]
    }
}

/// The four lanes `f(0..4)`.
#[inline(always)]
fn lanes(f: impl Fn(usize) -> f32) -> [f32; BLOCK] {
    let mut out = [0.0; BLOCK];
    for (l, x) in out.iter_mut().enumerate() {
        *x = f(l);
    }
    out
}

impl ShearedRay {
    /// `intersect` of the four triangles of `block`, before its final
    /// `0 < t < t_max` test: each lane's t in the frame (`scale` times the
    /// world's), NaN where the lane misses. Every lane runs the same IEEE
    /// operations in the same order as `intersect` (no fused multiply-add in
    /// Rust), so its t is bit for bit the one `intersect` compares.
    ///
    /// On x86-64 it is written in SSE2 (part of the architecture): left to
    /// the compiler's vectoriser, the same arithmetic on arrays was
    /// vectorised or not depending on where it was inlined, and an edit
    /// elsewhere in the crate once made the single-ray path 1.8 times
    /// slower on cornell-mirror-glass (`intersect_block_lanes` is the
    /// portable version, and the test holds the two to each other).
    #[inline(always)]
    pub fn intersect_block(&self, block: &LeafBlock) -> [f32; BLOCK] {
        #[cfg(target_arch = "x86_64")]
        {
            self.intersect_block_sse2(block)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.intersect_block_lanes(block)
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn intersect_block_sse2(&self, block: &LeafBlock) -> [f32; BLOCK] {
        use std::arch::x86_64::*;
        let o = self.origin.to_array();
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        // SAFETY: SSE2 is part of x86-64, and every row of `block.v` is 16
        // bytes at a 16-byte boundary (`LeafBlock` is `align(16)`).
        unsafe {
            let rel = |vertex: usize, axis: usize| {
                _mm_sub_ps(_mm_load_ps(block.v[3 * vertex + axis].as_ptr()), _mm_set1_ps(o[axis]))
            };
            let (a_x, a_y, a_z) = (rel(0, kx), rel(0, ky), rel(0, kz));
            let (b_x, b_y, b_z) = (rel(1, kx), rel(1, ky), rel(1, kz));
            let (c_x, c_y, c_z) = (rel(2, kx), rel(2, ky), rel(2, kz));
            let (sx, sy, sz) = (_mm_set1_ps(self.sx), _mm_set1_ps(self.sy), _mm_set1_ps(self.sz));
            let ax = _mm_sub_ps(a_x, _mm_mul_ps(sx, a_z));
            let ay = _mm_sub_ps(a_y, _mm_mul_ps(sy, a_z));
            let bx = _mm_sub_ps(b_x, _mm_mul_ps(sx, b_z));
            let by = _mm_sub_ps(b_y, _mm_mul_ps(sy, b_z));
            let cx = _mm_sub_ps(c_x, _mm_mul_ps(sx, c_z));
            let cy = _mm_sub_ps(c_y, _mm_mul_ps(sy, c_z));
            let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
            let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
            let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
            let det = _mm_add_ps(_mm_add_ps(u, v), w);
            let t_scaled = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(u, _mm_mul_ps(sz, a_z)), _mm_mul_ps(v, _mm_mul_ps(sz, b_z))),
                _mm_mul_ps(w, _mm_mul_ps(sz, c_z)),
            );
            // The comparisons are ordered (false on NaN), as Rust's.
            let zero = _mm_setzero_ps();
            let negative = _mm_or_ps(
                _mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)),
                _mm_cmplt_ps(w, zero),
            );
            let positive = _mm_or_ps(
                _mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)),
                _mm_cmpgt_ps(w, zero),
            );
            let behind = _mm_or_ps(
                _mm_and_ps(_mm_cmpgt_ps(det, zero), _mm_cmple_ps(t_scaled, zero)),
                _mm_and_ps(_mm_cmplt_ps(det, zero), _mm_cmpge_ps(t_scaled, zero)),
            );
            let miss = _mm_or_ps(
                _mm_or_ps(_mm_and_ps(negative, positive), _mm_cmpeq_ps(det, zero)),
                behind,
            );
            let t = _mm_div_ps(t_scaled, det);
            let out = _mm_or_ps(_mm_and_ps(miss, _mm_set1_ps(f32::NAN)), _mm_andnot_ps(miss, t));
            let mut lanes = [0.0; BLOCK];
            _mm_storeu_ps(lanes.as_mut_ptr(), out);
            lanes
        }
    }

    /// `intersect_block` in plain arrays, lane by lane.
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    fn intersect_block_lanes(&self, block: &LeafBlock) -> [f32; BLOCK] {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let o = self.origin.to_array();
        let rel = |vertex: usize, axis: usize| lanes(|l| block.v[3 * vertex + axis][l] - o[axis]);
        let (a_x, a_y, a_z) = (rel(0, kx), rel(0, ky), rel(0, kz));
        let (b_x, b_y, b_z) = (rel(1, kx), rel(1, ky), rel(1, kz));
        let (c_x, c_y, c_z) = (rel(2, kx), rel(2, ky), rel(2, kz));
        let ax = lanes(|l| a_x[l] - self.sx * a_z[l]);
        let ay = lanes(|l| a_y[l] - self.sy * a_z[l]);
        let bx = lanes(|l| b_x[l] - self.sx * b_z[l]);
        let by = lanes(|l| b_y[l] - self.sy * b_z[l]);
        let cx = lanes(|l| c_x[l] - self.sx * c_z[l]);
        let cy = lanes(|l| c_y[l] - self.sy * c_z[l]);
        let u = lanes(|l| cx[l] * by[l] - cy[l] * bx[l]);
        let v = lanes(|l| ax[l] * cy[l] - ay[l] * cx[l]);
        let w = lanes(|l| bx[l] * ay[l] - by[l] * ax[l]);
        let det = lanes(|l| u[l] + v[l] + w[l]);
        let t_scaled = lanes(|l| u[l] * (self.sz * a_z[l]) + v[l] * (self.sz * b_z[l]) + w[l] * (self.sz * c_z[l]));
        // The early exits of `intersect`, as masks (non-short-circuit `|`
        // and `&`: no branches).
        lanes(|l| {
            let negative = (u[l] < 0.0) | (v[l] < 0.0) | (w[l] < 0.0);
            let positive = (u[l] > 0.0) | (v[l] > 0.0) | (w[l] > 0.0);
            let behind = ((det[l] > 0.0) & (t_scaled[l] <= 0.0)) | ((det[l] < 0.0) & (t_scaled[l] >= 0.0));
            let miss = (negative & positive) | (det[l] == 0.0) | behind;
            if miss { f32::NAN } else { t_scaled[l] / det[l] }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each lane's t equals `intersect`'s bit for bit, hit or miss, over
    /// random, degenerate and edge-on triangles.
    #[test]
    fn block_lanes_equal_the_single_triangle_test() {
        let mut rng = crate::accel::kdtree::test_rng::Rng(0x2545_f491_4f6c_dd1d);
        let mut rnd = || rng.next_f32() * 2.0 - 1.0;
        let mut checked = [0usize; 2];
        for k in 0..4000 {
            let mut tris: Vec<[Vec3; 3]> = (0..BLOCK)
                .map(|_| [0; 3].map(|_| Vec3::new(rnd(), rnd(), rnd())))
                .collect();
            if k % 7 == 0 {
                tris[1] = [tris[1][0]; 3];
                tris[2][2] = tris[2][0] * 0.5 + tris[2][1] * 0.5;
            }
            let leaf = KdNode::leaf(0, BLOCK as u32);
            let ids: Vec<u32> = (0..BLOCK as u32).collect();
            let blocks = LeafBlocks::new(&[leaf], &ids, &tris);
            let o = Vec3::new(rnd(), rnd(), rnd()) * 3.0;
            // Through a vertex, through a lane's centroid, or anywhere.
            let d = match k % 3 {
                0 => tris[0][1] - o,
                1 => (tris[k % BLOCK][0] + tris[k % BLOCK][1] + tris[k % BLOCK][2]) / 3.0 - o,
                _ => Vec3::new(rnd(), rnd(), rnd()),
            };
            let ray = ShearedRay::in_frame(o, d, 0.5);
            let t = ray.intersect_block(&blocks.blocks[0]);
            let portable = ray.intersect_block_lanes(&blocks.blocks[0]);
            assert_eq!(
                t.map(f32::to_bits),
                portable.map(f32::to_bits),
                "case {k}: SSE2 and lanes"
            );
            for (lane, tri) in tris.iter().enumerate() {
                let single = ray.intersect(tri[0], tri[1], tri[2], f32::INFINITY);
                let block = (t[lane] > 0.0 && t[lane] < f32::INFINITY).then_some(t[lane] * ray.inv_scale);
                assert_eq!(
                    single.map(f32::to_bits),
                    block.map(f32::to_bits),
                    "case {k} lane {lane}"
                );
                checked[single.is_some() as usize] += 1;
            }
        }
        assert!(checked[0] > 1000 && checked[1] > 1000, "{checked:?}");
    }
}
