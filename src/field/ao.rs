//! Ambient occlusion with displacement fields: Algorithm 2 of the paper. The
//! receivers' points cast the same rays as the ray-casting reference
//! (`crate::ao`: same seed, same directions), and each ray asks every caster
//! instance's field instead of a kd-tree. Instances share their mesh's field
//! whatever their rigid motion and uniform scale (section 3.2: q' = M^-1 q).
//!
//! A point never consults the field of the instance it belongs to: a ray
//! leaving a surface sees that very surface first from the sphere, so the
//! field cannot tell what lies beyond it (self-occlusion needs the object's
//! own geometry; see `field::lookup`).

use glam::Vec3;
use rayon::prelude::*;

use super::build::DisplacementField;
use super::lookup::{FieldTrace, Positional};
use super::query::FieldQuery;
use crate::ao::{AoPoint, AoSettings, PointDirections, VisibilityMasks};
use crate::progress::Progress;
use crate::sampling::SampleSequence;
use crate::scene::Transform;
use glam::Quat;

/// One caster instance: its mesh's field and its placement.
#[derive(Debug, Clone, Copy)]
pub struct FieldCaster<'f> {
    pub field: &'f DisplacementField,
    pub transform: Transform,
    /// The instance's index in the scene; points with this owner skip it.
    pub instance: u32,
}

/// A point that belongs to no instance (consults every field).
pub const NO_OWNER: u32 = u32::MAX;

/// Per-ray classes, as bit masks in the layout of `VisibilityMasks`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RayClasses {
    /// The ray started inside the bounding sphere of a caster it entered.
    pub inside: Vec<u32>,
    /// Some field put its surface behind the ray's origin (see `lookup`).
    pub hidden: Vec<u32>,
}

impl FieldCaster<'_> {
    /// The ray (world space, unit direction) against this instance.
    pub fn trace(&self, o: Vec3, d: Vec3, positional: Positional) -> FieldTrace {
        let inv = self.transform.rotation.inverse();
        let o_obj = self.transform.inverse_point(o);
        let d_obj = (inv * d).normalize();
        match self.field.trace(o_obj, d_obj, positional) {
            FieldTrace::Hit { t, inside } => FieldTrace::Hit {
                t: t * self.transform.scale,
                inside,
            },
            other => other,
        }
    }
}

/// A caster made ready for the AO loop: its field's frames tabulated and
/// its inverse rotation computed once, so that a point moves its origin
/// into the caster's space once for all its rays and a ray only rotates its
/// direction. The arithmetic is `FieldCaster::trace`'s, step for step.
struct ReadyCaster<'f> {
    query: FieldQuery<'f>,
    transform: Transform,
    inverse_rotation: Quat,
    instance: u32,
}

impl<'f> ReadyCaster<'f> {
    fn new(c: &FieldCaster<'f>) -> Self {
        ReadyCaster {
            query: FieldQuery::new(c.field),
            transform: c.transform,
            inverse_rotation: c.transform.rotation.inverse(),
            instance: c.instance,
        }
    }

    /// The ray from `o_obj` (the point's origin in the caster's space) along
    /// world direction `d`.
    #[inline]
    fn trace(&self, o_obj: Vec3, d: Vec3, positional: Positional) -> FieldTrace {
        let d_obj = (self.inverse_rotation * d).normalize();
        match self.query.trace(o_obj, d_obj, positional) {
            FieldTrace::Hit { t, inside } => FieldTrace::Hit {
                t: t * self.transform.scale,
                inside,
            },
            other => other,
        }
    }
}

/// Visibility of `rays_per_point` rays per point through the casters'
/// fields; `owners[i]` is point i's instance (or `NO_OWNER`). The CPU twin
/// of `wgsl/field_ao.wgsl`.
pub fn field_ao(
    casters: &[FieldCaster],
    points: &[AoPoint],
    owners: &[u32],
    settings: &AoSettings,
    positional: Positional,
    progress: &Progress,
) -> (VisibilityMasks, RayClasses) {
    assert_eq!(points.len(), owners.len());
    let words = settings.words_per_point() as usize;
    let seq = SampleSequence::new(settings.seed);
    let mut bits = vec![0u32; points.len() * words];
    let mut inside = vec![0u32; points.len() * words];
    let mut hidden = vec![0u32; points.len() * words];
    let ready: Vec<ReadyCaster> = casters.iter().map(ReadyCaster::new).collect();
    bits.par_chunks_mut(words)
        .zip(inside.par_chunks_mut(words))
        .zip(hidden.par_chunks_mut(words))
        .zip(points.par_iter().zip(owners.par_iter()))
        .with_min_len(16)
        .for_each_init(Vec::new, |origins, (((mask, inside), hidden), (point, &owner))| {
            let normal = Vec3::from_array(point.normal);
            let origin = Vec3::from_array(point.origin);
            // The point's origin in each caster's space, once for all its rays.
            origins.clear();
            origins.extend(
                ready
                    .iter()
                    .filter(|c| c.instance != owner)
                    .map(|c| (c, c.transform.inverse_point(origin))),
            );
            let dirs = PointDirections::new(&seq, point.stream, normal);
            for j in 0..settings.rays_per_point {
                let bit = 1u32 << (j % 32);
                let w = (j / 32) as usize;
                if !point.has_hemisphere() {
                    mask[w] |= bit;
                    continue;
                }
                let dir = dirs.direction(j);
                let mut visible = true;
                for &(c, o_obj) in origins.iter() {
                    let trace = c.trace(o_obj, dir, positional);
                    if trace.inside() {
                        inside[w] |= bit;
                    }
                    match trace {
                        FieldTrace::Hit { t, .. } if t <= settings.radius => visible = false,
                        FieldTrace::Miss { hidden: true, .. } => hidden[w] |= bit,
                        _ => {}
                    }
                }
                if visible {
                    mask[w] |= bit;
                }
            }
            progress.inc(1);
        });
    let masks = VisibilityMasks {
        rays_per_point: settings.rays_per_point,
        words_per_point: words as u32,
        bits,
    };
    (masks, RayClasses { inside, hidden })
}
