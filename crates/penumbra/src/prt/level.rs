//! The coarse level of the two-level hierarchy (section 3.2): the
//! simplified mesh, each fine triangle's cluster, the proxy check
//! (`proxy`), and how many coarse triangles to use.
//!
//! **How coarse.** A vertex pays for every coarse triangle (less those its
//! culling groups skip) plus what the proxy check refines near it. Coarser
//! means fewer far triangles but larger deviations, so more and larger
//! clusters drawn in full. `c + a n / c` is least where the two terms are
//! equal, `c ~ sqrt(a n)`: the first guess is `8 sqrt(n)` (2,100 for the
//! 69K-triangle bunny, whose refinement then draws 242 fine triangles per
//! vertex), capped at the paper's sixteenth of the mesh (its cloth, 2560 ->
//! 160). Where the refined near field outgrows the coarse mesh — a detailed
//! model such as the 100K-triangle dragon, 2,200 fine triangles per vertex at
//! 2,500 coarse ones — the level doubles, up to that sixteenth (an eighth
//! for an animation checked on several poses). The paper's
//! own models keep 160-444 coarse triangles from 2,560 up to 15,854 (its
//! section 4); its hand is smooth.

use glam::Vec3;

use super::Csr;
use super::clusters::assign_clusters;
use super::hierarchy::HierarchySettings;
use super::proxy::{self, Deviation};

/// The coarse level, indices of coarse triangles in simplifier order.
pub struct CoarseLevel {
    pub tris: Vec<[u32; 3]>,
    /// Fine triangle -> its coarse triangle.
    pub cluster_of_fine: Vec<u32>,
    /// Per coarse triangle, the fine triangles drawn when it is not
    /// (`proxy::stand_ins`; its cluster alone without the proxy check).
    pub stand_in: Csr,
    /// Per vertex, the coarse triangles the proxy check replaces there.
    pub refine: Csr,
    pub deviation: Vec<Deviation>,
}

/// The first guess at the coarse level's size for a mesh of `n` triangles
/// (see the module doc).
pub fn default_coarse(n: usize) -> usize {
    (n / 16).min((8.0 * (n as f64).sqrt()) as usize).max(1)
}

/// Builds the coarse level of `triangles` from `poses` (the rest pose
/// first, then poses of the animation; all at unit size), or None where the
/// simplifier cannot reduce the mesh. The coarse mesh and its clusters come
/// from the rest pose; the proxy check holds on every pose (a coarse
/// triangle true to a straight finger strays once the finger curls).
pub fn coarse_level(poses: &[&[Vec3]], triangles: &[[u32; 3]], s: &HierarchySettings) -> Option<CoarseLevel> {
    let n = triangles.len();
    let rest = poses[0];
    let mut target = s.coarse_triangles.unwrap_or_else(|| default_coarse(n));
    let mut kept: Option<(f64, CoarseLevel)> = None;
    loop {
        let level = build(poses, triangles, target, s.tolerance)?;
        // Fine triangles a vertex draws for the proxy check, on average.
        let near: usize = level
            .refine
            .items
            .iter()
            .map(|&c| level.stand_in.get(c as usize).len())
            .sum();
        let near = near as f64 / rest.len().max(1) as f64;
        // What a vertex considers: every coarse triangle and its near field.
        // For an animation a doubled level that costs more than the one
        // before it is not kept (the balance `c ~ sqrt(a n)` assumes the
        // near field shrinks as fast as the level grows, which the cloth's
        // smooth sheet does not). Static meshes keep the rule they were
        // measured with (the dragon: doubling costs nothing in frame time
        // and is 0.5 points more accurate).
        let cost = level.tris.len() as f64 + near;
        if let Some((before, _)) = &kept
            && cost >= *before
            && poses.len() > 1
        {
            return kept.map(|(_, level)| level);
        }
        // An animation's poses refine more (a coarse finger true to the
        // straight hand strays once it grips), which moves the balance
        // point to a finer coarse level: up to an eighth of the mesh.
        let most = (n / if poses.len() > 1 { 8 } else { 16 }).max(1);
        if s.coarse_triangles.is_some() || near <= level.tris.len() as f64 || target >= most {
            return Some(level);
        }
        kept = Some((cost, level));
        target = (2 * target).min(most);
    }
}

fn build(poses: &[&[Vec3]], triangles: &[[u32; 3]], target: usize, tolerance: f32) -> Option<CoarseLevel> {
    let rest = poses[0];
    let tris = simplify(rest, triangles, target);
    if tris.is_empty() || tris.len() >= triangles.len() {
        return None;
    }
    let cluster_of_fine = assign_clusters(rest, triangles, &tris);
    let members = Csr::from_lists(
        tris.len(),
        cluster_of_fine.iter().enumerate().map(|(f, &c)| (c as usize, f as u32)),
    );
    // Coarse triangles whose error subtends too much at a vertex are
    // replaced there by what they stand for (`proxy`).
    let (refine, stand_in, deviation) = if tolerance > 0.0 {
        let mut checked = poses.iter().map(|pose| {
            let deviation = proxy::deviations(pose, triangles, &tris, &members);
            let refine = proxy::too_coarse(pose, &tris, &deviation, tolerance);
            (refine, proxy::stand_ins(&members, &deviation), deviation)
        });
        let first = checked.next().expect("the rest pose");
        checked.fold(first, |(refine, stand_in, mut deviation), (r, s, d)| {
            // Reported: the largest deviation a coarse triangle reaches.
            for (kept, posed) in deviation.iter_mut().zip(d) {
                kept.max = kept.max.max(posed.max);
            }
            (refine.union(&r), stand_in.union(&s), deviation)
        })
    } else {
        (Csr::from_vecs(&vec![Vec::new(); rest.len()]), members, Vec::new())
    };
    Some(CoarseLevel {
        tris,
        cluster_of_fine,
        stand_in,
        refine,
        deviation,
    })
}

/// The coarse mesh: meshoptimizer's simplifier on the rest pose, aiming at
/// `target` triangles with no error bound (it stops earlier only where the
/// topology forbids collapses). Without the `simplify` feature there is no
/// simplifier: no coarse level is made and every vertex considers every
/// triangle, as with the hierarchy off.
#[cfg(not(feature = "simplify"))]
fn simplify(_rest: &[Vec3], _triangles: &[[u32; 3]], _target: usize) -> Vec<[u32; 3]> {
    Vec::new()
}

/// The coarse mesh: meshoptimizer's simplifier on the rest pose, aiming at
/// `target` triangles with no error bound (it stops earlier only where the
/// topology forbids collapses).
#[cfg(feature = "simplify")]
fn simplify(rest: &[Vec3], triangles: &[[u32; 3]], target: usize) -> Vec<[u32; 3]> {
    // A target of the whole mesh or more keeps it whole (`--coarse` at its
    // top end); meshoptimizer asserts, aborting the process, above it.
    if target >= triangles.len() {
        return triangles.to_vec();
    }
    let positions: Vec<[f32; 3]> = rest.iter().map(|p| p.to_array()).collect();
    let Ok(adapter) = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&positions), 12, 0) else {
        return Vec::new();
    };
    let indices: Vec<u32> = triangles.iter().flatten().copied().collect();
    let out = meshopt::simplify(
        &indices,
        &adapter,
        target * 3,
        1.0,
        meshopt::SimplifyOptions::None,
        None,
    );
    out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}
