// Indirect light and the shaded image (twins: src/ssao/indirect.rs).
// `ssao_indirect`: L~, the average radiance of the pixels the sample points
// project to whose surface lies within R, in front of the tangent plane and
// facing the shaded point (section 3.1); writes (L~, pixels averaged).
// `ssao_compose`: direct + a (La O + L~ (1 - O)) from ao_out and
// indirect_out, linear rgba, background transparent.
// Composed after ssao_common.wgsl.

@compute @workgroup_size(8, 8)
fn ssao_indirect(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_image(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let sp = shaded_point(gid.x, gid.y);
    if (!sp.ok) {
        indirect[i] = vec4<f32>(0.0);
        return;
    }
    let s = sp.s;
    let n = sp.n;
    let f = frame_basis(n);
    let base = set_base(gid.x, gid.y);
    let r2 = params.radius * params.radius;
    var sum = vec3<f32>(0.0);
    var count = 0u;
    for (var j = 0u; j < params.samples; j = j + 1u) {
        let q = table[base + j];
        var p: vec3<f32>;
        if (params.table_kind == 1u) {
            p = s + params.radius * vec3<f32>(q.x, q.y, 0.0);
        } else {
            p = s + params.radius * (f[0] * q.x + f[1] * q.y + n * q.z);
        }
        let px = project(p);
        if (px.x < 0) {
            continue;
        }
        let z = depth[u32(px.y) * params.width + u32(px.x)];
        if (!valid_depth(z)) {
            continue;
        }
        let o = cam_point(u32(px.x), u32(px.y), z);
        let d = o - s;
        if (dot(d, d) < r2 && dot(d, n) > 0.0) {
            let g = textureLoad(geometry, px, 0);
            if (dot(g.xyz, d) < 0.0) {
                sum = sum + textureLoad(shade, px, 0).xyz;
                count = count + 1u;
            }
        }
    }
    if (count == 0u) {
        indirect[i] = vec4<f32>(0.0);
        return;
    }
    indirect[i] = vec4<f32>(sum * (1.0 / f32(count)), f32(count));
}

@compute @workgroup_size(8, 8)
fn ssao_compose(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_image(gid)) {
        return;
    }
    let i = pixel_index(gid);
    if (!valid_depth(depth[i])) {
        image[i] = vec4<f32>(0.0);
        return;
    }
    let sh = textureLoad(shade, vec2<i32>(i32(gid.x), i32(gid.y)), 0);
    let o = clamp(ao_out[i], 0.0, 1.0);
    let l = indirect_out[i].xyz;
    let a = unpack_albedo(sh.w);
    let c = sh.xyz + a * (vec3<f32>(params.ambient * o) + l * (1.0 - o));
    image[i] = vec4<f32>(c, 1.0);
}
