//! Small geometric helpers of the hierarchy and the mesh analysis.

use std::collections::HashMap;

use glam::Vec3;

/// Per vertex, the first vertex at exactly the same position: meshes cut
/// into patches (the teapot) or split for texture seams repeat vertices,
/// which topology (rings, boundary edges) must see through.
pub fn weld(positions: &[Vec3]) -> Vec<u32> {
    let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(positions.len());
    positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            // +0.0 and -0.0 are one position.
            let key = (*p + Vec3::ZERO).to_array().map(f32::to_bits);
            *first.entry(key).or_insert(i as u32)
        })
        .collect()
}

/// Squared distance from p to triangle t.
#[inline]
pub fn point_triangle_distance_sq(p: Vec3, t: &[Vec3; 3]) -> f32 {
    let w = closest_barycentric(p, t);
    (p - (t[0] * w[0] + t[1] * w[1] + t[2] * w[2])).length_squared()
}

/// Barycentric coordinates of the point of triangle t closest to p
/// (Ericson, Real-Time Collision Detection, 5.1.5).
pub fn closest_barycentric(p: Vec3, t: &[Vec3; 3]) -> [f32; 3] {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    [1.0 - v - w, v, w]
}
