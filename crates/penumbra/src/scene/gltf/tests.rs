//! Materials, texture coordinates and cameras of small glTF files built
//! here: a unit quad with TEXCOORD_0 and a 2x2 PNG of four colours, as a
//! `.gltf` with `data:` URIs and as a GLB whose image is a buffer view.

use std::path::Path;

use base64::Engine;
use glam::{DVec3, Vec2, Vec3};
use serde_json::{Value, json};

use super::gltf_from_bytes;
use crate::scene::obj::{NO_TEXCOORD, ObjFile};
use crate::scene::texture::TextureSource;

/// A 2x2 RGBA PNG: red, green on the top row; blue, white (alpha 0.5) below.
fn png() -> Vec<u8> {
    let texels = [
        [255, 0, 0, 255],
        [0, 255, 0, 255],
        [0, 0, 255, 255],
        [255, 255, 255, 128],
    ];
    let image = image::RgbaImage::from_fn(2, 2, |x, y| image::Rgba(texels[(2 * y + x) as usize]));
    let mut out = std::io::Cursor::new(Vec::new());
    image.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

fn data_uri(mime: &str, bytes: &[u8]) -> String {
    format!(
        "data:{mime};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// The quad z = 0, x and y in [0, 1], its glTF texture coordinates
/// (u, v_down) = (x, 1 - y), so the image's top row is at y = 1; u16
/// indices; and, with `image`, the PNG after them (bufferView 3). The JSON
/// has one textured material (material 0) on the quad, node 0 placing it.
fn quad(image: bool) -> (Value, Vec<u8>) {
    let xy = [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let mut bin: Vec<u8> = xy
        .iter()
        .flat_map(|&[x, y]| [x, y, 0.0])
        .flat_map(f32::to_le_bytes)
        .collect();
    bin.extend(xy.iter().flat_map(|&[x, y]| [x, 1.0 - y]).flat_map(f32::to_le_bytes));
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    let mut views = vec![
        json!({ "buffer": 0, "byteOffset": 0, "byteLength": 48 }),
        json!({ "buffer": 0, "byteOffset": 48, "byteLength": 32 }),
        json!({ "buffer": 0, "byteOffset": 80, "byteLength": 12 }),
    ];
    let mut images = json!([{ "uri": data_uri("image/png", &png()) }]);
    if image {
        bin.resize(96, 0);
        let png = png();
        views.push(json!({ "buffer": 0, "byteOffset": 96, "byteLength": png.len() }));
        bin.extend(png);
        images = json!([{ "bufferView": 3, "mimeType": "image/png", "name": "checker" }]);
    }
    let json = json!({
        "asset": { "version": "2.0" },
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": views,
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] },
            { "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2" },
            { "bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR" }
        ],
        "images": images,
        "textures": [{ "source": 0 }],
        "materials": [{
            "name": "textured",
            "pbrMetallicRoughness": { "baseColorFactor": [1, 0.5, 1, 0.8], "baseColorTexture": { "index": 0 },
                                      "metallicFactor": 0 }
        }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "indices": 2,
                                      "material": 0 }] }],
        "nodes": [{ "mesh": 0, "name": "quad" }],
        "scenes": [{ "nodes": [0] }],
        "scene": 0
    });
    (json, bin)
}

/// `json` with its buffer as a `data:` URI, read as `/nowhere/q.gltf`.
fn read_gltf(mut json: Value, bin: &[u8]) -> crate::error::Result<ObjFile> {
    json["buffers"][0]["uri"] = data_uri("application/octet-stream", bin).into();
    gltf_from_bytes(Path::new("/nowhere/q.gltf"), &serde_json::to_vec(&json).unwrap(), false)
}

fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).unwrap();
    text.resize(text.len().next_multiple_of(4), b' ');
    let mut data = bin.to_vec();
    data.resize(data.len().next_multiple_of(4), 0);
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + text.len() + 8 + data.len()) as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend((data.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(data);
    out
}

fn textured(f: &ObjFile) -> &crate::scene::mtl::Material {
    &f.materials[f.triangle_materials[0] as usize]
}

fn has_warning(f: &ObjFile, words: &[&str]) -> bool {
    f.warnings.iter().any(|w| words.iter().all(|p| w.contains(p)))
}

/// Every corner's texture coordinates are the file's, v flipped: for the
/// quad, (u, v_up) = the corner's (x, y) in the file, which `file_xy`
/// gives from the read (placed, recentred) position.
fn assert_corners_match(f: &ObjFile, file_xy: impl Fn(DVec3) -> Vec2) {
    for (t, (tri, corners)) in f.mesh.triangles.iter().zip(&f.corner_texcoords).enumerate() {
        for (k, (&v, &c)) in tri.iter().zip(corners).enumerate() {
            assert_ne!(c, NO_TEXCOORD);
            let world = f.mesh.positions[v as usize].as_dvec3() + f.mesh.origin;
            let uv = f.texcoords[c as usize];
            assert!(
                (uv - file_xy(world)).abs().max_element() < 1e-5,
                "triangle {t} corner {k}: {uv}"
            );
        }
    }
}

#[test]
fn texcoords_flip_v_and_follow_mirrored_corners() {
    let (mut json, bin) = quad(false);
    let f = read_gltf(json.clone(), &bin).unwrap();
    assert_eq!(f.texcoords.len(), 4);
    assert_eq!(
        f.texcoords[3],
        Vec2::new(0.0, 1.0),
        "glTF (0, 0) is the top-left: v up 1"
    );
    assert_corners_match(&f, |p| Vec2::new(p.x as f32, p.y as f32));
    // Mirrored in x and far off: the triangles' corners swap, and their
    // texture coordinates with them.
    json["nodes"][0]["matrix"] = json!([-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1e6, 0, 0, 1]);
    let f = read_gltf(json, &bin).unwrap();
    assert_ne!(f.mesh.origin, DVec3::ZERO);
    assert_eq!(f.mesh.triangles[0], [0, 2, 1], "mirrored: corners swapped");
    assert_corners_match(&f, |p| Vec2::new((1e6 - p.x) as f32, p.y as f32));
}

#[test]
fn texcoords_normalized_integers_and_unmapped_primitives() {
    // UNSIGNED_BYTE normalized texture coordinates.
    let (mut json, mut bin) = quad(false);
    let at = bin.len();
    bin.extend([0u8, 255, 255, 255, 255, 0, 0, 0]);
    json["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "buffer": 0, "byteOffset": at, "byteLength": 8 }));
    json["buffers"][0]["byteLength"] = bin.len().into();
    json["accessors"][1] = json!({ "bufferView": 3, "componentType": 5121, "normalized": true, "count": 4,
                                   "type": "VEC2" });
    let f = read_gltf(json.clone(), &bin).unwrap();
    assert_corners_match(&f, |p| Vec2::new(p.x as f32, p.y as f32));
    // Without a texture, texture coordinates are read all the same (a
    // bake lays its AO texture over them).
    json["materials"][0]["pbrMetallicRoughness"]
        .as_object_mut()
        .unwrap()
        .remove("baseColorTexture");
    let f = read_gltf(json.clone(), &bin).unwrap();
    assert_corners_match(&f, |p| Vec2::new(p.x as f32, p.y as f32));
    assert!(f.corner_texcoords.iter().all(|c| !c.contains(&NO_TEXCOORD)));
    // A TEXCOORD_0 that does not match POSITION is an error naming it.
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({ "index": 0 });
    json["accessors"][1]["count"] = 3.into();
    let e = read_gltf(json, &bin).unwrap_err().to_string();
    assert!(e.contains("TEXCOORD_0 accessor 1 has 3 elements"), "{e}");
}

#[test]
fn base_colour_texture_from_data_uri_buffer_view_and_file() {
    let (json, bin) = quad(false);
    let f = read_gltf(json.clone(), &bin).unwrap();
    let m = textured(&f);
    assert_eq!(m.kd, Vec3::new(1.0, 0.5, 1.0), "the factor stays the diffuse colour");
    let map = m.maps.kd.as_deref().expect("baseColorTexture is the kd map");
    assert_eq!((map.scale, map.offset, map.clamp), (Vec2::ONE, Vec2::ZERO, false));
    match &map.source {
        TextureSource::Embedded { name, bytes } => {
            assert_eq!(name, "/nowhere/q.gltf#images[0]");
            assert_eq!(&bytes[..], &png()[..]);
        }
        other => panic!("{other:?}"),
    }
    assert!(!f.warnings.iter().any(|w| w.contains("not used")), "{:?}", f.warnings);
    // GLB: the image is a buffer view of the BIN chunk.
    let (json, bin) = quad(true);
    let f = gltf_from_bytes(Path::new("q.glb"), &glb(&json, &bin), true).unwrap();
    match &textured(&f).maps.kd.as_deref().unwrap().source {
        TextureSource::Embedded { name, bytes } => {
            assert_eq!(name, "q.glb#images[0] 'checker'");
            assert_eq!(&bytes[..], &png()[..]);
        }
        other => panic!("{other:?}"),
    }
    // A file beside the asset (percent-decoded); a URI with a scheme is
    // not read.
    let (mut json, bin) = quad(false);
    json["images"][0]["uri"] = "tex/my%20wood.png".into();
    let f = read_gltf(json.clone(), &bin).unwrap();
    assert_eq!(
        textured(&f).maps.kd.as_deref().unwrap().source,
        TextureSource::File("/nowhere/tex/my wood.png".into())
    );
    json["images"][0]["uri"] = "https://example.com/wood.png".into();
    let f = read_gltf(json.clone(), &bin).unwrap();
    assert!(textured(&f).maps.kd.is_none());
    assert!(has_warning(&f, &["images[0]", "scheme 'https:'"]), "{:?}", f.warnings);
    // A broken data URI is an error naming the image.
    json["images"][0]["uri"] = "data:image/png;base64,!!".into();
    let e = read_gltf(json, &bin).unwrap_err().to_string();
    assert!(e.contains("images[0].uri") && e.contains("not valid base64"), "{e}");
    // A black factor times the texture is black: no map.
    let (mut json, bin) = quad(false);
    json["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = json!([0, 0, 0, 1]);
    assert!(textured(&read_gltf(json, &bin).unwrap()).maps.kd.is_none());
}

#[test]
fn texture_sets_other_than_0_are_not_used() {
    let (mut json, bin) = quad(false);
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 1.into();
    let f = read_gltf(json, &bin).unwrap();
    assert!(textured(&f).maps.kd.is_none());
    assert_eq!(f.texcoords.len(), 4, "TEXCOORD_0 is read, set 1 is not");
    assert!(
        has_warning(&f, &["'textured'", "baseColorTexture uses TEXCOORD_1"]),
        "{:?}",
        f.warnings
    );
}

#[test]
fn sampler_wrap_modes_clamp_or_repeat() {
    const CLAMP: u32 = 33071;
    const MIRROR: u32 = 33648;
    const REPEAT: u32 = 10497;
    let cases = [
        (CLAMP, CLAMP, true, None),
        (REPEAT, REPEAT, false, None),
        (MIRROR, MIRROR, false, Some("MIRRORED_REPEAT")),
        (CLAMP, REPEAT, true, Some("wraps S and T differently")),
    ];
    for (s, t, clamp, warning) in cases {
        let (mut json, bin) = quad(false);
        json["samplers"] = json!([{ "wrapS": s, "wrapT": t }]);
        json["textures"][0]["sampler"] = 0.into();
        let f = read_gltf(json, &bin).unwrap();
        assert_eq!(textured(&f).maps.kd.as_deref().unwrap().clamp, clamp, "{s} {t}");
        if let Some(w) = warning {
            assert!(has_warning(&f, &["'textured'", w]), "{:?}", f.warnings);
        } else {
            assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        }
    }
}

#[test]
fn alpha_modes_cut_out_or_dissolve() {
    let read = |mode: &str, cutoff: Option<f32>, alpha: f32, texture: bool| {
        let (mut json, bin) = quad(false);
        let m = &mut json["materials"][0];
        m["alphaMode"] = mode.into();
        if let Some(c) = cutoff {
            m["alphaCutoff"] = c.into();
        }
        m["pbrMetallicRoughness"]["baseColorFactor"][3] = alpha.into();
        if !texture {
            m["pbrMetallicRoughness"]
                .as_object_mut()
                .unwrap()
                .remove("baseColorTexture");
        }
        read_gltf(json, &bin).unwrap()
    };
    // MASK: the base colour texture's alpha, times the factor's, against
    // the cutoff.
    let f = read("MASK", Some(0.3), 0.8, true);
    let m = textured(&f);
    let a = m.maps.alpha.as_ref().expect("MASK with a texture is a cut-out");
    assert_eq!((a.factor, a.cutoff), (0.8, 0.3));
    assert_eq!(Some(&a.map), m.maps.kd.as_deref(), "the base colour texture's alpha");
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    assert_eq!(
        textured(&read("MASK", None, 1.0, true))
            .maps
            .alpha
            .as_ref()
            .unwrap()
            .cutoff,
        0.5
    );
    // BLEND with a texture: a cut-out at 0.5, with a warning.
    let f = read("BLEND", Some(0.9), 0.8, true);
    let a = textured(&f).maps.alpha.as_ref().unwrap();
    assert_eq!((a.factor, a.cutoff), (0.8, 0.5));
    assert!(has_warning(&f, &["BLEND", "cut-out at alpha 0.5"]), "{:?}", f.warnings);
    // Without a texture: MASK is all or nothing, BLEND a dissolve.
    let f = read("MASK", Some(0.5), 0.2, false);
    assert_eq!((textured(&f).dissolve, textured(&f).maps.alpha.is_none()), (0.0, true));
    assert!(has_warning(&f, &["'textured'", "holes"]), "{:?}", f.warnings);
    assert_eq!(textured(&read("MASK", Some(0.5), 0.7, false)).dissolve, 1.0);
    assert_eq!(textured(&read("BLEND", None, 0.25, false)).dissolve, 0.25);
    // OPAQUE ignores alpha.
    let f = read("OPAQUE", None, 0.1, true);
    assert_eq!((textured(&f).dissolve, textured(&f).maps.alpha.is_none()), (1.0, true));
}

#[test]
fn transmission_and_ior_make_glass() {
    let (mut json, bin) = quad(false);
    let m = &mut json["materials"][0];
    m["pbrMetallicRoughness"] = json!({ "baseColorFactor": [0.5, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 0 });
    m["extensions"] = json!({ "KHR_materials_transmission": { "transmissionFactor": 0.9 },
                              "KHR_materials_ior": { "ior": 1.33 } });
    let f = read_gltf(json.clone(), &bin).unwrap();
    let g = textured(&f);
    assert_eq!(g.illum, 7, "glass: reflection and refraction");
    assert!(g.has_tf);
    assert!(
        (g.tf - Vec3::new(0.45, 0.9, 0.9)).abs().max_element() < 1e-6,
        "{}",
        g.tf
    );
    assert_eq!(g.ni, 1.33);
    let f0 = (0.33f32 / 2.33).powi(2);
    assert!((g.ks - Vec3::splat(f0)).abs().max_element() < 1e-6, "{}", g.ks);
    assert!(
        (g.kd - Vec3::new(0.05, 0.1, 0.1)).abs().max_element() < 1e-6,
        "{}",
        g.kd
    );
    assert_eq!(g.ns, 1000.0, "a smooth surface: the sharpest highlight");
    // The default index is 1.5: a reflectance of 0.04.
    json["materials"][0]["extensions"]
        .as_object_mut()
        .unwrap()
        .remove("KHR_materials_ior");
    let f = read_gltf(json.clone(), &bin).unwrap();
    assert_eq!(textured(&f).ni, 1.5);
    assert!((textured(&f).ks.x - 0.04).abs() < 1e-7);
    // No transmission: not glass.
    json["materials"][0]["extensions"]["KHR_materials_transmission"]["transmissionFactor"] = 0.into();
    assert_eq!(textured(&read_gltf(json.clone(), &bin).unwrap()).illum, 1);
    // An index below 1 is an error naming the field.
    json["materials"][0]["extensions"] = json!({ "KHR_materials_transmission": { "transmissionFactor": 1 },
                                                 "KHR_materials_ior": { "ior": 0.5 } });
    let e = read_gltf(json, &bin).unwrap_err().to_string();
    assert!(e.contains("materials[0].extensions.KHR_materials_ior.ior"), "{e}");
}

#[test]
fn texture_transform_becomes_scale_and_offset_with_v_up() {
    let (mut json, bin) = quad(false);
    let (offset, scale) = ([0.25f32, 0.5], [2.0f32, 3.0]);
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] =
        json!({ "KHR_texture_transform": { "offset": offset, "scale": scale } });
    let f = read_gltf(json.clone(), &bin).unwrap();
    let map = textured(&f).maps.kd.clone().unwrap();
    assert_eq!(map.scale, Vec2::from(scale));
    // Where glTF looks up (u, v_down), penumbra looks up the same texel:
    // its v_up' = 1 - glTF's v_down'.
    for (u, v) in [(0.0f32, 0.0f32), (0.3, 0.7), (1.0, 1.0)] {
        let gltf = Vec2::new(u, v) * Vec2::from(scale) + Vec2::from(offset);
        let ours = Vec2::new(u, 1.0 - v) * map.scale + map.offset;
        assert!(
            (ours - Vec2::new(gltf.x, 1.0 - gltf.y)).abs().max_element() < 1e-6,
            "{ours} {gltf}"
        );
    }
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    // Rotation is not used (a warning); texCoord overrides the info's.
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"]["rotation"] =
        0.5.into();
    let f = read_gltf(json.clone(), &bin).unwrap();
    assert!(
        has_warning(&f, &["rotation (0.5 radians) is not used"]),
        "{:?}",
        f.warnings
    );
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"]["texCoord"] =
        1.into();
    assert!(textured(&read_gltf(json, &bin).unwrap()).maps.kd.is_none());
}

/// The quad with two cameras: the first under a parent far off (1e6 in x)
/// turned 90 degrees about +y (so it looks down -x), 60 degrees of yfov;
/// the second at the origin's +z, 30 degrees; an orthographic one between
/// them in traversal order.
fn with_cameras() -> (Value, Vec<u8>) {
    let (mut json, bin) = quad(false);
    let s = std::f64::consts::FRAC_1_SQRT_2;
    json["cameras"] = json!([
        { "type": "perspective", "perspective": { "yfov": 60f64.to_radians(), "znear": 0.1, "aspectRatio": 2.0 } },
        { "type": "orthographic", "orthographic": { "xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 10 } },
        { "type": "perspective", "perspective": { "yfov": 30f64.to_radians(), "znear": 0.1 } }
    ]);
    json["nodes"] = json!([
        { "mesh": 0, "name": "quad", "translation": [1e6, 0, 0] },
        { "name": "rig", "translation": [1e6, 0, 0], "children": [2, 3] },
        { "name": "first", "camera": 0, "translation": [5, 0.5, 0.5], "rotation": [0, s, 0, s] },
        { "name": "flat", "camera": 1 },
        { "name": "second", "camera": 2, "translation": [0.5, 0.5, 4] }
    ]);
    json["scenes"] = json!([{ "nodes": [0, 1, 4] }]);
    (json, bin)
}

#[test]
fn cameras_in_traversal_order_in_the_mesh_frame() {
    let (json, bin) = with_cameras();
    let f = read_gltf(json.clone(), &bin).unwrap();
    assert_ne!(f.mesh.origin, DVec3::ZERO, "a far-off mesh is recentred");
    assert_eq!(f.cameras.len(), 2, "the orthographic camera is skipped");
    assert!(
        has_warning(&f, &["camera 1 (node 'flat') is orthographic"]),
        "{:?}",
        f.warnings
    );
    let world = |p: Vec3| p.as_dvec3() + f.mesh.origin;
    let first = f.cameras[0];
    assert!(
        (world(first.eye) - DVec3::new(1e6 + 5.0, 0.5, 0.5)).length() < 1e-6,
        "{}",
        first.eye
    );
    let forward = (first.target - first.eye).normalize();
    assert!(
        (forward - Vec3::NEG_X).length() < 1e-6,
        "turned about +y: looks down -x ({forward})"
    );
    assert!((first.fov_degrees - 60.0).abs() < 1e-4);
    // Its target is as far along its view as the quad's centre (1e6 + 0.5,
    // 0.5, 0) is from its eye.
    let d = (4.5f64 * 4.5 + 0.5 * 0.5).sqrt();
    assert!(
        (world(first.target) - DVec3::new(1e6 + 5.0 - d, 0.5, 0.5)).length() < 1e-4,
        "{}",
        first.target
    );
    // 1e6 from the mesh's frame: within f32's spacing there.
    let second = f.cameras[1];
    assert!((world(second.eye) - DVec3::new(0.5, 0.5, 4.0)).length() < 0.07);
    assert!(((second.target - second.eye).normalize() - Vec3::NEG_Z).length() < 1e-6);
    assert!((second.fov_degrees - 30.0).abs() < 1e-4);
    // The scene of the file takes the first; `choose_camera` another.
    let mut scene = crate::scene::Scene::from_obj_file("q", Path::new("q.gltf"), f.clone());
    assert_eq!(scene.origin, f.mesh.origin);
    assert_eq!(scene.camera, Some(first));
    scene.choose_camera(1).unwrap();
    assert_eq!(scene.camera, Some(second));
    let e = scene.choose_camera(5).unwrap_err().to_string();
    assert!(
        e.contains("camera") && e.contains("is 5, but the input has 2 cameras (numbers 0 to 1)"),
        "{e}"
    );
}

#[test]
fn rolled_cameras_warn_and_bad_ones_are_errors() {
    let (mut json, bin) = with_cameras();
    // Rolled 90 degrees about its view (-z).
    let s = std::f64::consts::FRAC_1_SQRT_2;
    json["nodes"][4]["rotation"] = json!([0, 0, s, s]);
    let f = read_gltf(json.clone(), &bin).unwrap();
    assert!(
        has_warning(&f, &["camera 2 (node 'second') is rolled 90.0 degrees"]),
        "{:?}",
        f.warnings
    );
    json["cameras"][0]["perspective"]["yfov"] = 4.0.into();
    let e = read_gltf(json.clone(), &bin).unwrap_err().to_string();
    assert!(
        e.contains("cameras[0].perspective.yfov") && e.contains("(0, pi)"),
        "{e}"
    );
    json["cameras"][0]["perspective"]["yfov"] = 1.0.into();
    json["nodes"][2]["scale"] = json!([1, 1, 0]);
    let e = read_gltf(json, &bin).unwrap_err().to_string();
    assert!(e.contains("nodes[2]") && e.contains("no view direction"), "{e}");
}
