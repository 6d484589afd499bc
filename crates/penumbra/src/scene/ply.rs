//! Stanford PLY meshes, ASCII and binary (either byte order), numbered as
//! the command-line contract numbers OBJ: vertices in file order, polygons
//! fanned in file order.
//!
//! Read: the `vertex` element's `x y z` (any scalar type), optional
//! `nx ny nz` (shading normals) and `red green blue` (vertex colours,
//! integers scaled by their type's maximum, floats as they are); the `face`
//! element's `vertex_indices` (or `vertex_index`) list of any integer count
//! and index types. Every other element and property is skipped by its
//! type; `comment` and `obj_info` lines are ignored.
//!
//! Why not `ply-rs-bw` (4.0): its errors name a line but not the element,
//! record or property (a binary error gives no position at all), and quote
//! the whole offending line; it materialises every record as a struct and
//! every face's list as a fresh `Vec` through string-keyed setters; and it
//! has no hook to compare the header's counts with the bytes after it
//! before preallocating (it preallocates up to 65,536 records per element
//! whatever the file holds). This reader checks `count x minimum record
//! size` of every element against the file's length before allocating
//! anything (`header::check_size`), reads straight into the mesh, and names
//! each problem as `element[record].property (line N | byte N)`, records
//! counted from 0 as PLY indices are.

mod body;
mod header;

use std::path::Path;

use glam::{DVec3, Vec3};

use super::mesh::{Mesh, MeshObject};
use super::mtl::Material;
use super::obj::{NO_NORMAL, ObjFile, SMOOTH_DEFAULT};
use crate::error::{Error, Result};
use body::{Ascii, Binary, Body};
use header::{Element, Format, Kind, Property, Scalar};

/// Reads a PLY file; errors name the file, the header line or the
/// element, record and property, and the problem.
pub fn load_ply(path: &Path) -> Result<ObjFile> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    parse_ply(&bytes).map_err(|e| e.in_file(path))
}

/// Parses the bytes of a PLY file: one object, every triangle the default
/// material, `vn`-like normals where the file has `nx ny nz`.
pub fn parse_ply(bytes: &[u8]) -> Result<ObjFile> {
    let header = header::parse(bytes)?;
    let rest = &bytes[header.body..];
    let mut read = Read::default();
    match header.format {
        Format::Ascii => read.elements(&header.elements, &mut Ascii::new(rest, header.end_line + 1))?,
        Format::Binary { big_endian } => {
            read.elements(&header.elements, &mut Binary::new(rest, big_endian, header.body))?
        }
    }
    read.finish()
}

/// What a vertex property feeds.
#[derive(Clone, Copy, PartialEq)]
enum Slot {
    Position(usize),
    Normal(usize),
    Colour(usize),
    Skip,
}

/// The mesh as it is read.
#[derive(Default)]
struct Read {
    /// In f64 until the frame is known (`frame::recentre`).
    positions: Vec<DVec3>,
    normals: Option<Vec<Vec3>>,
    colours: Option<Vec<Vec3>>,
    triangles: Vec<[u32; 3]>,
    /// Per triangle, its face record.
    triangle_faces: Vec<u32>,
    seen_vertex: bool,
    seen_face: bool,
    warnings: Vec<String>,
}

/// `element[record].property (place): problem`.
fn at(e: &Element, record: u64, p: &Property, body: &dyn Body, problem: String) -> Error {
    Error::input(format!("{}[{record}].{} ({})", e.name, p.name, body.place()), problem)
}

impl Read {
    fn elements(&mut self, elements: &[Element], body: &mut dyn Body) -> Result<()> {
        for e in elements {
            match e.name.as_str() {
                "vertex" => self.vertices(e, body)?,
                "face" => self.faces(e, body)?,
                _ => skip_element(e, body)?,
            }
        }
        if let Some(place) = body.leftover() {
            self.warnings
                .push(format!("data after the last element ({place}) is ignored"));
        }
        Ok(())
    }

    fn vertices(&mut self, e: &Element, body: &mut dyn Body) -> Result<()> {
        self.seen_vertex = true;
        let slots = vertex_slots(e, &mut self.warnings)?;
        let has = |f: fn(usize) -> Slot| slots.contains(&f(0));
        // `header::check_size` has bounded the count by the file's length.
        let n = e.count as usize;
        self.positions = Vec::with_capacity(n);
        let mut normals = has(Slot::Normal).then(|| Vec::with_capacity(n));
        let mut colours = has(Slot::Colour).then(|| Vec::with_capacity(n));
        for record in 0..e.count {
            let (mut p, mut normal, mut colour) = ([0.0f64; 3], [0.0f32; 3], [0.0f32; 3]);
            for (property, &slot) in e.properties.iter().zip(&slots) {
                let fail = |body: &dyn Body, problem| at(e, record, property, body, problem);
                let ty = match property.kind {
                    Kind::Scalar(ty) => ty,
                    Kind::List { count, item } => {
                        let n = list_count(body, count).map_err(|m| fail(body, m))?;
                        body.skip(item, n).map_err(|m| fail(body, m))?;
                        continue;
                    }
                };
                let value = body.value(ty).map_err(|m| fail(body, m))?;
                match slot {
                    Slot::Position(axis) => {
                        // A double keeps its digits (a far-off model); the
                        // range is still f32's.
                        finite(value).map_err(|m| fail(body, m))?;
                        p[axis] = value;
                    }
                    Slot::Normal(axis) => normal[axis] = finite(value).map_err(|m| fail(body, m))?,
                    Slot::Colour(c) => {
                        let scale = if ty.is_integer() { ty.range().1 } else { 1.0 };
                        colour[c] = finite(value / scale).map_err(|m| fail(body, m))?;
                    }
                    Slot::Skip => {}
                }
            }
            self.positions.push(DVec3::from_array(p));
            if let Some(n) = normals.as_mut() {
                n.push(Vec3::from_array(normal));
            }
            if let Some(c) = colours.as_mut() {
                c.push(Vec3::from_array(colour));
            }
        }
        self.normals = normals;
        self.colours = colours;
        Ok(())
    }

    fn faces(&mut self, e: &Element, body: &mut dyn Body) -> Result<()> {
        self.seen_face = true;
        let Some(list) = ["vertex_indices", "vertex_index"].iter().find_map(|n| e.property(n)) else {
            return Err(Error::input(
                format!("header line {}", e.line),
                "element 'face' has no vertex_indices (or vertex_index) list",
            ));
        };
        let (index, item) = match list.1.kind {
            Kind::List { item, .. } if item.is_integer() => (list.0, item),
            _ => {
                return Err(Error::input(
                    format!("header line {}", e.line),
                    format!("face property '{}' is not a list of integers", list.1.name),
                ));
            }
        };
        // At most one triangle per face record before any polygon is seen
        // (the count is bounded by the file's length).
        self.triangles = Vec::with_capacity(e.count as usize);
        self.triangle_faces = Vec::with_capacity(e.count as usize);
        let mut corners: Vec<u32> = Vec::new();
        for record in 0..e.count {
            for (k, property) in e.properties.iter().enumerate() {
                let fail = |body: &dyn Body, problem| at(e, record, property, body, problem);
                let (count, ty) = match property.kind {
                    Kind::Scalar(ty) => {
                        body.value(ty).map_err(|m| fail(body, m))?;
                        continue;
                    }
                    Kind::List { count, item } => (count, item),
                };
                let n = list_count(body, count).map_err(|m| fail(body, m))?;
                if k != index {
                    body.skip(ty, n).map_err(|m| fail(body, m))?;
                    continue;
                }
                if n < 3 {
                    return Err(fail(body, format!("a face of {n} vertices; a face needs at least 3")));
                }
                corners.clear();
                for _ in 0..n {
                    let v = body.value(item).map_err(|m| fail(body, m))?;
                    if v < 0.0 {
                        return Err(fail(body, format!("vertex index {v} is negative")));
                    }
                    corners.push(v as u32);
                }
                let face = u32::try_from(record).unwrap_or(u32::MAX);
                // Fan triangulation in file order, as OBJ's.
                for k in 2..corners.len() {
                    self.triangles.push([corners[0], corners[k - 1], corners[k]]);
                    self.triangle_faces.push(face);
                }
            }
        }
        Ok(())
    }

    fn finish(self) -> Result<ObjFile> {
        if !self.seen_vertex {
            return Err(Error::input("header", "has no 'vertex' element"));
        }
        if !self.seen_face {
            return Err(Error::input(
                "header",
                format!(
                    "has no 'face' element ({} vertices and no faces: a point cloud cannot be traced)",
                    self.positions.len()
                ),
            ));
        }
        let nv = self.positions.len() as u64;
        for (tri, &face) in self.triangles.iter().zip(&self.triangle_faces) {
            if let Some(&bad) = tri.iter().find(|&&v| v as u64 >= nv) {
                return Err(Error::input(
                    format!("face[{face}]"),
                    format!("vertex index {bad} is out of range (the file has {nv} vertices)"),
                ));
            }
        }
        let n = self.triangles.len() as u32;
        let (origin, positions) = super::frame::recentre(&self.positions);
        let mesh = Mesh {
            origin,
            positions,
            triangles: self.triangles,
            objects: if n > 0 {
                vec![MeshObject {
                    name: "default".into(),
                    triangles: 0..n,
                }]
            } else {
                Vec::new()
            },
        };
        mesh.validate()?;
        let (normals, corner_normals) = match self.normals {
            Some(normals) => (normals, mesh.triangles.clone()),
            None => (Vec::new(), vec![[NO_NORMAL; 3]; mesh.triangles.len()]),
        };
        Ok(ObjFile {
            materials: vec![Material::default_surface()],
            triangle_materials: vec![0; mesh.triangles.len()],
            triangle_faces: self.triangle_faces,
            normals,
            corner_normals,
            texcoords: Vec::new(),
            corner_texcoords: vec![[super::obj::NO_TEXCOORD; 3]; mesh.triangles.len()],
            smoothing: vec![SMOOTH_DEFAULT; mesh.triangles.len()],
            vertex_colors: self.colours,
            cameras: Vec::new(),
            warnings: self.warnings,
            mesh,
        })
    }
}

/// What each vertex property feeds; x, y and z must be scalars. Normals and
/// colours are read only when all three components are there.
fn vertex_slots(e: &Element, warnings: &mut Vec<String>) -> Result<Vec<Slot>> {
    let mut slots = vec![Slot::Skip; e.properties.len()];
    // Property names, the slot they feed, and what they are (empty: required).
    type Group = ([&'static str; 3], fn(usize) -> Slot, &'static str);
    let groups: [Group; 3] = [
        (["x", "y", "z"], Slot::Position, ""),
        (["nx", "ny", "nz"], Slot::Normal, "normals"),
        (["red", "green", "blue"], Slot::Colour, "colours"),
    ];
    for (names, slot, what) in groups {
        let found: Vec<Option<(usize, &Property)>> = names.iter().map(|n| e.property(n)).collect();
        let present = found.iter().flatten().count();
        if present < 3 && what.is_empty() {
            let missing: Vec<&str> = names
                .iter()
                .zip(&found)
                .filter(|(_, f)| f.is_none())
                .map(|(n, _)| *n)
                .collect();
            return Err(Error::input(
                format!("header line {}", e.line),
                format!("element 'vertex' has no property {}", missing.join(", ")),
            ));
        }
        if present < 3 {
            if present > 0 {
                warnings.push(format!("vertex {what} need all of {}; ignored", names.join(", ")));
            }
            continue;
        }
        for (axis, (i, p)) in found.into_iter().flatten().enumerate() {
            if !matches!(p.kind, Kind::Scalar(_)) {
                return Err(Error::input(
                    format!("header line {}", e.line),
                    format!("vertex property '{}' is a list; it must be a scalar", p.name),
                ));
            }
            slots[i] = slot(axis);
        }
    }
    Ok(slots)
}

/// Skips an element the mesh does not use: in one step where the body can
/// (binary records of scalars), else value by value.
fn skip_element(e: &Element, body: &mut dyn Body) -> Result<()> {
    if e.properties.is_empty() || e.count == 0 {
        return Ok(());
    }
    let scalars: Option<usize> = e
        .properties
        .iter()
        .map(|p| match p.kind {
            Kind::Scalar(s) => Some(s.size()),
            Kind::List { .. } => None,
        })
        .sum();
    if let Some(size) = scalars
        && let Some(done) = body.skip_records(size, e.count)
    {
        return done.map_err(|m| at(e, 0, &e.properties[0], body, m));
    }
    for record in 0..e.count {
        for p in &e.properties {
            let fail = |body: &dyn Body, problem| at(e, record, p, body, problem);
            match p.kind {
                Kind::Scalar(ty) => body.value(ty).map(drop),
                Kind::List { count, item } => list_count(body, count).and_then(|n| body.skip(item, n)),
            }
            .map_err(|m| fail(body, m))?;
        }
    }
    Ok(())
}

/// A list's count: an integer of type `ty`, not negative.
fn list_count(body: &mut dyn Body, ty: Scalar) -> std::result::Result<u64, String> {
    let n = body.value(ty)?;
    if n < 0.0 {
        return Err(format!("list count {n} is negative"));
    }
    Ok(n as u64)
}

fn finite(value: f64) -> std::result::Result<f32, String> {
    let v = value as f32;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{value:e} is not a finite number (as f32)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                        property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

    fn error(body: &str) -> String {
        parse_ply(format!("{HEAD}{body}").as_bytes()).unwrap_err().to_string()
    }

    #[test]
    fn body_errors_name_element_record_property_and_line() {
        let cases = [
            (
                "0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n",
                "vertex[1].y (line 11): 'abc' is not a number (float)",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 1\n",
                "face[0].vertex_indices (line 14): the file ends where a int value",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
                "face[0].vertex_indices (line 13): a face of 2 vertices",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n",
                "face[0].vertex_indices (line 13): vertex index -2 is negative",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n",
                "face[0].vertex_indices (line 13): 300 is out of the range of uchar",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3.0 0 1 2\n",
                "face[0].vertex_indices (line 13): '3.0' is not an integer (uchar)",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                "face[0]: vertex index 3 is out of range (the file has 3 vertices)",
            ),
            (
                "0 0 0\n1 0 1e39\n0 1 0\n3 0 1 2\n",
                "vertex[1].z (line 11): '1e39' is out of the range of float",
            ),
            (
                "0 0 0\n1 0 0\nnan 1 0\n3 0 1 2\n",
                "vertex[2].x (line 12): NaN is not a finite number (as f32)",
            ),
        ];
        for (body, expected) in cases {
            let e = error(body);
            assert!(e.starts_with(expected), "{body:?} gave {e}");
        }
    }

    #[test]
    fn binary_errors_name_the_byte() {
        let head = HEAD.replace("ascii", "binary_little_endian");
        let mut bytes = head.as_bytes().to_vec();
        bytes.extend([0u8; 36]);
        bytes.extend([3, 0, 0, 0, 0, 1, 0, 0, 0]);
        let e = parse_ply(&bytes).unwrap_err().to_string();
        let at = head.len() + 45;
        assert_eq!(
            e,
            format!("face[0].vertex_indices (byte {at}): the file ends here: a int value needs 4 bytes, 0 are left")
        );
    }

    #[test]
    fn extras_and_warnings() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                    property float z\nproperty float nx\nproperty uchar red\nelement face 1\n\
                    property list uchar int vertex_indices\nend_header\n0 0 0 1 255\n1 0 0 1 0\n0 1 0 1 0\n\
                    3 0 1 2\n4\n";
        let f = parse_ply(text.as_bytes()).unwrap();
        assert!(f.normals.is_empty() && f.vertex_colors.is_none());
        assert_eq!(
            f.warnings,
            [
                "vertex normals need all of nx, ny, nz; ignored",
                "vertex colours need all of red, green, blue; ignored",
                "data after the last element (line 16) is ignored",
            ]
        );
        let e = parse_ply(text.replace("property float z\n", "").as_bytes()).unwrap_err();
        assert_eq!(e.to_string(), "header line 3: element 'vertex' has no property z");
        let e =
            parse_ply(b"ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n")
                .unwrap_err();
        assert_eq!(e.to_string(), "header: has no 'vertex' element");
        let e = parse_ply(
            format!("{HEAD}0 0 0\n1 0 0\n0 1 0\n5\n")
                .replace("list uchar int vertex_indices", "int a")
                .as_bytes(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("has no vertex_indices"), "{e}");
    }
}
