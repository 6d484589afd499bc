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

// Each pixel of a surface averages the grid cells around it whose depth is
// within filter_depth of its own: its cell (X, Y) = (x, y) / scale, and
// (X + 1, Y), (X, Y + 1), (X + 1, Y + 1) where x, y are not multiples of
// scale (the pixel lies between the cells' pixels; at scale 2 halfway, so
// equal weights). None such: the value of the cell of the 3x3 cells around
// (X, Y) nearest in depth (the first on a tie, rows first), 1 if none is a
// surface. Reads the filtered grid, scratch[2n + i].
@compute @workgroup_size(8, 8)
fn ssao_upsample(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!in_image(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let c = depth[i];
    if (!valid_depth(c)) {
        ao_out[i] = 1.0;
        return;
    }
    let lo = 2u * params.lo_width * params.lo_height;
    let x0 = gid.x / params.scale;
    let y0 = gid.y / params.scale;
    let x1 = select(x0, x0 + 1u, gid.x % params.scale != 0u && x0 + 1u < params.lo_width);
    let y1 = select(y0, y0 + 1u, gid.y % params.scale != 0u && y0 + 1u < params.lo_height);
    var sum = 0.0;
    var count = 0u;
    for (var y = y0; y <= y1; y = y + 1u) {
        for (var x = x0; x <= x1; x = x + 1u) {
            let d = grid_depth(x, y);
            if (valid_depth(d) && abs(d - c) <= params.filter_depth) {
                sum = sum + scratch[lo + y * params.lo_width + x];
                count = count + 1u;
            }
        }
    }
    if (count > 0u) {
        ao_out[i] = sum * (1.0 / f32(count));
        return;
    }
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
    ao_out[i] = value;
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
