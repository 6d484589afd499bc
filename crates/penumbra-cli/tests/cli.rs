//! The `penumbra` binary against the command-line contract (`CONTRACT.md`)
//! and the bad-input rule of DEVELOPERS.md: a clear error naming the file,
//! the field and the problem, exit code 2, nothing on stdout, and no panic.
//!
//! Every run passes `--device cpu` except the device and GPU tests, so the
//! file passes on a machine without any GPU adapter; the GPU tests check for
//! an adapter first and say when they skipped.
//!
//! Command lines are written as templates: `cmd("ao --mesh {mesh} --rays 8", &[("mesh", &path)])`
//! splits on whitespace first and then substitutes, so paths may contain spaces.

mod common;

use std::path::Path;

use common::cli::{Out, TempDir, asset_s, cmd, gpu_available, pen, run_env};
use common::{Rng, asset};
use serde_json::{Value, json};

// ---------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------

fn vertex_count(name: &str) -> usize {
    std::fs::read_to_string(asset(name))
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("v "))
        .count()
}

fn rays_bytes(rays: &[[f32; 6]]) -> Vec<u8> {
    rays.iter().flatten().flat_map(|c| c.to_le_bytes()).collect()
}

/// A ray straight down onto open-plane.obj.
const DOWN: [f32; 6] = [-500.0, 2.0, 500.0, 0.0, -1.0, 0.0];

fn read_hits(path: &str) -> Vec<(f32, u32)> {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(
        bytes.len() % 8,
        0,
        "{path}: size {} is not a multiple of 8",
        bytes.len()
    );
    bytes
        .chunks_exact(8)
        .map(|r| {
            (
                f32::from_le_bytes(r[0..4].try_into().unwrap()),
                u32::from_le_bytes(r[4..8].try_into().unwrap()),
            )
        })
        .collect()
}

/// Reads a per-vertex CSV, checking `index,ao` lines (no header) with indices
/// 0..n-1 in order and ao in [0, 1].
fn read_csv(path: &str) -> Vec<f32> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .enumerate()
        .map(|(i, line)| {
            let (index, ao) = line
                .split_once(',')
                .unwrap_or_else(|| panic!("{path}: line {line:?} is not index,ao"));
            assert_eq!(
                index.parse::<usize>().ok(),
                Some(i),
                "{path}: line {} has index {index:?}",
                i + 1
            );
            let ao: f32 = ao
                .parse()
                .unwrap_or_else(|_| panic!("{path}: ao {ao:?} is not a number"));
            assert!(
                (0.0..=1.0).contains(&ao),
                "{path}: ao {ao} of vertex {i} is outside [0, 1]"
            );
            ao
        })
        .collect()
}

/// The same bad mesh through the three subcommands that read `--mesh`; each
/// must fail with exit 2 naming the mesh file and every phrase.
fn mesh_fails_everywhere(d: &TempDir, mesh: &str, phrases: &[&str]) {
    let rays = d.write("ok-rays.f32", rays_bytes(&[DOWN]));
    let (hits, csv) = (d.p("hits.bin"), d.p("ao.csv"));
    let vars = [
        ("mesh", mesh),
        ("rays", rays.as_str()),
        ("hits", hits.as_str()),
        ("csv", csv.as_str()),
    ];
    let all: Vec<&str> = [&[mesh], phrases].concat();
    for template in [
        "trace-rays --mesh {mesh} --rays {rays} --out {hits} --device cpu",
        "trace-rays --mesh {mesh} --rays {rays} --out {hits} --device cpu --json",
        "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {csv} --device cpu",
        "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {csv} --device cpu --json",
        "trace --mesh {mesh} --width 8 --height 8 --device cpu",
        "trace --mesh {mesh} --width 8 --height 8 --device cpu --json",
    ] {
        pen(template, &vars).bad_input(&all);
    }
}

// ---------------------------------------------------------------------------
// 1. Malformed OBJ files (trace-rays, ao, trace)
// ---------------------------------------------------------------------------

#[test]
fn obj_vertex_with_two_coordinates() {
    let d = TempDir::new("obj_two_coords");
    let m = d.write("two.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    mesh_fails_everywhere(&d, &m, &["line 1", "no z coordinate"]);
}

#[test]
fn obj_non_numeric_coordinate() {
    let d = TempDir::new("obj_non_numeric");
    let m = d.write("word.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n");
    mesh_fails_everywhere(&d, &m, &["line 2", "'zero'", "not a number"]);
}

#[test]
fn obj_nan_and_inf_coordinates() {
    let d = TempDir::new("obj_nonfinite");
    let m = d.write("nan.obj", "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n");
    mesh_fails_everywhere(&d, &m, &["line 3", "finite"]);
    let m = d.write("inf.obj", "# comment\nv 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n");
    mesh_fails_everywhere(&d, &m, &["line 3", "finite"]);
    let m = d.write("neginf.obj", "v 0 0 0\nv 1 0 0\nv 0 1 -inf\nf 1 2 3\n");
    mesh_fails_everywhere(&d, &m, &["line 3", "finite"]);
    // Finite in f64 text, infinite as f32.
    let m = d.write("overflow.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n");
    mesh_fails_everywhere(&d, &m, &["line 2", "finite"]);
}

#[test]
fn obj_face_index_out_of_range() {
    let d = TempDir::new("obj_out_of_range");
    let m = d.write("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 7\n");
    mesh_fails_everywhere(&d, &m, &["line 5", "out of range"]);
}

#[test]
fn obj_face_index_zero() {
    let d = TempDir::new("obj_index_zero");
    let m = d.write("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    mesh_fails_everywhere(&d, &m, &["line 4", "index 0"]);
}

#[test]
fn obj_face_with_two_vertices() {
    let d = TempDir::new("obj_two_vertex_face");
    let m = d.write("edge.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n");
    mesh_fails_everywhere(&d, &m, &["line 5", "at least 3"]);
}

#[test]
fn obj_negative_index_before_first_vertex() {
    let d = TempDir::new("obj_negative_index");
    let m = d.write("negative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n");
    mesh_fails_everywhere(&d, &m, &["line 4", "before the first vertex"]);
}

#[test]
fn obj_empty_and_comment_only_files() {
    let d = TempDir::new("obj_empty");
    let m = d.write("empty.obj", "");
    mesh_fails_everywhere(&d, &m, &["no faces"]);
    let m = d.write("comments.obj", "# just a comment\n# and another\n\n");
    mesh_fails_everywhere(&d, &m, &["no faces"]);
    let m = d.write("vertices-only.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    mesh_fails_everywhere(&d, &m, &["no faces"]);
}

#[test]
fn obj_binary_garbage() {
    let d = TempDir::new("obj_garbage");
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let bytes: Vec<u8> = (0..4096).map(|_| (rng.f32() * 256.0) as u8).collect();
    let m = d.write("garbage.obj", bytes);
    // Whatever the parser trips on, it is a bad-input error naming the file.
    mesh_fails_everywhere(&d, &m, &[]);
}

#[test]
fn obj_directory_and_missing_file() {
    let d = TempDir::new("obj_not_a_file");
    std::fs::create_dir_all(d.0.join("folder.obj")).unwrap();
    mesh_fails_everywhere(&d, &d.p("folder.obj"), &["cannot read"]);
    mesh_fails_everywhere(&d, &d.p("missing.obj"), &["cannot read"]);
}

// ---------------------------------------------------------------------------
// 2. RAYS.f32 problems
// ---------------------------------------------------------------------------

fn trace_rays_with(d: &TempDir, rays: &str) -> Out {
    let (mesh, hits) = (asset_s("open-plane.obj"), d.p("hits.bin"));
    pen(
        "trace-rays --mesh {mesh} --rays {rays} --out {hits} --device cpu",
        &[("mesh", &mesh), ("rays", rays), ("hits", &hits)],
    )
}

#[test]
fn rays_size_not_a_multiple_of_24() {
    let d = TempDir::new("rays_size");
    let mut bytes = rays_bytes(&[DOWN]);
    bytes.push(0);
    let r = d.write("odd.f32", &bytes);
    trace_rays_with(&d, &r).bad_input(&[&r, "25 bytes", "24"]);
}

#[test]
fn rays_with_nan_or_infinite_component() {
    let d = TempDir::new("rays_nonfinite");
    let r = d.write(
        "nan.f32",
        rays_bytes(&[DOWN, DOWN, [0.0, 2.0, 0.0, 0.0, f32::NAN, 0.0]]),
    );
    trace_rays_with(&d, &r).bad_input(&[&r, "ray 2", "finite"]);
    let r = d.write(
        "inf.f32",
        rays_bytes(&[DOWN, [f32::INFINITY, 2.0, 0.0, 0.0, -1.0, 0.0]]),
    );
    trace_rays_with(&d, &r).bad_input(&[&r, "ray 1", "finite"]);
}

#[test]
fn rays_with_zero_direction() {
    let d = TempDir::new("rays_zero_dir");
    let r = d.write("zero.f32", rays_bytes(&[[0.0, 2.0, 0.0, 0.0, 0.0, 0.0]]));
    trace_rays_with(&d, &r).bad_input(&[&r, "ray 0", "zero"]);
}

#[test]
fn rays_file_missing() {
    let d = TempDir::new("rays_missing");
    let r = d.p("nowhere.f32");
    trace_rays_with(&d, &r).bad_input(&[&r, "cannot read"]);
}

#[test]
fn empty_rays_file_is_valid() {
    let d = TempDir::new("rays_empty");
    let (mesh, rays, hits) = (asset_s("open-plane.obj"), d.write("empty.f32", []), d.p("hits.bin"));
    let out = pen(
        "trace-rays --mesh {mesh} --rays {rays} --out {hits} --device cpu --json",
        &[("mesh", &mesh), ("rays", &rays), ("hits", &hits)],
    );
    let json = out.ok().json();
    assert_eq!(json["rays"], 0, "{}", out.describe());
    assert_eq!(json["hits"], 0, "{}", out.describe());
    assert_eq!(
        std::fs::metadata(&hits).unwrap().len(),
        0,
        "HITS.bin of no rays must be empty"
    );
}

// ---------------------------------------------------------------------------
// 3. Parameters
// ---------------------------------------------------------------------------

/// `ao` on cube-with-hole.obj writing `{csv}`, with `rest` appended.
fn ao(d: &TempDir, rest: &str) -> Out {
    let (mesh, csv, png) = (asset_s("cube-with-hole.obj"), d.p("out.csv"), d.p("out.png"));
    let template = format!("ao --mesh {{mesh}} --method raycast --per-vertex {{csv}} --device cpu {rest}");
    pen(&template, &[("mesh", &mesh), ("csv", &csv), ("png", &png)])
}

/// `trace` on cube-with-hole.obj, with `rest` appended.
fn trace(rest: &str) -> Out {
    let mesh = asset_s("cube-with-hole.obj");
    pen(
        &format!("trace --mesh {{mesh}} --device cpu {rest}"),
        &[("mesh", &mesh)],
    )
}

#[test]
fn ao_parameter_errors() {
    let d = TempDir::new("ao_params");
    ao(&d, "--rays 0").bad_input(&["--rays", "at least 1"]);
    ao(&d, "--rays 8 --radius 0").bad_input(&["--radius", "positive"]);
    ao(&d, "--rays 8 --radius=-1").bad_input(&["--radius", "positive"]);
    ao(&d, "--rays 8 --radius nan").bad_input(&["--radius"]);
    ao(&d, "--rays 8 --threads 0").bad_input(&["--threads"]);
    ao(&d, "--rays 8 --image {png} --width 0").bad_input(&["--width"]);
    assert!(
        !Path::new(&d.p("out.csv")).exists() && !Path::new(&d.p("out.png")).exists(),
        "no output may be written when the arguments are bad"
    );
}

#[test]
fn ao_without_any_output() {
    let mesh = asset_s("cube-with-hole.obj");
    pen(
        "ao --mesh {mesh} --method raycast --rays 8 --device cpu",
        &[("mesh", &mesh)],
    )
    .bad_input(&["--per-vertex", "--image", "output"]);
}

#[test]
fn ao_output_folder_missing() {
    let d = TempDir::new("ao_out_missing");
    let (mesh, csv, png) = (
        asset_s("cube-with-hole.obj"),
        d.p("no-such-folder/x.csv"),
        d.p("no-such-folder/x.png"),
    );
    let vars = [("mesh", mesh.as_str()), ("csv", csv.as_str()), ("png", png.as_str())];
    pen(
        "ao --mesh {mesh} --method raycast --rays 8 --per-vertex {csv} --device cpu",
        &vars,
    )
    .bad_input(&["--per-vertex", &csv, "does not exist"]);
    pen(
        "ao --mesh {mesh} --method raycast --rays 8 --image {png} --device cpu",
        &vars,
    )
    .bad_input(&["--image", &png, "does not exist"]);
}

/// `--radius -1`, a negative number as its own argument, must be taken as the
/// value of --radius (then rejected as not positive), or at least be rejected
/// with a message that names --radius.
#[test]
fn ao_negative_radius_as_separate_argument() {
    let d = TempDir::new("ao_negative_radius");
    ao(&d, "--rays 8 --radius -1").bad_input(&["--radius"]);
}

#[test]
fn ao_method_field_needs_a_receiver() {
    let d = TempDir::new("ao_method_field");
    let (mesh, csv) = (asset_s("cube-with-hole.obj"), d.p("out.csv"));
    pen(
        "ao --mesh {mesh} --method field --rays 8 --per-vertex {csv} --device cpu",
        &[("mesh", &mesh), ("csv", &csv)],
    )
    .bad_input(&["--method field", "--receiver"]);
}

#[test]
fn trace_parameter_errors() {
    trace("--width 0 --height 16").bad_input(&["--width"]);
    trace("--width 16 --height 0").bad_input(&["--height"]);
    trace("--width 100000 --height 100000").bad_input(&["--width", "--height"]);
    trace("--width 16 --height 16 --fov 0").bad_input(&["--fov"]);
    trace("--width 16 --height 16 --fov 180").bad_input(&["--fov"]);
    trace("--width 16 --height 16 --fov nan").bad_input(&["--fov"]);
    trace("--width 16 --height 16 --eye 1,2,3 --target 1,2,3").bad_input(&["--eye", "--target", "same point"]);
    trace("--width 16 --height 16 --threads 0").bad_input(&["--threads"]);
    trace("--width 16 --height 16 --eye 1,2").bad_input(&["--eye", "1,2"]);
    trace("--width 16 --height 16 --eye 1,nan,2").bad_input(&["--eye"]);
    trace("--width 16 --height 16 --target a,b,c").bad_input(&["--target"]);
}

#[test]
fn trace_mlrta_parameter_errors() {
    trace("--width 16 --height 16 --split-factor 8").bad_input(&["--split-factor", "square", "8"]);
    trace("--width 16 --height 16 --split-factor 1").bad_input(&["--split-factor"]);
    trace("--width 16 --height 16 --min-tile 2").bad_input(&["--min-tile", "2"]);
    trace("--width 16 --height 16 --tile 8 --min-tile 16").bad_input(&["--tile", "--min-tile"]);
    trace("--width 16 --height 16 --tile -1").bad_input(&["--tile"]);
    trace("--width 16 --height 16 --aa adaptive --aa-samples 5").bad_input(&["--aa-samples", "square"]);
    trace("--width 16 --height 16 --aa adaptive --aa-samples 0").bad_input(&["--aa-samples"]);
    trace("--width 16 --height 16 --aa sometimes").bad_input(&["--aa"]);
    trace("--width 16 --height 16 --mlrta maybe").bad_input(&["--mlrta"]);
    trace("--width 16 --height 16 --light 1,2").bad_input(&["--light", "1,2"]);
    trace("--width 16 --height 16 --single-ray --mlrta on").bad_input(&["--single-ray", "--mlrta"]);
}

#[test]
fn trace_rays_output_folder_missing() {
    let d = TempDir::new("trace_rays_out_missing");
    let (mesh, rays, out) = (
        asset_s("open-plane.obj"),
        d.write("r.f32", rays_bytes(&[DOWN])),
        d.p("nowhere/hits.bin"),
    );
    pen(
        "trace-rays --mesh {mesh} --rays {rays} --out {out} --device cpu",
        &[("mesh", &mesh), ("rays", &rays), ("out", &out)],
    )
    .bad_input(&["--out", &out, "does not exist"]);
}

#[test]
fn mesh_and_scene_options() {
    let mesh = asset_s("cube-with-hole.obj");
    pen("trace --width 8 --height 8 --device cpu", &[]).bad_input(&["--mesh", "required"]);
    pen(
        "trace --mesh {m} --scene {m} --width 8 --height 8 --device cpu",
        &[("m", &mesh)],
    )
    .bad_input(&["--mesh", "--scene", "cannot be used with"]);
    pen(
        "ao --receiver {m} --method raycast --rays 8 --device cpu",
        &[("m", &mesh)],
    )
    .bad_input(&["--mesh", "required"]);
}

// ---------------------------------------------------------------------------
// 4. Scene files (ao --scene, trace --scene)
// ---------------------------------------------------------------------------

/// `ao --scene` and `trace --scene` on a scene file; both must fail with exit
/// 2 and every phrase.
fn scene_fails(d: &TempDir, scene: &str, phrases: &[&str], env: &[(&str, Option<&str>)]) {
    let csv = d.p("scene.csv");
    let vars = [("scene", scene), ("csv", csv.as_str())];
    for template in [
        "ao --scene {scene} --method raycast --rays 4 --per-vertex {csv} --device cpu",
        "trace --scene {scene} --width 8 --height 8 --device cpu --json",
    ] {
        run_env(&cmd(template, &vars), env).bad_input(phrases);
    }
}

/// The corner as receiver and the sphere-on-plane mesh as `caster`.
fn corner_scene(caster: Value) -> Value {
    json!({
        "meshes": { "corner": asset_s("corner.obj"), "sphere": asset_s("sphere-on-plane.obj") },
        "instances": [ { "mesh": "corner", "role": "receiver" }, caster ],
    })
}

#[test]
fn scene_invalid_json() {
    let d = TempDir::new("scene_invalid_json");
    let s = d.write("broken.json", "{\n  \"meshes\": {},\n  \"instances\": [\n}\n");
    scene_fails(&d, &s, &[&s, "line 4", "column"], &[]);
    let s = d.write("binary.json", [0xffu8, 0xfe, 0x00, 0x7b]);
    scene_fails(&d, &s, &[&s], &[]);
}

#[test]
fn scene_unknown_field() {
    let d = TempDir::new("scene_unknown_field");
    let s = d.write(
        "typo.json",
        corner_scene(json!({ "mesh": "sphere", "role": "caster", "scael": 0.2 })).to_string(),
    );
    scene_fails(&d, &s, &[&s, "unknown field", "scael"], &[]);
}

#[test]
fn scene_instance_of_unknown_mesh() {
    let d = TempDir::new("scene_unknown_mesh");
    let s = d.write(
        "unknown-mesh.json",
        corner_scene(json!({ "mesh": "bunny", "role": "caster" })).to_string(),
    );
    scene_fails(&d, &s, &[&s, "instances[1].mesh", "bunny"], &[]);
}

#[test]
fn scene_scale_zero_and_negative() {
    let d = TempDir::new("scene_scale");
    for scale in [0.0, -2.0] {
        let scene = corner_scene(json!({ "mesh": "sphere", "role": "caster", "scale": scale }));
        let s = d.write("scale.json", scene.to_string());
        scene_fails(&d, &s, &[&s, "instances[1].scale", "positive"], &[]);
    }
}

#[test]
fn scene_zero_rotation_axis() {
    let d = TempDir::new("scene_rotation");
    let scene = corner_scene(json!({
        "mesh": "sphere", "role": "caster", "rotate": { "axis": [0, 0, 0], "degrees": 30 }
    }));
    let s = d.write("axis.json", scene.to_string());
    scene_fails(&d, &s, &[&s, "instances[1].rotate.axis", "zero"], &[]);
}

#[test]
fn scene_without_instances() {
    let d = TempDir::new("scene_empty");
    let scene = json!({ "meshes": { "corner": asset_s("corner.obj") }, "instances": [] });
    let s = d.write("empty.json", scene.to_string());
    scene_fails(&d, &s, &[&s, "instances", "empty"], &[]);
}

#[test]
fn scene_mesh_file_missing() {
    let d = TempDir::new("scene_mesh_missing");
    let scene = json!({ "meshes": { "ghost": "ghost-mesh.obj" }, "instances": [ { "mesh": "ghost" } ] });
    let s = d.write("ghost.json", scene.to_string());
    // Relative paths are relative to the scene file's folder.
    scene_fails(&d, &s, &[&d.p("ghost-mesh.obj"), "cannot read"], &[]);
}

#[test]
fn scene_environment_map_not_hdr() {
    let d = TempDir::new("scene_env_not_hdr");
    let hdr = d.write("fake.hdr", "this is plain text, not a Radiance HDR file\n");
    let mut scene = corner_scene(json!({ "mesh": "sphere", "role": "caster", "scale": 0.2 }));
    scene["environment"] = json!({ "map": "fake.hdr" });
    let s = d.write("env.json", scene.to_string());
    scene_fails(&d, &s, &[&hdr, "not a Radiance HDR"], &[]);
}

#[test]
fn scene_penumbra_data_unset() {
    let d = TempDir::new("scene_data_unset");
    let scene = json!({
        "meshes": { "bunny": "$PENUMBRA_DATA/models/stanford-bunny.obj" },
        "instances": [ { "mesh": "bunny" } ],
    });
    let s = d.write("data.json", scene.to_string());
    scene_fails(
        &d,
        &s,
        &[&s, "meshes.bunny", "PENUMBRA_DATA", "not set"],
        &[("PENUMBRA_DATA", None)],
    );
}

#[test]
fn scene_with_receiver_and_caster() {
    let d = TempDir::new("scene_valid");
    let scene = corner_scene(json!({
        "mesh": "sphere", "role": "caster", "scale": 0.2, "translate": [0.5, 0.0, 0.5],
        "rotate": { "axis": [0, 1, 0], "degrees": 30 }
    }));
    let (s, csv) = (d.write("scene.json", scene.to_string()), d.p("scene.csv"));
    let vars = [("scene", s.as_str()), ("csv", csv.as_str())];
    let out = pen(
        "ao --scene {scene} --method raycast --rays 16 --per-vertex {csv} --device cpu --json",
        &vars,
    );
    let json = out.ok().json();
    let ao = read_csv(&csv);
    assert_eq!(ao.len(), vertex_count("corner.obj"));
    assert_eq!(ao.len(), 3267);
    assert_eq!(json["points"], 3267, "{}", out.describe());
    // Only the caster occludes (the receiver does not shadow itself): some
    // vertices are fully open, some shadowed by the sphere and its plane.
    assert!(ao.contains(&1.0), "no vertex of the receiver is fully open");
    assert!(
        ao.iter().any(|&a| a < 1.0),
        "the caster shadows no vertex of the receiver"
    );

    pen(
        "trace --scene {scene} --width 16 --height 16 --device cpu --json",
        &vars,
    )
    .ok()
    .json();
}

#[test]
fn ao_with_receiver_option() {
    let d = TempDir::new("ao_receiver");
    let (caster, receiver, csv) = (asset_s("wall-on-floor.obj"), asset_s("open-plane.obj"), d.p("out.csv"));
    let vars = [
        ("caster", caster.as_str()),
        ("receiver", receiver.as_str()),
        ("csv", csv.as_str()),
    ];
    let out = pen(
        "ao --mesh {caster} --receiver {receiver} --method raycast --rays 16 --per-vertex {csv} --device cpu --json",
        &vars,
    );
    assert_eq!(
        out.ok().json()["points"],
        vertex_count("open-plane.obj"),
        "{}",
        out.describe()
    );
    assert_eq!(read_csv(&csv).len(), vertex_count("open-plane.obj"));
}

// ---------------------------------------------------------------------------
// 5. Device selection through the wgpu environment variables
// ---------------------------------------------------------------------------

const NO_SUCH_ADAPTER: (&str, Option<&str>) = ("WGPU_ADAPTER_NAME", Some("definitely-not-an-adapter"));

#[test]
fn device_gpu_with_unmatched_adapter_name_fails() {
    let d = TempDir::new("device_gpu_unmatched");
    let (mesh, csv) = (asset_s("cube-with-hole.obj"), d.p("out.csv"));
    let vars = [("mesh", mesh.as_str()), ("csv", csv.as_str())];
    for template in [
        "ao --mesh {mesh} --method raycast --rays 8 --per-vertex {csv} --device gpu",
        "trace --mesh {mesh} --width 8 --height 8 --device gpu --json",
    ] {
        run_env(&cmd(template, &vars), &[NO_SUCH_ADAPTER]).bad_input(&["WGPU_ADAPTER_NAME"]);
    }
}

#[test]
fn device_auto_with_unmatched_adapter_name_falls_back_to_cpu() {
    let d = TempDir::new("device_auto_unmatched");
    let (mesh, csv) = (asset_s("cube-with-hole.obj"), d.p("out.csv"));
    let args = cmd(
        "ao --mesh {mesh} --method raycast --rays 8 --per-vertex {csv} --device auto --json",
        &[("mesh", &mesh), ("csv", &csv)],
    );
    let out = run_env(&args, &[NO_SUCH_ADAPTER]);
    assert_eq!(out.ok().json()["device"], "cpu", "{}", out.describe());
    assert!(
        out.stderr.contains("CPU"),
        "auto must say on stderr that it uses the CPU\n{}",
        out.describe()
    );
    assert_eq!(read_csv(&csv).len(), vertex_count("cube-with-hole.obj"));
}

// ---------------------------------------------------------------------------
// 6. Contract shapes
// ---------------------------------------------------------------------------

#[test]
fn info_json_shape() {
    let out = pen("info --json", &[]);
    let json = out.ok().json();
    assert!(json["version"].is_string(), "{}", out.describe());
    let adapters = json["adapters"]
        .as_array()
        .unwrap_or_else(|| panic!("adapters\n{}", out.describe()));
    for a in adapters {
        for key in ["name", "backend", "device_type", "driver_info"] {
            assert!(a[key].is_string(), "adapter field {key}\n{}", out.describe());
        }
    }
    assert!(
        json["selected"].is_string() || json["selected"].is_null(),
        "{}",
        out.describe()
    );
}

#[test]
fn trace_rays_shape_and_known_hits() {
    let d = TempDir::new("trace_rays_shape");
    // open-plane.obj is y = 0; triangle 0 = (v1, v2, v4) covers z > x,
    // triangle 1 = (v1, v4, v3) covers z < x.
    let rays = [
        [-500.0, 2.0, 500.0, 0.0, -4.0, 0.0], // down onto triangle 0: t = 0.5
        [500.0, 2.0, -500.0, 0.0, -4.0, 0.0], // down onto triangle 1: t = 0.5
        [-500.0, 2.0, 500.0, 1.0, -1.0, 0.0], // slanted onto triangle 0: t = 2
        [-500.0, 2.0, 500.0, 0.0, 1.0, 0.0],  // away: miss
        [500.0, 2.0, -500.0, 3.0, 0.5, -2.0], // away: miss
    ];
    let (mesh, r, hits_path) = (
        asset_s("open-plane.obj"),
        d.write("rays.f32", rays_bytes(&rays)),
        d.p("hits.bin"),
    );
    let out = pen(
        "trace-rays --mesh {mesh} --rays {rays} --out {hits} --device cpu --json",
        &[("mesh", &mesh), ("rays", &r), ("hits", &hits_path)],
    );
    let json = out.ok().json();
    assert_eq!(json["rays"], 5, "{}", out.describe());
    assert_eq!(json["hits"], 3, "{}", out.describe());
    for key in ["build_ms", "trace_ms", "mrays_per_s"] {
        assert!(json[key].is_number(), "{key}\n{}", out.describe());
    }
    assert_eq!(json["device"], "cpu", "{}", out.describe());
    assert_eq!(std::fs::metadata(&hits_path).unwrap().len(), 8 * rays.len() as u64);
    let hits = read_hits(&hits_path);
    for (i, (t, tri)) in [(0.5, 0), (0.5, 1), (2.0, 0)].into_iter().enumerate() {
        assert!(
            (hits[i].0 - t).abs() <= 1e-6 * t,
            "ray {i}: t = {}, expected {t}",
            hits[i].0
        );
        assert_eq!(hits[i].1, tri, "ray {i}: triangle");
    }
    for (i, h) in hits.iter().enumerate().skip(3) {
        assert!(
            h.0 == f32::INFINITY && h.1 == 0xFFFF_FFFF,
            "ray {i} must miss as (+inf, 0xFFFFFFFF), got {h:?}"
        );
    }
}

#[test]
fn ao_per_vertex_shape() {
    let d = TempDir::new("ao_shape");
    let out = ao(&d, "--rays 64 --json");
    let json = out.ok().json();
    assert_eq!(json["method"], "raycast", "{}", out.describe());
    assert_eq!(json["rays_per_point"], 64, "{}", out.describe());
    assert_eq!(json["points"], vertex_count("cube-with-hole.obj"), "{}", out.describe());
    for key in ["build_ms", "ao_ms"] {
        assert!(json[key].is_number(), "{key}\n{}", out.describe());
    }
    assert_eq!(json["device"], "cpu", "{}", out.describe());
    let csv = d.p("out.csv");
    assert!(
        !std::fs::read_to_string(&csv).unwrap().starts_with("index"),
        "the CSV has no header"
    );
    let ao = read_csv(&csv);
    assert_eq!(ao.len(), vertex_count("cube-with-hole.obj"));
    assert!(
        ao.iter().any(|&a| a > 0.0 && a < 1.0),
        "cube-with-hole has partly occluded vertices"
    );
}

#[test]
fn ao_closed_box_is_zero_and_open_plane_is_one() {
    let d = TempDir::new("ao_box_plane");
    for (name, expected) in [("closed-box.obj", 0.0), ("open-plane.obj", 1.0)] {
        let (mesh, csv) = (asset_s(name), d.p("out.csv"));
        pen(
            "ao --mesh {mesh} --method raycast --rays 64 --per-vertex {csv} --device cpu",
            &[("mesh", &mesh), ("csv", &csv)],
        )
        .ok();
        let ao = read_csv(&csv);
        assert_eq!(ao.len(), vertex_count(name), "{name}");
        for (i, a) in ao.iter().enumerate() {
            assert_eq!(*a, expected, "{name}: vertex {i} has ao {a}, expected {expected}");
        }
    }
}

#[test]
fn ao_image_shape() {
    let d = TempDir::new("ao_image");
    let (mesh, png) = (asset_s("corner.obj"), d.p("ao.png"));
    let out = pen(
        "ao --mesh {mesh} --method raycast --rays 16 --image {png} --width 64 --height 48 --device cpu --json",
        &[("mesh", &mesh), ("png", &png)],
    );
    let json = out.ok().json();
    assert!(
        json["points"].as_u64().is_some_and(|p| p > 0 && p <= 64 * 48),
        "{}",
        out.describe()
    );
    assert_eq!(image::image_dimensions(&png).unwrap(), (64, 48));
}

#[test]
fn trace_json_shape() {
    let mesh = asset_s("corner.obj");
    let out = pen(
        "trace --mesh {mesh} --width 64 --height 64 --device cpu --json",
        &[("mesh", &mesh)],
    );
    let json = out.ok().json();
    for key in ["mrays_per_s", "trace_ms", "cells_per_packet", "isects_per_packet"] {
        assert!(json[key].is_number(), "{key}\n{}", out.describe());
    }
    assert!(json["cells_per_packet"].as_f64().unwrap() > 0.0, "{}", out.describe());
    assert_eq!(json["device"], "cpu", "{}", out.describe());
}

#[test]
fn trace_with_camera_and_image() {
    let d = TempDir::new("trace_camera");
    let (mesh, png) = (asset_s("corner.obj"), d.p("trace.png"));
    let out = pen(
        "trace --mesh {mesh} --width 32 --height 24 --eye 2,1.5,2 --target 0.5,0.5,0.5 --fov 60 --out {png} \
         --device cpu --json",
        &[("mesh", &mesh), ("png", &png)],
    );
    let json = out.ok().json();
    assert_eq!(json["camera"]["fov"], 60.0, "{}", out.describe());
    assert_eq!(image::image_dimensions(&png).unwrap(), (32, 24));
}

/// Without --json stdout is a short summary for a person: aligned `label
/// value` lines (what was computed, the device, the headline time, the
/// files written), no JSON in any of them.
#[test]
fn without_json_stdout_is_a_readable_summary() {
    let out = trace("--width 8 --height 8");
    out.ok();
    let lines: Vec<&str> = out.stdout.lines().collect();
    let labels: Vec<&str> = lines.iter().filter_map(|l| l.split_whitespace().next()).collect();
    assert_eq!(labels[..3], ["computed", "device", "time"], "{}", out.describe());
    assert!(lines[0].starts_with("computed  trace: "), "{}", out.describe());
    let column = lines[0].find("trace").unwrap();
    for line in &lines {
        assert!(!line.contains('{') && !line.contains('"'), "no JSON: {line}");
        assert!(line.len() > column && line[..column].ends_with("  "), "aligned: {line}");
    }
    assert!(lines[2].contains(" ms (trace)"), "{}", out.describe());
}

// ---------------------------------------------------------------------------
// 6b. trace: multi-level ray tracing options
// ---------------------------------------------------------------------------

/// `trace` on `mesh` into `d`, writing the shaded image to `png`, with JSON.
fn trace_png(d: &TempDir, mesh: &str, png: &str, rest: &str) -> (Value, Vec<u8>) {
    let (mesh, path) = (asset_s(mesh), d.p(png));
    let out = pen(
        &format!("trace --mesh {{mesh}} --out {{png}} --device cpu --json {rest}"),
        &[("mesh", &mesh), ("png", &path)],
    );
    let json = out.ok().json();
    (json, std::fs::read(&path).unwrap())
}

/// Packets with and without entry points, and single rays, are the same
/// geometric answer: the same hits, the same shadows, byte-identical images.
#[test]
fn trace_modes_give_identical_images() {
    let d = TempDir::new("trace_modes");
    for mesh in ["sphere-on-plane.obj", "closed-box.obj", "cube-with-hole.obj"] {
        let size = "--width 72 --height 40 --shadows";
        let tiles = "--tile 32 --min-tile 4";
        let (on, on_png) = trace_png(&d, mesh, "on.png", &format!("{size} {tiles} --mlrta on"));
        let (off, off_png) = trace_png(&d, mesh, "off.png", &format!("{size} {tiles} --mlrta off"));
        let (single, single_png) = trace_png(&d, mesh, "single.png", &format!("{size} --single-ray"));
        let (bvh, bvh_png) = trace_png(&d, mesh, "bvh.png", &format!("{size} --accel bvh"));
        assert_eq!((on["mlrta"].as_str(), off["mlrta"].as_str()), (Some("on"), Some("off")));
        assert_eq!(single["mlrta"], "single-ray");
        assert_eq!(
            (bvh["mlrta"].as_str(), bvh["accel"].as_str()),
            (Some("bvh-packets"), Some("bvh"))
        );
        assert!(bvh["bvh"]["nodes"].as_u64().unwrap() > 0, "{mesh}: {bvh}");
        assert_eq!(
            bvh["bvh_packets"]["packets"],
            18 * 10,
            "{mesh}: every 4x4 block a packet: {bvh}"
        );
        assert!(bvh["cells_per_packet"].as_f64().unwrap() >= 1.0, "{mesh}: {bvh}");
        assert_eq!(
            bvh_png, single_png,
            "{mesh}: --accel bvh packets and --single-ray images differ"
        );
        for (name, other) in [("off", &off), ("single-ray", &single), ("bvh packets", &bvh)] {
            assert_eq!(on["hits"], other["hits"], "{mesh}: hits with --mlrta on and {name}");
            assert_eq!(
                on["shadows"]["shadowed_hits"], other["shadows"]["shadowed_hits"],
                "{mesh}: shadowed hits with --mlrta on and {name}"
            );
        }
        assert!(
            on["hits"].as_u64().unwrap() > 0,
            "{mesh}: the default camera sees the mesh"
        );
        assert_eq!(on_png, off_png, "{mesh}: --mlrta on and off images differ");
        assert_eq!(on_png, single_png, "{mesh}: --mlrta on and --single-ray images differ");
        // Statistics: entry-point steps only with entry points; every packet
        // visits at least one cell; tiles split below the initial size.
        assert_eq!(off["ep_steps_per_packet"], 0.0, "{mesh}");
        assert!(on["ep_steps_per_packet"].as_f64().unwrap() > 0.0, "{mesh}");
        for j in [&on, &off] {
            assert!(j["cells_per_packet"].as_f64().unwrap() >= 1.0, "{mesh}: {j}");
            assert!(j["isects_per_packet"].as_f64().unwrap() >= 0.0, "{mesh}: {j}");
            assert!(
                j["shadows"]["cells_per_packet"].as_f64() > j["cells_per_packet"].as_f64(),
                "{mesh}: {j}"
            );
        }
        let tiles = &on["tiles"];
        assert_eq!((tiles["initial"].as_u64(), tiles["min"].as_u64()), (Some(32), Some(4)));
        // 72x40 in 32-pixel tiles is 3x2 tiles before any split.
        assert!(tiles["final"].as_u64().unwrap() >= 6, "{mesh}: {tiles}");
    }
}

#[test]
fn trace_light_and_default_shadows() {
    let d = TempDir::new("trace_light");
    let size = "--width 48 --height 48";
    let (plain, _) = trace_png(&d, "sphere-on-plane.obj", "plain.png", size);
    assert!(
        plain.get("shadows").is_none(),
        "no shadows without --light or --shadows: {plain}"
    );
    let (lit, _) = trace_png(&d, "sphere-on-plane.obj", "lit.png", &format!("{size} --shadows"));
    let shadows = &lit["shadows"];
    assert_eq!(shadows["shadow_rays"], lit["hits"], "one shadow ray per hit: {lit}");
    let shadowed = shadows["shadowed_hits"].as_u64().unwrap();
    assert!(
        shadowed > 0 && shadowed < lit["hits"].as_u64().unwrap(),
        "the sphere shadows part of the plane: {lit}"
    );
    // A light far below the plane: everything the camera sees from above is
    // in the plane's shadow or faces away.
    let (below, _) = trace_png(
        &d,
        "sphere-on-plane.obj",
        "below.png",
        &format!("{size} --light 0,-1000,0"),
    );
    assert_eq!(below["shadows"]["light"], json!([0.0, -1000.0, 0.0]));
    assert!(
        below["shadows"]["shadowed_hits"].as_u64().unwrap() >= shadowed,
        "{below}"
    );
}

#[test]
fn trace_dump_rays_feed_trace_rays() {
    let d = TempDir::new("trace_dump_rays");
    let (mesh, rays, hits) = (asset_s("corner.obj"), d.p("rays.f32"), d.p("hits.bin"));
    let vars = [
        ("mesh", mesh.as_str()),
        ("rays", rays.as_str()),
        ("hits", hits.as_str()),
    ];
    let traced = pen(
        "trace --mesh {mesh} --width 20 --height 12 --dump-rays {rays} --device cpu --json",
        &vars,
    )
    .ok()
    .json();
    assert_eq!(std::fs::metadata(&rays).unwrap().len(), 20 * 12 * 24);
    pen(
        "trace-rays --mesh {mesh} --rays {rays} --out {hits} --device cpu",
        &vars,
    )
    .ok();
    let hit_count = read_hits(&hits).iter().filter(|(t, _)| t.is_finite()).count();
    assert_eq!(traced["hits"].as_u64(), Some(hit_count as u64), "{traced}");
}

#[test]
fn trace_adaptive_aa_spends_fewer_rays_than_uniform() {
    let d = TempDir::new("trace_aa");
    let (mesh, aa_png, tiles_png) = (asset_s("sphere-on-plane.obj"), d.p("aa.png"), d.p("tiles.png"));
    let run = |mode: &str| -> Value {
        let template = format!(
            "trace --mesh {{mesh}} --width 64 --height 64 --tile 32 --min-tile 4 --aa {mode} --aa-samples 4 \
             --aa-reference --aa-image {{aa}} --tiles-image {{tiles}} --device cpu --json"
        );
        let vars = [
            ("mesh", mesh.as_str()),
            ("aa", aa_png.as_str()),
            ("tiles", tiles_png.as_str()),
        ];
        pen(&template, &vars).ok().json()
    };
    let uniform = run("uniform");
    assert_eq!(uniform["aa"]["rays"].as_u64(), Some(64 * 64 * 4), "{uniform}");
    let adaptive = run("adaptive");
    let aa = &adaptive["aa"];
    let rays = aa["rays"].as_u64().unwrap();
    assert!((64 * 64..64 * 64 * 4).contains(&rays), "{aa}");
    assert!(
        aa["complex_units"].as_u64().unwrap() > 0,
        "the sphere's outline is complex: {aa}"
    );
    let reference = &aa["reference"];
    let (adaptive_rmse, uniform_rmse) = (
        reference["rmse_edges"].as_f64().unwrap(),
        reference["uniform_rmse_edges"].as_f64().unwrap(),
    );
    println!("edge RMSE against 16 spp: adaptive {adaptive_rmse:.5}, uniform {uniform_rmse:.5}");
    assert!(reference["edge_pixels"].as_u64().unwrap() > 0, "{aa}");
    // Every edge pixel that shading can tell from its neighbours gets the
    // uniform samples, so the error is the same up to rounding.
    assert!(
        adaptive_rmse <= uniform_rmse * 1.001 + 1e-6,
        "adaptive anti-aliasing must keep the edge quality of uniform: {aa}"
    );
    assert_eq!(image::image_dimensions(&aa_png).unwrap(), (64, 64));
    assert_eq!(image::image_dimensions(&tiles_png).unwrap(), (64, 64));
}

// ---------------------------------------------------------------------------
// 7. Determinism
// ---------------------------------------------------------------------------

#[test]
fn ao_is_deterministic_per_seed_and_thread_count() {
    let d = TempDir::new("ao_determinism");
    let mesh = asset_s("cube-with-hole.obj");
    let csv = |name: &str, rest: &str| -> Vec<u8> {
        let path = d.p(name);
        let template =
            format!("ao --mesh {{mesh}} --method raycast --rays 64 --per-vertex {{csv}} --device cpu {rest}");
        pen(&template, &[("mesh", &mesh), ("csv", &path)]).ok();
        std::fs::read(&path).unwrap()
    };
    let a = csv("a.csv", "--seed 7");
    assert_eq!(
        a,
        csv("b.csv", "--seed 7"),
        "the same seed must give byte-identical CSVs"
    );
    assert_ne!(
        a,
        csv("c.csv", "--seed 8"),
        "a different seed must give a different CSV"
    );
    let t1 = csv("t1.csv", "--seed 7 --threads 1");
    let t2 = csv("t2.csv", "--seed 7 --threads 2");
    assert_eq!(t1, t2, "--threads 1 and --threads 2 must give byte-identical CSVs");
    assert_eq!(t1, a, "the thread count must not change the CSV");
    assert_eq!(csv("d1.csv", ""), csv("d2.csv", ""), "the default seed must repeat");
}

// ---------------------------------------------------------------------------
// 8. GPU against CPU (only with an adapter)
// ---------------------------------------------------------------------------

#[test]
fn gpu_ao_matches_cpu() {
    if !gpu_available() {
        return;
    }
    let d = TempDir::new("gpu_ao");
    let mesh = asset_s("corner.obj");
    let ao = |device: &str| -> Vec<f32> {
        let path = d.p(&format!("{device}.csv"));
        let out = pen(
            "ao --mesh {mesh} --method raycast --rays 64 --seed 11 --per-vertex {csv} --device {device} --json",
            &[("mesh", &mesh), ("csv", &path), ("device", device)],
        );
        assert_eq!(out.ok().json()["device"], device, "{}", out.describe());
        read_csv(&path)
    };
    let (gpu, cpu) = (ao("gpu"), ao("cpu"));
    assert_eq!(gpu.len(), cpu.len());
    let diffs: Vec<f32> = gpu.iter().zip(&cpu).map(|(g, c)| (g - c).abs()).collect();
    let worst = diffs.iter().copied().fold(0.0, f32::max);
    let mean = diffs.iter().map(|&x| x as f64).sum::<f64>() / diffs.len() as f64;
    println!("ao gpu vs cpu on corner.obj: worst {worst}, mean {mean:.3e}");
    // With 64 rays per vertex, the mean per-vertex difference bounds the
    // fraction of rays that differ. The kernel itself is held to >= 99.9% of
    // rays identical on the same tree (tests/gpu_twins.rs, `compare_ao`,
    // corner included); here each device builds its own tree
    // (`KdTreeSettings::for_cpu` on the CPU, `default` on the GPU), and the
    // rays of the corner's seam vertices start in a wall's plane, where a
    // hit at t ~ 1e-11 is found or not by the tree's cells
    // (docs/results/tracing.md, `Bvh8::contact`): measured 0.11% of rays
    // differing with the two trees, 0.05% with one. The shared models
    // (cow, bunny) differ in no vertex, the kitchen in 0.01% of its rays
    // with either tree.
    // Vertices on the seams also shoot rays grazing the walls, where the
    // GPU's ulp-different directions flip a few; the worst-vertex bound only
    // guards against gross errors.
    assert!(
        mean < 2e-3,
        "mean difference {mean} >= 2e-3: more than 0.2% of rays differ"
    );
    assert!(worst <= 8.0 / 64.0, "a vertex differs by {worst} (> 8/64)");
}

#[test]
fn gpu_trace_rays_matches_cpu() {
    if !gpu_available() {
        return;
    }
    let d = TempDir::new("gpu_trace_rays");
    let bounds = penumbra::scene::load_obj(&asset("sphere-on-plane.obj"))
        .unwrap()
        .bounds();
    let mut rng = Rng(2024);
    let rays: Vec<[f32; 6]> = (0..2000)
        .map(|_| {
            let o = bounds.center() + rng.vec3(-1.5, 1.5) * bounds.extent();
            let dir = bounds.min + rng.vec3(0.0, 1.0) * bounds.extent() - o;
            [o.x, o.y, o.z, dir.x, dir.y, dir.z]
        })
        .collect();
    let (mesh, r) = (asset_s("sphere-on-plane.obj"), d.write("rays.f32", rays_bytes(&rays)));
    let hits = |device: &str| -> Vec<(f32, u32)> {
        let path = d.p(&format!("{device}.bin"));
        let out = pen(
            "trace-rays --mesh {mesh} --rays {rays} --out {hits} --device {device} --json",
            &[("mesh", &mesh), ("rays", &r), ("hits", &path), ("device", device)],
        );
        assert_eq!(out.ok().json()["device"], device, "{}", out.describe());
        read_hits(&path)
    };
    let (gpu, cpu) = (hits("gpu"), hits("cpu"));
    assert_eq!((gpu.len(), cpu.len()), (rays.len(), rays.len()));
    let mut worst = 0f32;
    for (i, (g, c)) in gpu.iter().zip(&cpu).enumerate() {
        assert_eq!(
            g.0.is_finite(),
            c.0.is_finite(),
            "ray {i}: gpu {g:?}, cpu {c:?}: hit/miss differ"
        );
        if c.0.is_finite() {
            assert_eq!(g.1, c.1, "ray {i}: gpu {g:?}, cpu {c:?}: triangle differs");
            worst = worst.max((g.0 - c.0).abs() / c.0);
        } else {
            assert_eq!(*g, (f32::INFINITY, 0xFFFF_FFFF), "ray {i}: the GPU's miss record");
        }
    }
    let hit_count = cpu.iter().filter(|h| h.0.is_finite()).count();
    println!(
        "trace-rays gpu vs cpu: {hit_count} hits of {}, worst relative t difference {worst:.3e}",
        rays.len()
    );
    assert!(worst <= 1e-5, "t differs by {worst} relative");
    assert!(
        hit_count > 0 && hit_count < rays.len(),
        "the rays must include hits and misses"
    );
}

// ---------------------------------------------------------------------------
// 9. No panics
// ---------------------------------------------------------------------------

#[test]
fn bad_inputs_never_panic() {
    let d = TempDir::new("no_panics");
    let plane = asset_s("open-plane.obj");
    let vars = [
        ("plane", plane.clone()),
        ("nan", d.write("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")),
        (
            "huge",
            d.write(
                "huge.obj",
                "v 0 0 0\nv 3e38 0 0\nv 0 3e38 0\nf 1 2 3\nf 99999999999999999999 1 2\n",
            ),
        ),
        (
            "badrays",
            d.write("rays.f32", rays_bytes(&[[0.0, 2.0, 0.0, f32::NAN, -1.0, 0.0]])),
        ),
        ("half", d.write("half.f32", [0u8; 12])),
        ("scene", d.write("scene.json", [0xffu8, 0xfe, 0x00, 0x7b])),
        ("csv", d.p("out.csv")),
        ("png", d.p("out.png")),
        ("hits", d.p("hits.bin")),
    ];
    let vars: Vec<(&str, &str)> = vars.iter().map(|(k, v)| (*k, v.as_str())).collect();
    for template in [
        "trace-rays --mesh {nan} --rays {badrays} --out {hits} --device cpu",
        "trace-rays --mesh {plane} --rays {badrays} --out {hits} --device cpu --json",
        "trace-rays --mesh {plane} --rays {half} --out {hits} --device cpu",
        "trace-rays --mesh {huge} --rays {half} --out {hits} --device cpu --json",
        "ao --mesh {plane} --method raycast --rays 4294967295 --per-vertex {csv} --device cpu",
        "ao --mesh {plane} --method raycast --rays 8 --radius nan --per-vertex {csv} --device cpu",
        "ao --scene {scene} --method raycast --rays 8 --per-vertex {csv} --device cpu",
        "ao --mesh {plane} --method raycast --rays 8 --image {png} --width 0 --height 5 --device cpu",
        "ao --mesh {plane} --method raycast --rays 8 --image {png} --width 65536 --height 65536 --device cpu",
        "trace --mesh {plane} --width 100000 --height 100000 --device cpu",
        "trace --mesh {plane} --width 8 --height 8 --fov nan --device cpu",
        "trace --mesh {plane} --width 8 --height 8 --eye inf,0,0 --device cpu",
        "trace --mesh {plane} --width -8 --height 8 --device cpu",
        "trace --width 8 --height 8 --device cpu",
        "trace --mesh {plane} --width 8 --height 8 --device quantum",
        "frobnicate",
    ] {
        let out = pen(template, &vars); // asserts: no exit code 101, no "panicked"
        assert_eq!(out.code, 2, "bad input must exit with 2\n{}", out.describe());
        assert!(
            out.stdout.is_empty(),
            "stdout must be empty on error\n{}",
            out.describe()
        );
        assert!(
            !out.stderr.trim().is_empty(),
            "an error needs a message\n{}",
            out.describe()
        );
    }
}

/// A mesh whose only triangle has zero area and whose bounding box is a point:
/// success, or a bad-input error that names the mesh file; never a crash, and
/// never a message about options the user did not give.
#[test]
fn degenerate_mesh_is_handled_or_named() {
    let d = TempDir::new("degenerate");
    let mesh = d.write("degenerate.obj", "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n");
    let (rays, csv, hits) = (
        d.write("rays.f32", rays_bytes(&[DOWN])),
        d.p("out.csv"),
        d.p("hits.bin"),
    );
    let vars = [
        ("mesh", mesh.as_str()),
        ("rays", rays.as_str()),
        ("csv", csv.as_str()),
        ("hits", hits.as_str()),
    ];
    for template in [
        "ao --mesh {mesh} --method raycast --rays 8 --per-vertex {csv} --device cpu",
        "trace-rays --mesh {mesh} --rays {rays} --out {hits} --device cpu",
        "trace --mesh {mesh} --width 8 --height 8 --device cpu --json",
    ] {
        let out = pen(template, &vars);
        if out.code != 0 {
            out.bad_input(&[&mesh]);
        }
    }
}

/// The GPU packet kernel draws the CPU's image, with entry points and
/// shadows (the hits themselves are compared in tests/mlrta.rs).
#[test]
fn gpu_trace_packets_match_cpu() {
    if !gpu_available() {
        return;
    }
    let d = TempDir::new("gpu_trace_packets");
    let mesh = asset_s("sphere-on-plane.obj");
    let image = |device: &str, mlrta: &str| -> (Value, Vec<u8>) {
        let png = d.p(&format!("{device}-{mlrta}.png"));
        let out = pen(
            "trace --mesh {mesh} --width 80 --height 56 --tile 32 --shadows --mlrta {mlrta} --out {png} \
             --device {device} --json",
            &[("mesh", &mesh), ("png", &png), ("device", device), ("mlrta", mlrta)],
        );
        let json = out.ok().json();
        assert_eq!(json["device"], device, "{}", out.describe());
        (json, std::fs::read(&png).unwrap())
    };
    let (cpu, cpu_png) = image("cpu", "on");
    // Each device's own tree (`tracer::tree_params`), named in the JSON.
    assert_eq!(cpu["kdtree"]["traversal_cost"], 4.0);
    for mlrta in ["on", "off"] {
        let (gpu, gpu_png) = image("gpu", mlrta);
        assert_eq!(gpu["kdtree"]["traversal_cost"], 1.0);
        assert_eq!(gpu["hits"], cpu["hits"], "--mlrta {mlrta}");
        assert_eq!(
            gpu["shadows"]["shadowed_hits"], cpu["shadows"]["shadowed_hits"],
            "--mlrta {mlrta}"
        );
        assert!(
            gpu_png == cpu_png,
            "--mlrta {mlrta}: the GPU's image differs from the CPU's"
        );
    }
}

/// Every option a "does not apply" rule names is an option of its
/// subcommand (a misspelt id would never be given, so its rule could never fire).
#[test]
fn every_rule_names_a_real_option() {
    let lines = [
        "p ao --mesh m --method raycast --rays 1",
        "p raytrace --method whitted --mesh m",
        "p trace --mesh m --mlrta off",
        "p ssao --mesh m --estimator sphere --spp 1 --radius 1",
        "p prt --mesh m --env e",
        "p sweep field --mesh m --out d",
    ];
    for line in lines {
        let args: Vec<&str> = line.split_whitespace().collect();
        let options = penumbra_cli::rule_options(&args);
        assert!(options.len() > 3, "{line}: {options:?}");
        for (id, exists) in options {
            assert!(exists, "{line}: no option {id}");
        }
    }
}

/// One word for "compare against the ground truth": `--reference` (with
/// `--reference-rays`, `--reference-frames`) in prt, trace, ssao and sweep
/// as in ao and raytrace; the old spellings still work, hidden from help,
/// and give the same answers.
#[test]
fn the_reference_is_spelled_one_way_and_old_spellings_still_work() {
    let help = |sub: &str| {
        let args: Vec<String> = vec![sub.into(), "--help".into()];
        run_env(&args, &[]).ok().stdout.clone()
    };
    for (sub, new, old) in [
        ("prt", "--reference-rays", "--check-rays"),
        ("prt", "--reference-frames", "--check-frames"),
        ("trace", "--reference", "--aa-reference"),
        ("ssao", "--reference-rays", "--truth-rays"),
        ("ssao", "--screen-reference-spp", "--reference-spp "),
        ("sweep", "--reference-rays", "--truth-rays"),
    ] {
        let text = help(sub);
        assert!(text.contains(new), "{sub} --help lacks {new}");
        assert!(!text.contains(old), "{sub} --help shows the old {old}");
    }
    let d = TempDir::new("reference-spelling");
    let probe = common::cli::write_probe(&d, common::cli::SKY, common::cli::GROUND);
    let prt = "prt --animated cloth --env {env} --frames 2 --self-check off --device cpu --json";
    let error = |extra: &str| {
        let j = pen(&format!("{prt} {extra}"), &[("env", &probe)]).ok().json();
        j["transfer_l2_error"].as_f64().unwrap()
    };
    let new = error("--reference --reference-rays 64 --reference-frames 1");
    let old = error("--check --check-rays 64 --check-frames 1");
    assert_eq!(new, old);
    let mesh = asset_s("sphere-on-plane.obj");
    let trace = "trace --mesh {mesh} --width 32 --height 24 --aa adaptive --device cpu --json";
    let aa = |extra: &str| pen(&format!("{trace} {extra}"), &[("mesh", &mesh)]).ok().json()["aa"].clone();
    let (new, old) = (aa("--reference"), aa("--aa-reference"));
    assert!(
        new["reference"]["rmse_edges"].is_number(),
        "--reference adds the comparison: {new}"
    );
    assert_eq!(new["reference"], old["reference"]);
    assert!(aa("")["reference"].is_null());
}

/// `--shadows` takes on/off as prt spells it; the bare flag still means on.
#[test]
fn trace_shadows_are_spelled_as_in_prt() {
    let mesh = asset_s("sphere-on-plane.obj");
    let trace = "trace --mesh {mesh} --width 32 --height 24 --device cpu --json";
    let shadows = |extra: &str| pen(&format!("{trace} {extra}"), &[("mesh", &mesh)]).ok().json()["shadows"].clone();
    let (bare, on) = (shadows("--shadows"), shadows("--shadows on"));
    assert!(
        bare["shadow_rays"].as_u64() > Some(0),
        "--shadows traces shadow rays: {bare}"
    );
    assert_eq!(bare, on);
    assert!(shadows("--shadows off").is_null());
    assert!(shadows("").is_null());
}

/// Random rays from a box three times the mesh's, aimed at points of its
/// box, and rays from eight corners fanned over it (coherent, as a camera's).
fn rays_at(rng: &mut common::Rng, lo: glam::Vec3, hi: glam::Vec3, n: usize) -> Vec<penumbra::geom::ray::Ray> {
    let (c, e) = ((lo + hi) * 0.5, hi - lo);
    (0..n)
        .map(|k| {
            let target = lo + e * rng.vec3(0.0, 1.0);
            let o = if k % 2 == 0 {
                c + e * rng.vec3(-1.5, 1.5)
            } else {
                let corner = glam::Vec3::new(
                    (k & 2) as f32 - 1.0,
                    (k & 4) as f32 / 2.0 - 1.0,
                    (k & 8) as f32 / 4.0 - 1.0,
                );
                c + e * corner * 1.2
            };
            penumbra::geom::ray::Ray::new(o, target - o)
        })
        .collect()
}

/// `trace-rays --accel bvh|kdtree` write the same hit file; the JSON names
/// the BVH's cost only when it was built.
#[test]
fn trace_rays_accel_writes_the_same_hits() {
    let d = TempDir::new("bvh_accel");
    let mesh_path = common::asset("sphere-on-plane.obj");
    let mesh = penumbra::scene::load_mesh(&mesh_path).unwrap();
    let b = mesh.bounds();
    let rays = rays_at(&mut common::Rng(3), b.min, b.max, 5000);
    let rays_file = d.write("rays.f32", bytemuck::cast_slice::<penumbra::geom::ray::Ray, u8>(&rays));
    let mesh_s = asset_s("sphere-on-plane.obj");
    let mut files = Vec::new();
    for accel in ["bvh", "kdtree"] {
        let hits = d.p(&format!("hits-{accel}.bin"));
        let out = pen(
            "trace-rays --mesh {mesh} --rays {rays} --out {hits} --device cpu --accel {accel} --json",
            &[
                ("mesh", &mesh_s),
                ("rays", &rays_file),
                ("hits", &hits),
                ("accel", accel),
            ],
        );
        let json = out.ok().json();
        assert_eq!(json["rays"], 5000);
        assert_eq!(json["bvh"].is_object(), accel == "bvh", "{}", out.describe());
        if accel == "bvh" {
            assert!(json["bvh"]["nodes"].as_u64().unwrap() > 0);
        }
        files.push(std::fs::read(&hits).unwrap());
    }
    assert_eq!(files[0], files[1], "the two structures' hit files differ");
}
