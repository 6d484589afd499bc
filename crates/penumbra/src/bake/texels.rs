//! Texture space: which surface point each texel of an AO texture stands
//! for. A texel's sample (its centre, or `samples` jittered points) that
//! falls inside a triangle of the mesh's UV layout gets an AO point at the
//! corresponding surface point, its normal the triangle's interpolated
//! vertex normals (the very normals per-vertex AO uses, so the texture at a
//! corner's UV estimates that vertex's AO), off the surface by the same
//! distance. Texel rows run from the top of the image (v = 1, v up) down,
//! as glTF samples them after its v flip.

use glam::{Vec2, Vec3};

use crate::geom::sampling::{hash_u32, unit_float};
use crate::raycast::AoPoint;
use crate::scene::{Mesh, MeshShading};

/// A texel no sample of which falls on a triangle.
pub const EMPTY: u32 = u32::MAX;

/// The AO points of a texture and where they belong.
#[derive(Debug, Clone, Default)]
pub struct TexelPoints {
    /// Texels per side.
    pub resolution: u32,
    /// Samples per texel.
    pub samples: u32,
    /// One per covered sample, its stream the sample's index
    /// (`texel * samples + s`) so that results do not depend on batching.
    pub points: Vec<AoPoint>,
    /// Per point, its texel.
    pub texel: Vec<u32>,
    /// Texels with at least one covered sample.
    pub covered: usize,
    /// Samples that fall inside more than one triangle (mirrored halves or
    /// stacked shells): the first triangle (in mesh order) has them.
    pub overlapping_samples: usize,
    /// Triangles with a corner outside [0, 1]^2 (only the part inside is
    /// baked).
    pub triangles_outside_unit_square: usize,
    /// Triangles without texture coordinates (not baked).
    pub triangles_without_uv: usize,
}

/// The sample point `s` of `samples` in texel `texel`, in texels from its
/// corner: the centre for one sample, else jittered by a hash of both.
fn sample_offset(texel: u32, s: u32, samples: u32) -> Vec2 {
    if samples == 1 {
        return Vec2::splat(0.5);
    }
    let h = hash_u32(texel.wrapping_mul(0x9e37_79b9) ^ hash_u32(s.wrapping_add(0x51ed_270b)));
    Vec2::new(unit_float(h), unit_float(hash_u32(h ^ 0x68e3_1da4)))
}

/// The AO points of `mesh`'s UV layout (`shading`) at `resolution` texels a
/// side, `samples` a texel.
pub fn texel_points(mesh: &Mesh, shading: &MeshShading, resolution: u32, samples: u32) -> TexelPoints {
    texel_points_in(
        mesh,
        &mesh.vertex_normals(),
        shading,
        resolution,
        samples,
        0..resolution,
    )
}

/// `texel_points` of the texel rows `rows` only (a band of the texture:
/// large textures are baked band by band), `normals` the mesh's vertex
/// normals. Texel indices are the whole texture's.
pub fn texel_points_in(
    mesh: &Mesh,
    normals: &[Vec3],
    shading: &MeshShading,
    resolution: u32,
    samples: u32,
    rows: std::ops::Range<u32>,
) -> TexelPoints {
    let n = resolution as usize;
    let offset = mesh.origin_offset();
    let per_texel = samples as usize;
    let first_texel = rows.start as usize * n;
    // Per sample of the band, the triangle that has it.
    let mut owner = vec![EMPTY; (rows.end - rows.start) as usize * n * per_texel];
    let mut out = TexelPoints {
        resolution,
        samples,
        ..Default::default()
    };
    let size = resolution as f32;
    let band = (rows.start as f32, rows.end as f32);
    for (t, corners) in shading.corner_texcoords.iter().enumerate() {
        let Some(c) = corners else {
            out.triangles_without_uv += 1;
            continue;
        };
        let uv = c.map(|i| shading.texcoords[i as usize]);
        if uv
            .iter()
            .any(|p| !(0.0..=1.0).contains(&p.x) || !(0.0..=1.0).contains(&p.y))
        {
            out.triangles_outside_unit_square += 1;
        }
        // In texels: x along u, y down the image.
        let q = uv.map(|p| Vec2::new(p.x * size, (1.0 - p.y) * size));
        let area = edge(q[0], q[1], q[2]);
        if area == 0.0 || !area.is_finite() {
            continue;
        }
        let lo = q[0].min(q[1]).min(q[2]).floor().max(Vec2::new(0.0, band.0));
        let hi = q[0].max(q[1]).max(q[2]).ceil().min(Vec2::new(size, band.1));
        for y in lo.y as u32..hi.y as u32 {
            for x in lo.x as u32..hi.x as u32 {
                let texel = y * resolution + x;
                for s in 0..samples {
                    let p = Vec2::new(x as f32, y as f32) + sample_offset(texel, s, samples);
                    let w = [edge(q[1], q[2], p), edge(q[2], q[0], p), edge(q[0], q[1], p)].map(|e| e / area);
                    if w.iter().any(|&b| b < 0.0) {
                        continue;
                    }
                    let slot = (texel as usize - first_texel) * per_texel + s as usize;
                    if owner[slot] != EMPTY {
                        // On an edge two neighbours share, the first has it;
                        // strictly inside another triangle, the UVs overlap.
                        if w.iter().all(|&b| b > 0.0) {
                            out.overlapping_samples += 1;
                        }
                        continue;
                    }
                    owner[slot] = t as u32;
                    let tri = mesh.triangles[t];
                    let at = |f: &dyn Fn(usize) -> Vec3| f(0) * w[0] + f(1) * w[1] + f(2) * w[2];
                    let point = at(&|k| mesh.positions[tri[k] as usize]);
                    let mut normal = at(&|k| normals[tri[k] as usize]).normalize_or_zero();
                    if normal == Vec3::ZERO {
                        normal = mesh.unit_face_normal(t);
                    }
                    out.points
                        .push(AoPoint::new(point + offset * normal, normal, texel * samples + s));
                    out.texel.push(texel);
                }
            }
        }
    }
    let mut seen = vec![false; (rows.end - rows.start) as usize * n];
    for &t in &out.texel {
        seen[t as usize - first_texel] = true;
    }
    out.covered = seen.iter().filter(|&&c| c).count();
    out
}

/// Twice the signed area of (a, b, p): positive where p is left of a -> b.
fn edge(a: Vec2, b: Vec2, p: Vec2) -> f32 {
    (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)
}

/// Per texel, the mean AO of its covered samples (`ao` per point of
/// `points`); `None` for an empty texel.
pub fn texel_values(points: &TexelPoints, ao: &[f32]) -> Vec<Option<f32>> {
    let mut values = vec![None; (points.resolution * points.resolution) as usize];
    add_texel_values(points, ao, &mut values, 0);
    values
}

/// `texel_values` of a band written into `values`, which holds the texels
/// from index `first` on (the whole texture for 0).
pub fn add_texel_values(points: &TexelPoints, ao: &[f32], values: &mut [Option<f32>], first: usize) {
    let (Some(&lo), Some(&hi)) = (points.texel.iter().min(), points.texel.iter().max()) else {
        return;
    };
    let mut sums = vec![(0.0f64, 0u32); (hi - lo + 1) as usize];
    for (&t, &a) in points.texel.iter().zip(ao) {
        let e = &mut sums[(t - lo) as usize];
        e.0 += a as f64;
        e.1 += 1;
    }
    for (k, &(s, c)) in sums.iter().enumerate().filter(|(_, e)| e.1 > 0) {
        values[lo as usize + k - first] = Some((s / c as f64) as f32);
    }
}

/// Fills empty texels next to filled ones, `padding` rings deep: each ring
/// takes, per empty texel, the mean of its filled 8-neighbours of the ring
/// before, so bilinear and mip-mapped lookups at a chart's edge see the
/// chart's values rather than the background.
pub fn dilate(values: &mut [Option<f32>], resolution: u32, padding: u32) {
    let n = resolution as i64;
    for _ in 0..padding {
        let before = values.to_vec();
        let mut changed = false;
        for y in 0..n {
            for x in 0..n {
                let i = (y * n + x) as usize;
                if before[i].is_some() {
                    continue;
                }
                let (mut sum, mut count) = (0.0f32, 0u32);
                for (dx, dy) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                    let (u, v) = (x + dx, y + dy);
                    if (0..n).contains(&u)
                        && (0..n).contains(&v)
                        && let Some(a) = before[(v * n + u) as usize]
                    {
                        sum += a;
                        count += 1;
                    }
                }
                if count > 0 {
                    values[i] = Some(sum / count as f32);
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dilation_grows_a_chart_by_its_padding_with_its_values() {
        let mut v = vec![None; 25];
        v[12] = Some(0.5);
        dilate(&mut v, 5, 1);
        assert_eq!(v.iter().filter(|x| x.is_some()).count(), 9);
        assert!(v.iter().flatten().all(|&x| x == 0.5));
        dilate(&mut v, 5, 1);
        assert!(v.iter().all(|x| x == &Some(0.5)));
    }

    #[test]
    fn a_quad_over_the_unit_square_covers_every_texel_once() {
        let mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        };
        let shading = MeshShading {
            materials: Vec::new(),
            triangle_materials: vec![0, 0],
            triangle_faces: vec![0, 0],
            normals: Vec::new(),
            corner_normals: vec![None, None],
            texcoords: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            corner_texcoords: vec![Some([0, 1, 2]), Some([0, 2, 3])],
        };
        let p = texel_points(&mesh, &shading, 8, 1);
        assert_eq!(p.covered, 64);
        assert_eq!(p.points.len(), 64, "the diagonal's texels go to one triangle");
        // Texel (0, 0) is the image's top left: u = 1/16, v = 15/16.
        let first = p.texel.iter().position(|&t| t == 0).unwrap();
        let o = Vec3::from_array(p.points[first].origin);
        assert!(
            (o.x - 1.0 / 16.0).abs() < 1e-3 && (o.y - 15.0 / 16.0).abs() < 1e-3,
            "{o}"
        );
        assert_eq!(p.overlapping_samples, 0);
    }

    #[test]
    fn bands_of_rows_give_the_whole_texture_s_points() {
        let mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(0.3, 1.0, 0.2)],
            triangles: vec![[0, 1, 2]],
            ..Default::default()
        };
        let shading = MeshShading {
            materials: Vec::new(),
            triangle_materials: vec![0],
            triangle_faces: vec![0],
            normals: Vec::new(),
            corner_normals: vec![None],
            texcoords: vec![Vec2::new(0.1, 0.1), Vec2::new(0.9, 0.2), Vec2::new(0.4, 0.95)],
            corner_texcoords: vec![Some([0, 1, 2])],
        };
        let whole = texel_points(&mesh, &shading, 32, 2);
        let normals = mesh.vertex_normals();
        let mut banded = Vec::new();
        for rows in [0..5, 5..17, 17..32] {
            banded.extend(texel_points_in(&mesh, &normals, &shading, 32, 2, rows).points);
        }
        let key = |p: &AoPoint| p.stream;
        let (mut a, mut b) = (whole.points.clone(), banded);
        a.sort_by_key(key);
        b.sort_by_key(key);
        assert!(!a.is_empty());
        assert_eq!(a, b);
    }

    #[test]
    fn stacked_shells_are_counted_not_averaged() {
        let mesh = Mesh {
            positions: vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::Y,
                Vec3::Z,
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(0.0, 1.0, 1.0),
            ],
            triangles: vec![[0, 1, 2], [3, 4, 5]],
            ..Default::default()
        };
        let shading = MeshShading {
            materials: Vec::new(),
            triangle_materials: vec![0, 0],
            triangle_faces: vec![0, 1],
            normals: Vec::new(),
            corner_normals: vec![None, None],
            texcoords: vec![Vec2::ZERO, Vec2::X, Vec2::Y],
            corner_texcoords: vec![Some([0, 1, 2]), Some([0, 1, 2])],
        };
        let p = texel_points(&mesh, &shading, 16, 1);
        assert!(p.overlapping_samples > 100, "{}", p.overlapping_samples);
        assert_eq!(p.points.len(), p.covered, "each texel once, from the first shell");
    }
}
