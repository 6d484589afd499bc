//! Screen-space ambient occlusion and indirect light after Szirmay-Kalos,
//! Toth, Umenhoffer and Sbert, "GPU-based Ambient Occlusion and Indirect
//! Illumination" (the paper; `../shared/papers/003_*.txt`).
//!
//! A frame is: the G-buffer (`gbuffer`: camera-space normal and depth,
//! radiance, albedo), one of the paper's estimators of the ambient
//! occlusion O (`estimators`, over per-pixel sample sets from `interleave`),
//! optionally the depth-aware 4x4 low-pass filter of section 5 (`filter`;
//! estimator and AO filter at full or half resolution, then upsampled),
//! and optionally the indirect term I = L~ (1 - O) and the shaded image
//! (`indirect`). Every step is a WGSL kernel (`gpu`) with a CPU twin of the
//! same name and data layout. `truth` gives what the estimators are
//! measured against: world-space ray-traced AO with the same fuzzy measure
//! at the same points, and a dense quadrature over the same depth buffer.
//!
//! Accessibility, as in the contract: O = (1/pi) int_Omega mu(D(w)) cos+ dw,
//! 1 = open, 0 = occluded, with the fuzzy measure mu of `measure`.

mod entry;
pub(crate) mod estimators;
pub(crate) mod filter;
pub mod gbuffer;
pub mod gpu;
pub(crate) mod indirect;
pub(crate) mod interleave;
pub(crate) mod measure;
pub mod runner;
pub mod surfaces;
pub mod truth;
pub mod tune;

use std::time::Instant;

pub use entry::Ssao;
pub use estimators::{Estimator, Family, SampleTable};
pub use gbuffer::{GBuffer, ScreenConstants, ScreenView};
pub use measure::{Measure, MeasureKind};

use crate::error::{Error, Result};
use crate::gpu::device::{Timing, elapsed_ms};

/// Largest samples per pixel (the sample tables stay within a storage binding).
pub const MAX_SPP: u32 = 4096;

/// Default depth bias of the visibility test, in pixel footprints (see
/// `SsaoSettings::bias_px`).
pub const DEFAULT_BIAS_PX: f32 = 2.0;

/// Where the estimator runs: every pixel, or every other pixel in x and y
/// with the filtered result upsampled depth-aware (`filter::ssao_upsample`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Resolution {
    /// Estimate and filter at every pixel.
    Full,
    /// Estimate and filter at every other pixel in x and y (a quarter of the
    /// work), then upsample depth-aware to every pixel.
    Half,
}

crate::choice!(Resolution { Full = "full", Half = "half" });

impl Resolution {
    /// Pixels per grid cell along x and y.
    pub fn scale(&self) -> u32 {
        match self {
            Resolution::Full => 1,
            Resolution::Half => 2,
        }
    }

    /// The name the command line and reports use: `full` or `half`.
    pub fn name(&self) -> &'static str {
        match self {
            Resolution::Full => "full",
            Resolution::Half => "half",
        }
    }
}

/// Every knob of one SSAO frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SsaoSettings {
    /// Which of the paper's estimators of O (sections 3.2 and 4) runs.
    pub estimator: Estimator,
    /// Samples per pixel: depth-buffer tests (points, or steps of all rays
    /// for `raymarch`, or pipes for `base-disk`).
    pub spp: u32,
    /// Neighbourhood radius R, scene units.
    pub radius: f32,
    /// The fuzzy measure mu(r) of section 2.
    pub measure: Measure,
    /// Steps per ray of `raymarch` (rays = spp / steps).
    pub steps: u32,
    /// Interleaved sampling over 4x4 pixel patterns (section 5); off gives
    /// every pixel of a 64x64 tile its own sample set.
    pub interleave: bool,
    /// The depth-aware 4x4 low-pass filter of section 5.
    pub filter: bool,
    /// The filter leaves out neighbours whose depth differs by more than
    /// this (scene units); None = R / 2.
    pub filter_depth: Option<f32>,
    /// A sample is occluded when it lies behind the depth buffer by more
    /// than this many pixel footprints at that depth (depth x 2 tan(fov/2) / H):
    /// the nearest-pixel depth differs from the surface under the sample by
    /// up to half a pixel times the slope, and without a bias a tilted plane
    /// occludes itself.
    pub bias_px: f32,
    /// Scale each pixel's sample weights so that a point without occluders
    /// gets exactly 1 (see `estimators`); off = the paper's formulas as written.
    pub calibrate: bool,
    /// Estimation grid: every pixel or every other one (then upsampled).
    pub resolution: Resolution,
    /// Seed of the sample tables' Owen-scrambled Sobol sequence.
    pub seed: u32,
}

/// The command line's defaults: the importance-sampled estimator at 16
/// samples per pixel, `radius` 1 scene unit (set it for your scene, e.g.
/// `Ssao::suggested_radius`), the fourth-order polynomial measure,
/// interleaving, filter and calibration on, full resolution, the default
/// seed.
/// The fraction of a scene's size (its bounding box's diagonal) that
/// [`suggested_radius`] gives.
pub const RADIUS_OF_SIZE: f32 = 0.05;

/// A neighbourhood radius R for `scene`: [`RADIUS_OF_SIZE`] of its bounding
/// box's diagonal, so that a model's scale (millimetres or metres, a scan
/// 300 units across) does not decide what occludes. The CLI's `ssao`
/// without `--radius` and `sweep ssao` use it.
pub fn suggested_radius(scene: &crate::scene::Scene) -> f32 {
    RADIUS_OF_SIZE * scene.world_mesh(|_| true).bounds().diagonal()
}

impl Default for SsaoSettings {
    fn default() -> Self {
        SsaoSettings::new(Estimator::Importance, 16, 1.0)
    }
}

impl SsaoSettings {
    /// `estimator` at `spp` samples per pixel in a neighbourhood of radius
    /// `radius`, every other knob at its default.
    pub fn new(estimator: Estimator, spp: u32, radius: f32) -> SsaoSettings {
        SsaoSettings {
            estimator,
            spp,
            radius,
            measure: Measure::Poly4,
            steps: 4,
            interleave: true,
            filter: true,
            filter_depth: None,
            bias_px: DEFAULT_BIAS_PX,
            calibrate: true,
            resolution: Resolution::Full,
            seed: crate::geom::sampling::DEFAULT_SEED,
        }
    }

    /// Checks every knob and how they combine: spp from 1 to `MAX_SPP`, a
    /// positive finite radius, raymarch's spp a multiple of its steps, a
    /// measure with a density for the estimators that weight by dmu/dr, poly4
    /// for base-disk.
    pub fn validate(&self) -> Result<()> {
        if self.spp == 0 || self.spp > MAX_SPP {
            return Err(Error::param(
                "spp",
                format!("must be between 1 and {MAX_SPP}, got {}", self.spp),
            ));
        }
        if !(self.radius > 0.0 && self.radius.is_finite()) {
            return Err(Error::param(
                "radius",
                format!("must be positive and finite, got {}", self.radius),
            ));
        }
        self.measure.validate()?;
        if self.estimator == Estimator::Raymarch {
            if self.steps == 0 {
                return Err(Error::param("steps", "must be at least 1"));
            }
            if !self.spp.is_multiple_of(self.steps) {
                return Err(Error::param(
                    "steps",
                    format!(
                        "raymarch takes spp / steps rays: `spp` {} is not a multiple of `steps` {}",
                        self.spp, self.steps
                    ),
                ));
            }
        }
        if let Some(d) = self.filter_depth
            && !(d > 0.0 && d.is_finite())
        {
            return Err(Error::param(
                "filter_depth",
                format!("must be positive and finite, got {d}"),
            ));
        }
        if !(self.bias_px >= 0.0 && self.bias_px.is_finite()) {
            return Err(Error::param(
                "bias_px",
                format!("must be >= 0 and finite, got {}", self.bias_px),
            ));
        }
        if self.estimator.needs_density() && !self.measure.has_density() {
            return Err(Error::param(
                "estimator",
                format!(
                    "{} draws distances uniformly in a volume and weights them by dmu/dr, which \
                     the step measure does not have (a Dirac delta at R); use `measure` exp or \
                     poly4, or `estimator` importance/raymarch",
                    self.estimator.name()
                ),
            ));
        }
        if self.estimator == Estimator::BaseDisk && self.measure != Measure::Poly4 {
            return Err(Error::param(
                "estimator",
                "base-disk integrates each pipe analytically, which needs `measure` poly4 \
                 (section 4.5: (dmu/dr)/r must be a polynomial of r^2)",
            ));
        }
        Ok(())
    }

    /// The filter's depth limit.
    pub fn filter_depth(&self) -> f32 {
        self.filter_depth.unwrap_or(0.5 * self.radius)
    }
}

/// What the shaded image adds to the direct light: the paper's
/// a (La O + I), I = L~ (1 - O).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadeSettings {
    /// Ambient radiance La (grey).
    pub ambient: f32,
}

impl ShadeSettings {
    /// Checks that the ambient radiance is non-negative and finite.
    pub fn validate(&self) -> Result<()> {
        if !(self.ambient >= 0.0 && self.ambient.is_finite()) {
            return Err(Error::param(
                "ambient",
                format!("must be >= 0 and finite, got {}", self.ambient),
            ));
        }
        Ok(())
    }
}

impl Default for ShadeSettings {
    fn default() -> Self {
        ShadeSettings { ambient: 0.5 }
    }
}

/// Outputs of one frame, per pixel (row 0 at the top).
#[derive(Debug, Clone, Default)]
pub struct SsaoFrame {
    /// The estimator's output before filtering (not clamped), per cell of
    /// the estimation grid (every pixel at full resolution, row-major).
    pub ao_raw: Vec<f32>,
    /// Final accessibility in [0, 1] (filtered if asked); 1 on background.
    pub ao: Vec<f32>,
    /// L~ per pixel (rgb, sample count) after filtering, when asked.
    pub indirect: Option<Vec<[f32; 4]>>,
    /// Linear RGBA of the shaded image: direct + a (La O + I); alpha 0 on background.
    pub image: Option<Vec<[f32; 4]>>,
    /// What each step took.
    pub timings: Timings,
}

/// Milliseconds per step (GPU: timestamps where the device has them; over
/// repeated runs, each step's fastest).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Timings {
    /// The G-buffer: rasterising it and packing its depths on a GPU, its
    /// primary rays on the CPU (`run_cpu` starts after the G-buffer and leaves
    /// this 0).
    pub gbuffer_ms: f64,
    /// The estimator. On a GPU without timestamps: the whole frame's mean wall
    /// time, every other step 0.
    pub estimate_ms: f64,
    /// The AO filter and, at half resolution, the upsampling.
    pub filter_ms: f64,
    /// The indirect light and its filter (0 without shading).
    pub indirect_ms: f64,
    /// Composing the shaded image (0 without shading).
    pub compose_ms: f64,
    /// How the times were measured: GPU timestamps or the wall clock.
    pub timing: Timing,
}

impl Default for Timings {
    fn default() -> Self {
        Timings {
            gbuffer_ms: 0.0,
            estimate_ms: 0.0,
            filter_ms: 0.0,
            indirect_ms: 0.0,
            compose_ms: 0.0,
            timing: Timing::Wall,
        }
    }
}

impl Timings {
    /// The AO of a frame: estimator and filter.
    pub fn ao_ms(&self) -> f64 {
        self.estimate_ms + self.filter_ms
    }

    /// Everything that ran, G-buffer included.
    pub fn frame_ms(&self) -> f64 {
        self.gbuffer_ms + self.estimate_ms + self.filter_ms + self.indirect_ms + self.compose_ms
    }
}

/// The CPU twin of a whole frame after the G-buffer: estimator, filter,
/// indirect light and composition, exactly as `gpu::run_frame` dispatches
/// them.
pub fn run_cpu(
    gb: &GBuffer,
    view: &ScreenView,
    settings: &SsaoSettings,
    shade: Option<&ShadeSettings>,
) -> Result<SsaoFrame> {
    settings.validate()?;
    let table = SampleTable::build(settings)?;
    let params = estimators::SsaoUniforms::new(view, settings, &table, shade.copied().unwrap_or_default());
    let mut timings = Timings {
        timing: Timing::Wall,
        ..Default::default()
    };
    let start = Instant::now();
    let ao_raw = estimators::estimate_cpu(table.family, gb, &params, &table.entries);
    timings.estimate_ms = elapsed_ms(start);
    let start = Instant::now();
    let ao_filtered = filter::filter_ao(gb, &params, settings.filter, &ao_raw);
    timings.filter_ms = elapsed_ms(start);
    let mut indirect = None;
    let mut image = None;
    if shade.is_some() {
        let start = Instant::now();
        let raw = indirect::ssao_indirect(gb, &params, &table.entries, table.family);
        let l = if settings.filter {
            filter::ssao_filter_indirect(gb, &params, &raw)
        } else {
            raw
        };
        timings.indirect_ms = elapsed_ms(start);
        let start = Instant::now();
        image = Some(indirect::ssao_compose(gb, &params, &ao_filtered, &l));
        timings.compose_ms = elapsed_ms(start);
        indirect = Some(l);
    }
    let ao = final_ao(gb, &ao_filtered);
    Ok(SsaoFrame {
        ao_raw,
        ao,
        indirect,
        image,
        timings,
    })
}

/// Clamps to [0, 1] (unbiased estimators can leave it) and puts 1 on the
/// background.
pub fn final_ao(gb: &GBuffer, ao: &[f32]) -> Vec<f32> {
    ao.iter()
        .enumerate()
        .map(|(i, &a)| if gb.is_surface(i) { a.clamp(0.0, 1.0) } else { 1.0 })
        .collect()
}

/// Root-mean-square difference over the G-buffer's surface pixels.
pub fn rmse(gb: &GBuffer, a: &[f32], b: &[f32]) -> f64 {
    let surface: Vec<bool> = (0..gb.pixels()).map(|i| gb.is_surface(i)).collect();
    crate::geom::color::rms_difference(&a[..gb.pixels()], &b[..gb.pixels()], Some(&surface))
}
