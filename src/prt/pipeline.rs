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
use super::hierarchy::{Hierarchy, HierarchySettings, is_closed};
use super::lut::PlaneLut;
use super::mask::MaskGrid;
use super::raster::{Fate, edge_planes, or_coverage};
use super::transfer::{Brdf, CellTables, radiance};
use crate::error::{Error, Result};
use crate::sh::{MAX_BANDS, ShRotation, coefficient_count, tangent_frame};

/// Ray origins and the rasteriser's eye point sit this far above the
/// surface, in bounding-box diagonals (the command-line contract's offset).
pub const ORIGIN_OFFSET: f32 = 1e-4;

/// On, off, or decided from the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Toggle {
    Auto,
    On,
    Off,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PrtSettings {
    /// Mask side S (16, 32 or 64).
    pub mask_side: usize,
    /// LUT cells per cube-face side.
    pub lut_size: usize,
    /// SH bands (5 = 25 coefficients).
    pub bands: usize,
    pub brdf: Brdf,
    pub hierarchy: HierarchySettings,
    /// Skip culling groups whose box is below the tangent plane.
    pub group_culling: bool,
    /// Cull blockers facing away from the vertex (auto: if the mesh is closed).
    pub backface: Toggle,
    /// Shade the side of each vertex that faces the eye (auto: if the mesh
    /// is open, i.e. a two-sided sheet such as cloth).
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
            hierarchy: HierarchySettings::default(),
            group_culling: true,
            backface: Toggle::Auto,
            two_sided: Toggle::Auto,
            shadows: true,
        }
    }
}

impl PrtSettings {
    pub fn validate(&self) -> Result<()> {
        if self.bands == 0 || self.bands > MAX_BANDS {
            return Err(Error::param(
                "--order",
                format!("must be between 1 and {MAX_BANDS} bands, got {}", self.bands),
            ));
        }
        if self.lut_size == 0 {
            return Err(Error::param("--lut", "must be at least 1"));
        }
        if let Brdf::Phong { shininess, specular } = self.brdf {
            if !(shininess.is_finite() && shininess >= 0.0 && shininess <= 1e4) {
                return Err(Error::param("--shininess", format!("must be in [0, 10000], got {shininess}")));
            }
            if !(0.0..=1.0).contains(&specular) {
                return Err(Error::param("--specular", format!("must be in [0, 1], got {specular}")));
            }
        }
        MaskGrid::new(self.mask_side).map(|_| ())
    }
}

/// Counts of one frame (sums over vertices).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameStats {
    /// Vertices whose transfer was computed (with a normal).
    pub vertices: u64,
    /// Vertices without a normal (no triangle of non-zero area uses them).
    pub without_normal: u64,
    /// Blockers considered before any culling (hierarchy or PVS lists).
    pub candidates: u64,
    /// Blockers skipped with their culling group.
    pub group_culled: u64,
    pub below_horizon: u64,
    pub back_facing: u64,
    pub edge_on: u64,
    /// Blockers rasterised.
    pub drawn: u64,
    /// Nanoseconds in transform, rasterisation, integration, other (summed
    /// over threads; only with profiling on).
    pub phase_ns: [u64; 4],
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
    pub stats: FrameStats,
}

/// Everything built once per mesh: tables, LUT, hierarchy, optional PVS.
pub struct Prt {
    pub settings: PrtSettings,
    pub grid: MaskGrid,
    pub lut: PlaneLut,
    pub tables: CellTables,
    pub rotation: ShRotation,
    pub hierarchy: Hierarchy,
    /// Per vertex, blocker ids (`far` index, or `far.len() + fine index`).
    pub pvs: Option<Csr>,
    pub cull_backfaces: bool,
    pub two_sided: bool,
    pub vertex_count: usize,
    /// Bounding-box diagonal of the rest pose (sets the origin offset and
    /// the scale of tangent-frame coordinates).
    pub scale: f32,
    pub lut_ms: f64,
    pub setup_ms: f64,
}

/// Per-thread scratch, reused across vertices and frames.
#[derive(Default)]
struct Scratch {
    tris: Vec<[Vec3; 3]>,
    local: Vec<Vec3>,
    excluded: Vec<u64>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

impl Prt {
    /// Builds the tables and hierarchy for a mesh given its rest pose.
    pub fn new(rest: &[Vec3], triangles: &[[u32; 3]], settings: &PrtSettings) -> Result<Prt> {
        settings.validate()?;
        if triangles.is_empty() {
            return Err(Error::input("mesh", "has no triangles"));
        }
        if let Some(i) = rest.iter().position(|p| !p.is_finite()) {
            return Err(Error::input(format!("vertex {}", i + 1), "has a non-finite coordinate"));
        }
        let start = Instant::now();
        let grid = MaskGrid::new(settings.mask_side)?;
        let t = Instant::now();
        let lut = PlaneLut::build(&grid, settings.lut_size)?;
        let lut_ms = t.elapsed().as_secs_f64() * 1e3;
        let tables = CellTables::new(&grid, settings.bands);
        let rotation = ShRotation::new(settings.bands);
        let hierarchy = Hierarchy::build(rest, triangles, &settings.hierarchy)?;
        let closed = is_closed(triangles);
        let cull_backfaces = match settings.backface {
            Toggle::Auto => closed,
            t => t == Toggle::On,
        };
        let two_sided = match settings.two_sided {
            Toggle::Auto => !closed,
            t => t == Toggle::On,
        };
        let bounds = crate::aabb::Aabb::from_points(rest.iter());
        let scale = bounds.diagonal().max(f32::MIN_POSITIVE);
        Ok(Prt {
            settings: settings.clone(),
            grid,
            lut,
            tables,
            rotation,
            hierarchy,
            pvs: None,
            cull_backfaces,
            two_sided,
            vertex_count: rest.len(),
            scale,
            lut_ms,
            setup_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

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
    /// returned too.
    pub fn frame(&self, positions: &[Vec3], eye: Option<Vec3>, lighting: &[f32], profile: bool, keep_masks: bool, out: &mut FrameOutput) -> Result<()> {
        if positions.len() != self.vertex_count {
            return Err(Error::input(
                "frame",
                format!("{} positions for a mesh of {} vertices", positions.len(), self.vertex_count),
            ));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::input(format!("vertex {}", i + 1), "has a non-finite coordinate"));
        }
        if lighting.len() != 3 * self.coeffs() {
            return Err(Error::input("lighting", format!("needs {} values", 3 * self.coeffs())));
        }
        match self.grid.words {
            4 => self.frame_impl::<4>(positions, eye, lighting, profile, keep_masks, out),
            16 => self.frame_impl::<16>(positions, eye, lighting, profile, keep_masks, out),
            64 => self.frame_impl::<64>(positions, eye, lighting, profile, keep_masks, out),
            w => return Err(Error::internal(format!("no rasteriser for {w} mask words"))),
        }
        Ok(())
    }

    fn frame_impl<const W: usize>(&self, positions: &[Vec3], eye: Option<Vec3>, lighting: &[f32], profile: bool, keep_masks: bool, out: &mut FrameOutput) {
        let other_start = Instant::now();
        let n = self.coeffs();
        let nv = positions.len();
        out.transfer.resize(nv * n, 0.0);
        out.radiance.resize(nv, [0.0; 3]);
        out.masks.resize(if keep_masks { nv * W } else { 0 }, 0);
        self.shading_normals(positions, eye, &mut out.normals);
        let mut boxes = Vec::new();
        if self.settings.group_culling && self.pvs.is_none() {
            self.hierarchy.group_boxes(positions, &mut boxes);
        }
        let counters: [AtomicU64; 12] = Default::default();
        let setup_ns = other_start.elapsed().as_nanos() as u64;

        const CHUNK: usize = 16;
        let normals = &out.normals;
        let masks_out: Vec<&mut [u64]> = if keep_masks {
            out.masks.chunks_mut(CHUNK * W).collect()
        } else {
            Vec::new()
        };
        let mut masks_iter: Vec<Option<&mut [u64]>> = masks_out.into_iter().map(Some).collect();
        masks_iter.resize_with(nv.div_ceil(CHUNK), || None);
        out.transfer
            .par_chunks_mut(CHUNK * n)
            .zip(out.radiance.par_chunks_mut(CHUNK))
            .zip(masks_iter.into_par_iter())
            .enumerate()
            .for_each(|(chunk, ((transfer, radiance), mut masks))| {
                SCRATCH.with(|s| {
                    let scratch = &mut *s.borrow_mut();
                    let mut local = [0u64; 12];
                    for (k, (t, r)) in transfer.chunks_mut(n).zip(radiance.iter_mut()).enumerate() {
                        let v = chunk * CHUNK + k;
                        let mut mask = [0u64; W];
                        *r = self.vertex::<W>(v, positions, normals[v], eye, &boxes, lighting, scratch, t, &mut mask, profile, &mut local);
                        if let Some(m) = masks.as_mut() {
                            m[k * W..(k + 1) * W].copy_from_slice(&mask);
                        }
                    }
                    for (c, l) in counters.iter().zip(local) {
                        c.fetch_add(l, Ordering::Relaxed);
                    }
                });
            });
        let c = counters.map(|c| c.into_inner());
        out.stats = FrameStats {
            vertices: c[0],
            without_normal: c[1],
            candidates: c[2],
            group_culled: c[3],
            below_horizon: c[4],
            back_facing: c[5],
            edge_on: c[6],
            drawn: c[7],
            phase_ns: [c[8], c[9], c[10], c[11] + setup_ns],
        };
    }

    /// One vertex; returns its radiance. `counts`: vertices, without normal,
    /// candidates, group-culled, below, back-facing, edge-on, drawn, then the
    /// four phase times.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn vertex<const W: usize>(
        &self,
        v: usize,
        positions: &[Vec3],
        normal: Vec3,
        eye: Option<Vec3>,
        boxes: &[(Vec3, Vec3)],
        lighting: &[f32],
        scratch: &mut Scratch,
        transfer: &mut [f32],
        mask: &mut [u64; W],
        profile: bool,
        counts: &mut [u64; 12],
    ) -> [f32; 3] {
        if normal == Vec3::ZERO {
            counts[1] += 1;
            transfer.fill(0.0);
            return [0.0; 3];
        }
        counts[0] += 1;
        let clock = |on: bool| if on { Some(Instant::now()) } else { None };
        let t0 = clock(profile);
        let p = positions[v];
        let frame = tangent_frame(normal);
        let origin = p + normal * (ORIGIN_OFFSET * self.scale);
        let inv = 1.0 / self.scale;
        // Rows of the world-to-local matrix, scaled to unit mesh size.
        let rows = Mat3::from_cols(frame.x_axis * inv, frame.y_axis * inv, frame.z_axis * inv).transpose();
        let to_local = |q: Vec3| rows * (q - origin);
        scratch.tris.clear();
        if self.settings.shadows {
            self.gather::<W>(v, positions, normal, origin, boxes, &to_local, scratch, counts);
        }
        let t1 = clock(profile);
        for t in &scratch.tris {
            match edge_planes(t, self.cull_backfaces) {
                Ok(planes) => {
                    or_coverage(&self.lut, &planes, mask);
                    counts[7] += 1;
                }
                Err(Fate::BackFacing) => counts[5] += 1,
                Err(_) => counts[6] += 1,
            }
        }
        let t2 = clock(profile);
        let reflected = match (self.settings.brdf, eye) {
            (Brdf::Phong { .. }, Some(e)) => {
                let view = (e - p).normalize_or(normal);
                let r = 2.0 * normal.dot(view) * normal - view;
                frame.transpose() * r
            }
            _ => Vec3::Z,
        };
        self.tables.integrate(mask, &self.settings.brdf, reflected, transfer);
        self.rotation.frame_to_world(normal, transfer);
        let t3 = clock(profile);
        let out = radiance(lighting, transfer);
        if let (Some(t0), Some(t1), Some(t2), Some(t3)) = (t0, t1, t2, t3) {
            counts[8] += (t1 - t0).as_nanos() as u64;
            counts[9] += (t2 - t1).as_nanos() as u64;
            counts[10] += (t3 - t2).as_nanos() as u64;
            counts[11] += t3.elapsed().as_nanos() as u64;
        }
        out
    }

    /// Transform phase: candidate blockers of vertex v into the tangent
    /// frame, keeping those with a point above the horizon.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn gather<const W: usize>(
        &self,
        v: usize,
        positions: &[Vec3],
        normal: Vec3,
        origin: Vec3,
        boxes: &[(Vec3, Vec3)],
        to_local: &impl Fn(Vec3) -> Vec3,
        scratch: &mut Scratch,
        counts: &mut [u64; 12],
    ) {
        let h = &self.hierarchy;
        let fine_tri = |f: u32| {
            let t = h.fine[f as usize];
            [to_local(positions[t[0] as usize]), to_local(positions[t[1] as usize]), to_local(positions[t[2] as usize])]
        };
        let keep = |t: [Vec3; 3], scratch: &mut Scratch, counts: &mut [u64; 12]| {
            if t[0].z > 0.0 || t[1].z > 0.0 || t[2].z > 0.0 {
                scratch.tris.push(t);
            } else {
                counts[4] += 1;
            }
        };
        if let Some(pvs) = &self.pvs {
            let far = h.far.len() as u32;
            let list = pvs.get(v);
            counts[2] += list.len() as u64;
            for &id in list {
                let t = if id < far {
                    let t = h.far[id as usize];
                    [to_local(positions[t[0] as usize]), to_local(positions[t[1] as usize]), to_local(positions[t[2] as usize])]
                } else {
                    fine_tri(id - far)
                };
                keep(t, scratch, counts);
            }
            return;
        }
        let excluded = h.excluded.get(v);
        let near = h.near.get(v);
        counts[2] += (h.far.len() - excluded.len() + near.len()) as u64;
        if !excluded.is_empty() {
            scratch.excluded.resize(h.far.len().div_ceil(64), 0);
            for &e in excluded {
                scratch.excluded[e as usize / 64] |= 1 << (e % 64);
            }
        }
        for (g, group) in h.groups.iter().enumerate() {
            if let Some(&(c, e)) = boxes.get(g) {
                // Highest point of the box above the tangent plane.
                if normal.dot(c - origin) + normal.abs().dot(e) <= 0.0 {
                    let skipped = (group.far.start..group.far.end)
                        .filter(|&t| excluded.is_empty() || scratch.excluded[t as usize / 64] >> (t % 64) & 1 == 0)
                        .count();
                    counts[3] += skipped as u64;
                    continue;
                }
            }
            let verts = &h.group_verts[group.verts.start as usize..group.verts.end as usize];
            scratch.local.clear();
            scratch.local.extend(verts.iter().map(|&q| to_local(positions[q as usize])));
            for t in group.far.start..group.far.end {
                if !excluded.is_empty() && scratch.excluded[t as usize / 64] >> (t % 64) & 1 == 1 {
                    continue;
                }
                let l = h.far_local[t as usize];
                let tri = [scratch.local[l[0] as usize], scratch.local[l[1] as usize], scratch.local[l[2] as usize]];
                keep(tri, scratch, counts);
            }
        }
        for &e in excluded {
            scratch.excluded[e as usize / 64] = 0;
        }
        for &f in near {
            keep(fine_tri(f), scratch, counts);
        }
    }
}

/// The contract's vertex normals (area-weighted face normals, normalised;
/// zero where no triangle of non-zero area is incident), into `out`.
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]], out: &mut Vec<Vec3>) {
    out.clear();
    out.resize(positions.len(), Vec3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            out[i as usize] += n;
        }
    }
    for n in out.iter_mut() {
        *n = n.normalize_or_zero();
    }
}
