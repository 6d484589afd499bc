//! The builder: Algorithm 1 of the paper. From each positional sample on the
//! object's bounding sphere, a hemisphere of rays towards the centre; each
//! map texel stores the hit distance over 2R, or 1 (i.e. 2R) for a miss.
//! Rays are traced with the foundation's kd-tree, maps in parallel on all
//! cores of the current rayon pool.

use std::path::Path;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use super::directions::DirectionMapping;
use super::storage::{FieldData, FieldSampling};
use crate::accel::kdtree::{KdTree, KdTreeSettings};
use crate::error::{Error, Result};
use crate::geom::aabb::Aabb;
use crate::geom::sampling::Frame;
use crate::gpu::device::elapsed_ms;
use crate::progress::Bar;
use crate::raycast::holes::closest_past_holes;
use crate::scene::Mesh;
use crate::scene::cutouts::Cutouts;

/// A built displacement field: the object's bounding sphere (object space),
/// the sampling and storage, and the maps.
#[derive(Debug, Clone, PartialEq)]
pub struct DisplacementField {
    /// How the maps were sampled and how they are stored.
    pub params: FieldSampling,
    /// Centre of the bounding sphere the maps live on, object space
    /// (`bounding_sphere`).
    pub center: Vec3,
    /// Radius R of that sphere, object units: stored distances are in units of
    /// 2R.
    pub radius: f32,
    /// The object's bounding box (informative; checked against meshes).
    pub bounds: Aabb,
    /// Triangles of the object it was built from.
    pub triangles: u32,
    /// The maps: per positional sample, per direction, the normalised distance
    /// D = hit distance / 2R to the object (1: no hit).
    pub data: FieldData,
}

/// A field's header: sampling, storage, sphere, the object it came from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FieldSummary {
    /// Maps: one per positional sample, `grid_side` squared.
    pub maps: usize,
    /// Side N of the octahedral grid of positional samples.
    pub grid_side: u32,
    /// Side S of each map: S x S directions.
    pub res: u32,
    /// Bits per direction: 32, 8 or 1.
    pub bits: u32,
    /// How a map's texels cover the hemisphere of inward directions.
    pub directions: DirectionMapping,
    /// Bytes of map data (1-bit maps: the bits and the per-map mean distances).
    pub map_bytes: usize,
    /// The bounding sphere, object space.
    pub sphere: SphereSummary,
    /// The object's bounding box, object space.
    pub bounds: BoundsSummary,
    /// Triangles of the object the field was built from.
    pub triangles: u32,
}

/// A field's bounding sphere, as reports show it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SphereSummary {
    /// Centre, object space.
    pub center: [f32; 3],
    /// Radius, object units.
    pub radius: f32,
}

/// An object's bounding box, as reports show it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BoundsSummary {
    /// Smallest corner, object space.
    pub min: [f32; 3],
    /// Largest corner, object space.
    pub max: [f32; 3],
}

/// What building a field cost (`DisplacementField::build`).
#[derive(Debug, Clone, Serialize)]
pub struct BuildStats {
    /// Maps built, one per positional sample.
    pub maps: usize,
    /// Rays traced: maps x directions per map.
    pub rays: u64,
    /// Fraction of the rays that hit the object.
    pub hit_fraction: f64,
    /// Wall-clock milliseconds building the kd-tree over the object's
    /// triangles.
    pub kdtree_ms: f64,
    /// Wall-clock milliseconds of the whole build, kd-tree included.
    pub build_ms: f64,
}

/// The bounding sphere the maps live on: centred on the bounding box, the
/// radius reaching the farthest vertex, widened by 1e-4 so that no vertex
/// lies on the sphere itself.
pub fn bounding_sphere(mesh: &Mesh) -> (Vec3, f32) {
    let center = mesh.bounds().center();
    let far = mesh
        .triangles
        .iter()
        .flatten()
        .map(|&v| (mesh.positions[v as usize] - center).length())
        .fold(0.0f32, f32::max);
    (center, far.max(f32::MIN_POSITIVE) * (1.0 + 1e-4))
}

/// Map m's frame: +z the inward normal -p_m.
pub fn map_frame(params: &FieldSampling, m: u32) -> Frame {
    Frame::from_normal(-params.grid.position(m))
}

/// Local direction of texel (a, b): the texel centre's direction.
pub fn texel_direction(params: &FieldSampling, a: u32, b: u32) -> Vec3 {
    let res = params.res as f32;
    params
        .directions
        .direction((a as f32 + 0.5) / res, (b as f32 + 0.5) / res)
        .0
}

impl DisplacementField {
    /// Builds the field of `mesh` (its triangles occlude; an empty or
    /// degenerate mesh is an error naming `what`).
    pub fn build(
        mesh: &Mesh,
        params: &FieldSampling,
        what: &str,
        progress: &Bar,
    ) -> Result<(DisplacementField, BuildStats)> {
        DisplacementField::build_through(mesh, None, params, what, progress)
    }

    /// `build` with the holes of `cutouts` (of `mesh`) let through: a map
    /// texel stores the first hit that is not in a hole
    /// (`raycast::holes::closest_past_holes`).
    pub fn build_through(
        mesh: &Mesh,
        cutouts: Option<&Cutouts>,
        params: &FieldSampling,
        what: &str,
        progress: &Bar,
    ) -> Result<(DisplacementField, BuildStats)> {
        params.validate()?;
        if mesh.triangles.is_empty() {
            return Err(Error::input(what, "has no triangles: nothing to build a field of"));
        }
        let start = Instant::now();
        let tree = KdTree::build(mesh, &KdTreeSettings::for_cpu())?;
        let kdtree_ms = elapsed_ms(start);
        let (center, radius) = bounding_sphere(mesh);
        let texels = params.texels_per_map();
        // The local texel directions are the same for every map.
        let local: Vec<Vec3> = (0..params.res)
            .flat_map(|b| (0..params.res).map(move |a| (a, b)))
            .map(|(a, b)| texel_direction(params, a, b))
            .collect();
        let mut distances = vec![1.0f32; params.maps() * texels];
        let hits: u64 = distances
            .par_chunks_mut(texels)
            .enumerate()
            .map(|(m, map)| {
                let frame = map_frame(params, m as u32);
                let origin = center + radius * params.grid.position(m as u32);
                let mut hits = 0u64;
                for (d, &l) in map.iter_mut().zip(&local) {
                    let dir = frame.to_world(l);
                    let hit = match cutouts {
                        None => tree.closest_hit(origin, dir, f32::INFINITY),
                        Some(c) => closest_past_holes(c, &tree.triangles, origin, dir, f32::INFINITY, |o, d, t| {
                            tree.closest_hit(o, d, t)
                        }),
                    };
                    if hit.is_hit() {
                        *d = (hit.t / (2.0 * radius)).min(1.0);
                        hits += 1;
                    }
                }
                progress.inc(1);
                hits
            })
            .sum();
        let rays = (params.maps() * texels) as u64;
        let field = DisplacementField {
            params: *params,
            center,
            radius,
            bounds: mesh.bounds(),
            triangles: mesh.triangles.len() as u32,
            data: FieldData::from_distances(params, &distances),
        };
        let stats = BuildStats {
            maps: params.maps(),
            rays,
            hit_fraction: hits as f64 / rays as f64,
            kdtree_ms,
            build_ms: elapsed_ms(start),
        };
        Ok((field, stats))
    }

    /// The field's header, as reports show it.
    pub fn summary(&self) -> FieldSummary {
        let p = &self.params;
        FieldSummary {
            maps: p.maps(),
            grid_side: p.grid.side,
            res: p.res,
            bits: p.storage.bits(),
            directions: p.directions,
            map_bytes: self.data.bytes(),
            sphere: SphereSummary {
                center: self.center.to_array(),
                radius: self.radius,
            },
            bounds: BoundsSummary {
                min: self.bounds.min.to_array(),
                max: self.bounds.max.to_array(),
            },
            triangles: self.triangles,
        }
    }

    /// Checks that the field was built from `mesh` (same triangle count and
    /// bounds); `field_path` and `mesh_path` name them in the error.
    pub fn check_built_from(&self, mesh: &Mesh, field_path: &Path, mesh_path: &Path) -> Result<()> {
        let bounds = mesh.bounds();
        let tol = 1e-4 * bounds.diagonal().max(f32::MIN_POSITIVE);
        let same_bounds = (self.bounds.min - bounds.min).abs().max_element() <= tol
            && (self.bounds.max - bounds.max).abs().max_element() <= tol;
        if self.triangles as usize != mesh.triangles.len() || !same_bounds {
            return Err(Error::file(
                field_path,
                "triangles/bounds",
                format!(
                    "the field was built from a mesh of {} triangles in [{}, {}], but {} has {} triangles in [{}, {}]",
                    self.triangles,
                    self.bounds.min,
                    self.bounds.max,
                    mesh_path.display(),
                    mesh.triangles.len(),
                    bounds.min,
                    bounds.max
                ),
            ));
        }
        Ok(())
    }

    /// Normalised distance of texel (a, b) of map m.
    #[inline]
    pub fn texel(&self, m: u32, a: u32, b: u32) -> f32 {
        let i = (b * self.params.res + a) as usize;
        self.data.value(&self.params, m as usize, i)
    }
}
