//! Options shared by the computing subcommands.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use glam::Vec3;

use crate::aabb::Aabb;
use crate::error::{Error, Result};
use crate::kdtree::{KdTree, KdTreeParams};
use crate::progress::Progress;
use crate::scene::{Camera, Mesh, Scene, load_obj, load_scene};

/// The default `--seed`: outputs repeat bit for bit on one device.
pub const DEFAULT_SEED: u32 = 0x5eed;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DeviceArg {
    /// A GPU adapter if there is one (lavapipe counts), else the CPU.
    Auto,
    /// A GPU adapter; exit code 2 if there is none.
    Gpu,
    /// The CPU reference path.
    Cpu,
}

#[derive(Args, Clone, Debug)]
pub struct Common {
    /// Compute device.
    #[arg(long, value_enum, default_value_t = DeviceArg::Auto)]
    pub device: DeviceArg,
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
}

/// Sets up the global rayon pool with `threads` threads (default: all
/// cores); returns the thread count.
pub fn init_thread_pool(threads: Option<usize>) -> Result<usize> {
    let threads = match threads {
        Some(0) => return Err(Error::param("--threads", "must be at least 1")),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    // The global pool can be built once per process; the CLI does so once.
    match rayon::ThreadPoolBuilder::new().num_threads(threads).build_global() {
        Ok(()) => {}
        Err(_) if rayon::current_num_threads() == threads => {}
        Err(e) => return Err(e.into()),
    }
    Ok(threads)
}

/// `--eye/--target/--fov`; omitted ones come from the default camera.
#[derive(Args, Clone, Debug, Default)]
pub struct CameraArgs {
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

impl CameraArgs {
    /// The camera: the scene file's if it has one, then the contract's
    /// default for `bounds`, with each given option replacing its part.
    pub fn camera(&self, scene_camera: Option<Camera>, bounds: &Aabb) -> Result<Camera> {
        let base = scene_camera.unwrap_or_else(|| Camera::default_for(bounds));
        let camera = Camera {
            eye: self.eye.unwrap_or(base.eye),
            target: self.target.unwrap_or(base.target),
            fov_degrees: self.fov.unwrap_or(base.fov_degrees),
        };
        camera.validate()?;
        Ok(camera)
    }
}

pub(crate) fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected X,Y,Z, got '{s}'"));
    }
    let mut v = [0.0f32; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse().map_err(|_| format!("'{p}' is not a number"))?;
        if !slot.is_finite() {
            return Err(format!("'{p}' is not finite"));
        }
    }
    Ok(Vec3::from_array(v))
}

/// Image size options.
pub fn check_image_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::param("--width/--height", "must be at least 1"));
    }
    if width as u64 * height as u64 > 1 << 28 {
        return Err(Error::param(
            "--width/--height",
            format!("{width}x{height} is more than 2^28 pixels"),
        ));
    }
    Ok(())
}

/// `--mesh FILE` or `--scene FILE` as a scene.
pub fn load_input(mesh: Option<&Path>, scene: Option<&Path>) -> Result<Scene> {
    match (mesh, scene) {
        (Some(m), None) => {
            let name = m
                .file_stem()
                .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
            Ok(Scene::from_mesh(&name, m, load_obj(m)?))
        }
        (None, Some(s)) => load_scene(s),
        (Some(_), Some(_)) => Err(Error::param("--mesh/--scene", "give one of them, not both")),
        (None, None) => Err(Error::param(
            "--mesh",
            "a mesh (--mesh FILE) or a scene (--scene FILE) is required",
        )),
    }
}

/// Builds the kd-tree over `mesh` with a spinner for big meshes.
pub fn build_tree(mesh: &Mesh, what: &str) -> Result<KdTree> {
    let progress = if mesh.triangles.len() > 200_000 {
        Progress::spinner(&format!("building kd-tree ({what})"))
    } else {
        Progress::hidden()
    };
    let tree = KdTree::build(mesh, &KdTreeParams::default())?;
    progress.finish();
    Ok(tree)
}

/// An output path whose folder exists.
pub fn check_output(path: &Path, option: &str) -> Result<PathBuf> {
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    if let Some(dir) = parent
        && !dir.is_dir()
    {
        return Err(Error::param(
            option,
            format!("{}: folder {} does not exist", path.display(), dir.display()),
        ));
    }
    Ok(path.to_path_buf())
}
