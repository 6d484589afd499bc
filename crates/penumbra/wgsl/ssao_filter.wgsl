// The depth-aware 4x4 low-pass filter of section 5 (twins:
// src/ssao/filter.rs), window offsets -2..=1, and the half-resolution
// upsampling. Composed after ssao_common.wgsl.
//
// AO, on the estimation grid, in two passes: `ssao_filter_ao_rows` sums
// each cell's row window (cells whose depth is within params.filter_depth
// of the cell's) into scratch[2i] (sum) and scratch[2i + 1] (count);
// `ssao_filter_ao_columns` adds up the row sums and counts of the column
// window's cells that are within filter_depth of the centre, and writes
// sum / count to ao_out (scale 1) or to scratch[2n + i] (n cells; scale 2,
// for `ssao_upsample`). Background cells pass through.
//
// `ssao_filter_indirect`: the same window in one pass at full resolution;
// neighbours that are background or differ in depth by more than
// filter_depth are left out.

@compute @workgroup_size(8, 8)
fn ssao_filter_ao_rows(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_grid(gid)) {
        return;
    }
    let i = grid_index(gid);
    let c = grid_depth(gid.x, gid.y);
    if (!valid_depth(c)) {
        scratch[2u * i] = ao[i];
        scratch[2u * i + 1u] = 1.0;
        return;
    }
    var sum = 0.0;
    var count = 0.0;
    let w = i32(params.lo_width);
    for (var dx = -2; dx <= 1; dx = dx + 1) {
        let qx = i32(gid.x) + dx;
        if (qx < 0 || qx >= w) {
            continue;
        }
        let d = grid_depth(u32(qx), gid.y);
        if (valid_depth(d) && abs(d - c) <= params.filter_depth) {
            sum = sum + ao[gid.y * params.lo_width + u32(qx)];
            count = count + 1.0;
        }
    }
    scratch[2u * i] = sum;
    scratch[2u * i + 1u] = count;
}

@compute @workgroup_size(8, 8)
fn ssao_filter_ao_columns(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_grid(gid)) {
        return;
    }
    let i = grid_index(gid);
    let c = grid_depth(gid.x, gid.y);
    var value = scratch[2u * i];
    if (valid_depth(c)) {
        var sum = 0.0;
        var count = 0.0;
        let h = i32(params.lo_height);
        for (var dy = -2; dy <= 1; dy = dy + 1) {
            let qy = i32(gid.y) + dy;
            if (qy < 0 || qy >= h) {
                continue;
            }
            let d = grid_depth(gid.x, u32(qy));
            if (valid_depth(d) && abs(d - c) <= params.filter_depth) {
                let q = u32(qy) * params.lo_width + gid.x;
                sum = sum + scratch[2u * q];
                count = count + scratch[2u * q + 1u];
            }
        }
        value = sum * (1.0 / count);
    }
    if (params.scale == 1u) {
        ao_out[i] = value;
    } else {
        scratch[2u * params.lo_width * params.lo_height + i] = value;
    }
}

// The AO of every pixel from the filtered grid (scale 2; twin:
// filter::ssao_upsample, which gives the rule per pixel). One invocation
// per grid cell (X, Y) writes its 2x2 pixels, which read cells (X, Y),
// (X + 1, Y), (X, Y + 1), (X + 1, Y + 1): a pixel averages those of them
// that lie on its side of it (its own cell; the next in x where x is odd,
// in y where y is odd: halfway, so equal weights) and are within
// filter_depth of it in depth. None such: the value of the cell of the 3x3
// cells around (X, Y) nearest in depth (the first on a tie, rows first), 1
// if none is a surface. Background pixels get 1. Reads the filtered grid,
// scratch[2n + i].
@compute @workgroup_size(8, 8)
fn ssao_upsample(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_grid(gid)) {
        return;
    }
    let lo = 2u * params.lo_width * params.lo_height;
    let x0 = gid.x;
    let y0 = gid.y;
    let right = x0 + 1u < params.lo_width;
    let below = y0 + 1u < params.lo_height;
    let x1 = select(x0, x0 + 1u, right);
    let y1 = select(y0, y0 + 1u, below);
    let d = vec4<f32>(grid_depth(x0, y0), grid_depth(x1, y0), grid_depth(x0, y1), grid_depth(x1, y1));
    let v = vec4<f32>(
        scratch[lo + y0 * params.lo_width + x0],
        scratch[lo + y0 * params.lo_width + x1],
        scratch[lo + y1 * params.lo_width + x0],
        scratch[lo + y1 * params.lo_width + x1],
    );
    for (var py = 0u; py < 2u; py = py + 1u) {
        for (var px = 0u; px < 2u; px = px + 1u) {
            let x = 2u * x0 + px;
            let y = 2u * y0 + py;
            if (x >= params.width || y >= params.height) {
                continue;
            }
            let i = y * params.width + x;
            let c = depth[i];
            if (!valid_depth(c)) {
                ao_out[i] = 1.0;
                continue;
            }
            let use_x = px == 1u && right;
            let use_y = py == 1u && below;
            var sum = 0.0;
            var count = 0u;
            if (valid_depth(d.x) && abs(d.x - c) <= params.filter_depth) {
                sum = sum + v.x;
                count = count + 1u;
            }
            if (use_x && valid_depth(d.y) && abs(d.y - c) <= params.filter_depth) {
                sum = sum + v.y;
                count = count + 1u;
            }
            if (use_y && valid_depth(d.z) && abs(d.z - c) <= params.filter_depth) {
                sum = sum + v.z;
                count = count + 1u;
            }
            if (use_x && use_y && valid_depth(d.w) && abs(d.w - c) <= params.filter_depth) {
                sum = sum + v.w;
                count = count + 1u;
            }
            if (count > 0u) {
                ao_out[i] = sum * (1.0 / f32(count));
            } else {
                ao_out[i] = nearest_cell(x0, y0, c, lo);
            }
        }
    }
}

// The value of the cell of the 3x3 around (x0, y0) nearest to depth c (see
// ssao_upsample).
fn nearest_cell(x0: u32, y0: u32, c: f32, lo: u32) -> f32 {
    var found = false;
    var best = 0.0;
    var value = 1.0;
    for (var y = max(y0, 1u) - 1u; y <= min(y0 + 1u, params.lo_height - 1u); y = y + 1u) {
        for (var x = max(x0, 1u) - 1u; x <= min(x0 + 1u, params.lo_width - 1u); x = x + 1u) {
            let d = grid_depth(x, y);
            if (valid_depth(d) && (!found || abs(d - c) < best)) {
                found = true;
                best = abs(d - c);
                value = scratch[lo + y * params.lo_width + x];
            }
        }
    }
    return value;
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
