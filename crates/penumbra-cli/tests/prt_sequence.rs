//! Users' animations in `penumbra prt`: mesh sequences and
//! glTF skins and morph targets, the shipped examples, the sequence path
//! against the built-in animation it reproduces, skinning against an
//! independent computation, and bad input (exit 2 naming the frame, file
//! or field). CPU device throughout.

mod common;

use common::cli::{GROUND, SKY, TempDir, asset_s, pen, write_probe};
use glam::{DMat4, DQuat, DVec3, Vec3};
use penumbra::scene::animated::AnimatedScene;
use penumbra::scene::load_gltf_animation;
use penumbra::scene::procedural::uv_sphere;
use penumbra::scene::{Mesh, write_obj};
use penumbra_assets::animations::{FLAG_FRAMES, bending_tube, hand};

const FAST: &str = "--device cpu --json --self-check off --order 3 --mask 16";

fn write_frames(dir: &TempDir, sub: &str, frames: &[Mesh]) -> String {
    std::fs::create_dir_all(dir.0.join(sub)).unwrap();
    for (k, m) in frames.iter().enumerate() {
        dir.write(&format!("{sub}/f-{k:02}.obj"), write_obj(m, "test frame"));
    }
    dir.p(&format!("{sub}/*.obj"))
}

#[test]
fn shipped_flag_sequence_plays_every_frame() {
    let dir = TempDir::new("seq-flag");
    let env = write_probe(&dir, SKY, GROUND);
    let pattern = format!("{}/flag/*.obj", asset_s("animations"));
    let j = pen(
        &format!("prt --mesh-sequence {{p}} --env {{env}} {FAST}"),
        &[("p", &pattern), ("env", &env)],
    )
    .ok()
    .json();
    assert_eq!(j["frames"], FLAG_FRAMES);
    assert_eq!(j["animation"]["kind"], "sequence");
    assert_eq!(j["animation"]["files"], FLAG_FRAMES);
    assert!(j["animation"]["last"].as_str().unwrap().ends_with("flag-007.obj"));
    assert_eq!(j["triangles"], 480);
    let phases = &j["phases_ms"]["per_frame"];
    let whole = j["frame_ms"]["mean"].as_f64().unwrap();
    let sum = phases["animate"].as_f64().unwrap()
        + phases["lighting"].as_f64().unwrap()
        + phases["transfer"].as_f64().unwrap();
    assert!(
        (sum - whole).abs() <= 1e-6 * whole.max(1.0) + 1e-3,
        "{phases} vs {whole}"
    );
    let b = &j["blockers_per_vertex"];
    assert!(b["before_culling"].as_f64().unwrap() >= b["after_culling"].as_f64().unwrap());
}

/// The built-in cloth written as an OBJ sequence at its frame times plays
/// exactly as `--animated cloth`: same radiance at every vertex and frame.
#[test]
fn sequence_of_the_cloth_matches_the_built_in_cloth() {
    let dir = TempDir::new("seq-cloth");
    let env = write_probe(&dir, SKY, GROUND);
    let cloth = AnimatedScene::Cloth.build();
    let frames: Vec<Mesh> = (0..4).map(|k| cloth.mesh_at(k as f32 * (1.0 / 30.0))).collect();
    let pattern = write_frames(&dir, "cloth", &frames);
    let camera = "--eye 1.45,1.55,2.1 --target 0,0.05,0 --fov 45 --width 32 --height 24";
    let (a, b) = (dir.p("seq.csv"), dir.p("builtin.csv"));
    let seq = pen(
        &format!("prt --mesh-sequence {{p}} --env {{env}} {FAST} {camera} --out {{o1}} --per-vertex {{a}}"),
        &[("p", &pattern), ("env", &env), ("a", &a), ("o1", &dir.p("a.png"))],
    );
    let builtin = pen(
        &format!("prt --animated cloth --frames 4 --env {{env}} {FAST} {camera} --out {{o2}} --per-vertex {{b}}"),
        &[("env", &env), ("b", &b), ("o2", &dir.p("b.png"))],
    );
    assert_eq!(seq.ok().json()["frames"], 4);
    assert_eq!(builtin.ok().json()["frames"], 4);
    let (a, b) = (std::fs::read_to_string(a).unwrap(), std::fs::read_to_string(b).unwrap());
    assert_eq!(a.lines().count(), 1 + 4 * 1369);
    assert_eq!(a, b, "the sequence and the built-in cloth differ");
}

#[test]
fn bad_sequences_exit_2_naming_the_frame() {
    let dir = TempDir::new("seq-bad");
    let env = write_probe(&dir, SKY, GROUND);
    let flag = penumbra_assets::animations::flag_frames(3);
    let run = |pattern: &str| {
        pen(
            &format!("prt --mesh-sequence {{p}} --env {{env}} {FAST}"),
            &[("p", pattern), ("env", &env)],
        )
    };
    // A vertex more in frame 2.
    let mut more = flag.clone();
    more[2].positions.push(Vec3::ONE);
    run(&write_frames(&dir, "more", &more)).bad_input(&[
        "--mesh-sequence",
        "frame 2",
        "f-02.obj",
        "274 vertices",
        "273",
    ]);
    // Frame 1's triangle 5 turned around.
    let mut turned = flag.clone();
    let t = turned[1].triangles[5];
    turned[1].triangles[5] = [t[0], t[2], t[1]];
    run(&write_frames(&dir, "turned", &turned)).bad_input(&["frame 1", "f-01.obj", "triangle 5"]);
    // A triangle fewer in frame 1.
    let mut fewer = flag.clone();
    fewer[1].triangles.pop();
    fewer[1].objects[0].triangles = 0..fewer[1].triangles.len() as u32;
    run(&write_frames(&dir, "fewer", &fewer)).bad_input(&["frame 1", "479 triangles"]);
    // Frame 1 missing from the numbering.
    let four = penumbra_assets::animations::flag_frames(4);
    let gap = write_frames(&dir, "gap", &four);
    std::fs::remove_file(dir.0.join("gap/f-01.obj")).unwrap();
    run(&gap).bad_input(&["frame number 1 is missing", "f-00.obj", "f-02.obj"]);
    // A pattern that matches nothing, a folder that does not exist.
    run(&dir.p("gap/*.ply")).bad_input(&["--mesh-sequence", "matches no file"]);
    run(&dir.p("nowhere/*.obj")).bad_input(&["--mesh-sequence", "nowhere", "cannot read the folder"]);
    // A frame that is not a mesh names its file.
    let broken = write_frames(&dir, "broken", &flag);
    std::fs::write(dir.0.join("broken/f-01.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
    run(&broken).bad_input(&["f-01.obj"]);
}

#[test]
fn gltf_skins_and_morphs_animate_and_bad_ones_exit_2() {
    let dir = TempDir::new("seq-gltf");
    let env = write_probe(&dir, SKY, GROUND);
    let tube = format!("{}/bending-tube.glb", asset_s("animations"));
    let blob = format!("{}/morph-blob.glb", asset_s("animations"));
    let run = |mesh: &str, extra: &str| {
        pen(
            &format!("prt --mesh {{m}} --env {{env}} {FAST} {extra}"),
            &[("m", mesh), ("env", &env)],
        )
    };
    let j = run(&tube, "--frames 5").ok().json();
    assert_eq!(j["frames"], 5);
    assert_eq!(j["dt"], 0.5, "5 frames sample the 2 s clip evenly");
    assert_eq!(j["animation"]["name"], "bend");
    assert_eq!(j["animation"]["skinned_vertices"], 402);
    let j = run(&tube, "--animation twist").ok().json();
    assert_eq!(j["animation"]["name"], "twist");
    assert_eq!(j["frames"], 31, "a 1 s clip at 30 frames per second");
    let j = run(&tube, "--animation none").ok().json();
    assert!(j["animation"].is_null());
    assert_eq!(j["frames"], 1);
    run(&tube, "--animation nope").bad_input(&["bending-tube.glb", "no animation 'nope'", "bend, twist"]);
    let j = run(&blob, "--frames 3").ok().json();
    assert_eq!(j["animation"]["morph_targets"], 2);
    assert_eq!(j["animation"]["morphed_vertices"], 266);

    // A joint index past the skin's joints.
    let mut bad = bending_tube();
    bad.joints[7] = [9, 0, 0, 0];
    let path = dir.write("bad-joint.glb", bad.to_glb("bad"));
    run(&path, "").bad_input(&["bad-joint.glb", "JOINTS_0", "vertex 7", "joint 9 is out of range"]);
    // Weights summing to 0, and negative.
    let mut bad = bending_tube();
    bad.weights[3] = [0.0; 4];
    let path = dir.write("zero-weights.glb", bad.to_glb("bad"));
    run(&path, "").bad_input(&["zero-weights.glb", "WEIGHTS_0", "vertex 3"]);
    let mut bad = bending_tube();
    bad.weights[4] = [-0.5, 1.5, 0.0, 0.0];
    let path = dir.write("negative.glb", bad.to_glb("bad"));
    run(&path, "").bad_input(&["negative.glb", "negative weight"]);
    // A bone placed at NaN: its node and inverse bind matrix are not finite.
    let mut bad = bending_tube();
    bad.bones[2].offset = DVec3::new(f64::NAN, 0.0, 0.0);
    let path = dir.write("nan.glb", bad.to_glb("bad"));
    run(&path, "").bad_input(&["nan.glb"]);
    // Weights that do not sum to 1 are normalised, with a warning.
    let mut loose = bending_tube();
    loose.weights[5] = [0.5, 0.0, 0.0, 0.0];
    let path = dir.write("loose.glb", loose.to_glb("loose"));
    let out = run(&path, "--frames 2");
    out.ok();
    assert!(out.stderr.contains("normalised"), "{}", out.stderr);
    // --animation on a file that holds none.
    run(&asset_s("corner.obj"), "--animation bend").bad_input(&["--animation", "not a glTF file"]);
}

/// Linear blend skinning of the bending tube at t = 0.5 s (both upper
/// joints at 60 degrees about z), computed here from the model rather than
/// the file, against the glTF reader's skinned positions; and the STEP clip.
#[test]
fn skinned_positions_match_an_independent_computation() {
    let path = std::path::Path::new(&asset_s("animations")).join("bending-tube.glb");
    let model = bending_tube();
    let bind = model.bind_translations();
    let r = DMat4::from_quat(DQuat::from_rotation_z(60f64.to_radians()));
    let t = |y: f64| DMat4::from_translation(DVec3::new(0.0, y, 0.0));
    let global = [DMat4::IDENTITY, t(0.4) * r, t(0.4) * r * t(0.4) * r];
    let skin: Vec<DMat4> = global
        .iter()
        .zip(&bind)
        .map(|(g, b)| *g * DMat4::from_translation(-*b))
        .collect();
    let expected: Vec<DVec3> = model
        .positions
        .iter()
        .enumerate()
        .map(|(v, p)| {
            (0..4)
                .map(|c| model.weights[v][c] as f64 * skin[model.joints[v][c] as usize].transform_point3(p.as_dvec3()))
                .sum()
        })
        .collect();
    let animation = load_gltf_animation(&path, Some("bend")).unwrap().unwrap();
    let mut got = Vec::new();
    animation.positions_at(0.5, &mut got);
    assert_eq!(got.len(), expected.len());
    let worst = got
        .iter()
        .zip(&expected)
        .map(|(g, e)| (g.as_dvec3() - *e).length())
        .fold(0.0, f64::max);
    assert!(worst < 2e-6, "skinned positions differ by {worst}");
    assert!(
        expected
            .iter()
            .zip(&model.positions)
            .any(|(e, p)| (*e - p.as_dvec3()).length() > 0.3),
        "the tube bends"
    );

    // STEP: at 0.3 s the twist holds its 0.25 s key, 22.5 degrees about y,
    // and every bone hangs from the root, so the whole tube turns rigidly.
    let twist = load_gltf_animation(&path, Some("twist")).unwrap().unwrap();
    twist.positions_at(0.3, &mut got);
    let ry = DQuat::from_rotation_y(22.5f64.to_radians());
    let worst = got
        .iter()
        .zip(&model.positions)
        .map(|(g, p)| (g.as_dvec3() - ry * p.as_dvec3()).length())
        .fold(0.0, f64::max);
    assert!(worst < 2e-6, "STEP twist differs by {worst}");

    // Morph targets: at 0.25 s the weights are (0.5, 0): half the bulge.
    let blob = std::path::Path::new(&asset_s("animations")).join("morph-blob.glb");
    let morph = load_gltf_animation(&blob, None).unwrap().unwrap();
    morph.positions_at(0.25, &mut got);
    let sphere = uv_sphere("blob", Vec3::ZERO, 0.5, 24, 12);
    for (g, p) in got.iter().zip(&sphere.positions) {
        let n = p.as_dvec3() / 0.5;
        let e = p.as_dvec3() + 0.5 * n * 0.3 * n.x.max(0.0).powi(2);
        assert!((g.as_dvec3() - e).length() < 1e-6, "{g} vs {e}");
    }
    // The hand's clip is 2 s, sampled at 30 frames per second by default.
    let hand_path = std::path::Path::new(&asset_s("animations")).join("hand.glb");
    let clip = load_gltf_animation(&hand_path, None).unwrap().unwrap().clip().unwrap();
    assert_eq!((clip.duration, clip.frames), (2.0, 61));
    assert_eq!(hand().triangles.len(), 15_696);
}

#[test]
fn gen_assets_writes_the_committed_animations() {
    let dir = TempDir::new("seq-assets");
    pen("gen-assets --out {d} --json", &[("d", &dir.p("out"))]).ok();
    let written = dir.0.join("out/animations");
    let committed = std::path::PathBuf::from(asset_s("animations"));
    let mut names = vec![
        "bending-tube.glb".to_string(),
        "morph-blob.glb".into(),
        "hand.glb".into(),
    ];
    names.extend((0..FLAG_FRAMES).map(|k| format!("flag/flag-{k:03}.obj")));
    for name in names {
        assert_eq!(
            std::fs::read(written.join(&name)).unwrap(),
            std::fs::read(committed.join(&name)).unwrap_or_default(),
            "{name} differs from the committed assets/animations (run `penumbra gen-assets --out assets`)"
        );
    }
}

/// On animations: the coarse level is checked against the
/// fine mesh on poses of the clip, not the rest pose alone. The hand's
/// coarse fingers are true to the straight hand and stray once it grips
/// (13-16% off there when checked on the rest pose only).
#[test]
fn the_coarse_level_is_checked_on_the_animation_s_poses() {
    let dir = TempDir::new("seq-hand-poses");
    let env = write_probe(&dir, SKY, GROUND);
    let hand = std::path::Path::new(&asset_s("animations")).join("hand.glb");
    let worst = |extra: &str| {
        let json = pen(
            &format!(
                "prt --mesh {{m}} --env {{env}} --frames 5 --reference --reference-frames 5 \
                 --reference-rays 256 --device cpu --json --self-check off {extra}"
            ),
            &[("m", hand.to_str().unwrap()), ("env", &env)],
        )
        .ok()
        .json();
        let frames: Vec<f64> = json["check"]["per_frame"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e.as_f64().unwrap())
            .collect();
        frames.into_iter().fold(0.0, f64::max)
    };
    let (posed, rest_only) = (worst(""), worst("--coarse-poses 1"));
    println!("hand, worst of 5 frames: {posed:.4} checked on 8 poses, {rest_only:.4} on the rest pose only");
    assert!(posed < 0.05, "checked on the clip's poses, the worst frame is {posed}");
    assert!(rest_only > 2.0 * posed, "{rest_only} vs {posed}");
}
