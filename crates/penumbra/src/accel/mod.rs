//! Acceleration structures: the SAH kd-tree (the multi-level ray tracing
//! paper's foundation, walked by the GPU kernels and the CPU packets) and
//! the wide BVH single CPU rays walk.

pub mod bvh;
pub mod kdtree;
