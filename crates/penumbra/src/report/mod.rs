//! What runs report besides their answers: timed repeats of a run, and
//! what a run left out because the scene did not need it, and the warning
//! for an output that reads 1 everywhere because a length is off scale.

pub mod repeats;
pub(crate) mod skipped;

/// AO at least this everywhere reads as "nothing occludes".
pub const NEAR_ONE: f32 = 0.995;

/// A length below this fraction of the scene's size is far from its scale:
/// occluders that close to a surface are rarer than the surface's own
/// curvature, and AO reads 1 everywhere.
pub const SMALL_LENGTH: f32 = 0.005;

/// A warning (without a `warning:` prefix) when `values` (accessibility, 1 open) are all about 1 and the
/// length `option` (the option's name, as the library's messages give it:
/// `radius`) is `length`, far below the scene's size `size` (its bounding
/// box's diagonal): a length meant for another scale leaves nothing to
/// occlude. `suggested`: the length to try instead.
pub fn near_one_warning(values: &[f32], option: &str, length: f32, size: f32, suggested: f32) -> Option<String> {
    let least = values.iter().copied().fold(f32::INFINITY, f32::min);
    if values.is_empty() || least < NEAR_ONE || !length.is_finite() || length >= SMALL_LENGTH * size {
        return None;
    }
    Some(format!(
        "AO is at least {least:.3} everywhere: `{option}` {length} is {:.1e} of the scene's size \
         {size:.4} (its bounding box's diagonal), so nothing lies close enough to occlude; try `{option}` \
         {suggested:.4}",
        length / size
    ))
}

/// Millions of rays per second of `rays` in `ms` (0 when nothing was timed).
pub fn mrays_per_s(rays: usize, ms: f64) -> f64 {
    if ms > 0.0 { rays as f64 / (ms * 1e3) } else { 0.0 }
}

/// Whether a count is zero (serde's `skip_serializing_if` for counts a
/// report states only when something was counted).
pub fn is_zero(n: &usize) -> bool {
    *n == 0
}
