//! Geometry and numerics every layer above uses: boxes and rays, float
//! ordering, colour conversions, sample sequences and the vector lanes of
//! the CPU traversals.

pub mod aabb;
pub mod color;
pub(crate) mod float;
pub(crate) mod offset;
pub mod ray;
pub mod sampling;
pub mod simd;
