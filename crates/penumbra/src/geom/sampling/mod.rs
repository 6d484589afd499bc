//! Sample generation shared bit for bit by the CPU and the WGSL kernels
//! (`wgsl/sampling.wgsl` is the twin of this module).
//!
//! * `sequence`: Owen-scrambled Sobol points, seeded, integer arithmetic only,
//!   so a seed gives the same points on every device.
//! * `atan`: the arctangent on [-1, 1] as a polynomial (for the inverses).
//! * `concentric`: Shirley and Chiu's concentric square-to-disk map and its inverse.
//! * `hemisphere`: Malley's method (cosine-weighted hemisphere directions by
//!   lifting concentric-disk points), and an orthonormal basis around a normal.

pub(crate) mod atan;
pub(crate) mod concentric;
pub(crate) mod hemisphere;
pub(crate) mod sequence;

pub use concentric::{concentric_disk, concentric_square};
pub use hemisphere::{Frame, cosine_hemisphere, malley_inverse};
pub use sequence::{SampleSequence, StreamSampler, hash_u32, unit_float};

/// The seed every method's sample sequence starts from unless told: the
/// same seed gives the same samples, bit for bit, on one device.
pub const DEFAULT_SEED: u32 = 0x5eed;
