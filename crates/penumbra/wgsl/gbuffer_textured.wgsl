// Render pipeline: the G-buffer of gbuffer.wgsl for scenes with colour
// maps or alpha cut-outs (src/ssao/surfaces.rs; CPU twin: `gbuffer_with`
// over `GBufferSurfaces`). Composed after albedo.wgsl, texture_maps.wgsl
// and gbuffer.wgsl.
//
// The vertices are gbuffer.wgsl's; a vertex's triangle is its index / 3,
// and each corner carries its barycentric coordinates (of corners 1 and
// 2), interpolated perspective-correct to the pixel centre: the point the
// CPU's primary ray hits. A fragment in a cut-out's hole is discarded (what
// lies behind is drawn); a colour-mapped triangle's albedo is its colour
// times the map at the point, packed as the CPU packs it.
//
// `surfaces` is `GBufferSurfaces::words`: [cut-outs at, colour maps at,
// 0, 0] (NO_MAP: none), then each section, whose word indices count from
// its own first word; the texture lookups read the section `section`
// names.

@group(0) @binding(1) var<storage, read> surfaces: array<u32>;

// Words of a colour-mapped triangle's record (surfaces::ALBEDO_RECORD_WORDS).
const ALBEDO_RECORD_WORDS: u32 = 10u;
// Words of a cut-out triangle's record (Cutouts::words).
const CUTOUT_RECORD_WORDS: u32 = 8u;

// The first word of the section the texture lookups read.
var<private> section: u32;

fn map_word(k: u32) -> u32 {
    return surfaces[section + k];
}

fn maps_base() -> u32 {
    return surfaces[section];
}

struct TexturedOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) normal: vec3<f32>,
    @location(2) @interpolate(flat) albedo: f32,
    @location(3) @interpolate(flat) triangle: u32,
    @location(4) bary: vec2<f32>,
}

@vertex
fn gbuffer_textured_vs(v: VertexIn, @builtin(vertex_index) k: u32) -> TexturedOut {
    let plain = gbuffer_vertex(v);
    var out: TexturedOut;
    out.clip = plain.clip;
    out.world = plain.world;
    out.normal = plain.normal;
    out.albedo = plain.albedo;
    out.triangle = k / 3u;
    let corner = k % 3u;
    out.bary = vec2<f32>(select(0.0, 1.0, corner == 1u), select(0.0, 1.0, corner == 2u));
    return out;
}

// The (u, v) at barycentrics b of the three corners' stored from word at
// of the current section.
fn corner_uv(at: u32, b: vec2<f32>) -> vec2<f32> {
    let uv0 = vec2<f32>(bitcast<f32>(map_word(at)), bitcast<f32>(map_word(at + 1u)));
    let uv1 = vec2<f32>(bitcast<f32>(map_word(at + 2u)), bitcast<f32>(map_word(at + 3u)));
    let uv2 = vec2<f32>(bitcast<f32>(map_word(at + 4u)), bitcast<f32>(map_word(at + 5u)));
    return uv0 * (1.0 - b.x - b.y) + uv1 * b.x + uv2 * b.y;
}

// The record of triangle t in the current section, or NO_MAP.
fn section_record(t: u32) -> u32 {
    return map_word(map_word(1u) + t);
}

// A linear colour packed as albedo (the twin of surfaces::pack_colour).
fn pack_colour(c: vec3<f32>) -> f32 {
    let b = vec3<u32>(floor(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)) * 255.0 + 0.5));
    return f32(b.x + 256u * b.y + 65536u * b.z);
}

@fragment
fn gbuffer_textured_fs(in: TexturedOut) -> GBufferOut {
    if (surfaces[0] != NO_MAP) {
        section = surfaces[0];
        let r = section_record(in.triangle);
        if (r != NO_MAP) {
            let at = map_word(2u) + r * CUTOUT_RECORD_WORDS;
            if (map_hole(map_word(at), corner_uv(at + 1u, in.bary))) {
                discard;
            }
        }
    }
    var albedo = in.albedo;
    if (surfaces[1] != NO_MAP) {
        section = surfaces[1];
        let r = section_record(in.triangle);
        if (r != NO_MAP) {
            let at = map_word(2u) + r * ALBEDO_RECORD_WORDS;
            let kd = vec3<f32>(bitcast<f32>(map_word(at + 1u)), bitcast<f32>(map_word(at + 2u)), bitcast<f32>(map_word(at + 3u)));
            albedo = pack_colour(kd * sample_map(map_word(at), corner_uv(at + 4u, in.bary)));
        }
    }
    return gbuffer_texel(in.world, in.normal, albedo);
}
