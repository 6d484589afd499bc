// Twin of src/sampling/: Owen-scrambled Sobol points (integer arithmetic,
// bit-identical to the CPU), the concentric disk map, Malley's cosine
// hemisphere and the orthonormal basis of Duff et al. 2017.
// Self-contained: kernels prepend it.

const SAMPLING_PI_OVER_4: f32 = 0.78539816339744830962;
const SAMPLING_PI_OVER_2: f32 = 1.57079632679489661923;

// "lowbias32" integer hash.
fn hash_u32(x_in: u32) -> u32 {
    var x = x_in;
    x = x ^ (x >> 16u);
    x = x * 0x7feb352du;
    x = x ^ (x >> 15u);
    x = x * 0x846ca68bu;
    x = x ^ (x >> 16u);
    return x;
}

// Top 24 bits as an exact float in [0, 1).
fn unit_float(bits: u32) -> f32 {
    return f32(bits >> 8u) * (1.0 / 16777216.0);
}

fn laine_karras_permutation(x_in: u32, seed: u32) -> u32 {
    var x = x_in + seed;
    x = x ^ (x * 0x6c50b47cu);
    x = x ^ (x * 0xb82f1e52u);
    x = x ^ (x * 0xc7afe638u);
    x = x ^ (x * 0x8d22f6e6u);
    return x;
}

fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras_permutation(reverseBits(x), seed));
}

fn sobol_2d(index: u32) -> vec2<u32> {
    let x = reverseBits(index);
    var y = 0u;
    var v = 1u << 31u;
    var i = index;
    while (i != 0u) {
        if ((i & 1u) != 0u) {
            y = y ^ v;
        }
        i = i >> 1u;
        v = v ^ (v >> 1u);
    }
    return vec2<u32>(x, y);
}

fn owen_sobol_2d(index: u32, seed: u32) -> vec2<u32> {
    let shuffled = nested_uniform_scramble(index, seed);
    let p = sobol_2d(shuffled);
    return vec2<u32>(
        nested_uniform_scramble(p.x, hash_u32(seed ^ 0xa511e9b3u)),
        nested_uniform_scramble(p.y, hash_u32(seed ^ 0x63d83595u)),
    );
}

// SampleSequence::stream_seed
fn stream_seed(seed: u32, point: u32) -> u32 {
    return hash_u32(seed ^ hash_u32(point + 0x9e3779b9u));
}

// SampleSequence::sample
fn sequence_sample(seed: u32, point: u32, index: u32) -> vec2<f32> {
    let bits = owen_sobol_2d(index, stream_seed(seed, point));
    return vec2<f32>(unit_float(bits.x), unit_float(bits.y));
}

fn concentric_disk(u: f32, v: f32) -> vec2<f32> {
    let a = 2.0 * u - 1.0;
    let b = 2.0 * v - 1.0;
    if (a == 0.0 && b == 0.0) {
        return vec2<f32>(0.0, 0.0);
    }
    var r: f32;
    var phi: f32;
    if (abs(a) > abs(b)) {
        r = a;
        phi = SAMPLING_PI_OVER_4 * (b / a);
    } else {
        r = b;
        phi = SAMPLING_PI_OVER_2 - SAMPLING_PI_OVER_4 * (a / b);
    }
    return vec2<f32>(r * cos(phi), r * sin(phi));
}

fn cosine_hemisphere(u: f32, v: f32) -> vec3<f32> {
    let d = concentric_disk(u, v);
    let z = sqrt(max(0.0, 1.0 - d.x * d.x - d.y * d.y));
    return vec3<f32>(d.x, d.y, z);
}

// Frame::from_normal(n) as the columns (t, b, n). copysign(1, n.z) reads the
// sign bit so that n.z = -0.0 gives the same frame as on the CPU.
fn frame_basis(n: vec3<f32>) -> mat3x3<f32> {
    let sign = select(1.0, -1.0, (bitcast<u32>(n.z) & 0x80000000u) != 0u);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return mat3x3<f32>(t, bt, n);
}

// Frame::from_normal(n).to_world(local).
fn frame_to_world(n: vec3<f32>, local: vec3<f32>) -> vec3<f32> {
    let f = frame_basis(n);
    return f[0] * local.x + f[1] * local.y + f[2] * local.z;
}
