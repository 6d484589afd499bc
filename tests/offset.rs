//! Every world-space input follows a far-off model into its frame (issue
//! 14, class 1, `scene::frame`): a scene file's instance translation,
//! camera and point light, and the command line's `--eye`, `--target` and
//! `--light`, 1e6 times the scene's size from the origin, give the images
//! they give at the origin, within the twin tests' tolerance. (Meshes,
//! rays, fields, SSAO and PRT far off: `tests/scale.rs`.)

mod common;

use common::cli::{TempDir, asset_s, pen};

/// Far off on every axis, with digits f32 would drop there (f32's step at
/// 2e6 is 0.25).
const FAR: [f64; 3] = [2_000_000.123, -2_000_000.0, 2_000_000.0];

fn far(p: [f64; 3]) -> [f64; 3] {
    [p[0] + FAR[0], p[1] + FAR[1], p[2] + FAR[2]]
}

fn rgb(path: &str) -> Vec<u8> {
    image::open(path).unwrap().to_rgb8().into_raw()
}

/// The twin tests' image tolerance: at most 0.1% of bytes differ by more
/// than 1 (of 255). The far scene's coordinates round to other f32 values
/// than the near one's where its offset is not on its frame's grid (the
/// .123 here), so a few pixels may differ by one.
fn assert_alike(a: &[u8], b: &[u8], what: &str) {
    assert_eq!(a.len(), b.len());
    let outliers = a.iter().zip(b).filter(|(x, y)| x.abs_diff(**y) > 1).count();
    let differ = a.iter().zip(b).filter(|(x, y)| x != y).count();
    println!(
        "{what}: {differ} of {} bytes differ, {outliers} by more than 1",
        a.len()
    );
    assert!(
        outliers as f64 <= 1e-3 * a.len() as f64,
        "{what}: the far scene's image differs"
    );
}

fn scene(d: &TempDir, name: &str, at: fn([f64; 3]) -> [f64; 3]) -> String {
    let mesh = d.p("sop.obj");
    std::fs::copy(asset_s("sphere-on-plane.obj"), &mesh).unwrap();
    let json = serde_json::json!({
        "meshes": { "s": mesh },
        "instances": [ { "mesh": "s", "translate": at([0.0; 3]) } ],
        "camera": { "eye": at([3.0, 4.0, 9.0]), "target": at([0.0, 0.5, 0.0]) },
        "lights": [ { "point": { "position": at([2.0, 6.0, 2.0]), "intensity": [20, 20, 20] } } ],
    });
    d.write(name, json.to_string())
}

#[test]
fn a_far_scene_files_placement_camera_and_light_follow_its_frame() {
    let d = TempDir::new("offset-scene");
    let near = scene(&d, "near.json", |p| p);
    let far = scene(&d, "far.json", far);
    for (line, what) in [
        (
            "raytrace --method whitted --scene {scene} --width 48 --height 48 --out {out} --device cpu",
            "Whitted",
        ),
        (
            "ssao --scene {scene} --estimator importance --spp 16 --radius 0.5 --width 48 --height 48 \
             --out {out} --reference-rays 0 --screen-reference-spp 0 --device cpu",
            "SSAO",
        ),
    ] {
        let images: Vec<Vec<u8>> = [&near, &far]
            .iter()
            .enumerate()
            .map(|(i, scene)| {
                let out = d.p(&format!("{what}-{i}.png"));
                pen(line, &[("scene", scene), ("out", &out)]).ok();
                rgb(&out)
            })
            .collect();
        assert_alike(&images[0], &images[1], what);
    }
}

#[test]
fn the_command_lines_eye_target_and_light_follow_a_far_mesh() {
    let d = TempDir::new("offset-eye");
    let text = std::fs::read_to_string(asset_s("sphere-on-plane.obj")).unwrap();
    let moved: String = text
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(rest) => {
                let p: Vec<f64> = rest
                    .split_whitespace()
                    .map(|c| c.parse::<f32>().unwrap() as f64)
                    .collect();
                let q = far([p[0], p[1], p[2]]);
                format!("v {} {} {}\n", q[0], q[1], q[2])
            }
            None => format!("{l}\n"),
        })
        .collect();
    let far_mesh = d.write("far.obj", moved);
    let show = |p: [f64; 3]| format!("{},{},{}", p[0], p[1], p[2]);
    let mut images = Vec::new();
    for (i, (mesh, at)) in [(asset_s("sphere-on-plane.obj"), (|p| p) as fn(_) -> _), (far_mesh, far)]
        .into_iter()
        .enumerate()
    {
        let out = d.p(&format!("t{i}.png"));
        let (eye, target, light) = (
            show(at([3.0, 4.0, 9.0])),
            show(at([0.0, 0.5, 0.0])),
            show(at([2.0, 6.0, 2.0])),
        );
        pen(
            "trace --mesh {mesh} --eye {eye} --target {target} --light {light} --width 48 --height 48 \
             --out {out} --device cpu",
            &[
                ("mesh", &mesh),
                ("eye", &eye),
                ("target", &target),
                ("light", &light),
                ("out", &out),
            ],
        )
        .ok();
        images.push(rgb(&out));
    }
    assert_alike(&images[0], &images[1], "trace");
}
