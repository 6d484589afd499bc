//! The suite's count of skipped GPU tests, printed once at its end.
//!
//! Every test that skips a GPU part for want of an adapter lists it in
//! `common::skips_file()` (see `common::skip_gpu`; where a GPU is expected,
//! `CI` or `PENUMBRA_REQUIRE_GPU=1`, it fails instead). cargo runs the test
//! files one process each, the library's first, then the command line's
//! in the order of their names: this file's name puts it last, so its one
//! test reads what the run before it listed (the lines of the same `cargo
//! test` process), prints the count past the test harness's capture, and
//! empties the list for the next run.

mod common;

use std::io::Write;

#[test]
fn the_suite_reports_its_skipped_gpu_tests() {
    let path = common::skips_file();
    let listed = std::fs::read_to_string(&path).unwrap_or_default();
    let cargo = std::os::unix::process::parent_id().to_string();
    let skipped: Vec<&str> = listed
        .lines()
        .filter(|l| l.split('\t').next() == Some(cargo.as_str()))
        .collect();
    let mut report = format!(
        "\npenumbra suite: {} GPU test part(s) skipped for want of an adapter{}\n",
        skipped.len(),
        if common::gpu_required() {
            " (a GPU is required here: CI or PENUMBRA_REQUIRE_GPU=1)"
        } else {
            ""
        }
    );
    for line in &skipped {
        let fields: Vec<&str> = line.split('\t').collect();
        report.push_str(&format!("  skipped: {}\n", fields[1..].join(" | ")));
    }
    // Straight to the process's stderr: libtest captures `eprintln!` of a
    // passing test, and this count is for the person reading the run.
    let _ = std::io::stderr().write_all(report.as_bytes());
    let _ = std::fs::remove_file(&path);
    assert!(
        !common::gpu_required() || skipped.is_empty(),
        "a GPU is required, yet {} GPU part(s) were skipped",
        skipped.len()
    );
}
