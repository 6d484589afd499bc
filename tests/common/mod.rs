//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod cli;

use std::path::PathBuf;

use penumbra::device::Device;
use penumbra::gpu::GpuContext;

/// The GPU if there is one. Tests must pass without an adapter: they then run
/// their CPU half and say that the GPU half was skipped.
pub fn gpu() -> Option<GpuContext> {
    match GpuContext::headless() {
        Ok(ctx) => {
            println!("GPU adapter: {}", ctx.name);
            Some(ctx)
        }
        Err(e) => {
            println!("no GPU adapter ({e}): GPU half skipped");
            None
        }
    }
}

/// The CPU, then the GPU if there is one: every runner should give the
/// same answers on both.
pub fn devices() -> Vec<Device> {
    let mut devices = vec![Device::cpu()];
    devices.extend(gpu().map(Device::gpu));
    devices
}

/// A model of the shared data set, when `PENUMBRA_DATA` is set. If it is set
/// but the file is missing, that is a broken setup: panic.
pub fn data_model(name: &str) -> Option<PathBuf> {
    let Some(root) = std::env::var_os("PENUMBRA_DATA") else {
        println!("PENUMBRA_DATA not set: skipping the {name} evaluation");
        return None;
    };
    let path = PathBuf::from(root).join("models").join(name);
    assert!(path.is_file(), "PENUMBRA_DATA is set but {} is missing", path.display());
    Some(path)
}

/// A scene of the shared data set (`scenes/`), when `PENUMBRA_DATA` is set.
pub fn data_scene(name: &str) -> Option<PathBuf> {
    let Some(root) = std::env::var_os("PENUMBRA_DATA") else {
        println!("PENUMBRA_DATA not set: skipping the {name} evaluation");
        return None;
    };
    let path = PathBuf::from(root).join("scenes").join(name);
    assert!(path.is_file(), "PENUMBRA_DATA is set but {} is missing", path.display());
    Some(path)
}

pub fn asset(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets").join(name)
}

/// Deterministic xorshift numbers for test inputs.
pub struct Rng(pub u64);

impl Rng {
    pub fn f32(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn vec3(&mut self, lo: f32, hi: f32) -> glam::Vec3 {
        glam::Vec3::new(self.f32(), self.f32(), self.f32()) * (hi - lo) + glam::Vec3::splat(lo)
    }
}
