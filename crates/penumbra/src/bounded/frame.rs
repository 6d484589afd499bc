//! What a bounded-error frame returns: each pixel's radiance and path (and
//! why it was traced), and the frame's counts and phase times.

use glam::Vec3;
use serde::Serialize;

use crate::bounded::predicate::Failure;
use crate::scene::Camera;

/// Why a pixel was traced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TraceReason {
    /// Its cell was rejected by this sub-test.
    Failure(Failure),
    /// The pixel's line misses its face pair's faces (no line
    /// coordinates).
    Eye,
    /// Its ray hit another face of the object than the cell's rays.
    Mismatch,
    /// Epsilon 0, or the eye inside glass: the frame is the Whitted
    /// renderer's own.
    Exact,
    /// Its hit lies within rounding of an edge of its surface's texture,
    /// where the renderer's own hit point could fall in the other check.
    TextureEdge,
}

/// How a pixel got its radiance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PixelPath {
    Reprojected,
    SpanFilled,
    Interpolated,
    /// Its ray left the scene: the background, exactly.
    Background,
    Traced(TraceReason),
}

/// Pixels by path.
#[derive(Debug, Clone, Default, Serialize)]
pub struct PathCounts {
    pub reprojected: u64,
    pub span_filled: u64,
    pub interpolated: u64,
    pub background: u64,
    pub traced: u64,
    /// Traced pixels by the reason.
    pub traced_by: std::collections::BTreeMap<String, u64>,
}

/// What one frame did and cost.
#[derive(Debug, Clone, Default, Serialize)]
pub struct FrameStats {
    pub pixels: PathCounts,
    /// Share of pixels interpolated (fast path, span-filled or built) among
    /// those that hit a surface.
    pub success_rate: f64,
    pub cells: usize,
    pub leaves: usize,
    pub valid_cells: usize,
    pub cells_built: usize,
    pub cells_split: usize,
    pub cells_reprojected: usize,
    /// Cells reprojection tried and dropped: the eye was not before their
    /// front face, their shaft from the eye was not clear, or no pixel's
    /// line fell in them any more.
    pub reproject_dropped: [usize; 3],
    /// Extremal rays asked for (16 per built cell) and traced (the rest
    /// were shared with built cells).
    pub extremal_rays_requested: u64,
    pub extremal_rays_traced: u64,
    /// Of those, traced by the Whitted kernel's `whitted_trees` (the rest
    /// on the CPU: no GPU, `SlowPath` chose the CPU, or a tree overflowed
    /// its slot).
    pub extremal_rays_on_gpu: u64,
    pub rays_traced_slow_path: u64,
    pub memory_bytes: usize,
    pub memory_peak_bytes: usize,
    pub evicted_cells: usize,
    pub frame_ms: f64,
    pub reproject_ms: f64,
    pub assign_ms: f64,
    pub build_ms: f64,
    pub trace_ms: f64,
    pub interpolate_ms: f64,
}

/// A rendered frame.
pub struct BoundedFrame {
    pub width: u32,
    pub height: u32,
    pub camera: Camera,
    pub radiance: Vec<Vec3>,
    pub paths: Vec<PixelPath>,
    /// The linetree cell (index into `Linetrees::cells`) each interpolated
    /// or reprojected pixel took its radiance from, `u32::MAX` elsewhere.
    pub cells: Vec<u32>,
    pub stats: FrameStats,
}

pub(crate) fn count_paths(paths: &[PixelPath], stats: &mut FrameStats) {
    let p = &mut stats.pixels;
    // Counted by reason first, named once per reason (naming through
    // serde per pixel cost 1% of a frame); the few reasons in a list, the
    // last one tried first (hashing each traced pixel's reason cost 1%).
    let mut reasons: Vec<(TraceReason, u64)> = Vec::new();
    let mut last = 0;
    for path in paths {
        match path {
            PixelPath::Reprojected => p.reprojected += 1,
            PixelPath::SpanFilled => p.span_filled += 1,
            PixelPath::Interpolated => p.interpolated += 1,
            PixelPath::Background => p.background += 1,
            PixelPath::Traced(why) => {
                p.traced += 1;
                if reasons.get(last).is_none_or(|r| r.0 != *why) {
                    last = match reasons.iter().position(|r| r.0 == *why) {
                        Some(k) => k,
                        None => {
                            reasons.push((*why, 0));
                            reasons.len() - 1
                        }
                    };
                }
                reasons[last].1 += 1;
            }
        }
    }
    for (why, count) in reasons {
        let name = match why {
            TraceReason::Failure(f) => serde_json::to_value(f)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default(),
            TraceReason::Eye => "eye".into(),
            TraceReason::Mismatch => "face_mismatch".into(),
            TraceReason::Exact => "epsilon_zero".into(),
            TraceReason::TextureEdge => "texture_edge".into(),
        };
        *p.traced_by.entry(name).or_default() += count;
    }
    let surfaces = (paths.len() as u64).saturating_sub(p.background);
    let interpolated = p.reprojected + p.span_filled + p.interpolated;
    stats.success_rate = if surfaces > 0 {
        interpolated as f64 / surfaces as f64
    } else {
        0.0
    };
}
