//! `docs/scene.schema.json` (JSON Schema 2020-12) describes the scene files
//! the loader reads: every shipped scene validates, and on structural
//! mutations of a scene the schema and `scene::load_scene` agree (what the
//! schema accepts loads, what it refuses is refused). The validator below
//! covers the keywords the schema uses ($ref, oneOf, enum, type, required,
//! properties, additionalProperties, items, minItems, maxItems, minimum);
//! an unknown keyword fails the test, so the schema cannot outgrow it.

mod common;

use std::path::{Path, PathBuf};

use common::cli::TempDir;
use serde_json::{Value, json};

const KNOWN: &[&str] = &[
    "$schema",
    "$id",
    "title",
    "description",
    "default",
    "$defs",
    "$ref",
    "oneOf",
    "enum",
    "type",
    "required",
    "properties",
    "additionalProperties",
    "items",
    "minItems",
    "maxItems",
    "minimum",
];

fn schema() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/scene.schema.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn type_is(t: &str, v: &Value) -> bool {
    match t {
        "object" => v.is_object(),
        "array" => v.is_array(),
        "string" => v.is_string(),
        "number" => v.is_number(),
        "integer" => v.is_i64() || v.is_u64(),
        "boolean" => v.is_boolean(),
        "null" => v.is_null(),
        other => panic!("unknown type {other}"),
    }
}

/// Whether `v` satisfies `s` (`root` holds the `$defs`).
fn valid(root: &Value, s: &Value, v: &Value) -> bool {
    let s = s.as_object().expect("a schema is an object");
    for k in s.keys() {
        assert!(KNOWN.contains(&k.as_str()), "the validator does not know keyword {k}");
    }
    if let Some(r) = s.get("$ref").and_then(Value::as_str) {
        let name = r.strip_prefix("#/$defs/").expect("local $ref");
        if !valid(root, &root["$defs"][name], v) {
            return false;
        }
    }
    if let Some(alts) = s.get("oneOf").and_then(Value::as_array)
        && alts.iter().filter(|a| valid(root, a, v)).count() != 1
    {
        return false;
    }
    if let Some(values) = s.get("enum").and_then(Value::as_array)
        && !values.contains(v)
    {
        return false;
    }
    if let Some(t) = s.get("type").and_then(Value::as_str)
        && !type_is(t, v)
    {
        return false;
    }
    if let Some(min) = s.get("minimum").and_then(Value::as_f64)
        && v.as_f64().is_some_and(|x| x < min)
    {
        return false;
    }
    if let Some(map) = v.as_object() {
        let props = s.get("properties").and_then(Value::as_object);
        let required = s.get("required").and_then(Value::as_array).into_iter().flatten();
        if required.filter_map(Value::as_str).any(|k| !map.contains_key(k)) {
            return false;
        }
        for (k, x) in map {
            let ok = match (props.and_then(|p| p.get(k)), s.get("additionalProperties")) {
                (Some(p), _) => valid(root, p, x),
                (None, Some(Value::Bool(false))) => false,
                (None, Some(extra)) if extra.is_object() => valid(root, extra, x),
                (None, _) => true,
            };
            if !ok {
                return false;
            }
        }
    }
    if let Some(items) = v.as_array() {
        let n = items.len() as u64;
        if s.get("minItems").and_then(Value::as_u64).is_some_and(|m| n < m)
            || s.get("maxItems").and_then(Value::as_u64).is_some_and(|m| n > m)
        {
            return false;
        }
        if let Some(item) = s.get("items")
            && !items.iter().all(|x| valid(root, item, x))
        {
            return false;
        }
    }
    true
}

fn scene_files() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets");
    let mut files = Vec::new();
    for dir in ["scenes", "raytrace"] {
        for e in std::fs::read_dir(root.join(dir)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "json") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

#[test]
fn every_shipped_scene_is_valid_and_loads() {
    let root = schema();
    let files = scene_files();
    assert!(files.len() >= 10, "{files:?}");
    let data = common::data_root();
    for f in files {
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
        assert!(valid(&root, &root, &v), "{} does not validate", f.display());
        let needs_data = v.to_string().contains("$PENUMBRA_DATA");
        if data.is_some() || !needs_data {
            penumbra::scene::load_scene_in(&f, data.as_deref()).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        }
    }
}

/// A scene using every section, with files that exist.
fn full_scene(d: &TempDir) -> Value {
    let probe = common::cli::write_probe(d, common::cli::SKY, common::cli::GROUND);
    let corner = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/corner.obj");
    json!({
        "meshes": { "c": corner.display().to_string() },
        "instances": [
            { "mesh": "c", "role": "receiver" },
            { "mesh": "c", "name": "moving", "role": "caster", "translate": [0.1, 0, 0], "scale": 0.5,
              "rotate": { "axis": [0, 1, 0], "degrees": 30 },
              "motion": { "degrees_per_frame": 2, "pivot": [0, 0, 0] }, "material": "m" }
        ],
        "camera": { "eye": [2, 2, 2], "target": [0, 0, 0], "fov": 40 },
        "lights": [
            { "point": { "position": [1, 3, 1], "intensity": [5, 5, 5] } },
            { "directional": { "direction": [0, -1, 0], "radiance": [1, 1, 1] } }
        ],
        "environment": { "map": probe, "intensity": 1.5 },
        "materials": { "m": { "kd": [0.5, 0.4, 0.3], "illum": 2,
                              "checker": { "size": 0.5, "origin": [0, -0.25, 0], "odd": [0.2, 0.2, 0.2] } } },
        "spheres": [ { "center": [0, 1, 0], "radius": 0.25, "material": "m" } ],
        "ambient": [0.05, 0.05, 0.05],
        "background": [0, 0, 0]
    })
}

#[test]
fn schema_and_loader_agree_on_mutations() {
    let root = schema();
    let d = TempDir::new("scene-schema");
    let base = full_scene(&d);
    type Edit = fn(&mut Value);
    let mutations: Vec<(&str, Edit)> = vec![
        ("unchanged", |_| {}),
        ("unknown top-level key", |v| v["bogus"] = json!(1)),
        ("unknown instance key", |v| v["instances"][0]["colour"] = json!("red")),
        ("checker without odd", |v| {
            v["materials"]["m"]["checker"] = json!({ "size": 1 })
        }),
        ("unknown checker key", |v| {
            v["materials"]["m"]["checker"]["scale"] = json!(2)
        }),
        ("string checker size", |v| {
            v["materials"]["m"]["checker"]["size"] = json!("1")
        }),
        ("two-element translate", |v| {
            v["instances"][1]["translate"] = json!([1, 2])
        }),
        ("string translate", |v| v["instances"][1]["translate"] = json!("1,2,3")),
        ("unknown role", |v| v["instances"][0]["role"] = json!("occluder")),
        ("role both", |v| v["instances"][0]["role"] = json!("both")),
        ("string scale", |v| v["instances"][1]["scale"] = json!("2")),
        ("spot light", |v| {
            v["lights"][0] = json!({ "spot": { "position": [0, 1, 0] } })
        }),
        ("point light without intensity", |v| {
            v["lights"][0] = json!({ "point": { "position": [0, 1, 0] } })
        }),
        ("two lights in one", |v| {
            v["lights"][0]["directional"] = json!({ "direction": [0, -1, 0], "radiance": [1, 1, 1] })
        }),
        ("camera without target", |v| v["camera"] = json!({ "eye": [1, 1, 1] })),
        ("negative illum", |v| v["materials"]["m"]["illum"] = json!(-1)),
        ("fractional illum", |v| v["materials"]["m"]["illum"] = json!(1.5)),
        ("unknown material key", |v| {
            v["materials"]["m"]["roughness"] = json!(0.5)
        }),
        ("sphere without radius", |v| {
            v["spheres"][0] = json!({ "center": [0, 0, 0] })
        }),
        ("no meshes", |v| {
            v.as_object_mut().unwrap().remove("meshes");
        }),
        ("instances an object", |v| v["instances"] = json!({ "mesh": "c" })),
        ("motion with only an axis", |v| {
            v["instances"][1]["motion"] = json!({ "axis": [1, 0, 0] })
        }),
        ("environment without map", |v| {
            v["environment"] = json!({ "intensity": 2 })
        }),
        ("mesh path a number", |v| v["meshes"]["c"] = json!(3)),
        (
            "minimal scene",
            |v| *v = json!({ "meshes": v["meshes"].clone(), "instances": [{ "mesh": "c" }] }),
        ),
    ];
    let mut refused = 0;
    for (i, (what, edit)) in mutations.iter().enumerate() {
        let mut v = base.clone();
        edit(&mut v);
        let path = d.write(&format!("m{i}.json"), v.to_string());
        let schema_ok = valid(&root, &root, &v);
        let loaded = penumbra::scene::load_scene(Path::new(&path));
        assert_eq!(
            schema_ok,
            loaded.is_ok(),
            "{what}: schema says {schema_ok}, loader {:?}",
            loaded.err()
        );
        refused += !schema_ok as usize;
    }
    assert!(
        refused >= 14,
        "the mutations must mostly break the scene: {refused} refused"
    );
}
