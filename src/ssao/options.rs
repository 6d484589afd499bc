//! SSAO's knobs as command-line options (see `crate::options`).

use clap::Args;

use super::budget::Free;
use super::{DEFAULT_BIAS_PX, Estimator, Measure, MeasureKind, SsaoSettings};
use crate::error::Result;
use crate::options::OnOff;

#[derive(Args, Clone, Debug)]
pub struct SsaoOptions {
    /// The estimator of the paper (with --max-error: fixed, else chosen).
    #[arg(long, value_enum, required_unless_present = "max_error")]
    pub estimator: Option<Estimator>,
    /// Samples (depth-buffer tests) per pixel (with --max-error: fixed, else chosen).
    #[arg(long, allow_negative_numbers = true, required_unless_present = "max_error")]
    pub spp: Option<u32>,
    /// The fastest estimator and spp whose RMSE against the ray-traced truth,
    /// estimated on 2048 pixels, is within this at 95% confidence (cached per scene).
    #[arg(long, allow_negative_numbers = true)]
    pub max_error: Option<f64>,
    /// Neighbourhood radius R (scene units).
    #[arg(long, allow_negative_numbers = true)]
    pub radius: f32,
    /// Fuzzy measure mu(r).
    #[arg(long, value_enum, default_value_t = MeasureKind::Poly4)]
    pub measure: MeasureKind,
    /// Extinction sigma of --measure exp, inverse scene units [default: 3 / R].
    #[arg(long, allow_negative_numbers = true)]
    pub sigma: Option<f32>,
    /// Steps per ray of raymarch (rays = spp / steps).
    #[arg(long, default_value_t = 4, allow_negative_numbers = true)]
    pub steps: u32,
    /// Interleaved sampling over 4x4 pixel patterns.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub interleave: OnOff,
    /// Depth-aware 4x4 low-pass filter.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub filter: OnOff,
    /// The filter's depth limit (scene units) [default: R / 2].
    #[arg(long, allow_negative_numbers = true)]
    pub filter_depth: Option<f32>,
    /// Depth bias of the visibility test, in pixel footprints.
    #[arg(long, default_value_t = DEFAULT_BIAS_PX, allow_negative_numbers = true)]
    pub bias: f32,
    /// Scale each pixel's sample weights so an unoccluded point gets exactly 1
    /// (off: the paper's formulas as written).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub calibrate: OnOff,
}

impl SsaoOptions {
    /// The checked settings with the sample sequence's `seed` (without
    /// --estimator/--spp, as --max-error allows: its starting point).
    pub fn settings(&self, seed: u32) -> Result<SsaoSettings> {
        let settings = SsaoSettings {
            estimator: self.estimator.unwrap_or(Estimator::Importance),
            spp: self.spp.unwrap_or(16),
            radius: self.radius,
            measure: Measure::new(self.measure, self.sigma, self.radius)?,
            steps: self.steps,
            interleave: self.interleave.on(),
            filter: self.filter.on(),
            filter_depth: self.filter_depth,
            bias_px: self.bias,
            calibrate: self.calibrate.on(),
            seed,
        };
        settings.validate()?;
        Ok(settings)
    }

    /// What --max-error may choose: the knobs not given.
    pub fn free(&self) -> Free {
        Free {
            estimator: self.estimator.is_none(),
            spp: self.spp.is_none(),
        }
    }
}
