//! `penumbra bench`: the shape of its outputs (never its timings): one row
//! per method, device and thread count, fastest <= median <= slowest, a
//! throughput and, for the methods with a truth, an error; the CSV, JSON
//! and PNG written; bad settings refused naming the option.

mod common;

use common::cli::{TempDir, asset_s, gpu_available, pen};

const METHODS: [&str; 5] = ["primary", "random-rays", "ao", "ssao", "whitted"];

fn check_rows(json: &serde_json::Value, devices: usize, threads: &[u64]) {
    let rows = json["rows"].as_array().expect("rows");
    let per_device: usize = threads.len();
    // Each method: every thread count on the CPU, the most on a GPU.
    let expected = METHODS.len() * (per_device + devices - 1);
    assert_eq!(rows.len(), expected, "{json:#}");
    for (i, r) in rows.iter().enumerate() {
        let method = r["method"].as_str().unwrap();
        assert_eq!(
            method,
            METHODS[i / (per_device + devices - 1)],
            "rows come method by method"
        );
        if r["skipped"].is_string() {
            continue;
        }
        let (lo, mid, hi) = (
            r["min_ms"].as_f64().unwrap(),
            r["median_ms"].as_f64().unwrap(),
            r["max_ms"].as_f64().unwrap(),
        );
        assert!(lo > 0.0 && lo <= mid && mid <= hi, "{r}");
        assert_eq!(r["ms"].as_array().unwrap().len(), 2, "two measured runs: {r}");
        let (wlo, whi) = (r["wall_min_ms"].as_f64().unwrap(), r["wall_max_ms"].as_f64().unwrap());
        assert!(
            wlo > 0.0 && wlo <= r["wall_median_ms"].as_f64().unwrap() && r["wall_median_ms"].as_f64().unwrap() <= whi,
            "{r}"
        );
        assert!(r["throughput"].as_f64().unwrap() > 0.0, "{r}");
        let with_truth = matches!(method, "primary" | "ssao");
        assert_eq!(r["error"].is_number(), with_truth, "{r}");
        let rays = r["rays"].as_u64().unwrap();
        match method {
            "random-rays" => assert_eq!(rays, 1000, "{r}"),
            "primary" => assert_eq!(rays, 32 * 24, "{r}"),
            _ => {}
        }
        assert!(r["setup_ms"]["load"].is_number(), "{r}");
    }
}

#[test]
fn bench_writes_a_row_per_method_device_and_thread_count() {
    let d = TempDir::new("bench");
    let out = d.p("b");
    let mesh = asset_s("corner.obj");
    let line = "bench --mesh {mesh} --devices cpu --threads 1,2 --warmup 0 --repeat 2 \
                --methods primary,random-rays,ao,ssao,whitted --set random-rays.rays=1000 --set ao.rays=8 \
                --width 32 --height 24 --out {out} --json";
    let r = pen(line, &[("mesh", &mesh), ("out", &out)]);
    assert_eq!(r.code, 0, "{}", r.describe());
    let json = r.json();
    check_rows(&json, 1, &[1, 2]);
    let csv = std::fs::read_to_string(format!("{out}/bench.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + json["rows"].as_array().unwrap().len(), "{csv}");
    assert!(csv.starts_with("method,device,software,threads,"), "{csv}");
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{out}/bench.json")).unwrap()).unwrap();
    assert_eq!(
        file["rows"].as_array().unwrap().len(),
        json["rows"].as_array().unwrap().len()
    );
    let png = image::open(format!("{out}/bench.png")).expect("a PNG");
    assert_eq!((png.width(), png.height()), (1000, 700));
    // Without --json: the table, a line per row and a header.
    let r = pen(&line.replace(" --json", ""), &[("mesh", &mesh), ("out", &out)]);
    assert_eq!(r.code, 0, "{}", r.describe());
    let table: Vec<&str> = r
        .stdout
        .lines()
        .filter(|l| METHODS.iter().any(|m| l.starts_with(m)))
        .collect();
    assert_eq!(table.len(), 10, "{}", r.stdout);
    assert!(r.stdout.starts_with("method"), "{}", r.stdout);
    // Aligned: each row's throughput starts under the header's.
    let column = r.stdout.lines().next().unwrap().find("throughput").unwrap();
    for line in &table {
        let unit = line.find(" Mrays/s").or_else(|| line.find(" fps")).unwrap();
        let start = line[..unit].rfind(' ').unwrap() + 1;
        assert_eq!(start, column, "{}", r.stdout);
    }
}

#[test]
fn bench_on_every_adapter_marks_software_ones() {
    if !gpu_available() {
        return;
    }
    let d = TempDir::new("bench_gpu");
    let out = d.p("b");
    let mesh = asset_s("corner.obj");
    let line = "bench --mesh {mesh} --devices all --threads 1 --warmup 0 --repeat 2 \
                --methods primary,random-rays,ao,ssao,whitted --set random-rays.rays=1000 --set ao.rays=8 \
                --width 32 --height 24 --out {out} --json";
    let r = pen(line, &[("mesh", &mesh), ("out", &out)]);
    assert_eq!(r.code, 0, "{}", r.describe());
    let json = r.json();
    let rows = json["rows"].as_array().unwrap();
    let devices: std::collections::BTreeSet<&str> = rows.iter().map(|r| r["device"].as_str().unwrap()).collect();
    println!("devices: {devices:?}");
    assert!(devices.contains("cpu") && devices.len() >= 2, "{devices:?}");
    // lavapipe and llvmpipe are software adapters.
    for r in rows
        .iter()
        .filter(|r| r["device"].as_str().unwrap().contains("llvmpipe"))
    {
        assert_eq!(r["software"], true, "{r}");
    }
    check_rows(&json, devices.len(), &[1]);
}

#[test]
fn bad_bench_settings_name_the_option() {
    let d = TempDir::new("bench_bad");
    let out = d.p("b");
    let mesh = asset_s("corner.obj");
    for (extra, words) in [
        ("--set nope.rays=4", &["--set", "no method 'nope'"][..]),
        ("--set ao.nope=4", &["--set", "unknown knob 'nope'"]),
        ("--set ao.rays=x", &["--set", "ao.rays=x"]),
        ("--threads 0", &["--threads", "must each be between 1"]),
        ("--threads -1", &["--threads", "at least 1"]),
    ] {
        let line = format!("bench --mesh {{mesh}} --devices cpu --methods ao --out {{out}} {extra}");
        let r = pen(&line, &[("mesh", &mesh), ("out", &out)]);
        println!("{extra}: {}", r.stderr.trim());
        assert_eq!(r.code, 2, "{extra}: {}", r.describe());
        assert!(words.iter().all(|w| r.stderr.contains(w)), "{extra}: {}", r.describe());
        assert!(!std::path::Path::new(&out).exists(), "nothing written on bad input");
    }
}

/// A scene file: the methods that take one mesh are rows saying so, the
/// others run on the whole scene.
#[test]
fn bench_of_a_scene_file_says_which_methods_take_a_mesh() {
    let d = TempDir::new("bench_scene");
    let out = d.p("b");
    let scene = asset_s("scenes/chess.json");
    let line = "bench --scene {scene} --devices cpu --threads 1 --warmup 0 --repeat 1 \
                --methods primary,random-rays,prt,whitted --width 16 --height 12 --out {out} --json";
    let r = pen(line, &[("scene", &scene), ("out", &out)]);
    assert_eq!(r.code, 0, "{}", r.describe());
    let json = r.json();
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 4, "{json:#}");
    for row in rows {
        let method = row["method"].as_str().unwrap();
        let skipped = row["skipped"].as_str();
        match method {
            "random-rays" | "prt" => assert!(skipped.is_some_and(|s| s.contains("--mesh")), "{row}"),
            _ => assert!(skipped.is_none() && row["median_ms"].as_f64().unwrap() > 0.0, "{row}"),
        }
    }
}

/// PRT's row at its defaults is the probe's choice, as `prt` makes it: the
/// row's settings name it and its setup has the probe's time; on the
/// cylindrical well that is the hierarchy off. Settings given are kept.
#[test]
fn the_prt_row_runs_the_probe_s_choice() {
    let d = TempDir::new("bench_prt");
    let mesh = asset_s("cylindrical-well.obj");
    let run = |extra: &str, out: &str| {
        let line = format!(
            "bench --mesh {{mesh}} --devices cpu --threads 1 --warmup 0 --repeat 1 --methods prt \
             --set prt.order=3 --out {{out}} --json {extra}"
        );
        let r = pen(&line, &[("mesh", &mesh), ("out", out)]);
        assert_eq!(r.code, 0, "{}", r.describe());
        r.json()["rows"][0].clone()
    };
    let row = run("", &d.p("a"));
    assert_eq!(row["settings"]["hierarchy"], "off", "{row}");
    assert_eq!(row["settings"]["order"], "3", "{row}");
    assert!(row["settings"]["mask"].is_string(), "{row}");
    assert!(row["setup_ms"]["probe"].as_f64().unwrap() > 0.0, "{row}");
    let row = run(
        "--set prt.mask=16 --set prt.hierarchy=on --set prt.near=rings",
        &d.p("b"),
    );
    assert_eq!(row["settings"]["mask"], "16", "{row}");
    assert!(row["setup_ms"].get("probe").is_none(), "{row}");
}
