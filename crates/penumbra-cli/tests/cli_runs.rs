//! `--warmup N --repeat N` on every computing command: N measured runs with
//! min <= median <= max of the command's own timed work, warm-up runs not
//! among them, outputs from the last run; and on a GPU with an empty Mesa
//! shader cache, pipeline compilation reported apart (`pipelines`).

mod common;

use common::cli::{TempDir, asset_s, gpu_available, pen, run_env};
use serde_json::Value;

/// The `runs` object holds `repeat` measured times of `measure`, ordered stats.
fn check_runs(j: &Value, measure: &str, warmup: u64, repeat: u64) {
    let r = &j["runs"];
    assert_eq!(r["measure"], measure, "{j}");
    assert_eq!(
        (r["warmup"].as_u64(), r["repeat"].as_u64()),
        (Some(warmup), Some(repeat)),
        "{r}"
    );
    let ms: Vec<f64> = r["ms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(ms.len() as u64, repeat, "{r}");
    let (min, median, max) = (
        r["min_ms"].as_f64().unwrap(),
        r["median_ms"].as_f64().unwrap(),
        r["max_ms"].as_f64().unwrap(),
    );
    assert!(ms.iter().all(|&t| t >= 0.0 && t.is_finite()), "{r}");
    assert!(min <= median && median <= max, "{r}");
    assert_eq!(min, ms.iter().cloned().fold(f64::INFINITY, f64::min), "{r}");
    assert_eq!(max, ms.iter().cloned().fold(0.0, f64::max), "{r}");
}

#[test]
fn every_computing_command_reports_its_measured_runs() {
    let d = TempDir::new("runs-every");
    let mesh = asset_s("sphere-on-plane.obj");
    let o = |n: &str| d.p(n);
    let common = "--warmup 1 --repeat 3 --device cpu --json";
    let cases: Vec<(String, &str)> = vec![
        (
            format!("ao --mesh {mesh} --method raycast --rays 8 --per-vertex {}", o("a.csv")),
            "ao_ms",
        ),
        (format!("trace --mesh {mesh} --width 32 --height 24"), "trace_ms"),
        (
            format!(
                "raytrace --method whitted --mesh {mesh} --width 16 --height 12 --out {}",
                o("r.png")
            ),
            "render_ms",
        ),
        (
            format!(
                "ssao --mesh {mesh} --estimator importance --spp 4 --radius 0.2 --width 32 --height 24 --truth-rays 0 --reference-spp 0 --out {}",
                o("s.png")
            ),
            "frame_ms",
        ),
    ];
    for (args, measure) in cases {
        let j = pen(&format!("{args} {common}"), &[]).ok().json();
        check_runs(&j, measure, 1, 3);
    }
    // A field build: its builds are the runs; the last one is written.
    let j = pen(
        &format!(
            "field build --mesh {mesh} --positions 18 --res 8 -o {} --warmup 1 --repeat 2 --json",
            o("f.dfield")
        ),
        &[],
    )
    .ok()
    .json();
    check_runs(&j, "build_ms", 1, 2);
    // prt: each play of the animation is a run; outputs are the last play's.
    let probe = common::cli::write_probe(&d, common::cli::SKY, common::cli::GROUND);
    let csv = o("prt.csv");
    let j = pen(
        &format!("prt --animated cloth --env {probe} --frames 3 --self-check off --per-vertex {csv} {common}"),
        &[],
    )
    .ok()
    .json();
    check_runs(&j, "animation_ms", 1, 3);
    let rows = std::fs::read_to_string(&csv).unwrap().lines().count() - 1;
    assert_eq!(
        rows,
        3 * j["vertices"].as_u64().unwrap() as usize,
        "one play's frames in the CSV"
    );
    // Without the options: one measured run, no warm-up.
    let j = pen(
        &format!("trace --mesh {mesh} --width 8 --height 8 --device cpu --json"),
        &[],
    )
    .ok()
    .json();
    check_runs(&j, "trace_ms", 0, 1);
}

#[test]
fn bad_counts_and_the_bounded_renderer_are_refused() {
    let mesh = asset_s("sphere-on-plane.obj");
    for extra in ["--repeat 0", "--repeat 1001", "--warmup 1001"] {
        pen(
            &format!("trace --mesh {mesh} --width 8 --height 8 --device cpu {extra}"),
            &[],
        )
        .bad_input(&["between 1 and 1000", "at most 1000"][if extra.contains("warmup") { 1 } else { 0 }..][..1]);
    }
    let d = TempDir::new("runs-bounded");
    pen(
        &format!(
            "raytrace --method bounded --mesh {mesh} --width 8 --height 8 --out {} --repeat 2",
            d.p("b.png")
        ),
        &[],
    )
    .bad_input(&["--repeat", "--method whitted"]);
}

/// A fresh container's Mesa cache is empty: compiling the pipelines is
/// reported under `pipelines`, apart from the measured runs.
#[test]
fn cold_cache_compilation_is_reported_apart_from_the_runs() {
    if !gpu_available() {
        return;
    }
    let d = TempDir::new("runs-cold");
    let cache = d.p("mesa-cache");
    std::fs::create_dir_all(&cache).unwrap();
    let mesh = asset_s("sphere-on-plane.obj");
    let args: Vec<String> =
        format!("trace --mesh {mesh} --width 64 --height 48 --device gpu --warmup 1 --repeat 3 --json")
            .split_whitespace()
            .map(String::from)
            .collect();
    let j = run_env(&args, &[("MESA_SHADER_CACHE_DIR", Some(&cache))]).ok().json();
    let compile_ms = j["pipelines"]["compile_ms"].as_f64().unwrap();
    assert!(compile_ms > 0.0, "{j}");
    check_runs(&j, "trace_ms", 1, 3);
    println!(
        "cold cache: compile {compile_ms:.1} ms; trace min {:.2} median {:.2} max {:.2} ms",
        j["runs"]["min_ms"], j["runs"]["median_ms"], j["runs"]["max_ms"]
    );
}
