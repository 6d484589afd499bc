//! The self-check: a cheap ray-traced estimate of the transfer error, made
//! at setup so that a method gone wrong on a user's mesh says so without
//! `--check`.
//!
//! `--check` compares every vertex of up to four frames with 4096 rays each
//! (a minute on the 36K-vertex bunny). The error it reports is a mean over
//! vertices, so a random sample of vertices estimates it: a few hundred
//! vertices give it to a few tenths of a point (the per-vertex errors'
//! spread over the square root of the sample, reported as `uncertainty`).
//! The samples are spread over the poses `--check` would compare; each
//! pose's transfer comes from one frame of the method itself, the sampled
//! vertices are traced with the reference's code
//! (`reference::reference_transfer`). Vertices are drawn with unequal
//! probabilities and weighted back (`pick`).
//!
//! The reference's Monte Carlo noise adds to the measured error (roughly in
//! quadrature, and most on nearly dark vertices, where it is large relative
//! to `|T|`), so the sample is traced with as many rays as `--check` uses by
//! default (4096): the estimate is then of the figure `--check` reports,
//! noise included. With 1024 rays it came out up to 1.4 points above
//! `--check` on a folded sheet; the sample of vertices, not the rays, is
//! what keeps the self-check cheap (256 x 4096 rays against `--check`'s
//! 36K x 4096 on the bunny). Correcting 1024-ray errors by the rays' sample
//! variance does not work: that variance is the independent-sample one, and
//! the scrambled Sobol points are far less noisy than it says.

use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use super::pipeline::{FrameOutput, Prt};
use super::reference::{reference_transfer, relative_l2_errors};
use crate::accel::Accel;
use crate::accel::kdtree::{KdTree, KdTreeSettings};
use crate::error::{Error, Result};
use crate::geom::sampling::hash_u32;
use crate::gpu::device::elapsed_ms;

/// How the self-check samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelfCheck {
    /// Vertices sampled (all of them on smaller meshes).
    pub vertices: usize,
    /// Rays per sampled vertex.
    pub rays: u32,
    /// A warning above this estimated error.
    pub threshold: f64,
}

impl Default for SelfCheck {
    fn default() -> Self {
        SelfCheck {
            vertices: 256,
            rays: 4096,
            threshold: 0.03,
        }
    }
}

impl SelfCheck {
    /// Checks for at least one vertex and one ray and a positive, finite
    /// threshold; an error naming the setting otherwise.
    pub fn validate(&self) -> Result<()> {
        if self.vertices == 0 || self.rays == 0 {
            return Err(Error::param("self_check", "needs at least one vertex and one ray"));
        }
        if !(self.threshold.is_finite() && self.threshold > 0.0) {
            return Err(Error::param(
                "self_check_threshold",
                format!("must be positive, got {}", self.threshold),
            ));
        }
        Ok(())
    }
}

/// The estimate (`self_check` in the report).
#[derive(Debug, Clone, Serialize)]
pub struct SelfCheckReport {
    /// Estimated mean relative L2 transfer error (what `--check` measures).
    pub estimate: f64,
    /// One standard error of the estimate from sampling vertices.
    pub uncertainty: f64,
    /// Vertices compared (draws: a vertex drawn twice counts twice).
    pub vertices: usize,
    /// Drawn vertices skipped as nearly dark: a reference transfer of at
    /// most 1% of the unoccluded transfer's length (as `--check`).
    pub skipped_dark: usize,
    /// The frames the samples were spread over.
    pub frames: Vec<usize>,
    /// Rays traced per sampled vertex.
    pub rays: u32,
    /// The estimated error above which `exceeded` is set.
    pub threshold: f64,
    /// Whether the estimate is above the threshold (then `warning` has the
    /// text for a user).
    pub exceeded: bool,
    /// Milliseconds the self-check took (wall clock: frames, kd-trees and
    /// rays).
    pub ms: f64,
}

impl SelfCheckReport {
    /// The warning for a user, when the estimate exceeds the threshold.
    pub fn warning(&self) -> Option<String> {
        self.exceeded.then(|| {
            format!(
                "self-check: estimated transfer error {:.1}% (+/- {:.1}) exceeds {:.1}%; \
                 `--check` measures it on every vertex, and `--hierarchy off` or a smaller \
                 `--coarse-tolerance` trade speed for accuracy",
                100.0 * self.estimate,
                100.0 * self.uncertainty,
                100.0 * self.threshold
            )
        })
    }
}

/// Estimates the transfer error of `prt` on `poses` (frame index and
/// positions each) of the mesh `triangles`, seen from `eye`.
pub fn estimate(
    prt: &Prt,
    triangles: &[[u32; 3]],
    poses: &[(usize, Vec<Vec3>)],
    eye: Option<Vec3>,
    check: &SelfCheck,
    seed: u32,
) -> Result<SelfCheckReport> {
    check.validate()?;
    if poses.is_empty() {
        return Err(Error::param("self_check", "needs at least one pose"));
    }
    let start = Instant::now();
    let per_pose = check.vertices.div_ceil(poses.len());
    // (error, weight) of each sampled vertex the reference does not call dark.
    let mut samples: Vec<(f64, f64)> = Vec::new();
    let mut skipped = 0;
    for (p, (_, positions)) in poses.iter().enumerate() {
        let pick_seed = hash_u32(seed ^ p as u32);
        let (sample, mine) = TracedSample::trace_with(
            prt,
            triangles,
            positions,
            eye,
            (per_pose, check.rays),
            (pick_seed, seed),
        )?;
        let (mut errors, dark) = sample.errors(&mine);
        samples.append(&mut errors);
        skipped += dark;
    }
    let (estimate, uncertainty) = ratio_estimate(&samples);
    Ok(SelfCheckReport {
        estimate,
        uncertainty,
        vertices: samples.len(),
        skipped_dark: skipped,
        frames: poses.iter().map(|(f, _)| *f).collect(),
        rays: check.rays,
        threshold: check.threshold,
        exceeded: estimate > check.threshold,
        ms: elapsed_ms(start),
    })
}

/// Sampled vertices of one pose traced once with the reference's rays,
/// against which the transfer of any settings that shade with the same
/// normals is compared (a probe of several settings shares it: their
/// estimates then differ by what the settings change, not by which
/// vertices each happened to draw).
pub struct TracedSample {
    /// The sampled vertices (a vertex drawn twice is listed twice).
    pub vertices: Vec<u32>,
    /// Each draw's weight (`pick`).
    weights: Vec<f64>,
    /// The reference transfer at each draw, `coeffs` values each.
    reference: Vec<f32>,
    coeffs: usize,
    /// The dark floor: 1% of the unoccluded transfer's length.
    floor: f32,
}

impl TracedSample {
    /// `check.vertices` vertices of the pose `positions` drawn from `prt`'s
    /// frame there (nearly dark ones more often) and traced with
    /// `check.rays` rays each.
    pub fn trace(
        prt: &Prt,
        triangles: &[[u32; 3]],
        positions: &[Vec3],
        eye: Option<Vec3>,
        check: &SelfCheck,
        seed: u32,
    ) -> Result<TracedSample> {
        check.validate()?;
        let seeds = (hash_u32(seed), seed);
        Ok(Self::trace_with(prt, triangles, positions, eye, (check.vertices, check.rays), seeds)?.0)
    }

    /// `trace` of `n` draws with `rays` rays, the draws from `pick_seed`,
    /// the rays from `ray_seed`; also `prt`'s transfer at the draws.
    fn trace_with(
        prt: &Prt,
        triangles: &[[u32; 3]],
        positions: &[Vec3],
        eye: Option<Vec3>,
        (n, rays): (usize, u32),
        (pick_seed, ray_seed): (u32, u32),
    ) -> Result<(TracedSample, Vec<f32>)> {
        let s = &prt.settings;
        let coeffs = prt.coeffs();
        let floor = 0.01 * prt.tables.unoccluded.iter().map(|v| v * v).sum::<f32>().sqrt();
        let lighting = vec![0.0; 3 * coeffs];
        let mut frame = FrameOutput::default();
        prt.frame(positions, eye, &lighting, false, false, &mut frame)?;
        let norms: Vec<f32> = frame
            .transfer
            .chunks(coeffs)
            .map(|t| t.iter().map(|x| x * x).sum::<f32>().sqrt())
            .collect();
        let picked = pick(&norms, &frame.normals, floor, n, pick_seed);
        let at: Vec<Vec3> = picked.iter().map(|&(v, _)| positions[v]).collect();
        let nrm: Vec<Vec3> = picked.iter().map(|&(v, _)| frame.normals[v]).collect();
        let mine: Vec<f32> = picked
            .iter()
            .flat_map(|&(v, _)| frame.transfer[v * coeffs..(v + 1) * coeffs].iter().copied())
            .collect();
        let soup: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|i| positions[i as usize])).collect();
        let tree = Accel::new(KdTree::from_triangles(soup, &KdTreeSettings::default())?);
        let reference = reference_transfer(&tree, &at, &nrm, prt.scale, s.bands, &s.brdf, eye, rays, ray_seed);
        let sample = TracedSample {
            vertices: picked.iter().map(|&(v, _)| v as u32).collect(),
            weights: picked.iter().map(|&(_, w)| w).collect(),
            reference,
            coeffs,
            floor,
        };
        Ok((sample, mine))
    }

    /// (error, weight) of each draw not dark in the reference, and how many
    /// were dark, for `transfer` at the draws (`coeffs` values each, as
    /// `Prt::transfer_at` of `vertices` gives it).
    fn errors(&self, transfer: &[f32]) -> (Vec<(f64, f64)>, usize) {
        let mut samples = Vec::new();
        let mut dark = 0;
        for (e, &w) in relative_l2_errors(transfer, &self.reference, self.coeffs, self.floor)
            .into_iter()
            .zip(&self.weights)
        {
            match e {
                Some(e) => samples.push((e, w)),
                None => dark += 1,
            }
        }
        (samples, dark)
    }

    /// The estimated mean relative L2 error of `transfer` at the draws and
    /// one standard error of it.
    pub fn estimate(&self, transfer: &[f32]) -> Result<(f64, f64)> {
        if transfer.len() != self.reference.len() {
            return Err(Error::input(
                "transfer",
                format!(
                    "{} values for {} sampled coefficients",
                    transfer.len(),
                    self.reference.len()
                ),
            ));
        }
        Ok(ratio_estimate(&self.errors(transfer).0))
    }
}

/// `n` vertices (with repeats) drawn with probability `p_v` half uniform,
/// half proportional to `1 / max(|T_v|, 3 floor)`, by systematic sampling of
/// the cumulative probabilities from a random start; each with the weight
/// `1 / (n p_v)`. The relative error's mean is carried by few vertices:
/// nearly dark ones, where any absolute error is large relative to `|T|`
/// (the teapot's spout and handle ends inside its body are 1% of its
/// vertices and half its error). Drawing them more often and weighting them
/// less keeps the estimate unbiased and its spread small. Below three times
/// the dark floor the weight stops growing: such vertices are often dark in
/// the reference too, and skipped. Vertices without a normal are never
/// drawn (their transfer is zero by definition).
fn pick(norms: &[f32], normals: &[Vec3], floor: f32, n: usize, seed: u32) -> Vec<(usize, f64)> {
    let live: Vec<usize> = (0..norms.len()).filter(|&v| normals[v] != Vec3::ZERO).collect();
    if live.is_empty() {
        return Vec::new();
    }
    let inv: Vec<f64> = live.iter().map(|&v| 1.0 / norms[v].max(3.0 * floor) as f64).collect();
    let total: f64 = inv.iter().sum();
    let uniform = 1.0 / live.len() as f64;
    let prob: Vec<f64> = inv.iter().map(|i| 0.5 * uniform + 0.5 * i / total).collect();
    let u = hash_u32(seed) as f64 / 4_294_967_296.0;
    let mut out = Vec::with_capacity(n);
    let mut cumulative = 0.0;
    let mut k = 0;
    for (&v, &p) in live.iter().zip(&prob) {
        cumulative += p * n as f64;
        while k < n && (k as f64 + u) < cumulative {
            out.push((v, 1.0 / (n as f64 * p)));
            k += 1;
        }
    }
    out
}

/// The weighted mean of the errors and its standard error (the ratio
/// estimator's linearised variance).
fn ratio_estimate(samples: &[(f64, f64)]) -> (f64, f64) {
    let wsum: f64 = samples.iter().map(|s| s.1).sum();
    if samples.is_empty() || wsum <= 0.0 {
        return (0.0, 0.0);
    }
    let mean = samples.iter().map(|(e, w)| e * w).sum::<f64>() / wsum;
    let m = samples.len() as f64;
    if samples.len() < 2 {
        return (mean, 0.0);
    }
    let var = m / (m - 1.0) * samples.iter().map(|(e, w)| (w * (e - mean)).powi(2)).sum::<f64>() / (wsum * wsum);
    (mean, var.sqrt())
}
