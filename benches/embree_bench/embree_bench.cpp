// embree_bench: Embree 3 baseline for penumbra's CPU ray tracer (one thread, or --threads N
// for the random rays and the rtcIntersect1M stream of primary rays).
// Loads an OBJ (v and f lines, fans in file order), builds an Embree scene with
// RTC_BUILD_QUALITY_HIGH and times primary rays (rtcIntersect1 / rtcIntersect16 /
// rtcIntersect1M / rtcIntersectNp), per-vertex AO occlusion rays (rtcOccluded1 /
// rtcOccluded16 / rtcOccluded1M) and optionally a file of rays. One JSON line per
// mode on stdout. See README.md.
//
// Camera, vertex normals, ray origins and AO directions mirror penumbra's
// contract (src/scene/camera.rs, src/ao/points.rs, src/sampling/*.rs), so the
// same rays are traced: AO directions use penumbra's Owen-scrambled Sobol
// sequence (seed 24301 by default) with the concentric (Malley) mapping.
#include <embree3/rtcore.h>
#include <xmmintrin.h>
#include <pmmintrin.h>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <atomic>
#include <thread>
#include <vector>
#include <vector>
#include <algorithm>
#include <cstdarg>
#include <limits>

struct V3 { float x, y, z; };
static inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
static inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
static inline V3 operator*(float s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
static inline V3 operator*(V3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
static inline float dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
// glam's cross and normalize, term for term.
static inline V3 cross(V3 a, V3 b) { return {a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y}; }
static inline float length(V3 a) { return std::sqrt(dot(a, a)); }
static inline V3 normalize(V3 a) { return a * (1.0f / length(a)); }

static double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// ---------------------------------------------------------------- OBJ
struct Mesh { std::vector<V3> v; std::vector<uint32_t> tri; };

static bool load_obj(const char* path, Mesh& m) {
  FILE* f = fopen(path, "rb");
  if (!f) { perror(path); return false; }
  std::string text;
  char buf[1 << 16]; size_t n;
  while ((n = fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
  fclose(f);
  std::vector<long> face;
  size_t pos = 0, line_no = 0;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1; line_no++;
    size_t h = line.find('#'); if (h != std::string::npos) line.resize(h);
    const char* p = line.c_str();
    while (*p == ' ' || *p == '\t' || *p == '\r') p++;
    if (p[0] == 'v' && (p[1] == ' ' || p[1] == '\t')) {
      char* e; V3 c;
      c.x = strtof(p + 1, &e); c.y = strtof(e, &e); c.z = strtof(e, &e);
      m.v.push_back(c);
    } else if (p[0] == 'f' && (p[1] == ' ' || p[1] == '\t')) {
      face.clear();
      const char* q = p + 1;
      for (;;) {
        while (*q == ' ' || *q == '\t' || *q == '\r') q++;
        if (!*q) break;
        char* e; long i = strtol(q, &e, 10);
        if (e == q || i == 0) { fprintf(stderr, "%s:%zu: bad face index\n", path, line_no); return false; }
        long r = i > 0 ? i - 1 : (long)m.v.size() + i;
        if (r < 0) { fprintf(stderr, "%s:%zu: index before first vertex\n", path, line_no); return false; }
        face.push_back(r);
        q = e; while (*q && *q != ' ' && *q != '\t' && *q != '\r') q++;  // skip /vt/vn
      }
      for (size_t k = 2; k < face.size(); k++) {
        m.tri.push_back((uint32_t)face[0]); m.tri.push_back((uint32_t)face[k - 1]); m.tri.push_back((uint32_t)face[k]);
      }
    }
  }
  for (uint32_t i : m.tri) if (i >= m.v.size()) { fprintf(stderr, "%s: face index out of range\n", path); return false; }
  if (m.tri.empty()) { fprintf(stderr, "%s: no faces\n", path); return false; }
  return true;
}

// ---------------------------------------------------------------- camera (penumbra src/scene/camera.rs)
// px depends on the column only and py on the row only, so they are tabulated
// (bit-identical to computing them per pixel as penumbra's closure does).
struct Camera {
  V3 eye, right, up, fwd; float tan_half, aspect; unsigned W, H;
  std::vector<float> pxs, pys;
  void tabulate() {
    pxs.resize(W); pys.resize(H);
    for (unsigned x = 0; x < W; x++) pxs[x] = (2.0f * ((float)x + 0.5f) / (float)W - 1.0f) * tan_half * aspect;
    for (unsigned y = 0; y < H; y++) pys[y] = (1.0f - 2.0f * ((float)y + 0.5f) / (float)H) * tan_half;
  }
  inline V3 dir(unsigned x, unsigned y) const { return normalize(fwd + pxs[x] * right + pys[y] * up); }
};

static Camera make_camera(V3 eye, V3 target, float fov, unsigned W, unsigned H) {
  Camera c; c.eye = eye; c.W = W; c.H = H;
  c.fwd = normalize(target - eye);
  V3 Y{0, 1, 0}, Z{0, 0, 1};
  V3 cy = cross(c.fwd, Y);
  V3 world_up = dot(cy, cy) < 1e-12f ? Z : Y;
  c.right = normalize(cross(c.fwd, world_up));
  c.up = cross(c.right, c.fwd);
  const float rads_per_deg = 3.14159265358979323846f / 180.0f;
  c.tan_half = std::tan(0.5f * (fov * rads_per_deg));
  c.aspect = (float)W / (float)H;
  c.tabulate();
  return c;
}

// ---------------------------------------------------------------- sample sequence (penumbra src/sampling)
static inline uint32_t hash_u32(uint32_t x) {
  x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16; return x;
}
static inline uint32_t rev32(uint32_t x) {
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
  return __builtin_bswap32(x);
}
static inline uint32_t lk_perm(uint32_t x, uint32_t seed) {
  x += seed; x ^= x * 0x6c50b47cu; x ^= x * 0xb82f1e52u; x ^= x * 0xc7afe638u; x ^= x * 0x8d22f6e6u; return x;
}
static inline uint32_t nus(uint32_t x, uint32_t seed) { return rev32(lk_perm(rev32(x), seed)); }
static inline void owen_sobol_2d(uint32_t index, uint32_t seed, uint32_t& ox, uint32_t& oy) {
  uint32_t s = nus(index, seed);
  uint32_t x = rev32(s), y = 0, v = 1u << 31;
  for (uint32_t i = s; i; i >>= 1, v ^= v >> 1) if (i & 1) y ^= v;
  ox = nus(x, hash_u32(seed ^ 0xa511e9b3u));
  oy = nus(y, hash_u32(seed ^ 0x63d83595u));
}
static inline float unit_float(uint32_t b) { return (float)(b >> 8) * (1.0f / 16777216.0f); }
static inline uint32_t stream_seed(uint32_t seed, uint32_t point) { return hash_u32(seed ^ hash_u32(point + 0x9e3779b9u)); }

struct Frame { V3 t, b, n; };
static inline Frame frame_from_normal(V3 n) {
  float sign = std::copysign(1.0f, n.z);
  float a = -1.0f / (sign + n.z);
  float b = n.x * n.y * a;
  return {{1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x}, {b, sign + n.y * n.y * a, -n.y}, n};
}
// Direction of AO ray j at a point with stream seed `ss` and frame `F`.
static inline V3 ao_dir(uint32_t ss, uint32_t j, const Frame& F) {
  uint32_t bx, by; owen_sobol_2d(j, ss, bx, by);
  float u = unit_float(bx), v = unit_float(by);
  float a = 2.0f * u - 1.0f, b = 2.0f * v - 1.0f, dx = 0, dy = 0;
  if (!(a == 0.0f && b == 0.0f)) {
    float r, phi;
    const float q = 0.785398163397448309616f, h = 1.57079632679489661923f;
    if (std::fabs(a) > std::fabs(b)) { r = a; phi = q * (b / a); } else { r = b; phi = h - q * (a / b); }
    dx = r * std::cos(phi); dy = r * std::sin(phi);
  }
  float z = std::sqrt(std::max(0.0f, 1.0f - dx * dx - dy * dy));
  return F.t * dx + F.b * dy + F.n * z;
}

// ---------------------------------------------------------------- helpers
template <class F> static double best_of(int reps, F&& f) {
  double best = 1e300;
  for (int r = 0; r < reps; r++) { double t0 = now_ms(); f(); best = std::min(best, now_ms() - t0); }
  return best;
}
// Runs f(begin, end, thread) over [0, n) in chunks of `chunk` on `threads`
// threads (the caller's thread is one of them), chunks handed out in order
// as threads finish theirs. Each thread sets the flush-to-zero modes main sets.
template <class F> static void par_for(size_t n, size_t chunk, unsigned threads, F&& f) {
  std::atomic<size_t> next{0};
  auto work = [&](unsigned t) {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    for (size_t b; (b = next.fetch_add(chunk)) < n;) f(b, std::min(n, b + chunk), t);
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; t++) pool.emplace_back(work, t);
  work(0);
  for (auto& th : pool) th.join();
}
static std::string fmt(const char* f, ...) {
  char b[4096]; va_list ap; va_start(ap, f); vsnprintf(b, sizeof b, f, ap); va_end(ap); return b;
}
static bool parse3(const char* s, V3& v) { return sscanf(s, "%f,%f,%f", &v.x, &v.y, &v.z) == 3; }

static void init_ray(RTCRay& r, V3 o, V3 d, float tfar) {
  r.org_x = o.x; r.org_y = o.y; r.org_z = o.z; r.tnear = 0.0f;
  r.dir_x = d.x; r.dir_y = d.y; r.dir_z = d.z; r.time = 0.0f;
  r.tfar = tfar; r.mask = 0xffffffffu; r.id = 0; r.flags = 0;
}

static void usage() {
  fprintf(stderr,
    "usage: embree_bench MESH.obj [--modes primary,ao,rays] [--width W] [--height H]\n"
    "         [--eye X,Y,Z --target X,Y,Z] [--fov D] [--ao-rays N] [--seed S] [--reps R]\n"
    "         [--stream-tile T] [--rays FILE] [--gen-rays N OUT] [--per-vertex OUT.csv]\n"
    "         [--hits OUT.bin] [--check-rays PENUMBRA_RAYS.f32] [--isa avx512|avx2|sse4.2]\n"
    "         [--label NAME] [--threads N]\n");
}

int main(int argc, char** argv) {
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  if (argc < 2) { usage(); return 1; }
  const char* mesh_path = argv[1];
  std::string modes = "primary,ao";
  unsigned W = 1024, H = 1024, ao_n = 256, seed = 24301, stream_tile = 16;
  int reps = 5;
  unsigned threads = 1;
  bool have_eye = false, have_target = false; V3 eye_arg{}, target_arg{}; float fov = 45.0f;
  const char *rays_path = nullptr, *gen_out = nullptr, *per_vertex = nullptr, *hits_out = nullptr, *check_rays = nullptr;
  size_t gen_n = 0; std::string isa, label;
  for (int i = 2; i < argc; i++) {
    std::string a = argv[i];
    auto next = [&]() -> const char* { if (i + 1 >= argc) { usage(); exit(1); } return argv[++i]; };
    if (a == "--modes") modes = next();
    else if (a == "--width") W = atoi(next());
    else if (a == "--height") H = atoi(next());
    else if (a == "--eye") { if (!parse3(next(), eye_arg)) { usage(); return 1; } have_eye = true; }
    else if (a == "--target") { if (!parse3(next(), target_arg)) { usage(); return 1; } have_target = true; }
    else if (a == "--fov") fov = atof(next());
    else if (a == "--ao-rays") ao_n = atoi(next());
    else if (a == "--seed") seed = strtoul(next(), nullptr, 10);
    else if (a == "--reps") reps = atoi(next());
    else if (a == "--stream-tile") stream_tile = atoi(next());
    else if (a == "--rays") rays_path = next();
    else if (a == "--gen-rays") { gen_n = strtoull(next(), nullptr, 10); gen_out = next(); }
    else if (a == "--per-vertex") per_vertex = next();
    else if (a == "--hits") hits_out = next();
    else if (a == "--check-rays") check_rays = next();
    else if (a == "--isa") isa = next();
    else if (a == "--label") label = next();
    else if (a == "--threads") { threads = (unsigned)atoi(next()); if (threads < 1) { usage(); return 1; } }
    else { usage(); return 1; }
  }
  if (label.empty()) { label = mesh_path; size_t s = label.rfind('/'); if (s != std::string::npos) label = label.substr(s + 1); }
  auto has_mode = [&](const char* m) { return ("," + modes + ",").find(std::string(",") + m + ",") != std::string::npos; };

  Mesh mesh;
  double t0 = now_ms();
  if (!load_obj(mesh_path, mesh)) return 1;
  double load_ms = now_ms() - t0;
  size_t nv = mesh.v.size(), nt = mesh.tri.size() / 3;
  V3 lo = mesh.v[0], hi = mesh.v[0];
  for (const V3& p : mesh.v) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  float diag = length(hi - lo);

  // ---- random ray file generator (like embree_ref.py rays: origins on a sphere of 1.5 r, aimed at vertices)
  if (gen_out) {
    uint64_t s = 0x9e3779b97f4a7c15ull;
    auto rnd = [&]() { s ^= s << 13; s ^= s >> 7; s ^= s << 17; return (double)(s >> 11) * (1.0 / 9007199254740992.0); };
    auto gauss = [&]() { double u1 = rnd() + 1e-300, u2 = rnd(); return std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2); };
    V3 c = 0.5f * (lo + hi); float r = 0.5f * diag;
    std::vector<float> out(gen_n * 6);
    for (size_t k = 0; k < gen_n; k++) {
      V3 u{(float)gauss(), (float)gauss(), (float)gauss()}; u = normalize(u);
      V3 o = c + u * (r * 1.5f);
      size_t t = (size_t)(rnd() * nt) % nt, corner = (size_t)(rnd() * 3) % 3;
      V3 tg = mesh.v[mesh.tri[3 * t + corner]] + V3{(float)gauss(), (float)gauss(), (float)gauss()} * (r * 0.05f);
      V3 d = normalize(tg - o);
      float* w = &out[6 * k]; w[0] = o.x; w[1] = o.y; w[2] = o.z; w[3] = d.x; w[4] = d.y; w[5] = d.z;
    }
    FILE* f = fopen(gen_out, "wb"); fwrite(out.data(), 4, out.size(), f); fclose(f);
    fprintf(stderr, "wrote %zu rays to %s\n", gen_n, gen_out);
  }

  // ---- device and scene
  std::string cfg = "threads=" + std::to_string(threads);
  if (!isa.empty()) cfg += ",isa=" + isa;
  RTCDevice dev = rtcNewDevice(cfg.c_str());
  if (!dev) { fprintf(stderr, "rtcNewDevice(%s) failed: %d\n", cfg.c_str(), rtcGetDeviceError(nullptr)); return 1; }
  RTCScene scene = rtcNewScene(dev);
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geom = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
  float* vb = (float*)rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, nv);
  memcpy(vb, mesh.v.data(), nv * 12);
  uint32_t* ib = (uint32_t*)rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, nt);
  memcpy(ib, mesh.tri.data(), nt * 12);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  t0 = now_ms();
  rtcCommitScene(scene);
  double build_ms = now_ms() - t0;
  if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) { fprintf(stderr, "embree error\n"); return 1; }
  printf("{\"model\":\"%s\",\"mode\":\"build\",\"embree\":\"%s\",\"config\":\"%s\",\"native_ray4\":%ld,\"native_ray8\":%ld,"
         "\"native_ray16\":%ld,\"ray_stream\":%ld,\"vertices\":%zu,\"triangles\":%zu,\"load_ms\":%.1f,\"build_ms\":%.2f,"
         "\"build_quality\":\"high\",\"threads\":%u}\n",
         label.c_str(), RTC_VERSION_STRING, cfg.c_str(),
         (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED),
         (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED),
         (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED),
         (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_RAY_STREAM_SUPPORTED), nv, nt, load_ms, build_ms, threads);
  fflush(stdout);

  auto emit = [&](const char* mode, const char* api, size_t rays, double ms, const std::string& extra) {
    printf("{\"model\":\"%s\",\"mode\":\"%s\",\"api\":\"%s\",\"rays\":%zu,\"best_ms\":%.3f,\"mrays_per_s\":%.4f,\"reps\":%d,\"threads\":%u%s}\n",
           label.c_str(), mode, api, rays, ms, rays / ms * 1e-3, reps, threads, extra.c_str());
    fflush(stdout);
  };

  // ---- primary rays
  if (has_mode("primary")) {
    V3 c = 0.5f * (lo + hi);
    float r = 0.5f * diag; if (!(r > 0.0f && std::isfinite(r))) r = 1.0f;
    V3 u = normalize(V3{0.3f, 0.4f, 1.0f});
    V3 eye = have_eye ? eye_arg : c + (2.5f * r) * u;
    V3 target = have_target ? target_arg : c;
    Camera cam = make_camera(eye, target, fov, W, H);
    std::string cam_json = fmt(",\"width\":%u,\"height\":%u,\"eye\":[%.7g,%.7g,%.7g],\"target\":[%.7g,%.7g,%.7g],\"fov\":%g",
                               W, H, eye.x, eye.y, eye.z, target.x, target.y, target.z, fov);
    size_t npix = (size_t)W * H;

    if (check_rays) {  // compare our camera rays to penumbra's --dump-rays file
      FILE* f = fopen(check_rays, "rb"); std::vector<float> R(npix * 6);
      size_t got = f ? fread(R.data(), 4, R.size(), f) : 0; if (f) fclose(f);
      double maxo = 0, maxd = 0;
      if (got == R.size())
        for (unsigned y = 0; y < H; y++) for (unsigned x = 0; x < W; x++) {
          const float* q = &R[6 * ((size_t)y * W + x)]; V3 d = cam.dir(x, y);
          maxo = std::max({maxo, (double)std::fabs(q[0] - eye.x), (double)std::fabs(q[1] - eye.y), (double)std::fabs(q[2] - eye.z)});
          maxd = std::max({maxd, (double)std::fabs(q[3] - d.x), (double)std::fabs(q[4] - d.y), (double)std::fabs(q[5] - d.z)});
        }
      printf("{\"model\":\"%s\",\"mode\":\"check_rays\",\"file\":\"%s\",\"rays_in_file\":%zu,\"max_abs_origin_diff\":%g,\"max_abs_dir_diff\":%g}\n",
             label.c_str(), check_rays, got / 6, maxo, maxd);
    }

    RTCIntersectContext ctx_coh; rtcInitIntersectContext(&ctx_coh); ctx_coh.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTCIntersectContext ctx_inc; rtcInitIntersectContext(&ctx_inc); ctx_inc.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    const float INF = std::numeric_limits<float>::infinity();

    // (i) rtcIntersect1, pixels in the same 4x4-block order as the packets.
    for (int coherent = 0; coherent < 2; coherent++) {
      RTCIntersectContext* ctx = coherent ? &ctx_coh : &ctx_inc;
      size_t hits = 0; double tsum = 0;
      double ms = best_of(reps, [&] {
        hits = 0; tsum = 0;
        for (unsigned by = 0; by < H; by += 4) for (unsigned bx = 0; bx < W; bx += 4)
          for (unsigned y = by; y < std::min(by + 4, H); y++) for (unsigned x = bx; x < std::min(bx + 4, W); x++) {
            RTCRayHit rh; init_ray(rh.ray, cam.eye, cam.dir(x, y), INF);
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID; rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, ctx, &rh);
            if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) { hits++; tsum += rh.ray.tfar; }
          }
      });
      emit("primary", coherent ? "rtcIntersect1(coherent ctx)" : "rtcIntersect1", npix, ms,
           fmt(",\"hits\":%zu,\"sum_t\":%.6g%s", hits, tsum, cam_json.c_str()));
    }

    // (ii) rtcIntersect16, one 4x4 pixel block per packet.
    for (int coherent = 0; coherent < 2; coherent++) {
      RTCIntersectContext* ctx = coherent ? &ctx_coh : &ctx_inc;
      alignas(64) RTCRayHit16 rh; alignas(64) int valid[16];
      size_t hits = 0; double tsum = 0;
      double ms = best_of(reps, [&] {
        hits = 0; tsum = 0;
        for (unsigned by = 0; by < H; by += 4) for (unsigned bx = 0; bx < W; bx += 4) {
          for (int k = 0; k < 16; k++) {
            unsigned x = bx + (k & 3), y = by + (k >> 2);
            bool ok = x < W && y < H; valid[k] = ok ? -1 : 0;
            V3 d = ok ? cam.dir(x, y) : V3{0, 0, 1};
            rh.ray.org_x[k] = cam.eye.x; rh.ray.org_y[k] = cam.eye.y; rh.ray.org_z[k] = cam.eye.z; rh.ray.tnear[k] = 0.0f;
            rh.ray.dir_x[k] = d.x; rh.ray.dir_y[k] = d.y; rh.ray.dir_z[k] = d.z; rh.ray.time[k] = 0.0f;
            rh.ray.tfar[k] = INF; rh.ray.mask[k] = 0xffffffffu; rh.ray.id[k] = k; rh.ray.flags[k] = 0;
            rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID; rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
          }
          rtcIntersect16(valid, scene, ctx, &rh);
          for (int k = 0; k < 16; k++)
            if (valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID) { hits++; tsum += rh.ray.tfar[k]; }
        }
      });
      emit("primary", coherent ? "rtcIntersect16(coherent ctx)" : "rtcIntersect16", npix, ms,
           fmt(",\"packet\":\"4x4\",\"hits\":%zu,\"sum_t\":%.6g%s", hits, tsum, cam_json.c_str()));
    }

    // (iii) stream APIs over T x T pixel tiles (T = --stream-tile), coherent context.
    {
      unsigned T = stream_tile; size_t M = (size_t)T * T;
      std::vector<std::vector<RTCRayHit>> aos_of(threads, std::vector<RTCRayHit>(M));
      size_t hits = 0; double tsum = 0;
      unsigned tiles_x = (W + T - 1) / T, tiles = tiles_x * ((H + T - 1) / T);
      std::vector<size_t> hits_of(threads); std::vector<double> tsum_of(threads);
      double ms = best_of(reps, [&] {
        std::fill(hits_of.begin(), hits_of.end(), 0); std::fill(tsum_of.begin(), tsum_of.end(), 0.0);
        par_for(tiles, 1, threads, [&](size_t tile, size_t, unsigned t) {
          std::vector<RTCRayHit>& aos = aos_of[t];
          unsigned tx = (unsigned)(tile % tiles_x) * T, ty = (unsigned)(tile / tiles_x) * T;
          unsigned m = 0;
          for (unsigned by = ty; by < std::min(ty + T, H); by += 4) for (unsigned bx = tx; bx < std::min(tx + T, W); bx += 4)
            for (unsigned y = by; y < std::min(by + 4, H); y++) for (unsigned x = bx; x < std::min(bx + 4, W); x++) {
              RTCRayHit& rh = aos[m++]; init_ray(rh.ray, cam.eye, cam.dir(x, y), INF);
              rh.hit.geomID = RTC_INVALID_GEOMETRY_ID; rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            }
          RTCIntersectContext c = ctx_coh;
          rtcIntersect1M(scene, &c, aos.data(), m, sizeof(RTCRayHit));
          for (unsigned k = 0; k < m; k++) if (aos[k].hit.geomID != RTC_INVALID_GEOMETRY_ID) { hits_of[t]++; tsum_of[t] += aos[k].ray.tfar; }
        });
        hits = 0; tsum = 0;
        for (unsigned t = 0; t < threads; t++) { hits += hits_of[t]; tsum += tsum_of[t]; }
      });
      emit("primary", "rtcIntersect1M(coherent ctx)", npix, ms,
           fmt(",\"stream\":\"%ux%u tile, M=%zu\",\"hits\":%zu,\"sum_t\":%.6g%s", T, T, M, hits, tsum, cam_json.c_str()));

      // SOA stream (rtcIntersectNp)
      std::vector<float> f[9]; std::vector<unsigned> mask(M), id(M), flags(M), geomID(M), primID(M), instID(M);
      for (auto& v : f) v.resize(M);  // ox oy oz dx dy dz tnear tfar time
      std::vector<float> ng[3], uv[2]; for (auto& v : ng) v.resize(M); for (auto& v : uv) v.resize(M);
      RTCRayHitNp np;
      np.ray.org_x = f[0].data(); np.ray.org_y = f[1].data(); np.ray.org_z = f[2].data();
      np.ray.dir_x = f[3].data(); np.ray.dir_y = f[4].data(); np.ray.dir_z = f[5].data();
      np.ray.tnear = f[6].data(); np.ray.tfar = f[7].data(); np.ray.time = f[8].data();
      np.ray.mask = mask.data(); np.ray.id = id.data(); np.ray.flags = flags.data();
      np.hit.Ng_x = ng[0].data(); np.hit.Ng_y = ng[1].data(); np.hit.Ng_z = ng[2].data();
      np.hit.u = uv[0].data(); np.hit.v = uv[1].data();
      np.hit.primID = primID.data(); np.hit.geomID = geomID.data(); np.hit.instID[0] = instID.data();
      ms = best_of(reps, [&] {
        hits = 0; tsum = 0;
        for (unsigned ty = 0; ty < H; ty += T) for (unsigned tx = 0; tx < W; tx += T) {
          unsigned m = 0;
          for (unsigned by = ty; by < std::min(ty + T, H); by += 4) for (unsigned bx = tx; bx < std::min(tx + T, W); bx += 4)
            for (unsigned y = by; y < std::min(by + 4, H); y++) for (unsigned x = bx; x < std::min(bx + 4, W); x++) {
              V3 d = cam.dir(x, y);
              f[0][m] = cam.eye.x; f[1][m] = cam.eye.y; f[2][m] = cam.eye.z; f[3][m] = d.x; f[4][m] = d.y; f[5][m] = d.z;
              f[6][m] = 0.0f; f[7][m] = INF; f[8][m] = 0.0f; mask[m] = 0xffffffffu; id[m] = m; flags[m] = 0;
              geomID[m] = RTC_INVALID_GEOMETRY_ID; instID[m] = RTC_INVALID_GEOMETRY_ID; m++;
            }
          rtcIntersectNp(scene, &ctx_coh, &np, m);
          for (unsigned k = 0; k < m; k++) if (geomID[k] != RTC_INVALID_GEOMETRY_ID) { hits++; tsum += f[7][k]; }
        }
      });
      emit("primary", "rtcIntersectNp(coherent ctx)", npix, ms,
           fmt(",\"stream\":\"%ux%u tile, N=%zu, SOA\",\"hits\":%zu,\"sum_t\":%.6g%s", T, T, M, hits, tsum, cam_json.c_str()));
    }

    // ray generation alone, for reference
    {
      double sink = 0;
      double ms = best_of(reps, [&] {
        for (unsigned y = 0; y < H; y++) for (unsigned x = 0; x < W; x++) { V3 d = cam.dir(x, y); sink += d.x; }
      });
      emit("primary", "raygen only (no tracing)", npix, ms, fmt(",\"sink\":%g", sink));
    }
  }

  // ---- ambient occlusion per vertex
  if (has_mode("ao")) {
    // Area-weighted vertex normals: sum of cross(v1-v0, v2-v0) in f64, normalised (penumbra mesh.rs).
    std::vector<double> acc(3 * nv, 0.0);
    for (size_t t = 0; t < nt; t++) {
      V3 a = mesh.v[mesh.tri[3 * t]], b = mesh.v[mesh.tri[3 * t + 1]], c = mesh.v[mesh.tri[3 * t + 2]];
      V3 n = cross(b - a, c - a);
      for (int k = 0; k < 3; k++) { size_t i = mesh.tri[3 * t + k]; acc[3 * i] += n.x; acc[3 * i + 1] += n.y; acc[3 * i + 2] += n.z; }
    }
    struct Pt { V3 o; Frame F; uint32_t ss, index; };
    std::vector<Pt> pts; pts.reserve(nv);
    float offset = 1e-4f * diag;
    size_t skipped = 0;
    for (size_t i = 0; i < nv; i++) {
      double x = acc[3 * i], y = acc[3 * i + 1], z = acc[3 * i + 2], l = std::sqrt(x * x + y * y + z * z);
      if (!(l > 0.0) || !std::isfinite(1.0 / l)) { skipped++; continue; }
      V3 n{(float)(x / l), (float)(y / l), (float)(z / l)};
      pts.push_back({mesh.v[i] + offset * n, frame_from_normal(n), stream_seed(seed, (uint32_t)i), (uint32_t)i});
    }
    size_t np_ = pts.size(), total = np_ * ao_n;
    std::vector<uint32_t> open_count(np_);
    RTCIntersectContext ctx; rtcInitIntersectContext(&ctx); ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    const float INF = std::numeric_limits<float>::infinity();
    auto mean_acc = [&]() { double s = 0; for (uint32_t c : open_count) s += c; return s / (double)total; };
    std::string info = fmt(",\"vertices\":%zu,\"points\":%zu,\"skipped_vertices\":%zu,\"rays_per_point\":%u,\"seed\":%u,"
                           "\"sampler\":\"penumbra owen-sobol + concentric/malley\"", nv, np_, skipped, ao_n, seed);

    // (i) rtcOccluded1
    double ms = best_of(reps, [&] {
      for (size_t p = 0; p < np_; p++) {
        const Pt& P = pts[p]; uint32_t open = 0;
        for (uint32_t j = 0; j < ao_n; j++) {
          RTCRay r; init_ray(r, P.o, ao_dir(P.ss, j, P.F), INF);
          rtcOccluded1(scene, &ctx, &r);
          open += r.tfar >= 0.0f;  // occluded rays get tfar = -inf
        }
        open_count[p] = open;
      }
    });
    double mean1 = mean_acc();
    std::vector<uint32_t> open1 = open_count;
    emit("ao", "rtcOccluded1", total, ms, fmt(",\"mean_accessibility\":%.6f%s", mean1, info.c_str()));

    // (ii) rtcOccluded16, 16 rays of one vertex per packet (incoherent, then coherent context)
    RTCIntersectContext ctx_coh; rtcInitIntersectContext(&ctx_coh); ctx_coh.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (int coherent = 0; coherent < 2; coherent++) {
      RTCIntersectContext* c16 = coherent ? &ctx_coh : &ctx;
      alignas(64) RTCRay16 r; alignas(64) int valid[16];
      ms = best_of(reps, [&] {
        for (size_t p = 0; p < np_; p++) {
          const Pt& P = pts[p]; uint32_t open = 0;
          for (uint32_t j0 = 0; j0 < ao_n; j0 += 16) {
            for (int k = 0; k < 16; k++) {
              uint32_t j = j0 + k; valid[k] = j < ao_n ? -1 : 0;
              V3 d = j < ao_n ? ao_dir(P.ss, j, P.F) : P.F.n;
              r.org_x[k] = P.o.x; r.org_y[k] = P.o.y; r.org_z[k] = P.o.z; r.tnear[k] = 0.0f;
              r.dir_x[k] = d.x; r.dir_y[k] = d.y; r.dir_z[k] = d.z; r.time[k] = 0.0f;
              r.tfar[k] = INF; r.mask[k] = 0xffffffffu; r.id[k] = k; r.flags[k] = 0;
            }
            rtcOccluded16(valid, scene, c16, &r);
            for (int k = 0; k < 16; k++) open += valid[k] && r.tfar[k] >= 0.0f;
          }
          open_count[p] = open;
        }
      });
      size_t diff = 0; for (size_t p = 0; p < np_; p++) diff += open_count[p] != open1[p];
      emit("ao", coherent ? "rtcOccluded16(coherent ctx)" : "rtcOccluded16", total, ms, fmt(",\"mean_accessibility\":%.6f,\"points_differing_from_occluded1\":%zu%s", mean_acc(), diff, info.c_str()));
    }

    // (iii) rtcOccluded1M, all rays of one vertex per call (incoherent stream)
    {
      std::vector<RTCRay> rs(ao_n);
      ms = best_of(reps, [&] {
        for (size_t p = 0; p < np_; p++) {
          const Pt& P = pts[p]; uint32_t open = 0;
          for (uint32_t j = 0; j < ao_n; j++) init_ray(rs[j], P.o, ao_dir(P.ss, j, P.F), INF);
          rtcOccluded1M(scene, &ctx, rs.data(), ao_n, sizeof(RTCRay));
          for (uint32_t j = 0; j < ao_n; j++) open += rs[j].tfar >= 0.0f;
          open_count[p] = open;
        }
      });
      emit("ao", "rtcOccluded1M(per vertex)", total, ms, fmt(",\"mean_accessibility\":%.6f%s", mean_acc(), info.c_str()));
    }

    // Trace-only variants: the same directions, generated before the clock starts.
    if (total * 12 <= (size_t)4 << 30) {
      std::vector<V3> dirs(total);
      for (size_t p = 0; p < np_; p++) for (uint32_t j = 0; j < ao_n; j++) dirs[p * ao_n + j] = ao_dir(pts[p].ss, j, pts[p].F);
      ms = best_of(reps, [&] {
        for (size_t p = 0; p < np_; p++) {
          const Pt& P = pts[p]; uint32_t open = 0; const V3* D = &dirs[p * ao_n];
          for (uint32_t j = 0; j < ao_n; j++) {
            RTCRay r; init_ray(r, P.o, D[j], INF);
            rtcOccluded1(scene, &ctx, &r);
            open += r.tfar >= 0.0f;
          }
          open_count[p] = open;
        }
      });
      emit("ao", "rtcOccluded1(dirs precomputed)", total, ms, fmt(",\"mean_accessibility\":%.6f%s", mean_acc(), info.c_str()));
      alignas(64) RTCRay16 r; alignas(64) int valid[16];
      ms = best_of(reps, [&] {
        for (size_t p = 0; p < np_; p++) {
          const Pt& P = pts[p]; uint32_t open = 0; const V3* D = &dirs[p * ao_n];
          for (uint32_t j0 = 0; j0 < ao_n; j0 += 16) {
            for (int k = 0; k < 16; k++) {
              uint32_t j = j0 + k; valid[k] = j < ao_n ? -1 : 0;
              V3 d = j < ao_n ? D[j] : P.F.n;
              r.org_x[k] = P.o.x; r.org_y[k] = P.o.y; r.org_z[k] = P.o.z; r.tnear[k] = 0.0f;
              r.dir_x[k] = d.x; r.dir_y[k] = d.y; r.dir_z[k] = d.z; r.time[k] = 0.0f;
              r.tfar[k] = INF; r.mask[k] = 0xffffffffu; r.id[k] = k; r.flags[k] = 0;
            }
            rtcOccluded16(valid, scene, &ctx, &r);
            for (int k = 0; k < 16; k++) open += valid[k] && r.tfar[k] >= 0.0f;
          }
          open_count[p] = open;
        }
      });
      emit("ao", "rtcOccluded16(dirs precomputed)", total, ms, fmt(",\"mean_accessibility\":%.6f%s", mean_acc(), info.c_str()));
    }

    // direction generation alone, for reference
    {
      double sink = 0;
      ms = best_of(reps, [&] {
        for (size_t p = 0; p < np_; p++) for (uint32_t j = 0; j < ao_n; j++) sink += ao_dir(pts[p].ss, j, pts[p].F).x;
      });
      emit("ao", "raygen only (no tracing)", total, ms, fmt(",\"sink\":%g", sink));
    }

    if (per_vertex) {  // index,accessibility from rtcOccluded1; unused vertices written as 1 (penumbra's convention)
      FILE* f = fopen(per_vertex, "w");
      std::vector<double> a(nv, 1.0);
      for (size_t p = 0; p < np_; p++) a[pts[p].index] = (double)open1[p] / ao_n;
      for (size_t i = 0; i < nv; i++) fprintf(f, "%zu,%.8g\n", i, a[i]);
      fclose(f);
    }
  }

  // ---- ray file, rtcIntersect1 (incoherent)
  if (rays_path || (gen_out && has_mode("rays"))) {
    const char* path = rays_path ? rays_path : gen_out;
    FILE* f = fopen(path, "rb"); if (!f) { perror(path); return 1; }
    fseek(f, 0, SEEK_END); long bytes = ftell(f); fseek(f, 0, SEEK_SET);
    size_t n = bytes / 24; std::vector<float> R(n * 6);
    if (fread(R.data(), 4, R.size(), f) != R.size()) { fprintf(stderr, "short read\n"); return 1; }
    fclose(f);
    RTCIntersectContext ctx; rtcInitIntersectContext(&ctx); ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    const float INF = std::numeric_limits<float>::infinity();
    std::vector<float> ht(n); std::vector<uint32_t> hp(n);
    size_t hits = 0;
    double ms = best_of(reps, [&] {
      std::atomic<size_t> all{0};
      par_for(n, 4096, threads, [&](size_t b, size_t e, unsigned) {
        RTCIntersectContext c = ctx;
        size_t mine = 0;
        for (size_t k = b; k < e; k++) {
          const float* q = &R[6 * k];
          RTCRayHit rh; init_ray(rh.ray, V3{q[0], q[1], q[2]}, V3{q[3], q[4], q[5]}, INF);
          rh.hit.geomID = RTC_INVALID_GEOMETRY_ID; rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
          rtcIntersect1(scene, &c, &rh);
          bool hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
          mine += hit; ht[k] = hit ? rh.ray.tfar : INF; hp[k] = hit ? rh.hit.primID : 0xffffffffu;
        }
        all += mine;
      });
      hits = all;
    });
    emit("rays", "rtcIntersect1", n, ms, fmt(",\"file\":\"%s\",\"hits\":%zu", path, hits));
    if (hits_out) {
      FILE* o = fopen(hits_out, "wb");
      for (size_t k = 0; k < n; k++) { fwrite(&ht[k], 4, 1, o); fwrite(&hp[k], 4, 1, o); }
      fclose(o);
    }
  }

  rtcReleaseScene(scene);
  rtcReleaseDevice(dev);
  return 0;
}
