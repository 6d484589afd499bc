//! The methods' knobs as command-line option groups (`clap::Args`), each
//! building the library's settings with their checks: `ao`, `field`,
//! `ssao`, `prt`, `mlrta`, `raytrace`, `bounded`. The subcommands flatten
//! the groups they need (`#[command(flatten)]`) and add inputs, outputs and
//! reports. This module holds what the groups share.

pub mod ao;
pub mod bounded;
pub mod field;
pub mod mlrta;
pub mod prt;
pub mod raytrace;
pub mod ssao;

use clap::{Args, ValueEnum};
use glam::DVec3;

use penumbra::error::{Error, Result};
use penumbra::io::image::{Background, GreyStyle, PngBits};
use penumbra::report::repeats::{MAX_RUNS, Repeats};
use penumbra::scene::frame::parse_point;
use penumbra::scene::{CameraSpec, Scene};

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

/// `--camera`: which of the input's cameras is the scene's camera, for
/// the commands that read their input themselves (not `sweep`).
#[derive(Args, Clone, Debug, Default)]
pub struct CameraChoice {
    /// The input's camera N (from 0: a glTF file's cameras in scene order,
    /// a scene file's camera) instead of its first; --eye/--target/--fov
    /// still override its parts.
    #[arg(long, value_parser = crate::options::count::<usize>(0), value_name = "N", allow_negative_numbers = true)]
    pub camera: Option<usize>,
}

impl CameraChoice {
    /// Makes `--camera`'s camera the scene's (an error names `--camera`
    /// and how many cameras the input has).
    pub fn choose(&self, scene: &mut Scene) -> Result<()> {
        match self.camera {
            Some(n) => scene.choose_camera(n),
            None => Ok(()),
        }
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

/// Clap's parser of a count option whose least value is `lo`: a leading
/// minus is read as a value (never as another option) and a negative one is
/// refused with the option's own least value (`CountError`, which the
/// command line reports as its other bad values), where clap's integer
/// parser would name the type's range (`0..=4294967295`). Values from 0 up
/// reach the library's checks, which know the knob's whole range.
pub fn count<T>(lo: u32) -> impl Fn(&str) -> std::result::Result<T, CountParseError> + Clone + Send + Sync + 'static
where
    T: TryFrom<i128> + std::fmt::Display + Bounded + Send + Sync + 'static,
{
    move |text: &str| {
        // Not a number: clap's own words, as for every other option.
        let v: i128 = text.trim().parse()?;
        if v < 0 {
            return Err(CountError(format!("must be at least {lo}, got {v}")).into());
        }
        T::try_from(v).map_err(|_| CountError(format!("must be at most {}, got {v}", T::MAX)).into())
    }
}

/// What `count` refuses: not a number, or a `CountError`.
pub type CountParseError = Box<dyn std::error::Error + Send + Sync>;

/// A count option's value out of its bounds (`count`).
#[derive(Debug)]
pub struct CountError(pub String);

impl std::fmt::Display for CountError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for CountError {}

/// The largest value of a count type (`count`'s message names it).
pub trait Bounded {
    const MAX: Self;
}

impl Bounded for u32 {
    const MAX: u32 = u32::MAX;
}

impl Bounded for usize {
    const MAX: usize = usize::MAX;
}

/// A count option that must be positive (`name`: the library's name).
pub fn positive(name: &str, v: i64) -> Result<usize> {
    if v <= 0 {
        return Err(Error::param(name, format!("must be positive, got {v}")));
    }
    usize::try_from(v).map_err(|_| Error::param(name, "is too large"))
}

/// A count option within `lo..=hi` (`name`: the library's name); the
/// message names the range (every knob's ends).
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
        Err(e) => return Err(Error::internal(format!("cannot start the thread pool: {e}"))),
    }
    Ok(threads)
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
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 800, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 600, allow_negative_numbers = true)]
    pub height: u32,
}

/// The AO image options of a command line (`ao --image`, `ssao --out`).
#[derive(clap::Args, Clone, Copy, Debug, Default)]
pub struct GreyImageOptions {
    /// PNG AO image: bits per channel (16: value = pixel / 65535).
    #[arg(long, value_enum, default_value_t = PngBits::Eight)]
    pub png_bits: PngBits,
    /// AO image: what shows where no surface is (black: opaque; transparent: alpha 0).
    #[arg(long, value_enum, default_value_t = Background::Black)]
    pub background: Background,
}

impl GreyImageOptions {
    pub fn style(&self) -> GreyStyle {
        GreyStyle {
            bits: self.png_bits,
            background: self.background,
        }
    }
}

/// `--warmup N --repeat N`.
#[derive(Args, Clone, Debug, Default)]
pub struct RepeatOptions {
    /// Untimed runs before the measured ones.
    #[arg(long, value_parser = crate::options::count::<u32>(0), default_value_t = 0, allow_negative_numbers = true)]
    pub warmup: u32,
    /// Measured runs: the report gives min, median and max of their times
    /// [default: 1; sweep: 3 per setting].
    #[arg(long, value_parser = crate::options::count::<u32>(1), allow_negative_numbers = true)]
    pub repeat: Option<u32>,
}

impl RepeatOptions {
    /// The checked runs (`default`: measured runs when --repeat is not given).
    pub fn runs(&self, default: u32) -> Result<Repeats> {
        let repeat = self.repeat.unwrap_or(default);
        if !(1..=MAX_RUNS).contains(&repeat) {
            return Err(Error::param(
                "repeat",
                format!("must be between 1 and {MAX_RUNS}, got {repeat}"),
            ));
        }
        if self.warmup > MAX_RUNS {
            let problem = format!("must be at most {MAX_RUNS}, got {}", self.warmup);
            return Err(Error::param("warmup", problem));
        }
        Ok(Repeats {
            warmup: self.warmup,
            repeat,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_range_counts_are_refused() {
        let bad = |warmup, repeat| RepeatOptions { warmup, repeat }.runs(1).is_err();
        assert!(bad(0, Some(0)) && bad(0, Some(MAX_RUNS + 1)) && bad(MAX_RUNS + 1, None));
        assert_eq!(
            RepeatOptions::default().runs(3).unwrap(),
            Repeats { warmup: 0, repeat: 3 }
        );
    }
}
