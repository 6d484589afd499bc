//! `ao --method field --max-error E`: the cheapest field parameters whose
//! per-vertex AO error against ray casting with the same rays (the
//! `reference.rms_error` of `--reference`) is within E at 95% confidence,
//! estimated on a random sample of the receivers' vertices. Each point
//! keeps its sample stream, so the sample's ray-cast truth is exactly the
//! full reference's values there.
//!
//! Candidates are tried from the cheapest to build (positions x res^2 rays,
//! then bits) and the first within the budget wins: a field's build
//! dominates what `ao --method field` costs, and lookups cost about the
//! same at every setting (`penumbra sweep field` shows both). The winner's
//! fields are returned ready, so the run does not build them again.

use std::time::Instant;

use super::reach::Reach;
use super::runner::FieldAo;
use super::{DirectionMapping, FieldParams, Positional};
use crate::error::{Error, Result};
use crate::geom::sampling::hash_u32;
use crate::gpu::device::{Device, elapsed_ms};
use crate::progress::{Bar, Reporter};
use crate::raycast::points::vertex_points;
use crate::raycast::runner::{AoRequest, casters, receivers};
use crate::raycast::tracer::Tracer;
use crate::scene::Scene;
use crate::sweep::Setting;
use crate::sweep::budget::{Candidate, Choice, ErrorBudget, SampleError, cached};

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
    pub directions: DirectionMapping,
    pub positional: Positional,
    pub reach: Reach,
}

/// Chooses the field parameters for `request` (vertices) within
/// `max_error`; returns the choice and the winner's fields on `device`.
pub fn choose<'s>(
    device: &Device,
    scene: &'s Scene,
    request: &AoRequest,
    fixed: Fixed,
    max_error: f64,
    bars: &Reporter,
) -> Result<(Choice, FieldAo<'s>)> {
    let Fixed {
        directions, positional, ..
    } = fixed;
    if !(max_error > 0.0 && max_error.is_finite()) {
        return Err(Error::param("max_error", format!("must be positive, got {max_error}")));
    }
    let start = Instant::now();
    let settings = &request.settings;
    let points = vertex_points(&receivers(scene, 0)?);
    let mut sample: Vec<usize> = (0..points.len()).collect();
    sample.sort_by_key(|&i| hash_u32(i as u32 ^ settings.seed.rotate_left(16)));
    sample.truncate(SAMPLE_VERTICES);
    let sampled: Vec<_> = sample.iter().map(|&i| points[i]).collect();
    let mut tracer = Tracer::build(device, &casters(scene, 0)?, bars, "casters")?;
    let truth = tracer
        .ao_visibility(&sampled, settings, &Bar::hidden())?
        .value
        .accessibility();
    let only_vertices = AoRequest {
        vertices: true,
        image: None,
        ..*request
    };
    let progress = bars.bar(CANDIDATES.len() as u64, "max-error check");
    let mut tried = Vec::new();
    let mut winner = None;
    for (positions, res, bits) in CANDIDATES {
        if elapsed_ms(start) > MAX_CHECK_MS {
            break;
        }
        let params = FieldParams::new(positions, res, bits, directions)?;
        let build = Instant::now();
        let mut fields = FieldAo::new(scene, &params, positional, fixed.reach, &Reporter::silent())?;
        fields.upload(device)?;
        let run = fields.run(&only_vertices, 1, false)?;
        let time_ms = elapsed_ms(build);
        let ao = run.vertices.expect("vertices were asked for").ao;
        let squares: Vec<f64> = sample
            .iter()
            .zip(&truth)
            .map(|(&i, &t)| ((ao[i] - t) as f64).powi(2))
            .collect();
        let error = SampleError::rms(&squares);
        let within = error.upper <= max_error;
        tried.push(Candidate {
            knobs: knobs(positions, res, bits),
            time_ms,
            error,
            within,
        });
        progress.inc(1);
        if within {
            winner = Some(fields);
            break;
        }
        winner = Some(fields);
    }
    progress.finish();
    let measure = "RMS of per-vertex AO vs ray casting, same rays (build + lookups timed)";
    let choice = Choice::pick(max_error, measure, tried, elapsed_ms(start))
        .ok_or_else(|| Error::internal("no field candidate"))?;
    // Without a winner the most accurate candidate is chosen: rebuild it
    // unless it was the last one tried.
    let fields = match winner {
        Some(f) if choice.met || choice.chosen == *choice.candidates.last().map(|c| &c.knobs).expect("tried") => f,
        _ => fields_of(scene, &choice.chosen, fixed, device, bars)?,
    };
    Ok((choice, fields))
}

/// The fields of a choice (from the cache, or the most accurate tried).
pub fn fields_of<'s>(
    scene: &'s Scene,
    chosen: &Setting,
    fixed: Fixed,
    device: &Device,
    bars: &Reporter,
) -> Result<FieldAo<'s>> {
    let get = |k: &str| chosen.get::<i64>(k).map(|v| v.unwrap_or(0));
    let params = FieldParams::new(get("positions")?, get("res")?, get("bits")?, fixed.directions)?;
    let mut fields = FieldAo::new(scene, &params, fixed.positional, fixed.reach, bars)?;
    fields.upload(device)?;
    Ok(fields)
}

/// The fields a run uses: with `max_error`, the cached or checked choice
/// (`choose_cached`); else every caster's field read or built with `params`.
pub fn fields_for<'s>(
    device: &Device,
    inputs: (&'s Scene, &[&std::path::Path]),
    request: &AoRequest,
    (fixed, params): (Fixed, &FieldParams),
    budget: Option<&ErrorBudget>,
    bars: &Reporter,
) -> Result<(FieldAo<'s>, Option<Choice>)> {
    if let Some(budget) = budget {
        let (choice, fields) = choose_cached(device, inputs, request, fixed, budget, bars)?;
        return Ok((fields, Some(choice)));
    }
    let mut fields = FieldAo::new(inputs.0, params, fixed.positional, fixed.reach, bars)?;
    fields.upload(device)?;
    Ok((fields, None))
}

/// `choose` through the `--max-error` cache (`sweep::budget::cached`, keyed
/// on `files`' contents and every option that changes the answer): a
/// cached choice only builds (or reads) the chosen fields.
pub fn choose_cached<'s>(
    device: &Device,
    (scene, files): (&'s Scene, &[&std::path::Path]),
    request: &AoRequest,
    fixed: Fixed,
    budget: &ErrorBudget,
    bars: &Reporter,
) -> Result<(Choice, FieldAo<'s>)> {
    let max_error = budget.max_error;
    if !scene.fields.is_empty() {
        let problem = "does not apply: the scene names its field files, whose parameters are fixed";
        return Err(Error::param("max_error", problem));
    }
    let options = format!(
        "{max_error}|{:?}|{:?}|{:?}|{}",
        fixed.directions,
        fixed.positional,
        request.settings,
        device.kind()
    );
    let mut checked = None;
    let choice = cached("field", (&options, files), budget, bars, || {
        let (choice, fields) = choose(device, scene, request, fixed, max_error, bars)?;
        checked = Some(fields);
        Ok(choice)
    })?;
    let fields = match checked {
        Some(f) => f,
        None => fields_of(scene, &choice.chosen, fixed, device, bars)?,
    };
    Ok((choice, fields))
}

fn knobs(positions: i64, res: i64, bits: i64) -> Setting {
    let mut k = Setting::default();
    k.0.insert("positions".into(), positions.to_string());
    k.0.insert("res".into(), res.to_string());
    k.0.insert("bits".into(), bits.to_string());
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_candidate_is_valid_and_costs_at_least_the_last() {
        let mut last = 0.0;
        for (positions, res, bits) in CANDIDATES {
            let p = FieldParams::new(positions, res, bits, DirectionMapping::Concentric).unwrap();
            let rays = p.maps() as f64 * p.texels_per_map() as f64 * if bits == 32 { 1.01 } else { 1.0 };
            assert!(rays >= last, "{positions} {res} {bits}");
            last = rays;
        }
    }
}
