//! Wavefront OBJ geometry, numbered exactly as the command-line contract says,
//! and what shading adds to it: per-face materials (`usemtl`, MTL files read
//! by `mtl`), `vn` normals and smoothing groups.
//!
//! Why not `tobj`: tobj renumbers vertices per object in first-use order and
//! drops unreferenced ones, but the contract's per-vertex outputs are indexed by
//! the file order of `v` lines; and its errors carry no line number, while ours
//! must name the file, the line and the problem. Geometry is the only part of
//! OBJ most commands read (`v`, `f`, `o`, `g`: `parse_obj`, which neither reads
//! MTL files nor warns); `parse_obj_file` reads the same geometry in the same
//! pass (one parser for both) plus `vn`, `s`, `usemtl` and `mtllib`.

use std::collections::HashMap;
use std::path::Path;

use glam::{DVec3, Vec2, Vec3};

use super::camera::Camera;
use super::mesh::{Mesh, MeshObject};
use super::mtl::{Ignored, Material, parse_mtl};
use crate::error::{Error, Result};

/// A triangle corner whose face vertex had no `vn` index.
pub const NO_NORMAL: u32 = u32::MAX;
/// A triangle corner whose face vertex had no `vt` index.
pub const NO_TEXCOORD: u32 = u32::MAX;
/// The smoothing group of faces no `s` statement came before.
pub const SMOOTH_DEFAULT: u32 = u32::MAX;

/// Unknown `usemtl` names warned about one by one; the rest in one warning.
const UNKNOWN_USEMTL_SHOWN: usize = 3;

/// A triangle no `usemtl` statement (with a name) came before.
const NO_USEMTL: u32 = u32::MAX;

/// OBJ statements of free-form geometry and other parts of the format that
/// are not read; warned about apart from statements OBJ does not know.
const UNSUPPORTED: [&str; 27] = [
    "cstype",
    "curv",
    "curv2",
    "surf",
    "deg",
    "bmat",
    "step",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "mg",
    "lod",
    "bevel",
    "c_interp",
    "d_interp",
    "shadow_obj",
    "trace_obj",
    "maplib",
    "usemap",
    "ctech",
    "stech",
    "call",
    "csh",
];

/// A mesh file with what shading needs: per-face materials and normals.
/// OBJ's, and PLY's and glTF's read into the same shape (`load_mesh_file`).
#[derive(Debug, Clone)]
pub struct ObjFile {
    /// Geometry, numbered exactly as `parse_obj` numbers it (same Mesh).
    pub mesh: Mesh,
    /// Materials faces refer to, in order of first use; index 0 is always
    /// `Material::default_surface()` (faces with no `usemtl`, or naming a
    /// material no MTL file defines).
    pub materials: Vec<Material>,
    /// Per triangle, index into `materials`.
    pub triangle_materials: Vec<u32>,
    /// Per triangle, the index of the OBJ face (polygon, in file order) it
    /// was fanned from. PLY: the `face` record; each triangle of a
    /// `tristrips` element is a face of its own, numbered on after the
    /// `face` records.
    pub triangle_faces: Vec<u32>,
    /// `vn` normals as written (not normalised; may be zero).
    pub normals: Vec<Vec3>,
    /// Per triangle corner, index into `normals`, or `NO_NORMAL` where the
    /// face vertex had no `vn` index.
    pub corner_normals: Vec<[u32; 3]>,
    /// `vt` texture coordinates (u, v; v up the image).
    pub texcoords: Vec<Vec2>,
    /// Per triangle corner, index into `texcoords`, or `NO_TEXCOORD` where
    /// the face vertex had no `vt` index.
    pub corner_texcoords: Vec<[u32; 3]>,
    /// Per triangle, its smoothing group: `SMOOTH_DEFAULT` where no `s`
    /// statement came before the face, 0 after `s off` / `s 0`, else the
    /// group number.
    pub smoothing: Vec<u32>,
    /// Per-vertex linear RGB colours, where the file gives them (PLY's
    /// `red green blue`); OBJ files have none.
    pub vertex_colors: Option<Vec<Vec3>>,
    /// The file's cameras in the mesh's frame (relative to `mesh.origin`):
    /// a glTF file's perspective cameras in scene traversal order; OBJ and
    /// PLY files have none.
    pub cameras: Vec<Camera>,
    /// What was ignored or replaced by a default: missing MTL files, unknown
    /// `usemtl` names, MTL warnings (prefixed with the MTL file's path),
    /// statements not read (one warning per keyword).
    pub warnings: Vec<String>,
    /// A glTF file's primitives as placed, in mesh order: which of the
    /// file's primitives each run of `mesh`'s vertices comes from (a mesh
    /// that several nodes place appears once per node). Empty for OBJ and
    /// PLY, whose vertices are the file's.
    pub primitives: Vec<PrimitiveSpan>,
}

/// The vertices of one placed glTF primitive in a mesh read from the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PrimitiveSpan {
    /// The index of its mesh in the file's `meshes`.
    pub mesh: usize,
    /// Its index in that mesh's `primitives`.
    pub primitive: usize,
    /// The mesh vertex its POSITION accessor's first element became.
    pub first_vertex: u32,
    /// Its POSITION accessor's count.
    pub vertices: u32,
}

/// Reads an OBJ file: all objects merged, faces fan-triangulated in file order.
pub fn load_obj(path: &Path) -> Result<Mesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    obj_from_bytes(path, &bytes)
}

/// `load_obj` of a file already read (`bytes`, from `path`).
pub(super) fn obj_from_bytes(path: &Path, bytes: &[u8]) -> Result<Mesh> {
    parse_obj(&String::from_utf8_lossy(bytes)).map_err(|e| e.in_file(path))
}

/// Whether `bytes` look like OBJ text: their first statement (past a
/// byte-order mark, blank lines and `#` comments) is one OBJ knows. Used to
/// tell an OBJ file without a known extension from a file of another format.
pub(super) fn looks_like_obj(bytes: &[u8]) -> bool {
    const STATEMENTS: [&str; 12] = ["v", "vt", "vn", "vp", "f", "l", "p", "o", "g", "s", "usemtl", "mtllib"];
    let head = &bytes[..bytes.len().min(64 * 1024)];
    let text = String::from_utf8_lossy(head);
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    text.lines()
        .map(|line| line.split('#').next().unwrap_or("").trim())
        .find(|line| !line.is_empty())
        .and_then(|line| line.split_ascii_whitespace().next())
        .is_some_and(|keyword| STATEMENTS.contains(&keyword) || UNSUPPORTED.contains(&keyword))
}

/// Parses OBJ text. Errors name the line (`line N`) and the problem.
pub fn parse_obj(text: &str) -> Result<Mesh> {
    parse(text, false).map(|p| p.mesh)
}

/// Reads an OBJ file and the MTL files it names (relative to the OBJ's
/// folder). Errors in the OBJ name it; errors in an MTL file name that file.
pub fn load_obj_file(path: &Path) -> Result<ObjFile> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    obj_file_from_bytes(path, &bytes)
}

/// `load_obj_file` of a file already read (`bytes`, from `path`).
pub(super) fn obj_file_from_bytes(path: &Path, bytes: &[u8]) -> Result<ObjFile> {
    let parsed = parse(&String::from_utf8_lossy(bytes), true).map_err(|e| e.in_file(path))?;
    with_materials(parsed, Some(path.parent().unwrap_or(Path::new("."))))
}

/// Parses OBJ text; `mtl_dir` is where `mtllib` names are resolved (None:
/// MTL files are not read, every `usemtl` name is unknown and its faces get
/// the default material, with one warning per name). A missing or unreadable
/// MTL file is a warning; a malformed one an error naming it.
pub fn parse_obj_file(text: &str, mtl_dir: Option<&Path>) -> Result<ObjFile> {
    with_materials(parse(text, true)?, mtl_dir)
}

/// What one pass over OBJ text finds: the mesh, and with `extended` what
/// `ObjFile` adds (empty otherwise).
struct Parsed {
    mesh: Mesh,
    triangle_faces: Vec<u32>,
    normals: Vec<Vec3>,
    corner_normals: Vec<[u32; 3]>,
    texcoords: Vec<Vec2>,
    corner_texcoords: Vec<[u32; 3]>,
    smoothing: Vec<u32>,
    /// Per triangle, index into `usemtl`, or `NO_USEMTL`.
    triangle_usemtl: Vec<u32>,
    /// Distinct `usemtl` names, with the line of their first statement.
    usemtl: Vec<(String, usize)>,
    /// `mtllib` file names in file order, with their line.
    mtllib: Vec<(String, usize)>,
    warnings: Vec<String>,
}

/// The one OBJ parser. Without `extended` it reads only `v`, `f`, `o` and
/// `g` (and only the vertex index of a face corner), so `parse_obj` accepts
/// and rejects exactly what it always has.
fn parse(text: &str, extended: bool) -> Result<Parsed> {
    // A UTF-8 byte-order mark is not part of the first statement.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    // In f64 until the frame is known (`frame::recentre`): a model far
    // from the origin keeps its detail.
    let mut positions: Vec<DVec3> = Vec::new();
    // Positive indices may refer to vertices defined later in the file; they
    // are checked once all vertices are known, against the face's line.
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut triangle_lines: Vec<u32> = Vec::new();
    let mut objects: Vec<MeshObject> = Vec::new();
    let mut object_name = String::from("default");
    let mut object_start = 0u32;
    let mut face: Vec<u32> = Vec::with_capacity(8);

    // Extended: the same forward-reference rule holds for normals.
    let mut face_normals: Vec<u32> = Vec::with_capacity(8);
    let mut face_texcoords: Vec<u32> = Vec::with_capacity(8);
    let mut texcoords: Vec<Vec2> = Vec::new();
    let mut corner_texcoords: Vec<[u32; 3]> = Vec::new();
    // The first bad `vt` index (line, problem) and how many there were:
    // texture coordinates are not geometry, a bad one is dropped.
    let mut bad_texcoords: Option<(usize, String, usize)> = None;
    let mut faces = 0u32;
    let mut triangle_faces: Vec<u32> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut corner_normals: Vec<[u32; 3]> = Vec::new();
    let mut smoothing: Vec<u32> = Vec::new();
    let mut group = SMOOTH_DEFAULT;
    let mut triangle_usemtl: Vec<u32> = Vec::new();
    let mut usemtl: Vec<(String, usize)> = Vec::new();
    let mut usemtl_index: HashMap<String, u32> = HashMap::new();
    let mut material = NO_USEMTL;
    let mut mtllib: Vec<(String, usize)> = Vec::new();
    let mut ignored = Ignored::default();

    for (line_index, raw) in text.lines().enumerate() {
        let line_no = line_index + 1;
        let at = || format!("line {line_no}");
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut tokens = line.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else {
            continue;
        };
        match keyword {
            "v" => positions.push(point(&mut tokens, &at, ("vertex", "vertices"), positions.len())?),
            "vn" if extended => normals.push(point(&mut tokens, &at, ("normal", "normals"), normals.len())?.as_vec3()),
            "vt" if extended => texcoords.push(texcoord(&mut tokens, &at, texcoords.len())?),
            "f" => {
                face.clear();
                face_normals.clear();
                face_texcoords.clear();
                for token in tokens {
                    let mut parts = token.split('/');
                    let index_text = parts.next().unwrap_or("");
                    let index = parse_index(index_text).ok_or_else(|| {
                        Error::input(
                            at(),
                            format!("face vertex '{token}' does not start with an integer index"),
                        )
                    })?;
                    let resolved = match index {
                        0 => return Err(Error::input(at(), "face vertex index 0 (OBJ indices start at 1)")),
                        i if i > 0 => i - 1,
                        i => positions.len() as i128 + i,
                    };
                    if resolved < 0 {
                        return Err(Error::input(
                            at(),
                            format!("face vertex index {index} refers before the first vertex"),
                        ));
                    }
                    if resolved >= u32::MAX as i128 {
                        return Err(Error::input(
                            at(),
                            format!(
                                "face vertex index {index} is out of range (at most {} vertices)",
                                u32::MAX - 1
                            ),
                        ));
                    }
                    face.push(resolved as u32);
                    if extended {
                        // `v`, `v//vn`: no texture coordinate; `v/vt`,
                        // `v/vt/vn`: parts[1]. `v`, `v/vt`: no normal;
                        // `v//vn`, `v/vt/vn`: parts[2].
                        let texcoord = match parts.next() {
                            None | Some("") => NO_TEXCOORD,
                            Some(text) => corner_index(text, token, texcoords.len(), "texture coordinate")
                                .unwrap_or_else(|problem| {
                                    bad_texcoords.get_or_insert((line_no, problem, 0)).2 += 1;
                                    NO_TEXCOORD
                                }),
                        };
                        face_texcoords.push(texcoord);
                        let normal = match parts.next() {
                            None | Some("") => NO_NORMAL,
                            Some(text) => {
                                corner_index(text, token, normals.len(), "normal").map_err(|p| Error::input(at(), p))?
                            }
                        };
                        face_normals.push(normal);
                    }
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
                    if extended {
                        triangle_faces.push(faces);
                        corner_normals.push([face_normals[0], face_normals[k - 1], face_normals[k]]);
                        corner_texcoords.push([face_texcoords[0], face_texcoords[k - 1], face_texcoords[k]]);
                        smoothing.push(group);
                        triangle_usemtl.push(material);
                    }
                }
                faces = faces.saturating_add(1);
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
            "s" if extended => {
                let token = tokens
                    .next()
                    .ok_or_else(|| Error::input(at(), "s needs a smoothing group number or 'off'"))?;
                group = if token.eq_ignore_ascii_case("off") {
                    0
                } else {
                    token
                        .parse::<u32>()
                        .ok()
                        .filter(|&g| g != SMOOTH_DEFAULT)
                        .ok_or_else(|| {
                            Error::input(
                                at(),
                                format!(
                                    "smoothing group '{token}' is neither 'off' nor an integer in 0..={}",
                                    SMOOTH_DEFAULT - 1
                                ),
                            )
                        })?
                };
            }
            "usemtl" if extended => {
                // Names with spaces are joined by one space, as `newmtl`'s are.
                let name = tokens.collect::<Vec<_>>().join(" ");
                material = if name.is_empty() {
                    NO_USEMTL
                } else {
                    *usemtl_index.entry(name).or_insert_with_key(|name| {
                        usemtl.push((name.clone(), line_no));
                        usemtl.len() as u32 - 1
                    })
                };
            }
            "mtllib" if extended => mtllib.extend(tokens.map(|name| (name.to_string(), line_no))),
            // Not geometry we trace (texture coordinates, lines, points).
            "vt" | "vp" | "l" | "p" | "vn" | "s" | "usemtl" | "mtllib" => {}
            _ if extended => {
                let reason = if UNSUPPORTED.contains(&keyword) {
                    "free-form/unsupported statement"
                } else {
                    "unknown OBJ statement"
                };
                ignored.note(keyword, line_no, reason);
            }
            _ => {}
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
    let nn = normals.len() as u32;
    for (corners, &line) in corner_normals.iter().zip(&triangle_lines) {
        if let Some(&bad) = corners.iter().find(|&&n| n != NO_NORMAL && n >= nn) {
            return Err(Error::input(
                format!("line {line}"),
                format!(
                    "face normal index {} is out of range (the file has {nn} normals)",
                    bad + 1
                ),
            ));
        }
    }
    let nt = texcoords.len() as u32;
    for (corners, &line) in corner_texcoords.iter_mut().zip(&triangle_lines) {
        for c in corners.iter_mut().filter(|c| **c != NO_TEXCOORD && **c >= nt) {
            let problem = format!(
                "face texture coordinate index {} is out of range (the file has {nt} texture coordinates)",
                *c + 1
            );
            bad_texcoords.get_or_insert((line as usize, problem, 0)).2 += 1;
            *c = NO_TEXCOORD;
        }
    }
    if triangles.is_empty() {
        return Err(Error::input(
            "mesh",
            format!("no faces found ({nv} vertices); an empty mesh cannot be traced"),
        ));
    }
    let (origin, positions) = super::frame::recentre(&positions);
    let mesh = Mesh {
        positions,
        triangles,
        objects,
        origin,
    };
    mesh.validate()?;
    let mut warnings = Vec::new();
    ignored.warn(&mut warnings);
    if let Some((line, problem, count)) = bad_texcoords {
        let more = match count - 1 {
            0 => String::new(),
            1 => " (and 1 more)".into(),
            n => format!(" (and {n} more)"),
        };
        warnings.push(format!(
            "line {line}: {problem}{more}: those face corners have no texture coordinates"
        ));
    }
    Ok(Parsed {
        mesh,
        triangle_faces,
        normals,
        corner_normals,
        texcoords,
        corner_texcoords,
        smoothing,
        triangle_usemtl,
        usemtl,
        mtllib,
        warnings,
    })
}

/// The three coordinates of a `v` or `vn` statement (`noun`: "vertex" and
/// "vertices", or "normal" and "normals"; `count`: how many came before).
fn point<'a>(
    tokens: &mut impl Iterator<Item = &'a str>,
    at: &dyn Fn() -> String,
    (noun, plural): (&str, &str),
    count: usize,
) -> Result<DVec3> {
    let mut c = [0.0f64; 3];
    for (axis, slot) in ["x", "y", "z"].iter().zip(c.iter_mut()) {
        let token = tokens
            .next()
            .ok_or_else(|| Error::input(at(), format!("{noun} has no {axis} coordinate (need 3 numbers)")))?;
        *slot = token
            .parse::<f64>()
            .map_err(|_| Error::input(at(), format!("{noun} {axis} coordinate '{token}' is not a number")))?;
        // Beyond f32's range is as unusable as infinity (and was read as it).
        if !(*slot as f32).is_finite() {
            return Err(Error::input(
                at(),
                format!(
                    "{noun} {} coordinate {axis} is '{token}'; {plural} must be finite",
                    count + 1
                ),
            ));
        }
    }
    Ok(DVec3::from_array(c))
}

/// An OBJ index: an integer, clamped to +-1e30 where it has more digits
/// than any count (so that it is reported as out of range, not as text).
fn parse_index(text: &str) -> Option<i128> {
    let digits = text.strip_prefix(['-', '+']).unwrap_or(text);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let huge = if text.starts_with('-') {
        -1e30 as i128
    } else {
        1e30 as i128
    };
    Some(text.parse::<i128>().unwrap_or(huge))
}

/// A `vt` statement's coordinates: u, and v (0 where not given); a third
/// coordinate is allowed and not used.
fn texcoord<'a>(tokens: &mut impl Iterator<Item = &'a str>, at: &dyn Fn() -> String, count: usize) -> Result<Vec2> {
    let mut c = [0.0f32; 2];
    for (k, (axis, slot)) in ["u", "v"].iter().zip(c.iter_mut()).enumerate() {
        let Some(token) = tokens.next() else {
            if k == 0 {
                return Err(Error::input(at(), "texture coordinate has no u (need 1 to 3 numbers)"));
            }
            break;
        };
        *slot = token
            .parse::<f32>()
            .map_err(|_| Error::input(at(), format!("texture coordinate {axis} '{token}' is not a number")))?;
        if !slot.is_finite() {
            return Err(Error::input(
                at(),
                format!(
                    "texture coordinate {} has {axis} '{token}'; it must be finite",
                    count + 1
                ),
            ));
        }
    }
    Ok(Vec2::from_array(c))
}

/// The index of face corner `token`'s `noun` ("normal" or "texture
/// coordinate": `text`, one of its parts), 0-based; negative indices count
/// back from the `count` read so far. The error says what is wrong with it.
fn corner_index(text: &str, token: &str, count: usize, noun: &str) -> std::result::Result<u32, String> {
    let index = parse_index(text)
        .ok_or_else(|| format!("face vertex '{token}' has {noun} index '{text}', which is not an integer"))?;
    let resolved = match index {
        0 => return Err(format!("face {noun} index 0 (OBJ indices start at 1)")),
        i if i > 0 => i - 1,
        i => count as i128 + i,
    };
    if resolved < 0 {
        return Err(format!("face {noun} index {index} refers before the first {noun}"));
    }
    // u32::MAX is NO_NORMAL and NO_TEXCOORD.
    if resolved >= u32::MAX as i128 {
        return Err(format!("face {noun} index {index} is out of range"));
    }
    Ok(resolved as u32)
}

/// `parsed` with its `usemtl` names resolved against the MTL files its
/// `mtllib` statements name (in `mtl_dir`; none read without it).
fn with_materials(parsed: Parsed, mtl_dir: Option<&Path>) -> Result<ObjFile> {
    let mut warnings = parsed.warnings;
    // Every material the MTL files define, by name: the first file wins.
    let mut library: HashMap<String, Material> = HashMap::new();
    let mut defined_in: HashMap<String, String> = HashMap::new();
    if let Some(dir) = mtl_dir {
        let mut read: Vec<&str> = Vec::new();
        for (name, line) in &parsed.mtllib {
            if read.contains(&name.as_str()) {
                continue;
            }
            read.push(name);
            let path = dir.join(name);
            let bytes = match std::fs::read(&path) {
                Ok(bytes) => bytes,
                Err(e) => {
                    warnings.push(if e.kind() == std::io::ErrorKind::NotFound {
                        format!("mtllib '{name}' not found (line {line}): faces use the default material")
                    } else {
                        format!("mtllib '{name}' cannot be read (line {line}): {e}; faces use the default material")
                    });
                    continue;
                }
            };
            let mut mtl_warnings = Vec::new();
            let mut materials =
                parse_mtl(&String::from_utf8_lossy(&bytes), &mut mtl_warnings).map_err(|e| e.in_file(&path))?;
            super::mtl::resolve_maps(&mut materials, path.parent().unwrap_or(dir));
            let shown = path.display().to_string();
            warnings.extend(mtl_warnings.into_iter().map(|w| format!("{shown}: {w}")));
            for m in materials {
                if let Some(first) = defined_in.get(&m.name) {
                    warnings.push(format!(
                        "{shown}: material '{}' is also defined in {first}; the first definition is used",
                        m.name
                    ));
                    continue;
                }
                defined_in.insert(m.name.clone(), shown.clone());
                library.insert(m.name.clone(), m);
            }
        }
    }
    let unknown: Vec<&(String, usize)> = parsed.usemtl.iter().filter(|(n, _)| !library.contains_key(n)).collect();
    let why = if mtl_dir.is_some() {
        "no MTL file defines it"
    } else {
        "MTL files are not read"
    };
    // A missing MTL file leaves every name unknown: a few warnings, then one
    // that counts the rest.
    for (name, line) in unknown.iter().take(UNKNOWN_USEMTL_SHOWN) {
        warnings.push(format!(
            "usemtl '{name}' (line {line}): {why}; faces use the default material"
        ));
    }
    if unknown.len() > UNKNOWN_USEMTL_SHOWN {
        warnings.push(format!(
            "{} more usemtl names that {why} (the first: '{}', line {}); their faces use the default material",
            unknown.len() - UNKNOWN_USEMTL_SHOWN,
            unknown[UNKNOWN_USEMTL_SHOWN].0,
            unknown[UNKNOWN_USEMTL_SHOWN].1
        ));
    }

    let mut materials = vec![Material::default_surface()];
    // Per `usemtl` name, its index in `materials` once a triangle uses it.
    let mut index: Vec<Option<u32>> = vec![None; parsed.usemtl.len()];
    let triangle_materials = parsed
        .triangle_usemtl
        .iter()
        .map(|&u| {
            if u == NO_USEMTL {
                return 0;
            }
            *index[u as usize].get_or_insert_with(|| match library.get(&parsed.usemtl[u as usize].0) {
                Some(m) => {
                    materials.push(m.clone());
                    materials.len() as u32 - 1
                }
                None => 0,
            })
        })
        .collect();
    Ok(ObjFile {
        primitives: Vec::new(),
        mesh: parsed.mesh,
        materials,
        triangle_materials,
        triangle_faces: parsed.triangle_faces,
        normals: parsed.normals,
        corner_normals: parsed.corner_normals,
        texcoords: parsed.texcoords,
        corner_texcoords: parsed.corner_texcoords,
        smoothing: parsed.smoothing,
        vertex_colors: None,
        cameras: Vec::new(),
        warnings,
    })
}

/// Faces with no `s` statement before them are smoothed across an edge
/// only where their normals differ by less than this (a cube stays a cube,
/// a scanned or tessellated surface is smooth).
pub const DEFAULT_CREASE_DEGREES: f32 = 60.0;

impl ObjFile {
    /// Unit shading normals per triangle corner, as the ray tracer uses them:
    /// where all three corners have `vn` indices, the normalised `vn` (a
    /// zero-length `vn` sends that triangle to the rules below); else, where
    /// the triangle's smoothing group is 0 (`s off`): None (flat: the face
    /// normal); else the contract's area-weighted vertex normal (the sum of
    /// `cross(v1 - v0, v2 - v0)` over the triangles sharing that vertex and
    /// that smoothing group), normalised. Faces no `s` statement came before
    /// (`SMOOTH_DEFAULT`) are one group, except that a corner's sum only
    /// takes the faces within `DEFAULT_CREASE_DEGREES` of its own face: the
    /// OBJ format leaves smoothing off by default, and a file that says
    /// nothing about it may hold a cube as well as a scanned surface. Where
    /// a sum is zero or not finite, None for the triangle (flat).
    ///
    /// Returns the normals and, per triangle, its corners' indices into them;
    /// each `vn` and each distinct smoothed normal is stored once.
    pub fn shading_normals(&self) -> (Vec<Vec3>, Vec<Option<[u32; 3]>>) {
        let positions = &self.mesh.positions;
        let triangles = &self.mesh.triangles;
        let unit_vn: Vec<Option<Vec3>> = self.normals.iter().map(|n| n.try_normalize()).collect();
        let has_vn = |t: usize| {
            self.corner_normals[t]
                .iter()
                .all(|&n| n != NO_NORMAL && unit_vn[n as usize].is_some())
        };
        // Face normals (area-weighted, in f64 as `vertex_normals` sums) and
        // the smoothed faces around each (vertex, group).
        let face: Vec<DVec3> = triangles
            .iter()
            .map(|tri| {
                let [a, b, c] = tri.map(|i| positions[i as usize]);
                (b - a).cross(c - a).as_dvec3()
            })
            .collect();
        let unit_face: Vec<DVec3> = face.iter().map(|n| n.normalize_or_zero()).collect();
        let mut around: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
        for (t, (tri, &g)) in triangles.iter().zip(&self.smoothing).enumerate() {
            if g != 0 {
                for &v in tri {
                    around.entry((v, g)).or_default().push(t as u32);
                }
            }
        }
        let crease = (DEFAULT_CREASE_DEGREES as f64).to_radians().cos();
        // A corner's sum depends on its vertex, its group and (in the
        // default group, through the crease test) its face's unit normal
        // only. Around a vertex of many faces (a polygon's fan, a pole) it
        // is computed once per distinct key, not once per face: a 30,000
        // corner polygon would otherwise take 30,000^2 steps.
        const SHARED_SUM_FACES: usize = 16;
        let crease_key = |t: usize| match self.smoothing[t] {
            SMOOTH_DEFAULT => unit_face[t].to_array().map(f64::to_bits),
            _ => [0; 3],
        };
        let mut shared_sums: HashMap<(u32, u32, [u64; 3]), Option<Vec3>> = HashMap::new();
        let mut normals: Vec<Vec3> = Vec::new();
        let mut vn_out = vec![u32::MAX; self.normals.len()];
        let mut stored: HashMap<[u32; 3], u32> = HashMap::new();
        let mut store_smoothed = |n: Vec3, normals: &mut Vec<Vec3>| {
            *stored.entry(n.to_array().map(f32::to_bits)).or_insert_with(|| {
                normals.push(n);
                normals.len() as u32 - 1
            })
        };
        let corners = (0..triangles.len())
            .map(|t| {
                if has_vn(t) {
                    return Some(self.corner_normals[t].map(|n| {
                        let out = &mut vn_out[n as usize];
                        if *out == u32::MAX {
                            normals.push(unit_vn[n as usize].unwrap());
                            *out = normals.len() as u32 - 1;
                        }
                        *out
                    }));
                }
                let g = self.smoothing[t];
                if g == 0 {
                    return None;
                }
                let mut unit = [Vec3::ZERO; 3];
                for (k, &v) in triangles[t].iter().enumerate() {
                    let faces = &around[&(v, g)];
                    let sum = || -> Option<Vec3> {
                        let sum: DVec3 = faces
                            .iter()
                            .filter(|&&o| g != SMOOTH_DEFAULT || unit_face[o as usize].dot(unit_face[t]) >= crease)
                            .map(|&o| face[o as usize])
                            .sum();
                        Some(sum.try_normalize()?.as_vec3())
                    };
                    unit[k] = if faces.len() > SHARED_SUM_FACES {
                        *shared_sums.entry((v, g, crease_key(t))).or_insert_with(sum)
                    } else {
                        sum()
                    }?;
                }
                Some(unit.map(|n| store_smoothed(n, &mut normals)))
            })
            .collect();
        (normals, corners)
    }
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
    use std::path::PathBuf;

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

    const CORNELL_OBJ: &str = include_str!("../../tests/data/mtl/cornell.obj");
    const CORNELL_MTL: &str = include_str!("../../tests/data/mtl/cornell.mtl");

    /// A folder of its own under the system's temporary folder, removed on drop.
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(name: &str) -> TempDir {
            let dir = std::env::temp_dir().join(format!("penumbra-obj-{}-{name}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            TempDir(dir)
        }

        fn write(&self, name: &str, text: &str) -> PathBuf {
            let path = self.0.join(name);
            std::fs::write(&path, text).unwrap();
            path
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn obj(text: &str) -> ObjFile {
        parse_obj_file(text, None).unwrap_or_else(|e| panic!("{text:?}: {e}"))
    }

    const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

    #[test]
    fn obj_file_numbers_geometry_as_parse_obj_does() {
        let texts = [
            CORNELL_OBJ,
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 9 9 9\no a\nf 1/1/1 2//2 3 4\no b\nf -5 -4 -3\nvn 0 0 1\nvn 0 0 1\n",
            "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 2 0\ng x\nusemtl m\ns 1\nf 1 2 3 4 5\ng\ns off\nf 5 4 3\ncurv 0 1\n",
        ];
        for text in texts {
            let file = obj(text);
            let mesh = parse_obj(text).unwrap();
            assert_eq!(file.mesh, mesh, "{text:?}");
            let n = mesh.triangles.len();
            assert_eq!(
                [
                    file.triangle_faces.len(),
                    file.triangle_materials.len(),
                    file.corner_normals.len(),
                    file.smoothing.len()
                ],
                [n; 4]
            );
        }
    }

    #[test]
    fn parse_obj_still_ignores_what_only_shading_reads() {
        let text = format!("{TRIANGLE}vn x y z\ns smooth\nf 1//9 2//x 3\ncurv 1 2\nusemtl nothing\nmtllib none.mtl\n");
        assert_eq!(parse_obj(&text).unwrap().triangles, [[0, 1, 2]]);
        assert_eq!(
            parse_obj_file(&text, None).unwrap_err().to_string(),
            "line 4: normal x coordinate 'x' is not a number"
        );
    }

    #[test]
    fn materials_follow_usemtl_across_groups() {
        let dir = TempDir::new("usemtl");
        dir.write("a.mtl", "newmtl red\nKd 1 0 0\nnewmtl green\nKd 0 1 0\nnewmtl unused\n");
        let text = "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nusemtl green\ng one\nf 1 2 3 4\n\
                    g two\no three\nf 1 3 4\nusemtl red\nf 2 3 4\nusemtl\nf 1 2 3\nusemtl green\nf 1 2 3\n";
        let f = parse_obj_file(text, Some(&dir.0)).unwrap();
        assert_eq!(f.triangle_materials, [0, 1, 1, 1, 2, 0, 1]);
        let names: Vec<&str> = f.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(
            names,
            ["default", "green", "red"],
            "only materials faces use, in order of first use"
        );
        assert_eq!(f.materials[0], Material::default_surface());
        assert_eq!((f.materials[1].kd, f.materials[2].kd), (Vec3::Y, Vec3::X));
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        assert_eq!(f.triangle_faces, [0, 1, 1, 2, 3, 4, 5]);
    }

    #[test]
    fn unknown_names_and_missing_files_are_warnings() {
        let text = format!(
            "mtllib missing.mtl other.mtl\n{TRIANGLE}usemtl a\nf 1 2 3\nusemtl b\nf 1 2 3\nusemtl a\nf 1 2 3\n"
        );
        let f = obj(&text);
        assert_eq!(f.triangle_materials, [0, 0, 0]);
        assert_eq!(f.materials, [Material::default_surface()]);
        assert_eq!(
            f.warnings,
            [
                "usemtl 'a' (line 5): MTL files are not read; faces use the default material",
                "usemtl 'b' (line 7): MTL files are not read; faces use the default material",
            ]
        );
        let dir = TempDir::new("missing");
        let f = parse_obj_file(&text, Some(&dir.0)).unwrap();
        assert_eq!(f.triangle_materials, [0, 0, 0]);
        assert_eq!(
            f.warnings,
            [
                "mtllib 'missing.mtl' not found (line 1): faces use the default material",
                "mtllib 'other.mtl' not found (line 1): faces use the default material",
                "usemtl 'a' (line 5): no MTL file defines it; faces use the default material",
                "usemtl 'b' (line 7): no MTL file defines it; faces use the default material",
            ]
        );
        // A folder where a file should be cannot be read: also a warning.
        std::fs::create_dir(dir.0.join("missing.mtl")).unwrap();
        let f = parse_obj_file(&text, Some(&dir.0)).unwrap();
        assert!(
            f.warnings[0].starts_with("mtllib 'missing.mtl' cannot be read (line 1): "),
            "{:?}",
            f.warnings
        );
        assert!(
            f.warnings[0].ends_with("; faces use the default material"),
            "{:?}",
            f.warnings
        );
    }

    #[test]
    fn malformed_mtl_is_an_error_naming_it() {
        let dir = TempDir::new("malformed");
        let mtl = dir.write("bad.mtl", "newmtl a\nKd 0.5 x\n");
        let path = dir.write("m.obj", &format!("mtllib bad.mtl\n{TRIANGLE}f 1 2 3\n"));
        let e = load_obj_file(&path).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("{}: line 2: Kd: 'x' is not a number", mtl.display())
        );
        assert_eq!(e.exit_code(), 2);
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(parse_obj_file(&text, Some(&dir.0)).unwrap_err(), e);
        // Errors in the OBJ itself name the OBJ.
        let path = dir.write("m.obj", &format!("mtllib bad.mtl\n{TRIANGLE}f 1 2 4\n"));
        assert_eq!(
            load_obj_file(&path).unwrap_err().to_string(),
            format!(
                "{}: line 5: face vertex index 4 is out of range (the file has 3 vertices)",
                path.display()
            )
        );
        let e = load_obj_file(&dir.0.join("none.obj")).unwrap_err().to_string();
        assert!(e.contains("none.obj: cannot read"), "{e}");
    }

    #[test]
    fn first_mtl_file_wins() {
        let dir = TempDir::new("first");
        let a = dir.write("a.mtl", "newmtl m\nKd 1 0 0\n");
        let b = dir.write("b.mtl", "newmtl m\nKd 0 0 1\nnewmtl n\nmap_Kd n.png\nKd 0.5\n");
        let text = format!("mtllib a.mtl\nmtllib b.mtl a.mtl\n{TRIANGLE}usemtl m\nf 1 2 3\nusemtl n\nf 1 2 3\n");
        let f = parse_obj_file(&text, Some(&dir.0)).unwrap();
        assert_eq!(f.triangle_materials, [1, 2]);
        assert_eq!((f.materials[1].kd, f.materials[2].kd), (Vec3::X, Vec3::splat(0.5)));
        let (a, b) = (a.display(), b.display());
        assert_eq!(
            f.warnings,
            [format!(
                "{b}: material 'm' is also defined in {a}; the first definition is used"
            ),],
            "a file named twice is read once"
        );
    }

    #[test]
    fn texture_coordinates_per_corner() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0 0\nvt 1 1\nvt 0.25\n\
                    f 1/1 2/2 3/3 4/-1\nf 1 2 3\nf 1/9 2/1 3/2\nf 1/x 2/1 3/0\n";
        let f = obj(text);
        assert_eq!(f.texcoords, [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::new(0.25, 0.0)]);
        let no = NO_TEXCOORD;
        assert_eq!(
            f.corner_texcoords,
            [[0, 1, 2], [0, 2, 3], [no, no, no], [no, 0, 1], [no, 0, no]],
            "fans keep each corner's vt; a bad index drops that corner's"
        );
        assert_eq!(
            f.warnings,
            [
                "line 12: face vertex '1/x' has texture coordinate index 'x', which is not an integer (and 2 more): \
              those face corners have no texture coordinates"
            ]
        );
        assert_eq!(
            f.mesh,
            parse_obj(text).unwrap(),
            "geometry is read as parse_obj reads it"
        );
        for (bad, problem) in [
            ("vt\n", "line 1: texture coordinate has no u"),
            ("vt 0 inf\n", "line 1: texture coordinate 1 has v 'inf'"),
        ] {
            let e = parse_obj_file(&format!("{bad}{TRIANGLE}f 1 2 3\n"), None)
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(problem), "{e}");
        }
    }

    #[test]
    fn normals_per_corner() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 2\nf 1//1 2//2 3//-1\nvn 1 0 0\n\
                    f 1/1/-1 2/1/1 3/2/3 4\nf 1 2/5/ 3/4\nf 1//4 2//4 3//4\nvn 0 1 0\n";
        let f = obj(text);
        assert_eq!(f.normals, [Vec3::Z, Vec3::new(0.0, 0.0, 2.0), Vec3::X, Vec3::Y]);
        let no = NO_NORMAL;
        assert_eq!(
            f.corner_normals,
            [[0, 1, 1], [2, 0, 2], [2, 2, no], [no, no, no], [3, 3, 3]]
        );
        let cases = [
            ("vn 0 0\n", "line 1: normal has no z coordinate (need 3 numbers)"),
            ("vn 0 x 0\n", "line 1: normal y coordinate 'x' is not a number"),
            (
                "vn 0 0 1\nvn 0 0 -inf\n",
                "line 2: normal 2 coordinate z is '-inf'; normals must be finite",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//2 3//1\n",
                "line 5: face normal index 2 is out of range (the file has 1 normals)",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//a 2 3\n",
                "line 4: face vertex '1//a' has normal index 'a', which is not an integer",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1.5 2 3\n",
                "line 4: face vertex '1/1/1.5' has normal index '1.5'",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//0 2 3\n",
                "line 4: face normal index 0 (OBJ indices start at 1)",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//-2 2 3\n",
                "line 5: face normal index -2 refers before the first",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//4294967296 2 3\n",
                "line 4: face normal index 4294967296 is out of range",
            ),
        ];
        for (text, expected) in cases {
            let e = parse_obj_file(text, None).unwrap_err().to_string();
            assert!(e.starts_with(expected), "{text:?} gave {e}");
        }
    }

    #[test]
    fn smoothing_group_statements() {
        let text = format!(
            "{TRIANGLE}f 1 2 3\ns 1\nf 1 2 3\ns off\nf 1 2 3\ns 0\nf 1 2 3\ns 4294967294\nf 1 2 3\ns OFF\nf 1 2 3\n"
        );
        assert_eq!(obj(&text).smoothing, [SMOOTH_DEFAULT, 1, 0, 0, u32::MAX - 1, 0]);
        for (s, problem) in [
            (
                "s x",
                "smoothing group 'x' is neither 'off' nor an integer in 0..=4294967294",
            ),
            ("s -1", "smoothing group '-1'"),
            ("s 1.5", "smoothing group '1.5'"),
            ("s 4294967295", "smoothing group '4294967295'"),
            ("s", "s needs a smoothing group number or 'off'"),
        ] {
            let e = parse_obj_file(&format!("{TRIANGLE}{s}\nf 1 2 3\n"), None)
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(&format!("line 4: {problem}")), "{s:?} gave {e}");
        }
    }

    #[test]
    fn triangle_faces_of_a_quad_and_a_pentagon() {
        let f = obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0.5 1.5 0\nv 0 1 0\nf 1 2 3\nf 1 2 3 4\nf 1 2 3 4 5\nf 3 4 5\n");
        assert_eq!(f.triangle_faces, [0, 1, 1, 2, 2, 2, 3]);
        assert_eq!(f.mesh.triangles[3..6], [[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    }

    #[test]
    fn unknown_statements_warn_once_per_keyword() {
        let f = obj(&format!(
            "{TRIANGLE}vt 0 0\nvp 0\nl 1 2\np 1\ncstype bspline\ncurv 0 1 1 2\nfoo 1\ncurv 0 1 1 2\nfoo\ncsh -x\nfoo\nf 1 2 3\n"
        ));
        assert_eq!(
            f.warnings,
            [
                "ignoring `cstype` statements (line 8): free-form/unsupported statement",
                "ignoring `curv` statements (line 9 and 1 more line): free-form/unsupported statement",
                "ignoring `foo` statements (line 10 and 2 more lines): unknown OBJ statement",
                "ignoring `csh` statements (line 13): free-form/unsupported statement",
            ]
        );
    }

    /// Two triangles folded at a right angle along the edge (v1, v2): A in
    /// z = 0 (normal +z), B in y = 0 (normal +y), same area.
    const FOLD: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 -1\n";

    fn shading(text: &str) -> Vec<Option<[Vec3; 3]>> {
        let f = obj(text);
        let (normals, corners) = f.shading_normals();
        assert_eq!(corners.len(), f.mesh.triangles.len());
        for n in &normals {
            assert!((n.length() - 1.0).abs() < 1e-6, "{n}");
        }
        corners
            .iter()
            .map(|c| c.map(|c| c.map(|i| normals[i as usize])))
            .collect()
    }

    #[test]
    fn smoothing_groups_choose_the_triangles_a_normal_averages() {
        let diagonal = Vec3::new(0.0, 1.0, 1.0).normalize();
        // One explicit group: the contract's vertex normals across the fold.
        let text = format!("{FOLD}s 7\nf 1 2 3\nf 1 2 4\n");
        let n = shading(&text);
        assert_eq!(
            n,
            [Some([diagonal, diagonal, Vec3::Z]), Some([diagonal, diagonal, Vec3::Y])]
        );
        let vertex = parse_obj(&text).unwrap().vertex_normals();
        assert_eq!(n[0], Some([vertex[0], vertex[1], vertex[2]]));
        assert_eq!(n[1], Some([vertex[0], vertex[1], vertex[3]]));
        // No `s`: the right-angled fold is a crease (beyond 60 degrees), so
        // each face keeps its own normal...
        assert_eq!(
            shading(&format!("{FOLD}f 1 2 3\nf 1 2 4\n")),
            [Some([Vec3::Z; 3]), Some([Vec3::Y; 3])]
        );
        // ...and a fold of 30 degrees is smoothed as the contract's normals.
        let shallow = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -0.866025 -0.5\nf 1 2 3\nf 1 4 2\n";
        let vertex = parse_obj(shallow).unwrap().vertex_normals();
        let n = shading(shallow);
        assert_eq!(n[0], Some([vertex[0], vertex[1], vertex[2]]));
        assert_eq!(n[1], Some([vertex[0], vertex[3], vertex[1]]));
        // Different groups: the shared vertices get a normal per group.
        let f = obj(&format!("{FOLD}s 1\nf 1 2 3\ns 2\nf 1 2 4\n"));
        let (normals, corners) = f.shading_normals();
        assert_eq!(corners, [Some([0, 0, 0]), Some([1, 1, 1])], "equal normals stored once");
        assert_eq!(normals, [Vec3::Z, Vec3::Y]);
        // `s off`: flat, and not part of the others' sums.
        assert_eq!(
            shading(&format!("{FOLD}f 1 2 3\ns off\nf 1 2 4\n")),
            [Some([Vec3::Z; 3]), None]
        );
        assert_eq!(shading(&format!("{FOLD}s 0\nf 1 2 3\nf 1 2 4\n")), [None, None]);
        // Equal normals are stored once: the shared vertices' diagonal, +z, +y.
        let (normals, corners) = obj(&format!("{FOLD}s 1\nf 1 2 3\nf 1 2 4\n")).shading_normals();
        assert_eq!((normals.len(), corners), (3, vec![Some([0, 0, 1]), Some([0, 0, 2])]));
    }

    #[test]
    fn vn_normals_come_first_and_are_normalised() {
        let f = obj(&format!(
            "{FOLD}vn 0 0 2\nvn 3 0 0\ns off\nf 1//1 2//1 3//2\nf 1//2 2//2 4//1\nf 1 2//1 4//1\n"
        ));
        let (normals, corners) = f.shading_normals();
        assert_eq!(normals, [Vec3::Z, Vec3::X], "each vn stored once, normalised");
        assert_eq!(
            corners,
            [Some([0, 0, 1]), Some([1, 1, 0]), None],
            "partial vn: the smoothing rule"
        );
        // A zero-length vn: the smoothing rule (here group 1).
        let n = shading(&format!("{FOLD}vn 0 0 0\ns 1\nf 1//1 2//1 3//1\nf 1 2 4\n"));
        let diagonal = Vec3::new(0.0, 1.0, 1.0).normalize();
        assert_eq!(n[0], Some([diagonal, diagonal, Vec3::Z]));
    }

    #[test]
    fn zero_vertex_normals_fall_back_to_flat() {
        // The same triangle both ways round: every vertex's sum is zero.
        let text = format!("{FOLD}s 1\nf 1 2 3\nf 1 3 2\nf 1 2 4\n");
        let n = shading(&text);
        assert_eq!(n[..2], [None, None]);
        assert_eq!(n[2], Some([Vec3::Y; 3]), "vertex 1 and 2 sums: +z - z + y");
        // A degenerate triangle alone.
        assert_eq!(shading("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"), [None]);
        // A face normal that would overflow f32 belongs to a mesh whose
        // extent f32 cannot handle: refused before any normal is computed.
        let e = parse_obj_file("v 0 0 0\nv 3e38 0 0\nv 0 3e38 0\nf 1 2 3\n", None).unwrap_err();
        assert!(e.to_string().contains("extent"), "{e}");
    }

    fn check_cornell(f: &ObjFile) {
        assert_eq!(f.mesh.positions.len(), 72);
        assert_eq!(f.mesh.triangles.len(), 36, "18 quads");
        let names: Vec<&str> = f.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "default",
                "floor",
                "ceiling",
                "backWall",
                "rightWall",
                "leftWall",
                "shortBox",
                "tallBox",
                "light"
            ]
        );
        let mut expected = vec![1, 1, 2, 2, 3, 3, 4, 4, 5, 5];
        expected.extend([6; 12]);
        expected.extend([7; 12]);
        expected.extend([8, 8]);
        assert_eq!(
            f.triangle_materials, expected,
            "usemtl, not g, decides (shortBox's faces come before its g)"
        );
        assert_eq!(f.materials[8].ke, Vec3::new(17.0, 12.0, 4.0));
        assert_eq!(f.materials[4].kd, Vec3::new(0.14, 0.45, 0.091));
        assert_eq!(f.triangle_faces, (0..36).map(|t| t / 2).collect::<Vec<u32>>());
        assert!(f.normals.is_empty());
        assert!(f.corner_normals.iter().all(|c| *c == [NO_NORMAL; 3]));
        assert!(f.smoothing.iter().all(|&s| s == SMOOTH_DEFAULT));
        let (_, corners) = f.shading_normals();
        assert!(corners.iter().all(Option::is_some));
    }

    #[test]
    fn cornell_box() {
        let dir = TempDir::new("cornell");
        let path = dir.write("CornellBox-Original.obj", CORNELL_OBJ);
        let mtl = dir.write("CornellBox-Original.mtl", CORNELL_MTL);
        let f = load_obj_file(&path).unwrap();
        check_cornell(&f);
        assert_eq!(
            f.warnings,
            [format!(
                "{}: ignoring `v` statements (line 70): unknown MTL statement",
                mtl.display()
            )],
            "the stray `v` line in the MTL file"
        );
        // Without its MTL file: every face gets the default material.
        std::fs::remove_file(&mtl).unwrap();
        let f = load_obj_file(&path).unwrap();
        assert!(f.triangle_materials.iter().all(|&m| m == 0));
        assert_eq!(f.warnings.len(), 1 + 3 + 1, "{:?}", f.warnings);
        assert_eq!(
            f.warnings[0],
            "mtllib 'CornellBox-Original.mtl' not found (line 12): faces use the default material"
        );
        // The shared copy, where the data set is given.
        // A relative data set is named from the repository's root.
        if let Some(data) = std::env::var_os("PENUMBRA_DATA") {
            let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
            let shared = root.join(data).join("scenes/CornellBox-Original.obj");
            let f = load_obj_file(&shared).unwrap();
            check_cornell(&f);
            assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
        }
    }

    #[test]
    fn many_unknown_material_names_are_counted_not_listed() {
        let mut text = String::from(TRIANGLE);
        for k in 0..10 {
            text += &format!("usemtl m{k}\nf 1 2 3\n");
        }
        let f = obj(&text);
        assert_eq!(f.warnings.len(), 4, "{:?}", f.warnings);
        assert!(f.warnings[3].starts_with("7 more usemtl names"), "{:?}", f.warnings);
        assert!(f.warnings[3].contains("'m3'"), "{:?}", f.warnings);
    }
}
