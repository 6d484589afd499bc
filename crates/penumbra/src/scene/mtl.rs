//! Wavefront MTL materials: the colours and scalars a ray tracer shades with.
//!
//! Tolerant of what real exporters write (comments after values, tabs, CRLF,
//! stray statements: warnings), strict on numbers (a value that is not a
//! finite number in range is an error naming the line). `map_Kd`, `map_Ka`,
//! `map_Ks` and `map_d` name texture maps (`texture`); their images are read
//! only when the scene is made ready to render. Bump, displacement and
//! reflection maps are not used (one warning per keyword).
//! Values are read by the letter of the spec, and each block records which
//! of the statements exporters disagree on it wrote (`MtlWritten`):
//! `mtl_rules` reads a file as its exporter meant from them.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use super::texture::{AlphaMap, MaterialMaps, TextureSource, parse_map_statement};
use crate::error::{Error, Result};

/// One `newmtl` block, fields as MTL names them (linear RGB).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Material {
    /// The `newmtl` name, or the key in a scene file's `"materials"`.
    pub name: String,
    /// `Ka`, ambient reflectance (>= 0): what reflects the scene's ambient
    /// light.
    pub ka: Vec3,
    /// `Kd`, diffuse reflectance (>= 0).
    pub kd: Vec3,
    /// `Ks`, specular reflectance (>= 0): the highlight's colour and, where
    /// `illum` asks for it, the mirror reflection's.
    pub ks: Vec3,
    /// `Ke`, emitted radiance (>= 0): a face with a non-zero `Ke` lights
    /// the scene when ray traced.
    pub ke: Vec3,
    /// Transmission filter `Tf`.
    pub tf: Vec3,
    /// `Ns`, Phong exponent (>= 0).
    pub ns: f32,
    /// `Ni`, index of refraction (> 0).
    pub ni: f32,
    /// Dissolve `d` in [0, 1] (1 = opaque); `Tr t` sets d = 1 - t (the
    /// common reading; `mtl_rules` reads it as d where the file writes
    /// opacity as `Tr`); `d` wins when both are given.
    pub dissolve: f32,
    /// Which of the statements exporters disagree on the block wrote, and
    /// `d`'s and `Tr`'s values as written (`scene::mtl_rules` reads them);
    /// nothing written for a material that is not an MTL file's.
    pub written: MtlWritten,
    /// `illum` 0..=10.
    pub illum: u32,
    /// Whether the file gave `Tf` (glass uses Tf when given, else 1 - d).
    pub has_tf: bool,
    /// A procedural checker texture on `Ka` and `Kd` (scene files only;
    /// MTL has no such field).
    pub checker: Option<Checker>,
    /// Texture maps (`map_Kd`, `map_Ka`, `map_Ks`, `map_d`), their files
    /// relative to the MTL file's folder until `resolve_maps` (which the
    /// OBJ reader calls) resolves them.
    pub maps: MaterialMaps,
}

/// What an MTL block wrote of the statements whose meaning depends on the
/// exporter (`Tf` is `Material::has_tf`): what the rules of
/// `scene::mtl_rules` take as evidence. `Default`: nothing written.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct MtlWritten {
    /// An `illum` statement.
    pub illum: bool,
    /// A `Ka` statement.
    pub ka: bool,
    /// A `Ke` statement.
    pub ke: bool,
    /// An `Ni` statement (`Ni 0` included).
    pub ni: bool,
    /// The last `d` value.
    pub d: Option<f32>,
    /// The last `Tr` value.
    pub tr: Option<f32>,
}

/// A solid checker texture (pbrt's 3D checkerboard): space is cut into
/// cubes of side `size` from `origin`; where the cube's integer
/// coordinates sum to an odd number, `Ka` and `Kd` are multiplied by
/// `odd`, elsewhere they are as given. A plane should lie inside one layer
/// of cubes (not on a boundary between layers), or rounding decides its
/// pattern.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Checker {
    /// The cubes' side, in scene units (> 0).
    pub size: f32,
    /// A corner of the cube (0, 0, 0).
    pub origin: Vec3,
    /// The factor on `Ka` and `Kd` in the odd cubes.
    pub odd: Vec3,
}

impl Material {
    /// Values for fields a `newmtl` block leaves out: ka 0, kd 0.8, ks 0,
    /// ke 0, tf 1, ns 1, ni 1, d 1, illum 2, has_tf false, nothing
    /// written.
    pub fn named(name: &str) -> Material {
        Material {
            name: name.into(),
            ka: Vec3::ZERO,
            kd: Vec3::splat(0.8),
            ks: Vec3::ZERO,
            ke: Vec3::ZERO,
            tf: Vec3::ONE,
            ns: 1.0,
            ni: 1.0,
            dissolve: 1.0,
            written: MtlWritten::default(),
            illum: 2,
            has_tf: false,
            checker: None,
            maps: MaterialMaps::default(),
        }
    }

    /// The material of faces with no `usemtl`, an unknown name or a missing
    /// MTL file: named "default", ka = kd = 0.8 grey, ks 0, illum 1 (diffuse).
    pub fn default_surface() -> Material {
        Material {
            ka: Vec3::splat(0.8),
            illum: 1,
            ..Material::named("default")
        }
    }
}

/// Reads an MTL file; errors name the file, the line and the problem.
/// Texture maps' files stay as written, relative to the file's folder
/// (`resolve_maps` makes them paths; the OBJ reader does).
pub fn load_mtl(path: &Path, warnings: &mut Vec<String>) -> Result<Vec<Material>> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    parse_mtl(&String::from_utf8_lossy(&bytes), warnings).map_err(|e| e.in_file(path))
}

/// Makes the maps' relative file names relative to `dir` (the MTL file's
/// folder). Exporters on Windows write `\` between folders: read as `/`.
pub fn resolve_maps(materials: &mut [Material], dir: &Path) {
    for m in materials {
        let maps = &mut m.maps;
        let alpha = maps.alpha.as_mut().map(|a| &mut a.map);
        for map in [
            maps.kd.as_deref_mut(),
            maps.ka.as_deref_mut(),
            maps.ks.as_deref_mut(),
            alpha,
        ]
        .into_iter()
        .flatten()
        {
            if let TextureSource::File(path) = &mut map.source {
                let name = path.to_string_lossy().replace('\\', "/");
                let relative = Path::new(&name);
                if relative.is_relative() {
                    *path = dir.join(relative);
                }
            }
        }
    }
}

/// Parses MTL text into its materials, in file order (a name defined twice
/// keeps its first position and its later block). Errors name the line
/// (`line N`) and the problem; what is ignored goes to `warnings`.
pub fn parse_mtl(text: &str, warnings: &mut Vec<String>) -> Result<Vec<Material>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut materials: Vec<Material> = Vec::new();
    let mut by_name: HashMap<String, usize> = HashMap::new();
    let mut ignored = Ignored::default();
    let mut block: Option<Block> = None;
    let mut args: Vec<&str> = Vec::with_capacity(8);

    for (line_index, raw) in text.lines().enumerate() {
        let line_no = line_index + 1;
        let at = || format!("line {line_no}");
        let line = raw.split('#').next().unwrap_or("");
        let mut tokens = line.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else {
            continue;
        };
        args.clear();
        args.extend(tokens);
        if keyword == "newmtl" {
            if args.is_empty() {
                return Err(Error::input(at(), "newmtl without a name"));
            }
            if let Some(done) = block.take() {
                done.finish(&mut materials, &mut by_name, warnings);
            }
            block = Some(Block::new(&args.join(" "), line_no));
            continue;
        }
        if matches!(keyword, "map_Kd" | "map_Ka" | "map_Ks" | "map_d") {
            let Some(b) = block.as_mut() else {
                ignored.note(keyword, line_no, "a map before any newmtl belongs to no material");
                continue;
            };
            let mut skipped = Vec::new();
            let (file, mut map) =
                parse_map_statement(&args, &mut skipped).map_err(|p| Error::input(at(), format!("{keyword}: {p}")))?;
            for option in skipped {
                ignored.note(&format!("{keyword} {option}"), line_no, "this map option is not used");
            }
            map.source = TextureSource::File(file.into());
            let maps = &mut b.material.maps;
            match keyword {
                "map_Kd" => maps.kd = Some(Box::new(map)),
                "map_Ka" => maps.ka = Some(Box::new(map)),
                "map_Ks" => maps.ks = Some(Box::new(map)),
                _ => {
                    maps.alpha = Some(Box::new(AlphaMap {
                        map,
                        factor: 1.0,
                        cutoff: 0.5,
                        luminance: true,
                    }))
                }
            }
            continue;
        }
        if !is_property(keyword) {
            let reason =
                if keyword.starts_with("map_") || matches!(keyword, "bump" | "disp" | "decal" | "refl" | "norm") {
                    "bump, displacement, reflection and other maps than map_Kd, map_Ka, map_Ks and map_d are not used"
                } else {
                    "unknown MTL statement"
                };
            ignored.note(keyword, line_no, reason);
            continue;
        }
        let Some(b) = block.as_mut() else {
            return Err(Error::input(at(), format!("{keyword} before any newmtl")));
        };
        let m = &mut b.material;
        let problem = |p: String| Error::input(at(), format!("{keyword}: {p}"));
        match keyword {
            "Ka" | "Kd" | "Ks" | "Ke" | "Tf" => {
                if args.first() == Some(&"spectral") {
                    ignored.note(
                        &format!("{keyword} spectral"),
                        line_no,
                        "spectral colours are not supported",
                    );
                    continue;
                }
                let c = colour(&args).map_err(problem)?;
                match keyword {
                    "Ka" => {
                        m.ka = c;
                        m.written.ka = true;
                    }
                    "Kd" => m.kd = c,
                    "Ks" => m.ks = c,
                    "Ke" => {
                        m.ke = c;
                        m.written.ke = true;
                    }
                    _ => {
                        m.tf = c;
                        m.has_tf = true;
                    }
                }
            }
            "Ns" => {
                let v = scalar(&args).map_err(problem)?;
                if v < 0.0 {
                    return Err(problem(format!("{v} is negative (the Phong exponent must be >= 0)")));
                }
                m.ns = v;
            }
            "Ni" => {
                let v = scalar(&args).map_err(problem)?;
                if v < 0.0 {
                    return Err(problem(format!("{v} is negative (an index of refraction is > 0)")));
                }
                m.written.ni = true;
                if v == 0.0 {
                    // Some exporters write `Ni 0` for "not set". One
                    // warning per material (when it ends), not per line:
                    // each names the material.
                    match &mut b.ni_zero {
                        Some((_, more)) => *more += 1,
                        None => b.ni_zero = Some((line_no, 0)),
                    }
                } else {
                    m.ni = v;
                }
            }
            "d" | "Tr" => {
                let v = scalar(&args).map_err(problem)?;
                if !(0.0..=1.0).contains(&v) {
                    return Err(problem(format!("{v} is outside [0, 1]")));
                }
                if keyword == "d" {
                    m.dissolve = v;
                    m.written.d = Some(v);
                } else {
                    m.written.tr = Some(v);
                }
            }
            _ => {
                // illum
                let [token] = args[..] else {
                    return Err(problem(format!("takes 1 integer, got {}", args.len())));
                };
                m.illum = token
                    .parse::<u32>()
                    .ok()
                    .filter(|i| *i <= 10)
                    .ok_or_else(|| problem(format!("'{token}' is not an integer in 0..=10")))?;
                m.written.illum = true;
            }
        }
    }
    if let Some(done) = block.take() {
        done.finish(&mut materials, &mut by_name, warnings);
    }
    ignored.warn(warnings);
    if materials.is_empty() {
        warnings.push("no materials (the file has no newmtl)".into());
    }
    Ok(materials)
}

fn is_property(keyword: &str) -> bool {
    matches!(
        keyword,
        "Ka" | "Kd" | "Ks" | "Ke" | "Tf" | "Ns" | "Ni" | "d" | "Tr" | "illum"
    )
}

/// A `newmtl` block being read.
struct Block {
    material: Material,
    line: usize,
    /// The first `Ni 0` line and how many more came.
    ni_zero: Option<(usize, usize)>,
}

impl Block {
    fn new(name: &str, line: usize) -> Block {
        Block {
            material: Material::named(name),
            line,
            ni_zero: None,
        }
    }

    fn finish(
        mut self,
        materials: &mut Vec<Material>,
        by_name: &mut HashMap<String, usize>,
        warnings: &mut Vec<String>,
    ) {
        let m = &mut self.material;
        if let Some((line, more)) = self.ni_zero {
            let more = match more {
                0 => String::new(),
                1 => " and 1 more line".into(),
                n => format!(" and {n} more lines"),
            };
            warnings.push(format!(
                "material '{}': Ni 0 (line {line}{more}) is not an index of refraction; {} is used",
                m.name, m.ni
            ));
        }
        // The common reading of `Tr`; `scene::mtl_rules` reads it as `d`
        // where the file shows that convention.
        if let (None, Some(tr)) = (m.written.d, m.written.tr) {
            m.dissolve = 1.0 - tr;
        }
        match by_name.get(&m.name) {
            Some(&i) => {
                warnings.push(format!(
                    "material '{}' defined again (line {}): the later block wins",
                    m.name, self.line
                ));
                materials[i] = self.material;
            }
            None => {
                by_name.insert(m.name.clone(), materials.len());
                materials.push(self.material);
            }
        }
    }
}

/// A colour statement's arguments: 1 or 3 numbers (1 = grey), or `xyz`
/// and 1 or 3 CIE XYZ numbers (converted to linear sRGB, D65).
fn colour(args: &[&str]) -> std::result::Result<Vec3, String> {
    let (xyz, numbers) = match args.first() {
        Some(&"xyz") => (true, &args[1..]),
        _ => (false, args),
    };
    if numbers.len() > 3 {
        return Err(format!("more than 3 numbers ({})", numbers.len()));
    }
    let mut c = [0.0f32; 3];
    for (slot, token) in c.iter_mut().zip(numbers) {
        *slot = number(token)?;
        if *slot < 0.0 {
            return Err(format!("colour component {token} is negative"));
        }
    }
    let c = match numbers.len() {
        0 => return Err("missing number (need 1 or 3)".into()),
        1 => Vec3::splat(c[0]),
        2 => return Err("has 2 numbers (need 1 or 3)".into()),
        _ => Vec3::from_array(c),
    };
    if !xyz {
        return Ok(c);
    }
    xyz_to_linear_srgb(c).ok_or_else(|| {
        format!(
            "xyz {} is too large to convert to RGB (a component overflows)",
            numbers.join(" ")
        )
    })
}

/// CIE XYZ to linear sRGB (D65 white, IEC 61966-2-1 matrix); colours
/// outside the sRGB gamut are clipped to >= 0. None where a component
/// overflows f32 (XYZ components near f32's largest).
fn xyz_to_linear_srgb(c: Vec3) -> Option<Vec3> {
    let r = 3.240_454_2 * c.x - 1.537_138_5 * c.y - 0.498_531_4 * c.z;
    let g = -0.969_266 * c.x + 1.876_010_8 * c.y + 0.041_556 * c.z;
    let b = 0.055_643_4 * c.x - 0.204_025_9 * c.y + 1.057_225_2 * c.z;
    let rgb = Vec3::new(r, g, b);
    rgb.is_finite().then(|| rgb.max(Vec3::ZERO))
}

/// A statement's one number.
fn scalar(args: &[&str]) -> std::result::Result<f32, String> {
    match args {
        [] => Err("missing number".into()),
        [token] => number(token),
        _ => Err(format!("takes 1 number, got {}", args.len())),
    }
}

fn number(token: &str) -> std::result::Result<f32, String> {
    let v: f32 = token.parse().map_err(|_| format!("'{token}' is not a number"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("'{token}' is not a finite number"))
    }
}

/// Statements skipped, one warning per keyword however often it appears:
/// "ignoring `map_Kd` statements (line 14 and 2 more lines): texture maps
/// are not used".
#[derive(Default)]
pub(super) struct Ignored {
    /// Keyword, first line, count, reason; in order of first appearance.
    entries: Vec<(String, usize, usize, &'static str)>,
    index: HashMap<String, usize>,
}

impl Ignored {
    pub(super) fn note(&mut self, keyword: &str, line: usize, reason: &'static str) {
        match self.index.get(keyword) {
            Some(&i) => self.entries[i].2 += 1,
            None => {
                self.index.insert(keyword.to_string(), self.entries.len());
                self.entries.push((keyword.to_string(), line, 1, reason));
            }
        }
    }

    /// Appends one warning per keyword noted, in order of first appearance.
    pub(super) fn warn(self, warnings: &mut Vec<String>) {
        for (keyword, line, count, reason) in self.entries {
            let more = match count - 1 {
                0 => String::new(),
                1 => " and 1 more line".into(),
                n => format!(" and {n} more lines"),
            };
            warnings.push(format!("ignoring `{keyword}` statements (line {line}{more}): {reason}"));
        }
    }
}

/// Writes materials as MTL text that `parse_mtl` reads back to the same
/// values (every field written, `Tf` only where it was given).
pub fn write_mtl(materials: &[Material], header: &str) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for line in header.lines() {
        let _ = writeln!(s, "# {line}");
    }
    let rgb = |v: Vec3| format!("{} {} {}", v.x, v.y, v.z);
    for m in materials {
        let _ = writeln!(s, "\nnewmtl {}", m.name);
        let _ = writeln!(
            s,
            "Ka {}\nKd {}\nKs {}\nKe {}",
            rgb(m.ka),
            rgb(m.kd),
            rgb(m.ks),
            rgb(m.ke)
        );
        if m.has_tf {
            let _ = writeln!(s, "Tf {}", rgb(m.tf));
        }
        let _ = writeln!(s, "Ns {}\nNi {}\nd {}\nillum {}", m.ns, m.ni, m.dissolve, m.illum);
        let maps = &m.maps;
        let alpha = maps.alpha.as_ref().map(|a| &a.map);
        for (keyword, map) in [
            ("map_Kd", maps.kd.as_deref()),
            ("map_Ka", maps.ka.as_deref()),
            ("map_Ks", maps.ks.as_deref()),
            ("map_d", alpha),
        ] {
            let Some(map) = map else { continue };
            let mut options = String::new();
            if map.scale != glam::Vec2::ONE {
                let _ = write!(options, "-s {} {} ", map.scale.x, map.scale.y);
            }
            if map.offset != glam::Vec2::ZERO {
                let _ = write!(options, "-o {} {} ", map.offset.x, map.offset.y);
            }
            if map.clamp {
                options.push_str("-clamp on ");
            }
            let _ = writeln!(s, "{keyword} {options}{}", map.source.name());
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    const CORNELL: &str = include_str!("../../tests/data/mtl/cornell.mtl");

    fn parse(text: &str) -> (Vec<Material>, Vec<String>) {
        let mut warnings = Vec::new();
        let m = parse_mtl(text, &mut warnings).unwrap_or_else(|e| panic!("{text:?}: {e}"));
        (m, warnings)
    }

    fn error(text: &str) -> String {
        parse_mtl(text, &mut Vec::new()).unwrap_err().to_string()
    }

    #[test]
    fn defaults() {
        let m = Material::named("x");
        assert_eq!(
            (m.kd, m.ka, m.tf, m.ns, m.ni, m.dissolve, m.illum),
            (Vec3::splat(0.8), Vec3::ZERO, Vec3::ONE, 1.0, 1.0, 1.0, 2)
        );
        assert!(!m.has_tf);
        let d = Material::default_surface();
        assert_eq!(
            (d.name.as_str(), d.ka, d.kd, d.ks, d.illum),
            ("default", Vec3::splat(0.8), Vec3::splat(0.8), Vec3::ZERO, 1)
        );
        // A block that gives nothing gets `named`'s values.
        assert_eq!(parse("newmtl x\n").0, vec![Material::named("x")]);
    }

    #[test]
    fn cornell_box_materials() {
        let (m, warnings) = parse(CORNELL);
        let names: Vec<&str> = m.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "leftWall",
                "rightWall",
                "floor",
                "ceiling",
                "backWall",
                "shortBox",
                "tallBox",
                "light"
            ]
        );
        assert_eq!(m[7].ke, Vec3::new(17.0, 12.0, 4.0));
        assert_eq!(m[7].kd, Vec3::splat(0.78));
        assert_eq!(m[1].kd, Vec3::new(0.14, 0.45, 0.091));
        assert_eq!(m[1].ka, Vec3::new(0.14, 0.15, 0.091), "the comment after Ka is dropped");
        assert_eq!(m[0].kd, Vec3::new(0.63, 0.065, 0.05));
        assert_eq!((m[0].ns, m[0].ni, m[0].illum), (10.0, 1.5, 2));
        assert_eq!((m[2].ni, m[2].ke, m[2].dissolve), (1.0, Vec3::ZERO, 1.0));
        assert_eq!(
            warnings,
            ["ignoring `v` statements (line 70): unknown MTL statement"],
            "the stray `v` line in shortBox"
        );
    }

    #[test]
    fn line_endings_and_tabs_do_not_matter() {
        let lf = CORNELL.replace("\r\n", "\n");
        let crlf = lf.replace('\n', "\r\n");
        let tabs = lf.replace("  ", "\t").replace(' ', "\t \t");
        let crlf_tabs = tabs.replace('\n', "\r\n");
        let reference = parse(CORNELL);
        assert_eq!(parse(&lf), reference);
        assert_eq!(parse(&crlf), reference);
        assert_eq!(parse(&tabs), reference);
        assert_eq!(parse(&crlf_tabs), reference);
        assert_eq!(
            parse(&format!("\u{feff}{lf}")),
            reference,
            "a byte-order mark is skipped"
        );
    }

    #[test]
    fn errors_name_the_line_and_problem() {
        let cases = [
            ("newmtl a\nKd 1 abc 1\n", "line 2", "Kd: 'abc' is not a number"),
            ("newmtl a\n\nKs\n", "line 3", "Ks: missing number"),
            ("newmtl a\nKa xyz\n", "line 2", "Ka: missing number"),
            ("newmtl a\nNs\n", "line 2", "Ns: missing number"),
            ("newmtl a\nKe 1 inf 1\n", "line 2", "Ke: 'inf' is not a finite number"),
            ("newmtl a\nNi NaN\n", "line 2", "Ni: 'NaN' is not a finite number"),
            ("newmtl a\nd 1e40\n", "line 2", "d: '1e40' is not a finite number"),
            ("newmtl a\nKd 1 2 3 4\n", "line 2", "Kd: more than 3 numbers"),
            ("newmtl a\nKd 1 2\n", "line 2", "Kd: has 2 numbers (need 1 or 3)"),
            ("newmtl a\nNs 1 2\n", "line 2", "Ns: takes 1 number, got 2"),
            (
                "newmtl a\nTf 1 -0.5 1\n",
                "line 2",
                "Tf: colour component -0.5 is negative",
            ),
            ("newmtl a\nKd xyz -1\n", "line 2", "Kd: colour component -1 is negative"),
            ("newmtl a\nNs -1\n", "line 2", "Ns: -1 is negative"),
            ("newmtl a\nNi -1\n", "line 2", "Ni: -1 is negative"),
            ("newmtl a\nNi -1.5\n", "line 2", "Ni: -1.5 is negative"),
            ("newmtl a\nd 1.5\n", "line 2", "d: 1.5 is outside [0, 1]"),
            ("newmtl a\nd -0.1\n", "line 2", "d: -0.1 is outside [0, 1]"),
            ("newmtl a\nTr 2\n", "line 2", "Tr: 2 is outside [0, 1]"),
            (
                "newmtl a\nillum 11\n",
                "line 2",
                "illum: '11' is not an integer in 0..=10",
            ),
            (
                "newmtl a\nillum 2.0\n",
                "line 2",
                "illum: '2.0' is not an integer in 0..=10",
            ),
            (
                "newmtl a\nillum -1\n",
                "line 2",
                "illum: '-1' is not an integer in 0..=10",
            ),
            ("newmtl a\nillum\n", "line 2", "illum: takes 1 integer, got 0"),
            ("# header\nKd 1 1 1\nnewmtl a\n", "line 2", "Kd before any newmtl"),
            ("newmtl a\nnewmtl # no name\n", "line 2", "newmtl without a name"),
        ];
        for (text, place, problem) in cases {
            let e = error(text);
            assert!(e.starts_with(&format!("{place}: {problem}")), "{text:?} gave {e}");
        }
        // Unknown statements before the first newmtl are only warnings.
        let (m, w) = parse("map_Kd x.png\nnewmtl a\n");
        assert_eq!((m.len(), w.len()), (1, 1));
    }

    #[test]
    fn load_names_the_file() {
        let dir = std::env::temp_dir().join(format!("penumbra-mtl-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.mtl");
        std::fs::write(&path, "newmtl a\nKd 0.5\nNs x\n").unwrap();
        let e = load_mtl(&path, &mut Vec::new()).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("{}: line 3: Ns: 'x' is not a number", path.display())
        );
        assert_eq!(e.exit_code(), 2);
        let e = load_mtl(&dir.join("missing.mtl"), &mut Vec::new())
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing.mtl") && e.contains("cannot read"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn one_warning_per_unknown_keyword() {
        let text = "newmtl a\nmap_Kd a.png\nPr 0.5\nmap_Kd b.png\nbump n.png\nmap_Kd c.png\nKd spectral x.rfl\n\
                    Ks spectral y.rfl 2\nKd 0.5\n";
        let (m, w) = parse(text);
        assert_eq!(m[0].kd, Vec3::splat(0.5));
        assert_eq!(m[0].ks, Vec3::ZERO, "a spectral colour is ignored");
        assert_eq!(
            m[0].maps.kd.as_deref().map(|k| k.source.name()),
            Some("c.png".into()),
            "the last map_Kd wins"
        );
        assert_eq!(
            w,
            [
                "ignoring `Pr` statements (line 3): unknown MTL statement",
                "ignoring `bump` statements (line 5): bump, displacement, reflection and other maps than map_Kd, map_Ka, map_Ks and map_d are not used",
                "ignoring `Kd spectral` statements (line 7): spectral colours are not supported",
                "ignoring `Ks spectral` statements (line 8): spectral colours are not supported",
            ]
        );
        let (_, w) = parse("newmtl a\nkd 1 1 1\nnorm n.png\nnorm n.png\n");
        assert_eq!(
            w,
            [
                "ignoring `kd` statements (line 2): unknown MTL statement",
                "ignoring `norm` statements (line 3 and 1 more line): bump, displacement, reflection and other maps than map_Kd, map_Ka, map_Ks and map_d are not used",
            ],
            "keywords are case-sensitive"
        );
    }

    #[test]
    fn texture_maps_and_their_options() {
        let text = "newmtl a\nKd 0 0 0\nmap_Kd -s 2 2 1 -o 0.5 0 0 -clamp on tex\\wood grain.png\nmap_Ka amb.tga\n\
                    map_Ks -bm 0.2 spec.jpg\nmap_d -imfchan m leaf.png\nnewmtl b\n";
        let (m, w) = parse(text);
        let kd = m[0].maps.kd.as_deref().unwrap();
        assert_eq!(kd.source.name(), "tex\\wood grain.png");
        assert_eq!(
            (kd.scale, kd.offset, kd.clamp),
            (glam::Vec2::splat(2.0), glam::Vec2::new(0.5, 0.0), true)
        );
        assert_eq!(m[0].maps.ka.as_deref().unwrap().source.name(), "amb.tga");
        assert_eq!(m[0].maps.ks.as_deref().unwrap().source.name(), "spec.jpg");
        let alpha = m[0].maps.alpha.as_ref().unwrap();
        assert_eq!(
            (alpha.map.source.name().as_str(), alpha.factor, alpha.cutoff),
            ("leaf.png", 1.0, 0.5)
        );
        assert!(m[1].maps.is_empty());
        assert_eq!(
            w,
            [
                "ignoring `map_Ks -bm` statements (line 5): this map option is not used",
                "ignoring `map_d -imfchan` statements (line 6): this map option is not used",
            ]
        );
        // Resolved against the MTL file's folder, `\\` read as `/`.
        let mut m = m;
        resolve_maps(&mut m, Path::new("/scenes/room"));
        assert_eq!(
            m[0].maps.kd.as_deref().unwrap().source,
            TextureSource::File("/scenes/room/tex/wood grain.png".into())
        );
        // A bad option is an error naming the line; a map before any
        // material a warning.
        assert_eq!(
            error("newmtl a\nmap_Kd -clamp maybe x.png\n"),
            "line 2: map_Kd: -clamp 'maybe' is neither on nor off"
        );
        assert_eq!(error("newmtl a\nmap_d\n"), "line 2: map_d: names no image file");
        let (_, w) = parse("map_Kd x.png\nnewmtl a\n");
        assert_eq!(
            w,
            ["ignoring `map_Kd` statements (line 1): a map before any newmtl belongs to no material"]
        );
        // Written and read back the same.
        let (m, _) = parse(text);
        let again = parse_mtl(&write_mtl(&m, "t"), &mut Vec::new()).unwrap();
        let maps = |m: &[Material]| m.iter().map(|m| m.maps.clone()).collect::<Vec<_>>();
        assert_eq!(maps(&again), maps(&m));
    }

    #[test]
    fn dissolve_and_transmission() {
        let (m, w) = parse(
            "newmtl both\nTr 0.25\nd 0.5\nnewmtl tr\nTr 0.25\nnewmtl d_first\nd 0.9\nTr 0.3\n\
             newmtl opaque_tr\nTr 1\nnewmtl glass\nTr 0.8\nillum 7\nTf 0.9 1 0.9\nnewmtl tf_grey\nTf 0.5\n",
        );
        let d: Vec<f32> = m.iter().map(|m| m.dissolve).collect();
        assert_eq!(d, [0.5, 0.75, 0.9, 0.0, 1.0 - 0.8, 1.0]);
        // What Tr 1 alone means depends on the exporter: the rules
        // (`scene::mtl_rules`) decide and warn, not the parser.
        assert!(w.is_empty(), "{w:?}");
        let written: Vec<(Option<f32>, Option<f32>)> = m.iter().map(|m| (m.written.d, m.written.tr)).collect();
        assert_eq!(
            written,
            [
                (Some(0.5), Some(0.25)),
                (None, Some(0.25)),
                (Some(0.9), Some(0.3)),
                (None, Some(1.0)),
                (None, Some(0.8)),
                (None, None)
            ]
        );
        assert_eq!((m[4].tf, m[4].has_tf, m[4].illum), (Vec3::new(0.9, 1.0, 0.9), true, 7));
        assert_eq!((m[5].tf, m[5].has_tf), (Vec3::splat(0.5), true));
        assert!(!m[0].has_tf);
    }

    #[test]
    fn xyz_colours_become_linear_srgb() {
        let (m, w) = parse("newmtl a\nKd xyz 0.9505 1.0 1.089\nKs xyz 0.5\nKe 2\n");
        assert!(w.is_empty(), "{w:?}");
        assert!((m[0].kd - Vec3::ONE).abs().max_element() < 1e-3, "{}", m[0].kd);
        // One number means X = Y = Z.
        let grey = xyz_to_linear_srgb(Vec3::splat(0.5)).unwrap();
        assert_eq!(m[0].ks, grey);
        assert!(
            (grey - Vec3::new(0.6023, 0.4742, 0.4544)).abs().max_element() < 1e-3,
            "{grey}"
        );
        assert_eq!(m[0].ke, Vec3::splat(2.0));
        // Out of the sRGB gamut: clipped, never negative.
        assert!(xyz_to_linear_srgb(Vec3::new(0.0, 1.0, 0.0)).unwrap().min_element() >= 0.0);
        // Components near f32's largest overflow in the conversion: an
        // error naming the line, not an infinite colour.
        let mut w = Vec::new();
        let e = parse_mtl("newmtl a\nKa xyz 0 2e38 0\n", &mut w)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "line 2: Ka: xyz 0 2e38 0 is too large to convert to RGB (a component overflows)"
        );
    }

    #[test]
    fn duplicates_and_empty_files() {
        let (m, w) = parse("newmtl a\nKd 0.1\nnewmtl b\nnewmtl a\nKd 0.2\n");
        assert_eq!(m.len(), 2);
        assert_eq!((m[0].name.as_str(), m[0].kd), ("a", Vec3::splat(0.2)));
        assert_eq!(w, ["material 'a' defined again (line 4): the later block wins"]);
        for text in ["", "# only a comment\r\n\r\n", "map_Kd x.png\n"] {
            let (m, w) = parse(text);
            assert!(m.is_empty());
            assert_eq!(
                w.last().map(String::as_str),
                Some("no materials (the file has no newmtl)"),
                "{text:?}"
            );
        }
        // A name with spaces is kept, joined by single spaces.
        assert_eq!(parse("newmtl my \t mat\n").0[0].name, "my mat");
    }

    #[test]
    fn written_materials_read_back_the_same() {
        let glass = Material {
            ks: Vec3::splat(0.1),
            tf: Vec3::new(0.9, 0.95, 1.0),
            has_tf: true,
            ni: 1.5,
            illum: 7,
            ..Material::named("glass")
        };
        let light = Material {
            ke: Vec3::new(17.0, 12.0, 4.0),
            ..Material::named("light")
        };
        let text = write_mtl(&[glass.clone(), light.clone()], "test\ntwo lines");
        let mut warnings = Vec::new();
        // Read back, every statement was written.
        let all = |m: Material| Material {
            written: MtlWritten {
                illum: true,
                ka: true,
                ke: true,
                ni: true,
                d: Some(m.dissolve),
                tr: None,
            },
            ..m
        };
        assert_eq!(parse_mtl(&text, &mut warnings).unwrap(), vec![all(glass), all(light)]);
        assert!(warnings.is_empty(), "{warnings:?}");
    }

    #[test]
    fn what_was_written_is_recorded() {
        let (m, _) = parse("newmtl a\nKa 0 0 0\nKe 0\nNi 0\nillum 2\nnewmtl b\nKa xyz 1\nNi 1.5\nd 1\nd 0.5\n");
        assert_eq!(
            m[0].written,
            MtlWritten {
                illum: true,
                ka: true,
                ke: true,
                ni: true,
                d: None,
                tr: None
            },
            "values equal to the defaults are still written"
        );
        assert_eq!(
            m[1].written,
            MtlWritten {
                ka: true,
                ni: true,
                d: Some(0.5),
                ..MtlWritten::default()
            }
        );
        assert_eq!(
            parse("newmtl c\nKd 1\nNs 3\nTf 1\n").0[0].written,
            MtlWritten::default()
        );
    }

    #[test]
    fn ni_zero_is_a_warning_and_means_one() {
        let mut warnings = Vec::new();
        let m = parse_mtl("newmtl a\nNi 0\nillum 7\n", &mut warnings).unwrap();
        assert_eq!(m[0].ni, 1.0);
        assert_eq!(warnings.len(), 1);
        assert!(warnings[0].contains("Ni 0 (line 2)"), "{warnings:?}");
        // One warning per material however many lines say it.
        let mut warnings = Vec::new();
        parse_mtl("newmtl a\nNi 0\nNi 0\nNi 0\nnewmtl b\nNi 0\n", &mut warnings).unwrap();
        assert_eq!(
            warnings,
            [
                "material 'a': Ni 0 (line 2 and 2 more lines) is not an index of refraction; 1 is used",
                "material 'b': Ni 0 (line 6) is not an index of refraction; 1 is used"
            ]
        );
    }
}
