//! glTF 2.0 meshes (`.gltf` with external or `data:` buffers, and `.glb`),
//! as one mesh in world space, with their materials and cameras.
//!
//! The `gltf` crate (without its default features: no image decoding, no
//! `import`) parses and validates the JSON into its document model (every
//! index in range, every enum known); the containers (`container`) and the
//! accessors (`accessor`) are read here, so that every bound is checked and
//! every problem named.
//!
//! Geometry: the default scene's node trees (every scene's, in order, when
//! there is no default; every mesh once, untransformed, when there are no
//! scenes), depth first, a node's own mesh before its children. Each node's
//! world transform is the product of the local ones in f64, applied to
//! positions in f64 and rounded to f32 once; normals take its cofactor
//! matrix (the inverse transpose up to scale, defined for singular ones
//! too). A mirroring transform (negative determinant) swaps two corners of
//! its triangles, which keeps them front-facing by the contract's
//! `cross(v1 - v0, v2 - v0)`, as glTF's winding rule asks. Primitives are
//! concatenated in that order: vertex order is each primitive's POSITION
//! accessor order, and triangles follow its indices (or 0, 1, 2... without
//! them). TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN primitives are read;
//! points and lines are skipped with a warning. One object per node (or
//! mesh) that contributes triangles, named after the node, else its mesh.
//!
//! Shading: NORMAL attributes become per-corner normals; a primitive
//! without them is flat, as glTF says. Materials (`material`): the base
//! colour and its texture, alpha cut-outs, emission, and glass from
//! `KHR_materials_transmission`; `TEXCOORD_0` is read wherever a primitive
//! has it (textures and bakes use it), its v flipped to penumbra's
//! convention (v up the image). Application attributes (`_NAME`) are
//! accepted and not read. A mesh read as a mesh is its rest pose (skins and morph
//! targets not applied); `load_gltf_animation` reads its animation (`rig`:
//! linear blend skinning, morph targets, node animation).
//!
//! Cameras (`camera`): the perspective cameras the scenes' nodes place, in
//! traversal order, become `ObjFile::cameras`, in the mesh's frame.

mod accessor;
mod camera;
pub(crate) mod container;
mod material;
mod nodes;
mod out;
mod rig;
#[cfg(test)]
mod tests;
pub mod write;

use std::path::Path;

use std::collections::HashMap;

use ::gltf::accessor::Dimensions;
use ::gltf::mesh::Mode;
use ::gltf::{Document, Semantic};
use glam::{DMat4, Vec2, Vec3};

use super::animated::Animation;
use super::mesh::MeshObject;
use super::mesh_file::is_glb;
use super::obj::{ObjFile, PrimitiveSpan};
use super::texture::TextureSource;
use crate::error::{Error, Result};
use nodes::{Instance, instances};
use out::{Out, assemble};

/// Reads a `.gltf` or `.glb` file (by its content); buffers named by
/// relative URIs are read from the file's folder.
pub fn load_gltf(path: &Path) -> Result<ObjFile> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    gltf_from_bytes(path, &bytes, is_glb(&bytes))
}

/// `load_gltf` of a file already read, as GLB (`glb`) or as JSON. Errors
/// name `path` (also for problems in the buffers it names) and the JSON
/// path, mesh, primitive, accessor or node at fault.
pub(super) fn gltf_from_bytes(path: &Path, bytes: &[u8], glb: bool) -> Result<ObjFile> {
    read(path, bytes, glb, None).map(|(file, _)| file)
}

/// A glTF file's animation, if it has one (`rig`): `selector` names the
/// clip (its name or index; default the first). None for a file without
/// animations (its rest pose is `load_mesh`'s). Errors name the file and
/// the field at fault.
pub fn load_gltf_animation(path: &Path, selector: Option<&str>) -> Result<Option<Animation>> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    let (_, rig) = read(path, &bytes, is_glb(&bytes), Some(selector))?;
    Ok(rig.map(|r| r.into_animation()))
}

/// The mesh and, when `rig` asks (with its clip selector), the animation.
fn read(path: &Path, bytes: &[u8], glb: bool, rig: Option<Option<&str>>) -> Result<(ObjFile, Option<rig::Rig>)> {
    let (json, bin, what) = if glb {
        let (json, bin) = container::split_glb(bytes).map_err(|e| e.in_file(path))?;
        (json, bin, "GLB JSON chunk ")
    } else {
        (bytes, None, "")
    };
    let json = json.strip_prefix(b"\xef\xbb\xbf").unwrap_or(json);
    let mut root = ::gltf::json::Root::from_slice(json).map_err(|e| {
        Error::file(
            path,
            format!("{what}line {} column {}", e.line(), e.column()),
            e.to_string(),
        )
    })?;
    let mut warnings = check_asset(path, &mut root)?;
    check_attributes(path, &root)?;
    let document = Document::from_json(root).map_err(|e| invalid(path, e))?;
    let mut reader = Reader {
        path,
        document: &document,
        bin,
        buffers: vec![None; document.buffers().len()],
        out: Out::default(),
        rig: rig.is_some(),
        pieces: Vec::new(),
        images: HashMap::new(),
    };
    reader.out.warnings.append(&mut warnings);
    let placed = instances(path, &document)?;
    for instance in &placed.instances {
        reader.instance(instance)?;
    }
    reader.out.cameras = camera::world_cameras(path, &document, &placed.cameras, &mut reader.out)?;
    let rig = match rig {
        Some(selector) => reader.rig(selector)?,
        None => None,
    };
    let file = reader.out.finish().map_err(|e| e.in_file(path))?;
    let rig = rig.map(|mut r| {
        r.triangles = file.mesh.triangles.clone();
        r
    });
    Ok((file, rig))
}

/// Refuses what the document model would misread: other glTF versions,
/// and required extensions that change geometry (compression, quantization,
/// GPU instancing). Required extensions of appearance only (materials,
/// textures, lights) are dropped from the list, with a warning, so that
/// validation does not refuse what penumbra does not use anyway.
fn check_asset(path: &Path, root: &mut ::gltf::json::Root) -> Result<Vec<String>> {
    let version = &root.asset.version;
    if !version.starts_with("2.") {
        return Err(Error::file(
            path,
            "asset.version",
            format!("'{version}'; only glTF 2.0 is read"),
        ));
    }
    let appearance = |e: &str| {
        ["KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_lights_punctual"]
            .iter()
            .any(|a| e.starts_with(a))
    };
    let (looks, geometry): (Vec<String>, Vec<String>) = std::mem::take(&mut root.extensions_required)
        .into_iter()
        .partition(|e| appearance(e));
    if !geometry.is_empty() {
        return Err(Error::file(
            path,
            "extensionsRequired",
            format!(
                "{} cannot be read (mesh extensions are not supported)",
                geometry.join(", ")
            ),
        ));
    }
    Ok(looks
        .into_iter()
        .map(|e| format!("extension {e} is required; penumbra reads the geometry without it"))
        .collect())
}

/// Checks the accessor index of every primitive attribute: gltf-json's
/// validation (1.4.1) indexes the POSITION accessor before checking that it
/// exists, and panics when it does not (found by `tests/fuzz_readers.rs`;
/// `tests/regressions/glb/`).
fn check_attributes(path: &Path, root: &::gltf::json::Root) -> Result<()> {
    let n = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(bad) = primitive.attributes.values().map(|a| a.value()).find(|&a| a >= n) {
                return Err(Error::file(
                    path,
                    format!("meshes[{m}].primitives[{p}].attributes"),
                    format!("accessor {bad} is out of range (the file has {n} accessors)"),
                ));
            }
        }
    }
    Ok(())
}

/// The first validation problems of the JSON, by their JSON path.
fn invalid(path: &Path, e: ::gltf::Error) -> Error {
    match e {
        ::gltf::Error::Validation(problems) if !problems.is_empty() => {
            let (at, problem) = &problems[0];
            let more = match problems.len() - 1 {
                0 => String::new(),
                n => format!(" (and {n} more problems)"),
            };
            let problem = match problem {
                ::gltf::json::validation::Error::IndexOutOfBounds => "index out of range".to_string(),
                ::gltf::json::validation::Error::Invalid => "invalid value".to_string(),
                ::gltf::json::validation::Error::Missing => "missing".to_string(),
                other => other.to_string(),
            };
            Error::file(path, at.to_string(), format!("{problem}{more}"))
        }
        other => Error::file(path, "", format!("invalid glTF: {other}")),
    }
}

/// The document, its buffers as loaded on first use, and the mesh so far.
struct Reader<'a> {
    path: &'a Path,
    document: &'a Document,
    bin: Option<&'a [u8]>,
    buffers: Vec<Option<Vec<u8>>>,
    out: Out,
    /// Whether skins, morph targets and animations are read (`rig`), and
    /// each primitive's part of the mesh for them.
    rig: bool,
    pieces: Vec<rig::Piece>,
    /// Each image's source once read (None where it cannot be used; a
    /// warning said why).
    images: HashMap<usize, Option<TextureSource>>,
}

impl Reader<'_> {
    fn instance(&mut self, instance: &Instance) -> Result<()> {
        let Some(mesh) = self.document.meshes().nth(instance.mesh) else {
            return Ok(());
        };
        let start = self.out.triangles.len();
        for primitive in mesh.primitives() {
            let field = format!(
                "meshes[{}]{} primitives[{}]",
                mesh.index(),
                mesh.name().map_or_else(String::new, |n| format!(" '{n}'")),
                primitive.index()
            );
            let first = self.out.positions.len();
            let Some(base) = self.primitive(&field, &primitive, instance.world)? else {
                continue;
            };
            self.out.primitives.push(PrimitiveSpan {
                mesh: mesh.index(),
                primitive: primitive.index(),
                first_vertex: first as u32,
                vertices: base.len() as u32,
            });
            if self.rig {
                let piece = self.piece(&field, instance, &primitive, first, base)?;
                self.pieces.push(piece);
            }
        }
        if instance.skin.is_some() && !self.rig {
            self.out
                .warn(format!("'{}' has a skin: the rest pose is read", instance.name));
        }
        if !self.rig && (mesh.weights().is_some() || mesh.primitives().any(|p| p.morph_targets().len() > 0)) {
            self.out.warn(format!(
                "meshes[{}] has morph targets: the base shape is read",
                mesh.index()
            ));
        }
        let end = self.out.triangles.len();
        if end > start {
            self.out.objects.push(MeshObject {
                name: instance.name.clone(),
                triangles: start as u32..end as u32,
            });
        }
        Ok(())
    }

    /// The bytes of the buffer accessor `a` reads from, loaded once.
    fn buffer_of(&mut self, a: &::gltf::Accessor) -> std::result::Result<&[u8], String> {
        match a.view() {
            Some(view) => self.buffer(view.buffer()),
            None => Ok(&[]),
        }
    }

    /// The bytes of `buffer`, loaded once.
    fn buffer(&mut self, buffer: ::gltf::Buffer) -> std::result::Result<&[u8], String> {
        let i = buffer.index();
        if self.buffers[i].is_none() {
            let source = match buffer.source() {
                ::gltf::buffer::Source::Bin => container::Source::Bin(self.bin),
                ::gltf::buffer::Source::Uri(uri) => container::Source::Uri(uri),
            };
            let dir = self.path.parent().unwrap_or(Path::new("."));
            let data = container::load(source, buffer.length(), dir).map_err(|e| format!("buffers[{i}] {e}"))?;
            self.buffers[i] = Some(data);
        }
        Ok(self.buffers[i].as_deref().unwrap_or(&[]))
    }

    /// Appends a primitive; returns its positions as the file holds them
    /// (None where it is skipped).
    fn primitive(&mut self, field: &str, p: &::gltf::Primitive, world: DMat4) -> Result<Option<Vec<Vec3>>> {
        let path = self.path;
        let fail = |problem: String| Error::file(path, field, problem);
        let mode = p.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            self.out
                .warn(format!("{field}: mode {mode:?} is not a surface; skipped"));
            return Ok(None);
        }
        let Some(position) = p.get(&Semantic::Positions) else {
            return Err(fail("has no POSITION attribute".into()));
        };
        let attribute = |name: &'static str| move |e: String| format!("{name} {e}");
        let buffer = self.buffer_of(&position).map_err(attribute("POSITION")).map_err(fail)?;
        let positions = accessor::vec3(&position, buffer)
            .map_err(attribute("POSITION"))
            .map_err(fail)?;
        let normals = match p.get(&Semantic::Normals) {
            Some(a) => {
                let buffer = self.buffer_of(&a).map_err(attribute("NORMAL")).map_err(fail)?;
                let n = accessor::vec3(&a, buffer).map_err(attribute("NORMAL")).map_err(fail)?;
                if n.len() != positions.len() {
                    return Err(fail(format!(
                        "NORMAL accessor {} has {} elements, POSITION accessor {} has {}",
                        a.index(),
                        n.len(),
                        position.index(),
                        positions.len()
                    )));
                }
                Some(n)
            }
            None => None,
        };
        let indices = match p.indices() {
            Some(a) => {
                let buffer = self.buffer_of(&a).map_err(attribute("indices")).map_err(fail)?;
                let indices = accessor::indices(&a, buffer)
                    .map_err(attribute("indices"))
                    .map_err(fail)?;
                let n = positions.len();
                if let Some((k, bad)) = indices.iter().enumerate().find(|&(_, &v)| v as usize >= n) {
                    return Err(fail(format!(
                        "indices accessor {}: index {bad} (element {k}) is out of range (POSITION accessor {} \
                         has {n} vertices)",
                        a.index(),
                        position.index()
                    )));
                }
                indices
            }
            None => (0..positions.len() as u32).collect(),
        };
        let triangles = assemble(mode, &indices).map_err(fail)?;
        let material = self.material(p.material())?;
        // Read wherever present: textures need them, and so does baking.
        let texcoords = match p.get(&Semantic::TexCoords(0)) {
            Some(a) => {
                let buffer = self.buffer_of(&a).map_err(attribute("TEXCOORD_0")).map_err(fail)?;
                let uv = accessor::floats(&a, buffer, Dimensions::Vec2)
                    .map_err(attribute("TEXCOORD_0"))
                    .map_err(fail)?;
                if uv.len() != 2 * positions.len() {
                    return Err(fail(format!(
                        "TEXCOORD_0 accessor {} has {} elements, POSITION accessor {} has {}",
                        a.index(),
                        uv.len() / 2,
                        position.index(),
                        positions.len()
                    )));
                }
                // glTF's v runs down the image, penumbra's up.
                Some(
                    uv.chunks_exact(2)
                        .map(|c| Vec2::new(c[0], 1.0 - c[1]))
                        .collect::<Vec<_>>(),
                )
            }
            None => None,
        };
        let attributes = out::Attributes {
            normals: normals.as_deref(),
            texcoords: texcoords.as_deref(),
        };
        self.out
            .append(&positions, attributes, &triangles, world, material)
            .map_err(fail)?;
        Ok(Some(positions))
    }
}
