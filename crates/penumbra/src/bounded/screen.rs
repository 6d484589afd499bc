//! Screen-space work of a frame: the pixels whose eye lines lie in a cell
//! (reprojection), and span filling between reprojected pixels.

use glam::{DVec3, Vec3};

use crate::bounded::frame::PixelPath;
use crate::bounded::linespace::FacePair;
use crate::whitted::pixel_rays::PixelRays;
use crate::whitted::whitted::WhittedUniforms;

/// `claimed` of a pixel two reprojected cells claim.
pub(crate) const CONFLICT: u32 = u32::MAX - 1;

/// The pixels whose eye lines lie in the cell, oriented as its lines: the
/// box of its faces' corners projected (or, with the eye between the faces,
/// of its hits, where every such pixel's ray lands), each pixel then tested.
pub(crate) fn pixels_in_cell(
    params: &WhittedUniforms,
    rays: &PixelRays,
    pair: &FacePair,
    cell: &crate::bounded::linespace::CellBox,
    (hits_lo, hits_hi): (DVec3, DVec3),
    eye: DVec3,
) -> Vec<u32> {
    let forward = Vec3::from_array(params.forward).as_dvec3();
    let right = Vec3::from_array(params.right).as_dvec3();
    let up = Vec3::from_array(params.up).as_dvec3();
    let (w, h) = (params.width as f64, params.height as f64);
    // Per group of corners (the front face's, the back face's; or the
    // hits' box) the box of their image; a line of the cell crosses both
    // faces, so its pixel lies in both boxes: their intersection is what
    // is scanned (the union was several times the cell's pixels).
    let mut lo = [[f64::INFINITY; 2]; 2];
    let mut hi = [[f64::NEG_INFINITY; 2]; 2];
    let before = pair.before_front(eye);
    for k in 0..8usize {
        let p = if !before {
            DVec3::select(glam::BVec3::new(k & 1 == 1, k & 2 == 2, k & 4 == 4), hits_hi, hits_lo)
        } else if k < 4 {
            // The front face's four corners (a, b), then the back face's (c, d).
            let c = cell.corner(pair, k);
            pair.point(c[0], c[1], true)
        } else {
            let c = cell.corner(pair, (k - 4) << 2);
            pair.point(c[2], c[3], false)
        };
        let v = p - eye;
        let z = v.dot(forward);
        if z <= 0.0 {
            return Vec::new();
        }
        // Image coordinates of the direction (inverse of pixel_ray).
        let sx = v.dot(right) / right.length_squared() / z;
        let sy = v.dot(up) / up.length_squared() / z;
        let (x, y) = ((sx + 1.0) * 0.5 * w, (1.0 - sy) * 0.5 * h);
        // The hits' box is one group: both slots take all its corners.
        let groups = if before { k / 4..k / 4 + 1 } else { 0..2 };
        for g in groups {
            lo[g] = [lo[g][0].min(x), lo[g][1].min(y)];
            hi[g] = [hi[g][0].max(x), hi[g][1].max(y)];
        }
    }
    let lo = [lo[0][0].max(lo[1][0]), lo[0][1].max(lo[1][1])];
    let hi = [hi[0][0].min(hi[1][0]), hi[0][1].min(hi[1][1])];
    if lo[0] > hi[0] || lo[1] > hi[1] {
        return Vec::new();
    }
    let x0 = (lo[0].floor().max(0.0)) as u32;
    let y0 = (lo[1].floor().max(0.0)) as u32;
    let x1 = (hi[0].ceil().min(w)) as u32;
    let y1 = (hi[1].ceil().min(h)) as u32;
    let mut out = Vec::new();
    for y in y0..y1 {
        for x in x0..x1 {
            let i = y * params.width + x;
            let (_, d) = rays.ray(i);
            let oriented = (d[pair.axis] > 0.0) == pair.positive;
            if oriented && pair.coords(eye, d.as_dvec3()).is_some_and(|c| cell.contains(pair, &c)) {
                out.push(i);
            }
        }
    }
    out
}

/// Section 6.2: along each row, a run of reprojected pixels of one cell
/// is filled by screen-space interpolation between its ends.
pub(crate) fn span_fill(width: u32, claimed: &[u32], radiance: &mut [Vec3], paths: &mut [PixelPath]) {
    for (y, row) in claimed.chunks(width as usize).enumerate() {
        let base = y * width as usize;
        let mut x = 0;
        while x < row.len() {
            let c = row[x];
            let mut end = x;
            while end + 1 < row.len() && row[end + 1] == c {
                end += 1;
            }
            if c < CONFLICT && end >= x + 2 {
                let (a, b) = (radiance[base + x], radiance[base + end]);
                for k in x + 1..end {
                    let s = (k - x) as f32 / (end - x) as f32;
                    radiance[base + k] = a.lerp(b, s);
                    paths[base + k] = PixelPath::SpanFilled;
                }
            }
            x = end + 1;
        }
    }
}
