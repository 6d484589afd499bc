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
