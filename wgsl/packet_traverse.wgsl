// Kernel: MLRTA packets on the GPU, the twin of src/mlrta/packet.rs
// (`trace_packet`). Composed after kdtree_traverse.wgsl.
//
// A workgroup traces one packet (up to 16 rays with a common origin and
// same-sign directions) from the packet's entry point, found on the CPU.
// Every invocation runs the packet's interval traversal (section 4.3 of the
// MLRTA paper): the decisions at interior nodes use only the packet record,
// so all lanes take them alike and read the same nodes; leaves are clipped
// against the packet's frustum (equation (2)), then each lane tests the
// triangles for its own ray if the ray passes through the leaf. A lane stops
// when its hit lies before the next cell on the stack. No barriers are
// needed: the shared decisions are computed redundantly.
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
}

struct PacketParams {
    packet_count: u32,
    // Packets per row of the 2D dispatch grid.
    row_pitch: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<storage, read> packets: array<PacketRecord>;
@group(1) @binding(1) var<storage, read> packet_dirs: array<f32>;
@group(1) @binding(2) var<storage, read_write> packet_hits: array<vec2<u32>>;
@group(1) @binding(3) var<uniform> packet_params: PacketParams;
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
    var earliest_exit = pk.t_max;
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

// Frustum::may_hit_box.
fn pk_may_hit_box(pk: PacketRecord, lo: vec3<f32>, hi: vec3<f32>) -> bool {
    let t = pk_box_interval(pk, lo, hi);
    return pk_down(t.x) <= pk_up(t.y) && pk_up(t.y) >= 0.0;
}

// Packet::lane_slabs for this lane: does the ray pass the box within [0, limit]?
fn pk_lane_enters(o: vec3<f32>, inv: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>, limit: f32) -> bool {
    let t1 = (lo - o) * inv;
    let t2 = (hi - o) * inv;
    let n = min(t1, t2);
    let f = max(t1, t2);
    let near = max(max(n.x, n.y), max(n.z, 0.0));
    let far = min(min(f.x, f.y), min(f.z, limit));
    return pk_down(near) <= pk_up(far);
}

var<private> pk_cells: u32;
var<private> pk_isects: u32;

fn packet_traverse(pk: PacketRecord, d: vec3<f32>) -> Hit {
    let any_hit = (pk.flags & FLAG_ANY_HIT) != 0u;
    let o = pk.origin;
    let inv = 1.0 / d;
    let ray = make_sheared_ray(o, d);
    var best: Hit;
    best.t = pk.t_max;
    best.triangle = MISS_INDEX;
    // The packet's interval in the entry cell (from its frustum, as on the CPU).
    let entry = pk_box_interval(pk, pk.cell_min, pk.cell_max);
    var t0 = pk_down(max(entry.x, 0.0));
    var t1 = pk_up(entry.y);
    if (t0 > t1 || !pk_lane_enters(o, inv, pk.cell_min, pk.cell_max, pk.t_max)) {
        return best;
    }
    var stack_node: array<u32, MAX_TREE_DEPTH>;
    var stack_t: array<vec2<f32>, MAX_TREE_DEPTH>;
    var stack_lo: array<vec3<f32>, MAX_TREE_DEPTH>;
    var stack_hi: array<vec3<f32>, MAX_TREE_DEPTH>;
    var sp = 0u;
    var node_index = pk.entry_node;
    var lo = pk.cell_min;
    var hi = pk.cell_max;
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
            // The near and far cells: the current one cut at the plane.
            var near_lo = lo;
            var near_hi = hi;
            var far_lo = lo;
            var far_hi = hi;
            if (near_below) {
                near_hi[axis] = split;
                far_lo[axis] = split;
            } else {
                near_lo[axis] = split;
                far_hi[axis] = split;
            }
            let tp = pk_plane_t(pk, axis, split);
            if (tp.y <= 0.0 || pk_down(tp.x) > t1) {
                node_index = near;
                lo = near_lo;
                hi = near_hi;
            } else if (pk_up(tp.y) < t0) {
                node_index = far;
                lo = far_lo;
                hi = far_hi;
            } else {
                stack_node[sp] = far;
                stack_t[sp] = vec2<f32>(max(t0, pk_down(tp.x)), t1);
                stack_lo[sp] = far_lo;
                stack_hi[sp] = far_hi;
                sp = sp + 1u;
                t1 = min(t1, pk_up(tp.y));
                node_index = near;
                lo = near_lo;
                hi = near_hi;
            }
            continue;
        }
        let count = node.y >> 2u;
        if (count > 0u && pk_may_hit_box(pk, lo, hi)) {
            // This lane is masked if its hit lies before the cell's earliest
            // entry, or if it does not pass through the cell.
            if (best.t >= pk_down(t0) && pk_lane_enters(o, inv, lo, hi, best.t)) {
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
            }
        }
        // Next cell on the stack that starts before this lane's hit.
        loop {
            if (sp == 0u) {
                return best;
            }
            sp = sp - 1u;
            if (pk_down(stack_t[sp].x) <= best.t) {
                node_index = stack_node[sp];
                t0 = stack_t[sp].x;
                t1 = stack_t[sp].y;
                lo = stack_lo[sp];
                hi = stack_hi[sp];
                break;
            }
        }
    }
    return best;
}

@compute @workgroup_size(16)
fn trace_packets(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    let index = wid.x + wid.y * packet_params.row_pitch;
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
