//! OBJ: `parse_obj`, `parse_obj_file`, `load_obj`, `load_obj_file` and
//! `ObjFile::shading_normals`.

use std::path::Path;

use penumbra::scene::{Material, Mesh, NO_NORMAL, ObjFile, load_obj, load_obj_file, parse_obj, parse_obj_file};
use proptest::collection::vec;
use proptest::prelude::*;

use crate::harness::{Budget, MIB, Reader, agree, call, fail, finite, names_a_file, ok_or_bad_input, write_case};
use crate::inputs::{either, number, numbered, pick, text_lines, wildness};
use crate::mtl::{BAD_MTL, TINY_MTL, material_ok};

/// A small OBJ file with what shading reads.
pub const TINY_OBJ: &str = "mtllib tiny.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nusemtl red\ns 1\n\
                        f 1//1 2//1 3//1\nusemtl blue\nf 2 4 3\n";

const SEEDS: &[&[u8]] = &[
    include_bytes!("../../../../assets/open-plane.obj"),
    include_bytes!("../../../../assets/wall-on-floor.obj"),
    include_bytes!("../../../../assets/cube-with-hole.obj"),
    include_bytes!("../../../../assets/cylindrical-well.obj"),
    include_bytes!("../../../../assets/closed-box.obj"),
    include_bytes!("../../../../assets/raytrace/tir-block.obj"),
    include_bytes!("../../../../assets/raytrace/checker-spheres.obj"),
    include_bytes!("../data/mtl/cornell.obj"),
    TINY_OBJ.as_bytes(),
    b"mtllib a.mtl missing.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nvn 0 0 -1\n\
      o first\nusemtl red\ns off\nf 1/1/1 2/1/1 3/1/1 4/1/1\ng second part\nusemtl blue\ns 2\nf -4//-2 -3//-2 -2//-1\n\
      usemtl glass\ns 0\nf 1 3 4\nusemtl nowhere\ncurv 0 1 1 2\nl 1 2\np 3\nfoo bar\n",
    b"\xef\xbb\xbfv 1e-3 0 0\r\nv 0 3e3 0\r\nv 0 0 -3e3\r\nf 3 2 1 # comment\r\n",
];

const BUDGET: Budget = Budget::new(64, MIB);

pub static OBJ: Reader = Reader::new(
    "obj",
    &[
        "parse_obj",
        "parse_obj_file",
        "load_obj",
        "load_obj_file",
        "ObjFile::shading_normals",
    ],
    check,
)
.with_setup(setup);

fn setup(dir: &Path) -> std::io::Result<()> {
    std::fs::write(dir.join("a.mtl"), TINY_MTL)?;
    std::fs::write(dir.join("tiny.mtl"), TINY_MTL)?;
    std::fs::write(dir.join("bad.mtl"), BAD_MTL)?;
    std::fs::write(
        dir.join("tir-block.mtl"),
        include_str!("../../../../assets/raytrace/tir-block.mtl"),
    )?;
    std::fs::write(
        dir.join("checker-spheres.mtl"),
        include_str!("../../../../assets/raytrace/checker-spheres.mtl"),
    )?;
    std::fs::write(
        dir.join("CornellBox-Original.mtl"),
        include_str!("../data/mtl/cornell.mtl"),
    )
}

fn check(dir: &Path, input: &[u8]) -> Result<(), String> {
    let path = write_case(dir.join("case.obj"), input)?;
    let text = String::from_utf8_lossy(input);
    let len = input.len();
    let parsed = call("parse_obj", BUDGET, len, || parse_obj(&text))?;
    ok_or_bad_input(&parsed, mesh_ok)?;
    ok_or_bad_input(
        &call("parse_obj_file", BUDGET, len, || parse_obj_file(&text, Some(dir)))?,
        |obj| obj_file_ok(obj, len),
    )?;
    let loaded = call("load_obj", BUDGET, len, || load_obj(&path))?;
    agree("parse_obj", &parsed, "load_obj", loaded, &path, PartialEq::eq)?;
    match call("load_obj_file", BUDGET, len, || load_obj_file(&path))? {
        Ok(obj) => obj_file_ok(&obj, len),
        // The OBJ or an MTL file it names.
        Err(e) => names_a_file(&e),
    }
}

pub fn mesh_ok(mesh: &Mesh) -> Result<(), String> {
    for (i, &p) in mesh.positions.iter().enumerate() {
        finite(&format!("vertex {}", i + 1), p)?;
    }
    let n = mesh.positions.len();
    if mesh.triangles.is_empty() {
        return fail("a mesh without triangles".into());
    }
    if let Some(t) = mesh.triangles.iter().find(|t| t.iter().any(|&v| v as usize >= n)) {
        return fail(format!("triangle {t:?} refers beyond the {n} vertices"));
    }
    let mut next = 0;
    for o in &mesh.objects {
        if o.triangles.start != next || o.triangles.end <= o.triangles.start {
            return fail(format!(
                "object '{}' covers {:?}, expected to start at {next}",
                o.name, o.triangles
            ));
        }
        next = o.triangles.end;
    }
    if next as usize != mesh.triangles.len() {
        return fail(format!("objects cover {next} of {} triangles", mesh.triangles.len()));
    }
    Ok(())
}

/// `obj`, read from `len` bytes, and its shading normals.
pub fn obj_file_ok(obj: &ObjFile, len: usize) -> Result<(), String> {
    mesh_ok(&obj.mesh)?;
    let n = obj.mesh.triangles.len();
    let lens = [
        obj.triangle_materials.len(),
        obj.triangle_faces.len(),
        obj.corner_normals.len(),
        obj.smoothing.len(),
    ];
    if lens != [n; 4] {
        return fail(format!("per-triangle arrays of {lens:?} for {n} triangles"));
    }
    if obj.materials.first() != Some(&Material::default_surface()) {
        return fail("materials[0] is not the default surface".into());
    }
    obj.materials.iter().try_for_each(material_ok)?;
    if let Some(m) = obj
        .triangle_materials
        .iter()
        .find(|&&m| m as usize >= obj.materials.len())
    {
        return fail(format!("triangle material {m} of {}", obj.materials.len()));
    }
    for (i, &v) in obj.normals.iter().enumerate() {
        finite(&format!("normal {}", i + 1), v)?;
    }
    let nn = obj.normals.len();
    if let Some(c) = obj
        .corner_normals
        .iter()
        .find(|c| c.iter().any(|&k| k != NO_NORMAL && k as usize >= nn))
    {
        return fail(format!("corner normals {c:?} of {nn} normals"));
    }
    let (normals, corners) =
        call("ObjFile::shading_normals", BUDGET, len, || Ok(obj.shading_normals()))?.map_err(|e| e.to_string())?;
    if let Some(v) = normals
        .iter()
        .find(|v| !v.is_finite() || (v.length() - 1.0).abs() > 1e-3)
    {
        return fail(format!("shading normal {v} is not a finite unit vector"));
    }
    let in_range = |c: &Option<[u32; 3]>| c.is_none_or(|c| c.iter().all(|&k| (k as usize) < normals.len()));
    if corners.len() != n || !corners.iter().all(in_range) {
        return fail("shading normal corners out of range".into());
    }
    Ok(())
}

/// OBJ statements: vertices and faces (indices near the vertex count,
/// around 0 and beyond u32), and the rest of what the parser reads.
fn line(wild: f64) -> impl Strategy<Value = String> {
    let odd_index = pick(&[
        "0",
        "9",
        "-9",
        "4294967295",
        "4294967296",
        "4294967297",
        "-4294967297",
        "99999999999999999999999",
        "-99999999999999999999999",
        "x",
        "",
        "1.5",
        "+2",
        "--1",
        "1e3",
    ]);
    let vertex = either(
        wild,
        prop_oneof![1i64..=8, -8i64..=-1].prop_map(|i| i.to_string()),
        odd_index.clone(),
    );
    let normal = either(
        wild,
        prop_oneof![1i64..=4, -4i64..=-1].prop_map(|i| i.to_string()),
        odd_index,
    );
    let corner = (vertex, 0u8..4, normal, 1u8..9).prop_map(|(v, form, n, t)| match form {
        0 => v,
        1 => format!("{v}/{t}"),
        2 => format!("{v}//{n}"),
        _ => format!("{v}/{t}/{n}"),
    });
    let corners = either(wild, vec(corner.clone(), 3..8), vec(corner, 0..3));
    let point = (
        number(wild, -100.0, 100.0),
        number(wild, -100.0, 100.0),
        number(wild, -100.0, 100.0),
    );
    let statement = either(
        wild,
        pick(&[
            "o a",
            "g",
            "g b c",
            "s 1",
            "s off",
            "s 0",
            "s 4294967294",
            "usemtl red",
            "usemtl glass",
            "usemtl",
            "usemtl missing",
            "mtllib a.mtl",
            "mtllib missing.mtl tiny.mtl",
            "mtllib .",
            "vt 0 0",
            "l 1 2",
            "p 1",
            "curv 0 1",
            "bmat u 1",
            "# comment",
            "",
            "v 0 0 0 1",
        ]),
        pick(&[
            "s 4294967295",
            "s -1",
            "s",
            "mtllib bad.mtl",
            "v 1 2",
            "v",
            "f",
            "vn 0 0",
            "f 1 2",
            "f 1 x 2",
        ]),
    );
    prop_oneof![
        4 => point.clone().prop_map(|(x, y, z)| format!("v {x} {y} {z}")),
        1 => point.prop_map(|(x, y, z)| format!("vn {x} {y} {z}")),
        4 => corners.prop_map(|c| format!("f {}", c.join(" "))),
        2 => statement,
    ]
}

/// Files at the worst of each statement's cost in memory per input byte.
fn heavy() -> Vec<Vec<u8>> {
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n";
    let texts = [
        format!("{tri}f {}\n", "1 2 3 ".repeat(10_000)),
        format!("{tri}{}", "f 1 2 3\n".repeat(5_000)),
        format!("{tri}{}", "f 1//1 2//1 3//1\n".repeat(2_000)),
        format!("{tri}f 1 2 3\n{}", numbered(5_000, |i| format!("k{i}\n"))),
        format!("{tri}f 1 2 3\nmtllib {}\n", numbered(2_000, |i| format!("m{i} "))),
        format!("{tri}{}", numbered(2_000, |i| format!("usemtl u{i}\nf 1 2 3\n"))),
        format!("{tri}{}", numbered(2_000, |i| format!("o o{i}\nf 1 2 3\n"))),
        format!("{tri}{}", numbered(2_000, |i| format!("s {}\nf 1 2 3\n", i + 1))),
        format!("{}f 1 2 3\n", "v 0 0 0\n".repeat(10_000)),
    ];
    texts.into_iter().map(String::into_bytes).collect()
}

pub fn seeds() -> Vec<Vec<u8>> {
    SEEDS.iter().map(|s| s.to_vec()).chain(heavy()).collect()
}

/// 8 vertices and 4 normals, then random statements.
pub fn text() -> impl Strategy<Value = Vec<u8>> {
    let coordinate = || -10.0f32..10.0;
    let point = (coordinate(), coordinate(), coordinate());
    (wildness(), vec(point, 12))
        .prop_flat_map(|(wild, points)| (Just(points), text_lines(line(wild), 48)))
        .prop_map(|(points, statements)| {
            let header = points.iter().enumerate().map(|(i, (x, y, z))| {
                let keyword = if i < 8 { "v" } else { "vn" };
                format!("{keyword} {x} {y} {z}\n")
            });
            let mut text = header.collect::<String>().into_bytes();
            text.extend(statements);
            text
        })
}
