//! The `penumbra` command line, as `../shared/CONTRACT.md` specifies it.
//!
//! Every subcommand returns a JSON object; with `--json` it is the only thing
//! printed on stdout, otherwise a readable summary is. Messages and progress
//! go to stderr. Exit codes: 0 success, 2 bad input or unavailable device
//! (including usage errors from clap), 1 internal error (panics included).

mod ao;
mod ao_field;
mod args;
mod field;
mod info;
mod io;
mod prt;
mod ssao;
mod trace;
mod trace_rays;

use std::ffi::OsString;

use clap::{Parser, Subcommand};
use serde_json::Value;

use crate::error::{Error, Result};
use crate::gpu::GpuContext;

pub use args::{Common, DeviceArg};

#[derive(Parser)]
#[command(
    name = "penumbra",
    version,
    about = "Visibility on the GPU: ambient occlusion and ray casting with wgpu/WGSL, with a CPU reference path"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List GPU adapters and the one penumbra would use.
    Info(info::InfoArgs),
    /// Trace rays from a file against a mesh (closest hits).
    TraceRays(trace_rays::TraceRaysArgs),
    /// Ambient occlusion per vertex (CSV) and/or per pixel (PNG).
    Ao(ao::AoArgs),
    /// Primary rays from a camera, with traversal statistics.
    Trace(trace::TraceArgs),
    /// Self-shadowed rendering under an environment map, transfer recomputed every frame.
    Prt(prt::PrtArgs),
    /// Displacement fields: build one from a mesh, or inspect a .dfield file.
    Field(field::FieldArgs),
    /// Screen-space ambient occlusion and indirect light (the paper's estimators).
    Ssao(ssao::SsaoArgs),
    /// Write the procedural scenes (corner, closed box, well, ...) as OBJ files.
    GenAssets(GenAssetsArgs),
}

#[derive(clap::Args)]
struct GenAssetsArgs {
    /// Output folder.
    #[arg(long, default_value = "assets")]
    out: std::path::PathBuf,
    #[arg(long)]
    json: bool,
}

/// Runs the command line; returns the process exit code.
pub fn run(args: impl IntoIterator<Item = OsString>) -> i32 {
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return e.exit_code();
        }
    };
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| dispatch(cli.command)));
    match outcome {
        Ok(Ok(())) => 0,
        Ok(Err(e)) => {
            eprintln!("penumbra: error: {e}");
            e.exit_code()
        }
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("unknown panic");
            eprintln!("penumbra: internal error (a bug, please report it): {what}");
            1
        }
    }
}

fn dispatch(command: Command) -> Result<()> {
    match command {
        Command::Info(a) => emit(a.json, info::run(&a)?),
        Command::TraceRays(a) => emit(a.common.json, trace_rays::run(&a)?),
        Command::Ao(a) => emit(a.common.json, ao::run(&a)?),
        Command::Trace(a) => emit(a.common.json, trace::run(&a)?),
        Command::Prt(a) => emit(a.common.json, prt::run(&a)?),
        Command::Field(a) => emit(field::json_flag(&a), field::run(&a)?),
        Command::Ssao(a) => emit(a.common.json, ssao::run(&a)?),
        Command::GenAssets(a) => {
            let written = crate::scene::procedural::write_assets(&a.out)?;
            let files: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
            emit(a.json, serde_json::json!({ "files": files }))
        }
    }
}

/// Prints the result: the JSON object alone with `--json`, else its fields.
fn emit(json: bool, value: Value) -> Result<()> {
    if json {
        println!("{value}");
    } else if let Value::Object(map) = &value {
        for (k, v) in map {
            match v {
                Value::Object(_) | Value::Array(_) => println!("{k}: {v}"),
                Value::String(s) => println!("{k}: {s}"),
                _ => println!("{k}: {v}"),
            }
        }
    }
    Ok(())
}

/// The compute device a subcommand runs on.
pub enum Device {
    Cpu,
    Gpu(GpuContext),
}

impl Device {
    /// Resolves `--device`: `gpu` fails without an adapter, `auto` falls
    /// back to the CPU with a message, `cpu` never touches the GPU.
    pub fn open(arg: DeviceArg) -> Result<Device> {
        match arg {
            DeviceArg::Cpu => Ok(Device::Cpu),
            DeviceArg::Gpu => {
                let ctx = GpuContext::headless()?;
                eprintln!("penumbra: GPU adapter: {}", ctx.name);
                Ok(Device::Gpu(ctx))
            }
            DeviceArg::Auto => match GpuContext::headless() {
                Ok(ctx) => {
                    eprintln!("penumbra: GPU adapter: {}", ctx.name);
                    Ok(Device::Gpu(ctx))
                }
                Err(e) => {
                    eprintln!("penumbra: {e}; using the CPU reference path");
                    Ok(Device::Cpu)
                }
            },
        }
    }

    /// "cpu" or "gpu", the JSON `device` field.
    pub fn kind(&self) -> &'static str {
        match self {
            Device::Cpu => "cpu",
            Device::Gpu(_) => "gpu",
        }
    }

    /// The adapter's name, or null on the CPU.
    pub fn adapter(&self) -> Value {
        match self {
            Device::Cpu => Value::Null,
            Device::Gpu(ctx) => Value::String(ctx.name.clone()),
        }
    }
}

impl From<rayon::ThreadPoolBuildError> for Error {
    fn from(e: rayon::ThreadPoolBuildError) -> Self {
        Error::internal(format!("cannot start the thread pool: {e}"))
    }
}
