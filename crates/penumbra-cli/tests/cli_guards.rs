//! Guards every subcommand shares: no output may overwrite an input (under
//! any spelling or link), options the chosen method does not use are
//! refused, `--device auto` skips software adapters, and a closed stdout
//! ends a run quietly.

mod common;

use std::io::Read;
use std::process::{Command, Stdio};

use common::cli::{TempDir, asset_s, pen, run};

/// The mesh copied into the test's folder (so a failure cannot hurt the asset).
fn copy_mesh(d: &TempDir) -> String {
    let mesh = d.p("mesh.obj");
    std::fs::copy(asset_s("sphere-on-plane.obj"), &mesh).unwrap();
    mesh
}

/// Every command's output given the path of an input, through the path
/// itself, `./`, `..`, a symbolic link and a hard link: exit 2 naming the
/// option, before any work, the input unchanged.
#[test]
fn an_output_that_is_an_input_is_refused_under_every_spelling() {
    let d = TempDir::new("guard_overwrite");
    let mesh = copy_mesh(&d);
    let original = std::fs::read(&mesh).unwrap();
    std::fs::create_dir_all(d.0.join("sub")).unwrap();
    std::os::unix::fs::symlink(&mesh, d.0.join("link.obj")).unwrap();
    std::fs::hard_link(&mesh, d.0.join("hard.obj")).unwrap();
    let rays = d.write("rays.f32", [0u8; 24]);
    let spellings = [
        mesh.clone(),
        format!("{}/./mesh.obj", d.p("")),
        format!("{}/sub/../mesh.obj", d.p("")),
        d.p("link.obj"),
        d.p("hard.obj"),
    ];
    let commands = [
        (
            "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {out}",
            "--per-vertex",
        ),
        ("ao --mesh {mesh} --method raycast --rays 4 --image {out}", "--image"),
        ("trace --mesh {mesh} --width 8 --height 8 --out {out}", "--out"),
        (
            "trace --mesh {mesh} --width 8 --height 8 --dump-rays {out}",
            "--dump-rays",
        ),
        (
            "ssao --mesh {mesh} --estimator sphere --spp 4 --radius 0.5 --width 8 --height 8 --out {out}",
            "--out",
        ),
        (
            "field build --mesh {mesh} --positions 2 --res 4 --bits 8 -o {out}",
            "-o",
        ),
        (
            "raytrace --method whitted --mesh {mesh} --width 8 --height 8 --out {out}",
            "--out",
        ),
        ("trace-rays --mesh {mesh} --rays {rays} --out {out}", "--out"),
    ];
    for (template, option) in commands {
        for out in &spellings {
            let r = pen(
                &format!("{template} --json"),
                &[("mesh", &mesh), ("out", out), ("rays", &rays)],
            );
            r.bad_input(&[option, "never overwrites an input"]);
            assert_eq!(
                std::fs::read(&mesh).unwrap(),
                original,
                "{template} with {out} changed the mesh"
            );
        }
    }
    // The rays file of trace-rays, and a frame of a raytrace animation.
    let r = pen(
        "trace-rays --mesh {mesh} --rays {rays} --out {rays}",
        &[("mesh", &mesh), ("rays", &rays)],
    );
    r.bad_input(&["--out", "the input --rays"]);
    let frame = d.write("frame_0001.obj", std::fs::read(&mesh).unwrap());
    let mut args = common::cli::cmd(
        "raytrace --method whitted --mesh {mesh} --width 8 --height 8 --frames 3 --out",
        &[("mesh", &frame)],
    );
    args.push(d.p("frame_{:04}.obj"));
    let r = run(&args);
    r.bad_input(&["--out", "never overwrites an input"]);
}

/// prt's outputs (`--sh-out`, `--per-vertex`, a frame of a `{}` --out)
/// and a per-vertex PLY are refused over an input too, the input unchanged.
#[test]
fn the_numbers_out_of_prt_and_ply_ao_never_overwrite_inputs() {
    let d = TempDir::new("guard_prt_outputs");
    let mesh = copy_mesh(&d);
    let ply = d.write("mesh.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    let env = d.write("env.hdr", b"not read: refused first");
    let original = std::fs::read(&env).unwrap();
    for (option, out) in [("--sh-out", &env), ("--per-vertex", &env), ("--per-vertex", &mesh)] {
        let r = pen(
            &format!("prt --mesh {{mesh}} --env {{env}} {option} {{out}}"),
            &[("mesh", &mesh), ("env", &env), ("out", out)],
        );
        r.bad_input(&[option, "never overwrites an input"]);
    }
    let frame = d.write("f_0002.hdr", &original);
    let mut args = common::cli::cmd(
        "prt --mesh {mesh} --env {frame} --frames 3 --out",
        &[("mesh", &mesh), ("frame", &frame)],
    );
    args.push(d.p("f_{:04}.hdr"));
    let r = run(&args);
    r.bad_input(&["--out", "never overwrites an input"]);
    let r = pen(
        "ao --mesh {ply} --method raycast --rays 4 --per-vertex {ply}",
        &[("ply", &ply)],
    );
    r.bad_input(&["--per-vertex", "never overwrites an input"]);
    assert_eq!(std::fs::read(&env).unwrap(), original);
    assert!(std::fs::read_to_string(&ply).unwrap().starts_with("ply"));
}

/// A scene file's meshes are inputs too.
#[test]
fn an_output_over_a_scene_files_mesh_is_refused() {
    let d = TempDir::new("guard_scene");
    let mesh = copy_mesh(&d);
    let scene = d.write(
        "scene.json",
        r#"{"meshes": {"m": "mesh.obj"}, "instances": [{"mesh": "m"}]}"#,
    );
    let r = pen(
        "ao --scene {scene} --method raycast --rays 4 --per-vertex {out}",
        &[("scene", &scene), ("out", &mesh)],
    );
    r.bad_input(&["--per-vertex", "the input --scene"]);
}

/// A mesh's own companions (an OBJ's MTL file, a .gltf's buffer file) are
/// inputs too.
#[test]
fn an_output_over_a_meshs_mtl_or_buffer_is_refused() {
    let d = TempDir::new("guard_companions");
    let mtl = d.write("m.mtl", "newmtl red\nKd 1 0 0\n");
    let obj = d.write(
        "m.obj",
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
    );
    let r = pen(
        "raytrace --method whitted --mesh {obj} --width 8 --height 8 --out {out} --device cpu",
        &[("obj", &obj), ("out", &mtl)],
    );
    r.bad_input(&["--out", "the input --mesh"]);
    assert!(std::fs::read_to_string(&mtl).unwrap().contains("Kd 1 0 0"));
    let bin: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let bin_path = d.write("tri data.bin", &bin);
    let gltf = d.write(
        "t.gltf",
        r#"{"asset": {"version": "2.0"}, "buffers": [{"uri": "tri%20data.bin", "byteLength": 36}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                           "min": [0, 0, 0], "max": [1, 1, 0]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0}"#,
    );
    let r = pen(
        "ao --mesh {gltf} --method raycast --rays 4 --per-vertex {out} --device cpu",
        &[("gltf", &gltf), ("out", &bin_path)],
    );
    r.bad_input(&["--per-vertex", "the input --mesh"]);
    assert_eq!(std::fs::read(&bin_path).unwrap(), bin);
}

/// Outputs that are not inputs are still written (and replace old files).
#[test]
fn an_output_beside_the_inputs_is_written_and_replaced_whole() {
    let d = TempDir::new("guard_replace");
    let mesh = copy_mesh(&d);
    let csv = d.write("ao.csv", "stale contents that are longer than nothing\n".repeat(10_000));
    pen(
        "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {csv}",
        &[("mesh", &mesh), ("csv", &csv)],
    )
    .ok();
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("0,") && !text.contains("stale"), "{}", &text[..40]);
    let leftovers: Vec<_> = std::fs::read_dir(&d.0)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

/// An option the chosen method (or mode) does not use is exit 2 naming
/// the option and what it needs.
#[test]
fn options_that_do_not_apply_are_refused() {
    let d = TempDir::new("guard_unused");
    let mesh = copy_mesh(&d);
    let csv = d.p("ao.csv");
    let png = d.p("x.png");
    let ao = "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {csv}";
    let rt = "raytrace --mesh {mesh} --width 8 --height 8";
    let ssao = "ssao --mesh {mesh} --estimator sphere --spp 4 --radius 0.5 --width 8 --height 8";
    let cases = [
        (format!("{ao} --frames 2"), "--frames", "--method field"),
        (format!("{ao} --bits 8"), "--bits", "--method field"),
        (format!("{ao} --field {mesh}"), "--field", "--method field"),
        (format!("{ao} --width 64"), "--width", "--image"),
        (
            format!("{rt} --method whitted --epsilon 0.1"),
            "--epsilon",
            "--method bounded",
        ),
        (
            format!("{rt} --method whitted --reference"),
            "--reference",
            "--method bounded",
        ),
        (
            format!("{rt} --method bounded --ray-tree 1,1"),
            "--ray-tree",
            "--method whitted",
        ),
        (
            format!("{rt} --method whitted --path {mesh}"),
            "--path",
            "--frames above 1",
        ),
        (format!("{ssao} --sigma 3"), "--sigma", "--measure exp"),
        (format!("{ssao} --steps 4"), "--steps", "--estimator raymarch"),
        (format!("{ssao} --ambient 0.5"), "--ambient", "--image"),
        (
            "trace --mesh {mesh} --width 8 --height 8 --single-ray --tile 16".to_string(),
            "--tile",
            "without --single-ray",
        ),
        (
            "trace --mesh {mesh} --width 8 --height 8 --accel bvh --aa adaptive".to_string(),
            "--aa",
            "without --single-ray or --accel bvh",
        ),
        (
            "trace --mesh {mesh} --width 8 --height 8 --aa-samples 16".to_string(),
            "--aa-samples",
            "--aa adaptive",
        ),
        (
            "prt --mesh {mesh} --env {mesh} --shininess 8".to_string(),
            "--shininess",
            "--brdf phong",
        ),
        (
            "prt --mesh {mesh} --env {mesh} --check-rays 64".to_string(),
            "--reference-rays",
            "--reference or --shadows raytraced",
        ),
        (
            "prt --mesh {mesh} --env {mesh} --width 64".to_string(),
            "--width",
            "--out",
        ),
    ];
    for (line, option, needs) in &cases {
        let r = pen(line, &[("mesh", &mesh), ("csv", &csv), ("png", &png)]);
        r.bad_input(&[option, "does not apply", needs]);
    }
    // The same options where they apply still run.
    pen(
        &format!("{ssao} --measure exp --sigma 3 --out {{png}}"),
        &[("mesh", &mesh), ("png", &png)],
    )
    .ok();
    pen(&format!("{rt} --method bounded --epsilon 0.1"), &[("mesh", &mesh)]).ok();
}

/// `auto` never picks a software adapter: with only lavapipe/llvmpipe it
/// runs the CPU path and says why; `gpu` still takes lavapipe, and the
/// JSON names the adapter with its backend.
#[test]
fn device_auto_skips_software_adapters_and_reports_name_the_backend() {
    let d = TempDir::new("guard_auto");
    let mesh = copy_mesh(&d);
    let info = run(&["info".into(), "--json".into()]).json();
    let hardware = info["adapters"]
        .as_array()
        .unwrap()
        .iter()
        .any(|a| a["device_type"] != "cpu" && a["device_type"] != "other");
    let ao = "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {csv} --json --device";
    let csv = d.p("ao.csv");
    let auto = pen(&format!("{ao} auto"), &[("mesh", &mesh), ("csv", &csv)]);
    let report = auto.ok().json();
    if hardware {
        assert_eq!(report["device"], "gpu", "{}", auto.describe());
    } else {
        assert_eq!(report["device"], "cpu", "{}", auto.describe());
        assert!(report["adapter"].is_null());
        assert_eq!(info["auto"], "cpu");
        if !info["adapters"].as_array().unwrap().is_empty() {
            assert!(auto.stderr.contains("only software adapters"), "{}", auto.stderr);
        }
    }
    if info["selected"].is_string() {
        let gpu = pen(&format!("{ao} gpu"), &[("mesh", &mesh), ("csv", &csv)]);
        let report = gpu.ok().json();
        let backend = info["selected_backend"].as_str().unwrap();
        let adapter = report["adapter"].as_str().unwrap();
        assert!(adapter.ends_with(&format!("({backend})")), "{adapter}");
        assert!(gpu.stderr.contains(adapter), "{}", gpu.stderr);
    }
}

/// `penumbra ... --json | head -c 10`: a reader that closes the pipe early
/// ends the run quietly (exit 0, no panic, no error).
#[test]
fn a_closed_stdout_is_a_quiet_exit() {
    let d = TempDir::new("guard_pipe");
    let mesh = copy_mesh(&d);
    let mut child = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["ao", "--mesh", &mesh, "--method", "raycast", "--rays", "64"])
        .args(["--per-vertex", &d.p("ao.csv"), "--device", "cpu", "--json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let mut stderr = String::new();
    child.stderr.take().unwrap().read_to_string(&mut stderr).unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("panicked") && !stderr.contains("error"), "{stderr}");
}

/// Headers that promise more than their file holds, byte-order marks and
/// indices beyond any count: exit 2 naming the file and the field, or the
/// same answer as without the mark; never a panic or a huge allocation.
#[test]
fn headers_marks_and_indices_are_read_for_what_they_are() {
    let d = TempDir::new("guard_headers");
    let mesh = copy_mesh(&d);
    let text = std::fs::read_to_string(&mesh).unwrap();
    let bom = d.write("bom.obj", format!("\u{feff}{text}"));
    let ao = "ao --mesh {mesh} --method raycast --rays 8 --per-vertex {csv} --device cpu";
    let (plain_csv, bom_csv) = (d.p("plain.csv"), d.p("bom.csv"));
    pen(ao, &[("mesh", &mesh), ("csv", &plain_csv)]).ok();
    pen(ao, &[("mesh", &bom), ("csv", &bom_csv)]).ok();
    assert_eq!(
        std::fs::read(&plain_csv).unwrap(),
        std::fs::read(&bom_csv).unwrap(),
        "a byte-order mark changed the answer"
    );
    let huge = d.write("huge.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967297\n");
    pen(ao, &[("mesh", &huge), ("csv", &plain_csv)]).bad_input(&["huge.obj", "line 4", "out of range"]);
    let digits = d.write(
        "digits.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n",
    );
    pen(ao, &[("mesh", &digits), ("csv", &plain_csv)]).bad_input(&["digits.obj", "out of range"]);

    let header = |w: u32, h: u32| format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n");
    let prt = "prt --mesh {mesh} --env {env} --device cpu";
    for (name, w, h, phrase) in [
        ("empty.hdr", 0, 0, "declares 0x0"),
        ("vast.hdr", 400_000, 200_000, "up to"),
        ("promise.hdr", 4096, 2048, "more than a"),
    ] {
        let env = d.write(name, header(w, h));
        pen(prt, &[("mesh", &mesh), ("env", &env)]).bad_input(&[name, "header", phrase]);
    }
    let threads = pen(
        &format!("{ao} --threads 100000"),
        &[("mesh", &mesh), ("csv", &plain_csv)],
    );
    threads.bad_input(&["--threads", "at most"]);
}

/// Every GPU command on each backend wgpu offers here runs or exits 2
/// naming what the adapter lacks, checked when the device is opened: before
/// any work (no "GPU adapter" line, no output written), never a panic and
/// never a validation error later (llvmpipe GL cannot render to the
/// G-buffer's Rgba32Float: SSAO, `sweep ssao`). An unknown `WGPU_BACKEND`
/// is named as such.
#[test]
fn every_backend_runs_or_names_what_it_lacks() {
    let d = TempDir::new("guard_backends");
    let mesh = copy_mesh(&d);
    let unknown = common::cli::run_env(
        &common::cli::cmd(
            "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {csv} --device gpu",
            &[("mesh", &mesh), ("csv", &d.p("a.csv"))],
        ),
        &[("WGPU_BACKEND", Some("vulcan"))],
    );
    unknown.bad_input(&["WGPU_BACKEND", "vulcan", "not a backend"]);
    let rays: Vec<u8> = [0f32, 3.0, 0.0, 0.0, -1.0, 0.0]
        .iter()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    let rays = d.write("rays.f32", rays);
    let probe = common::cli::write_probe(&d, [2.0, 1.8, 1.5], [0.2, 0.2, 0.25]);
    for backend in ["vulkan", "gl"] {
        let env = [("WGPU_BACKEND", Some(backend))];
        let info = common::cli::run_env(&["info".into(), "--json".into()], &env).json();
        if !info["selected"].is_string() {
            common::skip_gpu(&format!("the {backend} backend's runs"), &"`info --json` selected none");
            continue;
        }
        for line in [
            "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {out}.csv",
            "ao --mesh {mesh} --receiver {mesh} --method field --positions 8 --res 8 --rays 4 --per-vertex {out}.csv",
            "trace --mesh {mesh} --width 16 --height 16 --out {out}.png",
            "trace-rays --mesh {mesh} --rays {rays} --out {out}.bin",
            "ssao --mesh {mesh} --estimator sphere --spp 4 --radius 0.5 --width 16 --height 16 --out {out}.png",
            "prt --mesh {mesh} --env {probe} --width 16 --height 16 --out {out}.png",
            "raytrace --method whitted --mesh {mesh} --width 16 --height 16 --out {out}.png",
            "raytrace --method bounded --mesh {mesh} --width 16 --height 16 --out {out}.png",
            "sweep ssao --mesh {mesh} --width 16 --height 16 --grid spp=4 --out {out}",
        ] {
            let out = d.p(&format!("{backend}-{}", line.split(' ').next().unwrap()));
            let vars = [
                ("mesh", mesh.as_str()),
                ("out", &out),
                ("rays", &rays),
                ("probe", &probe),
            ];
            let r = common::cli::run_env(&common::cli::cmd(&format!("{line} --device gpu"), &vars), &env);
            println!("{backend}: {line}: exit {}", r.code);
            match r.code {
                0 => assert!(!r.stderr.contains("refused the work"), "{}", r.describe()),
                2 => {
                    r.bad_input(&["cannot run", &format!("({backend})"), "lacks", "--device cpu"]);
                    assert!(!r.stderr.contains("GPU adapter:"), "not up front\n{}", r.describe());
                    assert!(
                        !std::path::Path::new(&out).exists() && !std::path::Path::new(&format!("{out}.png")).exists()
                    );
                }
                _ => panic!("{backend}: {}", r.describe()),
            }
            // What each backend here can do: lavapipe Vulkan runs everything;
            // llvmpipe GL everything but SSAO's G-buffer.
            let llvmpipe = info["selected"].as_str().unwrap().contains("llvmpipe");
            let refused = r.code == 2;
            let expected = backend == "gl" && line.contains("ssao");
            assert!(!llvmpipe || refused == expected, "{backend}: {line}\n{}", r.describe());
            if refused {
                assert!(r.stderr.contains("Rgba32Float"), "{}", r.describe());
            }
        }
    }
}
