// Library: displacement-field geometry, the GPU twin of src/field/positions.rs
// and directions.rs: the field's parameters, the octahedral grid of
// positional samples and the hemisphere mappings. A kernel composes
//     sampling.wgsl, frame.wgsl, field_lookup.wgsl, a map-access file, field_trace.wgsl
// where the map-access file (field_maps_*.wgsl) binds the maps and defines
//     fn field_map_taps(m: u32, x: f32, y: f32) -> vec2<f32>
// the four texels around continuous texel coordinates (x, y) of map m (x, y
// in [0, res - 1], texel centres at integers), bilinearly weighted, as
// (coverage, weighted distance): the weight of the taps that hit, and the
// weighted sum of their normalised distances.

const FIELD_PI: f32 = 3.14159265358979323846;
const FIELD_PI_OVER_2: f32 = 1.57079632679489661923;
const FIELD_PI_OVER_4: f32 = 0.78539816339744830962;
const FIELD_TAU: f32 = 6.28318530717958647692;

const FIELD_CONCENTRIC: u32 = 0u;
const FIELD_POLAR: u32 = 1u;
const FIELD_REJECTION: u32 = 2u;

const FIELD_OUTSIDE: u32 = 0u;
const FIELD_MISS: u32 = 1u;
const FIELD_HIT: u32 = 2u;

// `FieldLookupUniforms` in crates/penumbra/src/field/gpu.rs.
struct FieldLookupUniforms {
    center: vec3<f32>,
    radius: f32,
    side: u32,
    res: u32,
    storage_bits: u32,
    directions: u32,
    tiles_x: u32,
    tiles_y: u32,
    positional: u32, // 0 nearest, 1 bilinear
    words_per_map: u32,
}

@group(0) @binding(0) var<uniform> field: FieldLookupUniforms;

fn field_copysign(x: f32, s: f32) -> f32 {
    return select(abs(x), -abs(x), (bitcast<u32>(s) & 0x80000000u) != 0u);
}

// sampling::atan::atan_unit (Abramowitz and Stegun 4.4.49, t in [-1, 1])
fn field_atan_unit(t: f32) -> f32 {
    let z = t * t;
    var p = 0.0028662257;
    p = p * z - 0.016165737;
    p = p * z + 0.042909614;
    p = p * z - 0.07528964;
    p = p * z + 0.10656264;
    p = p * z - 0.142089;
    p = p * z + 0.19993551;
    p = p * z - 0.33333145;
    return t + t * (z * p);
}

// positions::square_to_sphere
fn field_square_to_sphere(u: f32, v: f32) -> vec3<f32> {
    let up = abs(u);
    let vp = abs(v);
    let signed = 1.0 - (up + vp);
    let r = 1.0 - abs(signed);
    var phi_n = 1.0;
    if (r != 0.0) {
        phi_n = (vp - up) / r + 1.0;
    }
    let phi = phi_n * FIELD_PI_OVER_4;
    let z = field_copysign(1.0 - r * r, signed);
    let ring = r * sqrt(max(2.0 - r * r, 0.0));
    return vec3<f32>(field_copysign(cos(phi), u) * ring, field_copysign(sin(phi), v) * ring, z);
}

// positions::sphere_to_square
fn field_sphere_to_square(d: vec3<f32>) -> vec2<f32> {
    let x = abs(d.x);
    let y = abs(d.y);
    let r = sqrt(max(1.0 - abs(d.z), 0.0));
    let x_major = x >= y;
    let angle = field_atan_unit(select(x / y, y / x, x_major)) / FIELD_PI_OVER_2;
    var phi = select(1.0 - angle, angle, x_major);
    if (x == 0.0 && y == 0.0) {
        phi = 0.0;
    }
    var v = phi * r;
    var u = r - v;
    if (d.z < 0.0) {
        let u0 = u;
        u = 1.0 - v;
        v = 1.0 - u0;
    }
    return vec2<f32>(field_copysign(u, d.x), field_copysign(v, d.y));
}

// OctahedralGrid::position
fn field_grid_position(m: u32) -> vec3<f32> {
    let n = f32(field.side);
    let i = f32(m % field.side);
    let j = f32(m / field.side);
    return field_square_to_sphere((2.0 * i + 1.0) / n - 1.0, (2.0 * j + 1.0) / n - 1.0);
}

// OctahedralGrid::grid_coordinates
fn field_grid_coordinates(d: vec3<f32>) -> vec2<f32> {
    let uv = field_sphere_to_square(d);
    let n = f32(field.side);
    return (uv + vec2<f32>(1.0)) * 0.5 * n - vec2<f32>(0.5);
}

// OctahedralGrid::wrap
fn field_wrap(i_in: i32, j_in: i32) -> u32 {
    let n = i32(field.side);
    var i = i_in;
    var j = j_in;
    if (i < 0) {
        i = -i - 1;
        j = n - 1 - j;
    } else if (i >= n) {
        i = 2 * n - 1 - i;
        j = n - 1 - j;
    }
    if (j < 0) {
        i = n - 1 - i;
        j = -j - 1;
    } else if (j >= n) {
        i = n - 1 - i;
        j = 2 * n - 1 - j;
    }
    return u32(clamp(i, 0, n - 1) + clamp(j, 0, n - 1) * n);
}

// concentric::concentric_square (the branch as selects, as `field::batch`)
fn field_concentric_square(x: f32, y: f32) -> vec2<f32> {
    let r = sqrt(x * x + y * y);
    if (r == 0.0) {
        return vec2<f32>(0.5, 0.5);
    }
    let x_major = abs(x) >= abs(y);
    let angle = field_atan_unit(select(x / y, y / x, x_major));
    let ax = field_copysign(r, x);
    let by = field_copysign(r, y);
    let a = select(by * angle / FIELD_PI_OVER_4, ax, x_major);
    let b = select(by, ax * angle / FIELD_PI_OVER_4, x_major);
    return vec2<f32>((a + 1.0) * 0.5, (b + 1.0) * 0.5);
}

// directions::rim_clamp
fn field_rim_clamp(x: f32, y: f32) -> vec2<f32> {
    let r2 = x * x + y * y;
    if (r2 > 1.0) {
        let r = sqrt(r2);
        return vec2<f32>(x / r, y / r);
    }
    return vec2<f32>(x, y);
}

// DirectionMapping::locate
fn field_locate(d: vec3<f32>) -> vec2<f32> {
    if (field.directions == FIELD_POLAR) {
        let theta = acos(clamp(d.z, 0.0, 1.0));
        var phi = atan2(d.y, d.x);
        if (phi < 0.0) {
            phi += FIELD_TAU;
        }
        return vec2<f32>(theta / FIELD_PI_OVER_2, phi / FIELD_TAU);
    }
    let p = field_rim_clamp(d.x, d.y);
    if (field.directions == FIELD_REJECTION) {
        return (p + vec2<f32>(1.0)) * 0.5;
    }
    return field_concentric_square(p.x, p.y);
}

// Where map m lies in the stacked 3D texture: texel origin of its tile and
// its layer (`gpu::TextureLayout`).
fn field_tile(m: u32) -> vec3<u32> {
    let per_layer = field.tiles_x * field.tiles_y;
    let tile = m % per_layer;
    return vec3<u32>((tile % field.tiles_x) * field.res, (tile / field.tiles_x) * field.res, m / per_layer);
}
