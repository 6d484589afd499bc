// The G-buffer's packed albedo, r + 256 g + 65536 b (8 bits each) in one
// float, the twin of `unpack_albedo` in src/ssao/gbuffer.rs: shared by the
// G-buffer pass and the SSAO indirect light. Self-contained.

fn unpack_albedo(v: f32) -> vec3<f32> {
    let b = u32(v);
    return vec3<f32>(f32(b & 255u), f32((b >> 8u) & 255u), f32((b >> 16u) & 255u)) * (1.0 / 255.0);
}
