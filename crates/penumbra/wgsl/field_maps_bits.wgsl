// Map access for 1-bit fields: hit bits packed 32 to a word, map after map
// (words_per_map words each), and each map's mean hit distance, which every
// hitting texel of the map stands for; the four texels weighed as the CPU
// twin does (DisplacementField::map_sample).
@group(0) @binding(1) var<storage, read> field_bits: array<u32>;
@group(0) @binding(2) var<storage, read> field_means: array<f32>;

fn field_tap(m: u32, a: u32, b: u32, w: f32) -> vec2<f32> {
    let i = b * field.res + a;
    let word = field_bits[m * field.words_per_map + i / 32u];
    if (((word >> (i % 32u)) & 1u) == 1u) {
        return vec2<f32>(w, w * field_means[m]);
    }
    return vec2<f32>(0.0);
}

fn field_map_taps(m: u32, x: f32, y: f32) -> vec2<f32> {
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let a0 = u32(x0);
    let b0 = u32(y0);
    let a1 = min(a0 + 1u, field.res - 1u);
    let b1 = min(b0 + 1u, field.res - 1u);
    return field_tap(m, a0, b0, (1.0 - fx) * (1.0 - fy)) + field_tap(m, a1, b0, fx * (1.0 - fy))
        + field_tap(m, a0, b1, (1.0 - fx) * fy) + field_tap(m, a1, b1, fx * fy);
}
