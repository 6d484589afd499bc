//! PLY: `parse_ply`, `load_ply`, and `load_mesh` / `load_mesh_file` of a
//! `.ply` (content and extension both say PLY), with the shading normals a
//! shaded scene computes.

use std::path::Path;

use glam::Vec3;
use penumbra::scene::{Mesh, ObjFile, load_mesh, load_mesh_file, load_ply, parse_ply, procedural};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::{Index, select};

use crate::harness::{Budget, MIB, Reader, agree, call, fail, finite, ok_or_bad_input, write_case};
use crate::inputs::{SPECIAL_F32, either, pick, wildness};
use crate::obj::obj_file_ok;
use crate::write::{Ply, ply, ply_strips, stripify};

const BUDGET: Budget = Budget::new(64, MIB);

pub static PLY: Reader = Reader::new(
    "ply",
    &[
        "parse_ply",
        "load_ply",
        "load_mesh(ply)",
        "load_mesh_file(ply)",
        "ObjFile::shading_normals",
    ],
    check,
);

fn check(dir: &Path, input: &[u8]) -> Result<(), String> {
    let path = write_case(dir.join("case.ply"), input)?;
    let len = input.len();
    let parsed = call("parse_ply", BUDGET, len, || parse_ply(input))?;
    ok_or_bad_input(&parsed, |f| ply_ok(f, len))?;
    let same = |a: &ObjFile, b: &ObjFile| {
        a.mesh == b.mesh && a.normals == b.normals && a.vertex_colors == b.vertex_colors && a.warnings == b.warnings
    };
    let loaded = call("load_ply", BUDGET, len, || load_ply(&path))?;
    agree("parse_ply", &parsed, "load_ply", loaded, &path, same)?;
    let file = call("load_mesh_file(ply)", BUDGET, len, || load_mesh_file(&path))?;
    agree("parse_ply", &parsed, "load_mesh_file", file, &path, same)?;
    let meshes = parsed.map(|f| f.mesh);
    let mesh = call("load_mesh(ply)", BUDGET, len, || load_mesh(&path))?;
    agree("parse_ply", &meshes, "load_mesh", mesh, &path, PartialEq::eq)
}

/// An ObjFile's checks, and colours: one per vertex, finite.
fn ply_ok(f: &ObjFile, len: usize) -> Result<(), String> {
    obj_file_ok(f, len)?;
    if let Some(colours) = &f.vertex_colors {
        if colours.len() != f.mesh.positions.len() {
            return fail(format!(
                "{} colours for {} vertices",
                colours.len(),
                f.mesh.positions.len()
            ));
        }
        colours.iter().try_for_each(|&c| finite("colour", c))?;
    }
    if !f.normals.is_empty() && f.normals.len() != f.mesh.positions.len() {
        return fail(format!(
            "{} normals for {} vertices",
            f.normals.len(),
            f.mesh.positions.len()
        ));
    }
    Ok(())
}

fn tetrahedron() -> Mesh {
    let p = Vec3::new;
    let positions = vec![p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(0.0, 1.0, 0.0), p(0.0, 0.0, 1.0)];
    Mesh::new(positions, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]).unwrap_or_else(|e| panic!("{e}"))
}

/// Quads and a pentagon, CRLF, float colours, a list element before the
/// faces and faces with a flag before their `vertex_index` list.
const HAND: &str = "ply\r\nformat ascii 1.0\r\ncomment by hand\r\nobj_info none\r\nelement vertex 5\r\n\
    property float x\r\nproperty float y\r\nproperty float z\r\nproperty float nx\r\nproperty float ny\r\n\
    property float nz\r\nproperty float red\r\nproperty float green\r\nproperty float blue\r\n\
    element range_grid 2\r\nproperty list uchar int vertex_indices\r\nelement face 2\r\nproperty uchar flags\r\n\
    property list ushort uint vertex_index\r\nend_header\r\n0 0 0 0 0 1 1 0 0\r\n1 0 0 0 0 2 0 1 0\r\n\
    1 1 0 0 0 1 0 0 1\r\n0 1 0 0 0 1 0.5 0.5 0.5\r\n0.5 1.5 0 0 0 1 0 0 0\r\n3 0 1 2\r\n0\r\n7 5 0 1 2 4 3\r\n\
    0 3 0 2 3\r\n";

/// The header of a binary file of `nv` vertices of `uchar x y z` and one
/// face of `n` uchar indices: the most output per input byte PLY allows
/// (12 bytes a vertex for 3; a triangle and its shading for each index).
/// As many triangles come from a `tristrips` element of one strip.
fn dense(nv: usize, n: usize, element: &str) -> Vec<u8> {
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {nv}\nproperty uchar x\nproperty uchar y\n\
         property uchar z\nelement {element} 1\nproperty list uint uchar vertex_indices\nend_header\n"
    )
    .into_bytes();
    for i in 0..nv {
        b.extend([(i % 7) as u8, (i / 7 % 5) as u8, (i % 3) as u8]);
    }
    b.extend((n as u32).to_le_bytes());
    b.extend((0..n).map(|i| (i % nv) as u8));
    b
}

/// ASCII and binary seeds (text and binary edits suit them differently).
pub fn seeds(ascii: bool) -> Vec<Vec<u8>> {
    let meshes = [tetrahedron(), procedural::cube_with_hole()];
    let formats: &[Ply] = if ascii {
        &[Ply::Ascii]
    } else {
        &[Ply::LittleEndian, Ply::BigEndian]
    };
    let mut out = Vec::new();
    for mesh in &meshes {
        for &format in formats {
            out.push(ply(mesh, format, false));
            out.push(ply(mesh, format, true));
            // Strips with restarts and repeated vertices, and faces.
            let half = mesh.triangles.len() / 2;
            let strips = stripify(&mesh.triangles[half..]);
            out.push(ply_strips(
                &mesh.positions,
                &mesh.triangles[..half],
                &strips.list,
                format,
            ));
        }
    }
    if ascii {
        out.push(HAND.as_bytes().to_vec());
        let polygon = (0..30_000).map(|i| format!(" {}", i % 3)).collect::<String>();
        out.push(
            format!(
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                 element face 1\nproperty list uint int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n30000{polygon}\n"
            )
            .into_bytes(),
        );
    } else {
        out.push(dense(200, 20_000, "face"));
        out.push(dense(20_000, 3, "face"));
        out.push(dense(200, 20_000, "tristrips"));
    }
    out
}

const TYPES: &[&str] = &[
    "char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "float32", "float64",
];
const ODD_TYPES: &[&str] = &["float7", "list", "string", "", "Float", "int64"];
const INTEGERS: &[&str] = &["uchar", "ushort", "int", "uint", "char", "short", "uint8", "int32"];

/// A property's name and type text (a list's: "list COUNT ITEM").
type Prop = (String, String);

/// A header of the elements a mesh has (and maybe one more), odd in places
/// with the file's wildness, then a body of values for it (at most 64
/// records an element) in its encoding, maybe cut short.
pub fn structured() -> impl Strategy<Value = Vec<u8>> {
    wildness()
        .prop_flat_map(|wild| {
            let ty = move |plain: &'static [&'static str]| either(wild, pick(plain), pick(ODD_TYPES));
            let vertex = (
                ty(&["float", "double", "float32", "int", "short", "uchar"]),
                vec((pick(&["confidence", "intensity", "s"]), ty(TYPES)), 0..3),
                any::<bool>(),
                proptest::option::of(ty(&["uchar", "float", "ushort"])),
            );
            let face = (
                ty(INTEGERS),
                ty(INTEGERS),
                either(
                    wild,
                    pick(&["vertex_indices", "vertex_index"]),
                    pick(&["vertices", "x"]),
                ),
                vec((pick(&["flags", "texnumber"]), ty(TYPES)), 0..2),
                pick(&["face", "face", "tristrips"]),
            );
            let counts = (
                either(wild, 3u64..12, select(vec![0u64, 1, 2, 255, 65536, 1 << 32, u64::MAX])),
                either(wild, 1u64..8, select(vec![0u64, 1000, 1 << 31, u64::MAX])),
            );
            (
                Just(wild),
                either(wild, 0usize..3, 0usize..6),
                vertex,
                face,
                counts,
                any::<bool>(),
                any::<u64>(),
                (prop::bool::weighted(wild), any::<Index>()),
            )
        })
        .prop_map(|(wild, encoding, vertex, face, counts, extra, seed, cut)| {
            let (coordinate, extras, normals, colour) = vertex;
            let mut vertex_props: Vec<Prop> = ["x", "y", "z"]
                .iter()
                .map(|n| (n.to_string(), coordinate.clone()))
                .collect();
            vertex_props.extend(extras);
            if normals {
                vertex_props.extend(["nx", "ny", "nz"].iter().map(|n| (n.to_string(), "float".to_string())));
            }
            if let Some(c) = colour {
                vertex_props.extend(["red", "green", "blue"].iter().map(|n| (n.to_string(), c.clone())));
            }
            let (count_type, index_type, list_name, face_extras, face_name) = face;
            let mut face_props: Vec<Prop> = vec![(list_name, format!("list {count_type} {index_type}"))];
            face_props.extend(face_extras);
            let mut elements = vec![("vertex".to_string(), counts.0, vertex_props)];
            if extra {
                let props = vec![
                    ("vertex1".to_string(), "int".to_string()),
                    ("path".to_string(), "list uchar float".to_string()),
                ];
                elements.push(("edge".to_string(), 2, props));
            }
            elements.push((face_name, counts.1, face_props));
            let mut bytes = encode(encoding, &elements, counts.0, wild, seed);
            if cut.0 {
                bytes.truncate(cut.1.index(bytes.len() + 1));
            }
            bytes
        })
}

/// The file of `elements` in `encoding` (3 and up: odd format lines).
fn encode(encoding: usize, elements: &[(String, u64, Vec<Prop>)], nv: u64, wild: f64, seed: u64) -> Vec<u8> {
    let format = [
        "ascii 1.0",
        "binary_little_endian 1.0",
        "binary_big_endian 1.0",
        "binary 1.0",
        "ascii 2.0",
        "ascii",
    ][encoding];
    let mut header = format!("ply\nformat {format}\n");
    for (name, count, props) in elements {
        header += &format!("element {name} {count}\n");
        for (p, ty) in props {
            header += &format!("property {ty} {p}\n");
        }
    }
    header += "end_header\n";
    let mut rng = seed | 1;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    let odd = move |r: u64| (r % 1000) as f64 / 1000.0 < wild;
    let mut body = Vec::new();
    let ascii = encoding != 1 && encoding != 2;
    for (name, count, props) in elements {
        for _ in 0..(*count).min(64) {
            for (_, ty) in props {
                let r = next();
                match ty.strip_prefix("list ").and_then(|t| t.split_once(' ')) {
                    Some((count_type, item)) => {
                        let n = if odd(r) {
                            [0.0, 1.0, 2.0, 255.0, -1.0][(r % 5) as usize]
                        } else {
                            3.0 + (r % 4) as f64
                        };
                        put(&mut body, count_type, n, encoding);
                        for _ in 0..(n.max(0.0) as usize).min(8) {
                            let r = next();
                            let index = if name != "edge" && !odd(r) {
                                (r % nv.max(1)) as f64
                            } else {
                                [nv as f64, -1.0, 4294967295.0, 0.5][(r % 4) as usize]
                            };
                            put(&mut body, item, index, encoding);
                        }
                    }
                    None => {
                        let v = if odd(r) {
                            SPECIAL_F32[(r % SPECIAL_F32.len() as u64) as usize] as f64
                        } else {
                            (r % 2000) as f64 / 100.0 - 10.0
                        };
                        put(&mut body, ty, v, encoding);
                    }
                }
            }
            if ascii {
                body.push(b'\n');
            }
        }
    }
    let mut out = header.into_bytes();
    out.extend(body);
    out
}

/// One value of type `ty` (ints rounded and saturated by `as`).
fn put(out: &mut Vec<u8>, ty: &str, v: f64, encoding: usize) {
    let big = encoding == 2;
    macro_rules! bytes {
        ($t:ty) => {{
            let x = v as $t;
            if big {
                x.to_be_bytes().to_vec()
            } else {
                x.to_le_bytes().to_vec()
            }
        }};
    }
    if encoding != 1 && encoding != 2 {
        let text = if TYPES.contains(&ty) && !ty.contains("float") && ty != "double" {
            format!("{} ", v as i64)
        } else {
            format!("{v} ")
        };
        out.extend(text.bytes());
        return;
    }
    out.extend(match ty {
        "char" | "int8" => bytes!(i8),
        "uchar" | "uint8" => bytes!(u8),
        "short" | "int16" => bytes!(i16),
        "ushort" | "uint16" => bytes!(u16),
        "int" | "int32" => bytes!(i32),
        "uint" | "uint32" => bytes!(u32),
        "double" | "float64" => bytes!(f64),
        _ => bytes!(f32),
    });
}
