// SH transfer vectors from per-vertex visibility masks (Kautz et al. 2004,
// equation 3 and section 3.2), rotated from each vertex's tangent frame to
// world space and dotted with the lighting (equation 2).
//
// CPU twin: `Prt::sh_transfer` (src/prt/pipeline.rs: `CellTables::integrate`,
// `ShRotation::frame_to_world`, `radiance`); the tables are `CellTables`'
// arrays, packed by `src/prt/gpu.rs`.
//
// A workgroup takes VERTS vertices. Their masks are staged in workgroup
// memory; the 4x4 cells' grey levels and first moments (four nibble-table
// fetches per cell) are computed once per cell and kept there too; then each
// invocation owns (vertex, coefficient) pairs for the integration, the four
// rotation steps (x90, z(beta), x90^T, z(alpha)) and the write-back.
//
// The workgroup arrays are sized by the file composed before this one:
// MAX_VERTS vertices a workgroup at most, STAGED entries of staged masks
// (VERTS x words) and cells (VERTS x cells). `sh_transfer_portable.wgsl`
// fits WebGPU's portable 16 KiB of workgroup memory, `sh_transfer_wide.wgsl`
// takes twice the vertices where a device has 32 KiB. A vertex's arithmetic
// is the same in either: only how many share a workgroup differs.

const MAX_COEFFS: u32 = 64u;   // 8 bands

struct ShTransferUniforms {
    // vertex count (this batch), coefficients, bands, mask side
    counts: vec4<u32>,
    // cells per side, u32 words per mask, integration (0 cells,
    // 1 cells-linear, 2 pixels), brdf (0 diffuse, 1 phong)
    shape: vec4<u32>,
    // workgroups per grid row, vertices per workgroup (<= MAX_VERTS, with
    // VERTS x words <= STAGED and VERTS x cells <= STAGED), 0, 0
    grid: vec4<u32>,
    // Phong exponent, lobe weight k_s, 0, 0
    phong: vec4<f32>,
    // eye position; w = 1 when there is one
    eye: vec4<f32>,
    // offsets into `tables` of: (unused), (unused), nibble, dirs
    tables_a: vec4<u32>,
    // offsets into `tables` of: unoccluded, area, pixel basis, x90
    tables_b: vec4<u32>,
}

@group(0) @binding(0) var<storage, read> tables: array<f32>;
// Planar RGB lighting, 3 x coeffs.
@group(0) @binding(1) var<storage, read> lighting: array<f32>;
// Per cell c and coefficient k: (B_ck, A_c g_ck.x, A_c g_ck.y, 0) / pi, the
// basis and gradient tables interleaved so that a cell costs one load.
@group(0) @binding(2) var<storage, read> cell_basis: array<vec4<f32>>;

@group(1) @binding(0) var<uniform> params: ShTransferUniforms;
@group(1) @binding(1) var<storage, read> masks: array<u32>;
// Per vertex: position, then shading normal (zero: no normal).
@group(1) @binding(2) var<storage, read> vertices: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> transfer: array<f32>;
// Exitant radiance, 3 per vertex.
@group(1) @binding(4) var<storage, read_write> radiance: array<f32>;

var<workgroup> wg_masks: array<u32, STAGED>;        // VERTS x words
var<workgroup> wg_cells: array<vec4<f32>, STAGED>;  // VERTS x cells: o, mu_x, mu_y, rho
var<workgroup> wg_coeffs: array<f32, MAX_VERTS * MAX_COEFFS>;
var<workgroup> wg_swap: array<f32, MAX_VERTS * MAX_COEFFS>;
// Per vertex, a bit per cell with any occluded pixel (256 cells at most).
var<workgroup> wg_occluded: array<atomic<u32>, MAX_VERTS * 8u>;
var<workgroup> wg_frame: array<vec4<f32>, MAX_VERTS>;    // cos a, sin a, cos b, sin b
var<workgroup> wg_reflected: array<vec4<f32>, MAX_VERTS>; // local reflected view; w = 1 with a normal

// cos/sin of the normal's azimuth alpha and polar angle beta; the tangent
// frame is Rz(alpha) Ry(beta) (`frame_angles` in src/sh/rotation.rs).
fn frame_angles(n: vec3<f32>) -> vec4<f32> {
    let sb = sqrt(n.x * n.x + n.y * n.y);
    let cb = n.z;
    if sb > 1e-12 {
        return vec4<f32>(n.x / sb, n.y / sb, cb, sb);
    }
    return vec4<f32>(1.0, 0.0, select(-1.0, 1.0, cb >= 0.0), 0.0);
}

// The view direction reflected about the normal, in the tangent frame.
fn reflected_local(p: vec3<f32>, n: vec3<f32>, f: vec4<f32>) -> vec3<f32> {
    if params.eye.w == 0.0 {
        return vec3<f32>(0.0, 0.0, 1.0);
    }
    let d = params.eye.xyz - p;
    let rcp = 1.0 / length(d);
    var view = n;
    if rcp > 0.0 && rcp <= 3.4028235e38 {
        view = d * rcp;
    }
    let r = 2.0 * dot(n, view) * n - view;
    let t = vec3<f32>(f.z * f.x, f.z * f.y, -f.w);
    let b = vec3<f32>(-f.y, f.x, 0.0);
    let nn = vec3<f32>(f.w * f.x, f.w * f.y, f.z);
    return vec3<f32>(dot(t, r), dot(b, r), dot(nn, r));
}

// pi f_r for the Phong BRDF (`Brdf::rho`); pow(0, 0) taken as 1.
fn rho(d: vec3<f32>, r: vec3<f32>) -> f32 {
    let e = params.phong.x;
    let ks = params.phong.y;
    let c = max(dot(d, r), 0.0);
    var lobe = 1.0;
    if e != 0.0 {
        lobe = select(0.0, pow(c, e), c > 0.0);
    }
    return (1.0 - ks) + ks * 0.5 * (e + 2.0) * lobe;
}

fn band_of(k: u32) -> u32 {
    var l = 0u;
    while (l + 1u) * (l + 1u) <= k {
        l += 1u;
    }
    return l;
}

// Entry (i, j) of band l's D(Rx(90 deg)); bands are packed one after the
// other, band l at sum_{k<l} (2k+1)^2 = l (4 l^2 - 1) / 3.
fn x90(l: u32, i: u32, j: u32) -> f32 {
    let size = 2u * l + 1u;
    return tables[params.tables_b.w + l * (4u * l * l - 1u) / 3u + i * size + j];
}

// One coefficient after D(Rx(+-90 deg)): reads wg_coeffs.
fn apply_x90(vl: u32, k: u32, inverse: bool) -> f32 {
    let l = band_of(k);
    let base = l * l;
    let row = k - base;
    var s = 0.0;
    for (var j = 0u; j < 2u * l + 1u; j += 1u) {
        let e = select(x90(l, row, j), x90(l, j, row), inverse);
        s += e * wg_coeffs[vl * MAX_COEFFS + base + j];
    }
    return s;
}

// One coefficient after D(Rz(theta)) given cos/sin of theta: reads wg_coeffs.
fn apply_z(vl: u32, k: u32, c: f32, s: f32) -> f32 {
    let l = band_of(k);
    let centre = l * (l + 1u);
    let value = wg_coeffs[vl * MAX_COEFFS + k];
    if k == centre {
        return value;
    }
    let am = select(centre - k, k - centre, k > centre);
    // cos/sin of m theta by the same recurrence as `rotate_z_f32`.
    var cm = 1.0;
    var sm = 0.0;
    for (var m = 1u; m <= am; m += 1u) {
        let next = cm * c - sm * s;
        sm = sm * c + cm * s;
        cm = next;
    }
    let a = wg_coeffs[vl * MAX_COEFFS + centre + am];
    let b = wg_coeffs[vl * MAX_COEFFS + centre - am];
    if k > centre {
        return a * cm - b * sm;
    }
    return a * sm + b * cm;
}

// Step 0..3 of `frame_to_world` for one coefficient: x90, z(beta), x90^T, z(alpha).
fn rotation_step(vl: u32, k: u32, step: u32) -> f32 {
    let f = wg_frame[vl];
    switch step {
        case 0u: { return apply_x90(vl, k, false); }
        case 1u: { return apply_z(vl, k, f.z, f.w); }
        case 2u: { return apply_x90(vl, k, true); }
        default: { return apply_z(vl, k, f.x, f.y); }
    }
}

fn swap_back(lid: u32, n: u32) {
    for (var i = lid; i < params.grid.y * n; i += 64u) {
        let vl = i / n;
        let k = i % n;
        wg_coeffs[vl * MAX_COEFFS + k] = wg_swap[vl * MAX_COEFFS + k];
    }
}

@compute @workgroup_size(64)
fn sh_transfer(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let verts = params.grid.y;
    let first = (wg.x + wg.y * params.grid.x) * verts;
    let nv = params.counts.x;
    let n = params.counts.y;
    let side = params.counts.w;
    let cps = params.shape.x;
    let words = params.shape.y;
    let integration = params.shape.z;
    let phong = params.shape.w == 1u;
    let cells = cps * cps;

    // Stage the masks; tangent frames and reflected views per vertex.
    for (var i = lid; i < verts * words; i += 64u) {
        let vl = i / words;
        var m = 0u;
        if first + vl < nv {
            m = masks[(first + vl) * words + i % words];
        }
        wg_masks[vl * words + i % words] = m;
    }
    for (var i = lid; i < MAX_VERTS * 8u; i += 64u) {
        atomicStore(&wg_occluded[i], 0u);
    }
    if lid < verts {
        var f = vec4<f32>(1.0, 0.0, 1.0, 0.0);
        var r = vec4<f32>(0.0, 0.0, 1.0, 0.0);
        let v = first + lid;
        if v < nv {
            let normal = vertices[2u * v + 1u].xyz;
            if any(normal != vec3<f32>(0.0)) {
                f = frame_angles(normal);
                r = vec4<f32>(reflected_local(vertices[2u * v].xyz, normal, f), 1.0);
            }
        }
        wg_frame[lid] = f;
        wg_reflected[lid] = r;
    }
    workgroupBarrier();

    // Cells: occluded fraction o and first moments mu from the four row
    // nibbles (a cell's nibble never straddles a u32 word), and rho_c.
    for (var i = lid; i < verts * cells; i += 64u) {
        let vl = i / cells;
        let c = i % cells;
        let cr = c / cps;
        let cc = c % cps;
        var acc = vec3<f32>(0.0);
        for (var k = 0u; k < 4u; k += 1u) {
            let bit = (cr * 4u + k) * side + cc * 4u;
            let nib = (wg_masks[vl * words + bit / 32u] >> (bit % 32u)) & 15u;
            let e = params.tables_a.z + ((c * 4u + k) * 16u + nib) * 4u;
            acc += vec3<f32>(tables[e], tables[e + 1u], tables[e + 2u]);
        }
        if integration == 0u {
            acc = vec3<f32>(acc.x, 0.0, 0.0);
        }
        var rc = 1.0;
        if phong {
            let d = params.tables_a.w + 4u * c;
            rc = rho(vec3<f32>(tables[d], tables[d + 1u], tables[d + 2u]), wg_reflected[vl].xyz);
        }
        wg_cells[vl * cells + c] = vec4<f32>(acc, rc);
        if any(acc != vec3<f32>(0.0)) {
            atomicOr(&wg_occluded[vl * 8u + c / 32u], 1u << (c % 32u));
        }
    }
    workgroupBarrier();

    // Integration in the tangent frame. Diffuse: the unoccluded transfer
    // minus the occluded cells (visited through their bits, so the lanes of
    // a vertex skip the rest together); glossy: the visible part weighted
    // by rho_c. Lanes are laid out 32 (or 64) per vertex so that a SIMD row
    // never straddles two vertices.
    let stride = select(64u, 32u, n <= 32u);
    for (var slot = lid; slot < verts * stride; slot += 64u) {
        let vl = slot / stride;
        let k = slot % stride;
        if k >= n {
            continue;
        }
        var acc = 0.0;
        if !phong {
            acc = tables[params.tables_b.x + k];
        }
        if integration == 2u {
            for (var p = 0u; p < side * side; p += 1u) {
                let occluded = ((wg_masks[vl * words + p / 32u] >> (p % 32u)) & 1u) == 1u;
                let pb = tables[params.tables_b.z + p * n + k];
                if !phong && occluded {
                    acc -= pb;
                } else if phong && !occluded {
                    let c = (p / side / 4u) * cps + (p % side) / 4u;
                    acc += wg_cells[vl * cells + c].w * pb;
                }
            }
        } else {
            if !phong {
                for (var w = 0u; w < (cells + 31u) / 32u; w += 1u) {
                    var bits = atomicLoad(&wg_occluded[vl * 8u + w]);
                    while bits != 0u {
                        let c = w * 32u + countTrailingZeros(bits);
                        bits &= bits - 1u;
                        let cell = wg_cells[vl * cells + c];
                        let g = cell_basis[c * n + k];
                        acc -= cell.x * g.x + cell.y * g.y + cell.z * g.z;
                    }
                }
            } else {
                for (var c = 0u; c < cells; c += 1u) {
                    if tables[params.tables_b.y + c] != 0.0 {
                        let cell = wg_cells[vl * cells + c];
                        let g = cell_basis[c * n + k];
                        acc += cell.w * ((1.0 - cell.x) * g.x - cell.y * g.y - cell.z * g.z);
                    }
                }
            }
        }
        if wg_reflected[vl].w == 0.0 {
            acc = 0.0;
        }
        wg_coeffs[vl * MAX_COEFFS + k] = acc;
    }
    workgroupBarrier();

    // Frame to world: D(Rz(alpha)) D(Rx(-90)) D(Rz(beta)) D(Rx(90)), one
    // step at a time from wg_coeffs into wg_swap; the result stays in wg_swap.
    for (var step = 0u; step < 4u; step += 1u) {
        for (var i = lid; i < verts * n; i += 64u) {
            wg_swap[(i / n) * MAX_COEFFS + i % n] = rotation_step(i / n, i % n, step);
        }
        workgroupBarrier();
        if step < 3u {
            swap_back(lid, n);
            workgroupBarrier();
        }
    }

    // Write back the transfer and the radiance L . V*.
    for (var i = lid; i < verts * n; i += 64u) {
        let v = first + i / n;
        if v < nv {
            transfer[v * n + i % n] = wg_swap[(i / n) * MAX_COEFFS + i % n];
        }
    }
    if lid < verts * 3u {
        let vl = lid / 3u;
        let ch = lid % 3u;
        let v = first + vl;
        if v < nv {
            var s = 0.0;
            for (var k = 0u; k < n; k += 1u) {
                s += lighting[ch * n + k] * wg_swap[vl * MAX_COEFFS + k];
            }
            radiance[v * 3u + ch] = s;
        }
    }
}
