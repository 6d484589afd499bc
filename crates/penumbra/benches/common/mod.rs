//! What the benches share: the models (from `PENUMBRA_DATA`, or the
//! procedural assets without it), their kd-trees and primary rays, the
//! ray tracer's scenes (`raytrace`) and the plots' drawing primitives
//! (`plot`). Not every bench uses every item.
#![allow(dead_code)]

pub mod plot;
pub mod raytrace;

use std::path::{Path, PathBuf};

use penumbra::accel::Accel;
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::geom::ray::Ray;
use penumbra::gpu::{GpuContext, enumerate_adapters};
use penumbra::scene::{Camera, Mesh, load_obj};

const DATA_MODELS: [&str; 3] = ["stanford-bunny", "dragon100k", "kitchen"];
const FALLBACK_MODELS: [&str; 3] = ["sphere-on-plane", "corner", "cube-with-hole"];
/// Side of the CPU benches' images.
pub const CPU_IMAGE: u32 = 1024;
const GPU_IMAGE_HARDWARE: u32 = 1024;
const GPU_IMAGE_SOFTWARE: u32 = 512;

pub struct Model {
    pub name: String,
    pub mesh: Mesh,
    /// The mesh's kd-tree (default parameters) and, once asked for, its BVH.
    pub accel: Accel,
}

impl Model {
    /// The kd-tree.
    pub fn tree(&self) -> &KdTree {
        self.accel.kdtree()
    }
}

/// The repository's root: `PENUMBRA_DATA`, outputs and assets are named
/// from there (cargo runs a bench in its package's folder).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The shared data set (`PENUMBRA_DATA`, relative to the repository's root).
pub fn data_root() -> Option<PathBuf> {
    std::env::var_os("PENUMBRA_DATA").map(|d| repo_root().join(d))
}

fn model_paths(names: &[&str]) -> Vec<(String, PathBuf)> {
    match data_root() {
        Some(data) => {
            let dir = Path::new(&data).join("models");
            names
                .iter()
                .filter_map(|m| {
                    let path = dir.join(format!("{m}.obj"));
                    if path.is_file() {
                        Some((m.to_string(), path))
                    } else {
                        eprintln!("note: {} not found; skipping {m}", path.display());
                        None
                    }
                })
                .collect()
        }
        None => {
            let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets");
            eprintln!(
                "note: PENUMBRA_DATA is not set; benchmarking the procedural scenes in {} \
                 ({}) instead of {}. Set PENUMBRA_DATA to the folder holding models/ for real numbers.",
                dir.display(),
                FALLBACK_MODELS.join(", "),
                names.join(", ")
            );
            FALLBACK_MODELS
                .iter()
                .map(|m| (m.to_string(), dir.join(format!("{m}.obj"))))
                .collect()
        }
    }
}

/// The ray-tracing benches' models: bunny, dragon, kitchen.
pub fn load_models() -> Vec<Model> {
    load_models_named(&DATA_MODELS)
}

/// The shared models `names` (without `PENUMBRA_DATA`, the procedural ones).
pub fn load_models_named(names: &[&str]) -> Vec<Model> {
    model_paths(names)
        .into_iter()
        .map(|(name, path)| {
            let mesh = load_obj(&path).unwrap_or_else(|e| panic!("loading {}: {e}", path.display()));
            let tree = KdTree::build(&mesh, &KdTreeSettings::default())
                .unwrap_or_else(|e| panic!("building the kd-tree of {}: {e}", path.display()));
            eprintln!(
                "{name}: {} triangles, kd-tree {} nodes, depth {}, built in {:.1} ms",
                mesh.triangles.len(),
                tree.stats.nodes,
                tree.stats.depth,
                tree.stats.build_ms
            );
            Model {
                name,
                mesh,
                accel: Accel::new(tree),
            }
        })
        .collect()
}

pub fn primary_rays(mesh: &Mesh, size: u32) -> Vec<Ray> {
    Camera::default_for(&mesh.bounds()).primary_rays(size, size)
}

/// Whether the adapter the context was created on is a software rasteriser.
pub fn is_software(ctx: &GpuContext) -> bool {
    let name = ctx.name.to_lowercase();
    name.contains("llvmpipe")
        || name.contains("lavapipe")
        || name.contains("swiftshader")
        || enumerate_adapters(&Default::default())
            .iter()
            .any(|a| a.name == ctx.name && a.device_type == "cpu")
}

/// Side of the GPU benches' images: 1024 on hardware, 512 on a software
/// adapter (lavapipe), `PENUMBRA_BENCH_GPU_SIZE=N` to force NxN.
pub fn gpu_image_size(ctx: &GpuContext) -> u32 {
    std::env::var("PENUMBRA_BENCH_GPU_SIZE")
        .ok()
        .and_then(|s| s.parse::<u32>().ok())
        .filter(|&n| n > 0)
        .unwrap_or(if is_software(ctx) {
            GPU_IMAGE_SOFTWARE
        } else {
            GPU_IMAGE_HARDWARE
        })
}

/// A rayon pool of `threads` threads (benches time 1 and 2 threads apart
/// from the global pool).
pub fn thread_pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon pool")
}

/// The CPU's model name and logical cores, from `/proc/cpuinfo`.
pub fn machine() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = info
        .lines()
        .find_map(|l| {
            l.strip_prefix("model name")
                .map(|v| v.trim_start_matches([' ', '\t', ':']))
        })
        .unwrap_or("unknown CPU")
        .to_string();
    let cores = info.lines().filter(|l| l.starts_with("processor")).count();
    format!("{model}, {cores} logical cores")
}

/// A criterion group of 10 flat samples after 1 s of warm-up, measured for
/// `seconds` (the benches' work is long and steady: no need for more).
pub fn flat_group<'a>(
    c: &'a mut criterion::Criterion,
    name: &str,
    seconds: u64,
) -> criterion::BenchmarkGroup<'a, criterion::measurement::WallTime> {
    let mut group = c.benchmark_group(name);
    group
        .sample_size(10)
        .sampling_mode(criterion::SamplingMode::Flat)
        .warm_up_time(std::time::Duration::from_secs(1))
        .measurement_time(std::time::Duration::from_secs(seconds));
    group
}
