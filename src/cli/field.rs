//! `penumbra field build` and `penumbra field info`: displacement fields on
//! disk.

use std::path::PathBuf;

use clap::Subcommand;
use serde_json::{Value, json};

use super::args::{check_output, init_thread_pool};
use crate::error::{Error, Result};
use crate::field::options::FieldOptions;
use crate::field::{DisplacementField, file};
use crate::progress::Bars;
use crate::scene::load_mesh;

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
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
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
    let params = args.field.params()?;
    let out = check_output(&args.out, "-o")?;
    let mesh = load_mesh(&args.mesh)?;
    let progress = Bars::Stderr.bar(params.maps() as u64, "building displacement maps");
    let (field, stats) = DisplacementField::build(&mesh, &params, &args.mesh.display().to_string(), &progress)?;
    progress.finish();
    file::write(out, &field)?;
    let bytes = std::fs::metadata(out).map_err(|e| Error::read(out, e))?.len();
    super::io::merged(
        json!(field.summary()),
        json!({
            "bytes": bytes,
            "build_ms": stats.build_ms,
            "kdtree_ms": stats.kdtree_ms,
            "rays": stats.rays,
            "hit_fraction": stats.hit_fraction,
            "positions_requested": args.field.positions,
            // Equal-area cells: the ratio tends to 1 as the quadrature refines.
            "cell_area_ratio": params.grid.cell_area_ratio(8),
            "threads": threads,
            "file": out.display().to_string(),
        }),
    )
}
