//! The bounded-error renderer's knobs as command-line options (see
//! `crate::options`).

use clap::Args;

use crate::options::{Applies, OnOff, applies};
use penumbra::bounded::sequence::Measures;
use penumbra::bounded::settings::DEFAULT_FLOOR;
use penumbra::bounded::{BoundKind, BoundedSettings, SlowPath, SplitKind};
use penumbra::error::{Error, Result};
use penumbra::whitted::WhittedSettings;

#[derive(Args, Clone, Debug)]
pub struct BoundedOptions {
    /// bounded: the relative error bound epsilon (0 renders the Whitted image exactly).
    #[arg(long, default_value_t = 0.05, allow_negative_numbers = true)]
    pub epsilon: f32,
    /// bounded: the radiance below which the bound is absolute (epsilon x floor).
    #[arg(long, default_value_t = DEFAULT_FLOOR, allow_negative_numbers = true)]
    pub floor: f32,
    /// bounded: affine-arithmetic bound (a guarantee) or the paper's estimate at the cell's centre.
    #[arg(long, value_enum, default_value_t = BoundKind::Conservative)]
    pub bound: BoundKind,
    /// bounded: split a failed cell 16 ways (the paper) or 4 ways along the coordinates it varies most in.
    #[arg(long, default_value = "16", value_parser = ["16", "4"])]
    pub split: String,
    /// bounded: reproject the previous frame's cells (the fast path).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub reproject: OnOff,
    /// bounded: fill runs of reprojected pixels by screen-space interpolation (outside the guarantee).
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub span: OnOff,
    /// bounded: linetrees over smooth patches of meshes (cells span triangles) or per smooth triangle.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub patches: OnOff,
    /// bounded: memory cap of linetree cells and samples; least recently used cells are evicted.
    #[arg(long, default_value_t = 1024.0, allow_negative_numbers = true)]
    pub memory_mb: f64,
    /// bounded: a failed cell is split only if at least this many pixels per child ask for it.
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = BoundedSettings::default().min_pixels, allow_negative_numbers = true)]
    pub min_pixels: u32,
    /// bounded: on a GPU, trace the pixels that are not interpolated and the extremal rays' trees with the Whitted kernel or on the CPU.
    #[arg(long, value_enum, default_value_t = SlowPath::Auto)]
    pub slow_path: SlowPath,
    /// bounded: also render every frame exactly and report the error and the speed-up.
    #[arg(long)]
    pub reference: bool,
    /// bounded: trace K random lines in every accepted cell a frame uses and count violations.
    #[arg(long, value_parser = crate::options::count::<u32>(1), allow_negative_numbers = true)]
    pub check: Option<u32>,
}

impl BoundedOptions {
    /// The checked settings over the Whitted tracer's.
    pub fn settings(&self, whitted: WhittedSettings) -> Result<BoundedSettings> {
        let s = BoundedSettings {
            epsilon: self.epsilon,
            floor: self.floor,
            bound: self.bound,
            split: if self.split == "4" {
                SplitKind::Four
            } else {
                SplitKind::Sixteen
            },
            reproject: self.reproject.on(),
            span: self.span.on(),
            patches: self.patches.on(),
            memory_mb: self.memory_mb,
            min_pixels: self.min_pixels,
            slow_path: self.slow_path,
            whitted,
        };
        s.validate()?;
        Ok(s)
    }

    /// The options that apply only to the bounded renderer (`bounded`: it is the one used).
    pub fn applies(bounded: bool) -> Applies {
        let ids = &[
            "epsilon",
            "floor",
            "bound",
            "split",
            "reproject",
            "span",
            "patches",
            "memory_mb",
            "min_pixels",
            "slow_path",
            "reference",
            "check",
        ];
        applies(bounded, ids, "--method bounded")
    }

    /// What each frame is measured against (`seed`: the check's lines').
    pub fn measures(&self, seed: u32) -> Result<Measures> {
        if self.check == Some(0) {
            return Err(Error::param("check", "must be at least 1 line per cell"));
        }
        Ok(Measures {
            reference: self.reference,
            check_lines: self.check,
            seed,
        })
    }
}
