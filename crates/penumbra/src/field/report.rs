//! What `ao --method field` reports (the CLI's `--json`): the AO report's
//! common fields, the fields used and skipped, per-frame times, ray classes
//! and, when asked, the error against ray casting and the `--max-error`
//! choice.

use std::path::Path;

use serde::Serialize;

use super::build::{DisplacementField, FieldSummary};
use super::lookup::Positional;
use super::runner::{FieldAo, FieldAoRun, FieldReference, FieldReport};
use super::storage::FieldSampling;
use crate::error::{Error, Result};
use crate::progress::Reporter;
use crate::raycast::AoSettings;
use crate::raycast::report::{AoReport, Casters, Written};
use crate::report::repeats::{Repeats, RunTimes};
use crate::report::skipped::Skipped;
use crate::scene::{Role, load_mesh};
use crate::tune::Pick;

#[derive(Debug, Clone, Serialize)]
pub struct FieldRunReport {
    #[serde(flatten)]
    pub ao: AoReport,
    pub positional: Positional,
    pub self_occlusion_ms: Option<Vec<f64>>,
    pub fields: Vec<FieldReport>,
    pub skipped: Vec<Skipped>,
    pub casters: Casters,
    pub frames: usize,
    pub frame_ao_ms: Vec<f64>,
    pub ao_ms_mean: f64,
    pub rays_inside_sphere: u64,
    pub rays_hidden: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference: Option<FieldReference>,
    /// What the error budget chose, where one was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_error: Option<Pick>,
}

impl FieldRunReport {
    /// The report of `run` by `fields` (AO speed from the last frame's time).
    pub fn new(fields: &FieldAo, run: FieldAoRun, settings: &AoSettings, written: Written) -> Self {
        let frame_ms = run.frame_ao_ms;
        let last_ms = frame_ms.last().copied().unwrap_or(0.0);
        let build_ms = fields.reports().iter().filter_map(|f| f.build_ms).sum::<f64>();
        let scene = fields.scene();
        FieldRunReport {
            ao: AoReport::new("field", settings, build_ms, (run.points, last_ms)).with(written),
            positional: fields.positional(),
            self_occlusion_ms: run.self_occlusion_ms,
            fields: fields.reports().to_vec(),
            skipped: fields.skipped().to_vec(),
            casters: Casters {
                instances: Some(scene.instances.iter().filter(|i| i.role.casts()).count()),
                triangles: scene.world_mesh(Role::casts).triangles.len(),
            },
            frames: frame_ms.len(),
            ao_ms_mean: frame_ms.iter().sum::<f64>() / frame_ms.len().max(1) as f64,
            frame_ao_ms: frame_ms,
            rays_inside_sphere: run.rays_inside_sphere,
            rays_hidden: run.rays_hidden,
            reference: run.reference,
            max_error: None,
        }
    }
}

/// What `field build` reports: the header, the file and what building cost.
#[derive(Debug, Clone, Serialize)]
pub struct BuildReport {
    #[serde(flatten)]
    pub summary: FieldSummary,
    pub file: String,
    pub bytes: u64,
    pub build_ms: f64,
    pub kdtree_ms: f64,
    pub rays: u64,
    pub hit_fraction: f64,
    pub positions_requested: i64,
    /// The measured builds' times (`--warmup`, `--repeat`).
    pub runs: RunTimes,
    /// Largest over smallest cell area of the positional grid: equal-area
    /// cells make it tend to 1 as the quadrature refines.
    pub cell_area_ratio: f64,
}

/// Builds the field of the mesh in the file `mesh` with `params` and
/// writes it to `out` (atomically, as every output).
/// `positions_requested`: the positional samples asked for (the grid takes
/// the nearest square). `runs`: untimed and measured builds; the last one
/// is written.
pub fn build_file(
    mesh: &Path,
    (params, positions_requested): (&FieldSampling, i64),
    out: &Path,
    (runs, bars): (Repeats, &Reporter),
) -> Result<BuildReport> {
    let object = load_mesh(mesh)?;
    let progress = bars.bar(
        (runs.warmup + runs.repeat) as u64 * params.maps() as u64,
        "building displacement maps",
    );
    let name = mesh.display().to_string();
    let once = || DisplacementField::build(&object, params, &name, &progress);
    let ((field, stats), times) = runs.run("build_ms", once, |(_, s)| s.build_ms)?;
    progress.finish();
    super::file::write(out, &field)?;
    Ok(BuildReport {
        summary: field.summary(),
        file: out.display().to_string(),
        bytes: std::fs::metadata(out).map_err(|e| Error::read(out, e))?.len(),
        build_ms: stats.build_ms,
        kdtree_ms: stats.kdtree_ms,
        rays: stats.rays,
        hit_fraction: stats.hit_fraction,
        positions_requested,
        runs: times,
        cell_area_ratio: params.grid.cell_area_ratio(8),
    })
}
