// Kernel: ambient-occlusion rays, the GPU twin of src/raycast/ao_rays.rs
// (`ao_rays`, and `ao_samples` for the check below). One invocation per
// ray: ray j of point p goes in the cosine-weighted direction of sample j of
// the point's stream of the seeded sequence, and sets bit j of the point's
// mask when nothing is hit within the radius. Composed after sampling.wgsl,
// frame.wgsl and kdtree_traverse.wgsl.
//
// points: 8 words per point (origin xyz, stream index, unit normal xyz, pad),
//         origins already offset; a zero normal casts no rays (all visible).
// visible: words_per_point u32 per point, bit j = ray j unoccluded.
// samples: written by `ao_samples` only (the CPU twin's check): per ray, the
//          sample point and the direction, as two vec4s (u, v, 0, 0), (dir, 0).

struct AoRaysUniforms {
    point_count: u32,
    rays_per_point: u32,
    words_per_point: u32,
    seed: u32,
    row_pitch: u32,
    radius: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<storage, read> points: array<f32>;
@group(1) @binding(1) var<storage, read_write> visible: array<atomic<u32>>;
@group(1) @binding(2) var<uniform> params: AoRaysUniforms;
@group(1) @binding(3) var<storage, read_write> samples: array<vec4<f32>>;

struct AoRay {
    point: u32,
    j: u32,
    origin: vec3<f32>,
    normal: vec3<f32>,
    uv: vec2<f32>,
    dir: vec3<f32>,
}

fn ao_ray(gid: vec3<u32>) -> AoRay {
    var r: AoRay;
    let ray = gid.x + gid.y * params.row_pitch;
    r.point = ray / params.rays_per_point;
    r.j = ray % params.rays_per_point;
    if (r.point >= params.point_count) {
        return r;
    }
    let b = r.point * 8u;
    r.origin = vec3<f32>(points[b], points[b + 1u], points[b + 2u]);
    let stream = bitcast<u32>(points[b + 3u]);
    r.normal = vec3<f32>(points[b + 4u], points[b + 5u], points[b + 6u]);
    r.uv = sequence_sample(params.seed, stream, r.j);
    r.dir = frame_to_world(r.normal, cosine_hemisphere(r.uv.x, r.uv.y));
    return r;
}

@compute @workgroup_size(64)
fn ao_rays(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = ao_ray(gid);
    if (r.point >= params.point_count) {
        return;
    }
    let word = r.point * params.words_per_point + r.j / 32u;
    // A zero normal has no hemisphere: no rays, counted as open.
    if (all(r.normal == vec3<f32>(0.0))) {
        atomicOr(&visible[word], 1u << (r.j % 32u));
        return;
    }
    let hit = kd_traverse(r.origin, r.dir, params.radius, true);
    if (hit.triangle == MISS_INDEX) {
        atomicOr(&visible[word], 1u << (r.j % 32u));
    }
}

@compute @workgroup_size(64)
fn ao_samples(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = ao_ray(gid);
    if (r.point >= params.point_count) {
        return;
    }
    let i = (r.point * params.rays_per_point + r.j) * 2u;
    samples[i] = vec4<f32>(r.uv, 0.0, 0.0);
    samples[i + 1u] = vec4<f32>(r.dir, 0.0);
}
