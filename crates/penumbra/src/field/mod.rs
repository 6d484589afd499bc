//! Displacement fields: presampled visibility of rigid objects (Gaitatzes,
//! Chrysanthou and Papaioannou, "Presampled Visibility for Ambient
//! Occlusion", WSCG 2008).
//!
//! For each caster, maps on its bounding sphere store the distance to its
//! surface along a hemisphere of inward directions (`build`, Algorithm 1);
//! at run time a ray's hit distance is a ray-sphere test plus a
//! constant-time lookup (`lookup`, Algorithm 2), on the CPU or from a 3D
//! texture in WGSL (`gpu`). AO through fields (`ao`) costs the same whatever
//! the caster's triangle count, and one field serves every instance and
//! every rigid motion of its object.
//!
//! - `positions`: positional samples (equal-area octahedral grid) and their
//!   constant-time inverse;
//! - `directions`: the (s, t) mappings of the hemisphere (concentric +
//!   Malley, polar, rejection) and inverses;
//! - `storage`: 32-bit, 8-bit and 1-bit maps;
//! - `file`: the `.dfield` format;
//! - `query`: a field made ready for many lookups (frames tabulated);
//! - `batch`: the lookups of sixteen rays of a point at once, in vector
//!   instructions;
//! - `runner`: AO of a scene's receivers through its casters' fields, on
//!   any device (`ao --method field`).

pub(crate) mod ao;
pub(crate) mod batch;
pub mod build;
pub(crate) mod directions;
mod entry;
pub mod file;
pub mod gpu;
pub mod lookup;
pub(crate) mod positions;
pub(crate) mod query;
pub mod reach;
pub mod report;
pub mod runner;
pub(crate) mod storage;
pub mod tune;

pub use ao::{FieldCaster, NO_OWNER, RayClasses, field_ao};
pub use build::{BuildStats, DisplacementField, FieldSummary, bounding_sphere};
pub use directions::DirectionMapping;
pub use entry::FieldSettings;
pub use lookup::{FieldTrace, Positional, Sample, field_probe};
pub use positions::OctahedralGrid;
pub use query::FieldQuery;
pub use storage::{FieldData, FieldSampling, Storage};
