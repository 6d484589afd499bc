//! The flat kd-tree node layout shared by the CPU traversal and the WGSL
//! kernels (`wgsl/kdtree_traverse.wgsl` reads the same two words).
//!
//! Nodes are 8 bytes, stored depth first so that an interior node's "below"
//! child (coordinate < split) immediately follows it and only the "above"
//! child's index is stored:
//!
//! | kind     | word 0                        | word 1                         |
//! |----------|-------------------------------|--------------------------------|
//! | interior | split position (f32 bits)     | axis (0..2) \| above child << 2 |
//! | leaf     | first entry in leaf_triangles | 3 \| triangle count << 2        |

use bytemuck::{Pod, Zeroable};

/// Deepest tree the builder makes, and the size of the traversal stack in the
/// CPU code and in WGSL (a per-thread array there, so it must be a constant).
pub const MAX_TREE_DEPTH: usize = 40;

/// Largest triangle count a leaf can record (30 bits).
pub const MAX_LEAF_TRIANGLES: u32 = (1 << 30) - 1;

#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct KdNode {
    pub word0: u32,
    pub word1: u32,
}

impl KdNode {
    pub fn interior(axis: usize, split: f32, above_child: u32) -> Self {
        debug_assert!(axis < 3 && above_child < (1 << 30));
        KdNode {
            word0: split.to_bits(),
            word1: axis as u32 | (above_child << 2),
        }
    }

    pub fn leaf(first: u32, count: u32) -> Self {
        debug_assert!(count <= MAX_LEAF_TRIANGLES);
        KdNode {
            word0: first,
            word1: 3 | (count << 2),
        }
    }

    #[inline(always)]
    pub fn is_leaf(self) -> bool {
        self.word1 & 3 == 3
    }

    /// Split axis of an interior node.
    #[inline(always)]
    pub fn axis(self) -> usize {
        (self.word1 & 3) as usize
    }

    #[inline(always)]
    pub fn split(self) -> f32 {
        f32::from_bits(self.word0)
    }

    #[inline(always)]
    pub fn above_child(self) -> u32 {
        self.word1 >> 2
    }

    /// Range of a leaf's entries in `leaf_triangles`.
    #[inline(always)]
    pub fn leaf_range(self) -> std::ops::Range<usize> {
        let first = self.word0 as usize;
        first..first + (self.word1 >> 2) as usize
    }
}
