//! An asset with baked ambient occlusion, as a GLB: a glTF input copied
//! with everything it has (nodes, materials, attributes, textures,
//! extensions), its buffers gathered into the BIN chunk, the AO texture
//! added as every material's `occlusionTexture` (glTF 2.0 section 3.9.3:
//! occlusion is read from the R channel, linearly) and per-vertex AO as
//! the application attribute `_AO` of each primitive (section 3.7.2.1:
//! names that start with an underscore are the application's); an OBJ or
//! PLY input becomes a GLB of one mesh, one primitive and one material.
//!
//! The JSON is edited as a tree (`serde_json`), so members this code does
//! not know travel unchanged, and its object members come out in key
//! order: the same inputs give the same bytes.

use std::collections::HashSet;
use std::path::Path;

use glam::Vec3;
use serde_json::{Map, Value, json};

use super::container::{Source, load, split_glb};
use crate::error::{Error, Result};
use crate::scene::mesh_file::{is_glb, is_gltf_json};
use crate::scene::obj::{NO_TEXCOORD, ObjFile};

/// What is baked into the asset.
#[derive(Debug, Clone, Copy, Default)]
pub struct BakedAo<'a> {
    /// The AO texture, a PNG file's bytes.
    pub texture_png: Option<&'a [u8]>,
    /// AO per vertex of the file's mesh as read (`ObjFile::mesh`).
    pub vertex_ao: Option<&'a [f32]>,
    /// Also write the per-vertex AO as `COLOR_0` (grey, linear).
    pub vertex_colors: bool,
    /// Replace a material's own `occlusionTexture` (else it is kept, with
    /// a warning).
    pub replace: bool,
}

/// The GLB's bytes and what writing them noticed.
#[derive(Debug, Clone, Default)]
pub struct GlbOut {
    /// The file.
    pub bytes: Vec<u8>,
    /// Materials given the AO texture as their `occlusionTexture`.
    pub materials_with_ao: usize,
    /// Primitives given `_AO`.
    pub primitives_with_ao: usize,
    /// What was kept or could not be done.
    pub warnings: Vec<String>,
}

/// `file` (read from `input`) with `baked` added, as a GLB.
pub fn glb_with_ao(input: &Path, file: &ObjFile, baked: &BakedAo) -> Result<GlbOut> {
    let bytes = std::fs::read(input).map_err(|e| Error::file(input, "", e.to_string()))?;
    if is_glb(&bytes) || is_gltf_json(&bytes) {
        from_gltf(input, &bytes, file, baked)
    } else {
        Ok(from_mesh(file, baked))
    }
}

/// The BIN chunk as it grows, and the JSON's bufferViews pointing into it.
struct Bin<'a> {
    data: Vec<u8>,
    root: &'a mut Value,
}

impl Bin<'_> {
    /// Appends `bytes` (4-aligned) as a new bufferView; returns its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        align4(&mut self.data, 0);
        let mut view = json!({"buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.data.extend_from_slice(bytes);
        push(self.root, "bufferViews", view)
    }

    /// Appends a PNG as an image and a texture of it; returns the texture.
    fn texture(&mut self, png: &[u8]) -> usize {
        let view = self.view(png, None);
        let image = push(
            self.root,
            "images",
            json!({"bufferView": view, "mimeType": "image/png", "name": "penumbra-ao"}),
        );
        push(self.root, "textures", json!({"source": image, "name": "penumbra-ao"}))
    }

    /// Appends floats as an accessor of `kind` ("SCALAR", "VEC3"...).
    fn floats(&mut self, values: &[f32], kind: &str, per: usize, bounds: bool) -> usize {
        let view = self.view(bytemuck::cast_slice(values), Some(ARRAY_BUFFER));
        let mut accessor = json!({
            "bufferView": view, "componentType": FLOAT, "count": values.len() / per, "type": kind
        });
        if bounds {
            let (mut lo, mut hi) = (vec![f32::INFINITY; per], vec![f32::NEG_INFINITY; per]);
            for c in values.chunks_exact(per) {
                for k in 0..per {
                    lo[k] = lo[k].min(c[k]);
                    hi[k] = hi[k].max(c[k]);
                }
            }
            accessor["min"] = json!(lo);
            accessor["max"] = json!(hi);
        }
        push(self.root, "accessors", accessor)
    }
}

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

fn push(root: &mut Value, array: &str, item: Value) -> usize {
    let list = root
        .as_object_mut()
        .expect("a glTF root is an object")
        .entry(array)
        .or_insert_with(|| Value::Array(Vec::new()));
    if !list.is_array() {
        *list = Value::Array(Vec::new());
    }
    let list = list.as_array_mut().expect("made an array above");
    list.push(item);
    list.len() - 1
}

fn align4(data: &mut Vec<u8>, fill: u8) {
    data.resize(data.len().div_ceil(4) * 4, fill);
}

fn from_gltf(input: &Path, bytes: &[u8], file: &ObjFile, baked: &BakedAo) -> Result<GlbOut> {
    let (json_bytes, bin) = if is_glb(bytes) {
        split_glb(bytes).map_err(|e| Error::file(input, "GLB", e.to_string()))?
    } else {
        (bytes, None)
    };
    let mut root: Value = serde_json::from_slice(json_bytes).map_err(|e| Error::file(input, "JSON", e.to_string()))?;
    let dir = input.parent().unwrap_or(Path::new("."));
    // Every buffer into the one BIN chunk, views moved to match.
    let buffers = root
        .get("buffers")
        .and_then(Value::as_array)
        .cloned()
        .unwrap_or_default();
    let mut data = Vec::new();
    let mut bases = Vec::new();
    for (i, b) in buffers.iter().enumerate() {
        let length = b.get("byteLength").and_then(Value::as_u64).unwrap_or(0) as usize;
        let source = match b.get("uri").and_then(Value::as_str) {
            Some(uri) => Source::Uri(uri),
            None => Source::Bin(bin),
        };
        let bytes = load(source, length, dir).map_err(|e| Error::file(input, format!("buffers[{i}]"), e))?;
        align4(&mut data, 0);
        bases.push(data.len());
        data.extend_from_slice(&bytes[..length]);
    }
    if let Some(views) = root.get_mut("bufferViews").and_then(Value::as_array_mut) {
        for v in views {
            let b = v.get("buffer").and_then(Value::as_u64).unwrap_or(0) as usize;
            let offset = v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
            v["buffer"] = json!(0);
            v["byteOffset"] = json!(bases.get(b).copied().unwrap_or(0) + offset);
        }
    }
    let mut out = GlbOut::default();
    let mut bin = Bin { data, root: &mut root };
    if let Some(png) = baked.texture_png {
        let texture = bin.texture(png);
        let occlusion = json!({"index": texture});
        let mut unassigned = false;
        if let Some(meshes) = bin.root.get("meshes").and_then(Value::as_array) {
            unassigned = meshes.iter().any(|m| {
                m.get("primitives")
                    .and_then(Value::as_array)
                    .is_some_and(|ps| ps.iter().any(|p| p.get("material").is_none()))
            });
        }
        let materials = bin.root.get("materials").and_then(Value::as_array).map_or(0, Vec::len);
        for i in 0..materials {
            let m = &mut bin.root["materials"][i];
            if m.get("occlusionTexture").is_some() && !baked.replace {
                let name = m.get("name").and_then(Value::as_str).unwrap_or("").to_string();
                out.warnings.push(format!(
                    "materials[{i}] '{name}' has its own occlusionTexture: kept (--replace puts the baked one in its place)"
                ));
                continue;
            }
            m["occlusionTexture"] = occlusion.clone();
            out.materials_with_ao += 1;
        }
        if unassigned {
            // glTF's default material, with the occlusion: its defaults
            // are those of an empty material.
            let m = push(
                bin.root,
                "materials",
                json!({"name": "penumbra-ao", "occlusionTexture": occlusion}),
            );
            out.materials_with_ao += 1;
            if let Some(meshes) = bin.root.get_mut("meshes").and_then(Value::as_array_mut) {
                for p in meshes
                    .iter_mut()
                    .filter_map(|m| m.get_mut("primitives")?.as_array_mut())
                    .flatten()
                {
                    if p.get("material").is_none() {
                        p["material"] = json!(m);
                    }
                }
            }
        }
    }
    if let Some(ao) = baked.vertex_ao {
        let mut done = HashSet::new();
        let mut placed_twice = 0;
        for span in &file.primitives {
            if !done.insert((span.mesh, span.primitive)) {
                placed_twice += 1;
                continue;
            }
            let range = span.first_vertex as usize..(span.first_vertex + span.vertices) as usize;
            let Some(values) = ao.get(range) else {
                continue;
            };
            let accessor = bin.floats(values, "SCALAR", 1, false);
            let colour = baked.vertex_colors.then(|| {
                let grey: Vec<f32> = values.iter().flat_map(|&a| [a, a, a]).collect();
                bin.floats(&grey, "VEC3", 3, false)
            });
            let attributes = &mut bin.root["meshes"][span.mesh]["primitives"][span.primitive]["attributes"];
            attributes["_AO"] = json!(accessor);
            if let Some(c) = colour {
                if attributes.get("COLOR_0").is_some() {
                    out.warnings.push(format!(
                        "meshes[{}] primitives[{}]: its COLOR_0 is replaced by the AO (--vertex-colors)",
                        span.mesh, span.primitive
                    ));
                }
                attributes["COLOR_0"] = json!(c);
            }
            out.primitives_with_ao += 1;
        }
        if placed_twice > 0 {
            out.warnings.push(format!(
                "{placed_twice} placements of meshes that several nodes place: a primitive's _AO is its first placement's"
            ));
        }
    }
    let Bin { data, .. } = bin;
    root["buffers"] = json!([{"byteLength": data.len()}]);
    out.bytes = glb(&root, data);
    Ok(out)
}

fn from_mesh(file: &ObjFile, baked: &BakedAo) -> GlbOut {
    let mesh = &file.mesh;
    let normals = mesh.vertex_normals();
    // One glTF vertex per (position, texture coordinate) pair.
    let mut index = std::collections::HashMap::new();
    let mut corners: Vec<(u32, u32)> = Vec::new();
    let mut indices = Vec::with_capacity(mesh.triangles.len() * 3);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let uv = file.corner_texcoords.get(t).copied().unwrap_or([NO_TEXCOORD; 3]);
        for k in 0..3 {
            let key = (tri[k], uv[k]);
            let next = corners.len() as u32;
            let i = *index.entry(key).or_insert_with(|| {
                corners.push(key);
                next
            });
            indices.push(i);
        }
    }
    let origin = mesh.origin;
    let positions: Vec<f32> = corners
        .iter()
        .flat_map(|&(p, _)| (origin + mesh.positions[p as usize].as_dvec3()).as_vec3().to_array())
        .collect();
    let normals: Vec<f32> = corners
        .iter()
        .flat_map(|&(p, _)| {
            let n = normals[p as usize];
            if n == Vec3::ZERO { Vec3::Z } else { n }.to_array()
        })
        .collect();
    let has_uv = corners.iter().all(|&(_, uv)| uv != NO_TEXCOORD);
    let mut root = json!({
        "asset": {"version": "2.0", "generator": concat!("penumbra ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
    });
    let mut bin = Bin {
        data: Vec::new(),
        root: &mut root,
    };
    let mut attributes = Map::new();
    attributes.insert("POSITION".into(), json!(bin.floats(&positions, "VEC3", 3, true)));
    attributes.insert("NORMAL".into(), json!(bin.floats(&normals, "VEC3", 3, false)));
    if has_uv {
        // glTF's v runs down the image.
        let uv: Vec<f32> = corners
            .iter()
            .flat_map(|&(_, t)| {
                let c = file.texcoords[t as usize];
                [c.x, 1.0 - c.y]
            })
            .collect();
        attributes.insert("TEXCOORD_0".into(), json!(bin.floats(&uv, "VEC2", 2, false)));
    }
    let mut out = GlbOut::default();
    if let Some(ao) = baked.vertex_ao {
        let values: Vec<f32> = corners.iter().map(|&(p, _)| ao[p as usize]).collect();
        attributes.insert("_AO".into(), json!(bin.floats(&values, "SCALAR", 1, false)));
        if baked.vertex_colors {
            let grey: Vec<f32> = values.iter().flat_map(|&a| [a, a, a]).collect();
            attributes.insert("COLOR_0".into(), json!(bin.floats(&grey, "VEC3", 3, false)));
        }
        out.primitives_with_ao = 1;
    }
    let view = bin.view(bytemuck::cast_slice(&indices), Some(ELEMENT_ARRAY_BUFFER));
    let indices = push(
        bin.root,
        "accessors",
        json!({"bufferView": view, "componentType": UNSIGNED_INT, "count": indices.len(), "type": "SCALAR"}),
    );
    let kd = file.materials.get(1).map_or(Vec3::splat(0.8), |m| m.kd);
    let mut material = json!({
        "name": file.materials.get(1).map_or("penumbra-ao", |m| m.name.as_str()),
        "pbrMetallicRoughness": {"baseColorFactor": [kd.x, kd.y, kd.z, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
    });
    if let Some(png) = baked.texture_png {
        let texture = bin.texture(png);
        material["occlusionTexture"] = json!({"index": texture});
        out.materials_with_ao = 1;
    }
    push(bin.root, "materials", material);
    push(
        bin.root,
        "meshes",
        json!({"primitives": [{"attributes": attributes, "indices": indices, "material": 0}]}),
    );
    let Bin { data, .. } = bin;
    root["buffers"] = json!([{"byteLength": data.len()}]);
    out.bytes = glb(&root, data);
    out
}

/// The GLB container (glTF 2.0 section 4.4): header, JSON chunk padded
/// with spaces, BIN chunk padded with zeros.
fn glb(root: &Value, mut bin: Vec<u8>) -> Vec<u8> {
    let mut json = serde_json::to_vec(root).expect("a JSON tree serialises");
    align4(&mut json, b' ');
    align4(&mut bin, 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}
