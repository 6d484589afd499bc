//! Baking ambient occlusion into an asset: an AO texture over the mesh's UV
//! layout (`texels`) and AO per vertex, both by ray casting (the reference
//! AO of `raycast`: the `ao_rays` kernel on a GPU, its CPU twin otherwise),
//! written back into a copy of the asset as a GLB (`scene::glb_with_ao`):
//! the texture as each material's `occlusionTexture`, the vertex values as
//! the attribute `_AO`.
//!
//! ```no_run
//! use penumbra::bake::{BakeSettings, bake};
//! use penumbra::{Device, Reporter};
//!
//! let baked = bake(&Device::cpu(), "model.glb".as_ref(), &BakeSettings::default(), &Reporter::silent())?;
//! std::fs::write("model-ao.glb", &baked.glb)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod texels;

use std::path::Path;
use std::sync::Arc;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::gpu::device::Device;
use crate::progress::Reporter;
use crate::raycast::AoSettings;
use crate::raycast::points::vertex_points;
use crate::raycast::tracer::Tracer;
use crate::scene::cutouts::Cutouts;
use crate::scene::texture_table::DEFAULT_TEXTURE_BYTES;
use crate::scene::{BakedAo, Scene, load_mesh_file};
use texels::{TexelPoints, dilate, texel_points, texel_values};

/// Largest texture side baked (a 16384² texture is 256 M texels).
pub const MAX_RESOLUTION: u32 = 16384;

/// What a bake makes and how.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BakeSettings {
    /// Texels per side of the AO texture; 0 for none (per-vertex AO only).
    pub resolution: u32,
    /// Rings of texels filled around each UV chart (default 4).
    pub padding: u32,
    /// Points per texel: 1 (the centre) or more, jittered (default 1).
    pub texel_samples: u32,
    /// Bits per channel of the PNG: 8 or 16 (default 8).
    pub png_bits: u8,
    /// Per-vertex AO as `_AO` (default on).
    pub vertex: bool,
    /// The per-vertex AO also as `COLOR_0` (default off).
    pub vertex_colors: bool,
    /// Replace materials' own occlusion textures (default off: kept).
    pub replace: bool,
    /// The AO rays: count per point, radius, seed.
    pub ao: AoSettings,
}

impl Default for BakeSettings {
    fn default() -> Self {
        BakeSettings {
            resolution: 1024,
            padding: 4,
            texel_samples: 1,
            png_bits: 8,
            vertex: true,
            vertex_colors: false,
            replace: false,
            ao: AoSettings::default(),
        }
    }
}

impl BakeSettings {
    /// Refuses settings no bake can use, naming the option.
    pub fn validate(&self) -> Result<()> {
        if self.resolution > MAX_RESOLUTION {
            return Err(Error::param(
                "resolution",
                format!(
                    "{} is above the largest texture baked, {MAX_RESOLUTION}",
                    self.resolution
                ),
            ));
        }
        if self.texel_samples == 0 || self.texel_samples > 64 {
            return Err(Error::param("texel_samples", "must be 1 to 64"));
        }
        if !matches!(self.png_bits, 8 | 16) {
            return Err(Error::param("png_bits", "must be 8 or 16"));
        }
        if self.resolution == 0 && !self.vertex {
            return Err(Error::param(
                "resolution/vertex",
                "with no texture (resolution 0) and no per-vertex AO there is nothing to bake",
            ));
        }
        self.ao.validate()
    }
}

/// What `bake` reports (`penumbra bake --json`).
#[derive(Debug, Clone, Serialize, Default)]
pub struct BakeReport {
    /// The texture's side in texels (0: none).
    pub resolution: u32,
    /// Texels on a triangle of the UV layout.
    pub texels_covered: usize,
    /// Texels filled by the padding.
    pub texels_padded: usize,
    /// Texel samples that fall in more than one triangle (overlapping UVs:
    /// the first triangle has them).
    pub overlapping_samples: usize,
    /// Triangles with a texture coordinate outside [0, 1].
    pub triangles_outside_unit_square: usize,
    /// Triangles without texture coordinates.
    pub triangles_without_uv: usize,
    /// AO points cast from the texture.
    pub texel_points: usize,
    /// Mean AO over the covered texels.
    pub mean_texel_ao: Option<f64>,
    /// Milliseconds of the texture's AO rays.
    pub texture_ms: f64,
    /// Vertices given AO.
    pub vertices: usize,
    /// Mean AO over the vertices (those no triangle uses count as 1).
    pub mean_vertex_ao: Option<f64>,
    /// Milliseconds of the vertices' AO rays.
    pub vertex_ms: f64,
    /// The kd-tree's build.
    pub build_ms: f64,
    /// Triangles with an alpha cut-out, whose holes the rays pass.
    pub cutout_triangles: usize,
    /// Materials given the texture.
    pub materials_with_ao: usize,
    /// Primitives given `_AO`.
    pub primitives_with_ao: usize,
}

/// A baked asset.
#[derive(Debug, Clone)]
pub struct Baked {
    /// The GLB file's bytes.
    pub glb: Vec<u8>,
    /// The AO texture as a PNG file's bytes (with a texture).
    pub png: Option<Vec<u8>>,
    /// AO per texel, rows from the top, padding filled; `None` beyond it.
    pub texture: Option<Vec<Option<f32>>>,
    /// AO per vertex of the mesh as read.
    pub vertex_ao: Option<Vec<f32>>,
    /// What was done and measured.
    pub report: BakeReport,
    /// Problems that did not stop the bake.
    pub warnings: Vec<String>,
}

/// Bakes AO into the asset at `input` (glTF, GLB, OBJ or PLY) on `device`.
pub fn bake(device: &Device, input: &Path, settings: &BakeSettings, bars: &Reporter) -> Result<Baked> {
    settings.validate()?;
    let file = load_mesh_file(input)?;
    let mut warnings = file.warnings.clone();
    let scene = Scene::from_obj_file("asset", input, file.clone());
    let shading = scene.meshes[0]
        .shading
        .as_ref()
        .expect("a mesh file's scene has its shading");
    let mesh = &file.mesh;
    let mut report = BakeReport::default();
    let texels = if settings.resolution > 0 {
        if shading.corner_texcoords.iter().all(Option::is_none) {
            return Err(Error::file(
                input,
                "texture coordinates",
                "the mesh has none (OBJ `vt`, glTF TEXCOORD_0): there is no UV layout to bake a texture on \
                 (--resolution 0 bakes per-vertex AO alone)",
            ));
        }
        Some(texel_points(mesh, shading, settings.resolution, settings.texel_samples))
    } else {
        None
    };
    let cutouts = Cutouts::of_scene(&scene, |_| true, DEFAULT_TEXTURE_BYTES, &mut warnings);
    report.cutout_triangles = cutouts.as_ref().map_or(0, |c| c.records.len());
    let mut tracer = Tracer::build(device, mesh, bars)?.with_cutouts(cutouts.map(Arc::new));
    report.build_ms = tracer.accel().kdtree().stats.build_ms;
    let (texture, png) = match &texels {
        Some(t) => {
            let (values, ms) = bake_texture(&mut tracer, t, settings, bars)?;
            report.texture_ms = ms;
            note_layout(&mut report, t, &mut warnings);
            let mean = mean(values.iter().flatten().copied());
            report.mean_texel_ao = mean;
            let mut filled = values;
            dilate(&mut filled, settings.resolution, settings.padding);
            report.texels_padded = filled.iter().flatten().count() - t.covered;
            let png = encode_png(&filled, settings.resolution, settings.png_bits)?;
            (Some(filled), Some(png))
        }
        None => (None, None),
    };
    let vertex_ao = if settings.vertex {
        let points = vertex_points(mesh);
        let bar = bars.bar(points.len() as u64, "AO vertices");
        let masks = tracer.ao_visibility(&points, &settings.ao, &bar)?;
        bar.finish();
        report.vertex_ms = masks.ms;
        report.vertices = points.len();
        let ao = masks.value.accessibility();
        report.mean_vertex_ao = mean(ao.iter().copied());
        Some(ao)
    } else {
        None
    };
    let baked = BakedAo {
        texture_png: png.as_deref(),
        vertex_ao: vertex_ao.as_deref(),
        vertex_colors: settings.vertex_colors,
        replace: settings.replace,
    };
    let out = crate::scene::glb_with_ao(input, &file, &baked)?;
    warnings.extend(out.warnings);
    report.resolution = settings.resolution;
    report.materials_with_ao = out.materials_with_ao;
    report.primitives_with_ao = out.primitives_with_ao;
    Ok(Baked {
        glb: out.bytes,
        png,
        texture,
        vertex_ao,
        report,
        warnings,
    })
}

/// The texture's AO per texel (before padding) and the rays' milliseconds.
fn bake_texture(
    tracer: &mut Tracer,
    texels: &TexelPoints,
    settings: &BakeSettings,
    bars: &Reporter,
) -> Result<(Vec<Option<f32>>, f64)> {
    let bar = bars.bar(texels.points.len() as u64, "AO texels");
    let masks = tracer.ao_visibility(&texels.points, &settings.ao, &bar)?;
    bar.finish();
    Ok((texel_values(texels, &masks.value.accessibility()), masks.ms))
}

fn note_layout(report: &mut BakeReport, t: &TexelPoints, warnings: &mut Vec<String>) {
    report.texels_covered = t.covered;
    report.overlapping_samples = t.overlapping_samples;
    report.triangles_outside_unit_square = t.triangles_outside_unit_square;
    report.triangles_without_uv = t.triangles_without_uv;
    report.texel_points = t.points.len();
    if t.overlapping_samples > 0 {
        warnings.push(format!(
            "{} texel samples fall on more than one triangle (overlapping UVs: mirrored halves or stacked shells): \
             each took the first triangle's AO",
            t.overlapping_samples
        ));
    }
    if t.triangles_outside_unit_square > 0 {
        warnings.push(format!(
            "{} triangles have texture coordinates outside [0, 1]: only their part inside the texture is baked",
            t.triangles_outside_unit_square
        ));
    }
    if t.triangles_without_uv > 0 {
        warnings.push(format!(
            "{} triangles have no texture coordinates: they are not in the texture",
            t.triangles_without_uv
        ));
    }
}

fn mean(values: impl Iterator<Item = f32>) -> Option<f64> {
    let (sum, n) = values.fold((0.0f64, 0usize), |(s, n), v| (s + v as f64, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// The texture as a grey PNG (linear AO, as glTF reads occlusion; texels
/// beyond the padding white: open), `bits` 8 or 16.
pub fn encode_png(values: &[Option<f32>], resolution: u32, bits: u8) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    let mut bytes = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut bytes);
    let result = if bits == 16 {
        let words: Vec<u8> = values
            .iter()
            .flat_map(|v| ((v.unwrap_or(1.0).clamp(0.0, 1.0) * 65535.0).round() as u16).to_ne_bytes())
            .collect();
        encoder.write_image(&words, resolution, resolution, image::ExtendedColorType::L16)
    } else {
        let grey: Vec<u8> = values
            .iter()
            .map(|v| (v.unwrap_or(1.0).clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect();
        encoder.write_image(&grey, resolution, resolution, image::ExtendedColorType::L8)
    };
    result.map_err(|e| Error::param("texture", format!("PNG encoding failed: {e}")))?;
    Ok(bytes)
}
