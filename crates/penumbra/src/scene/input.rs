//! The scene a command's inputs name: one mesh file or one scene file,
//! bare (geometry and roles) or with the materials shading needs. Every
//! runner starts from one of these, so a host tool accepts the same files.

use std::path::Path;

use super::mesh_file::load_mesh_and_cameras;
use super::{Scene, SceneMesh, load_mesh, load_mesh_file, load_scene_in, load_scene_shaded_in};
use crate::error::{Error, Result};

/// A mesh file (any format `load_mesh` reads) or a scene file, as a scene.
pub fn load_input(mesh: Option<&Path>, scene: Option<&Path>) -> Result<Scene> {
    load_input_in(mesh, scene, None)
}

/// `load_input` with `$PENUMBRA_DATA` in a scene file standing for `data`.
pub fn load_input_in(mesh: Option<&Path>, scene: Option<&Path>, data: Option<&Path>) -> Result<Scene> {
    match (mesh, scene) {
        (Some(m), None) => {
            let (mesh, cameras) = load_mesh_and_cameras(m)?;
            Ok(Scene::from_mesh(&file_stem(m), m, mesh).with_cameras(cameras))
        }
        (None, Some(s)) => load_scene_in(s, data),
        (Some(_), Some(_)) => Err(Error::param("mesh/scene", "give one of them, not both")),
        (None, None) => Err(Error::param(
            "mesh",
            "a mesh (--mesh FILE) or a scene (--scene FILE) is required",
        )),
    }
}

/// `load_input` keeping the meshes' materials (an OBJ's MTL, glTF's) for shading.
pub fn load_shaded_input(mesh: Option<&Path>, scene: Option<&Path>) -> Result<Scene> {
    load_shaded_input_in(mesh, scene, None)
}

/// `load_shaded_input` with `$PENUMBRA_DATA` in a scene file standing for `data`.
pub fn load_shaded_input_in(mesh: Option<&Path>, scene: Option<&Path>, data: Option<&Path>) -> Result<Scene> {
    match (mesh, scene) {
        (Some(m), None) => Ok(Scene::from_obj_file(&file_stem(m), m, load_mesh_file(m)?)),
        (None, Some(s)) => load_scene_shaded_in(s, data),
        _ => load_input_in(mesh, scene, data),
    }
}

/// A file's name without its extension ("mesh" if it has none): the name
/// a one-mesh scene gives its mesh.
pub fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map_or("mesh".into(), |s| s.to_string_lossy().into_owned())
}

impl Scene {
    /// This one-mesh scene made a caster onto the mesh in the file `receiver`.
    pub fn with_receiver_file(self, receiver: &Path) -> Result<Scene> {
        Ok(self.with_receiver(SceneMesh::new("receiver", receiver, load_mesh(receiver)?)))
    }
}
