//! Adaptive anti-aliasing driven by geometric complexity (section 4.2 of the
//! MLRTA paper: "the size of the sub-tree underneath any given node ...
//! serves as an indication of the geometrical complexity"; "when an EP is a
//! 2D leaf completely covered by triangles, we could cast rays sparingly and
//! reserve more of the ray budget for more complicated regions").
//!
//! The units are the final tiles of the one-ray pass, and the 4x4 blocks of
//! its diverging tiles (which have no entry point of their own). A unit is
//! judged by the entry point of its *footprint*: the group of all rays
//! through its pixels' area, where the extra samples fall (a pinhole
//! camera's directions are extreme at the rectangle's corners, so its four
//! corner rays bound the group). If the footprint hits nothing, or its
//! search stopped at a leaf of coplanar triangles because every ray ends on
//! one of them or on a covered plane, one ray per pixel renders it (a
//! change of triangle within one plane changes no shading); every other unit gets
//! `samples` rays per pixel on a stratified grid, traced with MLRTA again.
//! The reference below measures what this misses.
//!
//! Edge quality is measured against a reference of 16 rays per pixel (4x4
//! grid) everywhere: *edge pixels* are those whose 16 reference samples do
//! not all hit the same triangle (or all miss); the error is the RMSE of the
//! shaded value (|cos| between ray and triangle, 0 for background) over the
//! edge pixels.

use std::time::Instant;

use serde_json::{Value, json};

use crate::error::{Error, Result};
use crate::geom::color::rms_difference as rmse;
use crate::gpu::device::elapsed_ms;
use rayon::prelude::*;

use crate::geom::ray::{Hit, Ray};
use crate::mlrta::entry_point::entry_point;
use crate::mlrta::frustum::Frustum;
use crate::mlrta::tiles::{Rect, TileReport, block_rects, trace_image, trace_rects};
use crate::mlrta::{MlrtaSettings, Prepared};
use crate::scene::Camera;

/// Where anti-aliasing spends extra rays (`AaRequest::mode`; see the module
/// documentation for how adaptive mode picks its pixels).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum AaMode {
    /// One ray per pixel.
    None,
    /// Extra rays only in tiles with complex geometry.
    Adaptive,
    /// Extra rays everywhere (for comparison).
    Uniform,
}

/// Rays per anti-aliased pixel must be a square grid of 4 to 64.
pub fn validate_samples(n: u32) -> Result<()> {
    let k = (n as f64).sqrt() as u32;
    if k * k != n || !(4..=64).contains(&n) {
        return Err(Error::param(
            "aa_samples",
            format!("must be a square from 4 to 64, got {n}"),
        ));
    }
    Ok(())
}

/// The rectangles that get extra rays: final tiles of the one-ray pass and
/// 4x4 blocks of its diverging tiles whose footprint may contain an edge
/// (see the module documentation), and how many footprints were searched.
pub fn complex_units(
    p: &Prepared,
    camera: &Camera,
    width: u32,
    height: u32,
    tiles: &[TileReport],
) -> (Vec<Rect>, usize) {
    let origin_inside = p.inside_object(camera.eye);
    let units: Vec<Rect> = tiles
        .iter()
        .flat_map(|t| {
            let blocks: Vec<Rect> = if t.diverging {
                block_rects(t.rect).collect()
            } else {
                vec![t.rect]
            };
            blocks
        })
        .collect();
    let searched = units.len();
    let complex = units
        .into_par_iter()
        .filter(|&r| !footprint_is_simple(p, camera, width, height, r, origin_inside))
        .collect();
    (complex, searched)
}

fn footprint_is_simple(
    p: &Prepared,
    camera: &Camera,
    width: u32,
    height: u32,
    r: Rect,
    origin_inside: Option<u32>,
) -> bool {
    let (x0, y0, x1, y1) = (r.x as f32, r.y as f32, (r.x + r.w) as f32, (r.y + r.h) as f32);
    let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(x, y)| camera.direction(width, height, x, y));
    let Some(footprint) = Frustum::from_corners(camera.eye, corners, f32::INFINITY) else {
        return false;
    };
    let mut steps = 0;
    // The exhaustive search (budget 0): a budget would stop some searches
    // above a planar leaf, and more footprints would count as complex.
    match entry_point(p, &footprint, (0, p.tree.bounds), origin_inside, 0, &mut steps) {
        None => true,
        Some(e) => e.covered && is_planar_leaf(p, e.node),
    }
}

/// A leaf whose triangles all lie in one plane: once every ray of a group
/// ends on it (a covering triangle or covered plane), nothing in the leaf
/// can stand in front of another and make an edge.
fn is_planar_leaf(p: &Prepared, node: u32) -> bool {
    let node = p.tree.nodes[node as usize];
    if !node.is_leaf() {
        return false;
    }
    let triangles = &p.tree.leaf_vertices[node.leaf_range()];
    let Some(&[a, b, c]) = triangles.first() else {
        return false;
    };
    let n = (b - a).cross(c - a).normalize_or_zero();
    let scale = triangles
        .iter()
        .flatten()
        .map(|v| v.abs().max_element())
        .fold(1.0f32, f32::max);
    n != glam::Vec3::ZERO
        && triangles
            .iter()
            .flatten()
            .all(|&v| (v - a).dot(n).abs() <= 1e-5 * scale)
}

/// An anti-aliased image.
pub struct AaResult {
    /// Where the extra rays went.
    pub mode: AaMode,
    /// Rays per pixel of the stratified grid, in the pixels that get one
    /// (every pixel with `Uniform`, the complex units' with `Adaptive`, none
    /// with `None`).
    pub samples: u32,
    /// Shaded value per pixel, row-major: |cos| between ray and triangle
    /// times stripes across the scene, 0 for background; the mean over the
    /// pixel's grid where it has one.
    pub image: Vec<f32>,
    /// Rays per pixel, row-major: 1 for the one-ray pass, plus `samples`
    /// where the grid was traced (`samples` alone with `Uniform`).
    pub spp: Vec<u32>,
    /// Every ray traced: the one-ray pass (adaptive), the footprint
    /// searches (one per tile or block, counted as a ray each) and the
    /// extra samples.
    pub rays: u64,
    /// Tiles and blocks whose footprint was searched for an edge.
    pub footprint_searches: u64,
    /// Final tiles and diverging tiles' blocks that got extra rays.
    pub complex_units: usize,
    /// Final tiles of the one-ray pass.
    pub tiles: usize,
    /// Wall-clock milliseconds of `render`: its own one-ray pass (`None`,
    /// `Adaptive`), the footprint searches and the extra samples.
    pub ms: f64,
}

/// The 16-ray reference: shaded values and edge pixels.
pub struct Reference {
    /// Per pixel, row-major, the mean shaded value of its 16 samples.
    pub image: Vec<f32>,
    /// Per pixel, whether its 16 samples do not all hit the same triangle
    /// (or all miss): the pixels the edge error is measured on.
    pub edges: Vec<bool>,
    /// The same scene with uniform supersampling at the samples asked for.
    pub uniform: Option<AaResult>,
}

/// The shaded value of a pixel sample: |cos| between the ray and the hit
/// triangle, times stripes across the scene. The stripes vary within a
/// plane, so an edge between coplanar triangles costs nothing while a
/// missed silhouette or a change of plane shows in the edge error (with
/// |cos| alone a skipped pixel inside a plane could never be wrong).
fn shade(p: &Prepared, r: &Ray, h: &Hit) -> f32 {
    if !h.is_hit() {
        return 0.0;
    }
    let [a, b, c] = p.tree.triangles[h.triangle as usize];
    let cos = (b - a).cross(c - a).normalize_or_zero().dot(r.d().normalize()).abs();
    let bounds = p.tree.bounds;
    let period = (bounds.max - bounds.min).length() / STRIPES;
    let x = (r.o() + r.d() * h.t - bounds.min).dot(glam::Vec3::ONE) / period;
    cos * (0.8 + 0.2 * (std::f32::consts::TAU * x).sin())
}

/// Stripes across the bounding box's diagonal in the shading of `shade`.
const STRIPES: f32 = 24.0;

fn offsets(samples: u32) -> Vec<(f32, f32)> {
    let k = (samples as f64).sqrt() as u32;
    (0..k * k)
        .map(|s| ((s % k) as f32 + 0.5, (s / k) as f32 + 0.5))
        .map(|(x, y)| (x / k as f32, y / k as f32))
        .collect()
}

/// Renders the image with `mode`, reusing the one-ray pass's tiles.
#[allow(clippy::too_many_arguments)]
pub fn render(
    p: &Prepared,
    camera: &Camera,
    width: u32,
    height: u32,
    params: &MlrtaSettings,
    mode: AaMode,
    samples: u32,
    tiles: &[TileReport],
) -> Result<AaResult> {
    validate_samples(samples)?;
    let start = Instant::now();
    let n = width as usize * height as usize;
    // Uniform supersampling needs no centre ray; adaptive needs the
    // one-ray pass that found the tiles (traced by the caller), then one
    // footprint search per tile or block, then `samples` rays in each
    // complex pixel. Every one of them is counted.
    let mut image = vec![0.0f32; n];
    let mut spp = vec![0u32; n];
    let (complex, searched) = match mode {
        AaMode::None | AaMode::Adaptive => {
            let centre = camera.primary_rays(width, height);
            let base = trace_image(p, &centre, width, height, params, None)?;
            for (i, (r, h)) in centre.iter().zip(&base.hits).enumerate() {
                image[i] = shade(p, r, h);
                spp[i] = 1;
            }
            if mode == AaMode::Adaptive {
                complex_units(p, camera, width, height, tiles)
            } else {
                (Vec::new(), 0)
            }
        }
        AaMode::Uniform => (
            vec![Rect {
                x: 0,
                y: 0,
                w: width,
                h: height,
            }],
            0,
        ),
    };
    let mut rays = spp.iter().map(|&s| s as u64).sum::<u64>() + searched as u64;
    if !complex.is_empty() {
        let mut mask = vec![false; n];
        for r in &complex {
            for y in r.y..r.y + r.h {
                for x in r.x..r.x + r.w {
                    mask[(y * width + x) as usize] = true;
                }
            }
        }
        let mut sum = vec![0.0f32; n];
        for (ox, oy) in offsets(samples) {
            let sample_rays = camera.primary_rays_at(width, height, ox, oy);
            let traced = trace_rects(p, &sample_rays, width, height, params, &complex)?;
            for i in (0..n).filter(|&i| mask[i]) {
                sum[i] += shade(p, &sample_rays[i], &traced.hits[i]);
            }
        }
        for i in (0..n).filter(|&i| mask[i]) {
            image[i] = sum[i] / samples as f32;
            spp[i] += samples;
            rays += samples as u64;
        }
    }
    Ok(AaResult {
        mode,
        samples,
        image,
        spp,
        rays,
        footprint_searches: searched as u64,
        complex_units: if mode == AaMode::Adaptive { complex.len() } else { 0 },
        tiles: tiles.len(),
        ms: elapsed_ms(start),
    })
}

/// The 16-ray reference (4x4 grid in every pixel).
pub fn reference(p: &Prepared, camera: &Camera, width: u32, height: u32) -> Reference {
    let n = width as usize * height as usize;
    let params = MlrtaSettings::default();
    let mut sum = vec![0.0f32; n];
    let mut first = vec![u32::MAX - 1; n];
    let mut edges = vec![false; n];
    for (k, (ox, oy)) in offsets(16).into_iter().enumerate() {
        let rays = camera.primary_rays_at(width, height, ox, oy);
        let traced = trace_image(p, &rays, width, height, &params, None).expect("valid image");
        for i in 0..n {
            let h = &traced.hits[i];
            sum[i] += shade(p, &rays[i], h);
            if k == 0 {
                first[i] = h.triangle;
            } else if h.triangle != first[i] {
                edges[i] = true;
            }
        }
    }
    Reference {
        image: sum.iter().map(|s| s / 16.0).collect(),
        edges,
        uniform: None,
    }
}

impl AaResult {
    /// The JSON report; with a reference, the errors on edge pixels.
    pub fn report(&self, reference: Option<Reference>) -> Value {
        let pixels = self.spp.len() as u64;
        let uniform_rays = pixels * self.samples as u64;
        let mut v = json!({
            "mode": self.mode,
            "samples": self.samples,
            "rays": self.rays,
            "footprint_searches": self.footprint_searches,
            "rays_uniform": uniform_rays,
            "saved_vs_uniform": 1.0 - self.rays as f64 / uniform_rays as f64,
            "tiles": self.tiles,
            "complex_units": self.complex_units,
            "aa_ms": self.ms,
        });
        if let Some(r) = reference {
            let edge_pixels = r.edges.iter().filter(|&&e| e).count();
            v["reference"] = json!({
                "samples": 16,
                "edge_pixels": edge_pixels,
                "rmse_edges": rmse(&self.image, &r.image, Some(&r.edges)),
                "rmse_all": rmse(&self.image, &r.image, None),
            });
            if let Some(u) = r.uniform {
                v["reference"]["uniform_rmse_edges"] = json!(rmse(&u.image, &r.image, Some(&r.edges)));
            }
        }
        v
    }
}
