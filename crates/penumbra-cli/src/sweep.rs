//! `penumbra sweep METHOD`: time and error of every setting of a knob grid
//! on the user's scene (`penumbra::sweep` builds the method's sweep,
//! `penumbra::tune` runs it), written to DIR/sweep.{csv,json,png}.

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::args::{CameraArgs, Common};
use penumbra::error::{Error, Result};
use penumbra::scene::View;
pub use penumbra::sweep::SweepKind as Method;
use penumbra::sweep::{SweepInputs, with_method};
use penumbra::tune::{self, Grid, SweepReport};

#[derive(clap::Args)]
pub struct SweepArgs {
    /// The method whose knobs are swept.
    #[arg(value_enum)]
    pub method: Method,
    /// Mesh: OBJ, PLY or glTF.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh.
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    /// field: AO at this mesh's vertices [default: a ground under --mesh].
    #[arg(long, requires = "mesh")]
    pub receiver: Option<PathBuf>,
    /// Values of one knob, 'KNOB=V1,V2,...' (repeatable; one value fixes a
    /// knob). Knobs not named take the method's default grid.
    #[arg(long)]
    pub grid: Vec<String>,
    /// Output folder (created if missing) for sweep.csv, sweep.json, sweep.png.
    #[arg(long)]
    pub out: PathBuf,
    /// Rays per point of the reference, the ground truth (field: per vertex; ssao: per
    /// pixel; prt: per vertex) [default: field 64, ssao 256, prt 1024].
    #[arg(long, alias = "truth-rays", allow_negative_numbers = true)]
    pub reference_rays: Option<u32>,
    /// field and ssao: the AO radius [default: field infinite, ssao 5% of the scene's diagonal].
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Image width (ssao, trace, bounded).
    #[arg(long, default_value_t = 400, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height (ssao, trace, bounded).
    #[arg(long, default_value_t = 300, allow_negative_numbers = true)]
    pub height: u32,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
    #[command(flatten)]
    pub shard: crate::shard::ShardArgs,
}

impl SweepArgs {
    /// The files the sweep writes.
    pub fn outputs(&self) -> [PathBuf; 3] {
        tune::output_files(&self.out)
    }
}

pub fn run(args: &SweepArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let runs = args.common.runs.runs(3)?;
    if let Some(parent) = args.out.parent().filter(|p| !p.as_os_str().is_empty())
        && !parent.is_dir()
    {
        let problem = format!("folder {} does not exist", parent.display());
        return Err(Error::param("--out", problem));
    }
    let data_dir = crate::args::data_dir();
    let inputs = SweepInputs {
        mesh: args.mesh.as_deref(),
        scene: args.scene.as_deref(),
        receiver: args.receiver.as_deref(),
        view: View::new(args.camera.spec(), args.width, args.height)?,
        truth_rays: args.reference_rays,
        radius: args.radius,
        seed: args.common.seed,
        data_dir: data_dir.as_deref(),
    };
    let device = args.common.open_device_for(args.method.gpu_needs())?;
    let progress = crate::progress::stderr();
    let mut report = with_method(args.method, &inputs, &device, &progress, |method| {
        let grid = Grid::parse(&args.grid, method.knobs())?;
        tune::sweep(method, &grid, runs, &progress)
    })?;
    write_outputs(&mut report, &args.out)?;
    crate::io::merged(args.common.report(&device, threads), &report)
}

/// Writes `sweep.csv`, `sweep.json` and `sweep.png` into `dir` (created if
/// missing, its parent must exist); records them in the report.
pub fn write_outputs(report: &mut SweepReport, dir: &Path) -> Result<()> {
    if !dir.is_dir() {
        std::fs::create_dir(dir).map_err(|e| Error::file(dir, "", format!("cannot create the folder: {e}")))?;
    }
    let [csv, json, png] = tune::output_files(dir);
    report.files = [&csv, &json, &png].iter().map(|p| p.display().to_string()).collect();
    penumbra::io::output::write_bytes(&csv, tune::csv_text(report).as_bytes())?;
    crate::plot::write_png(&png, report)?;
    let text = serde_json::to_string_pretty(report).map_err(|e| Error::internal(e.to_string()))?;
    penumbra::io::output::write_bytes(&json, text.as_bytes())
}
