//! SSAO's G-buffer over texture maps (src/ssao/surfaces.rs): each pixel's
//! albedo is its material's colour times its `map_Kd` at the pixel's point
//! (the map alone beside a black colour), and an alpha cut-out's holes show
//! what lies behind, on the CPU (kd-tree primary rays) and the GPU raster
//! alike.
//!
//! The scene is made here: a wall (colour only), a quad showing a 2x2
//! checker map alone, and a card in front of the wall with the same map
//! tinted by half and a `map_d` whose left half is a hole; and the shipped
//! `textured-room` (a checker floor with a black `Kd`, a mapped globe, a
//! cut-out leaf).
//!
//! Tolerances, GPU against CPU: coverage and depth as in tests/ssao.rs
//! (>= 99% of pixels agree, the rest at silhouettes and the hole's edge);
//! on agreeing pixels the albedo within 1/255 per channel on all but 0.1%
//! of them (the worst is printed). At the chosen pixels both equal the
//! expected texel colours exactly.

mod common;
mod twins;

use common::{TempDir, gpu};
use glam::Vec3;
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::gpu::device::Device;
use penumbra::scene::texture_table::DEFAULT_TEXTURE_BYTES;
use penumbra::scene::{Camera, Scene, View, load_shaded_input};
use penumbra::ssao::gbuffer::{GBuffer, ScreenView, gbuffer_with};
use penumbra::ssao::surfaces::GBufferSurfaces;
use penumbra::ssao::{Ssao, SsaoSettings};
use twins::texels_agree;

const W: u32 = 160;
const H: u32 = 120;

/// The checker's four colours (sRGB bytes), by block: top-left, top-right,
/// bottom-left, bottom-right.
const CHECKER: [[u8; 3]; 4] = [[255, 0, 0], [0, 255, 0], [128, 128, 128], [255, 255, 255]];

/// The wall's diffuse colour, exact in 8 bits: 51, 102, 153.
const WALL: [u8; 3] = [51, 102, 153];

const OBJ: &str = "mtllib scene.mtl
v -4 -3 -1
v 4 -3 -1
v 4 3 -1
v -4 3 -1
v -2 -1 0
v -0.2 -1 0
v -0.2 1 0
v -2 1 0
v 0.2 -1 0
v 2 -1 0
v 2 1 0
v 0.2 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
o wall
usemtl wall
f 1 2 3 4
o checker
usemtl checker
f 5/1 6/2 7/3 8/4
o card
usemtl card
f 9/1 10/2 11/3 12/4
";

const MTL: &str = "newmtl wall
Kd 0.2 0.4 0.6
newmtl checker
Kd 0 0 0
map_Kd checker.png
newmtl card
Kd 0.5 0.5 0.5
map_Kd checker.png
map_d holes.png
";

/// An 8x8 image of 4x4 blocks: bilinear lookups within a block's inner
/// texel centres give its colour exactly.
fn checker_png() -> image::RgbaImage {
    image::RgbaImage::from_fn(8, 8, |x, y| {
        let [r, g, b] = CHECKER[(2 * (y / 4) + x / 4) as usize];
        image::Rgba([r, g, b, 255])
    })
}

/// Transparent in the left half, opaque in the right.
fn holes_png() -> image::RgbaImage {
    image::RgbaImage::from_fn(8, 8, |x, _| image::Rgba([255, 255, 255, if x < 4 { 0 } else { 255 }]))
}

fn camera() -> Camera {
    Camera {
        eye: Vec3::new(0.0, 0.0, 3.0),
        target: Vec3::ZERO,
        fov_degrees: 60.0,
    }
}

/// The scene written to `dir` and read back with its materials.
fn scene(dir: &TempDir) -> Scene {
    checker_png().save(dir.0.join("checker.png")).unwrap();
    holes_png().save(dir.0.join("holes.png")).unwrap();
    dir.write("scene.mtl", MTL);
    let obj = dir.write("scene.obj", OBJ);
    let mut scene = load_shaded_input(Some(std::path::Path::new(&obj)), None).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    scene.camera = Some(camera());
    scene
}

/// The sRGB byte `c` decoded, times `factor`, in 8 linear bits as the
/// G-buffer stores albedo (sRGB 128 is linear 0.2158: 55).
fn linear_byte(c: u8, factor: f32) -> u8 {
    let c = c as f64 / 255.0;
    let l = if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    };
    (l * factor as f64 * 255.0).round() as u8
}

fn expected(block: usize, factor: f32) -> [u8; 3] {
    CHECKER[block].map(|c| linear_byte(c, factor))
}

/// The pixel whose centre is nearest the world point `q`.
fn pixel_of(q: Vec3) -> (u32, u32) {
    let cam = camera();
    let (right, up, forward) = cam.basis();
    let rel = q - cam.eye;
    let sc = ScreenView::new(&cam, W, H).constants();
    sc.project(Vec3::new(rel.dot(right), rel.dot(up), rel.dot(forward)))
        .expect("in view")
}

fn albedo_bytes(gb: &GBuffer, i: usize) -> [u8; 3] {
    let b = gb.shade[i][3] as u32;
    [(b & 255) as u8, ((b >> 8) & 255) as u8, (b >> 16) as u8]
}

/// A point on the quad x in [x0, x0 + 1.8], y in [-1, 1] (z = 0) at (u, v).
fn on_quad(x0: f32, u: f32, v: f32) -> Vec3 {
    Vec3::new(x0 + 1.8 * u, -1.0 + 2.0 * v, 0.0)
}

/// A pixel with what it should show: (what, pixel, camera-space depth,
/// albedo bytes).
type Probe = (&'static str, (u32, u32), f32, [u8; 3]);

fn probes() -> Vec<Probe> {
    let checker = |u, v| pixel_of(on_quad(-2.0, u, v));
    let card = |u, v| pixel_of(on_quad(0.2, u, v));
    vec![
        ("checker top-left", checker(0.25, 0.75), 3.0, expected(0, 1.0)),
        ("checker top-right", checker(0.75, 0.75), 3.0, expected(1, 1.0)),
        ("checker bottom-left", checker(0.25, 0.25), 3.0, expected(2, 1.0)),
        ("checker bottom-right", checker(0.75, 0.25), 3.0, expected(3, 1.0)),
        ("card top-right (Kd 0.5)", card(0.75, 0.75), 3.0, expected(1, 0.5)),
        ("card bottom-right (Kd 0.5)", card(0.75, 0.25), 3.0, expected(3, 0.5)),
        ("card's hole: the wall", card(0.2, 0.5), 4.0, WALL),
        ("card's hole: the wall", card(0.3, 0.2), 4.0, WALL),
        ("wall", pixel_of(Vec3::new(-3.0, 2.0, -1.0)), 4.0, WALL),
    ]
}

fn check_probes(who: &str, gb: &GBuffer) {
    for (what, (x, y), depth, albedo) in probes() {
        let i = (y * W + x) as usize;
        let got = albedo_bytes(gb, i);
        println!("{who}: {what} at {x},{y}: depth {:.4}, albedo {got:?}", gb.depth(i));
        assert!(
            (gb.depth(i) - depth).abs() < 1e-3 * depth,
            "{who}: {what} at {x},{y}: depth {} not {depth}",
            gb.depth(i)
        );
        assert_eq!(got, albedo, "{who}: {what} at {x},{y}");
    }
}

#[test]
fn cpu_gbuffer_shows_the_maps_at_each_pixel_and_the_wall_through_the_hole() {
    let dir = TempDir::new("ssao-textures-cpu");
    let scene = scene(&dir);
    let mut warnings = Vec::new();
    let surfaces = GBufferSurfaces::of_scene(&scene, DEFAULT_TEXTURE_BYTES, &mut warnings);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert!(surfaces.maps.is_some() && surfaces.cutouts.is_some());
    let mesh = scene.world_mesh(|_| true);
    let tree = KdTree::build(&mesh, &KdTreeSettings::default()).unwrap();
    let gb = gbuffer_with(&tree, &mesh, &surfaces, &camera(), &[], (W, H));
    check_probes("CPU G-buffer", &gb);
    // The library's entry reads the scene's maps the same way.
    let run = Ssao::for_scene(&Device::cpu(), &scene)
        .frame(
            &View::sized(W, H),
            &SsaoSettings {
                radius: 0.5,
                ..Default::default()
            },
        )
        .unwrap();
    assert!(run.warnings.is_empty(), "{:?}", run.warnings);
    assert_eq!(run.gbuffer, gb, "Ssao::frame's G-buffer is gbuffer_with's");
}

/// The CPU and GPU G-buffers of `scene` through `view` (`None` without
/// a GPU adapter, with a note).
fn both_gbuffers(scene: &Scene, view: &View) -> Option<(GBuffer, GBuffer)> {
    let Some(ctx) = gpu() else {
        println!("no GPU adapter: the GPU G-buffer over texture maps is not checked");
        return None;
    };
    let settings = SsaoSettings {
        radius: 0.5,
        ..Default::default()
    };
    let frame = |device: &Device| {
        let run = Ssao::for_scene(device, scene).frame(view, &settings).unwrap();
        assert!(run.warnings.is_empty(), "{:?}", run.warnings);
        run.gbuffer
    };
    Some((frame(&Device::cpu()), frame(&Device::gpu(ctx))))
}

/// GPU against CPU as the header states: >= 99% of pixels agree in
/// coverage and depth; on those the albedo within 1/255 per channel on
/// all but 0.1%. Returns the CPU's albedos of the agreeing surface pixels.
fn assert_albedos_agree(name: &str, cpu: &GBuffer, gpu: &GBuffer) -> Vec<[u8; 3]> {
    let (mut agree, mut albedo_off, mut worst) = (0usize, 0usize, (0u8, 0usize));
    let mut albedos = Vec::new();
    for i in 0..cpu.pixels() {
        if !texels_agree(cpu.geometry[i], gpu.geometry[i]) {
            continue;
        }
        agree += 1;
        if !cpu.is_surface(i) {
            continue;
        }
        let (a, b) = (albedo_bytes(cpu, i), albedo_bytes(gpu, i));
        albedos.push(a);
        let d = (0..3).map(|k| a[k].abs_diff(b[k])).max().unwrap();
        albedo_off += (d > 1) as usize;
        if d > worst.0 {
            worst = (d, i);
        }
    }
    let n = cpu.pixels();
    let (wx, wy) = (worst.1 as u32 % cpu.width, worst.1 as u32 / cpu.width);
    println!(
        "{name}, GPU vs CPU: {agree} of {n} pixels agree in coverage and depth; albedo differs by more than \
         1/255 on {albedo_off} of them, worst {}/255 at {wx},{wy}",
        worst.0
    );
    assert!(
        agree as f64 >= 0.99 * n as f64,
        "{name}: only {agree} of {n} pixels agree"
    );
    assert!(
        albedo_off as f64 <= 1e-3 * agree as f64,
        "{name}: {albedo_off} pixels' albedo differs by more than 1/255"
    );
    albedos
}

#[test]
fn gpu_gbuffer_equals_the_cpu_one_over_maps_and_holes() {
    let dir = TempDir::new("ssao-textures-gpu");
    let scene = scene(&dir);
    let Some((cpu, gpu)) = both_gbuffers(&scene, &View::sized(W, H)) else {
        return;
    };
    check_probes("GPU G-buffer", &gpu);
    let albedos = assert_albedos_agree("maps and holes", &cpu, &gpu);
    // Pixels between the checker's blocks, where the bilinear blend and
    // the interpolated texture coordinates decide the colour.
    let blocks: Vec<[u8; 3]> = (0..4)
        .flat_map(|b| [expected(b, 1.0), expected(b, 0.5)])
        .chain([WALL])
        .collect();
    let blended = albedos.iter().filter(|a| !blocks.contains(a)).count();
    println!("{blended} pixels blend the checker's blocks");
    assert!(blended >= 100, "only {blended} pixels between the checker's blocks");
}

#[test]
fn gpu_gbuffer_equals_the_cpu_one_on_the_shipped_textured_room() {
    let path = common::asset("raytrace/textured-room.json");
    let scene = load_shaded_input(None, Some(&path)).unwrap();
    let Some((cpu, gpu)) = both_gbuffers(&scene, &View::sized(320, 240)) else {
        return;
    };
    let albedos = assert_albedos_agree("textured-room", &cpu, &gpu);
    // Five materials without their maps; the floor's checker, the globe
    // and the leaf give many more colours.
    let mut distinct = albedos.clone();
    distinct.sort_unstable();
    distinct.dedup();
    println!("textured-room: {} distinct albedos", distinct.len());
    assert!(distinct.len() > 50, "{} albedos: the maps are not read", distinct.len());
}
