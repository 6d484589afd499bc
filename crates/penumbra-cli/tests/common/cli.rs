//! Running the `penumbra` binary in tests: command-line templates, the
//! outcome of a run, and per-test temporary folders. Shared by every CLI
//! test file (`tests/cli*.rs`).

use std::path::PathBuf;
use std::process::Command;

use serde_json::Value;

pub use super::TempDir;
use super::{asset, data_root};

/// The argument list of a command-line template: whitespace-separated
/// tokens, each `{name}` in a token replaced by the value of `name`.
pub fn cmd(template: &str, vars: &[(&str, &str)]) -> Vec<String> {
    template
        .split_whitespace()
        .map(|token| {
            let mut t = token.to_string();
            for (name, value) in vars {
                t = t.replace(&format!("{{{name}}}"), value);
            }
            assert!(!t.contains('{'), "unbound variable in {token:?}");
            t
        })
        .collect()
}

/// One finished run of the binary.
pub struct Out {
    pub args: String,
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

impl Out {
    pub fn describe(&self) -> String {
        format!(
            "penumbra {}\nexit code: {}\n--- stdout ---\n{}\n--- stderr ---\n{}",
            self.args, self.code, self.stdout, self.stderr
        )
    }

    /// Exit 0.
    pub fn ok(&self) -> &Self {
        assert_eq!(self.code, 0, "expected success\n{}", self.describe());
        self
    }

    /// Exit 2, nothing on stdout, and every phrase in stderr.
    pub fn bad_input(&self, phrases: &[&str]) -> &Self {
        assert_eq!(self.code, 2, "expected exit code 2 (bad input)\n{}", self.describe());
        assert!(
            self.stdout.is_empty(),
            "stdout must be empty on error\n{}",
            self.describe()
        );
        for p in phrases {
            assert!(
                self.stderr.contains(p),
                "stderr must mention {p:?}\n{}",
                self.describe()
            );
        }
        self
    }

    /// The single JSON object on stdout: exactly one value, then one newline.
    pub fn json(&self) -> Value {
        assert!(
            self.stdout.ends_with('\n') && self.stdout.trim_end().lines().count() == 1,
            "--json stdout must be one line ending with a single newline\n{}",
            self.describe()
        );
        let mut values = serde_json::Deserializer::from_str(&self.stdout).into_iter::<Value>();
        let first = values
            .next()
            .unwrap_or_else(|| panic!("no JSON on stdout\n{}", self.describe()))
            .unwrap_or_else(|e| panic!("stdout is not JSON ({e})\n{}", self.describe()));
        assert!(
            values.next().is_none(),
            "more than one JSON value on stdout\n{}",
            self.describe()
        );
        assert!(
            first.is_object(),
            "the JSON value is not an object\n{}",
            self.describe()
        );
        first
    }
}

/// Runs the binary with `args` and `env` changes (`None` removes a variable).
/// Asserts what holds for every run: no panic (exit code 101 or a "panicked"
/// message) and no death by a signal.
pub fn run_env(args: &[String], env: &[(&str, Option<&str>)]) -> Out {
    let mut command = Command::new(env!("CARGO_BIN_EXE_penumbra"));
    command.args(args);
    // A relative data set is the repository root's; the binary runs here.
    if let Some(data) = data_root() {
        command.env("PENUMBRA_DATA", data);
    }
    for (k, v) in env {
        match v {
            Some(v) => command.env(k, v),
            None => command.env_remove(k),
        };
    }
    let output = command.output().expect("cannot start the penumbra binary");
    let out = Out {
        args: args.join(" "),
        code: output.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&output.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&output.stderr).into_owned(),
    };
    assert_ne!(out.code, 101, "the binary panicked\n{}", out.describe());
    assert_ne!(out.code, -1, "the binary was killed by a signal\n{}", out.describe());
    assert!(
        !out.stderr.contains("panicked"),
        "the binary panicked\n{}",
        out.describe()
    );
    out
}

pub fn run(args: &[String]) -> Out {
    run_env(args, &[])
}

/// `run(cmd(template, vars))`.
pub fn pen(template: &str, vars: &[(&str, &str)]) -> Out {
    run(&cmd(template, vars))
}

pub fn asset_s(name: &str) -> String {
    asset(name).to_str().unwrap().to_string()
}

/// Whether the binary's GPU runs can be tested here: `false` skips them
/// (`skip_gpu`: counted, or a failure where a GPU is expected).
pub fn gpu_available() -> bool {
    super::gpu().is_some()
}

/// The sky and ground of the probe most PRT tests light with.
pub const SKY: [f32; 3] = [2.0, 1.8, 1.5];
pub const GROUND: [f32; 3] = [0.2, 0.2, 0.25];

/// A Radiance probe `probe.hdr` in `dir`: `sky` above the horizon (+y),
/// `ground` below; 32 x 16 texels, so the horizon lies on a texel boundary.
pub fn write_probe(dir: &TempDir, sky: [f32; 3], ground: [f32; 3]) -> String {
    let (w, h) = (32usize, 16usize);
    let pixels: Vec<image::Rgb<f32>> = (0..w * h)
        .map(|i| image::Rgb(if i / w < h / 2 { sky } else { ground }))
        .collect();
    let path = dir.p("probe.hdr");
    let file = std::fs::File::create(&path).unwrap();
    image::codecs::hdr::HdrEncoder::new(std::io::BufWriter::new(file))
        .encode(&pixels, w, h)
        .unwrap();
    path
}
