//! A frame of bounded-error ray tracing (the paper's Figure 1 and section
//! 8.3), over a `WhittedRenderer`:
//!
//! 1. **Fast path** (section 6.1): the accepted cells the previous frame
//!    used are reprojected to the new eye. A cell whose whole shaft from the
//!    eye to its hits is clear (one shaft cull per cell) claims the pixels
//!    whose eye lines fall inside it; a pixel two cells claim is left to the
//!    next path. Claimed pixels are interpolated without tracing anything.
//! 2. **Pixel assignment** for the rest: the primary ray through the
//!    kd-tree (exact: which surface a pixel sees never comes from an
//!    interpolant), then the leaf of that object's linetree for the ray's
//!    line. An accepted leaf whose rays hit the same face interpolates the
//!    pixel; an unbuilt leaf is built (its missing extremal rays traced,
//!    the predicate run) and, if rejected and covering enough pixels
//!    (section 7's cost model), split and its pixels walked down again.
//! 3. **Slow path**: what is left is traced by the Whitted tracer.
//!
//! Builds run in rounds over all the cells the frame asks for, so the
//! extremal rays and the predicates of a round run in parallel.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::bounded::affine::{AVec3, Aff};
use crate::bounded::frame::{BoundedFrame, FrameStats, PixelPath, TraceReason, count_paths};
use crate::bounded::geometry::SceneGeometry;
use crate::bounded::gpu::InterpolatePass;
use crate::bounded::interpolate::{PixelJob, interpolate_pixels};
use crate::bounded::linespace::{FacePair, LineCoords, pair_index};
use crate::bounded::linetree::{CellState, HashSet, Interpolant, Linetrees, Sample, corner_ray};
use crate::bounded::predicate::{BoundKind, Corners, Predicate, RootFace};
use crate::bounded::samples::{first_surface, textured_split, trace_sample, tree_ray, twin_sample};
use crate::bounded::screen::{CONFLICT, pixels_in_cell, span_fill};
use crate::bounded::settings::{BoundedSettings, SlowPath, SplitKind};
use crate::bounded::shaft::{End, Exclude, Shafts};
use crate::error::{Error, Result};
use crate::geom::offset::max_abs;
use crate::gpu::GpuContext;
use crate::gpu::batch::Batched;
use crate::gpu::device::{Device, elapsed_ms};
use crate::progress::Bar;
use crate::scene::Camera;
use crate::whitted::WhittedRenderer;
use crate::whitted::pixel_rays::PixelRays;
use crate::whitted::tree_records::TreeRay;
use crate::whitted::whitted::{FirstHit, Media, WhittedUniforms};

/// A pixel's interpolation: its cell and coordinates in it.
#[derive(Debug, Clone, Copy)]
struct Assigned {
    cell: u32,
    local: [f32; 4],
    /// The pixel's primary hit, where it was traced (not reprojected).
    hit: Option<(f32, u32)>,
}

/// The bounded-error renderer of one scene, kept across frames.
pub struct BoundedRenderer {
    /// The Whitted renderer whose radiance is interpolated: its scene,
    /// kd-tree and device; it traces the slow path and the extremal rays.
    pub whitted: WhittedRenderer,
    geometry: SceneGeometry,
    /// Every linetree built so far, kept from frame to frame.
    pub trees: Linetrees,
    /// The knobs, as validated by `new`; `patches` is read only there.
    pub settings: BoundedSettings,
    frame: u32,
    /// The accepted cells the last frame used (what reprojection tries).
    last_used: Vec<u32>,
    /// The interpolation pass where the Whitted renderer is on a GPU.
    gpu: Option<(GpuContext, Batched<InterpolatePass>)>,
    /// Per-pixel lists kept from frame to frame (see `Scratch`).
    scratch: Scratch,
}

/// Lists of a frame's pixels kept for the next frame: allocated afresh,
/// those of more than 32 MB (1280x960 and up) were mapped, faulted in page
/// by page and unmapped every frame (glibc maps such blocks itself).
#[derive(Default)]
struct Scratch {
    /// What assignment found for each pixel left to it.
    found: Vec<Found>,
    /// A round's pixels in cell order (`sort_by_cell`).
    order: Vec<u32>,
}

/// A pixel's primary hit (distance, primitive) where it has one.
type PrimaryHit = Option<(f32, u32)>;

/// A pixel to trace and its primary hit where known.
type PixelToTrace = (u32, PrimaryHit);

/// A pixel on its way down a linetree: pixel, tree (then leaf cell), its
/// line, the surface it sees and its primary hit.
type PixelLeaf = (u32, u32, LineCoords, RootFace, (f32, u32));

/// What assignment found for a pixel that reprojection did not claim.
#[derive(Debug, Clone, Copy)]
enum Found {
    Background,
    Traced(TraceReason, Option<(f32, u32)>),
    Leaf {
        leaf: u32,
        coords: LineCoords,
        face: RootFace,
        hit: (f32, u32),
    },
    /// The hit's linetree is not made yet (`assign` makes it).
    NoTree {
        face: RootFace,
        d: Vec3,
        hit: (f32, u32),
    },
}

impl BoundedRenderer {
    /// A bounded-error renderer of `scene` on `device` with `settings`:
    /// radiance interpolants over Whitted ray tracing, every interpolated
    /// pixel within `settings.epsilon` of the exact one (Bala, Dorsey and
    /// Teller 1999).
    ///
    /// ```
    /// use penumbra::{BoundedRenderer, BoundedSettings, Device, Scene};
    /// use penumbra::scene::procedural::sphere_on_plane;
    ///
    /// let scene = Scene::from_mesh("sphere", "sphere.obj".as_ref(), sphere_on_plane());
    /// let mut renderer = BoundedRenderer::for_scene(&Device::cpu(), &scene, BoundedSettings::default())?;
    /// let camera = scene.camera_in(&Default::default(), &renderer.whitted.bounds())?;
    /// let frame = renderer.render(&camera, 64, 48)?;
    /// assert_eq!(frame.radiance.len(), 64 * 48);
    /// # Ok::<(), penumbra::Error>(())
    /// ```
    pub fn for_scene(
        device: &Device,
        scene: &crate::scene::Scene,
        settings: BoundedSettings,
    ) -> Result<BoundedRenderer> {
        BoundedRenderer::new(WhittedRenderer::for_scene(device, scene)?, settings)
    }

    /// A bounded-error renderer over `whitted`'s scene and device.
    pub fn new(whitted: WhittedRenderer, settings: BoundedSettings) -> Result<BoundedRenderer> {
        settings.validate()?;
        let geometry = SceneGeometry::new(whitted.scene(), whitted.tree(), settings.patches);
        let gpu = whitted.context().map(|ctx| (ctx.clone(), Batched::new(ctx)));
        Ok(BoundedRenderer {
            whitted,
            geometry,
            trees: Linetrees::default(),
            settings,
            frame: 0,
            last_used: Vec::new(),
            gpu,
            scratch: Scratch::default(),
        })
    }

    /// Renders the next frame from `camera`.
    pub fn render(&mut self, camera: &Camera, width: u32, height: u32) -> Result<BoundedFrame> {
        let start = Instant::now();
        self.frame += 1;
        let params = self.whitted.params(camera, width, height, &self.settings.whitted)?;
        let n = width as usize * height as usize;
        let mut stats = FrameStats::default();
        let mut paths = vec![PixelPath::Background; n];
        // Pixels interpolated in the cell assignment found, with their place.
        let mut assigned: Vec<(u32, Assigned)> = Vec::new();
        // Pixels left to trace, with their primary hit where known.
        let mut slow: Vec<(u32, Option<(f32, u32)>)> = Vec::new();
        let exact = if self.settings.epsilon == 0.0 {
            Some(TraceReason::EpsilonZero)
        } else {
            (params.media_len > 0).then_some(TraceReason::EyeInMedium)
        };
        if let Some(reason) = exact {
            // The Whitted renderer itself (packets or its kernel): the image
            // `--method whitted` makes, bit for bit.
            let t = Instant::now();
            let out = self
                .whitted
                .render(camera, width, height, &self.settings.whitted, &Bar::hidden())?;
            stats.trace_ms = elapsed_ms(t);
            stats.rays_traced_slow_path = out.stats.rays.total();
            paths.fill(PixelPath::Traced(reason));
            count_paths(&paths, &mut stats);
            stats.frame_ms = elapsed_ms(start);
            self.last_used.clear();
            return Ok(BoundedFrame {
                width,
                height,
                camera: *camera,
                radiance: out.radiance(),
                paths,
                cells: vec![u32::MAX; n],
                stats,
            });
        }

        let rays = PixelRays::new(&params);
        // 1. Fast path.
        let t0 = Instant::now();
        let mut claimed = vec![u32::MAX; n];
        if self.settings.reproject {
            (stats.cells_reprojected, stats.reproject_dropped) =
                self.reproject(&params, &rays, camera.eye, &mut claimed);
        }
        for (i, &c) in claimed.iter().enumerate() {
            if c < CONFLICT {
                paths[i] = PixelPath::Reprojected;
            }
        }
        stats.reproject_ms = elapsed_ms(t0);

        // 2. Pixel assignment.
        let t1 = Instant::now();
        let todo: Vec<u32> = (0..n as u32).filter(|&i| claimed[i as usize] >= CONFLICT).collect();
        let mut found = std::mem::take(&mut self.scratch.found);
        self.assign(&params, &rays, &todo, &mut found);
        // The pixels with a leaf, in pixel order.
        let mut round: Vec<PixelLeaf> = Vec::with_capacity(found.len());
        for (&i, f) in todo.iter().zip(&found) {
            match *f {
                Found::Background => paths[i as usize] = PixelPath::Background,
                Found::Traced(why, hit) => {
                    paths[i as usize] = PixelPath::Traced(why);
                    slow.push((i, hit));
                }
                Found::Leaf {
                    leaf,
                    coords,
                    face,
                    hit,
                } => round.push((i, leaf, coords, face, hit)),
                Found::NoTree { .. } => return Err(Error::internal("a pixel's linetree was not made")),
            }
        }
        self.scratch.found = found;
        stats.assign_ms = elapsed_ms(t1);

        // Rounds of builds until every pixel has an accepted leaf or a
        // rejected one that stays.
        let t2 = Instant::now();
        let mut order = std::mem::take(&mut self.scratch.order);
        while !round.is_empty() {
            let groups = sort_by_cell(&round, self.trees.cells.len(), &mut order);
            let to_build: Vec<u32> = groups
                .iter()
                .filter(|(c, _)| matches!(self.trees.cells[*c as usize].state, CellState::Unbuilt))
                .map(|(c, _)| *c)
                .collect();
            self.build(&params, &to_build, &mut stats)?;
            let mut next = Vec::new();
            for (cell, range) in groups {
                let pixels = order[range].iter().map(|&k| &round[k as usize]);
                self.trees.cells[cell as usize].used = self.frame;
                let tree = self.trees.cells[cell as usize].tree;
                let pair = self.trees.trees[tree as usize].pair;
                match &self.trees.cells[cell as usize].state {
                    CellState::Valid(interp) => {
                        let c = self.trees.cells[cell as usize].cell;
                        for &(i, _, coords, face, hit) in pixels {
                            if interp.accepted.covers(face, hit.1) {
                                paths[i as usize] = PixelPath::Interpolated;
                                assigned.push((
                                    i,
                                    Assigned {
                                        cell,
                                        local: c.local(&pair, &coords),
                                        hit: Some(hit),
                                    },
                                ));
                            } else {
                                paths[i as usize] = PixelPath::Traced(TraceReason::Mismatch);
                                slow.push((i, Some(hit)));
                            }
                        }
                    }
                    CellState::Failed { failure, split, .. } => {
                        let (failure, split) = (*failure, *split);
                        let axes = match self.settings.split {
                            SplitKind::Sixteen => 0b1111,
                            SplitKind::Four => split,
                        };
                        let c = self.trees.cells[cell as usize].cell;
                        let children = 1usize << (axes as u32).count_ones();
                        let can = (0..4).filter(|a| axes >> a & 1 == 1).all(|a| c.splittable(a));
                        if can && pixels.len() >= self.settings.min_pixels as usize * children {
                            self.trees.split(cell, axes);
                            stats.cells_split += 1;
                            for &(i, _, coords, face, hit) in pixels {
                                next.push((i, self.trees.leaf_below(cell, &coords), coords, face, hit));
                            }
                        } else {
                            if let CellState::Failed { pixels: p, .. } = &mut self.trees.cells[cell as usize].state {
                                *p = (*p).max(pixels.len() as u32);
                            }
                            for &(i, _, _, _, hit) in pixels {
                                paths[i as usize] = PixelPath::Traced(TraceReason::Failure(failure));
                                slow.push((i, Some(hit)));
                            }
                        }
                    }
                    CellState::Unbuilt | CellState::Split { .. } => {
                        return Err(Error::internal("a linetree leaf was neither built nor split"));
                    }
                }
            }
            round = next;
        }
        self.scratch.order = order;
        stats.build_ms = elapsed_ms(t2);

        // 3. Interpolation, and 4. the slow path (with the pixels at a
        // texture's edges that interpolation hands back).
        let t4 = Instant::now();
        let mut radiance = vec![Vec3::from_array(params.background); n];
        let (pixel_cells, edges) = self.interpolate_all(&params, &rays, &claimed, &assigned, &mut radiance)?;
        for (i, hit) in edges {
            paths[i as usize] = PixelPath::Traced(TraceReason::TextureEdge);
            slow.push((i, hit));
        }
        stats.interpolate_ms = elapsed_ms(t4);
        let t3 = Instant::now();
        let traced = self.trace_slow(&params, &rays, &slow)?;
        for (i, r, rays) in traced {
            radiance[i as usize] = r;
            stats.rays_traced_slow_path += rays as u64;
        }
        stats.trace_ms = elapsed_ms(t3);
        if self.settings.span {
            span_fill(width, &claimed, &mut radiance, &mut paths);
        }

        // Bookkeeping: what reprojection tries next, memory.
        // The cells used, each once, in increasing order: marked in a
        // bitset, then read off it (sorting every pixel's cell was a
        // sequential tenth of the frame's bookkeeping).
        let mut marks = vec![0u64; self.trees.cells.len().div_ceil(64)];
        let pixel_cells_used = assigned.iter().map(|(_, a)| a.cell);
        for c in pixel_cells_used.chain(claimed.iter().copied().filter(|&c| c < CONFLICT)) {
            marks[c as usize / 64] |= 1 << (c % 64);
        }
        let mut used = Vec::new();
        for (w, &bits) in marks.iter().enumerate() {
            let mut b = bits;
            while b != 0 {
                used.push(w as u32 * 64 + b.trailing_zeros());
                b &= b - 1;
            }
        }
        for &c in &used {
            self.trees.cells[c as usize].used = self.frame;
        }
        self.last_used = used;
        self.trees.release_split();
        let cap = (self.settings.memory_mb * 1024.0 * 1024.0) as usize;
        stats.evicted_cells = self.trees.evict(cap, self.frame);
        self.last_used
            .retain(|&c| matches!(self.trees.cells[c as usize].state, CellState::Valid(_)));
        let (cells, leaves, valid) = self.trees.counts();
        stats.cells = cells;
        stats.leaves = leaves;
        stats.valid_cells = valid;
        stats.memory_bytes = self.trees.bytes();
        stats.memory_peak_bytes = self.trees.peak_bytes;
        count_paths(&paths, &mut stats);
        stats.frame_ms = elapsed_ms(start);
        Ok(BoundedFrame {
            width,
            height,
            camera: *camera,
            radiance,
            paths,
            cells: pixel_cells,
            stats,
        })
    }

    /// Which leaf each pixel of `todo` has its line in (or why it has
    /// none), into `found`.
    fn assign(&mut self, params: &WhittedUniforms, rays: &PixelRays, todo: &[u32], found: &mut Vec<Found>) {
        let twin = self.whitted.twin(params);
        let eye = Vec3::from_array(params.eye).as_dvec3();
        let scene = self.whitted.scene();
        // One pass: the primary hit, its linetree, the line and its leaf
        // (in pixel order, each lookup starting from the previous pixel's
        // leaf). A hit whose tree is not made yet waits for it.
        let (trees, geometry) = (&self.trees, &self.geometry);
        found.clear();
        found.resize(todo.len(), Found::Background);
        found
            .par_chunks_mut(1024)
            .zip(todo.par_chunks(1024))
            .for_each(|(out, chunk)| {
                let mut last = None;
                for (f, &i) in out.iter_mut().zip(chunk) {
                    let (o, d) = rays.ray(i);
                    let hit = twin.closest(o, d, f32::INFINITY, None);
                    let Some((t, p)) = hit else {
                        continue;
                    };
                    let face = RootFace::of(geometry, scene, p);
                    let Some(tree) = trees.find(face, pair_index(d)) else {
                        *f = Found::NoTree { face, d, hit: (t, p) };
                        continue;
                    };
                    let pair = &trees.trees[tree as usize].pair;
                    // The eye may be between the faces: the line is what counts.
                    let Some(coords) = pair.coords(eye, d.as_dvec3()) else {
                        *f = Found::Traced(TraceReason::Eye, hit);
                        continue;
                    };
                    let leaf = trees.leaf_hinted(tree, &coords, last);
                    last = Some(leaf);
                    *f = Found::Leaf {
                        leaf,
                        coords,
                        face,
                        hit: (t, p),
                    };
                }
            });
        // The trees still missing (mostly in the first frame), made in the
        // order of their keys; their pixels' leaf is the new root.
        let mut keys: Vec<(RootFace, usize)> = found
            .iter()
            .filter_map(|f| match *f {
                Found::NoTree { face, d, .. } => Some((face, pair_index(d))),
                _ => None,
            })
            .collect::<HashSet<_>>()
            .into_iter()
            .collect();
        if keys.is_empty() {
            return;
        }
        keys.sort_unstable();
        for (surface, pair) in keys {
            let bounds = self.geometry.bounds(surface);
            self.trees.tree(surface, pair, || FacePair::new(&bounds, pair));
        }
        let trees = &self.trees;
        found.par_iter_mut().with_min_len(256).for_each(|f| {
            if let Found::NoTree { face, d, hit } = *f {
                let tree = trees.find(face, pair_index(d)).expect("made above");
                *f = match trees.trees[tree as usize].pair.coords(eye, d.as_dvec3()) {
                    Some(coords) => Found::Leaf {
                        leaf: trees.leaf(tree, &coords),
                        coords,
                        face,
                        hit,
                    },
                    None => Found::Traced(TraceReason::Eye, Some(hit)),
                };
            }
        });
    }

    /// Traces the missing extremal rays of `cells` and judges them.
    fn build(&mut self, params: &WhittedUniforms, cells: &[u32], stats: &mut FrameStats) -> Result<()> {
        if cells.is_empty() {
            return Ok(());
        }
        // The missing extremal rays, each once.
        let mut missing: Vec<(u128, u32, usize)> = Vec::new();
        for &c in cells {
            let keys = self.trees.corner_keys(c);
            stats.extremal_rays_requested += 16;
            for (k, key) in keys.iter().enumerate() {
                if self.trees.sample(*key).is_none() {
                    missing.push((*key, c, k));
                }
            }
        }
        missing.sort_unstable_by_key(|m| m.0);
        missing.dedup_by_key(|m| m.0);
        stats.extremal_rays_traced += missing.len() as u64;
        let (trees, geometry) = (&self.trees, &self.geometry);
        // Each missing ray with its root hit (on the linetree's surface).
        let (keys, rays): (Vec<u128>, Vec<TreeRay>) = missing
            .par_iter()
            .map(|&(key, c, k)| {
                let cell = &trees.cells[c as usize];
                let tree = &trees.trees[cell.tree as usize];
                let (o, d) = corner_ray(&tree.pair, &cell.cell, k);
                (key, tree_ray(geometry, tree.surface, o, d))
            })
            .unzip();
        let mut on_device = if self.slow_path_on_gpu() && !rays.is_empty() {
            self.whitted.trace_trees(params, &rays)?.unwrap_or_default()
        } else {
            Vec::new()
        };
        stats.extremal_rays_on_gpu += on_device.iter().flatten().count() as u64;
        // The twin traces what the kernel did not (no GPU, or a tree that
        // overflowed its slot).
        on_device.resize_with(rays.len(), || None);
        let twin = self.whitted.twin(params);
        let traced: Vec<Sample> = rays
            .par_iter()
            .zip(on_device)
            .map(|(ray, gpu)| match gpu {
                Some(r) => Sample::new(r.radiance, r.diffuse, r.tree),
                None => twin_sample(&twin, ray),
            })
            .collect();
        let traced = keys.into_iter().zip(traced);
        for (key, s) in traced {
            self.trees.insert_sample(key, s);
        }
        let predicate = Predicate {
            w: &twin,
            geometry: &self.geometry,
            epsilon: self.settings.epsilon as f64,
            floor: self.settings.floor as f64,
            bound: self.settings.bound,
        };
        let trees = &self.trees;
        let scene = self.whitted.scene();
        let verdicts: Vec<(u32, CellState)> = cells
            .par_iter()
            .map(|&c| {
                let cell = &trees.cells[c as usize];
                let (pair, root) = (
                    trees.trees[cell.tree as usize].pair,
                    trees.trees[cell.tree as usize].surface,
                );
                let keys = trees.corner_keys(c);
                let samples: [&Sample; 16] = keys.map(|k| trees.sample(k).expect("traced above"));
                let textured = first_surface(scene, samples[0]).is_some_and(|s| s.textured());
                let radiance = samples.map(|s| textured_split(scene, s).0);
                let diffuse = textured.then(|| samples.map(|s| s.diffuse));
                let centre = (predicate.bound == BoundKind::Paper).then(|| {
                    let mid = [0, 1, 2, 3].map(|i| {
                        let (lo, hi) = cell.cell.range(&pair, i);
                        0.5 * (lo + hi)
                    });
                    let (o, d) = pair.ray(mid);
                    textured_split(scene, &trace_sample(&twin, &self.geometry, root, o, d.normalize()))
                });
                let corners = Corners {
                    radiance: &radiance,
                    diffuse: diffuse.as_ref(),
                    centre,
                };
                let state = match predicate.judge(&pair, &cell.cell, &corners, samples.map(|s| &s.tree)) {
                    Ok(accepted) => CellState::Valid(Box::new(Interpolant {
                        radiance,
                        diffuse: diffuse.map(Box::new),
                        accepted,
                    })),
                    Err(r) => CellState::Failed {
                        failure: r.failure,
                        split: r.split,
                        pixels: 0,
                    },
                };
                (c, state)
            })
            .collect();
        stats.cells_built += verdicts.len();
        for (c, state) in verdicts {
            self.trees.settle(c, state);
        }
        Ok(())
    }

    /// Claims pixels for the cells of the last frame whose shafts from the
    /// eye are clear; `claimed[pixel]` becomes the cell, or `CONFLICT`.
    fn reproject(
        &self,
        params: &WhittedUniforms,
        rays: &PixelRays,
        eye: Vec3,
        claimed: &mut [u32],
    ) -> (usize, [usize; 3]) {
        let scene = self.whitted.scene();
        let shafts = Shafts {
            scene,
            tree: self.whitted.tree(),
            geometry: &self.geometry,
        };
        let eye_d = eye.as_dvec3();
        // Per cell: its pixels, or why it has none (0 eye, 1 shaft, 2 empty).
        let per_cell: Vec<(Vec<u32>, usize)> = self
            .last_used
            .par_iter()
            .map(|&c| {
                let cell = &self.trees.cells[c as usize];
                let CellState::Valid(interp) = &cell.state else {
                    return (Vec::new(), 0);
                };
                let pair = &self.trees.trees[cell.tree as usize].pair;
                if !interp.accepted.reprojectable {
                    return (Vec::new(), 0);
                }
                // One shaft cull: from the eye to the box of the cell's hits.
                let (lo, hi) = interp.accepted.hits;
                let d = AVec3::boxed(lo - eye_d, hi - eye_d);
                // The predicate proved every ray of the cell lands inside the
                // root's polygon, so everything in its plane may be skipped.
                let plane = |p: u32| {
                    let poly = &self.geometry.polygons[p as usize];
                    Exclude::Plane(poly.normal, poly.w)
                };
                let exclude = match interp.accepted.root {
                    RootFace::Polygon(p) => plane(p),
                    RootFace::Triangle(t) => plane(self.geometry.triangle_polygon[t as usize]),
                    RootFace::Sphere(t) => Exclude::Primitive(t),
                    // A reprojectable patch cell's lines all land in its one
                    // triangle (`Accepted::pieces`).
                    RootFace::Patch(_) => match *interp.accepted.pieces {
                        [t] => plane(self.geometry.triangle_polygon[t as usize]),
                        _ => Exclude::None,
                    },
                };
                // A patch cell's lines land on its pieces, whichever first.
                let pieces: &[u32] = match interp.accepted.root {
                    RootFace::Patch(_) => &interp.accepted.pieces,
                    _ => &[],
                };
                let eye = AVec3::constant(eye_d);
                let d = match &interp.accepted.hit_points {
                    Some(q) => q.add_const(-eye_d),
                    None => d,
                };
                if !shafts.clear_but(&eye, &d, End::At(Aff::constant(1.0)), &[exclude], pieces) {
                    return (Vec::new(), 1);
                }
                (
                    pixels_in_cell(params, rays, pair, &cell.cell, interp.accepted.hits, eye_d),
                    2,
                )
            })
            .collect();
        let mut count = 0;
        let mut dropped = [0; 3];
        for ((pixels, why), &c) in per_cell.iter().zip(&self.last_used) {
            if pixels.is_empty() {
                dropped[*why] += 1;
            } else {
                count += 1;
            }
            for &p in pixels {
                let slot = &mut claimed[p as usize];
                *slot = if *slot == u32::MAX { c } else { CONFLICT };
            }
        }
        (count, dropped)
    }

    /// Whether `trace_slow` runs the Whitted kernel (`SlowPath`).
    pub fn slow_path_on_gpu(&self) -> bool {
        match (self.whitted.context(), self.settings.slow_path) {
            (None, _) | (_, SlowPath::Cpu) => false,
            (Some(_), SlowPath::Device) => true,
            // A software adapter runs the kernel on the same cores as the
            // CPU twin, with a dispatch and no primary hit given: 12 times
            // slower on lavapipe (docs/results/bounded.md, "Slow path on a
            // GPU").
            (Some(ctx), SlowPath::Auto) => !ctx.is_software(),
        }
    }

    /// The slow path: each pixel's radiance and rays traced exactly. On a
    /// GPU, the Whitted kernel over the list of pixels (the pixels of the
    /// GPU's `--method whitted` image, bit for bit); on the CPU, the twin
    /// from the pixel's primary hit where assignment traced it.
    fn trace_slow(
        &mut self,
        params: &WhittedUniforms,
        rays: &PixelRays,
        slow: &[PixelToTrace],
    ) -> Result<Vec<(u32, Vec3, u32)>> {
        if self.slow_path_on_gpu() {
            let list: Vec<u32> = slow.iter().map(|&(i, _)| i).collect();
            let out = self.whitted.render_listed(params, &list, &Bar::hidden())?;
            return Ok(list
                .iter()
                .zip(&out.value)
                .map(|(&i, p)| (i, Vec3::from_array(p.radiance), p.rays.iter().sum()))
                .collect());
        }
        let twin = self.whitted.twin(params);
        let media = Media::from_ids(&params.media[..params.media_len as usize]);
        Ok(slow
            .par_iter()
            .with_min_len(64)
            // No shadow test is given: one list of unknowns per worker
            // (one per pixel was an allocation each).
            .map_init(
                || vec![None; params.light_count as usize],
                |blocked, &(i, hit)| {
                    let (o, d) = rays.ray(i);
                    let first = hit.map(|(t, p)| twin.facing(o, d, t, p));
                    let given = FirstHit { facing: first, blocked };
                    let out = twin.shade(o, d, media, hit.map(|_| &given), None);
                    (i, out.radiance, out.rays.iter().sum::<u32>())
                },
            )
            .collect())
    }

    /// Interpolates every pixel that has a cell: its position in the cell
    /// here (f64 line coordinates), the interpolation itself on the device
    /// (`interpolate.wgsl`) or by its CPU twin, over one table of the
    /// cells' corners. A textured cell takes two slots (base, diffuse), and
    /// its pixels' jobs carry the texture at their hits;
    /// pixels whose hit lies within rounding of a texture edge are handed
    /// back (with their hit) to be traced. Returns each pixel's cell.
    fn interpolate_all(
        &mut self,
        params: &WhittedUniforms,
        rays: &PixelRays,
        claimed: &[u32],
        assigned: &[(u32, Assigned)],
        out: &mut [Vec3],
    ) -> Result<(Vec<u32>, Vec<PixelToTrace>)> {
        let eye = Vec3::from_array(params.eye).as_dvec3();
        // Per pixel: its cell and place in it, and its texture factor (or
        // `None`: at a texture's edge).
        let textured = |i: u32, a: Assigned, ray: Option<(Vec3, Vec3)>| {
            let CellState::Valid(interp) = &self.trees.cells[a.cell as usize].state else {
                return None;
            };
            let texture = match interp.diffuse {
                Some(_) => {
                    let ray = ray.unwrap_or_else(|| rays.ray(i));
                    self.pixel_texture(ray, interp.accepted.root, a.hit)
                }
                None => Some(Vec3::ONE),
            };
            Some((i, a, texture))
        };
        // The reprojected pixels: their place in the cell from their line.
        let reprojected: Vec<u32> = (0..claimed.len() as u32)
            .filter(|&i| claimed[i as usize] < CONFLICT)
            .collect();
        let from_assigned: Vec<Option<(u32, Assigned, Option<Vec3>)>> = assigned
            .par_iter()
            .with_min_len(256)
            .map(|&(i, a)| textured(i, a, None))
            .collect();
        let from_reprojected: Vec<Option<(u32, Assigned, Option<Vec3>)>> = reprojected
            .par_iter()
            .with_min_len(256)
            .map(|&i| {
                let c = claimed[i as usize];
                let cell = &self.trees.cells[c as usize];
                let pair = &self.trees.trees[cell.tree as usize].pair;
                let ray = rays.ray(i);
                let coords = pair.coords(eye, ray.1.as_dvec3())?;
                let a = Assigned {
                    cell: c,
                    local: cell.cell.local(pair, &coords),
                    hit: None,
                };
                textured(i, a, Some(ray))
            })
            .collect();
        let found = from_assigned.iter().chain(&from_reprojected).flatten();
        let mut edges = Vec::new();
        // One slot per cell (two where textured), in order of first use.
        let mut slot_of = vec![u32::MAX; self.trees.cells.len()];
        let mut corners: Vec<[f32; 4]> = Vec::new();
        let mut jobs: Vec<PixelJob> = Vec::with_capacity(assigned.len() + reprojected.len());
        let mut job_cells: Vec<u32> = Vec::with_capacity(jobs.capacity());
        for &(pixel, a, texture) in found {
            let Some(texture) = texture else {
                edges.push((pixel, a.hit));
                continue;
            };
            let CellState::Valid(interp) = &self.trees.cells[a.cell as usize].state else {
                unreachable!("filtered above")
            };
            let slot = &mut slot_of[a.cell as usize];
            if *slot == u32::MAX {
                *slot = (corners.len() / 16) as u32;
                corners.extend(interp.radiance.iter().map(|r| r.extend(0.0).to_array()));
                if let Some(d) = &interp.diffuse {
                    corners.extend(d.iter().map(|r| r.extend(0.0).to_array()));
                }
            }
            let slot = *slot;
            jobs.push(PixelJob {
                slot,
                pixel,
                textured: interp.diffuse.is_some() as u32,
                local: a.local,
                texture: texture.extend(0.0).to_array(),
                ..Default::default()
            });
            job_cells.push(a.cell);
        }
        let radiance = match &mut self.gpu {
            Some((ctx, pass)) => pass.interpolate(ctx, &corners, &jobs)?.0,
            None => interpolate_pixels(&corners, &jobs),
        };
        let mut cells = vec![u32::MAX; out.len()];
        for ((job, r), cell) in jobs.iter().zip(radiance).zip(job_cells) {
            out[job.pixel as usize] = Vec3::from_slice(&r[..3]);
            cells[job.pixel as usize] = cell;
        }
        Ok((cells, edges))
    }

    /// The texture factor at a pixel's hit on the cell's root surface (its
    /// ray `(o, d)`): its traced primary hit, or (reprojected) its line's
    /// intersection with the root; `None` where the hit lies within
    /// rounding of an edge of the texture (the renderer's own hit point
    /// could be across it).
    fn pixel_texture(&self, (o, d): (Vec3, Vec3), root: RootFace, hit: PrimaryHit) -> Option<Vec3> {
        let (t, primitive) = match hit {
            Some(h) => h,
            None => {
                let (t, p) = self.geometry.root_distance(root, o.as_dvec3(), d.as_dvec3())?;
                (t as f32, p)
            }
        };
        let scene = self.whitted.scene();
        let surface = scene.surface(scene.primitive_surface(primitive));
        // The renderer's point (`Whitted::hit_info`) is this one up to
        // rounding of t and of the point: a margin with room to spare.
        let point = o + t * d;
        surface.texture_near(point, 1e-5 * (max_abs(o) + t.abs() + max_abs(point)))
    }

    /// The exact radiance leaving tree `tree`'s surface along its line `c`,
    /// the primitive it was shaded on (`None`: the line misses the
    /// surface) and the texture factor there, for `--check`.
    pub fn trace_line(&self, params: &WhittedUniforms, tree: u32, c: &LineCoords) -> (Vec3, Option<u32>, Vec3) {
        let tree = &self.trees.trees[tree as usize];
        let (o, d) = tree.pair.ray(*c);
        let s = trace_sample(
            &self.whitted.twin(params),
            &self.geometry,
            tree.surface,
            o,
            d.normalize(),
        );
        let first = s.tree.nodes.first().and_then(|n| n.hit);
        let texture = first.map_or(Vec3::ONE, |h| self.whitted.scene().surface(h.surface).texture(h.point));
        (s.radiance, first.map(|h| h.primitive), texture)
    }

    /// The scene's faces, spheres and patches as the predicate sees them.
    pub fn geometry(&self) -> &SceneGeometry {
        &self.geometry
    }

    /// The accepted cells the last frame used.
    pub fn used_cells(&self) -> &[u32] {
        &self.last_used
    }
}

/// The order of a round by cell, each cell's pixels kept in their order
/// (indices into `round`, written to `order`), and the run of each cell in
/// it: a stable counting sort over the cell indices (`cells` of them),
/// where a comparison sort of the 72-byte tuples by (cell, pixel) took a
/// third of the build phase. A round lists its pixels in increasing order
/// within each cell (the first in pixel order, later ones split from one
/// cell's sorted run), so the order is that sort's. Indices rather than a
/// sorted copy of the round: at 1280x960 a copy is 88 MB a frame, above
/// glibc's largest mmap threshold (32 MB), so each frame's copy was fresh
/// pages, faulted in and unmapped again.
fn sort_by_cell(round: &[PixelLeaf], cells: usize, order: &mut Vec<u32>) -> Vec<(u32, std::ops::Range<usize>)> {
    let mut next = vec![0u32; cells];
    for r in round {
        next[r.1 as usize] += 1;
    }
    let mut groups = Vec::new();
    let mut start = 0u32;
    for (cell, slot) in next.iter_mut().enumerate() {
        let count = std::mem::replace(slot, start);
        if count > 0 {
            groups.push((cell as u32, start as usize..(start + count) as usize));
            start += count;
        }
    }
    order.clear();
    order.resize(round.len(), 0);
    for (k, r) in round.iter().enumerate() {
        let slot = &mut next[r.1 as usize];
        order[*slot as usize] = k as u32;
        *slot += 1;
    }
    debug_assert!(order.windows(2).all(|w| {
        let (a, b) = (&round[w[0] as usize], &round[w[1] as usize]);
        (a.1, a.0) < (b.1, b.0)
    }));
    groups
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counting sort orders a round as the comparison sort by (cell,
    /// pixel) did, and its runs are that order's runs of equal cells.
    #[test]
    fn sort_by_cell_is_the_sort_by_cell_and_pixel() {
        let mut rng = crate::accel::kdtree::test_rng::Rng(0x853c_49e6_748f_ea9b);
        for case in 0..200 {
            let cells = 1 + (rng.next_u64() % 64) as usize;
            let n = (rng.next_u64() % 300) as u32;
            // Pixels in increasing order, as a round lists them.
            let mut pixel = 0;
            let round: Vec<PixelLeaf> = (0..n)
                .map(|_| {
                    pixel += 1 + (rng.next_u64() % 3) as u32;
                    let cell = (rng.next_u64() % cells as u64) as u32;
                    (pixel, cell, [0.0; 4], RootFace::Sphere(0), (1.0, 0))
                })
                .collect();
            let mut order = Vec::new();
            let groups = sort_by_cell(&round, cells, &mut order);
            let sorted: Vec<PixelLeaf> = order.iter().map(|&k| round[k as usize]).collect();
            let mut expected = round.clone();
            expected.sort_unstable_by_key(|r| (r.1, r.0));
            let key = |v: &[PixelLeaf]| v.iter().map(|r| (r.1, r.0)).collect::<Vec<_>>();
            assert_eq!(key(&sorted), key(&expected), "case {case}");
            let mut runs: Vec<(u32, std::ops::Range<usize>)> = Vec::new();
            for (k, r) in expected.iter().enumerate() {
                match runs.last_mut() {
                    Some((c, range)) if *c == r.1 => range.end = k + 1,
                    _ => runs.push((r.1, k..k + 1)),
                }
            }
            assert_eq!(groups, runs, "case {case}");
        }
    }
}
