//! The displacement-field AO runner (`ao --method field`, Algorithm 2 of
//! the paper over a scene with roles): one field per caster mesh, loaded
//! from the scene's `.dfield` files or built, serves every instance of the
//! mesh whatever its placement and motion. Receivers' vertices (and the
//! pixels a camera sees) cast the same rays as the reference AO runner; the
//! fields answer them, on the GPU or the CPU. Objects that cast and receive
//! get their own rays cast against their own geometry (a field cannot see
//! self-occlusion, see `field::ao`). Optionally the same rays are cast
//! against the triangles, and the error is reported per vertex and per ray.

use std::collections::BTreeMap;
use std::time::Instant;

use serde::Serialize;

use super::ao::{FieldCaster, NO_OWNER, RayClasses, field_ao};
use super::build::{DisplacementField, FieldSummary};
use super::gpu::{FieldAoBatches, FieldGroup, GpuField, GpuInstance};
use super::lookup::Positional;
use super::reach::{Reach, reaching, skipped_fields};
use super::storage::FieldSampling;
use crate::error::{Error, Result};
use crate::gpu::device::{Device, GpuOutput, OnDevice, Timed, elapsed_ms};
use crate::progress::{Bar, Reporter};
use crate::raycast::points::vertex_points;
use crate::raycast::runner::{AoRequest, PixelAo, VertexAo, casters, visible_points};
use crate::raycast::tracer::Tracer;
use crate::raycast::{AoPoint, AoSettings, VisibilityMasks};
use crate::report::skipped::Skipped;
use crate::scene::cutouts::Cutouts;
use crate::scene::texture_table::DEFAULT_TEXTURE_BYTES;
use crate::scene::{Instance, Mesh, Role, Scene};
use std::sync::Arc;

/// Most animation frames one run may ask for.
pub const MAX_FRAMES: u32 = 100_000;

/// Where a caster mesh's field came from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FieldReport {
    /// The scene's name of the mesh.
    pub mesh: String,
    /// The field's header.
    #[serde(flatten)]
    pub summary: FieldSummary,
    /// The `.dfield` file it was read from, if it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Build time, if it was built.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub build_ms: Option<f64>,
}

/// The fields of a scene's casters, on a device.
pub struct FieldAo<'s> {
    scene: &'s Scene,
    positional: Positional,
    fields: BTreeMap<usize, DisplacementField>,
    reports: Vec<FieldReport>,
    /// What the fields were built for, per instance whether its field can
    /// occlude some receiver there, and the meshes left without a field.
    reach: Reach,
    reaching: Vec<bool>,
    skipped: Vec<Skipped>,
    gpu: OnDevice<GpuFields>,
    /// Where the fields live (the CPU until `upload`).
    device: Device,
    bars: Reporter,
    cutout_triangles: usize,
}

/// What the runner keeps on a GPU.
struct GpuFields {
    fields: BTreeMap<usize, GpuField>,
    batches: FieldAoBatches,
}

impl<'s> FieldAo<'s> {
    /// Reads the field of every caster mesh the scene names a file for
    /// (`Scene::fields`) and builds the others with `params`, for the
    /// casters whose fields can occlude a receiver within `reach` (the
    /// others are `skipped`); the fields answer on the CPU until `upload`ed.
    pub fn new(
        scene: &'s Scene,
        params: &FieldSampling,
        positional: Positional,
        reach: Reach,
        bars: &Reporter,
    ) -> Result<Self> {
        if !scene.instances.iter().any(|i| i.role.casts()) {
            return Err(Error::param("scene", "no instance is a caster: nothing occludes"));
        }
        if !scene.instances.iter().any(|i| i.role.receives()) {
            return Err(Error::param("scene", "no instance is a receiver: no vertices to shade"));
        }
        let reaching = reaching(scene, reach);
        let skipped = skipped_fields(scene, &reaching, reach);
        let mut fields = BTreeMap::new();
        let mut reports = Vec::new();
        let mut cutout_triangles = 0;
        for (inst, _) in scene.instances.iter().zip(&reaching).filter(|(_, r)| **r) {
            if fields.contains_key(&inst.mesh) {
                continue;
            }
            let mesh = &scene.meshes[inst.mesh];
            let (field, file, build_ms) = match scene.fields.get(&inst.mesh) {
                Some(path) => {
                    let field = super::file::read(path)?;
                    field.check_built_from(&mesh.mesh, path, &mesh.path)?;
                    (field, Some(path.display().to_string()), None)
                }
                None => {
                    let progress = bars.bar(params.maps() as u64, &format!("field of {}", mesh.name));
                    let what = mesh.path.display().to_string();
                    let cutouts = Cutouts::of_mesh(mesh, DEFAULT_TEXTURE_BYTES, &mut Vec::new());
                    cutout_triangles += cutouts.as_ref().map_or(0, |c| c.records.len());
                    let (field, stats) =
                        DisplacementField::build_through(&mesh.mesh, cutouts.as_ref(), params, &what, &progress)?;
                    progress.finish();
                    (field, None, Some(stats.build_ms))
                }
            };
            reports.push(FieldReport {
                mesh: mesh.name.clone(),
                summary: field.summary(),
                file,
                build_ms,
            });
            fields.insert(inst.mesh, field);
        }
        Ok(FieldAo {
            scene,
            positional,
            fields,
            reports,
            reach,
            reaching,
            skipped,
            gpu: OnDevice::Cpu,
            device: Device::cpu(),
            bars: bars.clone(),
            cutout_triangles,
        })
    }

    /// Triangles of the built fields' meshes with an alpha cut-out, whose
    /// holes the fields' rays passed.
    pub fn cutout_triangles(&self) -> usize {
        self.cutout_triangles
    }

    /// Puts the fields on `device` (3D textures on a GPU); lookups run there.
    pub fn upload(&mut self, device: &Device) -> Result<()> {
        let (fields, positional) = (&self.fields, self.positional);
        self.gpu = device.prepare(|ctx| {
            let mut uploaded = BTreeMap::new();
            for (&mesh, field) in fields {
                uploaded.insert(mesh, GpuField::upload(&ctx.device, &ctx.queue, field, positional)?);
            }
            Ok(GpuFields {
                fields: uploaded,
                batches: FieldAoBatches::new(ctx),
            })
        })?;
        self.device = device.clone();
        Ok(())
    }

    /// The scene the fields serve.
    pub fn scene(&self) -> &'s Scene {
        self.scene
    }

    /// How lookups read the positional samples.
    pub fn positional(&self) -> Positional {
        self.positional
    }

    /// Where each field came from, in the order the casters name them.
    pub fn reports(&self) -> &[FieldReport] {
        &self.reports
    }

    /// The caster meshes no receiver needs a field of, and why.
    pub fn skipped(&self) -> &[Skipped] {
        &self.skipped
    }

    /// The AO rays of `points` (owned by instance `owners[i]`, or
    /// `NO_OWNER`) through every caster's field at animation `frame`.
    pub fn visibility(
        &mut self,
        frame: u32,
        points: &[AoPoint],
        owners: &[u32],
        settings: &AoSettings,
        progress: &Bar,
    ) -> Result<Timed<(VisibilityMasks, RayClasses)>> {
        if points.len() != owners.len() {
            return Err(Error::input("points", "need one owner each"));
        }
        let reaching = &self.reaching;
        let casters = self.scene.instances.iter().enumerate().filter(|&(k, _)| reaching[k]);
        if casters.clone().next().is_none() {
            // No field can occlude any receiver: every ray is open.
            let masks = open_masks(points.len(), settings);
            let none = vec![0; masks.bits.len()];
            let classes = RayClasses {
                inside: none.clone(),
                hidden: none,
            };
            return Timed::wall(|| Ok((without_extra_bits(masks, settings), classes)));
        }
        let (fields, positional) = (&self.fields, self.positional);
        self.gpu.run(
            |ctx, g| {
                let mut groups: BTreeMap<usize, Vec<GpuInstance>> = BTreeMap::new();
                for (k, inst) in casters.clone() {
                    let placed = GpuInstance::new(&inst.transform_at(frame), k as u32);
                    groups.entry(inst.mesh).or_default().push(placed);
                }
                let groups: Vec<FieldGroup> = groups
                    .into_iter()
                    .map(|(mesh, instances)| FieldGroup {
                        field: &g.fields[&mesh],
                        instances,
                    })
                    .collect();
                let r = g.batches.visibility(ctx, &groups, points, owners, settings, progress)?;
                Ok(GpuOutput {
                    value: (r.masks, r.classes),
                    gpu_ms: r.gpu_ms,
                })
            },
            || {
                let casters: Vec<FieldCaster> = casters
                    .clone()
                    .map(|(k, inst)| FieldCaster {
                        field: &fields[&inst.mesh],
                        transform: inst.transform_at(frame),
                        instance: k as u32,
                    })
                    .collect();
                Ok(field_ao(&casters, points, owners, settings, positional, progress))
            },
        )
    }

    /// AO of `request` over `frames` animation frames (instances with a
    /// motion move, fields are reused); the outputs are the last frame's.
    pub fn run(&mut self, request: &AoRequest, frames: u32, reference: bool) -> Result<FieldAoRun> {
        self.run_frames(request, frames, reference, None)
    }

    /// `run`, also handing every frame before the last to `each` (its
    /// number, its vertex AO and image as `request` asks): what writes an
    /// animation's every frame (`--image 'f_{:04}.png'`).
    pub fn run_frames(
        &mut self,
        request: &AoRequest,
        frames: u32,
        reference: bool,
        each: Option<FrameSink<'_>>,
    ) -> Result<FieldAoRun> {
        self.run_range(request, (frames, 0..frames), reference, each)
    }

    /// Frames `range` of an animation of `frames` frames, each computed as
    /// `run_frames` computes it: a frame's AO depends on that frame alone
    /// (frame 0's self-occlusion, the moving objects' own recast at the
    /// frame, the fields at the frame), so a range gives the bits of the
    /// same frames of the whole run. `each` sees every frame of the range
    /// but its last, whose outputs the run holds (and where the reference
    /// is compared); `frame_ao_ms` has the range's frames, and
    /// `self_occlusion_ms` frame 0's time then those of the range's frames
    /// after 0 where objects moved. What one shard of the frames computes.
    pub fn run_range(
        &mut self,
        request: &AoRequest,
        (frames, range): (u32, std::ops::Range<u32>),
        reference: bool,
        mut each: Option<FrameSink<'_>>,
    ) -> Result<FieldAoRun> {
        let settings = &request.settings;
        settings.validate()?;
        if !(1..=MAX_FRAMES).contains(&frames) {
            return Err(Error::param(
                "frames",
                format!("must be between 1 and {MAX_FRAMES}, got {frames}"),
            ));
        }
        if range.is_empty() || range.end > frames {
            let problem = format!("frames {}..{} are not some of 0..{frames}", range.start, range.end);
            return Err(Error::param("frames", problem));
        }
        if !self.reach.covers(settings.radius, frames) {
            let problem = format!(
                "the fields were chosen for radius {} over {} frame(s); this run asks radius {} over {frames}",
                self.reach.radius, self.reach.frames, settings.radius
            );
            return Err(Error::param("reach", problem));
        }
        let scene = self.scene;
        let owners = receiver_owners(scene);
        let moving_self = scene
            .instances
            .iter()
            .any(|i| i.role == Role::Both && i.motion.is_some());
        // Self-occlusion: once for objects that do not move, every frame
        // for those that do (the AO rays follow the world's tangent frame).
        let start = Instant::now();
        let points = vertex_points(&scene.world_mesh(Role::receives));
        let mut own = self_occlusion(scene, 0, &points, &owners, settings, |_| true)?;
        let mut self_ms = vec![elapsed_ms(start)];
        let mut frame_ms = Vec::new();
        let mut last = None;
        for frame in range.clone() {
            let points = vertex_points(&scene.world_mesh_at(frame, Role::receives));
            if frame > 0 && moving_self {
                let start = Instant::now();
                let moved = self_occlusion(scene, frame, &points, &owners, settings, |i| i.motion.is_some())?;
                if let (Some(all), Some(moved)) = (own.as_mut(), moved) {
                    replace_moving(scene, all, &moved, &owners);
                }
                self_ms.push(elapsed_ms(start));
            }
            let progress = self.bars.bar(points.len() as u64, &format!("field AO, frame {frame}"));
            let traced = self.visibility(frame, &points, &owners, settings, &progress)?;
            progress.finish();
            frame_ms.push(traced.ms);
            if let Some(each) = each.as_mut()
                && frame + 1 < range.end
            {
                let masks = combined(&traced.value.0, own.as_ref());
                let (vertices, image) = self.outputs(request, frame, &points, &masks, settings)?;
                each(frame, vertices.as_ref(), image.as_ref())?;
            }
            last = Some((points, traced.value));
        }
        let (points, (field_masks, classes)) = last.expect("at least one frame");
        let masks = combined(&field_masks, own.as_ref());
        let last_frame = range.end - 1;
        let reference = if reference {
            let device = self.device.clone();
            let lookups = ErrorInputs {
                combined: &masks,
                fields: &field_masks,
                classes: &classes,
            };
            Some(compare_with_raycast(
                &device, scene, last_frame, &points, &owners, settings, &lookups, &self.bars,
            )?)
        } else {
            None
        };
        let (vertices, image) = self.outputs(request, last_frame, &points, &masks, settings)?;
        Ok(FieldAoRun {
            self_occlusion_ms: own.as_ref().map(|_| self_ms),
            frame_ao_ms: frame_ms,
            vertices,
            points: points.len(),
            rays_inside_sphere: count(&classes.inside),
            rays_hidden: count(&classes.hidden),
            reference,
            image,
        })
    }

    /// What `request` asks of `frame`: the receivers' vertex AO from their
    /// combined `masks`, and the image.
    fn outputs(
        &mut self,
        request: &AoRequest,
        frame: u32,
        points: &[AoPoint],
        masks: &VisibilityMasks,
        settings: &AoSettings,
    ) -> Result<(Option<VertexAo>, Option<PixelAo>)> {
        let vertices = request.vertices.then(|| VertexAo {
            without_normal: crate::raycast::points::points_without_hemisphere(points),
            ao: masks.accessibility(),
            ms: 0.0,
        });
        let image = match &request.image {
            Some(view) => Some(self.image(frame, view, settings)?),
            None => None,
        };
        Ok((vertices, image))
    }

    /// Per-pixel AO through the fields at `frame`: the pixels the camera
    /// sees, each owned by the instance it shows.
    fn image(&mut self, frame: u32, view: &crate::scene::View, settings: &AoSettings) -> Result<PixelAo> {
        let scene = self.scene;
        let everything = scene.world_mesh_at(frame, |_| true);
        let cutouts = Cutouts::of_scene(scene, |_| true, DEFAULT_TEXTURE_BYTES, &mut Vec::new());
        let mut tracer = Tracer::build_labelled(&Device::cpu(), &everything, &self.bars, "all instances")?
            .with_cutouts(cutouts.map(Arc::new));
        let seen = visible_points(&mut tracer, &everything, scene.camera, view)?;
        // Objects of `everything` are the instances, in order.
        let owners: Vec<u32> = seen
            .hits
            .value
            .iter()
            .filter(|h| h.is_hit())
            .map(|h| everything.object_index(h.triangle).map_or(NO_OWNER, |k| k as u32))
            .collect();
        let progress = self
            .bars
            .bar(seen.points.len() as u64, &format!("field AO, frame {frame}"));
        let traced = self.visibility(frame, &seen.points, &owners, settings, &progress)?;
        Ok(seen.image(&traced.value.0.accessibility(), traced.ms))
    }
}

/// Takes a frame's results (`FieldAo::run_frames`).
pub type FrameSink<'a> = &'a mut dyn FnMut(u32, Option<&VertexAo>, Option<&PixelAo>) -> Result<()>;

/// The receivers' visibility: the fields' rays that also escape their own
/// object (`own`, where objects cast and receive).
fn combined(fields: &VisibilityMasks, own: Option<&VisibilityMasks>) -> VisibilityMasks {
    match own {
        Some(own) => VisibilityMasks {
            bits: fields.bits.iter().zip(&own.bits).map(|(a, b)| a & b).collect(),
            ..fields.clone()
        },
        None => fields.clone(),
    }
}

/// What `FieldAo::run` measured.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldAoRun {
    /// Self-occlusion of objects that cast and receive: frame 0, then each
    /// frame they moved in; `None` when no object casts and receives.
    pub self_occlusion_ms: Option<Vec<f64>>,
    /// Field AO time per frame.
    pub frame_ao_ms: Vec<f64>,
    /// The last frame's AO at the receivers' vertices.
    pub vertices: Option<VertexAo>,
    /// Receiver vertices that cast rays.
    pub points: usize,
    /// Rays of the last frame that started inside the bounding sphere of a
    /// caster they entered.
    pub rays_inside_sphere: u64,
    /// Rays of the last frame for which some field put the surface behind the
    /// origin (that field counts them as misses).
    pub rays_hidden: u64,
    /// The same rays cast against the casters' triangles at the last frame,
    /// when `run` was asked for it.
    pub reference: Option<FieldReference>,
    /// The last frame's AO per pixel, when the request asks for an image.
    pub image: Option<PixelAo>,
}

/// Rays on which the fields and ray casting disagree, by where they start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RayErrors {
    /// Rays compared: points x rays per point.
    pub total: u64,
    /// Rays that the fields and ray casting find differently open or blocked.
    pub disagree: u64,
    /// Rays that started inside the bounding sphere of a caster they entered.
    pub inside_sphere: u64,
    /// Of those, the rays that disagree.
    pub disagree_inside_sphere: u64,
    /// Disagreeing rays among the others (started outside every sphere they
    /// entered, or entered none).
    pub disagree_outside_sphere: u64,
    /// `disagree_inside_sphere` / `inside_sphere` (0 when no ray started
    /// inside).
    pub disagree_fraction_inside: f64,
    /// `disagree_outside_sphere` over the rays that started outside
    /// (0 when there are none).
    pub disagree_fraction_outside: f64,
}

/// Error against ray casting, per vertex and per ray.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AoErrors {
    /// Root-mean-square difference of the vertices' accessibility.
    pub rms_error: f64,
    /// Largest absolute difference of a vertex's accessibility.
    pub max_error: f64,
    /// The rays that disagree, by where they start.
    pub rays: RayErrors,
}

/// The same rays cast against the casters' triangles at the last frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FieldReference {
    /// Milliseconds ray casting the reference on the run's device: GPU
    /// timestamps where the device has them, else the wall clock.
    pub raycast_ms: f64,
    /// Milliseconds building the casters' kd-tree for it.
    pub kdtree_ms: f64,
    /// The result (fields and self-occlusion) against all casters.
    #[serde(flatten)]
    pub errors: AoErrors,
    /// Where objects cast and receive: the field lookups alone against each
    /// point's other instances (what a field represents).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fields_only: Option<AoErrors>,
}

struct ErrorInputs<'a> {
    combined: &'a VisibilityMasks,
    fields: &'a VisibilityMasks,
    classes: &'a RayClasses,
}

#[allow(clippy::too_many_arguments)]
fn compare_with_raycast(
    device: &Device,
    scene: &Scene,
    frame: u32,
    points: &[AoPoint],
    owners: &[u32],
    settings: &AoSettings,
    lookups: &ErrorInputs,
    bars: &Reporter,
) -> Result<FieldReference> {
    let cutouts = Cutouts::of_scene(scene, Role::casts, DEFAULT_TEXTURE_BYTES, &mut Vec::new());
    let mut tracer =
        Tracer::build_labelled(device, &casters(scene, frame)?, bars, "casters")?.with_cutouts(cutouts.map(Arc::new));
    let progress = bars.bar(points.len() as u64, "ray-cast reference");
    let truth = tracer.ao_visibility(points, settings, &progress)?;
    progress.finish();
    let both: Vec<u32> = scene
        .instances
        .iter()
        .enumerate()
        .filter(|(_, i)| i.role == Role::Both)
        .map(|(k, _)| k as u32)
        .collect();
    let fields_only = if both.is_empty() {
        None
    } else {
        let others = without_self(scene, frame, points, owners, settings, &both)?;
        Some(errors(lookups.fields, &others, lookups.classes))
    };
    Ok(FieldReference {
        raycast_ms: truth.ms,
        kdtree_ms: tracer.accel().kdtree().stats.build_ms,
        errors: errors(lookups.combined, &truth.value, lookups.classes),
        fields_only,
    })
}

fn errors(field: &VisibilityMasks, truth: &VisibilityMasks, classes: &RayClasses) -> AoErrors {
    let (a, b) = (field.accessibility(), truth.accessibility());
    AoErrors {
        rms_error: crate::geom::color::rms_difference(&a, &b, None),
        max_error: a.iter().zip(&b).map(|(x, y)| (x - y).abs() as f64).fold(0.0, f64::max),
        rays: ray_errors(field, truth, classes),
    }
}

/// Rays on which the field and the reference disagree, by class.
fn ray_errors(field: &VisibilityMasks, truth: &VisibilityMasks, classes: &RayClasses) -> RayErrors {
    let (mut inside, mut inside_wrong, mut outside_wrong) = (0u64, 0u64, 0u64);
    for (i, (a, b)) in field.bits.iter().zip(&truth.bits).enumerate() {
        let wrong = a ^ b;
        inside += classes.inside[i].count_ones() as u64;
        inside_wrong += (wrong & classes.inside[i]).count_ones() as u64;
        outside_wrong += (wrong & !classes.inside[i]).count_ones() as u64;
    }
    let total = field.points() as u64 * field.rays_per_point as u64;
    RayErrors {
        total,
        disagree: inside_wrong + outside_wrong,
        inside_sphere: inside,
        disagree_inside_sphere: inside_wrong,
        disagree_outside_sphere: outside_wrong,
        disagree_fraction_inside: inside_wrong as f64 / inside.max(1) as f64,
        disagree_fraction_outside: outside_wrong as f64 / (total - inside).max(1) as f64,
    }
}

fn count(words: &[u32]) -> u64 {
    words.iter().map(|w| w.count_ones() as u64).sum()
}

/// The instance each receiver vertex belongs to (in `Scene::receivers`'
/// order).
pub fn receiver_owners(scene: &Scene) -> Vec<u32> {
    scene
        .instances
        .iter()
        .enumerate()
        .filter(|(_, i)| i.role.receives())
        .flat_map(|(k, i)| std::iter::repeat_n(k as u32, scene.meshes[i.mesh].mesh.positions.len()))
        .collect()
}

/// Copies the masks of the moving instances that cast and receive from
/// `moved` into `all`.
fn replace_moving(scene: &Scene, all: &mut VisibilityMasks, moved: &VisibilityMasks, owners: &[u32]) {
    let words = all.words_per_point as usize;
    for (k, inst) in scene.instances.iter().enumerate() {
        if inst.role == Role::Both && inst.motion.is_some() {
            for i in (0..owners.len()).filter(|&i| owners[i] == k as u32) {
                all.bits[i * words..(i + 1) * words].copy_from_slice(moved.mask(i));
            }
        }
    }
}

/// Self-occlusion of the instances that cast and receive (those `which`
/// selects) at `frame`: each point's rays against its own instance (CPU).
/// Other points are open. None when no instance is both.
fn self_occlusion(
    scene: &Scene,
    frame: u32,
    points: &[AoPoint],
    owners: &[u32],
    settings: &AoSettings,
    which: impl Fn(&Instance) -> bool,
) -> Result<Option<VisibilityMasks>> {
    let selected: Vec<u32> = scene
        .instances
        .iter()
        .enumerate()
        .filter(|(_, i)| i.role == Role::Both && which(i))
        .map(|(k, _)| k as u32)
        .collect();
    if selected.is_empty() {
        return Ok(None);
    }
    let mut masks = open_masks(points.len(), settings);
    for &k in &selected {
        let inst = &scene.instances[k as usize];
        let t = inst.transform_at(frame);
        let own = scene.meshes[inst.mesh].mesh.map_positions(|p| t.apply_point(p));
        let cutouts = Cutouts::of_instances(scene, |j, _| j as u32 == k, DEFAULT_TEXTURE_BYTES, &mut Vec::new());
        cast_subset(
            &own,
            cutouts,
            &inst.name,
            points,
            |i| owners[i] == k,
            settings,
            &mut masks,
        )?;
    }
    Ok(Some(masks))
}

/// Ray casting where each point ignores its own instance (CPU).
fn without_self(
    scene: &Scene,
    frame: u32,
    points: &[AoPoint],
    owners: &[u32],
    settings: &AoSettings,
    both: &[u32],
) -> Result<VisibilityMasks> {
    let mut masks = open_masks(points.len(), settings);
    let groups: Vec<u32> = std::iter::once(NO_OWNER).chain(both.iter().copied()).collect();
    for &excluded in &groups {
        let selected = |i: usize| {
            if excluded == NO_OWNER {
                !both.contains(&owners[i])
            } else {
                owners[i] == excluded
            }
        };
        let mut casters = Mesh::default();
        for (k, inst) in scene.instances.iter().enumerate() {
            if inst.role.casts() && k as u32 != excluded {
                let t = inst.transform_at(frame);
                casters.append(&scene.meshes[inst.mesh].mesh.map_positions(|p| t.apply_point(p)));
            }
        }
        if !casters.triangles.is_empty() {
            let keep = |k: usize, i: &Instance| i.role.casts() && k as u32 != excluded;
            let cutouts = Cutouts::of_instances(scene, keep, DEFAULT_TEXTURE_BYTES, &mut Vec::new());
            cast_subset(&casters, cutouts, "casters", points, selected, settings, &mut masks)?;
        }
    }
    Ok(without_extra_bits(masks, settings))
}

/// Keeps only the valid ray bits (an all-open mask sets every bit).
fn without_extra_bits(mut masks: VisibilityMasks, settings: &AoSettings) -> VisibilityMasks {
    let words = masks.words_per_point as usize;
    for (i, w) in masks.bits.iter_mut().enumerate() {
        let rays = (settings.rays_per_point as usize)
            .saturating_sub(32 * (i % words))
            .min(32);
        if rays < 32 {
            *w &= (1u32 << rays) - 1;
        }
    }
    masks
}

/// Every ray of every point open (all bits set).
fn open_masks(points: usize, settings: &AoSettings) -> VisibilityMasks {
    let words = settings.words_per_point();
    VisibilityMasks {
        rays_per_point: settings.rays_per_point,
        words_per_point: words,
        bits: vec![u32::MAX; points * words as usize],
    }
}

/// Casts the rays of the points `selected` picks against `mesh` (CPU) and
/// writes their masks into `masks`.
fn cast_subset(
    mesh: &Mesh,
    cutouts: Option<Cutouts>,
    what: &str,
    points: &[AoPoint],
    selected: impl Fn(usize) -> bool,
    settings: &AoSettings,
    masks: &mut VisibilityMasks,
) -> Result<()> {
    let chosen: Vec<usize> = (0..points.len()).filter(|&i| selected(i)).collect();
    if chosen.is_empty() {
        return Ok(());
    }
    let mut tracer =
        Tracer::build_labelled(&Device::cpu(), mesh, &Reporter::silent(), what)?.with_cutouts(cutouts.map(Arc::new));
    let subset: Vec<AoPoint> = chosen.iter().map(|&i| points[i]).collect();
    let cast = tracer.ao_visibility(&subset, settings, &Bar::hidden())?.value;
    let words = masks.words_per_point as usize;
    for (j, &i) in chosen.iter().enumerate() {
        masks.bits[i * words..(i + 1) * words].copy_from_slice(cast.mask(j));
    }
    Ok(())
}
