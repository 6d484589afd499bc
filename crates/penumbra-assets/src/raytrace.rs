//! The ray tracer's shipped scenes, written by `penumbra gen-assets` into
//! `assets/raytrace/` (OBJ, MTL and scene files): the paper's kind of
//! scene (mirror, glass and Phong spheres over a checkerboard, analytic and
//! tessellated), a Cornell box with a mirror box and a glass sphere lit by
//! its ceiling, and extreme cases (total internal reflection in a glass
//! block, grazing views of a reflective floor, a camera inside glass).
//! The spheres' checkerboard is a texture (one square whose `ka` and `kd`
//! a checker pattern scales), as in the paper; the glass block's and the
//! grazing view's checkerboards are geometry, every check its own flat
//! face with its own material, so ray trees see their edges. A textured
//! room (image maps on a floor and a sphere, a cut-out leaf card, walls
//! whose MTL is written as Maya's and Blender's exporters write it) has
//! its images under `assets/raytrace/textures/`.

use std::fmt::Write;

use glam::{Quat, Vec2, Vec3};
use serde_json::json;

use penumbra::scene::{Checker, Material, write_mtl};
use penumbra::whitted::tessellate;

/// Rings from pole to pole of the tessellated twins' spheres.
pub const SPHERE_RINGS: u32 = 32;
/// Segments around each ring of the tessellated twins' spheres.
pub const SPHERE_SEGMENTS: u32 = 64;

/// One scene: its name, what it shows, and its files (name, contents).
pub struct ShippedScene {
    /// The scene's name, also its scene file's stem (`scene_file`).
    pub name: &'static str,
    /// What the scene shows and tests, in one line.
    pub summary: &'static str,
    /// Its files: name within `assets/raytrace/` and text contents (the
    /// scene file, and the OBJ and MTL files it has of its own; a scene
    /// may use another's).
    pub files: Vec<(String, String)>,
    /// Its images: name within `assets/raytrace/` and PNG bytes.
    pub images: Vec<(String, Vec<u8>)>,
}

impl ShippedScene {
    /// The file `penumbra raytrace --scene` reads.
    pub fn scene_file(&self) -> String {
        format!("{}.json", self.name)
    }
}

/// An OBJ file under construction: vertices, normals and faces grouped by
/// object, material and smoothing.
#[derive(Default)]
struct ObjWriter {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    texcoords: Vec<Vec2>,
    body: String,
}

impl ObjWriter {
    fn object(&mut self, name: &str, material: &str, smooth: bool) {
        let s = if smooth { "1" } else { "off" };
        let _ = write!(self.body, "o {name}\nusemtl {material}\ns {s}\n");
    }

    /// A flat face of its own vertices (counter-clockwise seen from the
    /// side its normal points to).
    fn face(&mut self, corners: &[Vec3]) {
        let first = self.positions.len() + 1;
        self.positions.extend_from_slice(corners);
        let ids: Vec<String> = (first..first + corners.len()).map(|i| i.to_string()).collect();
        let _ = writeln!(self.body, "f {}", ids.join(" "));
    }

    /// An n x n checkerboard on y = `height` over [-half, half]^2, facing
    /// up, checks alternating between materials `a` and `b`.
    fn checker(&mut self, name: &str, half: f32, n: u32, height: f32, (a, b): (&str, &str)) {
        let step = 2.0 * half / n as f32;
        for parity in 0..2 {
            self.object(
                &format!("{name}-{}", if parity == 0 { a } else { b }),
                [a, b][parity],
                false,
            );
            for j in 0..n {
                for i in (0..n).filter(|i| (i + j) as usize % 2 == parity) {
                    let (x0, z0) = (-half + i as f32 * step, -half + j as f32 * step);
                    let (x1, z1) = (x0 + step, z0 + step);
                    self.face(&[
                        Vec3::new(x0, height, z0),
                        Vec3::new(x0, height, z1),
                        Vec3::new(x1, height, z1),
                        Vec3::new(x1, height, z0),
                    ]);
                }
            }
        }
    }

    /// A quad by its corners, counter-clockwise, with texture coordinates
    /// (0, 0), (1, 0), (1, 1), (0, 1) at them.
    fn textured_quad(&mut self, name: &str, material: &str, corners: [Vec3; 4]) {
        self.object(name, material, false);
        let (v0, t0) = (self.positions.len() + 1, self.texcoords.len() + 1);
        self.positions.extend_from_slice(&corners);
        self.texcoords
            .extend_from_slice(&[Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]);
        let c: Vec<String> = (0..4).map(|k| format!("{}/{}", v0 + k, t0 + k)).collect();
        let _ = writeln!(self.body, "f {}", c.join(" "));
    }

    /// A sphere of latitude-longitude quads (as triangles) with radial
    /// normals and texture coordinates u = longitude, v = latitude (0 at
    /// the south pole); the seam's vertices are doubled so u runs 0 to 1.
    fn textured_sphere(
        &mut self,
        name: &str,
        material: &str,
        centre: Vec3,
        radius: f32,
        (rings, segments): (u32, u32),
    ) {
        self.object(name, material, true);
        let (v0, t0, n0) = (
            self.positions.len() + 1,
            self.texcoords.len() + 1,
            self.normals.len() + 1,
        );
        for i in 0..=rings {
            let lat = std::f32::consts::PI * (i as f32 / rings as f32 - 0.5);
            for j in 0..=segments {
                let lon = std::f32::consts::TAU * j as f32 / segments as f32;
                let n = Vec3::new(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos());
                self.positions.push(centre + radius * n);
                self.normals.push(n);
                self.texcoords
                    .push(Vec2::new(j as f32 / segments as f32, i as f32 / rings as f32));
            }
        }
        let at = |i: u32, j: u32| (i * (segments + 1) + j) as usize;
        for i in 0..rings {
            for j in 0..segments {
                let quad = [at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)];
                for tri in [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]] {
                    // The poles' rows meet in a point: no zero-area triangles.
                    if (i == 0 && tri.contains(&quad[1]) && tri.contains(&quad[0]))
                        || (i == rings - 1 && tri.contains(&quad[2]) && tri.contains(&quad[3]))
                    {
                        continue;
                    }
                    let c = tri.map(|k| format!("{}/{}/{}", v0 + k, t0 + k, n0 + k));
                    let _ = writeln!(self.body, "f {} {} {}", c[0], c[1], c[2]);
                }
            }
        }
    }

    /// An axis-aligned quad by its corners, counter-clockwise.
    fn quad(&mut self, name: &str, material: &str, corners: [Vec3; 4]) {
        self.object(name, material, false);
        self.face(&corners);
    }

    /// A box of half-sizes `half` around `centre`, turned by `yaw` degrees
    /// about y; faces outward.
    fn block(&mut self, name: &str, material: &str, centre: Vec3, half: Vec3, yaw: f32) {
        self.object(name, material, false);
        let turn = Quat::from_rotation_y(yaw.to_radians());
        let corner = |sx: f32, sy: f32, sz: f32| centre + turn * Vec3::new(sx * half.x, sy * half.y, sz * half.z);
        let faces = [
            [(-1., -1., 1.), (1., -1., 1.), (1., 1., 1.), (-1., 1., 1.)],
            [(1., -1., -1.), (-1., -1., -1.), (-1., 1., -1.), (1., 1., -1.)],
            [(1., -1., 1.), (1., -1., -1.), (1., 1., -1.), (1., 1., 1.)],
            [(-1., -1., -1.), (-1., -1., 1.), (-1., 1., 1.), (-1., 1., -1.)],
            [(-1., 1., 1.), (1., 1., 1.), (1., 1., -1.), (-1., 1., -1.)],
            [(-1., -1., -1.), (1., -1., -1.), (1., -1., 1.), (-1., -1., 1.)],
        ];
        for f in faces {
            self.face(&f.map(|(x, y, z)| corner(x, y, z)));
        }
    }

    /// A tessellated sphere with exact (radial) `vn` normals.
    fn sphere(&mut self, name: &str, material: &str, centre: Vec3, radius: f32) {
        self.object(name, material, true);
        let (positions, normals, triangles) = tessellate(centre, radius, SPHERE_RINGS, SPHERE_SEGMENTS);
        let (v0, n0) = (self.positions.len() + 1, self.normals.len() + 1);
        self.positions.extend(positions);
        self.normals.extend(normals);
        for t in triangles {
            let c = t.map(|i| format!("{}//{}", v0 + i as usize, n0 + i as usize));
            let _ = writeln!(self.body, "f {} {} {}", c[0], c[1], c[2]);
        }
    }

    fn text(&self, header: &str, mtllib: &str) -> String {
        let mut s = String::new();
        for line in header.lines() {
            let _ = writeln!(s, "# {line}");
        }
        let _ = writeln!(s, "mtllib {mtllib}");
        for p in &self.positions {
            let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
        }
        for n in &self.normals {
            let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
        }
        for t in &self.texcoords {
            let _ = writeln!(s, "vt {} {}", t.x, t.y);
        }
        s + &self.body
    }
}

fn diffuse(name: &str, kd: Vec3) -> Material {
    Material {
        ka: kd,
        kd,
        ..Material::named(name)
    }
}

fn mirror() -> Material {
    Material {
        kd: Vec3::splat(0.05),
        ks: Vec3::splat(0.9),
        ns: 200.0,
        illum: 3,
        ..Material::named("mirror")
    }
}

fn glass() -> Material {
    Material {
        kd: Vec3::ZERO,
        ks: Vec3::splat(0.1),
        tf: Vec3::new(0.9, 0.95, 0.95),
        has_tf: true,
        ns: 300.0,
        ni: 1.5,
        illum: 6,
        ..Material::named("glass")
    }
}

fn phong() -> Material {
    Material {
        ka: Vec3::new(0.7, 0.2, 0.1),
        kd: Vec3::new(0.7, 0.2, 0.1),
        ks: Vec3::splat(0.5),
        ns: 60.0,
        ..Material::named("phong")
    }
}

fn checks() -> [Material; 2] {
    [
        diffuse("check-light", Vec3::splat(0.8)),
        diffuse("check-dark", Vec3::splat(0.1)),
    ]
}

/// The spheres of the checkerboard scene: (name, material, centre, radius).
const CHECKER_SPHERES: [(&str, &str, [f32; 3], f32); 3] = [
    ("mirror-ball", "mirror", [-2.2, 1.0, -0.3], 1.0),
    ("glass-ball", "glass", [0.0, 1.0, 0.8], 1.0),
    ("phong-ball", "phong", [2.2, 1.0, -0.3], 1.0),
];

const HEADER: &str = "generated by `penumbra gen-assets` (crates/penumbra-assets/src/raytrace.rs); do not hand-edit.";

fn material_json(m: &Material) -> serde_json::Value {
    let rgb = |v: Vec3| json!([v.x, v.y, v.z]);
    let mut o = json!({
        "ka": rgb(m.ka), "kd": rgb(m.kd), "ks": rgb(m.ks), "ke": rgb(m.ke),
        "ns": m.ns, "ni": m.ni, "d": m.dissolve, "illum": m.illum,
    });
    if m.has_tf {
        o["tf"] = rgb(m.tf);
    }
    if let Some(c) = m.checker {
        o["checker"] = json!({ "size": c.size, "origin": rgb(c.origin), "odd": rgb(c.odd) });
    }
    o
}

fn pretty(v: &serde_json::Value) -> String {
    serde_json::to_string_pretty(v).unwrap_or_default() + "\n"
}

/// The checkerboard's light, sky and camera, shared by its two forms.
fn checker_setting() -> serde_json::Value {
    json!({
        "camera": { "eye": [0.0, 3.2, 8.0], "target": [0.0, 0.8, 0.0], "fov": 45 },
        "lights": [ { "point": { "position": [3.0, 7.0, 5.0], "intensity": [60.0, 60.0, 60.0] } } ],
        "ambient": [0.05, 0.05, 0.05],
        "background": [0.35, 0.45, 0.65]
    })
}

fn with_setting(mut scene: serde_json::Value, setting: serde_json::Value) -> serde_json::Value {
    if let (Some(o), serde_json::Value::Object(s)) = (scene.as_object_mut(), setting) {
        o.extend(s);
    }
    scene
}

/// The checkerboard of the paper's scene: one square of side 8 on y = 0,
/// its 8 x 8 checks a texture (the paper's section 7, "Textures"), not
/// 64 polygons: light checks `kd` 0.8, dark ones 0.1.
fn checkerboard() -> Material {
    Material {
        checker: Some(Checker {
            size: 1.0,
            origin: Vec3::new(0.0, -0.5, 0.0),
            odd: Vec3::splat(0.125),
        }),
        ..diffuse("checkerboard", Vec3::splat(0.8))
    }
}

/// The textured floor's OBJ (`checker-spheres.obj`), which the scenes that
/// stand on it share, and its MTL (the material untextured: the scene
/// files put `checkerboard()` on it).
fn checker_floor() -> Vec<(String, String)> {
    let mut obj = ObjWriter::default();
    let v = |x: f32, z: f32| Vec3::new(x, 0.0, z);
    obj.quad(
        "floor",
        "checkerboard",
        [v(-4.0, -4.0), v(-4.0, 4.0), v(4.0, 4.0), v(4.0, -4.0)],
    );
    let untextured = Material {
        checker: None,
        ..checkerboard()
    };
    vec![
        ("checker-spheres.obj".into(), obj.text(HEADER, "checker-spheres.mtl")),
        ("checker-spheres.mtl".into(), write_mtl(&[untextured], HEADER)),
    ]
}

fn materials_json(materials: &[Material]) -> serde_json::Map<String, serde_json::Value> {
    materials.iter().map(|m| (m.name.clone(), material_json(m))).collect()
}

fn checker_spheres() -> ShippedScene {
    let spheres: Vec<_> = CHECKER_SPHERES
        .iter()
        .map(|(name, material, c, r)| json!({ "name": name, "center": c, "radius": r, "material": material }))
        .collect();
    let scene = json!({
        "meshes": { "floor": "checker-spheres.obj" },
        "instances": [ { "mesh": "floor", "material": "checkerboard" } ],
        "materials": materials_json(&[checkerboard(), mirror(), glass(), phong()]),
        "spheres": spheres,
    });
    let mut files = checker_floor();
    files.push((
        "checker-spheres.json".into(),
        pretty(&with_setting(scene, checker_setting())),
    ));
    ShippedScene {
        name: "checker-spheres",
        summary: "mirror, glass and Phong spheres (analytic) over a checkerboard (one square, 8x8 checks as a texture), one point light, a sky",
        files,
        images: Vec::new(),
    }
}

fn checker_spheres_tessellated() -> ShippedScene {
    let mut obj = ObjWriter::default();
    for (name, material, c, r) in CHECKER_SPHERES {
        obj.sphere(name, material, Vec3::from_array(c), r);
    }
    let mtl = write_mtl(&[mirror(), glass(), phong()], HEADER);
    let scene = json!({
        "meshes": { "floor": "checker-spheres.obj", "spheres": "checker-spheres-tessellated.obj" },
        "instances": [ { "mesh": "floor", "material": "checkerboard" }, { "mesh": "spheres" } ],
        "materials": materials_json(&[checkerboard()]),
    });
    ShippedScene {
        name: "checker-spheres-tessellated",
        summary: "checker-spheres with each sphere tessellated (32x64, vn normals): the analytic scene's twin",
        files: vec![
            (
                "checker-spheres-tessellated.obj".into(),
                obj.text(HEADER, "checker-spheres-tessellated.mtl"),
            ),
            ("checker-spheres-tessellated.mtl".into(), mtl),
            (
                "checker-spheres-tessellated.json".into(),
                pretty(&with_setting(scene, checker_setting())),
            ),
        ],
        images: Vec::new(),
    }
}

fn cornell_mirror_glass() -> ShippedScene {
    let mut obj = ObjWriter::default();
    let v = Vec3::new;
    obj.quad(
        "floor",
        "white",
        [v(-1., 0., 1.), v(1., 0., 1.), v(1., 0., -1.), v(-1., 0., -1.)],
    );
    obj.quad(
        "ceiling",
        "white",
        [v(-1., 2., -1.), v(1., 2., -1.), v(1., 2., 1.), v(-1., 2., 1.)],
    );
    obj.quad(
        "back",
        "white",
        [v(-1., 0., -1.), v(1., 0., -1.), v(1., 2., -1.), v(-1., 2., -1.)],
    );
    obj.quad(
        "left",
        "red",
        [v(-1., 0., 1.), v(-1., 0., -1.), v(-1., 2., -1.), v(-1., 2., 1.)],
    );
    obj.quad(
        "right",
        "green",
        [v(1., 0., -1.), v(1., 0., 1.), v(1., 2., 1.), v(1., 2., -1.)],
    );
    obj.quad(
        "light",
        "light",
        [
            v(-0.25, 1.98, -0.25),
            v(0.25, 1.98, -0.25),
            v(0.25, 1.98, 0.25),
            v(-0.25, 1.98, 0.25),
        ],
    );
    obj.block("mirror-box", "mirror", v(-0.4, 0.6, -0.35), v(0.3, 0.6, 0.3), 20.0);
    obj.sphere("glass-ball", "glass", v(0.4, 0.35, 0.35), 0.35);
    let light = Material {
        ka: Vec3::splat(0.78),
        kd: Vec3::splat(0.78),
        ke: Vec3::new(17.0, 12.0, 4.0),
        ..Material::named("light")
    };
    let materials = [
        diffuse("white", Vec3::new(0.725, 0.71, 0.68)),
        diffuse("red", Vec3::new(0.63, 0.065, 0.05)),
        diffuse("green", Vec3::new(0.14, 0.45, 0.091)),
        light,
        mirror(),
        glass(),
    ];
    let scene = json!({
        "meshes": { "box": "cornell-mirror-glass.obj" },
        "instances": [ { "mesh": "box" } ],
        "camera": { "eye": [0.0, 1.0, 3.6], "target": [0.0, 1.0, 0.0], "fov": 38 },
        "ambient": [0.02, 0.02, 0.02]
    });
    ShippedScene {
        name: "cornell-mirror-glass",
        summary: "a Cornell box lit by its emissive ceiling quad, with a mirror box and a tessellated glass sphere",
        files: vec![
            (
                "cornell-mirror-glass.obj".into(),
                obj.text(HEADER, "cornell-mirror-glass.mtl"),
            ),
            ("cornell-mirror-glass.mtl".into(), write_mtl(&materials, HEADER)),
            ("cornell-mirror-glass.json".into(), pretty(&scene)),
        ],
        images: Vec::new(),
    }
}

fn tir_block() -> ShippedScene {
    let mut obj = ObjWriter::default();
    obj.checker("floor", 3.0, 12, 0.0, ("check-light", "check-dark"));
    // Lifted off the floor: a glass face coplanar with a floor face would
    // make the nearer of the two a matter of rounding, pixel by pixel.
    obj.block(
        "glass-block",
        "glass",
        Vec3::new(0.0, 0.61, 0.0),
        Vec3::new(0.9, 0.6, 0.6),
        30.0,
    );
    let [a, b] = checks();
    let scene = json!({
        "meshes": { "scene": "tir-block.obj" },
        "instances": [ { "mesh": "scene" } ],
        "camera": { "eye": [1.2, 3.0, 3.2], "target": [0.0, 0.5, 0.0], "fov": 40 },
        "lights": [ { "point": { "position": [-2.0, 5.0, 3.0], "intensity": [30.0, 30.0, 30.0] } } ],
        "ambient": [0.05, 0.05, 0.05],
        "background": [0.35, 0.45, 0.65]
    });
    ShippedScene {
        name: "tir-block",
        summary: "a glass block on a checkerboard seen from above: rays that enter its top leave through no side face (total internal reflection)",
        files: vec![
            ("tir-block.obj".into(), obj.text(HEADER, "tir-block.mtl")),
            ("tir-block.mtl".into(), write_mtl(&[a, b, glass()], HEADER)),
            ("tir-block.json".into(), pretty(&scene)),
        ],
        images: Vec::new(),
    }
}

fn grazing() -> ShippedScene {
    let mut obj = ObjWriter::default();
    obj.checker("floor", 20.0, 40, 0.0, ("glossy-light", "glossy-dark"));
    obj.block(
        "tower",
        "phong",
        Vec3::new(0.0, 1.5, -12.0),
        Vec3::new(1.0, 1.5, 1.0),
        45.0,
    );
    let glossy = |name: &str, kd: f32| Material {
        ka: Vec3::splat(kd),
        kd: Vec3::splat(kd),
        ks: Vec3::splat(0.3),
        ns: 80.0,
        illum: 3,
        ..Material::named(name)
    };
    let scene = json!({
        "meshes": { "scene": "grazing.obj" },
        "instances": [ { "mesh": "scene" } ],
        "camera": { "eye": [0.0, 0.02, 15.0], "target": [0.0, 0.4, -12.0], "fov": 30 },
        "lights": [ { "directional": { "direction": [0.3, -0.2, -1.0], "radiance": [1.0, 1.0, 1.0] } } ],
        "ambient": [0.05, 0.05, 0.05],
        "background": [0.35, 0.45, 0.65]
    });
    ShippedScene {
        name: "grazing",
        summary: "a reflective checkerboard seen from 0.02 above it: primary, reflected and shadow rays at grazing angles",
        files: vec![
            ("grazing.obj".into(), obj.text(HEADER, "grazing.mtl")),
            (
                "grazing.mtl".into(),
                write_mtl(
                    &[glossy("glossy-light", 0.7), glossy("glossy-dark", 0.1), phong()],
                    HEADER,
                ),
            ),
            ("grazing.json".into(), pretty(&scene)),
        ],
        images: Vec::new(),
    }
}

fn inside_glass() -> ShippedScene {
    let scene = json!({
        "meshes": { "floor": "checker-spheres.obj" },
        "instances": [ { "mesh": "floor", "material": "checkerboard" } ],
        "materials": materials_json(&[checkerboard(), glass(), phong()]),
        "spheres": [
            { "name": "glass-dome", "center": [0.0, 2.5, 0.0], "radius": 2.0, "material": "glass" },
            { "name": "phong-ball", "center": [1.5, 1.0, -3.0], "radius": 1.0, "material": "phong" }
        ],
        "camera": { "eye": [0.0, 2.5, 1.2], "target": [0.5, 0.5, -3.0], "fov": 60 },
        "lights": [ { "point": { "position": [3.0, 7.0, 5.0], "intensity": [60.0, 60.0, 60.0] } } ],
        "ambient": [0.05, 0.05, 0.05],
        "background": [0.35, 0.45, 0.65]
    });
    ShippedScene {
        name: "inside-glass",
        summary: "the camera inside a glass sphere (index 1.5) over the checkerboard: every primary ray starts in glass",
        files: vec![("inside-glass.json".into(), pretty(&scene))],
        images: Vec::new(),
    }
}

/// An image as PNG bytes, `f(x, y)` giving each pixel's RGBA (row 0 at
/// the top).
fn png(width: u32, height: u32, f: impl Fn(u32, u32) -> [u8; 4]) -> Vec<u8> {
    let image = image::RgbaImage::from_fn(width, height, |x, y| image::Rgba(f(x, y)));
    let mut bytes = std::io::Cursor::new(Vec::new());
    image
        .write_to(&mut bytes, image::ImageFormat::Png)
        .expect("encoding a PNG in memory");
    bytes.into_inner()
}

/// The textured room's images: a checkerboard (8 x 8 checks of warm and
/// cool tones), a globe (latitude bands, a darker meridian every 30
/// degrees) and a leaf (a green ellipse with a vein, transparent around).
fn room_images() -> Vec<(String, Vec<u8>)> {
    let checks = png(64, 64, |x, y| {
        if (x / 8 + y / 8) % 2 == 0 {
            [220, 200, 160, 255]
        } else {
            [50, 70, 110, 255]
        }
    });
    let globe = png(128, 64, |x, y| {
        let band = [[200, 60, 40], [230, 180, 50], [60, 150, 80], [50, 100, 200]][(y / 8 % 4) as usize];
        let shade = if x % 11 == 0 { 2 } else { 1 };
        [band[0] / shade, band[1] / shade, band[2] / shade, 255]
    });
    let leaf = png(64, 64, |x, y| {
        let (u, v) = ((x as f32 + 0.5) / 32.0 - 1.0, (y as f32 + 0.5) / 32.0 - 1.0);
        let inside = u * u / 0.45 + v * v / 0.95 < 1.0;
        let vein = u.abs() < 0.04;
        match (inside, vein) {
            (false, _) => [40, 120, 40, 0],
            (true, true) => [180, 200, 90, 255],
            (true, false) => [40, 120, 40, 255],
        }
    });
    vec![
        ("textures/checks.png".into(), checks),
        ("textures/globe.png".into(), globe),
        ("textures/leaf.png".into(), leaf),
    ]
}

/// The textured room's MTL, each block in the shape an exporter writes:
/// the walls as Maya writes every material (`illum 4`, `Tf 1 1 1`, `Ni 1`:
/// opaque surfaces, whatever the letter of the spec says), the textured
/// ones as Blender writes them (`Kd` beside `map_Kd`, black for the floor
/// as many exporters leave it, `Ni 1.45`, `illum 2`), the leaf with its
/// cut-out (`map_d`, the same image's alpha).
fn room_mtl() -> String {
    let mut s = String::new();
    for line in HEADER.lines() {
        let _ = writeln!(s, "# {line}");
    }
    for (name, kd) in [("wallBackSG", "0.60 0.55 0.50"), ("wallSideSG", "0.35 0.45 0.55")] {
        let _ = write!(
            s,
            "\nnewmtl {name}\nillum 4\nKd {kd}\nKa 0.00 0.00 0.00\nTf 1.00 1.00 1.00\nNi 1.00\n"
        );
    }
    s.push_str(
        "\nnewmtl floor\nNs 250.000000\nKa 1.000000 1.000000 1.000000\nKd 0.000000 0.000000 0.000000\n\
         Ks 0.100000 0.100000 0.100000\nKe 0.000000 0.000000 0.000000\nNi 1.450000\nd 1.000000\nillum 2\n\
         map_Kd -s 4 4 1 textures/checks.png\n",
    );
    s.push_str(
        "\nnewmtl globe\nNs 80.000000\nKa 1.000000 1.000000 1.000000\nKd 0.900000 0.900000 0.900000\n\
         Ks 0.300000 0.300000 0.300000\nKe 0.000000 0.000000 0.000000\nNi 1.450000\nd 1.000000\nillum 2\n\
         map_Kd textures/globe.png\n",
    );
    s.push_str(
        "\nnewmtl leaf\nNs 10.000000\nKa 1.000000 1.000000 1.000000\nKd 1.000000 1.000000 1.000000\n\
         Ks 0.000000 0.000000 0.000000\nKe 0.000000 0.000000 0.000000\nNi 1.450000\nd 1.000000\nillum 2\n\
         map_Kd -clamp on textures/leaf.png\nmap_d -clamp on textures/leaf.png\n",
    );
    s
}

fn textured_room() -> ShippedScene {
    let mut obj = ObjWriter::default();
    let (w, h) = (4.0, 3.0);
    obj.textured_quad(
        "floor",
        "floor",
        [
            Vec3::new(-w, 0.0, w),
            Vec3::new(w, 0.0, w),
            Vec3::new(w, 0.0, -w),
            Vec3::new(-w, 0.0, -w),
        ],
    );
    obj.quad(
        "wall-back",
        "wallBackSG",
        [
            Vec3::new(-w, 0.0, -w),
            Vec3::new(w, 0.0, -w),
            Vec3::new(w, h, -w),
            Vec3::new(-w, h, -w),
        ],
    );
    obj.quad(
        "wall-left",
        "wallSideSG",
        [
            Vec3::new(-w, 0.0, w),
            Vec3::new(-w, 0.0, -w),
            Vec3::new(-w, h, -w),
            Vec3::new(-w, h, w),
        ],
    );
    obj.textured_sphere("globe", "globe", Vec3::new(1.2, 1.0, -1.0), 1.0, (24, 48));
    obj.textured_quad(
        "leaf-card",
        "leaf",
        [
            Vec3::new(-2.2, 0.2, 0.2),
            Vec3::new(-0.6, 0.2, -0.4),
            Vec3::new(-0.6, 2.6, -0.4),
            Vec3::new(-2.2, 2.6, 0.2),
        ],
    );
    let scene = json!({
        "meshes": { "room": "textured-room.obj" },
        "instances": [ { "mesh": "room" } ],
        "camera": { "eye": [0.5, 1.8, 6.5], "target": [0.0, 1.0, -1.0], "fov": 50 },
        "lights": [ { "point": { "position": [2.5, 5.0, 4.0], "intensity": [40.0, 40.0, 40.0] } } ],
        "ambient": [0.08, 0.08, 0.08],
        "background": [0.35, 0.45, 0.65]
    });
    ShippedScene {
        name: "textured-room",
        summary: "image maps on a floor (repeated 4 x 4, Kd black beside the map) and a sphere, a cut-out leaf card casting a leaf-shaped shadow, walls written as Maya writes opaque materials",
        files: vec![
            ("textured-room.obj".into(), obj.text(HEADER, "textured-room.mtl")),
            ("textured-room.mtl".into(), room_mtl()),
            ("textured-room.json".into(), pretty(&scene)),
        ],
        images: room_images(),
    }
}

/// Every shipped scene, in the order `penumbra gen-assets` writes them.
pub fn shipped_scenes() -> Vec<ShippedScene> {
    vec![
        checker_spheres(),
        checker_spheres_tessellated(),
        cornell_mirror_glass(),
        tir_block(),
        grazing(),
        inside_glass(),
        textured_room(),
    ]
}
