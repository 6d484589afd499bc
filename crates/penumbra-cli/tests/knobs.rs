//! Every numeric knob at both ends of its allowed range, and just outside:
//! inside, exit 0, an answer that keeps the invariants its inputs fix
//! (`answer_holds`) and a JSON report whose numbers are
//! finite (serde writes a non-finite number as null: the figures each
//! command must report are checked to be numbers); outside, exit 2 naming
//! the option and its range. On the CPU, with an 8-vertex mesh
//! (`wall-on-floor.obj`) and small images, so the top ends stay short. A
//! top end that is only a matter of time (2^20 rays a point are allowed,
//! but are minutes on a big mesh) is run here where it is seconds; where
//! even that is minutes, `None` marks it and only the value past it is run.

mod common;

use common::cli::{TempDir, asset_s, pen, write_probe};

/// A knob's row: the command (a key of `base`), the option, its lowest and
/// highest allowed values (`None`: too slow to run here), and values just
/// outside (refused).
struct Knob {
    command: &'static str,
    option: &'static str,
    low: Option<&'static str>,
    high: Option<&'static str>,
    outside: &'static [&'static str],
}

const fn k(
    command: &'static str,
    option: &'static str,
    low: Option<&'static str>,
    high: Option<&'static str>,
    outside: &'static [&'static str],
) -> Knob {
    Knob {
        command,
        option,
        low,
        high,
        outside,
    }
}

const KNOBS: &[Knob] = &[
    k("ao", "rays", Some("1"), Some("1048576"), &["0", "1048577", "-1"]),
    k("ao", "radius", Some("1e-30"), Some("inf"), &["0", "-1", "nan"]),
    k("ao", "warmup", Some("0"), Some("3"), &["1001", "-1"]),
    k("ao", "repeat", Some("1"), Some("3"), &["0", "1001", "-1"]),
    k("ao-field", "frames", Some("1"), None, &["0", "100001"]),
    k("ao-field", "positions", Some("1"), None, &["0", "65536"]),
    k("ao-field", "res", Some("2"), Some("512"), &["1", "513"]),
    k("ao-field", "bits", Some("1"), Some("32"), &["0", "33"]),
    k("ao-image", "fov", Some("1e-3"), Some("179.99"), &["0", "180"]),
    k("ssao", "spp", Some("1"), Some("4096"), &["0", "4097", "-1"]),
    k("ssao", "radius", Some("1e-30"), Some("1e30"), &["0", "inf", "nan"]),
    k("ssao", "bias", Some("0"), Some("1e30"), &["-1", "inf"]),
    k("ssao", "filter-depth", Some("1e-30"), Some("1e30"), &["0", "inf"]),
    k("ssao", "reference-rays", Some("0"), Some("4096"), &["1048577", "-1"]),
    k(
        "ssao",
        "screen-reference-spp",
        Some("0"),
        Some("4096"),
        &["1048577", "-1"],
    ),
    k("ssao-exp", "sigma", Some("1e-30"), Some("1e30"), &["0", "inf"]),
    k("ssao-raymarch", "steps", Some("1"), Some("4"), &["0", "-1"]),
    k("prt", "order", Some("1"), Some("16"), &["0", "17"]),
    k("prt", "ring", Some("1"), Some("2"), &["0", "3"]),
    k("prt", "group-size", Some("1"), Some("4096"), &["0", "4097"]),
    // Above the mesh's triangles, the coarse mesh is the mesh (it aborted
    // the process in meshoptimizer before).
    k("prt", "coarse", Some("1"), Some("4294967295"), &["0"]),
    k("prt", "coarse-tolerance", Some("0"), Some("1e30"), &["-1", "inf"]),
    // More poses than frames: every frame played is a pose.
    k("prt", "coarse-poses", Some("1"), Some("4294967295"), &["0"]),
    k("prt", "frames", Some("1"), None, &["0", "100001", "4294967295"]),
    k("prt", "exposure", Some("1e-30"), Some("1e30"), &["0", "inf"]),
    k("trace", "tile", Some("4"), Some("65536"), &["3", "-1"]),
    k("trace", "split-factor", Some("4"), Some("65536"), &["1", "5", "-1"]),
    k("raytrace", "max-depth", Some("0"), Some("16"), &["17", "-1"]),
    k("raytrace", "spp", Some("1"), Some("64"), &["0", "4097", "-1"]),
    k("raytrace", "frames", Some("1"), None, &["0", "100001", "-1"]),
    k("raytrace", "exposure", Some("1e-30"), Some("1e30"), &["0", "nan"]),
    k("bounded", "epsilon", Some("0"), Some("1e30"), &["-1", "inf"]),
    k("bounded", "floor", Some("1e-30"), Some("1e30"), &["0"]),
    k("bounded", "memory-mb", Some("1"), Some("4294967295"), &["0"]),
    k("bounded", "check", Some("1"), Some("64"), &["0", "-1"]),
];

/// The command each row varies one option of, and the report's figures
/// that must be numbers.
fn base(command: &str) -> (&'static str, &'static [&'static str]) {
    match command {
        "ao" => (
            "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {out}.csv",
            &["ao_ms"],
        ),
        "ao-field" => (
            "ao --mesh {mesh} --receiver {mesh} --method field --rays 4 --positions 4 --res 4 \
             --per-vertex {out}.csv",
            &["ao_ms"],
        ),
        "ao-image" => (
            "ao --mesh {mesh} --method raycast --rays 4 --image {out}.png --width 8 --height 8",
            &["ao_ms"],
        ),
        "ssao" | "ssao-exp" | "ssao-raymarch" => (
            match command {
                "ssao" => "ssao --mesh {mesh} --estimator importance {ssao}",
                "ssao-exp" => "ssao --mesh {mesh} --estimator importance --measure exp {ssao}",
                _ => "ssao --mesh {mesh} --estimator raymarch {ssao}",
            },
            &["ao_ms"],
        ),
        "prt" => (
            "prt --mesh {mesh} --env {probe} --width 16 --height 16 --out {out}.png",
            &["fps", "vertices"],
        ),
        "trace" => ("trace --mesh {mesh} --width 16 --height 16", &["mrays_per_s"]),
        "raytrace" => (
            "raytrace --method whitted --mesh {mesh} --width 8 --height 8 --out {out}.png",
            &["render_ms", "mrays_per_s"],
        ),
        "bounded" => (
            "raytrace --method bounded --mesh {mesh} --width 8 --height 8 --out {out}.png",
            &["render_ms", "mrays_per_s"],
        ),
        _ => unreachable!("{command}"),
    }
}

/// `line` with `--option value`: replacing the option's value where the
/// base line gives one.
fn with_option(line: &str, option: &str, value: &str) -> String {
    let flag = format!("--{option} ");
    match line.find(&flag) {
        Some(i) => {
            let start = i + flag.len();
            let end = line[start..].find(' ').map_or(line.len(), |e| start + e);
            format!("{}{value}{}", &line[..start], &line[end..])
        }
        None => format!("{line} --{option} {value}"),
    }
}

/// What an in-range run's answer must satisfy, whatever the knob's value:
/// an invariant its inputs fix (the 8 vertices of `wall-on-floor.obj`, the
/// image's size, ray-cast AO a whole number of escaped rays over the rays
/// cast, hits among the primary rays, a lit Whitted image).
fn answer_holds(knob: &Knob, value: &str, json: &serde_json::Value, out: &str) -> Result<(), String> {
    let image = |w: u32, h: u32| -> Result<image::RgbaImage, String> {
        let img = image::open(format!("{out}.png"))
            .map_err(|e| format!("{out}.png: {e}"))?
            .to_rgba8();
        match img.dimensions() == (w, h) {
            true => Ok(img),
            false => Err(format!("{out}.png is {:?}, not {w}x{h}", img.dimensions())),
        }
    };
    match knob.command {
        "ao" | "ao-field" => {
            let csv = std::fs::read_to_string(format!("{out}.csv")).map_err(|e| format!("{out}.csv: {e}"))?;
            let rays: f64 = match (knob.command, knob.option) {
                ("ao", "rays") => value.parse().unwrap(),
                ("ao", _) => 4.0,
                _ => 0.0,
            };
            let rows: Vec<&str> = csv.lines().collect();
            if rows.len() != 8 {
                return Err(format!("{} rows for 8 vertices", rows.len()));
            }
            for (i, row) in rows.iter().enumerate() {
                let (index, ao) = row.split_once(',').ok_or(format!("row {row:?}"))?;
                let ao: f64 = ao.parse().map_err(|_| format!("row {row:?}"))?;
                let whole = rays == 0.0 || ((ao * rays).round() - ao * rays).abs() < 1e-6 * rays.max(1.0);
                if index != i.to_string() || !(0.0..=1.0).contains(&ao) || !whole {
                    return Err(format!("row {row:?}: AO outside [0, 1] or not escaped/{rays}"));
                }
            }
            Ok(())
        }
        "ao-image" => image(8, 8).map(drop),
        "ssao" | "ssao-exp" | "ssao-raymarch" => {
            let mean = json["mean_ao"].as_f64().ok_or("no mean_ao")?;
            match (0.0..=1.0).contains(&mean) {
                true => image(16, 16).map(drop),
                false => Err(format!("mean_ao {mean}")),
            }
        }
        "prt" => image(16, 16).map(drop),
        "trace" => {
            let (hits, rays) = (
                json["hits"].as_u64().ok_or("no hits")?,
                json["rays"].as_u64().ok_or("no rays")?,
            );
            match rays == 256 && (1..=rays).contains(&hits) {
                true => Ok(()),
                false => Err(format!("{hits} hits of {rays} rays (16x16, the scene framed)")),
            }
        }
        "raytrace" | "bounded" => {
            let img = image(8, 8)?;
            // An exposure of 1e-30 makes any radiance black.
            let dark = knob.option == "exposure" && value.parse::<f64>().is_ok_and(|e| e < 1e-6);
            match dark || img.pixels().any(|p| p[0] > 0 || p[1] > 0 || p[2] > 0) {
                true => Ok(()),
                false => Err("every pixel black".into()),
            }
        }
        other => Err(format!("no answer check for {other}")),
    }
}

/// The `--long-options` a message spells.
fn flags_in(text: &str) -> impl Iterator<Item = &str> {
    text.match_indices("--").filter_map(|(i, _)| {
        let rest = &text[i + 2..];
        let end = rest
            .find(|c: char| !(c.is_ascii_lowercase() || c == '-'))
            .unwrap_or(rest.len());
        (end > 0).then(|| &text[i..i + 2 + end])
    })
}

#[test]
fn every_knob_at_both_ends_answers_or_is_refused_with_its_range() {
    let d = TempDir::new("knobs");
    let mesh = asset_s("wall-on-floor.obj");
    let probe = write_probe(&d, [2.0, 1.8, 1.5], [0.2, 0.2, 0.25]);
    let ssao = "--spp 4 --radius 0.5 --width 16 --height 16 --out {out}.png --reference-rays 4 \
                --screen-reference-spp 4";
    let mut failures = Vec::new();
    let mut helps = std::collections::HashMap::new();
    for (i, knob) in KNOBS.iter().enumerate() {
        let (line, figures) = base(knob.command);
        let line = line.replace("{ssao}", ssao);
        let out = d.p(&format!("out{i}"));
        let vars = [("mesh", mesh.as_str()), ("out", &out), ("probe", &probe)];
        let values = knob.low.iter().chain(&knob.high).map(|v| (v, true));
        for (value, allowed) in values.chain(knob.outside.iter().map(|v| (v, false))) {
            let full = format!("{} --device cpu --json", with_option(&line, knob.option, value));
            let r = pen(&full, &vars);
            let what = format!("{} --{} {value}", knob.command, knob.option);
            println!("{what}: exit {}", r.code);
            let flag = format!("--{}", knob.option);
            let fine = match (allowed, r.code) {
                (true, 0) => {
                    let json = r.json();
                    let answer = answer_holds(knob, value, &json, &out);
                    if let Err(why) = &answer {
                        println!("  answer: {why}");
                    }
                    answer.is_ok() && figures.iter().all(|f| json[f].as_f64().is_some_and(f64::is_finite))
                }
                (false, 2) => {
                    // Every option the message names is one `--help` lists.
                    let sub = base(knob.command).0.split(' ').next().unwrap();
                    let help = helps
                        .entry(sub)
                        .or_insert_with(|| pen(&format!("{sub} --help"), &[]).stdout);
                    let unknown: Vec<&str> = flags_in(&r.stderr).filter(|f| !help.contains(f)).collect();
                    if !unknown.is_empty() {
                        println!("  names {unknown:?}, not in `{sub} --help`");
                    }
                    unknown.is_empty()
                        && r.stderr.contains(&flag)
                        && ["must", "need"].iter().any(|w| r.stderr.contains(w))
                }
                _ => false,
            };
            if !fine {
                failures.push(format!("{what}\n{}", r.describe()));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}
