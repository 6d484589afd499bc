//! Alpha cut-outs are holes for every ray that AO casts: a card whose map
//! is all holes occludes nothing (the very rays of a scene without it
//! escape), an opaque map occludes as the bare card does, a half-holed card
//! shades the floor under its solid half only; primary rays of an AO image
//! pass holes; a field built through cut-outs sees through them; and the
//! GPU kernel answers as the CPU twin does.

mod common;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::DVec3;
use penumbra::AmbientOcclusion;
use penumbra::field::DisplacementField;
use penumbra::field::{DirectionMapping, FieldSampling};
use penumbra::gpu::device::Device;
use penumbra::progress::Bar;
use penumbra::raycast::AoSettings;
use penumbra::scene::cutouts::Cutouts;
use penumbra::scene::texture_table::DEFAULT_TEXTURE_BYTES;
use penumbra::scene::{CameraSpec, Scene, View, load_obj_file};

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("penumbra-cutouts-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// An 8x8 RGBA image whose left half has alpha `left` and right half `right`.
fn halves(dir: &Path, name: &str, left: u8, right: u8) {
    let image = image::RgbaImage::from_fn(8, 8, |x, _| {
        image::Rgba([200, 200, 200, if x < 4 { left } else { right }])
    });
    image.save(dir.join(name)).unwrap();
}

/// A 9x9 grid floor over [-1, 1]^2 at z = 0 facing +z (material `floor`)
/// and, unless `card` is None, a card over [-0.5, 0.5]^2 at z = 0.3 with
/// texture coordinates 0..1 across it (material `card`, whose MTL body is
/// `card`).
fn scene(dir: &Path, card: Option<&str>) -> Scene {
    let mut obj = String::from("mtllib m.mtl\nusemtl floor\n");
    let n = 9;
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (
                -1.0 + 2.0 * i as f32 / (n - 1) as f32,
                -1.0 + 2.0 * j as f32 / (n - 1) as f32,
            );
            writeln!(obj, "v {x} {y} 0").unwrap();
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i + 1;
            writeln!(obj, "f {a} {} {} {}", a + 1, a + 1 + n, a + n).unwrap();
        }
    }
    let mut mtl = String::from("newmtl floor\nKd 0.8 0.8 0.8\n");
    if let Some(body) = card {
        let b = n * n;
        obj.push_str("v -0.5 -0.5 0.3\nv 0.5 -0.5 0.3\nv 0.5 0.5 0.3\nv -0.5 0.5 0.3\n");
        obj.push_str("vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl card\n");
        writeln!(obj, "f {}/1 {}/2 {}/3 {}/4", b + 1, b + 2, b + 3, b + 4).unwrap();
        writeln!(mtl, "newmtl card\nKd 0.5 0.5 0.5\n{body}").unwrap();
    }
    std::fs::write(dir.join("m.mtl"), mtl).unwrap();
    let path = dir.join("s.obj");
    std::fs::write(&path, obj).unwrap();
    Scene::from_obj_file("s", &path, load_obj_file(&path).unwrap())
}

/// AO of the floor's 81 vertices (the card's are dropped).
fn floor_ao(device: &Device, scene: &Scene) -> Vec<f32> {
    let settings = AoSettings {
        rays_per_point: 512,
        ..Default::default()
    };
    let mut ao = AmbientOcclusion::for_scene(device, scene).unwrap();
    let mut v = ao.vertices(&settings).unwrap().ao;
    v.truncate(81);
    v
}

#[test]
fn a_card_all_holes_occludes_nothing_and_an_opaque_map_as_the_bare_card() {
    let dir = folder("extremes");
    halves(&dir, "clear.png", 0, 0);
    halves(&dir, "solid.png", 255, 255);
    let device = Device::cpu();
    let none = floor_ao(&device, &scene(&dir, None));
    let bare = floor_ao(&device, &scene(&dir, Some("")));
    let clear = floor_ao(&device, &scene(&dir, Some("map_d clear.png")));
    let solid = floor_ao(&device, &scene(&dir, Some("map_d solid.png")));
    assert!(
        bare.iter().zip(&none).any(|(b, n)| b < n),
        "the bare card occludes the floor"
    );
    assert_eq!(clear, none, "a card that is all holes lets every ray through");
    assert_eq!(solid, bare, "an opaque cut-out map occludes as the bare card");
    let cutouts = Cutouts::of_scene(
        &scene(&dir, Some("map_d clear.png")),
        |_| true,
        DEFAULT_TEXTURE_BYTES,
        &mut Vec::new(),
    )
    .expect("the card has a cut-out");
    assert_eq!(cutouts.records.len(), 2, "the card's two triangles");
}

#[test]
fn a_half_holed_card_shades_the_floor_under_its_solid_half() {
    let dir = folder("half");
    // u < 0.5 (x < 0) holes, u > 0.5 solid.
    halves(&dir, "half.png", 0, 255);
    let device = Device::cpu();
    let none = floor_ao(&device, &scene(&dir, None));
    let half = floor_ao(&device, &scene(&dir, Some("map_d half.png")));
    // Vertices (i, j) of the grid at x = -0.25 and x = 0.25, y = 0: under
    // the card's holed and solid halves.
    let at = |i: usize| 4 * 9 + i;
    let (left, right) = (at(3), at(5));
    println!(
        "AO at x=-0.25: {} (no card {}), at x=0.25: {} (no card {})",
        half[left], none[left], half[right], none[right]
    );
    assert!(half[right] < none[right] - 0.2, "the solid half occludes");
    assert!(
        half[left] > half[right] + 0.1,
        "under the holes the floor sees more sky than under the solid half"
    );
}

#[test]
fn primary_rays_of_an_ao_image_pass_the_holes() {
    let dir = folder("image");
    halves(&dir, "half.png", 0, 255);
    let scene = scene(&dir, Some("map_d half.png"));
    // Straight down onto the card, which fills the middle of the image.
    let camera = CameraSpec {
        eye: Some(DVec3::new(0.0, 0.0, 3.0)),
        target: Some(DVec3::ZERO),
        fov_degrees: Some(20.0),
    };
    let view = View::new(camera, 40, 40).unwrap();
    let settings = AoSettings {
        rays_per_point: 64,
        ..Default::default()
    };
    let mut ao = AmbientOcclusion::for_scene(&Device::cpu(), &scene).unwrap();
    let image = ao.image(&view, &settings).unwrap();
    // The centre row: left of centre the holes show the floor (AO near 1
    // from straight above, with the card's solid half to one side), right
    // of centre the card itself (open to the sky: AO 1).
    let row = 20 * 40;
    let (l, r) = (image.values[row + 14].unwrap(), image.values[row + 26].unwrap());
    println!("AO left of centre (floor through a hole) {l}, right (the card) {r}");
    assert_eq!(r, 1.0, "the card's top sees only sky");
    assert!(l < 1.0, "through the hole the floor is seen, partly shaded by the card");
}

#[test]
fn a_field_built_through_holes_sees_through_them() {
    let dir = folder("field");
    halves(&dir, "clear.png", 0, 0);
    halves(&dir, "solid.png", 255, 255);
    let params = FieldSampling::new(289, 16, 32, DirectionMapping::Concentric).unwrap();
    let card_only = |map: &str| {
        let path = dir.join("card.obj");
        let obj = "mtllib m.mtl\nv -0.5 -0.5 0.3\nv 0.5 -0.5 0.3\nv 0.5 0.5 0.3\nv -0.5 0.5 0.3\n\
                   vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl card\nf 1/1 2/2 3/3 4/4\n";
        std::fs::write(&path, obj).unwrap();
        std::fs::write(dir.join("m.mtl"), format!("newmtl card\nKd 0.5 0.5 0.5\nmap_d {map}\n")).unwrap();
        let scene = Scene::from_obj_file("card", &path, load_obj_file(&path).unwrap());
        let mesh = &scene.meshes[0];
        let cutouts = Cutouts::of_mesh(mesh, DEFAULT_TEXTURE_BYTES, &mut Vec::new());
        let (_, stats) =
            DisplacementField::build_through(&mesh.mesh, cutouts.as_ref(), &params, "card", &Bar::hidden()).unwrap();
        stats.hit_fraction
    };
    let (clear, solid) = (card_only("clear.png"), card_only("solid.png"));
    println!("field hit fraction: card all holes {clear}, opaque {solid}");
    assert_eq!(clear, 0.0, "every ray passes a card that is all holes");
    assert!(solid > 0.1, "an opaque card stops the rays that meet it");
}

#[test]
fn gpu_ao_rays_pass_holes_as_the_cpu_twin() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let dir = folder("gpu");
    halves(&dir, "half.png", 0, 255);
    let scene = scene(&dir, Some("map_d half.png"));
    let cpu = floor_ao(&Device::cpu(), &scene);
    let gpu = floor_ao(&Device::gpu(ctx), &scene);
    let worst = cpu.iter().zip(&gpu).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    // Different trees (the GPU's and the CPU's leaves) may meet a hole's
    // edge on either side for a ray that grazes it: 2 of 512 rays.
    println!("worst per-vertex AO difference CPU vs GPU: {worst} (tolerance 2/512)");
    assert!(worst <= 2.0 / 512.0, "CPU and GPU agree within 2 rays of 512");
    let none = floor_ao(&Device::cpu(), &scene_without_card(&dir));
    assert!(
        gpu[4 * 9 + 3] > gpu[4 * 9 + 5] + 0.1 && gpu[4 * 9 + 3] <= none[4 * 9 + 3],
        "on the GPU too the holes let the sky through"
    );
}

fn scene_without_card(dir: &Path) -> Scene {
    scene(dir, None)
}
