//! The JSON scene file: meshes, instances with roles and rigid transforms,
//! camera, lights and an environment map.
//!
//! ```json
//! {
//!   "meshes": { "corner": "corner.obj", "bunny": "$PENUMBRA_DATA/models/stanford-bunny.obj" },
//!   "instances": [
//!     { "mesh": "corner", "role": "receiver" },
//!     { "mesh": "bunny", "role": "caster", "translate": [0.5, 0, 0.5],
//!       "rotate": { "axis": [0, 1, 0], "degrees": 30 }, "scale": 4 }
//!   ],
//!   "camera": { "eye": [3, 2, 3], "target": [0, 0, 0], "fov": 45 },
//!   "lights": [ { "point": { "position": [2, 3, 2], "intensity": [10, 10, 10] } } ],
//!   "environment": { "map": "$PENUMBRA_DATA/probes/grace.hdr", "intensity": 1 },
//!   "fields": { "bunny": "bunny.dfield" }
//! }
//! ```
//!
//! An instance may move over animation frames (`penumbra ao --frames N`):
//! `"motion": { "axis": [0, 1, 0], "degrees_per_frame": 5, "pivot": [0.5, 0, 0.5],
//! "translate_per_frame": [0, 0, 0.01] }` rotates it about the pivot (default:
//! its translation) and moves it, frame after frame. `"fields"` names
//! precomputed displacement fields (`penumbra field build`) of meshes.
//!
//! For rendering (`penumbra raytrace`), a scene file may also hold named
//! materials (MTL's fields in lower case, as numbers or RGB triples),
//! analytic spheres, an ambient light and a background radiance; an
//! instance may replace its mesh's MTL materials with one of them:
//!
//! ```json
//! "materials": { "glass": { "ks": [0.1, 0.1, 0.1], "tf": [1, 1, 1], "ni": 1.5, "illum": 7 },
//!                "mirror": { "kd": [0, 0, 0], "ks": [0.9, 0.9, 0.9], "illum": 3 },
//!                "floor": { "kd": [0.8, 0.8, 0.8], "ka": [0.8, 0.8, 0.8], "illum": 1,
//!                           "checker": { "size": 1, "origin": [0, -0.5, 0], "odd": [0.125, 0.125, 0.125] } } },
//! "spheres": [ { "name": "ball", "center": [0, 1, 0], "radius": 1, "material": "glass" } ],
//! "ambient": [0.05, 0.05, 0.05], "background": [0.2, 0.3, 0.5],
//! "instances": [ { "mesh": "box", "material": "mirror" } ]
//! ```
//!
//! Meshes may be OBJ, PLY or glTF files (`load_mesh`, which tells them
//! apart). Methods that only cast rays ignore materials and spheres. Meshes
//! are read with their materials (an OBJ's MTL files, a glTF's) only for
//! rendering (`load_scene_shaded`).
//!
//! Paths are relative to the scene file; a leading `$PENUMBRA_DATA` is the
//! shared data folder named by that environment variable. Unknown fields are
//! errors, so a typo does not silently fall back to a default.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{DVec3, Quat, Vec3};
use serde::Deserialize;

use super::mesh::MAX_EXTENT;
use super::{
    Camera, Instance, Light, Material, MeshShading, Motion, Role, Scene, SceneMesh, SceneSphere, Transform, load_mesh,
    load_mesh_file,
};
use crate::error::{Error, Result};
use crate::geom::aabb::Aabb;
use crate::scene::environment::EnvironmentMap;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    meshes: BTreeMap<String, String>,
    instances: Vec<InstanceFile>,
    #[serde(default)]
    camera: Option<CameraFile>,
    #[serde(default)]
    lights: Vec<LightFile>,
    #[serde(default)]
    environment: Option<EnvironmentFile>,
    #[serde(default)]
    fields: BTreeMap<String, String>,
    #[serde(default)]
    materials: BTreeMap<String, MaterialFile>,
    #[serde(default)]
    spheres: Vec<SphereFile>,
    #[serde(default)]
    ambient: Option<[f32; 3]>,
    #[serde(default)]
    background: Option<[f32; 3]>,
}

/// A material in MTL's terms (lower-case field names); what is left out
/// takes `Material::named`'s values.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    ka: Option<[f32; 3]>,
    kd: Option<[f32; 3]>,
    ks: Option<[f32; 3]>,
    ke: Option<[f32; 3]>,
    tf: Option<[f32; 3]>,
    ns: Option<f32>,
    ni: Option<f32>,
    d: Option<f32>,
    illum: Option<u32>,
    checker: Option<CheckerFile>,
}

/// `"checker": { "size": 1, "origin": [0, -0.5, 0], "odd": [0.1, 0.1, 0.1] }`:
/// a solid checker texture multiplying `ka` and `kd` (`Checker`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CheckerFile {
    size: f32,
    #[serde(default)]
    origin: [f32; 3],
    odd: [f32; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereFile {
    #[serde(default)]
    name: Option<String>,
    center: [f64; 3],
    radius: f32,
    #[serde(default)]
    material: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct InstanceFile {
    mesh: String,
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    role: Role,
    /// World-space points are read in f64 (`scene::frame`).
    #[serde(default)]
    translate: [f64; 3],
    #[serde(default)]
    rotate: Option<RotationFile>,
    #[serde(default = "one")]
    scale: f32,
    #[serde(default)]
    motion: Option<MotionFile>,
    #[serde(default)]
    material: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MotionFile {
    #[serde(default = "up")]
    axis: [f32; 3],
    #[serde(default)]
    degrees_per_frame: f32,
    #[serde(default)]
    pivot: Option<[f64; 3]>,
    #[serde(default)]
    translate_per_frame: [f32; 3],
}

fn up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

fn one() -> f32 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RotationFile {
    axis: [f32; 3],
    degrees: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFile {
    eye: [f64; 3],
    target: [f64; 3],
    #[serde(default = "default_fov")]
    fov: f32,
}

fn default_fov() -> f32 {
    45.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
enum LightFile {
    Point { position: [f64; 3], intensity: [f32; 3] },
    Directional { direction: [f32; 3], radiance: [f32; 3] },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EnvironmentFile {
    map: String,
    #[serde(default = "one")]
    intensity: f32,
    #[serde(default)]
    rotation_degrees: f32,
}

/// Expands `$PENUMBRA_DATA` to `data` (the shared data folder, which the
/// command line takes from the environment variable of that name) and
/// makes the path relative to the scene's folder.
fn resolve(scene: &Path, field: &str, text: &str, data: Option<&Path>) -> Result<PathBuf> {
    if let Some(rest) = text.strip_prefix("$PENUMBRA_DATA") {
        let data = data.ok_or_else(|| {
            Error::file(
                scene,
                field,
                "uses $PENUMBRA_DATA but that environment variable is not set",
            )
        })?;
        return Ok(PathBuf::from(data).join(rest.trim_start_matches(['/', '\\'])));
    }
    let base = scene.parent().unwrap_or(Path::new("."));
    Ok(base.join(text))
}

/// An error in a file the scene names, said as the scene's: "scene.json:
/// meshes.a: x.obj: line 3: ..." (exit code kept).
fn named_by(scene: &Path, field: &str, e: Error) -> Error {
    match e {
        Error::BadInput { .. } => Error::file(scene, field, e.to_string()),
        other => other,
    }
}

fn finite(scene: &Path, field: &str, v: &[f32]) -> Result<()> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(Error::file(scene, field, "must be finite"))
    }
}

/// `finite` for a point read in f64: finite in f32 too (what was read as
/// infinity before points were read in f64 still is refused).
fn finite64(scene: &Path, field: &str, v: &[f64]) -> Result<()> {
    finite(scene, field, &v.iter().map(|&c| c as f32).collect::<Vec<_>>())
}

/// An instance's transform in the scene's frame (whose origin is `origin`)
/// for its mesh (in its own frame) placed by `rotation`, `scale` and
/// `translate` (world units): the mesh's origin is placed too, then the
/// scene's taken off, in f64, so a far-off scene keeps its detail.
fn placed(mesh: &super::Mesh, (rotation, scale, translate): (Quat, f32, [f64; 3]), origin: DVec3) -> Transform {
    let world = rotation.as_dquat() * (mesh.origin * scale as f64) + DVec3::from_array(translate);
    Transform {
        translation: (world - origin).as_vec3(),
        rotation,
        scale,
    }
}

/// The scene's frame (`scene::frame`): the origin for the world box of
/// every instance (its mesh's box, placed by its translation, rotation and
/// scale in f64). Instances whose placement is not valid are left out
/// (the loader refuses them).
fn scene_origin(file: &SceneFile, meshes: &[SceneMesh], index_of: &BTreeMap<String, usize>) -> DVec3 {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for inst in &file.instances {
        let Some(&m) = index_of.get(&inst.mesh) else { continue };
        let mesh = &meshes[m].mesh;
        let rotation = inst.rotate.as_ref().map_or(glam::DQuat::IDENTITY, |r| {
            let axis = Vec3::from_array(r.axis).try_normalize().unwrap_or(Vec3::Y);
            Quat::from_axis_angle(axis, r.degrees.to_radians()).as_dquat()
        });
        let b = mesh.bounds();
        let scale = inst.scale as f64;
        let centre = rotation * ((mesh.origin + b.center().as_dvec3()) * scale) + DVec3::from_array(inst.translate);
        let half = DVec3::splat(0.5 * b.diagonal() as f64 * scale);
        if centre.is_finite() && half.is_finite() {
            (lo, hi) = (lo.min(centre - half), hi.max(centre + half));
        }
    }
    super::frame::origin_for(lo, hi)
}

/// The files a scene file names (meshes, fields, the environment), resolved
/// as the loader resolves them; empty where the file does not parse (the
/// loader reports that). Outputs must never overwrite these.
pub fn referenced_files(path: &Path, data: Option<&Path>) -> Vec<PathBuf> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Vec::new();
    };
    let Ok(file) = serde_json::from_str::<SceneFile>(&text) else {
        return Vec::new();
    };
    let named = file.meshes.values().chain(file.fields.values());
    let environment = file.environment.iter().map(|e| &e.map);
    let files: Vec<PathBuf> = named
        .chain(environment)
        .filter_map(|text| resolve(path, "", text, data).ok())
        .collect();
    let companions = files.iter().flat_map(|f| super::companion_files(f));
    companions.chain(files.iter().cloned()).collect()
}

/// Reads a scene file for methods that cast rays: geometry only. Paths
/// that start with `$PENUMBRA_DATA` are refused (see `load_scene_in`).
pub fn load_scene(path: &Path) -> Result<Scene> {
    load(path, false, None)
}

/// `load_scene` with `$PENUMBRA_DATA` in the file's paths standing for
/// `data` (the shared data folder).
pub fn load_scene_in(path: &Path, data: Option<&Path>) -> Result<Scene> {
    load(path, false, data)
}

/// Reads a scene file for rendering: meshes with their MTL materials and
/// shading normals (warnings about them in `Scene::warnings`).
pub fn load_scene_shaded(path: &Path) -> Result<Scene> {
    load(path, true, None)
}

/// `load_scene_shaded` with `$PENUMBRA_DATA` standing for `data`.
pub fn load_scene_shaded_in(path: &Path, data: Option<&Path>) -> Result<Scene> {
    load(path, true, data)
}

/// Refuses instances whose placement takes the scene past the extent f32
/// arithmetic handles (`mesh::MAX_EXTENT`), naming the first instance that
/// does (its mesh alone may be small: the placement is the scene file's),
/// before anything is built from the scene.
fn check_placed_extent(path: &Path, meshes: &[SceneMesh], instances: &[Instance]) -> Result<()> {
    let mut bounds = Aabb::EMPTY;
    for (i, inst) in instances.iter().enumerate() {
        let b = meshes[inst.mesh].mesh.bounds();
        for k in 0..8 {
            let pick = |bit: usize, lo: f32, hi: f32| if k & bit == 0 { lo } else { hi };
            let corner = Vec3::new(
                pick(1, b.min.x, b.max.x),
                pick(2, b.min.y, b.max.y),
                pick(4, b.min.z, b.max.z),
            );
            bounds = bounds.grow(inst.transform.apply_point(corner));
        }
        let extent = (bounds.max.as_dvec3() - bounds.min.as_dvec3()).max_element();
        if extent.is_nan() || extent > MAX_EXTENT as f64 {
            return Err(Error::file(
                path,
                format!("instances[{i}]"),
                format!(
                    "its translate, scale and rotate take the scene's extent to {extent:.3e}, beyond \
                     {MAX_EXTENT:.1e}, the largest f32 arithmetic handles; place the instances closer \
                     together or scale them down"
                ),
            ));
        }
    }
    Ok(())
}

fn load(path: &Path, shaded: bool, data: Option<&Path>) -> Result<Scene> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::read(path, e))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let file: SceneFile = serde_json::from_str(text)
        .map_err(|e| Error::file(path, format!("line {} column {}", e.line(), e.column()), e.to_string()))?;

    let mut meshes = Vec::new();
    let mut warnings = Vec::new();
    let mut index_of = BTreeMap::new();
    for (name, mesh_path) in &file.meshes {
        let field = format!("meshes.{name}");
        let resolved = resolve(path, &field, mesh_path, data)?;
        index_of.insert(name.clone(), meshes.len());
        if shaded {
            let obj = load_mesh_file(&resolved).map_err(|e| named_by(path, &field, e))?;
            warnings.extend(obj.warnings.iter().map(|w| format!("{}: {w}", resolved.display())));
            let mut mesh = SceneMesh::new(name, &resolved, obj.mesh.clone());
            mesh.shading = Some(MeshShading::from_obj(&obj));
            meshes.push(mesh);
        } else {
            let mesh = load_mesh(&resolved).map_err(|e| named_by(path, &field, e))?;
            meshes.push(SceneMesh::new(name, &resolved, mesh));
        }
    }
    let origin = scene_origin(&file, &meshes, &index_of);
    let local = |p: &[f64; 3]| super::frame::to_local(origin, DVec3::from_array(*p));
    let materials = file
        .materials
        .iter()
        .map(|(name, m)| material(path, name, m))
        .collect::<Result<Vec<_>>>()?;
    let known = |field: String, name: &Option<String>| match name {
        Some(n) if !file.materials.contains_key(n) => Err(Error::file(
            path,
            field,
            format!("no material named '{n}' in \"materials\""),
        )),
        _ => Ok(()),
    };
    if file.instances.is_empty() {
        return Err(Error::file(
            path,
            "instances",
            "is empty; a scene needs at least one instance",
        ));
    }
    let mut instances = Vec::new();
    for (i, inst) in file.instances.iter().enumerate() {
        let field = format!("instances[{i}]");
        let &mesh = index_of.get(&inst.mesh).ok_or_else(|| {
            Error::file(
                path,
                format!("{field}.mesh"),
                format!("no mesh named '{}' in \"meshes\"", inst.mesh),
            )
        })?;
        finite64(path, &format!("{field}.translate"), &inst.translate)?;
        known(format!("{field}.material"), &inst.material)?;
        if !(inst.scale > 0.0 && inst.scale.is_finite()) {
            return Err(Error::file(
                path,
                format!("{field}.scale"),
                format!("must be positive, got {}", inst.scale),
            ));
        }
        let rotation = match &inst.rotate {
            None => Quat::IDENTITY,
            Some(r) => {
                finite(
                    path,
                    &format!("{field}.rotate"),
                    &[r.axis[0], r.axis[1], r.axis[2], r.degrees],
                )?;
                let axis = Vec3::from_array(r.axis)
                    .try_normalize()
                    .ok_or_else(|| Error::file(path, format!("{field}.rotate.axis"), "must not be the zero vector"))?;
                Quat::from_axis_angle(axis, r.degrees.to_radians())
            }
        };
        let motion = match &inst.motion {
            None => None,
            Some(m) => {
                let f = format!("{field}.motion");
                let pivot = m.pivot.unwrap_or(inst.translate);
                finite(
                    path,
                    &f,
                    &[&m.axis[..], &[m.degrees_per_frame], &m.translate_per_frame].concat(),
                )?;
                finite64(path, &f, &pivot)?;
                let axis = Vec3::from_array(m.axis)
                    .try_normalize()
                    .ok_or_else(|| Error::file(path, format!("{f}.axis"), "must not be the zero vector"))?;
                Some(Motion {
                    axis,
                    degrees_per_frame: m.degrees_per_frame,
                    pivot: local(&pivot),
                    velocity: Vec3::from_array(m.translate_per_frame),
                })
            }
        };
        instances.push(Instance {
            name: inst.name.clone().unwrap_or_else(|| format!("{}#{i}", inst.mesh)),
            mesh,
            role: inst.role,
            transform: placed(&meshes[mesh].mesh, (rotation, inst.scale, inst.translate), origin),
            motion,
            material: inst.material.clone(),
        });
    }
    check_placed_extent(path, &meshes, &instances)?;
    let mut spheres = Vec::new();
    for (i, sphere) in file.spheres.iter().enumerate() {
        let field = format!("spheres[{i}]");
        finite64(path, &format!("{field}.center"), &sphere.center)?;
        if !(sphere.radius > 0.0 && sphere.radius.is_finite()) {
            return Err(Error::file(
                path,
                format!("{field}.radius"),
                format!("must be positive and finite, got {}", sphere.radius),
            ));
        }
        known(format!("{field}.material"), &sphere.material)?;
        spheres.push(SceneSphere {
            name: sphere.name.clone().unwrap_or_else(|| format!("sphere#{i}")),
            center: local(&sphere.center),
            radius: sphere.radius,
            material: sphere.material.clone(),
        });
    }
    let radiance = |field: &str, v: &Option<[f32; 3]>| -> Result<Option<Vec3>> {
        match v {
            None => Ok(None),
            Some(c) if c.iter().all(|x| x.is_finite() && *x >= 0.0) => Ok(Some(Vec3::from_array(*c))),
            Some(_) => Err(Error::file(path, field, "must be three finite numbers >= 0")),
        }
    };
    let ambient = radiance("ambient", &file.ambient)?;
    let background = radiance("background", &file.background)?;
    let camera = match &file.camera {
        None => None,
        Some(c) => {
            finite64(path, "camera", &[c.eye, c.target].concat())?;
            let camera = Camera {
                eye: local(&c.eye),
                target: local(&c.target),
                fov_degrees: c.fov,
            };
            camera
                .validate()
                .map_err(|e| Error::file(path, "camera", e.to_string()))?;
            Some(camera)
        }
    };
    let mut lights = Vec::new();
    for (i, l) in file.lights.iter().enumerate() {
        let field = format!("lights[{i}]");
        lights.push(match l {
            LightFile::Point { position, intensity } => {
                finite64(path, &field, position)?;
                finite(path, &field, intensity)?;
                Light::Point {
                    position: local(position),
                    intensity: Vec3::from_array(*intensity),
                }
            }
            LightFile::Directional { direction, radiance } => {
                finite(path, &field, &[direction.as_slice(), radiance.as_slice()].concat())?;
                let direction = Vec3::from_array(*direction)
                    .try_normalize()
                    .ok_or_else(|| Error::file(path, format!("{field}.direction"), "must not be zero"))?;
                Light::Directional {
                    direction,
                    radiance: Vec3::from_array(*radiance),
                }
            }
        });
    }
    let environment = match &file.environment {
        None => None,
        Some(env) => {
            let map_path = resolve(path, "environment.map", &env.map, data)?;
            if !(env.intensity >= 0.0 && env.intensity.is_finite()) {
                return Err(Error::file(path, "environment.intensity", "must be finite and >= 0"));
            }
            finite(path, "environment.rotation_degrees", &[env.rotation_degrees])?;
            Some(super::Environment {
                map: EnvironmentMap::load(&map_path)?,
                path: map_path,
                intensity: env.intensity,
                rotation_degrees: env.rotation_degrees,
            })
        }
    };
    let mut fields = BTreeMap::new();
    for (name, field_path) in &file.fields {
        let f = format!("fields.{name}");
        let &mesh = index_of
            .get(name)
            .ok_or_else(|| Error::file(path, &f, format!("no mesh named '{name}' in \"meshes\"")))?;
        fields.insert(mesh, resolve(path, &f, field_path, data)?);
    }
    Ok(Scene {
        origin,
        meshes,
        instances,
        cameras: camera.into_iter().collect(),
        camera,
        lights,
        environment,
        fields,
        spheres,
        materials,
        ambient,
        background,
        warnings,
    })
}

/// A scene file's material, checked as the MTL reader checks its fields.
fn material(path: &Path, name: &str, m: &MaterialFile) -> Result<Material> {
    let field = |f: &str| format!("materials.{name}.{f}");
    let colour = |f: &str, v: Option<[f32; 3]>, default: Vec3| -> Result<Vec3> {
        match v {
            None => Ok(default),
            Some(c) if c.iter().all(|x| x.is_finite() && *x >= 0.0) => Ok(Vec3::from_array(c)),
            Some(_) => Err(Error::file(path, field(f), "must be three finite numbers >= 0")),
        }
    };
    let base = Material::named(name);
    let check = |f: &str, v: Option<f32>, default: f32, ok: &dyn Fn(f32) -> bool, rule: &str| -> Result<f32> {
        match v {
            None => Ok(default),
            Some(x) if x.is_finite() && ok(x) => Ok(x),
            Some(x) => Err(Error::file(path, field(f), format!("{rule}, got {x}"))),
        }
    };
    let illum = m.illum.unwrap_or(base.illum);
    if illum > 10 {
        return Err(Error::file(
            path,
            field("illum"),
            format!("must be 0 to 10, got {illum}"),
        ));
    }
    Ok(Material {
        ka: colour("ka", m.ka, base.ka)?,
        kd: colour("kd", m.kd, base.kd)?,
        ks: colour("ks", m.ks, base.ks)?,
        ke: colour("ke", m.ke, base.ke)?,
        tf: colour("tf", m.tf, base.tf)?,
        has_tf: m.tf.is_some(),
        ns: check("ns", m.ns, base.ns, &|x| x >= 0.0, "must be >= 0")?,
        ni: check("ni", m.ni, base.ni, &|x| x > 0.0, "must be > 0")?,
        dissolve: check(
            "d",
            m.d,
            base.dissolve,
            &|x| (0.0..=1.0).contains(&x),
            "must be in [0, 1]",
        )?,
        illum,
        checker: m.checker.as_ref().map(|c| checker(path, name, c)).transpose()?,
        ..base
    })
}

fn checker(path: &Path, name: &str, c: &CheckerFile) -> Result<super::Checker> {
    let field = |f: &str| format!("materials.{name}.checker.{f}");
    if !(c.size.is_finite() && c.size > 0.0) {
        return Err(Error::file(
            path,
            field("size"),
            format!("must be a finite number > 0, got {}", c.size),
        ));
    }
    if !c.origin.iter().all(|x| x.is_finite()) {
        return Err(Error::file(path, field("origin"), "must be three finite numbers"));
    }
    if !c.odd.iter().all(|x| x.is_finite() && *x >= 0.0) {
        return Err(Error::file(path, field("odd"), "must be three finite numbers >= 0"));
    }
    Ok(super::Checker {
        size: c.size,
        origin: Vec3::from_array(c.origin),
        odd: Vec3::from_array(c.odd),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn checker_textures_are_read_and_bad_ones_name_their_field() {
        let path = Path::new("scene.json");
        let read = |text: &str| {
            let m: MaterialFile = serde_json::from_str(text).unwrap();
            material(path, "floor", &m)
        };
        let m = read(r#"{ "kd": [0.8, 0.8, 0.8], "checker": { "size": 2, "odd": [0.1, 0.2, 0.3] } }"#).unwrap();
        let c = m.checker.unwrap();
        assert_eq!((c.size, c.origin, c.odd), (2.0, Vec3::ZERO, Vec3::new(0.1, 0.2, 0.3)));
        for (text, field) in [
            (
                r#"{ "checker": { "size": 0, "odd": [1, 1, 1] } }"#,
                "materials.floor.checker.size",
            ),
            (
                r#"{ "checker": { "size": -1, "odd": [1, 1, 1] } }"#,
                "materials.floor.checker.size",
            ),
            (
                r#"{ "checker": { "size": 1, "odd": [1, -1, 1] } }"#,
                "materials.floor.checker.odd",
            ),
        ] {
            let e = read(text).unwrap_err().to_string();
            assert!(e.contains(field) && e.contains("scene.json"), "{text}: {e}");
        }
    }

    #[test]
    fn instances_are_placed_and_roles_select_geometry() {
        let dir = std::env::temp_dir().join(format!("penumbra-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        write(&dir, "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        let scene = write(
            &dir,
            "scene.json",
            r#"{
              "meshes": { "tri": "tri.obj" },
              "instances": [
                { "mesh": "tri", "role": "receiver" },
                { "mesh": "tri", "role": "caster", "name": "moved",
                  "translate": [10, 0, 0], "rotate": { "axis": [0, 0, 1], "degrees": 90 }, "scale": 2 },
                { "mesh": "tri" }
              ],
              "camera": { "eye": [0, 0, 5], "target": [0, 0, 0] },
              "lights": [ { "point": { "position": [1, 2, 3], "intensity": [4, 4, 4] } },
                          { "directional": { "direction": [0, -2, 0], "radiance": [1, 1, 1] } } ]
            }"#,
        );
        let s = load_scene(&scene).unwrap();
        assert_eq!(s.meshes.len(), 1, "one mesh shared by three instances");
        assert_eq!(s.instances[2].role, Role::Both, "role defaults to both");
        assert_eq!(s.camera.unwrap().fov_degrees, 45.0);
        assert_eq!(
            s.lights[1],
            Light::Directional {
                direction: -Vec3::Y,
                radiance: Vec3::ONE
            }
        );

        let casters = s.occluders();
        assert_eq!(casters.objects.len(), 2);
        assert_eq!(casters.objects[0].name, "moved");
        // (1,0,0) scaled by 2, rotated 90 degrees about z, moved by (10,0,0).
        let moved = casters.positions[1];
        assert!((moved - Vec3::new(10.0, 2.0, 0.0)).length() < 1e-5, "{moved}");
        let receivers = s.receivers();
        assert_eq!(receivers.objects.len(), 2);
        assert_eq!(receivers.positions[1], Vec3::X);
        let _ = std::fs::remove_dir_all(dir);
    }
}
