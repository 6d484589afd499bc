//! `penumbra sweep METHOD`: time and error of every setting of a knob grid
//! on the user's scene (`penumbra::sweep` builds the method's sweep,
//! `penumbra::tune` runs it), written to DIR/sweep.{csv,json,png}.

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::args::{CameraArgs, Common};
use penumbra::error::{Error, Result};
use penumbra::io::shard::{PartWriter, Parts, Shard};
use penumbra::report::repeats::Repeats;
use penumbra::scene::View;
pub use penumbra::sweep::SweepKind as Method;
use penumbra::sweep::{SweepInputs, with_method};
use penumbra::tune::{self, Grid, Sweep, SweepReport, SweepTotals};

use crate::shard::Mode;

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
    #[arg(long, value_parser = crate::options::count::<u32>(0), alias = "truth-rays", allow_negative_numbers = true)]
    pub reference_rays: Option<u32>,
    /// field and ssao: the AO radius [default: field infinite, ssao 5% of the scene's diagonal].
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Image width (ssao, trace, bounded).
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 400, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height (ssao, trace, bounded).
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 300, allow_negative_numbers = true)]
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
    crate::files::check_out_folder(&args.out, "--out")?;
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
    let mode = args.shard.mode()?;
    let report = with_method(args.method, &inputs, &device, &progress, |method| {
        let grid = Grid::parse(&args.grid, method.knobs())?;
        match &mode {
            Mode::Whole => tune::sweep(method, &grid, runs, &progress).map(Ok),
            Mode::Part(shard) => part(args, method, &grid, runs, *shard).map(Err),
            Mode::Merge(parts) => merge(method, &grid, runs, parts).map(Ok),
        }
    })?;
    let mut report = match report {
        Ok(report) => report,
        Err(shard) => {
            let report = crate::io::merged(args.common.report(&device, threads), shard.report)?;
            return crate::shard::finish_part(shard.writer, report);
        }
    };
    write_outputs(&mut report, &args.out)?;
    crate::io::merged(args.common.report(&device, threads), &report)
}

/// Writes `sweep.csv`, `sweep.json` and `sweep.png` into `dir` (created if
/// missing, its parent must exist); records them in the report.
pub fn write_outputs(report: &mut SweepReport, dir: &Path) -> Result<()> {
    crate::files::make_out_folder(dir)?;
    let [csv, json, png] = tune::output_files(dir);
    report.files = [&csv, &json, &png].iter().map(|p| p.display().to_string()).collect();
    penumbra::io::output::write_bytes(&csv, tune::csv_text(report).as_bytes())?;
    crate::plot::write_png(&png, report)?;
    let text = serde_json::to_string_pretty(report).map_err(|e| Error::internal(e.to_string()))?;
    penumbra::io::output::write_bytes(&json, text.as_bytes())
}

/// A finished shard's part, handed out of the method's closure.
struct Finished {
    writer: PartWriter,
    report: Value,
}

/// The file a sweep's parts are named after: `DIR/sweep.csv`.
fn target(args: &SweepArgs) -> PathBuf {
    args.outputs()[0].clone()
}

/// A row's measurements as a part records them (its knobs are the grid's
/// setting of that index).
#[derive(serde::Serialize, serde::Deserialize)]
struct Measured {
    time_ms: f64,
    times_ms: Vec<f64>,
    error: f64,
    memory_bytes: Option<u64>,
    phases: serde_json::Map<String, Value>,
}

/// `--shard I/N`: this shard's settings of the grid, each row recorded as
/// it is measured; the truth is computed in every shard.
fn part(args: &SweepArgs, method: &mut dyn Sweep, grid: &Grid, runs: Repeats, shard: Shard) -> Result<Finished> {
    crate::files::make_out_folder(&args.out)?;
    let total = grid.settings().len();
    let mut writer = crate::shard::open_part(&target(args), shard, total)?;
    let which: Vec<usize> = writer.todo(1).into_iter().map(|r| r.start).collect();
    let progress = crate::progress::stderr();
    let measured = tune::sweep_settings(method, grid, runs, &which, &progress, |i, row| {
        let m = Measured {
            time_ms: row.time_ms,
            times_ms: row.times_ms.clone(),
            error: row.error,
            memory_bytes: row.memory_bytes,
            phases: row.phases.clone(),
        };
        let bytes = serde_json::to_vec(&m).map_err(|e| Error::internal(e.to_string()))?;
        writer.record(i..i + 1, &bytes)
    })?;
    let report = serde_json::json!({
        "method": method.name(),
        "truth": measured.truth,
        "truth_ms": measured.truth_ms,
        "estimated_s": measured.estimated_s,
        "sweep_ms": measured.sweep_ms,
    });
    Ok(Finished { writer, report })
}

/// `penumbra merge DIR/sweep.csv`: every shard's rows, the front marked on
/// all of them; times are the shards' own, summed.
fn merge(method: &mut dyn Sweep, grid: &Grid, runs: Repeats, parts: &Parts) -> Result<SweepReport> {
    let settings = grid.settings();
    if settings.len() != parts.total_items() {
        let problem = format!(
            "the parts hold {} settings, the grid gives {}",
            parts.total_items(),
            settings.len()
        );
        return Err(Error::file(&parts.output, "", problem));
    }
    let mut rows = Vec::with_capacity(settings.len());
    for (items, bytes) in parts.records()? {
        let m: Measured = serde_json::from_slice(&bytes)
            .map_err(|e| Error::file(&parts.output, "", format!("a record of settings {items:?}: {e}")))?;
        rows.push(tune::Row {
            knobs: settings[items.start].clone(),
            time_ms: m.time_ms,
            times_ms: m.times_ms,
            error: m.error,
            memory_bytes: m.memory_bytes,
            phases: m.phases,
            pareto: false,
        });
    }
    let first = &parts.sidecars[0].report;
    let sum = |k: &str| parts.sidecars.iter().filter_map(|s| s.report[k].as_f64()).sum::<f64>();
    let totals = SweepTotals {
        truth: first["truth"].clone(),
        truth_ms: first["truth_ms"].as_f64().unwrap_or(0.0),
        estimated_s: sum("estimated_s"),
        sweep_ms: sum("sweep_ms"),
    };
    Ok(tune::sweep_report(method, grid, runs.repeat, totals, rows))
}
