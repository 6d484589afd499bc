//! Bounded-error interactive ray tracing (Bala, Dorsey and Teller, "Radiance
//! Interpolants for Accelerated Bounded-Error Ray Tracing", ACM TOG 1999):
//! the Whitted tracer's radiance interpolated over 4D line space within a
//! user's error bound, with exact pixel assignment, lazy linetrees, an
//! error predicate that is a guarantee (affine arithmetic through the ray
//! tree), reprojection of the previous frame's cells, and a memory cap.

pub(crate) mod affine;
pub(crate) mod frame;
pub(crate) mod geometry;
pub mod gpu;
pub mod interpolate;
pub(crate) mod jet;
pub(crate) mod linespace;
pub mod linetree;
pub mod measure;
pub(crate) mod patch;
pub mod predicate;
pub(crate) mod runner;
pub(crate) mod samples;
pub(crate) mod screen;
pub mod sequence;
pub mod settings;
pub(crate) mod shaft;
pub(crate) mod tune;

pub use frame::{BoundedFrame, FrameStats, PixelPath, TraceReason};
pub use predicate::{BoundKind, Failure};
pub use runner::BoundedRenderer;
pub use settings::{BoundedSettings, SlowPath, SplitKind};
