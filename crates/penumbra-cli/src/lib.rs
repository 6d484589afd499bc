//! The `penumbra` command line, as `../shared/CONTRACT.md` specifies it. It
//! parses, calls a library runner and reports: the methods themselves live
//! in the `penumbra` library.
//!
//! Every subcommand returns a JSON object; with `--json` it is the only thing
//! printed on stdout, otherwise a readable summary is. Messages and progress
//! go to stderr. Exit codes: 0 success, 2 bad input or unavailable device
//! (including usage errors from clap), 1 internal error (panics included).
//! Library errors name parameters in the library's language; `args::flag`
//! maps them to this command line's options.

mod ao;
mod ao_frames;
mod applies;
mod args;
mod bake;
mod bake_manifest;
mod bench;
mod field;
mod files;
mod gen_assets;
mod info;
mod io;
mod options;
mod plot;
mod progress;
mod prt;
mod prt_frames;
mod raytrace;
mod raytrace_bounded;
mod raytrace_frames;
mod raytrace_tiles;
mod shard;
mod ssao;
mod summary;
mod sweep;
mod trace;
mod trace_rays;

use std::ffi::OsString;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use serde_json::Value;

use penumbra::error::Result;

pub use args::{Common, DEFAULT_SEED, flag};

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
    /// Bake ambient occlusion into an asset: a GLB with an AO texture and per-vertex AO.
    Bake(bake::BakeArgs),
    /// Primary rays from a camera, with traversal statistics.
    Trace(trace::TraceArgs),
    /// Self-shadowed rendering under an environment map, transfer recomputed every frame.
    Prt(Box<prt::PrtArgs>),
    /// Displacement fields: build one from a mesh, or inspect a .dfield file.
    Field(field::FieldArgs),
    /// Screen-space ambient occlusion and indirect light (the paper's estimators).
    Ssao(ssao::SsaoArgs),
    /// Whitted ray tracing of OBJ/MTL materials or a scene file (PNG, EXR or PFM).
    Raytrace(raytrace::RaytraceArgs),
    /// Time and error of every setting of a grid of a method's knobs on your scene.
    Sweep(sweep::SweepArgs),
    /// CPU against GPU on your scene: every method at its defaults on every device and thread count, min / median / max, throughput and error, into DIR/bench.{csv,json,png}.
    Bench(bench::BenchArgs),
    /// Write OUTPUT from the parts of a run split with --shard, as one process writes it.
    Merge(MergeArgs),
    /// Write the procedural scenes (corner, closed box, well, ...) as OBJ files, the ray tracer's scenes into OUT/raytrace, example animations into OUT/animations and the chess-like scene into OUT/chess and OUT/scenes/chess.json.
    GenAssets(GenAssetsArgs),
}

#[derive(clap::Args)]
struct MergeArgs {
    /// The output the shards were given (their parts are OUTPUT.part-I-of-N).
    output: std::path::PathBuf,
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct GenAssetsArgs {
    /// Output folder.
    #[arg(long, default_value = "assets")]
    out: std::path::PathBuf,
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

/// Every option a rule of `args`' subcommand names, with whether the
/// subcommand has it (a misspelt id would never be given: its rule could
/// never fire). For tests.
pub fn rule_options(args: &[&str]) -> Vec<(&'static str, bool)> {
    let cli = Cli::try_parse_from(args).expect("a valid command line");
    let command = Cli::command();
    let sub = command.find_subcommand(args[1]).expect("a subcommand");
    let has = |id: &str| sub.get_arguments().any(|a| a.get_id() == id);
    let rules = applies::rules(&cli.command);
    rules
        .iter()
        .flat_map(|r| r.options.iter().map(|&id| (id, has(id))))
        .collect()
}

/// What a number-valued option's values are: one number, or a list or
/// point of numbers (`X,Y,Z`, `X,Y`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Numeric {
    /// One number.
    Number,
    /// Numbers separated by commas.
    List,
}

/// The kind of number `arg` takes, from its value parser's type.
fn numeric(arg: &clap::Arg) -> Option<Numeric> {
    use std::any::TypeId;
    if !arg.get_action().takes_values() {
        return None;
    }
    let t = arg.get_value_parser().type_id();
    let numbers = [
        TypeId::of::<u8>(),
        TypeId::of::<u16>(),
        TypeId::of::<u32>(),
        TypeId::of::<u64>(),
        TypeId::of::<usize>(),
        TypeId::of::<i32>(),
        TypeId::of::<i64>(),
        TypeId::of::<f32>(),
        TypeId::of::<f64>(),
    ];
    let lists = [
        TypeId::of::<glam::Vec3>(),
        TypeId::of::<glam::DVec3>(),
        TypeId::of::<(u32, u32)>(),
    ];
    if numbers.iter().any(|id| t == *id) {
        Some(Numeric::Number)
    } else if lists.iter().any(|id| t == *id) {
        Some(Numeric::List)
    } else {
        None
    }
}

/// Every number-valued option: (subcommand, long name, kind).
pub fn numeric_options() -> Vec<(String, String, Numeric)> {
    let command = Cli::command();
    let mut out = Vec::new();
    for sub in command.get_subcommands() {
        for arg in sub.get_arguments() {
            if let (Some(kind), Some(long)) = (numeric(arg), arg.get_long()) {
                out.push((sub.get_name().to_string(), long.to_string(), kind));
            }
        }
    }
    out
}

/// `Cli`'s parser, with every number-valued option taking a leading minus
/// as its value: a number (`allow_negative_numbers`) or a list
/// (`allow_hyphen_values`, "-1,0,0" is no number to clap). The option's
/// own range then refuses it by name, rather than clap calling "-1" an
/// unexpected argument.
fn command() -> clap::Command {
    fn allow(mut cmd: clap::Command) -> clap::Command {
        let args: Vec<(clap::Id, Numeric)> = cmd
            .get_arguments()
            .filter_map(|a| numeric(a).map(|k| (a.get_id().clone(), k)))
            .collect();
        for (id, kind) in args {
            cmd = cmd.mut_arg(id, |a| match kind {
                Numeric::Number => a.allow_negative_numbers(true),
                Numeric::List => a.allow_hyphen_values(true),
            });
        }
        let subs: Vec<String> = cmd.get_subcommands().map(|s| s.get_name().to_string()).collect();
        for sub in subs {
            cmd = cmd.mut_subcommand(sub, allow);
        }
        cmd
    }
    allow(Cli::command())
}

/// The subcommand `args` (the program's name first) spell, or clap's
/// message.
pub(crate) fn parse_command(args: &[String]) -> std::result::Result<Command, String> {
    command()
        .try_get_matches_from(args)
        .and_then(|m| Cli::from_arg_matches(&m))
        .map(|cli| cli.command)
        .map_err(|e| e.to_string())
}

/// The parse of `args` (the program's name first): `Ok` or clap's error
/// message. For tests.
pub fn parse_error(args: &[&str]) -> Option<String> {
    command().try_get_matches_from(args).err().map(|e| e.to_string())
}

/// The aliases of options that `args` spells: (`--long`, `--alias` as
/// typed), so that a message about the option names what the user wrote
/// (`--check-rays`, not `--reference-rays`).
fn typed_aliases(args: &[OsString]) -> Vec<(String, String)> {
    let given: Vec<&str> = args
        .iter()
        .filter_map(|a| a.to_str())
        .filter_map(|a| a.strip_prefix("--"))
        .map(|a| a.split('=').next().unwrap_or(a))
        .collect();
    let command = Cli::command();
    let mut out = Vec::new();
    for sub in command.get_subcommands() {
        for arg in sub.get_arguments() {
            let (Some(long), Some(aliases)) = (arg.get_long(), arg.get_all_aliases()) else {
                continue;
            };
            for alias in aliases {
                if given.contains(&alias) {
                    out.push((format!("--{long}"), format!("--{alias}")));
                }
            }
        }
    }
    out
}

/// The message of a count option's bad value (`options::count`), if that
/// is what clap refused.
fn count_error(e: &clap::Error) -> Option<String> {
    let source = std::error::Error::source(e)?;
    source.downcast_ref::<options::CountError>().map(|c| c.0.clone())
}

/// Runs the command line; returns the process exit code.
pub fn run(args: impl IntoIterator<Item = OsString>) -> i32 {
    let args: Vec<OsString> = args.into_iter().collect();
    let typed = typed_aliases(&args);
    let texts: Vec<String> = args.iter().map(|a| a.to_string_lossy().into_owned()).collect();
    let parsed = command()
        .try_get_matches_from(&args)
        .and_then(|m| Cli::from_arg_matches(&m).map(|cli| (cli, m)));
    let (cli, matches) = match parsed {
        Ok(parsed) => parsed,
        Err(e) if count_error(&e).is_some() => {
            // A count's own bound, said as the other bad values are: the
            // option as typed (an alias too), then the problem.
            let long = match e.get(clap::error::ContextKind::InvalidArg) {
                Some(clap::error::ContextValue::String(arg)) => arg.split(' ').next().unwrap_or(arg).to_string(),
                _ => String::new(),
            };
            let flag = typed
                .iter()
                .find(|(l, _)| *l == long)
                .map_or(long.as_str(), |(_, t)| t.as_str());
            eprintln!("penumbra: error: {flag}: {}", count_error(&e).unwrap_or_default());
            return 2;
        }
        Err(e) => {
            let _ = e.print();
            return e.exit_code();
        }
    };
    remove_unfinished_on_interrupt();
    prefer_isa_from_env();
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let sub = matches.subcommand().map(|(_, m)| m);
        if let Some(sub) = sub {
            applies::refuse_unused(&cli.command, sub)?;
        }
        dispatch(cli.command, &texts)
    }));
    match outcome {
        Ok(Ok(())) => 0,
        Ok(Err(e)) => {
            let rename = |name: &str| {
                let flag = args::flag(name)?;
                Some(
                    typed
                        .iter()
                        .find(|(long, _)| long == flag)
                        .map_or(flag, |(_, t)| t.as_str()),
                )
            };
            eprintln!("penumbra: error: {}", e.clone().with_names(rename));
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

fn dispatch(command: Command, args: &[String]) -> Result<()> {
    let files = files::of(&command);
    files.check()?;
    let inputs = files.inputs.iter().map(|(_, p)| p.clone()).collect();
    shard::record_invocation(args, inputs);
    let name = command.name();
    let emit =
        |json: bool, value: Value| io::print_report(json, &value, || summary::text(name, &files.outputs, &value));
    match command {
        Command::Merge(a) => emit(a.json, merge(&a.output)?),
        Command::Info(a) => emit(a.json, info::run(&a)?),
        Command::TraceRays(a) => emit(a.common.json, trace_rays::run(&a)?),
        Command::Ao(a) => emit(a.common.json, ao::run(&a)?),
        Command::Bake(a) => emit(a.common.json, bake::run(&a)?),
        Command::Trace(a) => emit(a.common.json, trace::run(&a)?),
        Command::Prt(a) => emit(a.common.json, prt::run(&a)?),
        Command::Field(a) => emit(field::json_flag(&a), field::run(&a)?),
        Command::Ssao(a) => emit(a.common.json, ssao::run(&a)?),
        Command::Raytrace(a) => emit(a.common.json, raytrace::run(&a)?),
        Command::Sweep(a) => emit(a.common.json, sweep::run(&a)?),
        Command::Bench(a) => {
            let report = bench::run(&a)?;
            if a.json {
                emit(true, report)?;
            }
            Ok(())
        }
        Command::GenAssets(a) => {
            let written = gen_assets::write_every_asset(&a.out)?;
            let files: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
            emit(a.json, serde_json::json!({ "files": files }))
        }
    }
}

impl Command {
    /// The subcommand's name, as typed.
    fn name(&self) -> &'static str {
        match self {
            Command::Info(_) => "info",
            Command::TraceRays(_) => "trace-rays",
            Command::Ao(_) => "ao",
            Command::Bake(_) => "bake",
            Command::Trace(_) => "trace",
            Command::Prt(_) => "prt",
            Command::Field(_) => "field",
            Command::Ssao(_) => "ssao",
            Command::Raytrace(_) => "raytrace",
            Command::Sweep(_) => "sweep",
            Command::Bench(_) => "bench",
            Command::Merge(_) => "merge",
            Command::GenAssets(_) => "gen-assets",
        }
    }

    /// The `--shard` options of a command that has them.
    fn shard_args(&mut self) -> Option<&mut shard::ShardArgs> {
        match self {
            Command::Ao(a) => Some(&mut a.shard),
            Command::Raytrace(a) => Some(&mut a.shard),
            Command::Sweep(a) => Some(&mut a.shard),
            Command::Bake(a) => Some(&mut a.shard),
            Command::Prt(a) => Some(&mut a.shard),
            _ => None,
        }
    }
}

/// `penumbra merge OUTPUT`: the parts' command run again with its items
/// read from the parts; its report gets each shard's items and time.
fn merge(output: &std::path::Path) -> Result<Value> {
    let parts = penumbra::io::shard::Parts::find(output)?;
    shard::check_program(&parts)?;
    let argv: Vec<String> = std::iter::once("penumbra".to_string())
        .chain(parts.command().iter().cloned())
        .collect();
    let mut command = command()
        .try_get_matches_from(&argv)
        .and_then(|m| Cli::from_arg_matches(&m))
        .map_err(|e| {
            let problem = format!("the parts' command '{}' does not parse: {e}", parts.command().join(" "));
            penumbra::error::Error::file(output, "", problem)
        })?
        .command;
    let Some(shard_args) = command.shard_args() else {
        let problem = format!("the parts' command '{}' cannot be split", parts.command().join(" "));
        return Err(penumbra::error::Error::file(output, "", problem));
    };
    shard_args.merging = Some(std::sync::Arc::new(parts.clone()));
    let files = files::of(&command);
    files.check()?;
    shard::record_invocation(&argv, files.inputs.iter().map(|(_, p)| p.clone()).collect());
    let mut value = match command {
        Command::Ao(a) => ao::run(&a)?,
        Command::Raytrace(a) => raytrace::run(&a)?,
        Command::Sweep(a) => sweep::run(&a)?,
        Command::Bake(a) => bake::run(&a)?,
        Command::Prt(a) => prt::run(&a)?,
        _ => unreachable!("shard_args is Some"),
    };
    value["merged"] = shard::merge_report(&parts);
    Ok(value)
}

/// `PENUMBRA_ISA=avx512|avx2|sse|scalar` runs the CPU's vector lanes at a
/// narrower instruction set, to measure what the wider one buys.
fn prefer_isa_from_env() {
    let asked = std::env::var("PENUMBRA_ISA")
        .ok()
        .and_then(|s| penumbra::geom::simd::Isa::parse(&s));
    if let Some(isa) = asked {
        penumbra::geom::simd::Isa::prefer(isa);
    }
}

/// On SIGINT/SIGTERM (Ctrl-C): removes every output being written (the
/// library's temporaries), says so on stderr and exits with 130, as shells
/// expect of an interrupted program. Outputs already in place are complete;
/// none is half written.
fn remove_unfinished_on_interrupt() {
    let _ = ctrlc::set_handler(|| {
        penumbra::io::output::remove_unfinished();
        eprintln!("penumbra: interrupted; unfinished outputs removed");
        std::process::exit(130);
    });
}

/// Every method's settings `Default` in the library is what this command
/// line builds when the options are left at their defaults (the options it
/// requires given the library's default values).
#[cfg(test)]
mod defaults {
    use super::{Cli, Command};
    use clap::Parser;
    use penumbra::scene::View;
    use penumbra::{
        AoSettings, BoundedSettings, FieldSettings, PrtSettings, SsaoSettings, TraceSettings, WhittedSettings,
    };

    fn parse(args: &str) -> Command {
        Cli::try_parse_from(std::iter::once("penumbra").chain(args.split_whitespace()))
            .expect("a valid command line")
            .command
    }

    #[test]
    fn ao_and_field() {
        let Command::Ao(a) = parse("ao --mesh m.obj --method raycast --rays 256 --per-vertex o.csv") else {
            unreachable!()
        };
        assert_eq!(a.knobs.settings(a.common.seed).unwrap(), AoSettings::default());
        let field = FieldSettings {
            sampling: a.field_options.params().unwrap(),
            positional: a.knobs.positional,
        };
        assert_eq!(field, FieldSettings::default());
    }

    #[test]
    fn ssao() {
        let d = SsaoSettings::default();
        let args = format!(
            "ssao --mesh m.obj --estimator importance --spp {} --radius {}",
            d.spp, d.radius
        );
        let Command::Ssao(a) = parse(&args) else { unreachable!() };
        assert_eq!(a.knobs.settings(a.common.seed, 0.5).unwrap(), d);
    }

    #[test]
    fn prt() {
        let Command::Prt(a) = parse("prt --mesh m.obj --env e.hdr") else {
            unreachable!()
        };
        assert_eq!(a.knobs.settings(true).unwrap(), PrtSettings::default());
    }

    #[test]
    fn trace() {
        let Command::Trace(a) = parse("trace --mesh m.obj") else {
            unreachable!()
        };
        let view = View::sized(a.size.width, a.size.height);
        assert_eq!(view, View::default());
        assert_eq!(a.knobs.request(view).unwrap(), TraceSettings::default().request(&view));
    }

    #[test]
    fn whitted_and_bounded() {
        let Command::Raytrace(a) = parse("raytrace --method bounded --mesh m.obj --out o.png") else {
            unreachable!()
        };
        let whitted = a.whitted.settings(a.common.seed).unwrap();
        assert_eq!(whitted, WhittedSettings::default());
        assert_eq!(a.bounded.settings(whitted).unwrap(), BoundedSettings::default());
    }
}
