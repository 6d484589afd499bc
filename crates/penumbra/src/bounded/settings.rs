//! The bounded-error renderer's knobs: epsilon and its floor, the bound,
//! how failed cells split, reprojection and span filling, the memory cap,
//! and where the Whitted kernel runs (`BoundedOptions` maps the command
//! line onto them).

use serde::Serialize;

use crate::bounded::predicate::BoundKind;
use crate::error::{Error, Result};
use crate::whitted::WhittedSettings;

/// How a failed cell is split.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub enum SplitKind {
    /// All four coordinates halved: 16 children (the paper).
    #[default]
    Sixteen,
    /// One pair of coordinates, (a, c) or (b, d), halved, the one the
    /// predicate blames: 4 children (the paper's section 8.6).
    Four,
}

/// Where the slow path's pixels and the extremal rays are traced when the
/// renderer runs on a GPU (on the CPU they always are on the CPU).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum SlowPath {
    /// The Whitted kernel on a hardware GPU; the CPU twin on a software adapter (lavapipe), where the kernel is slower than the CPU on the same cores.
    #[default]
    Auto,
    /// The Whitted kernel over the list of pixels and the extremal rays (their ray trees), on the renderer's GPU.
    Device,
    /// The CPU twin, from the primary hit pixel assignment traced (and for the extremal rays).
    Cpu,
}

/// The knobs of the bounded-error renderer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BoundedSettings {
    /// The relative error bound: an interpolated pixel is within
    /// `epsilon * max(L, floor)` of the exact radiance `L`, per channel.
    pub epsilon: f32,
    /// The radiance below which the bound is absolute (`epsilon * floor`).
    pub floor: f32,
    /// Which bound decides non-linearity: the conservative one (a
    /// guarantee) or the paper's estimate.
    pub bound: BoundKind,
    /// How a rejected cell is split.
    pub split: SplitKind,
    /// Reproject the previous frame's cells (the fast path).
    pub reproject: bool,
    /// Fill spans of reprojected pixels of one cell by screen-space
    /// interpolation (section 6.2; outside the guarantee).
    pub span: bool,
    /// Memory cap of linetree cells and samples, in MiB.
    pub memory_mb: f64,
    /// A rejected cell is split only if at least this many pixels per child
    /// asked for it (section 7's cost model).
    pub min_pixels: u32,
    /// Where traced pixels are traced on a GPU.
    pub slow_path: SlowPath,
    /// Linetrees over the smooth patches of meshes (`patch`): a cell may
    /// span a mesh's triangles, instead of each smooth triangle being a
    /// surface of its own. Off by default: on the shared meshes it
    /// interpolates 1 to 18% of the pixels where per-triangle linetrees
    /// interpolate none, but the cells cost more than the shadow rays and
    /// shading they save (docs/results/bounded.md, "Smooth patches").
    /// Read when the renderer is made.
    pub patches: bool,
    /// The Whitted tracer's knobs (ray depth, Fresnel, packets) for the
    /// slow path and the extremal rays; `spp` must be 1.
    pub whitted: WhittedSettings,
}

/// `floor`'s default: one step of an 8-bit image of white 1.
pub const DEFAULT_FLOOR: f32 = 1.0 / 255.0;

impl Default for BoundedSettings {
    fn default() -> Self {
        BoundedSettings {
            epsilon: 0.05,
            floor: DEFAULT_FLOOR,
            bound: BoundKind::Conservative,
            split: SplitKind::Sixteen,
            reproject: true,
            span: false,
            patches: false,
            memory_mb: 1024.0,
            // Section 7's cost model: a cell built costs some 4 new extremal
            // rays (each a whole ray tree) and the predicate, 10 to 40
            // tracings of a pixel; at 2 pixels per child most of that went
            // on cells that served a handful of pixels. 4 cut the CPU time
            // of a 10-frame walk by 25 to 30% (checker-spheres,
            // cornell-mirror-glass) at the same guarantee.
            min_pixels: 4,
            slow_path: SlowPath::Auto,
            whitted: WhittedSettings::default(),
        }
    }
}

impl BoundedSettings {
    /// Checks every knob (the Whitted ones too): an error names the first
    /// out of range.
    pub fn validate(&self) -> Result<()> {
        self.whitted.validate()?;
        if self.whitted.spp != 1 {
            return Err(Error::param(
                "spp",
                "bounded-error rendering takes one sample per pixel (the guarantee is per ray)",
            ));
        }
        if !(self.epsilon >= 0.0 && self.epsilon.is_finite()) {
            return Err(Error::param(
                "epsilon",
                format!("must be >= 0 and finite, got {}", self.epsilon),
            ));
        }
        if !(self.floor > 0.0 && self.floor.is_finite()) {
            return Err(Error::param("floor", format!("must be positive, got {}", self.floor)));
        }
        if !(self.memory_mb > 0.0 && self.memory_mb.is_finite()) {
            return Err(Error::param(
                "memory_mb",
                format!("must be positive, got {}", self.memory_mb),
            ));
        }
        if self.min_pixels == 0 {
            return Err(Error::param("min_pixels", "must be at least 1"));
        }
        Ok(())
    }
}
