//! Spherical rasterisation of blocker triangles into a visibility mask
//! (section 3.1.1, Figure 2): the CPU twin of `wgsl/hemi_raster.wgsl`.
//!
//! Each edge of a triangle abc (in the tangent frame, origin at the vertex)
//! defines a plane through the origin with normal `a × b`. With
//! `det = (a × b) · c`, the point c lies on the positive side of the edge
//! ab exactly when det > 0, and `(b × c)·a = (c × a)·b = det` too; so the
//! three normals `sign(det) (a×b, b×c, c×a)` all point into the triangle's
//! cone, and a pixel direction d is inside the spherical image iff
//! `d · m_e > 0` for all three edges (Figure 2a-c). The LUT gives each
//! half-space's mask; their AND is the triangle's coverage (Figure 2d), and
//! OR-ing coverage into the vertex's mask is the paper's occluder fusion.
//!
//! The face normal `(b - a) × (c - a)` satisfies `N · a = det`, so a
//! triangle faces the vertex (N points towards the origin) iff det < 0:
//! back-face culling is a sign test on the same determinant. `det = 0`
//! means the origin lies in the triangle's plane (seen edge-on: zero solid
//! angle); such triangles, zero-area ones included, are skipped.

use glam::Vec3;

use super::lut::PlaneLut;
use super::mask::MaskGrid;

/// Relative size of |det| below which a triangle counts as seen edge-on
/// (its solid angle is then below about 1e-6 sr).
pub const EDGE_ON: f32 = 1e-6;

/// What happened to one blocker triangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fate {
    BelowHorizon,
    BackFacing,
    EdgeOn,
    Drawn,
}

/// The three inward edge-plane normals of a triangle seen from the origin,
/// or why it covers nothing.
#[inline(always)]
pub fn edge_planes(t: &[Vec3; 3], cull_backfaces: bool) -> Result<[Vec3; 3], Fate> {
    let [a, b, c] = *t;
    if a.z <= 0.0 && b.z <= 0.0 && c.z <= 0.0 {
        return Err(Fate::BelowHorizon);
    }
    let ab = a.cross(b);
    let det = ab.dot(c);
    let scale = a.length_squared() * b.length_squared() * c.length_squared();
    if det * det <= EDGE_ON * EDGE_ON * scale || !det.is_finite() {
        return Err(Fate::EdgeOn);
    }
    if cull_backfaces && det > 0.0 {
        return Err(Fate::BackFacing);
    }
    let s = if det > 0.0 { 1.0 } else { -1.0 };
    Ok([ab * s, b.cross(c) * s, c.cross(a) * s])
}

/// Rasterises one triangle with the LUT, OR-ing its coverage into `mask`
/// (`W` u64 words).
#[inline(always)]
pub fn raster_triangle<const W: usize>(lut: &PlaneLut, t: &[Vec3; 3], cull_backfaces: bool, mask: &mut [u64; W]) -> Fate {
    match edge_planes(t, cull_backfaces) {
        Ok(planes) => {
            or_coverage(lut, &planes, mask);
            Fate::Drawn
        }
        Err(f) => f,
    }
}

/// AND of the three half-space masks, OR-ed into `mask`.
#[inline(always)]
pub fn or_coverage<const W: usize>(lut: &PlaneLut, planes: &[Vec3; 3], mask: &mut [u64; W]) {
    // The planes are non-zero (det != 0), so every lookup succeeds.
    let r = planes.map(|m| lut.lookup(m).expect("non-zero plane normal"));
    let flip = r.map(|r| if r.complement { u64::MAX } else { 0 });
    let m0: &[u64; W] = lut.mask(r[0].entry).try_into().expect("W words");
    let m1: &[u64; W] = lut.mask(r[1].entry).try_into().expect("W words");
    let m2: &[u64; W] = lut.mask(r[2].entry).try_into().expect("W words");
    for k in 0..W {
        mask[k] |= (m0[k] ^ flip[0]) & (m1[k] ^ flip[1]) & (m2[k] ^ flip[2]);
    }
}

/// The exact mask of one triangle: every pixel direction tested against the
/// three edge planes (the reference for the LUT's quantisation error).
pub fn raster_triangle_exact(grid: &MaskGrid, t: &[Vec3; 3], cull_backfaces: bool, mask: &mut [u64]) -> Fate {
    match edge_planes(t, cull_backfaces) {
        Ok([m0, m1, m2]) => {
            for (p, d) in grid.dirs.iter().enumerate() {
                if d.dot(m0) > 0.0 && d.dot(m1) > 0.0 && d.dot(m2) > 0.0 {
                    mask[p / 64] |= 1 << (p % 64);
                }
            }
            Fate::Drawn
        }
        Err(f) => f,
    }
}
