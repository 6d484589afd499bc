//! AO by ray casting on the CPU: the reference path and the twin of
//! `wgsl/ao_rays.wgsl` (`ao_rays`, `ao_samples`).

use glam::Vec3;
use rayon::prelude::*;

use super::{AoPoint, AoSettings, PointDirections, VisibilityMasks, packets, ray_direction};
use crate::accel::{Accel, Structure};
use crate::geom::sampling::SampleSequence;
use crate::geom::simd::Isa;
use crate::progress::Bar;
use crate::raycast::holes::closest_past_holes;
use crate::scene::cutouts::Cutouts;

/// How the CPU casts a point's AO rays; every way gives the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Casting {
    /// One ray at a time (`KdTree::any_hit`).
    Single,
    /// Packets of 16 sharing the origin (`raycast::packets`) through a
    /// structure (`Accel::occluded_in`), in an instruction set.
    Packets(Structure, Isa),
}

/// Casts `rays_per_point` AO rays from every point (rayon, all threads of the
/// current pool) and returns which escaped: packets of 16 in the widest
/// instruction set the CPU has, through the kd-tree (the twin of the
/// `ao_rays` kernel; `tracer::Tracer` casts them through the wide BVH on
/// the CPU, `Structure::Bvh`).
pub fn ao_rays(accel: &Accel, points: &[AoPoint], settings: &AoSettings, progress: &Bar) -> VisibilityMasks {
    let casting = Casting::Packets(Structure::Kdtree, Isa::best());
    ao_rays_by(accel, points, settings, progress, casting)
}

/// `ao_rays`, casting the rays as `casting` says.
pub fn ao_rays_by(
    accel: &Accel,
    points: &[AoPoint],
    settings: &AoSettings,
    progress: &Bar,
    casting: Casting,
) -> VisibilityMasks {
    ao_rays_through(accel, None, points, settings, progress, casting)
}

/// `ao_rays_by` with the holes of `cutouts` (of the traced mesh) let
/// through: a ray found blocked is cast again, closest hit after closest
/// hit, past every hole it meets (`holes::closest_past_holes`; the twin of
/// `ao_rays` in wgsl/ao_rays.wgsl with its cut-outs bound).
pub fn ao_rays_through(
    accel: &Accel,
    cutouts: Option<&Cutouts>,
    points: &[AoPoint],
    settings: &AoSettings,
    progress: &Bar,
    casting: Casting,
) -> VisibilityMasks {
    let words = settings.words_per_point() as usize;
    let seq = SampleSequence::new(settings.seed);
    let mut bits = vec![0u32; points.len() * words];
    bits.par_chunks_mut(words)
        .zip(points.par_iter())
        .with_min_len(16)
        .for_each(|(mask, point)| {
            point_visibility(accel, &seq, point, settings, casting, mask);
            if let Some(cutouts) = cutouts {
                open_holes(accel, cutouts, &seq, point, settings, casting, mask);
            }
            progress.inc(1);
        });
    VisibilityMasks {
        rays_per_point: settings.rays_per_point,
        words_per_point: words as u32,
        bits,
    }
}

fn point_visibility(
    accel: &Accel,
    seq: &SampleSequence,
    point: &AoPoint,
    settings: &AoSettings,
    casting: Casting,
    mask: &mut [u32],
) {
    let n = settings.rays_per_point;
    if !point.has_hemisphere() {
        for j in 0..n {
            mask[(j / 32) as usize] |= 1 << (j % 32);
        }
        return;
    }
    let origin = Vec3::from_array(point.origin);
    let dirs = PointDirections::new(seq, point.stream, Vec3::from_array(point.normal));
    match casting {
        Casting::Packets(structure, isa) => {
            packets::point_visibility((accel, structure), origin, &dirs, n, settings.radius, isa, mask)
        }
        Casting::Single => {
            let tree = accel.kdtree();
            for j in 0..n {
                if !tree.any_hit(origin, dirs.direction(j), settings.radius) {
                    mask[(j / 32) as usize] |= 1 << (j % 32);
                }
            }
        }
    }
}

/// Sets the bits of the rays of `point` that `point_visibility` found
/// blocked but that escape through cut-out holes.
fn open_holes(
    accel: &Accel,
    cutouts: &Cutouts,
    seq: &SampleSequence,
    point: &AoPoint,
    settings: &AoSettings,
    casting: Casting,
    mask: &mut [u32],
) {
    if !point.has_hemisphere() {
        return;
    }
    let structure = match casting {
        Casting::Packets(structure, _) => structure,
        Casting::Single => Structure::Kdtree,
    };
    let origin = Vec3::from_array(point.origin);
    let dirs = PointDirections::new(seq, point.stream, Vec3::from_array(point.normal));
    let triangles = &accel.kdtree().triangles;
    for j in 0..settings.rays_per_point {
        let (word, bit) = ((j / 32) as usize, 1 << (j % 32));
        if mask[word] & bit != 0 {
            continue;
        }
        let hit = closest_past_holes(
            cutouts,
            triangles,
            origin,
            dirs.direction(j),
            settings.radius,
            |o, d, t| accel.closest_hit(structure, o, d, t),
        );
        if !hit.is_hit() {
            mask[word] |= bit;
        }
    }
}

/// The sample point and direction of every AO ray (point-major): what the
/// `ao_samples` kernel writes, per ray `([u, v], direction)`.
pub fn ao_samples(points: &[AoPoint], settings: &AoSettings) -> Vec<([f32; 2], [f32; 3])> {
    let seq = SampleSequence::new(settings.seed);
    points
        .iter()
        .flat_map(|p| {
            let normal = Vec3::from_array(p.normal);
            let seq = &seq;
            (0..settings.rays_per_point).map(move |j| {
                let uv = seq.sample(p.stream, j);
                (uv, ray_direction(seq, p.stream, j, normal).to_array())
            })
        })
        .collect()
}
