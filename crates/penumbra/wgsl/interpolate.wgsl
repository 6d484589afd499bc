// interpolate.wgsl: the fast path of bounded-error ray tracing (Bala,
// Dorsey and Teller, sections 4.2 and 6): each pixel's radiance is the
// quadrilinear interpolation of the 16 extremal-ray radiances of the
// linetree cell its eye line falls in, at the line's coordinates in the
// cell (`local`, in [0, 1]^4, computed on the CPU in f64: in f32 a deep
// cell's coordinates would lose the precision the error bound assumes).
//
// CPU twin: `bounded::interpolate::interpolate_pixels` (same layout: a
// `PixelJob` per pixel, 16 `vec4` corners per cell slot, corner k's bit i
// set at the high end of coordinate i; a textured cell's diffuse terms in
// the slot after its own).

struct InterpolateUniforms {
    job_count: u32,
    row_pitch: u32,
    _pad0: u32,
    _pad1: u32,
}

struct PixelJob {
    // The cell's slot in `corners` (16 entries from slot * 16).
    slot: u32,
    pixel: u32,
    // 1 on a textured surface: the next slot holds the terms the texture
    // scales, and the radiance is B + texture * A.
    textured: u32,
    _pad0: u32,
    local: vec4<f32>,
    texture: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: InterpolateUniforms;
@group(0) @binding(1) var<storage, read> corners: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> jobs: array<PixelJob>;
@group(0) @binding(3) var<storage, read_write> radiance: array<vec4<f32>>;

// The weights are products over the four coordinates in order, the sums
// over corners in order, as the twin does, so both round alike.
fn corner_weights(u: vec4<f32>) -> array<f32, 16> {
    var w: array<f32, 16>;
    for (var k = 0u; k < 16u; k = k + 1u) {
        var x = 1.0;
        for (var i = 0u; i < 4u; i = i + 1u) {
            if (((k >> i) & 1u) == 1u) {
                x = x * u[i];
            } else {
                x = x * (1.0 - u[i]);
            }
        }
        w[k] = x;
    }
    return w;
}

fn weighted(base: u32, w: array<f32, 16>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < 16u; k = k + 1u) {
        sum = sum + corners[base + k].xyz * w[k];
    }
    return sum;
}

@compute @workgroup_size(64)
fn interpolate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * params.row_pitch;
    if (k >= params.job_count) {
        return;
    }
    let job = jobs[k];
    let w = corner_weights(job.local);
    var r = weighted(job.slot * 16u, w);
    if (job.textured != 0u) {
        r = r + job.texture.xyz * weighted((job.slot + 1u) * 16u, w);
    }
    radiance[k] = vec4<f32>(r, 0.0);
}
