//! `Accel`: a scene's kd-tree and its wide BVH, owned together, and the
//! CPU queries that walk either as `Structure` says.

use std::sync::OnceLock;
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::accel::bvh::{self, Bvh8, BvhSettings};
use crate::accel::kdtree::{self, KdTree};
use crate::geom::ray::{Hit, Ray};
use crate::geom::simd::{Isa, Lanes};
use crate::gpu::device::elapsed_ms;

/// The structure single rays and AO packets walk on the CPU (the GPU
/// kernels walk the kd-tree). The hits are the same; where two triangles
/// are hit at exactly the same t, the BVH reports the one of smaller index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Structure {
    /// The wide BVH (`bvh`): 1.1 to 2.2 times the kd-tree's speed on
    /// single rays (least on long thin triangles), built in about a fifth
    /// of the kd-tree's time.
    #[default]
    Bvh,
    /// The kd-tree's single-ray walk (the MLRTA paper's foundation).
    Kdtree,
}

crate::choice!(Structure { Bvh = "bvh", Kdtree = "kdtree" });

/// What the BVH cost and holds (JSON `bvh`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BvhStats {
    /// Milliseconds its build took (about 0 when it was already built).
    pub build_ms: f64,
    /// Interior nodes (`Bvh8::nodes`).
    pub nodes: usize,
    /// Leaves: blocks of up to four triangles (`Bvh8::blocks`).
    pub leaf_blocks: usize,
    /// Triangles in the leaves, counting the copies spatial splits made.
    pub references: usize,
    /// Bytes of nodes and blocks.
    pub bytes: usize,
}

/// A scene's acceleration for rays: its kd-tree and the wide BVH of the
/// same triangles, built the first time something asks for it (the GPU
/// never does). The BVH is built in the kd-tree's frame from its
/// triangles, so both report the same triangle indices and bit-identical
/// t; a BVH hit at a contact is the kd-tree's answer (`Bvh8::contact`),
/// which is why the two travel together.
#[derive(Debug, Clone)]
pub struct Accel {
    tree: KdTree,
    bvh: OnceLock<Bvh8>,
}

impl From<KdTree> for Accel {
    fn from(tree: KdTree) -> Accel {
        Accel::new(tree)
    }
}

impl Accel {
    /// `tree`, its BVH not built yet.
    pub fn new(tree: KdTree) -> Accel {
        Accel {
            tree,
            bvh: OnceLock::new(),
        }
    }

    /// The kd-tree: what the GPU kernels, MLRTA's packets and the kd-tree
    /// walks read.
    #[inline]
    pub fn kdtree(&self) -> &KdTree {
        &self.tree
    }

    /// The kd-tree, the BVH (if built) dropped.
    pub fn into_kdtree(self) -> KdTree {
        self.tree
    }

    /// The wide BVH of the kd-tree's triangles (in its frame: the same
    /// hits), built on first use with `BvhSettings::default()`.
    #[inline]
    pub fn bvh(&self) -> &Bvh8 {
        self.bvh.get_or_init(|| Bvh8::from_tree(&self.tree))
    }

    /// `bvh`, built with `params` if it is not built yet; a BVH already
    /// built (by `bvh` or an earlier call) is returned as it is, so a host
    /// with its own knobs calls this before the first trace.
    pub fn bvh_with(&self, params: &BvhSettings) -> &Bvh8 {
        self.bvh.get_or_init(|| Bvh8::build(&self.tree, params))
    }

    /// Whether `bvh` has been built.
    pub fn has_bvh(&self) -> bool {
        self.bvh.get().is_some()
    }

    /// Builds the BVH if it is not built yet (`build_ms` is then its
    /// build's time) and describes it.
    pub fn bvh_stats(&self) -> BvhStats {
        let start = Instant::now();
        let bvh = self.bvh();
        BvhStats {
            build_ms: elapsed_ms(start),
            nodes: bvh.nodes.len(),
            leaf_blocks: bvh.blocks.len(),
            references: bvh.references(),
            bytes: bvh.memory_bytes(),
        }
    }

    /// The closest hit with `0 < t < t_max` of the ray from `origin` along
    /// `dir` (need not be normalised; t in its units), walking `structure`.
    #[inline]
    pub fn closest_hit(&self, structure: Structure, origin: Vec3, dir: Vec3, t_max: f32) -> Hit {
        match structure {
            Structure::Bvh => self.bvh().closest_hit(&self.tree, origin, dir, t_max),
            Structure::Kdtree => self.tree.closest_hit(origin, dir, t_max),
        }
    }

    /// Whether the ray from `origin` along `dir` hits anything with
    /// `0 < t < t_max`, walking `structure`.
    #[inline]
    pub fn any_hit(&self, structure: Structure, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        match structure {
            Structure::Bvh => self.bvh().any_hit(&self.tree, origin, dir, t_max),
            Structure::Kdtree => self.tree.any_hit(origin, dir, t_max),
        }
    }

    /// Closest hits of a batch of rays into `hits` (same length), walking
    /// `structure`, on the calling thread.
    pub fn closest_hits(&self, structure: Structure, rays: &[Ray], hits: &mut [Hit]) {
        match structure {
            Structure::Bvh => self.bvh().closest_hits(&self.tree, rays, hits),
            Structure::Kdtree => {
                for (r, h) in rays.iter().zip(hits) {
                    *h = self.tree.closest_hit(r.o(), r.d(), f32::INFINITY);
                }
            }
        }
    }

    /// Closest hits of many rays, in parallel on the current rayon pool:
    /// through the BVH in chunks of 1,024 rays in their order, or by
    /// `KdTree::trace_closest`.
    pub fn trace_closest(&self, structure: Structure, rays: &[Ray]) -> Vec<Hit> {
        match structure {
            Structure::Bvh => self.bvh().trace_closest(&self.tree, rays),
            Structure::Kdtree => self.tree.trace_closest(rays),
        }
    }

    /// `trace_closest` of rays in no particular order (a ray file): the
    /// kd-tree traces them in an order sorted by where they enter it
    /// (`KdTree::trace_closest_incoherent`); the BVH, whose nodes stay in
    /// cache, gains nothing from the sort (measured: 2.93 sorted against
    /// 3.01 Mrays/s on 1M random bunny rays) and takes them as they come.
    pub fn trace_closest_incoherent(&self, structure: Structure, rays: &[Ray]) -> Vec<Hit> {
        match structure {
            Structure::Bvh => self.bvh().trace_closest(&self.tree, rays),
            Structure::Kdtree => self.tree.trace_closest_incoherent(rays),
        }
    }

    /// Which of the rays `dirs` (at most 16) from `origin` hit a triangle
    /// with `0 < t < t_max` (bit r for `dirs[r]`, equal to `any_hit` ray
    /// for ray), as one packet walking `structure` in the instruction set
    /// `isa` (one this CPU lacks is replaced by the best it has). Each
    /// structure's walk is dispatched as a kernel of its own: with both
    /// walks in one `#[target_feature]` function it outgrew LLVM's
    /// inlining budget, its intrinsics stayed calls, and the PRT
    /// reference's packets took 4.6 s instead of 3.3.
    pub fn occluded(&self, structure: Structure, origin: Vec3, dirs: &[Vec3], t_max: f32, isa: Isa) -> u16 {
        match structure {
            Structure::Bvh => bvh::occlusion::occluded(self.bvh(), &self.tree, origin, dirs, t_max, isa),
            Structure::Kdtree => kdtree::occlusion::occluded(&self.tree, origin, dirs, t_max, isa),
        }
    }

    /// `occluded` in lanes `V` through the BVH if `BVH`, else the kd-tree,
    /// for kernels that run many packets in one instruction set
    /// (`raycast::packets`): the structure is a constant of the kernel,
    /// not a branch in it (see `occluded`).
    #[inline(always)]
    pub fn occluded_in<V: Lanes, const BVH: bool>(&self, origin: Vec3, dirs: &[Vec3], t_max: f32) -> u16 {
        if BVH {
            bvh::occlusion::occluded_in::<V>(self.bvh(), &self.tree, origin, dirs, t_max)
        } else {
            kdtree::occlusion::occluded_in::<V>(&self.tree, origin, dirs, t_max)
        }
    }
}
