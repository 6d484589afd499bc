//! Error budgets (`--max-error E`): the fastest of a method's candidate
//! settings whose error, estimated on a random sample of the user's scene
//! against the method's truth, is within E with 95% confidence. Methods
//! supply the candidates, their times and the per-sample errors; this
//! module turns samples into an estimate with its bound, picks, reports and
//! remembers the pick per scene (content hash) so a second run pays nothing.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::Setting;
use crate::error::{Error, Result};
use crate::progress::Reporter;

/// The one-sided 95% normal quantile: the bound is the estimate plus this
/// many standard errors.
const Z95: f64 = 1.645;

/// An error estimated from a sample, with an upper bound at 95% confidence.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SampleError {
    pub estimate: f64,
    /// The estimate's one-sided 95% upper confidence bound.
    pub upper: f64,
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

/// One candidate tried: its setting, time and sampled error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    pub knobs: Setting,
    /// The method's timed phase on the full problem, ms.
    pub time_ms: f64,
    pub error: SampleError,
    /// The bound is within the budget.
    pub within: bool,
}

/// What `--max-error` chose and why (the JSON's `max_error` object).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Choice {
    pub max_error: f64,
    /// What the error measures (the method's own full comparison).
    pub measure: String,
    pub confidence: f64,
    pub chosen: Setting,
    pub estimate: f64,
    pub upper: f64,
    pub samples: usize,
    /// Whether a candidate was within the budget (else the most accurate
    /// one tried was chosen, with a warning).
    pub met: bool,
    pub candidates: Vec<Candidate>,
    /// What the check cost: sample truth and candidate runs, ms (for fields,
    /// the chosen fields' build too, which the run then reuses).
    pub check_ms: f64,
    /// Read from the cache: the check did not run again.
    pub cached: bool,
}

impl Choice {
    /// What a user is told of the choice (with `max_error` named in
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
    /// smallest bound; `None` with no candidates.
    pub fn pick(max_error: f64, measure: &str, mut candidates: Vec<Candidate>, check_ms: f64) -> Option<Choice> {
        for c in &mut candidates {
            c.within = c.error.upper <= max_error;
        }
        let fastest_within = candidates
            .iter()
            .filter(|c| c.within)
            .min_by(|a, b| a.time_ms.total_cmp(&b.time_ms));
        let best =
            fastest_within.or_else(|| candidates.iter().min_by(|a, b| a.error.upper.total_cmp(&b.error.upper)))?;
        Some(Choice {
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

/// Choices remembered per scene: a JSON file of key -> choice. The key
/// hashes the scene's files' contents and every option that changes the
/// answer, so an edited mesh or another option checks again.
pub struct ChoiceCache {
    path: PathBuf,
}

/// An error budget (`max_error`) and where the choices it led to are
/// remembered (`cache_dir`; `None`: nowhere, every run checks again).
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorBudget {
    /// The largest error a setting may have, in the method's measure.
    pub max_error: f64,
    /// The folder of the choice cache (`max-error-choices.json`).
    pub cache_dir: Option<PathBuf>,
}

impl ErrorBudget {
    /// A budget whose choices are not remembered.
    pub fn new(max_error: f64) -> ErrorBudget {
        ErrorBudget {
            max_error,
            cache_dir: None,
        }
    }
}

impl ChoiceCache {
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

    /// The choice stored under `key` (a damaged or missing cache is empty).
    pub fn get(&self, key: &str) -> Option<Choice> {
        let mut choice: Choice = serde_json::from_value(self.read().get(key)?.clone()).ok()?;
        choice.cached = true;
        Some(choice)
    }

    /// Stores `choice` under `key`. A cache that cannot be written costs
    /// the next run a check, nothing else: the error is for a note.
    pub fn put(&self, key: &str, choice: &Choice) -> Result<()> {
        let mut all = self.read();
        all.insert(
            key.to_string(),
            serde_json::to_value(choice).map_err(|e| Error::internal(e.to_string()))?,
        );
        if let Some(dir) = self.path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
        }
        let text = serde_json::to_string(&all).map_err(|e| Error::internal(e.to_string()))?;
        crate::io::output::write_bytes(&self.path, text.as_bytes())
    }
}

/// The choice for `method` with `options` on `files`: from the budget's
/// cache when it holds one, else `check`ed and stored there. A cache that
/// cannot be written is a note to `bars`, not an error.
pub fn cached(
    method: &str,
    (options, files): (&str, &[&Path]),
    budget: &ErrorBudget,
    bars: &Reporter,
    check: impl FnOnce() -> Result<Choice>,
) -> Result<Choice> {
    let key = cache_key(method, options, files)?;
    let cache = budget.cache_dir.as_deref().map(ChoiceCache::in_dir);
    if let Some(choice) = cache.as_ref().and_then(|c| c.get(&key)) {
        return Ok(choice);
    }
    let choice = check()?;
    if let Some(Err(e)) = cache.map(|c| c.put(&key, &choice)) {
        bars.note(&format!("note: the `max_error` choice is not cached: {e}"));
    }
    Ok(choice)
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

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(spp: &str, time_ms: f64, squares: &[f64]) -> Candidate {
        let mut knobs = Setting::default();
        knobs.0.insert("spp".into(), spp.into());
        Candidate {
            knobs,
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
            candidate("4", 1.0, &[0.04; 8]),    // 0.2: over
            candidate("16", 5.0, &[0.0025; 8]), // 0.05: within
            candidate("8", 3.0, &[0.0025; 8]),  // within and faster
        ];
        let choice = Choice::pick(0.1, "rmse", c.clone(), 2.0).unwrap();
        assert_eq!(choice.chosen.0["spp"], "8");
        assert!(choice.met);
        let strict = Choice::pick(0.01, "rmse", c, 2.0).unwrap();
        assert!(!strict.met);
        assert_eq!(strict.chosen.0["spp"], "16", "smallest bound, then first");
    }

    #[test]
    fn the_cache_returns_what_it_stored_and_survives_damage() {
        let dir = std::env::temp_dir().join(format!("penumbra-cache-{}", std::process::id()));
        let cache = ChoiceCache::in_dir(&dir);
        let choice = Choice::pick(0.1, "rmse", vec![candidate("8", 3.0, &[0.0025; 8])], 2.0).unwrap();
        cache.put("k", &choice).unwrap();
        let back = cache.get("k").unwrap();
        assert!(back.cached);
        assert_eq!(back.chosen, choice.chosen);
        assert!(cache.get("other").is_none());
        std::fs::write(dir.join("max-error-choices.json"), b"{not json").unwrap();
        assert!(cache.get("k").is_none());
        cache.put("k", &choice).unwrap();
        assert!(cache.get("k").is_some());
        let _ = std::fs::remove_dir_all(dir);
    }
}
