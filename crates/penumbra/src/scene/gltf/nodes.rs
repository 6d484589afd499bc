//! The scene graph: which meshes and cameras a glTF asset places, and where.

use std::path::Path;

use ::gltf::Document;
use glam::{DMat4, DQuat, DVec3};

use crate::error::{Error, Result};

/// A mesh placed in the world: by a node, or (no scenes) by itself.
pub struct Instance {
    pub mesh: usize,
    /// The node placing it (none without scenes) and its skin, if any
    /// (applied by `rig` when the file is animated).
    pub node: Option<usize>,
    pub skin: Option<usize>,
    /// The node's name, else the mesh's, else `mesh N`.
    pub name: String,
    pub world: DMat4,
}

/// A camera placed by a node.
pub struct CameraNode {
    /// Its index in the JSON's `cameras`.
    pub camera: usize,
    /// The node placing it.
    pub node: usize,
    /// The node's world transform (the camera looks down its -z, +y up).
    pub world: DMat4,
}

/// What the scenes place: mesh instances and cameras, each in traversal
/// order.
#[derive(Default)]
pub struct Placed {
    pub instances: Vec<Instance>,
    pub cameras: Vec<CameraNode>,
}

/// The instances and cameras of the default scene (or of every scene;
/// without scenes, every mesh once and no camera), depth first. A node
/// reached a second time within the trees is an error (glTF nodes form
/// trees; a shared subtree could otherwise multiply the geometry
/// exponentially); a root listed by two scenes is placed once.
pub fn instances(path: &Path, document: &Document) -> Result<Placed> {
    let mesh_name = |m: ::gltf::Mesh| m.name().map_or_else(|| format!("mesh {}", m.index()), str::to_string);
    let roots: Vec<::gltf::Node> = match document.default_scene() {
        Some(scene) => scene.nodes().collect(),
        None if document.scenes().len() > 0 => document.scenes().flat_map(|s| s.nodes()).collect(),
        None => {
            let instances = document
                .meshes()
                .map(|m| Instance {
                    mesh: m.index(),
                    node: None,
                    skin: None,
                    name: mesh_name(m),
                    world: DMat4::IDENTITY,
                })
                .collect();
            return Ok(Placed {
                instances,
                cameras: Vec::new(),
            });
        }
    };
    let mut placed = vec![false; document.nodes().len()];
    let mut out = Placed::default();
    // Iterative, so that a deep hierarchy cannot overflow the stack.
    let mut stack: Vec<(::gltf::Node, DMat4, bool)> =
        roots.into_iter().rev().map(|n| (n, DMat4::IDENTITY, true)).collect();
    while let Some((node, parent, is_root)) = stack.pop() {
        let i = node.index();
        if placed[i] {
            if is_root {
                continue;
            }
            return Err(Error::file(
                path,
                format!("nodes[{i}]"),
                "is reached twice in the node hierarchy (glTF nodes form trees: one parent each, no cycles)",
            ));
        }
        placed[i] = true;
        let world = parent * local_transform(path, &node)?;
        if let Some(mesh) = node.mesh() {
            let name = node.name().map_or_else(|| mesh_name(mesh.clone()), str::to_string);
            out.instances.push(Instance {
                mesh: mesh.index(),
                node: Some(i),
                skin: node.skin().map(|s| s.index()),
                name,
                world,
            });
        }
        if let Some(camera) = node.camera() {
            out.cameras.push(CameraNode {
                camera: camera.index(),
                node: i,
                world,
            });
        }
        let children: Vec<::gltf::Node> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world, false)));
    }
    Ok(out)
}

/// A node's local transform in f64 (from its matrix, or from translation,
/// rotation and scale).
pub fn local_transform(path: &Path, node: &::gltf::Node) -> Result<DMat4> {
    let m = match node.transform() {
        ::gltf::scene::Transform::Matrix { matrix } => DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from))),
        ::gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let [x, y, z, w] = rotation.map(f64::from);
            let q = DQuat::from_xyzw(x, y, z, w);
            if !q.length().is_finite() || q.length() == 0.0 {
                return Err(Error::file(
                    path,
                    format!("nodes[{}].rotation", node.index()),
                    format!("{rotation:?} is not a rotation quaternion"),
                ));
            }
            DMat4::from_scale_rotation_translation(
                DVec3::from(scale.map(f64::from)),
                q.normalize(),
                DVec3::from(translation.map(f64::from)),
            )
        }
    };
    if !m.is_finite() {
        return Err(Error::file(
            path,
            format!("nodes[{}]", node.index()),
            "the transform is not finite",
        ));
    }
    Ok(m)
}
