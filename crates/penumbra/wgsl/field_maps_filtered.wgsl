// Map access for 8-bit fields: the maps stacked in an RG8Unorm 3D texture
// (`gpu::TextureLayout`: several maps per layer), texel = (D if the
// direction hits else 0, 1 if it hits else 0), read through the texture
// unit's bilinear filter at the layer's centre: one fetch gives the weighted
// distance sum and the coverage of the four texels. Coordinates are clamped
// to texel centres inside the map's tile (field_map_sample), so a map never
// blends with its neighbours. The CPU twin (DisplacementField::map_sample)
// weighs in f32; the texture unit's weights are fixed point, see the README
// for the measured difference.
@group(0) @binding(1) var field_maps: texture_3d<f32>;
@group(0) @binding(2) var field_sampler: sampler;

fn field_map_taps(m: u32, x: f32, y: f32) -> vec2<f32> {
    let tile = vec3<f32>(field_tile(m));
    let dims = vec3<f32>(textureDimensions(field_maps));
    let uvw = vec3<f32>(tile.x + x + 0.5, tile.y + y + 0.5, tile.z + 0.5) / dims;
    let texel = textureSampleLevel(field_maps, field_sampler, uvw, 0.0);
    return vec2<f32>(texel.y, texel.x);
}
