//! Ray trees as flat records: what `whitted.wgsl`'s `whitted_trees` entry
//! writes per ray (the bounded renderer's extremal rays traced on a GPU),
//! `encode` the CPU twin's writes of the same layout, `decode` both back
//! into a [`RayTree`].
//!
//! A ray's slot is `2 + capacity * stride` words4: (radiance, node count or
//! [`OVERFLOW`]), (diffuse, 0), then per node in the order the renderer's
//! stack pops them: (flags, parent, object, face), (surface, primitive, t,
//! 0), origin, direction, weight, point (each with a zero fourth word), and
//! the light words: each light's code, then each light's occluder. Floats
//! are their bits. A tree with more nodes than the slot holds is not
//! written (its count is `OVERFLOW`): the caller traces that ray on the CPU.

use glam::Vec3;

use super::ray_tree::{LightCode, NodeLights, NodeOccluders, RayKind, RayNode, RayTree, TreeHit};
use super::scene::MISS;

/// Words4 before a slot's first node.
pub const HEADER_WORDS4: usize = 2;
/// Words4 of a node before its light words.
const NODE_WORDS4: u32 = 6;
/// A slot's count where the tree did not fit.
pub const OVERFLOW: u32 = u32::MAX;
/// Nodes a slot holds at most, whatever the depth: a full tree of depth 6.
/// Deeper trees are rarely full; those that overflow go to the CPU.
pub const MAX_CAPACITY: u32 = 127;

// A node's flags word: kind | depth << 2 | these.
const REFLECTED: u32 = 0x100;
const REFRACTED: u32 = 0x200;
const TIR: u32 = 0x400;
const FRONT: u32 = 0x800;
const HIT: u32 = 0x1000;
const LIT: u32 = 0x2000;

/// The ray a slot traces: from `origin` along the unit `dir`, its root hit
/// given (`root_primitive` = `MISS`: the line misses the root). Eight
/// words, as the kernel reads them from its ray list.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TreeRay {
    /// Where the ray starts, in the scene's frame (in air).
    pub origin: [f32; 3],
    /// Distance of the root hit along `dir` (unused for a miss).
    pub root_t: f32,
    /// Unit direction.
    pub dir: [f32; 3],
    /// The primitive the root hit is on (a triangle, or triangles + sphere
    /// index), or `MISS`.
    pub root_primitive: u32,
}

/// A ray's slot read back.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedTree {
    /// The ray's radiance.
    pub radiance: Vec3,
    /// The root's ambient and diffuse terms before its texture
    /// (`Whitted::shade`'s `diffuse`).
    pub diffuse: Vec3,
    /// The ray's tree.
    pub tree: RayTree,
}

/// Rejects a ray the kernel and its twin cannot trace: a non-finite
/// origin or direction, a direction that is not unit length (within
/// 1e-3), or a root primitive that is neither `MISS` nor one of the
/// scene's `primitives` (triangles, then spheres), which the twin would
/// index out of bounds.
pub fn check_rays(rays: &[TreeRay], primitives: u32) -> crate::error::Result<()> {
    for (i, r) in rays.iter().enumerate() {
        let (o, d) = (Vec3::from_array(r.origin), Vec3::from_array(r.dir));
        let problem = if !o.is_finite() || !d.is_finite() || !r.root_t.is_finite() {
            "has a non-finite origin, direction or root t".to_string()
        } else if (d.length() - 1.0).abs() > 1e-3 {
            format!("has a direction of length {} (unit expected)", d.length())
        } else if r.root_primitive != MISS && r.root_primitive >= primitives {
            format!("names root primitive {} of {primitives}", r.root_primitive)
        } else {
            continue;
        };
        return Err(crate::error::Error::param("rays", format!("ray {i} {problem}")));
    }
    Ok(())
}

/// The shape of the slots for a render's depth and lights.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TreeLayout {
    /// Nodes a slot holds.
    pub capacity: u32,
    /// Words4 a node takes.
    pub stride: u32,
    /// Lights per node: the scene's light count.
    pub lights: u32,
}

impl TreeLayout {
    /// Room for a full binary tree of `max_depth` (at most [`MAX_CAPACITY`]
    /// nodes) with `lights` lights per node.
    pub fn new(max_depth: u32, lights: u32) -> TreeLayout {
        let full = 1u64 << (max_depth.min(31) + 1);
        TreeLayout {
            capacity: (full - 1).min(MAX_CAPACITY as u64) as u32,
            stride: NODE_WORDS4 + (2 * lights).div_ceil(4),
            lights,
        }
    }

    /// Words4 of one ray's slot.
    pub fn slot_words4(&self) -> usize {
        HEADER_WORDS4 + self.capacity as usize * self.stride as usize
    }
}

fn bits(v: Vec3) -> [u32; 4] {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits(), 0]
}

fn vec3(w: [u32; 4]) -> Vec3 {
    Vec3::new(f32::from_bits(w[0]), f32::from_bits(w[1]), f32::from_bits(w[2]))
}

/// The slot the kernel writes for a ray of radiance `radiance`, root
/// diffuse terms `diffuse` and tree `tree` (the CPU twin's side).
pub fn encode(layout: &TreeLayout, radiance: Vec3, diffuse: Vec3, tree: &RayTree) -> Vec<[u32; 4]> {
    let mut slot = vec![[0u32; 4]; layout.slot_words4()];
    let fits = tree.nodes.len() <= layout.capacity as usize;
    let count = if fits { tree.nodes.len() as u32 } else { OVERFLOW };
    slot[0] = bits(radiance);
    slot[0][3] = count;
    slot[1] = bits(diffuse);
    if !fits {
        return slot;
    }
    for (n, node) in tree.nodes.iter().enumerate() {
        let at = HEADER_WORDS4 + n * layout.stride as usize;
        let mut flags = node.kind as u32 | node.depth << 2;
        let (mut object, mut face, mut surface, mut primitive, mut t, mut point) =
            (MISS, MISS, MISS, MISS, 0, Vec3::ZERO);
        if let Some(h) = node.hit {
            flags |= HIT | if h.front { FRONT } else { 0 };
            (object, face, surface, primitive, t, point) =
                (h.object, h.face, h.surface, h.primitive, h.t.to_bits(), h.point);
        }
        // (The kernel also marks a lit surface without lights: the same tree.)
        if !node.lights.is_empty() {
            flags |= LIT;
        }
        flags |= if node.reflected { REFLECTED } else { 0 }
            | if node.refracted { REFRACTED } else { 0 }
            | if node.tir { TIR } else { 0 };
        slot[at] = [flags, node.parent.unwrap_or(MISS), object, face];
        slot[at + 1] = [surface, primitive, t, 0];
        slot[at + 2] = bits(node.origin);
        slot[at + 3] = bits(node.dir);
        slot[at + 4] = bits(node.weight);
        slot[at + 5] = bits(point);
        let words = node
            .lights
            .iter()
            .map(|&c| c as u32)
            .chain(node.occluders.iter().copied());
        for (w, value) in words.enumerate() {
            slot[at + NODE_WORDS4 as usize + w / 4][w % 4] = value;
        }
    }
    slot
}

/// A slot read back, or `None` where the tree overflowed the slot.
pub fn decode(layout: &TreeLayout, slot: &[[u32; 4]]) -> Option<RecordedTree> {
    let count = slot[0][3];
    if count == OVERFLOW {
        return None;
    }
    let l = layout.lights as usize;
    let mut tree = RayTree::default();
    for n in 0..count as usize {
        let at = HEADER_WORDS4 + n * layout.stride as usize;
        let [flags, parent, object, face] = slot[at];
        let [surface, primitive, t, _] = slot[at + 1];
        let lit = flags & LIT != 0;
        let word = |w: usize| slot[at + NODE_WORDS4 as usize + w / 4][w % 4];
        let kind = match flags & 3 {
            0 => RayKind::Primary,
            1 => RayKind::Reflection,
            _ => RayKind::Refraction,
        };
        tree.nodes.push(RayNode {
            kind,
            depth: (flags >> 2) & 0x3f,
            parent: (parent != MISS).then_some(parent),
            origin: vec3(slot[at + 2]),
            dir: vec3(slot[at + 3]),
            weight: vec3(slot[at + 4]),
            hit: (flags & HIT != 0).then(|| TreeHit {
                object,
                face,
                surface,
                primitive,
                t: f32::from_bits(t),
                point: vec3(slot[at + 5]),
                front: flags & FRONT != 0,
            }),
            lights: if lit {
                (0..l).map(|j| LightCode::from_u32(word(j))).collect()
            } else {
                NodeLights::new()
            },
            occluders: if lit {
                (0..l).map(|j| word(l + j)).collect()
            } else {
                NodeOccluders::new()
            },
            reflected: flags & REFLECTED != 0,
            refracted: flags & REFRACTED != 0,
            tir: flags & TIR != 0,
        });
    }
    Some(RecordedTree {
        radiance: vec3(slot[0]),
        diffuse: vec3(slot[1]),
        tree,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(kind: RayKind, depth: u32, parent: Option<u32>, hit: bool, lights: usize) -> RayNode {
        let f = depth as f32;
        RayNode {
            kind,
            depth,
            parent,
            origin: Vec3::new(f, -0.5, 1e-30),
            dir: Vec3::new(0.6, -0.8, f32::MIN_POSITIVE),
            weight: Vec3::new(0.9, 0.5, 0.25),
            hit: hit.then_some(TreeHit {
                object: 3 + depth,
                face: if depth == 0 { 7 } else { u32::MAX - 1 },
                surface: 2,
                primitive: 40_000 + depth,
                t: 2.5 + f,
                point: Vec3::new(-1.0, f, 3.0),
                front: depth.is_multiple_of(2),
            }),
            lights: (0..lights).map(|j| LightCode::from_u32(j as u32 % 4)).collect(),
            occluders: (0..lights)
                .map(|j| if j % 2 == 0 { MISS } else { 17 + j as u32 })
                .collect(),
            reflected: hit,
            refracted: hit && depth < 2,
            tir: hit && depth == 2,
        }
    }

    /// Every field survives the slot: kinds, depths, parents, misses, unlit
    /// hits, light codes and occluders for 0 to 5 lights (the light words
    /// spanning several words4), floats bit for bit.
    #[test]
    fn a_tree_decodes_to_itself_and_an_overflow_to_none() {
        for lights in 0..6 {
            let layout = TreeLayout::new(3, lights as u32);
            let tree = RayTree {
                nodes: vec![
                    node(RayKind::Primary, 0, None, true, lights),
                    node(RayKind::Refraction, 1, Some(0), true, lights),
                    node(RayKind::Reflection, 2, Some(1), true, 0),
                    node(RayKind::Refraction, 2, Some(1), false, 0),
                    node(RayKind::Reflection, 1, Some(0), true, lights),
                ],
            };
            let (radiance, diffuse) = (Vec3::new(0.1, 2.0, 1e-20), Vec3::new(0.3, 0.0, 7.0));
            let slot = encode(&layout, radiance, diffuse, &tree);
            assert_eq!(slot.len(), layout.slot_words4());
            assert_eq!(
                decode(&layout, &slot),
                Some(RecordedTree {
                    radiance,
                    diffuse,
                    tree: tree.clone()
                }),
                "{lights} lights"
            );
            // One node more than the slot holds: decoded as overflow.
            let small = TreeLayout { capacity: 4, ..layout };
            assert_eq!(decode(&small, &encode(&small, radiance, diffuse, &tree)), None);
        }
    }

    #[test]
    fn rays_the_twin_cannot_trace_are_errors_naming_the_ray() {
        let good = TreeRay {
            origin: [0.0, 1.0, 2.0],
            root_t: 1.5,
            dir: [0.0, 0.6, -0.8],
            root_primitive: 4,
        };
        assert!(
            check_rays(
                &[
                    good,
                    TreeRay {
                        root_primitive: MISS,
                        ..good
                    }
                ],
                5
            )
            .is_ok()
        );
        let bad = [
            (
                TreeRay {
                    root_primitive: 5,
                    ..good
                },
                "root primitive 5 of 5",
            ),
            (
                TreeRay {
                    origin: [f32::NAN, 0.0, 0.0],
                    ..good
                },
                "non-finite",
            ),
            (
                TreeRay {
                    dir: [0.0, 0.0, f32::INFINITY],
                    ..good
                },
                "non-finite",
            ),
            (
                TreeRay {
                    root_t: f32::NAN,
                    ..good
                },
                "non-finite",
            ),
            (
                TreeRay {
                    dir: [0.0, 0.0, 2.0],
                    ..good
                },
                "length 2",
            ),
            (TreeRay { dir: [0.0; 3], ..good }, "length 0"),
        ];
        for (ray, says) in bad {
            let e = check_rays(&[good, ray], 5).unwrap_err().to_string();
            assert!(e.contains("ray 1") && e.contains(says), "{e}");
        }
    }

    #[test]
    fn slots_hold_a_full_tree_up_to_the_cap() {
        assert_eq!(TreeLayout::new(0, 1).capacity, 1);
        assert_eq!(TreeLayout::new(5, 1).capacity, 63);
        assert_eq!(TreeLayout::new(6, 1).capacity, MAX_CAPACITY);
        assert_eq!(TreeLayout::new(16, 1).capacity, MAX_CAPACITY);
        assert_eq!(TreeLayout::new(5, 0).stride, 6);
        assert_eq!(TreeLayout::new(5, 2).stride, 7);
        assert_eq!(TreeLayout::new(5, 3).stride, 8);
    }
}
