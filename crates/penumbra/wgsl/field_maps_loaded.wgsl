// Map access for 32-bit fields: the maps stacked in an R32Float 3D texture
// (`gpu::TextureLayout`). R32Float is not filterable in core WebGPU, so the
// four texels are loaded and weighed in f32 exactly as the CPU twin does
// (DisplacementField::map_sample).
@group(0) @binding(1) var field_maps: texture_3d<f32>;

fn field_tap(tile: vec3<u32>, a: u32, b: u32, w: f32) -> vec2<f32> {
    let d = textureLoad(field_maps, vec3<i32>(vec3<u32>(tile.x + a, tile.y + b, tile.z)), 0).x;
    if (d < 1.0) {
        return vec2<f32>(w, w * d);
    }
    return vec2<f32>(0.0);
}

fn field_map_taps(m: u32, x: f32, y: f32) -> vec2<f32> {
    let tile = field_tile(m);
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let a0 = u32(x0);
    let b0 = u32(y0);
    let a1 = min(a0 + 1u, field.res - 1u);
    let b1 = min(b0 + 1u, field.res - 1u);
    return field_tap(tile, a0, b0, (1.0 - fx) * (1.0 - fy)) + field_tap(tile, a1, b0, fx * (1.0 - fy))
        + field_tap(tile, a0, b1, (1.0 - fx) * fy) + field_tap(tile, a1, b1, fx * fy);
}
