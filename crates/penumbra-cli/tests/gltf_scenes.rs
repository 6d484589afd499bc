//! glTF files as users have them: a textured quad's image rendered, and
//! the file's cameras as the default view (`--camera N` picks another;
//! `--eye/--target/--fov` still override).

mod common;
#[path = "../../penumbra/tests/mesh_formats/write.rs"]
mod write;

use common::cli::{TempDir, pen};
use glam::Vec3;
use serde_json::{Value, json};
use write::glb;

/// A 2x2 PNG: red, green on the top row; blue, white below.
fn png() -> Vec<u8> {
    let texels = [
        [255, 0, 0, 255],
        [0, 255, 0, 255],
        [0, 0, 255, 255],
        [255, 255, 255, 255],
    ];
    let image = image::RgbaImage::from_fn(2, 2, |x, y| image::Rgba(texels[(2 * y + x) as usize]));
    let mut out = std::io::Cursor::new(Vec::new());
    image.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// A GLB of the quad x, y in [0, 1], z = 0 (its image's top row at y = 1)
/// textured with `png` (a buffer view), far off (1e5 in x), and two
/// cameras: "front" at (1e5 + 0.5, 0.5, 2) looking down -z with a 30
/// degree yfov, so that the quad fills the middle of the view, and "side"
/// at (1e5 + 4, 0.5, 0.5) turned to look down -x, 50 degrees.
fn textured_quad_with_cameras() -> Vec<u8> {
    let xy = [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let mut bin: Vec<u8> = xy
        .iter()
        .flat_map(|&[x, y]| [x, y, 0.0])
        .flat_map(f32::to_le_bytes)
        .collect();
    bin.extend(xy.iter().flat_map(|&[x, y]| [x, 1.0 - y]).flat_map(f32::to_le_bytes));
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    bin.resize(96, 0);
    let png = png();
    let png_len = png.len();
    bin.extend(png);
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let json = json!({
        "asset": { "version": "2.0" },
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 48 },
            { "buffer": 0, "byteOffset": 48, "byteLength": 32 },
            { "buffer": 0, "byteOffset": 80, "byteLength": 12 },
            { "buffer": 0, "byteOffset": 96, "byteLength": png_len }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] },
            { "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2" },
            { "bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR" }
        ],
        "images": [{ "bufferView": 3, "mimeType": "image/png" }],
        "samplers": [{ "wrapS": 33071, "wrapT": 33071 }],
        "textures": [{ "source": 0, "sampler": 0 }],
        "materials": [{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "metallicFactor": 0 } }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "indices": 2,
                                      "material": 0 }] }],
        "cameras": [
            { "type": "perspective", "perspective": { "yfov": 30f64.to_radians(), "znear": 0.01 } },
            { "type": "perspective", "perspective": { "yfov": 50f64.to_radians(), "znear": 0.01 } }
        ],
        "nodes": [
            { "name": "far", "translation": [1e5, 0, 0], "children": [1, 2, 3] },
            { "mesh": 0 },
            { "name": "front", "camera": 0, "translation": [0.5, 0.5, 2] },
            { "name": "side", "camera": 1, "translation": [4, 0.5, 0.5], "rotation": [0, s, 0, s] }
        ],
        "scenes": [{ "nodes": [0] }],
        "scene": 0
    });
    glb(&json, &bin)
}

fn close(v: &Value, expected: [f64; 3], tol: f64) -> bool {
    let v: Vec<f64> = v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    v.iter().zip(expected).all(|(a, b)| (a - b).abs() <= tol)
}

#[test]
fn gltf_cameras_are_the_default_view_and_camera_picks_one() {
    let dir = TempDir::new("gltf_cameras");
    let mesh = dir.write("quad.glb", textured_quad_with_cameras());
    let out = dir.p("q.png");
    let raytrace = |extra: &str| {
        pen(
            &format!(
                "raytrace --method whitted --mesh {{m}} --width 8 --height 6 --out {{o}} --device cpu --json {extra}"
            ),
            &[("m", &mesh), ("o", &out)],
        )
    };
    // The first camera (its node under a far-off parent).
    let first = raytrace("").ok().json();
    let c = &first["camera"];
    assert!(close(&c["eye"], [1e5 + 0.5, 0.5, 2.0], 1e-3), "{c}");
    assert!((c["fov"].as_f64().unwrap() - 30.0).abs() < 1e-3, "{c}");
    // --camera 1: the second, looking down -x.
    let second = raytrace("--camera 1").ok().json();
    let c = &second["camera"];
    assert!(close(&c["eye"], [1e5 + 4.0, 0.5, 0.5], 1e-3), "{c}");
    assert!((c["fov"].as_f64().unwrap() - 50.0).abs() < 1e-3, "{c}");
    let (eye, target) = (&c["eye"], &c["target"]);
    assert!(target[0].as_f64().unwrap() < eye[0].as_f64().unwrap(), "{c}");
    assert!(
        (target[1].as_f64().unwrap() - 0.5).abs() < 1e-3 && (target[2].as_f64().unwrap() - 0.5).abs() < 1e-3,
        "{c}"
    );
    // --fov and --eye still override the chosen camera's parts.
    let c = raytrace("--camera 1 --fov 20").ok().json()["camera"].clone();
    assert!(close(&c["eye"], [1e5 + 4.0, 0.5, 0.5], 1e-3) && c["fov"] == 20.0, "{c}");
    // Out of range: an error naming --camera and how many there are.
    raytrace("--camera 5").bad_input(&["--camera", "is 5", "2 cameras (numbers 0 to 1)"]);
    // The geometry-only readers carry the cameras too.
    pen(
        "trace --mesh {m} --width 8 --height 6 --device cpu --camera 2 --json",
        &[("m", &mesh)],
    )
    .bad_input(&["--camera", "is 2", "2 cameras"]);
    pen(
        "trace --mesh {m} --width 8 --height 6 --device cpu --camera 1 --json",
        &[("m", &mesh)],
    )
    .ok();
}

#[test]
fn files_without_cameras_keep_the_default_camera() {
    let dir = TempDir::new("gltf_no_cameras");
    let mesh = dir.write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".as_bytes());
    let out = dir.p("t.png");
    let j = pen(
        "raytrace --method whitted --mesh {m} --width 8 --height 6 --out {o} --device cpu --json",
        &[("m", &mesh), ("o", &out)],
    )
    .ok()
    .json();
    assert_eq!(j["camera"]["fov"], 45.0, "the contract's default camera");
    pen(
        "raytrace --method whitted --mesh {m} --width 8 --height 6 --out {o} --device cpu --camera 0",
        &[("m", &mesh), ("o", &out)],
    )
    .bad_input(&["--camera", "is 0, but the input has no cameras"]);
}

#[test]
fn a_textured_gltf_quad_shows_its_image() {
    use penumbra::gpu::device::Device;
    use penumbra::progress::{Bar, Reporter};
    use penumbra::whitted::{LightingSettings, RenderScene, WhittedRenderer, WhittedSettings};

    let dir = TempDir::new("gltf_textured_render");
    let path = dir.write("quad.glb", textured_quad_with_cameras());
    let scene = penumbra::scene::load_shaded_input(Some(std::path::Path::new(&path)), None).unwrap();
    let camera = scene.camera.expect("the file's first camera");
    let rs = RenderScene::new(&scene, 0, &LightingSettings::default()).unwrap();
    let mut renderer = WhittedRenderer::new(&Device::cpu(), rs, &Reporter::silent()).unwrap();
    let (w, h) = (64, 64);
    let image = renderer
        .render(&camera, w, h, &WhittedSettings::default(), &Bar::hidden())
        .unwrap()
        .radiance();
    // The quad spans about 2 tan(15 degrees) * 2 = 1.07 units of the view's
    // height: its quadrants' centres are at a quarter of the quad from the
    // image's centre.
    let half = 0.5 / (2.0 * 2.0 * 15f32.to_radians().tan()) * h as f32;
    let at = |dx: f32, dy: f32| {
        let (x, y) = (w as f32 / 2.0 + dx * half, h as f32 / 2.0 + dy * half);
        image[y as usize * w as usize + x as usize]
    };
    let hue = |c: Vec3| c / c.max_element();
    let near = |a: Vec3, b: Vec3| (hue(a) - b).abs().max_element() < 0.1;
    // Image rows run down: the quad's top (y = 1) is the PNG's top row.
    for (dx, dy, colour) in [
        (-0.5, -0.5, Vec3::X),
        (0.5, -0.5, Vec3::Y),
        (-0.5, 0.5, Vec3::Z),
        (0.5, 0.5, Vec3::ONE),
    ] {
        let c = at(dx, dy);
        assert!(near(c, colour), "at ({dx}, {dy}): {c}, expected the hue of {colour}");
    }
}
