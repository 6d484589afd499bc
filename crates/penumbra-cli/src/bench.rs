//! `penumbra bench`: every method at its defaults on every device and
//! thread count, on the user's mesh or scene (`penumbra::bench`), written
//! to DIR/bench.{csv,json,png} with a table on stdout.

use std::path::PathBuf;

use serde_json::Value;

use crate::args::CameraArgs;
use penumbra::bench::{BenchMethod, BenchReport, BenchSettings, DeviceSet, bench, bench_devices, csv_text};
use penumbra::error::{Error, Result};
use penumbra::report::repeats::Repeats;
use penumbra::scene::View;
use penumbra::sweep::SweepInputs;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Mesh: OBJ, PLY or glTF.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh (random-rays and prt need a mesh).
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    /// Methods, comma-separated [default: every one].
    #[arg(long, value_enum, value_delimiter = ',')]
    pub methods: Vec<BenchMethod>,
    /// Devices: cpu, gpu (every GPU adapter, each apart; software ones marked) or all.
    #[arg(long, value_enum, default_value_t = DeviceSet::All)]
    pub devices: DeviceSet,
    /// CPU thread counts, comma-separated (a GPU row runs with the most) [default: all cores].
    #[arg(long, value_delimiter = ',', value_parser = crate::options::count::<usize>(1), allow_negative_numbers = true)]
    pub threads: Vec<usize>,
    /// Untimed runs of each row before the measured ones.
    #[arg(long, value_parser = crate::options::count::<u32>(0), default_value_t = 1, allow_negative_numbers = true)]
    pub warmup: u32,
    /// Measured runs of each row: min, median and max are reported.
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 5, allow_negative_numbers = true)]
    pub repeat: u32,
    /// A setting away from the defaults, METHOD.KNOB=VALUE (repeatable; the
    /// knobs are `penumbra sweep`'s, plus ao.rays, ao.radius,
    /// random-rays.rays, random-rays.accel, whitted.spp, whitted.max-depth).
    #[arg(long)]
    pub set: Vec<String>,
    /// Image width (primary, ssao, whitted, bounded).
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 400, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height (primary, ssao, whitted, bounded).
    #[arg(long, value_parser = crate::options::count::<u32>(1), default_value_t = 300, allow_negative_numbers = true)]
    pub height: u32,
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Seed of every sample sequence.
    #[arg(long, value_parser = crate::options::count::<u32>(0), default_value_t = crate::args::DEFAULT_SEED, allow_negative_numbers = true)]
    pub seed: u32,
    /// Output folder (created if missing; its parent must exist) for bench.csv, bench.json, bench.png.
    #[arg(long)]
    pub out: PathBuf,
    /// Print exactly one JSON object on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Progress lines on stderr even when it is not a terminal (a CI log).
    #[arg(long)]
    pub progress: bool,
}

impl BenchArgs {
    /// The files the bench writes.
    pub fn outputs(&self) -> [PathBuf; 3] {
        ["bench.csv", "bench.json", "bench.png"].map(|f| self.out.join(f))
    }
}

pub fn run(args: &BenchArgs) -> Result<Value> {
    crate::progress::log_when_not_a_terminal(args.progress);
    if args.mesh.is_none() && args.scene.is_none() {
        return Err(Error::param("--mesh/--scene", "one of them is needed"));
    }
    crate::files::check_out_folder(&args.out, "--out")?;
    let mut settings = BenchSettings {
        runs: Repeats {
            warmup: args.warmup,
            repeat: args.repeat,
        },
        set: args.set.clone(),
        ..BenchSettings::default()
    };
    if !args.methods.is_empty() {
        settings.methods = args.methods.clone();
    }
    if !args.threads.is_empty() {
        settings.threads = args.threads.clone();
    }
    let data_dir = crate::args::data_dir();
    let inputs = SweepInputs {
        mesh: args.mesh.as_deref(),
        scene: args.scene.as_deref(),
        receiver: None,
        view: View::new(args.camera.spec(), args.width, args.height)?,
        truth_rays: None,
        radius: None,
        seed: args.seed,
        data_dir: data_dir.as_deref(),
    };
    settings.check()?;
    let (devices, refused) = bench_devices(args.devices);
    for why in &refused {
        crate::io::note(&format!("not benched: {why}"));
    }
    if devices.is_empty() {
        return Err(Error::Device(format!("no device to bench on ({})", refused.join("; "))));
    }
    let mut report = bench(&inputs, &devices, refused, &settings, &crate::progress::stderr())?;
    // Why a row was skipped, its parameters spelled as the options typed.
    for row in &mut report.rows {
        if let Some(why) = &row.skipped {
            row.skipped = Some(penumbra::error::rename_quoted(why, crate::args::flag));
        }
    }
    let files = write_outputs(args, &report)?;
    if !args.json {
        print!("{}", table(&report));
        println!("written: {}", files.join(", "));
    }
    let mut value = serde_json::to_value(&report).map_err(|e| Error::internal(e.to_string()))?;
    value["files"] = serde_json::json!(files);
    Ok(value)
}

fn write_outputs(args: &BenchArgs, report: &BenchReport) -> Result<Vec<String>> {
    crate::files::make_out_folder(&args.out)?;
    let [csv, json, png] = args.outputs();
    penumbra::io::output::write_bytes(&csv, csv_text(report).as_bytes())?;
    crate::plot::write_bench_png(&png, report)?;
    let text = serde_json::to_string_pretty(report).map_err(|e| Error::internal(e.to_string()))?;
    penumbra::io::output::write_bytes(&json, text.as_bytes())?;
    Ok([csv, json, png].iter().map(|p| p.display().to_string()).collect())
}

/// The report as an aligned table: one line per row.
pub fn table(report: &BenchReport) -> String {
    let head = [
        "method",
        "device",
        "threads",
        "min ms",
        "median ms",
        "max ms",
        "wall ms",
        "throughput",
        "error",
        "setup ms",
    ];
    let mut lines: Vec<Vec<String>> = vec![head.iter().map(|s| s.to_string()).collect()];
    for r in &report.rows {
        let device = match r.software {
            true => format!("{} [software]", r.device),
            false => r.device.clone(),
        };
        if let Some(why) = &r.skipped {
            lines.push(vec![
                r.method.name().into(),
                device,
                r.threads.to_string(),
                format!("skipped: {why}"),
            ]);
            continue;
        }
        let setup: f64 = r.setup_ms.values().sum();
        lines.push(vec![
            r.method.name().into(),
            device,
            r.threads.to_string(),
            format!("{:.2}", r.min_ms),
            format!("{:.2}", r.median_ms),
            format!("{:.2}", r.max_ms),
            format!("{:.2}", r.wall_median_ms),
            format!("{:.2} {}", r.throughput, r.unit),
            r.error
                .map_or("-".into(), |e| format!("{e:.3e} {}", r.error_measure.unwrap_or(""))),
            format!("{setup:.0}"),
        ]);
    }
    let widths: Vec<usize> = (0..head.len())
        .map(|c| {
            lines
                .iter()
                .filter(|l| l.len() == head.len())
                .map(|l| l[c].len())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for line in &lines {
        let cells: Vec<String> = line
            .iter()
            .enumerate()
            .map(|(c, cell)| match line.len() == head.len() {
                true => format!("{cell:<w$}", w = widths[c]),
                false => cell.clone(),
            })
            .collect();
        out.push_str(cells.join("  ").trim_end());
        out.push('\n');
    }
    out
}
