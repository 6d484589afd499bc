//! Scene JSON: `load_scene` and `load_scene_shaded`.

use std::path::Path;

use penumbra::scene::{Light, Scene, load_scene, load_scene_shaded};
use proptest::collection::vec;
use proptest::option;
use proptest::prelude::*;

use crate::harness::{Budget, MIB, Reader, call, fail, names_a_file, write_case};
use crate::hdr::{hdr_bytes, map_ok};
use crate::inputs::{either, numbered, pick, wildness};
use crate::mtl::{BAD_MTL, TINY_MTL, material_ok};
use crate::obj::{TINY_OBJ, mesh_ok};

/// Cases are written to `<dir>/s/case.json`; the meshes and probes they
/// name are tiny files in `<dir>/s` and `<dir>`.
const SEEDS: &[&str] = &[
    include_str!("../../../../assets/scenes/bunny-corner.json"),
    include_str!("../../../../assets/scenes/bunny-corner-moving.json"),
    include_str!("../../../../assets/scenes/cow-corner.json"),
    include_str!("../../../../assets/scenes/dragon-corner.json"),
    include_str!("../../../../assets/scenes/multi-corner.json"),
    include_str!("../../../../assets/raytrace/checker-spheres.json"),
    include_str!("../../../../assets/raytrace/checker-spheres-tessellated.json"),
    include_str!("../../../../assets/raytrace/cornell-mirror-glass.json"),
    include_str!("../../../../assets/raytrace/grazing.json"),
    include_str!("../../../../assets/raytrace/inside-glass.json"),
    include_str!("../../../../assets/raytrace/tir-block.json"),
    r#"{
  "meshes": { "tri": "tri.obj", "corner": "../corner.obj" },
  "instances": [
    { "mesh": "tri", "role": "receiver", "name": "floor" },
    { "mesh": "corner", "role": "caster", "translate": [0.5, 0, 0.5],
      "rotate": { "axis": [0, 1, 0], "degrees": 30 }, "scale": 4, "material": "glass",
      "motion": { "axis": [0, 1, 0], "degrees_per_frame": 5, "pivot": [0.5, 0, 0.5],
                  "translate_per_frame": [0, 0, 0.01] } },
    { "mesh": "tri", "role": "both" }
  ],
  "camera": { "eye": [3, 2, 3], "target": [0, 0, 0], "fov": 45 },
  "lights": [ { "point": { "position": [2, 3, 2], "intensity": [10, 10, 10] } },
              { "directional": { "direction": [0, -1, 0], "radiance": [1, 1, 1] } } ],
  "environment": { "map": "probe.hdr", "intensity": 1, "rotation_degrees": 90 },
  "fields": { "corner": "corner.dfield" },
  "materials": { "glass": { "ks": [0.1, 0.1, 0.1], "tf": [1, 1, 1], "ni": 1.5, "illum": 7, "d": 0.5 },
                 "mirror": { "kd": [0, 0, 0], "ks": [0.9, 0.9, 0.9], "ka": [0, 0, 0], "ke": [0, 0, 0],
                             "ns": 10, "illum": 3 } },
  "spheres": [ { "name": "ball", "center": [0, 1, 0], "radius": 1, "material": "mirror" },
               { "center": [2, 1, 0], "radius": 0.5 } ],
  "ambient": [0.05, 0.05, 0.05], "background": [0.2, 0.3, 0.5]
}"#,
];

const BUDGET: Budget = Budget::new(64, MIB);

pub static SCENE: Reader = Reader::new("scene", &["load_scene", "load_scene_shaded"], check).with_setup(setup);

fn setup(dir: &Path) -> std::io::Result<()> {
    let s = dir.join("s");
    std::fs::create_dir_all(&s)?;
    for folder in [dir, s.as_path()] {
        std::fs::write(folder.join("tiny.mtl"), TINY_MTL)?;
        std::fs::write(folder.join("corner.obj"), TINY_OBJ)?;
    }
    let meshes = [
        "tri",
        "cornell-mirror-glass",
        "checker-spheres",
        "checker-spheres-tessellated",
        "grazing",
        "tir-block",
    ];
    for name in meshes {
        std::fs::write(s.join(format!("{name}.obj")), TINY_OBJ)?;
    }
    // Meshes the scene seeds take from the shared data set: one of them
    // bad, the rest missing.
    std::fs::create_dir_all(dir.join("data/models"))?;
    std::fs::write(dir.join("data/models/cow.obj"), "v 0 0 0\nf 1 2 3\n")?;
    std::fs::write(s.join("bad.obj"), "v 0 0 0\nf 1 2 3\n")?;
    std::fs::write(
        s.join("mtl.obj"),
        "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )?;
    std::fs::write(s.join("bad.mtl"), BAD_MTL)?;
    std::fs::write(s.join("probe.hdr"), hdr_bytes(8, 4, 0))?;
    std::fs::write(s.join("square.hdr"), hdr_bytes(4, 4, 1))?;
    Ok(())
}

fn check(dir: &Path, input: &[u8]) -> Result<(), String> {
    let path = write_case(dir.join("s").join("case.json"), input)?;
    let len = input_len(dir, input);
    for (name, shaded) in [("load_scene", false), ("load_scene_shaded", true)] {
        let load = if shaded { load_scene_shaded } else { load_scene };
        match call(name, BUDGET, len, || load(&path))? {
            Ok(scene) => scene_ok(&scene, shaded)?,
            Err(e) => names_a_file(&e)?,
        }
    }
    Ok(())
}

/// The bytes a scene case reads: the scene file, and each mesh and probe
/// file it names (a file named twice is read twice).
fn input_len(dir: &Path, input: &[u8]) -> usize {
    let text = input.strip_prefix("\u{feff}".as_bytes()).unwrap_or(input);
    let Ok(value) = serde_json::from_slice::<serde_json::Value>(text) else {
        return input.len();
    };
    let base = dir.join("s");
    let size = |v: &serde_json::Value| {
        v.as_str()
            .and_then(|p| std::fs::metadata(base.join(p)).ok())
            .filter(|m| m.is_file())
            .map_or(0, |m| m.len() as usize)
    };
    let meshes = value.get("meshes").and_then(|m| m.as_object());
    let mesh_bytes: usize = meshes.map_or(0, |m| m.values().map(size).sum());
    let map_bytes = value.get("environment").and_then(|e| e.get("map")).map_or(0, size);
    input.len() + mesh_bytes + map_bytes
}

fn scene_ok(s: &Scene, shaded: bool) -> Result<(), String> {
    for m in &s.meshes {
        mesh_ok(&m.mesh)?;
        match (&m.shading, shaded) {
            (None, false) => {}
            (Some(sh), true) => {
                let n = m.mesh.triangles.len();
                sh.materials.iter().try_for_each(material_ok)?;
                let lens = [
                    sh.triangle_materials.len(),
                    sh.triangle_faces.len(),
                    sh.corner_normals.len(),
                ];
                let materials_ok = sh.triangle_materials.iter().all(|&k| (k as usize) < sh.materials.len());
                let normals_ok = sh.normals.iter().all(|v| v.is_finite());
                let corners_ok = sh
                    .corner_normals
                    .iter()
                    .all(|c| c.is_none_or(|c| c.iter().all(|&k| (k as usize) < sh.normals.len())));
                if lens != [n; 3] || !materials_ok || !normals_ok || !corners_ok {
                    return fail(format!(
                        "mesh '{}': shading inconsistent with its {n} triangles",
                        m.name
                    ));
                }
            }
            _ => {
                return fail(format!(
                    "mesh '{}': shading {}",
                    m.name,
                    if shaded { "missing" } else { "unasked" }
                ));
            }
        }
    }
    if s.instances.is_empty() {
        return fail("a scene without instances".into());
    }
    for i in &s.instances {
        let t = &i.transform;
        let placed = i.mesh < s.meshes.len()
            && t.translation.is_finite()
            && t.rotation.is_finite()
            && t.rotation.is_normalized()
            && t.scale.is_finite()
            && t.scale > 0.0;
        let moves = i.motion.is_none_or(|m| {
            m.axis.is_finite()
                && m.axis.is_normalized()
                && m.degrees_per_frame.is_finite()
                && m.pivot.is_finite()
                && m.velocity.is_finite()
        });
        if !placed || !moves {
            return fail(format!("instance {i:?} is not finite"));
        }
    }
    if let Some(c) = &s.camera {
        c.validate().map_err(|e| format!("camera {c:?}: {e}"))?;
    }
    for l in &s.lights {
        let ok = match l {
            Light::Point { position, intensity } => position.is_finite() && intensity.is_finite(),
            Light::Directional { direction, radiance } => direction.is_normalized() && radiance.is_finite(),
        };
        if !ok {
            return fail(format!("light {l:?} is not finite"));
        }
    }
    if let Some(env) = &s.environment {
        map_ok(&env.map)?;
        if !(env.intensity.is_finite() && env.intensity >= 0.0 && env.rotation_degrees.is_finite()) {
            return fail(format!(
                "environment intensity {} rotation {}",
                env.intensity, env.rotation_degrees
            ));
        }
    }
    if s.fields.keys().any(|&m| m >= s.meshes.len()) {
        return fail("a field of no mesh".into());
    }
    s.materials.iter().try_for_each(material_ok)?;
    for sphere in &s.spheres {
        let known = sphere
            .material
            .as_ref()
            .is_none_or(|name| s.materials.iter().any(|m| &m.name == name));
        if !(sphere.center.is_finite() && sphere.radius.is_finite() && sphere.radius > 0.0 && known) {
            return fail(format!("sphere {sphere:?}"));
        }
    }
    for c in [s.ambient, s.background].into_iter().flatten() {
        if !c.is_finite() || c.min_element() < 0.0 {
            return fail(format!("ambient or background {c} is not finite and >= 0"));
        }
    }
    Ok(())
}

/// A JSON number in `lo..hi`, or with probability `wild` one out of f32's
/// range (serde reads those as inf) or no number at all.
fn json_number(wild: f64, lo: f64, hi: f64) -> impl Strategy<Value = String> + Clone {
    let odd = prop_oneof![
        3 => pick(&["0", "-0", "1", "-1", "1e39", "-1e39", "1e-46", "3.4028235e38", "1e308", "4294967297", "0.0",
            "180", "1e400"]),
        1 => pick(&["null", "\"1\"", "true", "[]", "{}"]),
    ];
    either(wild, (lo..hi).prop_map(|x| x.to_string()), odd)
}

fn json_vec3(wild: f64, lo: f64, hi: f64) -> impl Strategy<Value = String> + Clone {
    let n = || json_number(wild, lo, hi);
    let three = (n(), n(), n()).prop_map(|(a, b, c)| format!("[{a}, {b}, {c}]"));
    either(
        wild / 3.0,
        three,
        pick(&["[1, 2]", "[1, 2, 3, 4]", "[]", "null", "0", "\"x\""]),
    )
}

/// A JSON string of `plain`, or with probability `wild` of `odd`.
fn json_string(
    wild: f64,
    plain: &'static [&'static str],
    odd: &'static [&'static str],
) -> impl Strategy<Value = String> + Clone {
    either(wild, pick(plain), pick(odd)).prop_map(|s| format!("\"{s}\""))
}

/// A scene file of random parts, each present or not.
pub fn text() -> impl Strategy<Value = Vec<u8>> {
    wildness().prop_flat_map(scene_parts)
}

fn scene_parts(wild: f64) -> impl Strategy<Value = Vec<u8>> {
    let number = |lo: f64, hi: f64| json_number(wild, lo, hi);
    let vec3 = |lo: f64, hi: f64| json_vec3(wild, lo, hi);
    let string = |plain: &'static [&'static str], odd: &'static [&'static str]| json_string(wild, plain, odd);
    let mesh_file = string(
        &["tri.obj", "../corner.obj"],
        &[
            "bad.obj",
            "mtl.obj",
            "missing.obj",
            "probe.hdr",
            "",
            "/",
            "$PENUMBRA_DATA/x.obj",
            "case.json",
        ],
    );
    let meshes = (
        prop::bool::weighted(1.0 - wild),
        vec((pick(&["a", "b", "tri"]), mesh_file), 0..3),
    )
        .prop_map(|(tri, m)| {
            let tri = tri.then(|| "\"tri\": \"tri.obj\"".to_string());
            let m = m.iter().map(|(n, f)| format!("\"{n}\": {f}"));
            tri.into_iter().chain(m).collect::<Vec<_>>().join(", ")
        });
    let rotate =
        (vec3(-1.0, 1.0), number(-360.0, 360.0)).prop_map(|(a, d)| format!("{{ \"axis\": {a}, \"degrees\": {d} }}"));
    let motion = (vec3(-1.0, 1.0), number(-10.0, 10.0), vec3(-5.0, 5.0), vec3(-0.1, 0.1)).prop_map(|(a, d, p, t)| {
        format!("{{ \"axis\": {a}, \"degrees_per_frame\": {d}, \"pivot\": {p}, \"translate_per_frame\": {t} }}")
    });
    let instance = (
        string(&["tri"], &["a", "zz", ""]),
        option::of(vec3(-10.0, 10.0)),
        option::of(rotate),
        option::of(number(0.01, 10.0)),
        option::of(string(&["caster", "receiver", "both"], &["none", "Caster", ""])),
        option::of(motion),
        option::of(string(&["glass"], &["nothing"])),
    )
        .prop_map(|(mesh, translate, rotate, scale, role, motion, material)| {
            let mut fields = vec![format!("\"mesh\": {mesh}")];
            let optional = [
                ("translate", translate),
                ("rotate", rotate),
                ("scale", scale),
                ("role", role),
                ("motion", motion),
                ("material", material),
            ];
            fields.extend(
                optional
                    .into_iter()
                    .filter_map(|(k, v)| v.map(|v| format!("\"{k}\": {v}"))),
            );
            format!("{{ {} }}", fields.join(", "))
        });
    let instances = either(wild, vec(instance.clone(), 1..4), vec(instance, 0..2)).prop_map(|i| i.join(", "));
    let camera = (vec3(-10.0, 10.0), vec3(-10.0, 10.0), number(1.0, 179.0))
        .prop_map(|(e, t, f)| format!("{{ \"eye\": {e}, \"target\": {t}, \"fov\": {f} }}"));
    let light = prop_oneof![
        (vec3(-10.0, 10.0), vec3(0.0, 10.0))
            .prop_map(|(p, i)| format!("{{ \"point\": {{ \"position\": {p}, \"intensity\": {i} }} }}")),
        (vec3(-1.0, 1.0), vec3(0.0, 10.0))
            .prop_map(|(d, r)| format!("{{ \"directional\": {{ \"direction\": {d}, \"radiance\": {r} }} }}")),
    ];
    let environment = (
        string(&["probe.hdr"], &["square.hdr", "missing.hdr", "tri.obj"]),
        number(0.0, 4.0),
        number(-360.0, 360.0),
    )
        .prop_map(|(m, i, r)| format!("{{ \"map\": {m}, \"intensity\": {i}, \"rotation_degrees\": {r} }}"));
    let illum = either(
        wild,
        (0u32..=10).prop_map(|i| i.to_string()),
        pick(&["11", "-1", "1.5", "null"]),
    );
    let material = (
        vec3(0.0, 1.0),
        vec3(0.0, 1.0),
        number(1.0, 2.0),
        number(0.0, 1.0),
        illum,
    )
        .prop_map(|(kd, tf, ni, d, illum)| {
            format!("{{ \"glass\": {{ \"kd\": {kd}, \"tf\": {tf}, \"ni\": {ni}, \"d\": {d}, \"illum\": {illum} }} }}")
        });
    let sphere = (
        vec3(-10.0, 10.0),
        number(0.1, 5.0),
        option::of(string(&["glass"], &["nothing"])),
    )
        .prop_map(|(c, r, m)| {
            let m = m.map(|m| format!(", \"material\": {m}")).unwrap_or_default();
            format!("[ {{ \"center\": {c}, \"radius\": {r}{m} }} ]")
        });
    let field = string(&["tri"], &["a", "zz"]).prop_map(|n| format!("{{ {n}: \"x.dfield\" }}"));
    // What instances and spheres need is there unless the file is wild.
    let required = |s: BoxedStrategy<String>| either(wild, s.clone().prop_map(Some), option::of(s));
    let parts = (
        required(meshes.boxed()),
        required(instances.boxed()),
        option::of(camera),
        option::of(vec(light, 0..3).prop_map(|l| format!("[{}]", l.join(", ")))),
        option::of(environment),
        option::of(field),
        required(material.boxed()),
        option::of(sphere),
        (
            option::of(vec3(0.0, 1.0)),
            option::of(vec3(0.0, 1.0)),
            prop::bool::weighted(wild),
        ),
    );
    parts.prop_map(
        |(meshes, instances, camera, lights, env, fields, materials, spheres, (ambient, background, extra))| {
            let mut fields_out = Vec::new();
            let mut put = |k: &str, v: Option<String>| {
                if let Some(v) = v {
                    fields_out.push(format!("\"{k}\": {v}"));
                }
            };
            put("meshes", meshes.map(|m| format!("{{ {m} }}")));
            put("instances", instances.map(|i| format!("[ {i} ]")));
            put("camera", camera);
            put("lights", lights);
            put("environment", env);
            put("fields", fields);
            put("materials", materials);
            put("spheres", spheres);
            put("ambient", ambient);
            put("background", background);
            if extra {
                put("colour", Some("1".into()));
            }
            format!("{{ {} }}", fields_out.join(",\n")).into_bytes()
        },
    )
}

/// Scenes at the worst of each part's cost in memory per input byte.
fn heavy() -> Vec<Vec<u8>> {
    let scene = |meshes: String, instances: String, rest: String| {
        format!("{{ \"meshes\": {{ {meshes}\"tri\": \"tri.obj\" }}, \"instances\": [ {instances} ]{rest} }}")
    };
    let one = || "{ \"mesh\": \"tri\" }".to_string();
    let texts = [
        scene(
            numbered(300, |i| format!("\"m{i}\": \"tri.obj\", ")),
            one(),
            String::new(),
        ),
        scene(String::new(), vec![one(); 2_000].join(", "), String::new()),
        scene(
            String::new(),
            one(),
            format!(
                ", \"lights\": [ {} ]",
                vec!["{ \"point\": { \"position\": [0, 1, 0], \"intensity\": [1, 1, 1] } }"; 1_000].join(", ")
            ),
        ),
        scene(
            String::new(),
            one(),
            format!(
                ", \"materials\": {{ {} }}",
                numbered(500, |i| format!("\"m{i}\": {{}}, ")) + "\"z\": {}"
            ),
        ),
        scene(
            String::new(),
            one(),
            format!(
                ", \"spheres\": [ {} ]",
                vec!["{ \"center\": [0, 0, 0], \"radius\": 1 }"; 1_000].join(", ")
            ),
        ),
    ];
    texts.into_iter().map(String::into_bytes).collect()
}

/// The scene seeds, with shared-data paths sent to `<dir>/data`.
pub fn seeds() -> Vec<Vec<u8>> {
    SEEDS
        .iter()
        .map(|s| s.replace("$PENUMBRA_DATA/", "../data/").into_bytes())
        .chain(heavy())
        .collect()
}
