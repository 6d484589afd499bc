//! Bounded-error interactive ray tracing (Bala, Dorsey and Teller, "Radiance
//! Interpolants for Accelerated Bounded-Error Ray Tracing", ACM TOG 1999):
//! the Whitted tracer's radiance interpolated over 4D line space within a
//! user's error bound, with exact pixel assignment, lazy linetrees, an
//! error predicate that is a guarantee (affine arithmetic through the ray
//! tree), reprojection of the previous frame's cells, and a memory cap.

pub mod affine;
pub mod frame;
pub mod geometry;
pub mod gpu;
pub mod interpolate;
pub mod jet;
pub mod linespace;
pub mod linetree;
pub mod measure;
pub mod patch;
pub mod predicate;
pub mod runner;
pub mod samples;
pub mod screen;
pub mod sequence;
pub mod settings;
pub mod shaft;
pub mod tune;

pub use frame::{BoundedFrame, FrameStats, PixelPath, TraceReason};
pub use predicate::{BoundKind, Failure};
pub use runner::BoundedRenderer;
pub use settings::{BoundedSettings, SlowPath, SplitKind};
