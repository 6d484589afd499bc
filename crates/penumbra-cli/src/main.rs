//! The `penumbra` command (see the `penumbra_cli` library).

fn main() {
    quiet_mesa_runtime_dir();
    std::process::exit(penumbra_cli::run(std::env::args_os()));
}

/// Mesa's Wayland probe prints "XDG_RUNTIME_DIR is invalid or not set" on
/// every run of a headless machine without the variable. Point it at a
/// private, empty folder (no display there, so the probe fails quietly).
/// Done first, while the process has one thread, as `set_var` requires.
#[cfg(target_os = "linux")]
fn quiet_mesa_runtime_dir() {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt};
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let Ok(me) = std::fs::metadata("/proc/self").map(|m| m.uid()) else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("penumbra-runtime-{me}"));
    let _ = std::fs::DirBuilder::new().mode(0o700).create(&dir);
    let ours = std::fs::symlink_metadata(&dir).is_ok_and(|m| m.is_dir() && m.uid() == me && m.mode() & 0o077 == 0);
    if ours {
        // SAFETY: no other thread exists yet (this is the first statement of main).
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
}

#[cfg(not(target_os = "linux"))]
fn quiet_mesa_runtime_dir() {}
