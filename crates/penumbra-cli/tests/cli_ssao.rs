//! `penumbra ssao` as the contract specifies it: JSON fields, outputs,
//! devices, knobs, and bad input (exit code 2, a message naming the option
//! and the problem, nothing on stdout, no panic).

mod common;

use common::cli::{TempDir, asset_s, gpu_available, pen, run_env};

const BASE: &str = "ssao --mesh {mesh} --estimator importance --spp 8 --radius 0.5 --width 64 --height 48 \
                    --truth-rays 16 --reference-spp 64";

#[test]
fn contract_form_writes_the_png_and_the_json_fields() {
    let dir = TempDir::new("ssao-contract");
    let mesh = asset_s("sphere-on-plane.obj");
    let out = dir.p("ao.png");
    for device in ["cpu", "auto"] {
        let r = pen(
            &format!("{BASE} --out {{out}} --device {device} --json"),
            &[("mesh", &mesh), ("out", &out)],
        );
        let j = r.ok().json();
        for key in [
            "estimator",
            "spp",
            "ao_ms",
            "rmse_vs_raytraced",
            "rmse_vs_screen_reference",
            "device",
        ] {
            assert!(j.get(key).is_some(), "missing {key}\n{}", r.describe());
        }
        assert_eq!(j["estimator"], "importance");
        assert_eq!(j["spp"], 8);
        for key in ["rmse_vs_raytraced", "rmse_vs_screen_reference", "ao_ms"] {
            let v = j[key].as_f64().unwrap();
            assert!(v.is_finite() && v >= 0.0, "{key} = {v}");
        }
        let img = image::open(&out).unwrap();
        assert_eq!((img.width(), img.height()), (64, 48));
    }
}

#[test]
fn every_estimator_and_knob_runs() {
    let dir = TempDir::new("ssao-knobs");
    let mesh = asset_s("sphere-on-plane.obj");
    let out = dir.p("ao.png");
    let image = dir.p("img.png");
    let devices: &[&str] = if gpu_available() { &["cpu", "gpu"] } else { &["cpu"] };
    for device in devices {
        for e in [
            "raymarch",
            "sphere",
            "hemisphere",
            "importance",
            "tangent-sphere",
            "base-disk",
        ] {
            let r = pen(
                &format!(
                    "ssao --mesh {{mesh}} --estimator {e} --spp 8 --radius 0.5 --width 40 --height 30 \
                     --truth-rays 8 --reference-spp 32 --interleave off --filter off --out {{out}} \
                     --image {{image}} --device {device} --json"
                ),
                &[("mesh", &mesh), ("out", &out), ("image", &image)],
            );
            let j = r.ok().json();
            assert_eq!(j["estimator"], e);
            assert_eq!(j["interleave"], false);
            assert!(image::open(&image).is_ok());
        }
        for knobs in [
            "--estimator importance --measure step",
            "--estimator hemisphere --measure exp --sigma 4",
            "--estimator raymarch --steps 2 --measure exp",
            "--estimator sphere --calibrate off --bias 0 --filter-depth 0.1",
            "--estimator base-disk --resolution half",
        ] {
            let r = pen(
                &format!(
                    "ssao --mesh {{mesh}} {knobs} --spp 8 --radius 0.5 --width 40 --height 30 \
                     --truth-rays 0 --reference-spp 0 --out {{out}} --device {device} --json"
                ),
                &[("mesh", &mesh), ("out", &out)],
            );
            let j = r.ok().json();
            assert!(j["rmse_vs_raytraced"].is_null() && j["rmse_vs_screen_reference"].is_null());
            let half = knobs.contains("--resolution half");
            assert_eq!(j["resolution"], if half { "half" } else { "full" });
        }
    }
}

#[test]
fn cpu_and_gpu_give_the_same_ao() {
    if !gpu_available() {
        return;
    }
    let dir = TempDir::new("ssao-devices");
    let mesh = asset_s("sphere-on-plane.obj");
    let (a, b) = (dir.p("cpu.png"), dir.p("gpu.png"));
    for (device, out) in [("cpu", &a), ("gpu", &b)] {
        pen(
            &format!("{BASE} --out {{out}} --device {device}"),
            &[("mesh", &mesh), ("out", out)],
        )
        .ok();
    }
    let (a, b) = (
        image::open(&a).unwrap().to_luma_alpha8(),
        image::open(&b).unwrap().to_luma_alpha8(),
    );
    // The rasterised G-buffer differs from the ray-traced one only on
    // silhouettes: nearly all pixels identical.
    let same = a.pixels().zip(b.pixels()).filter(|(p, q)| p == q).count();
    let n = (a.width() * a.height()) as usize;
    println!("{same} of {n} pixels identical");
    assert!(same as f64 >= 0.98 * n as f64);
}

#[test]
fn bad_input_exits_2_naming_the_option() {
    let dir = TempDir::new("ssao-bad");
    let mesh = asset_s("sphere-on-plane.obj");
    let out = dir.p("ao.png");
    let vars = [("mesh", mesh.as_str()), ("out", out.as_str())];
    let run = |args: &str, phrases: &[&str]| {
        pen(
            &format!("ssao --mesh {{mesh}} --width 32 --height 24 --device cpu {args}"),
            &vars,
        )
        .bad_input(phrases);
    };
    run("--estimator importance --spp 0 --radius 1 --out {out}", &["--spp"]);
    run("--estimator importance --spp -4 --radius 1 --out {out}", &["--spp"]);
    run("--estimator importance --spp 99999 --radius 1 --out {out}", &["--spp"]);
    run(
        "--estimator importance --spp 8 --radius 0 --out {out}",
        &["--radius", "positive"],
    );
    run("--estimator importance --spp 8 --radius -1 --out {out}", &["--radius"]);
    run("--estimator importance --spp 8 --radius NaN --out {out}", &["--radius"]);
    run("--estimator importance --spp 8 --radius inf --out {out}", &["--radius"]);
    run("--estimator magic --spp 8 --radius 1 --out {out}", &["--estimator"]);
    run(
        "--estimator sphere --measure step --spp 8 --radius 1 --out {out}",
        &["--estimator", "step"],
    );
    run(
        "--estimator base-disk --measure exp --spp 8 --radius 1 --out {out}",
        &["--estimator", "poly4"],
    );
    run(
        "--estimator raymarch --steps 3 --spp 8 --radius 1 --out {out}",
        &["--steps"],
    );
    run(
        "--estimator raymarch --steps 0 --spp 8 --radius 1 --out {out}",
        &["--steps"],
    );
    run(
        "--estimator importance --measure exp --sigma -2 --spp 8 --radius 1 --out {out}",
        &["--sigma"],
    );
    run(
        "--estimator importance --sigma 2 --spp 8 --radius 1 --out {out}",
        &["--sigma"],
    );
    run(
        "--estimator importance --filter-depth 0 --spp 8 --radius 1 --out {out}",
        &["--filter-depth"],
    );
    run(
        "--estimator importance --bias NaN --spp 8 --radius 1 --out {out}",
        &["--bias"],
    );
    run(
        "--estimator importance --ambient -1 --spp 8 --radius 1 --out {out}",
        &["--ambient"],
    );
    run(
        "--estimator importance --interleave maybe --spp 8 --radius 1 --out {out}",
        &["--interleave"],
    );
    run("--estimator importance --spp 8 --radius 1", &["--out"]);
    run(
        "--estimator importance --spp 8 --radius 1 --out /no/such/dir/ao.png",
        &["--out", "does not exist"],
    );
    run(
        "--estimator importance --spp 8 --radius 1 --out {out} --fov 0",
        &["--fov"],
    );
    run(
        "--estimator importance --spp 8 --radius 1 --out {out} --repeat 0",
        &["--repeat"],
    );
    pen(
        "ssao --mesh /no/such.obj --estimator importance --spp 8 --radius 1 --out {out}",
        &vars,
    )
    .bad_input(&["/no/such.obj"]);
    let bad = dir.write("nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
    pen(
        "ssao --mesh {bad} --estimator importance --spp 8 --radius 1 --out {out}",
        &[("bad", &bad), ("out", &out)],
    )
    .bad_input(&["nan.obj"]);
    pen(
        "ssao --mesh {mesh} --estimator importance --spp 8 --radius 1 --width 0 --height 10 --out {out}",
        &vars,
    )
    .bad_input(&["--width"]);
}

#[test]
fn seeds_repeat_and_differ() {
    let dir = TempDir::new("ssao-seed");
    let mesh = asset_s("sphere-on-plane.obj");
    let outs = [dir.p("a.png"), dir.p("b.png"), dir.p("c.png")];
    for (out, seed) in outs.iter().zip([1, 1, 2]) {
        pen(
            &format!("{BASE} --out {{out}} --device cpu --seed {seed} --filter off"),
            &[("mesh", &mesh), ("out", out)],
        )
        .ok();
    }
    let read = |p: &str| std::fs::read(p).unwrap();
    assert_eq!(read(&outs[0]), read(&outs[1]));
    assert_ne!(read(&outs[0]), read(&outs[2]));
}

/// Model only what the frame requires: on a GPU only the estimator's and
/// the used filter's pipelines compile (the others are listed as skipped),
/// no kd-tree is built without a truth, and the JSON says so.
#[test]
fn only_the_kernels_and_truths_used_are_built() {
    let dir = TempDir::new("ssao-modelled");
    let mesh = asset_s("sphere-on-plane.obj");
    let out = dir.p("ao.png");
    let vars = [("mesh", mesh.as_str()), ("out", out.as_str())];
    let lean = "ssao --mesh {mesh} --spp 8 --radius 0.5 --width 64 --height 48 --truth-rays 0 --reference-spp 0 \
                --out {out}";
    let cpu = pen(&format!("{lean} --estimator importance --device cpu --json"), &vars)
        .ok()
        .json();
    let whats: Vec<&str> = cpu["skipped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["what"].as_str().unwrap())
        .collect();
    assert_eq!(
        whats,
        ["ray-traced truth", "screen-space reference"],
        "the CPU G-buffer needs the tree"
    );
    assert!(cpu["build_ms"].as_f64().unwrap() > 0.0);
    assert!(cpu.get("pipelines").is_none(), "no pipelines on the CPU");
    if !gpu_available() {
        return;
    }
    for (options, compiled) in [
        (
            "--filter on --estimator importance",
            vec![
                "ssao_estimate.ssao_pack_depth",
                "ssao_estimate.ssao_points",
                "ssao_filter.ssao_filter_ao_rows",
                "ssao_filter.ssao_filter_ao_columns",
            ],
        ),
        (
            "--filter off --estimator raymarch",
            vec!["ssao_estimate.ssao_pack_depth", "ssao_estimate.ssao_march"],
        ),
        (
            "--filter off --estimator base-disk --resolution half",
            vec![
                "ssao_estimate.ssao_pack_depth",
                "ssao_estimate.ssao_disk",
                "ssao_filter.ssao_upsample",
            ],
        ),
    ] {
        let args = format!("{lean} {options} --device gpu --json");
        let gpu = pen(&args, &vars).ok().json();
        let names: Vec<&str> = gpu["pipelines"]["compiled"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["name"].as_str().unwrap())
            .collect();
        println!("{options}: compiled {names:?}, skipped {}", gpu["pipelines"]["skipped"]);
        assert_eq!(names, compiled);
        let skipped = gpu["pipelines"]["skipped"].as_array().unwrap();
        assert_eq!(names.len() + skipped.len(), 10, "every SSAO kernel is listed once");
        assert!(skipped.iter().any(|s| s == "ssao_indirect.ssao_compose"));
        assert!(gpu["pipelines"]["compile_ms"].as_f64().unwrap() > 0.0);
        assert_eq!(gpu["build_ms"], 0.0);
        assert_eq!(gpu["skipped"][0]["what"], "kd-tree");
    }
}

/// `--progress` logs the phases as plain lines when stderr is not a
/// terminal (as in CI): the ray-traced truth and the screen reference show
/// their progress; without it such a log stays clean.
#[test]
fn progress_lines_name_the_truth_and_the_reference_when_asked() {
    let d = TempDir::new("ssao-progress");
    let mesh = asset_s("sphere-on-plane.obj");
    let line = format!(
        "ssao --mesh {mesh} --estimator importance --spp 4 --radius 0.2 --width 200 --height 150 \
         --truth-rays 64 --reference-spp 64 --device cpu --out {}",
        d.p("ao.png")
    );
    let run = |extra: &str| {
        let args: Vec<String> = format!("{line} {extra}").split_whitespace().map(String::from).collect();
        run_env(&args, &[("PENUMBRA_PROGRESS_DELAY_MS", Some("0"))])
            .ok()
            .stderr
            .clone()
    };
    let logged = run("--progress");
    for phase in ["ray-traced truth", "screen-space reference"] {
        assert!(
            logged
                .lines()
                .any(|l| l.starts_with("penumbra: progress:") && l.contains(phase)),
            "no progress line for {phase}:\n{logged}"
        );
    }
    let quiet = run("");
    assert!(!quiet.contains("progress:"), "progress without --progress:\n{quiet}");
}

/// A cut-out card alone: its holes are background for the G-buffer of
/// every output, the AO image's (`--out` alone) as the shaded image's.
#[test]
fn cut_out_holes_are_background_with_or_without_the_image() {
    let d = TempDir::new("ssao-cutout");
    let holes = image::RgbaImage::from_fn(8, 8, |x, _| image::Rgba([255, 255, 255, if x < 4 { 0 } else { 255 }]));
    holes.save(d.0.join("holes.png")).unwrap();
    let obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
               usemtl card\nf 1/1 2/2 3/3 4/4\n";
    d.write("solid.mtl", "newmtl card\nKd 0.8 0.8 0.8\n");
    d.write("holed.mtl", "newmtl card\nKd 0.8 0.8 0.8\nmap_d holes.png\n");
    d.write("solid.obj", format!("mtllib solid.mtl\n{obj}"));
    d.write("holed.obj", format!("mtllib holed.mtl\n{obj}"));
    let surface = |mesh: &str, image: bool, device: &str| {
        let extra = if image {
            format!(" --image {}", d.p("img.png"))
        } else {
            String::new()
        };
        let r = pen(
            &format!(
                "ssao --mesh {{mesh}} --estimator importance --spp 4 --radius 0.2 --width 64 --height 48 \
                 --reference-rays 0 --screen-reference-spp 0 --eye 0,0,3 --target 0,0,0 --device {device} \
                 --out {{out}}{extra} --json"
            ),
            &[("mesh", &d.p(mesh)), ("out", &d.p("ao.png"))],
        );
        r.ok().json()["surface_pixels"].as_u64().unwrap()
    };
    let devices: &[&str] = if gpu_available() { &["cpu", "gpu"] } else { &["cpu"] };
    for device in devices {
        let solid = surface("solid.obj", false, device);
        for image in [false, true] {
            let holed = surface("holed.obj", image, device);
            // The left half of the card is a hole: about half its pixels.
            assert!(
                (holed as f64 - 0.5 * solid as f64).abs() <= 0.05 * solid as f64,
                "{device}, image {image}: {holed} surface pixels with the hole, {solid} without"
            );
        }
    }
}
