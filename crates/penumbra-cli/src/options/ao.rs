//! Ambient occlusion's knobs as command-line options (see
//! `crate::options`): how rays find occluders, how many, how far, and the
//! field runner's lookups, frames, reference and error budget.

use clap::{Args, ValueEnum};

use crate::options::{Applies, applies};
use penumbra::error::{Error, Result};
use penumbra::field::Positional;
use penumbra::field::runner::MAX_FRAMES;
use penumbra::raycast::AoSettings;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AoMethod {
    /// Reference: cast the rays against the casters' kd-tree.
    Raycast,
    /// Displacement fields of the casters (needs --receiver or --scene).
    Field,
}

#[derive(Args, Clone, Debug)]
pub struct AoOptions {
    /// How rays find occluders.
    #[arg(long, value_enum)]
    pub method: AoMethod,
    /// Rays per point.
    #[arg(long, value_parser = crate::options::count::<u32>(1), allow_negative_numbers = true)]
    pub rays: u32,
    /// Occluders beyond this distance do not count (default: infinite).
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// --method field: interpolate between the positional samples around a
    /// ray's entry point, or read the nearest (the paper).
    #[arg(long, value_enum, default_value_t = Positional::Bilinear)]
    pub positional: Positional,
    /// --method field: animation frames; instances with a "motion" in the
    /// scene file move between them, fields are reused. --per-vertex and
    /// --image get every frame where their name holds {} or {:04}, else the
    /// last frame.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub frames: i64,
    /// --method field: also cast the same rays against the casters' geometry
    /// and report the field's error (per vertex and per ray).
    #[arg(long)]
    pub reference: bool,
    /// --method field: the cheapest --positions/--res/--bits whose AO error
    /// against ray casting, estimated on 4096 vertices, is within this at
    /// 95% confidence (cached per scene).
    #[arg(long, allow_negative_numbers = true, conflicts_with_all = ["positions", "res", "bits"])]
    pub max_error: Option<f64>,
}

impl AoOptions {
    /// The field runner's options apply only with `--method field`.
    pub fn applies(&self) -> Applies {
        let ids = &["positional", "frames", "reference", "max_error"];
        applies(self.method == AoMethod::Field, ids, "--method field")
    }

    /// The checked settings (`seed`: the sample sequence's).
    pub fn settings(&self, seed: u32) -> Result<AoSettings> {
        let settings = AoSettings {
            rays_per_point: self.rays,
            radius: self.radius.unwrap_or(f32::INFINITY),
            seed,
        };
        settings.validate()?;
        Ok(settings)
    }

    /// The checked frame count of the field runner.
    pub fn frames(&self) -> Result<u32> {
        if !(1..=MAX_FRAMES as i64).contains(&self.frames) {
            let problem = format!("must be between 1 and {MAX_FRAMES}, got {}", self.frames);
            return Err(Error::param("frames", problem));
        }
        Ok(self.frames as u32)
    }
}
