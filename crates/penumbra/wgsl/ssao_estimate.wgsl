// The paper's AO estimators (twins: src/ssao/estimators.rs, same names):
// `ssao_points` (sphere, hemisphere, importance, tangent-sphere: weighted
// point samples in the tangent frame), `ssao_march` (ray marching, section
// 3.2) and `ssao_disk` (pipes through the base disk, section 4.5, with the
// analytic line integral for mu = (r/R)^4). One invocation per cell of the
// estimation grid (ssao_common.wgsl); writes `ao` (not clamped), 1 on
// background and zero-normal pixels. Composed after ssao_common.wgsl.

// Copies the geometry texture's depth into `depth` (twin: the G-buffer's
// z values; see ssao_common.wgsl).
@compute @workgroup_size(8, 8)
fn ssao_pack_depth(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_image(gid)) {
        return;
    }
    depth[pixel_index(gid)] = texel(gid.x, gid.y).w;
}

// estimators::HomogeneousFrame: the shaded point and its tangent frame
// scaled by R, mapped by `homogeneous`: sample q is at
// s + t q.x + b q.y + n q.z.
struct HomogeneousFrame {
    s: vec3<f32>,
    t: vec3<f32>,
    b: vec3<f32>,
    n: vec3<f32>,
}

fn homogeneous_frame(sp: Shaded) -> HomogeneousFrame {
    let f = frame_basis(sp.n);
    var h: HomogeneousFrame;
    h.s = homogeneous(sp.s);
    h.t = homogeneous(params.radius * f[0]);
    h.b = homogeneous(params.radius * f[1]);
    h.n = homogeneous(params.radius * sp.n);
    return h;
}

@compute @workgroup_size(8, 8)
fn ssao_points(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_grid(gid)) {
        return;
    }
    let sp = shaded_point(gid.x * params.scale, gid.y * params.scale);
    if (!sp.ok) {
        ao[grid_index(gid)] = 1.0;
        return;
    }
    let h = homogeneous_frame(sp);
    let base = set_base(gid.x, gid.y);
    var sum = 0.0;
    for (var j = 0u; j < params.samples; j = j + 1u) {
        let q = table[base + j];
        if (!occluded_homogeneous(h.s + h.t * q.x + h.b * q.y + h.n * q.z)) {
            sum = sum + q.w;
        }
    }
    ao[grid_index(gid)] = sum;
}

@compute @workgroup_size(8, 8)
fn ssao_march(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_grid(gid)) {
        return;
    }
    let sp = shaded_point(gid.x * params.scale, gid.y * params.scale);
    if (!sp.ok) {
        ao[grid_index(gid)] = 1.0;
        return;
    }
    let h = homogeneous_frame(sp);
    let base = set_base(gid.x, gid.y);
    var sum = 0.0;
    for (var ray = 0u; ray < params.rays; ray = ray + 1u) {
        var value = params.open_weight;
        for (var k = 0u; k < params.steps; k = k + 1u) {
            let q = table[base + ray * params.steps + k];
            if (occluded_homogeneous(h.s + h.t * q.x + h.b * q.y + h.n * q.z)) {
                value = q.w;
                break;
            }
        }
        sum = sum + value;
    }
    ao[grid_index(gid)] = sum;
}

// estimators::pipe_integral: 4 [a (t1 - t0) + N.z (t1^2 - t0^2) / 2]
// (derivation there).
fn pipe_integral(a: f32, nz: f32, t0: f32, t1: f32) -> f32 {
    return 4.0 * (a * (t1 - t0) + 0.5 * nz * (t1 * t1 - t0 * t0));
}

@compute @workgroup_size(8, 8)
fn ssao_disk(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_grid(gid)) {
        return;
    }
    let sp = shaded_point(gid.x * params.scale, gid.y * params.scale);
    if (!sp.ok) {
        ao[grid_index(gid)] = 1.0;
        return;
    }
    let n = sp.n;
    let s = sp.s;
    let base = set_base(gid.x, gid.y);
    // Disk point (x, y) projects to (fx0 + ax x, fy0 + ay y): the disk is
    // at the shaded depth (see `homogeneous`).
    let hs = homogeneous(s);
    let inv_z = 1.0 / hs.z;
    let fx0 = hs.x * inv_z;
    let fy0 = hs.y * inv_z;
    let ax = homogeneous(vec3<f32>(params.radius, 0.0, 0.0)).x * inv_z;
    let ay = homogeneous(vec3<f32>(0.0, params.radius, 0.0)).y * inv_z;
    let inv_r = 1.0 / params.radius;
    let inv_nz = 1.0 / n.z;
    var sum = 0.0;
    var open = 0.0;
    for (var j = 0u; j < params.samples; j = j + 1u) {
        let q = table[base + j];
        let w2 = 1.0 - q.x * q.x - q.y * q.y;
        if (!(w2 > 0.0)) {
            continue;
        }
        let hw = sqrt(w2);
        let a = q.x * n.x + q.y * n.y;
        var t0 = -hw;
        var t1 = hw;
        if (n.z < 0.0) {
            t1 = min(t1, -a * inv_nz);
        } else if (n.z > 0.0) {
            t0 = max(t0, -a * inv_nz);
        } else if (a < 0.0) {
            t1 = t0;
        }
        if (t1 > t0) {
            open = open + q.w * pipe_integral(a, n.z, t0, t1);
        }
        let fx = fx0 + ax * q.x;
        let fy = fy0 + ay * q.y;
        if (fx >= 0.0 && fx < f32(params.width) && fy >= 0.0 && fy < f32(params.height)) {
            let d = depth[u32(fy) * params.width + u32(fx)];
            if (valid_depth(d)) {
                t1 = min(t1, (d + params.bias * d - s.z) * inv_r);
            }
        }
        if (t1 > t0) {
            sum = sum + q.w * pipe_integral(a, n.z, t0, t1);
        }
    }
    var result = sum;
    if (params.calibrate != 0u) {
        result = select(1.0, sum / open, open > 0.0);
    }
    ao[grid_index(gid)] = result;
}
