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

use super::camera::Camera;
#[cfg(feature = "gltf")]
use super::gltf::gltf_from_bytes;
use super::mesh::Mesh;
use super::obj::{ObjFile, looks_like_obj, obj_file_from_bytes, obj_from_bytes};
#[cfg(feature = "ply")]
use super::ply::parse_ply;
use crate::error::{Error, Result};

/// Whether `bytes` start with the PLY magic line (`ply`, then LF or CRLF).
pub fn is_ply(bytes: &[u8]) -> bool {
    bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n")
}

/// Whether `bytes` start with the GLB magic (`glTF` as a little-endian u32).
pub fn is_glb(bytes: &[u8]) -> bool {
    bytes.starts_with(b"glTF")
}

/// Whether `bytes` are a JSON object with an `asset` key: what every glTF
/// asset has and other JSON files rarely do. Only the keys are looked at
/// (serde skips the values without building them).
pub fn is_gltf_json(bytes: &[u8]) -> bool {
    #[derive(serde::Deserialize)]
    struct Probe {
        asset: Option<serde::de::IgnoredAny>,
    }
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    let start = bytes.iter().position(|b| !b.is_ascii_whitespace());
    start.is_some_and(|i| bytes[i] == b'{') && serde_json::from_slice::<Probe>(bytes).is_ok_and(|p| p.asset.is_some())
}

/// The mesh formats penumbra reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ text.
    Obj,
    /// PLY, ASCII or binary.
    Ply,
    /// glTF 2.0 JSON (`.gltf`), its buffers in files beside it or in data URIs.
    Gltf,
    /// Binary glTF 2.0 (`.glb`).
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
    load_mesh_and_cameras(path).map(|(mesh, _)| mesh)
}

/// `load_mesh` and the file's cameras in the mesh's frame (a glTF file's,
/// `ObjFile::cameras`; none for OBJ and PLY).
pub fn load_mesh_and_cameras(path: &Path) -> Result<(Mesh, Vec<Camera>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    match MeshFormat::detect(path, &bytes)? {
        MeshFormat::Obj => obj_from_bytes(path, &bytes).map(|mesh| (mesh, Vec::new())),
        format => read_other(path, &bytes, format).map(|f| (f.mesh, f.cameras)),
    }
}

/// A PLY or glTF file, where this build reads it (the `ply` and `gltf`
/// features), else an error naming the feature.
fn read_other(path: &Path, bytes: &[u8], format: MeshFormat) -> Result<ObjFile> {
    match format {
        MeshFormat::Obj => obj_file_from_bytes(path, bytes),
        #[cfg(feature = "ply")]
        MeshFormat::Ply => parse_ply(bytes).map_err(|e| e.in_file(path)),
        #[cfg(feature = "gltf")]
        MeshFormat::Gltf | MeshFormat::Glb => gltf_from_bytes(path, bytes, format == MeshFormat::Glb),
        #[allow(unreachable_patterns)]
        _ => {
            let feature = if format == MeshFormat::Ply { "ply" } else { "gltf" };
            Err(Error::file(
                path,
                "",
                format!("this build of penumbra does not read {format:?} files (the `{feature}` cargo feature is off)"),
            ))
        }
    }
}

impl Mesh {
    /// Reads the mesh in the file `path` (`load_mesh`).
    pub fn load(path: impl AsRef<Path>) -> Result<Mesh> {
        load_mesh(path.as_ref())
    }
}

/// Reads a mesh in any format penumbra reads, with what rendering uses:
/// materials (OBJ's MTL files, glTF's materials), shading normals and
/// warnings. The same geometry as `load_mesh`.
pub fn load_mesh_file(path: &Path) -> Result<ObjFile> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    let format = MeshFormat::detect(path, &bytes)?;
    read_other(path, &bytes, format)
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
        #[cfg(feature = "gltf")]
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
