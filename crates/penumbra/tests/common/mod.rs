//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

use penumbra::gpu::GpuContext;
use penumbra::gpu::device::Device;

/// Whether a GPU is expected: `CI` set to anything but "", "false" or "0"
/// (as CI services set it), or `PENUMBRA_REQUIRE_GPU=1`. Where it is, a
/// missing adapter fails the test instead of skipping its GPU half, so a
/// broken adapter set-up cannot pass as "no GPU here".
pub fn gpu_required() -> bool {
    on_ci() || std::env::var("PENUMBRA_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// Whether this is a CI run: `CI` set to anything but "", "false" or "0".
pub fn on_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !matches!(v.trim(), "" | "false" | "0"))
}

/// Whether a test may rewrite its reference files instead of comparing:
/// `PENUMBRA_BLESS=1` exactly (any other value, "0" included, compares),
/// and never on CI, where a rewritten file would pass by construction.
pub fn bless() -> bool {
    let asked = std::env::var("PENUMBRA_BLESS").is_ok_and(|v| v == "1");
    if asked && on_ci() {
        println!("PENUMBRA_BLESS=1 ignored on CI: the reference files are compared");
    }
    asked && !on_ci()
}

/// How many cases a fuzz test runs: `PENUMBRA_FUZZ_CASES` where set, else
/// `default`. A value that is not a count, or (on CI) one below `default`,
/// is refused: a suite run with 0 cases would pass every fuzz test.
pub fn fuzz_cases(default: u32) -> u32 {
    let Ok(value) = std::env::var("PENUMBRA_FUZZ_CASES") else {
        return default;
    };
    let cases: u32 = value
        .trim()
        .parse()
        .unwrap_or_else(|_| panic!("PENUMBRA_FUZZ_CASES={value:?} is not a count of cases"));
    assert!(
        !on_ci() || cases >= default,
        "PENUMBRA_FUZZ_CASES={cases} is below this test's {default} cases, which CI does not allow"
    );
    cases
}

/// Where skipped GPU tests are listed, one line each, for the suite's last
/// test binary (`crates/penumbra-cli/tests/zz_skips.rs`) to print and
/// count: cargo runs each test file as its own process, so a count over
/// the whole suite has to be kept outside them. Both crates' tests share
/// the target directory, hence this file.
pub fn skips_file() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("penumbra-skips.txt")
}

/// A GPU test part that cannot run because there is no adapter (`why`):
/// panics where `gpu_required`, else prints the skip and lists it in
/// `skips_file` as `cargo's pid <TAB> test binary <TAB> test <TAB> what <TAB>
/// why` (the pid tells one `cargo test` run's skips from an earlier one's).
pub fn skip_gpu(what: &str, why: &dyn std::fmt::Display) {
    let why = why.to_string().replace(['\t', '\n'], " ");
    assert!(
        !gpu_required(),
        "no GPU adapter ({why}), but CI or PENUMBRA_REQUIRE_GPU=1 expects one: {what} cannot be skipped"
    );
    println!("no GPU adapter ({why}): {what} skipped");
    let binary = std::env::current_exe()
        .ok()
        .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_default();
    let binary = binary.split('-').next().unwrap_or_default().to_string();
    let test = std::thread::current().name().unwrap_or("?").to_string();
    let line = format!(
        "{}\t{binary}\t{test}\t{what}\t{why}\n",
        std::os::unix::process::parent_id()
    );
    use std::io::Write;
    let _ = std::fs::create_dir_all(env!("CARGO_TARGET_TMPDIR"));
    let file = std::fs::OpenOptions::new().create(true).append(true).open(skips_file());
    // One write of a short line to a file opened for appending: lines of
    // tests running at once do not interleave.
    file.and_then(|mut f| f.write_all(line.as_bytes()))
        .expect("the skipped-tests list is writable");
}

/// The GPU if there is one. Without an adapter, tests run their CPU half
/// and the GPU half is skipped (`skip_gpu`: counted, or a failure where a
/// GPU is expected).
pub fn gpu() -> Option<GpuContext> {
    match GpuContext::headless() {
        Ok(ctx) => {
            println!("GPU adapter: {}", ctx.name);
            Some(ctx)
        }
        Err(e) => {
            skip_gpu("GPU half", &e);
            None
        }
    }
}

/// The GPU if there is one, as a device created with WebGPU's portable
/// limits (`wgpu::Limits::default()`): what a host that asks for no more
/// gives penumbra.
pub fn portable_gpu() -> Option<GpuContext> {
    use penumbra::gpu::{AdapterKinds, AdapterSettings, LimitsChoice};
    let options = AdapterSettings {
        limits: LimitsChoice::Portable,
        ..Default::default()
    };
    match GpuContext::headless_on(AdapterKinds::Any, &options) {
        Ok(ctx) => {
            println!("GPU adapter: {} (portable limits)", ctx.label());
            Some(ctx)
        }
        Err(e) => {
            skip_gpu("portable-limits test", &e);
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

/// The repository's root (the workspace's folder).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The shared data set, when `PENUMBRA_DATA` is set; a relative path is
/// taken from the repository's root (where the README's commands run),
/// since cargo runs each test in its own package's folder.
pub fn data_root() -> Option<PathBuf> {
    let root = PathBuf::from(std::env::var_os("PENUMBRA_DATA")?);
    Some(if root.is_relative() {
        repo_root().join(root)
    } else {
        root
    })
}

/// A model of the shared data set, when `PENUMBRA_DATA` is set. If it is set
/// but the file is missing, that is a broken setup: panic.
pub fn data_model(name: &str) -> Option<PathBuf> {
    data_file("models", name)
}

/// A scene of the shared data set (`scenes/`), when `PENUMBRA_DATA` is set.
pub fn data_scene(name: &str) -> Option<PathBuf> {
    data_file("scenes", name)
}

/// `folder/name` of the shared data set, when `PENUMBRA_DATA` is set.
fn data_file(folder: &str, name: &str) -> Option<PathBuf> {
    let Some(root) = data_root() else {
        println!("PENUMBRA_DATA not set: skipping the {name} evaluation");
        return None;
    };
    let path = root.join(folder).join(name);
    assert!(path.is_file(), "PENUMBRA_DATA is set but {} is missing", path.display());
    Some(path)
}

pub fn asset(name: &str) -> PathBuf {
    repo_root().join("assets").join(name)
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

/// A per-test folder under the system temp dir, removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(test: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("penumbra-cli-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    /// Path of `name` in the folder, as a command-line string.
    pub fn p(&self, name: &str) -> String {
        self.0.join(name).to_str().expect("UTF-8 temp path").to_string()
    }

    /// Writes `bytes` to `name`; returns its path.
    pub fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> String {
        std::fs::write(self.0.join(name), bytes).unwrap();
        self.p(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
