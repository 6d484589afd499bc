//! Ray trees (the bounded-error paper, section 5.1): what a ray's radiance
//! depends on. The root holds the surface the eye ray hits (object, and
//! face where faces are flat) and, per light, whether it is visible,
//! blocked or seen through glass; its children are the reflected and
//! refracted rays' trees. Radiance changes discontinuously only where the
//! topology of the tree changes, so the bounded-error method compares the
//! trees of neighbouring rays.
//!
//! A change of surface (material) is a discontinuity too, so a node also
//! holds the surface it hits.
//!
//! `signature` condenses a tree's topology into 32 bits (FNV-1a over its
//! words, in the renderer's stack order), as both twins compute it per
//! pixel; `same_topology` compares trees exactly.

use glam::Vec3;
use smallvec::SmallVec;

/// A node's per-light codes, inline up to four lights, so that the extremal
/// rays the bounded-error renderer keeps, clones and frees carry no heap
/// blocks for them.
pub type NodeLights = SmallVec<[LightCode; 4]>;

/// A node's per-light occluders, inline up to four lights.
pub type NodeOccluders = SmallVec<[u32; 4]>;

/// What a node's ray is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RayKind {
    /// The root: an eye ray, or the ray a tree was asked for.
    Primary = 0,
    /// The mirror reflection of its parent at the parent's hit.
    Reflection = 1,
    /// The ray transmitted through its parent's hit (refracted, or straight
    /// on through a dissolved surface).
    Refraction = 2,
}

/// A light, seen from a hit point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LightCode {
    /// Behind the surface, or the emitter faces away: no shadow ray.
    FacesAway = 0,
    /// Nothing in the way: the light arrives unfiltered.
    Visible = 1,
    /// An opaque surface is in the way.
    Blocked = 2,
    /// Only glass (or dissolved surfaces) in the way: seen filtered.
    Filtered = 3,
}

impl LightCode {
    /// The code from its number as the kernel writes it (the
    /// discriminant); an unknown number reads as `FacesAway`.
    pub fn from_u32(c: u32) -> LightCode {
        match c {
            1 => LightCode::Visible,
            2 => LightCode::Blocked,
            3 => LightCode::Filtered,
            _ => LightCode::FacesAway,
        }
    }
}

/// The surface a node's ray hits.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TreeHit {
    /// Ray-tree object (`RenderScene::objects`).
    pub object: u32,
    /// Flat face (OBJ polygon), `SMOOTH_FACE` on a smooth patch, 0 on a sphere.
    pub face: u32,
    /// Surface (material) hit: an index into `RenderScene::surfaces`.
    pub surface: u32,
    /// The primitive: a triangle index, or triangles + sphere index.
    pub primitive: u32,
    /// Distance along the node's unit direction.
    pub t: f32,
    /// The hit point, in the scene's frame.
    pub point: Vec3,
    /// The ray meets the side the geometric normal points to (enters glass).
    pub front: bool,
}

/// One ray of a tree.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RayNode {
    /// How the ray came about.
    pub kind: RayKind,
    /// Reflections and refractions since the root (0 at the root).
    pub depth: u32,
    /// Index of the parent node (`None` at the root).
    pub parent: Option<u32>,
    /// Where the ray starts, in the scene's frame: at the root the given
    /// origin (the eye for a pixel), else its parent's hit point moved off
    /// the surface to the side the ray leaves into.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// What this ray's radiance is weighted by at the pixel.
    pub weight: Vec3,
    /// `None`: the ray left the scene.
    pub hit: Option<TreeHit>,
    /// Per light (the scene's order), at the hit; empty for a miss or an unlit surface.
    pub lights: NodeLights,
    /// Per light, the primitive nearest the light that stops or filters its
    /// shadow ray (`u32::MAX` where none does): the occluder of the paper's
    /// ray trees.
    pub occluders: NodeOccluders,
    /// Whether a reflected ray was traced from the hit (a `Reflection`
    /// child).
    pub reflected: bool,
    /// Whether a transmitted ray was traced from the hit (a `Refraction`
    /// child).
    pub refracted: bool,
    /// Total internal reflection: the refracted ray does not exist.
    pub tir: bool,
}

/// A ray tree, nodes in the order the renderer shades them (depth first).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RayTree {
    /// The rays, root first; each node's `parent` indexes this list.
    pub nodes: Vec<RayNode>,
}

/// FNV-1a over 32-bit words (the signature's hash; `fnv_word` in WGSL):
/// the hash before any word.
pub const FNV_OFFSET: u32 = 0x811c_9dc5;
const FNV_PRIME: u32 = 0x0100_0193;

/// One FNV-1a step: the hash `h` with `word` mixed in.
#[inline]
pub fn fnv_word(h: u32, word: u32) -> u32 {
    (h ^ word).wrapping_mul(FNV_PRIME)
}

/// The first word a node adds to the signature, its kind and depth
/// (`kind | depth << 2`). Then come the object, face and surface hit
/// (`MISS` each for a miss), a `light_word` per light and the
/// `children_word`.
pub fn ray_word(kind: RayKind, depth: u32) -> u32 {
    kind as u32 | depth << 2
}

/// A node's signature word for light `light` (the scene's order) and its
/// code: `light << 2 | code`.
pub fn light_word(light: u32, code: LightCode) -> u32 {
    light << 2 | code as u32
}

/// A node's last signature word, its children: bit 0 reflected, bit 1
/// refracted, bit 2 total internal reflection.
pub fn children_word(reflected: bool, refracted: bool, tir: bool) -> u32 {
    reflected as u32 | (refracted as u32) << 1 | (tir as u32) << 2
}

impl RayTree {
    /// The 32-bit signature of the tree's topology, as `whitted` computes it.
    pub fn signature(&self) -> u32 {
        let mut h = FNV_OFFSET;
        for n in &self.nodes {
            h = fnv_word(h, ray_word(n.kind, n.depth));
            let miss = super::scene::MISS;
            let (object, face, surface) = n.hit.map_or((miss, miss, miss), |h| (h.object, h.face, h.surface));
            h = fnv_word(h, object);
            h = fnv_word(h, face);
            h = fnv_word(h, surface);
            for (j, &c) in n.lights.iter().enumerate() {
                h = fnv_word(h, light_word(j as u32, c));
            }
            h = fnv_word(h, children_word(n.reflected, n.refracted, n.tir));
        }
        h
    }

    /// Whether two trees are isomorphic: node for node the same kind,
    /// depth, object, face, surface, light codes and children.
    pub fn same_topology(&self, other: &RayTree) -> bool {
        self.nodes.len() == other.nodes.len()
            && self.nodes.iter().zip(&other.nodes).all(|(a, b)| {
                a.kind == b.kind
                    && a.depth == b.depth
                    && a.parent == b.parent
                    && a.hit.map(|h| (h.object, h.face, h.surface, h.front))
                        == b.hit.map(|h| (h.object, h.face, h.surface, h.front))
                    && a.lights == b.lights
                    && (a.reflected, a.refracted, a.tir) == (b.reflected, b.refracted, b.tir)
            })
    }

    /// The objects the tree's rays hit, each once, in order.
    pub fn objects(&self) -> Vec<u32> {
        let mut out = Vec::new();
        for h in self.nodes.iter().filter_map(|n| n.hit) {
            if !out.contains(&h.object) {
                out.push(h.object);
            }
        }
        out
    }
}
