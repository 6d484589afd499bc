//! Packets of up to 16 rays (4x4) traced together: the interval traversal of
//! section 4.3 (the "XP search").
//!
//! The packet keeps one interval `t_cell = [t0, t1]` for the current cell: the
//! earliest entry and the latest exit over its rays. At an interior node the
//! interval `t_plane` of the rays' distances to the split plane decides, for
//! all rays at once, whether only the nearest child, only the farthest, or
//! both are traversed (the paper's listing). At a leaf each triangle is
//! tested against the rays still active (the leaf clipping of equation (2)
//! is implied by the interval, see below): a ray whose
//! closest hit lies before the cell's earliest entry cannot find a closer one
//! there and is masked. The packet stops when every ray's hit lies before the
//! next cell on the stack.
//!
//! Each ray's hit is the single-ray path's: the packet's intervals (widened by
//! the same slack as single rays use) enclose each ray's own, so the packet
//! visits every cell each of its rays would, in front-to-back order, and tests
//! triangles with the same watertight arithmetic.

use std::mem::MaybeUninit;

use glam::Vec3;

use crate::accel::kdtree::MAX_TREE_DEPTH;
use crate::accel::kdtree::watertight::{ShearedRay, shear_axes};
use crate::geom::aabb::Aabb;
use crate::geom::ray::Hit;
use crate::geom::simd::{Isa, Kernel, Lanes, Mask, dispatch};
use crate::mlrta::entry_point::EntryPoint;
use crate::mlrta::frustum::{Frustum, FrustumBounds, down, up};
use crate::mlrta::prepared::Prepared;

/// Rays per packet (4x4).
pub const PACKET: usize = 16;

/// Statistics counted as in the MLRTA paper's Table 2: traversal steps and
/// intersection tests per packet (a triangle tested against any number of
/// the packet's rays counts once), entry-point steps.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct MlrtaCounts {
    /// 4x4 packets the statistics are normalised by.
    pub packets: u64,
    /// Entry-point searches.
    pub ep_searches: u64,
    /// Nodes visited by entry-point searches.
    pub ep_steps: u64,
    /// Interval traversals: one per packet walked alone, one per group of
    /// packets walked together (`trace_packets_lanes`).
    pub walks: u64,
    /// Nodes visited by packets (intersection search): a group's steps
    /// count once for all its packets.
    pub xp_cells: u64,
    /// Triangle tests by packets with at least one active ray.
    pub isects: u64,
    /// Ray-triangle tests (each active ray of each packet test).
    pub ray_tests: u64,
    /// Leaves packets visited.
    pub xp_leaves: u64,
    /// How many of those leaves held no triangle.
    pub xp_empty_leaves: u64,
    /// Rays traced one by one: diverging directions (a zero component) and
    /// re-traces after a speculative entry point.
    pub single_rays: u64,
    /// Nodes those single rays visited.
    pub single_cells: u64,
    /// Their ray-triangle tests.
    pub single_isects: u64,
}

impl std::ops::AddAssign for MlrtaCounts {
    fn add_assign(&mut self, o: Self) {
        self.packets += o.packets;
        self.ep_searches += o.ep_searches;
        self.ep_steps += o.ep_steps;
        self.walks += o.walks;
        self.xp_cells += o.xp_cells;
        self.isects += o.isects;
        self.ray_tests += o.ray_tests;
        self.xp_leaves += o.xp_leaves;
        self.xp_empty_leaves += o.xp_empty_leaves;
        self.single_rays += o.single_rays;
        self.single_cells += o.single_cells;
        self.single_isects += o.single_isects;
    }
}

/// Up to 16 rays with a common origin and same-sign directions, with what
/// each lane needs precomputed, lane by lane side by side (unused lanes
/// repeat lane 0, so that the arithmetic stays valid for all sixteen).
pub struct Packet {
    /// What is known of the packet's rays as a group (its widened
    /// intervals), for the interval traversal and entry-point searches.
    pub frustum: Frustum,
    /// Rays in the packet, 1 to 16.
    pub len: usize,
    /// The rays' directions, lane by lane (lanes from `len` on repeat
    /// lane 0).
    pub dirs: [Vec3; PACKET],
    /// `1 / d` per axis and lane, for the lanes' own slab tests at leaves.
    inv: [[f32; PACKET]; 3],
    /// The lanes' `ShearedRay` axes and constants.
    k: [[u8; 3]; PACKET],
    sx: [f32; PACKET],
    sy: [f32; PACKET],
    sz: [f32; PACKET],
    /// Whether every lane uses the same axis permutation (the usual case):
    /// triangles are then tested against all lanes at once.
    common_axes: bool,
}

impl Packet {
    /// A packet of `dirs` from `origin`, or `None` if the directions do not
    /// share one sign class (or there are none, or more than 16): outside
    /// a dispatched kernel (inside one, `new_in` with the kernel's lanes).
    pub fn new(origin: Vec3, dirs: &[Vec3], t_max: f32) -> Option<Packet> {
        struct New<'a> {
            origin: Vec3,
            dirs: &'a [Vec3],
            t_max: f32,
        }
        impl Kernel for New<'_> {
            type Out = Option<Packet>;
            #[inline(always)]
            fn run<V: Lanes>(self) -> Option<Packet> {
                Packet::new_in::<V>(self.origin, self.dirs, self.t_max)
            }
        }
        dispatch(Isa::best(), New { origin, dirs, t_max })
    }

    /// `new` in lanes `V`, inlined into the kernel that makes the packet.
    /// The frustum's bounds are reductions over the lanes: made ray by ray
    /// (`FrustumBounds::add`), the set-up of a packet took about an eighth
    /// of the primary rays' time.
    #[inline(always)]
    pub(crate) fn new_in<V: Lanes>(origin: Vec3, dirs: &[Vec3], t_max: f32) -> Option<Packet> {
        let n = dirs.len();
        if n == 0 || n > PACKET {
            return None;
        }
        let mut own = [dirs[0]; PACKET];
        own[..n].copy_from_slice(dirs);
        let mut d = [[0.0f32; PACKET]; 3];
        for (r, v) in own.iter().enumerate() {
            for a in 0..3 {
                d[a][r] = v[a];
            }
        }
        let dv = [V::from_array(d[0]), V::from_array(d[1]), V::from_array(d[2])];
        let one = V::splat(1.0);
        let iv = [one.div(dv[0]), one.div(dv[1]), one.div(dv[2])];
        let inv = [iv[0].to_array(), iv[1].to_array(), iv[2].to_array()];
        // One sign class, no zero or infinite (or NaN) component: lanes past
        // `n` repeat lane 0, so all sixteen must agree.
        let (zero, below, above) = (V::splat(0.0), V::splat(f32::NEG_INFINITY), V::splat(f32::INFINITY));
        let mut class = 0u32;
        for (a, x) in dv.iter().enumerate() {
            if x.lt(zero).and(x.gt(below)).bits() == u16::MAX {
                class |= 1 << a;
            } else if x.gt(zero).and(x.lt(above)).bits() != u16::MAX {
                return None;
            }
        }
        let mut extremes = [[0.0f32; 3]; 2];
        let (mut slope_lo, mut slope_hi) = ([[0.0f32; 3]; 3], [[0.0f32; 3]; 3]);
        for a in 0..3 {
            extremes[0][a] = iv[a].min_lane();
            extremes[1][a] = iv[a].max_lane();
            // Not `b == a`: that slope is 1 (`FrustumBounds::finish`).
            for b in [(a + 1) % 3, (a + 2) % 3] {
                let s = dv[b].mul(iv[a]);
                slope_lo[a][b] = s.min_lane();
                slope_hi[a][b] = s.max_lane();
            }
        }
        let bounds = FrustumBounds::from_extremes(class, extremes, slope_lo, slope_hi);
        // ShearedRay::new lane by lane: the axes, then the constants (the
        // same divisions as there, so that hits are bit-identical). The
        // lanes share their signs, so they share the axes when they share
        // the dominant one (the usual case: then the constants are divisions
        // of whole rows, and `sz` is the row of reciprocals made above).
        let k0 = shear_axes(own[0]);
        // `shear_axes`' choice of the dominant axis, lane by lane as masks.
        let (ax, ay, az) = (magnitude(dv[0]), magnitude(dv[1]), magnitude(dv[2]));
        let x_dominant = ax.ge(ay).and(ax.ge(az)).bits();
        let y_dominant = ay.ge(az).bits() & !x_dominant;
        let dominant = [x_dominant, y_dominant, !(x_dominant | y_dominant)];
        let same_dominant = dominant[k0[2]] == u16::MAX;
        let (mut sx, mut sy) = ([0.0f32; PACKET], [0.0f32; PACKET]);
        let (k, sz, common_axes) = if same_dominant {
            let [kx, ky, kz] = k0;
            sx = dv[kx].div(dv[kz]).to_array();
            sy = dv[ky].div(dv[kz]).to_array();
            ([[kx as u8, ky as u8, kz as u8]; PACKET], inv[kz], true)
        } else {
            let k = own.map(shear_axes);
            let mut sz = [0.0f32; PACKET];
            for r in 0..PACKET {
                let [kx, ky, kz] = k[r];
                sx[r] = d[kx][r] / d[kz][r];
                sy[r] = d[ky][r] / d[kz][r];
                sz[r] = inv[kz][r];
            }
            // Lanes past `n` repeat lane 0 and do not count.
            let common = k[..n].iter().all(|x| *x == k[0]);
            (k.map(|axes| axes.map(|a| a as u8)), sz, common)
        };
        Some(Packet {
            frustum: bounds.finish(origin, t_max)?,
            len: n,
            dirs: own,
            inv,
            k,
            sx,
            sy,
            sz,
            common_axes,
        })
    }

    /// Lane `r` as a single `ShearedRay` in `frame`.
    #[inline]
    fn sheared(&self, r: usize, frame: &Frame) -> ShearedRay {
        let [kx, ky, kz] = self.k[r].map(usize::from);
        ShearedRay {
            origin: frame.origin,
            kx,
            ky,
            kz,
            sx: self.sx[r],
            sy: self.sy[r],
            sz: self.sz[r],
            scale: frame.scale,
            inv_scale: frame.inv_scale,
        }
    }
}

/// `|x|` per lane (lanes not NaN). A function, not a closure: a closure is
/// compiled outside the dispatched kernel, without its registers.
#[inline(always)]
fn magnitude<V: Lanes>(x: V) -> V {
    x.max(V::splat(0.0).sub(x))
}

/// `frustum::down` per lane: `x - |x| SLACK`.
#[inline(always)]
fn down_lanes<V: Lanes>(x: V) -> V {
    x.sub(magnitude(x).mul(V::splat(crate::mlrta::frustum::SLACK)))
}

/// `frustum::up` per lane: `x + |x| SLACK`.
#[inline(always)]
fn up_lanes<V: Lanes>(x: V) -> V {
    x.add(magnitude(x).mul(V::splat(crate::mlrta::frustum::SLACK)))
}

/// Active lanes above which a triangle is tested in all sixteen lanes at
/// once rather than lane by lane: 1, the fastest measured on 1024x1024
/// primary rays (one thread, alternated rounds: 2 was about 2% slower on
/// the bunny, the dragon and the kitchen with AVX2 and SSE, 4 slower
/// still).
const LANE_BY_LANE: u32 = 1;

/// The packet's `1 / d` as vectors of lanes `V`, for the lanes' own slab
/// tests at cells.
struct PacketLanes<V: Lanes> {
    inv: [V; 3],
}

impl<V: Lanes> PacketLanes<V> {
    #[inline(always)]
    fn new(p: &Packet) -> Self {
        // No `array::map`: generic library code, compiled outside the
        // dispatched kernel (this runs at every leaf a packet reaches).
        PacketLanes {
            inv: [
                V::from_array(p.inv[0]),
                V::from_array(p.inv[1]),
                V::from_array(p.inv[2]),
            ],
        }
    }

    /// Every lane's interval `(near, far)` in `cell`, clamped to
    /// `[0, limit]` (the directions have no zero component, so no NaN
    /// arises in used lanes).
    #[inline(always)]
    fn slabs(&self, p: &Packet, cell: &Aabb, limit: V) -> (V, V) {
        let o = p.frustum.origin;
        let mut near = V::splat(0.0);
        let mut far = limit;
        for a in 0..3 {
            let t1 = V::splat(cell.min[a] - o[a]).mul(self.inv[a]);
            let t2 = V::splat(cell.max[a] - o[a]).mul(self.inv[a]);
            let ordered = t1.lt(t2);
            let (n, f) = (V::select(ordered, t1, t2), V::select(ordered, t2, t1));
            near = V::select(n.gt(near), n, near);
            far = V::select(f.lt(far), f, far);
        }
        (near, far)
    }
}

/// Lanes' shear constants (`ShearedRay`'s) as vectors of lanes `V`, lanes
/// that share their shear axes `k0`: a packet's (`common_axes`) or a pool
/// of several packets' open lanes (`LanePool`). The triangle tests run on
/// them.
struct ShearLanes<V: Lanes> {
    sx: V,
    sy: V,
    sz: V,
    k0: [usize; 3],
}

impl<V: Lanes> ShearLanes<V> {
    #[inline(always)]
    fn new(p: &Packet) -> Self {
        let [kx, ky, kz] = p.k[0];
        ShearLanes {
            sx: V::from_array(p.sx),
            sy: V::from_array(p.sy),
            sz: V::from_array(p.sz),
            k0: [kx as usize, ky as usize, kz as usize],
        }
    }

    /// `Packet::test_common` in the lanes: the lanes of `active` that hit
    /// the triangle before their `best_t`, whose `best_t` it updates.
    /// Without a branch: returning early where no lane is inside the edges
    /// mispredicted often enough that the whole test of every triangle,
    /// its tests overlapping, is faster (in-process, 1024^2 primary rays,
    /// one thread, three alternated rounds: bunny 16.8-17.5 -> 16.0-16.8
    /// ms, dragon100k 18.0-18.7 -> 17.3-18.1, kitchen interior 20.6-21.0 ->
    /// 19.9-20.4, with `test_leaf`).
    #[inline(always)]
    fn test_common(&self, [a, b, c]: &[[f32; 3]; 3], active: u16, best_t: &mut V, frame: &Frame) -> V::M {
        let (scale, inv_scale) = (frame.scale, frame.inv_scale);
        // Every lane has lane 0's axes (`common_axes`).
        let [kx, ky, kz] = self.k0;
        let s = V::splat;
        let ax = s(a[kx]).sub(self.sx.mul(s(a[kz])));
        let ay = s(a[ky]).sub(self.sy.mul(s(a[kz])));
        let bx = s(b[kx]).sub(self.sx.mul(s(b[kz])));
        let by = s(b[ky]).sub(self.sy.mul(s(b[kz])));
        let cx = s(c[kx]).sub(self.sx.mul(s(c[kz])));
        let cy = s(c[ky]).sub(self.sy.mul(s(c[kz])));
        let u = cx.mul(by).sub(cy.mul(bx));
        let v = ax.mul(cy).sub(ay.mul(cx));
        let w = bx.mul(ay).sub(by.mul(ax));
        let zero = s(0.0);
        let negative = u.lt(zero).or(v.lt(zero)).or(w.lt(zero));
        let positive = u.gt(zero).or(v.gt(zero)).or(w.gt(zero));
        let inside = V::M::from_bits(active).and_not(negative.and(positive));
        // Narrow lanes (SSE's four registers a vector, the scalar lanes)
        // still leave early: the rest of the test costs them four times
        // the instructions (CLI, `PENUMBRA_ISA=sse`: bunny 27.8-28.6 ms
        // branch-free against 26.9-27.1 with the early exit).
        if !V::AVX2 && !inside.any() {
            return inside;
        }
        let det = u.add(v).add(w);
        let t_scaled = u
            .mul(self.sz.mul(s(a[kz])))
            .add(v.mul(self.sz.mul(s(b[kz]))))
            .add(w.mul(self.sz.mul(s(c[kz]))));
        let wrong_side = det
            .gt(zero)
            .and(t_scaled.le(zero))
            .or(det.lt(zero).and(t_scaled.ge(zero)));
        let t = t_scaled.div(det);
        let h = inside
            .and_not(det.eq(zero))
            .and_not(wrong_side)
            .and(t.gt(zero))
            .and(t.lt(best_t.mul(s(scale))));
        *best_t = V::select(h, t.mul(s(inv_scale)), *best_t);
        h
    }
}

/// The packet's origin in the tree's intersection frame (`KdTree::frame_scale`),
/// made once per packet rather than per triangle test.
struct Frame {
    origin: Vec3,
    scale: f32,
    inv_scale: f32,
}

/// The latest hit (or limit) over the lanes not `done`: a select and a
/// reduction in the lanes, where loops over an array of flags took 3% of
/// the trace (1024^2 primary rays, one thread: bunny 49.1 -> 47.7 ms,
/// kitchen interior 62.1 -> 60.3). A function, not a closure: a closure
/// here is compiled outside the dispatched kernel, without its registers.
#[inline(always)]
fn latest_open<V: Lanes>(best_t: &[f32; PACKET], done: u16) -> f32 {
    V::select(
        V::M::from_bits(!done),
        V::from_array(*best_t),
        V::splat(f32::NEG_INFINITY),
    )
    .max_lane()
}

/// Traces the packet from `entry` (closest hits, or any hit with `any_hit`).
/// Returns one hit per ray (`Hit::MISS` where nothing was hit in the entry
/// point's subtree).
pub fn trace_packet(
    p: &Prepared,
    packet: &Packet,
    entry: &EntryPoint,
    any_hit: bool,
    counts: &mut MlrtaCounts,
) -> [Hit; PACKET] {
    struct Trace<'a> {
        p: &'a Prepared<'a>,
        packet: &'a Packet,
        entry: &'a EntryPoint,
        any_hit: bool,
        counts: &'a mut MlrtaCounts,
    }
    impl Kernel for Trace<'_> {
        type Out = [Hit; PACKET];
        #[inline(always)]
        fn run<V: Lanes>(self) -> [Hit; PACKET] {
            trace_packet_lanes::<V>(self.p, self.packet, self.entry, self.any_hit, self.counts)
        }
    }
    dispatch(
        Isa::best(),
        Trace {
            p,
            packet,
            entry,
            any_hit,
            counts,
        },
    )
}

/// `trace_packet` in lanes `V` (inside a dispatched kernel).
#[inline(always)]
pub(crate) fn trace_packet_lanes<V: Lanes>(
    p: &Prepared,
    packet: &Packet,
    entry: &EntryPoint,
    any_hit: bool,
    counts: &mut MlrtaCounts,
) -> [Hit; PACKET] {
    let [hits] = trace_packets_lanes::<V, 1>(p, [packet], entry, any_hit, counts);
    hits
}

/// The hull of the packets' frusta (they share origin, signs and `t_max`).
#[inline(always)]
fn hull<const N: usize>(packets: [&Packet; N]) -> Frustum {
    let mut f = packets[0].frustum;
    for q in &packets[1..] {
        for a in 0..3 {
            f.inv[a] = f.inv[a].hull(q.frustum.inv[a]);
            for b in 0..3 {
                f.slope[a][b] = f.slope[a][b].hull(q.frustum.slope[a][b]);
            }
        }
    }
    f
}

/// `N` packets of one origin and sign class walked through the tree
/// together: one interval traversal (section 4.3) of the hull of their
/// frusta, each packet's lanes tested at the leaves it reaches. The walk's
/// steps are per group, not per packet, so neighbouring packets that
/// cross the same cells pay for them once.
#[inline(always)]
pub(crate) fn trace_packets_lanes<V: Lanes, const N: usize>(
    p: &Prepared,
    packets: [&Packet; N],
    entry: &EntryPoint,
    any_hit: bool,
    counts: &mut MlrtaCounts,
) -> [[Hit; PACKET]; N] {
    // Every ray ends by the entry point's limit: no need to look further.
    let mut shortened = hull(packets);
    shortened.t_max = shortened.t_max.min(entry.t_limit);
    let f = &shortened;
    let origin = f.origin;
    let tree = p.tree;
    let frame = Frame {
        origin: origin * tree.frame_scale,
        scale: tree.frame_scale,
        inv_scale: 1.0 / tree.frame_scale,
    };
    let mut best_t = [[f.t_max; PACKET]; N];
    let mut best_tri = [[Hit::MISS_INDEX; PACKET]; N];
    // The group's interval in the entry cell, from its frustum (the GPU
    // twin computes it the same way, without a reduction over lanes); rays
    // that miss the cell are done (nothing they can hit lies outside it).
    let (entry_t0, entry_t1) = f.box_interval(&entry.cell);
    let (mut t0, mut t1) = (down(entry_t0.max(0.0)), up(entry_t1));
    if t0 > t1 {
        return [[Hit::MISS; PACKET]; N];
    }
    counts.walks += 1;
    // Lanes done (bit r): unused lanes, lanes that miss the entry cell, and
    // with `any_hit` lanes that found a hit.
    let mut done = [0u16; N];
    for (j, packet) in packets.iter().enumerate() {
        // In the lanes: written lane by lane, this loop compiled to scalar
        // code that took a third of the bunny's primary rays' time.
        let lanes = PacketLanes::<V>::new(packet);
        let (near, far) = lanes.slabs(packet, &entry.cell, V::splat(f.t_max));
        // NaN bounds (a degenerate lane) count as a miss.
        let inside = down_lanes(near).le(up_lanes(far)).bits();
        let used = u16::MAX >> (PACKET - packet.len);
        done[j] = !(inside & used);
    }
    let mut stack = [const { MaybeUninit::<(u32, f32, f32, Aabb)>::uninit() }; MAX_TREE_DEPTH];
    let mut sp = 0usize;
    let (mut node_index, mut cell) = (entry.node, entry.cell);
    let mut latest = latest_of::<V, N>(&best_t, &done);
    // A group's packets side by side, to pass over at a leaf those whose
    // frustum cannot reach it before masking any lanes: of the packets a
    // leaf's lanes were masked for, 83% had none there (1024x1024 primary
    // rays: bunny 251,797 of 302,939, kitchen interior 220,097 of
    // 314,913); 92% and 82% of those are now passed over.
    let frusta = if N > 1 {
        Some(PacketFrusta::<V>::new(&packets))
    } else {
        None
    };
    loop {
        counts.xp_cells += 1;
        let mut tested = false;
        let node = tree.nodes[node_index as usize];
        if !node.is_leaf() {
            let (axis, split) = (node.axis(), node.split());
            let o = origin[axis];
            let near_below = o < split || (o == split && !f.positive[axis]);
            let (below, above) = (node_index + 1, node.above_child());
            // The child cells: the current cell cut at the split plane.
            let cut = |cell: &mut Aabb, is_below: bool| {
                if is_below {
                    cell.max[axis] = split
                } else {
                    cell.min[axis] = split
                }
            };
            let tp = f.plane_t(axis, split);
            if tp.hi <= 0.0 || down(tp.lo) > t1 {
                node_index = if near_below { below } else { above };
                cut(&mut cell, near_below);
            } else if up(tp.hi) < t0 {
                node_index = if near_below { above } else { below };
                cut(&mut cell, !near_below);
            } else {
                let mut far_cell = cell;
                cut(&mut far_cell, !near_below);
                let far = if near_below { above } else { below };
                // Stack entries never outnumber the tree's depth.
                stack[sp].write((far, t0.max(down(tp.lo)), t1, far_cell));
                sp += 1;
                t1 = t1.min(up(tp.hi));
                node_index = if near_below { below } else { above };
                cut(&mut cell, near_below);
            }
            continue;
        }

        let range = node.leaf_range();
        counts.xp_leaves += 1;
        if range.is_empty() {
            counts.xp_empty_leaves += 1;
        } else {
            // No leaf clipping (equation (2)) here: `Frustum::may_hit_box`
            // of a cell is `latest entry <= earliest exit` over its faces'
            // plane intervals, and the interval traversal carries exactly
            // that: `t0` is the latest `plane_t(..).lo` of the near faces
            // crossed on the way down, `t1` the earliest `.hi` of the far
            // ones, and a child is entered only where they overlap. It never
            // fired (0 of the 823,448 non-empty leaves the 1024x1024 primary
            // and shadow packets of bunny, dragon and kitchen reach) and cost
            // a box test per leaf.
            let entry_limit = down(t0);
            let mut active = [0u16; N];
            let mut m = [0u64; N];
            let apart = match &frusta {
                Some(frusta) => frusta.apart(f, &cell),
                None => 0,
            };
            // Packets (bit j) with lanes to test here.
            let mut reaching = 0u16;
            for j in 0..N {
                if done[j] != u16::MAX && apart & (1 << j) == 0 {
                    active[j] = leaf_lanes::<V>(packets[j], &cell, &best_t[j], done[j], entry_limit);
                    m[j] = active[j].count_ones() as u64;
                    reaching |= ((active[j] != 0) as u16) << j;
                }
            }
            tested = reaching != 0;
            if tested {
                let tris = &tree.leaf_triangles[range.clone()];
                let verts = &tree.leaf_vertices[range];
                let mut pool = if V::FAST_COMPRESS && N > 1 && !any_hit {
                    LanePool::gather::<V, N>(&packets, &active, reaching, &best_t, &best_tri)
                } else {
                    None
                };
                if pool.is_some() {
                    // Counted as if tested packet by packet (Table 2's
                    // statistics).
                    let n = tris.len() as u64;
                    let mut left = reaching;
                    while left != 0 {
                        let j = left.trailing_zeros() as usize;
                        left &= left - 1;
                        counts.isects += n;
                        counts.ray_tests += m[j] * n;
                    }
                }
                for (tris, verts) in tris.chunks(LEAF_CHUNK).zip(verts.chunks(LEAF_CHUNK)) {
                    // A triangle's corners are made once for all the
                    // packets that test it.
                    let mut corners = [[[0.0f32; 3]; 3]; LEAF_CHUNK];
                    let o = frame.origin;
                    for (c, v) in corners.iter_mut().zip(verts) {
                        *c = [(v[0] - o).to_array(), (v[1] - o).to_array(), (v[2] - o).to_array()];
                    }
                    let leaf = LeafTriangles {
                        tris,
                        verts,
                        corners: &corners[..verts.len()],
                    };
                    if let Some(pool) = &mut pool {
                        pool.test::<V>(&leaf, &frame);
                        continue;
                    }
                    // Packet by packet, all of the chunk's triangles: the
                    // packet's constants and hits stay in registers.
                    let mut left = reaching;
                    while left != 0 {
                        let j = left.trailing_zeros() as usize;
                        left &= left - 1;
                        let (hit, tests) = test_leaf::<V>(
                            packets[j],
                            &leaf,
                            active[j],
                            &frame,
                            &mut best_t[j],
                            &mut best_tri[j],
                            any_hit,
                        );
                        counts.isects += tests;
                        counts.ray_tests += m[j] * tests;
                        if any_hit {
                            active[j] &= !hit;
                            done[j] |= hit;
                            reaching &= !(((active[j] == 0) as u16) << j);
                        }
                    }
                }
                if let Some(pool) = &pool {
                    pool.scatter::<V, N>(reaching, &active, &mut best_t, &mut best_tri);
                }
            }
        }
        // Next cell: skip those that start beyond every open ray's hit. (The
        // lanes' hits change only at leaves with triangles.)
        if tested {
            latest = latest_of::<V, N>(&best_t, &done);
        }
        loop {
            if sp == 0 {
                let mut hits = [[Hit::MISS; PACKET]; N];
                for (j, packet) in packets.iter().enumerate() {
                    for r in 0..packet.len {
                        if best_tri[j][r] != Hit::MISS_INDEX {
                            hits[j][r] = Hit {
                                t: best_t[j][r],
                                triangle: best_tri[j][r],
                            };
                        }
                    }
                }
                return hits;
            }
            sp -= 1;
            // SAFETY: entry `sp` was written by the push that raised the
            // stack pointer above it, and entries are never read twice.
            let (i, a, b, c) = unsafe { stack[sp].assume_init() };
            if down(a) <= latest {
                (node_index, t0, t1, cell) = (i, a, b, c);
                break;
            }
        }
    }
}

/// The `1 / d` intervals of a group's packets, one packet per lane.
struct PacketFrusta<V: Lanes> {
    inv_lo: [V; 3],
    inv_hi: [V; 3],
}

impl<V: Lanes> PacketFrusta<V> {
    #[inline(always)]
    fn new(packets: &[&Packet]) -> Self {
        debug_assert!(packets.len() <= PACKET);
        let (mut lo, mut hi) = ([[0.0f32; PACKET]; 3], [[0.0f32; PACKET]; 3]);
        for a in 0..3 {
            for (j, packet) in packets.iter().enumerate() {
                (lo[a][j], hi[a][j]) = (packet.frustum.inv[a].lo, packet.frustum.inv[a].hi);
            }
        }
        PacketFrusta {
            inv_lo: [V::from_array(lo[0]), V::from_array(lo[1]), V::from_array(lo[2])],
            inv_hi: [V::from_array(hi[0]), V::from_array(hi[1]), V::from_array(hi[2])],
        }
    }

    /// The packets (bit j) none of whose rays reaches `cell`, from their
    /// frusta of the group `f` (same origin and signs): each lane's slab
    /// interval in the cell (`leaf_lanes`) starts no sooner than the least
    /// near-plane distance over its packet's `1 / d` interval and ends no
    /// later than the largest far-plane one (products round monotonically,
    /// and `down`/`up` as the lanes' test), so a packet whose bounds are
    /// apart has no lane there. NaN bounds (an infinite `1 / d`) compare
    /// false and cull nothing.
    #[inline(always)]
    fn apart(&self, f: &Frustum, cell: &Aabb) -> u16 {
        let mut near = V::splat(0.0);
        let mut far = V::splat(f.t_max);
        for a in 0..3 {
            let (lo, hi) = (cell.min[a] - f.origin[a], cell.max[a] - f.origin[a]);
            let (entry, exit) = if f.positive[a] { (lo, hi) } else { (hi, lo) };
            let (entry, exit) = (V::splat(entry), V::splat(exit));
            let enters = entry.mul(self.inv_lo[a]).min(entry.mul(self.inv_hi[a]));
            let exits = exit.mul(self.inv_lo[a]).max(exit.mul(self.inv_hi[a]));
            near = near.max(enters);
            far = far.min(exits);
        }
        down_lanes(near).gt(up_lanes(far)).bits()
    }
}

/// `latest_open` over the packets of a group.
#[inline(always)]
fn latest_of<V: Lanes, const N: usize>(best_t: &[[f32; PACKET]; N], done: &[u16; N]) -> f32 {
    let mut latest = f32::NEG_INFINITY;
    for j in 0..N {
        latest = latest.max(latest_open::<V>(&best_t[j], done[j]));
    }
    latest
}

/// A packet's lanes that test a leaf's triangles: those still open whose
/// hit does not lie before the cell's earliest entry (`entry_limit`) and
/// that pass through the `cell` (in the lanes: the same comparisons as lane
/// by lane).
#[inline(always)]
fn leaf_lanes<V: Lanes>(packet: &Packet, cell: &Aabb, best_t: &[f32; PACKET], done: u16, entry_limit: f32) -> u16 {
    let lanes = PacketLanes::<V>::new(packet);
    let bt = V::from_array(*best_t);
    let (near, far) = lanes.slabs(packet, cell, bt);
    let reaches = down_lanes(near).le(up_lanes(far));
    bt.ge(V::splat(entry_limit))
        .and(reaches)
        .and(V::M::from_bits(!done))
        .bits()
}

/// Triangles of a leaf tested a chunk at a time (the chunk's corners on
/// the stack).
const LEAF_CHUNK: usize = 32;

/// A chunk of a leaf's triangles: their indices, vertices, and corners
/// relative to the walk's frame origin.
struct LeafTriangles<'a> {
    tris: &'a [u32],
    verts: &'a [[Vec3; 3]],
    corners: &'a [[[f32; 3]; 3]],
}

/// The lanes of `active` that hit one of `leaf`'s triangles before their
/// `best_t` (updated with `best_tri`), in the leaf's order, and the number
/// of triangles tested (with `any_hit` a lane stops at its first hit and
/// the packet when every lane has).
#[inline(always)]
fn test_leaf<V: Lanes>(
    packet: &Packet,
    leaf: &LeafTriangles,
    mut active: u16,
    frame: &Frame,
    best_t: &mut [f32; PACKET],
    best_tri: &mut [u32; PACKET],
    any_hit: bool,
) -> (u16, u64) {
    let (mut hits, mut tests) = (0u16, 0u64);
    // Few active lanes: testing them one by one beats running all sixteen
    // side by side.
    if packet.common_axes && active.count_ones() > LANE_BY_LANE {
        let lanes = ShearLanes::<V>::new(packet);
        return test_lanes(&lanes, leaf, active, frame, best_t, best_tri, any_hit);
    }
    for (&[v0, v1, v2], &tri) in leaf.verts.iter().zip(leaf.tris) {
        tests += 1;
        let mut left = active;
        while left != 0 {
            let r = left.trailing_zeros() as usize;
            left &= left - 1;
            if let Some(t) = packet.sheared(r, frame).intersect(v0, v1, v2, best_t[r]) {
                best_t[r] = t;
                best_tri[r] = tri;
                hits |= 1 << r;
                if any_hit {
                    active &= !(1 << r);
                }
            }
        }
        if any_hit && active == 0 {
            break;
        }
    }
    (hits, tests)
}

/// `test_leaf` for lanes that share their shear axes (`lanes`).
#[inline(always)]
fn test_lanes<V: Lanes>(
    lanes: &ShearLanes<V>,
    leaf: &LeafTriangles,
    mut active: u16,
    frame: &Frame,
    best_t: &mut [f32; PACKET],
    best_tri: &mut [u32; PACKET],
    any_hit: bool,
) -> (u16, u64) {
    let (mut hits, mut tests) = (0u16, 0u64);
    let mut bt = V::from_array(*best_t);
    // Triangle indices as the bits of f32 lanes (a select moves bits): no
    // branch per hit either.
    let mut bi = V::from_array(bytemuck::cast(*best_tri));
    for (corners, &tri) in leaf.corners.iter().zip(leaf.tris) {
        tests += 1;
        let hit = lanes.test_common(corners, active, &mut bt, frame);
        bi = V::select(hit, V::splat(f32::from_bits(tri)), bi);
        hits |= hit.bits();
        if any_hit {
            active &= !hit.bits();
            if active == 0 {
                break;
            }
        }
    }
    *best_t = bt.to_array();
    *best_tri = bytemuck::cast(bi.to_array());
    (hits, tests)
}

/// Groups of sixteen made of the open lanes of several packets at a leaf,
/// for closest hits: a packet has 8.3 of its 16 lanes open at a leaf on
/// average (bunny), so a walk's packets need a third fewer vector tests
/// when their open lanes are packed together. The packets must share their
/// shear axes (`common_axes` and the same `k`); each lane keeps its own
/// shear constants and best hit, so its tests are its packet's. Packed and
/// unpacked with `Lanes::compress` and `expand` (one instruction each with
/// AVX-512; other lanes test packet by packet).
struct LanePool {
    groups: usize,
    /// Lanes in use.
    lanes: usize,
    /// Per packet (by `reaching`'s bits), where its lanes start.
    start: [u8; PACKET],
    sx: [f32; POOL_LANES],
    sy: [f32; POOL_LANES],
    sz: [f32; POOL_LANES],
    best_t: [f32; POOL_LANES],
    /// Triangle indices as f32 bits.
    best_tri: [f32; POOL_LANES],
    k0: [usize; 3],
}

/// Groups a leaf's lanes are packed into at most (more lanes are tested
/// packet by packet).
const POOL_GROUPS: usize = 8;
/// Lanes of the pool, with room for the last packet's whole vector.
const POOL_LANES: usize = (POOL_GROUPS + 1) * PACKET;

/// `v`'s lanes stored at `out[at..at + 16]`.
#[inline(always)]
fn store_at<V: Lanes>(out: &mut [f32; POOL_LANES], at: usize, v: V) {
    out[at..at + PACKET].copy_from_slice(&v.to_array());
}

/// The lanes at `out[at..at + 16]`.
#[inline(always)]
fn load_at<V: Lanes>(from: &[f32; POOL_LANES], at: usize) -> V {
    let mut a = [0.0f32; PACKET];
    a.copy_from_slice(&from[at..at + PACKET]);
    V::from_array(a)
}

impl LanePool {
    /// The open lanes (`active`) of the `reaching` packets packed into
    /// groups, if that saves at least one vector test per triangle and the
    /// packets share their shear axes.
    #[inline(always)]
    fn gather<V: Lanes, const N: usize>(
        packets: &[&Packet; N],
        active: &[u16; N],
        reaching: u16,
        best_t: &[[f32; PACKET]; N],
        best_tri: &[[u32; PACKET]; N],
    ) -> Option<LanePool> {
        let first = packets[reaching.trailing_zeros() as usize];
        let mut lanes = 0usize;
        let mut left = reaching;
        while left != 0 {
            let j = left.trailing_zeros() as usize;
            left &= left - 1;
            if !packets[j].common_axes || packets[j].k[0] != first.k[0] {
                return None;
            }
            lanes += active[j].count_ones() as usize;
        }
        let groups = lanes.div_ceil(PACKET);
        if groups >= reaching.count_ones() as usize || groups > POOL_GROUPS {
            return None;
        }
        let mut pool = LanePool {
            groups,
            lanes,
            start: [0; PACKET],
            sx: [0.0; POOL_LANES],
            sy: [0.0; POOL_LANES],
            sz: [0.0; POOL_LANES],
            best_t: [0.0; POOL_LANES],
            best_tri: [0.0; POOL_LANES],
            k0: first.k[0].map(|a| a as usize),
        };
        let mut n = 0usize;
        let mut left = reaching;
        while left != 0 {
            let j = left.trailing_zeros() as usize;
            left &= left - 1;
            let (p, open) = (packets[j], V::M::from_bits(active[j]));
            pool.start[j] = n as u8;
            // Each store writes sixteen lanes; the next packet's overwrite
            // what lies past this one's.
            store_at(&mut pool.sx, n, V::from_array(p.sx).compress(open));
            store_at(&mut pool.sy, n, V::from_array(p.sy).compress(open));
            store_at(&mut pool.sz, n, V::from_array(p.sz).compress(open));
            store_at(&mut pool.best_t, n, V::from_array(best_t[j]).compress(open));
            store_at(
                &mut pool.best_tri,
                n,
                V::from_array(bytemuck::cast(best_tri[j])).compress(open),
            );
            n += active[j].count_ones() as usize;
        }
        Some(pool)
    }

    /// Every group against the leaf's triangles (closest hits).
    #[inline(always)]
    fn test<V: Lanes>(&mut self, leaf: &LeafTriangles, frame: &Frame) {
        for g in 0..self.groups {
            let at = g * PACKET;
            let lanes = ShearLanes::<V> {
                sx: load_at(&self.sx, at),
                sy: load_at(&self.sy, at),
                sz: load_at(&self.sz, at),
                k0: self.k0,
            };
            let used = (self.lanes - at).min(PACKET);
            let open = (u32::MAX >> (32 - used)) as u16;
            let mut best_t = [0.0f32; PACKET];
            best_t.copy_from_slice(&self.best_t[at..at + PACKET]);
            let mut best_tri: [u32; PACKET] = bytemuck::cast(load_at::<V>(&self.best_tri, at).to_array());
            test_lanes(&lanes, leaf, open, frame, &mut best_t, &mut best_tri, false);
            self.best_t[at..at + PACKET].copy_from_slice(&best_t);
            self.best_tri[at..at + PACKET].copy_from_slice(&bytemuck::cast::<_, [f32; PACKET]>(best_tri));
        }
    }

    /// The lanes' hits back into their packets (`reaching`, with `active`).
    #[inline(always)]
    fn scatter<V: Lanes, const N: usize>(
        &self,
        reaching: u16,
        active: &[u16; N],
        best_t: &mut [[f32; PACKET]; N],
        best_tri: &mut [[u32; PACKET]; N],
    ) {
        let mut left = reaching;
        while left != 0 {
            let j = left.trailing_zeros() as usize;
            left &= left - 1;
            let (at, open) = (self.start[j] as usize, V::M::from_bits(active[j]));
            best_t[j] = load_at::<V>(&self.best_t, at)
                .expand(open, V::from_array(best_t[j]))
                .to_array();
            let tri = load_at::<V>(&self.best_tri, at).expand(open, V::from_array(bytemuck::cast(best_tri[j])));
            best_tri[j] = bytemuck::cast(tri.to_array());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::kdtree::test_rng::{Rng, random_soup};
    use crate::accel::kdtree::{KdTree, KdTreeSettings};
    use crate::scene::Mesh;

    /// Four and sixteen packets walked together find, lane for lane, the
    /// hits each finds walked alone (closest and any hit, in every
    /// instruction set the CPU has), with one walk instead of N.
    #[test]
    fn packets_walked_together_hit_what_each_hits_alone() {
        let mut rng = Rng(11);
        let soup = random_soup(&mut rng, 3000, 0.06);
        let positions: Vec<Vec3> = soup.iter().flatten().copied().collect();
        let triangles = (0..soup.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let mesh = Mesh::new(positions, triangles).unwrap();
        let tree = KdTree::build(&mesh, &KdTreeSettings::for_cpu()).unwrap();
        let (prepared, _) = Prepared::new(&tree, &mesh);
        walk_together::<4>(&prepared, &mut rng);
        walk_together::<16>(&prepared, &mut rng);
    }

    /// `n` packets of one origin and sign class around a random aim (with
    /// directions spread up to `spread` about it), or `None` where they do
    /// not share a sign class.
    struct RandomGroup {
        origin: Vec3,
        aim: Vec3,
        spread: f32,
        packets: Vec<Packet>,
    }

    impl RandomGroup {
        fn new(rng: &mut Rng, n: usize, t_max: f32) -> Option<RandomGroup> {
            let origin = rng.vec(-3.0, 3.0);
            let aim = (rng.vec(-0.8, 0.8) - origin).normalize();
            let spread = 0.002 + 0.05 * rng.next_f32();
            let dirs: Vec<Vec3> = (0..n * PACKET)
                .map(|_| (aim + rng.vec(-spread, spread)).normalize())
                .collect();
            let packets = dirs
                .chunks(PACKET)
                .map(|d| Packet::new(origin, d, t_max))
                .collect::<Option<Vec<_>>>()?;
            let positive = packets[0].frustum.positive;
            packets
                .iter()
                .all(|q| q.frustum.positive == positive)
                .then_some(RandomGroup {
                    origin,
                    aim,
                    spread,
                    packets,
                })
        }
    }

    fn walk_together<const N: usize>(prepared: &Prepared, rng: &mut Rng) {
        struct Walk<'a, const N: usize> {
            p: &'a Prepared<'a>,
            packets: [&'a Packet; N],
            any_hit: bool,
        }
        impl<const N: usize> Kernel for Walk<'_, N> {
            type Out = ([[Hit; PACKET]; N], [[Hit; PACKET]; N], [MlrtaCounts; 2]);
            #[inline(always)]
            fn run<V: Lanes>(self) -> Self::Out {
                let entry = EntryPoint::root(self.p);
                let mut counts = [MlrtaCounts::default(); 2];
                let together = trace_packets_lanes::<V, N>(self.p, self.packets, &entry, self.any_hit, &mut counts[0]);
                let mut alone = [[Hit::MISS; PACKET]; N];
                for (j, q) in self.packets.iter().enumerate() {
                    alone[j] = trace_packet_lanes::<V>(self.p, q, &entry, self.any_hit, &mut counts[1]);
                }
                (together, alone, counts)
            }
        }
        let (mut groups, mut hits, mut walks) = (0, 0, [0, 0]);
        while groups < 1200 / N {
            let Some(RandomGroup {
                origin, aim, packets, ..
            }) = RandomGroup::new(rng, N, f32::INFINITY)
            else {
                continue;
            };
            groups += 1;
            for any_hit in [false, true] {
                for isa in Isa::available() {
                    let walk = Walk::<N> {
                        p: prepared,
                        packets: std::array::from_fn(|j| &packets[j]),
                        any_hit,
                    };
                    let (together, alone, counts) = dispatch(isa, walk);
                    assert_eq!(
                        together, alone,
                        "{N} packets, {isa:?}, any hit {any_hit}, from {origin} along {aim}"
                    );
                    hits += together.iter().flatten().filter(|h| h.is_hit()).count();
                    walks[0] += counts[0].walks;
                    walks[1] += counts[1].walks;
                }
            }
        }
        assert!(hits > 10_000, "{N} packets: only {hits} hits, the groups miss the soup");
        assert!(
            walks[0] * (N as u64) * 3 < walks[1] * 4,
            "{N} packets: walks together {} against alone {}",
            walks[0],
            walks[1]
        );
    }

    /// A packet `PacketFrusta::apart` passes over at a cell has no lane
    /// that `leaf_lanes` would test there (every instruction set the CPU
    /// has); and it passes over some of the packets that miss a cell (on
    /// these random cells about one in ten, an interval test in each
    /// axis alone; in the tree's leaves far more, see `apart`).
    #[test]
    fn packets_passed_over_at_a_cell_have_no_lane_there() {
        struct Check<'a> {
            packets: [&'a Packet; 16],
            cells: &'a [Aabb],
        }
        impl Kernel for Check<'_> {
            type Out = (u64, u64);
            #[inline(always)]
            fn run<V: Lanes>(self) -> (u64, u64) {
                let f = hull(self.packets);
                let frusta = PacketFrusta::<V>::new(&self.packets);
                let (mut apart, mut reached) = (0, 0);
                for cell in self.cells {
                    let bits = frusta.apart(&f, cell);
                    for (j, packet) in self.packets.iter().enumerate() {
                        let unused = !(u16::MAX >> (PACKET - packet.len));
                        let lanes = leaf_lanes::<V>(packet, cell, &[f.t_max; PACKET], unused, f32::NEG_INFINITY);
                        assert!(
                            bits & (1 << j) == 0 || lanes == 0,
                            "packet {j} passed over at {cell:?}: lanes {lanes:b}"
                        );
                        apart += (bits >> j & 1) as u64;
                        reached += (lanes != 0) as u64;
                    }
                }
                (apart, reached)
            }
        }
        let mut rng = Rng(31);
        let (mut apart, mut reached, mut total) = (0, 0, 0);
        for _ in 0..200 {
            let Some(RandomGroup {
                origin,
                aim,
                spread,
                packets,
            }) = RandomGroup::new(&mut rng, 16, 20.0)
            else {
                continue;
            };
            // Cells along the group's way, of sizes from a tenth of its
            // spread to all of it.
            let cells: Vec<Aabb> = (0..40)
                .map(|_| {
                    let t = 0.5 + 4.0 * rng.next_f32();
                    let centre = origin + (aim + rng.vec(-spread, spread)) * t;
                    let half = rng.vec(0.1, 1.0) * spread * t;
                    Aabb::new(centre - half, centre + half)
                })
                .collect();
            for isa in Isa::available() {
                let check = Check {
                    packets: std::array::from_fn(|j| &packets[j]),
                    cells: &cells,
                };
                let (a, r) = dispatch(isa, check);
                (apart, reached, total) = (apart + a, reached + r, total + 16 * cells.len() as u64);
            }
        }
        let missed = total - reached;
        assert!(reached > total / 20, "cells reached by {reached} of {total} packets");
        assert!(
            apart * 20 > missed,
            "{apart} passed over of {missed} packets that miss their cells"
        );
    }

    /// Packets set up in the lanes of every instruction set the CPU has
    /// are the ray-by-ray set-up's: the frustum `Frustum::new` makes from
    /// the same directions (bit for bit), `None` exactly where it is (a
    /// second sign class, a zero, infinite or NaN component), and the
    /// lanes' shear constants `ShearedRay::in_frame`'s.
    #[test]
    fn packets_set_up_in_the_lanes_as_ray_by_ray() {
        struct Make<'a> {
            dirs: &'a [Vec3],
        }
        impl Kernel for Make<'_> {
            type Out = Option<Packet>;
            #[inline(always)]
            fn run<V: Lanes>(self) -> Option<Packet> {
                Packet::new_in::<V>(Vec3::new(0.5, -1.0, 2.0), self.dirs, 7.0)
            }
        }
        let mut rng = Rng(23);
        let frame = Frame {
            origin: Vec3::ZERO,
            scale: 1.0,
            inv_scale: 1.0,
        };
        let (mut made, mut refused) = (0, 0);
        for case in 0..3000 {
            let n = 1 + case % PACKET;
            let signs = Vec3::new(1.0, -1.0, 1.0) * if case % 2 == 0 { 1.0 } else { -1.0 };
            let mut dirs: Vec<Vec3> = (0..n).map(|_| (rng.vec(0.05, 1.0) * signs).normalize()).collect();
            let r = case / 7 % n;
            match case % 7 {
                0 => dirs[r].y = -dirs[r].y,
                1 => dirs[r].z = 0.0,
                2 => dirs[r].x = f32::INFINITY,
                3 => dirs[r].y = f32::NAN,
                4 => dirs[r].x = 1e-40 * dirs[r].x.signum(),
                _ => {}
            }
            let reference = Frustum::new(Vec3::new(0.5, -1.0, 2.0), dirs.iter().copied(), 7.0);
            for isa in Isa::available() {
                let packet = dispatch(isa, Make { dirs: &dirs });
                // As text: a lane with a denormal component has an
                // infinite 1 / d, and its widened interval may hold a NaN.
                let frustum = packet.as_ref().map(|p| p.frustum);
                assert_eq!(format!("{frustum:?}"), format!("{reference:?}"), "{isa:?} {dirs:?}");
                let Some(packet) = packet else {
                    refused += 1;
                    continue;
                };
                made += 1;
                let mut axes = Vec::new();
                for (r, &d) in dirs.iter().enumerate() {
                    let lane = packet.sheared(r, &frame);
                    let single = ShearedRay::in_frame(Vec3::ZERO, d, 1.0);
                    assert_eq!((lane.kx, lane.ky, lane.kz), (single.kx, single.ky, single.kz), "{d:?}");
                    let bits = |s: &ShearedRay| [s.sx, s.sy, s.sz].map(f32::to_bits);
                    assert_eq!(bits(&lane), bits(&single), "{isa:?} {d:?}");
                    axes.push((single.kx, single.ky, single.kz));
                }
                let common = axes.iter().all(|a| *a == axes[0]);
                assert_eq!(packet.common_axes, common, "{isa:?} {dirs:?}");
            }
        }
        assert!(made > 1000 && refused > 1000, "{made} made, {refused} refused");
    }

    /// Each lane's shear constants are `ShearedRay::in_frame`'s, bit for
    /// bit, whether the lanes share their dominant axis or not (ties of
    /// magnitudes included).
    #[test]
    fn lanes_shear_as_single_rays_do() {
        let mut rng = Rng(7);
        let frame = Frame {
            origin: Vec3::new(0.5, -2.0, 3.0),
            scale: 4.0,
            inv_scale: 0.25,
        };
        let (mut mixed, mut common) = (0, 0);
        for case in 0..2000 {
            let n = 1 + case % PACKET;
            // Same signs; magnitudes near one another so that the dominant
            // axis changes within a packet; some exact ties.
            let dirs: Vec<Vec3> = (0..n)
                .map(|i| {
                    let mut v = Vec3::new(0.5 + rng.next_f32(), 0.5 + rng.next_f32(), 0.5 + rng.next_f32());
                    if case % 3 == 0 && i % 2 == 0 {
                        v.y = v.x;
                    }
                    v.normalize()
                })
                .collect();
            let p = Packet::new(Vec3::ZERO, &dirs, f32::INFINITY).unwrap();
            if p.common_axes {
                common += 1
            } else {
                mixed += 1
            }
            for (r, &d) in dirs.iter().enumerate() {
                let lane = p.sheared(r, &frame);
                let single = ShearedRay::in_frame(Vec3::new(0.125, -0.5, 0.75), d, 4.0);
                assert_eq!((lane.kx, lane.ky, lane.kz), (single.kx, single.ky, single.kz), "{d:?}");
                let bits = |s: &ShearedRay| [s.sx, s.sy, s.sz].map(f32::to_bits);
                assert_eq!(bits(&lane), bits(&single), "{d:?}");
            }
        }
        assert!(mixed > 100 && common > 100, "{mixed} mixed, {common} common packets");
    }
}
