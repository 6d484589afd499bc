//! Texture maps in the Whitted renderer, checked against the texels
//! themselves: a map's colour where `Kd` is black, the product beside a
//! colour, repeat and clamp, a missing image warned about and replaced by
//! the colour, cut-out holes that primary and shadow rays pass, and the
//! textured shipped room's images on the CPU and the GPU alike.

mod common;

use std::path::{Path, PathBuf};

use glam::Vec3;
use penumbra::gpu::device::Device;
use penumbra::progress::{Bar, Reporter};
use penumbra::scene::{Camera, Scene, load_obj_file, load_scene_shaded};
use penumbra::whitted::{LightingSettings, RenderScene, WhittedRenderer, WhittedSettings};

/// A folder of its own under the system's temporary one.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("penumbra-textures-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// An 8x8 RGBA image of four 4x4 quadrants: top left, top right, bottom
/// left, bottom right.
fn quadrants(dir: &Path, name: &str, colours: [[u8; 4]; 4]) {
    let image = image::RgbaImage::from_fn(8, 8, |x, y| image::Rgba(colours[(2 * (y / 4) + x / 4) as usize]));
    image.save(dir.join(name)).unwrap();
}

/// sRGB code to linear (IEC 61966-2-1).
fn linear(c: u8) -> f32 {
    let c = c as f64 / 255.0;
    (if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }) as f32
}

/// A unit quad in z = 0 facing +z with texture coordinates at its corners,
/// seen straight on by a camera that it fills exactly.
const QUAD: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
usemtl m\nf 1/1 2/2 3/3 4/4\n";

fn straight_on() -> Camera {
    // A fov whose half-tangent is 1/2 at distance 2: the quad fills it.
    Camera {
        eye: Vec3::new(0.0, 0.0, 2.0),
        target: Vec3::ZERO,
        fov_degrees: 2.0 * 0.5f32.atan().to_degrees(),
    }
}

fn scene_in(dir: &Path, obj: &str, mtl: &str) -> (Scene, Vec<String>) {
    std::fs::write(dir.join("m.mtl"), mtl).unwrap();
    let path = dir.join("s.obj");
    std::fs::write(&path, format!("mtllib m.mtl\n{obj}")).unwrap();
    let obj = load_obj_file(&path).unwrap();
    let warnings = obj.warnings.clone();
    (Scene::from_obj_file("s", &path, obj), warnings)
}

/// The image of `scene` from `camera` on the CPU, with the render scene's
/// warnings.
fn render(scene: &Scene, camera: &Camera, (w, h): (u32, u32)) -> (Vec<Vec3>, Vec<String>) {
    let rs = RenderScene::new(scene, 0, &LightingSettings::default()).unwrap();
    let warnings = rs.warnings.clone();
    let mut r = WhittedRenderer::new(&Device::cpu(), rs, &Reporter::silent()).unwrap();
    let out = r
        .render(camera, w, h, &WhittedSettings::default(), &Bar::hidden())
        .unwrap();
    let pixels = out.pixels.iter().map(|p| Vec3::from_array(p.radiance)).collect();
    (pixels, warnings)
}

const COLOURS: [[u8; 4]; 4] = [
    [255, 0, 0, 255],
    [0, 128, 0, 255],
    [20, 40, 200, 255],
    [250, 250, 250, 255],
];

fn decoded(c: [u8; 4]) -> Vec3 {
    Vec3::new(linear(c[0]), linear(c[1]), linear(c[2]))
}

/// The pixels at the centres of the image's quadrants (16x16 image).
fn quadrant_centres(pixels: &[Vec3]) -> [Vec3; 4] {
    [(4, 4), (12, 4), (4, 12), (12, 12)].map(|(x, y)| pixels[y * 16 + x])
}

#[test]
fn a_map_beside_a_black_kd_is_the_colour_and_beside_a_colour_the_product() {
    let dir = folder("product");
    quadrants(&dir, "q.png", COLOURS);
    // illum 0: the constant colour, so the radiance is the texel itself.
    let (scene, w) = scene_in(&dir, QUAD, "newmtl m\nKd 0 0 0\nillum 0\nmap_Kd q.png\n");
    assert!(w.is_empty(), "{w:?}");
    let (pixels, warnings) = render(&scene, &straight_on(), (16, 16));
    assert!(warnings.is_empty(), "{warnings:?}");
    let centres = quadrant_centres(&pixels);
    for (got, want) in centres.iter().zip(COLOURS) {
        assert!(
            (*got - decoded(want)).abs().max_element() < 1e-6,
            "{got} vs {}",
            decoded(want)
        );
    }
    // sRGB 128 is linear 0.216, not 0.5.
    assert!((centres[1].y - 0.2158).abs() < 1e-3, "{}", centres[1]);
    let (scene, _) = scene_in(&dir, QUAD, "newmtl m\nKd 0.5 1 0.25\nillum 0\nmap_Kd q.png\n");
    let (pixels, _) = render(&scene, &straight_on(), (16, 16));
    for (got, want) in quadrant_centres(&pixels).iter().zip(COLOURS) {
        let product = decoded(want) * Vec3::new(0.5, 1.0, 0.25);
        assert!((*got - product).abs().max_element() < 1e-6, "{got} vs {product}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn scale_repeats_the_image_and_clamp_holds_its_edge() {
    let dir = folder("wrap");
    quadrants(&dir, "q.png", COLOURS);
    // -s 2 2: the quad shows the image twice in each direction; the quad's
    // top-left quarter is then the whole image, its top-left pixel red.
    let (scene, _) = scene_in(&dir, QUAD, "newmtl m\nKd 0 0 0\nillum 0\nmap_Kd -s 2 2 1 q.png\n");
    let (pixels, _) = render(&scene, &straight_on(), (32, 32));
    let at = |x: usize, y: usize| pixels[y * 32 + x];
    for (x, y) in [(2, 2), (18, 2), (2, 18), (18, 18)] {
        assert!(
            (at(x, y) - decoded(COLOURS[0])).abs().max_element() < 1e-6,
            "repeat at {x},{y}: {}",
            at(x, y)
        );
    }
    assert!((at(10, 2) - decoded(COLOURS[1])).abs().max_element() < 1e-6);
    // -s 2 2 with -clamp on: beyond the image's right and top edges the
    // edge texels hold (u, v > 1 covers three quarters of the quad).
    let (scene, _) = scene_in(
        &dir,
        QUAD,
        "newmtl m\nKd 0 0 0\nillum 0\nmap_Kd -s 2 2 1 -clamp on q.png\n",
    );
    let (pixels, _) = render(&scene, &straight_on(), (32, 32));
    let at = |x: usize, y: usize| pixels[y * 32 + x];
    assert!(
        (at(30, 1) - decoded(COLOURS[1])).abs().max_element() < 1e-6,
        "{}",
        at(30, 1)
    );
    assert!(
        (at(30, 30) - decoded(COLOURS[3])).abs().max_element() < 1e-6,
        "{}",
        at(30, 30)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_missing_map_is_one_warning_naming_it_and_the_colour_is_used() {
    let dir = folder("missing");
    let (scene, _) = scene_in(
        &dir,
        QUAD,
        "newmtl m\nKd 0.3 0.6 0.9\nillum 0\nmap_Kd gone.png\nmap_Ka gone.png\n",
    );
    let (pixels, warnings) = render(&scene, &straight_on(), (16, 16));
    let gone = dir.join("gone.png").display().to_string();
    assert_eq!(
        warnings,
        [format!(
            "texture '{gone}' (material 'm') not found: the material's colour is used instead"
        )],
        "one warning per image, however many maps name it"
    );
    assert!(pixels.iter().all(|p| *p == Vec3::new(0.3, 0.6, 0.9)));
    // Faces without texture coordinates: the maps are not used there.
    quadrants(&dir, "q.png", COLOURS);
    let untextured = QUAD.replace("f 1/1 2/2 3/3 4/4", "f 1 2 3 4");
    let (scene, _) = scene_in(&dir, &untextured, "newmtl m\nKd 0.3 0.6 0.9\nillum 0\nmap_Kd q.png\n");
    let (pixels, warnings) = render(&scene, &straight_on(), (16, 16));
    assert_eq!(warnings.len(), 1);
    assert!(
        warnings[0].contains("2 of its triangles have no texture coordinates"),
        "{warnings:?}"
    );
    assert!(pixels.iter().all(|p| *p == Vec3::new(0.3, 0.6, 0.9)));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn cut_out_holes_let_primary_and_shadow_rays_through() {
    let dir = folder("cutout");
    // Left half transparent, right half opaque: the card's alpha.
    let image = image::RgbaImage::from_fn(8, 8, |x, _| image::Rgba([30, 200, 30, if x < 4 { 0 } else { 255 }]));
    image.save(dir.join("leaf.png")).unwrap();
    // The card at z = 0 in front of a lit wall at z = -1, the light to the
    // right of the camera: through the hole the eye sees the wall, lit
    // where the light's ray also passes the hole, in the shadow of the
    // card's opaque half where it does not.
    let obj = format!("{QUAD}v -3 -3 -1\nv 3 -3 -1\nv 3 3 -1\nv -3 3 -1\nusemtl wall\nf 5 6 7 8\n");
    let mtl = "newmtl m\nKd 1 1 1\nillum 1\nmap_Kd leaf.png\nmap_d leaf.png\nnewmtl wall\nKd 0.8 0.8 0.8\nKa 0 0 0\nillum 1\n";
    let light = vec![penumbra::scene::Light::Point {
        position: Vec3::new(3.0, 0.0, 6.0),
        intensity: Vec3::splat(40.0),
    }];
    let camera = Camera {
        eye: Vec3::new(0.0, 0.0, 4.0),
        target: Vec3::ZERO,
        fov_degrees: 50.0,
    };
    let (mut scene, _) = scene_in(&dir, &obj, mtl);
    scene.lights = light.clone();
    let (pixels, warnings) = render(&scene, &camera, (64, 64));
    assert!(warnings.is_empty(), "{warnings:?}");
    let at = |x: usize, y: usize| pixels[y * 64 + x];
    // Pixel 20 meets the card at x = -0.67 (a hole), the wall at -0.85,
    // whose shadow ray crosses the card at -0.30 (a hole): lit grey.
    let lit = at(20, 32);
    assert!(
        (lit.x - lit.y).abs() < 1e-6 && lit.x > 0.1,
        "the lit wall through the hole: {lit}"
    );
    // Pixel 28 meets the card at -0.20 (a hole), the wall at -0.26, whose
    // shadow ray crosses the card at +0.21 (opaque): in its shadow.
    let shadowed = at(28, 32);
    assert!(
        (shadowed.x - shadowed.y).abs() < 1e-6,
        "the wall through the hole: {shadowed}"
    );
    assert!(lit.x > 4.0 * shadowed.x, "lit {lit}, shadowed {shadowed}");
    // On the opaque half: the card's green.
    let card = at(40, 32);
    assert!(card.y > 2.0 * card.x, "the card: {card}");
    // The same scene without the cut-out: no hole, the card everywhere.
    let (mut solid, _) = scene_in(&dir, &obj, &mtl.replace("map_d leaf.png\n", ""));
    solid.lights = light;
    let (solid, _) = render(&solid, &camera, (64, 64));
    for x in [20, 28] {
        let p = solid[32 * 64 + x];
        assert!(p.y > 2.0 * p.x, "no hole without map_d: {p}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_textured_room_renders_alike_on_cpu_and_gpu() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/raytrace/textured-room.json");
    let scene = load_scene_shaded(&path).unwrap();
    let camera = scene.camera.unwrap();
    let run = |device: &Device| {
        let rs = RenderScene::new(&scene, 0, &LightingSettings::default()).unwrap();
        let mut r = WhittedRenderer::new(device, rs, &Reporter::silent()).unwrap();
        r.render(&camera, 160, 120, &WhittedSettings::default(), &Bar::hidden())
            .unwrap()
    };
    let (cpu, gpu) = (run(&Device::cpu()), run(&Device::gpu(ctx)));
    let mut worst = 0f32;
    for (a, b) in cpu.pixels.iter().zip(&gpu.pixels) {
        let d = (Vec3::from_array(a.radiance) - Vec3::from_array(b.radiance))
            .abs()
            .max_element();
        worst = worst.max(d);
    }
    println!("textured room, 160x120: worst per-channel radiance difference CPU vs GPU {worst:.2e} (tolerance 1e-3)");
    assert!(worst <= 1e-3, "worst {worst}");
}
