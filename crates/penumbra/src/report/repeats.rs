//! Warm-up and measured runs: runs a benchmarker can trust. Warm-up runs
//! are untimed (caches, lazily compiled pipelines, CPU clocks settle);
//! the measured runs give min, median and max of the run's own timed work
//! (pipeline compilation is reported apart, in the device's `pipelines`).
//! The last run's results are the outputs.

use serde::Serialize;

use crate::error::Result;

/// Most warm-up or measured runs.
pub const MAX_RUNS: u32 = 1000;

/// How many untimed and measured runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Repeats {
    /// Untimed runs before the measured ones (at most [`MAX_RUNS`]).
    pub warmup: u32,
    /// Measured runs (1 to [`MAX_RUNS`]; [`Repeats::run`] runs at least one).
    pub repeat: u32,
}

impl Default for Repeats {
    fn default() -> Self {
        Repeats { warmup: 0, repeat: 1 }
    }
}

/// The measured runs' times (the JSON's `runs`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunTimes {
    /// Which time: the report's field the runs measure.
    pub measure: &'static str,
    /// Untimed warm-up runs made before the measured ones.
    pub warmup: u32,
    /// Measured runs: the length of `ms`.
    pub repeat: u32,
    /// Fastest measured run, in milliseconds (NaN when none was measured).
    pub min_ms: f64,
    /// Median of the measured runs, in milliseconds: the mean of the middle
    /// two for an even count (NaN when none was measured).
    pub median_ms: f64,
    /// Slowest measured run, in milliseconds (NaN when none was measured).
    pub max_ms: f64,
    /// Every measured run's time, in order.
    pub ms: Vec<f64>,
}

impl RunTimes {
    /// The statistics of `ms` (at least one time).
    pub fn of(measure: &'static str, warmup: u32, ms: Vec<f64>) -> RunTimes {
        let mut sorted = ms.clone();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let median = match n {
            0 => f64::NAN,
            _ if n % 2 == 1 => sorted[n / 2],
            _ => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
        };
        RunTimes {
            measure,
            warmup,
            repeat: n as u32,
            min_ms: sorted.first().copied().unwrap_or(f64::NAN),
            median_ms: median,
            max_ms: sorted.last().copied().unwrap_or(f64::NAN),
            ms,
        }
    }
}

impl Repeats {
    /// Runs `once` warm-up plus measured times; `ms` reads a run's time of
    /// `measure`. Returns the last run's result and the measured times.
    pub fn run<T>(
        &self,
        measure: &'static str,
        mut once: impl FnMut() -> Result<T>,
        ms: impl Fn(&T) -> f64,
    ) -> Result<(T, RunTimes)> {
        for _ in 0..self.warmup {
            once()?;
        }
        let mut times = Vec::with_capacity(self.repeat as usize);
        let mut last = None;
        for _ in 0..self.repeat.max(1) {
            let result = once()?;
            times.push(ms(&result));
            last = Some(result);
        }
        let last = last.expect("at least one measured run");
        Ok((last, RunTimes::of(measure, self.warmup, times)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_of_odd_and_even_counts() {
        let t = RunTimes::of("x", 2, vec![5.0, 1.0, 3.0]);
        assert_eq!((t.min_ms, t.median_ms, t.max_ms, t.repeat), (1.0, 3.0, 5.0, 3));
        let t = RunTimes::of("x", 0, vec![4.0, 1.0, 3.0, 2.0]);
        assert_eq!((t.min_ms, t.median_ms, t.max_ms), (1.0, 2.5, 4.0));
        assert_eq!(t.ms, vec![4.0, 1.0, 3.0, 2.0], "runs keep their order");
    }

    #[test]
    fn warmup_runs_are_run_but_not_measured() {
        let runs = Repeats { warmup: 2, repeat: 3 };
        let mut calls = 0;
        let (last, times) = runs
            .run(
                "x",
                || {
                    calls += 1;
                    Ok(calls)
                },
                |&c| c as f64,
            )
            .unwrap();
        assert_eq!((calls, last), (5, 5));
        assert_eq!(times.ms, vec![3.0, 4.0, 5.0]);
    }
}
