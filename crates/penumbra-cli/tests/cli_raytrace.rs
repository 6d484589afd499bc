//! `penumbra raytrace --method whitted` as the contract specifies it: JSON
//! fields, PNG/EXR/PFM outputs, frames along a path, devices, and bad input
//! (exit code 2 naming the file, the line or option and the problem,
//! nothing on stdout, no panic); missing MTL and texture files are warnings.

mod common;

use common::cli::{TempDir, asset_s, cmd, gpu_available, pen, run};
use penumbra::whitted::image::read_pfm;

const BASE: &str = "raytrace --method whitted --width 48 --height 36";

fn scene(name: &str) -> String {
    asset_s(&format!("raytrace/{name}.json"))
}

#[test]
fn contract_form_writes_the_image_and_the_json_fields() {
    let dir = TempDir::new("rt-contract");
    let devices: &[&str] = if gpu_available() { &["cpu", "gpu"] } else { &["cpu"] };
    for device in devices {
        for ext in ["png", "exr", "pfm"] {
            let out = dir.p(&format!("img-{device}.{ext}"));
            let r = pen(
                &format!("{BASE} --scene {{scene}} --out {{out}} --device {device} --json"),
                &[("scene", &scene("checker-spheres")), ("out", &out)],
            );
            let j = r.ok().json();
            for key in [
                "method",
                "width",
                "height",
                "frames",
                "rays",
                "render_ms",
                "mrays_per_s",
                "max_depth",
                "device",
                "build_ms",
            ] {
                assert!(j.get(key).is_some(), "missing {key}\n{}", r.describe());
            }
            assert_eq!(j["method"], "whitted");
            assert_eq!(j["device"], *device);
            assert_eq!(j["max_depth"], 5);
            assert_eq!(j["rays"]["primary"], 48 * 36);
            for kind in ["shadow", "reflection", "refraction"] {
                assert!(j["rays"][kind].as_u64().unwrap() > 0, "{kind}\n{}", r.describe());
            }
            let size = if ext == "pfm" {
                let (w, h, _) = read_pfm(std::path::Path::new(&out)).unwrap();
                (w, h)
            } else {
                let img = image::open(&out).unwrap();
                (img.width(), img.height())
            };
            assert_eq!(size, (48, 36));
        }
        // Linear radiance: the PFM and the EXR hold the same floats.
        let (w, h, pfm) = read_pfm(std::path::Path::new(&dir.p(&format!("img-{device}.pfm")))).unwrap();
        assert_eq!((w, h), (48, 36));
        let exr = image::open(dir.p(&format!("img-{device}.exr"))).unwrap().into_rgb32f();
        for (a, b) in pfm.iter().zip(exr.pixels()) {
            assert_eq!(a.to_array(), b.0);
        }
    }
}

#[test]
fn knobs_change_what_they_should() {
    let s = scene("checker-spheres");
    let rays = |extra: &str| {
        let r = pen(
            &format!("{BASE} --scene {{s}} --device cpu --json {extra}"),
            &[("s", &s)],
        );
        r.ok().json()
    };
    let base = rays("");
    let flat = rays("--max-depth 0");
    assert_eq!(flat["rays"]["reflection"], 0);
    assert_eq!(flat["rays"]["refraction"], 0);
    let aa = rays("--spp 4");
    assert_eq!(aa["rays"]["primary"], 4 * 48 * 36);
    let single = rays("--packets off");
    assert_eq!(single["rays"], base["rays"], "packets change the speed, not the rays");
    assert_eq!(single["path"], "cpu-single");
    let packets = rays("--packets on");
    assert_eq!(packets["rays"], base["rays"]);
    assert_eq!(packets["path"], "cpu-packets");
    // auto: two triangles and three spheres are traced ray by ray.
    assert_eq!(base["path"], "cpu-single");
    let fresnel = rays("--fresnel on");
    assert_eq!(fresnel["fresnel"], true);
    let tree = rays("--ray-tree 24,20");
    let nodes = tree["ray_tree"]["nodes"].as_array().unwrap();
    assert!(!nodes.is_empty());
    assert_eq!(nodes[0]["kind"], "primary");
}

#[test]
fn emissive_faces_light_an_obj_and_light_samples_multiply_lights() {
    let mesh = asset_s("raytrace/cornell-mirror-glass.obj");
    for (samples, lights) in [(1, 1), (8, 8)] {
        let r = pen(
            &format!("{BASE} --mesh {{m}} --light-samples {samples} --device cpu --json"),
            &[("m", &mesh)],
        );
        let j = r.ok().json();
        assert_eq!(j["lights"], lights);
        assert_eq!(j["emitters"], 1);
    }
}

#[test]
fn frames_follow_a_path_and_write_every_frame_with_a_pattern() {
    let dir = TempDir::new("rt-frames");
    let path = dir.write("path.txt", "# eye target fov\n0,3,8 0,0.8,0 45\n4,3,6 0,0.8,0 45\n");
    // The pattern's braces are the binary's, not the test template's.
    let mut args = cmd(
        &format!("{BASE} --scene {{s}} --frames 3 --path {{p}} --device cpu --json"),
        &[("s", &scene("checker-spheres")), ("p", &path)],
    );
    args.extend(["--out".to_string(), dir.p("frame_{:03}.png")]);
    let r = run(&args);
    let j = r.ok().json();
    assert_eq!(j["frames"], 3);
    assert_eq!(j["frame_ms"].as_array().unwrap().len(), 3);
    assert_eq!(j["rays"]["primary"], 3 * 48 * 36);
    for f in 0..3 {
        assert!(std::path::Path::new(&dir.p(&format!("frame_{f:03}.png"))).is_file());
    }
    assert_eq!(
        j["camera"]["eye"],
        serde_json::json!([4.0, 3.0, 6.0]),
        "the last frame's"
    );
    // Without a pattern, the last frame only.
    let last = dir.p("last.png");
    pen(
        &format!("{BASE} --scene {{s}} --frames 2 --out {{o}} --device cpu"),
        &[("s", &scene("checker-spheres")), ("o", &last)],
    )
    .ok();
    assert!(std::path::Path::new(&last).is_file());
}

#[test]
fn missing_mtl_and_texture_files_are_warnings() {
    let dir = TempDir::new("rt-warn");
    let obj = dir.write(
        "a.obj",
        "mtllib missing.mtl\nmtllib tex.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\nusemtl nowhere\nf 1 3 2\n",
    );
    dir.write("tex.mtl", "newmtl red\nKd 1 0 0\nmap_Kd red.png\n");
    let r = pen(&format!("{BASE} --mesh {{m}} --device cpu --json"), &[("m", &obj)]);
    let j = r.ok().json();
    assert_eq!(j["warnings"], 3, "{}", r.describe());
    for phrase in [
        "missing.mtl' not found",
        "red.png' (material 'red') not found",
        "usemtl 'nowhere'",
    ] {
        assert!(r.stderr.contains(phrase), "{phrase}\n{}", r.describe());
    }
}

#[test]
fn bad_mtl_obj_and_options_exit_2_naming_the_problem() {
    let dir = TempDir::new("rt-bad");
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let good = dir.write("good.obj", format!("{tri}f 1 2 3\n"));
    dir.write("bad.mtl", "newmtl m\nKd 0.5 abc 0.5\n");
    let with_bad_mtl = dir.write("badmtl.obj", format!("mtllib bad.mtl\n{tri}usemtl m\nf 1 2 3\n"));
    let bad_vn = dir.write("badvn.obj", format!("{tri}vn 0 0 nan\nf 1//1 2//1 3//1\n"));
    let bad_vn_index = dir.write("badvni.obj", format!("{tri}vn 0 0 1\nf 1//1 2//1 3//4\n"));
    dir.write("badni.mtl", "newmtl m\nNi -2\n");
    let with_bad_ni = dir.write("badni.obj", format!("mtllib badni.mtl\n{tri}usemtl m\nf 1 2 3\n"));
    let bad_scene = dir.write(
        "bad.json",
        format!(
            r#"{{ "meshes": {{ "a": "{}" }}, "instances": [ {{ "mesh": "a", "material": "gold" }} ] }}"#,
            good.replace('\\', "/")
        ),
    );
    let bad_sphere = dir.write(
        "sphere.json",
        format!(
            r#"{{ "meshes": {{ "a": "{}" }}, "instances": [ {{ "mesh": "a" }} ],
                 "spheres": [ {{ "center": [0, 0, 0], "radius": -1 }} ] }}"#,
            good.replace('\\', "/")
        ),
    );
    let path = dir.write("path.txt", "0,0,5 0,0,0\n");
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            format!("--mesh {with_bad_mtl}"),
            vec!["bad.mtl", "line 2", "not a number"],
        ),
        (format!("--mesh {with_bad_ni}"), vec!["badni.mtl", "line 2", "Ni"]),
        (format!("--mesh {bad_vn}"), vec!["badvn.obj", "line 4", "finite"]),
        (
            format!("--mesh {bad_vn_index}"),
            vec!["badvni.obj", "line 5", "normal index 4"],
        ),
        (
            format!("--scene {bad_scene}"),
            vec!["bad.json", "instances[0].material", "gold"],
        ),
        (
            format!("--scene {bad_sphere}"),
            vec!["sphere.json", "spheres[0].radius", "positive"],
        ),
        (format!("--mesh {good} --out {}", dir.p("x.jpg")), vec!["--out", ".png"]),
        (
            format!("--mesh {good} --max-depth 17"),
            vec!["--max-depth", "at most 16"],
        ),
        (format!("--mesh {good} --spp 0"), vec!["--spp"]),
        (format!("--mesh {good} --light-samples 0"), vec!["--light-samples"]),
        (format!("--mesh {good} --frames 0"), vec!["--frames"]),
        (format!("--mesh {good} --exposure 0"), vec!["--exposure"]),
        (
            format!("--mesh {good} --frames 2 --path {path}"),
            vec!["path.txt", "line 1", "2 fields"],
        ),
        (format!("--mesh {good} --ray-tree 48,0"), vec!["outside"]),
        (format!("--mesh {}", dir.p("none.obj")), vec!["none.obj", "cannot read"]),
        (format!("--mesh {good} --ambient 1,x,1"), vec!["--ambient"]),
    ];
    for (args, phrases) in cases {
        pen(&format!("{BASE} {args} --device cpu --json"), &[]).bad_input(&phrases);
    }
}

#[test]
fn gen_assets_writes_the_committed_scenes() {
    let dir = TempDir::new("rt-assets");
    pen("gen-assets --out {d} --json", &[("d", &dir.p("out"))]).ok();
    let written = dir.0.join("out/raytrace");
    // Every file, the textures' folder's included, by its path in the folder.
    fn files(dir: &std::path::Path, under: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let path = e.unwrap().path();
            let name = under.join(path.file_name().unwrap());
            if path.is_dir() {
                files(&path, &name, out);
            } else {
                out.push(name);
            }
        }
    }
    let mut names = Vec::new();
    files(&written, std::path::Path::new(""), &mut names);
    names.sort();
    assert_eq!(names.len(), 22, "{names:?}");
    assert!(
        names.contains(&std::path::PathBuf::from("textures/leaf.png")),
        "{names:?}"
    );
    for name in names {
        let committed = std::path::Path::new(&asset_s("raytrace")).join(&name);
        assert_eq!(
            std::fs::read(written.join(&name)).unwrap(),
            std::fs::read(&committed).unwrap_or_default(),
            "{name:?} differs from the committed assets/raytrace (run `penumbra gen-assets --out assets`)"
        );
    }
}

#[test]
fn bounded_method_reports_paths_errors_and_checks_and_refuses_bad_knobs() {
    let dir = TempDir::new("rt-bounded");
    let err = dir.p("why.png");
    let r = pen(
        "raytrace --method bounded --width 160 --height 120 --scene {scene} --frames 3 --reference \
         --check 4 --error-image {err} --epsilon 0.1 --split 4 --device cpu --json",
        &[("scene", &scene("checker-spheres")), ("err", &err)],
    );
    let j = r.ok().json();
    for key in [
        "pixels",
        "success_rate",
        "cells",
        "extremal_rays_traced",
        "memory_peak_bytes",
        "speedup",
        "error",
        "check",
    ] {
        assert!(j.get(key).is_some(), "missing {key} in {j}");
    }
    assert_eq!(j["error"]["violations"], 0, "{j}");
    assert_eq!(j["check"]["violations"], 0, "{j}");
    assert_eq!(j["per_frame"].as_array().map(|a| a.len()), Some(3));
    assert_eq!(j["rays"]["slow_path_on"], "cpu", "{j}");
    assert_eq!(j["bounded"]["slow_path"], "auto", "{j}");
    let image = image::open(&err).unwrap();
    assert_eq!((image.width(), image.height()), (160, 120));
    let good = scene("checker-spheres");
    for (args, phrases) in [
        ("--epsilon -0.1", vec!["--epsilon"]),
        ("--floor 0", vec!["--floor"]),
        ("--memory-mb 0", vec!["--memory-mb"]),
        ("--min-pixels 0", vec!["--min-pixels"]),
        ("--spp 4", vec!["--spp", "one sample"]),
        ("--slow-path gpu", vec!["--slow-path", "auto, device, cpu"]),
    ] {
        pen(
            &format!("raytrace --method bounded --width 48 --height 36 --scene {good} {args} --device cpu --json"),
            &[],
        )
        .bad_input(&phrases);
    }
    // On a GPU the slow path can be the Whitted kernel: the same image as
    // the CPU twin's slow path, within the kernel's tolerance.
    if gpu_available() {
        let shot = |slow: &str| {
            let out = dir.p(&format!("slow-{slow}.png"));
            let r = pen(
                &format!(
                    "raytrace --method bounded --width 96 --height 72 --scene {good} --frames 2 \
                     --slow-path {slow} --device gpu --out {out} --json"
                ),
                &[],
            );
            let j = r.ok().json();
            (j["rays"]["slow_path_on"].clone(), image::open(&out).unwrap().to_rgb8())
        };
        let ((on_gpu, a), (on_cpu, b)) = (shot("device"), shot("cpu"));
        assert_eq!((on_gpu.as_str(), on_cpu.as_str()), (Some("gpu"), Some("cpu")));
        let worst = a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| x.abs_diff(*y)).max();
        println!("--slow-path device against cpu: worst 8-bit difference {worst:?}");
        assert!(worst <= Some(1), "worst 8-bit difference {worst:?}");
    }
}

#[test]
fn mtl_rules_are_reported_and_spec_keeps_the_letter_of_the_spec() {
    // A dining room as Maya's OBJ exporter writes it: every material
    // illum 4, the opaque ones Tf 1 1 1 and Ni 1.
    let room = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../penumbra/tests/data/mtl/maya_room.obj");
    let room = room.to_str().unwrap();
    let view = "--eye 0,1.6,3.5 --target 0,1,0 --fov 70 --device cpu --json";
    for method in ["whitted", "bounded"] {
        let base = format!("raytrace --method {method} --width 48 --height 36 --mesh {{m}} {view}");
        let r = pen(&base, &[("m", room)]);
        let j = r.ok().json();
        let rules = j["material_rules"].as_array().unwrap();
        assert_eq!(rules.len(), 2, "{}", r.describe());
        assert_eq!(rules[0]["rule"], "invisible-glass");
        assert_eq!(
            rules[0]["materials"],
            serde_json::json!(["lambert2SG", "initialShadingGroup", "blinn1SG"])
        );
        assert_eq!(rules[1]["rule"], "maya-opacity");
        assert_eq!(rules[1]["materials"], serde_json::json!(["lambert4SG", "glassSG"]));
        assert!(
            r.stderr.contains("MTL rule 'invisible-glass': 3 materials")
                && r.stderr.contains("--mtl-rules spec keeps the letter of the spec"),
            "{}",
            r.describe()
        );
        assert_eq!(j["warnings"], 2, "one per rule\n{}", r.describe());
        let spec = pen(&format!("{base} --mtl-rules spec"), &[("m", room)]);
        let s = spec.ok().json();
        assert_eq!(s["material_rules"], serde_json::json!([]), "{}", spec.describe());
        assert!(!spec.stderr.contains("MTL rule"), "{}", spec.describe());
        if method == "whitted" {
            let refracted = |j: &serde_json::Value| j["rays"]["refraction"].as_u64().unwrap();
            assert!(refracted(&j) > 0, "the glass vase is in view");
            assert!(refracted(&s) > 10 * refracted(&j), "every surface is glass by the spec");
        }
    }
    // Shipped scenes: no rule.
    let r = pen(
        "raytrace --method whitted --width 48 --height 36 --mesh {m} --device cpu --json",
        &[("m", &asset_s("raytrace/cornell-mirror-glass.obj"))],
    );
    assert_eq!(r.ok().json()["material_rules"], serde_json::json!([]));
    pen(&format!("{BASE} --mesh {{m}} --mtl-rules letter"), &[("m", room)]).bad_input(&["--mtl-rules"]);
}

#[test]
fn a_room_seen_from_outside_by_the_default_camera_is_warned_about() {
    let dir = TempDir::new("rt-room");
    // A closed box whose faces look inward: a room.
    let room = dir.write(
        "room.obj",
        "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
         f 2 3 4 1\nf 8 7 6 5\nf 5 6 2 1\nf 3 7 8 4\nf 4 8 5 1\nf 6 7 3 2\n",
    );
    let warning = "meet the back of a face";
    let r = pen(&format!("{BASE} --mesh {{m}} --device cpu --json"), &[("m", &room)]);
    assert!(r.ok().stderr.contains(warning), "{}", r.describe());
    // From inside, or for a box whose faces look outward: no warning.
    let r = pen(
        &format!("{BASE} --mesh {{m}} --eye 0,0,0.5 --target 0,0,-1 --device cpu --json"),
        &[("m", &room)],
    );
    assert!(!r.ok().stderr.contains(warning), "{}", r.describe());
    let cube = dir.write(
        "cube.obj",
        "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n",
    );
    let r = pen(&format!("{BASE} --mesh {{m}} --device cpu --json"), &[("m", &cube)]);
    assert!(!r.ok().stderr.contains(warning), "{}", r.describe());
}
