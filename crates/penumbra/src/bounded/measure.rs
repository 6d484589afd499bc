//! How far a bounded-error frame lands from the exact one: against a
//! Whitted reference image (`compare`), and by tracing random lines inside
//! every accepted cell a frame used (`check`), which finds a violation
//! even where no pixel's ray happened to fall. Also the error image of
//! the paper's section 8.2 (why each pixel was traced).

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::bounded::frame::{BoundedFrame, PixelPath, TraceReason};
use crate::bounded::linetree::CellState;
use crate::bounded::predicate::{Failure, RootFace};
use crate::bounded::runner::BoundedRenderer;
use crate::geom::sampling::hash_u32;
use crate::whitted::whitted::WhittedUniforms;

/// The error of a frame against the exact image.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ErrorStats {
    /// The largest relative error `|L - L_exact| / max(L_exact, floor)`
    /// over channels and pixels (all pixels, whatever their path).
    pub max_rel: f64,
    /// The mean over all pixels of each pixel's largest relative error
    /// over its channels.
    pub mean_rel: f64,
    /// Interpolated (reprojected or built) pixels over `epsilon`.
    pub violations: u64,
    /// Span-filled pixels over `epsilon` (outside the guarantee).
    pub span_violations: u64,
    /// Traced and background pixels that differ at all from the reference.
    pub traced_differ: u64,
}

/// The relative error of `l` against `exact`, per the guarantee's measure.
pub fn relative_error(l: Vec3, exact: Vec3, floor: f32) -> f64 {
    let d = (l - exact).abs();
    (0..3)
        .map(|c| d[c] as f64 / exact[c].max(floor) as f64)
        .fold(0.0, f64::max)
}

/// Compares a frame with the exact radiance of the same camera.
pub fn compare(frame: &BoundedFrame, exact: &[Vec3], epsilon: f32, floor: f32) -> ErrorStats {
    let mut s = ErrorStats::default();
    let mut sum = 0.0;
    for ((l, e), path) in frame.radiance.iter().zip(exact).zip(&frame.paths) {
        let rel = relative_error(*l, *e, floor);
        s.max_rel = s.max_rel.max(rel);
        sum += rel;
        let over = rel > epsilon as f64;
        match path {
            PixelPath::Reprojected | PixelPath::Interpolated => s.violations += over as u64,
            PixelPath::SpanFilled => s.span_violations += over as u64,
            PixelPath::Background | PixelPath::Traced(_) => s.traced_differ += (l != e) as u64,
        }
    }
    s.mean_rel = sum / exact.len().max(1) as f64;
    s
}

/// What `check` found.
#[derive(Debug, Clone, Default, Serialize)]
pub struct CheckStats {
    /// Accepted cells checked.
    pub cells: u64,
    /// Random lines traced, `k` per cell.
    pub lines: u64,
    /// Lines whose first hit was not the cell's surface (or not one of its
    /// patch's triangles): no pixel could be interpolated with them, so
    /// they are left out of the comparison.
    pub skipped: u64,
    /// Lines compared whose interpolated radiance is more than `epsilon`
    /// from the traced one (relative, `relative_error`): each a broken
    /// guarantee.
    pub violations: u64,
    /// The largest relative error over the lines compared.
    pub max_rel: f64,
}

impl BoundedRenderer {
    /// Traces `k` random lines (seeded) in every accepted cell the last
    /// frame used and compares each with the cell's interpolation.
    pub fn check(&self, params: &WhittedUniforms, k: u32, seed: u32) -> CheckStats {
        let eps = self.settings.epsilon;
        let floor = self.settings.floor;
        let per_cell: Vec<CheckStats> = self
            .used_cells()
            .par_iter()
            .map(|&c| {
                let mut s = CheckStats::default();
                let cell = &self.trees.cells[c as usize];
                let CellState::Valid(interp) = &cell.state else {
                    return s;
                };
                s.cells = 1;
                let pair = &self.trees.trees[cell.tree as usize].pair;
                for j in 0..k {
                    let coords = [0, 1, 2, 3].map(|i| {
                        let (lo, hi) = cell.cell.range(pair, i);
                        let h = hash_u32(seed ^ hash_u32(c.wrapping_mul(0x9e37_79b9) ^ hash_u32(j * 4 + i as u32)));
                        lo + (hi - lo) * (h as f64 / u32::MAX as f64)
                    });
                    let (exact, first, texture) = self.trace_line(params, cell.tree, &coords);
                    s.lines += 1;
                    let same = first.is_some_and(|p| {
                        interp
                            .accepted
                            .covers(RootFace::of(self.geometry(), self.whitted.scene(), p), p)
                    });
                    if !same {
                        s.skipped += 1;
                        continue;
                    }
                    let l = interp.at(cell.cell.local(pair, &coords), texture);
                    let rel = relative_error(l, exact, floor);
                    s.max_rel = s.max_rel.max(rel);
                    s.violations += (rel > eps as f64) as u64;
                }
                s
            })
            .collect();
        per_cell.into_iter().fold(CheckStats::default(), |mut a, b| {
            a.cells += b.cells;
            a.lines += b.lines;
            a.skipped += b.skipped;
            a.violations += b.violations;
            a.max_rel = a.max_rel.max(b.max_rel);
            a
        })
    }
}

/// The colour of a pixel's path in the error image (the paper's section
/// 8.2: grey-blue success; green discontinuities, shadows darker; yellow
/// rays that miss the surface; red blockers of reflections; magenta
/// non-linear radiance), orange total internal reflection, cyan span
/// fills, white the eye inside glass or a slab, grey face mismatches,
/// blue texture edges, black the background.
pub fn path_colour(path: PixelPath) -> [u8; 3] {
    match path {
        PixelPath::Reprojected => [90, 110, 150],
        PixelPath::Interpolated => [150, 170, 210],
        PixelPath::SpanFilled => [0, 200, 200],
        PixelPath::Background => [0, 0, 0],
        PixelPath::Traced(why) => match why {
            TraceReason::Failure(Failure::Topology) => [0, 230, 0],
            TraceReason::Failure(Failure::Shadow) => [0, 130, 0],
            TraceReason::Failure(Failure::Silhouette) => [230, 230, 0],
            TraceReason::Failure(Failure::Blocker) => [230, 0, 0],
            TraceReason::Failure(Failure::Nonlinear) => [230, 0, 230],
            TraceReason::Failure(Failure::Tir) => [255, 140, 0],
            TraceReason::Eye => [255, 255, 255],
            TraceReason::Mismatch => [128, 128, 128],
            TraceReason::EpsilonZero | TraceReason::EyeInMedium => [60, 60, 60],
            TraceReason::TextureEdge => [0, 90, 230],
        },
    }
}
