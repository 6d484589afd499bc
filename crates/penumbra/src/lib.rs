//! penumbra: visibility on the GPU — ray casting, ambient occlusion, soft
//! self-shadowing, Whitted and bounded-error ray tracing — through
//! wgpu/WGSL compute kernels, headless, with a CPU twin for every kernel
//! (same name, same data layout, tested against each other).
//!
//! Every method has one entry, built from a [`Device`] and its input, run
//! with a settings struct whose `Default` is the command line's defaults:
//!
//! | method | entry | settings |
//! |---|---|---|
//! | ray casting and AO | [`AmbientOcclusion`], [`Tracer`] | [`AoSettings`] |
//! | displacement-field AO | [`FieldAo::build`] | [`FieldSettings`] |
//! | screen-space AO | [`Ssao`] | [`SsaoSettings`] |
//! | precomputed radiance transfer | [`PrtRunner::for_mesh`] | [`PrtSettings`] |
//! | multi-level ray tracing (primary rays) | [`PrimaryRays`] | [`TraceSettings`] |
//! | Whitted ray tracing | [`WhittedRenderer::for_scene`] | [`WhittedSettings`] |
//! | bounded-error ray tracing | [`BoundedRenderer::for_scene`] | [`BoundedSettings`] |
//!
//! ```
//! use penumbra::{AmbientOcclusion, AoSettings, Device};
//! use penumbra::scene::procedural::sphere_on_plane;
//!
//! let device = Device::cpu(); // or Device::from_host(&device, &queue)
//! let mesh = sphere_on_plane(); // or penumbra::Mesh::load("bunny.obj")?
//! let ao = AmbientOcclusion::new(&device, &mesh)?.vertices(&AoSettings::default())?;
//! println!("mean AO {:.3}", ao.mean());
//! # Ok::<(), penumbra::Error>(())
//! ```
//!
//! A host engine adopts its own `wgpu::Device` and `Queue`
//! ([`Device::from_host`]); the GPU passes one level down ([`ssao::gpu`],
//! [`prt::gpu`], [`field::gpu`], [`whitted::gpu`], ...) follow `new` /
//! `prepare` / `record`: built once for the device, uploading into buffers
//! they keep, recording only into the caller's encoder. Long work reports to a
//! [`Progress`] the host implements, through a [`Reporter`]; nothing is
//! printed, no environment variable is read and no file is written unless
//! a call is given its path.
//!
//! Cargo features, on by default: `gltf`, `ply` (readers), `png`, `exr`
//! (image writers), `hdr` (light probes) and `simplify` (PRT's coarse
//! level, meshoptimizer); off by default: `clap` (`clap::ValueEnum` on the
//! settings' enums). Layers and module map: docs/design.md.

#![warn(missing_docs)]

pub mod accel;
#[cfg(all(feature = "gltf", feature = "png"))]
pub mod bake;
pub mod bench;
pub mod bounded;
pub(crate) mod choice;
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

pub use bounded::{BoundedRenderer, BoundedSettings};
pub use error::{Error, Result};
pub use field::FieldSettings;
pub use field::runner::FieldAo;
pub use geom::sampling::DEFAULT_SEED;
pub use gpu::device::{AdapterSettings, Device, DeviceChoice, LimitsChoice};
pub use mlrta::{PrimaryRays, TraceSettings};
pub use progress::{Progress, Reporter, Silent, Task};
pub use prt::pipeline::PrtSettings;
pub use prt::runner::PrtRunner;
pub use raycast::runner::{AoRequest, PixelAo, VertexAo};
pub use raycast::tracer::Tracer;
pub use raycast::{AmbientOcclusion, AoSettings};
pub use scene::{Camera, CameraSpec, Mesh, Scene, View, load_mesh, load_scene};
pub use ssao::{Estimator, Ssao, SsaoSettings};
pub use whitted::{WhittedRenderer, WhittedSettings};
