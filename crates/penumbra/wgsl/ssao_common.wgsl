// Shared by the SSAO kernels (twins in src/ssao/): parameters, bindings,
// camera-space reconstruction and projection, the depth-buffer visibility
// test and the pixel's sample set. Composed after frame.wgsl.
//
// group(0): the G-buffer textures of gbuffer.wgsl (geometry = camera-space
//           normal and z, shade = radiance and packed albedo).
// group(1): params; table (the sample sets, (q.xyz, w) per entry, set k at
//           k * samples); ao (estimator output, on the estimation grid),
//           ao_out (filtered, full resolution);
//           indirect (L~ rgb, pixels averaged), indirect_out (filtered);
//           image (linear rgba); depth (the geometry texture's z as a
//           tight array, written by `ssao_pack_depth`: buffer loads are
//           much cheaper than texel fetches on a software rasteriser, and
//           every sample reads one); scratch (the filter's row sums and
//           counts, then at half resolution the filtered grid: see
//           ssao_filter.wgsl).
//
// The estimator and the AO filter run on the estimation grid: every
// `scale`-th pixel in x and y (lo_width x lo_height cells; scale 1 = every
// pixel, 2 = half resolution, upsampled by `ssao_upsample`). Cell (X, Y)
// shades pixel (scale X, scale Y) and takes sample set pattern_index(X, Y).

struct SsaoUniforms {
    width: u32,
    height: u32,
    samples: u32,
    pattern: u32,
    steps: u32,
    rays: u32,
    table_kind: u32,
    calibrate: u32,
    radius: f32,
    bias: f32,
    filter_depth: f32,
    ambient: f32,
    tan_half_x: f32,
    tan_half_y: f32,
    inv_tan_half_x: f32,
    inv_tan_half_y: f32,
    half_w: f32,
    half_h: f32,
    px_x: f32,
    px_y: f32,
    open_weight: f32,
    lo_width: u32,
    lo_height: u32,
    scale: u32,
}

@group(0) @binding(0) var geometry: texture_2d<f32>;
@group(0) @binding(1) var shade: texture_2d<f32>;

@group(1) @binding(0) var<uniform> params: SsaoUniforms;
@group(1) @binding(1) var<storage, read> table: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read_write> ao: array<f32>;
@group(1) @binding(3) var<storage, read_write> ao_out: array<f32>;
@group(1) @binding(4) var<storage, read_write> indirect: array<vec4<f32>>;
@group(1) @binding(5) var<storage, read_write> indirect_out: array<vec4<f32>>;
@group(1) @binding(6) var<storage, read_write> image: array<vec4<f32>>;
@group(1) @binding(7) var<storage, read_write> depth: array<f32>;
@group(1) @binding(8) var<storage, read_write> scratch: array<f32>;

// gbuffer::valid_depth: 0 < d <= 3e38 (0, NaN, infinity and huge
// far-plane values are background).
fn valid_depth(d: f32) -> bool {
    return d > 0.0 && d <= 3.0e38;
}

fn texel(x: u32, y: u32) -> vec4<f32> {
    return textureLoad(geometry, vec2<i32>(i32(x), i32(y)), 0);
}

// ScreenConstants::cam_point
fn cam_point(x: u32, y: u32, z: f32) -> vec3<f32> {
    let ndc_x = (f32(x) + 0.5) * params.px_x - 1.0;
    let ndc_y = 1.0 - (f32(y) + 0.5) * params.px_y;
    return vec3<f32>(ndc_x * params.tan_half_x * z, ndc_y * params.tan_half_y * z, z);
}

// ScreenConstants::project: the pixel of camera-space p, or (-1, -1)
// outside the image or behind the camera.
fn project(p: vec3<f32>) -> vec2<i32> {
    if (!(p.z > 0.0)) {
        return vec2<i32>(-1, -1);
    }
    let inv_z = 1.0 / p.z;
    let fx = (p.x * inv_z * params.inv_tan_half_x + 1.0) * params.half_w;
    let fy = (1.0 - p.y * inv_z * params.inv_tan_half_y) * params.half_h;
    if (fx >= 0.0 && fx < f32(params.width) && fy >= 0.0 && fy < f32(params.height)) {
        return vec2<i32>(i32(fx), i32(fy));
    }
    return vec2<i32>(-1, -1);
}

// ScreenConstants::homogeneous: (fx z, fy z, z) for camera-space p, where
// (fx, fy) is where `project` puts it; linear in p, so a pixel maps its
// tangent frame once and each sample costs three multiply-adds per axis.
fn homogeneous(p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        (p.x * params.inv_tan_half_x + p.z) * params.half_w,
        (p.z - p.y * params.inv_tan_half_y) * params.half_h,
        p.z,
    );
}

// estimators::occluded_homogeneous: `occluded` for h = homogeneous(p).
fn occluded_homogeneous(h: vec3<f32>) -> bool {
    if (!(h.z > 0.0)) {
        return false;
    }
    let inv_z = 1.0 / h.z;
    let fx = h.x * inv_z;
    let fy = h.y * inv_z;
    if (!(fx >= 0.0 && fx < f32(params.width) && fy >= 0.0 && fy < f32(params.height))) {
        return false;
    }
    let d = depth[u32(fy) * params.width + u32(fx)];
    return valid_depth(d) && h.z > d + params.bias * d;
}

struct Shaded {
    ok: bool,
    s: vec3<f32>,
    n: vec3<f32>,
}

// estimators::shaded_point
fn shaded_point(x: u32, y: u32) -> Shaded {
    let g = texel(x, y);
    var r: Shaded;
    r.ok = valid_depth(g.w) && any(g.xyz != vec3<f32>(0.0));
    r.n = g.xyz;
    r.s = cam_point(x, y, g.w);
    return r;
}

// SsaoUniforms::pattern_index times the set size: the pixel's first table entry.
fn set_base(x: u32, y: u32) -> u32 {
    let k = (x % params.pattern) + params.pattern * (y % params.pattern);
    return k * params.samples;
}

// The estimation grid (see the top).
fn in_grid(gid: vec3<u32>) -> bool {
    return gid.x < params.lo_width && gid.y < params.lo_height;
}

fn grid_index(gid: vec3<u32>) -> u32 {
    return gid.y * params.lo_width + gid.x;
}

// The depth of grid cell (x, y)'s pixel.
fn grid_depth(x: u32, y: u32) -> f32 {
    return depth[y * params.scale * params.width + x * params.scale];
}

fn in_image(gid: vec3<u32>) -> bool {
    return gid.x < params.width && gid.y < params.height;
}

fn pixel_index(gid: vec3<u32>) -> u32 {
    return gid.y * params.width + gid.x;
}
