//! `penumbra sweep` as the contract specifies it: for every method, one row
//! per setting of the grid in sweep.csv (header first), sweep.json with the
//! same rows and a Pareto front no other row beats, a PNG plot; bad grids
//! and options that do not apply are exit 2.

mod common;

use std::collections::BTreeSet;

use common::cli::{TempDir, asset_s, gpu_available, pen};
use serde_json::Value;

/// Runs a sweep into a fresh folder; checks the files against the JSON and
/// returns the JSON.
fn sweep(dir: &TempDir, name: &str, args: &str, device: &str, settings: usize) -> Value {
    let out = dir.p(name);
    let j = pen(
        &format!("sweep {args} --out {{out}} --repeat 2 --device {device} --json"),
        &[("out", &out)],
    )
    .ok()
    .json();
    let rows = j["rows"].as_array().expect("rows");
    assert_eq!(rows.len(), settings, "{name}: {j}");
    assert_eq!(j["settings"], settings);
    let csv = std::fs::read_to_string(dir.0.join(name).join("sweep.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), settings + 1, "{name}: header + one line per setting");
    assert!(lines[0].ends_with("time_ms,error,memory_bytes,pareto"), "{}", lines[0]);
    let on_front: Vec<usize> = (0..settings).filter(|&i| lines[i + 1].ends_with(",true")).collect();
    let front: Vec<usize> = j["front"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i.as_u64().unwrap() as usize)
        .collect();
    assert_eq!(
        on_front,
        front
            .iter()
            .copied()
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect::<Vec<_>>()
    );
    assert!(!front.is_empty());
    // No row beats a front row on both time and error.
    let te = |r: &Value| (r["time_ms"].as_f64().unwrap(), r["error"].as_f64().unwrap());
    for &f in &front {
        let (tf, ef) = te(&rows[f]);
        assert!(tf > 0.0 && ef.is_finite());
        for r in rows {
            let (t, e) = te(r);
            assert!(
                !(t <= tf && e <= ef && (t < tf || e < ef)),
                "{name}: front row {f} is beaten by {r}"
            );
        }
        assert_eq!(rows[f]["times_ms"].as_array().unwrap().len(), 2, "two repeats");
    }
    let png = image::open(dir.0.join(name).join("sweep.png")).expect("sweep.png decodes");
    assert!(png.width() >= 800 && png.height() >= 600);
    let json_file: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.0.join(name).join("sweep.json")).unwrap()).unwrap();
    assert_eq!(json_file["rows"].as_array().unwrap().len(), settings);
    j
}

#[test]
fn every_method_sweeps_its_grid() {
    let dir = TempDir::new("sweep");
    let sphere = asset_s("sphere-on-plane.obj");
    let corner = asset_s("corner.obj");
    let checker = asset_s("raytrace/checker-spheres.json");
    let devices: &[&str] = if gpu_available() { &["cpu", "gpu"] } else { &["cpu"] };
    for device in devices {
        let field = sweep(
            &dir,
            &format!("field-{device}"),
            &format!("field --mesh {sphere} --grid res=8,16 --grid bits=1,8 --grid positions=258 --truth-rays 32"),
            device,
            4,
        );
        assert_eq!(
            field["truth"]["receiver_vertices"], 4096,
            "the ground under the mesh receives"
        );
        // Deterministic for a seed, apart from times.
        let again = sweep(
            &dir,
            &format!("field-again-{device}"),
            &format!("field --mesh {sphere} --grid res=8,16 --grid bits=1,8 --grid positions=258 --truth-rays 32"),
            device,
            4,
        );
        let errors = |j: &Value| {
            j["rows"]
                .as_array()
                .unwrap()
                .iter()
                .map(|r| r["error"].clone())
                .collect::<Vec<_>>()
        };
        assert_eq!(errors(&field), errors(&again));
        let ssao = sweep(
            &dir,
            &format!("ssao-{device}"),
            &format!(
                "ssao --mesh {corner} --grid estimator=sphere,importance --grid spp=4,16 --width 64 --height 48 --truth-rays 64"
            ),
            device,
            4,
        );
        assert!(
            ssao["rows"]
                .as_array()
                .unwrap()
                .iter()
                .all(|r| r["error"].as_f64().unwrap() < 0.3)
        );
        let trace = sweep(
            &dir,
            &format!("trace-{device}"),
            &format!("trace --mesh {sphere} --width 64 --height 48"),
            device,
            6,
        );
        // MLRTA's knobs change speed only.
        assert!(
            trace["rows"].as_array().unwrap().iter().all(|r| r["error"] == 0.0),
            "{trace}"
        );
        let prt = sweep(
            &dir,
            &format!("prt-{device}"),
            &format!("prt --mesh {sphere} --grid mask=16,32 --grid hierarchy=off --truth-rays 128"),
            device,
            2,
        );
        assert!(
            prt["rows"]
                .as_array()
                .unwrap()
                .iter()
                .all(|r| r["error"].as_f64().unwrap() < 0.2)
        );
        let bounded = sweep(
            &dir,
            &format!("bounded-{device}"),
            &format!("bounded --scene {checker} --grid epsilon=0.02,0.2 --grid split=16 --width 64 --height 48"),
            device,
            2,
        );
        // The guarantee: every pixel within epsilon of exact Whitted.
        for r in bounded["rows"].as_array().unwrap() {
            let eps: f64 = r["knobs"]["epsilon"].as_str().unwrap().parse().unwrap();
            assert!(r["error"].as_f64().unwrap() <= eps * 1.0001, "{r}");
        }
    }
}

#[test]
fn bad_grids_and_options_that_do_not_apply_are_refused() {
    let dir = TempDir::new("sweep-bad");
    let sphere = asset_s("sphere-on-plane.obj");
    let out = dir.p("out");
    for (args, phrases) in [
        ("field --grid foo=1", &["unknown knob 'foo'", "positions"][..]),
        ("field --grid res", &["KNOB=V1"][..]),
        ("field --grid res=1000", &["--res", "1000"][..]),
        ("ssao --grid spp=four", &["spp=four"][..]),
        ("trace --radius 2", &["--radius", "does not apply"][..]),
        ("prt --receiver {mesh}", &["--receiver", "does not apply"][..]),
        ("field --repeat 0", &["repeat", "between 1 and 100"][..]),
    ] {
        let r = pen(
            &format!("sweep {args} --mesh {{mesh}} --out {{out}} --device cpu"),
            &[("mesh", &sphere), ("out", &out)],
        );
        r.bad_input(phrases);
    }
    assert!(
        !dir.0.join("out").exists(),
        "nothing is written before the grid is checked"
    );
}
