//! Messages name what the user typed: the option (or its alias) given, the
//! scene file and its field; and every number-valued option takes a
//! leading minus as its value, which its own range then refuses.

mod common;

use common::cli::{TempDir, pen, write_probe};
use penumbra_cli::{Numeric, numeric_options, parse_error};

const OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\n";

/// Every option whose values are numbers or lists of numbers: `-1` (or
/// `-1,0,0`, `-1,0`) is its value, never clap's "unexpected argument".
#[test]
fn every_numeric_option_takes_a_leading_minus() {
    let options = numeric_options();
    let lists = options.iter().filter(|o| o.2 == Numeric::List).count();
    println!("{} numeric options, {lists} of them lists", options.len());
    // The option the issue found, and a point of the camera.
    for (sub, long) in [("prt", "albedo"), ("ao", "eye"), ("raytrace", "ray-tree")] {
        assert!(
            options
                .iter()
                .any(|o| o.0 == sub && o.1 == long && o.2 == Numeric::List),
            "{sub} --{long} is a list of numbers"
        );
    }
    let mut failures = Vec::new();
    for (sub, long, kind) in &options {
        let values: &[&str] = match kind {
            Numeric::Number => &["-1", "-0.5"],
            Numeric::List => &["-1,0,0", "-1,0"],
        };
        for value in values {
            let flag = format!("--{long}");
            let Some(e) = parse_error(&["penumbra", sub, &flag, value]) else {
                continue;
            };
            // Refused as no value, or with the integer type's range
            // (`0..=4294967295`) rather than the option's own bound.
            if e.contains("unexpected argument") || e.contains("a value is required") || e.contains("is not in") {
                failures.push(format!("{sub} {flag} {value}: {e}"));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "refused without the option's range:\n{}",
        failures.join("\n")
    );
}

/// A negative count meets the option's own least value, under the name
/// typed (an alias included), with exit 2.
#[test]
fn a_negative_count_names_the_options_least_value() {
    let cases = [
        ("ao --mesh m.obj --rays -1", "--rays", "at least 1, got -1"),
        ("trace --mesh m.obj --tile -1", "--tile", "at least 4, got -1"),
        ("raytrace --mesh m.obj --spp -2", "--spp", "at least 1, got -2"),
        (
            "raytrace --mesh m.obj --max-depth -1",
            "--max-depth",
            "at least 0, got -1",
        ),
        ("ao --mesh m.obj --rays 4 --width -8", "--width", "at least 1, got -8"),
        (
            "ao --mesh m.obj --rays 4 --threads -1",
            "--threads",
            "at least 1, got -1",
        ),
        (
            "ssao --mesh m.obj --spp 4 --truth-rays -1",
            "--truth-rays",
            "at least 0, got -1",
        ),
        ("ao --mesh m.obj --rays 4 --repeat -3", "--repeat", "at least 1, got -3"),
    ];
    for (line, flag, problem) in cases {
        let r = pen(line, &[]);
        println!("{line}: {}", r.stderr.trim());
        assert_eq!(r.code, 2, "{line}\n{}", r.describe());
        assert!(
            r.stderr.contains(&format!("penumbra: error: {flag}: ")) && r.stderr.contains(problem),
            "{line}\n{}",
            r.describe()
        );
    }
}

/// A negative list value reaches the option's own check, by name.
#[test]
fn a_negative_list_value_meets_the_options_range() {
    let dir = TempDir::new("negative_list");
    let mesh = dir.write("m.obj", OBJ);
    let probe = write_probe(&dir, [1.0; 3], [0.5; 3]);
    let out = dir.p("o.png");
    pen(
        "prt --mesh {mesh} --env {probe} --device cpu --width 8 --height 8 --out {out} --albedo -1,0,0",
        &[("mesh", &mesh), ("probe", &probe), ("out", &out)],
    )
    .bad_input(&["--albedo", "non-negative"]);
}

/// An alias names itself in the message (`--check-rays` is
/// `--reference-rays`'s).
#[test]
fn the_alias_typed_is_the_option_named() {
    let dir = TempDir::new("alias_named");
    let mesh = dir.write("m.obj", OBJ);
    let probe = write_probe(&dir, [1.0; 3], [0.5; 3]);
    let out = pen(
        "prt --mesh {mesh} --env {probe} --device cpu --reference --check-rays 0",
        &[("mesh", &mesh), ("probe", &probe)],
    );
    out.bad_input(&["--check-rays", "must be positive"]);
    assert!(!out.stderr.contains("--reference-rays"), "{}", out.describe());
    pen(
        "prt --mesh {mesh} --env {probe} --device cpu --reference --reference-rays 0",
        &[("mesh", &mesh), ("probe", &probe)],
    )
    .bad_input(&["--reference-rays", "must be positive"]);
}

/// A scene whose instances, placed, are too large for f32 is refused
/// naming the scene file and the instance, not `--mesh`.
#[test]
fn a_placement_too_large_names_the_scene_and_instance() {
    let dir = TempDir::new("placement_extent");
    dir.write("m.obj", OBJ);
    let scene = dir.write(
        "big.json",
        r#"{"meshes": {"m": "m.obj"},
            "instances": [{"mesh": "m"}, {"mesh": "m", "translate": [3e38, 0, 0]}]}"#,
    );
    let scaled = dir.write(
        "scaled.json",
        r#"{"meshes": {"m": "m.obj"}, "instances": [{"mesh": "m", "scale": 1e38}]}"#,
    );
    let csv = dir.p("o.csv");
    for (file, instance) in [(&scene, "instances[1]"), (&scaled, "instances[0]")] {
        for template in [
            "ao --scene {scene} --method raycast --rays 4 --per-vertex {csv} --device cpu",
            "trace --scene {scene} --width 8 --height 8 --device cpu",
        ] {
            let out = pen(template, &[("scene", file), ("csv", &csv)]);
            out.bad_input(&[file, instance, "extent"]);
            assert!(!out.stderr.contains("--mesh"), "{}", out.describe());
        }
    }
}
