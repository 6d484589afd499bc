//! Options shared by the computing subcommands, and the one place the
//! command line resolves `--device`.

use clap::Args;
use serde_json::{Value, json};

use crate::device::{Device, DeviceChoice, Needs};
use crate::error::Result;

/// The default `--seed`: outputs repeat bit for bit on one device.
pub const DEFAULT_SEED: u32 = 0x5eed;

#[derive(Args, Clone, Debug)]
pub struct Common {
    /// Compute device.
    #[arg(long, value_enum, default_value_t = DeviceChoice::Auto)]
    pub device: DeviceChoice,
    /// CPU threads (default: all cores).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Seed of the sample sequence.
    #[arg(long, default_value_t = DEFAULT_SEED, allow_negative_numbers = true)]
    pub seed: u32,
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub runs: crate::repeats::RepeatOptions,
    /// Progress lines on stderr even when it is not a terminal (a CI log).
    #[arg(long)]
    pub progress: bool,
}

impl Common {
    /// Sets up `--progress` and the rayon pool for `--threads`; returns the thread count.
    pub fn init_threads(&self) -> Result<usize> {
        crate::progress::log_when_not_a_terminal(self.progress);
        init_thread_pool(self.threads)
    }

    /// Opens `--device` and says on stderr what was chosen.
    pub fn open_device(&self) -> Result<Device> {
        self.open_device_for(&Needs::COMPUTE)
    }

    /// Opens the device, refused up front (or left for the CPU, with
    /// `auto`) where its GPU lacks what `needs` names.
    pub fn open_device_for(&self, needs: &Needs) -> Result<Device> {
        let device = Device::open(self.device)?.require(needs)?;
        if let Some(name) = device.adapter() {
            eprintln!("penumbra: GPU adapter: {name}");
        } else if let Some(why) = device.fallback_reason() {
            let why = why.clone().with_names(flag);
            eprintln!("penumbra: {why}; using the CPU reference path");
        }
        Ok(device)
    }

    /// The report's fields every computing command has.
    pub fn report(&self, device: &Device, threads: usize) -> Value {
        let mut report = json!({ "device": device.kind(), "adapter": device.adapter(), "threads": threads });
        if let Some(pipelines) = device.pipelines() {
            report["pipelines"] = json!(pipelines);
        }
        report
    }
}

pub use crate::options::{CameraOptions as CameraArgs, init_thread_pool};
pub use crate::output::{check_output, check_outputs};
pub(crate) use crate::scene::parse_vec3;
pub use crate::scene::{load_input, load_shaded_input};

/// The command line's option for a library parameter name: the table's
/// where the names differ, else `--name-with-dashes` where some subcommand
/// has that option.
pub fn flag(name: &str) -> Option<&'static str> {
    const RENAMED: &[(&str, &str)] = &[
        ("rays_per_point", "--rays"),
        ("animation", "--animated"),
        ("eye/target", "--eye/--target"),
        ("fov_degrees", "--fov"),
        ("width/height", "--width/--height"),
        ("initial_tile/min_tile", "--tile/--min-tile"),
        ("bands", "--order"),
        ("lut_size", "--lut"),
        ("mask_side", "--mask"),
        ("coarse_triangles", "--coarse"),
        ("dt/start/env_spin", "--dt/--start/--env-spin"),
        ("bias_px", "--bias"),
        ("pixel", "--ray-tree"),
        ("mesh/scene", "--mesh/--scene"),
    ];
    static LONGS: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();
    if let Some((_, f)) = RENAMED.iter().find(|(n, _)| *n == name) {
        return Some(f);
    }
    let longs = LONGS.get_or_init(|| {
        let cli = <super::Cli as clap::CommandFactory>::command();
        let options = cli
            .get_subcommands()
            .flat_map(|c| c.get_arguments().filter_map(|a| a.get_long()));
        options.map(|l| format!("--{l}")).collect()
    });
    let wanted = format!("--{}", name.replace('_', "-"));
    longs.iter().find(|l| **l == wanted).map(String::as_str)
}
