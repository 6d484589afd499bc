// Kernel: ambient-occlusion rays, the GPU twin of src/raycast/ao_rays.rs
// (`ao_rays`, and `ao_samples` for the check below). One invocation per
// ray: ray j of point p goes in the cosine-weighted direction of sample j of
// the point's stream of the seeded sequence, and sets bit j of the point's
// mask when nothing is hit within the radius. Composed after sampling.wgsl,
// frame.wgsl, kdtree_traverse.wgsl and texture_maps.wgsl.
//
// points: 8 words per point (origin xyz, stream index, unit normal xyz, pad),
//         origins already offset; a zero normal casts no rays (all visible).
// visible: words_per_point u32 per point, bit j = ray j unoccluded.
// samples: written by `ao_samples` only (the CPU twin's check): per ray, the
//          sample point and the direction, as two vec4s (u, v, 0, 0), (dir, 0).
// cutouts: the words of scene::cutouts::Cutouts::words when `has_cutouts`
//          is 1: a ray that hits a cut-out's hole goes on past it.

struct AoRaysUniforms {
    point_count: u32,
    rays_per_point: u32,
    words_per_point: u32,
    seed: u32,
    row_pitch: u32,
    radius: f32,
    has_cutouts: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<storage, read> points: array<f32>;
@group(1) @binding(1) var<storage, read_write> visible: array<atomic<u32>>;
@group(1) @binding(2) var<uniform> params: AoRaysUniforms;
@group(1) @binding(3) var<storage, read_write> samples: array<vec4<f32>>;
@group(1) @binding(4) var<storage, read> cutouts: array<u32>;

const MAX_HOLE_CROSSINGS: u32 = 16u;
const OFFSET_SCALE: f32 = 1.52587890625e-5; // 2^-16
const MIN_POSITIVE: f32 = 1.17549435e-38;

// The cut-out maps (texture_maps.wgsl) at the words4 the header names.
fn map_word(k: u32) -> u32 {
    return cutouts[k];
}

fn maps_base() -> u32 {
    return cutouts[0];
}

// scene::cutouts::barycentrics.
fn cutout_barycentrics(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, p: vec3<f32>) -> vec2<f32> {
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let w = p - v0;
    let d00 = dot(e1, e1);
    let d01 = dot(e1, e2);
    let d11 = dot(e2, e2);
    let d20 = dot(w, e1);
    let d21 = dot(w, e2);
    let denom = d00 * d11 - d01 * d01;
    if (denom == 0.0) {
        return vec2<f32>(0.0);
    }
    return vec2<f32>((d11 * d20 - d01 * d21) / denom, (d00 * d21 - d01 * d20) / denom);
}

// Cutouts::is_hole.
fn cutout_hole(tri: u32, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, p: vec3<f32>) -> bool {
    let r = cutouts[cutouts[1] + tri];
    if (r == NO_MAP) {
        return false;
    }
    let b = cutouts[2] + r * 8u;
    let bc = cutout_barycentrics(v0, v1, v2, p);
    let uv0 = vec2<f32>(bitcast<f32>(cutouts[b + 1u]), bitcast<f32>(cutouts[b + 2u]));
    let uv1 = vec2<f32>(bitcast<f32>(cutouts[b + 3u]), bitcast<f32>(cutouts[b + 4u]));
    let uv2 = vec2<f32>(bitcast<f32>(cutouts[b + 5u]), bitcast<f32>(cutouts[b + 6u]));
    let uv = uv0 * (1.0 - bc.x - bc.y) + uv1 * bc.x + uv2 * bc.y;
    return map_hole(cutouts[b], uv);
}

fn max_abs3(v: vec3<f32>) -> f32 {
    let a = abs(v);
    return max(max(a.x, a.y), a.z);
}

// scene::cutouts::past_hole.
fn past_hole(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, p: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let c = cross(v1 - v0, v2 - v0);
    let len2 = dot(c, c);
    var n = vec3<f32>(0.0);
    if (len2 > 0.0) {
        n = c * (1.0 / sqrt(len2));
    }
    let through = select(-n, n, dot(n, d) > 0.0);
    let magnitude = max(max(max_abs3(v0), max_abs3(v1)), max_abs3(v2));
    let m = max(magnitude, max_abs3(p));
    return p + through * max(m * OFFSET_SCALE, MIN_POSITIVE);
}

// raycast::holes::closest_past_holes: whether the ray escapes within t_max.
fn escapes_past_holes(origin: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    var o = origin;
    var left = t_max;
    let scale = 1.0 / dot(d, d);
    for (var crossed = 0u; crossed <= MAX_HOLE_CROSSINGS; crossed = crossed + 1u) {
        let hit = kd_traverse(o, d, left, false);
        if (hit.triangle == MISS_INDEX) {
            return true;
        }
        let v0 = kd_vertex(hit.triangle, 0u);
        let v1 = kd_vertex(hit.triangle, 1u);
        let v2 = kd_vertex(hit.triangle, 2u);
        let p = o + d * hit.t;
        if (crossed == MAX_HOLE_CROSSINGS || !cutout_hole(hit.triangle, v0, v1, v2, p)) {
            return false;
        }
        let next = past_hole(v0, v1, v2, p, d);
        let step = dot(next - o, d) * scale;
        left = left - step;
        o = next;
        if (left <= 0.0) {
            return true;
        }
    }
    return true;
}

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
    if (hit.triangle == MISS_INDEX || (params.has_cutouts != 0u && escapes_past_holes(r.origin, r.dir, params.radius))) {
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
