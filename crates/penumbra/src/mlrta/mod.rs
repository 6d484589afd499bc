//! Multi-level ray tracing: Reshetov, Soupikov and Hurley, "Multi-Level Ray
//! Tracing Algorithm", SIGGRAPH 2005.
//!
//! * `frustum`: what is known about a group of rays (condition (3)), inverse
//!   frustum culling (section 3.3, assessment (1)) and leaf clipping (2);
//! * `prepared`: the kd-tree with subtree sizes and occluder leaves;
//! * `entry_point`: the entry-point search with its stopping rules (4.1);
//! * `packet`: 4x4 packets and the interval traversal (4.3);
//! * `tiles`: tile splitting for primary rays, shadow rays (4.2, 6);
//! * `squares`: a final tile's packets walked sixteen (or four) at a time;
//! * `ao`: AO ray groups through the same machinery;
//! * `runner`: a camera's image by single rays, packets or MLRTA, with
//!   shadows and anti-aliasing, on any device (`penumbra trace`).
//!
//! Every ray's hit equals the single-ray path's (`KdTree::closest_hit`): the
//! packet's decisions are conservative for each of its rays, and entry points
//! reached by a stopping rule re-trace the rays they found nothing for.

pub mod aa;
pub mod ao;
mod entry;
pub mod entry_point;
pub mod frustum;
pub mod gpu;
pub mod images;
pub mod packet;
pub(crate) mod prepared;
pub mod runner;
mod squares;
mod tile_rows;
pub mod tiles;
pub(crate) mod tune;

pub use entry::{PrimaryRays, TraceSettings};
pub use packet::MlrtaCounts;
pub use prepared::Prepared;
pub use tiles::{ImageBuffers, ImageTrace, MlrtaSettings, trace_camera_into, trace_image, trace_image_into};
