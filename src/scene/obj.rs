//! Wavefront OBJ geometry, numbered exactly as the command-line contract says.
//!
//! Why not `tobj`: tobj renumbers vertices per object in first-use order and
//! drops unreferenced ones, but the contract's per-vertex outputs are indexed by
//! the file order of `v` lines; and its errors carry no line number, while ours
//! must name the file, the line and the problem. Geometry is the only part of
//! OBJ penumbra reads (`v`, `f`, `o`, `g`), which is a few dozen lines.

use std::path::Path;

use glam::Vec3;

use super::mesh::{Mesh, MeshObject};
use crate::error::{Error, Result};

/// Reads an OBJ file: all objects merged, faces fan-triangulated in file order.
pub fn load_obj(path: &Path) -> Result<Mesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    parse_obj(&String::from_utf8_lossy(&bytes)).map_err(|e| e.in_file(path))
}

/// Parses OBJ text. Errors name the line (`line N`) and the problem.
pub fn parse_obj(text: &str) -> Result<Mesh> {
    let mut positions: Vec<Vec3> = Vec::new();
    // Positive indices may refer to vertices defined later in the file; they
    // are checked once all vertices are known, against the face's line.
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut triangle_lines: Vec<u32> = Vec::new();
    let mut objects: Vec<MeshObject> = Vec::new();
    let mut object_name = String::from("default");
    let mut object_start = 0u32;
    let mut face: Vec<u32> = Vec::with_capacity(8);

    for (line_index, raw) in text.lines().enumerate() {
        let line_no = line_index + 1;
        let at = || format!("line {line_no}");
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut tokens = line.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else {
            continue;
        };
        match keyword {
            "v" => {
                let mut c = [0.0f32; 3];
                for (axis, slot) in ["x", "y", "z"].iter().zip(c.iter_mut()) {
                    let token = tokens.next().ok_or_else(|| {
                        Error::input(at(), format!("vertex has no {axis} coordinate (need 3 numbers)"))
                    })?;
                    *slot = token.parse::<f32>().map_err(|_| {
                        Error::input(at(), format!("vertex {axis} coordinate '{token}' is not a number"))
                    })?;
                    if !slot.is_finite() {
                        return Err(Error::input(
                            at(),
                            format!(
                                "vertex {} coordinate {axis} is '{token}'; vertices must be finite",
                                positions.len() + 1
                            ),
                        ));
                    }
                }
                positions.push(Vec3::from_array(c));
            }
            "f" => {
                face.clear();
                for token in tokens {
                    let index_text = token.split('/').next().unwrap_or("");
                    let index: i64 = index_text.parse().map_err(|_| {
                        Error::input(
                            at(),
                            format!("face vertex '{token}' does not start with an integer index"),
                        )
                    })?;
                    let resolved = match index {
                        0 => return Err(Error::input(at(), "face vertex index 0 (OBJ indices start at 1)")),
                        i if i > 0 => i - 1,
                        i => positions.len() as i64 + i,
                    };
                    if resolved < 0 || resolved >= u32::MAX as i64 {
                        return Err(Error::input(
                            at(),
                            format!("face vertex index {index} refers before the first vertex"),
                        ));
                    }
                    face.push(resolved as u32);
                }
                if face.len() < 3 {
                    return Err(Error::input(
                        at(),
                        format!("face has {} vertices; a face needs at least 3", face.len()),
                    ));
                }
                // Fan triangulation in file order: (v0, v1, v2), (v0, v2, v3), ...
                for k in 2..face.len() {
                    triangles.push([face[0], face[k - 1], face[k]]);
                    triangle_lines.push(line_no as u32);
                }
            }
            "o" | "g" => {
                let end = triangles.len() as u32;
                if end > object_start {
                    objects.push(MeshObject {
                        name: std::mem::take(&mut object_name),
                        triangles: object_start..end,
                    });
                    object_start = end;
                }
                let name = tokens.collect::<Vec<_>>().join(" ");
                object_name = if name.is_empty() { "default".into() } else { name };
            }
            _ => {} // vt, vn, s, usemtl, mtllib, l, p...: not geometry we trace.
        }
    }
    let end = triangles.len() as u32;
    if end > object_start {
        objects.push(MeshObject {
            name: object_name,
            triangles: object_start..end,
        });
    }

    let nv = positions.len() as u32;
    for (tri, &line) in triangles.iter().zip(&triangle_lines) {
        if let Some(&bad) = tri.iter().find(|&&v| v >= nv) {
            return Err(Error::input(
                format!("line {line}"),
                format!(
                    "face vertex index {} is out of range (the file has {nv} vertices)",
                    bad + 1
                ),
            ));
        }
    }
    if triangles.is_empty() {
        return Err(Error::input(
            "mesh",
            format!("no faces found ({nv} vertices); an empty mesh cannot be traced"),
        ));
    }
    let mesh = Mesh {
        positions,
        triangles,
        objects,
    };
    mesh.validate()?;
    Ok(mesh)
}

/// Writes a mesh as OBJ, one `o` block per object, so that reading it back
/// gives the same vertex and triangle numbering.
pub fn write_obj(mesh: &Mesh, header: &str) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for line in header.lines() {
        let _ = writeln!(s, "# {line}");
    }
    for p in &mesh.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for object in &mesh.objects {
        let _ = writeln!(s, "o {}", object.name);
        for t in object.triangles.clone() {
            let [a, b, c] = mesh.triangles[t as usize];
            let _ = writeln!(s, "f {} {} {}", a + 1, b + 1, c + 1);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fans_in_file_order_and_keeps_vertex_order() {
        let m =
            parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 9 9 9\no a\nf 1/1/1 2//2 3 4\no b\nf -5 -4 -3\n").unwrap();
        assert_eq!(m.positions.len(), 5, "unreferenced vertices are kept");
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
        assert_eq!(m.objects.len(), 2);
        assert_eq!(m.objects[0].name, "a");
        assert_eq!(m.objects[0].triangles, 0..2);
        assert_eq!(m.objects[1].triangles, 2..3);
    }

    #[test]
    fn forward_references_resolve() {
        let m = parse_obj("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn errors_name_the_line_and_problem() {
        let cases = [
            ("v 0 0\nf 1 1 1\n", "line 1", "no z coordinate"),
            ("v 0 0 abc\n", "line 1", "not a number"),
            ("v 0 0 0\nv 1 0 nan\n", "line 2", "must be finite"),
            ("v 0 0 0\nv 0 0 inf\n", "line 2", "must be finite"),
            ("v 0 0 0\nf 1 2\n", "line 2", "at least 3"),
            ("v 0 0 0\nf 1 2 x\n", "line 2", "integer index"),
            ("v 0 0 0\nf 0 1 1\n", "line 2", "index 0"),
            ("v 0 0 0\n\nf 1 2 7\n", "line 3", "out of range"),
            ("v 0 0 0\nf -4 1 1\n", "line 2", "before the first vertex"),
            ("# nothing\n", "mesh", "no faces"),
            ("", "mesh", "no faces"),
        ];
        for (text, place, problem) in cases {
            let e = parse_obj(text).unwrap_err().to_string();
            assert!(e.contains(place) && e.contains(problem), "{text:?} gave {e}");
        }
    }

    #[test]
    fn write_then_read_round_trips() {
        let m = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0.5\no x\nf 1 2 3\no y\nf 3 2 1\n").unwrap();
        assert_eq!(parse_obj(&write_obj(&m, "test")).unwrap(), m);
    }
}
