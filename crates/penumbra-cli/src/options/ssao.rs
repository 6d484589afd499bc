//! SSAO's knobs as command-line options (see `crate::options`).

use clap::Args;

use crate::options::{Applies, OnOff, applies};
use penumbra::error::Result;
use penumbra::report::repeats::Repeats;
use penumbra::scene::View;
use penumbra::ssao::runner::SsaoRequest;
use penumbra::ssao::tune::Free;
use penumbra::ssao::{DEFAULT_BIAS_PX, Estimator, Measure, MeasureKind, Resolution, ShadeSettings, SsaoSettings};

#[derive(Args, Clone, Debug)]
pub struct SsaoOptions {
    /// The estimator of the paper (with --max-error: fixed, else chosen).
    #[arg(long, value_enum, required_unless_present = "max_error")]
    pub estimator: Option<Estimator>,
    /// Samples (depth-buffer tests) per pixel (with --max-error: fixed, else chosen).
    #[arg(long, value_parser = crate::options::count::<u32>(1), allow_negative_numbers = true, required_unless_present = "max_error")]
    pub spp: Option<u32>,
    /// The fastest estimator and spp whose RMSE against the ray-traced truth,
    /// estimated on 2048 pixels, is within this at 95% confidence (cached per scene).
    #[arg(long, allow_negative_numbers = true)]
    pub max_error: Option<f64>,
    /// Neighbourhood radius R (scene units) [default: 5% of the scene's
    /// bounding-box diagonal].
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Fuzzy measure mu(r).
    #[arg(long, value_enum, default_value_t = MeasureKind::Poly4)]
    pub measure: MeasureKind,
    /// Extinction sigma of --measure exp, inverse scene units [default: 3 / R].
    #[arg(long, allow_negative_numbers = true)]
    pub sigma: Option<f32>,
    /// Steps per ray of raymarch (rays = spp / steps).
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 4, allow_negative_numbers = true)]
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
    /// Where the estimator and the AO filter run: every pixel, or every
    /// other pixel in x and y, upsampled depth-aware (about a quarter of
    /// their time; blurs detail finer than two pixels).
    #[arg(long, value_enum, default_value_t = Resolution::Full)]
    pub resolution: Resolution,
}

impl SsaoOptions {
    /// The checked settings with the sample sequence's `seed` (without
    /// --estimator/--spp, as --max-error allows: its starting point), and
    /// `scene_radius` without --radius (`ssao::suggested_radius` of the
    /// scene).
    pub fn settings(&self, seed: u32, scene_radius: f32) -> Result<SsaoSettings> {
        let radius = self.radius.unwrap_or(scene_radius);
        let settings = SsaoSettings {
            estimator: self.estimator.unwrap_or(Estimator::Importance),
            spp: self.spp.unwrap_or(16),
            radius,
            measure: Measure::new(self.measure, self.sigma, radius)?,
            steps: self.steps,
            interleave: self.interleave.on(),
            filter: self.filter.on(),
            filter_depth: self.filter_depth,
            bias_px: self.bias,
            calibrate: self.calibrate.on(),
            resolution: self.resolution,
            seed,
        };
        settings.validate()?;
        Ok(settings)
    }

    /// Which knobs apply to the chosen measure, estimator and filter.
    pub fn applies(&self) -> Vec<Applies> {
        let raymarch = matches!(self.estimator, None | Some(Estimator::Raymarch));
        vec![
            applies(self.measure == MeasureKind::Exp, &["sigma"], "--measure exp"),
            applies(raymarch, &["steps"], "--estimator raymarch"),
            applies(self.filter == OnOff::On, &["filter_depth"], "--filter on"),
        ]
    }

    /// What --max-error may choose: the knobs not given.
    pub fn free(&self) -> Free {
        Free {
            estimator: self.estimator.is_none(),
            spp: self.spp.is_none(),
        }
    }
}

/// What a run computes besides the AO: the shaded image's ambient light,
/// the truths it is measured against, and repeats of the GPU passes.
#[derive(Args, Clone, Debug)]
pub struct SsaoRunOptions {
    /// Compute the indirect light and image even without --image (timed).
    #[arg(long)]
    pub indirect: bool,
    /// Ambient radiance La of the shaded image.
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub ambient: f32,
    /// Rays per pixel of the ray-traced reference, the ground truth (0: skip
    /// it, rmse_vs_raytraced is null).
    #[arg(long, value_parser = crate::options::count::<u32>(0), alias = "truth-rays", default_value_t = 256, allow_negative_numbers = true)]
    pub reference_rays: u32,
    /// Samples per pixel of the screen-space reference (0: skip it).
    #[arg(long, value_parser = crate::options::count::<u32>(0), alias = "reference-spp", default_value_t = 1024, allow_negative_numbers = true)]
    pub screen_reference_spp: u32,
}

impl SsaoRunOptions {
    /// The checked request of `settings` seen through `view`, shading only
    /// when `image` is wanted or --indirect asks.
    pub fn request(&self, settings: SsaoSettings, view: View, (image, runs): (bool, Repeats)) -> Result<SsaoRequest> {
        let shade = ShadeSettings { ambient: self.ambient };
        shade.validate()?;
        let request = SsaoRequest {
            settings,
            view,
            shade: (self.indirect || image).then_some(shade),
            truth_rays: self.reference_rays,
            reference_spp: self.screen_reference_spp,
            runs,
        };
        request.validate()?;
        Ok(request)
    }
}
