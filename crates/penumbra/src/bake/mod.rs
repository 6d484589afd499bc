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
use texels::{add_texel_values, dilate, texel_points_in};

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
    /// With a value, the fewest rays (a power of two, 8 to 4096) whose
    /// RMS Monte Carlo error over the texels is, at 95% confidence, at most
    /// this, estimated on a probe of texel points (`ao.rays_per_point` is
    /// then the probe's rays).
    pub max_error: Option<f64>,
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
            max_error: None,
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
        if self.resolution as u64 * self.resolution as u64 * self.texel_samples as u64 > u32::MAX as u64 {
            return Err(Error::param(
                "texel_samples",
                format!(
                    "{} samples on {}² texels are more than 2^32 sample streams",
                    self.texel_samples, self.resolution
                ),
            ));
        }
        if let Some(e) = self.max_error
            && !(e > 0.0 && e < 1.0)
        {
            return Err(Error::param("max_error", format!("must be in (0, 1), got {e}")));
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
    /// The rays per point the bake cast.
    pub rays_per_point: u32,
    /// How `max_error` chose them, when it was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub budget: Option<RaysChosen>,
}

/// The rays a `max_error` budget chose, and the estimate behind them.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct RaysChosen {
    /// The budget: RMS error of the texels' AO at 95% confidence.
    pub max_error: f64,
    /// Texel points (or vertices, without a texture) the probe cast.
    pub probe_points: usize,
    /// Rays per probe point.
    pub probe_rays: u32,
    /// The mean of a(1 - a) over the probe: the variance of one ray.
    pub ray_variance: f64,
    /// The rays chosen.
    pub rays: u32,
    /// 1.96 sqrt(ray_variance / rays): the error expected of them.
    pub estimated_error: f64,
}

/// Probe points most.
const PROBE_POINTS: usize = 4096;

/// The fewest rays (8 to 4096, powers of two) whose RMS error over points
/// of mean single-ray variance `variance` is, at 95% confidence, within
/// `max_error`: the standard error of a fraction of n rays is
/// sqrt(a (1 - a) / n).
pub fn rays_for(variance: f64, max_error: f64) -> (u32, f64) {
    let mut n = 8u32;
    loop {
        let e = 1.96 * (variance / n as f64).sqrt();
        if e <= max_error || n >= 4096 {
            return (n, e);
        }
        n *= 2;
    }
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

/// Texel samples traced at once: large textures are baked in bands of rows
/// (about 32 MiB of points a band), which also keeps every GPU batch
/// within the device's bindings.
pub const BAND_SAMPLES: u64 = 1 << 20;

/// Bakes AO into the asset at `input` (glTF, GLB, OBJ or PLY) on `device`:
/// a [`BakeJob`]'s pieces computed in order and finished.
pub fn bake(device: &Device, input: &Path, settings: &BakeSettings, bars: &Reporter) -> Result<Baked> {
    let mut job = BakeJob::new(device, input, settings, bars)?;
    let pieces = job.pieces();
    let bar = bars.bar(job.items() as u64, "AO texel rows and vertices");
    let mut done = Vec::with_capacity(pieces.len());
    for piece in pieces {
        let n = piece.len() as u64;
        done.push(job.compute(piece)?);
        bar.inc(n);
    }
    bar.finish();
    job.finish(done)
}

/// Vertices per piece of a [`BakeJob`].
pub const VERTEX_PIECE: usize = 1 << 16;

/// One asset's bake as a list of items that any process computes alike
/// (each point's rays depend on its texel sample or vertex index alone):
/// the texture's rows, then the vertices. A shard of a bake computes some
/// of its pieces; [`BakeJob::finish`] takes every piece, whoever computed
/// it, pads the texture and writes the asset as [`bake`] does.
pub struct BakeJob {
    input: std::path::PathBuf,
    file: crate::scene::ObjFile,
    scene: Scene,
    tracer: Tracer,
    settings: BakeSettings,
    budget: Option<RaysChosen>,
    warnings: Vec<String>,
    normals: Vec<glam::Vec3>,
}

/// What a piece of a [`BakeJob`] measured.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BakePiece {
    /// Its items: texture rows below the resolution, blocks of vertices
    /// after.
    pub items: std::ops::Range<usize>,
    /// AO per texel of its rows (NaN where no sample falls on a triangle),
    /// or per vertex.
    pub values: Vec<f32>,
    /// AO points cast.
    pub points: usize,
    /// Texels with a covered sample.
    pub texels_covered: usize,
    /// Samples on more than one triangle.
    pub overlapping_samples: usize,
    /// Triangles with a texture coordinate outside [0, 1] (the mesh's, the
    /// same in every row piece).
    pub triangles_outside_unit_square: usize,
    /// Triangles without texture coordinates (likewise).
    pub triangles_without_uv: usize,
    /// Milliseconds of its AO rays.
    pub ms: f64,
}

impl BakePiece {
    /// The piece as bytes: its counts, then its values (little-endian).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(56 + 4 * self.values.len());
        for n in [
            self.items.start,
            self.items.end,
            self.points,
            self.texels_covered,
            self.overlapping_samples,
            self.triangles_outside_unit_square,
            self.triangles_without_uv,
        ] {
            b.extend_from_slice(&(n as u64).to_le_bytes());
        }
        b.extend_from_slice(&self.ms.to_le_bytes());
        self.values.iter().for_each(|v| b.extend_from_slice(&v.to_le_bytes()));
        b
    }

    /// A piece from `to_bytes`; `None` for bytes that are not one.
    pub fn from_bytes(b: &[u8]) -> Option<BakePiece> {
        if b.len() < 64 || !(b.len() - 64).is_multiple_of(4) {
            return None;
        }
        let n = |k: usize| u64::from_le_bytes(b[8 * k..8 * k + 8].try_into().expect("8 bytes")) as usize;
        let values: Vec<f32> = b[64..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        let piece = BakePiece {
            items: n(0)..n(1),
            values,
            points: n(2),
            texels_covered: n(3),
            overlapping_samples: n(4),
            triangles_outside_unit_square: n(5),
            triangles_without_uv: n(6),
            ms: f64::from_le_bytes(b[56..64].try_into().expect("8 bytes")),
        };
        Some(piece)
    }
}

impl BakeJob {
    /// Reads the asset, builds its structure and, with `max_error`,
    /// chooses the rays from a probe (the same probe in every process).
    pub fn new(device: &Device, input: &Path, settings: &BakeSettings, bars: &Reporter) -> Result<BakeJob> {
        settings.validate()?;
        let file = load_mesh_file(input)?;
        let mut warnings = file.warnings.clone();
        let scene = Scene::from_obj_file("asset", input, file.clone());
        let cutouts = Cutouts::of_scene(&scene, |_| true, DEFAULT_TEXTURE_BYTES, &mut warnings);
        let mut tracer = Tracer::build(device, &scene.meshes[0].mesh, bars)?.with_cutouts(cutouts.map(Arc::new));
        let mesh = &scene.meshes[0];
        let placed = Placed {
            mesh: &mesh.mesh,
            shading: mesh.shading.as_ref().expect("a mesh file's scene has its shading"),
            input,
        };
        let (settings, budget) = rays_of(&mut tracer, &placed, settings, &mut warnings)?;
        let normals = mesh.mesh.vertex_normals();
        Ok(BakeJob {
            input: input.to_path_buf(),
            file,
            scene,
            tracer,
            settings,
            budget,
            warnings,
            normals,
        })
    }

    /// Texture rows, then blocks of vertices, each block as many vertices
    /// as a row has samples (so that items cost alike).
    pub fn items(&self) -> usize {
        self.layout().items()
    }

    fn layout(&self) -> Items {
        Items::of(&self.settings, self.scene.meshes[0].mesh.positions.len())
    }

    /// The pieces the items are computed in, in order: bands of rows
    /// ([`BAND_SAMPLES`] samples a band), then blocks of vertices, about
    /// as many points a piece.
    pub fn pieces(&self) -> Vec<std::ops::Range<usize>> {
        self.layout().pieces()
    }

    /// Computes one of `pieces`.
    pub fn compute(&mut self, piece: std::ops::Range<usize>) -> Result<BakePiece> {
        let mesh = &self.scene.meshes[0];
        let placed = Placed {
            mesh: &mesh.mesh,
            shading: mesh.shading.as_ref().expect("a mesh file's scene has its shading"),
            input: &self.input,
        };
        let items = self.layout();
        compute_piece(
            &mut self.tracer,
            &placed,
            &self.normals,
            &self.settings,
            (&items, piece),
        )
    }

    /// The asset from every piece (in any order): the texture padded and
    /// encoded, the GLB written, the counts summed.
    pub fn finish(self, pieces: Vec<BakePiece>) -> Result<Baked> {
        let mesh = &self.scene.meshes[0];
        let placed = Placed {
            mesh: &mesh.mesh,
            shading: mesh.shading.as_ref().expect("a mesh file's scene has its shading"),
            input: &self.input,
        };
        let build_ms = self.tracer.accel().kdtree().stats.build_ms;
        let cutout_triangles = self.tracer.cutouts().map_or(0, |c| c.records.len());
        let mut baked = assemble(
            &placed,
            &self.settings,
            (self.budget, build_ms, cutout_triangles),
            pieces,
        )?;
        write_asset(&self.input, &self.file, &self.settings, &mut baked)?;
        let mut warnings = self.warnings;
        warnings.append(&mut baked.warnings);
        baked.warnings = warnings;
        Ok(baked)
    }
}

/// One asset of a scene baked (`bake_scene`): its mesh's name and file.
#[derive(Debug, Clone)]
pub struct BakedMesh {
    /// The mesh's name in the scene file.
    pub name: String,
    /// Its file.
    pub path: std::path::PathBuf,
    /// The instance whose placement it was baked in.
    pub instance: String,
    /// The bake.
    pub baked: Baked,
}

/// Bakes each mesh of `scene` (loaded with its materials) where its first
/// instance stands, with every caster of the scene occluding it (its own
/// instance included), as Blender bakes an object among others.
pub fn bake_scene(device: &Device, scene: &Scene, settings: &BakeSettings, bars: &Reporter) -> Result<Vec<BakedMesh>> {
    settings.validate()?;
    let occluders = scene.world_mesh(crate::scene::Role::casts);
    if occluders.triangles.is_empty() {
        return Err(Error::param("scene", "no instance is a caster: nothing occludes"));
    }
    let mut scene_warnings = Vec::new();
    let cutouts = Cutouts::of_scene(
        scene,
        crate::scene::Role::casts,
        DEFAULT_TEXTURE_BYTES,
        &mut scene_warnings,
    );
    let mut tracer = Tracer::build(device, &occluders, bars)?.with_cutouts(cutouts.map(Arc::new));
    let mut out = Vec::new();
    for (m, mesh) in scene.meshes.iter().enumerate() {
        let Some(inst) = scene.instances.iter().find(|i| i.mesh == m) else {
            continue;
        };
        let t = inst.transform_at(0);
        let mut world = mesh.mesh.map_positions(|p| t.apply_point(p));
        world.origin = scene.origin;
        let Some(shading) = mesh.shading.as_ref() else {
            continue;
        };
        let placed = Placed {
            mesh: &world,
            shading,
            input: &mesh.path,
        };
        let mut baked = bake_placed(&mut tracer, &placed, settings, bars)?;
        let file = load_mesh_file(&mesh.path)?;
        write_asset(&mesh.path, &file, settings, &mut baked)?;
        out.push(BakedMesh {
            name: mesh.name.clone(),
            path: mesh.path.clone(),
            instance: inst.name.clone(),
            baked,
        });
    }
    if let Some(first) = out.first_mut() {
        first.baked.warnings.splice(0..0, scene_warnings);
    }
    Ok(out)
}

/// A mesh where it is baked: its positions placed in the traced frame,
/// its UV layout, and the file it came from (for errors).
struct Placed<'a> {
    mesh: &'a crate::scene::Mesh,
    shading: &'a crate::scene::MeshShading,
    input: &'a Path,
}

/// The texture and vertex AO of `placed` through `tracer` (the scene it
/// stands in), without the asset: every piece of the bake, assembled.
fn bake_placed(tracer: &mut Tracer, placed: &Placed, settings: &BakeSettings, bars: &Reporter) -> Result<Baked> {
    let mut warnings = Vec::new();
    let (settings, budget) = rays_of(tracer, placed, settings, &mut warnings)?;
    let normals = placed.mesh.vertex_normals();
    let items = Items::of(&settings, placed.mesh.positions.len());
    let pieces = items.pieces();
    let bar = bars.bar(items.items() as u64, "AO texel rows and vertices");
    let mut done = Vec::with_capacity(pieces.len());
    for piece in pieces {
        let len = piece.len() as u64;
        done.push(compute_piece(tracer, placed, &normals, &settings, (&items, piece))?);
        bar.inc(len);
    }
    bar.finish();
    let build_ms = tracer.accel().kdtree().stats.build_ms;
    let cutout_triangles = tracer.cutouts().map_or(0, |c| c.records.len());
    let mut baked = assemble(placed, &settings, (budget, build_ms, cutout_triangles), done)?;
    warnings.append(&mut baked.warnings);
    baked.warnings = warnings;
    Ok(baked)
}

/// `settings` with the rays `max_error` chooses (a warning where even the
/// most it chooses misses the budget), and the choice.
fn rays_of(
    tracer: &mut Tracer,
    placed: &Placed,
    settings: &BakeSettings,
    warnings: &mut Vec<String>,
) -> Result<(BakeSettings, Option<RaysChosen>)> {
    let mut settings = *settings;
    if settings.resolution > 0 && placed.shading.corner_texcoords.iter().all(Option::is_none) {
        return Err(Error::file(
            placed.input,
            "texture coordinates",
            "the mesh has none (OBJ `vt`, glTF TEXCOORD_0): there is no UV layout to bake a texture on \
             (--resolution 0 bakes per-vertex AO alone)",
        ));
    }
    let budget = match settings.max_error {
        Some(e) => Some(choose_rays(tracer, placed, &settings, e)?),
        None => None,
    };
    if let Some(b) = budget {
        settings.ao.rays_per_point = b.rays;
        if b.estimated_error > b.max_error {
            warnings.push(format!(
                "--max-error {}: {} rays (the most a budget chooses) give an estimated error of {:.4}",
                b.max_error, b.rays, b.estimated_error
            ));
        }
    }
    Ok((settings, budget))
}

/// A bake's items: the texture's rows, then blocks of `block` vertices.
struct Items {
    rows: usize,
    block: usize,
    vertices: usize,
    band: usize,
}

impl Items {
    fn of(settings: &BakeSettings, vertices: usize) -> Items {
        let per_row = settings.resolution as usize * settings.texel_samples as usize;
        Items {
            rows: settings.resolution as usize,
            block: if per_row > 0 { per_row } else { 4096 },
            vertices: if settings.vertex { vertices } else { 0 },
            band: band_rows(settings).max(1) as usize,
        }
    }

    fn items(&self) -> usize {
        self.rows + self.vertices.div_ceil(self.block)
    }

    /// Item `i` past the rows as its vertices.
    fn vertex_range(&self, items: std::ops::Range<usize>) -> std::ops::Range<usize> {
        let at = |i: usize| ((i - self.rows) * self.block).min(self.vertices);
        at(items.start)..at(items.end)
    }

    fn pieces(&self) -> Vec<std::ops::Range<usize>> {
        let (n, all) = (self.rows, self.items());
        let blocks = (VERTEX_PIECE / self.block).max(1);
        (0..n)
            .step_by(self.band)
            .map(|s| s..(s + self.band).min(n))
            .chain((n..all).step_by(blocks).map(|s| s..(s + blocks).min(all)))
            .collect()
    }
}

/// Rows of a band: about [`BAND_SAMPLES`] samples.
fn band_rows(settings: &BakeSettings) -> u32 {
    let n = settings.resolution.max(1);
    let per_row = n as u64 * settings.texel_samples as u64;
    (BAND_SAMPLES / per_row).clamp(1, n as u64) as u32
}

/// A piece of a bake: texture rows below `settings.resolution`, vertices
/// after.
fn compute_piece(
    tracer: &mut Tracer,
    placed: &Placed,
    normals: &[glam::Vec3],
    settings: &BakeSettings,
    (items, piece): (&Items, std::ops::Range<usize>),
) -> Result<BakePiece> {
    let n = settings.resolution as usize;
    let hidden = crate::progress::Bar::hidden();
    if piece.start < n {
        let rows = piece.start as u32..piece.end.min(n) as u32;
        let band = texel_points_in(
            placed.mesh,
            normals,
            placed.shading,
            n as u32,
            settings.texel_samples,
            rows.clone(),
        );
        let masks = tracer.ao_visibility(&band.points, &settings.ao, &hidden)?;
        let first = rows.start as usize * n;
        let mut values = vec![None; (rows.end - rows.start) as usize * n];
        add_texel_values(&band, &masks.value.accessibility(), &mut values, first);
        return Ok(BakePiece {
            items: piece,
            values: values.iter().map(|v| v.unwrap_or(f32::NAN)).collect(),
            points: band.points.len(),
            texels_covered: band.covered,
            overlapping_samples: band.overlapping_samples,
            triangles_outside_unit_square: band.triangles_outside_unit_square,
            triangles_without_uv: band.triangles_without_uv,
            ms: masks.ms,
        });
    }
    let all = vertex_points(placed.mesh);
    let points = &all[items.vertex_range(piece.clone())];
    let masks = tracer.ao_visibility(points, &settings.ao, &hidden)?;
    Ok(BakePiece {
        items: piece,
        values: masks.value.accessibility(),
        points: points.len(),
        ms: masks.ms,
        ..Default::default()
    })
}

/// The texture and vertex AO of a bake from its pieces: the texture
/// padded, the PNG encoded, the counts summed; the asset not yet written.
fn assemble(
    placed: &Placed,
    settings: &BakeSettings,
    (budget, build_ms, cutout_triangles): (Option<RaysChosen>, f64, usize),
    mut pieces: Vec<BakePiece>,
) -> Result<Baked> {
    pieces.sort_by_key(|p| p.items.start);
    let n = settings.resolution as usize;
    let mut warnings = Vec::new();
    let mut report = BakeReport {
        rays_per_point: settings.ao.rays_per_point,
        budget,
        resolution: settings.resolution,
        build_ms,
        cutout_triangles,
        ..Default::default()
    };
    let mut texture = (n > 0).then(|| Vec::with_capacity(n * n));
    let mut vertex_ao = settings.vertex.then(Vec::new);
    for p in &pieces {
        if p.items.start < n {
            let t = texture.as_mut().expect("rows come with a texture");
            t.extend(p.values.iter().map(|&v| (!v.is_nan()).then_some(v)));
            report.texture_ms += p.ms;
            report.texel_points += p.points;
            report.texels_covered += p.texels_covered;
            report.overlapping_samples += p.overlapping_samples;
            report.triangles_outside_unit_square = p.triangles_outside_unit_square;
            report.triangles_without_uv = p.triangles_without_uv;
        } else if let Some(v) = vertex_ao.as_mut() {
            v.extend_from_slice(&p.values);
            report.vertex_ms += p.ms;
        }
    }
    if let Some(values) = texture.as_mut() {
        if values.len() != n * n {
            return Err(Error::internal(format!(
                "a bake's rows give {} of {} texels",
                values.len(),
                n * n
            )));
        }
        note_layout(&report, &mut warnings);
        report.mean_texel_ao = mean(values.iter().flatten().copied());
        dilate(values, settings.resolution, settings.padding);
        report.texels_padded = values.iter().flatten().count() - report.texels_covered;
    }
    if let Some(v) = &vertex_ao {
        if v.len() != placed.mesh.positions.len() {
            let problem = format!(
                "a bake's pieces give {} of {} vertices",
                v.len(),
                placed.mesh.positions.len()
            );
            return Err(Error::internal(problem));
        }
        report.vertices = v.len();
        report.mean_vertex_ao = mean(v.iter().copied());
    }
    let png = match &texture {
        Some(values) => Some(encode_png(values, settings.resolution, settings.png_bits)?),
        None => None,
    };
    Ok(Baked {
        glb: Vec::new(),
        png,
        texture,
        vertex_ao,
        report,
        warnings,
    })
}

/// The rays `max_error` asks for, from a probe: texel points of rows
/// spread over the texture (vertices without a texture), up to
/// `PROBE_POINTS`, cast with `settings.ao`'s rays.
fn choose_rays(tracer: &mut Tracer, placed: &Placed, settings: &BakeSettings, max_error: f64) -> Result<RaysChosen> {
    let n = settings.resolution;
    let mut points = Vec::new();
    if n > 0 {
        let normals = placed.mesh.vertex_normals();
        let step = (n / 64).max(1);
        for y in (step / 2..n).step_by(step as usize) {
            let row = texel_points_in(placed.mesh, &normals, placed.shading, n, 1, y..y + 1);
            points.extend(row.points);
        }
    }
    if points.is_empty() {
        points = vertex_points(placed.mesh);
    }
    if points.len() > PROBE_POINTS {
        let stride = points.len().div_ceil(PROBE_POINTS);
        points = points.into_iter().step_by(stride).collect();
    }
    let masks = tracer.ao_visibility(&points, &settings.ao, &crate::progress::Bar::hidden())?;
    let ao = masks.value.accessibility();
    let variance = ao.iter().map(|&a| (a * (1.0 - a)) as f64).sum::<f64>() / ao.len().max(1) as f64;
    let (rays, estimated_error) = rays_for(variance, max_error);
    Ok(RaysChosen {
        max_error,
        probe_points: points.len(),
        probe_rays: settings.ao.rays_per_point,
        ray_variance: variance,
        rays,
        estimated_error,
    })
}

/// The asset at `input` (read as `file`) with `baked`'s AO, as a GLB.
fn write_asset(input: &Path, file: &crate::scene::ObjFile, settings: &BakeSettings, baked: &mut Baked) -> Result<()> {
    let ao = BakedAo {
        texture_png: baked.png.as_deref(),
        vertex_ao: baked.vertex_ao.as_deref(),
        vertex_colors: settings.vertex_colors,
        replace: settings.replace,
    };
    let out = crate::scene::glb_with_ao(input, file, &ao)?;
    baked.glb = out.bytes;
    baked.warnings.extend(out.warnings);
    baked.report.materials_with_ao = out.materials_with_ao;
    baked.report.primitives_with_ao = out.primitives_with_ao;
    Ok(())
}

fn note_layout(t: &BakeReport, warnings: &mut Vec<String>) {
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
