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
    // raytrace reports its camera where the scene file puts it, not in the
    // recentred frame it renders in.
    let report = pen(
        "raytrace --method whitted --scene {scene} --width 16 --height 16 --out {out} --device cpu --json",
        &[("scene", &far), ("out", &d.p("report.png"))],
    )
    .ok()
    .json();
    let eye: Vec<f64> = (0..3).map(|k| report["camera"]["eye"][k].as_f64().unwrap()).collect();
    let want = self::far([3.0, 4.0, 9.0]);
    // f32's step at 2e6 is 0.25.
    assert!((0..3).all(|k| (eye[k] - want[k]).abs() <= 0.25), "{eye:?} vs {want:?}");
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
        let report = pen(
            "trace --mesh {mesh} --eye {eye} --target {target} --light {light} --width 48 --height 48 \
             --out {out} --device cpu --json",
            &[
                ("mesh", &mesh),
                ("eye", &eye),
                ("target", &target),
                ("light", &light),
                ("out", &out),
            ],
        )
        .ok()
        .json();
        // The report's camera is where the user put it (f32's step there is 0.25).
        let reported = report["camera"]["eye"][0].as_f64().unwrap();
        assert!(
            (reported - at([3.0, 4.0, 9.0])[0]).abs() <= 0.25,
            "camera reported at {reported}"
        );
        images.push(rgb(&out));
    }
    assert_alike(&images[0], &images[1], "trace");
}

/// `sphere-on-plane.obj`'s vertices (as f32 reads them) and faces.
fn sphere_on_plane() -> (Vec<[f64; 3]>, Vec<Vec<usize>>) {
    let text = std::fs::read_to_string(asset_s("sphere-on-plane.obj")).unwrap();
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for line in text.lines() {
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("v") => vertices.push([0, 1, 2].map(|_| tokens.next().unwrap().parse::<f32>().unwrap() as f64)),
            Some("f") => faces.push(
                tokens
                    .map(|t| t.split('/').next().unwrap().parse::<usize>().unwrap() - 1)
                    .collect(),
            ),
            _ => {}
        }
    }
    (vertices, faces)
}

fn ao_csv(path: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect()
}

/// The twin tests' AO tolerance: mean |difference| per vertex <= 1e-3.
fn assert_ao_alike(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len());
    let mean = a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f64>() / a.len() as f64;
    println!("{what}: mean |AO difference| {mean:.2e}");
    assert!(mean <= 1e-3, "{what}: mean |AO difference| {mean}");
}

/// A PLY of doubles far off reads as the OBJ near the origin does; a
/// `.dfield` built from a far mesh serves that mesh (the field is in the
/// mesh's frame, as its instance is).
#[test]
fn a_far_ply_of_doubles_and_a_far_field_file_give_the_same_ao() {
    let d = TempDir::new("offset-ply-field");
    let (vertices, faces) = sphere_on_plane();
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        faces.len()
    );
    for v in &vertices {
        let p = far(*v);
        ply += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for f in &faces {
        ply += &format!(
            "{} {}\n",
            f.len(),
            f.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(" ")
        );
    }
    let near = asset_s("sphere-on-plane.obj");
    let far_ply = d.write("far.ply", ply);
    let run = |mesh: &str, tag: &str| {
        let csv = d.p(&format!("{tag}.csv"));
        let field = d.p(&format!("{tag}.dfield"));
        let vars = [("mesh", mesh), ("csv", csv.as_str()), ("field", field.as_str())];
        pen(
            "ao --mesh {mesh} --method raycast --rays 32 --per-vertex {csv} --device cpu",
            &vars,
        )
        .ok();
        let raycast = ao_csv(&csv);
        pen(
            "field build --mesh {mesh} --positions 16 --res 8 --bits 8 -o {field}",
            &vars,
        )
        .ok();
        pen(
            "ao --mesh {mesh} --receiver {mesh} --method field --field {field} --positions 16 --res 8 --bits 8 \
             --rays 32 --per-vertex {csv} --device cpu",
            &vars,
        )
        .ok();
        (raycast, ao_csv(&csv))
    };
    let (near_raycast, near_field) = run(&near, "near");
    let (far_raycast, far_field) = run(&far_ply, "far");
    assert_ao_alike(&near_raycast, &far_raycast, "PLY far off, ray-cast AO");
    assert_ao_alike(&near_field, &far_field, "PLY far off, field AO from a .dfield");
}
