//! `penumbra bake` from the command line: a GLB and its PNG written, the
//! JSON's counts, and the refusals (no texture coordinates, a PNG depth that
//! does not exist) with exit code 2, nothing written.

mod common;

use common::cli::{TempDir, pen};

const QUAD_ON_FLOOR: &str = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv -0.3 0.3 -0.3\nv 0.3 0.3 -0.3\nv 0.3 0.3 0.3\nv -0.3 0.3 0.3\n\
vt 0 0\nvt 0.5 0\nvt 0.5 1\nvt 0 1\nvt 0.6 0\nvt 1 0\nvt 1 1\nvt 0.6 1\n\
f 1/1 4/4 3/3 2/2\nf 5/5 6/6 7/7 8/8\n";

#[test]
fn bake_writes_the_glb_and_the_png_and_reports_the_layout() {
    let d = TempDir::new("bake_ok");
    let mesh = d.p("scene.obj");
    std::fs::write(&mesh, QUAD_ON_FLOOR).unwrap();
    let (glb, png) = (d.p("out.glb"), d.p("ao.png"));
    let out = pen(
        "bake --mesh {m} --out {g} --texture {t} --resolution 64 --rays 32 --device cpu --json",
        &[("m", &mesh), ("g", &glb), ("t", &png)],
    );
    let j = out.ok().json();
    let bake = &j["bake"];
    assert_eq!(bake["resolution"], 64);
    assert_eq!(bake["materials_with_ao"], 1);
    assert_eq!(bake["primitives_with_ao"], 1);
    assert!(bake["texels_covered"].as_u64().unwrap() > 64 * 64 / 2, "{bake}");
    assert!(std::fs::read(&glb).unwrap().starts_with(b"glTF"));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    // The floor under the raised quad is darker than its open edge.
    assert!(bake["mean_texel_ao"].as_f64().unwrap() < 1.0);
}

#[test]
fn bad_bakes_exit_2_naming_the_problem_and_write_nothing() {
    let d = TempDir::new("bake_bad");
    let bare = d.p("bare.obj");
    std::fs::write(&bare, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let glb = d.p("out.glb");
    pen("bake --mesh {m} --out {g} --rays 8", &[("m", &bare), ("g", &glb)]).bad_input(&[
        "bare.obj",
        "texture coordinates",
        "--resolution 0",
    ]);
    assert!(!std::path::Path::new(&glb).exists());
    pen(
        "bake --mesh {m} --out {g} --rays 8 --png-bits 12",
        &[("m", &bare), ("g", &glb)],
    )
    .bad_input(&["--png-bits", "8 or 16"]);
    pen(
        "bake --mesh {m} --out {g} --rays 8 --resolution 0 --vertex off",
        &[("m", &bare), ("g", &glb)],
    )
    .bad_input(&["nothing to bake"]);
    assert!(!std::path::Path::new(&glb).exists());
    // Per-vertex AO alone works without texture coordinates.
    pen(
        "bake --mesh {m} --out {g} --rays 8 --resolution 0 --device cpu",
        &[("m", &bare), ("g", &glb)],
    )
    .ok();
    assert!(std::path::Path::new(&glb).exists());
}

#[test]
fn a_scene_bakes_one_glb_per_mesh_into_the_out_folder() {
    let d = TempDir::new("bake_scene");
    std::fs::write(
        d.p("floor.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 4/4 3/3 2/2\n",
    )
    .unwrap();
    std::fs::write(
        d.p("card.obj"),
        "v -0.3 0 -0.3\nv 0.3 0 -0.3\nv 0.3 0 0.3\nv -0.3 0 0.3\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 4/4 3/3 2/2\n",
    )
    .unwrap();
    let scene = d.p("scene.json");
    std::fs::write(
        &scene,
        r#"{"meshes": {"floor": "floor.obj", "card": "card.obj"},
            "instances": [{"mesh": "floor"}, {"mesh": "card", "translate": [0, 0.2, 0]}]}"#,
    )
    .unwrap();
    let out = d.p("baked");
    std::fs::create_dir_all(&out).unwrap();
    let j = pen(
        "bake --scene {s} --out {o} --resolution 32 --rays 32 --device cpu --json",
        &[("s", &scene), ("o", &out)],
    )
    .ok()
    .json();
    let assets = j["assets"].as_array().unwrap();
    assert_eq!(assets.len(), 2);
    for name in ["floor", "card"] {
        assert!(std::path::Path::new(&out).join(format!("{name}.glb")).exists());
    }
    pen(
        "bake --scene {s} --out {o} --texture {t} --rays 8",
        &[("s", &scene), ("o", &out), ("t", &d.p("x.png"))],
    )
    .bad_input(&["--texture", "--scene"]);
}
