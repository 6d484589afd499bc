//! A kd-tree ready on a device: the runner every ray-casting method goes
//! through. Closest hits (`trace-rays`, primary visibility of images) and AO
//! rays (reference AO, and the ground truth of fields, SSAO and PRT) run in
//! the WGSL kernels on a GPU or in their CPU twins, with identical results;
//! on a GPU the tree is uploaded once and the passes keep their buffers
//! between calls. On the CPU, single rays and AO packets go through the
//! wide BVH by default, built the first time they are traced; a
//! `Structure` chooses (`accel`).

use serde::Serialize;

use crate::accel::kdtree::gpu::{GpuKdTree, TraceMode, TraceRaysBatches};
use crate::accel::kdtree::{BuildStats, KdTree, KdTreeSettings, TraversalCounts};
use crate::accel::{Accel, BvhStats, Structure};
use crate::error::Result;
use crate::geom::ray::{Hit, Ray};
use crate::geom::simd::Isa;
use crate::gpu::GpuContext;
use crate::gpu::device::{Device, GpuOutput, OnDevice, Timed, Timing};
use crate::progress::{Bar, Reporter};
use crate::raycast::ao_rays::{Casting, ao_rays_through};
use crate::raycast::gpu::AoRaysBatches;
use crate::raycast::holes::closest_past_holes;
use crate::raycast::{AoPoint, AoSettings, VisibilityMasks};
use crate::report::repeats::{Repeats, RunTimes};
use crate::scene::Mesh;
use crate::scene::cutouts::Cutouts;
use glam::Vec3;
use std::sync::Arc;

/// The kd-tree builder's settings for a tree walked on `device`: the CPU's
/// (`KdTreeSettings::for_cpu`, larger leaves for its vector lanes) or the
/// GPU's (`Default`).
pub fn tree_params(device: &Device) -> KdTreeSettings {
    if device.is_gpu() {
        KdTreeSettings::default()
    } else {
        KdTreeSettings::for_cpu()
    }
}

/// Builds the kd-tree of `mesh` with `params` (`tree_params` of the device
/// that walks it); the phase named for `what` (which of a run's meshes)
/// while a large mesh builds.
pub(crate) fn build_tree(mesh: &Mesh, params: &KdTreeSettings, bars: &Reporter, what: &str) -> Result<KdTree> {
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
    /// Rays traced.
    pub rays: usize,
    /// Rays that hit a triangle.
    pub hits: usize,
    /// The kd-tree's build (the BVH's is `bvh.build_ms`).
    pub build_ms: f64,
    /// The trace's time (the kernel's on a GPU with timestamps).
    pub trace_ms: f64,
    /// Millions of rays per second of `trace_ms`.
    pub mrays_per_s: f64,
    /// What `trace_ms` measured.
    pub timing: Timing,
    /// The kd-tree's build statistics.
    pub kdtree: BuildStats,
    /// The BVH's, when single rays walked it.
    pub bvh: Option<BvhStats>,
    /// Every run's time.
    pub runs: RunTimes,
}

/// Closest hits of `rays` (a ray file's, in no particular order) against
/// `mesh` on `device`, single rays walking `structure` on the CPU, timed as
/// `runs` says: the runner of `trace-rays`.
pub fn trace_ray_file(
    device: &Device,
    mesh: &Mesh,
    rays: &[Ray],
    structure: Structure,
    runs: &Repeats,
    bars: &Reporter,
) -> Result<(Vec<Hit>, TraceRaysReport)> {
    let mut tracer = Tracer::build_labelled(device, mesh, bars, "trace-rays")?.with_structure(structure);
    let progress = bars.spinner(&format!("tracing {} rays", rays.len()));
    let (traced, times) = runs.run("trace_ms", || tracer.closest_incoherent(rays), |t| t.ms)?;
    progress.finish();
    let kdtree = tracer.accel().kdtree().stats.clone();
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
    /// The kd-tree, uploaded.
    pub tree: GpuKdTree,
    rays: Option<TraceRaysBatches>,
    ao: Option<AoRaysBatches>,
}

/// A scene's `Accel` and, on a GPU, its kd-tree's upload and passes; on
/// the CPU, the BVH of its triangles once single rays or AO packets walk
/// it (`Structure::Bvh`).
pub struct Tracer {
    accel: Accel,
    gpu: OnDevice<GpuTracer>,
    structure: Structure,
    bvh_stats: Option<BvhStats>,
    /// The mesh's alpha cut-outs and their words as the kernels read them.
    cutouts: Option<(Arc<Cutouts>, Vec<u32>)>,
}

impl Tracer {
    /// Closest hits and AO rays of `mesh` on `device`: builds its kd-tree
    /// (`tree_params` of the device) and, on a GPU, uploads it.
    ///
    /// ```
    /// use glam::Vec3;
    /// use penumbra::{Device, Tracer};
    /// use penumbra::geom::ray::Ray;
    /// use penumbra::scene::procedural::sphere_on_plane;
    ///
    /// let mut tracer = Tracer::new(&Device::cpu(), &sphere_on_plane())?;
    /// let down = Ray::new(Vec3::new(0.0, 10.0, 0.0), Vec3::new(0.0, -1.0, 0.0));
    /// let hits = tracer.closest(&[down])?;
    /// assert!(hits.value[0].is_hit());
    /// # Ok::<(), penumbra::Error>(())
    /// ```
    pub fn new(device: &Device, mesh: &Mesh) -> Result<Tracer> {
        Self::build(device, mesh, &Reporter::silent())
    }

    /// `new`, following the kd-tree's build with `bars`.
    pub fn build(device: &Device, mesh: &Mesh, bars: &Reporter) -> Result<Tracer> {
        Self::build_labelled(device, mesh, bars, "mesh")
    }

    /// `build` with the phase named for `what` (which of a run's meshes).
    pub(crate) fn build_labelled(device: &Device, mesh: &Mesh, bars: &Reporter, what: &str) -> Result<Tracer> {
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
            accel: Accel::new(tree),
            gpu,
            structure: Structure::default(),
            bvh_stats: None,
            cutouts: None,
        })
    }

    /// Rays pass the holes of `cutouts` (of this tracer's mesh, triangle
    /// for triangle): AO rays on either device (`ao_rays_through`, the
    /// `ao_rays` kernel), and closest hits (`closest`), whose hits in a
    /// hole are followed on past it on the CPU.
    #[must_use]
    pub fn with_cutouts(mut self, cutouts: Option<Arc<Cutouts>>) -> Tracer {
        self.cutouts = cutouts.map(|c| {
            let words = c.words();
            (c, words)
        });
        self
    }

    /// The cut-outs rays pass, if any.
    pub fn cutouts(&self) -> Option<&Cutouts> {
        self.cutouts.as_ref().map(|c| &*c.0)
    }

    /// The structure of single rays and AO packets on the CPU.
    #[must_use]
    pub fn with_structure(mut self, structure: Structure) -> Tracer {
        self.structure = structure;
        self
    }

    /// The BVH's cost, once this tracer has built it.
    pub fn bvh_stats(&self) -> Option<&BvhStats> {
        self.bvh_stats.as_ref()
    }

    /// The structure rays walk on the CPU, the BVH built first if that is
    /// it (before any clock starts: its build is reported apart, as the
    /// kd-tree's); `None` on a GPU.
    fn ready_structure(&mut self) -> Option<Structure> {
        if self.gpu.state().is_some() {
            return None;
        }
        if self.structure == Structure::Bvh && !self.accel.has_bvh() {
            self.bvh_stats = Some(self.accel.bvh_stats());
        }
        Some(self.structure)
    }

    /// Whether a segment from `origin` along `dir` hits anything at `0 < t
    /// < t_max`, on the CPU (shadow rays of single-ray images), as a
    /// function threads can share.
    pub fn any_hit_fn(&mut self) -> impl Fn(glam::Vec3, glam::Vec3, f32) -> bool + Sync + '_ {
        let structure = self.ready_structure().unwrap_or(Structure::Kdtree);
        let accel = &self.accel;
        move |o, d, t_max| accel.any_hit(structure, o, d, t_max)
    }

    /// The scene's kd-tree and BVH.
    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    /// The tree on the GPU, if the device is one.
    pub fn gpu_tree(&self) -> Option<&GpuKdTree> {
        self.gpu.state().map(|g| &g.tree)
    }

    /// Closest hits of `rays` (directions need not be normalised; t in their units).
    pub fn closest(&mut self, rays: &[Ray]) -> Result<Timed<Vec<Hit>>> {
        self.closest_by(rays, Accel::trace_closest)
    }

    /// `closest` for rays in no particular order (a ray file): on the CPU
    /// `Accel::trace_closest_incoherent`.
    pub fn closest_incoherent(&mut self, rays: &[Ray]) -> Result<Timed<Vec<Hit>>> {
        self.closest_by(rays, Accel::trace_closest_incoherent)
    }

    /// Closest hits on the GPU, or on the CPU by `cpu` walking the
    /// tracer's structure.
    fn closest_by(&mut self, rays: &[Ray], cpu: fn(&Accel, Structure, &[Ray]) -> Vec<Hit>) -> Result<Timed<Vec<Hit>>> {
        let structure = self.ready_structure().unwrap_or(Structure::Kdtree);
        let accel = &self.accel;
        let mut traced = self.gpu.run(
            |ctx, g| {
                let traced = g.trace(ctx, rays, TraceMode::Closest)?;
                Ok(GpuOutput {
                    value: traced.hits,
                    gpu_ms: traced.gpu_ms,
                })
            },
            || Ok(cpu(accel, structure, rays)),
        )?;
        if let Some((cutouts, _)) = &self.cutouts {
            follow_past_holes(accel, structure, cutouts, rays, &mut traced.value);
        }
        Ok(traced)
    }

    /// Traversal steps and intersection tests of the closest hits of
    /// `rays`, summed (the kernel's counters on a GPU; not timed).
    pub fn traversal_counts(&mut self, rays: &[Ray]) -> Result<TraversalCounts> {
        let tree = self.accel.kdtree();
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
        let structure = self.ready_structure().unwrap_or(Structure::Kdtree);
        let accel = &self.accel;
        let cutouts = self.cutouts.as_ref();
        self.gpu.run(
            |ctx, g| {
                let batches = g.ao.get_or_insert_with(|| AoRaysBatches::new(ctx));
                let rays_per_batch = crate::raycast::gpu::RAYS_PER_BATCH;
                let words = cutouts.map(|c| c.1.as_slice());
                let (masks, gpu_ms) =
                    batches.visibility(ctx, &g.tree, words, points, settings, progress, rays_per_batch)?;
                Ok(GpuOutput { value: masks, gpu_ms })
            },
            || {
                let casting = Casting::Packets(structure, Isa::best());
                let cutouts = cutouts.map(|c| &*c.0);
                Ok(ao_rays_through(accel, cutouts, points, settings, progress, casting))
            },
        )
    }
}

/// Hits of `rays` that fall in a cut-out's hole, followed on past it (and
/// any holes after) on the CPU: few rays hit a hole, so the GPU's answer
/// for the rest stands.
fn follow_past_holes(accel: &Accel, structure: Structure, cutouts: &Cutouts, rays: &[Ray], hits: &mut [Hit]) {
    use rayon::prelude::*;
    let triangles = &accel.kdtree().triangles;
    hits.par_iter_mut()
        .zip(rays.par_iter())
        .with_min_len(256)
        .for_each(|(hit, ray)| {
            if !hit.is_hit() {
                return;
            }
            let (o, d) = (Vec3::from_array(ray.origin), Vec3::from_array(ray.dir));
            let v = triangles[hit.triangle as usize];
            if !cutouts.is_hole(hit.triangle, v, o + d * hit.t) {
                return;
            }
            *hit = closest_past_holes(cutouts, triangles, o, d, f32::INFINITY, |o, d, t| {
                accel.closest_hit(structure, o, d, t)
            });
        });
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
