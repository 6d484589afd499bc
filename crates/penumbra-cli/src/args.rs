//! Options shared by the computing subcommands, and the one place the
//! command line resolves `--device`.

use clap::Args;
use serde_json::{Value, json};

use penumbra::gpu::device::{AdapterSettings, Device, DeviceChoice, Needs};
use std::path::Path;

use penumbra::error::Result;
use penumbra::scene::Scene;
use penumbra::tune::ErrorBudget;

/// The default `--seed`: outputs repeat bit for bit on one device.
pub const DEFAULT_SEED: u32 = penumbra::geom::sampling::DEFAULT_SEED;

#[derive(Args, Clone, Debug)]
pub struct Common {
    /// Compute device.
    #[arg(long, value_enum, default_value_t = DeviceChoice::Auto)]
    pub device: DeviceChoice,
    /// CPU threads (default: all cores).
    #[arg(long, value_parser = crate::options::count::<usize>(1), allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Seed of the sample sequence.
    #[arg(long, value_parser = crate::options::count::<u32>(0), default_value_t = DEFAULT_SEED, allow_negative_numbers = true)]
    pub seed: u32,
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub runs: crate::options::RepeatOptions,
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
        let device = Device::open_with(self.device, &adapter_options())?.require(needs)?;
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

pub use crate::files::{check_output, check_outputs};
pub use crate::options::{CameraChoice, CameraOptions as CameraArgs, init_thread_pool};
pub(crate) use penumbra::scene::parse_vec3;
/// What `$PENUMBRA_DATA` in a scene file stands for: the environment
/// variable of that name.
pub fn data_dir() -> Option<std::path::PathBuf> {
    std::env::var_os("PENUMBRA_DATA").map(std::path::PathBuf::from)
}

/// A mesh or a scene file, as `--mesh` / `--scene` name it.
pub fn load_input(mesh: Option<&Path>, scene: Option<&Path>) -> Result<Scene> {
    penumbra::scene::load_input_in(mesh, scene, data_dir().as_deref())
}

/// `load_input` with the materials shading needs.
pub fn load_shaded_input(mesh: Option<&Path>, scene: Option<&Path>) -> Result<Scene> {
    penumbra::scene::load_shaded_input_in(mesh, scene, data_dir().as_deref())
}

/// The error budget `--max-error` sets, its choices remembered in
/// `$PENUMBRA_CACHE_DIR`, else `$XDG_CACHE_HOME/penumbra`, else
/// `~/.cache/penumbra`.
pub fn error_budget(max_error: f64) -> ErrorBudget {
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(std::path::PathBuf::from)
    };
    let cache_dir = env("PENUMBRA_CACHE_DIR")
        .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("penumbra")))
        .or_else(|| env("HOME").map(|d| d.join(".cache").join("penumbra")));
    ErrorBudget { max_error, cache_dir }
}

/// The adapter wgpu's variables ask for: `WGPU_BACKEND` (backends by
/// name) and `WGPU_ADAPTER_NAME` (a part of the adapter's name).
pub fn adapter_options() -> AdapterSettings {
    AdapterSettings {
        backends: std::env::var("WGPU_BACKEND").ok(),
        adapter_name: std::env::var("WGPU_ADAPTER_NAME").ok(),
        ..AdapterSettings::default()
    }
}

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
        ("backends", "WGPU_BACKEND"),
        ("adapter_name", "WGPU_ADAPTER_NAME"),
    ];
    static LONGS: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();
    if let Some((_, f)) = RENAMED.iter().find(|(n, _)| *n == name) {
        return Some(f);
    }
    let longs = LONGS.get_or_init(|| {
        let cli = <crate::Cli as clap::CommandFactory>::command();
        let options = cli
            .get_subcommands()
            .flat_map(|c| c.get_arguments().filter_map(|a| a.get_long()));
        options.map(|l| format!("--{l}")).collect()
    });
    let wanted = format!("--{}", name.replace('_', "-"));
    longs.iter().find(|l| **l == wanted).map(String::as_str)
}
