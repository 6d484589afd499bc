// Kernel: closest hit (or any hit) of a batch of rays, the GPU twin of
// KdTree::trace_closest / trace_any / trace_closest_counted (src/accel/kdtree/;
// src/accel/kdtree/gpu.rs drives it).
// Composed after kdtree_traverse.wgsl.
//
// rays: 6 f32 per ray (origin, direction), as in a RAYS.f32 file.
// hits: (t bits, triangle) per ray, as in a HITS.bin file; a miss is
//       (+inf, 0xffffffff).
// counts: (traversal steps, intersection tests) per ray, written by the
//         `_counted` entry point only.

struct TraceRaysUniforms {
    ray_count: u32,
    // Rays per row of the 2D dispatch grid (workgroups in x * 64).
    row_pitch: u32,
    t_max: f32,
    _pad: u32,
}

@group(1) @binding(0) var<storage, read> rays: array<f32>;
@group(1) @binding(1) var<storage, read_write> hits: array<vec2<u32>>;
@group(1) @binding(2) var<uniform> params: TraceRaysUniforms;
@group(1) @binding(3) var<storage, read_write> counts: array<vec2<u32>>;

const POSITIVE_INFINITY_BITS: u32 = 0x7f800000u;

fn ray_index(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * params.row_pitch;
}

fn trace_one(i: u32, any_hit: bool) -> vec2<u32> {
    let b = i * 6u;
    let o = vec3<f32>(rays[b], rays[b + 1u], rays[b + 2u]);
    let d = vec3<f32>(rays[b + 3u], rays[b + 4u], rays[b + 5u]);
    let hit = kd_traverse(o, d, params.t_max, any_hit);
    if (hit.triangle == MISS_INDEX) {
        return vec2<u32>(POSITIVE_INFINITY_BITS, MISS_INDEX);
    }
    return vec2<u32>(bitcast<u32>(hit.t), hit.triangle);
}

@compute @workgroup_size(64)
fn trace_closest(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = ray_index(gid);
    if (i >= params.ray_count) {
        return;
    }
    hits[i] = trace_one(i, false);
}

@compute @workgroup_size(64)
fn trace_any(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = ray_index(gid);
    if (i >= params.ray_count) {
        return;
    }
    hits[i] = trace_one(i, true);
}

@compute @workgroup_size(64)
fn trace_closest_counted(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = ray_index(gid);
    if (i >= params.ray_count) {
        return;
    }
    hits[i] = trace_one(i, false);
    counts[i] = vec2<u32>(kd_count_cells, kd_count_isects);
}
