//! `--shard I/N` over the frames of a walk: `raytrace --method whitted
//! --frames N --out 'walk-{}.png'` split 3 ways as separate processes, one
//! shard killed after its first frame's record and run again, then
//! `penumbra merge`: every frame byte-identical to one process's and the
//! report's sums the same; the same for `ao --method field --frames N`
//! split 2 ways (per-vertex CSVs and images). `merge` refuses a missing
//! frame file, and what is not split (one image, --method bounded, prt's
//! options that cannot be split) is refused naming --shard. A `prt` walk
//! split 2 ways with a killed shard: every frame's image byte-identical to
//! one process's and the merged report's counts and errors the same; a
//! `prt --scene` of moving objects into `--out-frames` split 2 ways, the
//! same.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::cli::{TempDir, asset_s, cmd, pen, run, write_probe};

/// 320 x 240 at 4 samples on one thread: a frame takes long enough to
/// kill a shard between its two frames.
fn walk(dir: &TempDir, frames: u32) -> Vec<String> {
    let path = dir.write("path.txt", "0,3,8 0,0.8,0 45\n4,3,6 0,0.8,0 45\n");
    cmd(
        &format!(
            "raytrace --method whitted --width 320 --height 240 --spp 4 --scene {{s}} --frames {frames} \
             --path {{p}} --threads 1 --device cpu --json"
        ),
        &[("s", &asset_s("raytrace/checker-spheres.json")), ("p", &path)],
    )
}

fn with(mut args: Vec<String>, extra: &[&str]) -> Vec<String> {
    args.extend(extra.iter().map(|s| s.to_string()));
    args
}

/// `penumbra merge OUT` (the pattern's braces are the binary's, so not
/// through `cmd`).
fn merge(out: &str, json: bool) -> Vec<String> {
    let mut args = vec!["merge".to_string(), out.to_string()];
    if json {
        args.push("--json".into());
    }
    args
}

/// Whether `partial` (a part being written) holds a whole first record: the
/// magic line, the job's line, then first item, count, seconds and payload
/// length (8 bytes each), the payload and a CRC-32.
fn has_a_record(partial: &Path) -> bool {
    let Ok(bytes) = std::fs::read(partial) else {
        return false;
    };
    let mut lines = 0;
    let Some(at) = bytes.iter().position(|&b| {
        lines += (b == b'\n') as usize;
        lines == 2
    }) else {
        return false;
    };
    let rest = &bytes[at + 1..];
    if rest.len() < 32 {
        return false;
    }
    let len = u64::from_le_bytes(rest[24..32].try_into().unwrap()) as usize;
    rest.len() >= 32 + len + 4
}

#[test]
fn a_walk_split_three_ways_with_a_killed_shard_merges_to_one_process() {
    let dir = TempDir::new("shard-frames-rt");
    let frames = 6;
    let args = walk(&dir, frames);
    let one = run(&with(args.clone(), &["--out", &dir.p("one-{}.png")])).ok().json();
    let out = dir.p("walk-{}.png");
    let sharded = with(args, &["--out", &out]);

    // Shard 1 killed once its first frame is recorded, its second not yet.
    let partial = format!("{out}.part-1-of-3.partial");
    let mut child = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(with(sharded.clone(), &["--shard", "1/3"]))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("starts");
    let start = Instant::now();
    while !has_a_record(Path::new(&partial)) {
        assert!(start.elapsed() < Duration::from_secs(120), "no record in {partial}");
        assert!(
            child.try_wait().unwrap().is_none(),
            "shard 1 ended before it was killed"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !Path::new(&format!("{out}.part-1-of-3.json")).exists(),
        "killed before it finished"
    );
    // A merge now names the shard still being written.
    run(&merge(&out, false)).bad_input(&["shard 1/3 is still being written"]);

    let mut kept = 0;
    for index in 0..3 {
        let j = run(&with(sharded.clone(), &["--shard", &format!("{index}/3")]))
            .ok()
            .json();
        assert_eq!(j["shard"]["items"], serde_json::json!([2 * index, 2 * index + 2]));
        assert_eq!(
            j["frame_ms"].as_array().unwrap().len(),
            2,
            "a shard reports its own frames"
        );
        kept += j["shard"]["items_kept"].as_u64().unwrap();
        if index == 1 {
            assert_eq!(
                j["shard"]["items_kept"], 1,
                "the frame recorded before the kill is kept"
            );
            assert_eq!(j["shard"]["items_computed"], 1);
        }
    }
    assert_eq!(kept, 1);
    // Every frame is where one process writes it, and the same bytes.
    for f in 0..frames {
        let a = std::fs::read(dir.p(&format!("one-{f}.png"))).unwrap();
        let b = std::fs::read(dir.p(&format!("walk-{f}.png"))).unwrap();
        assert!(a == b, "frame {f} differs from one process's");
    }
    let merged = run(&merge(&out, true)).ok().json();
    for field in [
        "rays",
        "camera",
        "frames",
        "width",
        "height",
        "spp",
        "path",
        "timing",
        "triangles",
    ] {
        assert_eq!(merged[field], one[field], "{field}");
    }
    let frame_ms = merged["frame_ms"].as_array().unwrap();
    assert_eq!(frame_ms.len(), frames as usize);
    let sum: f64 = frame_ms.iter().map(|v| v.as_f64().unwrap()).sum();
    assert!((merged["render_ms"].as_f64().unwrap() - sum).abs() < 1e-6);
    assert_eq!(merged["runs"]["ms"][0], merged["render_ms"]);
    assert_eq!(merged["merged"]["parts"], 3);

    // A frame file lost after its shard recorded it: merge names it.
    std::fs::remove_file(dir.p("walk-3.png")).unwrap();
    run(&merge(&out, true)).bad_input(&["walk-3.png", "frame 3 is missing", "1/3"]);
}

#[test]
fn what_is_not_split_is_refused_naming_shard() {
    let dir = TempDir::new("shard-frames-refused");
    let args = walk(&dir, 3);
    // A walk written as its last frame alone: neither one image nor a frame each.
    let walk_frames = "the frames of a walk (--frames N and an --out name holding {}";
    run(&with(args.clone(), &["--out", &dir.p("last.png"), "--shard", "0/2"])).bad_input(&["--shard", walk_frames]);
    let single = cmd(
        "raytrace --method whitted --width 32 --height 24 --scene {s} --device cpu --json",
        &[("s", &asset_s("raytrace/checker-spheres.json"))],
    );
    // One frame is one image, its rows split.
    let j = run(&with(single, &["--out", &dir.p("f-{}.png"), "--shard", "0/2"]))
        .ok()
        .json();
    assert_eq!(j["shard"]["items"][1], 12, "{j}");
    let mut bounded = with(args, &["--out", &dir.p("b-{}.png"), "--shard", "0/2"]);
    bounded[2] = "bounded".into();
    run(&bounded).bad_input(&["--shard", "--method bounded is not split"]);
    assert!(!Path::new(&dir.p("b-0.png")).exists(), "refused before any frame");

    let probe = write_probe(&dir, [2.0, 1.8, 1.5], [0.2, 0.2, 0.25]);
    // The braces of a frame pattern are the binary's, so not through `cmd`.
    let prt = |extra: &[&str], out: &str| {
        let template = "prt --mesh {m} --env {e} --frames 4 --width 32 --height 24 --shard 0/2 --json";
        let mesh = asset_s("raytrace/checker-spheres.obj");
        let args = with(cmd(template, &[("m", &mesh), ("e", &probe)]), extra);
        run(&with(args, &["--out", &dir.p(out)]))
    };
    prt(&[], "prt.png").bad_input(&["--shard", "an --out name holding {}"]);
    prt(&["--max-error", "0.05"], "p-{}.png").bad_input(&["--shard", "--max-error", "timing"]);
    let csv = dir.p("v.csv");
    prt(&["--per-vertex", &csv], "p-{}.png").bad_input(&["--shard", "--per-vertex", "one CSV"]);
    prt(&["--repeat", "2"], "p-{}.png").bad_input(&["--shard", "--repeat"]);
    assert!(!Path::new(&dir.p("p-0.png")).exists(), "refused before any frame");
    let field = "ao --method field --rays 16 --mesh {m} --receiver {m} --frames 2 --per-vertex {o} --shard 0/2 --json";
    let mesh = asset_s("raytrace/checker-spheres.obj");
    pen(field, &[("m", &mesh), ("o", &dir.p("v.csv"))]).bad_input(&["--shard", "--frames N (N > 1)"]);
}

/// A receiver, an object that casts and receives while it moves (its own
/// self-occlusion is recast every frame) and a still caster.
fn moving_scene(dir: &TempDir) -> String {
    dir.write(
        "scene.json",
        format!(
            r#"{{
  "meshes": {{ "corner": "{}", "cube": "{}" }},
  "instances": [
    {{ "mesh": "corner", "role": "receiver" }},
    {{ "mesh": "cube", "role": "both", "scale": 0.15, "translate": [0.4, 0.2, 0.4],
       "motion": {{ "degrees_per_frame": 20, "translate_per_frame": [0.05, 0, 0] }} }},
    {{ "mesh": "cube", "role": "caster", "scale": 0.1, "translate": [0.2, 0.3, 0.7] }}
  ]
}}"#,
            asset_s("corner.obj").replace('\\', "/"),
            asset_s("cube-with-hole.obj").replace('\\', "/")
        ),
    )
}

#[test]
fn field_frames_split_two_ways_merge_to_one_process() {
    let dir = TempDir::new("shard-frames-field");
    let frames = 5;
    let args = cmd(
        &format!(
            "ao --scene {{s}} --method field --rays 16 --positions 100 --res 8 --frames {frames} \
             --device cpu --json"
        ),
        &[("s", &moving_scene(&dir))],
    );
    for (name, option) in [("v-{}.csv", "--per-vertex"), ("i-{:04}.png", "--image")] {
        let args = match option {
            "--image" => with(args.clone(), &["--width", "48", "--height", "32"]),
            _ => args.clone(),
        };
        let one = run(&with(args.clone(), &[option, &dir.p(&format!("one-{name}"))]))
            .ok()
            .json();
        let out = dir.p(name);
        for index in 0..2 {
            let j = run(&with(args.clone(), &[option, &out, "--shard", &format!("{index}/2")]))
                .ok()
                .json();
            let (start, end) = (index * frames / 2, (index + 1) * frames / 2);
            assert_eq!(j["shard"]["items"], serde_json::json!([start, end]));
            assert_eq!(j["frame_ao_ms"].as_array().unwrap().len(), (end - start) as usize);
        }
        let merged = run(&merge(&out, true)).ok().json();
        for f in 0..frames {
            let file = |prefix: &str| {
                let name = name.replace("{:04}", &format!("{f:04}")).replace("{}", &f.to_string());
                std::fs::read(dir.p(&format!("{prefix}{name}"))).unwrap()
            };
            assert!(
                file("one-") == file(""),
                "{option} frame {f} differs from one process's"
            );
        }
        for field in ["frames", "points", "rays_inside_sphere", "rays_hidden", "casters"] {
            assert_eq!(merged[field], one[field], "{option}: {field}");
        }
        assert_eq!(merged["frame_ao_ms"].as_array().unwrap().len(), frames as usize);
        // Frame 0's self-occlusion, then every later frame's moving object's.
        assert_eq!(merged["self_occlusion_ms"].as_array().unwrap().len(), frames as usize);
        let summary = if option == "--image" { "image" } else { "per_vertex" };
        assert_eq!(merged[summary]["mean_ao"], one[summary]["mean_ao"], "{option}");
        assert_eq!(merged["merged"]["parts"], 2);
    }
    // A frame file lost: merge names it.
    std::fs::remove_file(dir.p("v-1.csv")).unwrap();
    run(&merge(&dir.p("v-{}.csv"), true)).bad_input(&["v-1.csv", "frame 1 is missing", "0/2"]);
}

/// `prt` of the cloth with a PVS, exposure set by frame 0 and ray-traced
/// checks spread over the frames, 1 thread.
fn prt_walk(dir: &TempDir, frames: u32) -> Vec<String> {
    let probe = write_probe(dir, [2.0, 1.8, 1.5], [0.2, 0.2, 0.25]);
    cmd(
        &format!(
            "prt --animated cloth --env {{e}} --frames {frames} --width 64 --height 48 --pvs on --pvs-frames 2 \
             --env-spin 15 --reference --reference-rays 64 --threads 1 --device cpu --json"
        ),
        &[("e", &probe)],
    )
}

#[test]
fn a_prt_walk_split_two_ways_with_a_killed_shard_merges_to_one_process() {
    let dir = TempDir::new("shard-frames-prt");
    let frames = 8;
    let args = prt_walk(&dir, frames);
    let one = run(&with(args.clone(), &["--out", &dir.p("one-{}.png")])).ok().json();
    let out = dir.p("walk-{}.png");
    let sharded = with(args, &["--out", &out]);

    // Shard 1 (frames 4..8, which does not play frame 0 that sets the
    // exposure) killed once its first frame is recorded.
    let partial = format!("{out}.part-1-of-2.partial");
    let mut child = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(with(sharded.clone(), &["--shard", "1/2"]))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("starts");
    let start = Instant::now();
    while !has_a_record(Path::new(&partial)) {
        assert!(start.elapsed() < Duration::from_secs(120), "no record in {partial}");
        assert!(
            child.try_wait().unwrap().is_none(),
            "shard 1 ended before it was killed"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!Path::new(&format!("{out}.part-1-of-2.json")).exists());

    for index in 0..2 {
        let j = run(&with(sharded.clone(), &["--shard", &format!("{index}/2")]))
            .ok()
            .json();
        assert_eq!(j["shard"]["items"], serde_json::json!([4 * index, 4 * index + 4]));
        assert_eq!(j["frames"], 4, "a shard reports its own frames");
        assert_eq!(j["exposure"], one["exposure"], "frame 0's exposure in shard {index}");
        if index == 1 {
            let kept = j["shard"]["items_kept"].as_u64().unwrap();
            assert!(kept > 0, "the frames recorded before the kill are kept");
            assert_eq!(j["shard"]["items_computed"].as_u64().unwrap(), 4 - kept);
        }
    }
    for f in 0..frames {
        let a = std::fs::read(dir.p(&format!("one-{f}.png"))).unwrap();
        let b = std::fs::read(dir.p(&format!("walk-{f}.png"))).unwrap();
        assert!(a == b, "frame {f} differs from one process's");
    }
    let merged = run(&merge(&out, true)).ok().json();
    for field in [
        "frames",
        "images",
        "exposure",
        "camera",
        "vertices",
        "blockers_per_vertex",
        "culling_per_vertex",
        "without_normal",
        "check",
        "transfer_l2_error",
        "lighting",
        "hierarchy",
    ] {
        assert_eq!(merged[field], one[field], "{field}");
    }
    assert_eq!(merged["pvs"]["avg_size"], one["pvs"]["avg_size"]);
    assert_eq!(merged["self_check"]["estimate"], one["self_check"]["estimate"]);
    assert_eq!(merged["check"]["frames"].as_array().unwrap().len(), 4);
    let total: f64 = (merged["frame_ms"]["mean"].as_f64().unwrap()) * frames as f64;
    assert!((merged["runs"]["ms"][0].as_f64().unwrap() - total).abs() < 1e-6 * total.max(1.0));
    assert_eq!(merged["merged"]["parts"], 2);

    // A frame's image lost after its shard recorded it: merge names it.
    std::fs::remove_file(dir.p("walk-5.png")).unwrap();
    run(&merge(&out, true)).bad_input(&["walk-5.png", "frame 5 is missing", "1/2"]);
}

#[test]
fn a_prt_scene_split_two_ways_merges_to_one_process() {
    let dir = TempDir::new("shard-frames-prt-scene");
    let frames = 4;
    let probe = write_probe(&dir, [2.0, 1.8, 1.5], [0.2, 0.2, 0.25]);
    let args = cmd(
        &format!(
            "prt --scene {{s}} --env {{e}} --frames {frames} --width 48 --height 32 --env-spin 15 --reference \
             --reference-rays 32 --threads 1 --device cpu --json"
        ),
        &[("s", &moving_scene(&dir)), ("e", &probe)],
    );
    std::fs::create_dir(dir.p("one")).unwrap();
    std::fs::create_dir(dir.p("split")).unwrap();
    let one = run(&with(args.clone(), &["--out-frames", &dir.p("one")])).ok().json();
    let sharded = with(args, &["--out-frames", &dir.p("split")]);
    for index in 0..2 {
        let j = run(&with(sharded.clone(), &["--shard", &format!("{index}/2")]))
            .ok()
            .json();
        assert_eq!(j["frames"], 2, "a shard reports its own frames");
    }
    for f in 0..frames {
        let name = format!("frame-{f:04}.png");
        let a = std::fs::read(dir.p(&format!("one/{name}"))).unwrap();
        let b = std::fs::read(dir.p(&format!("split/{name}"))).unwrap();
        assert!(a == b, "frame {f} differs from one process's");
    }
    let merged = run(&merge(&dir.p("split"), true)).ok().json();
    for field in [
        "frames",
        "images",
        "exposure",
        "vertices",
        "blockers_per_vertex",
        "check",
        "transfer_l2_error",
        "errors_by_inter_object",
        "inter_object_cost",
    ] {
        assert_eq!(merged[field], one[field], "{field}");
    }
    for (a, b) in merged["objects"]
        .as_array()
        .unwrap()
        .iter()
        .zip(one["objects"].as_array().unwrap())
    {
        assert_eq!(a["errors_by_inter_object"], b["errors_by_inter_object"]);
        assert_eq!(a["self_check"]["estimate"], b["self_check"]["estimate"]);
    }
}
