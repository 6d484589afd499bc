// Kernel: the Whitted pass's pixels into an image a host owns, one
// invocation per pixel: pixel first_pixel + k of the row-major image
// (`whitted`'s output k) goes to texel (p % width, p / width) of a
// storage texture as its linear radiance with alpha 1. The CPU twin is
// `whitted_image` in src/whitted/texture.rs; src/whitted/texture.rs
// drives it.
//
// pixels: `whitted`'s output, per pixel two words4 (radiance as bits,
//         signature), (rays by kind).

struct WhittedImageUniforms {
    width: u32,
    first_pixel: u32,
    pixel_count: u32,
    row_pitch: u32,
}

@group(0) @binding(0) var<uniform> params: WhittedImageUniforms;
@group(0) @binding(1) var<storage, read> pixels: array<vec4<u32>>;
@group(0) @binding(2) var image: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(64)
fn whitted_image(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * params.row_pitch;
    if (k >= params.pixel_count) {
        return;
    }
    let p = params.first_pixel + k;
    let radiance = bitcast<vec3<f32>>(pixels[2u * k].xyz);
    textureStore(image, vec2<u32>(p % params.width, p / params.width), vec4<f32>(radiance, 1.0));
}
