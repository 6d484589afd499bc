//! The per-frame loop on the CPU: for every vertex, build its tangent frame,
//! gather and cull blockers (hierarchy, culling groups or PVS, horizon),
//! rasterise them into a mask, integrate, rotate and shade (section 3,
//! "Rendering"). Nothing is precomputed from the animation unless a PVS is
//! given; the topology-dependent tables (LUT, cell integrals, hierarchy) are
//! built once per mesh.
//!
//! Time is spent in four phases, the columns of the paper's Table 2:
//! *transform* (tangent frame, group culling, blocker vertices into the
//! frame, horizon culling), *rasterisation* (edge planes, back-face and
//! edge-on tests, LUT fetches, AND/OR), *integration* (downsampling, SH
//! integration, rotation to world space) and *other* (vertex normals, group
//! boxes, dotting with the lighting, bookkeeping).

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use super::Csr;
use super::blockers::{OtherStats, Receiver, SceneBlockers};
use super::hierarchy::{Hierarchy, HierarchySettings};
use super::lut::PlaneLut;
use super::mask::MaskGrid;
use super::raster::{BatchRefs, TriangleBatch, batch_or, batch_refs_inline};
use super::sides::Sides;
use super::transfer::{Brdf, CellTables, Integration, radiance};
use crate::error::{Error, Result};
use crate::gpu::device::elapsed_ms;
use crate::scene::{ORIGIN_OFFSET, used_bounds, vertex_normals};
use crate::sh::{MAX_BANDS, ShRotation, coefficient_count, tangent_frame};

/// Per-vertex counters of a frame: vertices, without normal, candidates,
/// group-culled, below, back-facing, edge-on, drawn, the four phase times,
/// then other objects' blockers (`OtherStats` in field order).
const COUNTERS: usize = 19;

/// On, off, or decided from the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Toggle {
    /// Decided from the mesh.
    Auto,
    /// Forced on.
    On,
    /// Forced off.
    Off,
}

crate::choice!(Toggle { Auto = "auto", On = "on", Off = "off" });

impl Toggle {
    /// The forced value, or None for `Auto`.
    pub fn forced(self) -> Option<bool> {
        match self {
            Toggle::Auto => None,
            t => Some(t == Toggle::On),
        }
    }
}

/// How PRT computes transfer: mask and LUT resolution, SH order, BRDF,
/// integration, hierarchy and culling. `Default` is the command line's
/// defaults (the paper's 32x32 masks, 128² LUT cells per face, 25
/// coefficients, diffuse).
#[derive(Debug, Clone, PartialEq)]
pub struct PrtSettings {
    /// Mask side S (16, 32 or 64).
    pub mask_side: usize,
    /// LUT cells per cube-face side.
    pub lut_size: usize,
    /// SH bands (5 = 25 coefficients).
    pub bands: usize,
    /// The BRDF integrated into the transfer (default: diffuse).
    pub brdf: Brdf,
    /// How masks are integrated (4x4 cells, with first moments, or pixels).
    pub integration: Integration,
    /// The two-level mesh and culling groups (section 3.2).
    pub hierarchy: HierarchySettings,
    /// Skip culling groups whose box is below the tangent plane.
    pub group_culling: bool,
    /// Cull blockers facing away from the vertex (auto: where rays find that
    /// culling costs no accuracy, `sides`).
    pub backface: Toggle,
    /// Shade the side of each vertex that faces the eye (auto: where the
    /// mesh's back is seen from outside, as a cloth's, `sides`).
    pub two_sided: Toggle,
    /// Rasterise at all (off: the unshadowed transfer, for comparison).
    pub shadows: bool,
}

impl Default for PrtSettings {
    fn default() -> Self {
        PrtSettings {
            mask_side: 32,
            lut_size: 128,
            bands: 5,
            brdf: Brdf::Diffuse,
            integration: Integration::CellsLinear,
            hierarchy: HierarchySettings::default(),
            group_culling: true,
            backface: Toggle::Auto,
            two_sided: Toggle::Auto,
            shadows: true,
        }
    }
}

impl PrtSettings {
    /// Checks the settings before any work: 1 to [`MAX_BANDS`] bands, a LUT
    /// of at least one cell, Phong's exponent in [0, 10000] and weight in
    /// [0, 1], a supported mask side; an error naming the setting
    /// otherwise. (The hierarchy's settings are checked when it is built.)
    pub fn validate(&self) -> Result<()> {
        if self.bands == 0 || self.bands > MAX_BANDS {
            return Err(Error::param(
                "bands",
                format!("must be between 1 and {MAX_BANDS} bands, got {}", self.bands),
            ));
        }
        if self.lut_size == 0 {
            return Err(Error::param("lut_size", "must be at least 1"));
        }
        if let Brdf::Phong { shininess, specular } = self.brdf {
            if !(shininess.is_finite() && (0.0..=1e4).contains(&shininess)) {
                return Err(Error::param(
                    "shininess",
                    format!("must be in [0, 10000], got {shininess}"),
                ));
            }
            if !(0.0..=1.0).contains(&specular) {
                return Err(Error::param("specular", format!("must be in [0, 1], got {specular}")));
            }
        }
        MaskGrid::new(self.mask_side).map(|_| ())
    }
}

/// Counts of one frame (sums over vertices).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameStats {
    /// Vertices whose transfer was computed (with a normal).
    pub vertices: u64,
    /// Vertices without a normal (no triangle of non-zero area uses them).
    pub without_normal: u64,
    /// Blockers considered before any culling (hierarchy or PVS lists).
    pub candidates: u64,
    /// Blockers skipped with their culling group.
    pub group_culled: u64,
    /// Blockers with no vertex above the vertex's tangent plane.
    pub below_horizon: u64,
    /// Blockers culled as facing away from the vertex (back-face culling on).
    pub back_facing: u64,
    /// Blockers seen edge-on from the vertex (zero solid angle), zero-area
    /// ones included.
    pub edge_on: u64,
    /// Blockers rasterised.
    pub drawn: u64,
    /// Nanoseconds in transform, rasterisation, integration, other (summed
    /// over threads; only with profiling on).
    pub phase_ns: [u64; 4],
    /// Other objects' blockers (`blockers`; zero for a lone mesh).
    pub others: OtherStats,
}

impl std::ops::AddAssign<&FrameStats> for FrameStats {
    fn add_assign(&mut self, s: &FrameStats) {
        self.vertices += s.vertices;
        self.without_normal += s.without_normal;
        self.candidates += s.candidates;
        self.group_culled += s.group_culled;
        self.below_horizon += s.below_horizon;
        self.back_facing += s.back_facing;
        self.edge_on += s.edge_on;
        self.drawn += s.drawn;
        for (sum, ns) in self.phase_ns.iter_mut().zip(s.phase_ns) {
            *sum += ns;
        }
        self.others += &s.others;
    }
}

/// One frame's results.
#[derive(Debug, Clone, Default)]
pub struct FrameOutput {
    /// World-space transfer vectors, `coeffs` per vertex.
    pub transfer: Vec<f32>,
    /// Exitant radiance per vertex (linear RGB).
    pub radiance: Vec<[f32; 3]>,
    /// The normal each vertex was shaded with (zero: none).
    pub normals: Vec<Vec3>,
    /// Its visibility mask (only when asked for).
    pub masks: Vec<u64>,
    /// The frame's blocker counts and, with profiling, phase times.
    pub stats: FrameStats,
}

/// Everything built once per mesh: tables, LUT, hierarchy, optional PVS.
pub struct Prt {
    /// The settings it was built with (validated).
    pub settings: PrtSettings,
    /// The mask grid of `settings.mask_side`.
    pub grid: MaskGrid,
    /// The plane LUT of `settings.lut_size` cells per face.
    pub lut: PlaneLut,
    /// The cell and pixel integrals of `settings.bands` bands.
    pub tables: CellTables,
    /// Rotation of transfer vectors from tangent frame to world space.
    pub rotation: ShRotation,
    /// The two-level mesh and culling groups.
    pub hierarchy: Hierarchy,
    /// Per vertex, blocker ids (`far` index, or `far.len() + fine index`);
    /// set with `set_pvs`.
    pvs: Option<Csr>,
    /// Per vertex, the blockers it always visits (near field, or its whole
    /// PVS) with their vertices, for the transform loop.
    own: OwnLists,
    /// Blockers facing away from the vertex are culled (the `backface`
    /// toggle, or decided from the mesh).
    pub cull_backfaces: bool,
    /// Each vertex is shaded on the side facing the eye (the `two_sided`
    /// toggle, or decided from the mesh).
    pub two_sided: bool,
    /// How culling and sidedness were decided.
    pub sides: Sides,
    /// Vertices of the mesh: every frame's positions must have this many.
    pub vertex_count: usize,
    /// Bounding-box diagonal of the rest pose's used vertices (sets the
    /// contract's origin offset and the scale of tangent-frame coordinates).
    pub scale: f32,
    /// Milliseconds spent building the LUT (wall clock).
    pub lut_ms: f64,
    /// Milliseconds spent building everything, LUT included (wall clock).
    pub setup_ms: f64,
    avx2: bool,
}

/// Per-vertex blocker lists in local form: the distinct vertices they use
/// and the triangles as indices into those.
#[derive(Debug, Clone, Default)]
struct OwnLists {
    verts: Csr,
    tri_offsets: Vec<u32>,
    tris: Vec<[u16; 3]>,
    /// Largest number of blockers any vertex may gather.
    max_candidates: usize,
}

impl OwnLists {
    /// From per-vertex triangle lists (each triangle as 3 global vertices).
    fn build(lists: impl Iterator<Item = Vec<[u32; 3]>>) -> OwnLists {
        let mut verts = Vec::new();
        let mut tri_offsets = vec![0u32];
        let mut tris = Vec::new();
        let mut map = std::collections::HashMap::new();
        for list in lists {
            map.clear();
            let mut vs = Vec::new();
            for t in list {
                tris.push(t.map(|g| {
                    let next = vs.len() as u16;
                    *map.entry(g).or_insert_with(|| {
                        vs.push(g);
                        next
                    })
                }));
            }
            verts.push(vs);
            tri_offsets.push(tris.len() as u32);
        }
        OwnLists {
            verts: Csr::from_vecs(&verts),
            tri_offsets,
            tris,
            max_candidates: 0,
        }
    }

    fn tris(&self, v: usize) -> &[[u16; 3]] {
        &self.tris[self.tri_offsets[v] as usize..self.tri_offsets[v + 1] as usize]
    }
}

/// Per-thread scratch, reused across vertices and frames.
#[derive(Default)]
struct Scratch {
    tris: TriangleBatch,
    refs: BatchRefs,
    local: [Vec<f32>; 3],
    gathered: [Vec<f32>; 3],
    excluded: Vec<u64>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// What a frame computes: with timing, keeping the masks, and whether it
/// integrates, rotates and shades (false: masks only, for the GPU kernel).
#[derive(Debug, Clone, Copy)]
struct FrameWork {
    profile: bool,
    keep_masks: bool,
    integrate: bool,
}

/// Per-frame data shared by all vertices.
struct FrameShared<'a> {
    positions: &'a [Vec3],
    normals: &'a [Vec3],
    eye: Option<Vec3>,
    lighting: &'a [f32],
    boxes: Vec<(Vec3, Vec3)>,
    /// Group vertices (`Hierarchy::group_verts` order) in SoA.
    far_xyz: [Vec<f32>; 3],
    profile: bool,
    /// Integrate, rotate and shade (false: masks only, for the GPU kernel).
    integrate: bool,
    /// Other objects' blockers and the receiving object's id.
    others: Option<Receiver<'a>>,
}

impl Prt {
    /// Builds the tables and hierarchy for a mesh given its rest pose.
    pub fn new(rest: &[Vec3], triangles: &[[u32; 3]], settings: &PrtSettings) -> Result<Prt> {
        Self::new_posed(&[rest], triangles, settings)
    }

    /// `new` for an animated mesh: `poses[0]` is the rest pose, the others
    /// poses of the animation its coarse level is checked on as well.
    pub fn new_posed(poses: &[&[Vec3]], triangles: &[[u32; 3]], settings: &PrtSettings) -> Result<Prt> {
        let rest = *poses
            .first()
            .ok_or_else(|| Error::param("poses", "needs the rest pose"))?;
        settings.validate()?;
        if triangles.is_empty() {
            return Err(Error::input("mesh", "has no triangles"));
        }
        for pose in poses {
            if let Some(i) = pose.iter().position(|p| !p.is_finite()) {
                return Err(Error::input(format!("vertex {}", i + 1), "has a non-finite coordinate"));
            }
        }
        let nv = rest.len() as u32;
        if let Some((t, _)) = triangles.iter().enumerate().find(|(_, t)| t.iter().any(|&v| v >= nv)) {
            return Err(Error::input(format!("triangle {t}"), "has a vertex index out of range"));
        }
        let start = Instant::now();
        let grid = MaskGrid::new(settings.mask_side)?;
        let t = Instant::now();
        let lut = PlaneLut::build(&grid, settings.lut_size)?;
        let lut_ms = elapsed_ms(t);
        let hierarchy = Hierarchy::build_posed(poses, triangles, &settings.hierarchy)?;
        let sides = super::sides::decide(rest, triangles, settings.backface.forced(), settings.two_sided.forced())?;
        let mut prt = Self::assemble(rest, triangles, settings, (grid, lut, lut_ms), hierarchy, sides);
        prt.setup_ms = elapsed_ms(start);
        Ok(prt)
    }

    /// `new` from parts another `Prt` of the same mesh built: the LUT of
    /// `settings`' mask side and LUT size, the hierarchy of its hierarchy
    /// settings and the sidedness of its toggles (what a probe of several
    /// settings shares between them). `setup_ms` counts only the rest.
    pub(crate) fn with_parts(
        rest: &[Vec3],
        triangles: &[[u32; 3]],
        settings: &PrtSettings,
        lut: &PlaneLut,
        hierarchy: &Hierarchy,
        sides: Sides,
    ) -> Result<Prt> {
        let start = Instant::now();
        let grid = MaskGrid::new(settings.mask_side)?;
        if lut.n != settings.lut_size || lut.words != grid.words {
            return Err(Error::internal("a LUT of other settings"));
        }
        let mut prt = Self::assemble(
            rest,
            triangles,
            settings,
            (grid, lut.clone(), 0.0),
            hierarchy.clone(),
            sides,
        );
        prt.setup_ms = elapsed_ms(start);
        Ok(prt)
    }

    fn assemble(
        rest: &[Vec3],
        triangles: &[[u32; 3]],
        settings: &PrtSettings,
        (grid, lut, lut_ms): (MaskGrid, PlaneLut, f64),
        hierarchy: Hierarchy,
        sides: Sides,
    ) -> Prt {
        let tables = CellTables::with_integration(&grid, settings.bands, settings.integration);
        let rotation = ShRotation::new(settings.bands);
        let (cull_backfaces, two_sided) = (sides.backface_culling, sides.two_sided);
        let scale = used_bounds(rest, triangles).diagonal().max(f32::MIN_POSITIVE);
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        let mut prt = Prt {
            settings: settings.clone(),
            grid,
            lut,
            tables,
            rotation,
            hierarchy,
            pvs: None,
            own: OwnLists::default(),
            cull_backfaces,
            two_sided,
            sides,
            vertex_count: rest.len(),
            scale,
            lut_ms,
            setup_ms: 0.0,
            avx2,
        };
        prt.build_own_lists();
        prt
    }

    /// Uses a potentially visible set (per vertex, blocker ids as
    /// `pvs::build_pvs` makes them) instead of the hierarchy's lists.
    pub fn set_pvs(&mut self, pvs: Option<Csr>) {
        self.pvs = pvs;
        self.build_own_lists();
    }

    /// The potentially visible set in use, if any.
    pub fn pvs(&self) -> Option<&Csr> {
        self.pvs.as_ref()
    }

    fn build_own_lists(&mut self) {
        let h = &self.hierarchy;
        let far = h.far.len() as u32;
        let nv = self.vertex_count;
        let mut own = match &self.pvs {
            Some(pvs) => OwnLists::build((0..nv).map(|v| {
                pvs.get(v)
                    .iter()
                    .map(|&id| {
                        if id < far {
                            h.far[id as usize]
                        } else {
                            h.fine[(id - far) as usize]
                        }
                    })
                    .collect()
            })),
            None => OwnLists::build((0..nv).map(|v| h.near.get(v).iter().map(|&f| h.fine[f as usize]).collect())),
        };
        own.max_candidates = (0..nv)
            .map(|v| match &self.pvs {
                Some(p) => p.get(v).len(),
                None => h.candidates(v),
            })
            .max()
            .unwrap_or(0);
        self.own = own;
    }

    /// SH coefficients per transfer vector and lighting channel, `bands²`.
    pub fn coeffs(&self) -> usize {
        coefficient_count(self.settings.bands)
    }

    /// Average blockers per vertex before culling.
    pub fn average_candidates(&self) -> f64 {
        let n = self.vertex_count.max(1);
        let total: usize = match &self.pvs {
            Some(p) => p.items.len(),
            None => (0..self.vertex_count).map(|v| self.hierarchy.candidates(v)).sum(),
        };
        total as f64 / n as f64
    }

    /// The normals a frame is shaded with: the contract's area-weighted
    /// vertex normals, turned towards `eye` on two-sided meshes.
    pub fn shading_normals(&self, positions: &[Vec3], eye: Option<Vec3>, out: &mut Vec<Vec3>) {
        vertex_normals(positions, &self.hierarchy.fine, out);
        if self.two_sided
            && let Some(eye) = eye
        {
            for (n, p) in out.iter_mut().zip(positions) {
                if n.dot(eye - *p) < 0.0 {
                    *n = -*n;
                }
            }
        }
    }

    /// Computes one frame: transfer and radiance at every vertex.
    /// `lighting` is planar RGB SH (`3 x coeffs`); `eye` the camera (for
    /// two-sided meshes and glossy BRDFs). With `keep_masks` the masks are
    /// returned too (u64 words, `MaskGrid::words` per vertex).
    pub fn frame(
        &self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        lighting: &[f32],
        profile: bool,
        keep_masks: bool,
        out: &mut FrameOutput,
    ) -> Result<()> {
        self.frame_with(positions, eye, lighting, (profile, keep_masks), None, out)
    }

    /// `frame` of object `id` of a scene, other objects' `blockers`
    /// rasterised into its masks too (`blockers`); `(profile, keep_masks)`.
    pub fn frame_with(
        &self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        lighting: &[f32],
        (profile, keep_masks): (bool, bool),
        others: Option<(&SceneBlockers, usize)>,
        out: &mut FrameOutput,
    ) -> Result<()> {
        if lighting.len() != 3 * self.coeffs() {
            return Err(Error::input("lighting", format!("needs {} values", 3 * self.coeffs())));
        }
        let work = FrameWork {
            profile,
            keep_masks,
            integrate: true,
        };
        self.run_frame(positions, eye, lighting, work, others, out)
    }

    /// The CPU half of a GPU frame: normals and visibility masks only
    /// (`out.masks`, `MaskGrid::words` u64 per vertex); integration,
    /// rotation and shading are left to `gpu::ShTransferPass`.
    pub fn frame_masks(
        &self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        profile: bool,
        out: &mut FrameOutput,
    ) -> Result<()> {
        self.frame_masks_with(positions, eye, profile, None, out)
    }

    /// `frame_masks` of object `id` of a scene, with other objects' `blockers`.
    pub fn frame_masks_with(
        &self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        profile: bool,
        others: Option<(&SceneBlockers, usize)>,
        out: &mut FrameOutput,
    ) -> Result<()> {
        let work = FrameWork {
            profile,
            keep_masks: true,
            integrate: false,
        };
        self.run_frame(positions, eye, &[], work, others, out)
    }

    /// A frame's positions: one per vertex, all finite.
    fn check_positions(&self, positions: &[Vec3]) -> Result<()> {
        if positions.len() != self.vertex_count {
            return Err(Error::input(
                "frame",
                format!(
                    "{} positions for a mesh of {} vertices",
                    positions.len(),
                    self.vertex_count
                ),
            ));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::input(format!("vertex {}", i + 1), "has a non-finite coordinate"));
        }
        Ok(())
    }

    /// The transfer of the listed `vertices` only, as a frame computes it
    /// there: `out.transfer` holds `coeffs` values per listed vertex in the
    /// list's order, `out.normals` every vertex's shading normal, and
    /// `out.stats` the listed vertices' counts (radiance and masks are not
    /// computed). What a probe of settings measures on a sample of vertices
    /// without paying for whole frames.
    pub fn transfer_at(
        &self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        vertices: &[u32],
        out: &mut FrameOutput,
    ) -> Result<()> {
        self.check_positions(positions)?;
        if let Some(&v) = vertices.iter().find(|&&v| v as usize >= self.vertex_count) {
            return Err(Error::input(
                "vertices",
                format!("vertex {v} of a mesh of {} vertices", self.vertex_count),
            ));
        }
        match self.grid.words {
            4 => self.transfer_at_impl::<4>(positions, eye, vertices, out),
            16 => self.transfer_at_impl::<16>(positions, eye, vertices, out),
            64 => self.transfer_at_impl::<64>(positions, eye, vertices, out),
            w => return Err(Error::internal(format!("no rasteriser for {w} mask words"))),
        }
        Ok(())
    }

    fn transfer_at_impl<const W: usize>(
        &self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        vertices: &[u32],
        out: &mut FrameOutput,
    ) {
        let n = self.coeffs();
        out.transfer.clear();
        out.transfer.resize(vertices.len() * n, 0.0);
        out.radiance.clear();
        out.radiance.resize(vertices.len(), [0.0; 3]);
        out.masks.clear();
        let mut normals = std::mem::take(&mut out.normals);
        self.shading_normals(positions, eye, &mut normals);
        let lighting = vec![0.0; 3 * n];
        let work = FrameWork {
            profile: false,
            keep_masks: false,
            integrate: true,
        };
        let shared = self.frame_shared(positions, &normals, eye, &lighting, work, None);
        let counters: [AtomicU64; COUNTERS] = std::array::from_fn(|_| AtomicU64::new(0));
        const CHUNK: usize = 16;
        out.transfer
            .par_chunks_mut(CHUNK * n)
            .zip(out.radiance.par_chunks_mut(CHUNK))
            .zip(vertices.par_chunks(CHUNK))
            .for_each(|((transfer, radiance), listed)| {
                let verts = listed.iter().map(|&v| v as usize);
                self.run_chunk::<W, _>(verts, &shared, (transfer, radiance, None), &counters);
            });
        drop(shared);
        out.normals = normals;
        out.stats = stats_of(counters.map(|c| c.into_inner()), 0);
    }

    /// What every vertex of a frame reads: positions, normals, the
    /// culling groups' boxes and far vertices (without a PVS).
    fn frame_shared<'a>(
        &self,
        positions: &'a [Vec3],
        normals: &'a [Vec3],
        eye: Option<Vec3>,
        lighting: &'a [f32],
        work: FrameWork,
        others: Option<(&'a SceneBlockers, usize)>,
    ) -> FrameShared<'a> {
        let h = &self.hierarchy;
        let mut shared = FrameShared {
            positions,
            normals,
            eye,
            lighting,
            boxes: Vec::new(),
            far_xyz: Default::default(),
            profile: work.profile,
            integrate: work.integrate,
            others: others.filter(|(b, _)| !b.is_empty()).map(|(blockers, id)| Receiver {
                blockers,
                id,
                pixel: 1.0 / self.grid.side as f32,
            }),
        };
        if self.pvs.is_none() {
            if self.settings.group_culling {
                h.group_boxes(positions, &mut shared.boxes);
            }
            for (axis, a) in shared.far_xyz.iter_mut().enumerate() {
                a.extend(h.group_verts.iter().map(|&v| positions[v as usize][axis]));
            }
        }
        shared
    }

    fn run_frame(
        &self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        lighting: &[f32],
        work: FrameWork,
        others: Option<(&SceneBlockers, usize)>,
        out: &mut FrameOutput,
    ) -> Result<()> {
        self.check_positions(positions)?;
        match self.grid.words {
            4 => self.frame_impl::<4>(positions, eye, lighting, work, others, out),
            16 => self.frame_impl::<16>(positions, eye, lighting, work, others, out),
            64 => self.frame_impl::<64>(positions, eye, lighting, work, others, out),
            w => return Err(Error::internal(format!("no rasteriser for {w} mask words"))),
        }
        Ok(())
    }

    fn frame_impl<const W: usize>(
        &self,
        positions: &[Vec3],
        eye: Option<Vec3>,
        lighting: &[f32],
        work: FrameWork,
        others: Option<(&SceneBlockers, usize)>,
        out: &mut FrameOutput,
    ) {
        let keep_masks = work.keep_masks;
        let other_start = Instant::now();
        let n = self.coeffs();
        let nv = positions.len();
        out.transfer.resize(nv * n, 0.0);
        out.radiance.resize(nv, [0.0; 3]);
        out.masks.clear();
        out.masks.resize(if keep_masks { nv * W } else { 0 }, 0);
        let mut normals = std::mem::take(&mut out.normals);
        self.shading_normals(positions, eye, &mut normals);
        let shared = self.frame_shared(positions, &normals, eye, lighting, work, others);
        let counters: [AtomicU64; COUNTERS] = std::array::from_fn(|_| AtomicU64::new(0));
        let setup_ns = other_start.elapsed().as_nanos() as u64;

        const CHUNK: usize = 16;
        let mut mask_chunks: Vec<Option<&mut [u64]>> = if keep_masks {
            out.masks.chunks_mut(CHUNK * W).map(Some).collect()
        } else {
            Vec::new()
        };
        mask_chunks.resize_with(nv.div_ceil(CHUNK), || None);
        out.transfer
            .par_chunks_mut(CHUNK * n)
            .zip(out.radiance.par_chunks_mut(CHUNK))
            .zip(mask_chunks.into_par_iter())
            .enumerate()
            .for_each(|(chunk, ((transfer, radiance), masks))| {
                self.run_chunk::<W, _>(chunk * CHUNK..nv, &shared, (transfer, radiance, masks), &counters);
            });
        drop(shared);
        out.normals = normals;
        out.stats = stats_of(counters.map(|c| c.into_inner()), setup_ns);
    }

    /// One parallel task's vertices `verts` on this thread's scratch, in
    /// AVX2 where the CPU has it; its counts added to `counters`.
    #[inline(always)]
    fn run_chunk<const W: usize, I: Iterator<Item = usize>>(
        &self,
        verts: I,
        shared: &FrameShared,
        (transfer, radiance, masks): (&mut [f32], &mut [[f32; 3]], Option<&mut [u64]>),
        counters: &[AtomicU64; COUNTERS],
    ) {
        SCRATCH.with(|s| {
            let scratch = &mut *s.borrow_mut();
            let mut local = [0u64; COUNTERS];
            #[cfg(target_arch = "x86_64")]
            if self.avx2 {
                // SAFETY: AVX2 and FMA were detected in `Prt::new`.
                unsafe { self.chunk_avx2::<W, I>(verts, shared, scratch, transfer, radiance, masks, &mut local) };
            } else {
                self.chunk::<W, I>(verts, shared, scratch, transfer, radiance, masks, &mut local);
            }
            #[cfg(not(target_arch = "x86_64"))]
            self.chunk::<W, I>(verts, shared, scratch, transfer, radiance, masks, &mut local);
            for (c, l) in counters.iter().zip(local) {
                c.fetch_add(l, Ordering::Relaxed);
            }
        });
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[allow(clippy::too_many_arguments)]
    unsafe fn chunk_avx2<const W: usize, I: Iterator<Item = usize>>(
        &self,
        verts: I,
        shared: &FrameShared,
        scratch: &mut Scratch,
        transfer: &mut [f32],
        radiance: &mut [[f32; 3]],
        masks: Option<&mut [u64]>,
        counts: &mut [u64; COUNTERS],
    ) {
        self.chunk::<W, I>(verts, shared, scratch, transfer, radiance, masks, counts)
    }

    /// The vertices `verts`, as many as `radiance` has room for.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn chunk<const W: usize, I: Iterator<Item = usize>>(
        &self,
        verts: I,
        shared: &FrameShared,
        scratch: &mut Scratch,
        transfer: &mut [f32],
        radiance: &mut [[f32; 3]],
        mut masks: Option<&mut [u64]>,
        counts: &mut [u64; COUNTERS],
    ) {
        let n = self.coeffs();
        scratch.tris.reserve(self.own.max_candidates);
        for (k, ((t, r), v)) in transfer.chunks_mut(n).zip(radiance.iter_mut()).zip(verts).enumerate() {
            let mut mask = [0u64; W];
            *r = self.vertex::<W>(v, shared, scratch, t, &mut mask, counts);
            if let Some(m) = masks.as_mut() {
                m[k * W..(k + 1) * W].copy_from_slice(&mask);
            }
        }
    }

    /// One vertex; returns its radiance. `counts`: vertices, without normal,
    /// candidates, group-culled, below, back-facing, edge-on, drawn, then the
    /// four phase times.
    #[inline(always)]
    fn vertex<const W: usize>(
        &self,
        v: usize,
        shared: &FrameShared,
        scratch: &mut Scratch,
        transfer: &mut [f32],
        mask: &mut [u64; W],
        counts: &mut [u64; COUNTERS],
    ) -> [f32; 3] {
        let normal = shared.normals[v];
        if normal == Vec3::ZERO {
            counts[1] += 1;
            transfer.fill(0.0);
            return [0.0; 3];
        }
        counts[0] += 1;
        let clock = |on: bool| if on { Some(Instant::now()) } else { None };
        let t0 = clock(shared.profile);
        let p = shared.positions[v];
        let frame = tangent_frame(normal);
        let origin = p + normal * (ORIGIN_OFFSET * self.scale);
        scratch.tris.clear();
        if self.settings.shadows {
            self.gather(v, shared, normal, frame, origin, scratch, counts);
        }
        if let Some(r) = &shared.others {
            let mut o = OtherStats::default();
            let inv = 1.0 / self.scale;
            r.blockers.gather(
                r,
                origin,
                normal,
                frame,
                inv,
                &mut scratch.local,
                &mut scratch.tris,
                &mut o,
            );
            let c = [o.candidates, o.object_culled, o.group_culled, o.refined, o.refined_fine];
            for (k, n) in c.into_iter().chain([o.below_horizon, o.gathered]).enumerate() {
                counts[12 + k] += n;
            }
        }
        let t1 = clock(shared.profile);
        let nt = scratch.tris.len();
        let (drawn, back, edge) = batch_refs_inline(
            &scratch.tris,
            self.cull_backfaces,
            self.lut.n as u32,
            self.grid.side as u32,
            &mut scratch.refs,
        );
        counts[7] += drawn;
        counts[5] += back;
        counts[6] += edge;
        batch_or(&self.lut, &scratch.refs, nt, mask);
        let t2 = clock(shared.profile);
        if !shared.integrate {
            if let (Some(t0), Some(t1), Some(t2)) = (t0, t1, t2) {
                counts[8] += (t1 - t0).as_nanos() as u64;
                counts[9] += (t2 - t1).as_nanos() as u64;
            }
            return [0.0; 3];
        }
        let reflected = match (self.settings.brdf, shared.eye) {
            (Brdf::Phong { .. }, Some(e)) => {
                let view = (e - p).normalize_or(normal);
                let r = 2.0 * normal.dot(view) * normal - view;
                frame.transpose() * r
            }
            _ => Vec3::Z,
        };
        let out = self.sh_transfer(mask, normal, reflected, shared.lighting, transfer);
        let t3 = clock(shared.profile);
        if let (Some(t0), Some(t1), Some(t2), Some(t3)) = (t0, t1, t2, t3) {
            counts[8] += (t1 - t0).as_nanos() as u64;
            counts[9] += (t2 - t1).as_nanos() as u64;
            counts[10] += (t3 - t2).as_nanos() as u64;
            counts[11] += t3.elapsed().as_nanos() as u64;
        }
        out
    }

    /// One vertex's transfer and radiance from its mask, the CPU twin of
    /// `wgsl/sh_transfer.wgsl`: the mask integrated against the basis and
    /// BRDF in the tangent frame of `normal` (`reflected`: the reflected
    /// view there), rotated to world space into `transfer`, dotted with the
    /// planar RGB `lighting`.
    pub fn sh_transfer(
        &self,
        mask: &[u64],
        normal: Vec3,
        reflected: Vec3,
        lighting: &[f32],
        transfer: &mut [f32],
    ) -> [f32; 3] {
        self.tables.integrate(mask, &self.settings.brdf, reflected, transfer);
        self.rotation.frame_to_world(normal, transfer);
        radiance(lighting, transfer)
    }

    /// Transform phase: the candidate blockers of vertex v into the tangent
    /// frame (scaled to unit mesh size), keeping those with a point above
    /// the horizon, compacted into `scratch.tris` without branches.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn gather(
        &self,
        v: usize,
        shared: &FrameShared,
        normal: Vec3,
        frame: Mat3,
        origin: Vec3,
        scratch: &mut Scratch,
        counts: &mut [u64; COUNTERS],
    ) {
        let h = &self.hierarchy;
        let inv = 1.0 / self.scale;
        let (rt, rb, rn) = (frame.x_axis * inv, frame.y_axis * inv, frame.z_axis * inv);
        let Scratch {
            tris,
            local,
            gathered,
            excluded: excl,
            ..
        } = scratch;
        let mut emitted = 0u64;
        let mut visited = 0u64;
        let mut group_skipped = 0u64;
        if self.pvs.is_none() {
            let excluded = h.excluded.get(v);
            if !excluded.is_empty() && excl.len() < h.far.len().div_ceil(64) {
                excl.resize(h.far.len().div_ceil(64), 0);
            }
            for &e in excluded {
                excl[e as usize / 64] |= 1 << (e % 64);
            }
            let has_excl = !excluded.is_empty();
            for (g, group) in h.groups.iter().enumerate() {
                let (f0, f1) = (group.far.start as usize, group.far.end as usize);
                if let Some(&(c, e)) = shared.boxes.get(g) {
                    // Highest point of the box above the tangent plane.
                    if normal.dot(c - origin) + normal.abs().dot(e) <= 0.0 {
                        let skipped = (f0..f1)
                            .filter(|&t| !has_excl || excl[t / 64] >> (t % 64) & 1 == 0)
                            .count();
                        group_skipped += skipped as u64;
                        continue;
                    }
                }
                let (v0, v1) = (group.verts.start as usize, group.verts.end as usize);
                let [fx, fy, fz] = &shared.far_xyz;
                to_local(&fx[v0..v1], &fy[v0..v1], &fz[v0..v1], origin, rt, rb, rn, local);
                for t in f0..f1 {
                    if has_excl && excl[t / 64] >> (t % 64) & 1 == 1 {
                        continue;
                    }
                    visited += 1;
                    emitted += emit(local, h.far_local[t], tris) as u64;
                }
            }
            for &e in excluded {
                excl[e as usize / 64] = 0;
            }
        }
        // The vertex's own list: its near field, or its whole PVS.
        let own_tris = self.own.tris(v);
        if !own_tris.is_empty() {
            let verts = self.own.verts.get(v);
            for (a, g) in gathered.iter_mut().enumerate() {
                g.clear();
                g.extend(verts.iter().map(|&q| shared.positions[q as usize][a]));
            }
            let [gx, gy, gz] = &*gathered;
            to_local(gx, gy, gz, origin, rt, rb, rn, local);
            for &l in own_tris {
                visited += 1;
                emitted += emit(local, l, tris) as u64;
            }
        }
        counts[2] += visited + group_skipped;
        counts[3] += group_skipped;
        counts[4] += visited - emitted;
    }
}

/// Blocker vertices (SoA) into the tangent frame: rows rt, rb, rn of the
/// world-to-local matrix (already scaled), relative to `origin`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn to_local(
    xs: &[f32],
    ys: &[f32],
    zs: &[f32],
    origin: Vec3,
    rt: Vec3,
    rb: Vec3,
    rn: Vec3,
    local: &mut [Vec<f32>; 3],
) {
    let m = xs.len().min(ys.len()).min(zs.len());
    for a in local.iter_mut() {
        if a.len() < m {
            a.resize(m, 0.0);
        }
    }
    let [lx, ly, lz] = local;
    let (lx, ly, lz) = (&mut lx[..m], &mut ly[..m], &mut lz[..m]);
    for i in 0..m {
        let (dx, dy, dz) = (xs[i] - origin.x, ys[i] - origin.y, zs[i] - origin.z);
        lx[i] = rt.x * dx + rt.y * dy + rt.z * dz;
        ly[i] = rb.x * dx + rb.y * dy + rb.z * dz;
        lz[i] = rn.x * dx + rn.y * dy + rn.z * dz;
    }
}

/// Writes a blocker (local vertex indices `l`) into the batch and keeps it
/// if any vertex is above the horizon. Returns whether it was kept.
#[inline(always)]
pub(super) fn emit(local: &[Vec<f32>; 3], l: [u16; 3], tris: &mut TriangleBatch) -> bool {
    let [lx, ly, lz] = local;
    let p = |k: usize| Vec3::new(lx[l[k] as usize], ly[l[k] as usize], lz[l[k] as usize]);
    let t = [p(0), p(1), p(2)];
    tris.write(t);
    let above = t[0].z > 0.0 || t[1].z > 0.0 || t[2].z > 0.0;
    tris.len += above as usize;
    above
}

/// A frame's counters as its statistics, `setup_ns` added to "other".
fn stats_of(c: [u64; COUNTERS], setup_ns: u64) -> FrameStats {
    FrameStats {
        vertices: c[0],
        without_normal: c[1],
        candidates: c[2],
        group_culled: c[3],
        below_horizon: c[4],
        back_facing: c[5],
        edge_on: c[6],
        drawn: c[7],
        phase_ns: [c[8], c[9], c[10], c[11] + setup_ns],
        others: OtherStats {
            candidates: c[12],
            object_culled: c[13],
            group_culled: c[14],
            refined: c[15],
            refined_fine: c[16],
            below_horizon: c[17],
            gathered: c[18],
        },
    }
}
