//! AO rays through the MLRTA machinery: the rays of one point share their
//! origin, so each point's rays are sorted by sign class (octant) and traced
//! in packets of up to 16 with their own entry points. The result is the same
//! visibility mask `ao::raycast::ao_rays` computes, ray for ray.

use glam::Vec3;
use rayon::prelude::*;

use crate::geom::sampling::SampleSequence;
use crate::mlrta::entry_point::EntryPoint;
use crate::mlrta::frustum::sign_class;
use crate::mlrta::packet::{MlrtaCounts, PACKET};
use crate::mlrta::prepared::Prepared;
use crate::mlrta::tiles::{Group, trace_group};
use crate::progress::Bar;
use crate::raycast::{AoPoint, AoSettings, PointDirections, VisibilityMasks};

/// Casts the AO rays of every point as packets (rayon over points).
pub fn visibility_mlrta(
    p: &Prepared,
    points: &[AoPoint],
    settings: &AoSettings,
    progress: &Bar,
) -> (VisibilityMasks, MlrtaCounts) {
    let words = settings.words_per_point() as usize;
    let seq = SampleSequence::new(settings.seed);
    let mut bits = vec![0u32; points.len() * words];
    let counts = bits
        .par_chunks_mut(words)
        .zip(points.par_iter())
        .with_min_len(16)
        .map(|(mask, point)| {
            let mut counts = MlrtaCounts::default();
            point_visibility(p, &seq, point, settings, mask, &mut counts);
            progress.inc(1);
            counts
        })
        .reduce(MlrtaCounts::default, |mut a, b| {
            a += b;
            a
        });
    let masks = VisibilityMasks {
        rays_per_point: settings.rays_per_point,
        words_per_point: words as u32,
        bits,
    };
    (masks, counts)
}

fn point_visibility(
    p: &Prepared,
    seq: &SampleSequence,
    point: &AoPoint,
    settings: &AoSettings,
    mask: &mut [u32],
    counts: &mut MlrtaCounts,
) {
    let n = settings.rays_per_point;
    if !point.has_hemisphere() {
        for j in 0..n {
            mask[(j / 32) as usize] |= 1 << (j % 32);
        }
        return;
    }
    let origin = Vec3::from_array(point.origin);
    let normal = Vec3::from_array(point.normal);
    let point_dirs = PointDirections::new(seq, point.stream, normal);
    let dirs: Vec<Vec3> = (0..n).map(|j| point_dirs.direction(j)).collect();
    // Rays sorted by octant, so that packets are coherent.
    let mut order: Vec<u32> = (0..n).collect();
    order.sort_by_key(|&j| sign_class(dirs[j as usize]).unwrap_or(8));
    let root = EntryPoint::root(p);
    let origin_inside = p.inside_object(origin);
    for chunk in order.chunks(PACKET) {
        let group_dirs: Vec<Vec3> = chunk.iter().map(|&j| dirs[j as usize]).collect();
        let group = Group {
            origin,
            dirs: &group_dirs,
            t_max: settings.radius,
            any_hit: true,
        };
        let hits = trace_group(p, &group, &root, Some(origin_inside), counts);
        for (k, &j) in chunk.iter().enumerate() {
            if !hits[k].is_hit() {
                mask[(j / 32) as usize] |= 1 << (j % 32);
            }
        }
    }
}
