//! What a command prints on stdout without `--json`: a few aligned
//! `label  value` lines for a person (what was computed, on which device,
//! the files written, the headline time, the error where one was
//! measured), read from the same report `--json` prints whole.

use std::fmt::Write as _;
use std::path::PathBuf;

use serde_json::Value;

/// The headline times, the first a report has: (field, what it timed).
const TIMES: &[(&str, &str)] = &[
    ("render_ms", "render"),
    ("ao_ms", "AO"),
    ("trace_ms", "trace"),
    ("sweep_ms", "every setting"),
    ("frame_ms", "per frame"),
    ("build_ms", "build"),
];

/// The errors against a reference, the first a report has: (JSON pointer,
/// what it measures).
const ERRORS: &[(&str, &str)] = &[
    ("/rmse_vs_raytraced", "RMSE against ray-traced AO"),
    ("/error/max_rel", "largest relative error"),
    ("/transfer_l2_error", "mean relative L2 of the transfer"),
    ("/max_error/estimate", "estimated error of the chosen setting"),
];

/// The summary of `command`'s `report` with the files it wrote (`outputs`:
/// option and path), one aligned line each, ending with a newline.
pub fn text(command: &str, outputs: &[(&'static str, PathBuf)], report: &Value) -> String {
    let mut rows: Vec<(String, String)> = Vec::new();
    if report.get("device").is_some() {
        rows.push(("computed".into(), computed(command, report)));
        let mut device = string(report, "/device");
        if let Some(adapter) = report.pointer("/adapter").and_then(Value::as_str) {
            device += &format!(" ({adapter})");
        }
        rows.push(("device".into(), device));
        mean_ao(report, &mut rows);
        if let Some((ms, what)) = TIMES
            .iter()
            .find_map(|(k, what)| Some((report.get(*k)?.as_f64()?, what)))
        {
            rows.push(("time".into(), format!("{} ({what})", ms_text(ms))));
        }
        if let Some(rate) = number(report, "/mrays_per_s").filter(|r| *r > 0.0) {
            rows.push(("rate".into(), format!("{rate:.2} Mrays/s")));
        }
        if let Some(fps) = number(report, "/fps") {
            rows.push(("rate".into(), format!("{fps:.1} frames/s")));
        }
        if let Some((e, what)) = ERRORS.iter().find_map(|(p, what)| Some((number(report, p)?, what))) {
            rows.push(("error".into(), format!("{e:.4} ({what})")));
        }
    } else {
        // Commands that compute nothing on a device (info, field build,
        // gen-assets): their scalar fields, lists by their length.
        if let Value::Object(map) = report {
            for (k, v) in map {
                let value = match v {
                    Value::String(s) => s.clone(),
                    Value::Array(a) => format!("{} entries", a.len()),
                    Value::Object(_) | Value::Null => continue,
                    other => other.to_string(),
                };
                rows.push((k.replace('_', " "), value));
            }
        }
    }
    for (i, (option, path)) in outputs.iter().enumerate() {
        let label = if i == 0 { "wrote" } else { "" };
        rows.push((label.into(), format!("{} ({option})", path.display())));
    }
    let width = rows.iter().map(|(l, _)| l.len()).max().unwrap_or(0);
    let mut out = String::new();
    for (label, value) in rows {
        let _ = writeln!(out, "{label:width$}  {value}");
    }
    out
}

/// "ao: raycast, 16 rays per point, 2,275 points": the command and what
/// its report says it computed.
fn computed(command: &str, r: &Value) -> String {
    let mut parts = Vec::new();
    for key in ["method", "estimator"] {
        if let Some(s) = r.get(key).and_then(Value::as_str) {
            parts.push(s.to_string());
        }
    }
    // (field, what one is, what several are)
    let counted: &[(&str, &str, &str)] = &[
        ("/spp", "sample per pixel", "samples per pixel"),
        ("/rays_per_point", "ray per point", "rays per point"),
        ("/points", "point", "points"),
        ("/rays", "ray", "rays"),
        ("/vertices", "vertex", "vertices"),
        ("/settings", "setting", "settings"),
    ];
    for (pointer, one, several) in counted {
        if let Some(n) = r.pointer(pointer).and_then(Value::as_u64) {
            parts.push(format!("{} {}", thousands(n), if n == 1 { one } else { several }));
        }
    }
    if let (Some(w), Some(h)) = (number(r, "/width"), number(r, "/height")) {
        parts.push(format!("{w}x{h}"));
    }
    if let Some(frames) = r.get("frames").and_then(Value::as_u64).filter(|f| *f > 1) {
        parts.push(format!("{frames} frames"));
    }
    match parts.is_empty() {
        true => command.to_string(),
        false => format!("{command}: {}", parts.join(", ")),
    }
}

/// Mean AO lines: over the used vertices, over the pixels hit, or over the
/// surface pixels, each saying what it is over.
fn mean_ao(r: &Value, rows: &mut Vec<(String, String)>) {
    if let Some(m) = number(r, "/per_vertex/mean_ao") {
        let over = r
            .pointer("/per_vertex/used_vertices")
            .and_then(Value::as_u64)
            .unwrap_or(0);
        let unused = r
            .pointer("/per_vertex/without_normal")
            .and_then(Value::as_u64)
            .unwrap_or(0);
        let apart = if unused > 0 {
            format!("; {} unused, left out", thousands(unused))
        } else {
            String::new()
        };
        rows.push((
            "mean AO".into(),
            format!("{m:.4} (over {} used vertices{apart})", thousands(over)),
        ));
    }
    if let Some(m) = number(r, "/image/mean_ao") {
        let hit = r.pointer("/image/pixels_hit").and_then(Value::as_u64).unwrap_or(0);
        rows.push(("mean AO".into(), format!("{m:.4} (over {} pixels hit)", thousands(hit))));
    }
    if let Some(m) = number(r, "/mean_ao") {
        let surface = r.get("surface_pixels").and_then(Value::as_u64).unwrap_or(0);
        rows.push((
            "mean AO".into(),
            format!("{m:.4} (over {} surface pixels)", thousands(surface)),
        ));
    }
}

fn number(r: &Value, pointer: &str) -> Option<f64> {
    r.pointer(pointer).and_then(Value::as_f64)
}

fn string(r: &Value, pointer: &str) -> String {
    match r.pointer(pointer) {
        Some(Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
        None => String::new(),
    }
}

/// Milliseconds as a person reads them: "0.36 ms", "128 ms", "4.21 s".
fn ms_text(ms: f64) -> String {
    if ms >= 10_000.0 {
        format!("{:.1} s", ms / 1e3)
    } else if ms >= 1_000.0 {
        format!("{:.2} s", ms / 1e3)
    } else if ms >= 10.0 {
        format!("{ms:.0} ms")
    } else {
        format!("{ms:.2} ms")
    }
}

/// 35947 as "35,947".
fn thousands(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aligned_lines_with_the_headline_figures() {
        let report = serde_json::json!({
            "device": "cpu", "adapter": null, "method": "raycast", "rays_per_point": 16, "points": 35947,
            "ao_ms": 128.6, "build_ms": 4.8, "mrays_per_s": 4.47,
            "per_vertex": {"file": "b.csv", "mean_ao": 0.9072, "used_vertices": 34834, "without_normal": 1113}
        });
        let text = text("ao", &[("--per-vertex", PathBuf::from("b.csv"))], &report);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines,
            [
                "computed  ao: raycast, 16 rays per point, 35,947 points",
                "device    cpu",
                "mean AO   0.9072 (over 34,834 used vertices; 1,113 unused, left out)",
                "time      129 ms (AO)",
                "rate      4.47 Mrays/s",
                "wrote     b.csv (--per-vertex)",
            ]
        );
    }

    #[test]
    fn one_is_singular() {
        let report = serde_json::json!({"device": "cpu", "rays": 1, "hits": 1});
        assert!(text("trace-rays", &[], &report).starts_with("computed  trace-rays: 1 ray\n"));
    }

    #[test]
    fn thousands_and_times() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1000), "1,000");
        assert_eq!(thousands(1234567), "1,234,567");
        assert_eq!(ms_text(0.361), "0.36 ms");
        assert_eq!(ms_text(4210.0), "4.21 s");
    }
}
