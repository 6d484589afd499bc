//! The error predicate (the bounded-error paper, section 5): given the 16
//! extremal rays of a linetree cell, traced with their ray trees, may the
//! radiance of every ray of the cell be interpolated from them within
//! epsilon?
//!
//! Radiance discontinuities (section 5.1), each a sub-test whose failure
//! the caller reports:
//! - `Topology`: the 16 ray trees must be isomorphic (same surfaces, light
//!   codes, children, total internal reflections);
//! - `Silhouette`: every ray of the cell must hit the surface the trees
//!   name: a flat face's hits lie inside its polygon, a sphere's rays all
//!   meet it (positive discriminant everywhere), a smooth triangle's hits
//!   inside the triangle; no normal may be grazing;
//! - `Blocker`: a shaft cull of every reflected and refracted segment of
//!   the tree: no primitive the tree does not name may meet any of the
//!   cell's segments;
//! - `Shadow`: a shaft cull of every visible light's shadow segments, and
//!   lights that turn towards or away from the surface inside the cell; a
//!   blocked light must be proven blocked for every ray (its occluder, a
//!   sphere or a convex face, crossed by every shadow segment), else its
//!   contribution is unknown and counted whole in the bound;
//! - `Tir`: total internal reflection must hold for all rays of the cell
//!   or none of them, not only at the 16.
//!
//! On a smooth patch of a mesh (`patch`), the 16 rays may land on
//! different triangles: the bound is carried over every triangle around
//! them (`Predicate::patch_hit`), a pixel is interpolated only when its own
//! hit lies on one of those (`Accepted::covers`), and each triangle's
//! shadow rays are culled from the triangle itself.
//!
//! Radiance non-linearity (section 5.2), `Nonlinear`: the whole Whitted
//! shading of the tree (hit points, normals, Phong lobes, 1/d^2, Fresnel
//! weights, reflected and refracted directions) is evaluated in affine
//! arithmetic over the cell (`affine`). Its affine part is interpolated
//! exactly by the 16 samples; the remainder `r` bounds the interpolation
//! error by `2 r` per channel. Alongside, the same evaluation carries
//! enclosures of the pure second derivatives (`jet`), whose bound
//! `sum_i 1/2 max |L_ii| (+ 2 P)` leaves out the cross terms that
//! quadrilinear interpolation reproduces; the smaller of the two bounds,
//! `E`, is used. The cell is accepted where
//! `E + rounding <= epsilon * max(L_min, floor)` for every channel, with
//! `L_min` the smallest radiance the form allows: then
//! `|L_interp - L| <= epsilon * max(L, floor)` for every ray of the cell.
//! `BoundKind::Paper` keeps the discontinuity tests and replaces this
//! bound by the paper's kind of estimate (the interpolation error measured
//! at the cell's centre, doubled): cheaper cells, no guarantee.

use glam::{DVec3, Vec3};

use crate::bounded::affine::{AVec3, Aff};
use crate::bounded::geometry::{Polygon, SceneGeometry, Surface};
use crate::bounded::linespace::{CellBox, FacePair};
use crate::bounded::patch::{NO_PATCH, NormalField, barycentric_blend, clip_to_box, edge_key};
use crate::bounded::shaft::{End, Exclude, Shafts};
use crate::geom::offset::OFFSET_SCALE;
use crate::whitted::lights::DIRECTIONAL;
use crate::whitted::ray_tree::{LightCode, RayKind, RayNode, RayTree};
use crate::whitted::surface::Surface as Shading;
use crate::whitted::whitted::{FRESNEL, Whitted};

/// Why a cell may not be interpolated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Failure {
    /// The 16 ray trees are not isomorphic (section 5.1: geometry changes
    /// and shadows).
    Topology,
    /// Some line of the cell may miss the surface the trees name, or meet
    /// it at a grazing angle.
    Silhouette,
    /// A primitive the trees do not name may cross a reflected or refracted
    /// segment of some line (section 5.1, occluders: a shaft cull).
    Blocker,
    /// A light's visibility may change inside the cell: a shadow segment's
    /// shaft is not clear, the light turns towards or away from the
    /// surface, or the lights whose visibility is unknown (counted whole)
    /// push the bound over epsilon.
    Shadow,
    /// Total internal reflection holds for some lines of the cell and not
    /// others.
    Tir,
    /// The bound on the interpolation error (section 5.2) exceeds
    /// `epsilon * max(L, floor)` even with every light's visibility known.
    Nonlinear,
}

impl Failure {
    /// Every sub-test, in the order the module lists them.
    pub const ALL: [Failure; 6] = [
        Failure::Topology,
        Failure::Silhouette,
        Failure::Blocker,
        Failure::Shadow,
        Failure::Tir,
        Failure::Nonlinear,
    ];
}

/// Which bound decides non-linearity.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum BoundKind {
    /// Affine arithmetic through the ray tree: a guarantee.
    #[default]
    Conservative,
    /// The paper's kind of estimate: the interpolation error at the cell's
    /// centre, doubled. Not a guarantee.
    Paper,
}

crate::choice!(BoundKind { Conservative = "conservative", Paper = "paper" });

/// The surface a cell's rays hit first, which a pixel's own hit must be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RootFace {
    /// A flat face (index into `SceneGeometry::polygons`).
    Polygon(u32),
    /// A smoothly shaded triangle.
    Triangle(u32),
    /// A sphere (its primitive index).
    Sphere(u32),
    /// A smooth patch of a mesh (index into `SceneGeometry::patches`).
    Patch(u32),
}

impl RootFace {
    /// The surface of scene primitive `primitive` (a triangle's index, or
    /// a sphere's primitive index) as linetrees key it.
    pub(crate) fn of(geometry: &SceneGeometry, scene: &crate::whitted::RenderScene, primitive: u32) -> RootFace {
        if geometry.is_sphere(primitive) {
            return RootFace::Sphere(primitive);
        }
        match scene.triangles[primitive as usize].normals[0] {
            crate::whitted::scene::NO_NORMAL => RootFace::Polygon(geometry.triangle_polygon[primitive as usize]),
            _ => match geometry.triangle_patch[primitive as usize] {
                NO_PATCH => RootFace::Triangle(primitive),
                patch => RootFace::Patch(patch),
            },
        }
    }
}

/// An accepted cell.
#[derive(Debug, Clone)]
pub struct Accepted {
    /// The bound on the interpolation error, per channel.
    pub bound: [f64; 3],
    /// The surface every line of the cell hits first.
    pub root: RootFace,
    /// The box of the cell's first hits (the shaft of reprojection).
    pub hits: (DVec3, DVec3),
    /// A reprojectable patch cell's first hits over the cell (plain affine
    /// forms): its reprojection shaft runs to these points, where the box
    /// would take in the patch's neighbouring triangles around them.
    pub hit_points: Option<Box<AVec3>>,
    /// Every ray of the cell hits the root surface (a flat face or a
    /// sphere): its pixels may be assigned by reprojection.
    pub reprojectable: bool,
    /// On a smooth patch, the triangles the bound holds on (ascending):
    /// a pixel whose hit lies on another is traced. Empty elsewhere. A
    /// reprojectable patch cell's lines all meet them (one triangle whose
    /// edges no line crosses, or several whose union's edge none crosses).
    pub pieces: Box<[u32]>,
}

impl Accepted {
    /// Whether a pixel whose primary hit is `primitive`, on `face`, may be
    /// interpolated in the cell.
    pub fn covers(&self, face: RootFace, primitive: u32) -> bool {
        face == self.root && (self.pieces.is_empty() || self.pieces.binary_search(&primitive).is_ok())
    }
}

/// A rejected cell, and which coordinates a 4-way split should halve.
#[derive(Debug, Clone, Copy)]
pub struct Rejected {
    /// The sub-test that rejected the cell.
    pub failure: Failure,
    /// `0b0101` (a, c) or `0b1010` (b, d).
    pub split: u8,
}

/// Radiance allowance for the f32 renderer's rounding, relative to the
/// largest sample.
pub const ROUNDING: f64 = 2e-5;

/// A cell's 16 corner samples as the renderer interpolates them.
pub struct Corners<'a> {
    /// Radiance, or on a textured root what its texture does not scale.
    pub radiance: &'a [Vec3; 16],
    /// On a textured root, the terms its texture scales (`RayOut::diffuse`).
    pub diffuse: Option<&'a [Vec3; 16]>,
    /// For `BoundKind::Paper`: the cell's centre ray's (radiance, diffuse),
    /// split as the corners are.
    pub centre: Option<(Vec3, Vec3)>,
}

/// How a node's texture enters its shading.
#[derive(Clone, Copy)]
enum Texture {
    /// One factor of `ka` and `kd` for every line of the cell.
    Constant(DVec3),
    /// The root's texture, looked up per pixel: its terms are kept apart.
    PerPixel,
}

/// What the predicate reads.
pub(crate) struct Predicate<'a> {
    /// The Whitted twin, for the scene's surfaces, lights and kd-tree.
    pub w: &'a Whitted<'a>,
    /// The scene's faces, spheres and patches.
    pub geometry: &'a SceneGeometry,
    /// `BoundedSettings::epsilon`.
    pub epsilon: f64,
    /// `BoundedSettings::floor`.
    pub floor: f64,
    /// Which bound decides non-linearity.
    pub bound: BoundKind,
}

/// A family of rays of the cell arriving at a tree node.
struct Family {
    origin: AVec3,
    /// Unit directions (the root's are normalised here).
    dir: AVec3,
    weight: [Aff; 3],
    media: Vec<u32>,
    /// The surface its rays leave (not an occluder of them).
    leaves: Exclude,
}

/// A node's hit over the family.
/// A family's hit as its shading sees it: the surface's material, where
/// the lines meet it, the point lifted off it and the normals towards them.
struct AtHit<'a> {
    s: &'a Shading,
    hit: &'a Hit,
    lifted: AVec3,
    n_g: AVec3,
    n_s: AVec3,
    /// On a smooth patch's root, each triangle of the bound with its own
    /// lifted points (its shadow rays start there); empty elsewhere.
    pieces: &'a [PieceOrigin],
}

/// What a hit that is not a patch's puts in the place of a piece: no
/// plane to exclude behind.
const NO_PIECE: PieceOrigin = PieceOrigin {
    triangle: u32::MAX,
    points: AVec3 {
        x: Aff::ZERO,
        y: Aff::ZERO,
        z: Aff::ZERO,
    },
    side: DVec3::ZERO,
    beyond: f64::INFINITY,
};

/// Where the shadow rays of a patch's lines that meet one triangle start.
struct PieceOrigin {
    triangle: u32,
    /// The triangle's points (a parallelogram over it, in its plane),
    /// lifted as the renderer lifts a hit.
    points: AVec3,
    /// The triangle's normal on the lines' side, and a plane `side . x =
    /// beyond` every lifted point lies beyond.
    side: DVec3,
    beyond: f64,
}

struct Hit {
    q: AVec3,
    t: Aff,
    geometric: AVec3,
    shading: AVec3,
    magnitude: f64,
    exclude: Exclude,
}

type Outcome<T> = Result<T, Failure>;

fn consistent(a: &Aff, want_negative: bool) -> Outcome<()> {
    match a.sign() {
        Some(positive) if positive != want_negative => Ok(()),
        _ => Err(Failure::Silhouette),
    }
}

impl Predicate<'_> {
    /// Judges a cell of `pair` from its corner samples' radiance and ray
    /// trees (corner k: bit i of k is the high end of coordinate i).
    ///
    /// On a textured root the renderer interpolates `B` (`radiance`) and
    /// `A` (`diffuse`) and makes `B + T A` with the texture `T` at the
    /// pixel's exact hit, so its error is at most `E(B) + max T E(A)`,
    /// compared with `epsilon max(min B + min T min A, floor)`.
    pub fn judge(
        &self,
        pair: &FacePair,
        cell: &CellBox,
        corners: &Corners,
        trees: [&RayTree; 16],
    ) -> Result<Accepted, Rejected> {
        let default_split = if cell.depth[0] <= cell.depth[1] { 0b0101 } else { 0b1010 };
        let reject = |failure| Rejected {
            failure,
            split: default_split,
        };
        let template = trees[0];
        if template.nodes.is_empty() || template.nodes[0].hit.is_none() {
            return Err(reject(Failure::Topology));
        }
        if trees[1..].iter().any(|t| !same_surfaces(self.geometry, template, t)) {
            return Err(reject(Failure::Topology));
        }
        let (origin, dir) = cell.family(pair);
        let pieces = self.patch_pieces(&trees).map_err(reject)?;
        let walk = self.walk(template, origin, dir, pieces.as_ref()).map_err(reject)?;
        let split = if walk.linear_ac >= walk.linear_bd {
            0b0101
        } else {
            0b1010
        };
        let (t_lo, t_hi) = walk.texture_range;
        let zero = [Vec3::ZERO; 16];
        let diffuse = corners.diffuse.unwrap_or(&zero);
        let max_sample = (0..16).fold(Vec3::ZERO, |m, k| {
            m.max(corners.radiance[k].abs() + t_hi.as_vec3() * diffuse[k].abs())
        });
        let mean = |v: &[Vec3; 16], c: usize| v.iter().map(|r| r[c] as f64).sum::<f64>() / 16.0;
        let mut bound = [0.0; 3];
        let mut certain_fails = false;
        let mut fails = false;
        for c in 0..3 {
            let allowance = ROUNDING * max_sample[c] as f64 + 1e-9;
            let base = walk.certain[c].add(walk.uncertain[c]);
            let textured = walk.diffuse_certain[c].add(walk.diffuse_uncertain[c]);
            let lowest = |b: &Aff, a: &Aff| b.lo() + (t_lo[c] * a.lo()).min(t_hi[c] * a.lo());
            let (error, reference) = match (self.bound, corners.centre) {
                (BoundKind::Paper, Some((cb, ca))) => {
                    let e = 2.0 * (cb[c] as f64 - mean(corners.radiance, c)).abs()
                        + t_hi[c] * 2.0 * (ca[c] as f64 - mean(diffuse, c)).abs();
                    (e + allowance, cb[c] as f64 + t_lo[c] * ca[c] as f64)
                }
                _ => (
                    base.interp_error() + t_hi[c] * textured.interp_error() + allowance,
                    lowest(&base, &textured),
                ),
            };
            bound[c] = error;
            let limit = self.epsilon * reference.max(self.floor);
            // NaN fails: it is not at most the limit.
            fails |= error.partial_cmp(&limit).is_none_or(|o| o.is_gt()) || !base.is_finite() || !textured.is_finite();
            let certain_error =
                walk.certain[c].interp_error() + t_hi[c] * walk.diffuse_certain[c].interp_error() + allowance;
            let certain_limit = self.epsilon * lowest(&walk.certain[c], &walk.diffuse_certain[c]).max(self.floor);
            certain_fails |= certain_error.partial_cmp(&certain_limit).is_none_or(|o| o.is_gt());
        }
        if fails {
            let failure = if certain_fails || self.bound == BoundKind::Paper {
                Failure::Nonlinear
            } else {
                Failure::Shadow
            };
            return Err(Rejected { failure, split });
        }
        Ok(Accepted {
            bound,
            root: walk.root,
            hits: walk.hits,
            hit_points: walk.hit_points.map(Box::new),
            reprojectable: walk.reprojectable,
            pieces: walk.pieces.into_boxed_slice(),
        })
    }

    /// Where the trees' root is a smooth patch, the triangles a cell's
    /// bound is to cover: those the 16 corners hit (required: the corners'
    /// samples must lie within the bound) and the patch's other triangles
    /// around their hits (kept where the bound can be carried onto them,
    /// so that pixels between the corners that hit them are interpolated
    /// too). `None` where the root is not a patch.
    fn patch_pieces(&self, trees: &[&RayTree; 16]) -> Outcome<Option<Pieces>> {
        // No patches (`BoundedSettings::patches` off): nothing to gather
        // on every cell's way through the predicate.
        if self.geometry.patches.is_empty() {
            return Ok(None);
        }
        let roots: Vec<_> = trees.iter().filter_map(|t| t.nodes[0].hit).collect();
        let patch = match RootFace::of(self.geometry, self.w.scene, roots[0].primitive) {
            RootFace::Patch(p) => p,
            _ => return Ok(None),
        };
        let mut required: Vec<u32> = roots.iter().map(|h| h.primitive).collect();
        required.sort_unstable();
        required.dedup();
        if required.len() > MAX_PIECES {
            return Err(Failure::Silhouette);
        }
        // Lines between the corners may meet the triangles around theirs:
        // the corners' triangles' edge neighbours, as room allows.
        let mut optional: Vec<u32> = required
            .iter()
            .flat_map(|&t| self.geometry.patches[patch as usize].neighbours_of(t).iter().copied())
            .filter(|t| required.binary_search(t).is_err())
            .collect();
        optional.sort_unstable();
        optional.dedup();
        optional.truncate(MAX_PIECES - required.len());
        Ok(Some(Pieces {
            base: trees[0].nodes[0].hit.map_or(u32::MAX, |h| h.primitive),
            required,
            optional,
        }))
    }

    /// The affine radiance of the tree over the cell: certain terms and the
    /// terms of lights whose visibility is unknown, per channel.
    fn walk(&self, template: &RayTree, origin: AVec3, dir: AVec3, pieces: Option<&Pieces>) -> Outcome<Walk> {
        let root_dir = dir.normalize().ok_or(Failure::Silhouette)?;
        let mut pending: Vec<Option<Family>> = (0..template.nodes.len()).map(|_| None).collect();
        pending[0] = Some(Family {
            origin,
            dir: root_dir,
            weight: [Aff::constant(1.0); 3],
            media: Vec::new(),
            leaves: Exclude::None,
        });
        let mut out = Walk {
            certain: [Aff::ZERO; 3],
            uncertain: [Aff::ZERO; 3],
            diffuse_certain: [Aff::ZERO; 3],
            diffuse_uncertain: [Aff::ZERO; 3],
            texture_range: (DVec3::ONE, DVec3::ONE),
            root: RootFace::Polygon(0),
            hits: (DVec3::ZERO, DVec3::ZERO),
            hit_points: None,
            reprojectable: false,
            linear_ac: 0.0,
            linear_bd: 0.0,
            pieces: Vec::new(),
        };
        for (i, node) in template.nodes.iter().enumerate() {
            let fam = pending[i].take().ok_or(Failure::Topology)?;
            let background = Vec3::from_array(self.w.params.background).as_dvec3();
            let Some(tree_hit) = node.hit else {
                // A miss: nothing may lie on any of its rays.
                let shafts = self.shafts();
                if !shafts.clear(&fam.origin, &fam.dir, End::Infinite, &[fam.leaves]) {
                    return Err(Failure::Blocker);
                }
                for c in 0..3 {
                    out.certain[c] = out.certain[c].add(fam.weight[c].scale(background[c]));
                }
                continue;
            };
            let surface = self.geometry.surface(self.w.scene, tree_hit.primitive);
            let plain = || self.hit(&fam, &surface, tree_hit.primitive, tree_hit.front);
            let (hit, piece_hits, whole) = match pieces.filter(|_| i == 0) {
                // A patch cell whose lines all provably land in one triangle
                // is that triangle's, as a smooth triangle's cell is (and
                // may be reprojected); else the patch's bound.
                Some(p) => match (p.required.len() == 1).then(plain).and_then(Result::ok) {
                    Some(h) => (h, Vec::new(), Some(tree_hit.primitive)),
                    None => {
                        let (h, pieces) = self.patch_hit(&fam, p, tree_hit.front)?;
                        (h, pieces, None)
                    }
                },
                None => (plain()?, Vec::new(), None),
            };
            if i == 0 {
                out.root = RootFace::of(self.geometry, self.w.scene, tree_hit.primitive);
                out.hits = hit.q.bounds();
                // Lines of a patch's cell that miss the pieces are traced,
                // when their pixels' own hits (the kd-tree's) say so; a
                // cell is reprojected only where every line meets them.
                out.reprojectable = piece_hits.is_empty() || self.pieces_cover(&fam, &piece_hits, tree_hit.front);
                if out.reprojectable && !piece_hits.is_empty() {
                    out.hit_points = Some(hit.q.map(Aff::plain));
                }
                out.pieces = piece_hits.iter().map(|(t, _)| *t).chain(whole).collect();
                out.pieces.sort_unstable();
            } else {
                // The segment from the parent's surface to this hit.
                let shafts = self.shafts();
                if !shafts.clear(&fam.origin, &fam.dir, End::At(hit.t), &[fam.leaves, hit.exclude]) {
                    return Err(Failure::Blocker);
                }
            }
            let n_g = if tree_hit.front {
                hit.geometric
            } else {
                hit.geometric.scale(-1.0)
            };
            let mut n_s = if tree_hit.front {
                hit.shading
            } else {
                hit.shading.scale(-1.0)
            };
            // The renderer's fallback where the shading normal faces away.
            match n_s.dot(fam.dir).sign() {
                Some(false) => {}
                Some(true) => n_s = n_g,
                None => return Err(Failure::Silhouette),
            }
            let max_abs = hit
                .q
                .axes()
                .iter()
                .map(|a| a.lo().abs().max(a.hi().abs()))
                .fold(0.0, f64::max);
            let delta_hi = OFFSET_SCALE as f64 * hit.magnitude.max(max_abs);
            let delta_lo = OFFSET_SCALE as f64 * hit.magnitude;
            let delta = Aff::interval(delta_lo.min(delta_hi), delta_hi);
            let lifted = hit.q.add(n_g.times(delta));
            // A patch's shadow rays start on the triangle each line meets:
            // its points (a parallelogram over it, in its plane), lifted.
            let piece_origins: Vec<PieceOrigin> = piece_hits
                .iter()
                .map(|&(t, [v0, v1, v2])| {
                    let (u, w) = (Aff::coordinate(0, 0.5, 0.5), Aff::coordinate(1, 0.5, 0.5));
                    let on = AVec3::constant(v0)
                        .add(AVec3::constant(v1 - v0).times(u))
                        .add(AVec3::constant(v2 - v0).times(w));
                    let normal = (v1 - v0).cross(v2 - v0).normalize();
                    let side = if tree_hit.front { normal } else { -normal };
                    // A point of the triangle reaches its magnitude at most:
                    // the renderer lifts it by the triangle's own offset.
                    let lift = OFFSET_SCALE as f64 * self.geometry.magnitude[t as usize];
                    PieceOrigin {
                        triangle: t,
                        points: on.add(AVec3::constant(side * lift)),
                        side,
                        // Half the lift: every origin lies beyond it.
                        beyond: side.dot(v0) + 0.5 * lift,
                    }
                })
                .collect();
            let shading = *self.w.scene.surface(tree_hit.surface);
            if shading.mapped() {
                // An image map (or a cut-out's edge) varies within a cell
                // in ways no bound here follows: such cells are traced.
                return Err(Failure::Topology);
            }
            let texture = if !shading.textured() {
                Texture::Constant(DVec3::ONE)
            } else if i == 0 {
                let odd = Vec3::from_array(shading.checker_odd).as_dvec3();
                out.texture_range = (odd.min(DVec3::ONE), odd.max(DVec3::ONE));
                Texture::PerPixel
            } else {
                // Seen in a reflection or through glass, a texture's edge
                // is a discontinuity: every line must meet one check.
                Texture::Constant(constant_texture(&shading, &hit.q).ok_or(Failure::Topology)?)
            };
            let at = AtHit {
                s: &shading,
                hit: &hit,
                lifted,
                n_g,
                n_s,
                pieces: &piece_origins,
            };
            let local = self.local(node, &fam, &at, texture, &mut out)?;
            for (c, l) in local.iter().enumerate() {
                out.certain[c] = out.certain[c].add(fam.weight[c].mul(*l));
            }
            let children = self.children(node, &fam, &at, delta)?;
            for (kind, child) in children {
                let slot = template
                    .nodes
                    .iter()
                    .enumerate()
                    .skip(i + 1)
                    .find(|(_, n)| n.parent == Some(i as u32) && n.kind == kind)
                    .map(|(j, _)| j)
                    .ok_or(Failure::Topology)?;
                pending[slot] = Some(child);
            }
        }
        for c in 0..3 {
            let l = out.certain[c].add(out.uncertain[c]).l;
            out.linear_ac += l[0].abs() + l[2].abs();
            out.linear_bd += l[1].abs() + l[3].abs();
        }
        Ok(out)
    }

    fn shafts(&self) -> Shafts<'_> {
        Shafts {
            scene: self.w.scene,
            tree: self.w.tree,
            geometry: self.geometry,
        }
    }

    /// Where the family meets a smooth patch, for every line of the cell
    /// whose first hit lies on one of `pieces`' triangles (and only for
    /// those: the others are traced).
    ///
    /// The lines are met by one plane `P` for the region (normal: the
    /// corners' triangles' mean; offset: halfway between the region's
    /// lowest and highest points along it), and the shading is carried from
    /// there, widened by what a line that meets a triangle `k` of the
    /// pieces can differ by. Only the part of `k` the cell's lines can
    /// reach counts (`k` clipped to the box of the lines' hits on its
    /// plane: a convex polygon `R_k`):
    /// - the hit: the line meets `k` at `q_k = q_P + (t_k - t_P) d` with
    ///   `t_k - t_P = (n_P . q_k - w_P) / (n_P . d)`; `q_k` lies in `R_k`,
    ///   so `|t_k - t_P| <= max over R_k's vertices |n_P . v - w_P| /
    ///   min |n_P . d|` (the surface's curvature over the reachable part);
    /// - the shading normal before it is normalised: the renderer blends
    ///   `k`'s corner normals by the hit's barycentric coordinates in `k`,
    ///   an affine function of the point over `k`; one affine field `N` is
    ///   fitted to those blends at every `R_k`'s vertices (least squares),
    ///   and `blend - N` is affine over `k`, so over `R_k` it is largest at
    ///   a vertex: `N` at the widened hit, widened per component by the
    ///   largest such difference (`patch::NormalField`);
    /// - the geometric normal (used only for signs: facing, the lifted
    ///   point, lights behind the surface): within `max |n_k - n_b|` of the
    ///   base triangle `b`'s (the template tree's root).
    ///
    /// The widths enter the forms as bounded unknowns (`Aff::interval`: a
    /// remainder, and a jet's non-smooth part), so the shading over the
    /// widened forms bounds every covered line, whatever triangle it meets:
    /// crossing an edge is a kink, which the widths pay for. A required
    /// triangle (a corner's) seen edge-on or from behind by some line of
    /// the cell fails the cell; an optional one is kept only if it is seen
    /// from the front and widens nothing beyond what the required ones do.
    /// Returns the hit and, per triangle kept, its points (the origins of
    /// its shadow rays).
    fn patch_hit(&self, fam: &Family, pieces: &Pieces, front: bool) -> Outcome<(Hit, Vec<PieceTriangle>)> {
        let smooth = |t: u32| match self.geometry.surface(self.w.scene, t) {
            Surface::Smooth { polygon, normals } => Ok((polygon, normals)),
            _ => Err(Failure::Topology),
        };
        let (base, _) = smooth(pieces.base)?;
        // The region's plane: its triangles' mean normal (the corners'
        // triangles', each turned to b's side), so that the points' heights
        // over it are the surface's curvature, not its tilt.
        let facing = |n: DVec3| if n.dot(base.normal) < 0.0 { -n } else { n };
        let normal = pieces
            .required
            .iter()
            .filter_map(|&t| smooth(t).ok().map(|(p, _)| facing(p.normal)))
            .sum::<DVec3>()
            .try_normalize()
            .unwrap_or(base.normal);
        // Per triangle: its vertices; the part of it the cell's lines can
        // reach (the triangle clipped to the box of the lines' hits on its
        // plane) as a polygon, with the renderer's normal blend at its
        // vertices; the range of their heights along `normal`; its normal's
        // deviation from b's. The blend and the height are affine in the
        // point, so over the reachable part they lie within their values at
        // the polygon's vertices.
        type Measured = (u32, [DVec3; 3], Vec<(DVec3, DVec3)>, (f64, f64), DVec3);
        // Ranges are all the measures need: the family without its jets.
        let plain = Family {
            origin: fam.origin.map(Aff::plain),
            dir: fam.dir.map(Aff::plain),
            weight: fam.weight,
            media: Vec::new(),
            leaves: fam.leaves,
        };
        let measure = |t: u32| -> Outcome<Measured> {
            let (poly, normals) = smooth(t)?;
            consistent(&plain.dir.dot_const(poly.normal), front)?;
            let v = [poly.vertices[0], poly.vertices[1], poly.vertices[2]];
            let (on_plane, _) = plane_hit(&plain, &poly, front)?;
            let (reach_lo, reach_hi) = on_plane.bounds();
            let reached = clip_to_box(v.to_vec(), reach_lo, reach_hi);
            if reached.is_empty() {
                return Err(Failure::Silhouette);
            }
            let blend = barycentric_blend(&poly, &normals);
            let samples: Vec<(DVec3, DVec3)> = reached.into_iter().map(|x| (x, blend(x))).collect();
            let heights = samples.iter().map(|(x, _)| normal.dot(*x));
            let range = heights.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), h| (a.min(h), b.max(h)));
            Ok((t, v, samples, range, (poly.normal - base.normal).abs()))
        };
        let mut kept = Vec::with_capacity(pieces.required.len() + pieces.optional.len());
        for &t in &pieces.required {
            kept.push(measure(t)?);
        }
        let ((lo, hi), normal_dev) = kept
            .iter()
            .fold(((f64::INFINITY, f64::NEG_INFINITY), DVec3::ZERO), |((lo, hi), g), k| {
                ((lo.min(k.3.0), hi.max(k.3.1)), g.max(k.4))
            });
        for &t in &pieces.optional {
            if let Ok(k) = measure(t)
                && k.3.0 >= lo
                && k.3.1 <= hi
                && k.4.cmple(normal_dev).all()
            {
                kept.push(k);
            }
        }
        // The lines meet the plane halfway between the region's lowest and
        // highest points; any point of the region lies within `height` of
        // it.
        let mid = Polygon {
            normal,
            w: 0.5 * (lo + hi),
            vertices: Vec::new(),
        };
        let height = 0.5 * (hi - lo);
        let (q_b, t_b) = plane_hit(fam, &mid, front)?;
        let denom = fam.dir.dot_const(normal);
        let slowest = denom.lo().abs().min(denom.hi().abs());
        let dt = height / slowest;
        if !dt.is_finite() {
            return Err(Failure::Silhouette);
        }
        let spread = |x: Aff, w: f64| if w > 0.0 { x.add(Aff::interval(-w, w)) } else { x };
        let spread3 = |x: AVec3, w: DVec3| AVec3::new(spread(x.x, w.x), spread(x.y, w.y), spread(x.z, w.z));
        let q = if dt > 0.0 {
            q_b.add(fam.dir.times(Aff::interval(-dt, dt)))
        } else {
            q_b
        };
        let t = spread(t_b, dt);
        // The corner normals as one affine field over the region, and how
        // far any triangle's blend strays from it.
        let samples: Vec<(DVec3, DVec3)> = kept.iter().flat_map(|k| k.2.iter().copied()).collect();
        let field = NormalField::fit(normal, &samples).ok_or(Failure::Silhouette)?;
        let blend = spread3(field.at_form(&q), field.deviation(&samples));
        let n = blend.normalize().ok_or(Failure::Silhouette)?;
        // The renderer turns each triangle's normal to its own side: one
        // side for all of them, or no proof.
        let mut sides = kept
            .iter()
            .map(|k| n.dot_const((k.1[1] - k.1[0]).cross(k.1[2] - k.1[0])).sign());
        let first = sides.next().flatten().ok_or(Failure::Silhouette)?;
        if !sides.all(|side| side == Some(first)) {
            return Err(Failure::Silhouette);
        }
        let shading = if first { n } else { n.scale(-1.0) };
        let hit = Hit {
            q,
            t,
            geometric: spread3(AVec3::constant(base.normal), normal_dev),
            shading,
            magnitude: kept
                .iter()
                .map(|k| self.geometry.magnitude[k.0 as usize])
                .fold(0.0, f64::max),
            exclude: Exclude::None,
        };
        Ok((hit, kept.into_iter().map(|k| (k.0, k.1)).collect()))
    }

    /// Whether every line of the cell meets the triangles `pieces` (all
    /// seen from the `front` side by every line, as `patch_hit` checked):
    /// the number of times a line crosses them changes only where it
    /// crosses the edge of the pieces' union or grazes a triangle, so if no
    /// line crosses a boundary edge (an edge of one piece only: every line
    /// meets that piece's plane on one side of it), the count is the same
    /// for every line of the cell, and corner 0 meets them.
    fn pieces_cover(&self, fam: &Family, pieces: &[PieceTriangle], front: bool) -> bool {
        // The vertices are the renderer's f32 ones, widened exactly.
        let key = |a: DVec3, b: DVec3| edge_key(a.as_vec3(), b.as_vec3());
        let mut edges: std::collections::HashMap<_, u32> = std::collections::HashMap::new();
        for (_, v) in pieces {
            for k in 0..3 {
                *edges.entry(key(v[k], v[(k + 1) % 3])).or_default() += 1;
            }
        }
        pieces.iter().all(|(t, v)| {
            let Surface::Smooth { polygon, .. } = self.geometry.surface(self.w.scene, *t) else {
                return false;
            };
            let Ok((q, _)) = plane_hit(fam, &polygon, front) else {
                return false;
            };
            (0..3).all(|k| {
                let (a, b) = (v[k], v[(k + 1) % 3]);
                edges[&key(a, b)] > 1 || q.add_const(-a).dot_const(polygon.normal.cross(b - a)).sign().is_some()
            })
        })
    }

    /// Where the family meets `surface`, for all of its rays.
    fn hit(&self, fam: &Family, surface: &Surface, primitive: u32, front: bool) -> Outcome<Hit> {
        let magnitude = self.geometry.magnitude[primitive as usize];
        match surface {
            Surface::Flat(p) | Surface::Smooth { polygon: p, .. } => {
                let (q, t) = plane_hit(fam, p, front)?;
                for (m, v) in p.edges() {
                    if q.add_const(-v).dot_const(m).lo() < 0.0 {
                        return Err(Failure::Silhouette);
                    }
                }
                let geometric = AVec3::constant(p.normal);
                let (shading, exclude) = match surface {
                    Surface::Smooth { normals, .. } => (smooth_normal(&q, p, normals)?, Exclude::Primitive(primitive)),
                    _ => (geometric, Exclude::Plane(p.normal, p.w)),
                };
                Ok(Hit {
                    q,
                    t,
                    geometric,
                    shading,
                    magnitude,
                    exclude,
                })
            }
            Surface::Sphere { center, radius } => {
                let o = &fam.origin;
                let d = &fam.dir;
                let f = o.add_const(-*center);
                let a = d.dot(*d);
                let h = f.dot(*d).neg();
                let inv_a = a.recip().ok_or(Failure::Silhouette)?;
                let l = f.add(d.times(h.mul(inv_a)));
                let disc = a.mul(l.dot(l).neg().add_const(radius * radius));
                let s = disc.sqrt().ok_or(Failure::Silhouette)?;
                let (near, far) = (h.sub(s).mul(inv_a), h.add(s).mul(inv_a));
                let t = if front {
                    consistent(&near, false)?;
                    near
                } else {
                    // From inside: the near root behind, the far one ahead.
                    consistent(&near, true)?;
                    consistent(&far, false)?;
                    far
                };
                let q = o.add(d.times(t));
                let n = q.add_const(-*center).scale(1.0 / radius);
                Ok(Hit {
                    q,
                    t,
                    geometric: n,
                    shading: n,
                    magnitude,
                    exclude: Exclude::Primitive(primitive),
                })
            }
        }
    }

    /// The node's local radiance per channel (emission, ambient, lights);
    /// with `Texture::PerPixel` the terms the texture scales go to
    /// `out.diffuse_*` instead.
    fn local(&self, node: &RayNode, fam: &Family, at: &AtHit, texture: Texture, out: &mut Walk) -> Outcome<[Aff; 3]> {
        let s = at.s;
        let ke = Vec3::from_array(s.ke).as_dvec3();
        let mut local = [0, 1, 2].map(|c| Aff::constant(ke[c]));
        // The terms the texture scales: into `local` times a constant
        // factor, or apart (per pixel, at the root: weight 1).
        let (factor, per_pixel) = match texture {
            Texture::Constant(t) => (t, false),
            Texture::PerPixel => (DVec3::ONE, true),
        };
        let mut textured = [Aff::ZERO; 3];
        let mut textured_unknown = [Aff::ZERO; 3];
        let ambient = Vec3::from_array(self.w.params.ambient).as_dvec3();
        let (ka, kd, ks) = (
            Vec3::from_array(s.ka).as_dvec3() * factor,
            Vec3::from_array(s.kd).as_dvec3() * factor,
            Vec3::from_array(s.ks).as_dvec3(),
        );
        if !s.lit() {
            textured = [0, 1, 2].map(|c| Aff::constant(kd[c]));
        } else {
            for c in 0..3 {
                textured[c] = Aff::constant(ka[c] * ambient[c]);
            }
            let diffuse = per_pixel.then_some((&mut textured, &mut textured_unknown));
            self.lights(node, fam, at, (kd, ks), &mut local, diffuse, out)?;
        }
        for c in 0..3 {
            if per_pixel {
                out.diffuse_certain[c] = out.diffuse_certain[c].add(fam.weight[c].mul(textured[c]));
                out.diffuse_uncertain[c] = out.diffuse_uncertain[c].add(fam.weight[c].mul(textured_unknown[c]));
            } else {
                local[c] = local[c].add(textured[c]);
                out.uncertain[c] = out.uncertain[c].add(fam.weight[c].mul(textured_unknown[c]));
            }
        }
        Ok(local)
    }

    /// The lights' terms at a node into `local` (or `out.uncertain`), or,
    /// where `diffuse` is given, the diffuse ones into it apart (certain,
    /// unknown).
    #[allow(clippy::too_many_arguments)]
    fn lights(
        &self,
        node: &RayNode,
        fam: &Family,
        at: &AtHit,
        (kd, ks): (DVec3, DVec3),
        local: &mut [Aff; 3],
        mut diffuse: Option<(&mut [Aff; 3], &mut [Aff; 3])>,
        out: &mut Walk,
    ) -> Outcome<()> {
        let &AtHit {
            s,
            hit,
            lifted,
            n_g,
            n_s,
            pieces,
        } = at;
        // Where the shadow rays start, and what they leave: the hit's
        // lifted points, or on a patch each triangle's own (a shadow ray
        // from one triangle may be blocked by another of the patch).
        let origins: Vec<(AVec3, Exclude, &PieceOrigin)> = if pieces.is_empty() {
            vec![(lifted, hit.exclude, &NO_PIECE)]
        } else {
            pieces
                .iter()
                .map(|p| (p.points, Exclude::Primitive(p.triangle), p))
                .collect()
        };
        for (j, code) in node.lights.iter().enumerate() {
            let light = &self.w.scene.lights[j];
            let pos = Vec3::from_array(light.position).as_dvec3();
            let directional = light.kind == DIRECTIONAL;
            let (l, dist2, shadow_dir, end) = if directional {
                let l = AVec3::constant(-pos);
                (l, Aff::constant(1.0), l, End::Infinite)
            } else {
                let to = lifted.scale(-1.0).add_const(pos);
                let dist2 = to.dot(to);
                let inv_len = dist2.rsqrt().ok_or(Failure::Shadow)?;
                (to.times(inv_len), dist2, to, End::At(Aff::constant(1.0)))
            };
            let cos = n_s.dot(l);
            let ng_l = n_g.dot(l);
            let normal = Vec3::from_array(light.normal).as_dvec3();
            let emitted = if normal == DVec3::ZERO {
                Aff::constant(1.0)
            } else {
                l.dot_const(normal).neg()
            };
            if *code == LightCode::FacesAway {
                if ng_l.hi() <= 0.0 || cos.hi() <= 0.0 || emitted.hi() <= 0.0 {
                    continue;
                }
                return Err(Failure::Shadow);
            }
            if ng_l.lo() <= 0.0 || cos.lo() <= 0.0 || emitted.lo() <= 0.0 {
                return Err(Failure::Shadow);
            }
            let intensity = Vec3::from_array(light.intensity).as_dvec3();
            let falloff = emitted.mul(dist2.recip().ok_or(Failure::Shadow)?);
            let half = l.sub(fam.dir).normalize().ok_or(Failure::Silhouette)?;
            let n_h = n_s.dot(half);
            let lobe = if s.ns == 0.0 {
                match n_h.sign() {
                    Some(true) => Aff::constant(1.0),
                    Some(false) => Aff::ZERO,
                    None => return Err(Failure::Nonlinear),
                }
            } else {
                n_h.relu().powf(s.ns as f64).ok_or(Failure::Nonlinear)?
            };
            // Apart, or as one product (a tighter remainder).
            let (terms, diffuse_terms) = if diffuse.is_some() {
                (
                    [0, 1, 2].map(|c| falloff.scale(intensity[c]).mul(lobe.scale(ks[c]))),
                    [0, 1, 2].map(|c| falloff.scale(intensity[c]).mul(cos.scale(kd[c]))),
                )
            } else {
                let both = [0, 1, 2].map(|c| falloff.scale(intensity[c]).mul(cos.scale(kd[c]).add(lobe.scale(ks[c]))));
                (both, [Aff::ZERO; 3])
            };
            let shafts = self.shafts();
            // An emitter's sample lies just off its polygon, on the side its
            // shadow rays run: what lies behind that plane cannot block them.
            let behind = if normal == DVec3::ZERO {
                Exclude::None
            } else {
                Exclude::Behind(normal, normal.dot(pos))
            };
            let shadow_of = |o: &AVec3| {
                if directional {
                    shadow_dir
                } else {
                    o.scale(-1.0).add_const(pos)
                }
            };
            // A patch's triangle lit from its front: its shadow segments run
            // wholly in front of its plane (both ends are), so nothing wholly
            // behind the plane can block them, its convex neighbours
            // included (without this, every neighbour sharing an edge is a
            // candidate no shaft cull clears).
            let ahead = |p: &PieceOrigin| {
                let lit = if directional {
                    p.side.dot(-pos) > 0.0
                } else {
                    p.side.dot(pos) > p.beyond
                };
                if lit {
                    Exclude::Behind(p.side, p.beyond)
                } else {
                    Exclude::None
                }
            };
            let excludes = |leaves: Exclude, p: &PieceOrigin| [leaves, behind, ahead(p)];
            let visibility = match code {
                LightCode::Visible => {
                    // A patch triangle's shadow rays are the same for every
                    // cell (its points, lifted by its own offset): their cull
                    // is worked out once per triangle and light.
                    let cull = |(o, leaves, p): &(AVec3, Exclude, &PieceOrigin)| {
                        let run = || shafts.clear(o, &shadow_of(o), end, &excludes(*leaves, p));
                        if p.triangle == u32::MAX {
                            run()
                        } else {
                            self.geometry.piece_shadow(p.triangle, j as u32, run)
                        }
                    };
                    let clear = origins.iter().all(cull);
                    if !clear {
                        return Err(Failure::Shadow);
                    }
                    Some(1.0)
                }
                _ => {
                    let occluder = node.occluders.get(j).copied();
                    let each = origins.iter().map(|(o, leaves, p)| {
                        self.proven_visibility(occluder, o, &shadow_of(o), end, &excludes(*leaves, p))
                    });
                    each.reduce(|a, b| a.zip(b).filter(|(x, y)| x == y).map(|(x, _)| x))
                        .flatten()
                }
            };
            match visibility {
                Some(v) => {
                    for c in 0..3 {
                        local[c] = local[c].add(terms[c].scale(v));
                    }
                    if let Some((d, _)) = diffuse.as_mut() {
                        for c in 0..3 {
                            d[c] = d[c].add(diffuse_terms[c].scale(v));
                        }
                    }
                }
                None => {
                    // Blocked or filtered at the 16, unknown in between:
                    // anything from none of it to all of it.
                    for (c, term) in terms.iter().enumerate() {
                        let unknown = term.mul(Aff::interval(0.0, 1.0));
                        out.uncertain[c] = out.uncertain[c].add(fam.weight[c].mul(unknown));
                    }
                    if let Some((_, d)) = diffuse.as_mut() {
                        for c in 0..3 {
                            d[c] = d[c].add(diffuse_terms[c].mul(Aff::interval(0.0, 1.0)));
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// The visibility of a light blocked or filtered at the 16 corners,
    /// where every shadow segment of the cell provably passes through its
    /// occluder: 0 for an opaque one, its transmission squared for a glass
    /// sphere (crossed twice) with nothing else in the way.
    fn proven_visibility(
        &self,
        occluder: Option<u32>,
        o: &AVec3,
        d: &AVec3,
        end: End,
        exclude: &[Exclude; 3],
    ) -> Option<f64> {
        let p = occluder.filter(|&p| p != u32::MAX)?;
        let shading = self.w.scene.surface(self.w.scene.primitive_surface(p));
        if shading.map_alpha != crate::scene::texture_table::NO_MAP {
            // A cut-out's holes let some shadow rays through: unknown.
            // Colour maps do not change what an opaque occluder blocks.
            return None;
        }
        let t_max = match end {
            End::At(t) => t.lo(),
            End::Infinite => f64::INFINITY,
        };
        match self.geometry.surface(self.w.scene, p) {
            Surface::Sphere { center, radius } => {
                let f = o.add_const(-center);
                let dd = d.dot(*d);
                let inv = dd.recip()?;
                let fd = f.dot(*d);
                let dist2 = f.dot(f).sub(fd.mul(fd).mul(inv));
                let tc = fd.neg().mul(inv);
                if !(dist2.hi() < radius * radius && tc.lo() > 0.0 && tc.hi() < t_max) {
                    return None;
                }
                if !shading.transmits() {
                    return Some(0.0);
                }
                // Through glass: twice its transmission, if nothing else is
                // in the way (grey glass only: one factor for all channels).
                let kt = Vec3::from_array(shading.kt);
                if kt.x != kt.y || kt.y != kt.z {
                    return None;
                }
                let clear =
                    self.shafts()
                        .clear(o, d, end, &[exclude[0], exclude[1], exclude[2], Exclude::Primitive(p)]);
                clear.then_some((kt.x as f64).powi(2))
            }
            Surface::Flat(poly) | Surface::Smooth { polygon: poly, .. } => {
                if shading.transmits() {
                    return None;
                }
                let denom = d.dot_const(poly.normal);
                let t = Aff::constant(poly.w).sub(o.dot_const(poly.normal)).mul(denom.recip()?);
                if !(t.lo() > 0.0 && t.hi() < t_max) {
                    return None;
                }
                let x = o.add(d.times(t));
                poly.edges()
                    .all(|(m, v)| x.add_const(-v).dot_const(m).lo() >= 0.0)
                    .then_some(0.0)
            }
        }
    }

    /// The node's reflected and refracted families, as the renderer makes
    /// its rays (`Whitted::shade`).
    fn children(&self, node: &RayNode, fam: &Family, at: &AtHit, delta: Aff) -> Outcome<Vec<(RayKind, Family)>> {
        let &AtHit {
            s,
            hit,
            lifted,
            n_g,
            n_s,
            pieces,
        } = at;
        let mut out = Vec::new();
        if !(node.reflected || node.refracted || node.tir) {
            return Ok(out);
        }
        if !pieces.is_empty() {
            // Patches neither reflect nor refract (`patch`): a tree that
            // says otherwise is not the patch's.
            return Err(Failure::Topology);
        }
        let fresnel = self.w.params.flags & FRESNEL != 0;
        let kr0 = Vec3::from_array(s.kr).as_dvec3();
        let mut kr = [0, 1, 2].map(|c| Aff::constant(kr0[c]));
        let mut kt = [0, 1, 2].map(|c| Aff::constant(s.kt[c] as f64));
        let cos_i = fam.dir.dot(n_s).neg();
        let d = fam.dir;
        let mut transmitted: Option<(AVec3, Vec<u32>)> = None;
        let transmits = s.kt.iter().any(|&k| k > 0.0);
        let surface_id = node.hit.map_or(u32::MAX, |h| h.surface);
        if s.refracts() && transmits {
            let front = node.hit.is_some_and(|h| h.front);
            let ni = |media: &[u32]| media.last().map_or(1.0, |&m| self.w.scene.surface(m).ni as f64);
            let (n1, n2, inner) = if front {
                let mut inner = fam.media.clone();
                if inner.len() < crate::whitted::whitted::MAX_MEDIA {
                    inner.push(surface_id);
                }
                (ni(&fam.media), s.ni as f64, inner)
            } else {
                let mut inner = fam.media.clone();
                if let Some(k) = inner.iter().rposition(|&m| m == surface_id) {
                    inner.remove(k);
                }
                (s.ni as f64, ni(&inner), inner)
            };
            let eta = n1 / n2;
            let sin2_t = cos_i.mul(cos_i).neg().add_const(1.0).relu().scale(eta * eta);
            if fresnel {
                // Under total internal reflection Schlick's reflectance is 1.
                let f = if node.tir {
                    Aff::constant(1.0)
                } else {
                    schlick(&cos_i, &sin2_t, n1, n2)?
                };
                kr = [f; 3];
                kt = kt.map(|k| k.mul(f.neg().add_const(1.0)));
            }
            if node.tir {
                if sin2_t.lo() < 1.0 {
                    return Err(Failure::Tir);
                }
                kr = [0, 1, 2].map(|c| kr[c].add(kt[c]).min_one());
            } else {
                if sin2_t.hi() >= 1.0 {
                    return Err(Failure::Tir);
                }
                let t_dir = if eta == 1.0 {
                    d
                } else {
                    let cos_t = sin2_t.neg().add_const(1.0).sqrt().ok_or(Failure::Tir)?;
                    d.scale(eta)
                        .add(n_s.times(cos_i.scale(eta).sub(cos_t)))
                        .normalize()
                        .ok_or(Failure::Silhouette)?
                };
                consistent(&t_dir.dot(n_g), true)?;
                transmitted = Some((t_dir, inner));
            }
        } else if transmits {
            transmitted = Some((d, fam.media.clone()));
        }
        if !s.refracts() && fresnel && kr0.max_element() > 0.0 {
            let m = cos_i
                .neg()
                .add_const(1.0)
                .relu()
                .min_one()
                .powf(5.0)
                .ok_or(Failure::Nonlinear)?;
            kr = [0, 1, 2].map(|c| m.scale(1.0 - kr0[c]).add_const(kr0[c]));
        }
        let leaves = hit.exclude;
        if node.reflected {
            let r = d.sub(n_s.times(d.dot(n_s).scale(2.0)));
            consistent(&r.dot(n_g), false)?;
            out.push((
                RayKind::Reflection,
                Family {
                    origin: lifted,
                    dir: r,
                    weight: [0, 1, 2].map(|c| fam.weight[c].mul(kr[c])),
                    media: fam.media.clone(),
                    leaves,
                },
            ));
        }
        if node.refracted {
            let (t_dir, inner) = transmitted.ok_or(Failure::Topology)?;
            out.push((
                RayKind::Refraction,
                Family {
                    origin: hit.q.sub(n_g.times(delta)),
                    dir: t_dir,
                    weight: [0, 1, 2].map(|c| fam.weight[c].mul(kt[c])),
                    media: inner,
                    leaves,
                },
            ));
        }
        Ok(out)
    }
}

/// What the walk over a tree computes.
struct Walk {
    certain: [Aff; 3],
    uncertain: [Aff; 3],
    /// A textured root's terms its texture scales (`Texture::PerPixel`).
    diffuse_certain: [Aff; 3],
    diffuse_uncertain: [Aff; 3],
    /// The smallest and largest factor of that texture (1 and 1 without).
    texture_range: (DVec3, DVec3),
    root: RootFace,
    hits: (DVec3, DVec3),
    hit_points: Option<AVec3>,
    reprojectable: bool,
    /// The radiance's linear variation along (a, c) and along (b, d): a
    /// 4-way split halves the pair it varies more along.
    linear_ac: f64,
    linear_bd: f64,
    /// On a patch, the triangles the bound covers.
    pieces: Vec<u32>,
}

/// The most triangles of a patch one cell's bound covers; a cell whose
/// corners alone hit more is split.
const MAX_PIECES: usize = 24;

/// A triangle of a patch's bound and its vertices.
type PieceTriangle = (u32, [DVec3; 3]);

/// The triangles of a patch a cell's bound is to cover (`patch_pieces`).
struct Pieces {
    /// The template tree's root triangle: the bound is carried from it.
    base: u32,
    /// The corners' triangles: each must take the bound.
    required: Vec<u32>,
    /// Triangles around them: kept where the bound can be carried over.
    optional: Vec<u32>,
}

/// Two trees with the same topology and, node by node, the same
/// primitive where the surface is a smooth triangle or a flat face's
/// polygon (a polygon split into non-coplanar triangles has one id but
/// several planes).
/// At the root, a smooth patch's triangles are one surface (`patch`).
fn same_surfaces(geometry: &SceneGeometry, a: &RayTree, b: &RayTree) -> bool {
    let same_patch = |p: u32, q: u32| {
        let patch = geometry.triangle_patch[p as usize];
        patch != NO_PATCH && patch == geometry.triangle_patch[q as usize]
    };
    a.same_topology(b)
        && a.nodes
            .iter()
            .zip(&b.nodes)
            .enumerate()
            .all(|(i, (x, y))| match (x.hit, y.hit) {
                (Some(p), Some(q)) => {
                    p.face != crate::whitted::scene::SMOOTH_FACE
                        || p.primitive == q.primitive
                        || (i == 0 && same_patch(p.primitive, q.primitive))
                }
                _ => true,
            })
}

/// Where the family meets the plane of `p` (from the side `front` says).
fn plane_hit(fam: &Family, p: &Polygon, front: bool) -> Outcome<(AVec3, Aff)> {
    let denom = fam.dir.dot_const(p.normal);
    consistent(&denom, front)?;
    let inv = denom.recip().ok_or(Failure::Silhouette)?;
    let t = Aff::constant(p.w).sub(fam.origin.dot_const(p.normal)).mul(inv);
    if t.lo() <= 0.0 {
        return Err(Failure::Silhouette);
    }
    Ok((fam.origin.add(fam.dir.times(t)), t))
}

/// The interpolated shading normal of a smooth triangle at `q`, as the
/// renderer computes it (barycentric blend, normalised, turned to the
/// triangle's side).
fn smooth_normal(q: &AVec3, p: &Polygon, normals: &[DVec3; 3]) -> Outcome<AVec3> {
    let (v0, k1, k2) = p.barycentric_duals();
    let rel = q.add_const(-v0);
    let b1 = rel.dot_const(k1);
    let b2 = rel.dot_const(k2);
    let b0 = b1.add(b2).neg().add_const(1.0);
    let blend = AVec3::constant(normals[0])
        .times(b0)
        .add(AVec3::constant(normals[1]).times(b1))
        .add(AVec3::constant(normals[2]).times(b2));
    let n = blend.normalize().ok_or(Failure::Silhouette)?;
    match n.dot_const(p.normal).sign() {
        Some(true) => Ok(n),
        Some(false) => Ok(n.scale(-1.0)),
        None => Err(Failure::Silhouette),
    }
}

/// The texture factor of a surface over hit points `q`, where every
/// point (with room for the renderer's rounding) lies in one check.
fn constant_texture(s: &Shading, q: &AVec3) -> Option<DVec3> {
    let [lo, hi] = [0, 1].map(|k| DVec3::from_array(q.axes().map(|a| if k == 0 { a.lo() } else { a.hi() })));
    let margin = 1e-4 * lo.abs().max(hi.abs()).max_element().max(1.0);
    let cube = |p: DVec3| ((p - Vec3::from_array(s.checker_origin).as_dvec3()) * s.checker_inv_size as f64).floor();
    let centre = 0.5 * (lo + hi);
    (cube(lo - DVec3::splat(margin)) == cube(hi + DVec3::splat(margin))).then(|| s.texture(centre.as_vec3()).as_dvec3())
}

/// Schlick's reflectance over the family (`optics::schlick`).
fn schlick(cos_i: &Aff, sin2_t: &Aff, n1: f64, n2: f64) -> Outcome<Aff> {
    let r0 = ((n1 - n2) / (n1 + n2)).powi(2);
    let cos = if n1 > n2 {
        if sin2_t.hi() >= 1.0 {
            return Err(Failure::Tir);
        }
        sin2_t.neg().add_const(1.0).sqrt().ok_or(Failure::Tir)?
    } else {
        *cos_i
    };
    let m = cos
        .neg()
        .add_const(1.0)
        .relu()
        .min_one()
        .powf(5.0)
        .ok_or(Failure::Nonlinear)?;
    Ok(m.scale(1.0 - r0).add_const(r0))
}
