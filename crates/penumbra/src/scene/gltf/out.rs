//! Assembling the mesh: primitives' triangles by mode, placed by their
//! node's transform, with what shading adds and the cameras in the mesh's
//! frame.

use std::collections::HashMap;

use ::gltf::mesh::Mode;
use glam::{DMat3, DMat4, DVec3, Vec2, Vec3};

use super::camera::WorldCamera;
use crate::error::{Error, Result};
use crate::scene::mesh::{Mesh, MeshObject};
use crate::scene::mtl::Material;
use crate::scene::obj::{NO_NORMAL, NO_TEXCOORD, ObjFile, PrimitiveSpan, SMOOTH_DEFAULT};

/// Triangles of a primitive's index list by its mode (glTF 2.0 section
/// 3.7.2.1): strips alternate their winding so that every triangle faces
/// the same way; fans turn around the first vertex.
pub fn assemble(mode: Mode, idx: &[u32]) -> std::result::Result<Vec<[u32; 3]>, String> {
    let n = idx.len();
    Ok(match mode {
        Mode::Triangles => {
            if !n.is_multiple_of(3) {
                return Err(format!(
                    "has {n} vertices (or indices), not a multiple of 3 (TRIANGLES)"
                ));
            }
            idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
        }
        Mode::TriangleStrip => (0..n.saturating_sub(2))
            .map(|i| match i % 2 {
                0 => [idx[i], idx[i + 1], idx[i + 2]],
                _ => [idx[i + 1], idx[i], idx[i + 2]],
            })
            .collect(),
        _ => (0..n.saturating_sub(2))
            .map(|i| [idx[i + 1], idx[i + 2], idx[0]])
            .collect(),
    })
}

/// The mesh and what shading adds, as it is assembled.
pub struct Out {
    /// In f64 (node transforms applied) until the frame is known.
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    pub objects: Vec<MeshObject>,
    /// Per vertex (zero where a primitive has no NORMAL).
    pub normals: Vec<Vec3>,
    pub corner_normals: Vec<[u32; 3]>,
    /// Texture coordinates (v up) of the primitives that have them.
    pub texcoords: Vec<Vec2>,
    pub corner_texcoords: Vec<[u32; 3]>,
    pub smoothing: Vec<u32>,
    pub materials: Vec<Material>,
    /// glTF material index to ours.
    pub material_index: HashMap<usize, u32>,
    pub triangle_materials: Vec<u32>,
    /// Each placed primitive's vertices.
    pub primitives: Vec<PrimitiveSpan>,
    /// The scenes' perspective cameras, in world space until the frame
    /// is known.
    pub cameras: Vec<WorldCamera>,
    pub warnings: Vec<String>,
}

/// A primitive's attributes besides POSITION, per vertex.
pub struct Attributes<'a> {
    pub normals: Option<&'a [Vec3]>,
    pub texcoords: Option<&'a [Vec2]>,
}

impl Default for Out {
    fn default() -> Self {
        Out {
            positions: Vec::new(),
            triangles: Vec::new(),
            objects: Vec::new(),
            normals: Vec::new(),
            corner_normals: Vec::new(),
            texcoords: Vec::new(),
            corner_texcoords: Vec::new(),
            smoothing: Vec::new(),
            materials: vec![Material::default_surface()],
            material_index: HashMap::new(),
            triangle_materials: Vec::new(),
            primitives: Vec::new(),
            cameras: Vec::new(),
            warnings: Vec::new(),
        }
    }
}

impl Out {
    /// A warning, once.
    pub fn warn(&mut self, warning: String) {
        if !self.warnings.contains(&warning) {
            self.warnings.push(warning);
        }
    }

    /// Appends one primitive, placed by `world`.
    pub fn append(
        &mut self,
        positions: &[Vec3],
        attributes: Attributes,
        triangles: &[[u32; 3]],
        world: DMat4,
        material: u32,
    ) -> std::result::Result<(), String> {
        let base = self.positions.len();
        if base + positions.len() >= u32::MAX as usize || self.triangles.len() + triangles.len() >= u32::MAX as usize {
            return Err("the scene has more than 2^32-1 vertices or triangles".into());
        }
        let base = base as u32;
        let normals = attributes.normals;
        let uv_base = self.texcoords.len() as u32;
        if let Some(uv) = attributes.texcoords {
            self.texcoords.extend_from_slice(uv);
        }
        if world == DMat4::IDENTITY {
            // Bit for bit what the file holds (x * 1 + 0 would turn -0 into +0).
            self.positions.extend(positions.iter().map(|p| p.as_dvec3()));
        } else {
            // A node's translation far from the origin keeps the mesh's
            // detail: rounded to f32 only once recentred (`finish`).
            self.positions
                .extend(positions.iter().map(|p| world.transform_point3(p.as_dvec3())));
        }
        let linear = DMat3::from_mat4(world);
        let mirrored = linear.determinant() < 0.0;
        match normals {
            Some(normals) if world == DMat4::IDENTITY => self.normals.extend_from_slice(normals),
            Some(normals) => {
                // The cofactor matrix maps normals as the inverse transpose
                // does, up to a positive scale once the sign is fixed.
                let [c0, c1, c2] = [linear.x_axis, linear.y_axis, linear.z_axis];
                let cofactor = DMat3::from_cols(c1.cross(c2), c2.cross(c0), c0.cross(c1));
                let sign = if mirrored { -1.0 } else { 1.0 };
                self.normals.extend(
                    normals
                        .iter()
                        .map(|n| (cofactor * n.as_dvec3() * sign).normalize_or_zero().as_vec3()),
                );
            }
            None => self.normals.extend(std::iter::repeat_n(Vec3::ZERO, positions.len())),
        }
        for &[a, b, c] in triangles {
            // The primitive's own vertex numbers, in the placed winding.
            let local = if mirrored { [a, c, b] } else { [a, b, c] };
            let t = local.map(|v| v + base);
            self.triangles.push(t);
            self.corner_texcoords.push(match attributes.texcoords {
                Some(_) => local.map(|v| v + uv_base),
                None => [NO_TEXCOORD; 3],
            });
            self.corner_normals
                .push(if normals.is_some() { t } else { [NO_NORMAL; 3] });
            // Without NORMAL, glTF asks for flat shading: smoothing off.
            self.smoothing.push(if normals.is_some() { SMOOTH_DEFAULT } else { 0 });
            self.triangle_materials.push(material);
        }
        Ok(())
    }

    pub fn finish(self) -> Result<ObjFile> {
        let n = self.triangles.len() as u32;
        let (origin, positions) = super::super::frame::recentre(&self.positions);
        let cameras = super::camera::in_frame(&self.cameras, &self.positions, origin);
        let mesh = Mesh {
            positions,
            triangles: self.triangles,
            objects: self.objects,
            origin,
        };
        if n == 0 {
            return Err(Error::input(
                "mesh",
                format!(
                    "the scene has no triangles ({} vertices); an empty mesh cannot be traced",
                    mesh.positions.len()
                ),
            ));
        }
        mesh.validate()?;
        Ok(ObjFile {
            primitives: self.primitives,
            triangle_faces: (0..n).collect(),
            materials: self.materials,
            triangle_materials: self.triangle_materials,
            normals: self.normals,
            corner_normals: self.corner_normals,
            texcoords: self.texcoords,
            corner_texcoords: self.corner_texcoords,
            smoothing: self.smoothing,
            vertex_colors: None,
            cameras,
            warnings: self.warnings,
            mesh,
        })
    }
}
