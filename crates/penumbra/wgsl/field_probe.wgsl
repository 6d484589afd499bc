// Kernel: single lookups, the GPU twin of `field_probe` in
// src/field/lookup.rs (the sample at each object-space ray's entry point,
// and DisplacementField::trace's outcome). Composed after
// sampling.wgsl, frame.wgsl, field_lookup.wgsl, a map-access file and
// field_trace.wgsl.
//
// rays: per ray two vec4s, (origin, 0) and (unit direction, 0).
// results: per ray (kind + 4 flags, t, coverage, weighted distance), kind 0
// outside, 1 miss, 2 hit; flags = inside + 2 hidden.

struct FieldProbeUniforms {
    ray_count: u32,
    row_pitch: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> probe: FieldProbeUniforms;
@group(1) @binding(1) var<storage, read> rays: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read_write> results: array<vec4<f32>>;

@compute @workgroup_size(64)
fn field_probe(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * probe.row_pitch;
    if (i >= probe.ray_count) {
        return;
    }
    let tr = field_trace(rays[2u * i].xyz, rays[2u * i + 1u].xyz);
    let flags = select(0u, 1u, tr.inside) + select(0u, 2u, tr.hidden);
    results[i] = vec4<f32>(f32(tr.kind + 4u * flags), tr.t, tr.sample.x, tr.sample.y);
}
