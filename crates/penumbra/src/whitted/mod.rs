//! Whitted ray tracing (the base ray tracer of Bala, Dorsey and Teller's
//! bounded-error paper, section 3 and 8.1): OBJ/MTL materials, emissive
//! faces as lights, mirror reflection, refraction with total internal
//! reflection through nested glass, analytic spheres beside triangles, and
//! per-pixel ray trees, on the CPU and in `wgsl/whitted.wgsl`; the image
//! into a texture a host owns (`texture`, `wgsl/whitted_image.wgsl`).

pub mod gpu;
pub mod image;
pub(crate) mod lights;
pub(crate) mod optics;
pub(crate) mod packets;
pub(crate) mod pixel_rays;
pub mod ray_tree;
pub mod report;
pub(crate) mod runner;
pub mod scene;
pub(crate) mod sequence;
pub(crate) mod sphere;
pub(crate) mod surface;
pub mod texture;
pub mod tree_records;
// The CPU twin of `wgsl/whitted.wgsl` keeps the kernel's name.
#[allow(clippy::module_inception)]
pub(crate) mod whitted;

pub use ray_tree::{LightCode, RayKind, RayNode, RayTree};
pub use runner::{PACKETS_FROM_TRIANGLES, Packets, RayCounts, RenderStats, Rendered, WhittedRenderer, WhittedSettings};
pub use scene::{LightingSettings, RenderScene};
pub use sphere::tessellate;
pub use whitted::WhittedUniforms;
pub use whitted::{PixelOut, Whitted};
