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

/// One node of the tree, the two words of the table above; its layout is
/// the one `wgsl/kdtree_traverse.wgsl` reads.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct KdNode {
    /// An interior node's split position (f32 bits, world units); a leaf's
    /// first entry in `leaf_triangles`.
    pub word0: u32,
    /// The axis (0..2, or 3 for a leaf) in the low two bits; above them an
    /// interior node's above child index, a leaf's triangle count.
    pub word1: u32,
}

impl KdNode {
    /// An interior node splitting `axis` at `split`; its below child is the
    /// next node, its above child node `above_child` (under 2^30).
    pub fn interior(axis: usize, split: f32, above_child: u32) -> Self {
        debug_assert!(axis < 3 && above_child < (1 << 30));
        KdNode {
            word0: split.to_bits(),
            word1: axis as u32 | (above_child << 2),
        }
    }

    /// A leaf of `count` triangles (at most `MAX_LEAF_TRIANGLES`), whose
    /// indices start at entry `first` of `leaf_triangles`.
    pub fn leaf(first: u32, count: u32) -> Self {
        debug_assert!(count <= MAX_LEAF_TRIANGLES);
        KdNode {
            word0: first,
            word1: 3 | (count << 2),
        }
    }

    /// Whether the node is a leaf (axis bits 3).
    #[inline(always)]
    pub fn is_leaf(self) -> bool {
        self.word1 & 3 == 3
    }

    /// Split axis of an interior node.
    #[inline(always)]
    pub fn axis(self) -> usize {
        (self.word1 & 3) as usize
    }

    /// Split position of an interior node, in world units.
    #[inline(always)]
    pub fn split(self) -> f32 {
        f32::from_bits(self.word0)
    }

    /// Index of an interior node's above child (the side of larger
    /// coordinates); the below child is the node after this one.
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
