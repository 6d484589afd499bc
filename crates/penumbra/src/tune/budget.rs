//! Error budgets (`max_error` E): the fastest of a method's candidate
//! settings whose error, estimated on a random sample of the user's scene
//! against the method's truth, is within E with 95% confidence. A method
//! supplies its candidates, runs each on its sample ([`Budgeted`]); this
//! module turns sampled errors into an estimate with its bound, goes
//! through the candidates, picks, and remembers the pick per scene
//! (content hash) so a second run pays nothing.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::Tunable;
use super::knob::{Knob, Setting};
use crate::error::{Error, Result};
use crate::gpu::device::elapsed_ms;
use crate::progress::Reporter;

/// The one-sided 95% normal quantile: the bound is the estimate plus this
/// many standard errors.
pub const Z95: f64 = 1.645;

/// An error estimated from a sample, with an upper bound at 95% confidence.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SampleError {
    /// The error the sample estimates.
    pub estimate: f64,
    /// The estimate's one-sided 95% upper confidence bound.
    pub upper: f64,
    /// How many samples it was estimated on.
    pub samples: usize,
}

impl SampleError {
    /// The root of the mean of `squares` (per-sample squared errors), with
    /// the bound from the mean's standard error.
    pub fn rms(squares: &[f64]) -> SampleError {
        let (mean, se) = mean_and_se(squares);
        SampleError {
            estimate: mean.max(0.0).sqrt(),
            upper: (mean + Z95 * se).max(0.0).sqrt(),
            samples: squares.len(),
        }
    }

    /// The mean of per-sample errors, with the bound from its standard error.
    pub fn mean(errors: &[f64]) -> SampleError {
        let (mean, se) = mean_and_se(errors);
        SampleError {
            estimate: mean,
            upper: mean + Z95 * se,
            samples: errors.len(),
        }
    }
}

fn mean_and_se(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, (var / n).sqrt())
}

/// One candidate tried: its setting, time and sampled error. `S` is the
/// setting's form: typed ([`Setting`]), or its texts as a cache stores them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate<S = Setting> {
    /// The candidate's knobs.
    pub knobs: S,
    /// The method's timed phase on the full problem, ms.
    pub time_ms: f64,
    /// Its error on the sample.
    pub error: SampleError,
    /// The bound is within the budget.
    pub within: bool,
}

/// What a budget chose and why (the JSON's `max_error` object). `S` as
/// in [`Candidate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pick<S = Setting> {
    /// The budget.
    pub max_error: f64,
    /// What the error measures (the method's own full comparison).
    pub measure: String,
    /// The confidence of the bounds (0.95).
    pub confidence: f64,
    /// The setting chosen.
    pub chosen: S,
    /// Its estimated error.
    pub estimate: f64,
    /// Its error's bound.
    pub upper: f64,
    /// The samples its error was estimated on.
    pub samples: usize,
    /// Whether a candidate was within the budget (else the most accurate
    /// one tried was chosen, with a warning).
    pub met: bool,
    /// Every candidate tried, in order.
    pub candidates: Vec<Candidate<S>>,
    /// What the check cost: sample truth and candidate runs, ms (for fields,
    /// the chosen fields' build too, which the run then reuses).
    pub check_ms: f64,
    /// Read from the cache: the check did not run again.
    pub cached: bool,
}

impl Pick {
    /// What a user is told of the pick (with `max_error` named in
    /// backticks, for the caller's spelling): the setting, its error and
    /// bound, and a warning when no setting met the budget.
    pub fn notes(&self) -> Vec<String> {
        let how = if self.cached { "cached" } else { "checked" };
        let mut notes = vec![format!(
            "`max_error` {}: {} (error {:.4}, at most {:.4} at 95% confidence; {how}, {:.0} ms)",
            self.max_error,
            self.chosen.label(),
            self.estimate,
            self.upper,
            self.check_ms
        )];
        if !self.met {
            notes.push(format!(
                "warning: no setting tried is within `max_error` {}; using the most accurate one",
                self.max_error
            ));
        }
        notes
    }

    /// The fastest candidate within `max_error`, else the one with the
    /// smallest bound (the first of equals); `None` with no candidates.
    pub fn of(max_error: f64, measure: &str, mut candidates: Vec<Candidate>, check_ms: f64) -> Option<Pick> {
        for c in &mut candidates {
            c.within = c.error.upper <= max_error;
        }
        let fastest_within = candidates
            .iter()
            .filter(|c| c.within)
            .min_by(|a, b| a.time_ms.total_cmp(&b.time_ms));
        let best =
            fastest_within.or_else(|| candidates.iter().min_by(|a, b| a.error.upper.total_cmp(&b.error.upper)))?;
        Some(Pick {
            max_error,
            measure: measure.to_string(),
            confidence: 0.95,
            chosen: best.knobs.clone(),
            estimate: best.error.estimate,
            upper: best.error.upper,
            samples: best.error.samples,
            met: best.within,
            candidates: candidates.clone(),
            check_ms,
            cached: false,
        })
    }
}

/// A setting's texts, as a cache stores them.
type Texts = BTreeMap<String, String>;

impl Pick<Texts> {
    /// The pick with its settings read over `knobs`; `None` where one does
    /// not read (a cache written for other knobs).
    fn read(self, knobs: &[Knob]) -> Option<Pick> {
        let candidates = self
            .candidates
            .into_iter()
            .map(|c| {
                Some(Candidate {
                    knobs: Setting::read(&c.knobs, knobs)?,
                    time_ms: c.time_ms,
                    error: c.error,
                    within: c.within,
                })
            })
            .collect::<Option<_>>()?;
        Some(Pick {
            max_error: self.max_error,
            measure: self.measure,
            confidence: self.confidence,
            chosen: Setting::read(&self.chosen, knobs)?,
            estimate: self.estimate,
            upper: self.upper,
            samples: self.samples,
            met: self.met,
            candidates,
            check_ms: self.check_ms,
            cached: self.cached,
        })
    }
}

/// How a budget goes through its candidates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Order {
    /// Every candidate runs; the fastest within the budget wins.
    All,
    /// Candidates run in order, cheapest first, until one is within the
    /// budget (it wins) or the check has taken `limit_ms` (no candidate
    /// starts after that).
    CheapestFirst {
        /// The check's time limit, ms.
        limit_ms: f64,
    },
}

/// A method whose knobs a budget chooses: its candidates, each run on a
/// sample against the method's truth.
pub trait Budgeted: Tunable {
    /// What the error measures (the method's own full comparison).
    fn measure(&self) -> String;
    /// How the candidates are gone through.
    fn order(&self) -> Order {
        Order::All
    }
    /// Computes what the candidates are compared with (the sample and its
    /// truth), once, before any candidate runs.
    fn sample_truth(&mut self, bars: &Reporter) -> Result<()>;
    /// The candidate settings, in the order they are tried.
    fn candidates(&self) -> Vec<Setting>;
    /// Runs `setting` once: its time (ms) and its error on the sample.
    fn try_candidate(&mut self, setting: &Setting) -> Result<(f64, SampleError)>;
}

/// Chooses among `method`'s candidates for `max_error`: the truth on the
/// sample, then the candidates as its [`Order`] says, then [`Pick::of`].
pub fn choose(method: &mut dyn Budgeted, max_error: f64, bars: &Reporter) -> Result<Pick> {
    if !(max_error > 0.0 && max_error.is_finite()) {
        return Err(Error::param("max_error", format!("must be positive, got {max_error}")));
    }
    let start = Instant::now();
    method.sample_truth(bars)?;
    let candidates = method.candidates();
    let order = method.order();
    let progress = bars.bar(candidates.len() as u64, "max-error check");
    let mut tried = Vec::with_capacity(candidates.len());
    for knobs in candidates {
        if let Order::CheapestFirst { limit_ms } = order
            && elapsed_ms(start) > limit_ms
        {
            break;
        }
        let (time_ms, error) = method.try_candidate(&knobs)?;
        let within = error.upper <= max_error;
        tried.push(Candidate {
            knobs,
            time_ms,
            error,
            within,
        });
        progress.inc(1);
        if within && order != Order::All {
            break;
        }
    }
    progress.finish();
    Pick::of(max_error, &method.measure(), tried, elapsed_ms(start))
        .ok_or_else(|| Error::internal(format!("no {} candidate", method.name())))
}

/// An error budget (`max_error`) and where the picks it led to are
/// remembered (`cache_dir`; `None`: nowhere, every run checks again).
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorBudget {
    /// The largest error a setting may have, in the method's measure.
    pub max_error: f64,
    /// The folder of the choice cache (`max-error-choices.json`).
    pub cache_dir: Option<PathBuf>,
}

impl ErrorBudget {
    /// A budget whose picks are not remembered.
    pub fn new(max_error: f64) -> ErrorBudget {
        ErrorBudget {
            max_error,
            cache_dir: None,
        }
    }
}

/// [`choose`] through the budget's cache: the pick stored under the key of
/// `method`'s name, `options` (the canonical text of every option that
/// changes the answer) and `files`' contents when the cache holds one, else
/// checked and stored there. A cache that cannot be written is a note to
/// `bars`, not an error.
pub fn choose_cached(
    method: &mut dyn Budgeted,
    (options, files): (&str, &[&Path]),
    budget: &ErrorBudget,
    bars: &Reporter,
) -> Result<Pick> {
    let key = cache_key(method.name(), options, files)?;
    let cache = budget.cache_dir.as_deref().map(ChoiceCache::in_dir);
    if let Some(pick) = cache.as_ref().and_then(|c| c.get(&key, method.knobs())) {
        return Ok(pick);
    }
    let pick = choose(method, budget.max_error, bars)?;
    if let Some(Err(e)) = cache.map(|c| c.put(&key, &pick)) {
        bars.note(&format!("note: the `max_error` choice is not cached: {e}"));
    }
    Ok(pick)
}

/// A cache key: the method, the options' canonical text and the contents
/// of `files` (CRC-32 and length of each).
pub fn cache_key(method: &str, options: &str, files: &[&Path]) -> Result<String> {
    let mut key = format!("{method}|{options}");
    for f in files {
        let bytes = std::fs::read(f).map_err(|e| Error::read(f, e))?;
        key += &format!("|{:08x}:{}", crc32fast::hash(&bytes), bytes.len());
    }
    Ok(key)
}

/// Picks remembered per scene: a JSON file of key -> pick. The key hashes
/// the scene's files' contents and every option that changes the answer,
/// so an edited mesh or another option checks again.
pub struct ChoiceCache {
    path: PathBuf,
}

impl ChoiceCache {
    /// The cache `max-error-choices.json` in `dir`.
    pub fn in_dir(dir: &Path) -> ChoiceCache {
        ChoiceCache {
            path: dir.join("max-error-choices.json"),
        }
    }

    fn read(&self) -> serde_json::Map<String, serde_json::Value> {
        std::fs::read(&self.path)
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default()
    }

    /// The pick stored under `key`, its settings read over `knobs` (a
    /// damaged or missing cache, or one whose settings do not read, is
    /// empty).
    pub fn get(&self, key: &str, knobs: &[Knob]) -> Option<Pick> {
        let stored: Pick<Texts> = serde_json::from_value(self.read().get(key)?.clone()).ok()?;
        let mut pick = stored.read(knobs)?;
        pick.cached = true;
        Some(pick)
    }

    /// Stores `pick` under `key`. A cache that cannot be written costs the
    /// next run a check, nothing else: the error is for a note.
    pub fn put(&self, key: &str, pick: &Pick) -> Result<()> {
        let mut all = self.read();
        all.insert(
            key.to_string(),
            serde_json::to_value(pick).map_err(|e| Error::internal(e.to_string()))?,
        );
        if let Some(dir) = self.path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
        }
        let text = serde_json::to_string(&all).map_err(|e| Error::internal(e.to_string()))?;
        crate::io::output::write_bytes(&self.path, text.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KNOBS: [Knob; 1] = [Knob::new::<u32>("spp", "", &[])];

    fn candidate(spp: u32, time_ms: f64, squares: &[f64]) -> Candidate {
        Candidate {
            knobs: Setting::default().with("spp", spp),
            time_ms,
            error: SampleError::rms(squares),
            within: false,
        }
    }

    #[test]
    fn the_bound_covers_the_estimate_and_shrinks_with_samples() {
        let few = SampleError::rms(&[0.01, 0.03, 0.02, 0.04]);
        let many = SampleError::rms(&[0.01, 0.03, 0.02, 0.04].repeat(100));
        assert!((few.estimate - 0.025f64.sqrt()).abs() < 1e-12);
        assert!(few.upper > few.estimate && many.upper > many.estimate);
        assert!(many.upper < few.upper);
        let constant = SampleError::mean(&[0.5; 10]);
        assert_eq!((constant.estimate, constant.upper), (0.5, 0.5));
    }

    #[test]
    fn the_fastest_within_the_budget_wins_else_the_most_accurate() {
        let c = vec![
            candidate(4, 1.0, &[0.04; 8]),    // 0.2: over
            candidate(16, 5.0, &[0.0025; 8]), // 0.05: within
            candidate(8, 3.0, &[0.0025; 8]),  // within and faster
        ];
        let pick = Pick::of(0.1, "rmse", c.clone(), 2.0).unwrap();
        assert_eq!(pick.chosen.get::<u32>("spp"), Some(8));
        assert!(pick.met);
        assert_eq!(pick.candidates.iter().filter(|c| c.within).count(), 2);
        let strict = Pick::of(0.01, "rmse", c, 2.0).unwrap();
        assert!(!strict.met);
        assert_eq!(strict.chosen.get::<u32>("spp"), Some(16), "smallest bound, then first");
        assert!(Pick::of(0.1, "rmse", vec![], 0.0).is_none());
    }

    /// A budget over made-up candidates: spp n costs n ms and has error 1/n.
    struct Fake {
        truths: u32,
        tried: Vec<u32>,
        order: Order,
    }

    impl Tunable for Fake {
        fn name(&self) -> &'static str {
            "fake"
        }
        fn knobs(&self) -> &'static [Knob] {
            &KNOBS
        }
    }

    impl Budgeted for Fake {
        fn measure(&self) -> String {
            "1/spp".into()
        }
        fn order(&self) -> Order {
            self.order
        }
        fn sample_truth(&mut self, _bars: &Reporter) -> Result<()> {
            self.truths += 1;
            Ok(())
        }
        fn candidates(&self) -> Vec<Setting> {
            [4u32, 8, 16, 32].map(|n| Setting::default().with("spp", n)).to_vec()
        }
        fn try_candidate(&mut self, setting: &Setting) -> Result<(f64, SampleError)> {
            let n = setting.get::<u32>("spp").unwrap();
            self.tried.push(n);
            Ok((n as f64, SampleError::mean(&[1.0 / n as f64; 4])))
        }
    }

    fn fake(order: Order) -> Fake {
        Fake {
            truths: 0,
            tried: vec![],
            order,
        }
    }

    #[test]
    fn a_budget_tries_every_candidate_or_stops_at_the_first_within() {
        let mut all = fake(Order::All);
        let pick = choose(&mut all, 0.1, &Reporter::silent()).unwrap();
        assert_eq!((all.truths, &all.tried[..]), (1, &[4, 8, 16, 32][..]));
        assert_eq!(pick.chosen.get::<u32>("spp"), Some(16), "the fastest within");
        assert_eq!(pick.measure, "1/spp");
        let mut first = fake(Order::CheapestFirst { limit_ms: 60_000.0 });
        let pick = choose(&mut first, 0.2, &Reporter::silent()).unwrap();
        assert_eq!(first.tried, [4, 8]);
        assert_eq!(pick.chosen.get::<u32>("spp"), Some(8));
        let mut none_left = fake(Order::CheapestFirst { limit_ms: -1.0 });
        let e = choose(&mut none_left, 0.2, &Reporter::silent()).unwrap_err();
        assert_eq!(e, Error::internal("no fake candidate"));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = choose(&mut fake(Order::All), bad, &Reporter::silent()).unwrap_err();
            assert_eq!(e, Error::param("max_error", format!("must be positive, got {bad}")));
        }
    }

    #[test]
    fn the_cache_returns_what_it_stored_and_survives_damage() {
        let dir = std::env::temp_dir().join(format!("penumbra-cache-{}", std::process::id()));
        let cache = ChoiceCache::in_dir(&dir);
        let pick = Pick::of(0.1, "rmse", vec![candidate(8, 3.0, &[0.0025; 8])], 2.0).unwrap();
        cache.put("k", &pick).unwrap();
        let back = cache.get("k", &KNOBS).unwrap();
        assert!(back.cached);
        assert_eq!(back.chosen, pick.chosen);
        assert_eq!(back.candidates, pick.candidates);
        assert!(cache.get("other", &KNOBS).is_none());
        assert!(cache.get("k", &[]).is_none(), "knobs it was not written for");
        std::fs::write(dir.join("max-error-choices.json"), b"{not json").unwrap();
        assert!(cache.get("k", &KNOBS).is_none());
        cache.put("k", &pick).unwrap();
        assert!(cache.get("k", &KNOBS).is_some());
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn a_second_choose_cached_reads_the_cache() {
        let dir = std::env::temp_dir().join(format!("penumbra-cache-twice-{}", std::process::id()));
        let budget = ErrorBudget {
            max_error: 0.1,
            cache_dir: Some(dir.clone()),
        };
        let mut method = fake(Order::All);
        let first = choose_cached(&mut method, ("o", &[]), &budget, &Reporter::silent()).unwrap();
        let second = choose_cached(&mut method, ("o", &[]), &budget, &Reporter::silent()).unwrap();
        assert_eq!(method.truths, 1, "checked once");
        assert!(!first.cached && second.cached);
        assert_eq!(
            serde_json::to_value(&first.chosen).unwrap(),
            serde_json::json!({ "spp": "16" })
        );
        assert_eq!(second.chosen, first.chosen);
        let _ = std::fs::remove_dir_all(dir);
    }
}
