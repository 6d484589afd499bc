// Kernel: MLRTA packets on the GPU, the twin of src/mlrta/packet.rs
// (`trace_packet`). Composed after kdtree_traverse.wgsl.
//
// Sixteen invocations trace one packet (up to 16 rays with a common origin
// and same-sign directions) from the packet's entry point, found on the CPU.
// Every invocation runs the packet's interval traversal (section 4.3 of the
// MLRTA paper): the decisions at interior nodes use only the packet record,
// so all lanes take them alike and read the same nodes; each lane tests a
// leaf's triangles for its own ray where its own interval (below) says the
// ray passes. A lane stops when it has nothing left on the stack. No
// barriers are needed: the shared decisions are computed redundantly.
//
// A packet whose entry point came from a stopping rule ("speculative") traces
// lanes that found nothing again from the root with kd_traverse, as the CPU
// does; so does a packet flagged SINGLE (one ray with a zero direction
// component, which belongs to no packet).

struct PacketRecord {
    origin: vec3<f32>,
    t_max: f32,
    // Widened interval of 1/d per axis over the packet's rays.
    inv_lo: vec3<f32>,
    entry_node: u32,
    inv_hi: vec3<f32>,
    first_ray: u32,
    cell_min: vec3<f32>,
    ray_count: u32,
    cell_max: vec3<f32>,
    // Bits 0..2: direction component positive; 3: speculative; 4: any hit;
    // 5: single ray.
    flags: u32,
    // Every ray ends by this distance (EntryPoint::t_limit, <= t_max): the
    // packet traversal stops there; re-traces use t_max.
    t_limit: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

struct PacketUniforms {
    packet_count: u32,
    // Workgroups per row of the 2D dispatch grid.
    row_pitch: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<storage, read> packets: array<PacketRecord>;
@group(1) @binding(1) var<storage, read> packet_dirs: array<f32>;
@group(1) @binding(2) var<storage, read_write> packet_hits: array<vec2<u32>>;
@group(1) @binding(3) var<uniform> packet_params: PacketUniforms;
@group(1) @binding(4) var<storage, read_write> packet_counts: array<vec2<u32>>;

const FLAG_SPECULATIVE: u32 = 8u;
const FLAG_ANY_HIT: u32 = 16u;
const FLAG_SINGLE: u32 = 32u;
// frustum::SLACK of src/mlrta/frustum.rs.
const PACKET_SLACK: f32 = 4e-6;
const PACKET_INF_BITS: u32 = 0x7f800000u;

fn pk_down(x: f32) -> f32 {
    return x - abs(x) * PACKET_SLACK;
}

fn pk_up(x: f32) -> f32 {
    return x + abs(x) * PACKET_SLACK;
}

// Interval [lo, hi] * s.
fn pk_scale(lo: f32, hi: f32, s: f32) -> vec2<f32> {
    let a = lo * s;
    let b = hi * s;
    return vec2<f32>(min(a, b), max(a, b));
}

fn pk_positive(pk: PacketRecord, axis: u32) -> bool {
    return (pk.flags & (1u << axis)) != 0u;
}

// Frustum::plane_t: the packet's t at the plane x_axis = s.
fn pk_plane_t(pk: PacketRecord, axis: u32, s: f32) -> vec2<f32> {
    return pk_scale(pk.inv_lo[axis], pk.inv_hi[axis], s - pk.origin[axis]);
}

// Frustum::slabs reduced as in may_hit_box: (latest entry, earliest exit)
// over the packet's rays, for the box [lo, hi].
fn pk_box_interval(pk: PacketRecord, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    var latest_entry = -T_INFINITE;
    var earliest_exit = pk.t_limit;
    for (var a = 0u; a < 3u; a = a + 1u) {
        var near = lo[a];
        var far = hi[a];
        if (!pk_positive(pk, a)) {
            near = hi[a];
            far = lo[a];
        }
        latest_entry = max(latest_entry, pk_plane_t(pk, a, near).x);
        earliest_exit = min(earliest_exit, pk_plane_t(pk, a, far).y);
    }
    return vec2<f32>(latest_entry, earliest_exit);
}

var<private> pk_cells: u32;
var<private> pk_isects: u32;

// The lane follows the packet's decisions but carries its own interval
// [lt0, lt1], cut at each split plane exactly as the single-ray traversal
// cuts its interval (kd_traverse): it is the single ray's interval on the
// ray's own path and empty in cells the packet visits without it. So the
// lane tests the single ray's triangles, and stops where the single ray
// would, without carrying the cells' boxes. (The CPU packet clips lanes
// against the leaf's box instead; the GPU saves that private memory.
// Equation (2) against the leaf's box is implied by the packet's interval
// on both.)
fn packet_traverse(pk: PacketRecord, d: vec3<f32>) -> Hit {
    let any_hit = (pk.flags & FLAG_ANY_HIT) != 0u;
    let o = pk.origin;
    let inv = 1.0 / d;
    let ray = make_sheared_ray(o, d);
    var best: Hit;
    best.t = pk.t_limit;
    best.triangle = MISS_INDEX;
    // The packet's interval in the entry cell (from its frustum, as on the
    // CPU) and the lane's own, widened like the single ray's root interval.
    let entry = pk_box_interval(pk, pk.cell_min, pk.cell_max);
    var t0 = pk_down(max(entry.x, 0.0));
    var t1 = pk_up(entry.y);
    let lt1_0 = (pk.cell_min - o) * inv;
    let lt2_0 = (pk.cell_max - o) * inv;
    let n0 = min(lt1_0, lt2_0);
    let f0 = max(lt1_0, lt2_0);
    var lt0 = max(max(n0.x, n0.y), max(n0.z, 0.0)) * (1.0 - TRAVERSAL_SLACK);
    var lt1 = min(min(f0.x, f0.y), min(f0.z, pk.t_limit)) * (1.0 + TRAVERSAL_SLACK);
    if (t0 > t1 || lt0 > lt1) {
        return best;
    }
    var stack_node: array<u32, MAX_TREE_DEPTH>;
    var stack_t: array<vec4<f32>, MAX_TREE_DEPTH>;
    var sp = 0u;
    var node_index = pk.entry_node;
    loop {
        pk_cells = pk_cells + 1u;
        let node = kd_nodes[node_index];
        if ((node.y & 3u) != 3u) {
            let axis = node.y & 3u;
            let split = bitcast<f32>(node.x);
            let oa = o[axis];
            let near_below = oa < split || (oa == split && !pk_positive(pk, axis));
            let below = node_index + 1u;
            let above = node.y >> 2u;
            let near = select(above, below, near_below);
            let far = select(below, above, near_below);
            // The lane's parts of its interval on either side of the plane.
            let ltp = (split - oa) * inv[axis];
            var near_t = vec2<f32>(lt0, lt1);
            var far_t = vec2<f32>(1.0, 0.0);
            if (ltp > 0.0) {
                near_t = vec2<f32>(lt0, min(lt1, ltp * (1.0 + TRAVERSAL_SLACK)));
                far_t = vec2<f32>(max(lt0, ltp * (1.0 - TRAVERSAL_SLACK)), lt1);
            }
            let tp = pk_plane_t(pk, axis, split);
            if (tp.y <= 0.0 || pk_down(tp.x) > t1) {
                node_index = near;
                lt0 = near_t.x;
                lt1 = near_t.y;
            } else if (pk_up(tp.y) < t0) {
                node_index = far;
                lt0 = far_t.x;
                lt1 = far_t.y;
            } else {
                stack_node[sp] = far;
                stack_t[sp] = vec4<f32>(max(t0, pk_down(tp.x)), t1, far_t.x, far_t.y);
                sp = sp + 1u;
                t1 = min(t1, pk_up(tp.y));
                node_index = near;
                lt0 = near_t.x;
                lt1 = near_t.y;
            }
            continue;
        }
        let count = node.y >> 2u;
        // The lane is masked where its own interval is empty or starts
        // beyond its hit.
        if (count > 0u && lt0 <= lt1 && lt0 <= best.t) {
            for (var k = 0u; k < count; k = k + 1u) {
                pk_isects = pk_isects + 1u;
                let tri = kd_leaf_triangles[node.x + k];
                let t = intersect_triangle(ray, tri, best.t);
                if (t > 0.0) {
                    best.t = t;
                    best.triangle = tri;
                    if (any_hit) {
                        return best;
                    }
                }
            }
            // A hit inside the lane's part of this cell is its closest.
            if (best.triangle != MISS_INDEX && best.t * (1.0 + TRAVERSAL_SLACK) <= lt1) {
                return best;
            }
        }
        // Next cell on the stack where this lane has something left to do.
        loop {
            if (sp == 0u) {
                return best;
            }
            sp = sp - 1u;
            let e = stack_t[sp];
            if (e.z <= e.w && e.z <= best.t) {
                node_index = stack_node[sp];
                t0 = e.x;
                t1 = e.y;
                lt0 = e.z;
                lt1 = e.w;
                break;
            }
        }
    }
    return best;
}

// Four packets per workgroup: they never synchronise, and larger
// workgroups cost less to schedule (on lavapipe notably).
const PACKETS_PER_WORKGROUP: u32 = 4u;

@compute @workgroup_size(64)
fn trace_packet(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    let lane = local % 16u;
    let index = (wid.x + wid.y * packet_params.row_pitch) * PACKETS_PER_WORKGROUP + local / 16u;
    if (index >= packet_params.packet_count) {
        return;
    }
    let pk = packets[index];
    if (lane >= pk.ray_count) {
        return;
    }
    let r = pk.first_ray + lane;
    let d = vec3<f32>(packet_dirs[3u * r], packet_dirs[3u * r + 1u], packet_dirs[3u * r + 2u]);
    let any_hit = (pk.flags & FLAG_ANY_HIT) != 0u;
    pk_cells = 0u;
    pk_isects = 0u;
    var hit: Hit;
    if ((pk.flags & FLAG_SINGLE) != 0u) {
        hit = kd_traverse(pk.origin, d, pk.t_max, any_hit);
        pk_cells = kd_count_cells;
        pk_isects = kd_count_isects;
    } else {
        hit = packet_traverse(pk, d);
        if (hit.triangle == MISS_INDEX && (pk.flags & FLAG_SPECULATIVE) != 0u) {
            hit = kd_traverse(pk.origin, d, pk.t_max, any_hit);
            pk_cells = pk_cells + kd_count_cells;
            pk_isects = pk_isects + kd_count_isects;
        }
    }
    if (hit.triangle == MISS_INDEX) {
        packet_hits[r] = vec2<u32>(PACKET_INF_BITS, MISS_INDEX);
    } else {
        packet_hits[r] = vec2<u32>(bitcast<u32>(hit.t), hit.triangle);
    }
    packet_counts[r] = vec2<u32>(pk_cells, pk_isects);
}
