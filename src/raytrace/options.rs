//! The Whitted ray tracer's knobs as command-line options (see
//! `crate::options`).

use clap::Args;
use glam::Vec3;

use super::{LightingOptions, WhittedSettings};
use crate::error::Result;
use crate::options::OnOff;
use crate::scene::parse_vec3;

#[derive(Args, Clone, Debug)]
pub struct WhittedOptions {
    /// Deepest reflection/refraction (0: primary and shadow rays only).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true)]
    pub max_depth: u32,
    /// Samples per pixel: 1 through the pixel centre, more jittered (anti-aliasing).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub spp: u32,
    /// Fresnel-weighted (Schlick) reflection and transmission instead of
    /// the materials' constant coefficients.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub fresnel: OnOff,
    /// Point lights per emissive polygon (1: at its centroid; more soften shadows).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub light_samples: u32,
    /// Ambient light "R,G,B" (over the scene file's; default 0.05 grey).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub ambient: Option<Vec3>,
    /// Radiance "R,G,B" of rays that leave the scene (over the scene file's; default black).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub background: Option<Vec3>,
    /// CPU path: primary and shadow rays as MLRTA packets (off: every ray alone).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub packets: OnOff,
}

impl WhittedOptions {
    /// The checked settings with the sample sequence's `seed`.
    pub fn settings(&self, seed: u32) -> Result<WhittedSettings> {
        let settings = WhittedSettings {
            max_depth: self.max_depth,
            spp: self.spp,
            seed,
            fresnel: self.fresnel.on(),
            packets: self.packets.on(),
        };
        settings.validate()?;
        Ok(settings)
    }

    pub fn lighting(&self) -> LightingOptions {
        LightingOptions {
            light_samples: self.light_samples,
            ambient: self.ambient,
            background: self.background,
        }
    }
}
