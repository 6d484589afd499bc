//! Ambient occlusion with displacement fields: Algorithm 2 of the paper. The
//! receivers' points cast the same rays as the ray-casting reference
//! (`crate::raycast`: same seed, same directions), and each ray asks every caster
//! instance's field instead of a kd-tree. Instances share their mesh's field
//! whatever their rigid motion and uniform scale (section 3.2: q' = M^-1 q).
//!
//! A point never consults the field of the instance it belongs to: a ray
//! leaving a surface sees that very surface first from the sphere, so the
//! field cannot tell what lies beyond it (self-occlusion needs the object's
//! own geometry; see `field::lookup`).

use glam::Vec3;
use rayon::prelude::*;

use super::batch::{Batchable, Directions, LANES, Traces};
use super::build::DisplacementField;
use super::lookup::{FieldTrace, Positional};
use super::query::FieldQuery;
use crate::geom::sampling::SampleSequence;
use crate::geom::simd::{Isa, Kernel, Lanes, dispatch};
use crate::progress::Bar;
use crate::raycast::{AoPoint, AoSettings, PointDirections, VisibilityMasks};
use crate::scene::Transform;
use glam::Quat;

/// One caster instance: its mesh's field and its placement.
#[derive(Debug, Clone, Copy)]
pub struct FieldCaster<'f> {
    /// The field of the instance's mesh, in the mesh's object space.
    pub field: &'f DisplacementField,
    /// Object to world: the instance's rigid motion and uniform scale at the
    /// frame traced (section 3.2's M; rays are taken back by M^-1).
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

    /// Rays' world directions in the caster's space.
    #[inline(always)]
    fn object_directions(&self, rays: &[(Vec3, u8)]) -> Directions {
        let mut d = Directions::default();
        for (i, &(w, _)) in rays.iter().enumerate() {
            let v = (self.inverse_rotation * w).normalize();
            (d.x[i], d.y[i], d.z[i]) = (v.x, v.y, v.z);
        }
        d
    }

    /// A batch's lanes as AO sees them: blocked within `radius` (world
    /// units), inside the sphere, surface behind the origin.
    #[inline(always)]
    fn classify(&self, traces: Traces, radius: f32) -> LaneClasses {
        let mut blocked = 0u16;
        for i in 0..LANES {
            if traces.hit >> i & 1 == 1 && traces.t[i] * self.transform.scale <= radius {
                blocked |= 1 << i;
            }
        }
        LaneClasses {
            blocked,
            inside: traces.inside,
            hidden: traces.hidden,
        }
    }

    /// One ray's classes (lane 0) for a field the batch path does not take.
    fn classify_one(&self, o_obj: Vec3, d: Vec3, positional: Positional, radius: f32) -> LaneClasses {
        let mut c = LaneClasses::default();
        let trace = self.trace(o_obj, d, positional);
        c.inside = u16::from(trace.inside());
        match trace {
            FieldTrace::Hit { t, .. } if t <= radius => c.blocked = 1,
            FieldTrace::Miss { hidden: true, .. } => c.hidden = 1,
            _ => {}
        }
        c
    }

    /// The rays `world` (of one point, from `o_obj` in the caster's space;
    /// directions with their sample cells, which this ignores)
    /// that enter the caster's sphere, gathered sixteen to a batch, their
    /// classes set in `sink`; the others are `Outside`, which sets no class.
    #[inline(always)]
    fn trace_entering(&self, batch: &Batchable, o_obj: Vec3, world: &[(Vec3, u8)], radius: f32, sink: &mut ClassWords) {
        let mut pending = Directions::default();
        let mut rays = [0u32; LANES];
        let mut n = 0;
        for (k, chunk) in world.chunks(LANES).enumerate() {
            let d = self.object_directions(chunk);
            let mut enters = batch.enters(o_obj, &d) & (u32::MAX >> (32 - chunk.len())) as u16;
            while enters != 0 {
                let i = enters.trailing_zeros() as usize;
                enters &= enters - 1;
                (pending.x[n], pending.y[n], pending.z[n]) = (d.x[i], d.y[i], d.z[i]);
                rays[n] = (k * LANES + i) as u32;
                n += 1;
                if n == LANES {
                    sink.set(&rays[..n], self.classify(batch.trace(o_obj, &pending), radius));
                    n = 0;
                }
            }
        }
        if n > 0 {
            // The unused lanes repeat the first ray (a valid lookup).
            for i in n..LANES {
                (pending.x[i], pending.y[i], pending.z[i]) = (pending.x[0], pending.y[0], pending.z[0]);
            }
            sink.set(&rays[..n], self.classify(batch.trace(o_obj, &pending), radius));
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

/// A worker's buffers: the point's origin in each caster's space (with
/// the caster's batch path, if it has one), its rays' sample bits and
/// directions (with their sample cells), and which rays a caster blocked.
#[derive(Default)]
struct Scratch<'c, 'q, 'f> {
    origins: Vec<Origin<'c, 'q, 'f>>,
    bits: Vec<[u32; 2]>,
    rays: Vec<(Vec3, u8)>,
    blocked: Vec<u32>,
}

/// A caster, its batch path if it has one, and a point's origin in its space.
type Origin<'c, 'q, 'f> = (&'c ReadyCaster<'f>, Option<&'c Batchable<'q, 'f>>, Vec3);

/// A point's per-ray words: bit j % 32 of word j / 32 for ray j.
struct ClassWords<'a> {
    blocked: &'a mut [u32],
    inside: &'a mut [u32],
    hidden: &'a mut [u32],
}

impl ClassWords<'_> {
    /// Ray `rays[i]`'s classes are lane i of `lanes`.
    #[inline(always)]
    fn set(&mut self, rays: &[u32], lanes: LaneClasses) {
        for (i, &j) in rays.iter().enumerate() {
            let (w, shift) = ((j / 32) as usize, j % 32);
            self.blocked[w] |= u32::from(lanes.blocked >> i & 1) << shift;
            self.inside[w] |= u32::from(lanes.inside >> i & 1) << shift;
            self.hidden[w] |= u32::from(lanes.hidden >> i & 1) << shift;
        }
    }
}

/// One point's rays against the casters, as a kernel: the directions, the
/// batches and the lookups compiled in the instruction set `dispatch`
/// picks (the lanes type itself is unused: the passes are plain loops the
/// compiler vectorises).
struct PointRays<'a, 'c, 'q, 'f> {
    origins: &'a [Origin<'c, 'q, 'f>],
    dirs: &'a PointDirections,
    positional: Positional,
    radius: f32,
    bits: &'a mut [[u32; 2]],
    rays: &'a mut [(Vec3, u8)],
    words: ClassWords<'a>,
}

impl Kernel for PointRays<'_, '_, '_, '_> {
    type Out = ();

    #[inline(always)]
    fn run<V: Lanes>(mut self) {
        self.dirs.directions_and_cells(self.bits, self.rays);
        for &(c, batch, o_obj) in self.origins {
            match batch {
                Some(b) => c.trace_entering(b, o_obj, self.rays, self.radius, &mut self.words),
                None => {
                    for (j, &(d, _)) in self.rays.iter().enumerate() {
                        let lane = c.classify_one(o_obj, d, self.positional, self.radius);
                        self.words.set(&[j as u32], lane);
                    }
                }
            }
        }
    }
}

/// Sixteen rays' classes against one caster (bit i = lane i).
#[derive(Debug, Clone, Copy, Default)]
struct LaneClasses {
    blocked: u16,
    inside: u16,
    hidden: u16,
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
    progress: &Bar,
) -> (VisibilityMasks, RayClasses) {
    assert_eq!(points.len(), owners.len());
    let words = settings.words_per_point() as usize;
    let seq = SampleSequence::new(settings.seed);
    let mut bits = vec![0u32; points.len() * words];
    let mut inside = vec![0u32; points.len() * words];
    let mut hidden = vec![0u32; points.len() * words];
    let ready: Vec<ReadyCaster> = casters.iter().map(ReadyCaster::new).collect();
    let batches: Vec<Option<Batchable>> = ready.iter().map(|c| Batchable::of(&c.query, positional)).collect();
    bits.par_chunks_mut(words)
        .zip(inside.par_chunks_mut(words))
        .zip(hidden.par_chunks_mut(words))
        .zip(points.par_iter().zip(owners.par_iter()))
        .with_min_len(16)
        .for_each_init(
            Scratch::default,
            |scratch, (((mask, inside), hidden), (point, &owner))| {
                let rays = settings.rays_per_point as usize;
                if !point.has_hemisphere() {
                    (0..rays).for_each(|j| mask[j / 32] |= 1 << (j % 32));
                    progress.inc(1);
                    return;
                }
                let normal = Vec3::from_array(point.normal);
                let origin = Vec3::from_array(point.origin);
                // The point's origin in each caster's space, once for all its rays.
                scratch.origins.clear();
                scratch.origins.extend(
                    ready
                        .iter()
                        .zip(&batches)
                        .filter(|(c, _)| c.instance != owner)
                        .map(|(c, b)| (c, b.as_ref(), c.transform.inverse_point(origin))),
                );
                scratch.bits.resize(rays, [0; 2]);
                scratch.rays.resize(rays, (Vec3::ZERO, 0));
                scratch.blocked.clear();
                scratch.blocked.resize(words, 0);
                let dirs = PointDirections::new(&seq, point.stream, normal);
                let kernel = PointRays {
                    origins: &scratch.origins,
                    dirs: &dirs,
                    positional,
                    radius: settings.radius,
                    bits: &mut scratch.bits,
                    rays: &mut scratch.rays,
                    words: ClassWords {
                        blocked: &mut scratch.blocked,
                        inside,
                        hidden,
                    },
                };
                dispatch(Isa::best(), kernel);
                for j in 0..rays {
                    let (w, bit) = (j / 32, 1u32 << (j % 32));
                    if scratch.blocked[w] & bit == 0 {
                        mask[w] |= bit;
                    }
                }
                progress.inc(1);
            },
        );
    let masks = VisibilityMasks {
        rays_per_point: settings.rays_per_point,
        words_per_point: words as u32,
        bits,
    };
    (masks, RayClasses { inside, hidden })
}
