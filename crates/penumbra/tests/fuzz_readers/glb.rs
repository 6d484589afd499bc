//! GLB: `load_gltf`, and `load_mesh` / `load_mesh_file` of a `.glb`, with
//! the shading normals a shaded scene computes.

use std::path::Path;

use glam::Vec3;
use penumbra::scene::{Mesh, load_gltf, load_mesh, load_mesh_file, procedural};
use proptest::prelude::*;
use proptest::sample::select;
use serde_json::json;

use crate::harness::{Budget, MIB, Reader, agree, call, names, write_case};
use crate::inputs::{binary_edit, mutated, text_edit};
use crate::obj::obj_file_ok;
use crate::write::{data_uri, glb_bytes, gltf_parts, scene_parts};

const BUDGET: Budget = Budget::new(128, MIB);

pub static GLB: Reader = Reader::new(
    "glb",
    &[
        "load_gltf",
        "load_mesh(glb)",
        "load_mesh_file(glb)",
        "ObjFile::shading_normals",
    ],
    check,
)
.with_setup(setup);

/// The buffer file a seed's JSON names (`"uri": "m.bin"`).
fn setup(dir: &Path) -> std::io::Result<()> {
    std::fs::write(dir.join("m.bin"), gltf_parts(&tetrahedron()).1)
}

fn check(dir: &Path, input: &[u8]) -> Result<(), String> {
    let path = write_case(dir.join("case.glb"), input)?;
    let len = input.len();
    let read = call("load_gltf", BUDGET, len, || load_gltf(&path))?;
    match &read {
        Ok(f) => obj_file_ok(f, len)?,
        Err(e) => names(e, &path)?,
    }
    let file = call("load_mesh_file(glb)", BUDGET, len, || load_mesh_file(&path))?;
    agree("load_gltf", &read, "load_mesh_file", file, &path, |a, b| {
        a.mesh == b.mesh && a.materials == b.materials && a.normals == b.normals && a.cameras == b.cameras
    })?;
    let meshes = read.map(|f| f.mesh);
    let mesh = call("load_mesh(glb)", BUDGET, len, || load_mesh(&path))?;
    agree("load_gltf", &meshes, "load_mesh", mesh, &path, PartialEq::eq)
}

fn tetrahedron() -> Mesh {
    let p = Vec3::new;
    let positions = vec![p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(0.0, 1.0, 0.0), p(0.0, 0.0, 1.0)];
    Mesh::new(positions, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]).unwrap_or_else(|e| panic!("{e}"))
}

/// JSON texts and BIN chunks: the writers' meshes and scene, the same with
/// the buffer in a `data:` URI or in `m.bin`, and dense ones (a strip of u8
/// indices: a triangle a byte; many nodes placing one mesh).
fn parts() -> Vec<(Vec<u8>, Vec<u8>)> {
    let text = |v: &serde_json::Value| serde_json::to_vec(v).unwrap_or_default();
    let mut out = Vec::new();
    for mesh in [tetrahedron(), procedural::cube_with_hole()] {
        let (json, bin) = gltf_parts(&mesh);
        out.push((text(&json), bin));
    }
    let (scene, bin) = scene_parts();
    out.push((text(&scene), bin.clone()));
    let mut embedded = scene.clone();
    embedded["buffers"][0]["uri"] = data_uri(&bin).into();
    out.push((text(&embedded), Vec::new()));
    let (mut external, bin) = gltf_parts(&tetrahedron());
    external["buffers"][0]["uri"] = "m.bin".into();
    out.push((text(&external), Vec::new()));
    // A strip of 20,000 u8 indices over the tetrahedron's 4 vertices.
    let (mut strip, mut bin_strip) = (external.clone(), bin.clone());
    strip["buffers"][0] = json!({ "byteLength": bin.len() + 20_000 });
    strip["bufferViews"][1] = json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": 20_000 });
    strip["accessors"][1] = json!({ "bufferView": 1, "componentType": 5121, "count": 20_000, "type": "SCALAR" });
    strip["meshes"][0]["primitives"][0]["mode"] = 5.into();
    bin_strip.extend((0..20_000u32).map(|i| (i % 4) as u8));
    out.push((text(&strip), bin_strip));
    // 2,000 nodes, each placing the tetrahedron somewhere else.
    let (mut many, bin) = gltf_parts(&tetrahedron());
    many["nodes"] = (0..2_000)
        .map(|i| json!({ "mesh": 0, "translation": [i, 0, 0] }))
        .collect();
    many["scenes"][0]["nodes"] = (0..2_000).collect();
    out.push((text(&many), bin));
    out.push(looks());
    out
}

/// The tetrahedron with what appearance adds: TEXCOORD_0, a base colour
/// texture in a buffer view (its bytes are not decoded when a mesh is
/// read) with a sampler and `KHR_texture_transform`, a cut-out, glass, and
/// cameras (perspective and orthographic) under a transformed node.
fn looks() -> (Vec<u8>, Vec<u8>) {
    let (mut json, mut bin) = gltf_parts(&tetrahedron());
    let uv = bin.len();
    bin.extend(
        [0.0f32, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0]
            .iter()
            .flat_map(|f| f.to_le_bytes()),
    );
    let image = bin.len();
    bin.extend(b"\x89PNG not really");
    json["buffers"][0]["byteLength"] = bin.len().into();
    let views = json["bufferViews"].as_array_mut().expect("views");
    views.push(json!({ "buffer": 0, "byteOffset": uv, "byteLength": 32 }));
    views.push(json!({ "buffer": 0, "byteOffset": image, "byteLength": bin.len() - image }));
    json["accessors"]
        .as_array_mut()
        .expect("accessors")
        .push(json!({ "bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2" }));
    json["images"] = json!([{ "bufferView": 3, "mimeType": "image/png" }]);
    json["samplers"] = json!([{ "wrapS": 33071, "wrapT": 33648 }]);
    json["textures"] = json!([{ "source": 0, "sampler": 0 }]);
    json["materials"] = json!([
        { "alphaMode": "MASK", "alphaCutoff": 0.25,
          "pbrMetallicRoughness": { "baseColorFactor": [1, 0.5, 0.5, 0.75], "baseColorTexture": { "index": 0,
              "extensions": { "KHR_texture_transform": { "offset": [0.5, 0], "scale": [2, 2], "rotation": 0.1 } } } } },
        { "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1 }, "KHR_materials_ior": { "ior": 1.4 } } }
    ]);
    json["meshes"][0]["primitives"] = json!([
        { "attributes": { "POSITION": 0, "TEXCOORD_0": 2 }, "indices": 1, "material": 0 },
        { "attributes": { "POSITION": 0 }, "indices": 1, "material": 1, "mode": 4 }
    ]);
    json["cameras"] = json!([
        { "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } },
        { "type": "orthographic", "orthographic": { "xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 9 } }
    ]);
    let s = std::f64::consts::FRAC_1_SQRT_2;
    json["nodes"] = json!([
        { "mesh": 0, "children": [1, 2], "rotation": [0, s, 0, s] },
        { "camera": 0, "translation": [0, 0, 5] },
        { "camera": 1, "matrix": [-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 3, 0, 0, 1] }
    ]);
    (serde_json::to_vec(&json).unwrap_or_default(), bin)
}

pub fn seeds() -> Vec<Vec<u8>> {
    parts().iter().map(|(json, bin)| glb_bytes(json, bin)).collect()
}

/// Seeds with byte edits anywhere (chunk headers included).
pub fn mutated_bytes() -> impl Strategy<Value = Vec<u8>> {
    mutated(seeds(), binary_edit(), 4)
}

/// Seeds whose JSON text is edited, rewrapped with the chunk lengths
/// right, so that the edits reach the JSON and what it describes.
pub fn mutated_json() -> impl Strategy<Value = Vec<u8>> {
    select(parts()).prop_flat_map(|(json, bin)| {
        (mutated(vec![json], text_edit(), 6), Just(bin)).prop_map(|(json, bin)| glb_bytes(&json, &bin))
    })
}

/// The appearance seed reads, so that its mutations reach what it adds.
#[test]
fn the_looks_seed_reads_with_its_texture_glass_and_camera() {
    let dir = std::env::temp_dir().join(format!("penumbra-glb-looks-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let (json, bin) = looks();
    let path = dir.join("looks.glb");
    std::fs::write(&path, glb_bytes(&json, &bin)).expect("write");
    let f = load_mesh_file(&path).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).ok();
    assert!(f.materials[1].maps.alpha.is_some() && f.materials[2].illum == 7);
    assert_eq!((f.texcoords.len(), f.cameras.len()), (4, 1));
}
