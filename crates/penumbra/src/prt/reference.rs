//! Monte Carlo ray-traced transfer: the ground truth of Table 1's error
//! column. Per vertex, `rays` cosine-distributed directions (Malley's method
//! on the seeded Owen-scrambled Sobol sequence of `sampling`) are traced
//! against the full-resolution mesh (in packets of 16 through its wide
//! BVH, `Accel::occluded`: the kd-tree's answers) from the vertex lifted by
//! the contract's offset along its normal; with the cosine density
//! `cos θ / π`, equation 3 is estimated by
//! `V*_i ≈ (1/N) Σ_j V(s_j) ρ(s_j) Y_i(s_j)` where `ρ = π f_r`.

use glam::Vec3;
use rayon::prelude::*;

use super::transfer::Brdf;
use crate::accel::kdtree::occlusion::LANES;
use crate::accel::{Accel, Structure};
use crate::geom::sampling::{Frame, SampleSequence, cosine_hemisphere};
use crate::geom::simd::Isa;
use crate::scene::ORIGIN_OFFSET;
use crate::sh::{ShBasis, coefficient_count};

/// Reference transfer vectors (world space, `bands²` per vertex) for the
/// given shading normals (zero normal: zero transfer), the rays traced
/// against `accel`.
#[allow(clippy::too_many_arguments)]
pub fn reference_transfer(
    accel: &Accel,
    positions: &[Vec3],
    normals: &[Vec3],
    scale: f32,
    bands: usize,
    brdf: &Brdf,
    eye: Option<Vec3>,
    rays: u32,
    seed: u32,
) -> Vec<f32> {
    let n = coefficient_count(bands);
    let basis = ShBasis::new(bands);
    let seq = SampleSequence::new(seed);
    let mut out = vec![0.0f32; positions.len() * n];
    out.par_chunks_mut(n).enumerate().with_min_len(4).for_each(|(v, t)| {
        let normal = normals[v];
        if normal == Vec3::ZERO {
            return;
        }
        let p = positions[v];
        let origin = p + normal * (ORIGIN_OFFSET * scale);
        let frame = Frame::from_normal(normal);
        let reflected = match eye {
            Some(e) => {
                let view = (e - p).normalize_or(normal);
                2.0 * normal.dot(view) * normal - view
            }
            None => normal,
        };
        let mut acc = vec![0.0f64; n];
        let mut y = vec![0.0f32; n];
        let stream = seq.stream(v as u32);
        // Sixteen rays at a time through the shared-origin packets (the
        // same answers as `any_hit` one by one), summed in ray order.
        let mut dirs = [Vec3::ZERO; LANES];
        for first in (0..rays).step_by(LANES) {
            let n = (rays - first).min(LANES as u32) as usize;
            for (k, d) in dirs[..n].iter_mut().enumerate() {
                let [u, w] = stream.sample(first + k as u32);
                *d = frame.to_world(cosine_hemisphere(u, w)).normalize();
            }
            // Through the wide BVH: the kd-tree's answers, and the cow's
            // `prt --reference` took 2.97 s instead of 3.36.
            let hit = accel.occluded(Structure::Bvh, origin, &dirs[..n], f32::INFINITY, Isa::best());
            for (_, &d) in dirs[..n].iter().enumerate().filter(|&(k, _)| hit & (1 << k) == 0) {
                let rho = brdf.rho(d, reflected);
                basis.eval(d, &mut y);
                for (a, yi) in acc.iter_mut().zip(&y) {
                    *a += (rho * yi) as f64;
                }
            }
        }
        for (ti, a) in t.iter_mut().zip(&acc) {
            *ti = (a / rays as f64) as f32;
        }
    });
    out
}

/// Relative L2 error per vertex, `|T - T_ref| / |T_ref|`, averaged over
/// vertices whose reference is not (nearly) zero. Returns (mean, vertices
/// counted, vertices skipped).
pub fn relative_l2_error(transfer: &[f32], reference: &[f32], coeffs: usize, floor: f32) -> (f64, usize, usize) {
    let errors = relative_l2_errors(transfer, reference, coeffs, floor);
    let counted: Vec<f64> = errors.iter().flatten().copied().collect();
    let skipped = errors.len() - counted.len();
    let mean = if counted.is_empty() {
        0.0
    } else {
        counted.iter().sum::<f64>() / counted.len() as f64
    };
    (mean, counted.len(), skipped)
}

/// Each vertex's `|T - T_ref| / |T_ref|`, or None where `|T_ref| <= floor`.
pub fn relative_l2_errors(transfer: &[f32], reference: &[f32], coeffs: usize, floor: f32) -> Vec<Option<f64>> {
    transfer
        .chunks(coeffs)
        .zip(reference.chunks(coeffs))
        .map(|(t, r)| {
            let norm: f32 = r.iter().map(|x| x * x).sum::<f32>().sqrt();
            if norm <= floor {
                return None;
            }
            let diff: f32 = t.iter().zip(r).map(|(a, b)| (a - b) * (a - b)).sum::<f32>().sqrt();
            Some((diff / norm) as f64)
        })
        .collect()
}
