// The depth-aware 4x4 low-pass filter of section 5 (twins:
// src/ssao/filter.rs). Window offsets -2..=1; neighbours that are
// background or differ in depth by more than params.filter_depth are left
// out; background pixels pass through. Composed after ssao_common.wgsl.

@compute @workgroup_size(8, 8)
fn ssao_filter_ao(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_image(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let c = depth[i];
    if (!valid_depth(c)) {
        ao_out[i] = ao[i];
        return;
    }
    var sum = 0.0;
    var count = 0u;
    let w = i32(params.width);
    let h = i32(params.height);
    for (var dy = -2; dy <= 1; dy = dy + 1) {
        for (var dx = -2; dx <= 1; dx = dx + 1) {
            let qx = i32(gid.x) + dx;
            let qy = i32(gid.y) + dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h) {
                continue;
            }
            let d = depth[u32(qy * w + qx)];
            if (valid_depth(d) && abs(d - c) <= params.filter_depth) {
                sum = sum + ao[u32(qy * w + qx)];
                count = count + 1u;
            }
        }
    }
    ao_out[i] = sum * (1.0 / f32(count));
}

@compute @workgroup_size(8, 8)
fn ssao_filter_indirect(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_image(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let c = depth[i];
    if (!valid_depth(c)) {
        indirect_out[i] = indirect[i];
        return;
    }
    var sum = vec4<f32>(0.0);
    var count = 0u;
    let w = i32(params.width);
    let h = i32(params.height);
    for (var dy = -2; dy <= 1; dy = dy + 1) {
        for (var dx = -2; dx <= 1; dx = dx + 1) {
            let qx = i32(gid.x) + dx;
            let qy = i32(gid.y) + dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h) {
                continue;
            }
            let d = depth[u32(qy * w + qx)];
            if (valid_depth(d) && abs(d - c) <= params.filter_depth) {
                sum = sum + indirect[u32(qy * w + qx)];
                count = count + 1u;
            }
        }
    }
    indirect_out[i] = sum * (1.0 / f32(count));
}
