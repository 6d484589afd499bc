//! The defaults of the knobs whose best value depends on the mesh (mask
//! side, two-level hierarchy, near field), chosen per mesh by a quick probe.
//!
//! No one setting is right everywhere: on a 2,500-triangle head the
//! hierarchy's coarse level misses shadows the full mesh casts (5% off at
//! 32x32 masks, 3% without it), on a 12,000-triangle mesh it is several
//! times faster at the same error, and on a few hundred triangles it costs
//! more than it saves. So each candidate setting is built on the rest pose
//! and measured two ways:
//!
//! * **error**: its transfer at the self-check's sample of vertices
//!   (`selfcheck::TracedSample`, traced once and shared by every candidate,
//!   so candidates differ by what they change, not by which vertices each
//!   drew), as the estimate `--check` would measure and its 95% upper
//!   bound;
//! * **cost**: the work of its frame counted on an even stride of vertices
//!   (culling groups tested, blockers transformed, blockers rasterised,
//!   masks integrated) and
//!   priced by a [`CostModel`] measured once per machine kind. The same
//!   counts price the same on every run, thread count and shard, so the same
//!   command shades with the same settings everywhere; a frame of those
//!   vertices is also timed, and reported beside the model's figure.
//!
//! The choice is the cheapest candidate whose upper bound is within
//! `max_error`; with none, the most accurate. Either way no candidate tried
//! is both cheaper and at least as accurate.

use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use super::hierarchy::Hierarchy;
use super::hierarchy::NearField;
use super::lut::PlaneLut;
use super::mask::MaskGrid;
use super::pipeline::{FrameOutput, FrameStats, Prt, PrtSettings};
use super::selfcheck::{SelfCheck, TracedSample};
use crate::choice::Choice;
use crate::error::{Error, Result};
use crate::gpu::device::elapsed_ms;
use crate::tune::budget::Z95;

/// Nanoseconds per unit of a frame's work on one thread, by mask side (16,
/// 32, 64). Fitted by non-negative least squares (relative) to one-thread
/// frames of six settings (hierarchy on and off, three masks) on eleven
/// meshes: the shared cow, spot and teapot, both animations, the shipped
/// cylindrical well and five public meshes (AVX-512 machine, AVX2
/// rasteriser). Median residual 8%, largest 36%; of the 165 pairs of
/// settings of one mesh, the model orders all but 2 as their timed frames
/// do, and those 2 were within 15% of each other. The per-vertex
/// integration of 16x16 masks fits at 0: it is within the other terms'
/// noise. What matters to the choice is the terms' ratios, which hold
/// across x86 machines far better than the absolute figures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CostModel {
    /// Per blocker gathered and moved into the tangent frame (after group
    /// culling).
    pub transform_ns: f64,
    /// Per culling group's box tested at a vertex (every group, at every
    /// vertex, with group culling on).
    pub group_ns: f64,
    /// Per blocker rasterised, masks of 16, 32 and 64 pixels a side.
    pub raster_ns: [f64; 3],
    /// Per vertex integrated and rotated, by mask side.
    pub integrate_ns: [f64; 3],
}

impl Default for CostModel {
    fn default() -> Self {
        CostModel {
            transform_ns: 18.3,
            group_ns: 5.6,
            raster_ns: [3.3, 11.1, 49.2],
            integrate_ns: [0.0, 83.0, 336.0],
        }
    }
}

impl CostModel {
    /// Nanoseconds of the counted work `stats` with masks of `side` pixels,
    /// `groups` culling groups tested at each vertex.
    pub fn ns(&self, stats: &FrameStats, side: usize, groups: usize) -> f64 {
        let k = match side {
            16 => 0,
            32 => 1,
            _ => 2,
        };
        let transformed = stats.candidates.saturating_sub(stats.group_culled) as f64;
        let vertices = stats.vertices as f64;
        self.transform_ns * transformed
            + self.group_ns * (groups as f64) * vertices
            + self.raster_ns[k] * stats.drawn as f64
            + self.integrate_ns[k] * vertices
    }
}

/// What the probe tries and how it judges.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    /// Largest error (95% upper bound of the estimate) a chosen setting may
    /// have.
    pub max_error: f64,
    /// The error sample: vertices drawn and rays traced per vertex.
    pub check: SelfCheck,
    /// Vertices whose work is counted and timed (an even stride of the
    /// mesh; all of them on smaller meshes).
    pub counted: usize,
    /// Mask sides tried.
    pub masks: Vec<usize>,
    /// Hierarchy on and/or off.
    pub hierarchy: Vec<bool>,
    /// Near fields tried with the hierarchy on.
    pub near: Vec<NearField>,
    /// How counted work is priced.
    pub cost: CostModel,
}

impl Default for Probe {
    fn default() -> Self {
        Probe {
            max_error: 0.03,
            check: SelfCheck::default(),
            counted: 1024,
            masks: vec![32, 16, 64],
            hierarchy: vec![true, false],
            near: vec![NearField::Clusters, NearField::Rings],
            cost: CostModel::default(),
        }
    }
}

impl Probe {
    /// Checks a positive, finite `max_error`, at least one value of each
    /// knob, a counted vertex and the sample's settings.
    pub fn validate(&self) -> Result<()> {
        if !(self.max_error.is_finite() && self.max_error > 0.0) {
            return Err(Error::param(
                "max_error",
                format!("must be positive, got {}", self.max_error),
            ));
        }
        if self.masks.is_empty() || self.hierarchy.is_empty() || self.near.is_empty() {
            return Err(Error::param(
                "probe",
                "needs at least one mask side, hierarchy and near field",
            ));
        }
        if self.counted == 0 {
            return Err(Error::param("counted", "must be at least 1"));
        }
        self.check.validate()
    }

    /// The candidates in order of preference on ties: `base`'s own values
    /// first where they are among those tried.
    fn candidates(&self, base: &PrtSettings) -> Vec<(usize, bool, NearField)> {
        let masks = base_first(&self.masks, base.mask_side);
        let nears = base_first(&self.near, base.hierarchy.near);
        let hs = base_first(&self.hierarchy, base.hierarchy.enabled);
        let mut out = Vec::new();
        for h in hs {
            for &near in if h { &nears[..] } else { &nears[..1] } {
                for &m in &masks {
                    out.push((m, h, near));
                }
            }
        }
        out
    }
}

/// `values` without repeats, `base` first where it is among them.
fn base_first<T: Copy + PartialEq>(values: &[T], base: T) -> Vec<T> {
    let mut out: Vec<T> = values.iter().copied().filter(|&v| v == base).take(1).collect();
    for &v in values {
        if !out.contains(&v) {
            out.push(v);
        }
    }
    out
}

/// One candidate's figures.
#[derive(Debug, Clone, Serialize)]
pub struct ProbeRow {
    /// Mask side.
    pub mask: usize,
    /// Two-level hierarchy on.
    pub hierarchy: bool,
    /// Near field (with the hierarchy on).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub near: Option<NearField>,
    /// Estimated mean relative L2 transfer error (what `--check` measures);
    /// `None` where a cheaper candidate was within the bound, so this one
    /// was not needed (nor built).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<f64>,
    /// One standard error of it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<f64>,
    /// `error` plus 1.96 standard errors: what is held to `max_error`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub upper: Option<f64>,
    /// The cost model's milliseconds per frame on one thread, every used
    /// vertex.
    pub model_ms: f64,
    /// The counted vertices' frame, timed (best of two, the threads in
    /// use) and scaled to every used vertex. Reported, not used to choose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timed_ms: Option<f64>,
    /// Whether its error was estimated (the others' cost alone is known:
    /// a cheaper candidate was within the bound; their error fields are
    /// left out).
    pub estimated: bool,
    /// Blockers rasterised per counted vertex.
    pub drawn_per_vertex: f64,
    /// Blockers gathered per counted vertex (after group culling).
    pub transformed_per_vertex: f64,
    /// Milliseconds building it (hierarchy; LUTs are shared).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub setup_ms: Option<f64>,
    /// Whether `upper` is within `max_error`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fits: Option<bool>,
}

/// The probe's choice and every candidate's figures.
#[derive(Debug, Clone, Serialize)]
pub struct ProbeReport {
    /// Index into `rows` of the chosen setting.
    pub chosen: usize,
    /// Every candidate tried, in the order tried.
    pub rows: Vec<ProbeRow>,
    /// The error bound held to.
    pub max_error: f64,
    /// Why the choice: "cheapest within" or "none within: most accurate".
    pub rule: &'static str,
    /// Vertices drawn for the error sample (with repeats), rays each.
    pub sample_vertices: usize,
    /// Rays traced per sampled vertex.
    pub rays: u32,
    /// Vertices whose work was counted.
    pub counted_vertices: usize,
    /// Milliseconds the whole probe took (wall clock).
    pub ms: f64,
}

impl ProbeReport {
    /// The chosen row.
    pub fn choice(&self) -> &ProbeRow {
        &self.rows[self.chosen]
    }

    /// Sets `settings`' mask side, hierarchy and near field to the choice.
    pub fn apply(&self, settings: &mut PrtSettings) {
        let c = self.choice();
        settings.mask_side = c.mask;
        settings.hierarchy.enabled = c.hierarchy;
        if let Some(near) = c.near {
            settings.hierarchy.near = near;
        }
    }

    /// The choice in the command line's words, e.g. `--mask 16 --hierarchy
    /// on --near clusters`.
    pub fn options(&self) -> String {
        let c = self.choice();
        let h = if c.hierarchy { "on" } else { "off" };
        match c.near {
            Some(n) => format!("--mask {} --hierarchy {h} --near {}", c.mask, n.name()),
            None => format!("--mask {} --hierarchy {h}", c.mask),
        }
    }
}

/// Probes `probe`'s candidates for `base` (its other settings kept) on the
/// pose `rest` of the mesh `triangles`, seen from `eye`; `seed` draws the
/// sample and its rays.
///
/// The work counted does not depend on the mask side (the same blockers
/// are gathered and rasterised whatever the mask), so it is counted once
/// per hierarchy and near field, and every candidate priced from it. The
/// error is then estimated in order of price, up to the first candidate
/// within the bound: the dearer ones cannot be chosen, are not built and
/// are reported without an error.
pub fn probe(
    rest: &[Vec3],
    triangles: &[[u32; 3]],
    base: &PrtSettings,
    eye: Option<Vec3>,
    probe: &Probe,
    seed: u32,
) -> Result<ProbeReport> {
    probe.validate()?;
    base.validate()?;
    let start = Instant::now();
    let candidates = probe.candidates(base);
    let with = |&(mask, hierarchy, near): &(usize, bool, NearField)| {
        let mut s = base.clone();
        s.mask_side = mask;
        s.hierarchy.enabled = hierarchy;
        s.hierarchy.near = near;
        s
    };
    let counted: Vec<u32> = {
        let step = rest.len().div_ceil(probe.counted).max(1);
        (0..rest.len() as u32).step_by(step).collect()
    };
    let smallest = *probe.masks.iter().min().expect("validated");
    let sides = super::sides::decide(rest, triangles, base.backface.forced(), base.two_sided.forced())?;
    let mut luts: Vec<(usize, PlaneLut)> = Vec::new();
    let mut lut = |side: usize| -> Result<PlaneLut> {
        if let Some((_, l)) = luts.iter().find(|(s, _)| *s == side) {
            return Ok(l.clone());
        }
        let l = PlaneLut::build(&MaskGrid::new(side)?, base.lut_size)?;
        luts.push((side, l.clone()));
        Ok(l)
    };
    // The work of each hierarchy and near field, counted with the smallest
    // mask; the hierarchies are kept for the candidates built later.
    let mut kinds: Vec<Counted> = Vec::new();
    let mut out = FrameOutput::default();
    for c in &candidates {
        if kinds.iter().any(|k| k.key == (c.1, c.2)) {
            continue;
        }
        let t = Instant::now();
        let s = with(&(smallest, c.1, c.2));
        let hierarchy = Hierarchy::build(rest, triangles, &s.hierarchy)?;
        let setup_ms = elapsed_ms(t);
        let prt = Prt::with_parts(rest, triangles, &s, &lut(smallest)?, &hierarchy, sides)?;
        prt.transfer_at(rest, eye, &counted, &mut out)?;
        let used = out.normals.iter().filter(|n| **n != Vec3::ZERO).count() as f64;
        let scale = used / out.stats.vertices.max(1) as f64;
        kinds.push(Counted {
            key: (c.1, c.2),
            hierarchy,
            stats: out.stats.clone(),
            scale,
            setup_ms,
        });
    }
    let kind = |c: &(usize, bool, NearField)| kinds.iter().position(|k| k.key == (c.1, c.2)).expect("counted above");
    let model_ms = |c: &(usize, bool, NearField)| {
        let k = &kinds[kind(c)];
        let groups = if base.group_culling {
            k.hierarchy.groups.len()
        } else {
            0
        };
        probe.cost.ns(&k.stats, c.0, groups) * k.scale * 1e-6
    };
    // Every candidate's row with its price; the estimated ones filled in
    // below.
    let mut rows: Vec<ProbeRow> = candidates
        .iter()
        .map(|c| {
            let stats = &kinds[kind(c)].stats;
            let n = stats.vertices.max(1) as f64;
            ProbeRow {
                mask: c.0,
                hierarchy: c.1,
                near: c.1.then_some(c.2),
                error: None,
                uncertainty: None,
                upper: None,
                model_ms: model_ms(c),
                timed_ms: None,
                estimated: false,
                drawn_per_vertex: stats.drawn as f64 / n,
                transformed_per_vertex: stats.candidates.saturating_sub(stats.group_culled) as f64 / n,
                setup_ms: None,
                fits: None,
            }
        })
        .collect();
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&a, &b| rows[a].model_ms.total_cmp(&rows[b].model_ms));
    let mut sample: Option<TracedSample> = None;
    for &i in &order {
        let c = &candidates[i];
        let Counted {
            hierarchy,
            scale,
            setup_ms: hierarchy_ms,
            ..
        } = &kinds[kind(c)];
        let t = Instant::now();
        let prt = Prt::with_parts(rest, triangles, &with(c), &lut(c.0)?, hierarchy, sides)?;
        let setup_ms = elapsed_ms(t) + hierarchy_ms;
        // The sample is drawn from the first candidate's frame and traced
        // once; every candidate shades with the same normals (sidedness
        // does not depend on the knobs tried), so one reference serves all.
        if sample.is_none() {
            sample = Some(TracedSample::trace(&prt, triangles, rest, eye, &probe.check, seed)?);
        }
        let traced = sample.as_ref().expect("traced above");
        prt.transfer_at(rest, eye, &traced.vertices, &mut out)?;
        let (error, uncertainty) = traced.estimate(&out.transfer)?;
        let mut timed = f64::INFINITY;
        for _ in 0..2 {
            let t = Instant::now();
            prt.transfer_at(rest, eye, &counted, &mut out)?;
            timed = timed.min(elapsed_ms(t));
        }
        let upper = error + Z95 * uncertainty;
        let fits = upper <= probe.max_error;
        let row = &mut rows[i];
        row.error = Some(error);
        row.uncertainty = Some(uncertainty);
        row.upper = Some(upper);
        row.timed_ms = Some(timed * scale);
        row.estimated = true;
        row.setup_ms = Some(setup_ms);
        row.fits = Some(fits);
        if fits {
            break;
        }
    }
    let (chosen, rule) = choose(&rows);
    let traced = sample.as_ref().expect("at least one candidate");
    Ok(ProbeReport {
        chosen,
        rows,
        max_error: probe.max_error,
        rule,
        sample_vertices: traced.vertices.len(),
        rays: probe.check.rays,
        counted_vertices: counted.len(),
        ms: elapsed_ms(start),
    })
}

/// The work of one hierarchy and near field, counted on the probe's
/// vertices with the smallest mask.
struct Counted {
    key: (bool, NearField),
    hierarchy: Hierarchy,
    stats: FrameStats,
    /// Used vertices over counted ones with a normal.
    scale: f64,
    /// Milliseconds building the hierarchy.
    setup_ms: f64,
}

/// The cheapest row within the bound (the more accurate of equals, then
/// the first); with none, the most accurate (the cheapest of equals).
fn choose(rows: &[ProbeRow]) -> (usize, &'static str) {
    let best = |key: &dyn Fn(&ProbeRow) -> (f64, f64), keep: &dyn Fn(&ProbeRow) -> bool| {
        let mut best: Option<usize> = None;
        for (i, r) in rows.iter().enumerate().filter(|(_, r)| keep(r)) {
            if best.is_none_or(|b| key(r) < key(&rows[b])) {
                best = Some(i);
            }
        }
        best
    };
    let upper = |r: &ProbeRow| r.upper.unwrap_or(f64::INFINITY);
    match best(&|r| (r.model_ms, upper(r)), &|r| r.fits == Some(true)) {
        Some(i) => (i, "cheapest within the bound"),
        None => (
            best(&|r| (upper(r), r.model_ms), &|r| r.upper.is_some()).expect("at least one candidate estimated"),
            "none within the bound: the most accurate",
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(error: f64, model_ms: f64, max: f64) -> ProbeRow {
        ProbeRow {
            mask: 32,
            hierarchy: true,
            near: None,
            error: Some(error),
            uncertainty: Some(0.0),
            upper: Some(error),
            model_ms,
            timed_ms: Some(model_ms),
            estimated: true,
            drawn_per_vertex: 0.0,
            transformed_per_vertex: 0.0,
            setup_ms: Some(0.0),
            fits: Some(error <= max),
        }
    }

    #[test]
    fn the_choice_is_the_cheapest_within_else_the_most_accurate() {
        let rows = [
            row(0.05, 1.0, 0.03),
            row(0.02, 3.0, 0.03),
            row(0.01, 9.0, 0.03),
            row(0.025, 2.0, 0.03),
        ];
        assert_eq!(choose(&rows), (3, "cheapest within the bound"));
        let rows = [row(0.05, 1.0, 0.03), row(0.04, 3.0, 0.03), row(0.04, 2.0, 0.03)];
        assert_eq!(choose(&rows).0, 2);
        // Equal cost: the more accurate, then the first (the base's own
        // values come first).
        let rows = [row(0.02, 2.0, 0.03), row(0.01, 2.0, 0.03)];
        assert_eq!(choose(&rows).0, 1, "equal cost, more accurate");
        let rows = [row(0.02, 2.0, 0.03), row(0.02, 2.0, 0.03)];
        assert_eq!(choose(&rows).0, 0);
    }

    #[test]
    fn the_base_values_are_tried_first_and_near_only_with_the_hierarchy() {
        let c = Probe::default().candidates(&PrtSettings::default());
        assert_eq!(c[0], (32, true, NearField::Clusters));
        assert_eq!(c.len(), 3 * 2 + 3);
        assert!(c.iter().filter(|x| !x.1).all(|x| x.2 == NearField::Clusters));
        let mut base = PrtSettings {
            mask_side: 64,
            ..PrtSettings::default()
        };
        base.hierarchy.enabled = false;
        let p = Probe {
            masks: vec![64],
            ..Probe::default()
        };
        assert_eq!(
            p.candidates(&base),
            vec![
                (64, false, NearField::Clusters),
                (64, true, NearField::Clusters),
                (64, true, NearField::Rings)
            ]
        );
    }
}
