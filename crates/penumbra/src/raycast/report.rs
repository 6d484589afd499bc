//! What an AO run writes and reports: the per-vertex file and the image
//! with their summaries, the notes a user should read, and the report of
//! `ao --method raycast` (the CLI's `--json`). The field runner's report
//! (`field::report`) shares the outputs and the common fields.

use std::path::Path;

use serde::Serialize;

use super::AoSettings;
use super::runner::{PixelAo, RaycastAo, VertexAo, mean, near_zero_warning, write_vertex_ao};
use crate::accel::BvhStats;
use crate::error::Result;
use crate::io::image::{GreyStyle, write_grey};
use crate::io::output::{frame_output, frame_path};
use crate::report::repeats::RunTimes;
use crate::scene::{Camera, Scene};

/// Where an AO run's results go; `None`: not asked for.
#[derive(Debug, Clone, Copy)]
pub struct AoOutputs<'a> {
    /// CSV `index,ao`, or a `.ply` with AO as vertex colours.
    pub per_vertex: Option<&'a Path>,
    /// AO per pixel: PNG, EXR or PFM.
    pub image: Option<&'a Path>,
    /// How the image is written: PNG bit depth, and what a pixel whose
    /// primary ray missed becomes.
    pub style: GreyStyle,
}

/// The per-vertex file written.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VertexSummary {
    /// The path written, as given.
    pub file: String,
    /// Vertices written: the receivers'.
    pub vertices: usize,
    /// Vertices no triangle of non-zero area uses (ao = 1, no rays): written,
    /// but left out of `mean_ao`.
    pub without_normal: usize,
    /// Vertices some triangle of non-zero area uses: those `mean_ao` is over.
    pub used_vertices: usize,
    /// What `mean_ao` is over: always `"used_vertices"`, so that a reader
    /// of the JSON need not guess whether unused vertices (ao = 1) count.
    pub mean_over: &'static str,
    /// Mean AO over the used vertices (in [0, 1], 1 open); 0 when none is used.
    pub mean_ao: f64,
    /// Ray casting's time for the vertices (the field runner reports per frame instead).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ao_ms: Option<f64>,
}

/// The image written.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImageSummary {
    /// The path written, as given.
    pub file: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Pixels whose primary ray hit, and so have AO.
    pub pixels_hit: usize,
    /// Mean AO over the pixels hit.
    pub mean_ao: f64,
    /// Milliseconds of the pixels' AO (primary rays not included): the
    /// kernels' own time from GPU timestamps where the device has them,
    /// else wall clock.
    pub ao_ms: f64,
    /// The camera's eye, in the scene's frame (world coordinates less
    /// `Mesh::origin`, which is zero but for models far from the origin).
    pub eye: [f32; 3],
    /// The point the camera looks at, in the same frame.
    pub target: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov: f32,
}

/// What `AoOutputs::write` wrote, and what a user should be told about it.
#[derive(Debug, Clone, Default)]
pub struct Written {
    /// The per-vertex file, if one was written.
    pub per_vertex: Option<VertexSummary>,
    /// The image, if one was written.
    pub image: Option<ImageSummary>,
    /// Warnings worth a line on stderr (AO near 0 everywhere, vertices without a normal).
    pub notes: Vec<String>,
}

impl AoOutputs<'_> {
    /// Writes the asked-for results of the receivers at `frame` (`radius`:
    /// the settings', infinite for none).
    pub fn write(
        &self,
        scene: &Scene,
        frame: u32,
        radius: f32,
        vertices: Option<&VertexAo>,
        image: Option<&PixelAo>,
    ) -> Result<Written> {
        let mut written = Written::default();
        let radius = radius.is_finite().then_some(radius);
        if let (Some(path), Some(v)) = (self.per_vertex, vertices) {
            if v.without_normal > 0 {
                written.notes.push(format!(
                    "{} vertices are used by no triangle of non-zero area; they have no normal, cast no rays and \
                     are written as ao = 1 and left out of mean_ao",
                    v.without_normal
                ));
            }
            let used_ao = used_values(scene, frame, &v.ao)?;
            written.notes.extend(near_zero_warning(&used_ao, radius, scene));
            written.notes.extend(near_one(&used_ao, radius, scene));
            write_vertex_ao(path, scene, frame, &v.ao)?;
            written.per_vertex = Some(VertexSummary {
                file: path.display().to_string(),
                vertices: v.ao.len(),
                without_normal: v.without_normal,
                used_vertices: used_ao.len(),
                mean_over: "used_vertices",
                mean_ao: mean(&used_ao),
                ao_ms: (v.ms > 0.0).then_some(v.ms),
            });
        }
        if let (Some(path), Some(image)) = (self.image, image) {
            let values: Vec<f32> = image.values.iter().flatten().copied().collect();
            written.notes.extend(near_zero_warning(&values, radius, scene));
            written.notes.extend(near_one(&values, radius, scene));
            write_grey(path, image.width, image.height, &image.values, self.style)?;
            written.image = Some(ImageSummary::of(path, image));
        }
        Ok(written)
    }

    /// `write` for frame `frame` of an animation (`last`: its last frame):
    /// an output whose name holds `{}` or `{:04}` gets a file per frame,
    /// any other only the last frame.
    pub fn write_frame(
        &self,
        scene: &Scene,
        (frame, last): (u32, bool),
        radius: f32,
        vertices: Option<&VertexAo>,
        image: Option<&PixelAo>,
    ) -> Result<Written> {
        let per_vertex = self.per_vertex.and_then(|p| frame_output(p, frame, last));
        let image_file = self.image.and_then(|p| frame_output(p, frame, last));
        let outputs = AoOutputs {
            per_vertex: per_vertex.as_deref(),
            image: image_file.as_deref(),
            style: self.style,
        };
        outputs.write(scene, frame, radius, vertices, image)
    }

    /// Whether an output is a file per frame (its name holds `{}`).
    pub fn per_frame(&self) -> bool {
        [self.per_vertex, self.image]
            .into_iter()
            .flatten()
            .any(|p| frame_path(p, 0).is_some())
    }
}

/// The warning for AO about 1 everywhere under a finite `radius` far below
/// the scene's size (`report::near_one_warning`), suggesting a tenth of it.
fn near_one(ao: &[f32], radius: Option<f32>, scene: &Scene) -> Option<String> {
    let radius = radius?;
    let size = scene.world_mesh(|_| true).bounds().diagonal();
    crate::report::near_one_warning(ao, "radius", radius, size, 0.1 * size).map(|w| format!("warning: {w}"))
}

/// The values of `ao` (one per receiver vertex at `frame`) at the vertices
/// some triangle of non-zero area uses: an unused vertex casts no rays and
/// reads 1, which would pull a mean towards open. Values of another length
/// than the receivers' vertices are all kept.
pub fn used_values(scene: &Scene, frame: u32, ao: &[f32]) -> Result<Vec<f32>> {
    let normals = super::runner::receivers(scene, frame)?.vertex_normals();
    if normals.len() != ao.len() {
        return Ok(ao.to_vec());
    }
    Ok(ao
        .iter()
        .zip(&normals)
        .filter(|(_, n)| **n != glam::Vec3::ZERO)
        .map(|(&a, _)| a)
        .collect())
}

impl ImageSummary {
    fn of(path: &Path, image: &PixelAo) -> Self {
        let Camera {
            eye,
            target,
            fov_degrees,
            ..
        } = image.camera;
        ImageSummary {
            file: path.display().to_string(),
            width: image.width,
            height: image.height,
            pixels_hit: image.hit(),
            mean_ao: image.mean(),
            ao_ms: image.ms,
            eye: eye.to_array(),
            target: target.to_array(),
            fov: fov_degrees,
        }
    }
}

/// The fields every AO report has.
#[derive(Debug, Clone, Serialize)]
pub struct AoReport {
    /// The method: `raycast` or `field`.
    pub method: &'static str,
    /// Rays per point (`AoSettings::rays_per_point`).
    pub rays_per_point: u32,
    /// `None`: infinite.
    pub radius: Option<f32>,
    /// The sample sequence's seed.
    pub seed: u32,
    /// Kd-tree (ray casting) or field (fields) build time.
    pub build_ms: f64,
    /// Points that cast rays.
    pub points: usize,
    /// AO time (the field runner: its last frame's).
    pub ao_ms: f64,
    /// Millions of rays a second: `points * rays_per_point` over `ao_ms`.
    pub mrays_per_s: f64,
    /// The per-vertex file, if one was written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_vertex: Option<VertexSummary>,
    /// The image, if one was written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub image: Option<ImageSummary>,
    /// The measured runs' `ao_ms` (`--warmup`, `--repeat`); the rest is the last run's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub runs: Option<RunTimes>,
}

impl AoReport {
    /// The common fields of `method`'s run with `settings`: `build_ms` its
    /// structure's build, `points` that cast rays in `ao_ms`; no outputs
    /// or runs yet.
    pub fn new(method: &'static str, settings: &AoSettings, build_ms: f64, (points, ao_ms): (usize, f64)) -> Self {
        AoReport {
            method,
            rays_per_point: settings.rays_per_point,
            radius: settings.radius.is_finite().then_some(settings.radius),
            seed: settings.seed,
            build_ms,
            points,
            ao_ms,
            mrays_per_s: points as f64 * settings.rays_per_point as f64 / (ao_ms.max(1e-9) * 1e3),
            per_vertex: None,
            image: None,
            runs: None,
        }
    }

    /// The report with the outputs' summaries.
    pub fn with(mut self, written: Written) -> Self {
        self.per_vertex = written.per_vertex;
        self.image = written.image;
        self
    }
}

/// The casters' size.
#[derive(Debug, Clone, Serialize)]
pub struct Casters {
    /// Instances that cast (the field runner's report); `None` for ray
    /// casting, which merges them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub instances: Option<usize>,
    /// The casters' triangles, merged.
    pub triangles: usize,
    /// Those with an alpha cut-out, whose holes every ray passes.
    #[serde(skip_serializing_if = "crate::report::is_zero")]
    pub cutout_triangles: usize,
}

/// `ao --method raycast`'s report.
#[derive(Debug, Clone, Serialize)]
pub struct RaycastReport {
    /// The fields every AO report has, at the top level of the JSON.
    #[serde(flatten)]
    pub ao: AoReport,
    /// The casters' size.
    pub casters: Casters,
    /// The casters' wide BVH on the CPU: its build (apart from `build_ms`,
    /// the kd-tree's, and from `ao_ms`), nodes, blocks and bytes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bvh: Option<BvhStats>,
}

impl RaycastReport {
    /// The report with the measured runs' times.
    pub fn with_runs(mut self, runs: RunTimes) -> Self {
        self.ao.runs = Some(runs);
        self
    }

    /// The report of a run's AO with `settings`, and of what was written.
    pub fn new(ao: &RaycastAo, settings: &AoSettings, written: Written) -> Self {
        RaycastReport {
            ao: AoReport::new("raycast", settings, ao.build_ms, (ao.points(), ao.ao_ms())).with(written),
            casters: Casters {
                instances: None,
                triangles: ao.caster_triangles,
                cutout_triangles: ao.cutout_triangles,
            },
            bvh: ao.bvh.clone(),
        }
    }
}
