//! Which casters a field run needs: a field is built (or read) only for a
//! mesh with an instance whose field some receiver can consult and be
//! occluded by, so a scene models only what its AO requires.
//!
//! Two reasons make a caster instance's lookups pointless, both exact (the
//! answer with and without the instance is the same bit for bit):
//! - no other receiver: a point never consults its own instance's field
//!   (`field::ao`), so a caster that is the only receiver occludes nothing
//!   through its field (its self-occlusion is ray cast);
//! - out of reach: a field reports hits inside its bounding sphere only, at
//!   t >= the ray's entry into the sphere (`lookup`), so when every receiver
//!   point stays farther than the AO radius from the sphere over all
//!   frames, no hit counts (`t <= radius`), and no point starts inside the
//!   sphere (the ray classes are unchanged too).

use glam::Vec3;

use super::build::bounding_sphere;
use crate::report::skipped::Skipped;
use crate::scene::{Instance, Scene};

/// What a field run covers: AO rays reach `radius` (infinite: no limit)
/// over animation frames `0..frames`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// Largest AO radius, world units (infinite: no limit).
    pub radius: f32,
    /// Animation frames covered, from frame 0.
    pub frames: u32,
}

impl Reach {
    /// Every caster may occlude every other receiver (one frame).
    pub const EVERYTHING: Reach = Reach {
        radius: f32::INFINITY,
        frames: 1,
    };

    /// Whether a run at AO `radius` over `frames` stays within this reach.
    pub fn covers(&self, radius: f32, frames: u32) -> bool {
        radius <= self.radius && frames <= self.frames
    }
}

/// Pairs of bounding spheres compared before the test gives up and keeps
/// every caster (long animations of many instances).
const MOST_SPHERE_TESTS: u64 = 1 << 24;

/// Per instance of `scene`: whether it casts and some other receiver can be
/// occluded by its field within `reach`.
pub fn reaching(scene: &Scene, reach: Reach) -> Vec<bool> {
    let others = |k: usize| {
        scene
            .instances
            .iter()
            .enumerate()
            .filter(move |&(r, i)| r != k && i.role.receives())
    };
    let casters = scene.instances.iter().filter(|i| i.role.casts()).count() as u64;
    let receivers = scene.instances.iter().filter(|i| i.role.receives()).count() as u64;
    let tests = casters * receivers * reach.frames as u64;
    let bounded = reach.radius.is_finite() && tests <= MOST_SPHERE_TESTS;
    // Spheres only where distances decide.
    let spheres: Vec<(Vec3, f32)> = match bounded {
        true => scene.meshes.iter().map(|m| bounding_sphere(&m.mesh)).collect(),
        false => Vec::new(),
    };
    scene
        .instances
        .iter()
        .enumerate()
        .map(|(k, caster)| {
            caster.role.casts()
                && others(k).any(|(_, receiver)| {
                    !bounded || (0..reach.frames).any(|f| within(caster, receiver, &spheres, f, reach.radius))
                })
        })
        .collect()
}

/// Whether `receiver`'s bounding sphere comes within `radius` of
/// `caster`'s at `frame` (the gap between the spheres, with a margin for
/// rounding so the test never skips a caster that could count).
fn within(caster: &Instance, receiver: &Instance, spheres: &[(Vec3, f32)], frame: u32, radius: f32) -> bool {
    let world = |inst: &Instance| {
        let (center, r) = spheres[inst.mesh];
        let t = inst.transform_at(frame);
        (t.apply_point(center), r * t.scale)
    };
    let ((a, ra), (b, rb)) = (world(caster), world(receiver));
    let gap = a.distance(b) - ra - rb;
    let margin = 1e-4 * (a.length() + b.length() + ra + rb + radius);
    gap <= radius + margin
}

/// The caster meshes of `scene` none of whose instances `reaching`, with
/// why, for the report.
pub fn skipped_fields(scene: &Scene, reaching: &[bool], reach: Reach) -> Vec<Skipped> {
    let mut skipped: Vec<Skipped> = Vec::new();
    for (k, inst) in scene.instances.iter().enumerate() {
        let mesh = &scene.meshes[inst.mesh].name;
        let needed = scene
            .instances
            .iter()
            .zip(reaching)
            .any(|(i, &r)| r && i.mesh == inst.mesh);
        if !inst.role.casts() || needed || skipped.iter().any(|s| s.name.as_ref() == Some(mesh)) {
            continue;
        }
        let alone = !scene
            .instances
            .iter()
            .enumerate()
            .any(|(r, i)| r != k && i.role.receives());
        let why = if alone {
            "no other instance receives: its own points never consult its field (self-occlusion is ray cast)".into()
        } else {
            format!(
                "every receiver stays farther than the AO radius {} from its bounding sphere over {} frame(s)",
                reach.radius, reach.frames
            )
        };
        skipped.push(Skipped::named("field", mesh, why));
    }
    skipped
}
