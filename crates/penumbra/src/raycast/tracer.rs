//! A kd-tree ready on a device: the runner every ray-casting method goes
//! through. Closest hits (`trace-rays`, primary visibility of images) and AO
//! rays (reference AO, and the ground truth of fields, SSAO and PRT) run in
//! the WGSL kernels on a GPU or in their CPU twins, with identical results;
//! on a GPU the tree is uploaded once and the passes keep their buffers
//! between calls. On the CPU, single rays go through the wide BVH
//! (`bvh`) by default, built the first time they are traced; `Accel`
//! chooses.

use serde::Serialize;

use crate::accel::bvh::Bvh8;
use crate::accel::kdtree::gpu::{GpuKdTree, TraceMode, TraceRaysBatches};
use crate::accel::kdtree::{BuildStats, KdTree, KdTreeParams, TraversalCounts};
use crate::error::Result;
use crate::geom::ray::{Hit, Ray};
use crate::geom::simd::Isa;
use crate::gpu::GpuContext;
use crate::gpu::device::{Device, GpuOutput, OnDevice, Timed, Timing, elapsed_ms};
use crate::progress::{Bar, Reporter};
use crate::raycast::ao_rays::{Casting, ao_rays_by};
use crate::raycast::gpu::AoRaysBatches;
use crate::raycast::{AoPoint, AoSettings, VisibilityMasks};
use crate::report::repeats::{Repeats, RunTimes};
use crate::scene::Mesh;

/// The kd-tree builder's settings for a tree walked on `device`: the CPU's
/// (`KdTreeParams::for_cpu`, larger leaves for its vector lanes) or the
/// GPU's (`Default`).
pub fn tree_params(device: &Device) -> KdTreeParams {
    if device.is_gpu() {
        KdTreeParams::default()
    } else {
        KdTreeParams::for_cpu()
    }
}

/// Builds the kd-tree of `mesh` with `params` (`tree_params` of the device
/// that walks it); a spinner names `what` while a large mesh builds.
pub fn build_tree(mesh: &Mesh, params: &KdTreeParams, bars: &Reporter, what: &str) -> Result<KdTree> {
    // A bar of one step per triangle, shown once the build has taken a
    // second (`progress`), advancing leaf by leaf.
    let progress = bars.bar(mesh.triangles.len() as u64, &format!("building kd-tree ({what})"));
    let tree = KdTree::build_with(mesh, params, &progress)?;
    progress.finish();
    Ok(tree)
}

/// What `trace-rays` reports: the contract's fields, the tree's (and on the
/// CPU the BVH's) build, and the runs.
#[derive(Debug, Clone, Serialize)]
pub struct TraceRaysReport {
    pub rays: usize,
    pub hits: usize,
    /// The kd-tree's build (the BVH's is `bvh.build_ms`).
    pub build_ms: f64,
    pub trace_ms: f64,
    pub mrays_per_s: f64,
    pub timing: Timing,
    pub kdtree: BuildStats,
    pub bvh: Option<BvhStats>,
    pub runs: RunTimes,
}

/// Closest hits of `rays` (a ray file's, in no particular order) against
/// `mesh` on `device`, single rays walking `accel` on the CPU, timed as
/// `runs` says: the runner of `trace-rays`.
pub fn trace_ray_file(
    device: &Device,
    mesh: &Mesh,
    rays: &[Ray],
    accel: Accel,
    runs: &Repeats,
    bars: &Reporter,
) -> Result<(Vec<Hit>, TraceRaysReport)> {
    let mut tracer = Tracer::build(device, mesh, bars, "trace-rays")?.with_accel(accel);
    let progress = bars.spinner(&format!("tracing {} rays", rays.len()));
    let (traced, times) = runs.run("trace_ms", || tracer.closest_incoherent(rays), |t| t.ms)?;
    progress.finish();
    let kdtree = tracer.tree().stats.clone();
    let report = TraceRaysReport {
        rays: rays.len(),
        hits: traced.value.iter().filter(|h| h.is_hit()).count(),
        build_ms: kdtree.build_ms,
        trace_ms: traced.ms,
        mrays_per_s: crate::report::mrays_per_s(rays.len(), traced.ms),
        timing: traced.timing,
        kdtree,
        bvh: tracer.bvh_stats().cloned(),
        runs: times,
    };
    Ok((traced.value, report))
}

/// What a tracer keeps on a GPU.
pub struct GpuTracer {
    pub tree: GpuKdTree,
    rays: Option<TraceRaysBatches>,
    ao: Option<AoRaysBatches>,
}

/// The structure single rays walk on the CPU (the GPU kernels walk the
/// kd-tree). The hits are the same; where two triangles are hit at exactly
/// the same t, the BVH reports the one of smaller index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Accel {
    /// The wide BVH (`bvh`): 1.1 to 2.2 times the kd-tree's speed on
    /// single rays (least on long thin triangles), built in about a fifth
    /// of the kd-tree's time.
    #[default]
    Bvh,
    /// The kd-tree's single-ray walk (the MLRTA paper's foundation).
    Kdtree,
}

/// What the BVH cost and holds (JSON `bvh`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BvhStats {
    pub build_ms: f64,
    pub nodes: usize,
    pub leaf_blocks: usize,
    /// Triangles in the leaves, counting the copies spatial splits made.
    pub references: usize,
    pub bytes: usize,
}

impl BvhStats {
    /// Builds `tree`'s BVH if it has none yet (the time is then its build's)
    /// and describes it.
    pub fn build(tree: &KdTree) -> BvhStats {
        let start = std::time::Instant::now();
        let bvh = tree.bvh();
        BvhStats {
            build_ms: elapsed_ms(start),
            nodes: bvh.nodes.len(),
            leaf_blocks: bvh.blocks.len(),
            references: bvh.references(),
            bytes: bvh.memory_bytes(),
        }
    }
}

/// A kd-tree and, on a GPU, its upload and passes; on the CPU, the BVH of
/// its triangles once single rays need it.
pub struct Tracer {
    tree: KdTree,
    gpu: OnDevice<GpuTracer>,
    accel: Accel,
    bvh_stats: Option<BvhStats>,
}

impl Tracer {
    /// Builds the tree over `mesh` for `device` (`tree_params`) and
    /// uploads it; `what` names the mesh on a spinner for large meshes.
    pub fn build(device: &Device, mesh: &Mesh, bars: &Reporter, what: &str) -> Result<Tracer> {
        Self::from_tree(device, build_tree(mesh, &tree_params(device), bars, what)?)
    }

    /// A tree built elsewhere, uploaded to `device`.
    pub fn from_tree(device: &Device, tree: KdTree) -> Result<Tracer> {
        let gpu = device.prepare(|ctx| {
            Ok(GpuTracer {
                tree: GpuKdTree::upload(&ctx.device, &tree)?,
                rays: None,
                ao: None,
            })
        })?;
        Ok(Tracer {
            tree,
            gpu,
            accel: Accel::default(),
            bvh_stats: None,
        })
    }

    /// The structure of single rays on the CPU.
    #[must_use]
    pub fn with_accel(mut self, accel: Accel) -> Tracer {
        self.accel = accel;
        self
    }

    /// The BVH's cost, once it has been built.
    pub fn bvh_stats(&self) -> Option<&BvhStats> {
        self.bvh_stats.as_ref()
    }

    /// Builds the BVH if single rays on the CPU will walk it (before any
    /// clock starts: its build is reported apart, as the kd-tree's).
    fn ready_bvh(&mut self) -> Option<&Bvh8> {
        if self.accel != Accel::Bvh || self.gpu.state().is_some() {
            return None;
        }
        if !self.tree.has_bvh() {
            self.bvh_stats = Some(BvhStats::build(&self.tree));
        }
        Some(self.tree.bvh())
    }

    /// Whether a segment from `origin` along `dir` hits anything at `0 < t
    /// < t_max`, on the CPU (shadow rays of single-ray images), as a
    /// function threads can share.
    pub fn any_hit_fn(&mut self) -> impl Fn(glam::Vec3, glam::Vec3, f32) -> bool + Sync + '_ {
        let bvh = self.ready_bvh().is_some();
        let tree = &self.tree;
        move |o, d, t_max| {
            if bvh {
                tree.bvh_any_hit(o, d, t_max)
            } else {
                tree.any_hit(o, d, t_max)
            }
        }
    }

    pub fn tree(&self) -> &KdTree {
        &self.tree
    }

    /// The tree on the GPU, if the device is one.
    pub fn gpu_tree(&self) -> Option<&GpuKdTree> {
        self.gpu.state().map(|g| &g.tree)
    }

    /// Closest hits of `rays` (directions need not be normalised; t in their units).
    pub fn closest(&mut self, rays: &[Ray]) -> Result<Timed<Vec<Hit>>> {
        self.closest_by(rays, KdTree::trace_closest)
    }

    /// `closest` for rays in no particular order (a ray file): on the CPU
    /// the kd-tree traces them in an order sorted by where they enter it
    /// (`KdTree::trace_closest_incoherent`); the BVH, whose nodes stay in
    /// cache, gains nothing from the sort (measured: 2.93 sorted against
    /// 3.01 Mrays/s on 1M random bunny rays) and takes them as they come.
    pub fn closest_incoherent(&mut self, rays: &[Ray]) -> Result<Timed<Vec<Hit>>> {
        self.closest_by(rays, KdTree::trace_closest_incoherent)
    }

    /// Closest hits on the GPU, on the CPU through the BVH, or else by
    /// the kd-tree's `cpu`.
    fn closest_by(&mut self, rays: &[Ray], cpu: fn(&KdTree, &[Ray]) -> Vec<Hit>) -> Result<Timed<Vec<Hit>>> {
        let bvh = self.ready_bvh().is_some();
        let tree = &self.tree;
        self.gpu.run(
            |ctx, g| {
                let traced = g.trace(ctx, rays, TraceMode::Closest)?;
                Ok(GpuOutput {
                    value: traced.hits,
                    gpu_ms: traced.gpu_ms,
                })
            },
            || {
                Ok(if bvh {
                    tree.bvh_trace_closest(rays)
                } else {
                    cpu(tree, rays)
                })
            },
        )
    }

    /// Traversal steps and intersection tests of the closest hits of
    /// `rays`, summed (the kernel's counters on a GPU; not timed).
    pub fn traversal_counts(&mut self, rays: &[Ray]) -> Result<TraversalCounts> {
        let tree = &self.tree;
        let counted = self.gpu.run(
            |ctx, g| {
                let traced = g.trace(ctx, rays, TraceMode::ClosestCounted)?;
                Ok(GpuOutput {
                    value: traced.counts.unwrap_or_default(),
                    gpu_ms: None,
                })
            },
            || Ok(tree.trace_closest_counted(rays).1),
        )?;
        let sum = counted.value.iter().fold(TraversalCounts::default(), |mut acc, c| {
            acc.cells += c[0] as u64;
            acc.intersections += c[1] as u64;
            acc
        });
        Ok(sum)
    }

    /// AO rays of `points`: which of each point's rays escape.
    pub fn ao_visibility(
        &mut self,
        points: &[AoPoint],
        settings: &AoSettings,
        progress: &Bar,
    ) -> Result<Timed<VisibilityMasks>> {
        settings.validate()?;
        let bvh = self.ready_bvh().is_some();
        let tree = &self.tree;
        self.gpu.run(
            |ctx, g| {
                let batches = g.ao.get_or_insert_with(|| AoRaysBatches::new(ctx));
                let rays_per_batch = crate::raycast::gpu::RAYS_PER_BATCH;
                let (masks, gpu_ms) = batches.visibility(ctx, &g.tree, points, settings, progress, rays_per_batch)?;
                Ok(GpuOutput { value: masks, gpu_ms })
            },
            || {
                let casting = if bvh {
                    Casting::BvhPackets(Isa::best())
                } else {
                    Casting::Packets(Isa::best())
                };
                Ok(ao_rays_by(tree, points, settings, progress, casting))
            },
        )
    }
}

impl GpuTracer {
    fn trace(
        &mut self,
        ctx: &GpuContext,
        rays: &[Ray],
        mode: TraceMode,
    ) -> Result<crate::accel::kdtree::gpu::GpuTrace> {
        let batches = self.rays.get_or_insert_with(|| TraceRaysBatches::new(ctx));
        batches.trace(ctx, &self.tree, rays, mode, f32::INFINITY, usize::MAX)
    }
}
