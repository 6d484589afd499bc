//! penumbra: visibility on the GPU — ambient occlusion, soft self-shadowing
//! and ray casting through wgpu/WGSL compute kernels, headless, with a CPU
//! reference path for every kernel.
//!
//! Every WGSL kernel in `wgsl/` has a CPU twin with the same name and data
//! layout (see `wgsl` for the list); tests run both and compare.

pub mod aabb;
pub mod ao;
pub mod bounded;
pub mod bvh;
pub mod cli;
pub mod color;
pub mod device;
pub mod error;
pub mod field;
pub mod float;
pub mod gpu;
pub mod image_out;
pub mod kdtree;
pub mod mlrta;
pub mod options;
pub mod output;
pub mod progress;
pub mod prt;
pub mod ray;
pub mod ray_file;
pub mod raytrace;
pub mod repeats;
pub mod sampling;
pub mod scene;
pub mod sh;
pub mod simd;
pub mod skipped;
pub mod ssao;
pub mod sweep;
pub mod tracer;
pub mod vertex_out;
pub mod wgsl;

pub use error::{Error, Result};
