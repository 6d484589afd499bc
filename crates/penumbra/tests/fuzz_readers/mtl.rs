//! MTL: `parse_mtl` and `load_mtl`.

use std::path::Path;

use penumbra::scene::{Material, load_mtl, parse_mtl};
use proptest::collection::vec;
use proptest::prelude::*;

use crate::harness::{Budget, KIB, Reader, agree, call, fail, ok_or_bad_input, write_case};
use crate::inputs::{either, numbered, pick, text_lines, text_number, wildness};

/// A small MTL file OBJ and scene cases refer to.
pub const TINY_MTL: &str =
    "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\nd 0.5\nnewmtl glass\nTf 1 1 1\nNi 1.5\nillum 7\n";
/// An MTL file that does not parse: errors must name it.
pub const BAD_MTL: &str = "Kd 1 1 1\n";

const SEEDS: &[&[u8]] = &[
    include_bytes!("../../../../assets/raytrace/checker-spheres.mtl"),
    include_bytes!("../../../../assets/raytrace/checker-spheres-tessellated.mtl"),
    include_bytes!("../../../../assets/raytrace/cornell-mirror-glass.mtl"),
    include_bytes!("../../../../assets/raytrace/grazing.mtl"),
    include_bytes!("../../../../assets/raytrace/tir-block.mtl"),
    include_bytes!("../data/mtl/cornell.mtl"),
    TINY_MTL.as_bytes(),
    b"\xef\xbb\xbf# exporter\r\nnewmtl  glass  pane \r\n\tKa 0.1\r\n\tKd xyz 0.2 0.3 0.4 # comment\r\n\
      Ks spectral file.rfl 1\r\nKe 0 0 0\r\nTf xyz 1\r\nNs 96.0\r\nNi 0\r\nTr 0.75\r\nillum 4\r\nmap_Kd glass.png\r\n\
      bump -bm 1 n.png\r\nrefl -type sphere r.png\r\nfoo\r\nnewmtl mirror\r\nd 1\r\nTr 0.5\r\nillum 3\r\n\
      newmtl glass  pane\r\nKd 1\r\n",
];

const BUDGET: Budget = Budget::new(64, 256 * KIB);

pub static MTL: Reader = Reader::new("mtl", &["parse_mtl", "load_mtl"], check);

fn check(dir: &Path, input: &[u8]) -> Result<(), String> {
    let path = write_case(dir.join("case.mtl"), input)?;
    let text = String::from_utf8_lossy(input);
    let len = input.len();
    let mut warnings = Vec::new();
    let parsed = call("parse_mtl", BUDGET, len, || parse_mtl(&text, &mut warnings))?;
    ok_or_bad_input(&parsed, |materials| materials.iter().try_for_each(material_ok))?;
    if warnings.iter().any(|w| w.trim().is_empty()) {
        return fail(format!("an empty warning among {warnings:?}"));
    }
    let mut file_warnings = Vec::new();
    let loaded = call("load_mtl", BUDGET, len, || load_mtl(&path, &mut file_warnings))?;
    agree("parse_mtl", &parsed, "load_mtl", loaded, &path, |a, b| {
        a == b && warnings == file_warnings
    })
}

pub fn material_ok(m: &Material) -> Result<(), String> {
    for (field, c) in [("Ka", m.ka), ("Kd", m.kd), ("Ks", m.ks), ("Ke", m.ke), ("Tf", m.tf)] {
        if !c.is_finite() || c.min_element() < 0.0 {
            return fail(format!("material '{}': {field} {c} is not finite and >= 0", m.name));
        }
    }
    let scalars_ok = m.ns.is_finite()
        && m.ns >= 0.0
        && m.ni.is_finite()
        && m.ni > 0.0
        && (0.0..=1.0).contains(&m.dissolve)
        && m.illum <= 10;
    if scalars_ok {
        Ok(())
    } else {
        fail(format!("material out of range: {m:?}"))
    }
}

fn line(wild: f64) -> impl Strategy<Value = String> {
    // Colours, in CIE XYZ half of the time, with components up to f32's
    // largest (where the conversion to RGB may overflow).
    let component = either(
        wild,
        prop_oneof![
            3 => (0.0f32..2.0).prop_map(|x| x.to_string()),
            1 => pick(&["1e30", "1e38", "2e38", "3e38", "3.4028235e38", "-0", "0"]),
        ],
        text_number(),
    );
    let components = either(
        wild,
        prop_oneof![vec(component.clone(), 1), vec(component.clone(), 3)],
        vec(component, 0..5),
    );
    let colour = (pick(&["Ka", "Kd", "Ks", "Ke", "Tf"]), any::<bool>(), components)
        .prop_map(|(k, xyz, c)| format!("{k} {}{}", if xyz { "xyz " } else { "" }, c.join(" ")));
    let value = prop_oneof![4 => (0.0f32..1.0).prop_map(|x| x.to_string()), 1 => pick(&["0", "1", "1.5"])];
    let scalar =
        (pick(&["Ns", "Ni", "d", "Tr"]), either(wild, value, text_number())).prop_map(|(k, v)| format!("{k} {v}"));
    let illum = either(
        wild,
        (0u32..=10).prop_map(|i| i.to_string()),
        pick(&["11", "-1", "x", "1.5", "4294967296", "", "1 2"]),
    )
    .prop_map(|i| format!("illum {i}"));
    let other = either(
        wild,
        pick(&[
            "newmtl m2",
            "newmtl m",
            "newmtl a b",
            "map_Kd a.png",
            "bump -bm 1 n.png",
            "refl -type sphere r.png",
            "Ks spectral a.rfl",
            "# c",
            "",
            "foo",
        ]),
        pick(&[
            "newmtl", "Kd", "Ns -1", "d 2", "Tr -0.5", "Ni -1", "illum", "Kd 1 2", "Kd xyz",
        ]),
    );
    prop_oneof![3 => colour, 2 => scalar, 1 => illum, 1 => other]
}

/// Files at the worst of each statement's cost in memory per input byte.
fn heavy() -> Vec<Vec<u8>> {
    let long = format!("newmtl {}\n", "n".repeat(2_000));
    let texts = [
        numbered(3_000, |i| format!("newmtl m{i}\n")),
        "newmtl a\n".repeat(3_000),
        format!("newmtl a\n{}", numbered(3_000, |i| format!("k{i} 1\n"))),
        format!("newmtl a\n{}", "Kd 1 1 1\n".repeat(3_000)),
        format!("{long}{}", "Ni 0\n".repeat(2_000)),
        format!("{long}{}", "Tr 0.9\n".repeat(2_000)),
        long.repeat(20),
    ];
    texts.into_iter().map(String::into_bytes).collect()
}

pub fn seeds() -> Vec<Vec<u8>> {
    SEEDS.iter().map(|s| s.to_vec()).chain(heavy()).collect()
}

/// Mostly a `newmtl`, then random statements.
pub fn text() -> impl Strategy<Value = Vec<u8>> {
    wildness()
        .prop_flat_map(|wild| (prop::bool::weighted(1.0 - wild), text_lines(line(wild), 32)))
        .prop_map(|(named, statements)| {
            let mut text = if named { b"newmtl m\n".to_vec() } else { Vec::new() };
            text.extend(statements);
            text
        })
}
