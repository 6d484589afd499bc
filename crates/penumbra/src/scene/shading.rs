//! What rendering needs of a scene beyond geometry: a mesh's materials and
//! shading normals (from its OBJ and MTL files), and the analytic spheres
//! a scene file may hold. Methods that only cast rays ignore both.

use glam::{Vec2, Vec3};

use super::mtl::Material;
use super::obj::ObjFile;

/// A mesh's per-face materials and shading normals.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshShading {
    /// Index 0 is the default material (faces with none).
    pub materials: Vec<Material>,
    /// Per triangle, an index into `materials`.
    pub triangle_materials: Vec<u32>,
    /// Per triangle, the OBJ polygon it was fanned from.
    pub triangle_faces: Vec<u32>,
    /// Unit shading normals.
    pub normals: Vec<Vec3>,
    /// Per triangle, its corners' indices into `normals`; `None` shades it flat.
    pub corner_normals: Vec<Option<[u32; 3]>>,
    /// Texture coordinates (u, v; v up the image).
    pub texcoords: Vec<Vec2>,
    /// Per triangle, its corners' indices into `texcoords`; `None` where a
    /// corner has none (texture maps are then not used on it).
    pub corner_texcoords: Vec<Option<[u32; 3]>>,
}

impl MeshShading {
    /// The shading of an OBJ file: its materials, and its `vn` normals or
    /// smoothing groups' vertex normals (`ObjFile::shading_normals`).
    pub fn from_obj(obj: &ObjFile) -> MeshShading {
        let (normals, corner_normals) = obj.shading_normals();
        MeshShading {
            materials: obj.materials.clone(),
            triangle_materials: obj.triangle_materials.clone(),
            triangle_faces: obj.triangle_faces.clone(),
            normals,
            corner_normals,
            texcoords: obj.texcoords.clone(),
            corner_texcoords: obj
                .corner_texcoords
                .iter()
                .map(|c| (!c.contains(&super::obj::NO_TEXCOORD)).then_some(*c))
                .collect(),
        }
    }
}

/// An analytic sphere of a scene file.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSphere {
    /// Its `name` in the file, else `sphere#i` for the `i`th sphere.
    pub name: String,
    /// Its centre, in the scene's frame.
    pub center: Vec3,
    /// Its radius, > 0.
    pub radius: f32,
    /// A material of the scene's `"materials"` (none: the default material).
    pub material: Option<String>,
}
