// Kernel: Whitted ray tracing, one invocation per pixel; the GPU twin of
// Whitted::whitted in src/whitted/whitted.rs (with src/whitted/optics.rs,
// offset.rs, sphere.rs and ray_tree.rs's signature), written in the same
// order of operations over the same data. src/whitted/gpu.rs drives it.
// Composed after sampling.wgsl, kdtree_traverse.wgsl and whitted_pixels.wgsl
// or whitted_trees.wgsl (RECORD_TREES: whether shade can record trees).
//
// A pixel's samples are traced one after another; each sample's ray tree is
// walked depth first with an explicit stack (WGSL has no recursion).
//
// records: the scene's surfaces (8 words4 each), lights (3) and spheres (2),
//          one after another from params.lights_at / spheres_at; floats as
//          their bits; then from params.maps_at the sRGB table (64 words4),
//          the texture maps (3 words4 each: scale, offset; texels' first
//          word, width, height, flags; factor, cutoff) and their texels
//          (RGBA8, one per word).
// triangle_shading: 2 words4 per triangle: (surface, normal indices),
//                   (object, face, texture coordinates' index, -).
// shading_normals: the shading normals, then per textured triangle two
//                  entries (u0, v0, u1, v1), (u2, v2, -, -).
// pixels: per pixel two words4 (radiance, signature), (rays by kind); for
//         `whitted_trees`, per ray a slot of ray-tree records (below).
// pixel_list: the pixels `whitted_listed` renders, any order (the bounded
//             renderer's slow path); `whitted` renders a range instead.
//             For `whitted_trees`, 8 words per ray: origin, the root's t;
//             direction, the root's primitive (the bounded renderer's
//             extremal rays, whose first hit is given).
//
// Ray-tree records (src/whitted/tree_records.rs writes the CPU twin's and
// reads both), per ray `params.tree_stride * params.tree_capacity + 2`
// words4: (radiance, node count or TREE_OVERFLOW), (diffuse, 0), then
// per node, in the order the stack pops them: (flags, parent, object,
// face), (surface, primitive, t, 0), origin, direction, weight, point, and
// the light words, each light's code then each light's occluder.

struct WhittedUniforms {
    eye: vec3<f32>,
    width: u32,
    forward: vec3<f32>,
    height: u32,
    right: vec3<f32>,
    spp: u32,
    up: vec3<f32>,
    seed: u32,
    ambient: vec3<f32>,
    max_depth: u32,
    background: vec3<f32>,
    flags: u32,
    media: vec4<u32>,
    media_len: u32,
    light_count: u32,
    sphere_count: u32,
    transmissive: u32,
    first_pixel: u32,
    pixel_count: u32,
    row_pitch: u32,
    lights_at: u32,
    spheres_at: u32,
    tree_capacity: u32,
    tree_stride: u32,
    maps_at: u32,
}

struct PixelOut {
    radiance: vec3<f32>,
    signature: u32,
    rays: vec4<u32>,
}

@group(1) @binding(0) var<uniform> params: WhittedUniforms;
@group(1) @binding(1) var<storage, read> triangle_shading: array<vec4<u32>>;
@group(1) @binding(2) var<storage, read> shading_normals: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read> records: array<vec4<u32>>;
@group(1) @binding(4) var<storage, read_write> pixels: array<vec4<u32>>;
@group(1) @binding(5) var<storage, read> pixel_list: array<u32>;

const MAX_DEPTH: u32 = 16u;
const STACK_SIZE: u32 = 17u;
const MAX_MEDIA: u32 = 4u;
const MAX_SHADOW_CROSSINGS: u32 = 16u;
const FRESNEL: u32 = 1u;
const LIT: u32 = 1u;
const REFRACTS: u32 = 2u;
const DIRECTIONAL: u32 = 1u;
const NO_NORMAL: u32 = 0xffffffffu;
const NO_TEXCOORDS: u32 = 0xffffffffu;
const MAX_HOLE_CROSSINGS: u32 = 16u;
const OFFSET_SCALE: f32 = 1.52587890625e-5; // 2^-16
const MIN_POSITIVE: f32 = 1.17549435e-38;
const FNV_OFFSET: u32 = 0x811c9dc5u;
const FNV_PRIME: u32 = 0x01000193u;
const KIND_PRIMARY: u32 = 0u;
const KIND_REFLECTION: u32 = 1u;
const KIND_REFRACTION: u32 = 2u;
const CODE_FACES_AWAY: u32 = 0u;
const CODE_VISIBLE: u32 = 1u;
const CODE_BLOCKED: u32 = 2u;
const CODE_FILTERED: u32 = 3u;
// shade's `slot` when no tree is recorded, and its root primitive when the
// root is traced rather than given.
const NO_SLOT: u32 = 0xffffffffu;
const TRACE_ROOT: u32 = 0xfffffffeu;
const TREE_HEADER_WORDS4: u32 = 2u;
const TREE_OVERFLOW: u32 = 0xffffffffu;
// A node's flags word: kind | depth << 2 | these.
const NODE_REFLECTED: u32 = 0x100u;
const NODE_REFRACTED: u32 = 0x200u;
const NODE_TIR: u32 = 0x400u;
const NODE_FRONT: u32 = 0x800u;
const NODE_HIT: u32 = 0x1000u;
const NODE_LIT: u32 = 0x2000u;

struct Surface {
    ka: vec3<f32>,
    flags: u32,
    kd: vec3<f32>,
    ns: f32,
    ks: vec3<f32>,
    ni: f32,
    kr: vec3<f32>,
    kt: vec3<f32>,
    ke: vec3<f32>,
    checker_odd: vec3<f32>,
    checker_inv_size: f32,
    checker_origin: vec3<f32>,
    map_kd: u32,
    map_ka: u32,
    map_ks: u32,
    map_alpha: u32,
}

const SURFACE_WORDS4: u32 = 8u;

fn load_surface(id: u32) -> Surface {
    let b = id * SURFACE_WORDS4;
    let r0 = records[b];
    let r1 = records[b + 1u];
    let r2 = records[b + 2u];
    var s: Surface;
    s.ka = bitcast<vec3<f32>>(r0.xyz);
    s.flags = r0.w;
    s.kd = bitcast<vec3<f32>>(r1.xyz);
    s.ns = bitcast<f32>(r1.w);
    s.ks = bitcast<vec3<f32>>(r2.xyz);
    s.ni = bitcast<f32>(r2.w);
    let r3 = records[b + 3u];
    let r4 = records[b + 4u];
    let r5 = records[b + 5u];
    s.kr = bitcast<vec3<f32>>(r3.xyz);
    s.map_kd = r3.w;
    s.kt = bitcast<vec3<f32>>(r4.xyz);
    s.map_ka = r4.w;
    s.ke = bitcast<vec3<f32>>(r5.xyz);
    s.map_ks = r5.w;
    let r6 = records[b + 6u];
    s.checker_odd = bitcast<vec3<f32>>(r6.xyz);
    s.checker_inv_size = bitcast<f32>(r6.w);
    let r7 = records[b + 7u];
    s.checker_origin = bitcast<vec3<f32>>(r7.xyz);
    s.map_alpha = r7.w;
    return s;
}

fn surface_map_alpha(id: u32) -> u32 {
    return records[id * SURFACE_WORDS4 + 7u].w;
}

// One word of the records, counted from the first word.
fn record_word(k: u32) -> u32 {
    return records[k >> 2u][k & 3u];
}

// The texture maps (texture_maps.wgsl) ride in the records.
fn map_word(k: u32) -> u32 {
    return record_word(k);
}

fn maps_base() -> u32 {
    return params.maps_at;
}

// Whether a hit falls in a cut-out's hole (Whitted::is_hole).
fn is_hole(surface: u32, has_uv: bool, uv: vec2<f32>) -> bool {
    let m = surface_map_alpha(surface);
    return m != NO_MAP && has_uv && map_hole(m, uv);
}

// Texture factors on ka, kd and the highlight (Whitted::textures).
struct TextureFactors {
    ka: vec3<f32>,
    kd: vec3<f32>,
    ks: vec3<f32>,
}

fn textures(s: Surface, p: vec3<f32>, has_uv: bool, uv: vec2<f32>) -> TextureFactors {
    let checker = texture(s, p);
    var f = TextureFactors(checker, checker, vec3<f32>(1.0));
    if (!has_uv) {
        return f;
    }
    if (s.map_kd != NO_MAP) {
        f.kd = checker * sample_map(s.map_kd, uv);
        f.ka = f.kd;
    }
    if (s.map_ka != NO_MAP) {
        f.ka = checker * sample_map(s.map_ka, uv);
    }
    if (s.map_ks != NO_MAP) {
        f.ks = sample_map(s.map_ks, uv);
    }
    return f;
}

fn surface_ni(id: u32) -> f32 {
    return bitcast<f32>(records[id * SURFACE_WORDS4 + 2u].w);
}

// The checker texture's factor of ka and kd at p (Surface::texture).
fn texture(s: Surface, p: vec3<f32>) -> vec3<f32> {
    if (s.checker_inv_size == 0.0) {
        return vec3<f32>(1.0);
    }
    let c = floor((p - s.checker_origin) * s.checker_inv_size);
    let k = c.x + c.y + c.z;
    if (k - 2.0 * floor(0.5 * k) != 0.0) {
        return s.checker_odd;
    }
    return vec3<f32>(1.0);
}

struct Light {
    position: vec3<f32>,
    kind: u32,
    intensity: vec3<f32>,
    normal: vec3<f32>,
}

fn load_light(j: u32) -> Light {
    let b = params.lights_at + j * 3u;
    var l: Light;
    l.position = bitcast<vec3<f32>>(records[b].xyz);
    l.kind = records[b].w;
    l.intensity = bitcast<vec3<f32>>(records[b + 1u].xyz);
    l.normal = bitcast<vec3<f32>>(records[b + 2u].xyz);
    return l;
}

fn sphere_center(k: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(records[params.spheres_at + k * 2u]);
}

fn sphere_ids(k: u32) -> vec4<u32> {
    return records[params.spheres_at + k * 2u + 1u];
}

// ---- optics.rs ----

fn reflect_dir(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - 2.0 * dot(d, n) * n;
}

// refract_dir: the refracted direction, or a zero vector under total
// internal reflection.
fn refract_dir(d: vec3<f32>, n: vec3<f32>, eta: f32) -> vec3<f32> {
    if (eta == 1.0) {
        return d;
    }
    let cos_i = -dot(d, n);
    let sin2_t = eta * eta * max(1.0 - cos_i * cos_i, 0.0);
    if (sin2_t >= 1.0) {
        return vec3<f32>(0.0);
    }
    let cos_t = sqrt(1.0 - sin2_t);
    return normalize(eta * d + (eta * cos_i - cos_t) * n);
}

fn schlick(cos_i: f32, n1: f32, n2: f32) -> f32 {
    let q = (n1 - n2) / (n1 + n2);
    let r0 = q * q;
    var c = cos_i;
    if (n1 > n2) {
        let eta = n1 / n2;
        let sin2_t = eta * eta * max(1.0 - cos_i * cos_i, 0.0);
        if (sin2_t >= 1.0) {
            return 1.0;
        }
        c = sqrt(1.0 - sin2_t);
    }
    let m = clamp(1.0 - c, 0.0, 1.0);
    return r0 + (1.0 - r0) * m * m * m * m * m;
}

fn schlick_mirror(cos_i: f32, r0: vec3<f32>) -> vec3<f32> {
    let m = clamp(1.0 - cos_i, 0.0, 1.0);
    return r0 + (vec3<f32>(1.0) - r0) * (m * m * m * m * m);
}

// ---- offset.rs ----

fn max_abs(v: vec3<f32>) -> f32 {
    let a = abs(v);
    return max(a.x, max(a.y, a.z));
}

fn offset_point(p: vec3<f32>, n: vec3<f32>, magnitude: f32) -> vec3<f32> {
    let m = max(magnitude, max_abs(p));
    return p + n * max(m * OFFSET_SCALE, MIN_POSITIVE);
}

// ---- sphere.rs ----

// intersect_sphere: the nearest t in (0, t_max), or -1.
fn intersect_sphere(center: vec3<f32>, radius: f32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> f32 {
    let f = o - center;
    let a = dot(d, d);
    let h = -dot(f, d);
    let l = f + (h / a) * d;
    let disc = a * (radius - length(l)) * (radius + length(l));
    if (disc < 0.0) {
        return -1.0;
    }
    let q = h + select(-sqrt(disc), sqrt(disc), h >= 0.0);
    let c = dot(f, f) - radius * radius;
    var t0 = c / q;
    var t1 = q / a;
    if (t0 > t1) {
        let tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    if (t0 > 0.0 && t0 < t_max) {
        return t0;
    }
    if (t1 > 0.0 && t1 < t_max) {
        return t1;
    }
    return -1.0;
}

// ---- ray_tree.rs ----

fn fnv_word(h: u32, word: u32) -> u32 {
    return (h ^ word) * FNV_PRIME;
}

// ---- whitted.rs ----

struct Media {
    ids: vec4<u32>,
    len: u32,
}

fn media_push(m_in: Media, id: u32) -> Media {
    var m = m_in;
    if (m.len < MAX_MEDIA) {
        m.ids[m.len] = id;
        m.len = m.len + 1u;
    }
    return m;
}

fn media_remove(m_in: Media, id: u32) -> Media {
    var m = m_in;
    var k = m.len;
    while (k > 0u) {
        k = k - 1u;
        if (m.ids[k] == id) {
            for (var i = k; i + 1u < m.len; i = i + 1u) {
                m.ids[i] = m.ids[i + 1u];
            }
            m.len = m.len - 1u;
            return m;
        }
    }
    return m;
}

fn media_ni(m: Media) -> f32 {
    if (m.len == 0u) {
        return 1.0;
    }
    return surface_ni(m.ids[m.len - 1u]);
}

struct PathRay {
    origin: vec3<f32>,
    depth: u32,
    dir: vec3<f32>,
    kind: u32,
    weight: vec3<f32>,
    // The node that spawned it, where a tree is recorded.
    parent: u32,
    media: Media,
}

// Closest hit (t, primitive); primitive = MISS_INDEX for none.
struct Closest {
    t: f32,
    primitive: u32,
}

fn triangle_count() -> u32 {
    return kd_scene.triangle_count;
}

fn closest(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> Closest {
    let tri = kd_traverse(o, d, t_max, false);
    var best: Closest;
    best.primitive = tri.triangle;
    best.t = select(t_max, tri.t, tri.triangle != MISS_INDEX);
    let n = triangle_count();
    for (var k = 0u; k < params.sphere_count; k = k + 1u) {
        let c = sphere_center(k);
        let t = intersect_sphere(c.xyz, c.w, o, d, best.t);
        if (t > 0.0) {
            best.t = t;
            best.primitive = n + k;
        }
    }
    return best;
}

fn any_hit(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    if (kd_traverse(o, d, t_max, true).triangle != MISS_INDEX) {
        return true;
    }
    for (var k = 0u; k < params.sphere_count; k = k + 1u) {
        let c = sphere_center(k);
        if (intersect_sphere(c.xyz, c.w, o, d, t_max) > 0.0) {
            return true;
        }
    }
    return false;
}

struct SurfaceHit {
    point: vec3<f32>,
    geometric: vec3<f32>,
    shading: vec3<f32>,
    surface: u32,
    object: u32,
    face: u32,
    magnitude: f32,
    has_uv: bool,
    uv: vec2<f32>,
}

fn hit_info(o: vec3<f32>, d: vec3<f32>, t: f32, primitive: u32) -> SurfaceHit {
    var h: SurfaceHit;
    let n_tri = triangle_count();
    if (primitive >= n_tri) {
        let k = primitive - n_tri;
        let c = sphere_center(k);
        let ids = sphere_ids(k);
        let n = normalize(o + t * d - c.xyz);
        h.point = c.xyz + c.w * n;
        h.geometric = n;
        h.shading = n;
        h.surface = ids.x;
        h.object = ids.y;
        h.face = 0u;
        h.magnitude = max_abs(c.xyz) + c.w;
        h.has_uv = false;
        h.uv = vec2<f32>(0.0);
        return h;
    }
    let v0 = kd_vertex(primitive, 0u);
    let v1 = kd_vertex(primitive, 1u);
    let v2 = kd_vertex(primitive, 2u);
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let vp = o + t * d - v0;
    let d00 = dot(e1, e1);
    let d01 = dot(e1, e2);
    let d11 = dot(e2, e2);
    let d20 = dot(vp, e1);
    let d21 = dot(vp, e2);
    let denom = d00 * d11 - d01 * d01;
    var b1 = 0.0;
    var b2 = 0.0;
    if (denom > 0.0) {
        b1 = clamp((d11 * d20 - d01 * d21) / denom, 0.0, 1.0);
        b2 = clamp((d00 * d21 - d01 * d20) / denom, 0.0, 1.0 - b1);
    }
    let b0 = 1.0 - b1 - b2;
    let scale = max(max_abs(e1), max_abs(e2));
    let geometric = normalize(cross(e1 / scale, e2 / scale));
    let info = triangle_shading[primitive * 2u];
    let ids = triangle_shading[primitive * 2u + 1u];
    var shading = geometric;
    if (info.y != NO_NORMAL) {
        let s = b0 * shading_normals[info.y].xyz + b1 * shading_normals[info.z].xyz + b2 * shading_normals[info.w].xyz;
        if (dot(s, s) > 0.0) {
            shading = normalize(s);
            if (dot(shading, geometric) < 0.0) {
                shading = -shading;
            }
        }
    }
    h.point = v0 + b1 * e1 + b2 * e2;
    h.geometric = geometric;
    h.shading = shading;
    h.surface = info.x;
    h.object = ids.x;
    h.face = ids.y;
    h.magnitude = max(max_abs(v0), max(max_abs(v1), max_abs(v2)));
    h.has_uv = ids.z != NO_TEXCOORDS;
    h.uv = vec2<f32>(0.0);
    if (h.has_uv) {
        let a = shading_normals[ids.z];
        let c2 = shading_normals[ids.z + 1u];
        h.uv = b0 * a.xy + b1 * a.zw + b2 * c2.xy;
    }
    return h;
}

// Shadow rays traced by the last light_term / transmittance call.
var<private> shadow_rays: u32;

// What reaches the end of the shadow ray o + t d, 0 < t < t_max: the
// filter in xyz and the light's code in w.
fn transmittance(o: vec3<f32>, d: vec3<f32>, t_max: f32, finite: bool) -> vec4<f32> {
    if (params.transmissive == 0u) {
        shadow_rays = shadow_rays + 1u;
        if (any_hit(o, d, t_max)) {
            return vec4<f32>(0.0, 0.0, 0.0, f32(CODE_BLOCKED));
        }
        return vec4<f32>(1.0, 1.0, 1.0, f32(CODE_VISIBLE));
    }
    let end = o + d * select(1.0, t_max, finite);
    var origin = o;
    var dir = d;
    var filt = vec3<f32>(1.0);
    var code = CODE_VISIBLE;
    for (var k = 0u; k < MAX_SHADOW_CROSSINGS; k = k + 1u) {
        shadow_rays = shadow_rays + 1u;
        let c = closest(origin, dir, t_max);
        if (c.primitive == MISS_INDEX) {
            return vec4<f32>(filt, f32(code));
        }
        let hit = hit_info(origin, dir, c.t, c.primitive);
        // A cut-out's hole lets the light through unfiltered.
        if (!is_hole(hit.surface, hit.has_uv, hit.uv)) {
            let surf = load_surface(hit.surface);
            if (max(surf.kt.x, max(surf.kt.y, surf.kt.z)) <= 0.0) {
                return vec4<f32>(0.0, 0.0, 0.0, f32(CODE_BLOCKED));
            }
            filt = filt * surf.kt;
        }
        code = CODE_FILTERED;
        let through = select(-hit.geometric, hit.geometric, dot(dir, hit.geometric) > 0.0);
        origin = offset_point(hit.point, through, hit.magnitude);
        if (finite) {
            dir = end - origin;
        }
    }
    return vec4<f32>(0.0, 0.0, 0.0, f32(CODE_BLOCKED));
}

// Light j at a lifted point: its radiance, its code, and the part of the
// radiance the surface's (untextured) kd makes, which a textured root's
// interpolant keeps apart (RayOut::diffuse).
struct LightOut {
    radiance: vec3<f32>,
    code: u32,
    diffuse: vec3<f32>,
}

fn light_term(j: u32, lifted: vec3<f32>, n_g: vec3<f32>, n_s: vec3<f32>, d: vec3<f32>, surf: Surface, kd: vec3<f32>, ks_factor: vec3<f32>) -> LightOut {
    let none = LightOut(vec3<f32>(0.0), CODE_FACES_AWAY, vec3<f32>(0.0));
    let light = load_light(j);
    var l: vec3<f32>;
    var dist2 = 1.0;
    var start = lifted;
    var dir: vec3<f32>;
    var t_max = T_INFINITE;
    let directional = light.kind == DIRECTIONAL;
    if (directional) {
        l = -light.position;
        dir = l;
    } else {
        let to = light.position - lifted;
        dist2 = dot(to, to);
        l = to / sqrt(dist2);
        start = light.position;
        dir = -to;
        t_max = 1.0;
    }
    let cos_p = dot(n_s, l);
    if (dot(n_g, l) <= 0.0 || cos_p <= 0.0) {
        return none;
    }
    var emitted = 1.0;
    if (any(light.normal != vec3<f32>(0.0))) {
        emitted = -dot(light.normal, l);
        if (emitted <= 0.0) {
            return none;
        }
    }
    let seen = transmittance(start, dir, t_max, !directional);
    if (u32(seen.w) == CODE_BLOCKED) {
        return LightOut(vec3<f32>(0.0), CODE_BLOCKED, vec3<f32>(0.0));
    }
    let irradiance = seen.xyz * (light.intensity * (emitted / dist2));
    let h = normalize(l - d);
    let n_h = dot(n_s, h);
    var spec = vec3<f32>(0.0);
    if (n_h > 0.0) {
        spec = surf.ks * pow(n_h, surf.ns);
    }
    return LightOut(irradiance * (kd * cos_p + spec * ks_factor), u32(seen.w), irradiance * (surf.kd * cos_p));
}

// The primitive nearest light j on a blocked or filtered shadow ray from
// the lifted point (MISS_INDEX for another code): the occluder a ray tree
// records (Whitted::occluder).
fn occluder(j: u32, lifted: vec3<f32>, code: u32) -> u32 {
    if (code != CODE_BLOCKED && code != CODE_FILTERED) {
        return MISS_INDEX;
    }
    let light = load_light(j);
    if (light.kind == DIRECTIONAL) {
        return closest(lifted, -light.position, T_INFINITE).primitive;
    }
    return closest(light.position, -(light.position - lifted), 1.0).primitive;
}

struct RayOut {
    radiance: vec3<f32>,
    signature: u32,
    rays: vec4<u32>,
    // A recorded tree's root: its ambient and diffuse terms before the
    // texture (Whitted::shade's `diffuse`).
    diffuse: vec3<f32>,
}

// Where node n of the tree recorded at `slot` starts (words4).
fn node_at(slot: u32, n: u32) -> u32 {
    return slot + TREE_HEADER_WORDS4 + n * params.tree_stride;
}

fn write_vec3(at: u32, v: vec3<f32>) {
    pixels[at] = vec4<u32>(bitcast<vec3<u32>>(v), 0u);
}

// The fields of node n that are known when its ray is popped.
fn write_ray(slot: u32, n: u32, ray: PathRay) {
    let at = node_at(slot, n);
    pixels[at] = vec4<u32>(ray.kind | (ray.depth << 2u), ray.parent, MISS_INDEX, MISS_INDEX);
    pixels[at + 1u] = vec4<u32>(MISS_INDEX, MISS_INDEX, 0u, 0u);
    write_vec3(at + 2u, ray.origin);
    write_vec3(at + 3u, ray.dir);
    write_vec3(at + 4u, ray.weight);
    write_vec3(at + 5u, vec3<f32>(0.0));
}

// Word w of node n's light words (codes, then occluders).
fn write_light_word(slot: u32, n: u32, w: u32, value: u32) {
    pixels[node_at(slot, n) + 6u + w / 4u][w % 4u] = value;
}

// The radiance of the ray o + t d (unit d) that starts inside `media`
// (Whitted::shade). With `slot` other than NO_SLOT its ray tree is written
// there, and the root's hit is `root` (TRACE_ROOT: traced as any other).
fn shade(o: vec3<f32>, d: vec3<f32>, media: Media, root: Closest, slot: u32) -> RayOut {
    var stack: array<PathRay, STACK_SIZE>;
    stack[0] = PathRay(o, 0u, d, KIND_PRIMARY, vec3<f32>(1.0), MISS_INDEX, media);
    var len = 1u;
    var out: RayOut;
    out.radiance = vec3<f32>(0.0);
    out.signature = FNV_OFFSET;
    out.rays = vec4<u32>(0u);
    out.diffuse = vec3<f32>(0.0);
    let fresnel = (params.flags & FRESNEL) != 0u;
    let recording = RECORD_TREES && slot != NO_SLOT;
    var nodes = 0u;
    while (len > 0u) {
        len = len - 1u;
        let ray = stack[len];
        // This node's index, and whether it fits the slot.
        let node = nodes;
        nodes = nodes + 1u;
        let record = recording && node < params.tree_capacity;
        if (record) {
            write_ray(slot, node, ray);
        }
        // Slots: primary 0, shadow 1, reflection 2, refraction 3.
        out.rays[select(ray.kind + 1u, 0u, ray.kind == KIND_PRIMARY)] += 1u;
        var sig = fnv_word(out.signature, ray.kind | (ray.depth << 2u));
        var c = root;
        var past = ray.origin;
        if (ray.depth != 0u || root.primitive == TRACE_ROOT) {
            c = closest(ray.origin, ray.dir, T_INFINITE);
        }
        // Cut-out holes: the ray goes on from just past each one.
        for (var holes = 0u; holes < MAX_HOLE_CROSSINGS && c.primitive != MISS_INDEX; holes = holes + 1u) {
            let h = hit_info(past, ray.dir, c.t, c.primitive);
            if (!is_hole(h.surface, h.has_uv, h.uv)) {
                break;
            }
            let n_g = select(-h.geometric, h.geometric, dot(ray.dir, h.geometric) < 0.0);
            past = offset_point(h.point, -n_g, h.magnitude);
            c = closest(past, ray.dir, T_INFINITE);
        }
        if (c.primitive == MISS_INDEX) {
            out.radiance = out.radiance + ray.weight * params.background;
            sig = fnv_word(fnv_word(fnv_word(sig, MISS_INDEX), MISS_INDEX), MISS_INDEX);
            out.signature = fnv_word(sig, 0u);
            continue;
        }
        let hit = hit_info(past, ray.dir, c.t, c.primitive);
        sig = fnv_word(fnv_word(fnv_word(sig, hit.object), hit.face), hit.surface);
        let surf = load_surface(hit.surface);
        let front = dot(ray.dir, hit.geometric) < 0.0;
        let n_g = select(-hit.geometric, hit.geometric, front);
        var n_s = select(-hit.shading, hit.shading, front);
        if (dot(n_s, ray.dir) >= 0.0) {
            n_s = n_g;
        }
        let lifted = offset_point(hit.point, n_g, hit.magnitude);
        var local = surf.ke;
        let tex = textures(surf, hit.point, hit.has_uv, hit.uv);
        let lit = (surf.flags & LIT) != 0u;
        if (lit) {
            local = local + surf.ka * tex.ka * params.ambient;
            if (ray.depth == 0u) {
                out.diffuse = surf.ka * params.ambient;
            }
            let kd = surf.kd * tex.kd;
            for (var j = 0u; j < params.light_count; j = j + 1u) {
                shadow_rays = 0u;
                let term = light_term(j, lifted, n_g, n_s, ray.dir, surf, kd, tex.ks);
                out.rays.y += shadow_rays;
                sig = fnv_word(sig, (j << 2u) | term.code);
                local = local + term.radiance;
                if (ray.depth == 0u) {
                    out.diffuse = out.diffuse + term.diffuse;
                }
                if (record) {
                    write_light_word(slot, node, j, term.code);
                    write_light_word(slot, node, params.light_count + j, occluder(j, lifted, term.code));
                }
            }
        } else {
            local = local + surf.kd * tex.kd;
            if (ray.depth == 0u) {
                out.diffuse = surf.kd;
            }
        }
        out.radiance = out.radiance + ray.weight * local;

        var reflected = false;
        var refracted = false;
        var tir = false;
        if (ray.depth < params.max_depth) {
            var kr = surf.kr;
            var kt = surf.kt;
            let cos_i = -dot(ray.dir, n_s);
            let refracts = (surf.flags & REFRACTS) != 0u;
            var t_dir = vec3<f32>(0.0);
            var inner = ray.media;
            var transmits = false;
            if (refracts && max(kt.x, max(kt.y, kt.z)) > 0.0) {
                var n1: f32;
                var n2: f32;
                if (front) {
                    n1 = media_ni(ray.media);
                    n2 = surf.ni;
                    inner = media_push(ray.media, hit.surface);
                } else {
                    inner = media_remove(ray.media, hit.surface);
                    n1 = surf.ni;
                    n2 = media_ni(inner);
                }
                let eta = n1 / n2;
                if (fresnel) {
                    let f = schlick(cos_i, n1, n2);
                    kr = vec3<f32>(f);
                    kt = kt * (1.0 - f);
                }
                t_dir = refract_dir(ray.dir, n_s, eta);
                if (any(t_dir != vec3<f32>(0.0)) && dot(t_dir, n_g) >= 0.0) {
                    t_dir = refract_dir(ray.dir, n_g, eta);
                }
                if (all(t_dir == vec3<f32>(0.0))) {
                    tir = true;
                    kr = min(kr + kt, vec3<f32>(1.0));
                    kt = vec3<f32>(0.0);
                } else {
                    transmits = true;
                }
            } else if (max(kt.x, max(kt.y, kt.z)) > 0.0) {
                t_dir = ray.dir;
                transmits = true;
            }
            if (!refracts && fresnel && max(kr.x, max(kr.y, kr.z)) > 0.0) {
                kr = schlick_mirror(cos_i, kr);
            }
            if (max(kr.x, max(kr.y, kr.z)) > 0.0) {
                var r = reflect_dir(ray.dir, n_s);
                if (dot(r, n_g) <= 0.0) {
                    r = reflect_dir(ray.dir, n_g);
                }
                stack[len] = PathRay(lifted, ray.depth + 1u, r, KIND_REFLECTION, ray.weight * kr, node, ray.media);
                len = len + 1u;
                reflected = true;
            }
            if (transmits && max(kt.x, max(kt.y, kt.z)) > 0.0) {
                let origin = offset_point(hit.point, -n_g, hit.magnitude);
                stack[len] = PathRay(origin, ray.depth + 1u, t_dir, KIND_REFRACTION, ray.weight * kt, node, inner);
                len = len + 1u;
                refracted = true;
            }
        }
        out.signature = fnv_word(sig, u32(reflected) | (u32(refracted) << 1u) | (u32(tir) << 2u));
        if (record) {
            let at = node_at(slot, node);
            var flags = ray.kind | (ray.depth << 2u) | NODE_HIT;
            flags = flags | select(0u, NODE_REFLECTED, reflected) | select(0u, NODE_REFRACTED, refracted);
            flags = flags | select(0u, NODE_TIR, tir) | select(0u, NODE_FRONT, front) | select(0u, NODE_LIT, lit);
            pixels[at] = vec4<u32>(flags, ray.parent, hit.object, hit.face);
            pixels[at + 1u] = vec4<u32>(hit.surface, c.primitive, bitcast<u32>(c.t), 0u);
            write_vec3(at + 5u, hit.point);
        }
    }
    if (recording) {
        let count = select(TREE_OVERFLOW, nodes, nodes <= params.tree_capacity);
        pixels[slot] = vec4<u32>(bitcast<vec3<u32>>(out.radiance), count);
        pixels[slot + 1u] = vec4<u32>(bitcast<vec3<u32>>(out.diffuse), 0u);
    }
    return out;
}

// pixel_ray: the direction of sample `sample` of pixel `pixel`.
fn pixel_dir(pixel: u32, sample: u32) -> vec3<f32> {
    let x = pixel % params.width;
    let y = pixel / params.width;
    var j = vec2<f32>(0.5, 0.5);
    if (params.spp != 1u) {
        j = sequence_sample(params.seed, pixel, sample);
    }
    let sx = 2.0 * (f32(x) + j.x) / f32(params.width) - 1.0;
    let sy = 1.0 - 2.0 * (f32(y) + j.y) / f32(params.height);
    return normalize(params.forward + sx * params.right + sy * params.up);
}

fn write_pixel(k: u32, p: PixelOut) {
    pixels[2u * k] = vec4<u32>(bitcast<vec3<u32>>(p.radiance), p.signature);
    pixels[2u * k + 1u] = p.rays;
}

// Whitted::whitted: every sample of one pixel, averaged; the ray tree's
// signature is the first sample's.
fn render_pixel(pixel: u32) -> PixelOut {
    var media: Media;
    media.ids = params.media;
    media.len = params.media_len;
    var sum = vec3<f32>(0.0);
    var out: PixelOut;
    out.signature = 0u;
    out.rays = vec4<u32>(0u);
    for (var s = 0u; s < params.spp; s = s + 1u) {
        let r = shade(params.eye, pixel_dir(pixel, s), media, Closest(0.0, TRACE_ROOT), NO_SLOT);
        sum = sum + r.radiance;
        if (s == 0u) {
            out.signature = r.signature;
        }
        out.rays = out.rays + r.rays;
    }
    out.radiance = sum / f32(params.spp);
    return out;
}

// The pixels first_pixel ..+ pixel_count.
@compute @workgroup_size(64)
fn whitted(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * params.row_pitch;
    if (k >= params.pixel_count) {
        return;
    }
    write_pixel(k, render_pixel(params.first_pixel + k));
}

// The pixels pixel_list[0 ..pixel_count], in the list's order.
@compute @workgroup_size(64)
fn whitted_listed(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * params.row_pitch;
    if (k >= params.pixel_count) {
        return;
    }
    write_pixel(k, render_pixel(pixel_list[k]));
}

// The rays in pixel_list[8k ..8k + 8] (origin, root t, direction, root
// primitive), each from a root hit given (the bounded renderer's extremal
// rays: trace_sample in src/bounded/runner.rs), in air; their ray trees
// recorded, one slot each.
@compute @workgroup_size(64)
fn whitted_trees(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * params.row_pitch;
    if (k >= params.pixel_count) {
        return;
    }
    let b = 8u * k;
    let o = bitcast<vec3<f32>>(vec3<u32>(pixel_list[b], pixel_list[b + 1u], pixel_list[b + 2u]));
    let d = bitcast<vec3<f32>>(vec3<u32>(pixel_list[b + 4u], pixel_list[b + 5u], pixel_list[b + 6u]));
    let root = Closest(bitcast<f32>(pixel_list[b + 3u]), pixel_list[b + 7u]);
    var air: Media;
    air.ids = vec4<u32>(0u);
    air.len = 0u;
    let slot = k * (params.tree_capacity * params.tree_stride + TREE_HEADER_WORDS4);
    shade(o, d, air, root, slot);
}
