//! No `null` where a number belongs: `prt --json` with degenerate probes
//! (all black, two texels) and the lowest `--order` reports every field of
//! `lighting` as a value; the only nulls are the fields that do not apply
//! to the run (listed below with why).

mod common;

use common::cli::{TempDir, pen};
use serde_json::Value;

const OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\n";

/// Fields that are null when they do not apply to a run on the CPU of one
/// frame of a mesh, without a reference, a PVS, a hierarchy of low
/// resolution, an image or an SH output.
const NOT_APPLICABLE: &[&str] = &[
    "adapter",                     // the CPU: no GPU adapter
    "animation",                   // a still mesh
    "check",                       // no --reference
    "exposure",                    // no image written
    "gpu_ms_per_frame",            // the CPU
    "hierarchy.deviation_max",     // no simplified hierarchy on a mesh this small
    "hierarchy.deviation_mean",    // the same
    "hierarchy.low_res_triangles", // the same
    "max_error",                   // no --max-error
    "per_vertex",                  // no --per-vertex
    "phases",                      // no --profile
    "pvs",                         // no --pvs
    "sh_out",                      // no --sh-out
    "sides.culling_error",         // back-face culling not measured here
    "transfer_l2_error",           // no --reference
];

fn nulls(v: &Value, path: &str, out: &mut Vec<String>) {
    match v {
        Value::Null => out.push(path.to_string()),
        Value::Object(m) => {
            for (k, x) in m {
                let p = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                nulls(x, &p, out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                nulls(x, &format!("{path}[{i}]"), out);
            }
        }
        _ => {}
    }
}

/// An HDR probe of `w x h` texels, all `rgb`.
fn probe(dir: &TempDir, name: &str, (w, h): (usize, usize), rgb: [f32; 3]) -> String {
    let pixels = vec![image::Rgb(rgb); w * h];
    let path = dir.p(name);
    let file = std::fs::File::create(&path).unwrap();
    image::codecs::hdr::HdrEncoder::new(std::io::BufWriter::new(file))
        .encode(&pixels, w, h)
        .unwrap();
    path
}

#[test]
fn prt_json_has_no_null_but_the_fields_that_do_not_apply() {
    let dir = TempDir::new("prt_nulls");
    let mesh = dir.write("m.obj", OBJ);
    let black = probe(&dir, "black.hdr", (32, 16), [0.0; 3]);
    let tiny = probe(&dir, "tiny.hdr", (2, 1), [1.0, 0.5, 0.25]);
    let grey = probe(&dir, "grey.hdr", (32, 16), [0.5; 3]);
    for (env, extra) in [(&black, ""), (&tiny, ""), (&grey, "--order 1"), (&black, "--order 1")] {
        let out = pen(
            &format!("prt --mesh {{mesh}} --env {{env}} --device cpu --json {extra}"),
            &[("mesh", &mesh), ("env", env)],
        );
        let j = out.ok().json();
        let mut found = Vec::new();
        nulls(&j, "", &mut found);
        let unexpected: Vec<&String> = found.iter().filter(|p| !NOT_APPLICABLE.contains(&p.as_str())).collect();
        assert!(unexpected.is_empty(), "nulls {unexpected:?}\n{}", out.describe());
        let lighting = &j["lighting"];
        assert_eq!(lighting["windowed"], Value::Bool(false), "{lighting}");
        assert!(
            lighting["exponent"].is_number() && lighting["window"].is_array(),
            "{lighting}"
        );
        if env == &black {
            assert_eq!(lighting["black"], Value::Bool(true));
            assert!(
                out.stderr.contains("environment map is black"),
                "a black probe is said to be:\n{}",
                out.describe()
            );
        }
    }
}
