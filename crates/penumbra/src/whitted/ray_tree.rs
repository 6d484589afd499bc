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

/// A node's per-light codes, inline up to four lights: a node's lists were
/// two heap blocks each, allocated, cloned and freed with every extremal
/// ray the bounded-error renderer keeps.
pub type NodeLights = SmallVec<[LightCode; 4]>;

/// A node's per-light occluders, inline up to four lights.
pub type NodeOccluders = SmallVec<[u32; 4]>;

/// What a node's ray is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RayKind {
    Primary = 0,
    Reflection = 1,
    Refraction = 2,
}

/// A light, seen from a hit point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LightCode {
    /// Behind the surface, or the emitter faces away: no shadow ray.
    FacesAway = 0,
    Visible = 1,
    /// An opaque surface is in the way.
    Blocked = 2,
    /// Only glass (or dissolved surfaces) in the way: seen filtered.
    Filtered = 3,
}

impl LightCode {
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
    pub surface: u32,
    /// The primitive: a triangle index, or triangles + sphere index.
    pub primitive: u32,
    pub t: f32,
    pub point: Vec3,
    /// The ray meets the side the geometric normal points to (enters glass).
    pub front: bool,
}

/// One ray of a tree.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RayNode {
    pub kind: RayKind,
    pub depth: u32,
    /// Index of the parent node (`None` at the root).
    pub parent: Option<u32>,
    pub origin: Vec3,
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
    pub reflected: bool,
    pub refracted: bool,
    /// Total internal reflection: the refracted ray does not exist.
    pub tir: bool,
}

/// A ray tree, nodes in the order the renderer shades them (depth first).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RayTree {
    pub nodes: Vec<RayNode>,
}

/// FNV-1a over 32-bit words (the signature's hash; `fnv_word` in WGSL).
pub const FNV_OFFSET: u32 = 0x811c_9dc5;
const FNV_PRIME: u32 = 0x0100_0193;

#[inline]
pub fn fnv_word(h: u32, word: u32) -> u32 {
    (h ^ word).wrapping_mul(FNV_PRIME)
}

/// The words a node adds to the signature: its kind and depth, the object,
/// face and surface hit, each light's code, and which children it has.
pub fn ray_word(kind: RayKind, depth: u32) -> u32 {
    kind as u32 | depth << 2
}

pub fn light_word(light: u32, code: LightCode) -> u32 {
    light << 2 | code as u32
}

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
