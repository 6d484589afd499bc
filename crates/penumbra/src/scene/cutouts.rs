//! Alpha cut-outs as occluders see them: which triangles of a merged mesh
//! have a cut-out map (MTL `map_d`, glTF `alphaMode` MASK or BLEND), their
//! corners' texture coordinates, and the maps' texels. A ray that hits such
//! a triangle where the map's value is below the cut-off passes through, for
//! every method that casts rays through the scene (AO rays, field builds,
//! G-buffers), on the CPU and in `wgsl/texture_maps.wgsl` alike.
//!
//! Everything lives in one array of words (`Cutouts::words`) that the
//! kernels read as the CPU does: a header, the texture table of the cut-out
//! maps, one word per triangle (its record, or `NO_MAP`) and the records.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use super::texture_table::{MapUse, NO_MAP, TextureTable, TextureTableBuilder};
use super::{Instance, MeshShading, Role, Scene, SceneMesh};
use crate::geom::offset::{max_abs, offset_point};

/// Holes a ray passes before the next surface counts as hit, whatever it
/// is (as the Whitted renderer's rays do).
pub const MAX_HOLE_CROSSINGS: u32 = 16;

/// Words before the texture table in `Cutouts::words`.
const HEADER_WORDS: usize = 4;

/// The cut-out triangles of a merged mesh and their maps.
#[derive(Debug, Clone)]
pub struct Cutouts {
    /// The cut-out maps (alpha values in red).
    pub table: TextureTable,
    /// Per triangle of the merged mesh: its index in `records`, or `NO_MAP`.
    pub triangles: Vec<u32>,
    /// Per cut-out triangle: its map and its corners' (u, v).
    pub records: Vec<CutoutTriangle>,
}

/// A triangle with a cut-out map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutoutTriangle {
    /// Its map in `Cutouts::table`.
    pub map: u32,
    /// Its corners' texture coordinates.
    pub uv: [Vec2; 3],
}

impl Cutouts {
    /// The cut-outs of the instances whose role passes `keep`, merged in
    /// instance order as `Scene::world_mesh_at` merges them; `None` when no
    /// such triangle has a cut-out map that can be read (one warning in
    /// `warnings` per image that cannot, as the renderer gives). Texels are
    /// kept within `budget` bytes (`TextureTableBuilder::finish`).
    pub fn of_scene(
        scene: &Scene,
        keep: impl Fn(Role) -> bool,
        budget: u64,
        warnings: &mut Vec<String>,
    ) -> Option<Cutouts> {
        Cutouts::of_instances(scene, |_, i| keep(i.role), budget, warnings)
    }

    /// `of_scene` for the instances (index, instance) that `keep` picks.
    pub fn of_instances(
        scene: &Scene,
        keep: impl Fn(usize, &Instance) -> bool,
        budget: u64,
        warnings: &mut Vec<String>,
    ) -> Option<Cutouts> {
        let mut parts = Parts::default();
        for (_, inst) in scene.instances.iter().enumerate().filter(|(k, i)| keep(*k, i)) {
            let source = &scene.meshes[inst.mesh];
            // A scene material has no texture coordinates to read a map
            // through; a bare mesh has no maps.
            let shading = source.shading.as_ref().filter(|_| inst.material.is_none());
            parts.add(inst.mesh, source.mesh.triangles.len(), shading, warnings);
        }
        parts.finish(budget, warnings)
    }

    /// The cut-outs of one mesh (in its own triangle order), as `of_scene`.
    pub fn of_mesh(mesh: &SceneMesh, budget: u64, warnings: &mut Vec<String>) -> Option<Cutouts> {
        let mut parts = Parts::default();
        parts.add(0, mesh.mesh.triangles.len(), mesh.shading.as_ref(), warnings);
        parts.finish(budget, warnings)
    }

    /// Whether triangle `tri` (corners `v`) has a hole at `p`, a point on
    /// it. The twin of `cutout_hole` in `wgsl/ao_rays.wgsl`.
    pub fn is_hole(&self, tri: u32, v: [Vec3; 3], p: Vec3) -> bool {
        let Some(&r) = self.triangles.get(tri as usize).filter(|&&r| r != NO_MAP) else {
            return false;
        };
        let rec = &self.records[r as usize];
        let (b1, b2) = barycentrics(v, p);
        let uv = rec.uv[0] * (1.0 - b1 - b2) + rec.uv[1] * b1 + rec.uv[2] * b2;
        self.table.is_hole(rec.map, uv)
    }

    /// The words the kernels read: `[texture table at (words4), triangles
    /// at, records at, count]`, the sRGB table, the map records, one word
    /// per triangle, eight words per cut-out triangle (map, then u, v of
    /// each corner, then padding) and the texels. `TextureTable::texels_at`
    /// is made absolute, as the Whitted kernel's records have it.
    pub fn words(&self) -> Vec<u32> {
        let mut words = vec![0u32; HEADER_WORDS];
        words[0] = (HEADER_WORDS / 4) as u32;
        self.table.append_words(&mut words);
        let triangles_at = words.len();
        let records_at = triangles_at + self.triangles.len();
        words.extend_from_slice(&self.triangles);
        for r in &self.records {
            words.push(r.map);
            for c in r.uv {
                words.push(c.x.to_bits());
                words.push(c.y.to_bits());
            }
            words.push(0);
        }
        words[1] = triangles_at as u32;
        words[2] = records_at as u32;
        words[3] = self.records.len() as u32;
        words
    }
}

/// Cut-outs gathered mesh after mesh.
#[derive(Default)]
struct Parts {
    builder: TextureTableBuilder,
    /// Each (mesh, material)'s map, None where it has none.
    map_ids: HashMap<(usize, u32), Option<u32>>,
    triangles: Vec<u32>,
    records: Vec<CutoutTriangle>,
}

impl Parts {
    /// The `count` triangles of mesh `mesh` (`shading` its materials).
    fn add(&mut self, mesh: usize, count: usize, shading: Option<&MeshShading>, warnings: &mut Vec<String>) {
        let Some(shading) = shading else {
            self.triangles.extend(std::iter::repeat_n(NO_MAP, count));
            return;
        };
        for t in 0..count {
            let m = shading.triangle_materials[t];
            let builder = &mut self.builder;
            let map = *self.map_ids.entry((mesh, m)).or_insert_with(|| {
                let material = shading.materials.get(m as usize)?;
                let alpha = material.maps.alpha.as_deref()?;
                let usage = MapUse::Alpha {
                    luminance: alpha.luminance,
                };
                let id = builder.add(&alpha.map, usage, &material.name, warnings)?;
                builder.cut_out(id, alpha.factor, alpha.cutoff);
                Some(id)
            });
            let uv = shading
                .corner_texcoords
                .get(t)
                .copied()
                .flatten()
                .map(|c| c.map(|i| shading.texcoords[i as usize]));
            match (map, uv) {
                (Some(map), Some(uv)) => {
                    self.triangles.push(self.records.len() as u32);
                    self.records.push(CutoutTriangle { map, uv });
                }
                _ => self.triangles.push(NO_MAP),
            }
        }
    }

    fn finish(self, budget: u64, warnings: &mut Vec<String>) -> Option<Cutouts> {
        if self.records.is_empty() {
            return None;
        }
        Some(Cutouts {
            table: self.builder.finish(budget, warnings),
            triangles: self.triangles,
            records: self.records,
        })
    }
}

/// The barycentric coordinates (of corners 1 and 2) of `p` in the plane of
/// triangle `v`, by the normal equations of `p - v0 = b1 e1 + b2 e2`
/// (0, 0 for a degenerate triangle). The twin of `cutout_barycentrics` in
/// `wgsl/ao_rays.wgsl`.
pub fn barycentrics(v: [Vec3; 3], p: Vec3) -> (f32, f32) {
    let (e1, e2, w) = (v[1] - v[0], v[2] - v[0], p - v[0]);
    let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d20, d21) = (w.dot(e1), w.dot(e2));
    let denom = d00 * d11 - d01 * d01;
    if denom == 0.0 || !denom.is_finite() {
        return (0.0, 0.0);
    }
    ((d11 * d20 - d01 * d21) / denom, (d00 * d21 - d01 * d20) / denom)
}

/// Where a ray along `d` goes on after the hole it hit at `p` on triangle
/// `v`: just past the triangle's plane on the far side.
pub fn past_hole(v: [Vec3; 3], p: Vec3, d: Vec3) -> Vec3 {
    let c = (v[1] - v[0]).cross(v[2] - v[0]);
    let len2 = c.dot(c);
    let n = if len2 > 0.0 {
        c * (1.0 / len2.sqrt())
    } else {
        Vec3::ZERO
    };
    let through = if n.dot(d) > 0.0 { n } else { -n };
    let magnitude = max_abs(v[0]).max(max_abs(v[1])).max(max_abs(v[2]));
    offset_point(p, through, magnitude)
}
