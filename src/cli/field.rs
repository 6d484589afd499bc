//! `penumbra field build` and `penumbra field info`: displacement fields on
//! disk.

use std::path::PathBuf;

use clap::Subcommand;
use serde_json::{Value, json};

use super::args::{check_output, init_thread_pool};
use crate::error::{Error, Result};
use crate::field::{DirectionMapping, DisplacementField, FieldParams, OctahedralGrid, Storage, file};
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

/// The field's sampling and storage: shared by `field build` and
/// `ao --method field` (which builds fields on the fly without `--field`).
#[derive(clap::Args, Clone, Debug)]
pub struct FieldOptions {
    /// Positional samples on the bounding sphere; the octahedral grid takes
    /// the nearest square (4226 -> 65 x 65 = 4225).
    #[arg(long, default_value_t = 4226, allow_negative_numbers = true)]
    pub positions: i64,
    /// Each map is RES x RES directions.
    #[arg(long, default_value_t = 32, allow_negative_numbers = true)]
    pub res: i64,
    /// Bits per direction: 32 (float), 8, or 1 (visibility + mean distance).
    #[arg(long, default_value_t = 8, allow_negative_numbers = true)]
    pub bits: i64,
    /// How the map's texels cover the hemisphere of directions.
    #[arg(long, value_enum, default_value_t = DirectionMapping::Concentric)]
    pub directions: DirectionMapping,
}

impl FieldOptions {
    pub fn params(&self) -> Result<FieldParams> {
        if self.positions < 1 {
            let problem = format!("must be at least 1, got {}", self.positions);
            return Err(Error::param("--positions", problem));
        }
        let storage = u32::try_from(self.bits)
            .ok()
            .and_then(Storage::from_bits)
            .ok_or_else(|| Error::param("--bits", format!("must be 32, 8 or 1, got {}", self.bits)))?;
        let res = u32::try_from(self.res)
            .map_err(|_| Error::param("--res", format!("must be between 2 and 512, got {}", self.res)))?;
        let params = FieldParams {
            grid: OctahedralGrid::with_count(self.positions.min(u32::MAX as i64) as u32),
            res,
            storage,
            directions: self.directions,
        };
        params.validate()?;
        Ok(params)
    }
}

#[derive(clap::Args)]
pub struct BuildArgs {
    /// The object (Wavefront OBJ), in its own coordinates.
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
