//! Rays and hits in the command-line contract's units.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use rayon::prelude::*;

use crate::geom::aabb::Aabb;

/// A ray `o + t d`. The direction need not be normalised: `t` is measured in
/// units of `d`, as in the `trace-rays` file format.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Ray {
    /// The origin `o`, relative to the traced mesh's `origin` (its frame).
    pub origin: [f32; 3],
    /// The direction `d`, of any length: `t` counts in its units.
    pub dir: [f32; 3],
}

/// `d` with its subnormal components (below `f32::MIN_POSITIVE` in
/// magnitude, not zero) made zeros of their sign. Their reciprocals
/// overflow to infinity, so a walk's slab and split-plane distances take
/// the ray as parallel to a plane that its triangle test, dividing by the
/// largest component instead, sees it cross: the kd-tree and the BVH
/// would disagree. Every walk takes its directions through this first, so
/// all read such a component as the zero it nearly is.
#[inline(always)]
pub fn flush_subnormal(d: Vec3) -> Vec3 {
    Vec3::select(d.abs().cmplt(Vec3::splat(f32::MIN_POSITIVE)), d * 0.0, d)
}

/// `flush_subnormal` of up to 16 directions, copied where one needs it.
#[inline(always)]
pub fn flush_subnormals(dirs: &[Vec3], out: &mut [Vec3; 16]) -> usize {
    for (o, &d) in out.iter_mut().zip(dirs) {
        *o = flush_subnormal(d);
    }
    dirs.len().min(16)
}

impl Ray {
    /// The ray from `origin` along `dir` (not normalised).
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray {
            origin: origin.to_array(),
            dir: dir.to_array(),
        }
    }

    /// The origin as a vector.
    pub fn o(&self) -> Vec3 {
        Vec3::from_array(self.origin)
    }

    /// The direction as a vector.
    pub fn d(&self) -> Vec3 {
        Vec3::from_array(self.dir)
    }
}

/// Closest hit of a ray: `(t, triangle index)`, a miss is `(+inf, MISS)`.
/// Same layout as a `HITS.bin` record and as the GPU kernel's output.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Hit {
    /// Where along the ray the hit is, in units of the ray's direction;
    /// `+inf` for a miss.
    pub t: f32,
    /// The index of the triangle hit in the mesh traced, `MISS_INDEX` for
    /// a miss.
    pub triangle: u32,
}

impl Hit {
    /// Triangle index of a miss.
    pub const MISS_INDEX: u32 = u32::MAX;
    /// The hit of a ray that hits nothing.
    pub const MISS: Hit = Hit {
        t: f32::INFINITY,
        triangle: Hit::MISS_INDEX,
    };

    /// Whether the ray hit a triangle.
    pub fn is_hit(&self) -> bool {
        self.triangle != Hit::MISS_INDEX
    }
}

/// Traces rays in no particular order (a ray file) with `trace` (a batch of
/// rays into their hits), in an order sorted by the octant of their
/// direction and the Morton code of where they enter `bounds`, so that
/// consecutive rays walk the same nodes while they are in cache; the hits
/// come back in the rays' order. The rays are copied into the sorted order
/// first: read through the permutation inside the trace loop, each ray's
/// load missed the cache and waited behind the previous ray's walk (a fifth
/// of the time on 1M random rays); a pass of independent loads overlaps them.
pub fn trace_sorted(bounds: &Aabb, rays: &[Ray], trace: impl Fn(&[Ray], &mut [Hit]) + Sync) -> Vec<Hit> {
    let extent = (bounds.max - bounds.min).max(Vec3::splat(f32::MIN_POSITIVE));
    let mut keyed: Vec<(u64, u32)> = rays
        .par_iter()
        .enumerate()
        .map(|(i, r)| {
            let entry = match bounds.clip_ray(r.o(), r.d(), 0.0, f32::INFINITY) {
                Some((t0, _)) => r.o() + r.d() * t0,
                None => r.o(),
            };
            let q = ((entry - bounds.min) / extent * 1023.0).clamp(Vec3::ZERO, Vec3::splat(1023.0));
            let octant = (r.d().x < 0.0) as u64 | ((r.d().y < 0.0) as u64) << 1 | ((r.d().z < 0.0) as u64) << 2;
            (octant << 30 | morton3(q.x as u32, q.y as u32, q.z as u32), i as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    let sorted: Vec<Ray> = keyed.par_iter().map(|&(_, i)| rays[i as usize]).collect();
    let mut traced = vec![Hit::MISS; rays.len()];
    traced
        .par_chunks_mut(1024)
        .zip(sorted.par_chunks(1024))
        .for_each(|(h, r)| trace(r, h));
    let mut hits = vec![Hit::MISS; rays.len()];
    for (&(_, i), h) in keyed.iter().zip(traced) {
        hits[i as usize] = h;
    }
    hits
}

/// Interleaves the low 10 bits of x, y and z (a Morton code).
fn morton3(x: u32, y: u32, z: u32) -> u64 {
    let spread = |v: u32| (0..10).fold(0u64, |m, b| m | (((v >> b) & 1) as u64) << (3 * b));
    spread(x) | spread(y) << 1 | spread(z) << 2
}
