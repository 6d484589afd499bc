//! Speed against accuracy on the user's own scene (`penumbra sweep`): every
//! setting of a grid of a method's knobs, timed on one device in one
//! process (best of N repeats) and compared with the method's ground truth,
//! computed once and reused; the settings no other beats on both time and
//! error form the Pareto front.
//!
//! A method takes part by implementing `SweepMethod`: its knobs with a
//! default grid, its truth, and one timed run of a setting. The adapters
//! (`field`, `ssao`, `prt`, `trace`, `bounded`) drive the library's runners,
//! never the command line.

pub mod bounded;
pub mod budget;
pub mod field;
pub mod grid;
pub mod inputs;
pub mod prt;
pub mod ssao;
pub mod trace;

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use serde_json::Value;

use crate::error::{Error, Result};
use crate::gpu::device::elapsed_ms;
use crate::progress::Reporter;
use crate::report::repeats::Repeats;

pub use grid::{Grid, Knob, Setting};
pub use inputs::{SweepInputs, SweepKind, with_method};

/// One timed run of a setting.
#[derive(Debug, Clone, Default)]
pub struct Run {
    /// The method's own timed work (see `SweepMethod::time_measure`).
    pub time_ms: f64,
    /// The error against the truth (see `SweepMethod::error_measure`).
    pub error: f64,
    /// Memory the setting's data structures take, where the method knows.
    pub memory_bytes: Option<u64>,
    /// Other phases of the run (build times, ...), reported, not compared.
    pub phases: Vec<(&'static str, f64)>,
}

/// A method the sweep can drive.
pub trait SweepMethod {
    /// The name on the command line (`sweep field`, ...).
    fn name(&self) -> &'static str;
    /// The knobs a grid may vary.
    fn knobs(&self) -> &'static [Knob];
    /// What `Run::time_ms` measures.
    fn time_measure(&self) -> &'static str;
    /// What `Run::error` measures, against which truth.
    fn error_measure(&self) -> &'static str;
    /// Checks a setting before any work (bad values are refused up front).
    fn check(&self, setting: &Setting) -> Result<()>;
    /// Computes the ground truth once; returns what describes it.
    fn truth(&mut self, bars: &Reporter) -> Result<Value>;
    /// Runs `setting` once against the truth.
    fn run(&mut self, setting: &Setting) -> Result<Run>;
}

/// One row of the sweep: a setting and what it measured.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    pub knobs: Setting,
    /// Best of the repeats.
    pub time_ms: f64,
    /// Every repeat, in order.
    pub times_ms: Vec<f64>,
    pub error: f64,
    pub memory_bytes: Option<u64>,
    /// The fastest repeat's other phases.
    pub phases: serde_json::Map<String, Value>,
    pub pareto: bool,
}

/// What `penumbra sweep --json` reports (and `sweep.json` holds).
#[derive(Debug, Clone, Serialize)]
pub struct SweepReport {
    pub method: &'static str,
    pub time_measure: &'static str,
    pub error_measure: &'static str,
    pub repeats: u32,
    /// The knobs the grid varies or fixes, in the order given.
    pub axes: Vec<String>,
    pub settings: usize,
    pub truth: Value,
    pub truth_ms: f64,
    /// Estimated before the settings ran: the first setting's time times
    /// the runs left.
    pub estimated_s: f64,
    pub sweep_ms: f64,
    /// Indices into `rows` of the Pareto front, fastest first.
    pub front: Vec<usize>,
    pub rows: Vec<Row>,
    pub files: Vec<String>,
}

/// Runs every setting of `grid` `repeats` times against the truth.
/// Each setting first runs `runs.warmup` untimed times.
pub fn sweep(method: &mut dyn SweepMethod, grid: &Grid, runs: Repeats, bars: &Reporter) -> Result<SweepReport> {
    let repeats = runs.repeat;
    if repeats == 0 || repeats > 100 {
        return Err(Error::param(
            "repeat",
            format!("must be between 1 and 100, got {repeats}"),
        ));
    }
    let settings = grid.settings();
    for s in &settings {
        method.check(s)?;
    }
    let start = Instant::now();
    let truth = method.truth(bars)?;
    let truth_ms = elapsed_ms(start);
    let sweep_start = Instant::now();
    let mut rows: Vec<Row> = Vec::with_capacity(settings.len());
    let mut estimated_s = 0.0;
    let progress = bars.bar(settings.len() as u64 * repeats as u64, "sweep");
    for (i, setting) in settings.iter().enumerate() {
        for _ in 0..runs.warmup {
            method.run(setting)?;
        }
        let mut runs = Vec::with_capacity(repeats as usize);
        for _ in 0..repeats {
            let run_start = Instant::now();
            runs.push(method.run(setting)?);
            progress.inc(1);
            if i == 0 && runs.len() == 1 {
                let runs_left = (settings.len() * repeats as usize - 1) as f64;
                estimated_s = elapsed_ms(run_start) * runs_left / 1e3;
                bars.note(&format!(
                    "sweep: {} settings x {repeats} repeats; about {estimated_s:.0} s more (as the first run took)",
                    settings.len()
                ));
            }
        }
        rows.push(row(setting, runs));
    }
    progress.finish();
    let front = pareto_front(&rows);
    for &i in &front {
        rows[i].pareto = true;
    }
    Ok(SweepReport {
        method: method.name(),
        time_measure: method.time_measure(),
        error_measure: method.error_measure(),
        repeats,
        axes: grid.axes.iter().map(|(name, _)| name.clone()).collect(),
        settings: rows.len(),
        truth,
        truth_ms,
        estimated_s,
        sweep_ms: elapsed_ms(sweep_start),
        front,
        rows,
        files: Vec::new(),
    })
}

/// A setting's row from its repeats: the fastest time and its phases; the
/// error of the first (repeats compute the same answer).
fn row(setting: &Setting, runs: Vec<Run>) -> Row {
    let best = runs
        .iter()
        .min_by(|a, b| a.time_ms.total_cmp(&b.time_ms))
        .expect("at least one repeat");
    let phases = best
        .phases
        .iter()
        .map(|(k, v)| (k.to_string(), Value::from(*v)))
        .collect();
    Row {
        knobs: setting.clone(),
        time_ms: best.time_ms,
        times_ms: runs.iter().map(|r| r.time_ms).collect(),
        error: runs[0].error,
        memory_bytes: best.memory_bytes,
        phases,
        pareto: false,
    }
}

/// Rows no other row beats on both time and error (one at least as good on
/// both and better on one), ordered by time.
pub fn pareto_front(rows: &[Row]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..rows.len()).collect();
    order.sort_by(|&a, &b| {
        rows[a]
            .time_ms
            .total_cmp(&rows[b].time_ms)
            .then(rows[a].error.total_cmp(&rows[b].error))
    });
    // Sweeping by time, a row is on the front when its error is below every
    // faster row's.
    let mut front = Vec::new();
    let mut best_error = f64::INFINITY;
    for i in order {
        if rows[i].error < best_error {
            best_error = rows[i].error;
            front.push(i);
        }
    }
    front
}

/// The files a sweep writes into `dir`.
pub fn output_files(dir: &Path) -> [PathBuf; 3] {
    ["sweep.csv", "sweep.json", "sweep.png"].map(|f| dir.join(f))
}

/// A header row (the knobs, time_ms, error, memory_bytes, pareto), then one
/// row per setting.
pub fn csv_text(report: &SweepReport) -> String {
    let knobs: Vec<&String> = report
        .rows
        .first()
        .map(|r| r.knobs.0.keys().collect())
        .unwrap_or_default();
    let mut text = String::new();
    for k in &knobs {
        text += &format!("{k},");
    }
    text += "time_ms,error,memory_bytes,pareto\n";
    for r in &report.rows {
        for k in &knobs {
            text += &format!("{},", csv_field(&r.knobs.0[*k]));
        }
        let memory = r.memory_bytes.map_or(String::new(), |m| m.to_string());
        text += &format!("{},{},{memory},{}\n", r.time_ms, r.error, r.pareto);
    }
    text
}

/// Quotes a value holding a comma or quote, as RFC 4180 does.
fn csv_field(v: &str) -> String {
    if v.contains([',', '"', '\n']) {
        format!("\"{}\"", v.replace('"', "\"\""))
    } else {
        v.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(time_ms: f64, error: f64) -> Row {
        Row {
            knobs: Setting(Default::default()),
            time_ms,
            times_ms: vec![time_ms],
            error,
            memory_bytes: None,
            phases: Default::default(),
            pareto: false,
        }
    }

    #[test]
    fn the_front_keeps_only_unbeaten_settings() {
        let rows = [
            row(10.0, 0.5),
            row(20.0, 0.1),
            row(15.0, 0.6), // beaten by the first
            row(30.0, 0.1), // as accurate as the second, slower
            row(40.0, 0.01),
            row(10.0, 0.7), // as fast as the first, worse
        ];
        assert_eq!(pareto_front(&rows), vec![0, 1, 4]);
    }

    #[test]
    fn csv_has_a_header_and_one_row_per_setting() {
        let mut r = row(1.5, 0.25);
        r.knobs.0.insert("spp".into(), "8".into());
        r.knobs.0.insert("estimator".into(), "a,b".into());
        r.pareto = true;
        let report = SweepReport {
            method: "ssao",
            time_measure: "",
            error_measure: "",
            repeats: 1,
            axes: vec!["estimator".into(), "spp".into()],
            settings: 1,
            truth: Value::Null,
            truth_ms: 0.0,
            estimated_s: 0.0,
            sweep_ms: 0.0,
            front: vec![0],
            rows: vec![r],
            files: vec![],
        };
        assert_eq!(
            csv_text(&report),
            "estimator,spp,time_ms,error,memory_bytes,pareto\n\"a,b\",8,1.5,0.25,,true\n"
        );
    }
}
