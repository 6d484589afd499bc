//! Bounded-error ray tracing (`penumbra::bounded`) against exact Whitted:
//! the guarantee on every shipped scene at three epsilons, epsilon 0 bit for
//! bit, no interpolation across a ray-tree change at any epsilon, occluders
//! seen after reprojection, the eye inside glass, the memory cap.

mod common;

use common::{asset, data_scene};
use glam::Vec3;
use penumbra::bounded::linetree::CellState;
use penumbra::bounded::measure::compare;
use penumbra::bounded::{BoundedFrame, BoundedRenderer, BoundedSettings, PixelPath};
use penumbra::gpu::device::Device;
use penumbra::progress::{Bar, Reporter};
use penumbra::scene::CameraPath;
use penumbra::scene::{Camera, Scene, load_scene_shaded};
use penumbra::whitted::{LightingSettings, RenderScene, WhittedRenderer, WhittedSettings};

/// The shipped scenes with their cameras, and the Cornell box of the shared
/// data where it is present.
fn scenes() -> Vec<(String, Scene, Camera)> {
    let mut out: Vec<(String, Scene, Camera)> = penumbra_assets::raytrace::shipped_scenes()
        .iter()
        .map(|s| {
            let scene = load_scene_shaded(&asset("raytrace").join(s.scene_file())).unwrap();
            let camera = scene.camera.unwrap();
            (s.name.to_string(), scene, camera)
        })
        .collect();
    if let Some(path) = data_scene("CornellBox-Original.obj") {
        let obj = penumbra::scene::load_obj_file(&path).unwrap();
        let scene = Scene::from_obj_file("cornell", &path, obj);
        let camera = Camera {
            eye: Vec3::new(0.0, 1.0, 3.5),
            target: Vec3::new(0.0, 1.0, 0.0),
            fov_degrees: 40.0,
        };
        out.push(("CornellBox-Original".into(), scene, camera));
    }
    out
}

fn whitted(scene: &Scene) -> WhittedRenderer {
    let rs = RenderScene::new(scene, 0, &LightingSettings::default()).unwrap();
    WhittedRenderer::new(&Device::cpu(), rs, &Reporter::silent()).unwrap()
}

fn bounded(scene: &Scene, settings: BoundedSettings) -> BoundedRenderer {
    BoundedRenderer::new(whitted(scene), settings).unwrap()
}

/// The exact Whitted image (CPU twin, the renderer's defaults).
fn exact(scene: &Scene, camera: &Camera, (w, h): (u32, u32)) -> Vec<Vec3> {
    let frame = whitted(scene)
        .render(camera, w, h, &WhittedSettings::default(), &Bar::hidden())
        .unwrap();
    frame.radiance()
}

fn interpolated(frame: &BoundedFrame) -> usize {
    frame
        .paths
        .iter()
        .filter(|p| matches!(p, PixelPath::Interpolated | PixelPath::Reprojected))
        .count()
}

/// Every interpolated or reprojected pixel's exact ray tree (from the eye)
/// has the topology of its cell's extremal rays: the same surfaces, lights
/// and reflection/refraction structure. Returns how many were checked.
fn assert_no_pixel_crosses_a_tree_change(name: &str, b: &BoundedRenderer, frame: &BoundedFrame) -> usize {
    let mut checked = 0;
    for (i, &cell) in frame.cells.iter().enumerate() {
        if cell == u32::MAX {
            continue;
        }
        let corner = b.trees.corner_keys(cell)[0];
        let template = &b.trees.sample(corner).expect("a used cell keeps its samples").tree;
        let (x, y) = (i as u32 % frame.width, i as u32 / frame.width);
        let (_, tree) = b
            .whitted
            .pixel_tree(
                &frame.camera,
                (frame.width, frame.height),
                &b.settings.whitted,
                (x, y, 0),
            )
            .unwrap();
        assert!(
            tree.same_topology(template),
            "{name}: pixel ({x}, {y}) was {:?} from a cell whose rays have another ray tree",
            frame.paths[i]
        );
        checked += 1;
    }
    checked
}

#[test]
fn no_violations_on_any_shipped_scene_at_three_epsilons() {
    let size = (320, 240);
    let frames = 3;
    for (name, scene, camera) in scenes() {
        let path = CameraPath::Walk(camera);
        let truth: Vec<Vec<Vec3>> = (0..frames).map(|f| exact(&scene, &path.at(f, frames), size)).collect();
        for epsilon in [0.01, 0.05, 0.2] {
            let mut b = bounded(
                &scene,
                BoundedSettings {
                    epsilon,
                    ..Default::default()
                },
            );
            let (mut worst, mut fast) = (0f64, 0);
            for (f, truth) in truth.iter().enumerate() {
                let frame = b.render(&path.at(f as u32, frames), size.0, size.1).unwrap();
                let e = compare(&frame, truth, epsilon, b.settings.floor);
                assert_eq!(e.violations, 0, "{name} at epsilon {epsilon}, frame {f}: {e:?}");
                worst = worst.max(e.max_rel);
                fast += interpolated(&frame);
            }
            let params = b
                .whitted
                .params(&path.at(frames - 1, frames), size.0, size.1, &b.settings.whitted)
                .unwrap();
            let check = b.check(&params, 64, 7);
            println!(
                "{name} epsilon {epsilon}: {fast} pixels interpolated, worst relative error {worst:.2e}; \
                 check: {} lines in {} cells, {} violations, worst {:.2e}",
                check.lines, check.cells, check.violations, check.max_rel
            );
            assert_eq!(check.violations, 0, "{name} at epsilon {epsilon}: {check:?}");
            if fast > 0 {
                assert!(
                    check.lines > 0,
                    "{name} at epsilon {epsilon}: no line was checked: {check:?}"
                );
            }
            if name == "inside-glass" {
                assert_whole_frame_traced(&b.render(&camera, 40, 30).unwrap(), "eye_in_medium");
            } else if epsilon >= 0.05 {
                assert!(fast > 0, "{name} at epsilon {epsilon}: nothing was interpolated");
            }
        }
    }
}

/// The frame was the Whitted renderer's own, and its counts say why: every
/// pixel traced for `why`, none interpolated, no cell built.
fn assert_whole_frame_traced(frame: &BoundedFrame, why: &str) {
    let n = frame.radiance.len() as u64;
    let p = &frame.stats.pixels;
    assert_eq!(p.traced, n, "{p:?}");
    assert_eq!(p.traced_by.get(why), Some(&n), "{p:?}");
    assert_eq!(p.traced_by.len(), 1, "{p:?}");
    assert_eq!(frame.stats.cells_built, 0);
    assert_eq!(interpolated(frame), 0);
}

/// A tiny epsilon still goes through the interpolants: cells are built,
/// pixels interpolated from them, and the image is Whitted's within that
/// epsilon (relative, above the floor, as the guarantee is stated).
#[test]
fn a_tiny_epsilon_is_the_whitted_image_within_it_through_the_interpolants() {
    let size = (160, 120);
    let epsilon = 1e-3;
    let mut all = scenes();
    let occluder = occluder_scene();
    all.push(("occluder".into(), occluder.clone(), occluder.camera.unwrap()));
    let (mut built, mut fast) = (0, 0);
    for (name, scene, camera) in all {
        if name == "inside-glass" {
            continue;
        }
        let mut b = bounded(
            &scene,
            BoundedSettings {
                epsilon,
                ..Default::default()
            },
        );
        let frame = b.render(&camera, size.0, size.1).unwrap();
        let e = compare(&frame, &exact(&scene, &camera, size), epsilon, b.settings.floor);
        let here = interpolated(&frame);
        println!(
            "{name}: {} cells built, {here} pixels interpolated, worst relative error {:.2e}",
            frame.stats.cells_built, e.max_rel
        );
        assert_eq!(e.violations, 0, "{name} at epsilon {epsilon}: {e:?}");
        assert_eq!(frame.stats.pixels.traced_by.get("epsilon_zero"), None);
        built += frame.stats.cells_built;
        fast += here;
    }
    assert!(built > 0, "no cell was built at epsilon {epsilon}");
    assert!(fast >= 1000, "only {fast} pixels interpolated at epsilon {epsilon}");
}

#[test]
fn epsilon_zero_is_the_whitted_image_bit_for_bit() {
    let size = (160, 120);
    for (name, scene, camera) in scenes() {
        let mut b = bounded(
            &scene,
            BoundedSettings {
                epsilon: 0.0,
                ..Default::default()
            },
        );
        let frame = b.render(&camera, size.0, size.1).unwrap();
        let truth = exact(&scene, &camera, size);
        let differ = frame.radiance.iter().zip(&truth).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{name}: {differ} pixels differ from Whitted at epsilon 0");
        assert_whole_frame_traced(&frame, "epsilon_zero");
    }
}

#[test]
fn a_huge_epsilon_never_interpolates_across_a_tree_change_shadow_edge_or_silhouette() {
    let size = (200, 150);
    let mut total = 0;
    for (name, scene, camera) in scenes() {
        let mut b = bounded(
            &scene,
            BoundedSettings {
                epsilon: 1e6,
                ..Default::default()
            },
        );
        let path = CameraPath::Walk(camera);
        let mut checked = 0;
        for f in 0..2 {
            let frame = b.render(&path.at(f, 2), size.0, size.1).unwrap();
            checked += assert_no_pixel_crosses_a_tree_change(&name, &b, &frame);
        }
        println!("{name}: {checked} interpolated pixels have their cell's ray tree");
        if name == "inside-glass" {
            assert_whole_frame_traced(&b.render(&camera, 40, 30).unwrap(), "eye_in_medium");
        } else {
            assert!(checked > 0, "{name}: nothing interpolated at epsilon 1e6");
        }
        total += checked;
    }
    assert!(total > 10_000, "only {total} pixels interpolated in all");
}

/// A matte floor and a small ball near the eye: a small sideways step of
/// the eye sweeps the ball across the floor's reprojected cells.
fn occluder_scene() -> Scene {
    let json = r#"{
        "ambient": [0.05, 0.05, 0.05],
        "background": [0.3, 0.4, 0.6],
        "camera": {"eye": [0.0, 2.0, 6.0], "fov": 45, "target": [0.0, 0.0, 0.0]},
        "meshes": {"floor": "floor.obj"},
        "instances": [{"mesh": "floor", "material": "matte"}],
        "lights": [{"point": {"intensity": [400.0, 400.0, 400.0], "position": [0.0, 20.0, 0.0]}}],
        "materials": {"matte": {"kd": [0.6, 0.6, 0.6], "ka": [0.6, 0.6, 0.6], "illum": 1}},
        "spheres": [{"center": [-0.5, 1.5, 4.5], "radius": 0.15, "material": "matte", "name": "occluder"}]
    }"#;
    scene_over_floor("occluder", json)
}

/// A scene file `json` whose mesh "floor" is a 12 x 12 square at y = 0,
/// written to a temporary folder and read back.
fn scene_over_floor(name: &str, json: &str) -> Scene {
    scene_over_floor_with(name, json, &[])
}

/// `scene_over_floor` with more files beside the scene (name, text).
fn scene_over_floor_with(name: &str, json: &str, files: &[(&str, &str)]) -> Scene {
    let dir = std::env::temp_dir().join(format!("penumbra-bounded-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("floor.obj"),
        "v -6 0 -6\nv 6 0 -6\nv 6 0 6\nv -6 0 6\nf 1 4 3 2\n",
    )
    .unwrap();
    for (file, text) in files {
        std::fs::write(dir.join(file), text).unwrap();
    }
    std::fs::write(dir.join("scene.json"), json).unwrap();
    let scene = load_scene_shaded(&dir.join("scene.json")).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    scene
}

#[test]
fn an_occluder_moving_into_a_reprojected_cells_shaft_is_seen() {
    let scene = occluder_scene();
    let first = scene.camera.unwrap();
    let size = (240, 180);
    let mut b = bounded(&scene, BoundedSettings::default());
    b.render(&first, size.0, size.1).unwrap();
    let mut moved = first;
    moved.eye += Vec3::new(0.1, 0.0, 0.0);
    let frame = b.render(&moved, size.0, size.1).unwrap();
    let reprojected = frame.paths.iter().filter(|p| **p == PixelPath::Reprojected).count();
    let blocked = frame.stats.reproject_dropped[1];
    println!("{reprojected} pixels reprojected, {blocked} cells dropped for a blocked shaft");
    assert!(reprojected > 500, "only {reprojected} pixels reprojected");
    assert!(
        blocked > 0,
        "no shaft was blocked: the test does not move an occluder in"
    );
    assert_no_pixel_crosses_a_tree_change("occluder", &b, &frame);
    let e = compare(
        &frame,
        &exact(&scene, &moved, size),
        b.settings.epsilon,
        b.settings.floor,
    );
    assert_eq!(e.violations, 0, "{e:?}");
}

/// No linetree serves lines that start inside a medium: the frame falls
/// back to the Whitted renderer, and its report says so.
#[test]
fn an_eye_inside_glass_renders_exactly() {
    let scene = load_scene_shaded(&asset("raytrace").join("inside-glass.json")).unwrap();
    let camera = scene.camera.unwrap();
    let size = (160, 120);
    let mut b = bounded(&scene, BoundedSettings::default());
    let frame = b.render(&camera, size.0, size.1).unwrap();
    assert_whole_frame_traced(&frame, "eye_in_medium");
    let truth = exact(&scene, &camera, size);
    assert!(frame.radiance.iter().zip(&truth).all(|(a, b)| a == b));
}

#[test]
fn the_guarantee_holds_under_a_memory_cap_that_evicts() {
    let scene = load_scene_shaded(&asset("raytrace").join("cornell-mirror-glass.json")).unwrap();
    let path = CameraPath::Walk(scene.camera.unwrap());
    let size = (240, 180);
    let capped = |memory_mb| {
        bounded(
            &scene,
            BoundedSettings {
                memory_mb,
                ..Default::default()
            },
        )
    };
    let (mut b, mut free) = (capped(1.0), capped(1024.0));
    let (mut evicted, mut fast, mut requested, mut traced) = (0, 0, 0, 0);
    for f in 0..4 {
        let camera = path.at(f, 4);
        let frame = b.render(&camera, size.0, size.1).unwrap();
        let e = compare(
            &frame,
            &exact(&scene, &camera, size),
            b.settings.epsilon,
            b.settings.floor,
        );
        assert_eq!(e.violations, 0, "frame {f}: {e:?}");
        // Only what the frame used is kept beyond the cap.
        let uncapped = free.render(&camera, size.0, size.1).unwrap().stats.memory_bytes;
        if f > 0 {
            assert!(
                frame.stats.memory_bytes < uncapped,
                "{} bytes kept",
                frame.stats.memory_bytes
            );
        }
        evicted += frame.stats.evicted_cells;
        fast += interpolated(&frame);
        requested += frame.stats.extremal_rays_requested;
        traced += frame.stats.extremal_rays_traced;
    }
    println!("{evicted} cells evicted, {fast} pixels interpolated, extremal rays {traced} of {requested} traced");
    assert!(evicted > 0, "a 1 MB cap evicted nothing");
    assert!(fast > 0);
    // Siblings share their corners' rays (see also linetree's unit test).
    assert!(traced * 2 < requested, "{traced} of {requested} extremal rays traced");
}

/// The shipped checkerboard's texture factor at a ray tree node's hit.
fn texture_at(b: &BoundedRenderer, hit: &penumbra::whitted::ray_tree::TreeHit) -> Vec3 {
    b.whitted.scene().surface(hit.surface).texture(hit.point)
}

#[test]
fn a_texture_is_looked_up_per_pixel_and_never_interpolated_across_in_a_reflection() {
    let scene = load_scene_shaded(&asset("raytrace").join("checker-spheres.json")).unwrap();
    let camera = scene.camera.unwrap();
    let size = (320, 240);
    let truth = exact(&scene, &camera, size);
    let mut b = bounded(
        &scene,
        BoundedSettings {
            epsilon: 0.2,
            ..Default::default()
        },
    );
    let frame = b.render(&camera, size.0, size.1).unwrap();
    let e = compare(&frame, &truth, 0.2, b.settings.floor);
    assert_eq!(e.violations, 0, "{e:?}");
    // At a huge epsilon only discontinuities split cells: the mirror ball
    // shows the checkerboard in cells that must each keep to one check.
    let mut b = bounded(
        &scene,
        BoundedSettings {
            epsilon: 1e6,
            ..Default::default()
        },
    );
    let camera = Camera {
        eye: Vec3::new(-1.6, 1.6, 2.4),
        target: Vec3::new(-2.2, 0.7, -0.3),
        fov_degrees: 30.0,
    };
    let frame = b.render(&camera, size.0, size.1).unwrap();
    // Per cell: the texture factors of its pixels' first hits (the root,
    // looked up per pixel) and of their later hits (constant per cell).
    let mut roots: std::collections::HashMap<u32, Vec<[u32; 3]>> = Default::default();
    let mut later: std::collections::HashMap<(u32, usize), Vec<[u32; 3]>> = Default::default();
    for (i, &cell) in frame.cells.iter().enumerate() {
        if cell == u32::MAX {
            continue;
        }
        let (x, y) = (i as u32 % frame.width, i as u32 / frame.width);
        let (_, tree) = b
            .whitted
            .pixel_tree(&camera, size, &b.settings.whitted, (x, y, 0))
            .unwrap();
        for (k, node) in tree.nodes.iter().enumerate() {
            let Some(hit) = node.hit.filter(|h| b.whitted.scene().surface(h.surface).textured()) else {
                continue;
            };
            let factor = texture_at(&b, &hit).to_array().map(f32::to_bits);
            let seen = if k == 0 {
                roots.entry(cell).or_default()
            } else {
                later.entry((cell, k)).or_default()
            };
            if !seen.contains(&factor) {
                seen.push(factor);
            }
        }
    }
    let spanning = roots.values().filter(|f| f.len() > 1).count();
    let crossing = later.values().filter(|f| f.len() > 1).count();
    println!(
        "{} cells on the checkerboard, {spanning} of them over both checks; {} later textured hits, {crossing} over both",
        roots.len(),
        later.len()
    );
    assert!(
        spanning > 0,
        "no cell spans a texture edge: the texture is not looked up per pixel"
    );
    assert!(later.len() > 10, "too few reflected textured hits interpolated to test");
    assert_eq!(
        crossing, 0,
        "a reflected or refracted texture edge was interpolated across"
    );
}

/// A big analytic ball with a fine, tinted checker texture (its odd
/// checks' factor differs per channel, one above 1) and a highlight, over
/// a matte floor.
fn textured_ball_scene() -> Scene {
    let json = r#"{
        "ambient": [0.05, 0.05, 0.05],
        "background": [0.3, 0.4, 0.6],
        "camera": {"eye": [0.0, 2.0, 6.0], "fov": 40, "target": [0.0, 1.2, 0.0]},
        "meshes": {"floor": "floor.obj"},
        "instances": [{"mesh": "floor", "material": "matte"}],
        "lights": [{"point": {"intensity": [120.0, 120.0, 120.0], "position": [3.0, 8.0, 4.0]}}],
        "materials": {
            "matte": {"kd": [0.6, 0.6, 0.6], "ka": [0.6, 0.6, 0.6], "illum": 1},
            "ball": {"kd": [0.7, 0.7, 0.7], "ka": [0.7, 0.7, 0.7], "ks": [0.3, 0.3, 0.3], "ns": 30, "illum": 2,
                     "checker": {"size": 0.3, "origin": [0.05, 0.05, 0.05], "odd": [0.2, 0.6, 1.2]}}
        },
        "spheres": [{"center": [0.0, 1.2, 0.0], "radius": 1.2, "material": "ball", "name": "ball"}]
    }"#;
    scene_over_floor("ball", json)
}

#[test]
fn a_textured_sphere_keeps_the_guarantee_over_a_walk() {
    let scene = textured_ball_scene();
    let camera = scene.camera.unwrap();
    // Large enough that cells on the ball split small enough to pass.
    let size = (400, 300);
    let path = CameraPath::Walk(camera);
    for epsilon in [0.05, 0.5] {
        let mut b = bounded(
            &scene,
            BoundedSettings {
                epsilon,
                ..Default::default()
            },
        );
        let (mut on_ball, mut reprojected) = (0, 0);
        for f in 0..3 {
            let cam = path.at(f, 3);
            let frame = b.render(&cam, size.0, size.1).unwrap();
            let e = compare(&frame, &exact(&scene, &cam, size), epsilon, b.settings.floor);
            assert_eq!(e.violations, 0, "epsilon {epsilon}, frame {f}: {e:?}");
            reprojected += frame.stats.pixels.reprojected;
            for &cell in frame.cells.iter().filter(|&&c| c != u32::MAX) {
                if let CellState::Valid(interp) = &b.trees.cells[cell as usize].state {
                    on_ball += interp.diffuse.is_some() as usize;
                }
            }
        }
        println!("epsilon {epsilon}: {on_ball} pixels interpolated on textured cells, {reprojected} reprojected");
        assert!(
            on_ball > 100,
            "epsilon {epsilon}: only {on_ball} textured pixels interpolated"
        );
    }
}

/// A UV sphere of smooth triangles (an OBJ with `vn`) over the floor, lit
/// by a point light: one smooth patch whose triangles cover a few pixels
/// each at 320 x 240, as a user's mesh does.
fn smooth_ball_scene() -> Scene {
    let (rings, segments) = (24, 48);
    let mut obj = String::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            let p = n + Vec3::new(0.0, 1.05, 0.0);
            obj += &format!("v {} {} {}\nvn {} {} {}\n", p.x, p.y, p.z, n.x, n.y, n.z);
        }
    }
    let at = |r: usize, s: usize| r * segments + s % segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (at(r, s), at(r, s + 1), at(r + 1, s + 1), at(r + 1, s));
            if r > 0 {
                obj += &format!("f {a}//{a} {b}//{b} {c}//{c}\n");
            }
            if r + 1 < rings {
                obj += &format!("f {a}//{a} {c}//{c} {d}//{d}\n");
            }
        }
    }
    let json = r#"{
        "ambient": [0.05, 0.05, 0.05],
        "background": [0.3, 0.4, 0.6],
        "camera": {"eye": [0.3, 2.2, 5.0], "fov": 40, "target": [0.0, 1.0, 0.0]},
        "meshes": {"floor": "floor.obj", "ball": "ball.obj"},
        "instances": [{"mesh": "floor", "material": "matte"}, {"mesh": "ball", "material": "clay"}],
        "lights": [{"point": {"intensity": [60.0, 60.0, 60.0], "position": [3.0, 6.0, 4.0]}}],
        "materials": {
            "matte": {"kd": [0.6, 0.6, 0.6], "ka": [0.6, 0.6, 0.6], "illum": 1},
            "clay": {"kd": [0.7, 0.5, 0.3], "ka": [0.7, 0.5, 0.3], "ks": [0.1, 0.1, 0.1], "ns": 8, "illum": 2}
        }
    }"#;
    scene_over_floor_with("smooth-ball", json, &[("ball.obj", &obj)])
}

/// Over a smooth mesh, with `patches` on, cells interpolate across its
/// triangles (a smooth patch is one linetree surface), and the bound
/// holds: against exact Whitted pixel by pixel, and on random lines of
/// every accepted cell. Also on the shared teapot, where present. With
/// `patches` off (the default) no cell spans triangles.
#[test]
fn a_smooth_mesh_is_interpolated_across_its_triangles_within_the_bound() {
    use penumbra::bounded::predicate::RootFace;
    let mut scenes = vec![("smooth ball".to_string(), smooth_ball_scene())];
    if let Some(path) = common::data_model("teapot.obj") {
        let obj = penumbra::scene::load_obj_file(&path).unwrap();
        let mut scene = Scene::from_obj_file("teapot", &path, obj);
        scene.camera = Some(Camera {
            eye: Vec3::new(2.0, 4.5, 7.5),
            target: Vec3::new(0.2, 1.4, 0.0),
            fov_degrees: 40.0,
        });
        scenes.push(("teapot".into(), scene));
    }
    for ((name, scene), patches) in scenes.iter().flat_map(|s| [(s, true), (s, false)]) {
        let path = CameraPath::Walk(scene.camera.unwrap());
        let size = (320, 240);
        let settings = BoundedSettings {
            patches,
            ..Default::default()
        };
        let mut b = bounded(scene, settings);
        let (mut across, mut lines) = (0, 0);
        for f in 0..3 {
            let camera = path.at(f, 3);
            let frame = b.render(&camera, size.0, size.1).unwrap();
            let e = compare(
                &frame,
                &exact(scene, &camera, size),
                b.settings.epsilon,
                b.settings.floor,
            );
            assert_eq!(e.violations, 0, "{name} frame {f}: {e:?}");
            let params = b.whitted.params(&camera, size.0, size.1, &b.settings.whitted).unwrap();
            let check = b.check(&params, 16, f);
            assert_eq!(check.violations, 0, "{name} frame {f}: {check:?}");
            lines += check.lines - check.skipped;
            assert_no_pixel_crosses_a_tree_change(name, &b, &frame);
            across += frame
                .cells
                .iter()
                .filter(|&&c| c != u32::MAX)
                .filter(|&&c| match &b.trees.cells[c as usize].state {
                    CellState::Valid(i) => matches!(i.accepted.root, RootFace::Patch(_)) && i.accepted.pieces.len() > 1,
                    _ => false,
                })
                .count();
        }
        println!(
            "{name}, patches {patches}: {across} pixels interpolated in cells over several triangles, {lines} random lines checked"
        );
        if patches {
            assert!(
                across > 500,
                "{name}: only {across} pixels interpolated across triangles"
            );
        } else {
            assert_eq!(across, 0, "{name}: cells span triangles with patches off");
        }
    }
}
