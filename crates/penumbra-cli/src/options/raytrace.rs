//! The Whitted ray tracer's knobs as command-line options (see
//! `crate::options`).

use clap::Args;
use glam::Vec3;
use penumbra::whitted::report::RaytraceMethod;

use crate::options::OnOff;
use penumbra::error::{Error, Result};
use penumbra::scene::{MtlRules, parse_vec3};
use penumbra::whitted::{LightingSettings, Packets, WhittedSettings};

#[derive(Args, Clone, Debug)]
pub struct WhittedOptions {
    /// Deepest reflection/refraction (0: primary and shadow rays only).
    #[arg(long, value_parser = crate::options::count::<u32>(0), default_value_t = 5, allow_negative_numbers = true)]
    pub max_depth: u32,
    /// Samples per pixel: 1 through the pixel centre, more jittered (anti-aliasing).
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 1, allow_negative_numbers = true)]
    pub spp: u32,
    /// Fresnel-weighted (Schlick) reflection and transmission instead of
    /// the materials' constant coefficients.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub fresnel: OnOff,
    /// Point lights per emissive polygon (1: at its centroid; more soften shadows).
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 1, allow_negative_numbers = true)]
    pub light_samples: u32,
    /// Ambient light "R,G,B" (over the scene file's; default 0.05 grey).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub ambient: Option<Vec3>,
    /// Radiance "R,G,B" of rays that leave the scene (over the scene file's; default black).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub background: Option<Vec3>,
    /// How MTL materials are read; each rule applied is a warning and an
    /// entry of the JSON's "material_rules".
    #[arg(long, value_enum, default_value_t = MtlRules::Exporters)]
    pub mtl_rules: MtlRules,
    /// CPU path: primary and shadow rays as MLRTA packets, or every ray
    /// alone (the same image); auto: packets from 8192 triangles up.
    #[arg(long, value_enum, default_value_t = Packets::Auto)]
    pub packets: Packets,
}

impl WhittedOptions {
    /// The checked settings with the sample sequence's `seed`.
    pub fn settings(&self, seed: u32) -> Result<WhittedSettings> {
        let settings = WhittedSettings {
            max_depth: self.max_depth,
            spp: self.spp,
            seed,
            fresnel: self.fresnel.on(),
            packets: self.packets,
        };
        settings.validate()?;
        Ok(settings)
    }

    pub fn lighting(&self) -> LightingSettings {
        LightingSettings {
            light_samples: self.light_samples,
            ambient: self.ambient,
            background: self.background,
            mtl_rules: self.mtl_rules,
            ..LightingSettings::default()
        }
    }
}

/// The method, the animation and the image's tone.
#[derive(Args, Clone, Debug)]
pub struct RaytraceOptions {
    #[arg(long, value_enum)]
    pub method: RaytraceMethod,
    /// PNG only: radiance is multiplied by this before clamping to [0, 1].
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Render this many frames along --path (or the built-in walk from the camera without one).
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 1, allow_negative_numbers = true)]
    pub frames: u32,
    /// Adds the ray tree of pixel "X,Y" (first sample, first frame) to the JSON.
    #[arg(long, value_parser = parse_pixel)]
    pub ray_tree: Option<(u32, u32)>,
}

impl RaytraceOptions {
    /// Refuses no frames and a non-positive exposure.
    pub fn validate(&self) -> Result<()> {
        let most = penumbra::field::runner::MAX_FRAMES;
        if self.frames == 0 || self.frames > most {
            return Err(Error::param(
                "frames",
                format!("must be between 1 and {most}, got {}", self.frames),
            ));
        }
        if !(self.exposure > 0.0 && self.exposure.is_finite()) {
            return Err(Error::param(
                "exposure",
                format!("must be positive, got {}", self.exposure),
            ));
        }
        Ok(())
    }
}

/// "X,Y" as pixel coordinates.
fn parse_pixel(s: &str) -> std::result::Result<(u32, u32), String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    match parts[..] {
        [x, y] => match (x.parse(), y.parse()) {
            (Ok(x), Ok(y)) => Ok((x, y)),
            _ => Err(format!("'{s}' is not two pixel coordinates X,Y")),
        },
        _ => Err(format!("expected X,Y, got '{s}'")),
    }
}
