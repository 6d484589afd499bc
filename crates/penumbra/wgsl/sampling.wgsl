// Twin of src/geom/sampling/: Owen-scrambled Sobol points (integer arithmetic,
// bit-identical to the CPU), the concentric disk map and Malley's cosine
// hemisphere (the orthonormal basis is frame.wgsl). Self-contained:
// kernels prepend it.

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
