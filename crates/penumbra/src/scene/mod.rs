//! Scenes: the one geometry model of every method. Meshes (from OBJ, PLY or
//! glTF files, `load_mesh`; or deforming: a closed-form animation),
//! instances of them with rigid transforms, motions and roles, a camera,
//! lights and an environment map.
//! Features ask a scene only for what its roles require: occluders are built
//! from casters, sample points are taken from receivers. Rigid motion moves
//! instances per animation frame (`world_mesh_at`); a deforming mesh moves
//! its vertices with time (`SceneMesh::positions_at`). Vertex normals and
//! the origin offset of per-vertex rays are the contract's, computed in
//! `mesh` for everyone.

pub mod animated;
mod camera;
mod camera_path;
pub mod cutouts;
pub(crate) mod deform;
pub mod environment;
pub mod frame;
#[cfg(feature = "gltf")]
mod gltf;
mod input;
mod mesh;
mod mesh_file;
pub(crate) mod mtl;
pub mod mtl_rules;
mod obj;
#[cfg(feature = "ply")]
mod ply;
pub mod procedural;
mod scene_file;
pub mod sequence;
mod shading;
pub mod texture;
pub mod texture_table;
mod transform;

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Deserialize;

pub use camera::{Camera, CameraRays, CameraSpec, MAX_PIXELS, PixelDirections, View, check_image_size, parse_vec3};
pub use camera_path::CameraPath;
pub use environment::EnvironmentMap;
#[cfg(feature = "gltf")]
pub use gltf::write::{BakedAo, GlbOut, glb_with_ao};
#[cfg(feature = "gltf")]
pub use gltf::{load_gltf, load_gltf_animation};
pub use input::{file_stem, load_input, load_input_in, load_shaded_input, load_shaded_input_in};
pub use mesh::{Mesh, MeshObject, ORIGIN_OFFSET, used_bounds, vertex_normals};
pub use mesh_file::{MeshFormat, companion_files, is_glb, is_gltf_json, is_ply, load_mesh, load_mesh_file};
pub use mtl::{Checker, Material, MtlWritten, load_mtl, parse_mtl, resolve_maps, write_mtl};
pub use mtl_rules::MtlRules;
pub use obj::{
    DEFAULT_CREASE_DEGREES, NO_NORMAL, ObjFile, PrimitiveSpan, SMOOTH_DEFAULT, load_obj, load_obj_file, parse_obj,
    parse_obj_file, write_obj,
};
#[cfg(feature = "ply")]
pub use ply::{load_ply, parse_ply};
pub use scene_file::{load_scene, load_scene_in, load_scene_shaded, load_scene_shaded_in, referenced_files};
pub use shading::{MeshShading, SceneSphere};
pub use texture::{AlphaMap, MaterialMaps, Texture, TextureMap, TextureSource};
pub use transform::{Motion, Transform};

/// What an instance takes part in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Occludes others (and itself) but gets no results.
    Caster,
    /// Gets results (AO at its vertices / pixels) but occludes nothing.
    Receiver,
    /// Both.
    #[default]
    Both,
}

impl Role {
    /// Whether instances of this role occlude (`Caster` or `Both`).
    pub fn casts(self) -> bool {
        matches!(self, Role::Caster | Role::Both)
    }
    /// Whether instances of this role get results (`Receiver` or `Both`).
    pub fn receives(self) -> bool {
        matches!(self, Role::Receiver | Role::Both)
    }
}

/// A mesh of a scene, which its instances place.
#[derive(Debug, Clone)]
pub struct SceneMesh {
    /// The scene file's name for it (a key of `"meshes"`), or a
    /// one-mesh scene's name.
    pub name: String,
    /// The file it was read from, resolved against the scene file's
    /// folder (`<NAME animation>` for a built-in animation).
    pub path: PathBuf,
    /// The mesh (a deforming one's rest pose).
    pub mesh: Mesh,
    /// How its vertices move with time, if they do (same topology).
    pub animation: Option<animated::Animation>,
    /// Materials and shading normals, where the mesh was read for rendering.
    pub shading: Option<MeshShading>,
}

impl SceneMesh {
    /// A static mesh read from `path`.
    pub fn new(name: &str, path: &Path, mesh: Mesh) -> SceneMesh {
        SceneMesh {
            name: name.into(),
            path: path.to_path_buf(),
            mesh,
            animation: None,
            shading: None,
        }
    }

    /// The length and frames of the mesh's animation, where it has one
    /// (a sequence, a glTF clip; the built-in animations are endless).
    pub fn clip(&self) -> Option<deform::Clip> {
        self.animation.as_ref().and_then(|a| a.clip())
    }

    /// The vertex positions at `seconds` of the mesh's animation (a static
    /// mesh's positions whatever the time), into `out`.
    pub fn positions_at(&self, seconds: f32, out: &mut Vec<Vec3>) {
        match &self.animation {
            Some(a) => a.positions_at(seconds, out),
            None => {
                out.clear();
                out.extend_from_slice(&self.mesh.positions);
            }
        }
    }
}

/// One placement of a mesh in a scene: which mesh, where, and what part
/// it takes.
#[derive(Debug, Clone)]
pub struct Instance {
    /// The scene file's `name`, else `MESH#i` for its `i`th instance; a
    /// one-mesh scene's is the mesh's name.
    pub name: String,
    /// Index into `Scene::meshes`.
    pub mesh: usize,
    /// Whether it occludes, receives or both.
    pub role: Role,
    /// Its placement in the scene's frame at animation frame 0: mesh
    /// coordinates (the mesh's own frame) to scene coordinates.
    pub transform: Transform,
    /// Rigid motion over animation frames, if any.
    pub motion: Option<Motion>,
    /// A scene material that replaces the mesh's own (rendering only).
    pub material: Option<String>,
}

impl Instance {
    /// The instance's transform at animation frame `frame`.
    pub fn transform_at(&self, frame: u32) -> Transform {
        self.motion.map_or(self.transform, |m| m.at(&self.transform, frame))
    }
}

/// A light of a scene file, for the methods that shade (`raytrace`, and
/// the first four for SSAO's G-buffer).
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// A point light, falling off as 1/d².
    Point {
        /// Where it is, in the scene's frame.
        position: Vec3,
        /// RGB intensity (W/sr per channel).
        intensity: Vec3,
    },
    /// A light from infinitely far; `direction` is the direction the light
    /// travels.
    Directional {
        /// Unit direction of travel (from the light towards the scene).
        direction: Vec3,
        /// RGB irradiance it gives a surface facing it (the scene file's
        /// `radiance`).
        radiance: Vec3,
    },
}

impl Light {
    /// The light of a scene that has none: a white directional light of
    /// radiance 1 from above, slightly off-axis (the direction of `trace
    /// --shadows`).
    pub fn default_light() -> Light {
        Light::Directional {
            direction: -Vec3::new(-0.4, 1.0, 0.3).normalize(),
            radiance: Vec3::ONE,
        }
    }
}

/// A scene file's `"environment"`: a light probe around the scene.
#[derive(Debug, Clone)]
pub struct Environment {
    /// The `.hdr` file it was read from.
    pub path: PathBuf,
    /// The probe's radiance.
    pub map: EnvironmentMap,
    /// The factor on the probe's radiance, >= 0 (default 1).
    pub intensity: f32,
    /// The probe's rotation about +y, in degrees (default 0).
    pub rotation_degrees: f32,
}

/// Everything a method is given to work on: meshes, their instances, a
/// camera, lights, an environment and, for rendering, materials and
/// spheres, with every point in the scene's frame (relative to `origin`).
#[derive(Debug, Clone)]
pub struct Scene {
    /// Where the scene's coordinate zero is in world coordinates: every
    /// point of the scene (instances' placements, camera, lights, spheres)
    /// is relative to it (`frame`; zero unless the scene is far off).
    pub origin: glam::DVec3,
    /// The meshes the instances place (a scene file's in the order of
    /// their names).
    pub meshes: Vec<SceneMesh>,
    /// The instances, in the scene file's order: a merged mesh
    /// (`world_mesh`) numbers its objects, triangles and vertices in it.
    pub instances: Vec<Instance>,
    /// The scene file's camera, if it has one, or a mesh file's first
    /// (the command line's `--eye/--target/--fov` override it;
    /// `camera_in`).
    pub camera: Option<Camera>,
    /// Every camera the input offers, in its order (a glTF file's, a scene
    /// file's one), for `choose_camera`.
    pub cameras: Vec<Camera>,
    /// Its lights, in file order; with none (and no emissive faces) the
    /// methods that shade use `Light::default_light`.
    pub lights: Vec<Light>,
    /// The light probe of the file, if it names one.
    pub environment: Option<Environment>,
    /// Precomputed displacement fields by mesh index (`.dfield` paths).
    pub fields: std::collections::BTreeMap<usize, PathBuf>,
    /// Analytic spheres (rendering only).
    pub spheres: Vec<SceneSphere>,
    /// Named materials of the scene file (instances and spheres use them).
    pub materials: Vec<Material>,
    /// Ambient light and the radiance of rays that leave the scene, where
    /// the scene file gives them (rendering only).
    pub ambient: Option<Vec3>,
    /// The RGB radiance of rays that leave the scene, where the scene
    /// file gives it (rendering only).
    pub background: Option<Vec3>,
    /// Problems met while loading that do not stop it (MTL files...).
    pub warnings: Vec<String>,
}

impl Scene {
    /// A scene of one mesh, one untransformed instance that is both caster
    /// and receiver: what `--mesh FILE` means.
    pub fn from_mesh(name: &str, path: &Path, mesh: Mesh) -> Scene {
        Self::of(SceneMesh::new(name, path, mesh))
    }

    /// This one-mesh scene made a caster onto `receiver`, which only
    /// receives (`ao --receiver`: the displacement-field paper's form).
    /// A receiver read in another frame than the caster's is placed by
    /// the difference of their origins (exact: both are on a grid).
    pub fn with_receiver(mut self, receiver: SceneMesh) -> Scene {
        self.instances[0].role = Role::Caster;
        let translation = (receiver.mesh.origin - self.origin).as_vec3();
        self.instances.push(Instance {
            name: receiver.name.clone(),
            mesh: self.meshes.len(),
            role: Role::Receiver,
            transform: Transform {
                translation,
                ..Transform::default()
            },
            motion: None,
            material: None,
        });
        self.meshes.push(receiver);
        self
    }

    /// A scene of one deforming mesh (its rest pose at time 0), framed by
    /// the animation's camera.
    pub fn from_animation(animation: animated::Animation) -> Scene {
        let name = animation.name.clone();
        let mut scene = Self::of(SceneMesh {
            name: name.clone(),
            path: PathBuf::from(format!("<{name} animation>")),
            mesh: animation.mesh_at(0.0),
            animation: None,
            shading: None,
        });
        scene.camera = animation.camera.map(|(eye, target, fov_degrees)| Camera {
            eye,
            target,
            fov_degrees,
        });
        scene.meshes[0].animation = Some(animation);
        scene
    }

    /// A scene of a user's animation read from `path` (a glTF file, a
    /// sequence's pattern): its rest pose the clip's first frame, framed
    /// like a mesh (no camera of its own).
    pub fn from_user_animation(path: &Path, animation: animated::Animation) -> crate::error::Result<Scene> {
        let mut rest = Vec::new();
        animation.positions_at(animation.clip().map_or(0.0, |c| c.start), &mut rest);
        let mut mesh = Mesh::new(rest, animation.triangles.clone()).map_err(|e| e.in_file(path))?;
        mesh.objects[0].name = animation.name.clone();
        let mut scene = Self::of(SceneMesh {
            name: animation.name.clone(),
            path: path.to_path_buf(),
            mesh,
            animation: None,
            shading: None,
        });
        scene.warnings = animation.warnings();
        scene.meshes[0].animation = Some(animation);
        Ok(scene)
    }

    fn of(mesh: SceneMesh) -> Scene {
        let name = mesh.name.clone();
        Scene {
            origin: mesh.mesh.origin,
            meshes: vec![mesh],
            instances: vec![Instance {
                name,
                mesh: 0,
                role: Role::Both,
                transform: Transform::default(),
                motion: None,
                material: None,
            }],
            camera: None,
            cameras: Vec::new(),
            lights: Vec::new(),
            environment: None,
            fields: Default::default(),
            spheres: Vec::new(),
            materials: Vec::new(),
            ambient: None,
            background: None,
            warnings: Vec::new(),
        }
    }

    /// A scene of one mesh file (OBJ, PLY, glTF) read for rendering: its
    /// materials and shading normals kept, its warnings the scene's.
    pub fn from_obj_file(name: &str, path: &Path, obj: ObjFile) -> Scene {
        let mut mesh = SceneMesh::new(name, path, obj.mesh.clone());
        mesh.shading = Some(MeshShading::from_obj(&obj));
        let mut scene = Self::of(mesh).with_cameras(obj.cameras);
        scene.warnings = obj.warnings;
        scene
    }

    /// This scene with `cameras` (in its frame), the first its camera.
    pub fn with_cameras(mut self, cameras: Vec<Camera>) -> Scene {
        self.camera = cameras.first().copied();
        self.cameras = cameras;
        self
    }

    /// Makes `cameras[index]` the scene's camera (the command line's
    /// `--camera`); an error names the parameter and how many cameras
    /// there are.
    pub fn choose_camera(&mut self, index: usize) -> crate::error::Result<()> {
        match self.cameras.get(index) {
            Some(&camera) => {
                self.camera = Some(camera);
                Ok(())
            }
            None => {
                let has = match self.cameras.len() {
                    0 => "the input has no cameras".to_string(),
                    1 => "the input has 1 camera (number 0)".to_string(),
                    n => format!("the input has {n} cameras (numbers 0 to {})", n - 1),
                };
                Err(crate::error::Error::param("camera", format!("is {index}, but {has}")))
            }
        }
    }

    /// All instances whose role passes `keep`, in world space, merged into one
    /// mesh with one object per instance (in instance order).
    pub fn world_mesh(&self, keep: impl Fn(Role) -> bool) -> Mesh {
        self.world_mesh_at(0, keep)
    }

    /// `world_mesh` with every instance where its motion puts it at
    /// animation frame `frame`.
    pub fn world_mesh_at(&self, frame: u32, keep: impl Fn(Role) -> bool) -> Mesh {
        let mut out = Mesh {
            origin: self.origin,
            ..Mesh::default()
        };
        for inst in self.instances.iter().filter(|i| keep(i.role)) {
            let transform = inst.transform_at(frame);
            let mut m = self.meshes[inst.mesh].mesh.map_positions(|p| transform.apply_point(p));
            // Placed: in the scene's frame now.
            m.origin = self.origin;
            let n = m.triangles.len() as u32;
            m.objects = vec![MeshObject {
                name: inst.name.clone(),
                triangles: 0..n,
            }];
            out.append(&m);
        }
        out
    }

    /// `spec` completed against this scene (its camera, else the default
    /// camera for `bounds`, which are in the scene's frame) and validated,
    /// as a camera in world coordinates (`CameraSpec::world`).
    pub fn complete_camera(
        &self,
        spec: &CameraSpec,
        bounds: &crate::geom::aabb::Aabb,
    ) -> crate::error::Result<CameraSpec> {
        let camera = spec.resolve(self.camera, bounds, self.origin)?;
        Ok(CameraSpec::world(camera, self.origin))
    }

    /// `spec` resolved in the scene's frame: its camera, else the default
    /// camera for `bounds` (in the scene's frame), with `spec`'s parts.
    pub fn camera_in(&self, spec: &CameraSpec, bounds: &crate::geom::aabb::Aabb) -> crate::error::Result<Camera> {
        spec.resolve(self.camera, bounds, self.origin)
    }

    /// The camera path in the file `path`, if one is given, in the scene's
    /// frame (its keyframes are world coordinates).
    pub fn camera_path(&self, path: Option<&Path>) -> crate::error::Result<Option<CameraPath>> {
        path.map(|p| CameraPath::load_in(p, self.origin)).transpose()
    }

    /// What occludes: casters and instances that are both.
    pub fn occluders(&self) -> Mesh {
        self.world_mesh(Role::casts)
    }

    /// Where results are wanted: receivers and instances that are both.
    pub fn receivers(&self) -> Mesh {
        self.world_mesh(Role::receives)
    }
}
