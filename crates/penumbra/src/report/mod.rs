//! What runs report besides their answers: timed repeats of a run, and
//! what a run left out because the scene did not need it.

pub mod repeats;
pub(crate) mod skipped;

/// Millions of rays per second of `rays` in `ms` (0 when nothing was timed).
pub fn mrays_per_s(rays: usize, ms: f64) -> f64 {
    if ms > 0.0 { rays as f64 / (ms * 1e3) } else { 0.0 }
}

/// Whether a count is zero (serde's `skip_serializing_if` for counts a
/// report states only when something was counted).
pub fn is_zero(n: &usize) -> bool {
    *n == 0
}
