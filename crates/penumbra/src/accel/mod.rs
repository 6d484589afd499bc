//! Acceleration structures for rays against a scene's triangles, and
//! `Accel`, the type that owns them: the SAH kd-tree (`kdtree`, the
//! multi-level ray tracing paper's foundation) and the wide BVH of the same
//! triangles (`bvh`), built from the kd-tree in its frame the first time
//! something asks for it. Whatever traces rays against "the scene" holds an
//! `Accel`; code that only ever walks the kd-tree (MLRTA's packets, the
//! Whitted tracer, the GPU uploads) reads `Accel::kdtree`, or holds a
//! `KdTree` of its own.
//!
//! Which structure a ray walks:
//! - the GPU kernels (closest hits, AO rays, MLRTA, Whitted) walk the
//!   kd-tree, uploaded as it is (`kdtree::gpu`);
//! - on the CPU, single rays (closest hit, any hit, batches) and AO packets
//!   walk the structure `Structure` names: by default the BVH, faster on
//!   the CPU; `--accel kdtree` on the command line picks the kd-tree;
//! - MLRTA's CPU packets (tiles, entry points) and the Whitted tracer's CPU
//!   twin walk the kd-tree; a camera's 4x4 packets walk the BVH from its
//!   root instead with `trace --accel bvh` (`bvh::packet`);
//! - a BVH hit closer than `Bvh8::contact` is traced again through the
//!   kd-tree, whose answer it gets.
//!
//! Both structures give the same hits, bit for bit; only where two
//! triangles are hit at exactly the same t may they name different ones
//! (the BVH the smaller index).

pub mod bvh;
pub mod kdtree;
mod structures;

pub use structures::{Accel, BvhStats, Structure};
