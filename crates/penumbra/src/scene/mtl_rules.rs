//! MTL as exporters write it: rules that read an MTL file's materials the
//! way the program that wrote them meant, where the letter of the MTL spec
//! renders them visibly wrong.
//!
//! The parser (`mtl`) reads every file by the spec and records what each
//! block wrote (`MtlWritten`); these rules are a pure function over one
//! OBJ file's materials (`MeshShading::materials`), applied when a scene is
//! made ready to render (`whitted::RenderScene::new`). Scene-file
//! `"materials"` are penumbra's own and are never subject to them. Each rule
//! needs evidence in the file itself, so a file written to the letter of
//! the spec (penumbra's own generator's, a hand-written one) passes
//! unchanged; `MtlRules::Spec` turns them all off. The rules, in the order
//! they are applied:
//!
//! - `tr-as-d`: `Tr` is commonly transparency (d = 1 - Tr, penumbra's
//!   reading), but some exporters (MeshLab's, some 3ds Max plug-ins) write
//!   the opacity under that name, `Tr 1` for an opaque surface. A file
//!   shows which: a material giving both `d` and `Tr` with d = Tr (not
//!   d = 1 - Tr), or, with no such pair, every material that gives `Tr`
//!   alone giving `Tr 1` (fully invisible under the common reading: no one
//!   models a scene of invisible surfaces). Materials giving `Tr` alone then
//!   take d = Tr. Pairs that disagree (one d = Tr, another d = 1 - Tr)
//!   decide nothing.
//! - `default-emission`: some exporters write an emission colour on every
//!   material (one that reads Blender 4's Principled "Emission Color",
//!   white by default, without its strength, 0 by default, writes
//!   `Ke 1 1 1` everywhere), turning every face into a light. Where every
//!   material emits and one `Ke` is shared by more than half of them (at
//!   least two), that `Ke` is an exporter's default, not a light: those
//!   materials take `Ke 0`; materials with another `Ke` stay lights.
//! - `white-ambient`: Blender (2.8 onwards) writes `Ka 1 1 1` on every
//!   non-metallic material (and the metallic factor, grey, on metals): it
//!   has no ambient colour, but penumbra lights `Ka` with the ambient light,
//!   which greys every shadow and makes black things grey. In a file in
//!   Blender's shape (every material writes `Ka`, `Ke`, `Ni`, `d` and
//!   `illum`, none `Tf` or `Tr`; every `Ka` is 1 1 1, or grey on a mirror,
//!   illum 3 or 6), a `Ka 1 1 1` with another `Kd` takes Ka = Kd, as 3ds
//!   Max and the Cornell box write it (except a black `Kd` beside a
//!   `map_Kd`: the map is then the colour, and the ambient light takes it
//!   through `Ka 1`).
//! - `invisible-glass`: Maya's OBJ exporter (and programs that copy it)
//!   writes every material as `illum 4` (glass) with `Tf 1 1 1` and `Ni 1`
//!   for an opaque one. By the letter of the spec that is a glass that
//!   neither filters (Tf 1), bends (Ni 1) nor dissolves (d 1): invisible,
//!   only its highlight and reflection left, which no one means. Such a
//!   material is rendered opaque as illum 3 (Phong and mirror reflection
//!   `Ks`, which illum 4 also has: the rule takes away only the
//!   transmission the exporter did not mean). Only illum 4: no exporter is
//!   known to write 6, 7 or 9 for opaque surfaces, and a hand-written clear
//!   glass of index 1 stays as written.
//! - `maya-opacity`: Maya writes `Tf` = 1 - transparency, an opacity, not
//!   the spec's transmission filter: `Tf 1 1 1` opaque, `Tf 0 0 0` fully
//!   see-through. In a file in Maya's shape (every material `illum 4` with
//!   `Tf` and `Ni`, none with `d`, `Tr` or `Ke`) that shows it (some
//!   material is an `invisible-glass`), the other materials are read so:
//!   a `Tf 1 1 1` one (with an `Ni` other than 1) is opaque (illum 3); any
//!   other transmits 1 - Tf, refracting with its `Ni`, and its `Ka` and
//!   `Kd` are scaled by Tf (Maya fades a transparent surface's colour as it
//!   clears). Without a Tf-1 opaque material the file shows nothing about
//!   its `Tf`, and the spec's reading stands.
//!
//! Read the same way by every exporter and left as the spec says: `Ni`
//! without a glass `illum` (Blender's 1.45 and 3ds Max's 1.5 on every
//! material), `Tf` without one (3ds Max's `Tf 1 1 1`), `Ka` = `Kd` (3ds
//! Max), `d` from Blender's alpha (illum 9 with d < 1 is its glass), and a
//! `Ke` only some materials have (lights).

use std::collections::HashMap;

use glam::Vec3;

use super::SceneMesh;
use super::mtl::Material;

/// How the materials of MTL files are read when rendered.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum MtlRules {
    /// As the file shows its exporter meant (Maya's opaque illum 4, Tr
    /// written as opacity, ...); each rule applied is reported.
    #[default]
    Exporters,
    /// The letter of the MTL spec, whoever wrote the file.
    Spec,
}

crate::choice!(MtlRules { Exporters = "exporters", Spec = "spec" });

/// One of the rules (see the module's description).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MtlRule {
    /// `Tr` read as `d` where the file writes opacity under that name.
    TrAsD,
    /// A `Ke` most materials share, where all emit, taken as 0.
    DefaultEmission,
    /// Blender's `Ka 1 1 1` taken as Ka = Kd.
    WhiteAmbient,
    /// `illum 4`, `Tf 1 1 1`, `Ni 1`, `d 1` rendered opaque.
    InvisibleGlass,
    /// Maya's `Tf` read as opacity.
    MayaOpacity,
}

impl MtlRule {
    /// Every rule, in the order they are applied.
    pub const ALL: [MtlRule; 5] = [
        MtlRule::TrAsD,
        MtlRule::DefaultEmission,
        MtlRule::WhiteAmbient,
        MtlRule::InvisibleGlass,
        MtlRule::MayaOpacity,
    ];

    /// The rule's name (as the JSON report writes it).
    pub fn name(self) -> &'static str {
        match self {
            MtlRule::TrAsD => "tr-as-d",
            MtlRule::DefaultEmission => "default-emission",
            MtlRule::WhiteAmbient => "white-ambient",
            MtlRule::InvisibleGlass => "invisible-glass",
            MtlRule::MayaOpacity => "maya-opacity",
        }
    }

    /// What the materials it changes have in common, and what they become.
    fn change(self) -> &'static str {
        match self {
            MtlRule::TrAsD => {
                "give Tr without d in a file that writes opacity as Tr (a d/Tr pair with d = Tr, or Tr 1 \
                 on every Tr-only material): d = Tr, not 1 - Tr"
            }
            MtlRule::DefaultEmission => {
                "share the Ke of most of a file whose every material emits (an exporter's default, not \
                 lights): Ke 0"
            }
            MtlRule::WhiteAmbient => {
                "have Blender's Ka 1 1 1 (it has no ambient colour; a white Ka greys every shadow): Ka = Kd"
            }
            MtlRule::InvisibleGlass => {
                "are illum 4 glass with Tf 1 1 1, Ni 1 and d 1, which would be invisible (what Maya writes \
                 for an opaque surface): rendered opaque, as illum 3"
            }
            MtlRule::MayaOpacity => {
                "are in a file in Maya's shape, whose Tf is opacity (1 - transparency): they transmit 1 - Tf \
                 (opaque where Tf is 1 1 1), Ka and Kd scaled by Tf"
            }
        }
    }
}

/// A rule and the materials it changed.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RuleApplied {
    /// The rule.
    pub rule: MtlRule,
    /// The materials it changed, by name, in the order the meshes use them.
    pub materials: Vec<String>,
}

/// How many material names a warning lists before "and N more".
const NAMES_SHOWN: usize = 5;

/// "a, b, c and 2 more".
fn name_list(names: &[String]) -> String {
    let shown = names.iter().take(NAMES_SHOWN).cloned().collect::<Vec<_>>().join(", ");
    match names.len().saturating_sub(NAMES_SHOWN) {
        0 => shown,
        n => format!("{shown} and {n} more"),
    }
}

impl RuleApplied {
    /// The rule's one warning: what it changed, in which materials, and how
    /// to keep the spec's reading.
    pub fn warning(&self) -> String {
        let n = self.materials.len();
        format!(
            "MTL rule '{}': {n} material{} {} ({}); --mtl-rules spec keeps the letter of the spec",
            self.rule.name(),
            if n == 1 { "" } else { "s" },
            self.rule.change(),
            name_list(&self.materials)
        )
    }
}

/// One file's materials as rendered, and what the rules changed.
#[derive(Debug, Clone, PartialEq)]
pub struct Ruled {
    /// The materials, in the order given, changed where a rule applies.
    pub materials: Vec<Material>,
    /// The rules that changed any material, in the order applied.
    pub applied: Vec<RuleApplied>,
    /// Readings worth a look that no rule changed (`Tr` alone read as
    /// mostly see-through).
    pub warnings: Vec<String>,
}

/// Two values an exporter printed equal (to 2 decimals, as Maya prints).
fn same(a: f32, b: f32) -> bool {
    (a - b).abs() < 0.005
}

/// Reads one MTL file's materials (as one OBJ file uses them, its default
/// material left out) by `rules`.
pub fn apply(materials: &[Material], rules: MtlRules) -> Ruled {
    let mut ruled = Ruled {
        materials: materials.to_vec(),
        applied: Vec::new(),
        warnings: Vec::new(),
    };
    let exporters = rules == MtlRules::Exporters;
    let mut changed: Vec<(MtlRule, String)> = Vec::new();

    let tr_as_d = exporters && tr_written_as_d(materials);
    let mut see_through = Vec::new();
    for m in &mut ruled.materials {
        let (None, Some(tr)) = (m.written.d, m.written.tr) else {
            continue;
        };
        if tr_as_d {
            if m.dissolve != tr {
                m.dissolve = tr;
                changed.push((MtlRule::TrAsD, m.name.clone()));
            }
        } else if tr > 0.5 && m.illum < 4 {
            see_through.push(format!("{} (Tr {tr}, illum {})", m.name, m.illum));
        }
    }
    if !see_through.is_empty() {
        ruled.warnings.push(format!(
            "{} material{} give Tr > 0.5 without d and are read as d = 1 - Tr, mostly see-through: {}",
            see_through.len(),
            if see_through.len() == 1 { "" } else { "s" },
            name_list(&see_through)
        ));
    }

    if exporters && let Some(ke) = default_emission(materials) {
        for m in ruled.materials.iter_mut().filter(|m| m.ke == ke) {
            m.ke = Vec3::ZERO;
            changed.push((MtlRule::DefaultEmission, m.name.clone()));
        }
    }

    if exporters && blender_ambient(materials) {
        for m in ruled
            .materials
            .iter_mut()
            .filter(|m| m.ka == Vec3::ONE && m.kd != Vec3::ONE)
            // Kd black beside a map: the map is the diffuse colour, and
            // Ka 1 already lets the ambient light take it.
            .filter(|m| !(m.kd == Vec3::ZERO && m.maps.kd.is_some()))
        {
            m.ka = m.kd;
            changed.push((MtlRule::WhiteAmbient, m.name.clone()));
        }
    }

    if exporters {
        let maya = maya_shaped(&ruled.materials);
        for m in &mut ruled.materials {
            if invisible_glass(m) {
                m.illum = 3;
                changed.push((MtlRule::InvisibleGlass, m.name.clone()));
            } else if maya {
                let opacity = m.tf;
                if opacity == Vec3::ONE {
                    m.illum = 3;
                } else {
                    m.tf = Vec3::ONE - opacity;
                    m.ka *= opacity;
                    m.kd *= opacity;
                }
                changed.push((MtlRule::MayaOpacity, m.name.clone()));
            }
        }
    }

    ruled.applied = group(changed);
    ruled
}

/// Changes grouped by rule, rules in `MtlRule::ALL` order, each material
/// once.
fn group(changed: Vec<(MtlRule, String)>) -> Vec<RuleApplied> {
    let mut by_rule: HashMap<MtlRule, Vec<String>> = HashMap::new();
    for (rule, name) in changed {
        let names = by_rule.entry(rule).or_default();
        if !names.contains(&name) {
            names.push(name);
        }
    }
    MtlRule::ALL
        .iter()
        .filter_map(|rule| {
            by_rule
                .remove(rule)
                .map(|materials| RuleApplied { rule: *rule, materials })
        })
        .collect()
}

/// Whether the file writes opacity under the name `Tr` (see the module's
/// description).
fn tr_written_as_d(materials: &[Material]) -> bool {
    let (mut as_d, mut as_transparency) = (0, 0);
    for m in materials {
        if let (Some(d), Some(tr)) = (m.written.d, m.written.tr) {
            match (same(d, tr), same(d, 1.0 - tr)) {
                (true, false) => as_d += 1,
                (false, true) => as_transparency += 1,
                _ => {}
            }
        }
    }
    if as_d + as_transparency > 0 {
        return as_transparency == 0;
    }
    let mut tr_alone = materials.iter().filter_map(|m| match (m.written.d, m.written.tr) {
        (None, Some(tr)) => Some(tr),
        _ => None,
    });
    let first = tr_alone.next();
    first == Some(1.0) && tr_alone.all(|tr| tr == 1.0)
}

/// The `Ke` that is an exporter's default, where the file has one.
fn default_emission(materials: &[Material]) -> Option<Vec3> {
    let emits = |m: &Material| m.written.ke && m.ke.max_element() > 0.0;
    if materials.len() < 2 || !materials.iter().all(emits) {
        return None;
    }
    let mut counts: Vec<(Vec3, usize)> = Vec::new();
    for m in materials {
        match counts.iter_mut().find(|(ke, _)| *ke == m.ke) {
            Some((_, n)) => *n += 1,
            None => counts.push((m.ke, 1)),
        }
    }
    let (ke, n) = counts.into_iter().max_by_key(|(_, n)| *n)?;
    (n >= 2 && 2 * n > materials.len()).then_some(ke)
}

/// Whether the file is in Blender's shape with its white `Ka` (see the
/// module's description).
fn blender_ambient(materials: &[Material]) -> bool {
    let shape = |m: &Material| {
        let w = &m.written;
        w.ka && w.ke && w.ni && w.d.is_some() && w.illum && w.tr.is_none() && !m.has_tf
    };
    let grey = |v: Vec3| v.x == v.y && v.y == v.z;
    let blender_ka = |m: &Material| m.ka == Vec3::ONE || (matches!(m.illum, 3 | 6) && grey(m.ka));
    !materials.is_empty() && materials.iter().all(|m| shape(m) && blender_ka(m))
}

/// An illum 4 glass that neither filters, bends nor dissolves.
fn invisible_glass(m: &Material) -> bool {
    m.illum == 4 && m.written.illum && m.tf == Vec3::ONE && m.ni == 1.0 && m.dissolve == 1.0
}

/// Whether the file is in Maya's shape and shows Tf as opacity (see the
/// module's description).
fn maya_shaped(materials: &[Material]) -> bool {
    let shape = |m: &Material| {
        let w = &m.written;
        m.illum == 4 && w.illum && m.has_tf && w.ni && w.d.is_none() && w.tr.is_none() && !w.ke
    };
    materials.iter().all(shape) && materials.iter().any(invisible_glass)
}

/// Every mesh's materials as they are rendered, and what the rules
/// changed in them.
#[derive(Debug, Clone)]
pub struct SceneMaterials {
    /// Per mesh of the scene, its `MeshShading::materials` as read by the
    /// rules (empty for a mesh without shading).
    meshes: Vec<Vec<Material>>,
    /// The rules that changed any material, in the order applied, each
    /// once with the materials of every mesh it changed.
    pub applied: Vec<RuleApplied>,
    /// One warning per applied rule, then the readings worth a look.
    pub warnings: Vec<String>,
}

impl SceneMaterials {
    /// Applies `rules` to each mesh's materials but its default (index 0
    /// of `MeshShading::materials`, penumbra's, not the file's).
    pub fn new(meshes: &[SceneMesh], rules: MtlRules) -> SceneMaterials {
        let mut changed = Vec::new();
        let mut notes = Vec::new();
        let meshes = meshes
            .iter()
            .map(|mesh| {
                let Some(shading) = &mesh.shading else {
                    return Vec::new();
                };
                let Some((default, file)) = shading.materials.split_first() else {
                    return Vec::new();
                };
                let ruled = apply(file, rules);
                changed.extend(
                    ruled
                        .applied
                        .into_iter()
                        .flat_map(|a| a.materials.into_iter().map(move |name| (a.rule, name))),
                );
                notes.extend(ruled.warnings);
                std::iter::once(default.clone()).chain(ruled.materials).collect()
            })
            .collect();
        let applied = group(changed);
        let warnings = applied.iter().map(RuleApplied::warning).chain(notes).collect();
        SceneMaterials {
            meshes,
            applied,
            warnings,
        }
    }

    /// Material `index` of mesh `mesh`'s `MeshShading::materials`, as
    /// rendered.
    pub fn material(&self, mesh: usize, index: u32) -> &Material {
        &self.meshes[mesh][index as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_mtl;

    fn parse(text: &str) -> Vec<Material> {
        let mut warnings = Vec::new();
        parse_mtl(text, &mut warnings).unwrap()
    }

    fn by_name<'a>(materials: &'a [Material], name: &str) -> &'a Material {
        materials.iter().find(|m| m.name == name).unwrap()
    }

    fn names(r: &Ruled, rule: MtlRule) -> Vec<&str> {
        r.applied
            .iter()
            .filter(|a| a.rule == rule)
            .flat_map(|a| a.materials.iter().map(String::as_str))
            .collect()
    }

    const MAYA: &str = include_str!("../../tests/data/mtl/maya_room.mtl");

    #[test]
    fn maya_opaque_glass_is_opaque_and_its_real_glass_stays_glass() {
        let spec = apply(&parse(MAYA), MtlRules::Spec);
        assert!(spec.applied.is_empty() && spec.warnings.is_empty());
        assert_eq!(spec.materials, parse(MAYA), "spec: the parser's reading");
        assert!(
            spec.materials.iter().all(|m| m.illum == 4),
            "by the letter of the spec, every Maya material is glass"
        );

        let r = apply(&parse(MAYA), MtlRules::Exporters);
        assert_eq!(
            names(&r, MtlRule::InvisibleGlass),
            ["initialShadingGroup", "lambert2SG", "blinn1SG"]
        );
        assert_eq!(names(&r, MtlRule::MayaOpacity), ["lambert4SG", "glassSG"]);
        for name in ["initialShadingGroup", "lambert2SG", "blinn1SG", "lambert4SG"] {
            let m = by_name(&r.materials, name);
            assert_eq!((m.illum, m.dissolve), (3, 1.0), "{name} is opaque");
        }
        // The blinn keeps its highlight and illum 4's mirror reflection (Ks).
        let blinn = by_name(&r.materials, "blinn1SG");
        assert_eq!((blinn.ks, blinn.ns), (Vec3::splat(0.5), 20.0));
        // Maya's glass, transparency 0.75 (Tf 0.25): transmits 0.75, still
        // refracting with its Ni, its colour faded by its opacity.
        let glass = by_name(&r.materials, "glassSG");
        assert_eq!((glass.illum, glass.tf, glass.ni), (4, Vec3::splat(0.75), 1.5));
        assert_eq!(
            (glass.kd, glass.ka, glass.ks),
            (Vec3::splat(0.2) * 0.25, Vec3::ZERO, Vec3::splat(0.5))
        );
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    }

    #[test]
    fn maya_tf_is_read_as_opacity_only_where_the_file_shows_it() {
        // Glass alone in Maya's shape: nothing shows Tf 1 means opaque, so
        // Tf is the spec's filter.
        let glass = "newmtl glassSG\nillum 4\nKd 0 0 0\nKa 0 0 0\nTf 0.90 0.90 0.90\nNi 1.50\n";
        let r = apply(&parse(glass), MtlRules::Exporters);
        assert!(r.applied.is_empty());
        assert_eq!(r.materials[0].tf, Vec3::splat(0.9));
        // With Maya's opaque lambert beside it, it is Maya's 10% opacity.
        let room = format!("newmtl lambert2SG\nillum 4\nKd 0.5 0.5 0.5\nKa 0 0 0\nTf 1.00 1.00 1.00\nNi 1.00\n{glass}");
        let r = apply(&parse(&room), MtlRules::Exporters);
        assert_eq!(names(&r, MtlRule::MayaOpacity), ["glassSG"]);
        assert!((r.materials[1].tf - Vec3::splat(0.1)).abs().max_element() < 1e-6);
        // A file that writes d is not Maya's; its opaque glass still is.
        let with_d = room.replace("Ni 1.50\n", "Ni 1.50\nd 1\n");
        let r = apply(&parse(&with_d), MtlRules::Exporters);
        assert_eq!(names(&r, MtlRule::MayaOpacity), Vec::<&str>::new());
        assert_eq!(names(&r, MtlRule::InvisibleGlass), ["lambert2SG"]);
        // Not illum 4, not see-through, or dissolved: not invisible glass.
        for text in [
            "newmtl a\nillum 6\nTf 1 1 1\nNi 1\n",
            "newmtl a\nillum 4\nTf 1 1 1\nNi 1.5\n",
            "newmtl a\nillum 4\nTf 1 0.9 1\nNi 1\n",
            "newmtl a\nillum 4\nTf 1 1 1\nNi 1\nd 0.5\n",
        ] {
            assert!(apply(&parse(text), MtlRules::Exporters).applied.is_empty(), "{text:?}");
        }
        // Tf left out is 1 1 1 too.
        let r = apply(&parse("newmtl a\nillum 4\nKd 0.5\n"), MtlRules::Exporters);
        assert_eq!(names(&r, MtlRule::InvisibleGlass), ["a"]);
    }

    #[test]
    fn real_glass_and_mirrors_survive() {
        let text = include_str!("../../tests/data/mtl/glass_and_mirrors.mtl");
        let r = apply(&parse(text), MtlRules::Exporters);
        assert!(r.applied.is_empty(), "{:?}", r.applied);
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        assert_eq!(r.materials, parse(text));
        let illum: Vec<u32> = r.materials.iter().map(|m| m.illum).collect();
        assert_eq!(illum, [2, 7, 4, 6, 3, 2]);
        assert_eq!(by_name(&r.materials, "glass4").tf, Vec3::splat(0.9));
        assert_eq!(by_name(&r.materials, "lamp").ke, Vec3::splat(10.0));
    }

    #[test]
    fn tr_written_as_opacity_is_read_as_d() {
        // MeshLab's shape: Tr 1 on every material.
        let text = include_str!("../../tests/data/mtl/meshlab_tr.mtl");
        let spec = apply(&parse(text), MtlRules::Spec);
        assert!(spec.materials.iter().all(|m| m.dissolve == 0.0));
        assert_eq!(spec.warnings.len(), 1);
        assert!(
            spec.warnings[0].starts_with("3 materials give Tr > 0.5 without d and are read as d = 1 - Tr"),
            "{:?}",
            spec.warnings
        );
        let r = apply(&parse(text), MtlRules::Exporters);
        assert_eq!(names(&r, MtlRule::TrAsD), ["material_0", "material_1", "material_2"]);
        assert!(r.materials.iter().all(|m| m.dissolve == 1.0));
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        // A d/Tr pair with d = Tr shows the convention for the Tr-only ones.
        let text = include_str!("../../tests/data/mtl/tr_pairs.mtl");
        let r = apply(&parse(text), MtlRules::Exporters);
        assert_eq!(names(&r, MtlRule::TrAsD), ["curtain", "trim"]);
        let d: Vec<f32> = r.materials.iter().map(|m| m.dissolve).collect();
        assert_eq!(d, [1.0, 0.3, 0.6, 1.0]);
        let spec = apply(&parse(text), MtlRules::Spec);
        let d: Vec<f32> = spec.materials.iter().map(|m| m.dissolve).collect();
        assert!((d[2] - 0.4).abs() < 1e-6 && d[3] == 0.0, "{d:?}");
        // A pair with d = 1 - Tr shows the common convention; pairs that
        // disagree show nothing; a Tr 0 beside the Tr 1 shows nothing.
        for text in [
            "newmtl a\nd 1\nTr 0\nnewmtl b\nTr 1\n",
            "newmtl a\nd 1\nTr 0\nnewmtl c\nd 0.3\nTr 0.3\nnewmtl b\nTr 1\n",
            "newmtl a\nTr 0\nnewmtl b\nTr 1\n",
        ] {
            let r = apply(&parse(text), MtlRules::Exporters);
            assert!(r.applied.is_empty(), "{text:?}: {:?}", r.applied);
            assert_eq!(by_name(&r.materials, "b").dissolve, 0.0, "{text:?}");
        }
    }

    #[test]
    fn an_emission_every_material_shares_is_no_light() {
        let text = include_str!("../../tests/data/mtl/emission_default.mtl");
        let emitting = |r: &Ruled| -> Vec<String> {
            r.materials
                .iter()
                .filter(|m| m.ke.max_element() > 0.0)
                .map(|m| m.name.clone())
                .collect()
        };
        let spec = apply(&parse(text), MtlRules::Spec);
        assert_eq!(emitting(&spec).len(), 4);
        let r = apply(&parse(text), MtlRules::Exporters);
        assert_eq!(names(&r, MtlRule::DefaultEmission), ["Wall", "Floor", "Sofa"]);
        assert_eq!(r.applied.len(), 1, "{:?}", r.applied);
        assert_eq!(emitting(&r), ["Lamp"], "the lamp keeps its own Ke");
        // Lights among unlit materials are lights.
        let r = apply(
            &parse("newmtl a\nKe 1 1 1\nnewmtl b\nKe 1 1 1\nnewmtl c\nKe 0 0 0\n"),
            MtlRules::Exporters,
        );
        assert!(r.applied.is_empty());
        // Every one emitting something of its own: no default to see.
        let r = apply(
            &parse("newmtl a\nKe 1 0 0\nnewmtl b\nKe 0 1 0\nnewmtl c\nKe 0 0 1\n"),
            MtlRules::Exporters,
        );
        assert!(r.applied.is_empty());
    }

    #[test]
    fn blenders_white_ambient_takes_the_diffuse_colour() {
        let text = include_str!("../../tests/data/mtl/blender.mtl");
        let spec = apply(&parse(text), MtlRules::Spec);
        assert_eq!(by_name(&spec.materials, "Counter").ka, Vec3::ONE);
        let r = apply(&parse(text), MtlRules::Exporters);
        assert_eq!(names(&r, MtlRule::WhiteAmbient), ["Counter", "Glass", "Chrome"]);
        assert_eq!(r.applied.len(), 1, "{:?}", r.applied);
        for m in &r.materials[..3] {
            assert_eq!(m.ka, m.kd, "{}", m.name);
        }
        assert_eq!(
            by_name(&r.materials, "Steel").ka,
            Vec3::splat(0.6),
            "a metal's grey Ka stays"
        );
        assert_eq!(by_name(&r.materials, "White").ka, Vec3::ONE, "Ka = Kd already");
        // Blender's glass (alpha 0.2: illum 9, d 0.2, Ni 1.45) and mirror
        // survive as they are, but for Ka.
        let (before, after) = (by_name(&spec.materials, "Glass"), by_name(&r.materials, "Glass"));
        assert_eq!(
            Material {
                ka: before.kd,
                ..before.clone()
            },
            *after
        );
        assert_eq!((after.illum, after.dissolve, after.ni), (9, 0.2, 1.45));
        assert_eq!(by_name(&r.materials, "Chrome").illum, 3);
        // The same colours without Blender's shape (no Ke, no d) stay.
        let plain = "newmtl a\nKa 1 1 1\nKd 0.5 0 0\nillum 2\n";
        assert!(apply(&parse(plain), MtlRules::Exporters).applied.is_empty());
    }

    #[test]
    fn three_ds_max_files_need_no_rule() {
        let text = include_str!("../../tests/data/mtl/max.mtl");
        let r = apply(&parse(text), MtlRules::Exporters);
        assert!(r.applied.is_empty() && r.warnings.is_empty(), "{:?}", r.applied);
        assert_eq!(r.materials, parse(text));
        assert_eq!(by_name(&r.materials, "window").dissolve, 0.3);
    }

    #[test]
    fn shipped_scenes_are_read_by_the_spec() {
        for text in [
            include_str!("../../../../assets/raytrace/checker-spheres.mtl"),
            include_str!("../../../../assets/raytrace/checker-spheres-tessellated.mtl"),
            include_str!("../../../../assets/raytrace/cornell-mirror-glass.mtl"),
            include_str!("../../../../assets/raytrace/grazing.mtl"),
            include_str!("../../../../assets/raytrace/tir-block.mtl"),
            include_str!("../../tests/data/mtl/cornell.mtl"),
        ] {
            let r = apply(&parse(text), MtlRules::Exporters);
            assert!(r.applied.is_empty() && r.warnings.is_empty(), "{:?}", r.applied);
            assert_eq!(r.materials, parse(text));
        }
    }

    #[test]
    fn one_warning_per_rule_names_the_materials() {
        let applied = RuleApplied {
            rule: MtlRule::InvisibleGlass,
            materials: (1..=7).map(|i| format!("lambert{i}SG")).collect(),
        };
        assert_eq!(
            applied.warning(),
            "MTL rule 'invisible-glass': 7 materials are illum 4 glass with Tf 1 1 1, Ni 1 and d 1, which \
             would be invisible (what Maya writes for an opaque surface): rendered opaque, as illum 3 \
             (lambert1SG, lambert2SG, lambert3SG, lambert4SG, lambert5SG and 2 more); --mtl-rules spec keeps \
             the letter of the spec"
        );
        for rule in MtlRule::ALL {
            assert_eq!(serde_json::to_value(rule).unwrap(), rule.name());
        }
        use crate::choice::Choice;
        assert_eq!(MtlRules::parse("spec"), Ok(MtlRules::Spec));
        assert_eq!(MtlRules::default(), MtlRules::Exporters);
    }
}
