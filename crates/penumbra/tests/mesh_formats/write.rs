//! Small writers of the mesh formats penumbra reads, for tests: PLY (ASCII
//! and binary of either byte order, faces or triangle strips) and glTF
//! (JSON with an external or a `data:` buffer, and GLB). Shared by `tests/mesh_formats.rs` and the PLY
//! and GLB fuzz targets' seeds.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use base64::Engine;
use glam::Vec3;
use penumbra::scene::Mesh;
use serde_json::{Value, json};

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ply {
    Ascii,
    LittleEndian,
    BigEndian,
}

/// `mesh` as PLY: float x, y, z and `list uchar int vertex_indices`. With
/// `extras`, also what the reader must skip or keep by type: comments and
/// obj_info, a double before the coordinates, normals, uchar colours, a
/// list in the vertex element, an element before and one after the
/// vertices, and a float list and a flag after each face's indices.
pub fn ply(mesh: &Mesh, format: Ply, extras: bool) -> Vec<u8> {
    let encoding = match format {
        Ply::Ascii => "ascii",
        Ply::LittleEndian => "binary_little_endian",
        Ply::BigEndian => "binary_big_endian",
    };
    let (nv, nf) = (mesh.positions.len(), mesh.triangles.len());
    let mut h = format!("ply\nformat {encoding} 1.0\n");
    if extras {
        h += "comment written by tests/mesh_formats\nobj_info extras\nelement camera 1\nproperty float view\n\
              property list uchar short path\n";
    }
    h += &format!("element vertex {nv}\n");
    if extras {
        h += "property double confidence\n";
    }
    h += "property float x\nproperty float y\nproperty float z\n";
    if extras {
        h += "property float nx\nproperty float ny\nproperty float nz\nproperty list uint8 float32 uv\n\
              property uchar red\nproperty uchar green\nproperty uchar blue\nelement edge 2\n\
              property int vertex1\nproperty int32 vertex2\n";
    }
    h += &format!("element face {nf}\nproperty list uchar int vertex_indices\n");
    if extras {
        h += "property list uchar float texcoord\nproperty uchar flags\n";
    }
    h += "end_header\n";
    let normals = mesh.vertex_normals();
    let mut out = Values::new(format);
    if extras {
        out.f32(0.5);
        out.u8(2);
        out.i16(-1);
        out.i16(7);
        out.end();
    }
    for (i, p) in mesh.positions.iter().enumerate() {
        if extras {
            out.f64(0.25);
        }
        out.f32(p.x);
        out.f32(p.y);
        out.f32(p.z);
        if extras {
            for c in normals[i].to_array() {
                out.f32(c);
            }
            out.u8(1);
            out.f32(0.5);
            for c in colour(i) {
                out.u8(c);
            }
        }
        out.end();
    }
    if extras {
        for _ in 0..2 {
            out.i32(0);
            out.i32(1);
            out.end();
        }
    }
    for t in &mesh.triangles {
        out.u8(3);
        for &v in t {
            out.i32(v as i32);
        }
        if extras {
            out.u8(2);
            out.f32(0.0);
            out.f32(1.0);
            out.u8(9);
        }
        out.end();
    }
    let mut bytes = h.into_bytes();
    bytes.extend(out.bytes);
    bytes
}

/// Triangle strips that give `triangles` in their order and winding, as a
/// greedy stripifier writes them: each triangle continues the strip when
/// one of its rotations starts with the edge the strip's next triangle
/// needs, else starts a strip (turned so that the triangle after it can
/// continue, where one rotation allows). Strips are joined alternately by
/// a `-1` restart and by repeated vertices (triangles a reader drops).
pub fn stripify(triangles: &[[u32; 3]]) -> Stripped {
    let rotations = |[a, b, c]: [u32; 3]| [[a, b, c], [b, c, a], [c, a, b]];
    let mut strips: Vec<Vec<u32>> = Vec::new();
    let mut decoded = Vec::with_capacity(triangles.len());
    for (i, &t) in triangles.iter().enumerate() {
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "triangle {i} repeats a vertex"
        );
        if let Some(s) = strips.last_mut() {
            // Triangle k of a strip: (s[k], s[k+1], s[k+2]) for even k,
            // (s[k+1], s[k], s[k+2]) for odd k.
            let k = s.len() - 2;
            let need = if k % 2 == 0 { (s[k], s[k + 1]) } else { (s[k + 1], s[k]) };
            if let Some(r) = rotations(t).into_iter().find(|r| (r[0], r[1]) == need) {
                s.push(r[2]);
                decoded.push(r);
                continue;
            }
        }
        // The strip's second triangle is (s[2], s[1], s[3]).
        let fits = |r: &[u32; 3]| {
            triangles
                .get(i + 1)
                .is_some_and(|&next| rotations(next).iter().any(|n| (n[0], n[1]) == (r[2], r[1])))
        };
        let r = rotations(t).into_iter().find(fits).unwrap_or(t);
        strips.push(r.to_vec());
        decoded.push(r);
    }
    let mut list: Vec<i64> = Vec::new();
    // Entries since the last restart: a strip must start at an even one.
    let mut run = 0usize;
    for (j, s) in strips.iter().enumerate() {
        if j % 2 == 1 {
            list.push(-1);
            run = 0;
        } else if j > 0 {
            let last = *list.last().unwrap();
            list.extend([last, s[0] as i64]);
            run += 2;
            if run % 2 == 1 {
                list.push(s[0] as i64);
                run += 1;
            }
        }
        list.extend(s.iter().map(|&v| v as i64));
        run += s.len();
    }
    Stripped {
        list,
        triangles: decoded,
        strips: strips.len(),
    }
}

/// What `stripify` makes.
pub struct Stripped {
    /// The strips' entries, one list.
    pub list: Vec<i64>,
    /// The triangles as a reader decodes `list`: the ones stripified, in
    /// order, each turned where its strip needed.
    pub triangles: Vec<[u32; 3]>,
    /// How many strips.
    pub strips: usize,
}

/// A PLY of float `x y z` vertices, `faces` (if any) as a `face` element
/// after a `tristrips` element whose `list int int vertex_indices` holds
/// `strips` in two records (split at a restart near the middle, if any),
/// as scanned models have it.
pub fn ply_strips(positions: &[Vec3], faces: &[[u32; 3]], strips: &[i64], format: Ply) -> Vec<u8> {
    let encoding = match format {
        Ply::Ascii => "ascii",
        Ply::LittleEndian => "binary_little_endian",
        Ply::BigEndian => "binary_big_endian",
    };
    let middle = strips[strips.len() / 2..].iter().position(|&v| v == -1);
    let records: Vec<&[i64]> = match middle {
        Some(at) => {
            let at = strips.len() / 2 + at;
            vec![&strips[..at], &strips[at + 1..]]
        }
        None => vec![strips],
    };
    let mut h = format!(
        "ply\nformat {encoding} 1.0\ncomment triangle strips by tests/mesh_formats\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\nelement tristrips {}\n\
         property list int int vertex_indices\n",
        positions.len(),
        records.len()
    );
    if !faces.is_empty() {
        h += &format!("element face {}\nproperty list uchar int vertex_indices\n", faces.len());
    }
    h += "end_header\n";
    let mut out = Values::new(format);
    for p in positions {
        out.f32(p.x);
        out.f32(p.y);
        out.f32(p.z);
        out.end();
    }
    for r in records {
        out.i32(r.len() as i32);
        for &v in r {
            out.i32(v as i32);
        }
        out.end();
    }
    for t in faces {
        out.u8(3);
        for &v in t {
            out.i32(v as i32);
        }
        out.end();
    }
    let mut bytes = h.into_bytes();
    bytes.extend(out.bytes);
    bytes
}

/// The uchar colour `ply` gives vertex `i` with `extras`.
pub fn colour(i: usize) -> [u8; 3] {
    [(i % 256) as u8, 255, 0]
}

/// Values of a PLY body, as text or bytes.
struct Values {
    format: Ply,
    bytes: Vec<u8>,
}

impl Values {
    fn new(format: Ply) -> Values {
        Values {
            format,
            bytes: Vec::new(),
        }
    }

    fn put<const N: usize>(&mut self, text: String, le: [u8; N], be: [u8; N]) {
        match self.format {
            Ply::Ascii => {
                self.bytes.extend(text.bytes());
                self.bytes.push(b' ');
            }
            Ply::LittleEndian => self.bytes.extend(le),
            Ply::BigEndian => self.bytes.extend(be),
        }
    }
    fn f32(&mut self, v: f32) {
        self.put(v.to_string(), v.to_le_bytes(), v.to_be_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.put(v.to_string(), v.to_le_bytes(), v.to_be_bytes());
    }
    fn i32(&mut self, v: i32) {
        self.put(v.to_string(), v.to_le_bytes(), v.to_be_bytes());
    }
    fn i16(&mut self, v: i16) {
        self.put(v.to_string(), v.to_le_bytes(), v.to_be_bytes());
    }
    fn u8(&mut self, v: u8) {
        self.put(v.to_string(), [v], [v]);
    }
    fn end(&mut self) {
        if self.format == Ply::Ascii {
            self.bytes.pop();
            self.bytes.push(b'\n');
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Gltf {
    /// `.gltf` with its buffer in a `.bin` file beside it.
    External,
    /// `.gltf` with its buffer in a base64 `data:` URI.
    DataUri,
    Glb,
}

/// The JSON and the binary buffer of `mesh` as one node's one indexed
/// TRIANGLES primitive (FLOAT VEC3 positions, UNSIGNED_INT indices); the
/// buffer has no URI yet.
pub fn gltf_parts(mesh: &Mesh) -> (Value, Vec<u8>) {
    let mut bin: Vec<u8> = mesh
        .positions
        .iter()
        .flat_map(|p| p.to_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    let positions = bin.len();
    bin.extend(mesh.triangles.iter().flatten().flat_map(|v| v.to_le_bytes()));
    let (min, max) = mesh
        .positions
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let json = json!({
        "asset": { "version": "2.0", "generator": "tests/mesh_formats" },
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": positions, "target": 34962 },
            { "buffer": 0, "byteOffset": positions, "byteLength": bin.len() - positions, "target": 34963 }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": mesh.positions.len(), "type": "VEC3",
              "min": min.to_array(), "max": max.to_array() },
            { "bufferView": 1, "componentType": 5125, "count": mesh.triangles.len() * 3, "type": "SCALAR" }
        ],
        "meshes": [{ "name": "mesh", "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1 }] }],
        "nodes": [{ "mesh": 0 }],
        "scenes": [{ "nodes": [0] }],
        "scene": 0
    });
    (json, bin)
}

/// A GLB file of `json` and `bin` (each chunk padded to 4 bytes).
pub fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    glb_bytes(&serde_json::to_vec(json).expect("JSON"), bin)
}

/// A GLB file of JSON text (not necessarily valid) and `bin`.
pub fn glb_bytes(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut text = json.to_vec();
    text.resize(text.len().next_multiple_of(4), b' ');
    let mut data = bin.to_vec();
    data.resize(data.len().next_multiple_of(4), 0);
    let length = 12 + 8 + text.len() + if data.is_empty() { 0 } else { 8 + data.len() };
    let mut out = Vec::with_capacity(length);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((length as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    if !data.is_empty() {
        out.extend((data.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(data);
    }
    out
}

/// A base64 `data:` URI of `bin`.
pub fn data_uri(bin: &[u8]) -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bin)
    )
}

/// Writes `json` (its buffer 0 being `bin`) in `form` as `dir/name.gltf`
/// (and `name.bin`) or `dir/name.glb`; returns the path.
pub fn write_gltf(dir: &Path, name: &str, form: Gltf, mut json: Value, bin: &[u8]) -> PathBuf {
    let path = match form {
        Gltf::Glb => {
            let path = dir.join(format!("{name}.glb"));
            std::fs::write(&path, glb(&json, bin)).expect("write .glb");
            return path;
        }
        _ => dir.join(format!("{name}.gltf")),
    };
    json["buffers"][0]["uri"] = match form {
        Gltf::External => {
            std::fs::write(dir.join(format!("{name}.bin")), bin).expect("write .bin");
            format!("{name}.bin").into()
        }
        _ => data_uri(bin).into(),
    };
    std::fs::write(&path, serde_json::to_vec_pretty(&json).expect("JSON")).expect("write .gltf");
    path
}

/// A glTF scene of two meshes in a node tree (translation, scale, a
/// mirroring matrix; a root of another scene), one buffer holding a unit
/// right triangle (3 vertices) with u16 indices at a stride of 4, and a
/// quad (4 vertices) drawn as a strip (with normals), a fan and lines;
/// two materials (a named base colour, an unnamed emission).
pub fn scene_parts() -> (serde_json::Value, Vec<u8>) {
    let floats: [[f32; 3]; 10] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
    ];
    let mut bin: Vec<u8> = floats.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
    bin.extend(0.0f32.to_le_bytes().repeat(3)); // the fourth normal: 0 0 1
    bin.splice(bin.len() - 4.., 1.0f32.to_le_bytes());
    // u16 indices 2, 1, 0 with a stride of 4 (two bytes of padding each).
    for i in [2u16, 1, 0] {
        bin.extend(i.to_le_bytes());
        bin.extend([0, 0]);
    }
    let json = json!({
        "asset": { "version": "2.0" },
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 84 },
            { "buffer": 0, "byteOffset": 84, "byteLength": 48 },
            { "buffer": 0, "byteOffset": 132, "byteLength": 12, "byteStride": 4 }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] },
            { "bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [0, 0, 0], "max": [1, 1, 0] },
            { "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3" },
            { "bufferView": 2, "componentType": 5123, "count": 3, "type": "SCALAR" }
        ],
        "materials": [
            { "name": "red", "pbrMetallicRoughness": { "baseColorFactor": [1, 0, 0, 1], "metallicFactor": 0 } },
            { "emissiveFactor": [1, 0.5, 0.25], "pbrMetallicRoughness": { "metallicFactor": 0 } }
        ],
        "meshes": [
            { "name": "tri", "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 3, "material": 0 }] },
            { "name": "quad", "primitives": [
                { "attributes": { "POSITION": 1, "NORMAL": 2 }, "mode": 5, "material": 1 },
                { "attributes": { "POSITION": 1 }, "mode": 6 },
                { "attributes": { "POSITION": 1 }, "mode": 1 }
            ] }
        ],
        "nodes": [
            { "name": "parent", "translation": [10, 0, 0], "children": [1, 2] },
            { "mesh": 0, "scale": [2, 2, 2] },
            { "mesh": 1, "name": "mirror", "matrix": [-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 5, 1] },
            { "mesh": 0, "name": "unused" }
        ],
        "scenes": [{ "nodes": [3] }, { "nodes": [0] }],
        "scene": 1
    });
    (json, bin)
}
