// Render pipeline: the G-buffer of src/ssao/gbuffer.rs (CPU twin:
// `gbuffer`, kd-tree primary rays through the pixel centres). Composed
// after albedo.wgsl.
//
// Vertices are unindexed, three per triangle: world position, the unit
// world face normal (zero for degenerate triangles) and the packed albedo.
// The projection is reversed-Z with an infinite far plane: clip =
// (x / tan_half_x, y / tan_half_y, near, z) in camera space (x right,
// y up, z forward), so depth = near / z, nearer is larger (compare Greater,
// clear 0). Outputs per pixel:
//   geometry = (camera-space normal turned towards the camera, camera-space z)
//   shade    = (albedo x direct light, packed albedo r + 256 g + 65536 b)
// Background stays cleared to zero (z = 0). Scenes with colour maps or
// cut-outs are drawn by the entry points of gbuffer_textured.wgsl, composed
// after this file.

struct View {
    eye: vec3<f32>,
    light_count: u32,
    right: vec3<f32>,
    tan_half_x: f32,
    up: vec3<f32>,
    tan_half_y: f32,
    forward: vec3<f32>,
    near: f32,
    // per light: (position or travel direction, 1 point / 0 directional),
    // (intensity or radiance, 0)
    lights: array<vec4<f32>, 8>,
}

@group(0) @binding(0) var<uniform> view: View;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: f32,
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) normal: vec3<f32>,
    @location(2) @interpolate(flat) albedo: f32,
}

struct GBufferOut {
    @location(0) geometry: vec4<f32>,
    @location(1) shade: vec4<f32>,
}

// A vertex projected (reversed-Z, infinite far plane), its attributes passed on.
fn gbuffer_vertex(v: VertexIn) -> VertexOut {
    let rel = v.position - view.eye;
    let c = vec3<f32>(dot(rel, view.right), dot(rel, view.up), dot(rel, view.forward));
    var out: VertexOut;
    out.clip = vec4<f32>(c.x / view.tan_half_x, c.y / view.tan_half_y, view.near, c.z);
    out.world = v.position;
    out.normal = v.normal;
    out.albedo = v.albedo;
    return out;
}

@vertex
fn gbuffer_vs(v: VertexIn) -> VertexOut {
    return gbuffer_vertex(v);
}

// Twin of gbuffer::direct_light (no shadows).
fn direct_light(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    var e = vec3<f32>(0.0);
    for (var i = 0u; i < min(view.light_count, 4u); i = i + 1u) {
        let a = view.lights[2u * i];
        let power = view.lights[2u * i + 1u].xyz;
        if (a.w == 0.0) {
            let l = -a.xyz;
            e = e + power * max(dot(n, l), 0.0);
        } else {
            let d = a.xyz - p;
            let d2 = max(dot(d, d), 1e-12);
            e = e + power * max(dot(n, d) / sqrt(d2), 0.0) / d2;
        }
    }
    return e;
}

// The targets' texels of a surface point (world position, unit face
// normal, packed albedo): the twin of gbuffer::texel.
fn gbuffer_texel(world: vec3<f32>, normal: vec3<f32>, albedo: f32) -> GBufferOut {
    let rel = world - view.eye;
    var n = normal;
    if (dot(n, rel) > 0.0) {
        n = -n;
    }
    var out: GBufferOut;
    let z = dot(rel, view.forward);
    out.geometry = vec4<f32>(dot(n, view.right), dot(n, view.up), dot(n, view.forward), z);
    out.shade = vec4<f32>(unpack_albedo(albedo) * direct_light(world, n), albedo);
    return out;
}

@fragment
fn gbuffer_fs(in: VertexOut) -> GBufferOut {
    return gbuffer_texel(in.world, in.normal, in.albedo);
}
