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
    /// Epsilon 0: the frame is the Whitted renderer's own.
    EpsilonZero,
    /// The eye inside glass (a medium around it): no linetree is built
    /// for lines that start inside a medium, so the frame is the Whitted
    /// renderer's own.
    EyeInMedium,
    /// Its hit lies within rounding of an edge of its surface's texture,
    /// where the renderer's own hit point could fall in the other check.
    TextureEdge,
}

/// How a pixel got its radiance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PixelPath {
    /// The fast path (section 6.1): a cell of the previous frame,
    /// reprojected to this eye, claimed the pixel, which was interpolated
    /// from it without tracing anything.
    Reprojected,
    /// Inside a run of one reprojected cell's pixels along a row, filled
    /// by screen-space interpolation between the run's ends (section 6.2,
    /// `BoundedSettings::span`): outside the guarantee.
    SpanFilled,
    /// Its primary ray was traced (pixel assignment is exact) and its line
    /// interpolated in an accepted cell of that surface's linetree.
    Interpolated,
    /// Its ray left the scene: the background, exactly.
    Background,
    /// Traced exactly by the Whitted tracer (the slow path), for this
    /// reason.
    Traced(TraceReason),
}

/// Pixels by path.
#[derive(Debug, Clone, Default, Serialize)]
pub struct PathCounts {
    /// Pixels `PixelPath::Reprojected`.
    pub reprojected: u64,
    /// Pixels `PixelPath::SpanFilled`.
    pub span_filled: u64,
    /// Pixels `PixelPath::Interpolated`.
    pub interpolated: u64,
    /// Pixels `PixelPath::Background`.
    pub background: u64,
    /// Pixels `PixelPath::Traced`, whatever the reason.
    pub traced: u64,
    /// Traced pixels by the reason: a `Failure`'s name (`topology`,
    /// `nonlinear`, ...), `eye`, `face_mismatch`, `epsilon_zero`,
    /// `eye_in_medium` or `texture_edge`.
    pub traced_by: std::collections::BTreeMap<String, u64>,
}

/// What one frame did and cost.
#[derive(Debug, Clone, Default, Serialize)]
pub struct FrameStats {
    /// Pixels by how they got their radiance.
    pub pixels: PathCounts,
    /// Share of pixels interpolated (fast path, span-filled or built) among
    /// those that hit a surface.
    pub success_rate: f64,
    /// Linetree cells after the frame, over every tree, split ones
    /// included (the trees persist from frame to frame).
    pub cells: usize,
    /// Leaves among them (cells not split).
    pub leaves: usize,
    /// Accepted leaves among them.
    pub valid_cells: usize,
    /// Cells built this frame: their extremal rays traced and the
    /// predicate run.
    pub cells_built: usize,
    /// Rejected cells split this frame (section 7's cost model let them).
    pub cells_split: usize,
    /// Cells of the previous frame that reprojection let claim pixels.
    pub cells_reprojected: usize,
    /// Cells reprojection tried and dropped, by why: `[0]` the predicate
    /// did not prove that every line of the cell hits its surface (not
    /// reprojectable), `[1]` their shaft from the eye was not clear, `[2]`
    /// no pixel's line fell in them any more.
    pub reproject_dropped: [usize; 3],
    /// Extremal rays asked for (16 per built cell) and traced (the rest
    /// were shared with built cells).
    pub extremal_rays_requested: u64,
    /// Extremal rays traced: those asked for that no cell had traced yet,
    /// each once.
    pub extremal_rays_traced: u64,
    /// Of those, traced by the Whitted kernel's `whitted_trees` (the rest
    /// on the CPU: no GPU, `SlowPath` chose the CPU, or a tree overflowed
    /// its slot).
    pub extremal_rays_on_gpu: u64,
    /// Rays the slow path traced: every ray of each traced pixel's ray
    /// tree (primary, shadow, reflected and refracted).
    pub rays_traced_slow_path: u64,
    /// Bytes the linetrees' cells and samples take after the frame (after
    /// eviction).
    pub memory_bytes: usize,
    /// The most bytes they have taken at once since the renderer was made.
    pub memory_peak_bytes: usize,
    /// Built leaves evicted after the frame to keep under
    /// `BoundedSettings::memory_mb` (least recently used first).
    pub evicted_cells: usize,
    /// Wall-clock milliseconds of the whole frame; the phases below are
    /// parts of it.
    pub frame_ms: f64,
    /// Milliseconds of the fast path: reprojecting the previous frame's
    /// cells and claiming their pixels.
    pub reproject_ms: f64,
    /// Milliseconds of pixel assignment: the primary rays and each line's
    /// linetree leaf.
    pub assign_ms: f64,
    /// Milliseconds of the rounds of builds: extremal rays, predicates and
    /// splits.
    pub build_ms: f64,
    /// Milliseconds of the slow path (on an exact frame, the whole Whitted
    /// render).
    pub trace_ms: f64,
    /// Milliseconds of interpolating the reprojected and interpolated
    /// pixels, on the GPU where the renderer has one.
    pub interpolate_ms: f64,
}

/// A rendered frame.
pub struct BoundedFrame {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The camera it was rendered from, in the scene's frame.
    pub camera: Camera,
    /// Linear RGB radiance per pixel, row-major from the top row.
    pub radiance: Vec<Vec3>,
    /// How each pixel got its radiance, in the same order.
    pub paths: Vec<PixelPath>,
    /// The linetree cell (index into `Linetrees::cells`) each interpolated
    /// or reprojected pixel took its radiance from, `u32::MAX` elsewhere.
    pub cells: Vec<u32>,
    /// What the frame did and cost.
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
            TraceReason::EpsilonZero => "epsilon_zero".into(),
            TraceReason::EyeInMedium => "eye_in_medium".into(),
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
