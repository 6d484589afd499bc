//! The minimum Rust version stated in Cargo.toml (`rust-version`) covers
//! every dependency's own: a dependency that needs a newer compiler fails
//! here, not on a user's older toolchain. (Cargo itself refuses a toolchain
//! older than the stated version, which CI's build checks.)

use std::process::Command;

fn version(text: &str) -> Vec<u32> {
    let mut v: Vec<u32> = text.split('.').map(|p| p.parse().unwrap()).collect();
    v.resize(3, 0);
    v
}

#[test]
fn stated_rust_version_covers_every_dependency() {
    let out = Command::new(env!("CARGO"))
        .args(["metadata", "--format-version", "1", "--offline"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let packages = meta["packages"].as_array().unwrap();
    let ours = packages.iter().find(|p| p["name"] == "penumbra").unwrap();
    let stated = version(ours["rust_version"].as_str().expect("rust-version is stated"));
    let mut highest = (vec![0, 0, 0], String::new());
    for p in packages {
        if let Some(v) = p["rust_version"].as_str() {
            let v = version(v);
            assert!(
                v <= stated,
                "{} needs Rust {v:?}, above the stated {stated:?}",
                p["name"]
            );
            if v > highest.0 {
                highest = (v, p["name"].as_str().unwrap().to_string());
            }
        }
    }
    println!(
        "stated {stated:?}; the highest a dependency needs: {:?} ({})",
        highest.0, highest.1
    );
}

/// The library with its default features off carries none of the command
/// line's crates nor the optional formats' (what a host engine that adds
/// `penumbra = { default-features = false }` builds).
#[test]
fn the_library_without_default_features_builds_none_of_the_command_lines_crates() {
    let out = Command::new(env!("CARGO"))
        .args([
            "tree",
            "-p",
            "penumbra",
            "-e",
            "normal",
            "--no-default-features",
            "--offline",
        ])
        .args(["--prefix", "none"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo tree runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let mut crates: Vec<&str> = text.lines().filter_map(|l| l.split_whitespace().next()).collect();
    crates.sort_unstable();
    crates.dedup();
    println!("penumbra without default features: {} crates", crates.len());
    let forbidden = [
        "clap",
        "indicatif",
        "ctrlc",
        "plotters",
        "meshopt",
        "image",
        "exr",
        "gltf",
    ];
    let found: Vec<&&str> = forbidden.iter().filter(|f| crates.contains(f)).collect();
    assert!(
        found.is_empty(),
        "the library without default features pulls in {found:?}"
    );
    assert!(crates.contains(&"wgpu") && crates.contains(&"glam"), "{crates:?}");
}

/// The library documents every public item (`#![warn(missing_docs)]`) and
/// its docs build without a warning: rustdoc run with warnings as errors.
#[test]
fn the_library_docs_build_without_a_warning() {
    let out = Command::new(env!("CARGO"))
        .args(["doc", "-p", "penumbra", "--no-deps", "--offline"])
        .env("RUSTDOCFLAGS", "-D warnings")
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo doc runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "cargo doc -p penumbra failed:\n{stderr}");
    assert!(!stderr.contains("warning:"), "{stderr}");
}

/// Every crate's features as `cargo tree` resolves them over the workspace
/// with `edges` (a crate built twice, e.g. as a build dependency, keeps
/// each set).
fn features(edges: &str) -> std::collections::BTreeMap<String, std::collections::BTreeSet<String>> {
    let out = Command::new(env!("CARGO"))
        .args([
            "tree",
            "--workspace",
            "-e",
            edges,
            "-f",
            "{p} {f}",
            "--prefix",
            "none",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo tree runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut map = std::collections::BTreeMap::<String, std::collections::BTreeSet<String>>::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        if words.len() < 2 {
            continue;
        }
        let last = words[words.len() - 1];
        let listed = words.len() > 2 && !last.starts_with('(') && !last.ends_with(')');
        let features = if listed { last } else { "" };
        map.entry(format!("{} {}", words[0], words[1]))
            .or_default()
            .insert(features.to_string());
    }
    map
}

/// `cargo test --release` (dev-dependencies included) and `cargo run
/// --release` (without them) resolve every crate the binary uses with the
/// same features, so the binary after the suite is the suite's build and
/// the README's first job starts at once.
#[test]
fn the_test_build_and_the_binary_resolve_the_same_features() {
    let with_dev = features("normal,build,dev");
    let without = features("normal,build");
    let differing: Vec<String> = without
        .iter()
        .filter(|(name, f)| with_dev.get(*name).is_some_and(|d| d != *f))
        .map(|(name, f)| format!("{name}: binary {f:?}, tests {:?}", with_dev[name]))
        .collect();
    assert!(differing.is_empty(), "features differ:\n{}", differing.join("\n"));
}
