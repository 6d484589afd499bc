//! The SSAO runner (`penumbra ssao`): a scene's G-buffer, one of the
//! paper's estimators with its filter, optionally the indirect light and
//! shaded image, on the GPU or in the CPU twins; then the estimator's error
//! against world-space ray-traced AO of the same measure and against the
//! screen-space reference (dense quadrature over the same depth buffer).

use serde::Serialize;

use super::estimators::SampleTable;
use super::gbuffer::{GBuffer, ScreenView, gbuffer_with, validate_lights};
use super::gpu::{GBufferSource, run_frame};
use super::surfaces::GBufferSurfaces;
use super::truth::{Estimate, raytraced, screen_reference};
use super::{Estimator, Measure, ShadeSettings, SsaoFrame, SsaoSettings, Timings, rmse, run_cpu};
use crate::accel::Accel;
use crate::accel::kdtree::KdTreeSettings;
use crate::error::{Error, Result};
use crate::gpu::device::{Device, GpuOutput, Timing, elapsed_ms};
use crate::progress::Reporter;
use crate::raycast::tracer::build_tree;
use crate::report::repeats::{MAX_RUNS, Repeats, RunTimes};
use crate::report::skipped::Skipped;
use crate::scene::texture_table::DEFAULT_TEXTURE_BYTES;
use crate::scene::{Camera, Scene, View};
use std::cell::OnceCell;

/// One SSAO frame and its measurements.
#[derive(Debug, Clone, PartialEq)]
pub struct SsaoRequest {
    /// The estimator and its knobs.
    pub settings: SsaoSettings,
    /// The camera (completed from the scene's, else framing the scene) and the
    /// image size.
    pub view: View,
    /// The indirect light and shaded image (ambient La), if wanted.
    pub shade: Option<ShadeSettings>,
    /// Rays per pixel of the ray-traced truth (0: none).
    pub truth_rays: u32,
    /// Samples per pixel of the screen-space reference (0: none).
    pub reference_spp: u32,
    /// Untimed frames first, then measured ones (the passes' fastest
    /// times are reported, and every run's in `runs`); outputs are the last's.
    pub runs: Repeats,
}

impl SsaoRequest {
    /// Checks the settings, the image size, the shading, the references'
    /// samples per pixel (at most `raycast::MAX_RAYS_PER_POINT`) and the
    /// repeats.
    pub fn validate(&self) -> Result<()> {
        self.settings.validate()?;
        crate::scene::check_image_size(self.view.width, self.view.height)?;
        if let Some(shade) = &self.shade {
            shade.validate()?;
        }
        // The references' rays per pixel: as many as AO's per point at most.
        let most = crate::raycast::MAX_RAYS_PER_POINT;
        for (name, n) in [
            ("reference_rays", self.truth_rays),
            ("screen_reference_spp", self.reference_spp),
        ] {
            if n > most {
                return Err(Error::param(name, format!("must be between 0 and {most}, got {n}")));
            }
        }
        if self.runs.repeat == 0 || self.runs.repeat > MAX_RUNS || self.runs.warmup > MAX_RUNS {
            return Err(Error::param("repeat", format!("must be between 1 and {MAX_RUNS}")));
        }
        Ok(())
    }
}

/// A frame with its G-buffer and references.
pub struct SsaoRun {
    /// The camera the frame was seen through, resolved against the scene.
    pub camera: Camera,
    /// The frame's G-buffer.
    pub gbuffer: GBuffer,
    /// The frame's outputs (the last run's) and timings.
    pub frame: SsaoFrame,
    /// World-space ray-traced AO at the same points, when asked for
    /// (`truth_rays` > 0).
    pub truth: Option<Estimate>,
    /// The screen-space reference, when asked for (`reference_spp` > 0).
    pub reference: Option<Estimate>,
    /// What `ssao --json` reports of it.
    pub report: SsaoReport,
    /// The scene's texture images that could not be read or were reduced
    /// (`GBufferSurfaces::of_scene`).
    pub warnings: Vec<String>,
}

/// What `ssao --json` reports.
#[derive(Debug, Clone, Serialize)]
pub struct SsaoReport {
    /// The estimator run.
    pub estimator: Estimator,
    /// Samples per pixel.
    pub spp: u32,
    /// Milliseconds of the AO: estimator and filter.
    pub ao_ms: f64,
    /// RMS difference of the final AO from the ray-traced truth over the
    /// surface pixels; None without truth.
    pub rmse_vs_raytraced: Option<f64>,
    /// RMS difference of the final AO from the screen-space reference over the
    /// surface pixels; None without reference.
    pub rmse_vs_screen_reference: Option<f64>,
    /// How the times were measured: GPU timestamps or the wall clock.
    pub timing: Timing,
    /// Milliseconds of the G-buffer (`Timings::gbuffer_ms`).
    pub gbuffer_ms: f64,
    /// Milliseconds of the estimator (`Timings::estimate_ms`).
    pub estimate_ms: f64,
    /// Milliseconds of the AO filter (`Timings::filter_ms`).
    pub filter_ms: f64,
    /// Milliseconds of the indirect light (`Timings::indirect_ms`).
    pub indirect_ms: f64,
    /// Milliseconds composing the shaded image (`Timings::compose_ms`).
    pub compose_ms: f64,
    /// Milliseconds of every step together.
    pub frame_ms: f64,
    /// Neighbourhood radius R, scene units.
    pub radius: f32,
    /// The fuzzy measure's name.
    pub measure: &'static str,
    /// The exponential measure's sigma, inverse scene units; None for the
    /// others.
    pub sigma: Option<f32>,
    /// Steps per ray; raymarch only.
    pub steps: Option<u32>,
    /// Whether the sample sets were interleaved over 4x4 pixels.
    pub interleave: bool,
    /// Whether the depth-aware filter ran.
    pub filter: bool,
    /// The filter's depth limit, scene units (R / 2 unless set).
    pub filter_depth: f32,
    /// The visibility test's depth bias, in pixel footprints.
    pub bias_px: f32,
    /// Whether each pixel's weights were scaled to give 1 at an open point.
    pub calibrate: bool,
    /// Sample sets that carry no weight at an open point
    /// (`SampleTable::weightless_sets`): 0 unless the measure's weight lies
    /// closer to the point than a volume estimator's samples reach; the
    /// pixels using them read about 0 (a warning says so).
    pub weightless_sets: u32,
    /// The estimation grid: `full` or `half`.
    pub resolution: &'static str,
    /// Seed of the sample tables.
    pub seed: u32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Pixels that show a surface.
    pub surface_pixels: usize,
    /// Mean final accessibility over the surface pixels.
    pub mean_ao: f64,
    /// The ray-traced truth's noise, samples per pixel and time (its values are
    /// not written).
    pub truth: Option<Estimate>,
    /// The screen-space reference's noise, samples per pixel and time (its
    /// values are not written).
    pub reference: Option<Estimate>,
    /// The whole scene's kd-tree (0 when it was not needed).
    pub build_ms: f64,
    /// The camera the frame was seen through.
    pub camera: Camera,
    /// What the frame did not need: the kd-tree of the drawn scene (a GPU
    /// rasterises the G-buffer; the truth needs only the casters'), the
    /// truth and the screen reference when not asked for.
    pub skipped: Vec<Skipped>,
    /// What screen space cannot see (with a reference; null without truth).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rmse_reference_vs_raytraced: Option<Option<f64>>,
    /// The measured frames' times (`--warmup`, `--repeat`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub runs: Option<RunTimes>,
}

/// Runs `request` on `scene` (every instance is drawn; casters occlude the
/// ray-traced truth) on `device`.
pub fn run(device: &Device, scene: &Scene, request: &SsaoRequest, bars: &Reporter) -> Result<SsaoRun> {
    request.validate()?;
    validate_lights(&scene.lights)?;
    let settings = &request.settings;
    let mesh = scene.world_mesh(|_| true);
    let occluders = scene.occluders();
    let camera = scene.camera_in(&request.view.camera, &mesh.bounds())?;
    let (w, h) = (request.view.width, request.view.height);
    let view = ScreenView::new(&camera, w, h);
    let shade = request.shade.as_ref();
    // The whole scene's tree serves the CPU G-buffer and a truth whose
    // casters are the whole scene; built on first need.
    let tree = OnceCell::new();
    let whole_tree = || -> Result<&Accel> {
        if tree.get().is_none() {
            let _ = tree.set(Accel::new(build_tree(&mesh, &KdTreeSettings::for_cpu(), bars, "ssao")?));
        }
        Ok(tree.get().expect("set above"))
    };
    let mut warnings = Vec::new();
    let table = SampleTable::build(settings)?;
    if table.weightless_sets > 0 {
        warnings.push(weightless_warning(settings, &table));
    }
    let surfaces = GBufferSurfaces::of_scene(scene, DEFAULT_TEXTURE_BYTES, &mut warnings);
    let framed = device.run(
        |ctx| {
            let source = || GBufferSource::Render {
                mesh: &mesh,
                camera: &camera,
                lights: &scene.lights,
                surfaces: Some(&surfaces),
            };
            for _ in 0..request.runs.warmup {
                run_frame(ctx, source(), &view, settings, shade, 1)?;
            }
            let f = run_frame(ctx, source(), &view, settings, shade, request.runs.repeat)?;
            Ok(GpuOutput {
                value: (f.gbuffer, f.frame, f.runs_ms),
                gpu_ms: None,
            })
        },
        || {
            let tree = whole_tree()?;
            let once = || {
                let start = std::time::Instant::now();
                let gb = gbuffer_with(tree.kdtree(), &mesh, &surfaces, &camera, &scene.lights, (w, h));
                let gbuffer_ms = elapsed_ms(start);
                let mut frame = run_cpu(&gb, &view, settings, shade)?;
                frame.timings.gbuffer_ms = gbuffer_ms;
                Ok((gb, frame))
            };
            let ((gb, frame), runs) = request.runs.run("frame_ms", once, |(_, f)| f.timings.frame_ms())?;
            Ok((gb, frame, runs.ms))
        },
    )?;
    let (gb, frame, runs_ms) = framed.value;
    // Ground truth: only casters occlude.
    let truth = if request.truth_rays > 0 {
        let caster_tree;
        let occ_tree = if occluders.triangles.len() == mesh.triangles.len() {
            whole_tree()?
        } else if occluders.triangles.is_empty() {
            return Err(Error::param("scene", "no instance is a caster: nothing occludes"));
        } else {
            caster_tree = Accel::new(build_tree(&occluders, &KdTreeSettings::for_cpu(), bars, "casters")?);
            &caster_tree
        };
        let (measure, radius) = (settings.measure, settings.radius);
        let progress = bars.bar(gb.pixels() as u64, "ray-traced truth");
        let rays = (request.truth_rays, settings.seed);
        Some(raytraced(
            occ_tree, &camera, &view, &gb, measure, radius, rays, &progress,
        ))
    } else {
        None
    };
    let reference = (request.reference_spp > 0).then(|| {
        let progress = bars.bar(gb.pixels() as u64, "screen-space reference");
        screen_reference(&gb, &view, settings, request.reference_spp, &progress)
    });
    let mut report = SsaoReport::new(request, &camera, &gb, &frame, &truth, &reference);
    let surface_ao: Vec<f32> = (0..gb.pixels())
        .filter(|&i| gb.is_surface(i))
        .map(|i| frame.ao[i])
        .collect();
    let size = mesh.bounds().diagonal();
    let suggested = super::RADIUS_OF_SIZE * size;
    warnings.extend(crate::report::near_one_warning(
        &surface_ao,
        "radius",
        settings.radius,
        size,
        suggested,
    ));
    report.build_ms = tree.get().map_or(0.0, |t| t.kdtree().stats.build_ms);
    report.weightless_sets = table.weightless_sets;
    report.runs = Some(RunTimes::of("frame_ms", request.runs.warmup, runs_ms));
    report.skipped = skipped(request, tree.get().is_none());
    Ok(SsaoRun {
        camera,
        gbuffer: gb,
        frame,
        truth,
        reference,
        report,
        warnings,
    })
}

/// Why a volume estimator's image reads about 0: its sets' uniform samples
/// miss where the measure puts its weight.
fn weightless_warning(s: &SsaoSettings, table: &SampleTable) -> String {
    let sets = table.patterns.count();
    let scale = match s.measure {
        Measure::Exp { sigma } => format!(" (`sigma` x `radius` = {:.3e})", sigma as f64 * s.radius as f64),
        _ => String::new(),
    };
    format!(
        "{} of {sets} sample sets of the {} estimator carry no weight: the {} measure's weight lies \
         closer to the point{scale} than their uniform samples reach, so the pixels using them read \
         AO about 0 whatever occludes them; the importance or raymarch estimator samples the \
         measure's own density, or lower `sigma`",
        table.weightless_sets,
        s.estimator.name(),
        s.measure.name(),
    )
}

/// What `request` left out (`tree_unused`: the whole scene's kd-tree was
/// never needed).
fn skipped(request: &SsaoRequest, tree_unused: bool) -> Vec<Skipped> {
    let mut skipped = Vec::new();
    if tree_unused {
        let why = "the G-buffer was rasterised and no truth traced the whole scene";
        skipped.push(Skipped::new("kd-tree", why));
    }
    if request.truth_rays == 0 {
        skipped.push(Skipped::new("ray-traced truth", "--reference-rays 0"));
    }
    if request.reference_spp == 0 {
        skipped.push(Skipped::new("screen-space reference", "--screen-reference-spp 0"));
    }
    skipped
}

impl SsaoRun {
    /// Writes the accessibility image (`ao`, grey in `style`) and the
    /// shaded image (`image`, linear radiance) where asked.
    pub fn write_images(
        &self,
        ao: Option<&std::path::Path>,
        image: Option<&std::path::Path>,
        style: crate::io::image::GreyStyle,
    ) -> Result<()> {
        let (w, h) = (self.gbuffer.width, self.gbuffer.height);
        if let Some(p) = ao {
            crate::io::image::write_grey(p, w, h, &self.ao_image(), style)?;
        }
        if let (Some(p), Some(pixels)) = (image, &self.frame.image) {
            let radiance: Vec<glam::Vec3> = pixels.iter().map(|c| glam::Vec3::new(c[0], c[1], c[2])).collect();
            crate::io::image::write_radiance(p, w, h, &radiance, 1.0)?;
        }
        Ok(())
    }

    /// Final accessibility per pixel; `None` on the background.
    pub fn ao_image(&self) -> Vec<Option<f32>> {
        (0..self.gbuffer.pixels())
            .map(|i| self.gbuffer.is_surface(i).then_some(self.frame.ao[i]))
            .collect()
    }
}

impl SsaoReport {
    fn new(
        request: &SsaoRequest,
        camera: &Camera,
        gb: &GBuffer,
        frame: &SsaoFrame,
        truth: &Option<Estimate>,
        reference: &Option<Estimate>,
    ) -> SsaoReport {
        let s = &request.settings;
        let t: Timings = frame.timings;
        let surface = gb.surface_pixels();
        let mean_ao = (0..gb.pixels())
            .filter(|&i| gb.is_surface(i))
            .map(|i| frame.ao[i] as f64)
            .sum::<f64>()
            / surface.max(1) as f64;
        let against = |e: &Option<Estimate>| e.as_ref().map(|e| rmse(gb, &frame.ao, &e.values));
        SsaoReport {
            estimator: s.estimator,
            spp: s.spp,
            ao_ms: t.ao_ms(),
            rmse_vs_raytraced: against(truth),
            rmse_vs_screen_reference: against(reference),
            timing: t.timing,
            gbuffer_ms: t.gbuffer_ms,
            estimate_ms: t.estimate_ms,
            filter_ms: t.filter_ms,
            indirect_ms: t.indirect_ms,
            compose_ms: t.compose_ms,
            frame_ms: t.frame_ms(),
            radius: s.radius,
            measure: s.measure.name(),
            sigma: match s.measure {
                Measure::Exp { sigma } => Some(sigma),
                _ => None,
            },
            steps: (s.estimator == Estimator::Raymarch).then_some(s.steps),
            interleave: s.interleave,
            filter: s.filter,
            filter_depth: s.filter_depth(),
            bias_px: s.bias_px,
            calibrate: s.calibrate,
            weightless_sets: 0,
            resolution: s.resolution.name(),
            seed: s.seed,
            width: gb.width,
            height: gb.height,
            surface_pixels: surface,
            mean_ao,
            truth: truth.clone(),
            reference: reference.clone(),
            build_ms: 0.0,
            camera: *camera,
            skipped: Vec::new(),
            rmse_reference_vs_raytraced: reference
                .as_ref()
                .map(|r| truth.as_ref().map(|t| rmse(gb, &r.values, &t.values))),
            runs: None,
        }
    }
}
