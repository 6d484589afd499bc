//! `--max-error E` on `ssao` and `ao --method field`: the choice is the
//! fastest (ssao) or cheapest (field) candidate whose sampled error bound
//! is within E; the sampled estimate agrees with the method's own full
//! comparison; a second run reads the cache; fixed knobs stay fixed; an
//! impossible budget warns and takes the most accurate candidate.

mod common;

use common::cli::{Out, TempDir, asset_s, cmd, run_env};
use serde_json::Value;

fn pen_cached(dir: &TempDir, template: &str, vars: &[(&str, &str)]) -> Out {
    let cache = dir.p("cache");
    run_env(&cmd(template, vars), &[("PENUMBRA_CACHE_DIR", Some(&cache))])
}

/// The choice's sampled estimate is within its bound's reach of `full`.
fn agrees(choice: &Value, full: f64) {
    let (estimate, upper) = (choice["estimate"].as_f64().unwrap(), choice["upper"].as_f64().unwrap());
    let half_width = upper - estimate;
    println!("estimate {estimate:.4} (upper {upper:.4}), full {full:.4}");
    assert!((estimate - full).abs() <= 2.0 * half_width + 1e-3, "{choice}");
}

#[test]
fn ssao_picks_the_fastest_setting_within_the_budget() {
    let dir = TempDir::new("max-error-ssao");
    let corner = asset_s("corner.obj");
    let out = dir.p("ao.png");
    let base = "ssao --mesh {mesh} --radius 0.3 --width 160 --height 120 --out {out} --device cpu --json";
    let first = pen_cached(
        &dir,
        &format!("{base} --max-error 0.08"),
        &[("mesh", &corner), ("out", &out)],
    );
    let j = first.ok().json();
    let choice = &j["max_error"];
    assert_eq!(choice["cached"], false);
    assert_eq!(choice["met"], true, "{choice}");
    assert!(choice["upper"].as_f64().unwrap() <= 0.08);
    // The chosen one is the fastest of the candidates within the budget.
    let candidates = choice["candidates"].as_array().unwrap();
    assert!(candidates.len() >= 20, "every estimator x spp: {}", candidates.len());
    let time = |c: &Value| c["time_ms"].as_f64().unwrap();
    let fastest = candidates
        .iter()
        .filter(|c| c["within"] == true)
        .min_by(|a, b| time(a).total_cmp(&time(b)))
        .unwrap();
    assert_eq!(fastest["knobs"], choice["chosen"]);
    assert_eq!(j["estimator"].as_str(), choice["chosen"]["estimator"].as_str());
    agrees(choice, j["rmse_vs_raytraced"].as_f64().unwrap());
    let again = pen_cached(
        &dir,
        &format!("{base} --max-error 0.08"),
        &[("mesh", &corner), ("out", &out)],
    );
    let j2 = again.ok().json();
    assert_eq!(j2["max_error"]["cached"], true);
    assert_eq!(j2["max_error"]["chosen"], choice["chosen"]);
    // A fixed estimator stays; only spp is chosen.
    let fixed = pen_cached(
        &dir,
        &format!("{base} --max-error 0.08 --estimator sphere"),
        &[("mesh", &corner), ("out", &out)],
    );
    let j3 = fixed.ok().json();
    assert_eq!(j3["estimator"], "sphere");
    assert!(
        j3["max_error"]["candidates"]
            .as_array()
            .unwrap()
            .iter()
            .all(|c| c["knobs"]["estimator"] == "sphere")
    );
    // No candidate can reach 1e-6: a warning, the most accurate one.
    let strict = pen_cached(
        &dir,
        &format!("{base} --max-error 0.000001"),
        &[("mesh", &corner), ("out", &out)],
    );
    assert!(
        strict.stderr.contains("no setting tried is within --max-error"),
        "{}",
        strict.stderr
    );
    assert_eq!(strict.ok().json()["max_error"]["met"], false);
    for bad in ["0", "-1", "nan"] {
        pen_cached(
            &dir,
            &format!("{base} --max-error {bad}"),
            &[("mesh", &corner), ("out", &out)],
        )
        .bad_input(&["--max-error", "must be positive"]);
    }
}

#[test]
fn field_picks_the_cheapest_parameters_within_the_budget() {
    let dir = TempDir::new("max-error-field");
    // A wall standing on a ground twice its footprint: the ground's AO is
    // the field's work.
    let wall_obj = dir.write("wall.obj", std::fs::read(asset_s("wall-on-floor.obj")).unwrap());
    let wall = penumbra::scene::load_obj(std::path::Path::new(&wall_obj)).unwrap();
    let b = wall.bounds();
    let (c, half) = (b.center(), b.extent().max_element());
    let n = 48u32;
    let at = |i: u32| 2.0 * i as f32 / (n - 1) as f32 - 1.0;
    let ground: Vec<glam::Vec3> = (0..n * n)
        .map(|i| glam::Vec3::new(c.x + at(i % n) * half, b.min.y, c.z + at(i / n) * half))
        .collect();
    let quads = (0..(n - 1) * (n - 1)).flat_map(|q| {
        let i = q / (n - 1) * n + q % (n - 1);
        [[i, i + n, i + 1], [i + 1, i + n, i + n + 1]]
    });
    let plane = dir.write("ground.obj", obj_text(&ground, &quads.collect::<Vec<_>>()));
    let csv = dir.p("ao.csv");
    let base = "ao --mesh {mesh} --receiver {receiver} --method field --rays 32 --reference --per-vertex {csv} --device cpu --json";
    let vars = [
        ("mesh", wall_obj.as_str()),
        ("receiver", plane.as_str()),
        ("csv", csv.as_str()),
    ];
    let j = pen_cached(&dir, &format!("{base} --max-error 0.085"), &vars)
        .ok()
        .json();
    let choice = &j["max_error"];
    assert_eq!(choice["met"], true, "{choice}");
    let candidates = choice["candidates"].as_array().unwrap();
    assert!(
        candidates.len() >= 2,
        "the cheapest fields are not within 0.085 here: {choice}"
    );
    // Cheapest first: every candidate before the chosen one was over.
    let last = candidates.last().unwrap();
    assert_eq!(last["knobs"], choice["chosen"]);
    assert!(candidates[..candidates.len() - 1].iter().all(|c| c["within"] == false));
    assert_eq!(
        j["fields"][0]["res"].to_string(),
        choice["chosen"]["res"].as_str().unwrap()
    );
    agrees(choice, j["reference"]["rms_error"].as_f64().unwrap());
    let again = pen_cached(&dir, &format!("{base} --max-error 0.085"), &vars)
        .ok()
        .json();
    assert_eq!(again["max_error"]["cached"], true);
    assert_eq!(
        again["reference"]["rms_error"], j["reference"]["rms_error"],
        "the cached choice gives the same AO"
    );
    // An edited mesh is another scene: checked again.
    let mut edited = std::fs::read_to_string(&wall_obj).unwrap();
    edited.push_str("# edited\n");
    std::fs::write(&wall_obj, edited).unwrap();
    let after = pen_cached(&dir, &format!("{base} --max-error 0.085"), &vars)
        .ok()
        .json();
    assert_eq!(after["max_error"]["cached"], false);
    pen_cached(&dir, &format!("{base} --max-error 0.05 --res 16"), &vars).bad_input(&["--res", "--max-error"]);
}

fn obj_text(positions: &[glam::Vec3], triangles: &[[u32; 3]]) -> String {
    let mut text = String::new();
    for p in positions {
        text += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for t in triangles {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    text
}

#[test]
fn prt_picks_the_fastest_mask_and_hierarchy_within_the_budget() {
    let dir = TempDir::new("max-error-prt");
    let env = common::cli::write_probe(&dir, common::cli::SKY, common::cli::GROUND);
    let mesh = asset_s("sphere-on-plane.obj");
    let base = "prt --mesh {mesh} --env {env} --check --check-rays 1024 --device cpu --json";
    let vars = [("mesh", mesh.as_str()), ("env", env.as_str())];
    let j = pen_cached(&dir, &format!("{base} --max-error 0.05"), &vars).ok().json();
    let choice = &j["max_error"];
    assert_eq!(choice["candidates"].as_array().unwrap().len(), 6, "{choice}");
    let time = |c: &Value| c["time_ms"].as_f64().unwrap();
    let within: Vec<&Value> = choice["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["within"] == true)
        .collect();
    if let Some(fastest) = within.iter().min_by(|a, b| time(a).total_cmp(&time(b))) {
        assert_eq!(fastest["knobs"], choice["chosen"]);
    }
    // The self-check's estimate is of --check's figure (its rays: 4096 there, 1024 here).
    let full = j["transfer_l2_error"].as_f64().unwrap();
    println!("prt: estimate {} full {full}", choice["estimate"]);
    assert!(
        (choice["estimate"].as_f64().unwrap() - full).abs() < 0.01,
        "{choice} vs {full}"
    );
    pen_cached(&dir, &format!("{base} --max-error 0.05 --mask 16"), &vars).bad_input(&["--mask", "--max-error"]);
}
