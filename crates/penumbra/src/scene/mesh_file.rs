//! The one entry point for a mesh a user names (`--mesh`, `--receiver`,
//! scene files' `meshes`): Wavefront OBJ, PLY (ASCII or binary) or glTF 2.0
//! (`.gltf`, `.glb`), told apart by content first and extension second.
//!
//! Content: the PLY magic line (`ply`), the GLB magic (`glTF`), a JSON
//! object with an `asset` key (a `.gltf`). A file that shows none of them
//! is read as its extension says (so a broken `.ply` gets the PLY reader's
//! message, not OBJ's), and a file with an extension penumbra does not know
//! is read as OBJ only if it looks like OBJ text; anything else is
//! "unknown mesh format". Every format ends in the same `Mesh::validate`
//! (finite coordinates, extent, indices, at least one triangle).

use std::path::Path;

use super::gltf::{gltf_from_bytes, is_glb, is_gltf_json};
use super::mesh::Mesh;
use super::obj::{ObjFile, looks_like_obj, obj_file_from_bytes, obj_from_bytes};
use super::ply::{is_ply, parse_ply};
use crate::error::{Error, Result};

/// The mesh formats penumbra reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    Obj,
    Ply,
    Gltf,
    Glb,
}

impl MeshFormat {
    /// Extensions (lower case) and the formats they name.
    const EXTENSIONS: [(&'static str, MeshFormat); 4] = [
        ("obj", MeshFormat::Obj),
        ("ply", MeshFormat::Ply),
        ("gltf", MeshFormat::Gltf),
        ("glb", MeshFormat::Glb),
    ];

    /// The format of the file `path` whose content is `bytes`.
    pub fn detect(path: &Path, bytes: &[u8]) -> Result<MeshFormat> {
        if is_ply(bytes) {
            return Ok(MeshFormat::Ply);
        }
        if is_glb(bytes) {
            return Ok(MeshFormat::Glb);
        }
        if is_gltf_json(bytes) {
            return Ok(MeshFormat::Gltf);
        }
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if let Some(&(_, format)) = Self::EXTENSIONS.iter().find(|(e, _)| *e == extension) {
            return Ok(format);
        }
        if looks_like_obj(bytes) {
            return Ok(MeshFormat::Obj);
        }
        let named = if extension.is_empty() {
            "it has no extension".to_string()
        } else {
            format!("'.{extension}' is not an extension penumbra reads")
        };
        Err(Error::file(
            path,
            "",
            format!(
                "unknown mesh format: the content is not PLY, glTF or OBJ text and {named} \
                 (meshes may be Wavefront OBJ (.obj), PLY (.ply, ASCII or binary) or glTF 2.0 (.gltf, .glb))"
            ),
        ))
    }
}

/// Reads a mesh in any format penumbra reads: geometry only, numbered as
/// the contract says (vertices in file order; for glTF, primitives in scene
/// order). Errors name the file, where in it, and the problem.
pub fn load_mesh(path: &Path) -> Result<Mesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    match MeshFormat::detect(path, &bytes)? {
        MeshFormat::Obj => obj_from_bytes(path, &bytes),
        MeshFormat::Ply => parse_ply(&bytes).map(|f| f.mesh).map_err(|e| e.in_file(path)),
        format => gltf_from_bytes(path, &bytes, format == MeshFormat::Glb).map(|f| f.mesh),
    }
}

/// Reads a mesh in any format penumbra reads, with what rendering uses:
/// materials (OBJ's MTL files, glTF's materials), shading normals and
/// warnings. The same geometry as `load_mesh`.
pub fn load_mesh_file(path: &Path) -> Result<ObjFile> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    match MeshFormat::detect(path, &bytes)? {
        MeshFormat::Obj => obj_file_from_bytes(path, &bytes),
        MeshFormat::Ply => parse_ply(&bytes).map_err(|e| e.in_file(path)),
        format => gltf_from_bytes(path, &bytes, format == MeshFormat::Glb),
    }
}

/// Files a mesh file names and a reader opens with it: an OBJ's `mtllib`
/// files, a `.gltf`'s external buffers (relative to the mesh's folder).
/// Outputs must not overwrite them either (`output::refuse_overwrites`);
/// an unreadable or malformed mesh names none (its reader reports it).
pub fn companion_files(path: &Path) -> Vec<std::path::PathBuf> {
    let Ok(bytes) = std::fs::read(path) else {
        return Vec::new();
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    match MeshFormat::detect(path, &bytes) {
        Ok(MeshFormat::Obj) => String::from_utf8_lossy(&bytes)
            .lines()
            .filter_map(|l| l.trim_start().strip_prefix("mtllib"))
            .flat_map(|names| names.split_whitespace().map(|n| dir.join(n)).collect::<Vec<_>>())
            .collect(),
        Ok(MeshFormat::Gltf) => {
            let json: serde_json::Value = serde_json::from_slice(&bytes).unwrap_or_default();
            let buffers = json["buffers"].as_array().cloned().unwrap_or_default();
            buffers
                .iter()
                .filter_map(|b| b["uri"].as_str())
                .filter(|uri| !uri.starts_with("data:"))
                .map(|uri| dir.join(&*percent_encoding::percent_decode_str(uri).decode_utf8_lossy()))
                .collect()
        }
        _ => Vec::new(),
    }
}
