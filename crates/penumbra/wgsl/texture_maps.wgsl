// Texture maps as scene::texture_table packs them: the sRGB table, one
// record of three words4 per map, and the texels, all in one array of words
// that the composing kernel reads through `map_word(k)` (word k of that
// array) from `maps_base()` (the words4 its sRGB table starts at). The twin
// of `TextureTable::sample` and `TextureTable::is_hole`, operation for
// operation.

const NO_MAP: u32 = 0xffffffffu;
const MAP_CLAMP: u32 = 1u;
const MAP_SRGB: u32 = 2u;
const MAP_WORDS4: u32 = 3u;
const SRGB_WORDS4: u32 = 64u;

// A texel of a map, decoded (TextureTable::texel).
fn map_texel(first: u32, flags: u32, k: u32) -> vec3<f32> {
    let w = map_word(first + k);
    let c = vec3<u32>(w & 255u, (w >> 8u) & 255u, (w >> 16u) & 255u);
    if ((flags & MAP_SRGB) != 0u) {
        let at = maps_base() * 4u;
        return vec3<f32>(bitcast<f32>(map_word(at + c.x)), bitcast<f32>(map_word(at + c.y)), bitcast<f32>(map_word(at + c.z)));
    }
    return vec3<f32>(c) * (1.0 / 255.0);
}

// u clamped to [0, 1]; 0 where it is not a number (texture_table::unit_clamp).
fn unit_clamp(u: f32) -> f32 {
    if (u >= 0.0) {
        return select(1.0, u, u <= 1.0);
    }
    return 0.0;
}

// The fractional part of u in [0, 1); 0 where u is not finite.
fn unit_fract(u: f32) -> f32 {
    let f = u - floor(u);
    return select(0.0, f, f >= 0.0 && f < 1.0);
}

fn wrap_index(i: i32, n: i32, clamped: bool) -> i32 {
    if (clamped) {
        return clamp(i, 0, n - 1);
    }
    return (i + n) % n;
}

// The first word of map m's record.
fn map_record(m: u32) -> u32 {
    return (maps_base() + SRGB_WORDS4 + m * MAP_WORDS4) * 4u;
}

// Map m at texture coordinates uv (v up the image): the bilinear blend of
// the four texels around the point (TextureTable::sample).
fn sample_map(m: u32, uv: vec2<f32>) -> vec3<f32> {
    let b = map_record(m);
    let scale = vec2<f32>(bitcast<f32>(map_word(b)), bitcast<f32>(map_word(b + 1u)));
    let offset = vec2<f32>(bitcast<f32>(map_word(b + 2u)), bitcast<f32>(map_word(b + 3u)));
    let first = map_word(b + 4u);
    let w = i32(map_word(b + 5u));
    let h = i32(map_word(b + 6u));
    let flags = map_word(b + 7u);
    let clamped = (flags & MAP_CLAMP) != 0u;
    var u = uv.x * scale.x + offset.x;
    var v = uv.y * scale.y + offset.y;
    if (clamped) {
        u = unit_clamp(u);
        v = unit_clamp(v);
    } else {
        u = unit_fract(u);
        v = unit_fract(v);
    }
    let x = u * f32(w) - 0.5;
    let y = (1.0 - v) * f32(h) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let i0 = i32(x0);
    let j0 = i32(y0);
    let ia = wrap_index(i0, w, clamped);
    let ib = wrap_index(i0 + 1, w, clamped);
    let ja = wrap_index(j0, h, clamped);
    let jb = wrap_index(j0 + 1, h, clamped);
    let top = map_texel(first, flags, u32(ja * w + ia)) * (1.0 - fx) + map_texel(first, flags, u32(ja * w + ib)) * fx;
    let bottom = map_texel(first, flags, u32(jb * w + ia)) * (1.0 - fx) + map_texel(first, flags, u32(jb * w + ib)) * fx;
    return top * (1.0 - fy) + bottom * fy;
}

// Whether cut-out map m has a hole at uv (TextureTable::is_hole).
fn map_hole(m: u32, uv: vec2<f32>) -> bool {
    let b = map_record(m) + 8u;
    return sample_map(m, uv).x * bitcast<f32>(map_word(b)) < bitcast<f32>(map_word(b + 1u));
}
