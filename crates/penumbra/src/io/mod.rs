//! Files a run writes: images (PNG, EXR, PFM), per-vertex values (CSV,
//! PLY), ray files, each written whole or not at all.

pub mod image;
pub mod output;
pub mod rays;
pub mod shard;
pub mod vertex;
