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

/// What `ao --method field` reports (the CLI's `--json`).
#[derive(Debug, Clone, Serialize)]
pub struct FieldRunReport {
    /// The fields every AO report has: `build_ms` is the time of the fields
    /// built (read ones cost none), `ao_ms` the last frame's.
    #[serde(flatten)]
    pub ao: AoReport,
    /// How the lookups combined the positional samples.
    pub positional: Positional,
    /// Wall-clock milliseconds ray casting (CPU) the self-occlusion of the
    /// objects that cast and receive: frame 0, then every frame in which one
    /// moved; None when no object does both.
    pub self_occlusion_ms: Option<Vec<f64>>,
    /// Each caster mesh's field: its header, and the file it was read from or
    /// its build time.
    pub fields: Vec<FieldReport>,
    /// The caster meshes left without a field, and why.
    pub skipped: Vec<Skipped>,
    /// Caster instances, and their triangles in the world.
    pub casters: Casters,
    /// Animation frames run.
    pub frames: usize,
    /// Milliseconds of each frame's field lookups for the receivers' vertices:
    /// GPU timestamps where the device has them, else the wall clock.
    pub frame_ao_ms: Vec<f64>,
    /// Mean of `frame_ao_ms`.
    pub ao_ms_mean: f64,
    /// Rays of the last frame that started inside the bounding sphere of a
    /// caster they entered.
    pub rays_inside_sphere: u64,
    /// Rays of the last frame for which some field put the surface behind the
    /// origin (that field counts them as misses).
    pub rays_hidden: u64,
    /// The error against ray casting the same rays, when asked for.
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
                cutout_triangles: fields.cutout_triangles(),
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
    /// The field's header.
    #[serde(flatten)]
    pub summary: FieldSummary,
    /// The `.dfield` file written.
    pub file: String,
    /// The file's size in bytes.
    pub bytes: u64,
    /// Wall-clock milliseconds of the last build, kd-tree included.
    pub build_ms: f64,
    /// Of which building the kd-tree over the mesh.
    pub kdtree_ms: f64,
    /// Rays traced per build: maps x directions per map.
    pub rays: u64,
    /// Fraction of those rays that hit the object.
    pub hit_fraction: f64,
    /// Positional samples asked for; the grid takes the nearest square
    /// (`maps`).
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
