//! Texture maps as the kernels read them: every image a scene's
//! materials use, decoded once, packed as RGBA8 words; one record per map
//! (scale, offset, wrap, where its texels are); and the lookup, bilinear
//! between texel centres, that `sample_map` in `wgsl/texture_maps.wgsl` repeats
//! operation for operation (`TextureTable::sample` is its CPU twin).
//!
//! Colour maps are sRGB-encoded and decoded per texel through one table
//! (`scene::texture::srgb_to_linear_table`, uploaded with the records), so
//! the two sides decode alike; the four decoded texels are then blended in
//! linear values. Alpha maps are packed apart as one value per texel (the
//! image's alpha, or its luminance where the image is opaque) in red.

use std::collections::HashMap;
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

use crate::geom::float::floor;
use crate::scene::texture::{Texture, TextureMap, decode_texture, srgb_to_linear_table};

/// A surface's map id where it has no such map.
pub const NO_MAP: u32 = u32::MAX;
/// `MapRecord::flags`: clamp coordinates to [0, 1] (else repeat).
pub const MAP_CLAMP: u32 = 1;
/// `MapRecord::flags`: texels are sRGB-encoded colours (else linear values).
pub const MAP_SRGB: u32 = 2;

/// Bytes of texels a scene keeps by default: larger sets of images are
/// halved, largest first, with a warning each (64 MiB: half of the smallest
/// storage binding WebGPU guarantees, leaving room for the other records).
pub const DEFAULT_TEXTURE_BYTES: u64 = 64 << 20;

/// One map as the kernel reads it (three words4).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct MapRecord {
    /// Scale of the texture coordinates.
    pub scale: [f32; 2],
    /// Offset added after scaling.
    pub offset: [f32; 2],
    /// Its first texel in `TextureTable::texels` (in the GPU's records: the
    /// word it starts at).
    pub texels_at: u32,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `MAP_CLAMP`, `MAP_SRGB`.
    pub flags: u32,
    /// A cut-out's factor on the sampled value (1 for colour maps).
    pub factor: f32,
    /// A cut-out's threshold: holes where the value times `factor` is
    /// below it (0 for colour maps).
    pub cutoff: f32,
    /// Padding to three words4.
    pub _pad: [u32; 2],
}

/// What a map is for: how its texels are packed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MapUse {
    /// A colour (sRGB-encoded RGB).
    Colour,
    /// A cut-out's alpha: one linear value per texel, in red. With
    /// `luminance`, an image with no transparent texel gives its luminance
    /// instead (a grey mask, as MTL's `map_d` often is).
    Alpha {
        /// Whether an opaque image's luminance is the value.
        luminance: bool,
    },
}

/// The scene's maps and their texels.
#[derive(Debug, Clone)]
pub struct TextureTable {
    /// One record per map (an index is a surface's map id).
    pub maps: Vec<MapRecord>,
    /// Every map's texels, RGBA8 packed little-endian into words.
    pub texels: Vec<u32>,
    /// The linear value of each sRGB code.
    pub srgb: [f32; 256],
    /// The images in use, by name, with their size as packed.
    pub images: Vec<(String, u32, u32)>,
}

impl Default for TextureTable {
    fn default() -> Self {
        TextureTable {
            maps: Vec::new(),
            texels: Vec::new(),
            srgb: srgb_to_linear_table(),
            images: Vec::new(),
        }
    }
}

/// Builds a `TextureTable`: maps are added one by one (each image decoded
/// once, a warning per image that cannot be read), then `finish` packs the
/// texels within a budget.
#[derive(Default)]
pub struct TextureTableBuilder {
    maps: Vec<(MapRecord, usize)>,
    /// The images as packed (colours, or alpha values); a colour map
    /// shares its decoded image.
    images: Vec<Arc<Texture>>,
    /// `images`' index by (name, use).
    index: HashMap<(String, MapUse), usize>,
    /// Decoded images by name; None where decoding failed (warned once).
    decoded: HashMap<String, Option<Arc<Texture>>>,
    flags: Vec<u32>,
}

impl TextureTableBuilder {
    /// The id of `map` used as `usage`, or None where its image cannot be
    /// read (one warning per image in `warnings`, naming it and `material`).
    pub fn add(&mut self, map: &TextureMap, usage: MapUse, material: &str, warnings: &mut Vec<String>) -> Option<u32> {
        let key = (map.source.name(), usage);
        let image = match self.index.get(&key) {
            Some(&i) => i,
            None => {
                let decoded = self.decoded.entry(key.0.clone()).or_insert_with(|| {
                    decode_texture(&map.source)
                        .map_err(|why| {
                            warnings.push(format!(
                                "texture '{}' (material '{material}') {why}: the material's colour is used instead",
                                key.0
                            ))
                        })
                        .ok()
                        .map(Arc::new)
                });
                let t = decoded.clone()?;
                self.images.push(match usage {
                    MapUse::Colour => t,
                    MapUse::Alpha { luminance } => Arc::new(alpha_of(&t, luminance)),
                });
                self.flags.push(if usage == MapUse::Colour { MAP_SRGB } else { 0 });
                self.index.insert(key, self.images.len() - 1);
                self.images.len() - 1
            }
        };
        let record = MapRecord {
            scale: map.scale.to_array(),
            offset: map.offset.to_array(),
            texels_at: 0,
            width: 0,
            height: 0,
            flags: self.flags[image] | if map.clamp { MAP_CLAMP } else { 0 },
            factor: 1.0,
            cutoff: 0.0,
            _pad: [0; 2],
        };
        self.maps.push((record, image));
        Some(self.maps.len() as u32 - 1)
    }

    /// Makes map `id` (an alpha map) a cut-out with `factor` and `cutoff`.
    pub fn cut_out(&mut self, id: u32, factor: f32, cutoff: f32) {
        let record = &mut self.maps[id as usize].0;
        record.factor = factor;
        record.cutoff = cutoff;
    }

    /// The table, its images halved (largest first) until their texels fit
    /// `budget` bytes, a warning for each image reduced.
    pub fn finish(mut self, budget: u64, warnings: &mut Vec<String>) -> TextureTable {
        let bytes = |images: &[Arc<Texture>]| images.iter().map(|t| 4 * t.width as u64 * t.height as u64).sum::<u64>();
        let original: Vec<(u32, u32)> = self.images.iter().map(|t| (t.width, t.height)).collect();
        while bytes(&self.images) > budget {
            let Some(largest) = (0..self.images.len())
                .filter(|&i| self.images[i].width * self.images[i].height > 1)
                .max_by_key(|&i| self.images[i].width as u64 * self.images[i].height as u64)
            else {
                break;
            };
            self.images[largest] = Arc::new(self.images[largest].halved());
        }
        for (t, &(w, h)) in self.images.iter().zip(&original) {
            if (t.width, t.height) != (w, h) {
                warnings.push(format!(
                    "texture '{}' ({w}x{h}) is reduced to {}x{} to keep the scene's textures within {} MiB",
                    t.name,
                    t.width,
                    t.height,
                    budget >> 20
                ));
            }
        }
        let mut table = TextureTable::default();
        let mut starts = Vec::with_capacity(self.images.len());
        for t in &self.images {
            starts.push(table.texels.len() as u32);
            table.texels.extend(t.texels.iter().map(|&c| u32::from_le_bytes(c)));
            table.images.push((t.name.clone(), t.width, t.height));
        }
        table.maps = self
            .maps
            .into_iter()
            .map(|(r, i)| MapRecord {
                texels_at: starts[i],
                width: self.images[i].width,
                height: self.images[i].height,
                ..r
            })
            .collect();
        table
    }
}

/// The cut-out value of each texel, in red: alpha, or with `luminance`
/// where the image has no texel that is not opaque, luminance (Rec. 709
/// weights on the stored values, as a grey mask is written).
fn alpha_of(t: &Texture, luminance: bool) -> Texture {
    let alpha = !luminance || t.has_alpha();
    let texels = t
        .texels
        .iter()
        .map(|c| {
            let v = if alpha {
                c[3]
            } else {
                (0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32).round() as u8
            };
            [v, v, v, 255]
        })
        .collect();
    Texture {
        texels,
        name: t.name.clone(),
        ..*t
    }
}

impl TextureTable {
    /// Map `map` at texture coordinates `uv` (v up the image): the
    /// bilinear blend of the four texels around the point, decoded (sRGB
    /// through the table, else /255). The CPU twin of `sample_map` in
    /// texture_maps.wgsl.
    pub fn sample(&self, map: u32, uv: Vec2) -> Vec3 {
        let m = &self.maps[map as usize];
        let (w, h) = (m.width as i32, m.height as i32);
        let mut u = uv.x * m.scale[0] + m.offset[0];
        let mut v = uv.y * m.scale[1] + m.offset[1];
        if m.flags & MAP_CLAMP != 0 {
            u = unit_clamp(u);
            v = unit_clamp(v);
        } else {
            u = unit_fract(u);
            v = unit_fract(v);
        }
        // Texel centres at (i + 0.5) / w; image rows from the top.
        let x = u * w as f32 - 0.5;
        let y = (1.0 - v) * h as f32 - 0.5;
        let (x0, y0) = (floor(x), floor(y));
        let (fx, fy) = (x - x0, y - y0);
        let (i0, j0) = (x0 as i32, y0 as i32);
        let clamp = m.flags & MAP_CLAMP != 0;
        let wrap = |i: i32, n: i32| {
            if clamp { i.clamp(0, n - 1) } else { (i + n) % n }
        };
        let (ia, ib) = (wrap(i0, w), wrap(i0 + 1, w));
        let (ja, jb) = (wrap(j0, h), wrap(j0 + 1, h));
        let texel = |i: i32, j: i32| self.texel(m, (j * w + i) as u32);
        let top = texel(ia, ja) * (1.0 - fx) + texel(ib, ja) * fx;
        let bottom = texel(ia, jb) * (1.0 - fx) + texel(ib, jb) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Appends the table as the kernels read it through `texture_maps.wgsl`
    /// to `words`: the sRGB table, the map records (their `texels_at` made
    /// absolute: counted from `words`' first word) and the texels.
    pub fn append_words(&self, words: &mut Vec<u32>) {
        words.extend(self.srgb.iter().map(|f| f.to_bits()));
        let record_words = std::mem::size_of::<MapRecord>() / 4;
        let texels_at = (words.len() + self.maps.len() * record_words) as u32;
        for m in &self.maps {
            let m = MapRecord {
                texels_at: texels_at + m.texels_at,
                ..*m
            };
            words.extend_from_slice(bytemuck::cast_slice(bytemuck::bytes_of(&m)));
        }
        words.extend_from_slice(&self.texels);
    }

    /// Whether cut-out map `map` has a hole at `uv` (the CPU twin of
    /// `map_hole` in texture_maps.wgsl).
    pub fn is_hole(&self, map: u32, uv: Vec2) -> bool {
        let m = &self.maps[map as usize];
        self.sample(map, uv).x * m.factor < m.cutoff
    }

    fn texel(&self, m: &MapRecord, k: u32) -> Vec3 {
        let [r, g, b, _] = self.texels[(m.texels_at + k) as usize].to_le_bytes();
        if m.flags & MAP_SRGB != 0 {
            Vec3::new(self.srgb[r as usize], self.srgb[g as usize], self.srgb[b as usize])
        } else {
            Vec3::new(r as f32, g as f32, b as f32) * (1.0 / 255.0)
        }
    }
}

/// `u` clamped to [0, 1]; 0 where it is not a number.
fn unit_clamp(u: f32) -> f32 {
    if u >= 0.0 { if u <= 1.0 { u } else { 1.0 } } else { 0.0 }
}

/// The fractional part of `u` in [0, 1); 0 where it is not finite.
fn unit_fract(u: f32) -> f32 {
    let f = u - floor(u);
    if (0.0..1.0).contains(&f) { f } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::texture::{TextureMap, TextureSource};

    fn table(texels: Vec<[u8; 4]>, w: u32, h: u32, clamp: bool, usage: MapUse) -> TextureTable {
        let image = Texture {
            name: "t".into(),
            width: w,
            height: h,
            texels,
        };
        let flags = if usage == MapUse::Colour { MAP_SRGB } else { 0 };
        let mut b = TextureTableBuilder {
            images: vec![Arc::new(match usage {
                MapUse::Alpha { luminance } => alpha_of(&image, luminance),
                MapUse::Colour => image,
            })],
            flags: vec![flags],
            ..Default::default()
        };
        let mut map = TextureMap::new(TextureSource::File("t.png".into()));
        map.clamp = clamp;
        b.maps.push((
            MapRecord {
                scale: [1.0; 2],
                offset: [0.0; 2],
                texels_at: 0,
                width: 0,
                height: 0,
                flags: flags | if clamp { MAP_CLAMP } else { 0 },
                factor: 1.0,
                cutoff: 0.0,
                _pad: [0; 2],
            },
            0,
        ));
        b.finish(DEFAULT_TEXTURE_BYTES, &mut Vec::new())
    }

    #[test]
    fn texel_centres_are_exact_and_v_runs_up() {
        // 2x2: top row black, white; bottom row red, green.
        let t = table(
            vec![[0, 0, 0, 255], [255, 255, 255, 255], [255, 0, 0, 255], [0, 255, 0, 255]],
            2,
            2,
            false,
            MapUse::Colour,
        );
        assert_eq!(t.sample(0, Vec2::new(0.25, 0.75)), Vec3::ZERO, "top left");
        assert_eq!(t.sample(0, Vec2::new(0.75, 0.75)), Vec3::ONE, "top right");
        assert_eq!(t.sample(0, Vec2::new(0.25, 0.25)), Vec3::X, "bottom left");
        assert_eq!(t.sample(0, Vec2::new(1.75, -0.75)), Vec3::Y, "repeats");
        // Halfway between black and white: linear 0.5, not sRGB's.
        assert_eq!(t.sample(0, Vec2::new(0.5, 0.75)), Vec3::splat(0.5));
        // At u = 0 with repeat: halfway between the left and right columns.
        assert_eq!(t.sample(0, Vec2::new(0.0, 0.75)), Vec3::splat(0.5));
        // NaN and infinite coordinates land on a texel, not out of bounds.
        assert!(t.sample(0, Vec2::new(f32::NAN, f32::INFINITY)).is_finite());
    }

    #[test]
    fn clamp_holds_the_edge_and_srgb_decodes() {
        let t = table(vec![[0, 0, 0, 255], [188, 188, 188, 255]], 2, 1, true, MapUse::Colour);
        assert_eq!(t.sample(0, Vec2::new(-3.0, 0.5)), Vec3::ZERO);
        let right = t.sample(0, Vec2::new(7.0, 0.5));
        assert!((right.x - 0.5029).abs() < 1e-3, "{right}");
        assert_eq!(
            t.sample(0, Vec2::new(0.0, 0.5)),
            Vec3::ZERO,
            "clamped: no wrap to the right edge"
        );
    }

    #[test]
    fn alpha_maps_take_alpha_else_luminance() {
        let t = table(
            vec![[255, 255, 255, 0], [255, 255, 255, 255]],
            2,
            1,
            true,
            MapUse::Alpha { luminance: true },
        );
        assert_eq!(t.sample(0, Vec2::new(0.0, 0.5)).x, 0.0);
        assert_eq!(t.sample(0, Vec2::new(1.0, 0.5)).x, 1.0);
        let t = table(
            vec![[0, 0, 0, 255], [255, 255, 255, 255]],
            2,
            1,
            true,
            MapUse::Alpha { luminance: true },
        );
        assert_eq!(
            t.sample(0, Vec2::new(1.0, 0.5)).x,
            1.0,
            "opaque image: luminance, linear"
        );
        assert_eq!(t.sample(0, Vec2::new(0.5, 0.5)).x, 0.5);
        // glTF reads the alpha channel only: an opaque image has no hole.
        let t = table(
            vec![[0, 0, 0, 255], [255, 255, 255, 255]],
            2,
            1,
            true,
            MapUse::Alpha { luminance: false },
        );
        assert_eq!(t.sample(0, Vec2::new(0.0, 0.5)).x, 1.0);
    }

    #[test]
    fn budget_halves_the_largest_and_warns() {
        let big = Texture {
            name: "big".into(),
            width: 64,
            height: 64,
            texels: vec![[9; 4]; 64 * 64],
        };
        let small = Texture {
            name: "small".into(),
            width: 8,
            height: 8,
            texels: vec![[7; 4]; 64],
        };
        let mut b = TextureTableBuilder {
            images: vec![Arc::new(big), Arc::new(small)],
            flags: vec![MAP_SRGB, MAP_SRGB],
            ..Default::default()
        };
        let rec = MapRecord {
            scale: [1.0; 2],
            offset: [0.0; 2],
            texels_at: 0,
            width: 0,
            height: 0,
            flags: MAP_SRGB,
            factor: 1.0,
            cutoff: 0.0,
            _pad: [0; 2],
        };
        b.maps = vec![(rec, 0), (rec, 1)];
        let mut w = Vec::new();
        let t = b.finish(4 * (32 * 32 + 64), &mut w);
        assert_eq!(t.images, [("big".to_string(), 32, 32), ("small".to_string(), 8, 8)]);
        assert_eq!((t.maps[1].texels_at, t.texels.len()), (32 * 32, 32 * 32 + 64));
        assert_eq!(w.len(), 1);
        assert!(w[0].contains("'big' (64x64) is reduced to 32x32"), "{w:?}");
    }
}
