//! Scenes: meshes from OBJ files, instances of them with rigid transforms and
//! roles, a camera, lights and an environment map. Features ask a scene only
//! for what its roles require: occluders are built from casters, sample
//! points are taken from receivers.

pub mod animated;
mod camera;
pub mod environment;
mod mesh;
mod obj;
pub mod procedural;
mod scene_file;
mod transform;

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Deserialize;

pub use camera::Camera;
pub use environment::EnvironmentMap;
pub use mesh::{Mesh, MeshObject};
pub use obj::{load_obj, parse_obj, write_obj};
pub use scene_file::load_scene;
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
    pub fn casts(self) -> bool {
        matches!(self, Role::Caster | Role::Both)
    }
    pub fn receives(self) -> bool {
        matches!(self, Role::Receiver | Role::Both)
    }
}

#[derive(Debug, Clone)]
pub struct SceneMesh {
    pub name: String,
    pub path: PathBuf,
    pub mesh: Mesh,
}

#[derive(Debug, Clone)]
pub struct Instance {
    pub name: String,
    /// Index into `Scene::meshes`.
    pub mesh: usize,
    pub role: Role,
    pub transform: Transform,
    /// Rigid motion over animation frames, if any.
    pub motion: Option<Motion>,
}

impl Instance {
    /// The instance's transform at animation frame `frame`.
    pub fn transform_at(&self, frame: u32) -> Transform {
        self.motion.map_or(self.transform, |m| m.at(&self.transform, frame))
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    Point { position: Vec3, intensity: Vec3 },
    Directional { direction: Vec3, radiance: Vec3 },
}

#[derive(Debug, Clone)]
pub struct Environment {
    pub path: PathBuf,
    pub map: EnvironmentMap,
    pub intensity: f32,
    pub rotation_degrees: f32,
}

#[derive(Debug, Clone)]
pub struct Scene {
    pub meshes: Vec<SceneMesh>,
    pub instances: Vec<Instance>,
    pub camera: Option<Camera>,
    pub lights: Vec<Light>,
    pub environment: Option<Environment>,
    /// Precomputed displacement fields by mesh index (`.dfield` paths).
    pub fields: std::collections::BTreeMap<usize, PathBuf>,
}

impl Scene {
    /// A scene of one mesh, one untransformed instance that is both caster
    /// and receiver: what `--mesh FILE` means.
    pub fn from_mesh(name: &str, path: &Path, mesh: Mesh) -> Scene {
        Scene {
            meshes: vec![SceneMesh {
                name: name.into(),
                path: path.to_path_buf(),
                mesh,
            }],
            instances: vec![Instance {
                name: name.into(),
                mesh: 0,
                role: Role::Both,
                transform: Transform::default(),
                motion: None,
            }],
            camera: None,
            lights: Vec::new(),
            environment: None,
            fields: Default::default(),
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
        let mut out = Mesh::default();
        for inst in self.instances.iter().filter(|i| keep(i.role)) {
            let transform = inst.transform_at(frame);
            let mut m = self.meshes[inst.mesh].mesh.map_positions(|p| transform.apply_point(p));
            let n = m.triangles.len() as u32;
            m.objects = vec![MeshObject {
                name: inst.name.clone(),
                triangles: 0..n,
            }];
            out.append(&m);
        }
        out
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
