// Twin of src/accel/kdtree/traverse.rs and src/accel/kdtree/watertight.rs: single-ray
// kd-tree traversal (closest hit / any hit) with watertight intersection over
// the buffers of src/accel/kdtree/mod.rs, uploaded as they are.
// Self-contained (group 0 = the tree); kernels prepend it.
//
// Node words (src/accel/kdtree/node.rs): interior = (split bits, axis | above << 2),
// leaf = (first leaf entry, 3 | count << 2). Below child = node + 1.
//
// WGSL may assume no infinities or NaNs, so where the CPU code lets IEEE
// arithmetic handle zero direction components (1/0 = inf, 0 * inf = NaN) this
// code branches on them explicitly; the decisions are the same.

struct KdScene {
    bounds_min: vec3<f32>,
    node_count: u32,
    bounds_max: vec3<f32>,
    triangle_count: u32,
    // KdTree::frame_scale (a power of two) and its inverse: the frame of
    // the intersection test (ShearedRay::in_frame).
    frame_scale: f32,
    inv_frame_scale: f32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<storage, read> kd_nodes: array<vec2<u32>>;
@group(0) @binding(1) var<storage, read> kd_leaf_triangles: array<u32>;
@group(0) @binding(2) var<storage, read> kd_triangles: array<f32>;
@group(0) @binding(3) var<uniform> kd_scene: KdScene;

const MAX_TREE_DEPTH: u32 = 40u;
const MISS_INDEX: u32 = 0xffffffffu;
// TRAVERSAL_SLACK of src/accel/kdtree/traverse.rs: cells are entered when the ray
// comes within this relative distance of them, so rounding cannot skip a
// cell the ray touches at a single point.
const TRAVERSAL_SLACK: f32 = 1e-6;
// Stands in for +infinity as a ray's t_max ("no radius").
const T_INFINITE: f32 = 3.4028235e38;

struct Hit {
    t: f32,
    triangle: u32,
}

// Traversal steps and intersection tests of the last kd_traverse call.
var<private> kd_count_cells: u32;
var<private> kd_count_isects: u32;

// Ray interval inside the scene box, widened by TRAVERSAL_SLACK before it is
// tested (Aabb::clip_ray_widened); x > y when the ray misses it.
fn kd_clip_ray(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> vec2<f32> {
    var t0 = 0.0;
    var t1 = t_max;
    for (var a = 0u; a < 3u; a = a + 1u) {
        if (d[a] == 0.0) {
            if (o[a] < kd_scene.bounds_min[a] || o[a] > kd_scene.bounds_max[a]) {
                return vec2<f32>(1.0, 0.0);
            }
            continue;
        }
        let inv = 1.0 / d[a];
        var near = (kd_scene.bounds_min[a] - o[a]) * inv;
        var far = (kd_scene.bounds_max[a] - o[a]) * inv;
        if (near > far) {
            let tmp = near;
            near = far;
            far = tmp;
        }
        t0 = max(t0, near);
        t1 = min(t1, far);
    }
    return vec2<f32>(t0 * (1.0 - TRAVERSAL_SLACK), t1 * (1.0 + TRAVERSAL_SLACK));
}

struct ShearedRay {
    org: vec3<f32>,
    kx: u32,
    ky: u32,
    kz: u32,
    s: vec3<f32>,
}

fn make_sheared_ray(o: vec3<f32>, d: vec3<f32>) -> ShearedRay {
    let a = abs(d);
    var kz = 2u;
    if (a.x >= a.y && a.x >= a.z) {
        kz = 0u;
    } else if (a.y >= a.z) {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if (d[kz] < 0.0) {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    var r: ShearedRay;
    r.org = o;
    r.kx = kx;
    r.ky = ky;
    r.kz = kz;
    r.s = vec3<f32>(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    return r;
}

// Edge function p.x q.y - p.y q.x, always evaluated in one canonical vertex
// order and negated when swapped: an edge shared by two triangles then gets
// exactly opposite values even if the compiler fuses the multiply-add.
fn edge_function(p: vec2<f32>, q: vec2<f32>) -> f32 {
    let swap = p.x > q.x || (p.x == q.x && p.y > q.y);
    let a = select(p, q, swap);
    let b = select(q, p, swap);
    let e = a.x * b.y - a.y * b.x;
    return select(e, -e, swap);
}

fn kd_vertex(tri: u32, v: u32) -> vec3<f32> {
    let i = tri * 9u + v * 3u;
    return vec3<f32>(kd_triangles[i], kd_triangles[i + 1u], kd_triangles[i + 2u]);
}

// ShearedRay::intersect: t in (0, t_max) or -1. In the frame of
// kd_scene.frame_scale: (v - o) * scale equals the CPU's v * scale - o * scale
// exactly (a power of two), so t_scaled can neither overflow nor underflow
// at extreme scene sizes and the hits stay the CPU's.
fn intersect_triangle(r: ShearedRay, tri: u32, t_max: f32) -> f32 {
    let k = kd_scene.frame_scale;
    let a = (kd_vertex(tri, 0u) - r.org) * k;
    let b = (kd_vertex(tri, 1u) - r.org) * k;
    let c = (kd_vertex(tri, 2u) - r.org) * k;
    let a2 = vec2<f32>(a[r.kx] - r.s.x * a[r.kz], a[r.ky] - r.s.y * a[r.kz]);
    let b2 = vec2<f32>(b[r.kx] - r.s.x * b[r.kz], b[r.ky] - r.s.y * b[r.kz]);
    let c2 = vec2<f32>(c[r.kx] - r.s.x * c[r.kz], c[r.ky] - r.s.y * c[r.kz]);
    let u = edge_function(c2, b2);
    let v = edge_function(a2, c2);
    let w = edge_function(b2, a2);
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return -1.0;
    }
    let det = u + v + w;
    if (det == 0.0) {
        return -1.0;
    }
    let t_scaled = u * (r.s.z * a[r.kz]) + v * (r.s.z * b[r.kz]) + w * (r.s.z * c[r.kz]);
    if ((det > 0.0 && t_scaled <= 0.0) || (det < 0.0 && t_scaled >= 0.0)) {
        return -1.0;
    }
    let t = t_scaled / det;
    if (t > 0.0 && t < t_max * k) {
        return t * kd_scene.inv_frame_scale;
    }
    return -1.0;
}

// KdTree::traverse. `any_hit` returns the first hit found.
fn kd_traverse(o: vec3<f32>, d_in: vec3<f32>, t_max: f32, any_hit: bool) -> Hit {
    // geom::ray::flush_subnormal: subnormal direction components are zeros.
    let d = select(d_in, d_in * 0.0, abs(d_in) < vec3<f32>(1.17549435e-38));
    kd_count_cells = 0u;
    kd_count_isects = 0u;
    var best: Hit;
    best.t = t_max;
    best.triangle = MISS_INDEX;
    let clipped = kd_clip_ray(o, d, t_max);
    if (clipped.x > clipped.y) {
        return best;
    }
    var t_min = clipped.x;
    var t_cell_max = clipped.y;
    let ray = make_sheared_ray(o, d);
    // Same rounding as the CPU's (split - o) * (1 / d); unused where d = 0.
    let inv_d = 1.0 / select(d, vec3<f32>(1.0), d == vec3<f32>(0.0));

    var stack_node: array<u32, MAX_TREE_DEPTH>;
    var stack_t: array<vec2<f32>, MAX_TREE_DEPTH>;
    var sp = 0u;
    var node_index = 0u;
    loop {
        kd_count_cells = kd_count_cells + 1u;
        let node = kd_nodes[node_index];
        if ((node.y & 3u) != 3u) {
            let axis = node.y & 3u;
            let split = bitcast<f32>(node.x);
            let above = node.y >> 2u;
            let oa = o[axis];
            let da = d[axis];
            let below_first = oa < split || (oa == split && da <= 0.0);
            let first = select(above, node_index + 1u, below_first);
            let second = select(node_index + 1u, above, below_first);
            if (da == 0.0) {
                // Parallel to the plane: one side, or both if lying in it.
                if (oa != split) {
                    node_index = first;
                } else {
                    stack_node[sp] = second;
                    stack_t[sp] = vec2<f32>(t_min, t_cell_max);
                    sp = sp + 1u;
                    node_index = first;
                }
                continue;
            }
            let t_plane = (split - oa) * inv_d[axis];
            if (t_plane <= 0.0 || t_plane * (1.0 - TRAVERSAL_SLACK) > t_cell_max) {
                node_index = first;
            } else if (t_plane * (1.0 + TRAVERSAL_SLACK) < t_min) {
                node_index = second;
            } else {
                stack_node[sp] = second;
                stack_t[sp] = vec2<f32>(max(t_min, t_plane * (1.0 - TRAVERSAL_SLACK)), t_cell_max);
                sp = sp + 1u;
                t_cell_max = min(t_cell_max, t_plane * (1.0 + TRAVERSAL_SLACK));
                node_index = first;
            }
            continue;
        }

        let first_entry = node.x;
        let count = node.y >> 2u;
        for (var k = 0u; k < count; k = k + 1u) {
            kd_count_isects = kd_count_isects + 1u;
            let tri = kd_leaf_triangles[first_entry + k];
            let t = intersect_triangle(ray, tri, best.t);
            if (t > 0.0) {
                best.t = t;
                best.triangle = tri;
                if (any_hit) {
                    return best;
                }
            }
        }
        if (best.triangle != MISS_INDEX && best.t * (1.0 + TRAVERSAL_SLACK) <= t_cell_max) {
            return best;
        }
        loop {
            if (sp == 0u) {
                return best;
            }
            sp = sp - 1u;
            node_index = stack_node[sp];
            t_min = stack_t[sp].x;
            t_cell_max = stack_t[sp].y;
            if (t_min <= best.t) {
                break;
            }
        }
    }
    return best;
}
