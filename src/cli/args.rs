//! Options shared by the computing subcommands, and the one place the
//! command line resolves `--device`.

use std::path::{Path, PathBuf};

use clap::Args;
use serde_json::{Value, json};

use crate::device::{Device, DeviceChoice};
use crate::error::{Error, Result};
use crate::scene::{Scene, load_mesh, load_scene};

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
}

impl Common {
    /// Sets up the rayon pool for `--threads`; returns the thread count.
    pub fn init_threads(&self) -> Result<usize> {
        init_thread_pool(self.threads)
    }

    /// Opens `--device` and says on stderr what was chosen.
    pub fn open_device(&self) -> Result<Device> {
        let device = Device::open(self.device)?;
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

/// The most `--threads` per available core.
pub const MAX_THREADS_PER_CORE: usize = 8;

/// Sets up the global rayon pool with `threads` threads (default: all
/// cores); returns the thread count.
pub fn init_thread_pool(threads: Option<usize>) -> Result<usize> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Oversubscribing a little can help a benchmark; thousands of threads
    // only cost minutes of start-up and memory.
    let most = MAX_THREADS_PER_CORE * cores;
    let threads = match threads {
        Some(0) => return Err(Error::param("--threads", "must be at least 1")),
        Some(n) if n > most => {
            let problem = format!("is {n}; at most {most} ({MAX_THREADS_PER_CORE} per core, {cores} cores here)");
            return Err(Error::param("--threads", problem));
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

pub use crate::options::{CameraOptions as CameraArgs, OnOff, positive};
pub(crate) use crate::scene::parse_vec3;

/// `--mesh FILE` or `--scene FILE` as a scene.
pub fn load_input(mesh: Option<&Path>, scene: Option<&Path>) -> Result<Scene> {
    match (mesh, scene) {
        (Some(m), None) => Ok(Scene::from_mesh(&stem(m), m, load_mesh(m)?)),
        (None, Some(s)) => load_scene(s),
        (Some(_), Some(_)) => Err(Error::param("--mesh/--scene", "give one of them, not both")),
        (None, None) => Err(Error::param(
            "--mesh",
            "a mesh (--mesh FILE) or a scene (--scene FILE) is required",
        )),
    }
}

/// `load_input` keeping the meshes' materials (an OBJ's MTL, glTF's) for shading.
pub fn load_shaded_input(mesh: Option<&Path>, scene: Option<&Path>) -> Result<Scene> {
    match (mesh, scene) {
        (Some(m), None) => Ok(Scene::from_obj_file(&stem(m), m, crate::scene::load_mesh_file(m)?)),
        (None, Some(s)) => crate::scene::load_scene_shaded(s),
        _ => load_input(mesh, scene),
    }
}

/// A file's name without its extension ("mesh" if it has none).
pub fn stem(path: &Path) -> String {
    path.file_stem()
        .map_or("mesh".into(), |s| s.to_string_lossy().into_owned())
}

/// The output paths that are given, each checked to have an existing folder.
pub fn check_outputs<'a>(outputs: &[(&'a Option<PathBuf>, &str)]) -> Result<Vec<Option<&'a Path>>> {
    outputs
        .iter()
        .map(|(path, option)| path.as_deref().map(|p| check_output(p, option)).transpose())
        .collect()
}

/// An output path whose folder exists.
pub fn check_output<'a>(path: &'a Path, option: &str) -> Result<&'a Path> {
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    if let Some(dir) = parent
        && !dir.is_dir()
    {
        return Err(Error::param(
            option,
            format!("{}: folder {} does not exist", path.display(), dir.display()),
        ));
    }
    Ok(path)
}

/// The command line's option for a library parameter name.
pub fn flag(name: &str) -> Option<&'static str> {
    Some(match name {
        "rays_per_point" => "--rays",
        "radius" => "--radius",
        "positions" => "--positions",
        "res" => "--res",
        "bits" => "--bits",
        "frames" => "--frames",
        "animation" => "--animated",
        "eye/target" => "--eye/--target",
        "fov_degrees" => "--fov",
        "width/height" => "--width/--height",
        "split_factor" => "--split-factor",
        "initial_tile/min_tile" => "--tile/--min-tile",
        "aa_samples" => "--aa-samples",
        "bands" => "--order",
        "lut_size" => "--lut",
        "mask_side" => "--mask",
        "ring" => "--ring",
        "group_size" => "--group-size",
        "coarse_triangles" => "--coarse",
        "coarse_tolerance" => "--coarse-tolerance",
        "self_check_threshold" => "--self-check-threshold",
        "shininess" => "--shininess",
        "specular" => "--specular",
        "pvs_frames" => "--pvs-frames",
        "dt/start/env_spin" => "--dt/--start/--env-spin",
        "estimator" => "--estimator",
        "measure" => "--measure",
        "sigma" => "--sigma",
        "spp" => "--spp",
        "steps" => "--steps",
        "filter_depth" => "--filter-depth",
        "bias_px" => "--bias",
        "ambient" => "--ambient",
        "repeat" => "--repeat",
        "scene" => "--scene",
        "device" => "--device",
        "max_depth" => "--max-depth",
        "light_samples" => "--light-samples",
        "pixel" => "--ray-tree",
        "out" => "--out",
        "epsilon" => "--epsilon",
        "floor" => "--floor",
        "memory_mb" => "--memory-mb",
        "min_pixels" => "--min-pixels",
        "max_error" => "--max-error",
        _ => return None,
    })
}
