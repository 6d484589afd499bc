//! The field's knobs, tuned two ways (`crate::tune`).
//!
//! `sweep field` ([`FieldSweep`]): displacement fields' sampling and
//! storage against ray casting with the very same rays (`ao --method
//! raycast`, the truth of `ao --method field --reference`), cast once.
//!
//! `ao --method field --max-error E` ([`FieldBudget`]): the cheapest field
//! parameters whose per-vertex AO error against ray casting with the same
//! rays (the `reference.rms_error` of `--reference`) is within E at 95%
//! confidence, estimated on a random sample of the receivers' vertices.
//! Each point keeps its sample stream, so the sample's ray-cast truth is
//! exactly the full reference's values there. Candidates are tried from
//! the cheapest to build (positions x res^2 rays, then bits) and the first
//! within the budget wins: a field's build dominates what `ao --method
//! field` costs, and lookups cost about the same at every setting (`sweep
//! field` shows both). The winner's fields are returned ready, so the run
//! does not build them again.

use crate::scene::cutouts::Cutouts;
use crate::scene::texture_table::DEFAULT_TEXTURE_BYTES;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use serde_json::{Value, json};

use super::reach::Reach;
use super::runner::FieldAo;
use super::{DirectionMapping, FieldSampling, Positional};
use crate::error::{Error, Result};
use crate::geom::sampling::hash_u32;
use crate::gpu::device::{Device, elapsed_ms};
use crate::progress::{Bar, Reporter};
use crate::raycast::AoSettings;
use crate::raycast::points::vertex_points;
use crate::raycast::runner::{AoRequest, casters, raycast, receivers};
use crate::raycast::tracer::Tracer;
use crate::scene::{Mesh, Scene, SceneMesh};
use crate::tune::{self, Budgeted, ErrorBudget, Knob, Order, Pick, Run, SampleError, Setting, Sweep, Tunable};

/// The field's knobs.
pub const KNOBS: &[Knob] = &[
    Knob::new::<i64>(
        "positions",
        "positional samples on the bounding sphere",
        &["1026", "4226"],
    ),
    Knob::new::<i64>("res", "each map is RES x RES directions", &["16", "32"]),
    Knob::new::<i64>("bits", "bits per direction: 32, 8 or 1", &["1", "8", "32"]),
    Knob::new::<DirectionMapping>("directions", "texel mapping: concentric, polar or rejection", &[]),
    Knob::new::<Positional>("positional", "nearest sample or bilinear between four", &[]),
];

/// The field parameters of `s` with `directions`; knobs it leaves keep
/// `ao --method field`'s defaults.
fn params_of(s: &Setting, directions: DirectionMapping) -> Result<FieldSampling> {
    FieldSampling::new(
        s.get("positions").unwrap_or(4226),
        s.get("res").unwrap_or(32),
        s.get("bits").unwrap_or(8),
        directions,
    )
}

/// The field sweep of a scene with casters and receivers.
pub struct FieldSweep<'s> {
    device: Device,
    scene: &'s Scene,
    request: AoRequest,
    truth: Vec<f32>,
    /// The fields of the last parameters, reused by repeats and by settings
    /// that change only the lookup.
    built: Option<(FieldSampling, Positional, FieldAo<'s>, f64)>,
}

impl<'s> FieldSweep<'s> {
    /// The sweep of `scene`'s receivers, the truth cast with `settings`.
    pub fn new(device: Device, scene: &'s Scene, settings: AoSettings) -> Result<Self> {
        settings.validate()?;
        Ok(FieldSweep {
            device,
            scene,
            request: AoRequest {
                settings,
                vertices: true,
                image: None,
            },
            truth: Vec::new(),
            built: None,
        })
    }

    fn params(s: &Setting) -> Result<(FieldSampling, Positional)> {
        let directions = s.get("directions").unwrap_or(DirectionMapping::Concentric);
        let params = params_of(s, directions)?;
        Ok((params, s.get("positional").unwrap_or(Positional::Bilinear)))
    }

    /// The sweep runs one frame at the request's radius.
    fn reach(&self) -> Reach {
        Reach {
            radius: self.request.settings.radius,
            frames: 1,
        }
    }
}

/// `mesh` casting onto a ground it stands on: a square of 64 x 64 vertices,
/// twice the mesh's footprint, at its lowest point (+y up): the
/// displacement-field paper's object over a receiving floor, for a mesh
/// given without a receiver.
pub fn on_ground(name: &str, path: &Path, mesh: Mesh) -> Result<Scene> {
    let b = mesh.bounds();
    let (centre, half) = (b.center(), b.extent().max_element());
    let n = 64u32;
    let positions = (0..n * n)
        .map(|i| {
            let (u, v) = ((i % n) as f32 / (n - 1) as f32, (i / n) as f32 / (n - 1) as f32);
            Vec3::new(
                centre.x + (2.0 * u - 1.0) * half,
                b.min.y,
                centre.z + (2.0 * v - 1.0) * half,
            )
        })
        .collect();
    let triangles = (0..(n - 1) * (n - 1))
        .flat_map(|q| {
            let (x, y) = (q % (n - 1), q / (n - 1));
            let i = y * n + x;
            [[i, i + n, i + 1], [i + 1, i + n, i + n + 1]]
        })
        .collect();
    let ground = SceneMesh::new("ground", Path::new("<ground>"), Mesh::new(positions, triangles)?);
    Ok(Scene::from_mesh(name, path, mesh).with_receiver(ground))
}

impl Tunable for FieldSweep<'_> {
    fn name(&self) -> &'static str {
        "field"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }
}

impl Sweep for FieldSweep<'_> {
    fn time_measure(&self) -> &'static str {
        "field AO lookups of every receiver vertex, ao_ms"
    }

    fn error_measure(&self) -> &'static str {
        "RMS of per-vertex AO vs ray casting, same rays"
    }

    fn check(&self, setting: &Setting) -> Result<()> {
        Self::params(setting).map(|_| ())
    }

    fn truth(&mut self, bars: &Reporter) -> Result<Value> {
        let cast = raycast(&self.device, self.scene, &self.request, bars)?;
        let vertices = cast.vertices.expect("vertices were asked for");
        self.truth = vertices.ao;
        Ok(json!({
            "what": "ray casting against the casters' triangles, the same rays",
            "receiver_vertices": self.truth.len(),
            "rays_per_point": self.request.settings.rays_per_point,
            "ms": vertices.ms,
            "build_ms": cast.build_ms,
        }))
    }

    fn run(&mut self, setting: &Setting) -> Result<Run> {
        let (params, positional) = Self::params(setting)?;
        let reuse = matches!(&self.built, Some((p, l, _, _)) if *p == params && *l == positional);
        if !reuse {
            self.built = None;
            let mut fields = FieldAo::new(self.scene, &params, positional, self.reach(), &Reporter::silent())?;
            fields.upload(&self.device)?;
            let build_ms = fields.reports().iter().filter_map(|r| r.build_ms).sum();
            self.built = Some((params, positional, fields, build_ms));
        }
        let (_, _, fields, build_ms) = self.built.as_mut().expect("built above");
        let bytes: usize = fields.reports().iter().map(|r| r.summary.map_bytes).sum();
        let run = fields.run(&self.request, 1, false)?;
        let ao = run.vertices.expect("vertices were asked for").ao;
        Ok(Run {
            time_ms: run.frame_ao_ms[0],
            error: crate::geom::color::rms_difference(&ao, &self.truth, None),
            memory_bytes: Some(bytes as u64),
            phases: vec![("build_ms", *build_ms)],
        })
    }
}

/// Receiver vertices the error is estimated on.
pub const SAMPLE_VERTICES: usize = 4096;
/// (positions, res, bits) tried, cheapest first. 8 bits: 32-bit maps
/// measured no more accurate on the shared models (`sweep field`), at four
/// times the memory; 32 bits comes only where the directions are finest.
pub const CANDIDATES: [(i64, i64, i64); 8] = [
    (258, 16, 8),
    (258, 32, 8),
    (1026, 16, 8),
    (1026, 32, 8),
    (4226, 32, 8),
    (4226, 64, 8),
    (4226, 64, 32),
    (16384, 64, 8),
];
/// No candidate starts once the check has taken this long (ms); the most
/// accurate one tried is chosen then, with a warning.
pub const MAX_CHECK_MS: f64 = 60_000.0;

/// What `--max-error` does not choose: how directions map and lookups
/// interpolate, and what the fields must cover (the run's radius and frames).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fixed {
    /// How a map's texels map to directions.
    pub directions: DirectionMapping,
    /// How lookups interpolate between positional samples.
    pub positional: Positional,
    /// What the fields must cover.
    pub reach: Reach,
}

/// The setting of field parameters (positions, res, bits).
pub fn setting(positions: i64, res: i64, bits: i64) -> Setting {
    Setting::default()
        .with("positions", positions)
        .with("res", res)
        .with("bits", bits)
}

/// The field's `--max-error` search for a scene's receivers (their
/// vertices): [`CANDIDATES`] cheapest first, each built and run on every
/// receiver vertex, its error estimated on [`SAMPLE_VERTICES`] of them.
pub struct FieldBudget<'s> {
    device: Device,
    scene: &'s Scene,
    request: AoRequest,
    fixed: Fixed,
    /// The sampled vertices and their ray-cast truth.
    sample: Vec<usize>,
    truth: Vec<f32>,
    /// The fields of the last candidate tried (the run's, where chosen).
    last: Option<FieldAo<'s>>,
}

impl<'s> FieldBudget<'s> {
    /// The search for `request`'s rays (its vertices only) on `scene`.
    pub fn new(device: &Device, scene: &'s Scene, request: &AoRequest, fixed: Fixed) -> Self {
        FieldBudget {
            device: device.clone(),
            scene,
            request: AoRequest {
                vertices: true,
                image: None,
                ..*request
            },
            fixed,
            sample: Vec::new(),
            truth: Vec::new(),
            last: None,
        }
    }

    /// The chosen fields: the last candidate's where it was chosen (the
    /// one within the budget, or the most accurate being the last tried),
    /// else built again (a cached pick, or an earlier candidate).
    pub fn into_fields(self, pick: &Pick, bars: &Reporter) -> Result<FieldAo<'s>> {
        let last_tried = pick.candidates.last().map(|c| &c.knobs);
        match self.last {
            Some(f) if pick.met || last_tried == Some(&pick.chosen) => Ok(f),
            _ => fields_of(self.scene, &pick.chosen, self.fixed, &self.device, bars),
        }
    }
}

impl Tunable for FieldBudget<'_> {
    fn name(&self) -> &'static str {
        "field"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }
}

impl Budgeted for FieldBudget<'_> {
    fn measure(&self) -> String {
        "RMS of per-vertex AO vs ray casting, same rays (build + lookups timed)".into()
    }

    fn order(&self) -> Order {
        Order::CheapestFirst { limit_ms: MAX_CHECK_MS }
    }

    fn sample_truth(&mut self, bars: &Reporter) -> Result<()> {
        let settings = &self.request.settings;
        let points = vertex_points(&receivers(self.scene, 0)?);
        let mut sample: Vec<usize> = (0..points.len()).collect();
        sample.sort_by_key(|&i| hash_u32(i as u32 ^ settings.seed.rotate_left(16)));
        sample.truncate(SAMPLE_VERTICES);
        let sampled: Vec<_> = sample.iter().map(|&i| points[i]).collect();
        let cutouts = Cutouts::of_scene(
            self.scene,
            crate::scene::Role::casts,
            DEFAULT_TEXTURE_BYTES,
            &mut Vec::new(),
        );
        let mut tracer = Tracer::build_labelled(&self.device, &casters(self.scene, 0)?, bars, "casters")?
            .with_cutouts(cutouts.map(Arc::new));
        self.truth = tracer
            .ao_visibility(&sampled, settings, &Bar::hidden())?
            .value
            .accessibility();
        self.sample = sample;
        Ok(())
    }

    fn candidates(&self) -> Vec<Setting> {
        CANDIDATES.iter().map(|&(p, r, b)| setting(p, r, b)).collect()
    }

    fn try_candidate(&mut self, setting: &Setting) -> Result<(f64, SampleError)> {
        let params = params_of(setting, self.fixed.directions)?;
        let (positional, reach) = (self.fixed.positional, self.fixed.reach);
        let build = Instant::now();
        let mut fields = FieldAo::new(self.scene, &params, positional, reach, &Reporter::silent())?;
        fields.upload(&self.device)?;
        let run = fields.run(&self.request, 1, false)?;
        let time_ms = elapsed_ms(build);
        let ao = run.vertices.expect("vertices were asked for").ao;
        let squares: Vec<f64> = self
            .sample
            .iter()
            .zip(&self.truth)
            .map(|(&i, &t)| ((ao[i] - t) as f64).powi(2))
            .collect();
        self.last = Some(fields);
        Ok((time_ms, SampleError::rms(&squares)))
    }
}

/// Chooses the field parameters for `request` (vertices) within
/// `max_error`; returns the pick and the winner's fields on `device`.
pub fn choose<'s>(
    device: &Device,
    scene: &'s Scene,
    request: &AoRequest,
    fixed: Fixed,
    max_error: f64,
    bars: &Reporter,
) -> Result<(Pick, FieldAo<'s>)> {
    let mut budget = FieldBudget::new(device, scene, request, fixed);
    let pick = tune::choose(&mut budget, max_error, bars)?;
    let fields = budget.into_fields(&pick, bars)?;
    Ok((pick, fields))
}

/// The fields of a chosen setting (from the cache, or the most accurate
/// tried).
pub fn fields_of<'s>(
    scene: &'s Scene,
    chosen: &Setting,
    fixed: Fixed,
    device: &Device,
    bars: &Reporter,
) -> Result<FieldAo<'s>> {
    let params = params_of(chosen, fixed.directions)?;
    let mut fields = FieldAo::new(scene, &params, fixed.positional, fixed.reach, bars)?;
    fields.upload(device)?;
    Ok(fields)
}

/// The fields a run uses: with a budget, the cached or checked pick
/// (`choose_cached`); else every caster's field read or built with `params`.
pub fn fields_for<'s>(
    device: &Device,
    inputs: (&'s Scene, &[&Path]),
    request: &AoRequest,
    (fixed, params): (Fixed, &FieldSampling),
    budget: Option<&ErrorBudget>,
    bars: &Reporter,
) -> Result<(FieldAo<'s>, Option<Pick>)> {
    if let Some(budget) = budget {
        let (pick, fields) = choose_cached(device, inputs, request, fixed, budget, bars)?;
        return Ok((fields, Some(pick)));
    }
    let mut fields = FieldAo::new(inputs.0, params, fixed.positional, fixed.reach, bars)?;
    fields.upload(device)?;
    Ok((fields, None))
}

/// [`choose`] through the budget's cache (`tune::choose_cached`, keyed on
/// `files`' contents and every option that changes the answer): a cached
/// pick only builds (or reads) the chosen fields.
pub fn choose_cached<'s>(
    device: &Device,
    (scene, files): (&'s Scene, &[&Path]),
    request: &AoRequest,
    fixed: Fixed,
    budget: &ErrorBudget,
    bars: &Reporter,
) -> Result<(Pick, FieldAo<'s>)> {
    if !scene.fields.is_empty() {
        let problem = "does not apply: the scene names its field files, whose parameters are fixed";
        return Err(Error::param("max_error", problem));
    }
    let options = format!(
        "{}|{:?}|{:?}|{:?}|{}",
        budget.max_error,
        fixed.directions,
        fixed.positional,
        request.settings,
        device.kind()
    );
    let mut search = FieldBudget::new(device, scene, request, fixed);
    let pick = tune::choose_cached(&mut search, (&options, files), budget, bars)?;
    let fields = search.into_fields(&pick, bars)?;
    Ok((pick, fields))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_candidate_is_valid_and_costs_at_least_the_last() {
        let mut last = 0.0;
        for (positions, res, bits) in CANDIDATES {
            let p = FieldSampling::new(positions, res, bits, DirectionMapping::Concentric).unwrap();
            let rays = p.maps() as f64 * p.texels_per_map() as f64 * if bits == 32 { 1.01 } else { 1.0 };
            assert!(rays >= last, "{positions} {res} {bits}");
            last = rays;
        }
    }

    #[test]
    fn every_default_grid_reads_as_its_knob() {
        let grid = tune::Grid::parse(&[], KNOBS).unwrap();
        assert_eq!(grid.len(), 2 * 2 * 3);
        for s in grid.settings() {
            FieldSweep::params(&s).unwrap();
        }
    }
}
