//! Camera paths: `CameraPath::parse` and `load`.

use std::path::Path;

use penumbra::scene::CameraPath;
use proptest::prelude::*;

use crate::harness::{Budget, KIB, Reader, call, fail, names, ok_or_bad_input, write_case};
use crate::inputs::{either, number, pick, text_lines, wildness};

const SEEDS: &[&[u8]] = &[
    b"# a path\n0,0,5 0,0,0 40\n\n10,0,5 10,0,0 60\n",
    b"\xef\xbb\xbf0,1,4 0,1,0 45\r\n0.5,1,3.8 0.1,1,0 45 # turn\r\n1,1.2,3.5 0.2,1,0 50\r\n",
    b"1e-3,2e-3,3e-3\t-1e3,-2e3,-3e3\t179.9\n-0,0,1 0,0,0 0.001\n",
];

const BUDGET: Budget = Budget::new(16, 64 * KIB);

pub static CAMERA_PATH: Reader = Reader::new("camera_path", &["CameraPath::parse", "CameraPath::load"], check);

fn check(dir: &Path, input: &[u8]) -> Result<(), String> {
    let path = write_case(dir.join("case.path"), input)?;
    let text = String::from_utf8_lossy(input);
    let len = input.len();
    ok_or_bad_input(
        &call("CameraPath::parse", BUDGET, len, || CameraPath::parse(&text))?,
        camera_path_ok,
    )?;
    match call("CameraPath::load", BUDGET, len, || CameraPath::load(&path))? {
        Ok(p) => camera_path_ok(&p),
        Err(e) => names(&e, &path),
    }
}

fn camera_path_ok(path: &CameraPath) -> Result<(), String> {
    let CameraPath::Keys(keys) = path else {
        return fail("a parsed path that is not keyframes".into());
    };
    if keys.is_empty() {
        return fail("a path without keyframes".into());
    }
    for k in keys {
        k.validate().map_err(|e| format!("keyframe {k:?}: {e}"))?;
    }
    for frame in 0..7 {
        let c = path.at(frame, 7);
        if !(c.eye.is_finite() && c.target.is_finite() && c.fov_degrees.is_finite()) {
            return fail(format!("frame {frame} of 7 is {c:?}"));
        }
    }
    Ok(())
}

fn line(wild: f64) -> impl Strategy<Value = String> {
    let n = || number(wild, -10.0, 10.0);
    let separator = either(wild, pick(&[","]), pick(&[", ", " ,", ";", "", ",,"]));
    let v3 = (n(), n(), n(), separator).prop_map(|(x, y, z, sep)| format!("{x}{sep}{y}{sep}{z}"));
    let gap = either(wild, pick(&[" ", "\t", "  "]), pick(&["", ",", " # "]));
    let other = either(
        wild,
        pick(&["# comment", "", "   ", "0,0,1 0,0,0 45 # c"]),
        pick(&[
            "0,0,0 0,0,0 45",
            "0,0,1 0,0,0 180",
            "0,0,1 0,0,0 0",
            "0,0 0,0,0 45",
            "0,0,1 0,0,0",
            "x",
        ]),
    );
    prop_oneof![
        6 => (v3.clone(), v3, number(wild, 1.0, 179.0), gap).prop_map(|(e, t, f, sep)| format!("{e}{sep}{t}{sep}{f}")),
        1 => other,
    ]
}

pub fn seeds() -> Vec<Vec<u8>> {
    let heavy = [
        "0,0,1 0,0,0 1\n".repeat(5_000),
        format!("0,0,1 0,0,0 1\n{}", "#\n".repeat(5_000)),
    ];
    SEEDS
        .iter()
        .map(|s| s.to_vec())
        .chain(heavy.map(String::into_bytes))
        .collect()
}

/// Files of random keyframe lines.
pub fn text() -> impl Strategy<Value = Vec<u8>> {
    wildness().prop_flat_map(|wild| text_lines(line(wild), 12))
}
