//! Speed against accuracy: every setting of a grid of a method's knobs,
//! timed on one device in one process (best of N repeats) and compared
//! with the method's ground truth, computed once and reused; the settings
//! no other beats on both time and error form the Pareto front.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use serde_json::Value;

use super::Tunable;
use super::grid::Grid;
use super::knob::Setting;
use crate::error::{Error, Result};
use crate::gpu::device::elapsed_ms;
use crate::progress::Reporter;
use crate::report::repeats::Repeats;

/// One timed run of a setting.
#[derive(Debug, Clone, Default)]
pub struct Run {
    /// The method's own timed work (see [`Sweep::time_measure`]).
    pub time_ms: f64,
    /// The error against the truth (see [`Sweep::error_measure`]).
    pub error: f64,
    /// Memory the setting's data structures take, where the method knows.
    pub memory_bytes: Option<u64>,
    /// Other phases of the run (build times, ...), reported, not compared.
    pub phases: Vec<(&'static str, f64)>,
}

/// A method a sweep drives: its truth, and one timed run of a setting.
pub trait Sweep: Tunable {
    /// What [`Run::time_ms`] measures.
    fn time_measure(&self) -> &'static str;
    /// What [`Run::error`] measures, against which truth.
    fn error_measure(&self) -> &'static str;
    /// Checks a setting before any work (values the method refuses are
    /// refused up front).
    fn check(&self, setting: &Setting) -> Result<()>;
    /// Computes the ground truth once; returns what describes it.
    fn truth(&mut self, bars: &Reporter) -> Result<Value>;
    /// Runs `setting` once against the truth.
    fn run(&mut self, setting: &Setting) -> Result<Run>;
}

/// One row of the sweep: a setting and what it measured.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// The setting.
    pub knobs: Setting,
    /// Best of the repeats.
    pub time_ms: f64,
    /// Every repeat, in order.
    pub times_ms: Vec<f64>,
    /// The error against the truth.
    pub error: f64,
    /// Memory the setting's data structures take, where the method knows.
    pub memory_bytes: Option<u64>,
    /// The fastest repeat's other phases.
    pub phases: serde_json::Map<String, Value>,
    /// On the Pareto front.
    pub pareto: bool,
}

/// What a sweep reports (`penumbra sweep --json`, `sweep.json`).
#[derive(Debug, Clone, Serialize)]
pub struct SweepReport {
    /// The method's name.
    pub method: &'static str,
    /// What the times measure.
    pub time_measure: &'static str,
    /// What the errors measure.
    pub error_measure: &'static str,
    /// Timed runs per setting.
    pub repeats: u32,
    /// The knobs the grid varies or fixes, in the order given.
    pub axes: Vec<String>,
    /// How many settings ran.
    pub settings: usize,
    /// What describes the truth.
    pub truth: Value,
    /// What the truth cost, ms.
    pub truth_ms: f64,
    /// Estimated before the settings ran: the first setting's time times
    /// the runs left.
    pub estimated_s: f64,
    /// What the settings' runs cost, ms.
    pub sweep_ms: f64,
    /// Indices into `rows` of the Pareto front, fastest first.
    pub front: Vec<usize>,
    /// One row per setting, in the grid's order.
    pub rows: Vec<Row>,
    /// The files the report was written to (the caller's to fill).
    pub files: Vec<String>,
}

/// Runs every setting of `grid` `runs.repeat` times against the truth,
/// after `runs.warmup` untimed runs each; rows in the grid's order, the
/// Pareto front marked.
pub fn sweep(method: &mut dyn Sweep, grid: &Grid, runs: Repeats, bars: &Reporter) -> Result<SweepReport> {
    let all: Vec<usize> = (0..grid.settings().len()).collect();
    let part = sweep_settings(method, grid, runs, &all, bars, |_, _| Ok(()))?;
    let rows = part.rows.into_iter().map(|(_, r)| r).collect();
    let totals = SweepTotals {
        truth: part.truth,
        truth_ms: part.truth_ms,
        estimated_s: part.estimated_s,
        sweep_ms: part.sweep_ms,
    };
    Ok(sweep_report(method, grid, runs.repeat, totals, rows))
}

/// What the settings `sweep_settings` ran measured, with the truth they
/// were measured against.
#[derive(Debug, Clone)]
pub struct SweepPart {
    /// What describes the truth.
    pub truth: Value,
    /// What the truth cost, ms.
    pub truth_ms: f64,
    /// The first setting's time times the runs left, seconds.
    pub estimated_s: f64,
    /// What the settings' runs cost, ms.
    pub sweep_ms: f64,
    /// Each setting's index in `Grid::settings` and its row, Pareto
    /// front not marked.
    pub rows: Vec<(usize, Row)>,
}

/// The report-wide figures of a sweep (`SweepReport`'s fields that are
/// not rows).
#[derive(Debug, Clone)]
pub struct SweepTotals {
    /// See [`SweepReport::truth`].
    pub truth: Value,
    /// See [`SweepReport::truth_ms`].
    pub truth_ms: f64,
    /// See [`SweepReport::estimated_s`].
    pub estimated_s: f64,
    /// See [`SweepReport::sweep_ms`].
    pub sweep_ms: f64,
}

/// Runs the settings `which` (indices into `grid.settings()`, each checked
/// first) against the truth, computed once here: a shard of a sweep runs
/// its settings this way, `done` recording each row as it is measured.
pub fn sweep_settings(
    method: &mut dyn Sweep,
    grid: &Grid,
    runs: Repeats,
    which: &[usize],
    bars: &Reporter,
    mut done: impl FnMut(usize, &Row) -> Result<()>,
) -> Result<SweepPart> {
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
    if let Some(&i) = which.iter().find(|&&i| i >= settings.len()) {
        return Err(Error::internal(format!("setting {i} of {}", settings.len())));
    }
    let start = Instant::now();
    let truth = method.truth(bars)?;
    let truth_ms = elapsed_ms(start);
    let sweep_start = Instant::now();
    let mut rows: Vec<(usize, Row)> = Vec::with_capacity(which.len());
    let mut estimated_s = 0.0;
    let progress = bars.bar(which.len() as u64 * repeats as u64, "sweep");
    for (k, &i) in which.iter().enumerate() {
        let setting = &settings[i];
        for _ in 0..runs.warmup {
            method.run(setting)?;
        }
        let mut runs = Vec::with_capacity(repeats as usize);
        for _ in 0..repeats {
            let run_start = Instant::now();
            runs.push(method.run(setting)?);
            progress.inc(1);
            if k == 0 && runs.len() == 1 {
                let runs_left = (which.len() * repeats as usize - 1) as f64;
                estimated_s = elapsed_ms(run_start) * runs_left / 1e3;
                bars.note(&format!(
                    "sweep: {} settings x {repeats} repeats; about {estimated_s:.0} s more (as the first run took)",
                    which.len()
                ));
            }
        }
        let row = row(setting, runs);
        done(i, &row)?;
        rows.push((i, row));
    }
    progress.finish();
    Ok(SweepPart {
        truth,
        truth_ms,
        estimated_s,
        sweep_ms: elapsed_ms(sweep_start),
        rows,
    })
}

/// The report of `rows` (one per setting of `grid`, in its order), the
/// Pareto front marked: what `sweep` returns, and what the rows of a
/// sweep's shards merge into.
pub fn sweep_report(
    method: &dyn Sweep,
    grid: &Grid,
    repeats: u32,
    totals: SweepTotals,
    mut rows: Vec<Row>,
) -> SweepReport {
    for r in &mut rows {
        r.pareto = false;
    }
    let front = pareto_front(&rows);
    for &i in &front {
        rows[i].pareto = true;
    }
    SweepReport {
        method: method.name(),
        time_measure: method.time_measure(),
        error_measure: method.error_measure(),
        repeats,
        axes: grid.axes.iter().map(|(name, _)| name.to_string()).collect(),
        settings: rows.len(),
        truth: totals.truth,
        truth_ms: totals.truth_ms,
        estimated_s: totals.estimated_s,
        sweep_ms: totals.sweep_ms,
        front,
        rows,
        files: Vec::new(),
    }
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

/// The files a sweep writes into `dir`: `sweep.csv`, `sweep.json`,
/// `sweep.png`.
pub fn output_files(dir: &Path) -> [PathBuf; 3] {
    ["sweep.csv", "sweep.json", "sweep.png"].map(|f| dir.join(f))
}

/// A header row (the knobs, time_ms, error, memory_bytes, pareto), then one
/// row per setting.
pub fn csv_text(report: &SweepReport) -> String {
    let knobs: Vec<&str> = report
        .rows
        .first()
        .map(|r| r.knobs.texts().map(|(k, _)| k).collect())
        .unwrap_or_default();
    let mut text = String::new();
    for k in &knobs {
        text += &format!("{k},");
    }
    text += "time_ms,error,memory_bytes,pareto\n";
    for r in &report.rows {
        for k in &knobs {
            text += &format!("{},", csv_field(r.knobs.text(k).unwrap_or_default()));
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
    use crate::tune::knob::{Given, Knob};

    fn row(time_ms: f64, error: f64) -> Row {
        Row {
            knobs: Setting::default(),
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
        assert!(pareto_front(&[]).is_empty());
    }

    fn report(rows: Vec<Row>) -> SweepReport {
        SweepReport {
            method: "test",
            time_measure: "",
            error_measure: "",
            repeats: 1,
            axes: vec![],
            settings: rows.len(),
            truth: Value::Null,
            truth_ms: 0.0,
            estimated_s: 0.0,
            sweep_ms: 0.0,
            front: vec![],
            rows,
            files: vec![],
        }
    }

    #[test]
    fn csv_has_a_header_and_one_row_per_setting() {
        let name = Knob::new::<f64>("name", "", &[]);
        let mut r = row(1.5, 0.25);
        // A text with a comma cannot come from a grid; a host may build one.
        let odd = Given {
            value: crate::tune::KnobValue::Float(1.0),
            text: "a,b".into(),
        };
        r.knobs = Setting::default().with("spp", 8u32).with_given(name.name, odd);
        r.pareto = true;
        assert_eq!(
            csv_text(&report(vec![r])),
            "name,spp,time_ms,error,memory_bytes,pareto\n\"a,b\",8,1.5,0.25,,true\n"
        );
        assert_eq!(csv_text(&report(vec![])), "time_ms,error,memory_bytes,pareto\n");
    }

    /// A method whose error is 1/spp and whose time is spp ms (as it says).
    struct Fake {
        truths: u32,
        runs: Vec<u32>,
    }

    const KNOBS: [Knob; 1] = [Knob::new::<u32>("spp", "samples", &["1", "2", "4"])];

    impl Tunable for Fake {
        fn name(&self) -> &'static str {
            "fake"
        }
        fn knobs(&self) -> &'static [Knob] {
            &KNOBS
        }
    }

    impl Sweep for Fake {
        fn time_measure(&self) -> &'static str {
            "spp"
        }
        fn error_measure(&self) -> &'static str {
            "1/spp"
        }
        fn check(&self, setting: &Setting) -> Result<()> {
            match setting.get::<u32>("spp") {
                Some(0) => Err(Error::param("spp", "must be at least 1")),
                _ => Ok(()),
            }
        }
        fn truth(&mut self, _bars: &Reporter) -> Result<Value> {
            self.truths += 1;
            Ok(Value::from("exact"))
        }
        fn run(&mut self, setting: &Setting) -> Result<Run> {
            let spp = setting.get::<u32>("spp").unwrap();
            self.runs.push(spp);
            Ok(Run {
                time_ms: spp as f64,
                error: 1.0 / spp as f64,
                memory_bytes: None,
                phases: vec![("other_ms", 1.0)],
            })
        }
    }

    #[test]
    fn a_sweep_runs_every_setting_after_checking_them_all() {
        let mut fake = Fake {
            truths: 0,
            runs: vec![],
        };
        let grid = Grid::parse(&[], &KNOBS).unwrap();
        let runs = Repeats { repeat: 2, warmup: 1 };
        let report = sweep(&mut fake, &grid, runs, &Reporter::silent()).unwrap();
        assert_eq!(fake.truths, 1);
        assert_eq!(fake.runs, [1, 1, 1, 2, 2, 2, 4, 4, 4], "a warm-up, then two repeats");
        assert_eq!(
            (report.settings, report.repeats, report.axes.clone()),
            (3, 2, vec!["spp".to_string()])
        );
        assert_eq!(report.front, [0, 1, 2], "each slower setting is more accurate");
        assert_eq!(report.rows[1].times_ms, [2.0, 2.0]);
        assert_eq!(report.truth, Value::from("exact"));
        let zero = Grid::parse(&["spp=4,0".into()], &KNOBS).unwrap();
        let e = sweep(&mut fake, &zero, runs, &Reporter::silent()).unwrap_err();
        assert_eq!(e, Error::param("spp", "must be at least 1"));
        assert_eq!(fake.truths, 1, "no work before every setting is checked");
        let none = Repeats { repeat: 0, warmup: 0 };
        let e = sweep(&mut fake, &grid, none, &Reporter::silent()).unwrap_err();
        assert_eq!(e, Error::param("repeat", "must be between 1 and 100, got 0"));
    }
}
