//! `--shard I/N` and `penumbra merge` as a job scheduler runs them: each
//! shard a separate process, one of them killed part-way and run again,
//! the merged output compared byte for byte with one process's; and the
//! merges refused (a missing part, parts of other commands, inputs or N).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::cli::{Out, TempDir, cmd, run, run_env};
use common::data_model;

/// A shared model when `PENUMBRA_DATA` is set, else a shipped asset.
fn model(shared: &str) -> PathBuf {
    data_model(shared).unwrap_or_else(|| common::asset("cylindrical-well.obj"))
}

fn args(template: &str, vars: &[(&str, &str)], extra: &[&str]) -> Vec<String> {
    let mut a = cmd(template, vars);
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

/// Starts `args`, waits until the part being written holds a record past
/// its header (`partial` grew past its first size and then stayed), then
/// kills the process
/// (SIGKILL: nothing of it runs after). Returns whether it was still
/// running when killed.
fn kill_after_first_record(args: &[String], partial: &Path) -> bool {
    let mut child = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start penumbra");
    let start = Instant::now();
    let mut header = None;
    loop {
        if let Ok(Some(_)) = child.try_wait() {
            return false;
        }
        if let Ok(m) = std::fs::metadata(partial) {
            // The header is written and synced first; a record follows.
            match header {
                None if m.len() > 0 => header = Some(m.len()),
                // Grown past the header, and then still for 10 ms: a
                // record is being written, or was; kill it after.
                Some(h) if m.len() > h => {
                    std::thread::sleep(Duration::from_millis(10));
                    if std::fs::metadata(partial).map(|n| n.len()).ok() == Some(m.len()) {
                        break;
                    }
                }
                _ => {}
            }
        }
        assert!(start.elapsed() < Duration::from_secs(300), "no record in 300 s");
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().expect("kill");
    child.wait().expect("reap");
    true
}

fn partial(output: &Path, i: u32, n: u32) -> PathBuf {
    PathBuf::from(format!("{}.part-{i}-of-{n}.partial", output.display()))
}

fn part(output: &Path, i: u32, n: u32) -> PathBuf {
    PathBuf::from(format!("{}.part-{i}-of-{n}", output.display()))
}

fn merge(output: &Path) -> Out {
    run(&cmd("merge {o} --json", &[("o", output.to_str().unwrap())]))
}

/// Runs shards `0..n` of `template` (`{out}` the output) one after another,
/// shard `killed` first killed part-way and then run again; checks that the
/// rerun kept the killed run's records, and returns each shard's JSON.
fn shards(template: &str, vars: &[(&str, &str)], out: &Path, n: u32, killed: u32) -> Vec<serde_json::Value> {
    let mut reports = Vec::new();
    for i in 0..n {
        let shard = format!("{i}/{n}");
        if i == killed {
            // One thread, so that the shard is still running at its first record.
            let slow = args(template, vars, &["--shard", &shard, "--threads", "1", "--json"]);
            let was_running = kill_after_first_record(&slow, &partial(out, i, n));
            assert!(was_running, "shard {shard} finished before it could be killed");
            assert!(
                !part(out, i, n).exists(),
                "a killed shard left its part under the final name"
            );
            assert!(!out.exists(), "a killed shard wrote the output");
        }
        let a = args(template, vars, &["--shard", &shard, "--json"]);
        let j = run(&a).ok().json();
        if i == killed {
            let kept = j["shard"]["items_kept"].as_u64().unwrap();
            let computed = j["shard"]["items_computed"].as_u64().unwrap();
            assert!(kept > 0, "the rerun kept nothing of the killed run: {j}");
            assert!(computed > 0, "the killed run had finished everything: {j}");
            eprintln!("shard {shard}: {kept} items kept from the killed run, {computed} computed");
        }
        reports.push(j);
    }
    reports
}

/// A bumpy `n` x `n` grid of vertices (a height field that occludes
/// itself), as an OBJ in `d`.
fn bumpy_grid(d: &TempDir, n: usize) -> String {
    let mut obj = String::new();
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f32 / n as f32 * 8.0, j as f32 / n as f32 * 8.0);
            obj += &format!("v {x} {} {y}\n", 0.6 * x.sin() * y.cos());
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = j * n + i + 1;
            obj += &format!("f {} {} {} {}\n", v, v + n, v + n + 1, v + 1);
        }
    }
    d.write("grid.obj", obj)
}

fn same_bytes(a: &Path, b: &Path) {
    let (x, y) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
    assert!(
        x == y,
        "{} ({} bytes) differs from {} ({} bytes)",
        a.display(),
        x.len(),
        b.display(),
        y.len()
    );
}

#[test]
fn per_vertex_ao_in_four_shards_one_killed_is_one_process_byte_for_byte() {
    let d = TempDir::new("shard_ao");
    // Enough vertices that a shard has several records to be killed between.
    let mesh = data_model("stanford-bunny.obj").unwrap_or_else(|| PathBuf::from(bumpy_grid(&d, 200)));
    let (one, split) = (d.p("one.csv"), d.p("split.csv"));
    let template = "ao --method raycast --mesh {m} --rays 512 --device cpu --per-vertex {out}";
    let m = mesh.to_str().unwrap();
    run(&cmd(template, &[("m", m), ("out", &one)])).ok();
    let split_path = PathBuf::from(&split);
    let reports = shards(template, &[("m", m), ("out", &split)], &split_path, 4, 1);
    let items: u64 = reports
        .iter()
        .map(|r| r["shard"]["items"][1].as_u64().unwrap() - r["shard"]["items"][0].as_u64().unwrap())
        .sum();
    let j = merge(&split_path).ok().json();
    assert_eq!(j["merged"]["parts"], 4);
    assert_eq!(j["merged"]["items"].as_u64(), Some(items));
    assert_eq!(j["per_vertex"]["vertices"].as_u64(), Some(items));
    same_bytes(Path::new(&one), &split_path);
}

#[test]
fn ao_image_pixels_in_three_shards_are_one_process_byte_for_byte() {
    let d = TempDir::new("shard_ao_image");
    let mesh = model("spot.obj");
    let m = mesh.to_str().unwrap();
    let template = "ao --method raycast --mesh {m} --rays 64 --device cpu --width 96 --height 64 --image {out}";
    let (one, split) = (d.p("one.png"), d.p("split.png"));
    run(&cmd(template, &[("m", m), ("out", &one)])).ok();
    for i in 0..3 {
        run(&args(
            template,
            &[("m", m), ("out", &split)],
            &["--shard", &format!("{i}/3")],
        ))
        .ok();
    }
    let j = merge(Path::new(&split)).ok().json();
    assert_eq!(j["merged"]["items"], 96 * 64);
    same_bytes(Path::new(&one), Path::new(&split));
}

#[test]
fn a_bake_in_four_shards_one_killed_is_one_process_byte_for_byte() {
    let d = TempDir::new("shard_bake");
    let mesh = data_model("spot.obj").unwrap_or_else(|| common::asset("raytrace/textured-room.obj"));
    let m = mesh.to_str().unwrap();
    let template = "bake --mesh {m} --resolution 512 --rays 256 --device cpu --out {out} --texture {png}";
    let (one, one_png) = (d.p("one.glb"), d.p("one.png"));
    let (split, split_png) = (d.p("split.glb"), d.p("split.png"));
    run(&cmd(template, &[("m", m), ("out", &one), ("png", &one_png)])).ok();
    let split_path = PathBuf::from(&split);
    shards(
        template,
        &[("m", m), ("out", &split), ("png", &split_png)],
        &split_path,
        4,
        0,
    );
    let j = merge(&split_path).ok().json();
    assert_eq!(j["merged"]["parts"], 4);
    same_bytes(Path::new(&one), &split_path);
    same_bytes(Path::new(&one_png), Path::new(&split_png));
}

#[test]
fn a_sweep_in_three_shards_merges_into_one_process_rows() {
    let d = TempDir::new("shard_sweep");
    let mesh = model("cow.obj");
    let m = mesh.to_str().unwrap();
    let template = "sweep ssao --mesh {m} --device cpu --repeat 1 --width 80 --height 60 --out {out}";
    let (one, split) = (d.p("one"), d.p("split"));
    run(&cmd(template, &[("m", m), ("out", &one)])).ok();
    for i in 0..3 {
        run(&args(
            template,
            &[("m", m), ("out", &split)],
            &["--shard", &format!("{i}/3")],
        ))
        .ok();
    }
    let csv = Path::new(&split).join("sweep.csv");
    let j = merge(&csv).ok().json();
    assert_eq!(j["merged"]["parts"], 3);
    // Times are each run's own; every other column is the same bytes.
    let columns = |p: &Path| -> Vec<String> {
        let text = std::fs::read_to_string(p).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let keep: Vec<usize> = (0..header.len())
            .filter(|&k| !["time_ms", "pareto"].contains(&header[k]))
            .collect();
        text.lines()
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                keep.iter().map(|&k| f[k]).collect::<Vec<_>>().join(",")
            })
            .collect()
    };
    let (a, b) = (columns(&Path::new(&one).join("sweep.csv")), columns(&csv));
    assert!(a.len() > 10, "{} rows", a.len());
    assert_eq!(a, b);
    for f in ["sweep.json", "sweep.png"] {
        assert!(Path::new(&split).join(f).is_file(), "{f} not written");
    }
}

#[test]
fn merge_refuses_a_missing_part_other_commands_other_inputs_and_other_counts() {
    let d = TempDir::new("shard_refuse");
    let mesh = d.p("mesh.obj");
    std::fs::copy(model("cow.obj"), &mesh).unwrap();
    let out = d.p("ao.csv");
    let out_path = PathBuf::from(&out);
    let template = "ao --method raycast --mesh {m} --rays {r} --device cpu --per-vertex {out}";
    let shard = |i: u32, n: u32, rays: &str| {
        run(&args(
            template,
            &[("m", &mesh), ("out", &out), ("r", rays)],
            &["--shard", &format!("{i}/{n}")],
        ))
        .ok();
    };
    let clear = || {
        for e in std::fs::read_dir(d.p(".")).unwrap().flatten() {
            if e.file_name().to_string_lossy().starts_with("ao.csv") {
                std::fs::remove_file(e.path()).unwrap();
            }
        }
    };
    // A missing part: nothing written.
    shard(0, 3, "16");
    shard(2, 3, "16");
    merge(&out_path).bad_input(&["ao.csv", "shard(s) 1 of 3 missing"]);
    assert!(!out_path.exists());
    // Another command.
    shard(1, 3, "32");
    merge(&out_path).bad_input(&["different jobs", "command", "--rays"]);
    clear();
    // Other counts.
    shard(0, 2, "16");
    shard(1, 3, "16");
    merge(&out_path).bad_input(&["different shard counts", "2, 3"]);
    clear();
    // Another input: the mesh changed between shards.
    shard(0, 2, "16");
    let mut text = std::fs::read_to_string(&mesh).unwrap();
    text.push_str("\n# edited\n");
    std::fs::write(&mesh, text).unwrap();
    shard(1, 2, "16");
    merge(&out_path).bad_input(&["different jobs", "input", "mesh.obj"]);
    assert!(!out_path.exists());
    // No parts at all.
    clear();
    merge(&out_path).bad_input(&["no parts found"]);
}

#[test]
fn shard_auto_reads_slurm_and_kubernetes_and_names_them_when_unset() {
    let d = TempDir::new("shard_auto");
    let mesh = model("cow.obj");
    let out = d.p("ao.csv");
    let template = "ao --method raycast --mesh {m} --rays 8 --device cpu --per-vertex {out} --json";
    let a = |shard: &str| {
        args(
            template,
            &[("m", mesh.to_str().unwrap()), ("out", &out)],
            &["--shard", shard],
        )
    };
    let unset = [
        ("JOB_COMPLETION_INDEX", None),
        ("SLURM_ARRAY_TASK_ID", None),
        ("SLURM_ARRAY_TASK_COUNT", None),
        ("SLURM_ARRAY_TASK_MIN", None),
    ];
    run_env(&a("auto"), &unset).bad_input(&["--shard", "JOB_COMPLETION_INDEX", "SLURM_ARRAY_TASK_ID"]);
    let mut k8s = unset.to_vec();
    k8s[0].1 = Some("1");
    run_env(&a("auto"), &k8s).bad_input(&["--shard", "auto/N"]);
    let j = run_env(&a("auto/2"), &k8s).ok().json();
    assert_eq!(
        (j["shard"]["index"].as_u64(), j["shard"]["count"].as_u64()),
        (Some(1), Some(2))
    );
    let slurm = [
        ("JOB_COMPLETION_INDEX", None),
        ("SLURM_ARRAY_TASK_ID", Some("1")),
        ("SLURM_ARRAY_TASK_COUNT", Some("2")),
        ("SLURM_ARRAY_TASK_MIN", Some("1")),
    ];
    let j = run_env(&a("auto"), &slurm).ok().json();
    assert_eq!(
        (j["shard"]["index"].as_u64(), j["shard"]["count"].as_u64()),
        (Some(0), Some(2))
    );
    run(&a("2/2")).bad_input(&["--shard", "0..2"]);
    let both = format!("{template} --image {}", d.p("ao.png"));
    run(&args(
        &both,
        &[("m", mesh.to_str().unwrap()), ("out", &out)],
        &["--shard", "0/2"],
    ))
    .bad_input(&["--shard", "one output"]);
}

#[test]
fn a_two_asset_manifest_in_two_shards_is_one_process_byte_for_byte() {
    let d = TempDir::new("shard_manifest");
    let textured = data_model("spot.obj").unwrap_or_else(|| common::asset("raytrace/textured-room.obj"));
    std::fs::copy(&textured, d.p("a.obj")).unwrap();
    std::fs::copy(model("cow.obj"), d.p("b b.obj")).unwrap();
    let manifest = d.write(
        "assets.txt",
        "# two assets, one per line\na.obj --resolution 128 --texture a-ao.png\n\n\"b b.obj\" --resolution 0 --out b.glb\n",
    );
    let (one, split) = (d.p("one"), d.p("split"));
    std::fs::create_dir(&one).unwrap();
    std::fs::create_dir(&split).unwrap();
    let template = "bake --manifest {m} --rays 32 --device cpu --out {out} --json";
    let j = run(&cmd(template, &[("m", &manifest), ("out", &one)])).ok().json();
    assert_eq!(j["assets"].as_array().map(Vec::len), Some(2), "{j}");
    for i in 0..2 {
        let s = run(&args(
            template,
            &[("m", &manifest), ("out", &split)],
            &["--shard", &format!("{i}/2")],
        ))
        .ok()
        .json();
        assert_eq!(s["shard"]["items_computed"], 1, "{s}");
    }
    let j = merge(Path::new(&split)).ok().json();
    assert_eq!(j["assets"][1]["line"], 4, "{j}");
    for f in ["a.glb", "a-ao.png", "b.glb"] {
        same_bytes(&Path::new(&one).join(f), &Path::new(&split).join(f));
    }
    // A missing baked asset is refused by name; a bad line names the line.
    std::fs::remove_file(Path::new(&split).join("b.glb")).unwrap();
    merge(Path::new(&split)).bad_input(&["b.glb", "manifest line 4", "shard 1"]);
    let bad = d.write("bad.txt", "a.obj\na.obj --resolution -3 --out c.glb\n");
    run(&cmd(template, &[("m", &bad), ("out", &one)])).bad_input(&["bad.txt", "line 2", "--resolution"]);
    let twice = d.write("twice.txt", "a.obj\na.obj\n");
    run(&cmd(template, &[("m", &twice), ("out", &one)])).bad_input(&["twice.txt", "line 2", "as line 1 does"]);
}

#[test]
fn one_large_image_in_three_shards_one_killed_is_one_process_byte_for_byte() {
    let d = TempDir::new("shard_image");
    let mesh = model("stanford-bunny.obj");
    let m = mesh.to_str().unwrap();
    // The CPU's packets path (the bunny's triangles are above its threshold).
    let template = "raytrace --method whitted --mesh {m} --width 320 --height 240 --spp 4 --device cpu --out {out}";
    let (one, split) = (d.p("one.png"), d.p("split.png"));
    run(&cmd(template, &[("m", m), ("out", &one)])).ok();
    let split_path = PathBuf::from(&split);
    shards(template, &[("m", m), ("out", &split)], &split_path, 3, 1);
    let j = merge(&split_path).ok().json();
    assert_eq!(j["merged"]["items"], 240, "rows are the items: {j}");
    same_bytes(Path::new(&one), &split_path);
}
