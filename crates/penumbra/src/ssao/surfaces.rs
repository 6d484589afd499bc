//! What the G-buffer shows of a scene's surfaces: the albedo at each
//! pixel's surface point and the alpha cut-outs. A triangle's albedo is its
//! material's diffuse colour, or with a diffuse colour map (`map_Kd`, glTF
//! `baseColorTexture`) and texture coordinates that colour times the map
//! at the point, as the renderer shades it (`whitted`: a black colour
//! beside its map leaves the map alone). A cut-out's holes are no surface:
//! the pixel shows what lies behind.
//!
//! The CPU G-buffer (`gbuffer::gbuffer_with`) reads these tables; the
//! raster (`wgsl/gbuffer_textured.wgsl`) reads the same through
//! `GBufferSurfaces::words` with `wgsl/texture_maps.wgsl`'s lookups.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use super::gbuffer::{pack_albedo, scene_albedos, triangle_albedos};
use crate::geom::float::floor;
use crate::scene::cutouts::{Cutouts, MAX_HOLE_CROSSINGS, barycentrics, past_hole};
use crate::scene::texture_table::{MapUse, NO_MAP, TextureTable, TextureTableBuilder};
use crate::scene::{Mesh, Scene};

/// Words before the texture table in a section of `GBufferSurfaces::words`
/// (the same header as `Cutouts::words`).
const SECTION_HEADER_WORDS: usize = 4;

/// Words of one textured triangle's record in `GBufferSurfaces::words`:
/// its map, its diffuse colour (3), its corners' (u, v) (6).
pub const ALBEDO_RECORD_WORDS: usize = 10;

/// The surfaces of a merged mesh as the G-buffer shows them.
#[derive(Debug, Clone)]
pub struct GBufferSurfaces {
    /// Per triangle, the packed albedo (`gbuffer::pack_albedo`) where it
    /// shows no map: `gbuffer::scene_albedos` or the palette.
    pub albedos: Vec<f32>,
    /// The diffuse colour maps; `None` where no triangle has one.
    pub maps: Option<AlbedoMaps>,
    /// The alpha cut-outs; `None` where no triangle has one.
    pub cutouts: Option<Cutouts>,
}

/// The triangles with a diffuse colour map and the maps.
#[derive(Debug, Clone)]
pub struct AlbedoMaps {
    /// The colour maps (sRGB-encoded, decoded through the table).
    pub table: TextureTable,
    /// Per triangle of the merged mesh: its index in `records`, or `NO_MAP`.
    pub triangles: Vec<u32>,
    /// Per textured triangle: its map, colour and corners' (u, v).
    pub records: Vec<AlbedoTriangle>,
}

/// A triangle whose albedo is a colour times a map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlbedoTriangle {
    /// Its map in `AlbedoMaps::table`.
    pub map: u32,
    /// The factor on the map's colour: the material's diffuse colour, or
    /// white where that is black (the map alone).
    pub kd: Vec3,
    /// Its corners' texture coordinates.
    pub uv: [Vec2; 3],
}

impl GBufferSurfaces {
    /// A mesh without materials: each object's palette colour
    /// (`gbuffer::triangle_albedos`), no maps, no cut-outs.
    pub fn palette(mesh: &Mesh) -> GBufferSurfaces {
        GBufferSurfaces {
            albedos: triangle_albedos(mesh),
            maps: None,
            cutouts: None,
        }
    }

    /// The surfaces of `scene.world_mesh(|_| true)`: the colours of
    /// `gbuffer::scene_albedos`, the diffuse colour maps of the meshes'
    /// materials (a scene file's material has none) and the cut-outs
    /// (`Cutouts::of_scene`). Cut-out texels are kept within `budget`
    /// bytes, colour texels within what they leave (at least half of it);
    /// one warning in `warnings` per image that cannot be read or is
    /// reduced.
    pub fn of_scene(scene: &Scene, budget: u64, warnings: &mut Vec<String>) -> GBufferSurfaces {
        let cutouts = Cutouts::of_scene(scene, |_| true, budget, warnings);
        let cut_bytes = cutouts.as_ref().map_or(0, |c| 4 * c.table.texels.len() as u64);
        let colour_budget = budget.saturating_sub(cut_bytes).max(budget / 2);
        GBufferSurfaces {
            albedos: scene_albedos(scene),
            maps: AlbedoMaps::of_scene(scene, colour_budget, warnings),
            cutouts,
        }
    }

    /// Whether anything but the per-triangle colours is shown: the G-buffer
    /// then needs the textured raster.
    pub fn is_textured(&self) -> bool {
        self.maps.is_some() || self.cutouts.is_some()
    }

    /// The packed albedo of triangle `t` of `mesh` at `p`, a point on it.
    pub fn albedo(&self, mesh: &Mesh, t: usize, p: Vec3) -> f32 {
        let Some(maps) = &self.maps else {
            return self.albedos[t];
        };
        match maps.triangles.get(t).filter(|&&r| r != NO_MAP) {
            Some(&r) => {
                let rec = &maps.records[r as usize];
                let (b1, b2) = barycentrics(mesh.triangle(t), p);
                let uv = rec.uv[0] * (1.0 - b1 - b2) + rec.uv[1] * b1 + rec.uv[2] * b2;
                pack_colour(rec.kd * maps.table.sample(rec.map, uv))
            }
            None => self.albedos[t],
        }
    }

    /// The first surface along the ray `o + t d`, past the cut-outs' holes:
    /// its triangle and point, or `None` where the ray leaves the scene. A
    /// ray stops at the surface after `MAX_HOLE_CROSSINGS` holes whatever
    /// it is, as every ray through holes does.
    pub fn first_surface(
        &self,
        tree: &crate::accel::kdtree::KdTree,
        mesh: &Mesh,
        o: Vec3,
        d: Vec3,
    ) -> Option<(usize, Vec3)> {
        let mut from = o;
        let mut crossings = 0;
        loop {
            let h = tree.closest_hit(from, d, f32::INFINITY);
            if !h.is_hit() {
                return None;
            }
            let t = h.triangle as usize;
            let p = from + h.t * d;
            match &self.cutouts {
                Some(c) if crossings < MAX_HOLE_CROSSINGS && c.is_hole(t as u32, mesh.triangle(t), p) => {
                    from = past_hole(mesh.triangle(t), p, d);
                    crossings += 1;
                }
                _ => return Some((t, p)),
            }
        }
    }

    /// The words the textured raster reads (`surfaces` in
    /// gbuffer_textured.wgsl): `[cut-outs at, colour maps at, 0, 0]`
    /// (`NO_MAP` for none), then each section. The cut-outs' section is
    /// `Cutouts::words`; the colour maps' has the same header (`[texture
    /// table at (words4), triangles at, records at, count]`), the sRGB
    /// table, the map records, the texels, one word per triangle and
    /// `ALBEDO_RECORD_WORDS` per textured triangle. A section's word
    /// indices count from its own first word.
    pub fn words(&self) -> Vec<u32> {
        let mut words = vec![NO_MAP, NO_MAP, 0, 0];
        if let Some(c) = &self.cutouts {
            words[0] = words.len() as u32;
            words.extend(c.words());
        }
        if let Some(m) = &self.maps {
            words[1] = words.len() as u32;
            words.extend(m.words());
        }
        words
    }
}

impl AlbedoMaps {
    /// The colour-mapped triangles of `scene.world_mesh(|_| true)`, in its
    /// order; `None` where none has a map that can be read and texture
    /// coordinates. Texels are kept within `budget` bytes.
    pub fn of_scene(scene: &Scene, budget: u64, warnings: &mut Vec<String>) -> Option<AlbedoMaps> {
        let mut builder = TextureTableBuilder::default();
        let mut map_ids: HashMap<(usize, u32), Option<u32>> = HashMap::new();
        let mut triangles = Vec::new();
        let mut records = Vec::new();
        for inst in &scene.instances {
            let source = &scene.meshes[inst.mesh];
            let count = source.mesh.triangles.len();
            let Some(shading) = source.shading.as_ref().filter(|_| inst.material.is_none()) else {
                // A scene file's material has no maps; a bare mesh neither.
                triangles.extend(std::iter::repeat_n(NO_MAP, count));
                continue;
            };
            for t in 0..count {
                let m = shading.triangle_materials[t];
                let map = *map_ids.entry((inst.mesh, m)).or_insert_with(|| {
                    // Material 0 is penumbra's default (faces with none): no maps.
                    let material = shading.materials.get(m as usize).filter(|_| m != 0)?;
                    let kd = material.maps.kd.as_deref()?;
                    builder.add(kd, MapUse::Colour, &material.name, warnings)
                });
                let uv = shading
                    .corner_texcoords
                    .get(t)
                    .copied()
                    .flatten()
                    .map(|c| c.map(|i| shading.texcoords[i as usize]));
                match (map, uv) {
                    (Some(map), Some(uv)) => {
                        let kd = shading.materials[m as usize].kd;
                        triangles.push(records.len() as u32);
                        records.push(AlbedoTriangle {
                            map,
                            kd: if kd == Vec3::ZERO { Vec3::ONE } else { kd },
                            uv,
                        });
                    }
                    _ => triangles.push(NO_MAP),
                }
            }
        }
        if records.is_empty() {
            return None;
        }
        Some(AlbedoMaps {
            table: builder.finish(budget, warnings),
            triangles,
            records,
        })
    }

    /// This section of `GBufferSurfaces::words` (its map records'
    /// `texels_at` counted from its first word).
    pub fn words(&self) -> Vec<u32> {
        let mut words = vec![0u32; SECTION_HEADER_WORDS];
        words[0] = (SECTION_HEADER_WORDS / 4) as u32;
        self.table.append_words(&mut words);
        let triangles_at = words.len();
        let records_at = triangles_at + self.triangles.len();
        words.extend_from_slice(&self.triangles);
        for r in &self.records {
            words.push(r.map);
            words.extend(r.kd.to_array().map(f32::to_bits));
            for c in r.uv {
                words.push(c.x.to_bits());
                words.push(c.y.to_bits());
            }
        }
        words[1] = triangles_at as u32;
        words[2] = records_at as u32;
        words[3] = self.records.len() as u32;
        words
    }
}

/// A linear colour packed as the G-buffer stores albedo: each channel
/// clamped to [0, 1] and rounded to 8 bits (`pack_colour` in
/// gbuffer_textured.wgsl; halves round up on both sides).
pub fn pack_colour(c: Vec3) -> f32 {
    let byte = |x: f32| floor(x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    pack_albedo([byte(c.x), byte(c.y), byte(c.z)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_round_to_the_nearest_byte() {
        let bytes = |v: f32| {
            let b = v as u32;
            [b & 255, (b >> 8) & 255, b >> 16]
        };
        assert_eq!(bytes(pack_colour(Vec3::new(0.0, 1.0, 0.5))), [0, 255, 128]);
        assert_eq!(bytes(pack_colour(Vec3::new(-1.0, 2.0, 1.0 / 255.0))), [0, 255, 1]);
        assert_eq!(bytes(pack_colour(Vec3::splat(f32::NAN))), [0, 0, 0]);
    }
}
