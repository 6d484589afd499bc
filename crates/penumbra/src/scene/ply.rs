//! Stanford PLY meshes, ASCII and binary (either byte order), numbered as
//! the command-line contract numbers OBJ: vertices in file order, polygons
//! fanned in file order.
//!
//! Read: the `vertex` element's `x y z` (any scalar type), optional
//! `nx ny nz` (shading normals) and `red green blue` (vertex colours,
//! integers scaled by their type's maximum, floats as they are); the `face`
//! element's polygons and the `tristrips` element's triangle strips (as
//! range scanners' files have them), each from its `vertex_indices` (or
//! `vertex_index`) list of any integer count and index types, or from its
//! only list whatever its name. A file may have both: the faces'
//! triangles come first, then the strips', whatever the elements' order.
//! Every other element and property is skipped by its type; `comment` and
//! `obj_info` lines are ignored.
//!
//! Polygons are fanned in file order, `(v0, v1, v2), (v0, v2, v3), ...`, as
//! OBJ's are, and keep every triangle the file gives (a repeated corner
//! included), so that triangle numbers match the same mesh written as OBJ.
//! A `tristrips` list holds strips separated by `-1` (in a `uint` list also
//! its bit pattern, 4294967295); strip `s` gives triangle `k` as
//! `(s[k], s[k+1], s[k+2])` for even `k` and `(s[k+1], s[k], s[k+2])` for
//! odd `k`, every triangle with the strip's orientation. A strip triangle
//! with a repeated vertex is dropped: strippers write those to turn corners
//! or to join strips, and they are no surface of the model. Each strip
//! triangle is a face of its own (`ObjFile::triangle_faces`), numbered on
//! after the `face` records.
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
//! and list entries counted from 0 as PLY indices are.

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
    let mut read = Read {
        vertex_count: mesh_elements(&header.elements)?,
        ..Read::default()
    };
    let rest = &bytes[header.body..];
    match header.format {
        Format::Ascii => read.elements(&header.elements, &mut Ascii::new(rest, header.end_line + 1))?,
        Format::Binary { big_endian } => {
            read.elements(&header.elements, &mut Binary::new(rest, big_endian, header.body))?
        }
    }
    read.finish()
}

/// The `vertex` element's count, once the header is known to declare
/// vertices and something that joins them into triangles.
fn mesh_elements(elements: &[Element]) -> Result<u64> {
    let Some(vertex) = elements.iter().find(|e| e.name == "vertex") else {
        return Err(Error::input("header", "has no 'vertex' element"));
    };
    if !elements.iter().any(|e| e.name == "face" || e.name == "tristrips") {
        let declared: Vec<String> = elements.iter().map(describe).collect();
        return Err(Error::input(
            "header",
            format!(
                "has no 'face' or 'tristrips' element: the header declares {}; a point cloud cannot be traced",
                and_list(&declared)
            ),
        ));
    }
    Ok(vertex.count)
}

/// `element NAME (COUNT records, properties A B C)`: what a header
/// declares, for messages.
fn describe(e: &Element) -> String {
    let names: Vec<&str> = e.properties.iter().map(|p| p.name.as_str()).collect();
    let properties = if names.is_empty() {
        "no properties".to_string()
    } else {
        format!("properties {}", names.join(" "))
    };
    let records = if e.count == 1 { "record" } else { "records" };
    format!("element {} ({} {records}, {properties})", e.name, e.count)
}

/// `a`, `a and b`, `a, b and c`.
fn and_list(items: &[String]) -> String {
    match items {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
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
    /// The `vertex` element's count, known from the header before any
    /// element is read (strip indices are checked against it as they come).
    vertex_count: u64,
    /// In f64 until the frame is known (`frame::recentre`).
    positions: Vec<DVec3>,
    normals: Option<Vec<Vec3>>,
    colours: Option<Vec<Vec3>>,
    /// The `face` element's triangles.
    triangles: Vec<[u32; 3]>,
    /// Per triangle, its face record.
    triangle_faces: Vec<u32>,
    /// The `face` element's record count: the first face number of the
    /// strips' triangles.
    face_records: u64,
    /// The `tristrips` element's triangles, each a face of its own.
    strip_triangles: Vec<[u32; 3]>,
    warnings: Vec<String>,
}

/// `element[record].property (place): problem`.
fn at(e: &Element, record: u64, p: &Property, body: &dyn Body, problem: String) -> Error {
    Error::input(format!("{}[{record}].{} ({})", e.name, p.name, body.place()), problem)
}

/// The list of vertex indices of a `face` or `tristrips` element: its
/// `vertex_indices` or `vertex_index` list, else its only list (exporters
/// name it as they like), as (property index, item type). Errors name the
/// element's header line and what it has.
fn index_list(e: &Element) -> Result<(usize, Scalar)> {
    let fail = |problem: String| Error::input(format!("header line {}", e.line), problem);
    let named = ["vertex_indices", "vertex_index"].iter().find_map(|n| e.property(n));
    let lists: Vec<(usize, &Property)> = e
        .properties
        .iter()
        .enumerate()
        .filter(|(_, p)| matches!(p.kind, Kind::List { .. }))
        .collect();
    let (index, property) = match (named, &lists[..]) {
        (Some(found), _) => found,
        (None, &[only]) => only,
        (None, []) => {
            let has: Vec<String> = e
                .properties
                .iter()
                .map(|p| match p.kind {
                    Kind::Scalar(ty) => format!("{} {}", ty.name(), p.name),
                    Kind::List { .. } => p.name.clone(),
                })
                .collect();
            let has = if has.is_empty() {
                "no properties".to_string()
            } else {
                format!("only {}", has.join(", "))
            };
            return Err(fail(format!(
                "element '{}' has no list of vertex indices (vertex_indices or vertex_index); it has {has}",
                e.name
            )));
        }
        (None, many) => {
            let names: Vec<String> = many.iter().map(|(_, p)| format!("'{}'", p.name)).collect();
            return Err(fail(format!(
                "element '{}' has {} lists, {}, and none is named vertex_indices or vertex_index: \
                 which one holds the vertex indices is ambiguous",
                e.name,
                many.len(),
                and_list(&names)
            )));
        }
    };
    match property.kind {
        Kind::List { item, .. } if item.is_integer() => Ok((index, item)),
        _ => Err(fail(format!(
            "{} property '{}' is not a list of integers",
            e.name, property.name
        ))),
    }
}

/// Reads every record of `e`, skipping all but property `index`, whose
/// list count goes to `each` with the body positioned at the list's first
/// value; `each`'s problem is named with the record and property.
fn index_lists(
    e: &Element,
    body: &mut dyn Body,
    index: usize,
    mut each: impl FnMut(u64, u64, &mut dyn Body) -> std::result::Result<(), String>,
) -> Result<()> {
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
            if k == index {
                each(record, n, body)
            } else {
                body.skip(ty, n)
            }
            .map_err(|m| fail(body, m))?;
        }
    }
    Ok(())
}

impl Read {
    fn elements(&mut self, elements: &[Element], body: &mut dyn Body) -> Result<()> {
        for e in elements {
            match e.name.as_str() {
                "vertex" => self.vertices(e, body)?,
                "face" => self.faces(e, body)?,
                "tristrips" => self.strips(e, body)?,
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
        let (index, item) = index_list(e)?;
        self.face_records = e.count;
        // At most one triangle per face record before any polygon is seen
        // (the count is bounded by the file's length).
        self.triangles = Vec::with_capacity(e.count as usize);
        self.triangle_faces = Vec::with_capacity(e.count as usize);
        let mut corners: Vec<u32> = Vec::new();
        index_lists(e, body, index, |record, n, body| {
            if n < 3 {
                return Err(format!("a face of {n} vertices; a face needs at least 3"));
            }
            corners.clear();
            for _ in 0..n {
                let v = body.value(item)?;
                if v < 0.0 {
                    return Err(format!("vertex index {v} is negative"));
                }
                corners.push(v as u32);
            }
            let face = u32::try_from(record).unwrap_or(u32::MAX);
            // Fan triangulation in file order, as OBJ's.
            for k in 2..corners.len() {
                self.triangles.push([corners[0], corners[k - 1], corners[k]]);
                self.triangle_faces.push(face);
            }
            Ok(())
        })
    }

    fn strips(&mut self, e: &Element, body: &mut dyn Body) -> Result<()> {
        let (index, item) = index_list(e)?;
        let nv = self.vertex_count;
        // A uint list cannot hold -1; writers put its bit pattern there (no
        // vertex has that index: `Mesh::validate` refuses 2^32-1 vertices).
        let restart = |v: f64| v == -1.0 || (item == Scalar::U32 && v == u32::MAX as f64);
        let mut strip: Vec<u32> = Vec::new();
        let triangles = &mut self.strip_triangles;
        index_lists(e, body, index, |_, n, body| {
            strip.clear();
            for entry in 0..n {
                let v = body.value(item)?;
                if restart(v) {
                    push_strip(&strip, triangles);
                    strip.clear();
                } else if v < 0.0 {
                    return Err(format!(
                        "entry {entry} is {v}; a strip holds vertex indices and -1 (a restart)"
                    ));
                } else if v >= nv as f64 {
                    return Err(format!(
                        "entry {entry}: vertex index {v} is out of range (the file has {nv} vertices)"
                    ));
                } else {
                    strip.push(v as u32);
                }
            }
            push_strip(&strip, triangles);
            Ok(())
        })
    }

    fn finish(mut self) -> Result<ObjFile> {
        let nv = self.positions.len() as u64;
        for (tri, &face) in self.triangles.iter().zip(&self.triangle_faces) {
            if let Some(&bad) = tri.iter().find(|&&v| v as u64 >= nv) {
                return Err(Error::input(
                    format!("face[{face}]"),
                    format!("vertex index {bad} is out of range (the file has {nv} vertices)"),
                ));
            }
        }
        let first = self.face_records;
        let strip_faces = (first..).map(|f| u32::try_from(f).unwrap_or(u32::MAX));
        self.triangle_faces.extend(strip_faces.take(self.strip_triangles.len()));
        if self.triangles.is_empty() {
            self.triangles = self.strip_triangles;
        } else {
            self.triangles.append(&mut self.strip_triangles);
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
            primitives: Vec::new(),
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

/// The triangles of one strip, `(s[k], s[k+1], s[k+2])` for even `k` and
/// `(s[k+1], s[k], s[k+2])` for odd `k` (so all wind as the first does),
/// without those that repeat a vertex.
fn push_strip(strip: &[u32], triangles: &mut Vec<[u32; 3]>) {
    for (k, w) in strip.windows(3).enumerate() {
        let [a, b, c] = [w[0], w[1], w[2]];
        if a != b && b != c && a != c {
            triangles.push(if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
        }
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
        assert_eq!(
            e.to_string(),
            "header line 7: element 'face' has no list of vertex indices (vertex_indices or vertex_index); \
             it has only int a"
        );
    }

    /// Seven vertices on a zigzag: strip 0 1 2 3 4 turns left then right.
    const STRIP_VERTICES: &str = "0 0 0\n0 1 0\n1 0 0\n1 1 0\n2 0 0\n2 1 0\n3 0 0\n";

    fn strips_head(format: &str, lists: &[&str], records: usize) -> String {
        let mut h = format!(
            "ply\nformat {format} 1.0\nelement vertex 7\nproperty float x\nproperty float y\nproperty float z\n\
             element tristrips {records}\n"
        );
        for l in lists {
            h += &format!("property {l}\n");
        }
        h + "end_header\n"
    }

    #[test]
    fn strips_restart_and_alternate_winding() {
        // Strip 0 1 2 3 4, a restart, strip 6 5 4 2 2 3 0 (a repeated 2
        // turns the corner), a lone -1 and a strip too short to make a
        // triangle.
        let list = "0 1 2 3 4 -1 6 5 4 2 2 3 0 -1 -1 5 6";
        let n = list.split(' ').count();
        let text = format!(
            "{}{STRIP_VERTICES}{n} {list}\n",
            strips_head("ascii", &["list int int vertex_indices"], 1)
        );
        let f = parse_ply(text.as_bytes()).unwrap();
        let expected = [
            [0, 1, 2],
            [2, 1, 3],
            [2, 3, 4],
            [6, 5, 4],
            [4, 5, 2],
            // (4, 2, 2), (2, 2, 3) repeat a vertex; then k = 4, even.
            [2, 3, 0],
        ];
        assert_eq!(f.mesh.triangles, expected);
        let facing: Vec<f32> = (0..expected.len()).map(|t| f.mesh.face_normal(t).z.signum()).collect();
        assert_eq!(
            facing,
            [-1.0, -1.0, -1.0, 1.0, 1.0, 1.0],
            "each strip's triangles wind as its first"
        );
        assert_eq!(
            f.triangle_faces,
            [0, 1, 2, 3, 4, 5],
            "each strip triangle a face of its own"
        );
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    }

    /// `values` as a binary list of `item` with a uchar count.
    fn binary_list(values: &[i64], item: Scalar, big_endian: bool) -> Vec<u8> {
        let mut out = vec![values.len() as u8];
        for &v in values {
            let bytes = match item {
                Scalar::I32 => (v as i32).to_le_bytes(),
                Scalar::U32 => (v as u32).to_le_bytes(),
                _ => unreachable!(),
            };
            let mut bytes = bytes.to_vec();
            if big_endian {
                bytes.reverse();
            }
            out.extend(bytes);
        }
        out
    }

    #[test]
    fn binary_strips_of_either_byte_order_with_faces_first() {
        let strip = [0i64, 1, 2, 3, 4, -1, 6, 5, 4];
        let mut ascii_list = format!("{}", strip.len());
        for v in strip {
            ascii_list += &format!(" {v}");
        }
        // The strips element before the faces: faces' triangles still first.
        let head = |format: &str, item: &str| {
            format!(
                "ply\nformat {format} 1.0\nelement vertex 7\nproperty float x\nproperty float y\nproperty float z\n\
                 element tristrips 1\nproperty list uchar {item} vertex_indices\nelement face 1\n\
                 property list uchar int vertex_indices\nend_header\n"
            )
        };
        let ascii = format!("{}{STRIP_VERTICES}{ascii_list}\n4 0 2 3 1\n", head("ascii", "int"));
        let reference = parse_ply(ascii.as_bytes()).unwrap();
        assert_eq!(
            reference.mesh.triangles,
            [[0, 2, 3], [0, 3, 1], [0, 1, 2], [2, 1, 3], [2, 3, 4], [6, 5, 4]]
        );
        assert_eq!(reference.triangle_faces, [0, 0, 1, 2, 3, 4]);
        for big_endian in [false, true] {
            // uint lists restart at -1's bit pattern.
            for (item, name) in [(Scalar::I32, "int"), (Scalar::U32, "uint")] {
                let format = if big_endian {
                    "binary_big_endian"
                } else {
                    "binary_little_endian"
                };
                let mut bytes = head(format, name).into_bytes();
                for line in STRIP_VERTICES.lines() {
                    for c in line.split(' ') {
                        let c: f32 = c.parse().unwrap();
                        bytes.extend(if big_endian { c.to_be_bytes() } else { c.to_le_bytes() });
                    }
                }
                bytes.extend(binary_list(&strip, item, big_endian));
                bytes.extend(binary_list(&[0, 2, 3, 1], Scalar::I32, big_endian));
                let f = parse_ply(&bytes).unwrap_or_else(|e| panic!("{format} {name}: {e}"));
                assert_eq!(f.mesh, reference.mesh, "{format} {name}");
                assert_eq!(f.triangle_faces, reference.triangle_faces, "{format} {name}");
            }
        }
    }

    #[test]
    fn bad_strip_indices_name_the_element_entry_and_value() {
        let ascii = |list: &str, item: &str| {
            let n = list.split(' ').count();
            let head = strips_head(
                "ascii",
                &["uchar flags", &format!("list uchar {item} vertex_indices")],
                2,
            );
            parse_ply(format!("{head}{STRIP_VERTICES}0 3 0 1 2\n0 {n} {list}\n").as_bytes())
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            ascii("0 1 2 -1 3 -2 4", "int"),
            "tristrips[1].vertex_indices (line 19): entry 5 is -2; a strip holds vertex indices and -1 (a restart)"
        );
        assert_eq!(
            ascii("0 1 2 7", "int"),
            "tristrips[1].vertex_indices (line 19): entry 3: vertex index 7 is out of range (the file has 7 vertices)"
        );
        assert_eq!(
            ascii("0 1 2", "float"),
            "header line 7: tristrips property 'vertex_indices' is not a list of integers"
        );
        // Binary: the byte of the bad entry.
        let head = strips_head("binary_little_endian", &["list uchar int vertex_indices"], 1);
        let mut bytes = head.clone().into_bytes();
        bytes.extend([0u8; 7 * 12]);
        bytes.extend(binary_list(&[0, 1, 2, 9], Scalar::I32, false));
        let at = head.len() + 7 * 12 + 1 + 3 * 4;
        assert_eq!(
            parse_ply(&bytes).unwrap_err().to_string(),
            format!(
                "tristrips[0].vertex_indices (byte {at}): entry 3: vertex index 9 is out of range (the file has 7 vertices)"
            )
        );
    }

    #[test]
    fn index_lists_by_either_name_or_alone() {
        let with = |lists: &str| {
            let text = format!(
                "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
                 element face 2\n{lists}end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
            );
            let body = if lists.contains("uchar flags") {
                "7 4 0 1 2 3\n7 3 0 2 3\n"
            } else {
                "4 0 1 2 3\n3 0 2 3\n"
            };
            parse_ply(format!("{text}{body}").as_bytes()).map(|f| (f.mesh.triangles, f.triangle_faces))
        };
        let quad = (vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]], vec![0, 0, 1]);
        for lists in [
            "property list uchar int vertex_indices\n",
            "property list uchar uint vertex_index\n",
            "property uchar flags\nproperty list uchar int corners\n",
        ] {
            assert_eq!(with(lists).unwrap(), quad, "{lists}");
        }
        let e = with("property list uchar int corners\nproperty list uchar float uv\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "header line 7: element 'face' has 2 lists, 'corners' and 'uv', and none is named vertex_indices or \
             vertex_index: which one holds the vertex indices is ambiguous"
        );
        let e = with("property list uchar float corners\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "header line 7: face property 'corners' is not a list of integers"
        );
    }

    #[test]
    fn polygons_fan_in_file_order_before_the_strips() {
        let text = "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
                    element face 3\nproperty list uchar int vertex_indices\nelement tristrips 1\n\
                    property list int int vertex_indices\nend_header\n\
                    0 0 0\n1 0 0\n2 1 0\n1 2 0\n0 2 0\n-1 1 0\n\
                    6 0 1 2 3 4 5\n3 5 4 3\n4 1 2 3 4\n4 0 1 5 4\n";
        let f = parse_ply(text.as_bytes()).unwrap();
        assert_eq!(
            f.mesh.triangles,
            [
                [0, 1, 2],
                [0, 2, 3],
                [0, 3, 4],
                [0, 4, 5],
                [5, 4, 3],
                [1, 2, 3],
                [1, 3, 4],
                [0, 1, 5],
                [5, 1, 4]
            ]
        );
        assert_eq!(
            f.triangle_faces,
            [0, 0, 0, 0, 1, 2, 2, 3, 4],
            "a polygon's triangles share its record's number; strip triangles are numbered on, one each"
        );
        // A repeated corner is kept, as OBJ keeps it (triangle numbers match).
        let f = parse_ply(text.replace("3 5 4 3", "3 5 5 3").as_bytes()).unwrap();
        assert_eq!(f.mesh.triangles[4], [5, 5, 3]);
    }

    #[test]
    fn a_point_cloud_is_refused_naming_what_the_header_declares() {
        let text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n\
                    property uchar confidence\nelement range_grid 1\nproperty list uchar int vertex_indices\n\
                    element empty 0\nend_header\n0 0 0 1\n1 0 0 1\n1 0\n";
        assert_eq!(
            parse_ply(text.as_bytes()).unwrap_err().to_string(),
            "header: has no 'face' or 'tristrips' element: the header declares element vertex (2 records, \
             properties x y z confidence), element range_grid (1 record, properties vertex_indices) and element \
             empty (0 records, no properties); a point cloud cannot be traced"
        );
    }
}
