//! `penumbra ao --method field`: Algorithm 2 of the displacement-field paper
//! over a scene with roles. Receivers' vertices (and, with `--image`, the
//! pixels the camera sees) cast the same rays as `--method raycast`; only
//! the casters' fields are built (or loaded) and consulted, one field per
//! mesh whatever its instances' transforms and motions.

use std::collections::BTreeMap;
use std::time::Instant;

use serde_json::{Value, json};

use super::Device;
use super::ao::{AoArgs, mean, outputs, scene_of, visibility};
use super::args::build_tree;
use super::field::describe;
use super::io::{write_grey_png, write_vertex_csv};
use crate::ao::points::{ORIGIN_OFFSET, vertex_points};
use crate::ao::raycast::visibility_cpu;
use crate::ao::{AoPoint, AoSettings, VisibilityMasks};
use crate::error::{Error, Result};
use crate::field::gpu::{FieldGroup, GpuField, GpuInstance, visibility_field_gpu};
use crate::field::{DisplacementField, FieldCaster, NO_OWNER, Positional, RayClasses, file, visibility_field};
use crate::kdtree::KdTree;
use crate::progress::Progress;
use crate::ray::Hit;
use crate::scene::{Mesh, Role, Scene};

/// Most animation frames one run may ask for.
const MAX_FRAMES: i64 = 100_000;

pub fn run(args: &AoArgs, settings: &AoSettings, threads: usize) -> Result<Value> {
    if args.mesh.is_some() && args.receiver.is_none() {
        return Err(Error::param(
            "--method field",
            "needs --receiver (or --scene with receivers): a field answers for rays from outside its \
             object, so it cannot shade the object's own vertices",
        ));
    }
    if args.field.is_some() && args.scene.is_some() {
        return Err(Error::param(
            "--field",
            "goes with --mesh/--receiver; a scene file names its fields in \"fields\"",
        ));
    }
    if !(1..=MAX_FRAMES).contains(&args.frames) {
        return Err(Error::param(
            "--frames",
            format!("must be between 1 and {MAX_FRAMES}, got {}", args.frames),
        ));
    }
    let frames = args.frames as u32;
    let params = args.field_options.params()?;
    let (csv, png) = outputs(args)?;
    let scene = scene_of(args)?;
    if !scene.instances.iter().any(|i| i.role.casts()) {
        return Err(Error::param("--scene", "no instance is a caster: nothing occludes"));
    }
    if !scene.instances.iter().any(|i| i.role.receives()) {
        return Err(Error::param(
            "--scene",
            "no instance is a receiver: no vertices to shade",
        ));
    }

    // One field per caster mesh: loaded, or built once.
    let mut fields: BTreeMap<usize, DisplacementField> = BTreeMap::new();
    let mut field_reports = Vec::new();
    let mut build_ms = 0.0;
    for inst in scene.instances.iter().filter(|i| i.role.casts()) {
        if fields.contains_key(&inst.mesh) {
            continue;
        }
        let mesh = &scene.meshes[inst.mesh];
        let source = if args.field.is_some() {
            args.field.clone()
        } else {
            scene.fields.get(&inst.mesh).cloned()
        };
        let (field, mut report) = match source {
            Some(path) => {
                let field = file::read(&path)?;
                check_matches(&field, &mesh.mesh, &path, &mesh.path)?;
                let mut r = describe(&field);
                r["file"] = json!(path.display().to_string());
                (field, r)
            }
            None => {
                let progress = Progress::bar(params.maps() as u64, &format!("field of {}", mesh.name));
                let (field, stats) =
                    DisplacementField::build(&mesh.mesh, &params, &mesh.path.display().to_string(), &progress)?;
                progress.finish();
                build_ms += stats.build_ms;
                let mut r = describe(&field);
                r["build_ms"] = json!(stats.build_ms);
                (field, r)
            }
        };
        report["mesh"] = json!(mesh.name);
        field_reports.push(report);
        fields.insert(inst.mesh, field);
    }

    let device = Device::open(args.common.device)?;
    let mut gpu_fields = BTreeMap::new();
    if let Device::Gpu(ctx) = &device {
        for (&mesh, field) in &fields {
            gpu_fields.insert(mesh, GpuField::upload(&ctx.device, &ctx.queue, field, args.positional)?);
        }
    }
    let owners = receiver_owners(&scene);
    // Self-occlusion of objects that cast and receive: a field cannot see it
    // (see `field::ao`), so their rays are cast against their own geometry,
    // once for objects that do not move, every frame for those that do (the
    // AO rays follow the world's tangent frame, not the object's).
    let self_start = Instant::now();
    let mut self_masks = self_occlusion(
        &scene,
        0,
        &vertex_points(&scene.world_mesh(Role::receives)),
        &owners,
        settings,
        |_| true,
    )?;
    let mut self_ms = vec![self_start.elapsed().as_secs_f64() * 1e3];
    let mut frame_ms = Vec::new();
    let mut last = None;
    for frame in 0..frames {
        let points = vertex_points(&scene.world_mesh_at(frame, Role::receives));
        if frame > 0
            && scene
                .instances
                .iter()
                .any(|i| i.role == Role::Both && i.motion.is_some())
        {
            let start = Instant::now();
            let moved = self_occlusion(&scene, frame, &points, &owners, settings, |i| i.motion.is_some())?;
            if let (Some(all), Some(moved)) = (self_masks.as_mut(), moved) {
                for (k, inst) in scene.instances.iter().enumerate() {
                    if inst.role == Role::Both && inst.motion.is_some() {
                        let words = all.words_per_point as usize;
                        for i in (0..points.len()).filter(|&i| owners[i] == k as u32) {
                            all.bits[i * words..(i + 1) * words].copy_from_slice(moved.mask(i));
                        }
                    }
                }
            }
            self_ms.push(start.elapsed().as_secs_f64() * 1e3);
        }
        let (field_masks, classes, ms) = field_visibility(
            &device,
            &scene,
            &fields,
            &gpu_fields,
            frame,
            &points,
            &owners,
            settings,
            args.positional,
        )?;
        frame_ms.push(ms);
        last = Some((points, field_masks, classes));
    }
    let (points, field_masks, classes) = last.expect("at least one frame");
    let masks = match &self_masks {
        Some(own) => VisibilityMasks {
            bits: field_masks.bits.iter().zip(&own.bits).map(|(a, b)| a & b).collect(),
            ..field_masks.clone()
        },
        None => field_masks.clone(),
    };
    let ao = masks.accessibility();
    let mut report = json!({
        "method": "field",
        "rays_per_point": settings.rays_per_point,
        "radius": args.radius,
        "seed": settings.seed,
        "positional": args.positional,
        "build_ms": build_ms,
        "self_occlusion_ms": self_masks.as_ref().map(|_| self_ms),
        "device": device.kind(),
        "adapter": device.adapter(),
        "threads": threads,
        "fields": field_reports,
        "casters": {
            "instances": scene.instances.iter().filter(|i| i.role.casts()).count(),
            "triangles": scene.world_mesh(Role::casts).triangles.len(),
        },
        "frames": frame_ms.len(),
        "frame_ao_ms": frame_ms,
        "ao_ms": frame_ms.last(),
        "ao_ms_mean": frame_ms.iter().sum::<f64>() / frame_ms.len() as f64,
        "rays_inside_sphere": count(&classes.inside),
        "rays_hidden": count(&classes.hidden),
    });
    if let Some(csv) = &csv {
        write_vertex_csv(csv, &ao)?;
        report["per_vertex"] =
            json!({ "file": csv.display().to_string(), "vertices": points.len(), "mean_ao": mean(&ao) });
    }
    report["points"] = json!(points.len());
    let total_rays = points.len() as f64 * settings.rays_per_point as f64;
    report["mrays_per_s"] = json!(total_rays / (frame_ms.last().copied().unwrap_or(0.0).max(1e-9) * 1e3));
    if args.reference {
        report["reference"] = reference(
            &device,
            &scene,
            frames - 1,
            &points,
            &owners,
            &masks,
            &field_masks,
            &classes,
            settings,
        )?;
    }
    if let Some(png) = &png {
        report["image"] = image(args, &device, &scene, &fields, &gpu_fields, frames - 1, settings, png)?;
    }
    Ok(report)
}

/// A precomputed field must come from the caster's mesh.
fn check_matches(
    field: &DisplacementField,
    mesh: &Mesh,
    field_path: &std::path::Path,
    mesh_path: &std::path::Path,
) -> Result<()> {
    let bounds = mesh.bounds();
    let tol = 1e-4 * bounds.diagonal().max(f32::MIN_POSITIVE);
    let same_bounds = (field.bounds.min - bounds.min).abs().max_element() <= tol
        && (field.bounds.max - bounds.max).abs().max_element() <= tol;
    if field.triangles as usize != mesh.triangles.len() || !same_bounds {
        return Err(Error::file(
            field_path,
            "triangles/bounds",
            format!(
                "the field was built from a mesh of {} triangles in [{}, {}], but {} has {} triangles in [{}, {}]",
                field.triangles,
                field.bounds.min,
                field.bounds.max,
                mesh_path.display(),
                mesh.triangles.len(),
                bounds.min,
                bounds.max
            ),
        ));
    }
    Ok(())
}

/// The instance each receiver vertex belongs to (in `Scene::receivers`'
/// order).
fn receiver_owners(scene: &Scene) -> Vec<u32> {
    scene
        .instances
        .iter()
        .enumerate()
        .filter(|(_, i)| i.role.receives())
        .flat_map(|(k, i)| std::iter::repeat_n(k as u32, scene.meshes[i.mesh].mesh.positions.len()))
        .collect()
}

/// AO rays through the fields at `frame`, on the chosen device; the time is
/// the GPU kernels' (timestamps) or the CPU's wall time.
#[allow(clippy::too_many_arguments)]
fn field_visibility(
    device: &Device,
    scene: &Scene,
    fields: &BTreeMap<usize, DisplacementField>,
    gpu_fields: &BTreeMap<usize, GpuField>,
    frame: u32,
    points: &[AoPoint],
    owners: &[u32],
    settings: &AoSettings,
    positional: Positional,
) -> Result<(VisibilityMasks, RayClasses, f64)> {
    let casters = scene.instances.iter().enumerate().filter(|(_, i)| i.role.casts());
    let progress = Progress::bar(points.len() as u64, &format!("field AO, frame {frame}"));
    let result = match device {
        Device::Gpu(ctx) => {
            let mut groups: BTreeMap<usize, Vec<GpuInstance>> = BTreeMap::new();
            for (k, inst) in casters {
                groups
                    .entry(inst.mesh)
                    .or_default()
                    .push(GpuInstance::new(&inst.transform_at(frame), k as u32));
            }
            let groups: Vec<FieldGroup> = groups
                .into_iter()
                .map(|(mesh, instances)| FieldGroup {
                    field: &gpu_fields[&mesh],
                    instances,
                })
                .collect();
            let r = visibility_field_gpu(ctx, &groups, points, owners, settings, &progress)?;
            (r.masks, r.classes, r.gpu_ms.unwrap_or(r.wall_ms))
        }
        Device::Cpu => {
            let casters: Vec<FieldCaster> = casters
                .map(|(k, inst)| FieldCaster {
                    field: &fields[&inst.mesh],
                    transform: inst.transform_at(frame),
                    instance: k as u32,
                })
                .collect();
            let start = Instant::now();
            let (masks, classes) = visibility_field(&casters, points, owners, settings, positional, &progress);
            (masks, classes, start.elapsed().as_secs_f64() * 1e3)
        }
    };
    progress.finish();
    Ok(result)
}

fn count(words: &[u32]) -> u64 {
    words.iter().map(|w| w.count_ones() as u64).sum()
}

fn rms(a: &[f32], b: &[f32]) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum();
    (sum / a.len().max(1) as f64).sqrt()
}

/// The same rays cast against the casters' triangles at `frame`: the error
/// per vertex (RMS of accessibility) and per ray, split by whether the ray
/// started inside a caster's sphere. The result (fields and presampled
/// self-occlusion) against all casters; and, where objects cast and receive,
/// the field lookups alone against each point's other instances (what a
/// field represents).
#[allow(clippy::too_many_arguments)]
fn reference(
    device: &Device,
    scene: &Scene,
    frame: u32,
    points: &[AoPoint],
    owners: &[u32],
    masks: &VisibilityMasks,
    field_masks: &VisibilityMasks,
    classes: &RayClasses,
    settings: &AoSettings,
) -> Result<Value> {
    let casters = scene.world_mesh_at(frame, Role::casts);
    let tree = build_tree(&casters, "casters")?;
    let gpu_tree = match device {
        Device::Gpu(ctx) => Some(crate::kdtree::gpu::GpuKdTree::upload(&ctx.device, &tree)?),
        Device::Cpu => None,
    };
    let (truth, raycast_ms) = visibility(device, &tree, gpu_tree.as_ref(), points, settings, "ray-cast reference")?;
    let field_ao = masks.accessibility();
    let mut out = json!({
        "raycast_ms": raycast_ms,
        "kdtree_ms": tree.stats.build_ms,
        "rms_error": rms(&field_ao, &truth.accessibility()),
        "max_error": max_error(&field_ao, &truth.accessibility()),
        "rays": ray_errors(masks, &truth, classes),
    });
    // Without self-occlusion: differs only when an instance casts and receives.
    let both: Vec<u32> = scene
        .instances
        .iter()
        .enumerate()
        .filter(|(_, i)| i.role == Role::Both)
        .map(|(k, _)| k as u32)
        .collect();
    if !both.is_empty() {
        let others = without_self(scene, frame, points, owners, settings, &both)?;
        let lookups = field_masks.accessibility();
        out["fields_only"] = json!({
            "rms_error": rms(&lookups, &others.accessibility()),
            "max_error": max_error(&lookups, &others.accessibility()),
            "rays": ray_errors(field_masks, &others, classes),
        });
    }
    Ok(out)
}

fn max_error(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs() as f64).fold(0.0, f64::max)
}

/// Rays on which the field and the reference disagree, by class.
fn ray_errors(field: &VisibilityMasks, truth: &VisibilityMasks, classes: &RayClasses) -> Value {
    let (mut inside, mut inside_wrong, mut outside_wrong) = (0u64, 0u64, 0u64);
    for (i, (a, b)) in field.bits.iter().zip(&truth.bits).enumerate() {
        let wrong = a ^ b;
        inside += classes.inside[i].count_ones() as u64;
        inside_wrong += (wrong & classes.inside[i]).count_ones() as u64;
        outside_wrong += (wrong & !classes.inside[i]).count_ones() as u64;
    }
    let total = field.points() as u64 * field.rays_per_point as u64;
    json!({
        "total": total,
        "disagree": inside_wrong + outside_wrong,
        "inside_sphere": inside,
        "disagree_inside_sphere": inside_wrong,
        "disagree_outside_sphere": outside_wrong,
        "disagree_fraction_inside": inside_wrong as f64 / inside.max(1) as f64,
        "disagree_fraction_outside": outside_wrong as f64 / (total - inside).max(1) as f64,
    })
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
    which: impl Fn(&crate::scene::Instance) -> bool,
) -> Result<Option<VisibilityMasks>> {
    let words = settings.words_per_point() as usize;
    let mut bits = vec![u32::MAX; points.len() * words];
    let mut any = false;
    for (k, inst) in scene
        .instances
        .iter()
        .enumerate()
        .filter(|(_, i)| i.role == Role::Both && which(i))
    {
        let selected: Vec<usize> = (0..points.len()).filter(|&i| owners[i] == k as u32).collect();
        let t = inst.transform_at(frame);
        let own = scene.meshes[inst.mesh].mesh.map_positions(|p| t.apply_point(p));
        let tree = build_tree(&own, &inst.name)?;
        let subset: Vec<AoPoint> = selected.iter().map(|&i| points[i]).collect();
        let masks = visibility_cpu(&tree, &subset, settings, &Progress::hidden());
        for (j, &i) in selected.iter().enumerate() {
            bits[i * words..(i + 1) * words].copy_from_slice(masks.mask(j));
        }
        any = true;
    }
    Ok(any.then_some(VisibilityMasks {
        rays_per_point: settings.rays_per_point,
        words_per_point: words as u32,
        bits,
    }))
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
    let words = settings.words_per_point() as usize;
    let mut bits = vec![0u32; points.len() * words];
    let groups: Vec<u32> = std::iter::once(NO_OWNER).chain(both.iter().copied()).collect();
    for &excluded in &groups {
        let selected: Vec<usize> = (0..points.len())
            .filter(|&i| {
                if excluded == NO_OWNER {
                    !both.contains(&owners[i])
                } else {
                    owners[i] == excluded
                }
            })
            .collect();
        if selected.is_empty() {
            continue;
        }
        let mut casters = Mesh::default();
        for (k, inst) in scene.instances.iter().enumerate() {
            if inst.role.casts() && k as u32 != excluded {
                let t = inst.transform_at(frame);
                casters.append(&scene.meshes[inst.mesh].mesh.map_positions(|p| t.apply_point(p)));
            }
        }
        let subset: Vec<AoPoint> = selected.iter().map(|&i| points[i]).collect();
        let masks = if casters.triangles.is_empty() {
            VisibilityMasks {
                rays_per_point: settings.rays_per_point,
                words_per_point: words as u32,
                bits: vec![u32::MAX; subset.len() * words],
            }
        } else {
            let tree: KdTree = build_tree(&casters, "casters")?;
            visibility_cpu(&tree, &subset, settings, &Progress::hidden())
        };
        for (j, &i) in selected.iter().enumerate() {
            bits[i * words..(i + 1) * words].copy_from_slice(masks.mask(j));
        }
    }
    // Keep only the valid ray bits (an all-open mask sets every bit).
    for (i, w) in bits.iter_mut().enumerate() {
        let rays = (settings.rays_per_point as usize)
            .saturating_sub(32 * (i % words))
            .min(32);
        if rays < 32 {
            *w &= (1u32 << rays) - 1;
        }
    }
    Ok(VisibilityMasks {
        rays_per_point: settings.rays_per_point,
        words_per_point: words as u32,
        bits,
    })
}

/// Per-pixel AO through the fields at `frame`: the pixels the camera sees,
/// each owned by the instance it shows.
#[allow(clippy::too_many_arguments)]
fn image(
    args: &AoArgs,
    device: &Device,
    scene: &Scene,
    fields: &BTreeMap<usize, DisplacementField>,
    gpu_fields: &BTreeMap<usize, GpuField>,
    frame: u32,
    settings: &AoSettings,
    png: &std::path::Path,
) -> Result<Value> {
    let everything = scene.world_mesh_at(frame, |_| true);
    let camera = args.camera.camera(scene.camera, &everything.bounds())?;
    let rays = camera.primary_rays(args.width, args.height);
    let tree = build_tree(&everything, "all instances")?;
    let hits: Vec<Hit> = tree.trace_closest(&rays);
    let offset = ORIGIN_OFFSET * everything.bounds().diagonal();
    let points = crate::ao::points::hit_points(&everything, &rays, &hits, offset);
    // Objects of `everything` are the instances, in order.
    let owners: Vec<u32> = hits
        .iter()
        .filter(|h| h.is_hit())
        .map(|h| {
            everything
                .objects
                .iter()
                .position(|o| o.triangles.contains(&h.triangle))
                .map_or(NO_OWNER, |k| k as u32)
        })
        .collect();
    let (masks, _, ms) = field_visibility(
        device,
        scene,
        fields,
        gpu_fields,
        frame,
        &points,
        &owners,
        settings,
        args.positional,
    )?;
    let ao = masks.accessibility();
    let mut pixels = vec![None; rays.len()];
    for (p, a) in points.iter().zip(&ao) {
        pixels[p.stream as usize] = Some(*a);
    }
    write_grey_png(png, args.width, args.height, &pixels)?;
    Ok(json!({
        "file": png.display().to_string(),
        "width": args.width,
        "height": args.height,
        "pixels_hit": points.len(),
        "mean_ao": mean(&ao),
        "ao_ms": ms,
    }))
}
