//! penumbra: visibility on the GPU — ambient occlusion, soft self-shadowing
//! and ray casting through wgpu/WGSL compute kernels, headless, with a CPU
//! reference path for every kernel.
//!
//! Every WGSL kernel in `wgsl/` has a CPU twin with the same name and data
//! layout (see `wgsl` for the list); tests run both and compare.

pub mod accel;
pub mod bounded;
pub mod choice;
pub mod error;
pub mod field;
pub mod geom;
pub mod gpu;
pub mod io;
pub mod mlrta;
pub mod progress;
pub mod prt;
pub mod raycast;
pub mod report;
pub mod scene;
pub mod sh;
pub mod ssao;
pub mod sweep;
pub mod tune;
pub mod whitted;

pub use error::{Error, Result};
