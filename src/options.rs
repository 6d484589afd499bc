//! The methods' knobs as command-line option groups (`clap::Args`), next to
//! the settings they build: `ssao::options`, `mlrta::options`,
//! `raytrace::options`, `bounded::options`, `field::options`. A tool built
//! on penumbra flattens the groups it needs (`#[command(flatten)]`) and
//! gets the same flags, help, defaults and checks as `penumbra` itself;
//! ours (`src/cli`) adds only inputs, outputs and reports. This module
//! holds what the groups share.

use clap::{Args, ValueEnum};
use glam::Vec3;

use crate::error::{Error, Result};
use crate::scene::{CameraSpec, parse_vec3};

/// On or off, however a flag is spelled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

impl OnOff {
    pub fn on(self) -> bool {
        self == OnOff::On
    }
}

/// `--eye/--target/--fov`; omitted ones come from the scene's camera, else
/// the default camera.
#[derive(Args, Clone, Debug, Default)]
pub struct CameraOptions {
    /// Camera position, "X,Y,Z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Point looked at, "X,Y,Z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long, allow_negative_numbers = true)]
    pub fov: Option<f32>,
}

impl CameraOptions {
    pub fn spec(&self) -> CameraSpec {
        CameraSpec {
            eye: self.eye,
            target: self.target,
            fov_degrees: self.fov,
        }
    }
}

/// A count option that must be positive (`name`: the library's name).
pub fn positive(name: &str, v: i64) -> Result<usize> {
    if v <= 0 {
        return Err(Error::param(name, format!("must be positive, got {v}")));
    }
    usize::try_from(v).map_err(|_| Error::param(name, "is too large"))
}
