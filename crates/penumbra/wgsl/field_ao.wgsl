// Kernel: ambient occlusion through displacement fields (Algorithm 2 of the
// paper), the GPU twin of src/field/ao.rs (`field_ao`). One invocation
// per word of a point's mask (32 rays; `row_pitch` counts words): ray j of
// point p follows sample j of the point's stream, as in ao_rays.wgsl, and
// asks every instance of this dispatch's field (not the point's own
// instance). Composed after sampling.wgsl, frame.wgsl, field_lookup.wgsl, a
// map-access file and field_trace.wgsl. A scene with several fields runs one
// dispatch per field into the same `classes` buffer.
//
// classes: three bit masks of words_per_point words per point, one after the
// other: occluded (a field hit within the radius), inside (the ray started
// inside a sphere it entered), hidden (a field put its surface behind the
// origin). Visibility is the complement of `occluded`.

// `FieldAoUniforms` in src/field/gpu.rs.
struct FieldAoUniforms {
    point_count: u32,
    rays_per_point: u32,
    words_per_point: u32,
    seed: u32,
    row_pitch: u32,
    radius: f32,
    instance_count: u32,
    _pad: u32,
}

// `GpuInstance` in src/field/gpu.rs: the world-to-object motion.
struct FieldInstance {
    inv_rotation: vec4<f32>,
    translation: vec3<f32>,
    scale: f32,
    instance: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<uniform> ao: FieldAoUniforms;
@group(1) @binding(1) var<storage, read> points: array<f32>;
@group(1) @binding(2) var<storage, read> owners: array<u32>;
@group(1) @binding(3) var<storage, read> instances: array<FieldInstance>;
@group(1) @binding(4) var<storage, read_write> classes: array<atomic<u32>>;

// glam's Quat * Vec3.
fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let b = q.xyz;
    let w = q.w;
    return v * (w * w - dot(b, b)) + b * (dot(v, b) * 2.0) + cross(b, v) * (w * 2.0);
}

// One invocation per mask word: the up to 32 rays of point p whose bits
// share word w, so that the point's inputs are read once and each class is
// one atomicOr (where any of its bits is set) instead of one per ray. Per
// ray invocations spent about 40 ns each on lavapipe before any work (the
// cow corner's 836,352 rays: 35 of its 111 ms with the kernel returning
// after reading its point).
@compute @workgroup_size(64)
fn field_ao(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w_all = gid.x + gid.y * ao.row_pitch;
    let p = w_all / ao.words_per_point;
    let w = w_all % ao.words_per_point;
    if (p >= ao.point_count) {
        return;
    }
    let base = p * 8u;
    let normal = vec3<f32>(points[base + 4u], points[base + 5u], points[base + 6u]);
    if (all(normal == vec3<f32>(0.0))) {
        return;
    }
    let origin = vec3<f32>(points[base], points[base + 1u], points[base + 2u]);
    let stream = bitcast<u32>(points[base + 3u]);
    let owner = owners[p];
    let first = 32u * w;
    let count = min(32u, ao.rays_per_point - first);
    // The word's directions, made once for every instance.
    let frame = frame_basis(normal);
    var dirs: array<vec3<f32>, 32>;
    for (var b = 0u; b < count; b++) {
        let uv = sequence_sample(ao.seed, stream, first + b);
        dirs[b] = basis_to_world(frame, cosine_hemisphere(uv.x, uv.y));
    }
    var occluded = 0u;
    var inside = 0u;
    var hidden = 0u;
    for (var k = 0u; k < ao.instance_count; k++) {
        let inst = instances[k];
        if (inst.instance == owner) {
            continue;
        }
        let o = quat_rotate(inst.inv_rotation, origin - inst.translation) / inst.scale;
        // The sphere tests first, then the lookups of the rays that reach
        // the sphere one after another: lanes run in step, and testing and
        // looking up ray by ray made every lane wait on the lookup whenever
        // one of its neighbours' rays entered (most steps, with a quarter of
        // the rays entering), where now each lane's lookups are its own.
        var entering = 0u;
        for (var b = 0u; b < count; b++) {
            let d = normalize(quat_rotate(inst.inv_rotation, dirs[b]));
            if (field_enters(field_sphere_span(o, d))) {
                entering |= 1u << b;
            }
        }
        while (entering != 0u) {
            let b = firstTrailingBit(entering);
            let bit = 1u << b;
            entering ^= bit;
            let d = normalize(quat_rotate(inst.inv_rotation, dirs[b]));
            let tr = field_trace(o, d);
            if (tr.inside) {
                inside |= bit;
            }
            if (tr.kind == FIELD_HIT && tr.t * inst.scale <= ao.radius) {
                occluded |= bit;
            }
            if (tr.hidden) {
                hidden |= bit;
            }
        }
    }
    // Several fields' dispatches OR into the same words.
    let words = ao.point_count * ao.words_per_point;
    let word = p * ao.words_per_point + w;
    if (occluded != 0u) {
        atomicOr(&classes[word], occluded);
    }
    if (inside != 0u) {
        atomicOr(&classes[words + word], inside);
    }
    if (hidden != 0u) {
        atomicOr(&classes[2u * words + word], hidden);
    }
}
