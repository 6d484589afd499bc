//! `penumbra field build` and `penumbra field info`: displacement fields on
//! disk.

use std::path::PathBuf;

use clap::Subcommand;
use serde_json::{Value, json};

use crate::args::{check_output, init_thread_pool};
use crate::options::field::FieldOptions;
use penumbra::error::Result;
use penumbra::field::file;
use penumbra::field::report::build_file;

#[derive(clap::Args)]
pub struct FieldArgs {
    #[command(subcommand)]
    pub command: FieldCommand,
}

#[derive(Subcommand)]
pub enum FieldCommand {
    /// Build the displacement field of a mesh (maps on its bounding sphere).
    Build(BuildArgs),
    /// Print a .dfield file's header.
    Info(InfoArgs),
}

#[derive(clap::Args)]
pub struct BuildArgs {
    /// The object (OBJ, PLY or glTF), in its own coordinates.
    #[arg(long)]
    pub mesh: PathBuf,
    #[command(flatten)]
    pub field: FieldOptions,
    /// Output .dfield file.
    #[arg(short = 'o', long = "out")]
    pub out: PathBuf,
    /// CPU threads (default: all cores).
    #[arg(long, value_parser = crate::options::count::<usize>(1), allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub runs: crate::options::RepeatOptions,
}

#[derive(clap::Args)]
pub struct InfoArgs {
    /// A .dfield file.
    pub file: PathBuf,
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn json_flag(args: &FieldArgs) -> bool {
    match &args.command {
        FieldCommand::Build(b) => b.json,
        FieldCommand::Info(i) => i.json,
    }
}

pub fn run(args: &FieldArgs) -> Result<Value> {
    match &args.command {
        FieldCommand::Build(b) => build(b),
        FieldCommand::Info(i) => Ok(json!(file::read(&i.file)?.summary())),
    }
}

fn build(args: &BuildArgs) -> Result<Value> {
    let threads = init_thread_pool(args.threads)?;
    let out = check_output(&args.out, "-o")?;
    let report = build_file(
        &args.mesh,
        (&args.field.params()?, args.field.positions),
        out,
        (args.runs.runs(1)?, &crate::progress::stderr()),
    )?;
    crate::io::merged(json!({ "threads": threads }), report)
}
