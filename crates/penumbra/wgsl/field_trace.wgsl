// Library: the displacement-field query, the GPU twin of src/field/lookup.rs
// (DisplacementField::map_sample_world, ::sample, ::trace). Composed after
// frame.wgsl (frame_basis), field_lookup.wgsl and a map-access file
// (field_map_taps).

// DisplacementField::map_sample_world: (coverage, weighted distance) of the
// four texels around direction d in map m, through field_map_taps.
fn field_map_sample(m: u32, d: vec3<f32>) -> vec2<f32> {
    let f = frame_basis(-field_grid_position(m));
    let st = field_locate(vec3<f32>(dot(d, f[0]), dot(d, f[1]), dot(d, f[2])));
    let r = f32(field.res);
    let x = clamp(st.x * r - 0.5, 0.0, r - 1.0);
    let y = clamp(st.y * r - 0.5, 0.0, r - 1.0);
    return field_map_taps(m, x, y);
}

// DisplacementField::sample
fn field_sample(p: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    let g = field_grid_coordinates(p);
    if (field.positional == 0u) {
        let last = i32(field.side) - 1;
        let i = u32(clamp(i32(floor(g.x + 0.5)), 0, last));
        let j = u32(clamp(i32(floor(g.y + 0.5)), 0, last));
        return field_map_sample(i + j * field.side, d);
    }
    let x0 = floor(g.x);
    let y0 = floor(g.y);
    let fx = g.x - x0;
    let fy = g.y - y0;
    let i = i32(x0);
    let j = i32(y0);
    let w = vec4<f32>((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy);
    let m = vec4<u32>(field_wrap(i, j), field_wrap(i + 1, j), field_wrap(i, j + 1), field_wrap(i + 1, j + 1));
    var sum = vec2<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        if (w[k] > 0.0) {
            sum += w[k] * field_map_sample(m[k], d);
        }
    }
    return sum;
}

struct FieldTrace {
    kind: u32,
    t: f32,
    // The lookup: (coverage, weighted distance); zero when outside.
    sample: vec2<f32>,
    inside: bool,
    hidden: bool,
}

// Where the line o + s d (d unit) crosses the field's bounding sphere:
// (s0, s1), (-1, -1) where it does not (DisplacementField::trace's first step).
fn field_sphere_span(o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    let oc = o - field.center;
    let b = dot(oc, d);
    let h = oc - b * d;
    let disc = field.radius * field.radius - dot(h, h);
    if (disc < 0.0) {
        return vec2<f32>(-1.0, -1.0);
    }
    let q = sqrt(disc);
    return vec2<f32>(-b - q, -b + q);
}

// Whether the ray (not only its line) reaches the sphere: the lookup's
// work is for these rays alone (field_ao.wgsl tests the rest first).
fn field_enters(span: vec2<f32>) -> bool {
    return span.y > 0.0;
}

// DisplacementField::trace: the object-space ray o + s d, d unit.
fn field_trace(o: vec3<f32>, d: vec3<f32>) -> FieldTrace {
    var r: FieldTrace;
    r.kind = FIELD_OUTSIDE;
    r.t = 0.0;
    r.sample = vec2<f32>(0.0);
    r.inside = false;
    r.hidden = false;
    let span = field_sphere_span(o, d);
    if (!field_enters(span)) {
        return r;
    }
    let s0 = span.x;
    let s1 = span.y;
    r.inside = s0 < 0.0;
    var p = (o + s0 * d - field.center) / field.radius;
    let len = length(p);
    if (len > 0.0) {
        p = p * (1.0 / len);
    } else {
        p = vec3<f32>(0.0, 0.0, 1.0);
    }
    r.sample = field_sample(p, d);
    r.kind = FIELD_MISS;
    // Less than half the weight hits: a miss (see src/field/lookup.rs).
    if (r.sample.x < 0.5) {
        return r;
    }
    let t = s0 + (r.sample.y / r.sample.x) * 2.0 * field.radius;
    r.t = t;
    if (t <= 0.0) {
        r.hidden = true;
    } else if (t < s1) {
        r.kind = FIELD_HIT;
    }
    return r;
}
