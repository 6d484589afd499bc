//! `penumbra field build|info` and `penumbra ao --method field` against the
//! contract and the bad-input rule: exit code 2 with the file, field and
//! problem named, nothing on stdout, no panic.

mod common;

use common::cli::{TempDir, asset_s, gpu_available, pen};

/// `field build` of cube-with-hole.obj into `out` with `rest` appended.
fn build(out: &str, rest: &str) -> common::cli::Out {
    let mesh = asset_s("cube-with-hole.obj");
    pen(
        &format!("field build --mesh {{mesh}} -o {{out}} {rest}"),
        &[("mesh", &mesh), ("out", out)],
    )
}

#[test]
fn field_build_writes_the_file_the_contract_describes() {
    let d = TempDir::new("field_build");
    for (bits, directions) in [(8, "concentric"), (32, "polar"), (1, "rejection")] {
        let out = d.p(&format!("cube-{bits}.dfield"));
        let json = build(
            &out,
            &format!("--positions 100 --res 8 --bits {bits} --directions {directions} --json"),
        )
        .ok()
        .json();
        assert_eq!(json["maps"], 100);
        assert_eq!(json["res"], 8);
        assert_eq!(json["bits"], bits);
        assert_eq!(json["directions"], directions);
        assert!(json["build_ms"].as_f64().unwrap() > 0.0);
        let size = std::fs::metadata(&out).unwrap().len();
        assert_eq!(json["bytes"].as_u64(), Some(size));
        // The header and checksum around the maps.
        let maps: u64 = match bits {
            8 => 100 * 64,
            32 => 100 * 64 * 4,
            _ => 100 * (2 * 4 + 4),
        };
        assert_eq!(size, 96 + maps + 4, "{bits} bits");
        let info = pen("field info {f} --json", &[("f", &out)]).ok().json();
        assert_eq!(
            (info["maps"].clone(), info["bits"].clone()),
            (json["maps"].clone(), json["bits"].clone())
        );
    }
    // 4226 positions become the 65 x 65 octahedral grid.
    let json = build(&d.p("grid.dfield"), "--positions 4226 --res 2 --json")
        .ok()
        .json();
    assert_eq!(json["maps"], 4225);
}

#[test]
fn field_build_parameter_errors() {
    let d = TempDir::new("field_params");
    let out = d.p("x.dfield");
    build(&out, "--positions 0").bad_input(&["--positions"]);
    build(&out, "--positions -3").bad_input(&["--positions"]);
    build(&out, "--positions 100000").bad_input(&["--positions"]);
    build(&out, "--res 1").bad_input(&["--res", "1"]);
    build(&out, "--res 4096").bad_input(&["--res"]);
    build(&out, "--bits 4").bad_input(&["--bits", "32, 8 or 1"]);
    build(&out, "--directions spiral").bad_input(&["--directions"]);
    build(&out, "--threads 0").bad_input(&["--threads"]);
    build(&d.p("missing/x.dfield"), "").bad_input(&["-o", "does not exist"]);
    assert!(!std::path::Path::new(&out).exists());
}

#[test]
fn field_build_of_bad_meshes() {
    let d = TempDir::new("field_bad_mesh");
    let empty = d.write("empty.obj", "# nothing\n");
    let nan = d.write("nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
    for (mesh, phrase) in [(empty.as_str(), "empty.obj"), (nan.as_str(), "nan.obj")] {
        pen(
            "field build --mesh {mesh} -o {out} --res 4 --positions 4",
            &[("mesh", mesh), ("out", &d.p("o.dfield"))],
        )
        .bad_input(&[phrase]);
    }
}

#[test]
fn corrupt_field_files_are_refused() {
    let d = TempDir::new("field_corrupt");
    let good = d.p("good.dfield");
    build(&good, "--positions 16 --res 4").ok();
    let bytes = std::fs::read(&good).unwrap();
    let garbage = d.write(
        "garbage.dfield",
        b"this is not a field at all, not at all, no no no no no no no no no no no no no no no no no no no no no no no",
    );
    let truncated = d.write("truncated.dfield", &bytes[..bytes.len() - 10]);
    let mut flipped = bytes.clone();
    flipped[120] ^= 1;
    let flipped = d.write("flipped.dfield", &flipped);
    for (file, field) in [(&garbage, "magic"), (&truncated, "data"), (&flipped, "checksum")] {
        pen("field info {f}", &[("f", file)]).bad_input(&[file, field]);
        let (mesh, recv, csv) = (asset_s("cube-with-hole.obj"), asset_s("corner.obj"), d.p("o.csv"));
        pen(
            "ao --mesh {mesh} --receiver {recv} --method field --field {f} --rays 8 --per-vertex {csv} --device cpu",
            &[("mesh", &mesh), ("recv", &recv), ("f", file), ("csv", &csv)],
        )
        .bad_input(&[file, field]);
    }
    pen("field info {f}", &[("f", &d.p("none.dfield"))]).bad_input(&["none.dfield"]);
}

/// cube-with-hole.obj shrunk to 0.15 and moved into the corner (the
/// contract's `--mesh --receiver` form has no transforms).
fn cube_in_corner(d: &TempDir) -> String {
    let text = std::fs::read_to_string(asset_s("cube-with-hole.obj")).unwrap();
    let moved: Vec<String> = text
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(rest) => {
                let c: Vec<f32> = rest.split_whitespace().map(|x| x.parse().unwrap()).collect();
                format!("v {} {} {}", 0.15 * c[0] + 0.4, 0.15 * c[1] + 0.2, 0.15 * c[2] + 0.4)
            }
            None => l.to_string(),
        })
        .collect();
    d.write("cube-in-corner.obj", moved.join("\n"))
}

/// `ao` options for the cube caster and the corner receiver.
fn ao_field(d: &TempDir, rest: &str) -> common::cli::Out {
    let (mesh, recv, csv) = (cube_in_corner(d), asset_s("corner.obj"), d.p("ao.csv"));
    pen(
        &format!("ao --mesh {{mesh}} --receiver {{recv}} --method field --rays 32 --per-vertex {{csv}} {rest}"),
        &[("mesh", &mesh), ("recv", &recv), ("csv", &csv)],
    )
}

#[test]
fn ao_method_field_with_a_receiver() {
    let d = TempDir::new("ao_field");
    let json = ao_field(&d, "--positions 289 --res 16 --reference --device cpu --json")
        .ok()
        .json();
    assert_eq!(json["method"], "field");
    assert_eq!(json["points"], 3267);
    assert_eq!(json["rays_per_point"], 32);
    for key in ["build_ms", "ao_ms"] {
        assert!(json[key].as_f64().is_some(), "{key}: {json}");
    }
    let rms = json["reference"]["rms_error"].as_f64().unwrap();
    println!("cube over corner, 289 x 16x16 8-bit: RMS {rms:.4} against ray casting");
    assert!(rms < 0.03, "{json}");
    let csv = std::fs::read_to_string(d.p("ao.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3267);
    // A field built beforehand gives the same AO.
    let f = d.p("cube.dfield");
    pen(
        "field build --mesh {m} -o {o} --positions 289 --res 16",
        &[("m", &cube_in_corner(&d)), ("o", &f)],
    )
    .ok();
    ao_field(&d, &format!("--field {f} --device cpu --json")).ok();
    assert_eq!(std::fs::read_to_string(d.p("ao.csv")).unwrap(), csv);
}

#[test]
fn ao_method_field_errors() {
    let d = TempDir::new("ao_field_errors");
    ao_field(&d, "--frames 0 --device cpu").bad_input(&["--frames"]);
    ao_field(&d, "--res 1 --device cpu").bad_input(&["--res"]);
    ao_field(&d, "--positional everywhere --device cpu").bad_input(&["--positional"]);
    // A field of another mesh.
    let other = d.p("box.dfield");
    let boxed = asset_s("closed-box.obj");
    pen(
        "field build --mesh {m} -o {o} --positions 16 --res 4",
        &[("m", &boxed), ("o", &other)],
    )
    .ok();
    ao_field(&d, &format!("--field {other} --device cpu")).bad_input(&[&other, "triangles"]);
}

#[test]
fn ao_method_field_over_animation_frames() {
    let d = TempDir::new("ao_field_frames");
    let scene = d.write(
        "scene.json",
        format!(
            r#"{{
  "meshes": {{ "corner": "{}", "cube": "{}" }},
  "instances": [
    {{ "mesh": "corner", "role": "receiver" }},
    {{ "mesh": "cube", "role": "caster", "scale": 0.15, "translate": [0.4, 0.2, 0.4],
       "motion": {{ "degrees_per_frame": 20, "translate_per_frame": [0.05, 0, 0] }} }},
    {{ "mesh": "cube", "role": "caster", "scale": 0.1, "translate": [0.2, 0.3, 0.7] }}
  ]
}}"#,
            asset_s("corner.obj").replace('\\', "/"),
            asset_s("cube-with-hole.obj").replace('\\', "/")
        ),
    );
    let csv = d.p("ao.csv");
    let json = pen(
        "ao --scene {s} --method field --rays 16 --positions 100 --res 8 --frames 3 --per-vertex {csv} --device cpu --json",
        &[("s", &scene), ("csv", &csv)],
    )
    .ok()
    .json();
    assert_eq!(json["frames"], 3);
    assert_eq!(json["frame_ao_ms"].as_array().unwrap().len(), 3);
    // One field serves both instances of the cube.
    assert_eq!(json["fields"].as_array().unwrap().len(), 1);
    assert_eq!(json["casters"]["instances"], 2);

    // `{:04}`/`{}` in an output's name: a file per frame, each what a run
    // ending at that frame writes; a plain name gets the last frame.
    let run = |frames: u32, csv: &str, image: &str| {
        let mut args = common::cli::cmd(
            &format!("ao --scene {{s}} --method field --rays 16 --positions 100 --res 8 --frames {frames}"),
            &[("s", &scene)],
        );
        args.extend(["--per-vertex", csv, "--image", image].map(String::from));
        args.extend("--width 48 --height 32 --device cpu".split(' ').map(String::from));
        common::cli::run(&args).ok();
    };
    run(3, &d.p("v_{}.csv"), &d.p("f_{:04}.png"));
    for frame in 0..3 {
        run(frame + 1, &d.p("alone.csv"), &d.p("alone.png"));
        let read = |name: String| std::fs::read(d.p(&name)).unwrap();
        assert_eq!(
            read(format!("v_{frame}.csv")),
            read("alone.csv".into()),
            "frame {frame}"
        );
        assert_eq!(
            read(format!("f_{frame:04}.png")),
            read("alone.png".into()),
            "frame {frame}"
        );
    }
    assert_ne!(
        std::fs::read(d.p("v_0.csv")).unwrap(),
        std::fs::read(d.p("v_2.csv")).unwrap()
    );
    assert!(!std::path::Path::new(&d.p("v_3.csv")).exists());
}

#[test]
fn gpu_field_ao_matches_cpu() {
    if !gpu_available() {
        return;
    }
    let d = TempDir::new("gpu_ao_field");
    let run = |device: &str| -> Vec<f32> {
        let json = ao_field(&d, &format!("--positions 289 --res 16 --device {device} --json"))
            .ok()
            .json();
        assert_eq!(json["device"], device);
        std::fs::read_to_string(d.p("ao.csv"))
            .unwrap()
            .lines()
            .map(|l| l.split_once(',').unwrap().1.parse().unwrap())
            .collect()
    };
    let (gpu, cpu) = (run("gpu"), run("cpu"));
    let worst = gpu.iter().zip(&cpu).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    println!("per-vertex AO, GPU vs CPU field lookups: worst difference {worst}");
    // A ray whose vote the texture unit's weights flip changes AO by 1/32.
    assert!(worst <= 2.0 / 32.0 + 1e-6, "{worst}");
}

/// Objects that cast and receive: their self-occlusion is ray-cast (a field
/// cannot see it), the rest comes from the other objects' fields.
#[test]
fn ao_method_field_with_objects_that_cast_and_receive() {
    let d = TempDir::new("ao_field_both");
    let scene = d.write(
        "scene.json",
        format!(
            r#"{{
  "meshes": {{ "corner": "{}", "cube": "{}" }},
  "instances": [
    {{ "mesh": "corner", "role": "receiver" }},
    {{ "mesh": "cube", "role": "both", "scale": 0.15, "translate": [0.35, 0.17, 0.35] }},
    {{ "mesh": "cube", "role": "both", "scale": 0.12, "translate": [0.75, 0.14, 0.3],
       "rotate": {{ "axis": [0, 1, 0], "degrees": 30 }} }}
  ]
}}"#,
            asset_s("corner.obj").replace('\\', "/"),
            asset_s("cube-with-hole.obj").replace('\\', "/")
        ),
    );
    let csv = d.p("ao.csv");
    let json = pen(
        "ao --scene {s} --method field --rays 32 --positions 289 --res 16 --reference --per-vertex {csv} --device cpu --json",
        &[("s", &scene), ("csv", &csv)],
    )
    .ok()
    .json();
    let (all, fields) = (
        json["reference"]["rms_error"].as_f64().unwrap(),
        json["reference"]["fields_only"]["rms_error"].as_f64().unwrap(),
    );
    println!("two cubes that cast and receive: RMS {all:.4} (fields only {fields:.4})");
    assert!(
        json["self_occlusion_ms"].as_array().is_some_and(|a| a.len() == 1),
        "{json}"
    );
    assert_eq!(json["points"], 3267 + 2 * 192);
    assert!(all < 0.03 && fields < 0.03, "{json}");
}

/// Model only what the scene requires: a caster mesh out of every
/// receiver's reach at the AO radius gets no field, and `--json` names it
/// under `skipped` with the reason; with an infinite radius it is built.
#[test]
fn ao_field_skips_the_fields_no_receiver_needs() {
    let d = TempDir::new("ao_field_reach");
    let scene = format!(
        r#"{{"meshes": {{"floor": "{floor}", "near": "{cube}", "far": "{sphere}"}},
           "instances": [
             {{"mesh": "floor", "role": "receiver"}},
             {{"mesh": "near", "role": "caster", "translate": [0.3, 0.15, 0.3], "scale": 0.12}},
             {{"mesh": "far", "role": "caster", "translate": [9, 0, 0], "scale": 0.2}}]}}"#,
        floor = asset_s("corner.obj"),
        cube = asset_s("cube-with-hole.obj"),
        sphere = asset_s("sphere-on-plane.obj"),
    );
    let scene = d.write("scene.json", scene);
    let base = "ao --method field --scene {scene} --rays 16 --positions 258 --res 8 --per-vertex {csv} --json";
    let csv = d.p("ao.csv");
    let vars = [("scene", scene.as_str()), ("csv", csv.as_str())];
    let near = pen(&format!("{base} --radius 0.5"), &vars).ok().json();
    let built: Vec<&str> = near["fields"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["mesh"].as_str().unwrap())
        .collect();
    println!("radius 0.5: built {built:?}, skipped {}", near["skipped"]);
    assert_eq!(built, ["near"]);
    assert_eq!(near["skipped"][0]["what"], "field");
    assert_eq!(near["skipped"][0]["name"], "far");
    assert!(near["skipped"][0]["why"].as_str().unwrap().contains("radius 0.5"));
    let near_csv = std::fs::read(&csv).unwrap();
    let all = pen(base, &vars).ok().json();
    assert_eq!(all["fields"].as_array().unwrap().len(), 2);
    assert!(all["skipped"].as_array().unwrap().is_empty());
    // The far caster is beyond 0.5 of every receiver point: without the
    // radius it may occlude, with it the AO equals a run without it.
    let without_far = d.write(
        "near-only.json",
        std::fs::read_to_string(&scene).unwrap().replace(
            r#",
             {"mesh": "far", "role": "caster", "translate": [9, 0, 0], "scale": 0.2}"#,
            "",
        ),
    );
    assert_ne!(
        std::fs::read_to_string(&without_far).unwrap(),
        std::fs::read_to_string(&scene).unwrap()
    );
    let vars = [("scene", without_far.as_str()), ("csv", csv.as_str())];
    pen(&format!("{base} --radius 0.5"), &vars).ok();
    assert_eq!(std::fs::read(&csv).unwrap(), near_csv);
}
