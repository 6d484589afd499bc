//! Any-hit packets of up to 16 rays sharing an origin (AO rays, shadow rays
//! towards a point): which of them hit something with `0 < t < t_max`.
//!
//! Each lane keeps its own interval `[t_min, t_max]` in the current cell
//! and makes, at every interior node, exactly the decision the single-ray
//! traversal (`traverse.rs`) makes for its ray: the same distance to the
//! split plane, the same slack, the same NaN rule, the same check of a
//! deferred cell's entry against the ray's limit. A lane therefore visits
//! exactly the cells its single ray would (until either finds a hit) and
//! tests their triangles with the watertight test's operations in the same
//! order, so its answer is the single ray's, bit for bit. Only the order in
//! which the packet visits cells differs, which cannot change whether a ray
//! hits anything: with a shared origin the child holding the origin comes
//! first for every lane, and lanes that want one child only are masked off
//! the other.
//!
//! The lanes run in AVX-512, AVX2, SSE2 or plain scalars (`simd::Isa`),
//! chosen at run time; `occluded` takes the instruction set so that tests
//! can run each.

use std::mem::MaybeUninit;

use glam::Vec3;

use super::KdTree;
use super::node::MAX_TREE_DEPTH;
use super::traverse::{NoCounts, SingleRay, TRAVERSAL_SLACK};
use super::watertight::ShearedRay;
use crate::geom::aabb::Aabb;
use crate::geom::ray::flush_subnormals;
use crate::geom::simd::{Isa, Kernel, Lanes, Mask, dispatch};

/// Rays per packet.
pub const LANES: usize = 16;

/// Which of the rays `dirs` (at most 16) from `origin` hit a triangle with
/// `0 < t < t_max`: bit r for `dirs[r]`, equal to `tree.any_hit` ray for ray.
/// `isa` picks the instruction set (`Isa::best()` normally; one this CPU
/// lacks is replaced by the best it has).
pub fn occluded(tree: &KdTree, origin: Vec3, dirs: &[Vec3], t_max: f32, isa: Isa) -> u16 {
    struct One<'a> {
        tree: &'a KdTree,
        origin: Vec3,
        dirs: &'a [Vec3],
        t_max: f32,
    }
    impl Kernel for One<'_> {
        type Out = u16;
        #[inline(always)]
        fn run<V: Lanes>(self) -> u16 {
            occluded_in::<V>(self.tree, self.origin, self.dirs, self.t_max)
        }
    }
    dispatch(
        isa,
        One {
            tree,
            origin,
            dirs,
            t_max,
        },
    )
}

/// `occluded` in lanes `V`, for kernels that run many packets in one
/// instruction set (`raycast::packets`, through `Accel::occluded_in`).
#[inline(always)]
pub fn occluded_in<V: Lanes>(tree: &KdTree, origin: Vec3, dirs: &[Vec3], t_max: f32) -> u16 {
    assert!(dirs.len() <= LANES, "at most {LANES} rays per packet");
    if dirs.is_empty() {
        return 0;
    }
    let mut flushed = [Vec3::ZERO; LANES];
    let n = flush_subnormals(dirs, &mut flushed);
    let dirs = &flushed[..n];
    let rays = match Rays::<V>::new(&tree.bounds, tree.frame_scale, origin, dirs, t_max) {
        Some(rays) => rays,
        None => SharedOrigin::new(tree, origin, dirs, t_max).lanes(),
    };
    if rays.live == 0 {
        return 0;
    }
    traverse(tree, &rays)
}

/// The packet's lanes as vectors (the BVH's packets, `bvh::occlusion`,
/// share them).
pub(crate) struct Rays<V: Lanes> {
    pub origin: Vec3,
    pub t_max: f32,
    /// Lanes whose ray meets the scene's box.
    pub live: u16,
    t_min: V,
    t_cell_max: V,
    pub inv: [V; 3],
    below_on_plane: [V::M; 3],
    pub shear: Shear<V>,
    pub frame_origin: Vec3,
    pub scale: f32,
}

impl<V: Lanes> Rays<V> {
    /// Lane `r` as the single-ray traversal's ray (`traverse::SingleRay`).
    #[inline(always)]
    fn single(&self, r: usize) -> SingleRay {
        let lane = |v: V| lane_of(v, r);
        let bit = |m: V::M| bit_of(m, r);
        let k = &self.shear.k;
        let (kx, ky, kz) = (axis_of(k[0], r), axis_of(k[1], r), axis_of(k[2], r));
        let o = self.origin;
        SingleRay {
            o4: [o.x, o.y, o.z, 0.0],
            inv4: [lane(self.inv[0]), lane(self.inv[1]), lane(self.inv[2]), 0.0],
            below_on_plane: [
                bit(self.below_on_plane[0]),
                bit(self.below_on_plane[1]),
                bit(self.below_on_plane[2]),
                false,
            ],
            ray: ShearedRay {
                origin: self.frame_origin,
                kx,
                ky,
                kz,
                sx: lane(self.shear.sx),
                sy: lane(self.shear.sy),
                sz: lane(self.shear.sz),
                scale: self.scale,
                inv_scale: 1.0 / self.scale,
            },
        }
    }

    /// The single ray's set-up (`KdTree::traverse`, `ShearedRay::in_frame`)
    /// for all lanes at once, or `None` if a direction has a zero component
    /// (`SharedOrigin` then does it lane by lane, as `Aabb::clip_ray` takes
    /// another path for such rays).
    #[inline(always)]
    pub fn new(bounds: &Aabb, frame_scale: f32, origin: Vec3, dirs: &[Vec3], t_max: f32) -> Option<Self> {
        let d: [V; 3] = [column(dirs, 0), column(dirs, 1), column(dirs, 2)];
        Self::from_columns(bounds, frame_scale, origin, d, dirs.len(), t_max)
    }

    /// `new` for the first `n` lanes of directions given as columns (x, y
    /// and z of every lane; lanes from `n` on repeat a ray, as `new` makes
    /// them).
    #[inline(always)]
    pub fn from_columns(
        bounds: &Aabb,
        frame_scale: f32,
        origin: Vec3,
        d: [V; 3],
        n: usize,
        t_max: f32,
    ) -> Option<Self> {
        let zero = V::splat(0.0);
        if d[0].eq(zero).any() || d[1].eq(zero).any() || d[2].eq(zero).any() {
            return None;
        }
        let one = V::splat(1.0);
        let inv = [one.div(d[0]), one.div(d[1]), one.div(d[2])];
        // Aabb::clip_ray: the slabs' entries and exits (no NaN arises).
        let (lo, hi) = (bounds.min - origin, bounds.max - origin);
        let (x, y, z) = (
            slab(lo.x, hi.x, inv[0]),
            slab(lo.y, hi.y, inv[1]),
            slab(lo.z, hi.z, inv[2]),
        );
        // Widened before the test, as Aabb::clip_ray_widened.
        let t0 = x.0.max(y.0).max(z.0).max(zero).mul(V::splat(1.0 - TRAVERSAL_SLACK));
        let t1 =
            x.1.min(y.1)
                .min(z.1)
                .min(V::splat(t_max))
                .mul(V::splat(1.0 + TRAVERSAL_SLACK));
        let live = t0.le(t1).bits() & (((1u32 << n) - 1) as u16);
        // shear_axes: kz the largest |component| (x, then y on ties), kx and
        // ky the next two, swapped where d[kz] < 0.
        let abs = [
            d[0].max(zero.sub(d[0])),
            d[1].max(zero.sub(d[1])),
            d[2].max(zero.sub(d[2])),
        ];
        let kz0 = abs[0].ge(abs[1]).and(abs[0].ge(abs[2]));
        let kz1 = abs[1].ge(abs[2]).and_not(kz0);
        let kz2 = V::M::from_bits(!0).and_not(kz0).and_not(kz1);
        let pick = pick_of::<V>;
        let dz = pick(kz0, kz1, &d);
        let neg = dz.lt(zero);
        let kx0 = kz2.and_not(neg).or(kz1.and(neg));
        let kx1 = kz0.and_not(neg).or(kz2.and(neg));
        let ky0 = kz1.and_not(neg).or(kz2.and(neg));
        let ky1 = kz2.and_not(neg).or(kz0.and(neg));
        let shear = Shear {
            sx: pick(kx0, kx1, &d).div(dz),
            sy: pick(ky0, ky1, &d).div(dz),
            sz: one.div(dz),
            k: [[kx0, kx1], [ky0, ky1], [kz0, kz1]],
            limit: V::splat(t_max * frame_scale),
        };
        Some(Rays {
            origin,
            t_max,
            live,
            t_min: t0,
            t_cell_max: t1,
            inv,
            below_on_plane: [d[0].le(zero), d[1].le(zero), d[2].le(zero)],
            shear,
            frame_origin: origin * frame_scale,
            scale: frame_scale,
        })
    }
}

/// The packet's per-lane constants computed lane by lane, for packets with
/// a zero direction component (unused and dead lanes repeat a live lane's
/// values, so their arithmetic stays finite).
struct SharedOrigin {
    origin: Vec3,
    t_max: f32,
    /// Lanes whose ray meets the tree's box.
    live: u16,
    t_min: [f32; LANES],
    t_cell_max: [f32; LANES],
    inv: [[f32; LANES]; 3],
    /// Per axis: lanes whose direction component is <= 0 (the single ray's
    /// choice of first child when the origin lies on a split plane).
    below_on_plane: [u16; 3],
    sx: [f32; LANES],
    sy: [f32; LANES],
    sz: [f32; LANES],
    /// The shear axes as lane masks: `k[i][0]` lanes whose axis i is x,
    /// `k[i][1]` those whose axis i is y (else z); i = kx, ky, kz.
    k: [[u16; 2]; 3],
    /// The origin in the intersection frame, and the frame's scale.
    frame_origin: Vec3,
    scale: f32,
}

impl SharedOrigin {
    fn new(tree: &KdTree, origin: Vec3, dirs: &[Vec3], t_max: f32) -> Self {
        let mut s = SharedOrigin {
            origin,
            t_max,
            live: 0,
            t_min: [0.0; LANES],
            t_cell_max: [0.0; LANES],
            inv: [[1.0; LANES]; 3],
            below_on_plane: [0; 3],
            sx: [0.0; LANES],
            sy: [0.0; LANES],
            sz: [1.0; LANES],
            k: [[0; 2]; 3],
            frame_origin: origin * tree.frame_scale,
            scale: tree.frame_scale,
        };
        let mut first_live = None;
        for (r, &dir) in dirs.iter().enumerate() {
            // The single ray's set-up (`KdTree::traverse`), lane by lane.
            let Some((t0, t1)) = tree.bounds.clip_ray_widened(origin, dir, 0.0, t_max, TRAVERSAL_SLACK) else {
                continue;
            };
            s.live |= 1 << r;
            first_live.get_or_insert(r);
            s.t_min[r] = t0;
            s.t_cell_max[r] = t1;
            let inv = dir.recip();
            for a in 0..3 {
                s.inv[a][r] = inv[a];
                s.below_on_plane[a] |= ((dir[a] <= 0.0) as u16) << r;
            }
            let sheared = ShearedRay::in_frame(origin, dir, tree.frame_scale);
            (s.sx[r], s.sy[r], s.sz[r]) = (sheared.sx, sheared.sy, sheared.sz);
            for (i, axis) in [sheared.kx, sheared.ky, sheared.kz].into_iter().enumerate() {
                if axis < 2 {
                    s.k[i][axis] |= 1 << r;
                }
            }
        }
        // Dead lanes copy a live one's numbers (a zero direction component
        // gives infinite inverses; masked lanes may compute with them, but
        // finite copies keep the arithmetic free of surprises).
        if let Some(l) = first_live {
            for r in (0..LANES).filter(|r| s.live & (1 << r) == 0) {
                s.t_min[r] = s.t_min[l];
                s.t_cell_max[r] = s.t_cell_max[l];
                for a in 0..3 {
                    s.inv[a][r] = s.inv[a][l];
                }
                (s.sx[r], s.sy[r], s.sz[r]) = (s.sx[l], s.sy[l], s.sz[l]);
            }
        }
        s
    }

    #[inline(always)]
    fn lanes<V: Lanes>(&self) -> Rays<V> {
        Rays {
            origin: self.origin,
            t_max: self.t_max,
            live: self.live,
            t_min: V::from_array(self.t_min),
            t_cell_max: V::from_array(self.t_cell_max),
            inv: [
                V::from_array(self.inv[0]),
                V::from_array(self.inv[1]),
                V::from_array(self.inv[2]),
            ],
            below_on_plane: [
                V::M::from_bits(self.below_on_plane[0]),
                V::M::from_bits(self.below_on_plane[1]),
                V::M::from_bits(self.below_on_plane[2]),
            ],
            shear: Shear {
                sx: V::from_array(self.sx),
                sy: V::from_array(self.sy),
                sz: V::from_array(self.sz),
                k: [
                    [V::M::from_bits(self.k[0][0]), V::M::from_bits(self.k[0][1])],
                    [V::M::from_bits(self.k[1][0]), V::M::from_bits(self.k[1][1])],
                    [V::M::from_bits(self.k[2][0]), V::M::from_bits(self.k[2][1])],
                ],
                // The single ray compares with `t_max * scale` (its best t is
                // t_max until it hits).
                limit: V::splat(self.t_max * self.scale),
            },
            frame_origin: self.frame_origin,
            scale: self.scale,
        }
    }
}

/// The lanes' shear constants as vectors.
pub(crate) struct Shear<V: Lanes> {
    sx: V,
    sy: V,
    sz: V,
    k: [[V::M; 2]; 3],
    limit: V,
}

impl<V: Lanes> Shear<V> {
    /// Coordinate `axis i` (kx, ky or kz) of `p`, per lane.
    #[inline(always)]
    fn pick(&self, p: [f32; 3], i: usize) -> V {
        let [m0, m1] = self.k[i];
        V::select(m0, V::splat(p[0]), V::select(m1, V::splat(p[1]), V::splat(p[2])))
    }

    /// The lanes of `active` that hit the triangle (vertices in the frame,
    /// origin subtracted): `ShearedRay::intersect` lane by lane, the same
    /// operations in the same order; and each lane's t in the frame
    /// (meaningful where it hits).
    /// `common`: the axes when every lane has the same (then a coordinate
    /// is one broadcast rather than two selects).
    #[inline(always)]
    pub fn hits(&self, a: [f32; 3], b: [f32; 3], c: [f32; 3], active: V::M, common: Option<[usize; 3]>) -> (V::M, V) {
        let (ok, t) = self.crossings(a, b, c, active, common);
        (ok.and(t.gt(V::splat(0.0))).and(t.lt(self.limit)), t)
    }

    /// The lanes of `active` whose line crosses the triangle on the
    /// direction's side (t >= 0 not yet checked, nor any limit), and t in
    /// the frame: what closest-hit packets (`bvh::packet`) compare with each
    /// lane's best so far.
    #[inline(always)]
    pub fn crossings(
        &self,
        a: [f32; 3],
        b: [f32; 3],
        c: [f32; 3],
        active: V::M,
        common: Option<[usize; 3]>,
    ) -> (V::M, V) {
        match common {
            Some(k) => self.hits_with(a, b, c, active, |p: [f32; 3], i| V::splat(p[k[i]])),
            None => self.hits_with(a, b, c, active, |p, i| self.pick(p, i)),
        }
    }

    #[inline(always)]
    fn hits_with(
        &self,
        a: [f32; 3],
        b: [f32; 3],
        c: [f32; 3],
        active: V::M,
        pick: impl Fn([f32; 3], usize) -> V,
    ) -> (V::M, V) {
        let (az0, bz0, cz0) = (pick(a, 2), pick(b, 2), pick(c, 2));
        let ax = pick(a, 0).sub(self.sx.mul(az0));
        let ay = pick(a, 1).sub(self.sy.mul(az0));
        let bx = pick(b, 0).sub(self.sx.mul(bz0));
        let by = pick(b, 1).sub(self.sy.mul(bz0));
        let cx = pick(c, 0).sub(self.sx.mul(cz0));
        let cy = pick(c, 1).sub(self.sy.mul(cz0));
        let u = cx.mul(by).sub(cy.mul(bx));
        let v = ax.mul(cy).sub(ay.mul(cx));
        let w = bx.mul(ay).sub(by.mul(ax));
        let zero = V::splat(0.0);
        let negative = u.lt(zero).or(v.lt(zero)).or(w.lt(zero));
        let positive = u.gt(zero).or(v.gt(zero)).or(w.gt(zero));
        // Inside: not (some edge negative and some positive).
        let mut ok = active.and_not(negative.and(positive));
        if !ok.any() {
            return (ok, zero);
        }
        let det = u.add(v).add(w);
        ok = ok.and_not(det.eq(zero));
        let az = self.sz.mul(az0);
        let bz = self.sz.mul(bz0);
        let cz = self.sz.mul(cz0);
        let t_scaled = u.mul(az).add(v.mul(bz)).add(w.mul(cz));
        let wrong_side = det
            .gt(zero)
            .and(t_scaled.le(zero))
            .or(det.lt(zero).and(t_scaled.ge(zero)));
        ok = ok.and_not(wrong_side);
        (ok, t_scaled.div(det))
    }
}

// Helpers of the lanes' set-up as functions, not closures: a closure that
// the compiler leaves out of line (or hands to `array::map`) is compiled
// without the dispatching function's instruction set, and every intrinsic
// in it becomes a call (on AVX2 that cost the AO packets a third).

/// Lane `r` of `v`.
#[inline(always)]
fn lane_of<V: Lanes>(v: V, r: usize) -> f32 {
    v.to_array()[r]
}

/// Whether lane `r` of `m` is set.
#[inline(always)]
fn bit_of<M: Mask>(m: M, r: usize) -> bool {
    m.bits() & (1 << r) != 0
}

/// The axis (0 x, 1 y, 2 z) a pair of axis masks gives lane `r`.
#[inline(always)]
fn axis_of<M: Mask>([m0, m1]: [M; 2], r: usize) -> usize {
    if bit_of(m0, r) {
        0
    } else if bit_of(m1, r) {
        1
    } else {
        2
    }
}

/// Component `a` of the directions, one per lane (the last repeated).
#[inline(always)]
fn column<V: Lanes>(dirs: &[Vec3], a: usize) -> V {
    let n = dirs.len();
    let mut c = [0.0; LANES];
    for (r, x) in c.iter_mut().enumerate() {
        *x = dirs[r.min(n - 1)][a];
    }
    V::from_array(c)
}

/// A slab's entry and exit distances along one axis.
#[inline(always)]
fn slab<V: Lanes>(lo: f32, hi: f32, inv: V) -> (V, V) {
    let (p, q) = (V::splat(lo).mul(inv), V::splat(hi).mul(inv));
    (p.min(q), p.max(q))
}

/// `v[0]` where `m0`, else `v[1]` where `m1`, else `v[2]`.
#[inline(always)]
fn pick_of<V: Lanes>(m0: V::M, m1: V::M, v: &[V; 3]) -> V {
    V::select(m0, v[0], V::select(m1, v[1], v[2]))
}

/// The live lanes' shear axes (kx, ky, kz), if they are all the same.
#[inline(always)]
pub(crate) fn common_axes<V: Lanes>(shear: &Shear<V>, live: u16) -> Option<[usize; 3]> {
    let mut k = [0usize; 3];
    for (i, [m0, m1]) in shear.k.iter().enumerate() {
        let (m0, m1) = (m0.bits() & live, m1.bits() & live);
        k[i] = match (m0, m1) {
            (m, 0) if m == live => 0,
            (0, m) if m == live => 1,
            (0, 0) => 2,
            _ => return None,
        };
    }
    Some(k)
}

/// A deferred cell: node, lanes, and their intervals.
type Deferred<V> = (u32, <V as Lanes>::M, V, V);

#[inline(always)]
fn traverse<V: Lanes>(tree: &KdTree, rays: &Rays<V>) -> u16 {
    let shear = &rays.shear;
    let inv = rays.inv;
    let below_on_plane = rays.below_on_plane;
    let (lo_slack, hi_slack) = (V::splat(1.0 - TRAVERSAL_SLACK), V::splat(1.0 + TRAVERSAL_SLACK));
    let t_limit = V::splat(rays.t_max);
    let zero = V::splat(0.0);
    let o = rays.origin.to_array();
    let fo = rays.frame_origin;
    // The live lanes' shear axes, if they are all the same.
    let common = common_axes(shear, rays.live);

    let mut alive = rays.live;
    let mut stack = [const { MaybeUninit::<Deferred<V>>::uninit() }; MAX_TREE_DEPTH];
    let mut sp = 0usize;
    let mut node_index = 0u32;
    let mut mask = V::M::from_bits(rays.live);
    let mut t_min = rays.t_min;
    let mut t_max = rays.t_cell_max;
    loop {
        let node = tree.nodes[node_index as usize];
        let lanes = mask.bits();
        if lanes.count_ones() == 1 {
            // One lane left in this subtree: the single-ray traversal goes
            // on from here with the lane's interval (the state its own
            // traversal would have here), at a third of the packet's cost
            // per node. Far from the origin most packets end this way.
            let r = lanes.trailing_zeros() as usize;
            let (a, b) = (t_min.to_array()[r], t_max.to_array()[r]);
            if tree
                .walk::<true, false, _>(&rays.single(r), node_index, a, b, rays.t_max, &mut NoCounts)
                .is_hit()
            {
                alive &= !lanes;
                if alive == 0 {
                    return rays.live;
                }
            }
        } else if !node.is_leaf() {
            let axis = node.axis();
            let split = node.split();
            let tp = V::splat(split - o[axis]).mul(inv[axis]);
            // The single ray's three cases, per lane.
            let first_only = tp.le(zero).or(tp.mul(lo_slack).gt(t_max));
            let second_only = tp.mul(hi_slack).lt(t_min).and_not(first_only);
            let both = V::M::from_bits(!0).and_not(first_only).and_not(second_only);
            let cut = both.and_not(tp.ne(tp));
            let first_max = V::select(cut, t_max.min(tp.mul(hi_slack)), t_max);
            let second_min = V::select(cut, t_min.max(tp.mul(lo_slack)), t_min);
            let first = mask.and_not(second_only);
            let second = mask.and_not(first_only);
            // A deferred second child is dropped at its pop when it starts
            // beyond the ray's limit (no hit yet: best t = t_max).
            let second = second.and_not(both.and_not(second_min.le(t_limit)));
            // Per lane, which child is its first.
            // Per lane, which child is its first: the origin's side, or on
            // the plane the direction's sign.
            let ((below, below_iv), (above, above_iv)) = if o[axis] != split {
                let firsts = (first, (t_min, first_max));
                let seconds = (second, (second_min, t_max));
                if o[axis] < split {
                    (firsts, seconds)
                } else {
                    (seconds, firsts)
                }
            } else {
                let below_first = below_on_plane[axis];
                (
                    (
                        first.and(below_first).or(second.and_not(below_first)),
                        (
                            V::select(below_first, t_min, second_min),
                            V::select(below_first, first_max, t_max),
                        ),
                    ),
                    (
                        first.and_not(below_first).or(second.and(below_first)),
                        (
                            V::select(below_first, second_min, t_min),
                            V::select(below_first, t_max, first_max),
                        ),
                    ),
                )
            };
            let below_node = node_index + 1;
            let above_node = node.above_child();
            // The child holding the origin first (every lane's first
            // child, unless the origin lies on the plane).
            let near_below = o[axis] <= split;
            let (near, near_iv, near_node, far, far_iv, far_node) = if near_below {
                (below, below_iv, below_node, above, above_iv, above_node)
            } else {
                (above, above_iv, above_node, below, below_iv, below_node)
            };
            if near.any() {
                if far.any() {
                    // Stack entries never outnumber the tree's depth.
                    stack[sp].write((far_node, far, far_iv.0, far_iv.1));
                    sp += 1;
                }
                (node_index, mask, t_min, t_max) = (near_node, near, near_iv.0, near_iv.1);
                continue;
            }
            if far.any() {
                (node_index, mask, t_min, t_max) = (far_node, far, far_iv.0, far_iv.1);
                continue;
            }
        } else {
            let range = node.leaf_range();
            for verts in &tree.leaf_vertices[range] {
                let [a, b, c] = verts.map(|v| (v - fo).to_array());
                let hit = shear.hits(a, b, c, mask, common).0.bits();
                if hit != 0 {
                    alive &= !hit;
                    if alive == 0 {
                        return rays.live;
                    }
                    mask = mask.and_not(V::M::from_bits(hit));
                    if !mask.any() {
                        break;
                    }
                }
            }
        }
        // The next deferred cell with lanes still looking.
        loop {
            if sp == 0 {
                return rays.live & !alive;
            }
            sp -= 1;
            // SAFETY: entry `sp` was written by the push that raised the
            // stack pointer above it, and entries are never read twice.
            let (i, m, a, b) = unsafe { stack[sp].assume_init() };
            let m = m.and(V::M::from_bits(alive));
            if m.any() {
                (node_index, mask, t_min, t_max) = (i, m, a, b);
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests;
