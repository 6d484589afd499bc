//! The methods' knobs as command-line option groups (`clap::Args`), next to
//! the settings they build: `ssao::options`, `mlrta::options`,
//! `raytrace::options`, `bounded::options`, `field::options`. A tool built
//! on penumbra flattens the groups it needs (`#[command(flatten)]`) and
//! gets the same flags, help, defaults and checks as `penumbra` itself;
//! ours (`src/cli`) adds only inputs, outputs and reports. This module
//! holds what the groups share.

use clap::{Args, ValueEnum};
use glam::DVec3;

use crate::error::{Error, Result};
use crate::scene::CameraSpec;
use crate::scene::frame::parse_point;

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
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    pub eye: Option<DVec3>,
    /// Point looked at, "X,Y,Z".
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    pub target: Option<DVec3>,
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

/// A count option within `lo..=hi` (`name`: the library's name); the
/// message names the range (issue 14, class 8: every knob's ends).
pub fn in_range(name: &str, v: i64, lo: i64, hi: i64) -> Result<usize> {
    if !(lo..=hi).contains(&v) {
        return Err(Error::param(name, format!("must be between {lo} and {hi}, got {v}")));
    }
    usize::try_from(v).map_err(|_| Error::param(name, "is too large"))
}

/// The most threads per available core.
pub const MAX_THREADS_PER_CORE: usize = 8;

/// Sets up the global rayon pool with `threads` threads (default: all
/// cores); returns the thread count.
pub fn init_thread_pool(threads: Option<usize>) -> Result<usize> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Oversubscribing a little can help a benchmark; thousands of threads
    // only cost minutes of start-up and memory.
    let most = MAX_THREADS_PER_CORE * cores;
    let threads = match threads {
        Some(0) => return Err(Error::param("threads", "must be at least 1")),
        Some(n) if n > most => {
            let problem = format!("is {n}; at most {most} ({MAX_THREADS_PER_CORE} per core, {cores} cores here)");
            return Err(Error::param("threads", problem));
        }
        Some(n) => n,
        None => cores,
    };
    // The global pool can be built once per process; the CLI does so once.
    match rayon::ThreadPoolBuilder::new().num_threads(threads).build_global() {
        Ok(()) => {}
        Err(_) if rayon::current_num_threads() == threads => {}
        Err(e) => return Err(e.into()),
    }
    Ok(threads)
}

impl From<rayon::ThreadPoolBuildError> for Error {
    fn from(e: rayon::ThreadPoolBuildError) -> Self {
        Error::internal(format!("cannot start the thread pool: {e}"))
    }
}

/// Options (clap ids: the groups' field names) that do something only
/// where `holds`; `needs` names what makes them apply. A group's
/// `applies` lists its own; `refuse_unused` turns a given option whose rule
/// does not hold into an error, so no option is silently ignored.
pub struct Applies {
    pub holds: bool,
    pub options: &'static [&'static str],
    pub needs: &'static str,
}

pub fn applies(holds: bool, options: &'static [&'static str], needs: &'static str) -> Applies {
    Applies { holds, options, needs }
}

/// Refuses the first option given on the command line (clap's
/// `ValueSource`: defaults never count) whose rule does not hold.
pub fn refuse_unused(rules: &[Applies], matches: &clap::ArgMatches) -> Result<()> {
    let given = |id: &str| matches.value_source(id) == Some(clap::parser::ValueSource::CommandLine);
    for r in rules.iter().filter(|r| !r.holds) {
        if let Some(id) = r.options.iter().find(|id| given(id)) {
            let problem = format!("does not apply here: it is used only with {}", r.needs);
            return Err(Error::param(format!("--{}", id.replace('_', "-")), problem));
        }
    }
    Ok(())
}

/// `--width/--height`: every command that draws an image has the same
/// defaults (`sweep` its own smaller ones: it runs every setting many times).
#[derive(Args, Clone, Copy, Debug)]
pub struct ImageSize {
    /// Image width in pixels.
    #[arg(long, default_value_t = 800, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 600, allow_negative_numbers = true)]
    pub height: u32,
}
