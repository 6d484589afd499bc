//! The Whitted ray tracer, correct by construction: equal indices do not
//! bend light, a mirror flips what it shows, total internal reflection has
//! no refracted ray, no path gains energy, no scale makes acne or NaN,
//! packets and single rays agree, anti-aliasing converges and repeats.

mod common;

use std::path::{Path, PathBuf};

use glam::Vec3;
use penumbra::gpu::device::Device;
use penumbra::progress::{Bar, Reporter};
use penumbra::scene::{Camera, Light, MtlRules, Scene, load_obj_file, load_scene_shaded};
use penumbra::whitted::ray_tree::RayKind;
use penumbra::whitted::{LightingSettings, Packets, RenderScene, Rendered, WhittedRenderer, WhittedSettings};
use penumbra_assets::raytrace::shipped_scenes;

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/raytrace")
}

fn shipped(name: &str) -> Scene {
    load_scene_shaded(&assets().join(format!("{name}.json"))).unwrap()
}

/// A scene of an OBJ and its MTL written to a temporary folder.
fn obj_scene(name: &str, obj: &str, mtl: &str) -> Scene {
    let dir = std::env::temp_dir().join(format!("penumbra-rt-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("m.mtl"), mtl).unwrap();
    let path = dir.join("s.obj");
    std::fs::write(&path, format!("mtllib m.mtl\n{obj}")).unwrap();
    let obj = load_obj_file(&path).unwrap();
    assert!(obj.warnings.is_empty(), "{:?}", obj.warnings);
    Scene::from_obj_file(name, &path, obj)
}

fn renderer(scene: &Scene) -> WhittedRenderer {
    let rs = RenderScene::new(scene, 0, &LightingSettings::default()).unwrap();
    WhittedRenderer::new(&Device::cpu(), rs, &Reporter::silent()).unwrap()
}

fn render(scene: &Scene, camera: &Camera, (w, h): (u32, u32), settings: &WhittedSettings) -> Rendered {
    renderer(scene).render(camera, w, h, settings, &Bar::hidden()).unwrap()
}

fn camera(eye: [f32; 3], target: [f32; 3], fov: f32) -> Camera {
    Camera {
        eye: Vec3::from_array(eye),
        target: Vec3::from_array(target),
        fov_degrees: fov,
    }
}

/// Largest per-channel difference relative to max(1, |a|), and how many
/// pixels differ by more than `tol`.
fn compare(a: &[Vec3], b: &[Vec3], tol: f32) -> (f32, usize) {
    let mut worst = 0f32;
    let mut over = 0;
    for (x, y) in a.iter().zip(b) {
        let d = ((*x - *y).abs() / x.abs().max(Vec3::ONE)).max_element();
        worst = worst.max(d);
        over += (d > tol) as usize;
    }
    (worst, over)
}

const WALL_MTL: &str = "newmtl red\nKd 0.9 0.1 0.1\nillum 0\nnewmtl green\nKd 0.1 0.9 0.1\nillum 0\n\
newmtl floor\nKa 0.5 0.5 0.5\nKd 0.6 0.6 0.6\nillum 1\n";

/// A wall at z = -4 (red left, green right), facing +z.
const WALL: &str = "v -4 -3 -4\nv 0 -3 -4\nv 0 3 -4\nv -4 3 -4\nv 4 -3 -4\nv 4 3 -4\n\
usemtl red\nf 1 2 3 4\nusemtl green\nf 2 5 6 3\n";

#[test]
fn glass_of_index_one_leaves_the_scene_behind_unchanged() {
    // A wall and a lit floor behind a glass block of index 1 that
    // transmits everything and reflects nothing.
    let floor = "v -6 -2 -6\nv -6 -2 3\nv 6 -2 3\nv 6 -2 -6\nusemtl floor\nf 7 8 9 10\n";
    let block = "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
usemtl clear\nf 11 14 13 12\nf 15 16 17 18\nf 11 12 16 15\nf 14 18 17 13\nf 11 15 18 14\nf 12 13 17 16\n";
    let mtl = format!("{WALL_MTL}newmtl clear\nKa 0 0 0\nKd 0 0 0\nKs 0 0 0\nTf 1 1 1\nNi 1\nillum 6\n");
    let with = obj_scene("ni1-with", &format!("{WALL}{floor}{block}"), &mtl);
    let without = obj_scene("ni1-without", &format!("{WALL}{floor}"), &mtl);
    let cam = camera([0.5, 0.8, 5.0], [0.0, -0.5, -4.0], 50.0);
    let settings = WhittedSettings::default();
    let a = render(&with, &cam, (64, 48), &settings);
    let b = render(&without, &cam, (64, 48), &settings);
    assert!(a.stats.rays.refraction > 0, "the block is in view");
    let (worst, over) = compare(&a.radiance(), &b.radiance(), 1e-5);
    println!("index-1 glass: worst relative difference {worst:.2e}, {over} pixels above 1e-5");
    assert_eq!(over, 0);
}

#[test]
fn a_mirror_shows_the_wall_flipped() {
    // A mirror at z = 0 facing +z, the wall of constant colours behind
    // the camera at z = +4 facing -z: seen in the mirror from (0, 0, 2), it
    // is what a camera at (0, 0, -2) looking at it directly sees, flipped
    // left to right.
    let wall_behind = "v 4 -3 4\nv 0 -3 4\nv 0 3 4\nv 4 3 4\nv -4 -3 4\nv -4 3 4\n\
usemtl red\nf 1 2 3 4\nusemtl green\nf 2 5 6 3\n";
    let mirror = "v -6 -6 0\nv 6 -6 0\nv 6 6 0\nv -6 6 0\nusemtl mirror\nf 7 8 9 10\n";
    let mtl = format!("{WALL_MTL}newmtl mirror\nKa 0 0 0\nKd 0 0 0\nKs 1 1 1\nillum 3\n");
    // The light is behind the mirror, so the mirror adds no highlight of
    // its own; the wall's colours are constant (illum 0).
    let lit = |mut s: Scene| {
        s.lights = vec![Light::Point {
            position: Vec3::new(0.0, 0.0, -10.0),
            intensity: Vec3::ONE,
        }];
        s
    };
    let seen = render(
        &lit(obj_scene("mirror", &format!("{wall_behind}{mirror}"), &mtl)),
        &camera([0.0, 0.0, 2.0], [0.0, 0.0, 0.0], 40.0),
        (40, 30),
        &WhittedSettings::default(),
    );
    let direct = render(
        &lit(obj_scene("mirror-direct", wall_behind, &mtl)),
        &camera([0.0, 0.0, -2.0], [0.0, 0.0, 0.0], 40.0),
        (40, 30),
        &WhittedSettings::default(),
    );
    let (a, b) = (seen.radiance(), direct.radiance());
    let mut differ = 0;
    for y in 0..30 {
        for x in 0..40 {
            differ += (a[y * 40 + x] != b[y * 40 + 39 - x]) as usize;
        }
    }
    assert!(
        a.iter().any(|c| c.x > 0.5) && a.iter().any(|c| c.y > 0.5),
        "both halves in view"
    );
    assert_eq!(differ, 0, "pixels that are not the flipped direct view");
}

#[test]
fn total_internal_reflection_exactly_beyond_the_critical_angle() {
    // From inside a glass block (index 1.5) towards its top face: beyond
    // asin(1/1.5) = 41.81 degrees no refracted ray exists.
    let block = "v -50 -1 -5\nv 50 -1 -5\nv 50 1 -5\nv -50 1 -5\nv -50 -1 5\nv 50 -1 5\nv 50 1 5\nv -50 1 5\n\
usemtl glass\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";
    let mtl = "newmtl glass\nKd 0 0 0\nKs 0.1 0.1 0.1\nTf 0.9 0.9 0.9\nNi 1.5\nillum 6\n";
    let r = renderer(&obj_scene("tir", block, mtl));
    let critical = (1.0f32 / 1.5).asin().to_degrees();
    let settings = WhittedSettings {
        max_depth: 1,
        ..WhittedSettings::default()
    };
    for tenth in 0..850 {
        let degrees = tenth as f32 * 0.1;
        if (degrees - critical).abs() < 0.05 {
            continue;
        }
        let a = degrees.to_radians();
        let (_, tree) = r
            .ray_tree(Vec3::new(0.0, 0.0, 0.0), Vec3::new(a.sin(), a.cos(), 0.0), &settings)
            .unwrap();
        let root = &tree.nodes[0];
        let tir = degrees > critical;
        assert_eq!(root.tir, tir, "{degrees} degrees");
        assert_eq!(root.refracted, !tir, "{degrees} degrees");
        assert!(root.reflected, "{degrees} degrees");
        let kinds: Vec<RayKind> = tree.nodes.iter().map(|n| n.kind).collect();
        assert_eq!(kinds.contains(&RayKind::Refraction), !tir);
    }
}

#[test]
fn energy_never_increases_along_a_path() {
    for scene in shipped_scenes() {
        let s = shipped(scene.name);
        let r = renderer(&s);
        let cam = s.camera.unwrap();
        for fresnel in [false, true] {
            let settings = WhittedSettings {
                fresnel,
                ..WhittedSettings::default()
            };
            let mut nodes = 0;
            for y in (0..24).step_by(3) {
                for x in (0..32).step_by(3) {
                    let (radiance, tree) = r.pixel_tree(&cam, (32, 24), &settings, (x, y, 0)).unwrap();
                    assert!(radiance.is_finite());
                    for n in &tree.nodes {
                        let parent = n.parent.map_or(Vec3::ONE, |p| tree.nodes[p as usize].weight);
                        assert!(
                            n.weight.cmple(parent).all() && n.weight.cmpge(Vec3::ZERO).all(),
                            "{}: weight {} under {}",
                            scene.name,
                            n.weight,
                            parent
                        );
                    }
                    nodes += tree.nodes.len();
                }
            }
            assert!(nodes > 0);
        }
    }
}

/// `scene` scaled by `s` about the origin, with lights scaled so that the
/// image stays the same: positions and the camera by `s`, point lights'
/// intensities by `s^2`, checker textures' cubes by `s`.
fn scaled(scene: &Scene, s: f32) -> (Scene, Camera) {
    let mut out = scene.clone();
    let materials = out.materials.iter_mut().chain(
        out.meshes
            .iter_mut()
            .flat_map(|m| m.shading.iter_mut().flat_map(|sh| sh.materials.iter_mut())),
    );
    for c in materials.filter_map(|m| m.checker.as_mut()) {
        c.size *= s;
        c.origin *= s;
    }
    for inst in &mut out.instances {
        inst.transform.scale *= s;
        inst.transform.translation *= s;
    }
    for sphere in &mut out.spheres {
        sphere.center *= s;
        sphere.radius *= s;
    }
    for light in &mut out.lights {
        if let Light::Point { position, intensity } = light {
            *position *= s;
            *intensity *= s * s;
        }
    }
    let c = scene.camera.unwrap();
    let cam = Camera {
        eye: c.eye * s,
        target: c.target * s,
        ..c
    };
    (out, cam)
}

#[test]
fn every_shipped_scene_renders_alike_at_every_scale_without_nan() {
    for shipped_scene in shipped_scenes() {
        let scene = shipped(shipped_scene.name);
        let (w, h) = (64, 48);
        let base = render(&scene, &scene.camera.unwrap(), (w, h), &WhittedSettings::default()).radiance();
        for s in [1e-4f32, 1e5] {
            let (big, cam) = scaled(&scene, s);
            let img = render(&big, &cam, (w, h), &WhittedSettings::default()).radiance();
            assert!(img.iter().all(|c| c.is_finite()), "{} at scale {s}", shipped_scene.name);
            let (worst, over) = compare(&base, &img, 1e-2);
            println!(
                "{} at scale {s:e}: worst relative difference {worst:.2e}, {over} of {} pixels above 1%",
                shipped_scene.name,
                w * h
            );
            // Rounding may move a pixel across an edge; acne would move many.
            assert!(over * 200 <= (w * h) as usize, "{} at scale {s}", shipped_scene.name);
        }
    }
}

#[test]
fn packets_and_single_rays_give_the_same_image() {
    for shipped_scene in shipped_scenes() {
        let scene = shipped(shipped_scene.name);
        let cam = scene.camera.unwrap();
        for spp in [1, 4] {
            let settings = |packets| WhittedSettings {
                packets,
                spp,
                ..WhittedSettings::default()
            };
            let a = render(&scene, &cam, (67, 45), &settings(Packets::On));
            let b = render(&scene, &cam, (67, 45), &settings(Packets::Off));
            assert_eq!(a.pixels, b.pixels, "{} with {spp} samples", shipped_scene.name);
        }
    }
}

#[test]
fn antialiasing_converges_and_repeats_for_a_seed() {
    let scene = shipped("checker-spheres");
    let cam = scene.camera.unwrap();
    let mut r = renderer(&scene);
    let mut image = |spp: u32, seed: u32| {
        let settings = WhittedSettings {
            spp,
            seed,
            ..WhittedSettings::default()
        };
        r.render(&cam, 48, 36, &settings, &Bar::hidden()).unwrap().radiance()
    };
    let reference = image(256, 99);
    let rms = |img: &[Vec3]| {
        let sum: f32 = img
            .iter()
            .zip(&reference)
            .map(|(a, b)| (*a - *b).length_squared())
            .sum();
        (sum / img.len() as f32).sqrt()
    };
    let errors: Vec<f32> = [1, 4, 16, 64].iter().map(|&spp| rms(&image(spp, 7))).collect();
    println!("RMS error against 256 samples per pixel, by 1, 4, 16, 64 samples: {errors:?}");
    assert!(errors.windows(2).all(|e| e[1] < e[0]), "{errors:?}");
    assert!(errors[2] < 0.5 * errors[0], "{errors:?}");
    assert_eq!(image(16, 7), image(16, 7), "a seed repeats bit for bit");
    assert_ne!(image(16, 7), image(16, 8), "another seed, other samples");
}

#[test]
fn a_camera_inside_glass_starts_in_it() {
    let scene = shipped("inside-glass");
    let r = renderer(&scene);
    let cam = scene.camera.unwrap();
    let media = r.scene().media_at(cam.eye);
    assert_eq!(media.len(), 1);
    assert_eq!(r.scene().surface_names[media[0] as usize], "glass");
    // The eye ray leaves the glass: it meets the dome from inside and its
    // refracted child bends away from the normal (index 1.5 to 1).
    let (_, tree) = r
        .pixel_tree(&cam, (16, 12), &WhittedSettings::default(), (8, 6, 0))
        .unwrap();
    let root = &tree.nodes[0];
    assert_eq!(r.scene().objects[root.hit.unwrap().object as usize], "glass-dome");
    let child = tree
        .nodes
        .iter()
        .find(|n| n.kind == RayKind::Refraction)
        .expect("a refracted ray");
    let normal = (root.hit.unwrap().point - Vec3::new(0.0, 2.5, 0.0)).normalize();
    let (sin_in, sin_out) = (root.dir.cross(normal).length(), child.dir.cross(normal).length());
    assert!((sin_out - 1.5 * sin_in).abs() < 1e-3, "Snell: {sin_in} -> {sin_out}");
}

#[test]
fn analytic_and_tessellated_spheres_agree_closely() {
    let a = shipped("checker-spheres");
    let b = shipped("checker-spheres-tessellated");
    let cam = a.camera.unwrap();
    let settings = WhittedSettings::default();
    let (ia, ib) = (
        render(&a, &cam, (96, 72), &settings).radiance(),
        render(&b, &cam, (96, 72), &settings).radiance(),
    );
    let (worst, over) = compare(&ia, &ib, 0.05);
    println!("analytic vs tessellated spheres: worst {worst:.3}, {over} of 6912 pixels differ by more than 5%");
    // Silhouettes and refracted images differ by the polygons' facets.
    assert!(over * 20 < ia.len(), "{over}");
}

#[test]
fn emissive_faces_light_the_shared_cornell_box() {
    let Some(path) = common::data_scene("CornellBox-Original.obj") else {
        return;
    };
    let obj = load_obj_file(&path).unwrap();
    assert_eq!(obj.warnings.len(), 1, "the MTL's stray `v` line: {:?}", obj.warnings);
    let scene = Scene::from_obj_file("cornell", &path, obj);
    for samples in [1, 16] {
        let options = LightingSettings {
            light_samples: samples,
            ..LightingSettings::default()
        };
        let rs = RenderScene::new(&scene, 0, &options).unwrap();
        assert_eq!(rs.lights.len(), samples as usize, "one emissive quad");
        assert_eq!(rs.emitters, 1);
        let mut r = WhittedRenderer::new(&Device::cpu(), rs, &Reporter::silent()).unwrap();
        let cam = camera([0.0, 1.0, 3.5], [0.0, 1.0, 0.0], 40.0);
        let img = r
            .render(&cam, 32, 32, &WhittedSettings::default(), &Bar::hidden())
            .unwrap();
        // The floor and boxes in the lower quarter are lit well above the
        // ambient term (0.05 x 0.725): Kd E / pi with E = Ke A cos cos / d^2
        // comes to about 0.18 below the light.
        let radiance = img.radiance();
        let brightest = radiance[24 * 32..].iter().map(|c| c.x).fold(0.0, f32::max);
        assert!(brightest > 0.12, "{brightest}");
        assert!(radiance.iter().all(|c| c.is_finite()));
    }
}

#[test]
fn shipped_scenes_need_no_mtl_rule_but_the_exporters_room() {
    // Their MTL files are penumbra's generator's, written to the letter of
    // the spec: no rule reads them otherwise, so they render as before.
    // The textured room's MTL is written as exporters write it, to show the
    // rules: its Maya-style walls are opaque, its Blender-style white
    // ambient follows the colour (not beside a map: Kd is black there).
    for shipped_scene in shipped_scenes() {
        let scene = shipped(shipped_scene.name);
        if shipped_scene.name == "textured-room" {
            let rs = RenderScene::new(&scene, 0, &LightingSettings::default()).unwrap();
            let rules: Vec<(String, Vec<String>)> = rs
                .material_rules
                .iter()
                .map(|r| (r.rule.name().to_string(), r.materials.clone()))
                .collect();
            assert_eq!(
                rules,
                [(
                    "invisible-glass".to_string(),
                    vec!["wallBackSG".to_string(), "wallSideSG".to_string()]
                )],
                "{:?}",
                rs.material_rules
            );
            assert!(
                rs.surfaces.iter().all(|s| s.kt == [0.0; 3]),
                "nothing in the room is see-through"
            );
            continue;
        }
        let exporters = RenderScene::new(&scene, 0, &LightingSettings::default()).unwrap();
        let spec = LightingSettings {
            mtl_rules: MtlRules::Spec,
            ..LightingSettings::default()
        };
        let spec = RenderScene::new(&scene, 0, &spec).unwrap();
        assert!(exporters.material_rules.is_empty(), "{}", shipped_scene.name);
        assert_eq!(exporters.surfaces, spec.surfaces, "{}", shipped_scene.name);
        assert_eq!(exporters.warnings, spec.warnings, "{}", shipped_scene.name);
    }
}

/// The Maya-style dining room (`tests/data/mtl/maya_room.obj`: a closed
/// box room, a table, a chair and a glass vase, every material illum 4),
/// its MTL replaced by `mtl` where given, lit by a point light under the
/// ceiling.
fn maya_room(mtl: Option<&str>) -> Scene {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mtl");
    let mut scene = match mtl {
        None => {
            let path = data.join("maya_room.obj");
            Scene::from_obj_file("maya_room", &path, load_obj_file(&path).unwrap())
        }
        Some(mtl) => {
            let obj = std::fs::read_to_string(data.join("maya_room.obj")).unwrap();
            let obj = obj.replace("mtllib maya_room.mtl\n", "");
            obj_scene("maya-room-spec", &obj, mtl)
        }
    };
    scene.lights = vec![Light::Point {
        position: Vec3::new(0.0, 2.8, 1.5),
        intensity: Vec3::splat(4.0),
    }];
    scene
}

/// The room as Maya meant it, written to the letter of the spec: opaque
/// walls, floor and table, a half-mirror blinn chair (illum 4 reflects
/// `Ks`), and glass transmitting 1 - Tf = 0.75 with Kd faded by Tf.
const MAYA_ROOM_AS_MEANT: &str = "newmtl initialShadingGroup\nKd 0.5 0.5 0.5\nillum 2\n\
newmtl lambert2SG\nKd 0.70 0.65 0.55\nillum 2\n\
newmtl lambert4SG\nKd 0.45 0.30 0.15\nNi 1.33\nillum 2\n\
newmtl blinn1SG\nKd 0.40 0.20 0.10\nKs 0.5 0.5 0.5\nNs 20\nillum 3\n\
newmtl glassSG\nKd 0.05 0.05 0.05\nKs 0.5 0.5 0.5\nNs 80\nTf 0.75 0.75 0.75\nNi 1.5\nillum 4\n";

#[test]
fn a_maya_room_renders_opaque_with_only_its_glass_refracting() {
    let (w, h) = (48, 36);
    let cam = camera([0.0, 1.6, 3.5], [0.0, 1.0, 0.0], 70.0);
    // Rays that leave the room come back bright blue.
    let lighting = |mtl_rules| LightingSettings {
        background: Some(Vec3::new(0.0, 0.0, 4.0)),
        mtl_rules,
        ..LightingSettings::default()
    };
    let run = |scene: &Scene, rules| {
        let rs = RenderScene::new(scene, 0, &lighting(rules)).unwrap();
        let rules: Vec<(String, Vec<String>)> = rs
            .material_rules
            .iter()
            .map(|a| (a.rule.name().to_string(), a.materials.clone()))
            .collect();
        let mut r = WhittedRenderer::new(&Device::cpu(), rs, &Reporter::silent()).unwrap();
        let img = r
            .render(&cam, w, h, &WhittedSettings::default(), &Bar::hidden())
            .unwrap();
        (img, rules)
    };
    let (maya, rules) = run(&maya_room(None), MtlRules::Exporters);
    let (meant, no_rules) = run(&maya_room(Some(MAYA_ROOM_AS_MEANT)), MtlRules::Exporters);
    let (glass_room, spec_rules) = run(&maya_room(None), MtlRules::Spec);
    let refraction = |r: &Rendered| r.stats.rays.refraction;
    println!(
        "refraction rays, {w}x{h}: Maya room {} with the rules, {} as meant, {} by the letter of the spec",
        refraction(&maya),
        refraction(&meant),
        refraction(&glass_room)
    );
    assert_eq!(
        rules,
        [
            (
                "invisible-glass".to_string(),
                vec![
                    "lambert2SG".to_string(),
                    "initialShadingGroup".into(),
                    "blinn1SG".into()
                ]
            ),
            (
                "maya-opacity".to_string(),
                vec!["lambert4SG".to_string(), "glassSG".into()]
            )
        ]
    );
    assert!(no_rules.is_empty() && spec_rules.is_empty());
    // With the rules, the Maya room is the room as meant, ray for ray.
    assert_eq!(maya.stats.rays, meant.stats.rays);
    assert_eq!(maya.radiance(), meant.radiance());
    // Only the vase refracts, and it is in view.
    assert!(refraction(&maya) > 0);
    assert!(
        refraction(&glass_room) > 10 * refraction(&maya),
        "by the letter of the spec every surface is glass"
    );
    // Opaque walls: no pixel sees out of the room; through the glass room
    // most do.
    let sees_out = |r: &Rendered| r.radiance().iter().filter(|c| c.z > 1.0).count();
    assert_eq!(sees_out(&maya), 0);
    assert!(
        sees_out(&glass_room) * 2 > (w * h) as usize,
        "{}",
        sees_out(&glass_room)
    );
}
