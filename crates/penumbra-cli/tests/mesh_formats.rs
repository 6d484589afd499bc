//! Meshes in PLY and glTF 2.0 read as their OBJ twins (the contract: "Meshes
//! may be Wavefront OBJ, PLY (ASCII or binary) or glTF 2.0; vertex order is
//! the file's"): the same positions and triangles through `load_mesh` and
//! `load_mesh_file`, what each format adds (normals, colours, node
//! transforms, primitive modes, materials), the choice of reader by content
//! and extension, bad files as errors naming the file, and the command line
//! giving byte-identical results for one mesh in three formats.

mod common;
#[path = "../../penumbra/tests/mesh_formats/write.rs"]
mod write;

use std::path::Path;
use std::time::Instant;

use common::cli::{TempDir, cmd, pen, run};
use common::data_model;
use glam::Vec3;
use penumbra::scene::{
    Mesh, MeshFormat, NO_NORMAL, SMOOTH_DEFAULT, load_mesh, load_mesh_file, load_obj, procedural, write_obj,
};
use serde_json::json;
use write::{Gltf, Ply, data_uri, glb, gltf_parts, ply, ply_strips, scene_parts, stripify, write_gltf};

const PLY_FORMS: [(Ply, bool, &str); 5] = [
    (Ply::Ascii, false, "ascii"),
    (Ply::LittleEndian, false, "le"),
    (Ply::BigEndian, false, "be"),
    (Ply::Ascii, true, "ascii-extras"),
    (Ply::BigEndian, true, "be-extras"),
];
const GLTF_FORMS: [Gltf; 3] = [Gltf::External, Gltf::DataUri, Gltf::Glb];

/// Writes `mesh` in every form; returns (form, path).
fn every_form(dir: &TempDir, name: &str, mesh: &Mesh) -> Vec<(String, std::path::PathBuf)> {
    let mut out = Vec::new();
    for (format, extras, tag) in PLY_FORMS {
        let path = dir.0.join(format!("{name}-{tag}.ply"));
        std::fs::write(&path, ply(mesh, format, extras)).unwrap();
        out.push((format!("PLY {tag}"), path));
    }
    let (json, bin) = gltf_parts(mesh);
    for form in GLTF_FORMS {
        let path = write_gltf(&dir.0, &format!("{name}-{form:?}"), form, json.clone(), &bin);
        out.push((format!("glTF {form:?}"), path));
    }
    out
}

/// `mesh` (as its OBJ reads) read back from every form: identical
/// positions and triangles, through both entry points.
fn same_in_every_form(dir: &TempDir, name: &str, obj: &Mesh) {
    for (form, path) in every_form(dir, name, obj) {
        let mesh = load_mesh(&path).unwrap_or_else(|e| panic!("{name} as {form}: {e}"));
        assert!(mesh.positions == obj.positions, "{name} as {form}: positions differ");
        assert!(mesh.triangles == obj.triangles, "{name} as {form}: triangles differ");
        let file = load_mesh_file(&path).unwrap_or_else(|e| panic!("{name} as {form}: {e}"));
        assert!(file.mesh == mesh, "{name} as {form}: load_mesh_file's mesh differs");
        assert_eq!(file.triangle_faces, (0..obj.triangles.len() as u32).collect::<Vec<_>>());
    }
}

#[test]
fn procedural_meshes_read_the_same_in_every_format() {
    let dir = TempDir::new("formats_procedural");
    for (name, mesh) in procedural::all_scenes() {
        let obj_path = dir.write(&format!("{name}.obj"), write_obj(&mesh, name));
        let obj = load_obj(Path::new(&obj_path)).unwrap();
        assert_eq!(load_mesh(Path::new(&obj_path)).unwrap(), obj);
        same_in_every_form(&dir, name, &obj);
    }
}

/// The shared models, and the time each form takes to load (`--release`).
#[test]
fn shared_models_read_the_same_in_every_format() {
    let dir = TempDir::new("formats_shared");
    for name in ["stanford-bunny.obj", "cow.obj"] {
        let Some(path) = data_model(name) else { return };
        let obj = load_obj(&path).unwrap();
        same_in_every_form(&dir, name, &obj);
        // The best of 20 loads (the machine may be busy), in ms.
        let time = |path: &Path| {
            (0..20)
                .map(|_| {
                    let start = Instant::now();
                    load_mesh(path).unwrap();
                    start.elapsed().as_secs_f64() * 1e3
                })
                .fold(f64::INFINITY, f64::min)
        };
        let ply_le = dir.0.join(format!("{name}-le.ply"));
        let ply_ascii = dir.0.join(format!("{name}-ascii.ply"));
        let glb = dir.0.join(format!("{name}-Glb.glb"));
        println!(
            "{name} ({} vertices, {} triangles), load_mesh, best of 20: OBJ {:.1} ms, ASCII PLY {:.1} ms, binary PLY {:.1} ms, \
             GLB {:.1} ms",
            obj.positions.len(),
            obj.triangles.len(),
            time(&path),
            time(&ply_ascii),
            time(&ply_le),
            time(&glb)
        );
    }
}

#[test]
fn ply_normals_colours_quads_and_skipped_elements() {
    let text = "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nelement vertex 5\r\nproperty float x\r\n\
                property float y\r\nproperty float z\r\nproperty float nx\r\nproperty float ny\r\nproperty float nz\r\n\
                property float red\r\nproperty float green\r\nproperty float blue\r\nelement range_grid 2\r\n\
                property list uchar int vertex_indices\r\nelement face 2\r\nproperty uchar flags\r\n\
                property list ushort uint vertex_index\r\nend_header\r\n\
                0 0 0 0 0 1 1 0 0\r\n1 0 0 0 0 2 0 1 0\r\n1 1 0 0 0 1 0 0 1\r\n0 1 0 0 0 1 0.5 0.5 0.5\r\n\
                0.5 1.5 0 0 0 1 0 0 0\r\n3 0 1 2\r\n0\r\n7 5 0 1 2 4 3\r\n0 3 0 2 3\r\n";
    let dir = TempDir::new("formats_ply_extras");
    let path = dir.write("hand.ply", text);
    let f = load_mesh_file(Path::new(&path)).unwrap();
    assert_eq!(f.mesh.positions.len(), 5);
    assert_eq!(
        f.mesh.triangles,
        [[0, 1, 2], [0, 2, 4], [0, 4, 3], [0, 2, 3]],
        "a pentagon fanned in file order, then a triangle"
    );
    assert_eq!(f.triangle_faces, [0, 0, 0, 1]);
    assert_eq!(f.normals[1], Vec3::new(0.0, 0.0, 2.0), "normals as written");
    assert_eq!(f.corner_normals, f.mesh.triangles);
    let colours = f.vertex_colors.as_ref().expect("float colours");
    assert_eq!(colours[0..2], [Vec3::X, Vec3::Y]);
    assert!(f.smoothing.iter().all(|&s| s == SMOOTH_DEFAULT));
    assert_eq!(f.materials.len(), 1);
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    let (normals, corners) = f.shading_normals();
    assert!(corners.iter().all(Option::is_some) && normals.iter().all(|n| *n == Vec3::Z));
}

#[test]
fn ply_binary_types_and_element_order() {
    // Big-endian doubles, a short list count, unsigned indices, and the
    // faces before the vertices they refer to.
    let mut bytes = b"ply\nformat binary_big_endian 1.0\nelement face 1\nproperty list short uint vertex_indices\n\
                      element vertex 3\nproperty double x\nproperty int8 y\nproperty uint16 z\n\
                      property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
        .to_vec();
    bytes.extend(3i16.to_be_bytes());
    for v in [2u32, 1, 0] {
        bytes.extend(v.to_be_bytes());
    }
    for (x, y, z) in [(0.0f64, 0i8, 0u16), (1.5, -1, 0), (0.0, 0, 300)] {
        bytes.extend(x.to_be_bytes());
        bytes.push(y as u8);
        bytes.extend(z.to_be_bytes());
        bytes.extend([255, 0, 51]);
    }
    let f = penumbra::scene::parse_ply(&bytes).unwrap();
    assert_eq!(
        f.mesh.positions,
        [Vec3::ZERO, Vec3::new(1.5, -1.0, 0.0), Vec3::new(0.0, 0.0, 300.0)]
    );
    assert_eq!(f.mesh.triangles, [[2, 1, 0]]);
    assert_eq!(f.vertex_colors.unwrap()[0], Vec3::new(1.0, 0.0, 0.2));
    assert_eq!(f.corner_normals, [[NO_NORMAL; 3]]);
}

#[test]
fn gltf_nodes_modes_normals_and_materials() {
    let dir = TempDir::new("formats_gltf_scene");
    let (json, bin) = scene_parts();
    let path = write_gltf(&dir.0, "scene", Gltf::External, json.clone(), &bin);
    let f = load_mesh_file(&path).unwrap();
    let m = &f.mesh;
    // The default scene only (not node 3), its tree depth first.
    let names: Vec<&str> = m.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["tri", "mirror"], "node names, else mesh names");
    assert_eq!(m.positions.len(), 3 + 4 + 4);
    // tri: scaled by 2, then moved by the parent's translation.
    assert_eq!(
        m.positions[..3],
        [
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(12.0, 0.0, 0.0),
            Vec3::new(10.0, 2.0, 0.0)
        ]
    );
    assert_eq!(m.triangles[0], [2, 1, 0], "u16 indices with a stride");
    // mirror: x negated (then the parent's +10), z + 5; strip, then fan.
    assert_eq!(m.positions[3 + 1], Vec3::new(9.0, 0.0, 5.0));
    assert_eq!(
        m.positions[7..],
        m.positions[3..7],
        "each primitive has its own vertices"
    );
    // Mirrored: corners 1 and 2 swapped to keep the triangles front-facing.
    let strip = [[3, 4, 5], [5, 4, 6]].map(|[a, b, c]| [a, c, b]);
    let fan = [[8, 9, 7], [9, 10, 7]].map(|[a, b, c]| [a, c, b]);
    assert_eq!(m.triangles[1..], [strip[0], strip[1], fan[0], fan[1]]);
    // In the file the strip's triangles and the fan's first face +z, the
    // fan's second -z (this vertex order folds a fan over): so in the world.
    let facing: Vec<f32> = (1..5).map(|t| m.face_normal(t).z.signum()).collect();
    assert_eq!(facing, [1.0, 1.0, 1.0, -1.0]);
    // The quad's NORMAL (+z), through the mirror, still +z; the fan has none.
    assert_eq!(f.normals[3..7], [Vec3::Z; 4]);
    assert_eq!(f.corner_normals[1], m.triangles[1]);
    assert_eq!(f.corner_normals[3], [NO_NORMAL; 3]);
    assert_eq!(
        f.smoothing,
        [0, SMOOTH_DEFAULT, SMOOTH_DEFAULT, 0, 0],
        "no NORMAL: flat"
    );
    // Materials: default, "red", the unnamed emissive one; in first-use order.
    let names: Vec<&str> = f.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["default", "red", "material 1"]);
    assert_eq!(f.materials[1].kd, Vec3::X);
    assert_eq!(f.materials[2].ke, Vec3::new(1.0, 0.5, 0.25));
    assert_eq!(f.triangle_materials, [1, 2, 2, 0, 0]);
    assert!(
        f.warnings.iter().any(|w| w.contains("mode Lines is not a surface")),
        "{:?}",
        f.warnings
    );
    // The same from a GLB and a data: URI.
    for form in [Gltf::Glb, Gltf::DataUri] {
        let other = write_gltf(&dir.0, &format!("scene-{form:?}"), form, json.clone(), &bin);
        assert_eq!(load_mesh(&other).unwrap(), f.mesh, "{form:?}");
    }
    // No default scene: every scene's roots, in order (node 3 first).
    let mut all = json.clone();
    all.as_object_mut().unwrap().remove("scene");
    let path = write_gltf(&dir.0, "all", Gltf::DataUri, all, &bin);
    let names: Vec<String> = load_mesh(&path).unwrap().objects.into_iter().map(|o| o.name).collect();
    assert_eq!(names, ["unused", "tri", "mirror"]);
}

#[test]
fn format_by_content_then_extension() {
    let dir = TempDir::new("formats_detect");
    let mesh = procedural::cube_with_hole();
    let obj = write_obj(&mesh, "cube");
    let detect = |name: &str, bytes: &[u8]| {
        let path = dir.write(name, bytes);
        MeshFormat::detect(Path::new(&path), bytes)
    };
    let (json, bin) = gltf_parts(&mesh);
    let mut embedded = json.clone();
    embedded["buffers"][0]["uri"] = data_uri(&bin).into();
    let gltf_text = serde_json::to_vec(&embedded).unwrap();
    let ply_bytes = ply(&mesh, Ply::LittleEndian, false);
    // Content wins over the extension.
    assert_eq!(detect("really-ply.obj", &ply_bytes).unwrap(), MeshFormat::Ply);
    assert_eq!(detect("really-glb.obj", &glb(&json, &bin)).unwrap(), MeshFormat::Glb);
    assert_eq!(detect("really-gltf.txt", &gltf_text).unwrap(), MeshFormat::Gltf);
    // An unknown extension or none: OBJ if it looks like OBJ text.
    assert_eq!(detect("cube.mesh", obj.as_bytes()).unwrap(), MeshFormat::Obj);
    assert_eq!(detect("cube", obj.as_bytes()).unwrap(), MeshFormat::Obj);
    // A known extension decides for content that shows no format.
    assert_eq!(detect("empty.obj", b"").unwrap(), MeshFormat::Obj);
    assert_eq!(detect("garbage.ply", b"\x00\x01garbage").unwrap(), MeshFormat::Ply);
    assert_eq!(detect("odd.GLB", b"{}").unwrap(), MeshFormat::Glb);
    let e = detect("solid.stl", b"solid cube\nfacet normal 0 0 1\n").unwrap_err();
    assert!(e.to_string().contains("solid.stl: unknown mesh format"), "{e}");
    assert!(e.to_string().contains("'.stl'") && e.to_string().contains("PLY"), "{e}");
    // Read through the entry point: the PLY in a `.obj`, the glTF in a `.txt`.
    for name in ["really-ply.obj", "really-gltf.txt", "cube.mesh"] {
        assert_eq!(
            load_mesh(&dir.0.join(name)).unwrap().triangles,
            mesh.triangles,
            "{name}"
        );
    }
}

/// `load_mesh` of `bytes` written to `name`: an error (exit code 2) whose
/// message starts with the file and holds every phrase.
fn refused(dir: &TempDir, name: &str, bytes: &[u8], phrases: &[&str]) {
    let path = dir.write(name, bytes);
    for e in [
        load_mesh(Path::new(&path)).unwrap_err(),
        load_mesh_file(Path::new(&path)).unwrap_err(),
    ] {
        let text = e.to_string();
        assert_eq!(e.exit_code(), 2, "{text}");
        assert!(text.starts_with(&format!("{path}: ")), "{name}: {text}");
        for p in phrases {
            assert!(text.contains(p), "{name}: {text} lacks {p:?}");
        }
    }
}

/// Bad files of each format, each with the message it should give.
fn bad_files(dir: &TempDir) -> Vec<(&'static str, Vec<u8>, Vec<&'static str>)> {
    let mesh = procedural::cube_with_hole();
    let le = ply(&mesh, Ply::LittleEndian, false);
    let (json, bin) = gltf_parts(&mesh);
    let mut bad_chunk = glb(&json, &bin);
    bad_chunk[12..16].copy_from_slice(&10_000u32.to_le_bytes());
    let mut missing = json.clone();
    missing["buffers"][0]["uri"] = "nowhere.bin".into();
    let mut sparse = json.clone();
    sparse["accessors"][1]["sparse"] = json!({ "count": 1,
        "indices": { "bufferView": 1, "componentType": 5125 }, "values": { "bufferView": 1 } });
    let mut out_of_range = bin.clone();
    let last = out_of_range.len() - 4;
    out_of_range[last..].copy_from_slice(&9999u32.to_le_bytes());
    let mut ints = json.clone();
    ints["accessors"][0]["componentType"] = 5125.into();
    let _ = dir;
    vec![
        ("truncated.ply", le[..le.len() - 7].to_vec(), vec!["face[", "the file ends here"]),
        (
            "promises.ply",
            format!("ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\n\
                     property float y\nproperty float z\nend_header\n{}", "\0".repeat(1000))
                .into_bytes(),
            vec!["header line 3", "1000000000 records", "1000 bytes follow the header"],
        ),
        ("garbage.ply", b"\x89PNG\r\n\x1a\n garbage".to_vec(), vec!["header line 1", "magic line 'ply'"]),
        ("no-faces.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n".to_vec(), vec!["no 'face' or 'tristrips' element", "element vertex (1 record, properties x y z)", "a point cloud"]),
        ("nan.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n".to_vec(), vec!["vertex[1].y (line 11)", "NaN", "finite"]),
        ("index.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n".to_vec(), vec!["face[0]", "vertex index 3 is out of range"]),
        ("bad-chunk.glb", bad_chunk, vec!["GLB chunk 0", "declares 10000 bytes"]),
        ("cut.glb", glb(&json, &bin)[..100].to_vec(), vec!["GLB header", "declares a length"]),
        ("missing-buffer.gltf", serde_json::to_vec(&missing).unwrap(), vec!["buffers[0]", "cannot read 'nowhere.bin'"]),
        ("sparse.glb", glb(&sparse, &bin), vec!["meshes[0] 'mesh' primitives[0]", "accessor 1 is sparse"]),
        ("range.glb", glb(&json, &out_of_range), vec!["indices accessor 1: index 9999", "out of range"]),
        ("ints.glb", glb(&ints, &bin), vec!["POSITION accessor 0 is UNSIGNED_INT VEC3", "only FLOAT VEC3"]),
        ("broken.gltf", b"{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [}".to_vec(), vec!["line 1 column"]),
        ("version1.gltf", br#"{"asset": {"version": "1.0"}}"#.to_vec(), vec!["asset.version", "only glTF 2.0"]),
        ("empty.gltf", br#"{"asset": {"version": "2.0"}}"#.to_vec(), vec!["no triangles"]),
        ("cube.stl", b"solid cube\nendsolid cube\n".to_vec(), vec!["unknown mesh format", "'.stl'"]),
    ]
}

#[test]
fn bad_files_are_errors_naming_the_file() {
    let dir = TempDir::new("formats_bad");
    for (name, bytes, phrases) in bad_files(&dir) {
        refused(&dir, name, &bytes, &phrases);
    }
}

// ---------------------------------------------------------------------------
// The command line
// ---------------------------------------------------------------------------

#[test]
fn cli_ao_is_byte_identical_for_obj_ply_and_glb() {
    let dir = TempDir::new("formats_cli_ao");
    let mesh = load_obj(&common::asset("cube-with-hole.obj")).unwrap();
    let obj = dir.write("m.obj", write_obj(&mesh, "m"));
    let ascii = dir.write("m-ascii.ply", ply(&mesh, Ply::Ascii, true));
    let binary = dir.write("m.ply", ply(&mesh, Ply::LittleEndian, false));
    let (json, bin) = gltf_parts(&mesh);
    let glb_path = write_gltf(&dir.0, "m", Gltf::Glb, json.clone(), &bin);
    let gltf_path = write_gltf(&dir.0, "m", Gltf::External, json, &bin);
    let mut csvs = Vec::new();
    for (i, input) in [obj, ascii, binary, path_s(&glb_path), path_s(&gltf_path)]
        .iter()
        .enumerate()
    {
        let csv = dir.p(&format!("ao{i}.csv"));
        pen(
            "ao --mesh {mesh} --method raycast --rays 16 --per-vertex {csv} --device cpu",
            &[("mesh", input), ("csv", &csv)],
        )
        .ok();
        csvs.push((input.clone(), std::fs::read(&csv).unwrap()));
    }
    assert_eq!(csvs[0].1.iter().filter(|&&b| b == b'\n').count(), mesh.positions.len());
    for (input, csv) in &csvs[1..] {
        assert!(*csv == csvs[0].1, "{input}: the CSV differs from the OBJ's");
    }
}

/// A PLY of triangle strips (as scanned models have them) and the same
/// triangles as OBJ: byte-identical per-vertex AO.
#[test]
fn cli_ao_is_byte_identical_for_strips_and_obj() {
    let dir = TempDir::new("formats_cli_strips");
    let mesh = procedural::sphere_on_plane();
    let stripped = stripify(&mesh.triangles);
    assert!(stripped.strips < mesh.triangles.len() / 2, "{} strips", stripped.strips);
    let as_stripped = Mesh::new(mesh.positions.clone(), stripped.triangles.clone()).unwrap();
    let obj = dir.write("m.obj", write_obj(&as_stripped, "m"));
    let strips = dir.write(
        "strips.ply",
        ply_strips(&mesh.positions, &[], &stripped.list, Ply::LittleEndian),
    );
    let mut csvs = Vec::new();
    for (i, input) in [&obj, &strips].into_iter().enumerate() {
        let csv = dir.p(&format!("ao{i}.csv"));
        pen(
            "ao --mesh {mesh} --method raycast --rays 16 --per-vertex {csv} --device cpu",
            &[("mesh", input), ("csv", &csv)],
        )
        .ok();
        csvs.push(std::fs::read(&csv).unwrap());
    }
    assert_eq!(csvs[0].iter().filter(|&&b| b == b'\n').count(), mesh.positions.len());
    assert!(csvs[1] == csvs[0], "the strips' CSV differs from the OBJ's");
}

fn path_s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

#[test]
fn cli_trace_raytrace_and_scenes_accept_every_format() {
    let dir = TempDir::new("formats_cli_trace");
    let mesh = procedural::sphere_on_plane();
    let ply_path = dir.write("m.ply", ply(&mesh, Ply::BigEndian, false));
    let (json, bin) = gltf_parts(&mesh);
    let glb_path = path_s(&write_gltf(&dir.0, "m", Gltf::Glb, json, &bin));
    let mut reports = Vec::new();
    for input in [&ply_path, &glb_path] {
        let out = pen(
            "trace --mesh {mesh} --width 16 --height 16 --device cpu --json",
            &[("mesh", input)],
        );
        out.ok();
        reports.push(out.json());
    }
    assert_eq!(reports[0]["cells_per_packet"], reports[1]["cells_per_packet"]);
    let png = dir.p("r.png");
    pen(
        "raytrace --method whitted --mesh {mesh} --width 16 --height 16 --out {png} --device cpu",
        &[("mesh", &glb_path), ("png", &png)],
    )
    .ok();
    let scene = dir.write(
        "scene.json",
        serde_json::to_vec(&json!({
            "meshes": { "a": "m.ply", "b": "m.glb" },
            "instances": [{ "mesh": "a" }, { "mesh": "b", "translate": [0, 5, 0] }]
        }))
        .unwrap(),
    );
    let csv = dir.p("scene.csv");
    pen(
        "ao --scene {scene} --method raycast --rays 4 --per-vertex {csv} --device cpu",
        &[("scene", &scene), ("csv", &csv)],
    )
    .ok();
}

#[test]
fn cli_bad_meshes_exit_2_naming_the_file() {
    let dir = TempDir::new("formats_cli_bad");
    let csv = dir.p("out.csv");
    for (name, bytes, phrases) in bad_files(&dir) {
        let path = dir.write(name, bytes);
        let all: Vec<&str> = [&[path.as_str()][..], &phrases].concat();
        for template in [
            "ao --mesh {mesh} --method raycast --rays 16 --per-vertex {csv} --device cpu",
            "trace --mesh {mesh} --width 8 --height 8 --device cpu --json",
        ] {
            run(&cmd(template, &[("mesh", &path), ("csv", &csv)])).bad_input(&all);
        }
    }
}
