// Stress probes at scale: every probe function of shaders/tests/probe.comp and its CPU twin
// (host/cpu/probe.cpp; layout.h PROBE_*) driven with N random inputs each (N from the
// environment variable BASALT_STRESS_N, default 10^7), drawn from hard-case generators that mix
// ordinary inputs with grazing directions (cos theta 1e-7 .. 1e-3 and exactly 0), zeros,
// denormals, huge (1e20 .. 1e30) and tiny (1e-20 .. 1e-30) magnitudes, the largest finite
// float and the neighbours of limits, lattice-aligned noise points (integers, integers +- 1 ulp,
// 2^23, 2^24 + 2), degenerate geometry (zero-area and collinear triangles, zero footprints and
// differentials, degenerate uv), sphere poles, and sample values 0 and 1 - 2^-24.
//
// For every function, on BOTH sides, the test counts and asserts:
// - no NaN or infinite value in the output fields the op defines;
// - no negative value where the op's output must be non-negative (radiance, pdfs, the hit
//   distance and barycentrics, turbulence; each test says what it checks);
// - no self-intersection (CLOSEST, OCCLUDED, RESPAWN, DIFFERENTIALS: a ray spawned from a
//   surface never re-hits its own primitive near its origin; the rules of
//   tests/gpu/robustness_test.cpp NoSelfIntersectionAtAnyScale);
// - GPU == CPU under the tolerance the probe's existing test uses (robustness_test.cpp,
//   bsdf_probe_test.cpp with tests/common/bsdf_check.*, texture_probe_test.cpp,
//   envmap_gpu_test.cpp, bump_probe_test.cpp, sampler_probe_test.cpp), with excusals only
//   where that test has the same rule, each counted, printed and bounded by a stated fraction.
// Inputs respect each function's documented preconditions (stated at each generator), e.g.
// unit local directions for BSDF queries and pixels inside the film for camera queries.
//
// Queries go in batches of 2^18 through one GPU probe runner per scene (pipeline and buffers
// built once, tests/common/test_util.h ProbeRunner) and through the CPU twin on 2 threads. The
// generators are seeded per test (std::mt19937_64), so a failure is reproducible; the first
// offending inputs of each kind are printed bit-exactly (hex floats). One line per function:
//   STRESS <function> inputs=<n> nonfinite_cpu=<a> nonfinite_gpu=<b> negative_cpu=<c>
//   negative_gpu=<d> self_intersections_cpu=<e> self_intersections_gpu=<f> mismatches=<g>
//   excused=<h> seconds=<s>
// Tests named *Stress* carry the ctest label "stress" only (CMakeLists.txt).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <glm/gtc/matrix_transform.hpp>

#include "common/bsdf_check.h"
#include "common/sampler_scenes.h"
#include "common/test_util.h"
#include "common/bump_scenes.h"
#include "common/texture_scenes.h"
#include "cpu/wide_bvh.h"
#include "image/image_io.h"

namespace basalt::test {
namespace {

using Rng = std::mt19937_64;
using u64 = std::uint64_t;
using gpu::ProbeIn;
using gpu::ProbeOut;
using bsdf::effective_wi;
using bsdf::has_measured;
using bsdf::material_eta;
using bsdf::refract_dir;
using bsdf::tangent_or_no_sample;

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kBatch = std::size_t(1) << 18;  // queries per GPU dispatch
constexpr float kOneMinus = 0x1.fffffep-1f;           // 1 - 2^-24, the largest u below 1
constexpr float kDenormMin = 0x1p-149f;                // smallest positive denormal
constexpr float kDenorm = 1e-40f;                      // a denormal
constexpr int kPrintMax = 10;                          // offending inputs printed per kind

/// N, from BASALT_STRESS_N (default 10^7).
std::size_t stress_n() {
  const char* e = std::getenv("BASALT_STRESS_N");
  if (!e || !*e) return 10000000;
  return std::size_t(std::strtoull(e, nullptr, 10));
}

// ---- random values -------------------------------------------------------------------------

/// Uniform in [0, 1) (24 bits: every value a float, 1 never).
float U(Rng& r) { return float(r() >> 40) * 0x1p-24f; }
/// Uniform double in [0, 1).
double Ud(Rng& r) { return double(r() >> 11) * 0x1p-53; }
float S(Rng& r, float a, float b) { return a + (b - a) * U(r); }
bool chance(Rng& r, double p) { return Ud(r) < p; }
int pick(Rng& r, int n) { return int(r() % std::uint64_t(n)); }
/// 10^U(a, b).
float log10_uniform(Rng& r, float a, float b) { return float(std::pow(10.0, a + (b - a) * Ud(r))); }
float rsign(Rng& r, float v) { return chance(r, 0.5) ? -v : v; }

/// A hard |cos theta| for a direction against a normal: exactly 0, 1e-7 .. 1e-3 (log-uniform),
/// 1 - 1e-7, exactly 1, or uniform.
double hard_cos_abs(Rng& r) {
  switch (pick(r, 8)) {
    case 0: return 0.0;
    case 1:
    case 2: return std::pow(10.0, -7.0 + 4.0 * Ud(r));
    case 3: return 1.0 - 1e-7;
    case 4: return 1.0;
    default: return Ud(r);
  }
}

/// A hard sample value in [0, 1): 0, 1 - 2^-24, a denormal, 1e-30 .. 1e-20, 1e-7, 0.5, or
/// uniform (half of the draws).
float hard_u(Rng& r) {
  switch (pick(r, 14)) {
    case 0: return 0.0f;
    case 1: return kOneMinus;
    case 2: return kDenorm;
    case 3: return log10_uniform(r, -30.0f, -20.0f);
    case 4: return 1e-7f;
    case 5: return 0.5f;
    case 6: return std::nextafter(0.5f, 0.0f);
    default: return U(r);
  }
}

/// Uniform unit vector (double, rounded).
glm::vec3 uniform_dir(Rng& r) {
  const double z = 1.0 - 2.0 * Ud(r), phi = 2.0 * kPi * Ud(r);
  const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
  return glm::vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(z));
}

/// Orthonormal pair perpendicular to unit n (double).
void perp(glm::dvec3 n, glm::dvec3& a, glm::dvec3& b) {
  const glm::dvec3 h = std::fabs(n.x) < 0.6 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  a = glm::normalize(glm::cross(n, h));
  b = glm::cross(n, a);
}

/// A unit direction at cosine \p c to unit \p n (the sign of c picks the side), azimuth random.
glm::vec3 dir_at_cos(Rng& r, glm::vec3 n, double c) {
  glm::dvec3 a, b;
  const glm::dvec3 nd = glm::normalize(glm::dvec3(n));
  perp(nd, a, b);
  const double phi = 2.0 * kPi * Ud(r), s = std::sqrt(std::max(0.0, 1.0 - c * c));
  return glm::vec3(glm::normalize(c * nd + s * (std::cos(phi) * a + std::sin(phi) * b)));
}

// ---- printing ------------------------------------------------------------------------------

std::string hexf(float v) {
  char b[40];
  std::snprintf(b, sizeof(b), "%a", double(v));
  return b;
}
std::string hex4(glm::vec4 v) {
  return "(" + hexf(v.x) + ", " + hexf(v.y) + ", " + hexf(v.z) + ", " + hexf(v.w) + ")";
}
std::string hex(const ProbeIn& q) {
  char b[80];
  std::snprintf(b, sizeof(b), "key (%u, %u, %u, %u)", q.key.x, q.key.y, q.key.z, q.key.w);
  return std::string(b) + " o_tmax " + hex4(q.o_tmax) + " d " + hex4(q.d) + " extra " +
         hex4(q.extra) + " extra2 " + hex4(q.extra2) + " extra3 " + hex4(q.extra3);
}
std::string hex(const ProbeOut& o) {
  char b[80];
  std::snprintf(b, sizeof(b), " u (%u, %u, %u, %u)", o.u.x, o.u.y, o.u.z, o.u.w);
  return "f0 " + hex4(o.f0) + " f1 " + hex4(o.f1) + " f2 " + hex4(o.f2) + " f3 " + hex4(o.f3) + b;
}

bool finite3(glm::vec4 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite4(glm::vec4 v) { return finite3(v) && std::isfinite(v.w); }

// ---- the counts of one function ------------------------------------------------------------

/// Seconds spent in the GPU probe (the first call includes the pipeline's compile) and in the
/// CPU twin, over the whole test run (printed by Stress::finish).
double g_gpu_seconds = 0.0, g_cpu_seconds = 0.0, g_compile_seconds = 0.0;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}


enum { kCpu = 0, kGpu = 1 };

/// Counts, the excusal bounds and the summary line of one stress function.
struct Stress {
  std::string name;
  u64 inputs = 0;
  u64 nonfinite[2] = {0, 0}, negative[2] = {0, 0}, self[2] = {0, 0};
  u64 mismatches = 0, excused = 0;
  std::map<std::string, u64> detail;   // further checks, each asserted 0 unless bounded
  std::map<std::string, int> printed;  // offending inputs printed per kind
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();

  explicit Stress(std::string n) : name(std::move(n)) {
    g_gpu_seconds = g_cpu_seconds = g_compile_seconds = 0.0;
  }

  /// Prints the first few offending inputs of kind \p what bit-exactly.
  void offend(const std::string& what, const ProbeIn& q, const ProbeOut* cpu,
              const ProbeOut* gpu, const std::string& note = "") {
    if (++printed[what] > kPrintMax) return;
    std::printf("  [%s] %s%s%s\n    input %s\n", name.c_str(), what.c_str(),
                note.empty() ? "" : ": ", note.c_str(), hex(q).c_str());
    if (cpu) std::printf("    cpu   %s\n", hex(*cpu).c_str());
    if (gpu) std::printf("    gpu   %s\n", hex(*gpu).c_str());
    std::fflush(stdout);
  }
  void count_nonfinite(int side, const ProbeIn& q, const ProbeOut& c, const ProbeOut& g) {
    ++nonfinite[side];
    offend(side ? "nonfinite gpu" : "nonfinite cpu", q, &c, &g);
  }
  void count_negative(int side, const ProbeIn& q, const ProbeOut& c, const ProbeOut& g) {
    ++negative[side];
    offend(side ? "negative gpu" : "negative cpu", q, &c, &g);
  }
  void count_self(int side, const ProbeIn& q, const ProbeOut& c, const ProbeOut& g) {
    ++self[side];
    offend(side ? "self-intersection gpu" : "self-intersection cpu", q, &c, &g);
  }
  void count_detail(const std::string& what, const ProbeIn& q, const ProbeOut* c,
                    const ProbeOut* g, const std::string& note = "") {
    ++detail[what];
    offend(what, q, c, g, note);
  }

  /// Prints the summary line and asserts: every count 0, excused <= \p excused_bound inputs
  /// (a negative bound: the caller bounds its excusals itself).
  void finish(double excused_bound, const std::string& excused_rule) {
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("STRESS %s inputs=%llu nonfinite_cpu=%llu nonfinite_gpu=%llu negative_cpu=%llu "
                "negative_gpu=%llu self_intersections_cpu=%llu self_intersections_gpu=%llu "
                "mismatches=%llu excused=%llu seconds=%.1f\n",
                name.c_str(), (unsigned long long)inputs, (unsigned long long)nonfinite[0],
                (unsigned long long)nonfinite[1], (unsigned long long)negative[0],
                (unsigned long long)negative[1], (unsigned long long)self[0],
                (unsigned long long)self[1], (unsigned long long)mismatches,
                (unsigned long long)excused, secs);
    std::printf("  %s: probe pipeline builds %.1f s, GPU probe %.1f s, CPU twin %.1f s\n",
                name.c_str(), g_compile_seconds, g_gpu_seconds, g_cpu_seconds);
    for (const auto& [k, v] : detail)
      std::printf("  %s: %s %llu\n", name.c_str(), k.c_str(), (unsigned long long)v);
    if (excused_bound > 0.0)
      std::printf("  %s: excused %llu of %llu inputs (%.3g; bound %.3g: %s)\n", name.c_str(),
                  (unsigned long long)excused, (unsigned long long)inputs,
                  inputs ? double(excused) / double(inputs) : 0.0, excused_bound,
                  excused_rule.c_str());
    std::fflush(stdout);
    EXPECT_EQ(nonfinite[0], 0u) << name << ": NaN or infinite CPU outputs";
    EXPECT_EQ(nonfinite[1], 0u) << name << ": NaN or infinite GPU outputs";
    EXPECT_EQ(negative[0], 0u) << name << ": negative CPU outputs";
    EXPECT_EQ(negative[1], 0u) << name << ": negative GPU outputs";
    EXPECT_EQ(self[0], 0u) << name << ": CPU self-intersections";
    EXPECT_EQ(self[1], 0u) << name << ": GPU self-intersections";
    EXPECT_EQ(mismatches, 0u) << name << ": unexcused GPU/CPU mismatches";
    if (excused_bound >= 0.0) {
      EXPECT_LE(double(excused), excused_bound * double(inputs)) << name << ": excused";
    }
  }
};

/// A probe runner for \p t whose pipeline is built (and compiled by the driver, at its first
/// dispatch) here, timed apart from the batches.
std::unique_ptr<ProbeRunner> make_runner(const SceneTables& t) {
  const auto t0 = std::chrono::steady_clock::now();
  auto r = std::make_unique<ProbeRunner>(t);
  // A full batch: the runner sizes its buffers (and builds its pipeline) for the largest call.
  ProbeIn q{};
  q.key.x = gpu::PROBE_RNG;
  r->run(std::vector<ProbeIn>(kBatch, q));
  g_compile_seconds += seconds_since(t0);
  return r;
}

/// Both sides' answers to one batch: the GPU through \p runner, the CPU on 2 threads.
struct Answers {
  std::vector<ProbeOut> cpu, gpu;
};
Answers run_both(ProbeRunner& runner, const SceneTables& t, const std::vector<ProbeIn>& q) {
  Answers a;
  auto t0 = std::chrono::steady_clock::now();
  a.gpu = runner.run(q);
  g_gpu_seconds += seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  a.cpu = probe_cpu_threads(t, q, 2);
  g_cpu_seconds += seconds_since(t0);
  EXPECT_EQ(a.gpu.size(), q.size());
  EXPECT_EQ(a.cpu.size(), q.size());
  return a;
}

/// Moves a point by k ulps of its largest coordinate with alternating signs (x +, y -, z +):
/// the nudge of the existing excusal rules (texture_probe_test.cpp, envmap_gpu_test.cpp).
glm::vec3 nudge_point(glm::vec3 p, int k) {
  const float m = std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z)));
  const float s = float(k) * (std::nextafter(m, INFINITY) - m);
  return glm::vec3(p.x + s, p.y - s, p.z + s);
}
constexpr int kNudges[10] = {1, -1, 2, -2, 4, -4, 8, -8, 16, -16};

// =============================================================================================
// CLOSEST, OCCLUDED, RESPAWN: a scene of clusters at six scales (1e-4 .. 1e6, the range of
// robustness_test.cpp), each with 200 random triangles, 40 spheres and a 6 x 6 grid of quads with
// shared vertices (watertight edges), some triangles made degenerate after the build.
// =============================================================================================

/// The scene of the ray stress tests and what the generators need to aim at it.
struct RayScene {
  SceneTables t;
  struct Tri {
    std::uint32_t index;  // triangle index in the tables
    float scale;          // its cluster's scale
  };
  std::vector<Tri> tris;                  // non-degenerate triangles
  std::vector<std::uint32_t> degenerate;  // planted zero-area triangles
  std::vector<std::uint8_t> exactly_degenerate;  // per triangle: cross(p0 - p2, p1 - p2) == 0
  std::vector<float> sphere_scale;
  struct Grid {
    glm::vec3 origin, ex, ey;  // point (i, j) = origin + i ex + j ey, i, j in 0..6
    float scale;
  };
  std::vector<Grid> grids;
  std::vector<float> scales;
};

RayScene make_ray_scene() {
  RayScene rs;
  Scene s = one_material_scene();
  Rng rng(7001);
  rs.scales = {1e-4f, 1e-2f, 1.0f, 1e2f, 1e4f, 1e6f};
  std::vector<float> tri_scale;
  for (float scale : rs.scales) {
    const glm::vec3 offset(scale * 3.0f, -scale * 2.0f, scale * 5.0f);
    Shape sh;
    sh.kind = Shape::Kind::Triangles;
    sh.material = 0;
    for (int i = 0; i < 200; ++i) {
      const glm::vec3 c = offset + scale * glm::vec3(S(rng, -1, 1), S(rng, -1, 1), S(rng, -1, 1));
      for (int k = 0; k < 3; ++k) {
        sh.mesh.indices.push_back(unsigned(sh.mesh.P.size()));
        sh.mesh.P.push_back(c + 0.3f * scale * glm::vec3(S(rng, -1, 1), S(rng, -1, 1), S(rng, -1, 1)));
      }
      tri_scale.push_back(scale);
    }
    s.shapes.push_back(sh);
    // A grid of 6 x 6 quads with shared vertices, randomly oriented, 1.2 scale wide.
    Shape g;
    g.kind = Shape::Kind::Triangles;
    g.material = 0;
    const glm::vec3 n = uniform_dir(rng);
    glm::dvec3 a, b;
    perp(glm::dvec3(n), a, b);
    const glm::vec3 ex = float(0.2 * scale) * glm::vec3(a), ey = float(0.2 * scale) * glm::vec3(b);
    const glm::vec3 go = offset + scale * glm::vec3(S(rng, -1, 1), S(rng, -1, 1), S(rng, -1, 1));
    for (int j = 0; j <= 6; ++j)
      for (int i = 0; i <= 6; ++i) g.mesh.P.push_back(go + float(i) * ex + float(j) * ey);
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 6; ++i) {
        const unsigned v = unsigned(j * 7 + i);
        g.mesh.indices.insert(g.mesh.indices.end(), {v, v + 1, v + 8, v, v + 8, v + 7});
        tri_scale.push_back(scale);
        tri_scale.push_back(scale);
      }
    s.shapes.push_back(g);
    rs.grids.push_back({go, ex, ey, scale});
    for (int i = 0; i < 40; ++i) {
      Shape sp;
      sp.kind = Shape::Kind::Sphere;
      sp.material = 0;
      sp.radius = scale * (0.02f + 0.2f * U(rng));
      sp.world_from_object = glm::translate(
          glm::mat4(1.0f), offset + scale * glm::vec3(S(rng, -1, 1), S(rng, -1, 1), S(rng, -1, 1)));
      if (i % 8 == 0) sp.reverse_orientation = true;
      s.shapes.push_back(sp);
      rs.sphere_scale.push_back(scale);
    }
  }
  rs.t = build_tables(s);
  SceneTables& t = rs.t;
  EXPECT_EQ(t.triangles.size(), tri_scale.size());
  // Degenerate triangles planted after the build (the builder drops them), as
  // robustness_test.cpp DegenerateTrianglesAreSkipped: every 25th random (unshared) triangle
  // gets a repeated vertex, a collinear vertex (the midpoint of an edge) or all three equal.
  // The new vertices lie in the old triangle's bounds, so the BVH still covers them.
  std::vector<int> uses(t.vertices.size(), 0);
  for (const gpu::Triangle& tr : t.triangles) ++uses[tr.v0], ++uses[tr.v1], ++uses[tr.v2];
  for (std::uint32_t i = 0; i < t.triangles.size(); ++i) {
    const gpu::Triangle& tr = t.triangles[i];
    const bool shared = uses[tr.v0] > 1 || uses[tr.v1] > 1 || uses[tr.v2] > 1;
    if (!shared && i % 25 == 3) {
      glm::vec4& p2 = t.vertices[tr.v2].p_u;
      const glm::vec4 p0 = t.vertices[tr.v0].p_u, p1 = t.vertices[tr.v1].p_u;
      switch ((i / 25) % 3) {
        case 0: p2 = p0; break;
        case 1: p2 = glm::vec4(0.5f * (glm::vec3(p0) + glm::vec3(p1)), p2.w); break;
        default: p2 = p0; t.vertices[tr.v1].p_u = p0; break;
      }
      rs.degenerate.push_back(i);
    } else {
      rs.tris.push_back({i, tri_scale[i]});
    }
  }
  t.cpu_wide = cpu::build_cpu_wide_bvh(t);  // the CPU reference's copy of the corners
  rs.exactly_degenerate.assign(t.triangles.size(), 0);
  for (std::uint32_t i = 0; i < t.triangles.size(); ++i) {
    const gpu::Triangle& tr = t.triangles[i];
    const glm::vec3 p0(t.vertices[tr.v0].p_u), p1(t.vertices[tr.v1].p_u), p2(t.vertices[tr.v2].p_u);
    const glm::vec3 c = glm::cross(p0 - p2, p1 - p2);
    rs.exactly_degenerate[i] = c.x == 0.0f && c.y == 0.0f && c.z == 0.0f;
  }
  return rs;
}

/// A point on a primitive with its geometric normal (path-spec 4) and magnitude bound m
/// (path-spec 5), as the renderers compute them (float, no contraction).
struct SurfaceSample {
  std::uint32_t prim;  // probe prim (sphere bit set for spheres)
  glm::vec3 p, ng;
  float m;
  float scale;  // cluster scale
  float radius = 0.0f;
  glm::vec3 center{0.0f};
};

glm::vec3 safe_normalize(glm::vec3 v) {
  const float l2 = glm::dot(v, v);
  return l2 > 0.0f ? v / std::sqrt(l2) : glm::vec3(0.0f);
}

/// A point on a random non-degenerate triangle (barycentrics from the hard set: vertices,
/// edges, 1e-7 from an edge, or uniform) or a random sphere (poles one time in four).
SurfaceSample surface_sample(const RayScene& rs, Rng& r, bool sphere) {
  const SceneTables& t = rs.t;
  SurfaceSample s;
  if (!sphere) {
    const RayScene::Tri& tri = rs.tris[std::size_t(pick(r, int(rs.tris.size())))];
    const gpu::Triangle& tr = t.triangles[tri.index];
    const glm::vec3 p0(t.vertices[tr.v0].p_u), p1(t.vertices[tr.v1].p_u), p2(t.vertices[tr.v2].p_u);
    float b1 = U(r), b2 = U(r);
    switch (pick(r, 8)) {
      case 0: b1 = 0.0f; break;                        // on an edge
      case 1: b1 = 1e-7f; break;                       // next to an edge
      case 2: b1 = float(pick(r, 2)); b2 = 0.0f; break;  // a vertex
      case 3: b2 = 1.0f - b1; break;                   // the third edge
      default: break;
    }
    if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
    const float b0 = 1.0f - b1 - b2;
    s.prim = tri.index;
    s.p = b0 * p0 + b1 * p1 + b2 * p2;
    s.ng = safe_normalize(glm::cross(p0 - p2, p1 - p2));
    const glm::vec3 mm = glm::abs(b0 * p0) + glm::abs(b1 * p1) + glm::abs(b2 * p2);
    s.m = std::max(mm.x, std::max(mm.y, mm.z));
    s.scale = tri.scale;
    return s;
  }
  const std::uint32_t k = std::uint32_t(pick(r, int(t.spheres.size())));
  const gpu::Sphere& sp = t.spheres[k];
  const glm::vec3 c(sp.center_radius);
  const float rad = sp.center_radius.w;
  glm::vec3 n = uniform_dir(r);
  if (chance(r, 0.25)) n = (chance(r, 0.5) ? 1.0f : -1.0f) * glm::vec3(sp.axis_z);  // a pole
  s.prim = gpu::PRIM_SPHERE_BIT | k;
  s.p = c + rad * n;
  s.ng = n;
  s.m = std::max(std::fabs(c.x), std::max(std::fabs(c.y), std::fabs(c.z))) + rad;
  s.scale = rs.sphere_scale[k];
  s.radius = rad;
  s.center = c;
  return s;
}

/// path-spec 5: offset_ray(p, n, m) = p + (m 2^-17) n.
glm::vec3 offset_ray(glm::vec3 p, glm::vec3 n, float m) {
  const float k = m * 0x1p-17f;
  return p + k * n;
}

/// The magnitude applied to a ray direction: 1, or 10^[-15, 15]. Precondition (path-spec 3 says
/// any non-zero d): |d|^2 must be a normal float, or the sphere test's a = dot(d, d) loses its
/// bits (|d| near 1e-19: both sides then report phantom hits of the sphere a ray starts on);
/// the renderers pass unit directions and scene-sized shadow-ray directions.
float dir_scale(Rng& r) { return chance(r, 0.7) ? 1.0f : log10_uniform(r, -15.0f, 15.0f); }

/// tMax: FLT_MAX mostly; its neighbour below, 0, a denormal, or a random fraction of \p dist.
float hard_tmax(Rng& r, float t_target) {
  const int k = pick(r, 40);
  if (k == 0) return std::nextafter(FLT_MAX, 0.0f);
  if (k == 1) return 0.0f;
  if (k == 2) return kDenormMin;
  if (k < 6 && std::isfinite(t_target)) return t_target * S(r, 0.5f, 1.5f);
  return FLT_MAX;
}

/// One ray of the CLOSEST / OCCLUDED generators, and what its checks need to know.
struct RayCase {
  ProbeIn q;
  // Spawned: leaves a surface (never to come back to its plane); Shadow: a shadow ray from a
  // surface to a point of another primitive, which may lie in the same plane (a neighbouring
  // triangle of a grid), so that the segment meets that plane again at its end.
  enum Kind { Ordinary, Spawned, Shadow, Leak } kind = Ordinary;
  SurfaceSample from;  // Spawned: the surface the ray leaves
};

/// A direction with components exactly 0 or denormal: an axis, or an axis with denormal
/// neighbours (the slab test's 1e-20 substitution).
glm::vec3 axis_dir(Rng& r) {
  glm::vec3 d(0.0f);
  const int a = pick(r, 3);
  d[a] = chance(r, 0.5) ? 1.0f : -1.0f;
  if (chance(r, 0.5)) d[(a + 1) % 3] = rsign(r, chance(r, 0.5) ? kDenorm : kDenormMin);
  if (chance(r, 0.3)) d[(a + 2) % 3] = rsign(r, 1e-30f);
  return d;
}

/// Preconditions respected (path-spec 3): d != 0 (any magnitude), o finite, tMax >= 0 finite.
RayCase ray_case(const RayScene& rs, Rng& r, std::uint32_t op) {
  RayCase c;
  c.q = ProbeIn{};
  c.q.key = glm::uvec4(op, 0u, 0u, 0u);
  const int k = pick(r, 100);
  if (k < 25) {
    // Spawned from a surface as path-spec 5 does, leaving at a hard angle (grazing, exactly
    // tangent, or any): must never re-hit its own primitive near the origin.
    c.kind = RayCase::Spawned;
    c.from = surface_sample(rs, r, chance(r, 0.3));
    const double cs = hard_cos_abs(r) * (chance(r, 0.5) ? 1.0 : -1.0);
    const glm::vec3 wi = dir_at_cos(r, c.from.ng, cs);
    const glm::vec3 n = glm::dot(wi, c.from.ng) > 0.0f ? c.from.ng : -c.from.ng;
    const glm::vec3 o = offset_ray(c.from.p, n, c.from.m);
    c.q.o_tmax = glm::vec4(o, chance(r, 0.95) ? FLT_MAX : log10_uniform(r, -3, 1) * c.from.scale);
    c.q.d = glm::vec4(wi * dir_scale(r), 0.0f);
    return c;
  }
  if (k < 32) {
    // At a grid's interior edge or vertex from a moderate distance and angle: a closed grid
    // is watertight, the ray must hit (robustness_test.cpp ClosedMeshIsWatertight).
    c.kind = RayCase::Leak;
    const RayScene::Grid& g = rs.grids[std::size_t(pick(r, int(rs.grids.size())))];
    const float i = float(1 + pick(r, 5)), j = float(1 + pick(r, 5));
    glm::vec3 target = g.origin + i * g.ex + j * g.ey;  // a vertex
    const int e = pick(r, 3);                            // or a point of an edge from it
    const float f = chance(r, 0.5) ? 0.5f : U(r);
    if (e == 1) target += f * g.ex;
    if (e == 2) target += f * (g.ex + g.ey);
    const glm::vec3 n = glm::normalize(glm::cross(g.ex, g.ey));
    const glm::vec3 w = dir_at_cos(r, chance(r, 0.5) ? n : -n, S(r, 0.1f, 1.0f));
    const glm::vec3 o = target + g.scale * log10_uniform(r, -2, 1) * w;
    c.q.o_tmax = glm::vec4(o, FLT_MAX);
    c.q.d = glm::vec4(safe_normalize(target - o) * dir_scale(r), 0.0f);
    return c;
  }
  if (k < 37) {
    // Random rays through the scene's bounds.
    const float scale = rs.scales[std::size_t(pick(r, int(rs.scales.size())))];
    const glm::vec3 o = scale * glm::vec3(S(r, -4, 10), S(r, -8, 4), S(r, -4, 12));
    c.q.o_tmax = glm::vec4(o, hard_tmax(r, INFINITY));
    c.q.d = glm::vec4(uniform_dir(r) * dir_scale(r), 0.0f);
    return c;
  }
  // At a point of a primitive (sphere poles included) from a distance: ordinary, grazing (at a
  // hard cosine to the surface, exactly 0 included), along an axis (zero and denormal
  // components), or from very far (up to 1e20).
  const SurfaceSample s = surface_sample(rs, r, chance(r, 0.35));
  glm::vec3 w;
  const int how = pick(r, 10);
  if (how < 4) w = uniform_dir(r);
  else if (how < 7) w = dir_at_cos(r, s.ng, hard_cos_abs(r) * (chance(r, 0.5) ? 1.0 : -1.0));
  else w = -axis_dir(r);
  const float dist = s.scale * (how == 9 ? log10_uniform(r, 0, 20) : 4.0f * log10_uniform(r, -3, 0.5f));
  const glm::vec3 o = s.p + dist * w;
  // The direction: the axis itself, the raw difference (a shadow ray's target - o, at least
  // 4e-7 long here), or the unit direction at a dir_scale magnitude.
  glm::vec3 d = -w * dir_scale(r);
  if (how < 7 || how == 9) {
    const glm::vec3 raw = s.p - o;
    const float len = glm::length(raw);
    if (chance(r, 0.5) && len > 1e-15f && len < 1e15f) d = raw;
    else if (len > 0.0f) d = safe_normalize(raw) * dir_scale(r);
  }
  c.q.o_tmax = glm::vec4(o, hard_tmax(r, glm::length(s.p - o) / glm::length(d)));
  c.q.d = glm::vec4(d, 0.0f);
  return c;
}

/// Self-intersection of a ray spawned from \p from answered with prim \p prim at t (the rules
/// of robustness_test.cpp NoSelfIntersectionAtAnyScale): its own triangle at any t; its own
/// sphere when it left outwards (chord < -1e-3 r), or left inwards and came back before half
/// the chord; near-tangent directions are not judged.
bool self_hit(const SurfaceSample& from, const ProbeIn& q, std::uint32_t prim, float t,
              glm::vec3 wi) {
  if (prim != from.prim) return false;
  if (!(prim & gpu::PRIM_SPHERE_BIT)) return true;
  const float chord = -2.0f * from.radius * glm::dot(wi, from.ng) / glm::length(wi);
  if (chord < -1e-3f * from.radius) return true;
  return chord > 1e-3f * from.radius && t * glm::length(glm::vec3(q.d)) < 0.5f * chord;
}

/// Distance in units of the tolerance (1e-4 relative or 1e-6 absolute, bsdf::close) between two
/// hit records (t, b1, b2): infinite when the primitives differ.
float hit_diff(std::uint32_t pa, glm::vec4 a, std::uint32_t pb, glm::vec4 b) {
  if (pa != pb) return INFINITY;
  if (pa == gpu::INVALID_INDEX) return 0.0f;
  float d = 0.0f;
  for (int k = 0; k < 3; ++k) {
    if (a[k] == b[k]) continue;
    const float tol = std::max(1e-4f * std::max(std::fabs(a[k]), std::fabs(b[k])), 1e-6f);
    d = std::max(d, std::fabs(a[k] - b[k]) / tol);
  }
  return std::isnan(d) ? INFINITY : d;
}

/// The hit-record checks of CLOSEST (and of each ray of RESPAWN) on one side: finite t, b1, b2;
/// a hit has 0 < t < tMax and b1, b2 >= 0 (triangles; a sphere reports 0, 0); a miss t = -1.
/// Returns 0 ok, 1 non-finite, 2 negative, 3 beyond tMax.
int hit_check(glm::vec4 f, std::uint32_t prim, float tmax) {
  if (!finite3(f)) return 1;
  if (prim == gpu::INVALID_INDEX) return f.x == -1.0f ? 0 : 2;
  if (!(f.x > 0.0f) || f.y < 0.0f || f.z < 0.0f) return 2;
  if (!(f.x < tmax)) return 3;
  return 0;
}

/// True if the ray of \p q hits an exactly degenerate triangle (path-spec 3: it must miss).
bool degenerate_hit(const RayScene& rs, std::uint32_t prim) {
  return prim != gpu::INVALID_INDEX && !(prim & gpu::PRIM_SPHERE_BIT) &&
         prim < rs.exactly_degenerate.size() && rs.exactly_degenerate[prim];
}

/// The origin-nudge excusal (the rule of texture_probe_test.cpp and envmap_gpu_test.cpp
/// applied to the ray's origin, the precision to which a spawned origin is known): a mismatch
/// is excused when moving the origin by 1 to 16 ulps of its largest coordinate changes the
/// CPU's own answer by at least half as much. \p diff measures two answers in tolerance units.
/// Inputs whose two sides disagree, with the CPU's answer, by how much, and their batch index.
struct Suspects {
  std::vector<ProbeIn> q;
  std::vector<ProbeOut> cpu;
  std::vector<float> amount;
  std::vector<std::size_t> index;
  /// \brief Records input \p i of the batch.
  void add(const ProbeIn& in, const ProbeOut& c, float d, std::size_t i) {
    q.push_back(in), cpu.push_back(c), amount.push_back(d), index.push_back(i);
  }
};

/// Moves a query's ray origin by k ulps (the ray probes' nudge).
ProbeIn origin_nudge(ProbeIn q, int k) {
  q.o_tmax = glm::vec4(nudge_point(glm::vec3(q.o_tmax), k), q.o_tmax.w);
  return q;
}

/// For each suspect: true if nudging its input (by 1..16 ulps, \p nudge) moves the CPU's own
/// answer by at least half the GPU/CPU difference (an ill-conditioned input, excused).
std::vector<bool> nudge_excusal(const SceneTables& t, const Suspects& s,
                                const std::function<ProbeIn(ProbeIn, int)>& nudge,
                                const std::function<float(const ProbeOut&, const ProbeOut&)>& diff) {
  std::vector<bool> ok(s.q.size(), false);
  if (s.q.empty()) return ok;
  std::vector<ProbeIn> near;
  for (const ProbeIn& q : s.q)
    for (int k : kNudges) near.push_back(nudge(q, k));
  const std::vector<ProbeOut> c2 = probe_cpu_threads(t, near, 2);
  for (std::size_t j = 0; j < s.q.size(); ++j) {
    float spread = 0.0f;
    for (std::size_t k = 0; k < 10; ++k) spread = std::max(spread, diff(c2[j * 10 + k], s.cpu[j]));
    ok[j] = spread >= 0.5f * s.amount[j];
  }
  return ok;
}

/// Counts each suspect as excused or as a mismatch (reported with \p note of its input).
void settle(Stress& st, const Suspects& s, const std::vector<bool>& ok, const Answers& a,
            const std::function<std::string(const ProbeIn&)>& note = {}) {
  for (std::size_t j = 0; j < s.q.size(); ++j) {
    if (ok[j]) {
      ++st.excused;
      continue;
    }
    ++st.mismatches;
    const std::size_t i = s.index[j];
    st.offend("mismatch", s.q[j], &a.cpu[i], &a.gpu[i], note ? note(s.q[j]) : std::string());
  }
}

TEST(Stress, Closest) {
  const std::size_t n = stress_n();
  Stress st("Closest");
  const RayScene rs = make_ray_scene();
  auto runner_ptr = make_runner(rs.t);
  ProbeRunner& runner = *runner_ptr;
  Rng rng(0xC105E57);
  auto diff = [](const ProbeOut& a, const ProbeOut& b) { return hit_diff(a.u.x, a.f0, b.u.x, b.f0); };
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(kBatch, n - done);
    std::vector<RayCase> cases(k);
    std::vector<ProbeIn> q(k);
    for (std::size_t i = 0; i < k; ++i) q[i] = (cases[i] = ray_case(rs, rng, gpu::PROBE_CLOSEST)).q;
    const Answers a = run_both(runner, rs.t, q);
    Suspects sus;
    for (std::size_t i = 0; i < k; ++i) {
      const ProbeOut* o[2] = {&a.cpu[i], &a.gpu[i]};
      for (int side = 0; side < 2; ++side) {
        const int h = hit_check(o[side]->f0, o[side]->u.x, q[i].o_tmax.w);
        if (h == 1) st.count_nonfinite(side, q[i], a.cpu[i], a.gpu[i]);
        if (h == 2) st.count_negative(side, q[i], a.cpu[i], a.gpu[i]);
        if (h == 3) st.count_detail(side ? "hits beyond tMax gpu" : "hits beyond tMax cpu", q[i], o[0], o[1]);
        if (degenerate_hit(rs, o[side]->u.x))
          st.count_detail(side ? "degenerate triangle hit gpu" : "degenerate triangle hit cpu", q[i], o[0], o[1]);
        if (cases[i].kind == RayCase::Spawned &&
            self_hit(cases[i].from, q[i], o[side]->u.x, o[side]->f0.x, glm::vec3(q[i].d)))
          st.count_self(side, q[i], a.cpu[i], a.gpu[i]);
        if (cases[i].kind == RayCase::Leak && o[side]->u.x == gpu::INVALID_INDEX)
          st.count_detail(side ? "leaks through a closed grid gpu" : "leaks through a closed grid cpu",
                          q[i], o[0], o[1]);
      }
      const float d = diff(a.cpu[i], a.gpu[i]);
      if (d > 1.0f) {
        sus.add(q[i], a.cpu[i], d, i);
      }
    }
    const std::vector<bool> ok = nudge_excusal(rs.t, sus, origin_nudge, diff);
    settle(st, sus, ok, a);
    st.inputs += k;
    done += k;
  }
  st.finish(0.005, "origin nudge of 1..16 ulps moves the CPU's own answer as much");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}


/// A shadow ray of path-spec 5 between two surface points: from offset_ray(a) towards b (for an
/// area light the target is offset_ray(b) towards the origin), tMax = 1 - 1e-4.
RayCase shadow_case(const RayScene& rs, Rng& r, std::uint32_t op) {
  RayCase c;
  c.q = ProbeIn{};
  c.q.key = glm::uvec4(op, 0u, 0u, 0u);
  c.kind = RayCase::Shadow;
  c.from = surface_sample(rs, r, chance(r, 0.3));
  SurfaceSample b = surface_sample(rs, r, chance(r, 0.3));
  // A point of another primitive: a shadow ray to a point of its own plane legitimately meets
  // that plane again at its end.
  while (b.prim == c.from.prim) b = surface_sample(rs, r, chance(r, 0.3));
  const glm::vec3 to_b = b.p - c.from.p;
  const glm::vec3 o =
      offset_ray(c.from.p, glm::dot(to_b, c.from.ng) > 0.0f ? c.from.ng : -c.from.ng, c.from.m);
  glm::vec3 target = b.p;
  if (chance(r, 0.5)) target = offset_ray(b.p, glm::dot(o - b.p, b.ng) > 0.0f ? b.ng : -b.ng, b.m);
  c.q.o_tmax = glm::vec4(o, 1.0f - 1e-4f);
  c.q.d = glm::vec4(target - o, 0.0f);
  if (!(glm::dot(target - o, target - o) > 1e-30f)) c.q.d = glm::vec4(c.from.ng, 0.0f);
  return c;
}

TEST(Stress, Occluded) {
  // Each input is an OCCLUDED query and a CLOSEST query of the same ray (its companion): on each
  // side, occluded must equal "the closest hit exists" (path-spec 3: any hit in (0, tMax)), and
  // a ray spawned from a surface must not be occluded by its own primitive (the companion's hit
  // judged by the CLOSEST rule). Outputs: u.x in {0, 1} (no float outputs: nothing can be
  // non-finite or negative). GPU == CPU exactly, excused by the origin nudge (bounded).
  const std::size_t n = stress_n();
  Stress st("Occluded");
  const RayScene rs = make_ray_scene();
  auto runner_ptr = make_runner(rs.t);
  ProbeRunner& runner = *runner_ptr;
  Rng rng(0x0CC1DED);
  auto diff = [](const ProbeOut& a, const ProbeOut& b) { return a.u.x != b.u.x ? INFINITY : 0.0f; };
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(kBatch / 2, n - done);
    std::vector<RayCase> cases(k);
    std::vector<ProbeIn> q(2 * k);
    for (std::size_t i = 0; i < k; ++i) {
      cases[i] = chance(rng, 0.3) ? shadow_case(rs, rng, gpu::PROBE_OCCLUDED)
                                  : ray_case(rs, rng, gpu::PROBE_OCCLUDED);
      q[2 * i] = q[2 * i + 1] = cases[i].q;
      q[2 * i + 1].key.x = gpu::PROBE_CLOSEST;
    }
    const Answers a = run_both(runner, rs.t, q);
    Suspects sus;
    for (std::size_t i = 0; i < k; ++i) {
      const ProbeIn& qi = q[2 * i];
      const ProbeOut* occ[2] = {&a.cpu[2 * i], &a.gpu[2 * i]};
      const ProbeOut* hit[2] = {&a.cpu[2 * i + 1], &a.gpu[2 * i + 1]};
      for (int side = 0; side < 2; ++side) {
        const std::string sn = side ? " gpu" : " cpu";
        if (occ[side]->u.x > 1u) st.count_detail("occluded not 0 or 1" + sn, qi, occ[0], occ[1]);
        if ((occ[side]->u.x == 1u) != (hit[side]->u.x != gpu::INVALID_INDEX))
          st.count_detail("occluded disagrees with the closest hit" + sn, qi, hit[0], hit[1]);
        // A shadow ray's own primitive counts near its origin only (t < 1/2): a coplanar target
        // (another triangle of a grid) brings the segment back to the origin's plane at t ~ 1,
        // possibly on the origin's own triangle next to the target.
        const bool judged = cases[i].kind == RayCase::Spawned ||
                            (cases[i].kind == RayCase::Shadow && hit[side]->f0.x < 0.5f);
        if (judged && occ[side]->u.x == 1u &&
            self_hit(cases[i].from, qi, hit[side]->u.x, hit[side]->f0.x, glm::vec3(qi.d)))
          st.count_self(side, qi, *hit[0], *hit[1]);
        if (cases[i].kind == RayCase::Leak && occ[side]->u.x != 1u)
          st.count_detail("leaks through a closed grid" + sn, qi, occ[0], occ[1]);
      }
      if (occ[0]->u.x != occ[1]->u.x) {
        sus.add(qi, *occ[0], INFINITY, 2 * i);
      }
    }
    const std::vector<bool> ok = nudge_excusal(rs.t, sus, origin_nudge, diff);
    settle(st, sus, ok, a);
    st.inputs += k;
    done += k;
  }
  st.finish(0.005, "origin nudge of 1..16 ulps flips the CPU's own answer");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}

TEST(Stress, Respawn) {
  // RESPAWN (layout.h): the first hit as CLOSEST, then the ray spawned from that hit's surface
  // point (path-spec 5) in the continuation direction extra.xyz: unit, at a hard cosine to the
  // target's normal (exactly tangent, 1e-7 .. 1e-3, either side), uniform, or an axis with zero
  // and denormal components (precondition: extra != 0). Both hit records are checked as CLOSEST's;
  // the second ray never re-hits its own primitive near its origin (robustness_test.cpp
  // NoSelfIntersectionAtAnyScale: the same triangle at any t; the same sphere only as the far
  // side of the chord when it left inwards). GPU == CPU: both prims equal, t, b1, b2 within
  // 1e-4 relative / 1e-6 absolute; excusal by the origin nudge (bounded).
  const std::size_t n = stress_n();
  Stress st("Respawn");
  const RayScene rs = make_ray_scene();
  auto runner_ptr = make_runner(rs.t);
  ProbeRunner& runner = *runner_ptr;
  Rng rng(0x4E5BA3);
  auto diff = [](const ProbeOut& a, const ProbeOut& b) {
    return std::max(hit_diff(a.u.x, a.f0, b.u.x, b.f0), hit_diff(a.u.y, a.f1, b.u.y, b.f1));
  };
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(kBatch, n - done);
    std::vector<ProbeIn> q(k);
    std::vector<glm::vec3> target_n(k);
    for (std::size_t i = 0; i < k; ++i) {
      const SurfaceSample s = surface_sample(rs, rng, chance(rng, 0.35));
      const glm::vec3 w = chance(rng, 0.5) ? uniform_dir(rng) : dir_at_cos(rng, s.ng, S(rng, 0.05f, 1.0f));
      const glm::vec3 o = s.p + s.scale * 4.0f * log10_uniform(rng, -3, 0.5f) * w;
      glm::vec3 d = safe_normalize(s.p - o) * dir_scale(rng);
      if (chance(rng, 0.1)) d = s.p - o;  // raw, at least 4e-7 long
      glm::vec3 wi;
      const int how = pick(rng, 10);
      if (how < 6) wi = dir_at_cos(rng, s.ng, hard_cos_abs(rng) * (chance(rng, 0.5) ? 1.0 : -1.0));
      else if (how < 8) wi = uniform_dir(rng);
      else wi = axis_dir(rng);
      if (chance(rng, 0.1)) wi *= dir_scale(rng);
      q[i] = ProbeIn{};
      q[i].key = glm::uvec4(gpu::PROBE_RESPAWN, 0u, 0u, 0u);
      q[i].o_tmax = glm::vec4(o, FLT_MAX);
      q[i].d = glm::vec4(d, 0.0f);
      q[i].extra = glm::vec4(wi, 0.0f);
    }
    const Answers a = run_both(runner, rs.t, q);
    Suspects sus;
    for (std::size_t i = 0; i < k; ++i) {
      const ProbeOut* o[2] = {&a.cpu[i], &a.gpu[i]};
      for (int side = 0; side < 2; ++side) {
        const std::string sn = side ? " gpu" : " cpu";
        const int h1 = hit_check(o[side]->f0, o[side]->u.x, q[i].o_tmax.w);
        const int h2 = hit_check(o[side]->f1, o[side]->u.y, FLT_MAX);
        if (h1 == 1 || h2 == 1) st.count_nonfinite(side, q[i], a.cpu[i], a.gpu[i]);
        if (h1 == 2 || h2 == 2) st.count_negative(side, q[i], a.cpu[i], a.gpu[i]);
        if (h1 == 3 || h2 == 3) st.count_detail("hits beyond tMax" + sn, q[i], o[0], o[1]);
        if (degenerate_hit(rs, o[side]->u.x) || degenerate_hit(rs, o[side]->u.y))
          st.count_detail("degenerate triangle hit" + sn, q[i], o[0], o[1]);
        if (o[side]->u.x == gpu::INVALID_INDEX || o[side]->u.y != o[side]->u.x) continue;
        if (!(o[side]->u.x & gpu::PRIM_SPHERE_BIT)) {
          st.count_self(side, q[i], a.cpu[i], a.gpu[i]);
          continue;
        }
        const glm::vec4 cr = rs.t.spheres[o[side]->u.x & gpu::PRIM_INDEX_MASK].center_radius;
        const glm::vec3 hit = glm::vec3(q[i].o_tmax) + o[side]->f0.x * glm::vec3(q[i].d);
        const glm::vec3 nn = glm::normalize(hit - glm::vec3(cr));
        const glm::vec3 wi(q[i].extra);
        const float chord = -2.0f * cr.w * glm::dot(wi, nn) / glm::length(wi);
        if (chord < -1e-3f * cr.w ||
            (chord > 1e-3f * cr.w && o[side]->f1.x * glm::length(wi) < 0.5f * chord))
          st.count_self(side, q[i], a.cpu[i], a.gpu[i]);
      }
      const float d = diff(a.cpu[i], a.gpu[i]);
      if (d > 1.0f) {
        sus.add(q[i], a.cpu[i], d, i);
      }
    }
    const std::vector<bool> ok = nudge_excusal(rs.t, sus, origin_nudge, diff);
    settle(st, sus, ok, a);
    st.inputs += k;
    done += k;
  }
  st.finish(0.005, "origin nudge of 1..16 ulps moves the CPU's own answer as much");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}

// =============================================================================================
// RNG and SAMPLER: bit-identical on both sides (robustness_test.cpp RngIsBitIdentical,
// sampler_probe_test.cpp), values in [0, 1).
// =============================================================================================

/// A hard 32-bit key: 0, 1, 0xffffffff, 0x80000000, a small value, or any.
std::uint32_t hard_key(Rng& r) {
  switch (pick(r, 10)) {
    case 0: return 0u;
    case 1: return 1u;
    case 2: return 0xffffffffu;
    case 3: return 0x80000000u;
    case 4: return std::uint32_t(r() & 0xfffu);
    default: return std::uint32_t(r());
  }
}

/// Checks a value that must lie in [0, 1) and be identical on both sides (no excusal).
void check_unit_value(Stress& st, const ProbeIn& q, const ProbeOut& c, const ProbeOut& g) {
  const float v[2] = {c.f0.x, g.f0.x};
  for (int side = 0; side < 2; ++side) {
    if (!std::isfinite(v[side])) st.count_nonfinite(side, q, c, g);
    else if (v[side] < 0.0f) st.count_negative(side, q, c, g);
    else if (!(v[side] < 1.0f)) st.count_detail(side ? "value >= 1 gpu" : "value >= 1 cpu", q, &c, &g);
  }
  if (std::bit_cast<std::uint32_t>(c.f0.x) != std::bit_cast<std::uint32_t>(g.f0.x)) {
    ++st.mismatches;
    st.offend("mismatch", q, &c, &g);
  }
}

TEST(Stress, Rng) {
  // rng(px, py, sample, dim) with every argument any 32-bit value (hard ones: 0, 1, 2^31,
  // 2^32 - 1), and the scene seed (Globals.image.w) changed every batch among 0, 1, 2^32 - 1 and
  // random values (the probe reads it from Globals: one runner, set_globals per batch).
  const std::size_t n = stress_n();
  Stress st("Rng");
  Scene s;
  s.film.xres = s.film.yres = 8;
  SceneTables t = build_tables(s);
  auto runner_ptr = make_runner(t);
  ProbeRunner& runner = *runner_ptr;
  Rng rng(0x5EED);
  for (std::size_t done = 0, batch = 0; done < n; ++batch) {
    const std::size_t k = std::min(kBatch, n - done);
    const std::uint32_t seeds[4] = {0u, 1u, 0xffffffffu, std::uint32_t(rng())};
    set_seed(t, seeds[batch % 4]);
    runner.set_globals(t.globals);
    std::vector<ProbeIn> q(k);
    for (ProbeIn& e : q) {
      e = ProbeIn{};
      e.key = glm::uvec4(gpu::PROBE_RNG, hard_key(rng), hard_key(rng), hard_key(rng));
      e.extra.x = std::bit_cast<float>(hard_key(rng));
    }
    const Answers a = run_both(runner, t, q);
    for (std::size_t i = 0; i < k; ++i) check_unit_value(st, q[i], a.cpu[i], a.gpu[i]);
    st.inputs += k;
    done += k;
  }
  st.finish(0.0, "");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}

TEST(Stress, Sampler) {
  // sampler_get(px, py, s, d) of every sampler and randomisation of sampler_probe_test.cpp, at
  // 1 sample per pixel, at 24 (64 for zsobol, which rounds to a power of two) and at 256.
  // Preconditions (docs/sampler-spec.md, as that test): pixel inside the film, sample index
  // below the count the sampler was built for, dimension d <= 4 + 16 * 80 (bounces up to 80).
  // Hard arguments: the film's corners, samples 0 and count - 1, dimensions 0 .. 4 and the
  // first and last of a bounce's 16. One runner per sampler table (primes, sobol, pmj02bn);
  // the rest of a case is Globals (set_globals).
  const std::size_t n = stress_n();
  Stress st("Sampler");
  const SceneTables base = tables_from_string(lit_plane_scene());
  std::vector<std::pair<SamplerCase, int>> cases;
  for (const SamplerCase& c : sampler_cases())
    for (int spp : {1, 24, 256}) cases.push_back({c, std::string(c.type) == "zsobol" && spp == 24 ? 64 : spp});
  // Group by table so that each table's runner is built once.
  std::stable_sort(cases.begin(), cases.end(), [](const auto& a, const auto& b) {
    auto rank = [](const char* t) { return std::string(t) == "sobol" ? 1 : std::string(t) == "pmj02bn" ? 2 : 0; };
    return rank(a.first.type) < rank(b.first.type);
  });
  Rng rng(0x5A3D1E);
  std::unique_ptr<ProbeRunner> runner;
  std::vector<std::uint32_t> table;
  const std::size_t per_case = (n + cases.size() - 1) / cases.size();
  std::size_t done = 0;
  for (const auto& [c, spp] : cases) {
    SceneTables t = with_sampler(base, c, spp);
    set_seed(t, std::uint32_t(rng()));
    if (!runner || t.sampler_data != table) {
      runner.reset();
      runner = make_runner(t);
      table = t.sampler_data;
    }
    runner->set_globals(t.globals);
    const std::uint32_t count = t.globals.sampler_opts.x == gpu::SAMPLER_STRATIFIED
                                    ? t.globals.sampler_opts.z * t.globals.sampler_opts.w
                                    : t.globals.sampler_opts.z;
    const std::uint32_t w = t.width(), h = t.height(), dmax = 4 + 16 * 80;
    for (std::size_t left = std::min(per_case, n - done); left > 0;) {
      const std::size_t k = std::min(kBatch, left);
      std::vector<ProbeIn> q(k);
      for (ProbeIn& e : q) {
        e = ProbeIn{};
        const std::uint32_t px = chance(rng, 0.1) ? (chance(rng, 0.5) ? 0u : w - 1) : std::uint32_t(rng() % w);
        const std::uint32_t py = chance(rng, 0.1) ? (chance(rng, 0.5) ? 0u : h - 1) : std::uint32_t(rng() % h);
        const std::uint32_t sm = chance(rng, 0.1) ? (chance(rng, 0.5) ? 0u : count - 1)
                                                  : std::uint32_t(rng() % std::max(count, 1u));
        std::uint32_t d = std::uint32_t(rng() % (dmax + 1));
        if (chance(rng, 0.2)) d = std::uint32_t(rng() % 5);
        else if (chance(rng, 0.1)) d = 4 + 16 * std::uint32_t(rng() % 81) + (chance(rng, 0.5) ? 0u : 15u);
        d = std::min(d, dmax);
        e.key = glm::uvec4(gpu::PROBE_SAMPLER, px, py, sm);
        e.extra.x = std::bit_cast<float>(d);
      }
      const Answers a = run_both(*runner, t, q);
      for (std::size_t i = 0; i < k; ++i) check_unit_value(st, q[i], a.cpu[i], a.gpu[i]);
      st.inputs += k;
      done += k;
      left -= k;
    }
  }
  st.finish(0.0, "");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}

// =============================================================================================
// CAMERA and CAMERA_DIFF: the cameras of robustness_test.cpp (thin lens with a gaussian filter,
// a rotated and translated pinhole with a box filter) and wider ranges of the same settings
// (fov 0.5 .. 170 degrees, films from 1 x 1 to 4096 x 2160, lens radius up to 1); agreement
// within 1e-5 absolute per component (ProbeConformance.CameraRaysAgree and
// CameraDifferentialsAgree), no excusal.
// =============================================================================================

struct CameraConfig {
  const char* name;
  bool gaussian;
  Scene scene;
};

std::vector<CameraConfig> camera_configs() {
  std::vector<CameraConfig> v;
  auto base = [](int w, int h, float fov, bool gaussian) {
    Scene s;
    s.film.xres = w;
    s.film.yres = h;
    s.camera.fov_deg = fov;
    s.filter.type = gaussian ? Filter::Type::Gaussian : Filter::Type::Box;
    if (!gaussian) s.filter.radius = glm::vec2(0.5f);
    Material m;
    m.type = "diffuse";
    m.params["reflectance"] = MaterialParam{{0.5f, 0.5f, 0.5f}, "", {}};
    s.materials.push_back(m);
    return s;
  };
  const glm::mat4 pose = glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(1.0f, -2.0f, 3.0f)),
                                     0.7f, glm::normalize(glm::vec3(1.0f, 2.0f, -0.5f)));
  for (bool g : {true, false}) {
    CameraConfig a{"thin lens 64x48", g, base(64, 48, 50.0f, g)};
    a.scene.camera.lens_radius = 0.1f;
    a.scene.camera.focal_distance = 5.0f;
    v.push_back(a);
    CameraConfig b{"pinhole 64x48 posed", g, base(64, 48, 50.0f, g)};
    b.scene.camera.world_from_camera = pose;
    v.push_back(b);
    CameraConfig c{"thin lens wide 1x1", g, base(1, 1, 170.0f, g)};
    c.scene.camera.lens_radius = 1.0f;
    c.scene.camera.focal_distance = 0.5f;
    v.push_back(c);
    CameraConfig d{"pinhole narrow 4096x2160", g, base(4096, 2160, 0.5f, g)};
    d.scene.camera.world_from_camera = pose;
    v.push_back(d);
    CameraConfig e{"thin lens 7x3 posed", g, base(7, 3, 120.0f, g)};
    e.scene.camera.lens_radius = 0.3f;
    e.scene.camera.focal_distance = 1e3f;
    e.scene.camera.world_from_camera = pose;
    v.push_back(e);
  }
  return v;
}

/// CAMERA (\p diff false: origin f0, direction f1) or CAMERA_DIFF (\p diff: the rx and ry
/// directions f0, f1) over the camera configurations.
void camera_stress(const char* name, std::uint32_t op, std::uint64_t seed) {
  const std::size_t n = stress_n();
  const std::vector<CameraConfig> configs = camera_configs();
  Stress st(name);
  Rng rng(seed);
  const std::size_t per = (n + configs.size() - 1) / configs.size();
  std::size_t done = 0;
  std::unique_ptr<ProbeRunner> runner;
  bool runner_gaussian = false;
  for (const CameraConfig& cfg : configs) {
    const SceneTables t = build_tables(cfg.scene);
    // Settings that differ only in Globals share a runner (the filter table differs between
    // the gaussian and the box filter).
    if (!runner || runner_gaussian != cfg.gaussian) {
      runner.reset();
      runner = make_runner(t);
      runner_gaussian = cfg.gaussian;
    }
    runner->set_globals(t.globals);
    const std::uint32_t w = t.width(), h = t.height();
    for (std::size_t left = std::min(per, n - done); left > 0;) {
      const std::size_t k = std::min(kBatch, left);
      std::vector<ProbeIn> q(k);
      for (ProbeIn& e : q) {
        // Precondition: the pixel lies in the film (any sample index).
        e = ProbeIn{};
        const std::uint32_t px = chance(rng, 0.15) ? (chance(rng, 0.5) ? 0u : w - 1) : std::uint32_t(rng() % w);
        const std::uint32_t py = chance(rng, 0.15) ? (chance(rng, 0.5) ? 0u : h - 1) : std::uint32_t(rng() % h);
        e.key = glm::uvec4(op, px, py, hard_key(rng));
      }
      const Answers a = run_both(*runner, t, q);
      for (std::size_t i = 0; i < k; ++i) {
        const ProbeOut* o[2] = {&a.cpu[i], &a.gpu[i]};
        for (int side = 0; side < 2; ++side) {
          if (!finite3(o[side]->f0) || !finite3(o[side]->f1)) {
            st.count_nonfinite(side, q[i], a.cpu[i], a.gpu[i]);
            continue;
          }
          // Directions are unit (CameraDifferentialsAgree asserts 1e-6 on the CPU's; the
          // GPU's normalize is not correctly rounded, 1e-5 here for both).
          const float l1 = glm::length(glm::vec3(o[side]->f1));
          const float l0 = glm::length(glm::vec3(o[side]->f0));
          if (std::fabs(l1 - 1.0f) > 1e-5f || (op == gpu::PROBE_CAMERA_DIFF && std::fabs(l0 - 1.0f) > 1e-5f))
            st.count_detail(side ? "direction not unit gpu" : "direction not unit cpu", q[i], o[0], o[1],
                            cfg.name);
        }
        bool agree = true;
        for (int c = 0; c < 3; ++c)
          agree &= std::fabs(a.cpu[i].f0[c] - a.gpu[i].f0[c]) <= 1e-5f &&
                   std::fabs(a.cpu[i].f1[c] - a.gpu[i].f1[c]) <= 1e-5f;
        if (!agree) {
          ++st.mismatches;
          st.offend("mismatch", q[i], &a.cpu[i], &a.gpu[i], cfg.name);
        }
      }
      st.inputs += k;
      done += k;
      left -= k;
    }
  }
  st.finish(0.0, "");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}

TEST(Stress, Camera) { camera_stress("Camera", gpu::PROBE_CAMERA, 0xCA3E7A); }

TEST(Stress, CameraDiff) { camera_stress("CameraDiff", gpu::PROBE_CAMERA_DIFF, 0xCA3D1F); }


// =============================================================================================
// BSDF: random materials of every kind (bsdf_check.h add_random_material: roughness 0 or
// 1e-4 .. 1, eta 1 or 1.0001 .. 4, k up to 10, every remap mode, isotropic and anisotropic,
// layered with up to 10 bounces and 3 samples, measured, nested mixes) and the comparison rules
// of bsdf_probe_test.cpp check_agreement.
// =============================================================================================

/// A unit direction with cos theta \p c and azimuth \p phi (double, rounded).
glm::vec3 dir_cos_phi(double c, double phi) { return bsdf::dir(c, phi); }

/// Rotates unit \p w by a small random angle (log-uniform 1e-5 .. 0.3 rad, as
/// bsdf_probe_test.cpp jitter).
glm::vec3 jitter(glm::vec3 w, Rng& r) {
  const double a = std::exp(std::log(1e-5) + Ud(r) * (std::log(0.3) - std::log(1e-5)));
  const glm::dvec3 d(w);
  glm::dvec3 x = glm::dvec3(uniform_dir(r));
  x = x - d * glm::dot(x, d);
  if (glm::length(x) < 1e-6) return w;
  x = glm::normalize(x);
  return glm::vec3(glm::normalize(d * std::cos(a) + x * std::sin(a)));
}

/// A hard cos theta for local directions: the set of bsdf_check.h hard_cos (0, +-1e-7, +-1e-4,
/// +-1e-3, +-1, +-(1 - 1e-7), uniform) or log-uniform +-[1e-7, 1e-3].
double hard_cos_signed(Rng& r) {
  static const double values[] = {0.0, 1e-7, -1e-7, 1.0, -1.0, 1e-4, -1e-4, 1.0 - 1e-7,
                                  -(1.0 - 1e-7), 1e-3, -1e-3};
  const int i = pick(r, int(std::size(values)) + 4);
  if (i < int(std::size(values))) return values[i];
  if (i < int(std::size(values)) + 2) return (chance(r, 0.5) ? 1.0 : -1.0) * std::pow(10.0, -7.0 + 4.0 * Ud(r));
  return 2.0 * Ud(r) - 1.0;
}

/// One BSDF query over the hard ranges. Preconditions (docs/materials-spec.md 6): wo, wi and ng
/// unit local directions, ng in the upper hemisphere of the shading normal (+z) as the renderers
/// face-forward it, u in [0, 1); p (the mix hash's point) and the stream key any value.
bsdf::Query bsdf_query(Rng& r, std::uint32_t material, float eta) {
  bsdf::Query q;
  q.material = material;
  const int ko = pick(r, 20);
  const double phi = chance(r, 0.2) ? 0.0 : 2 * kPi * Ud(r);
  if (ko < 8) q.wo = uniform_dir(r);
  else if (ko < 18) q.wo = dir_cos_phi(hard_cos_signed(r), phi);
  else q.wo = ko == 18 ? glm::vec3(0.0f, 0.0f, chance(r, 0.5) ? 1.0f : -1.0f) : glm::vec3(1.0f, 0.0f, 0.0f);
  const int ki = pick(r, 40);
  if (ki < 10) q.wi = uniform_dir(r);
  else if (ki < 18) q.wi = jitter(glm::vec3(-q.wo.x, -q.wo.y, q.wo.z), r);
  else if (ki < 24) q.wi = jitter(refract_dir(q.wo, eta), r);
  else if (ki < 32) q.wi = dir_cos_phi(hard_cos_signed(r), 2 * kPi * Ud(r));
  else if (ki < 34) q.wi = glm::vec3(-q.wo.x, -q.wo.y, q.wo.z);  // exact mirror
  else if (ki < 36) q.wi = refract_dir(q.wo, eta);                // exact refraction
  else if (ki < 37) q.wi = q.wo;
  else if (ki < 38) q.wi = -q.wo;
  else q.wi = dir_cos_phi(0.0, 2 * kPi * Ud(r));                  // exactly tangent
  for (int c = 0; c < 3; ++c) q.u[c] = chance(r, 0.5) ? hard_u(r) : U(r);
  const int kn = pick(r, 20);
  if (kn == 0) q.ng = dir_cos_phi(std::pow(10.0, -2.0 * Ud(r)), 2 * kPi * Ud(r));  // tilted far
  else if (kn < 4) {
    const glm::dvec3 t(Ud(r) - 0.5, Ud(r) - 0.5, 1.0);
    q.ng = glm::vec3(glm::normalize(t * glm::dvec3(1.2, 1.2, 1.0)));
  }
  const int kp = pick(r, 10);
  if (kp < 7) q.p = glm::vec3(S(r, -5, 5), S(r, -5, 5), S(r, -5, 5));
  else if (kp == 7) q.p = glm::vec3(rsign(r, log10_uniform(r, 20, 30)), rsign(r, log10_uniform(r, 20, 30)), rsign(r, log10_uniform(r, 20, 30)));
  else if (kp == 8) q.p = glm::vec3(chance(r, 0.5) ? 0.0f : kDenorm, rsign(r, log10_uniform(r, -30, -20)), -0.0f);
  else q.p = glm::floor(glm::vec3(S(r, -100, 100), S(r, -100, 100), S(r, -100, 100)));
  q.px = chance(r, 0.5) ? std::uint32_t(r() & 0xffffu) : hard_key(r);
  q.py = chance(r, 0.5) ? std::uint32_t(r() & 0xffffu) : hard_key(r);
  return q;
}

/// The sanity of a BSDF answer, split as the summary counts it: 1 non-finite, 2 negative (f or a
/// pdf), 3 another violation of bsdf::sane (a sample with pdf 0, a non-unit sampled direction,
/// eta <= 0).
int bsdf_sanity(const bsdf::Result& r) {
  auto fin = [](glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  auto nonneg = [](glm::vec3 v) { return v.x >= 0 && v.y >= 0 && v.z >= 0; };
  if (!fin(r.f) || !std::isfinite(r.pdf) || !fin(r.sf) || !std::isfinite(r.spdf) || !fin(r.swi) ||
      !std::isfinite(r.seta) || !std::isfinite(r.pdf_at_sample))
    return 1;
  if (!nonneg(r.f) || !(r.pdf >= 0) || !nonneg(r.sf) || !(r.spdf >= 0) || !(r.pdf_at_sample >= 0))
    return 2;
  std::string why;
  return bsdf::sane(r, &why) ? 0 : 3;
}

/// The materials of Stress.Bsdf: 64 random materials of every kind (bsdf_check.h
/// add_random_material, seed 2077) and a measured table, so that a find replays by its index.
struct BsdfStressSet {
  glm::uvec3 dims{16, 8, 16};
  bsdf::MaterialSet set;
  struct Mat {
    std::uint32_t index, kind;
    float eta;
  };
  std::vector<Mat> mats;
  SceneTables t;
};

/// Builds the material set of Stress.Bsdf (the same every call).
BsdfStressSet bsdf_stress_set() {
  BsdfStressSet s;
  std::mt19937 mrng(2077);
  const std::uint32_t offset = s.set.add_table(bsdf::measured_table(s.dims));
  for (std::uint32_t kind : bsdf::random_kinds())
    for (int m = 0; m < 64; ++m) {
      const std::uint32_t idx = bsdf::add_random_material(s.set, kind, mrng, offset, s.dims);
      s.mats.push_back({idx, kind, material_eta(s.set.materials[idx])});
    }
  s.t = bsdf::make_tables(s.set.materials, s.set.measured);
  return s;
}

TEST(Stress, Bsdf) {
  // Outputs (layout.h PROBE_BSDF): eval f and pdf, the sample's f, pdf, wi, eta, the pdf at the
  // sampled wi: all finite, f and pdfs non-negative, and bsdf::sane (a sample has pdf > 0, a unit
  // direction and eta > 0). GPU == CPU by bsdf_check.h judge, the rules of bsdf_probe_test.cpp:
  // 1e-4 relative or 1e-6 absolute on every value (directions: 1e-4 of their length), flags,
  // lobe count and tags identical; excused with its rules and bounds: ill-conditioned, tangent
  // or direction-rounded (<= 0.5% of all queries), layered random walks that branch on a last
  // bit (<= 0.5% of the layered and mix queries); measured lookups near a bin boundary (that
  // test bounds them per kind; here <= 2% of the queries of materials with a measured BRDF).
  const std::size_t n = stress_n();
  Stress st("Bsdf");
  const BsdfStressSet S = bsdf_stress_set();
  auto runner_ptr = make_runner(S.t);
  ProbeRunner& runner = *runner_ptr;
  Rng rng(0xB5DF);
  std::map<std::uint32_t, u64> kind_queries, kind_samples;
  std::map<bsdf::Verdict, u64> verdicts;
  u64 measured_queries = 0, layered_queries = 0;
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(kBatch, n - done);
    // Runs of 64 queries (one workgroup) on one material: the shader's lanes then take the same
    // branches (lavapipe runs every branch any lane of a group takes).
    std::vector<bsdf::Query> qs(k);
    std::vector<std::uint32_t> kind(k);
    for (std::size_t i = 0; i < k; i += 64) {
      const BsdfStressSet::Mat& m = S.mats[std::size_t(pick(rng, int(S.mats.size())))];
      for (std::size_t j = i; j < std::min(k, i + 64); ++j) {
        qs[j] = bsdf_query(rng, m.index, m.eta);
        kind[j] = m.kind;
      }
    }
    std::vector<ProbeIn> in(k);
    for (std::size_t i = 0; i < k; ++i) in[i] = bsdf::to_probe(qs[i]);
    const Answers a = run_both(runner, S.t, in);
    std::vector<bsdf::Result> cpu(k), gpu(k);
    for (std::size_t i = 0; i < k; ++i) cpu[i] = bsdf::from_probe(a.cpu[i]), gpu[i] = bsdf::from_probe(a.gpu[i]);
    for (std::size_t i = 0; i < k; ++i) {
      ++kind_queries[kind[i]];
      kind_samples[kind[i]] += cpu[i].sampled();
      measured_queries += has_measured(S.set, qs[i].material);
      layered_queries += kind[i] == gpu::MATERIAL_COATED_DIFFUSE || kind[i] == gpu::MATERIAL_COATED_CONDUCTOR ||
                         kind[i] == gpu::MATERIAL_MIX || kind[i] == gpu::MATERIAL_MIX_WEIGHTED;
      const bsdf::Result* rr[2] = {&cpu[i], &gpu[i]};
      for (int side = 0; side < 2; ++side) {
        const int h = bsdf_sanity(*rr[side]);
        if (h == 1) st.count_nonfinite(side, in[i], a.cpu[i], a.gpu[i]);
        if (h == 2) st.count_negative(side, in[i], a.cpu[i], a.gpu[i]);
        if (h == 3) st.count_detail(side ? "insane sample gpu" : "insane sample cpu", in[i], &a.cpu[i], &a.gpu[i]);
      }
    }
    const bsdf::Judgement J = bsdf::judge(S.set, S.t, S.dims, qs, cpu, gpu);
    for (std::size_t i = 0; i < k; ++i) {
      ++verdicts[J.verdict[i]];
      if (J.verdict[i] != bsdf::Verdict::Mismatch) continue;
      ++st.mismatches;
      st.offend("mismatch", in[i], &a.cpu[i], &a.gpu[i],
                "field mask " + std::to_string(J.fields[i]) + ", ill-conditioned mask " +
                    std::to_string(J.ill[i]) + "; " + bsdf::describe(S.set.materials[qs[i].material]));
    }
    st.inputs += k;
    done += k;
  }
  const u64 excused_cond = verdicts[bsdf::Verdict::IllConditioned] + verdicts[bsdf::Verdict::Tangent],
            excused_dir = verdicts[bsdf::Verdict::OtherDirection],
            excused_measured = verdicts[bsdf::Verdict::MeasuredBin], stochastic = verdicts[bsdf::Verdict::RandomWalk];
  st.excused = excused_cond + excused_dir + excused_measured + stochastic;
  st.finish(-1.0, "");
  const double total = double(st.inputs);
  std::printf("  Bsdf: excused ill-conditioned %llu + same at the other side's direction %llu = %.3g of "
              "all queries (bound 0.005); layered random walk %llu = %.3g of %llu layered/mix queries "
              "(bound 0.005); measured bin %llu = %.3g of %llu measured queries (bound 0.02)\n",
              (unsigned long long)excused_cond, (unsigned long long)excused_dir,
              total ? double(excused_cond + excused_dir) / total : 0.0, (unsigned long long)stochastic,
              layered_queries ? double(stochastic) / double(layered_queries) : 0.0,
              (unsigned long long)layered_queries, (unsigned long long)excused_measured,
              measured_queries ? double(excused_measured) / double(measured_queries) : 0.0,
              (unsigned long long)measured_queries);
  EXPECT_LE(double(excused_cond + excused_dir), 0.005 * total);
  EXPECT_LE(double(stochastic), 0.005 * double(layered_queries));
  EXPECT_LE(double(excused_measured), 0.02 * double(measured_queries));
  for (const auto& [kd, q] : kind_queries)  // not vacuous: most queries of a kind sample
    EXPECT_GT(double(kind_samples[kd]), 0.2 * double(q)) << bsdf::type_name(kd) << ": few samples";
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}

/// A BSDF probe input printed by a stress run (hex floats, bit-exact): key.yzw, wo.xyz, wi.xyz,
/// u.xyz, ng.xyz, p, what it is, and whether its cause was fixed (then the sampled f, pdf,
/// direction and flags must agree, beyond what the excusal rules allow).
struct BsdfFind {
  std::uint32_t material, px, py;
  float wo[3], wi[3], u[3], ng[3], p[3];
  const char* why;
  bool fixed = true;
};

// Mismatches of Stress.Bsdf at 10^7 (2026-11-26), before their causes were fixed on both sides:
// the sum dot(wi, wm) + dot(wo, wm) / etap of a sampled rough transmission at eta within 2e-3
// of 1 kept a few bits (now from Snell's law, lobes refracted_half_denom), and FrComplex of an
// index-matched conductor (reflectance 0: eta 1, k 0) was 1e-14 of noise on one side and 0 on the
// other, so one side sampled and the other did not (now exactly 0, fresnel fr_complex). The
// rough conductor at wo.z = 1e-4 and the pdf at the sampled direction at eta near 1 (the half
// vector recomputed from a wi that nearly cancels wo) are ill-conditioned; the rules judge them
// (the verdicts once depended on the other queries of a batch: unstable_fields now seeds its
// perturbations from each query, and a sample value is explained by the direction when each
// value that differs, not every value, is what the CPU computes at the GPU's direction).
const BsdfFind kBsdfFinds[] = {
    {373, 37295u, 55415u, {0x1.84e2ccp-1f, -0x1.1ee0e8p-1f, -0x1.524de4p-2f},
     {-0x1.8e7716p-1f, -0x1.2f85b2p-1f, 0x1.a82564p-3f}, {0x1.8da772p-1f, 0x1.fffffep-2f, 0x1.fec318p-2f},
     {0, 0, 1}, {0x1.f137e8p+1f, -0x1.8a367ap+1f, 0x1.87e778p+0f}, "dielectric eta 1.0002 transmission"},
    {325, 2147483648u, 2147483648u, {0x1.7d6c62p-1f, 0x1.0fd356p-1f, 0x1.9d9f9cp-2f},
     {-0x1.8b1896p-1f, -0x1.ee3394p-2f, -0x1.a830b4p-2f}, {0x1.bb7f74p-1f, 0x1.448dfap-1f, 0x1.4b0e48p-1f},
     {0, 0, 1}, {-0x1.27dafp+2f, 0x1.283b44p+2f, -0x1.69a8cp-3f}, "anisotropic dielectric eta 1.0012"},
    {373, 241343986u, 49368, {0x1.d160dp-1f, 0x1.a3c3ecp-2f, 0x1.3787a8p-4f},
     {0x1.a904d4p-1f, 0x1.1c3898p-1f, -0x1.adb99ap-5f}, {0x1.1cc34p-6f, 0x1.621178p-2f, 0x0p+0f},
     {0, 0, 1}, {0x1.c89558p+1f, 0x1.04822p+0f, 0x1.de0ddp-1f}, "dielectric eta 1.0002 transmission"},
    {1293, 27180, 53733, {0x1.70b67ep-1f, -0x1.61f184p-1f, 0x1.e50216p-5f},
     {-0x1.5c1e0ap-1f, 0x1.600da6p-6f, -0x1.77486ep-1f}, {0x1.aebb9ep-1f, 0x1.c73848p-2f, 0x1.311b98p-3f},
     {0, 0, 1}, {-0x1.88p+5f, -0x1.38p+6f, 0x0p+0f}, "mix with a dielectric near eta 1"},
    {159, 46098, 45706, {-0x1.c14e44p-1f, -0x1.eafdcp-2f, 0x1.0624dep-10f},
     {0x1.236ceep-1f, 0x1.569e3ep-2f, -0x1.80895cp-1f}, {0x1.bd8574p-1f, 0x1.722738p-2f, 0x1.e6066p-4f},
     {0, 0, 1}, {0x1.09479p+2f, -0x1.348766p+1f, -0x1.cd63ep-1f}, "conductor of reflectance 0"},
    {132, 33554, 52409, {0x1.376336p-5f, 0x1.ffa144p-1f, 0x1.7c02aap-12f},
     {-0x1.16af74p-4f, -0x1.feb2a4p-1f, -0x1.5beddep-6f}, {0x1.26e082p-1f, 0x1.89d97ep-1f, 0x1.42976ap-1f},
     {0, 0, 1}, {0x1.16c2p-133f, -0x1.32917ep-85f, -0x0p+0f}, "conductor of reflectance 0"},
    {139, 2147483648u, 42196u, {0x1.9898e4p-1f, -0x1.34885p-1f, 0x1.a36e2ep-14f},
     {-0x1.85276cp-1f, 0x1.4b211ap-1f, -0x1.040946p-4f}, {0x1.fffffep-1f, 0x1.fffffep-1f, 0x1.59b068p-2f},
     {0, 0, 1}, {-0x1.ac5954p+1f, 0x1.46e3ep-2f, 0x1.42ef14p+1f}, "rough conductor, wo.z 1e-4 (ill-conditioned)", false},
    {351, 49140u, 900987896u, {-0x1.58e80ap-1f, -0x1.7a6564p-1f, 0x1.a36e2ep-14f},
     {0x1.59527p-1f, 0x1.78c2a6p-1f, -0x1.ecb8fep-5f}, {0x1.2ebbd4p-2f, 0x1.98cf94p-2f, 0x1.3cb12cp-1f},
     {0, 0, 1}, {0x0p+0f, 0x1.b4ea6ep-86f, -0x0p+0f}, "anisotropic dielectric eta 1.0017, wo.z 1e-4"},
    {351, 57875u, 1223617743u, {0x1.fa9374p-1f, 0x1.736a14p-4f, 0x1.d05dd6p-4f},
     {0x1.5939d6p-2f, -0x1.7dbb5p-2f, -0x1.baa09cp-1f}, {0x1.143becp-1f, 0x1.34482cp-2f, 0x1.2d0556p-1f},
     {0, 0, 1}, {0x1.08p+5f, -0x1.d8p+5f, 0x1.4cp+6f}, "anisotropic dielectric eta 1.0017"},
    {351, 37535u, 1084u, {-0x1.11246ep-2f, -0x1.76ebf4p-1f, 0x1.40d226p-1f},
     {-0x1.11246ep-2f, -0x1.76ebf4p-1f, 0x1.40d226p-1f}, {0x1.bc1a4ep-1f, 0x1.ca90a4p-2f, 0x1.649bb8p-1f},
     {0x1.f0e4e6p-2f, 0x1.2b04d4p-3f, 0x1.b9653p-1f}, {-0x1.2a2804p+2f, 0x1.2cd69cp+2f, 0x1.fb771p+1f},
     "anisotropic dielectric eta 1.0017, wi = wo, tilted ng"},
    {351, 53249u, 6897u, {0x0p+0f, 0x0p+0f, -0x1p+0f}, {-0x0p+0f, -0x0p+0f, 0x1p+0f},
     {0x1.e3fccp-2f, 0x1.f00e16p-1f, 0x1.5386dcp-1f}, {0, 0, 1}, {-0x1.6f9008p+1f, -0x1.6ae8p-7f, 0x1.2d6a1cp+1f},
     "anisotropic dielectric eta 1.0017 from inside at normal incidence"},
};

TEST(ProbeFinds, Bsdf) {
  // Each find of kBsdfFinds agrees on both sides or is excused by the rules of Stress.Bsdf; the
  // sample of a fixed one agrees outright.
  const BsdfStressSet S = bsdf_stress_set();
  std::vector<bsdf::Query> qs;
  std::vector<const char*> why;
  for (const BsdfFind& f : kBsdfFinds) {
    bsdf::Query q;
    q.material = f.material;
    q.px = f.px;
    q.py = f.py;
    q.wo = glm::vec3(f.wo[0], f.wo[1], f.wo[2]);
    q.wi = glm::vec3(f.wi[0], f.wi[1], f.wi[2]);
    q.u = glm::vec3(f.u[0], f.u[1], f.u[2]);
    q.ng = glm::vec3(f.ng[0], f.ng[1], f.ng[2]);
    q.p = glm::vec3(f.p[0], f.p[1], f.p[2]);
    ASSERT_LT(q.material, S.set.materials.size());
    qs.push_back(q);
    why.push_back(f.why);
  }
  const std::vector<bsdf::Result> cpu = bsdf::run(Side::Cpu, S.t, qs), gpu = bsdf::run(Side::Gpu, S.t, qs);
  const bsdf::Judgement J = bsdf::judge(S.set, S.t, S.dims, qs, cpu, gpu);
  for (std::size_t i = 0; i < qs.size(); ++i) {
    std::printf("  %s: %s (field mask %u)\n", why[i], bsdf::verdict_name(J.verdict[i]), J.fields[i]);
    constexpr unsigned kSampled = bsdf::kSampleFlags | bsdf::kSampleF | bsdf::kSamplePdf | bsdf::kSampleWi | bsdf::kSampleEta;
    if (kBsdfFinds[i].fixed) {
      EXPECT_EQ(bsdf::differences(cpu[i], gpu[i]) & kSampled, 0u) << why[i];
    }
    EXPECT_NE(J.verdict[i], bsdf::Verdict::Mismatch)
        << why[i] << ": field mask " << J.fields[i] << ", ill-conditioned mask " << J.ill[i] << "; "
        << bsdf::describe(S.set.materials[qs[i].material]) << "\n  cpu " << bsdf::describe(cpu[i])
        << "\n  gpu " << bsdf::describe(gpu[i]);
  }
}

// =============================================================================================
// TEXTURE and NOISE: the texture scene of texture_probe_test.cpp (every procedural kind and
// mapping; common/texture_scenes.h) plus image maps of every filter and wrap (as its
// ImageMapsGpuMatchCpuEveryFilterAndWrap), every instruction a program root.
// =============================================================================================

/// A temporary folder of this process (removed by the caller).
std::filesystem::path temp_dir(const std::string& tag) {
  const std::filesystem::path d = std::filesystem::temp_directory_path() /
                                  ("basalt-stress-" + tag + "-" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d;
}

/// kTextureScene plus image maps (a non-power-of-two 8-bit PNG and a float EXR, written here)
/// with every filter, wrap and option, and Shirley's interpimage with each interpolation.
SceneTables texture_tables() {
  const std::filesystem::path dir = temp_dir("tex");
  const std::string scene = image_texture_scene(dir);
  SceneTables t = tables_from_string(scene);
  std::filesystem::remove_all(dir);
  return t;
}

/// True if texture program \p i can only give values >= 0 (rgb and float alike): constants of
/// non-negative values, image maps (non-negative texels, clamped resampling),
/// wrinkled (a sum of |noise|), marble (a Bezier spline of non-negative colours), volumes of
/// non-negative values, and checkerboard, dots, scale and directionmix of such children (convex
/// weights). Other kinds (fbm, windy, mix with a textured amount, Shirley's noise, stripes,
/// hermite interpolation, bilerp, which extrapolates outside [0, 1]^2 under a planar mapping)
/// may be negative and are not checked.
bool nonneg_texture(const SceneTables& t, std::uint32_t i) {
  const gpu::Texture& x = t.textures[i];
  auto nonneg_params = [&](int count) {
    for (int k = 0; k < count; ++k)
      if (x.param[k].x < 0 || x.param[k].y < 0 || x.param[k].z < 0) return false;
    return true;
  };
  // The children of a post-order instruction: the subtrees just before it, the last one first.
  auto children = [&](int count, std::vector<std::uint32_t>& out) {
    std::uint32_t end = i;
    for (int k = 0; k < count; ++k) {
      if (end == 0 || end <= x.first) return false;
      const std::uint32_t c = end - 1;
      out.push_back(c);
      end = t.textures[c].first;
    }
    return end == x.first;
  };
  std::vector<std::uint32_t> ch;
  switch (x.type) {
    case gpu::TEXTURE_CONSTANT: return nonneg_params(1);
    case gpu::TEXTURE_IMAGEMAP:
    case gpu::TEXTURE_WRINKLED:
    case gpu::TEXTURE_MARBLE: return true;
    case gpu::TEXTURE_VOLUME: {
      const gpu::MipLevel& ml = t.mip_levels[x.image];
      for (std::uint32_t k = 0; k < ml.width * ml.height * ml.channels; ++k)
        if (t.texels[ml.offset + k] < 0.0f) return false;
      return true;
    }
    case gpu::TEXTURE_CHECKERBOARD:
    case gpu::TEXTURE_DOTS:
    case gpu::TEXTURE_SCALE:
    case gpu::TEXTURE_DIRECTION_MIX:
      if (!children(2, ch)) return false;
      return nonneg_texture(t, ch[0]) && nonneg_texture(t, ch[1]);
    default: return false;
  }
}

/// Hard magnitudes for a coordinate.
float hard_coord(Rng& r, int cls) {
  switch (cls) {
    case 0: return S(r, -6, 6);
    case 1: return S(r, -300, 300);
    case 2: return S(r, -1e4f, 1e4f);
    case 3: return std::floor(S(r, -1e4f, 1e4f));                 // integer lattice
    case 4: return std::floor(S(r, -300, 300)) * 0.5f;            // half lattice
    case 5: {                                                     // integer +- 1 ulp
      const float v = std::floor(S(r, -300, 300));
      return std::nextafter(v, chance(r, 0.5) ? INFINITY : -INFINITY);
    }
    case 6: {                                                     // large integers
      static const float big[] = {8388608.0f, 8388609.0f, 16777216.0f, 16777218.0f, 1073741824.0f};
      return rsign(r, big[pick(r, 5)]);
    }
    case 7: return rsign(r, log10_uniform(r, 20, 30));            // huge
    case 8: {                                                     // tiny, denormal, zero
      const int k = pick(r, 4);
      return k == 0 ? 0.0f : k == 1 ? rsign(r, kDenorm) : k == 2 ? -0.0f : rsign(r, log10_uniform(r, -30, -20));
    }
    default: return rsign(r, std::nextafter(FLT_MAX / 4.0f, 0.0f));
  }
}

/// Hard differential scale: 0, denormal, 1e-30 .. 1e-20, 1e-8, 1e-2, 0.3, 1e4, 1e20 .. 1e30.
float hard_diff_scale(Rng& r) {
  switch (pick(r, 9)) {
    case 0: return 0.0f;
    case 1: return kDenorm;
    case 2: return log10_uniform(r, -30, -20);
    case 3: return 1e-8f;
    case 4: return 1e-2f;
    case 5: return 0.3f;
    case 6: return 1e4f;
    case 7: return log10_uniform(r, 20, 30);
    default: return log10_uniform(r, -8, 4);
  }
}

float diff3(glm::vec3 a, glm::vec3 b) {
  const glm::vec3 d = glm::abs(a - b);
  const float m = std::max(d.x, std::max(d.y, d.z));
  return std::isnan(m) ? INFINITY : m;
}

TEST(Stress, Texture) {
  // tex_eval_rgb / tex_eval_float of every instruction as a root (runs of 64 queries per root)
  // in hard contexts. Preconditions: n unit (it is a normal); everything else any finite value.
  // p: ordinary (6, 300, 1e4), lattice (integers, halves, integers +- 1 ulp), large integers
  // (2^23, 2^23 + 1, 2^24, 2^24 + 2, 2^30), huge (1e20 .. 1e30), tiny, denormal, zero, FLT_MAX/4;
  // uv likewise; differentials 0, denormal, 1e-30 .. 1e-20, 1e-8 .. 1e4, 1e20 .. 1e30.
  // Outputs: finite; >= 0 for the programs nonneg_texture accepts. GPU == CPU as
  // texture_probe_test.cpp (1e-5 absolute plus 1e-5 relative, excused when moving p and uv by
  // 1 .. 16 ulps changes the CPU's own answer by half the mismatch, < 0.5%), compared where that
  // test compares: |p| <= 1e4 (marble's sine is accurate below 2^15, docs/textures-spec.md 8),
  // |uv| <= 1e5 and differentials up to 1e4 (beyond: finiteness and sign only).
  const std::size_t n = stress_n();
  Stress st("Texture");
  const SceneTables t = texture_tables();
  auto runner_ptr = make_runner(t);
  ProbeRunner& runner = *runner_ptr;
  std::vector<bool> nonneg(t.textures.size()), bilerp(t.textures.size(), false);
  for (std::uint32_t i = 0; i < t.textures.size(); ++i) {
    nonneg[i] = nonneg_texture(t, i);
    for (std::uint32_t j = t.textures[i].first; j <= i; ++j)
      bilerp[i] = bilerp[i] || t.textures[j].type == gpu::TEXTURE_BILERP;
  }
  Rng rng(0x7E47);
  u64 compared = 0;
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(kBatch, n - done);
    std::vector<ProbeIn> q(k);
    std::vector<bool> cmp(k);
    for (std::size_t i = 0; i < k; i += 64) {
      const std::uint32_t root = std::uint32_t(pick(rng, int(t.textures.size())));
      const bool is_float = (t.textures[root].flags & gpu::TEXFLAG_FLOAT) != 0u;
      for (std::size_t j = i; j < std::min(k, i + 64); ++j) {
        ProbeIn& e = q[j];
        e = ProbeIn{};
        e.key = glm::uvec4(gpu::PROBE_TEXTURE, root, is_float ? 1u : 0u, 0u);
        // p up to 1e30 (classes 0 .. 8; precondition: the noise textures scale p by their
        // scale and by 1.99 per octave, which must stay finite: at FLT_MAX / 4 the CPU's marble
        // indexes its colour spline with int(floor(NaN))); uv likewise up to 1e30 (the mappings
        // scale it; at FLT_MAX / 4 the scaled coordinate overflows and interpimage gives NaN).
        const int pc = chance(rng, 0.4) ? pick(rng, 3) : pick(rng, 9);
        glm::vec3 p(hard_coord(rng, pc), hard_coord(rng, pc), hard_coord(rng, pc));
        if (chance(rng, 0.2)) p[pick(rng, 3)] = hard_coord(rng, pick(rng, 9));
        const int uc = chance(rng, 0.5) ? 0 : pick(rng, 9);
        glm::vec2 uv = uc == 0 ? glm::vec2(S(rng, -1, 2), S(rng, -1, 2))
                               : glm::vec2(hard_coord(rng, uc), hard_coord(rng, uc));
        if (uc == 1) uv = glm::vec2(S(rng, -1e5f, 1e5f), S(rng, -1e5f, 1e5f));
        if (chance(rng, 0.05)) uv = glm::vec2(float(pick(rng, 2)), std::nextafter(1.0f, float(pick(rng, 2)) * 2.0f));
        glm::vec3 nn = chance(rng, 0.1) ? glm::vec3(0.0f) : uniform_dir(rng);
        if (nn == glm::vec3(0.0f)) nn[pick(rng, 3)] = chance(rng, 0.5) ? 1.0f : -1.0f;
        const float ds = hard_diff_scale(rng);
        auto dv = [&] { return ds * glm::vec3(S(rng, -1, 1), S(rng, -1, 1), S(rng, -1, 1)); };
        glm::vec3 dpdx = dv(), dpdy = dv();
        // (u, v) differentials are clamped to [-1e8, 1e8] where the renderers make them
        // (docs/textures-spec.md 3 step 4): that is their domain; dpdx, dpdy any finite value.
        const float du = std::min(ds, 1e8f);
        glm::vec4 duv(du * S(rng, -1, 1), du * S(rng, -1, 1), du * S(rng, -1, 1), du * S(rng, -1, 1));
        if (chance(rng, 0.1)) dpdx = dpdy = glm::vec3(0.0f);    // zero footprint in p only
        if (chance(rng, 0.1)) duv = glm::vec4(0.0f);             // zero footprint in uv only
        if (chance(rng, 0.05)) dpdy = dpdx;                      // degenerate: parallel
        if (bilerp[root]) {
          // Precondition of bilerp (pbrt-v4's (1 - s)(1 - t) v00 + ..., which extrapolates
          // outside [0, 1]^2): the products of the mapped (s, t) stay finite, |s|, |t| < 1e19.
          p = glm::clamp(p, glm::vec3(-1e15f), glm::vec3(1e15f));
          uv = glm::clamp(uv, glm::vec2(-1e15f), glm::vec2(1e15f));
        }
        e.o_tmax = glm::vec4(p, uv.x);
        e.d = glm::vec4(nn, uv.y);
        e.extra = glm::vec4(dpdx, duv.x);
        e.extra2 = glm::vec4(dpdy, duv.y);
        e.extra3 = glm::vec4(duv.z, duv.w, 0.0f, 0.0f);
        const float pm = std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z)));
        const float um = std::max(std::fabs(uv.x), std::fabs(uv.y));
        cmp[j] = pm <= 1e4f && um <= 1e5f && ds <= 1e4f;
      }
    }
    const Answers a = run_both(runner, t, q);
    Suspects sus;
    for (std::size_t i = 0; i < k; ++i) {
      const glm::vec3 v[2] = {glm::vec3(a.cpu[i].f0), glm::vec3(a.gpu[i].f0)};
      for (int side = 0; side < 2; ++side) {
        const gpu::Texture& x = t.textures[q[i].key.y];
        const std::string note = "texture type " + std::to_string(x.type) + " flags " + std::to_string(x.flags);
        if (!finite3(glm::vec4(v[side], 0.0f))) {
          ++st.nonfinite[side];
          st.offend(side ? "nonfinite gpu" : "nonfinite cpu", q[i], &a.cpu[i], &a.gpu[i], note);
        }
        else if (nonneg[q[i].key.y] && (v[side].x < 0 || v[side].y < 0 || v[side].z < 0)) {
          ++st.negative[side];
          st.offend(side ? "negative gpu" : "negative cpu", q[i], &a.cpu[i], &a.gpu[i], note);
        }
      }
      if (!cmp[i]) continue;
      ++compared;
      const float d = diff3(v[0], v[1]);
      const float tol = 1e-5f + 1e-5f * std::max(glm::length(v[0]), glm::length(v[1]));
      if (d > tol) {
        sus.add(q[i], a.cpu[i], d, i);
      }
    }
    auto f0_diff = [](const ProbeOut& x, const ProbeOut& y) {
      return diff3(glm::vec3(x.f0), glm::vec3(y.f0));
    };
    settle(st, sus, nudge_excusal(t, sus, texture_probe_nudge, f0_diff), a, [&t](const ProbeIn& in) {
      const gpu::Texture& x = t.textures[in.key.y];
      return "texture type " + std::to_string(x.type) + " flags " + std::to_string(x.flags);
    });
    st.inputs += k;
    done += k;
  }
  std::printf("  Texture: %llu of %llu inputs in the compared domain\n", (unsigned long long)compared,
              (unsigned long long)st.inputs);
  st.finish(0.005, "moving p and uv by 1..16 ulps moves the CPU's own answer by half as much");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}

TEST(Stress, Noise) {
  // The noise functions of PROBE_NOISE: op 0 Perlin, 1 Shirley's noise, 2 fbm, 3 turbulence
  // (both lookup precisions, key.w), 4 Shirley's turbulence, 5 Perlin at lambda p. Points from
  // the hard set of Stress.Texture (lattice integers, integers +- 1 ulp, 2^23 .. 2^30, huge,
  // tiny, denormal, zero); dpdx, dpdy zero, denormal, tiny, 1e-2 .. 10, huge; octaves 1 .. 12;
  // roughness 0, 1 or in [0, 1]; lambda 1.99^0 .. 1.99^20. Preconditions: octaves >= 1,
  // roughness in [0, 1] (pbrt-v4's ranges), |lambda p| finite (FLT_MAX/4 coordinates only with
  // lambda 1). Outputs: finite; turbulence (3, 4) >= 0 and |Perlin| (0, 5) <= 1 (counted as
  // negative: outside their range). GPU == CPU within 1e-5 absolute (texture_probe_test.cpp
  // NoiseGpuMatchesCpuUpToLargeCoordinates, no excusal) everywhere.
  const std::size_t n = stress_n();
  Stress st("Noise");
  const SceneTables t = tables_from_string(kTextureScene);
  auto runner_ptr = make_runner(t);
  ProbeRunner& runner = *runner_ptr;
  Rng rng(0x401CE);
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(kBatch, n - done);
    std::vector<ProbeIn> q(k);
    for (std::size_t i = 0; i < k; i += 64) {
      // One op, octave count and precision per run of 64 (one workgroup).
      const std::uint32_t op = std::uint32_t(pick(rng, 6));
      const std::uint32_t octaves = 1u + std::uint32_t(pick(rng, 12));
      const std::uint32_t split = std::uint32_t(pick(rng, 2));
      for (std::size_t j = i; j < std::min(k, i + 64); ++j) {
        ProbeIn& e = q[j];
        e = ProbeIn{};
        e.key = glm::uvec4(gpu::PROBE_NOISE, op, octaves, split);
        // FLT_MAX / 4 (class 9) only where p is not scaled (ops 0, 1): the octaves scale p by
        // up to 1.99^12 (precondition: the scaled point stays finite).
        const int nc = op <= 1 ? 10 : 9;
        const int pc = pick(rng, nc);
        glm::vec3 p(hard_coord(rng, pc), hard_coord(rng, pc), hard_coord(rng, pc));
        if (chance(rng, 0.2)) p[pick(rng, 3)] = hard_coord(rng, pick(rng, nc));
        if (chance(rng, 0.1)) p = glm::vec3(S(rng, -1e6f, 1e6f), S(rng, -1e6f, 1e6f), S(rng, -1e6f, 1e6f));
        const float ds = chance(rng, 0.3) ? log10_uniform(rng, -2, 1) : hard_diff_scale(rng);
        e.o_tmax = glm::vec4(p, 0.0f);
        e.d = glm::vec4(ds * S(rng, -1, 1), ds * S(rng, -1, 1), ds * S(rng, -1, 1), 0.0f);
        const int kr = pick(rng, 6);
        const float rough = kr == 0 ? 0.0f : kr == 1 ? 1.0f : U(rng);
        e.extra = glm::vec4(ds * S(rng, -1, 1), ds * S(rng, -1, 1), ds * S(rng, -1, 1), rough);
        if (op == 5) {
          e.extra.w = std::pow(1.99f, float(pick(rng, 21)));
          const float pm = std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z)));
          if (pm > 1e30f) e.extra.w = 1.0f;  // |lambda p| finite
        }
      }
    }
    const Answers a = run_both(runner, t, q);
    for (std::size_t i = 0; i < k; ++i) {
      const float v[2] = {a.cpu[i].f0.x, a.gpu[i].f0.x};
      const std::uint32_t op = q[i].key.y;
      for (int side = 0; side < 2; ++side) {
        if (!std::isfinite(v[side])) st.count_nonfinite(side, q[i], a.cpu[i], a.gpu[i]);
        else if (((op == 3 || op == 4) && v[side] < 0.0f) || ((op == 0 || op == 5) && std::fabs(v[side]) > 1.0f))
          st.count_negative(side, q[i], a.cpu[i], a.gpu[i]);
      }
      const bool both_nonfinite = !std::isfinite(v[0]) && !std::isfinite(v[1]);  // counted above
      if (!both_nonfinite && !(std::fabs(double(v[0]) - double(v[1])) <= 1e-5)) {
        ++st.mismatches;
        st.offend("mismatch", q[i], &a.cpu[i], &a.gpu[i]);
      }
    }
    st.inputs += k;
    done += k;
  }
  st.finish(0.0, "");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}

// =============================================================================================
// ENV: the three mappings of envmap_gpu_test.cpp (equal-area 32 x 32, lat-long 48 x 24, cube
// 8 x 48 skies with a bright texel and a dark band), each a rotated light of one scene.
// =============================================================================================



/// The scene of Stress.Env: three image infinite lights (equal-area, lat-long, cube) of
/// sky_map images, each under its own rotation.
SceneTables env_stress_tables() {
  const std::filesystem::path dir = temp_dir("env");
  write_image((dir / "ea.exr").string(), sky_map(32, 32));
  write_image((dir / "ll.exr").string(), sky_map(48, 24));
  write_image((dir / "cube.exr").string(), sky_map(8, 48));
  SceneTables t = tables_from_string(
      "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n"
      "Film \"rgb\" \"integer xresolution\" [ 24 ] \"integer yresolution\" [ 24 ]\n"
      "Sampler \"independent\" \"integer pixelsamples\" [ 16 ]\nWorldBegin\n"
      "AttributeBegin\nRotate 33 0.3 1 0.2\nLightSource \"infinite\" \"string filename\" \"" +
      (dir / "ea.exr").string() + "\"\nAttributeEnd\n"
      "AttributeBegin\nRotate -71 1 0.2 0.5\nLightSource \"infinite\" \"string filename\" \"" +
      (dir / "ll.exr").string() + "\" \"string mapping\" \"latlong\"\nAttributeEnd\n"
      "AttributeBegin\nRotate 12 0 0 1\nLightSource \"infinite\" \"string filename\" \"" +
      (dir / "cube.exr").string() + "\" \"string mapping\" \"cube\"\nAttributeEnd\n"
      "Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.5 0.5 ]\n"
      "Shape \"sphere\" \"float radius\" [ 1 ]\n");
  std::filesystem::remove_all(dir);
  return t;
}

TEST(Stress, Env) {
  // Le and pdf (plain and compensated) at a direction d and a sample of the plain distribution
  // with u = extra.xy, for each mapping. Preconditions: d non-zero with |d|^2 a normal float
  // (the light normalizes it; magnitudes 1e-15 .. 1e15 here), u in [0, 1). Directions: uniform,
  // the world's and the light frame's axes and poles (and 1 ulp off them), the map's equator,
  // cube edges and corners (|x| = |y| (= |z|) in the light frame), components zero or denormal;
  // u from the hard set (0, 1 - 2^-24, denormal, tiny). Outputs: finite; Le, pdfs, the sample's
  // pdf and Le >= 0; a sample with pdf > 0 has a unit direction. GPU == CPU as
  // envmap_gpu_test.cpp ProbeMatchesCpu (1e-4 relative, direction 1e-5), excused when nudging d
  // and u by 1 .. 16 ulps moves the CPU's own answer by half as much (< 0.5%).
  const std::size_t n = stress_n();
  Stress st("Env");
  const SceneTables t = env_stress_tables();
  std::vector<std::uint32_t> lights;
  for (std::uint32_t i = 0; i < t.lights.size(); ++i)
    if (t.lights[i].type == gpu::LIGHT_INFINITE_IMAGE) lights.push_back(i);
  ASSERT_EQ(lights.size(), 3u);
  auto runner_ptr = make_runner(t);
  ProbeRunner& runner = *runner_ptr;
  Rng rng(0xE4F);
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(kBatch, n - done);
    std::vector<ProbeIn> q(k);
    for (std::size_t i = 0; i < k; i += 64) {
      const std::uint32_t li = lights[std::size_t(pick(rng, 3))];
      const glm::mat3 light_from_world(t.lights[li].light_from_world);
      const glm::mat3 world_from_light = glm::transpose(light_from_world);  // a rotation
      for (std::size_t j = i; j < std::min(k, i + 64); ++j) {
        ProbeIn& e = q[j];
        e = ProbeIn{};
        e.key = glm::uvec4(gpu::PROBE_ENV, li, 0u, 0u);
        glm::vec3 d;
        const int kd = pick(rng, 12);
        if (kd < 4) d = uniform_dir(rng);
        else if (kd == 4) d = axis_dir(rng);  // world axes, zero and denormal components
        else if (kd < 8) {                    // the light frame's special directions
          glm::vec3 l;
          const int s = pick(rng, 4);
          if (s == 0) l = axis_dir(rng);                                     // poles, axes
          else if (s == 1) l = dir_cos_phi(0.0, 2 * kPi * Ud(rng));         // equator
          else if (s == 2) l = glm::normalize(glm::vec3(rsign(rng, 1), rsign(rng, 1), chance(rng, 0.5) ? 0.0f : rsign(rng, 1)));
          else l = dir_cos_phi(hard_cos_signed(rng), chance(rng, 0.3) ? 0.0 : 2 * kPi * Ud(rng));
          d = world_from_light * l;
          if (chance(rng, 0.3)) d = l;
        } else if (kd < 10) {  // 1 ulp off a pole or axis
          d = axis_dir(rng);
          for (int c = 0; c < 3; ++c)
            if (d[c] == 0.0f && chance(rng, 0.5)) d[c] = rsign(rng, 0x1p-24f);
        } else {
          d = uniform_dir(rng);
          d[pick(rng, 3)] = 0.0f;
          if (d == glm::vec3(0.0f)) d.z = 1.0f;
        }
        if (chance(rng, 0.15)) d *= log10_uniform(rng, -15, 15);
        glm::vec2 u(hard_u(rng), hard_u(rng));
        if (chance(rng, 0.5)) u = glm::vec2(U(rng), U(rng));
        e.d = glm::vec4(d, S(rng, -2, 2));
        e.extra = glm::vec4(u, S(rng, -2, 2), S(rng, -2, 2));
      }
    }
    const Answers a = run_both(runner, t, q);
    Suspects sus;
    for (std::size_t i = 0; i < k; ++i) {
      const ProbeOut* o[2] = {&a.cpu[i], &a.gpu[i]};
      for (int side = 0; side < 2; ++side) {
        const ProbeOut& r = *o[side];
        if (!finite4(r.f0) || !finite4(r.f1) || !finite3(r.f2) || !std::isfinite(r.f3.x)) {
          st.count_nonfinite(side, q[i], a.cpu[i], a.gpu[i]);
          continue;
        }
        if (r.f0.x < 0 || r.f0.y < 0 || r.f0.z < 0 || r.f0.w < 0 || r.f1.w < 0 || r.f2.x < 0 ||
            r.f2.y < 0 || r.f2.z < 0 || r.f3.x < 0)
          st.count_negative(side, q[i], a.cpu[i], a.gpu[i]);
        if (r.f1.w > 0.0f && std::fabs(glm::length(glm::vec3(r.f1)) - 1.0f) > 1e-5f)
          st.count_detail(side ? "sampled direction not unit gpu" : "sampled direction not unit cpu",
                          q[i], o[0], o[1]);
      }
      const float d = env_probe_diff(a.cpu[i], a.gpu[i]);
      if (d > 1e-4f) {
        sus.add(q[i], a.cpu[i], d, i);
      }
    }
    settle(st, sus, nudge_excusal(t, sus, env_probe_nudge, env_probe_diff), a);
    st.inputs += k;
    done += k;
  }
  st.finish(0.005, "nudging d and u by 1..16 ulps moves the CPU's own answer by half as much");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}


/// An ENV probe input printed by a stress run: the light, d (xyz, w unused) and extra (u, .zw).
struct EnvFind {
  std::uint32_t light;
  float d[4], extra[4];
};

// Mismatches of Stress.Env at 10^7 (2026-11-26): lat-long Le of ~1e-2 in the map's dimmed row
// (sky_map scales row 25/32 by 0.01) beside rows 100 times brighter, so that the 1 .. 2 ulps by
// which the two sides' (u, v) differ move Le by 2e-4 of itself.
const EnvFind kEnvFinds[] = {
    {1, {0x1.ffc9a2p-2f, -0x1.20960ep-1f, -0x1.50b856p-1f, -0x1.da55d8p+0f}, {0x1.b33958p-3f, 0x1.22693cp-2f, -0x1.0d500cp+0f, 0x1.237b94p+0f}},
    {1, {-0x1.e4cb8cp-2f, -0x1.bd745ep-1f, 0x1.19a496p-3f, -0x1.2404acp+0f}, {0x1.bbcb04p-1f, 0x1.63b5a4p-1f, -0x1.eb6fdp+0f, -0x1.36744p-2f}},
    {1, {-0x1.be04c2p+38f, -0x1.614b5p+39f, 0x1.3d8632p+36f, 0x1.c9d60cp+0f}, {0x1.127a1p-1f, 0x1.5c8f1cp-2f, -0x1.47fde4p+0f, -0x1.56e33p+0f}},
    {1, {-0x1.17fe16p-1f, -0x1.aa998p-1f, 0x1.4fb5cep-4f, -0x1.c1c4ap-3f}, {0x1.8dda6cp-1f, 0x1.4194e8p-2f, 0x1.7809f8p-1f, -0x1.0fcb94p+0f}},
    {1, {-0x1.02933cp-1f, -0x1.b5db82p-1f, 0x1.dd93e6p-4f, -0x1.229d3p+0f}, {0x1.724fap-4f, 0x1.23ap-3f, -0x1.975348p+0f, 0x1.b8101p-2f}},
};

TEST(ProbeFinds, Env) {
  // Each find agrees within 1e-4 or is excused by Stress.Env's rule (env_probe_nudge moves the
  // CPU's own answer by at least half the difference); the rule's former nudge, one fixed
  // pattern (+d.x, -d.y, +d.z), moved these answers by 2.8e-6 .. 1.2e-5 only.
  const SceneTables t = env_stress_tables();
  Suspects sus;
  std::vector<ProbeIn> q;
  for (const EnvFind& f : kEnvFinds) {
    ProbeIn e{};
    e.key = glm::uvec4(gpu::PROBE_ENV, f.light, 0u, 0u);
    e.d = glm::vec4(f.d[0], f.d[1], f.d[2], f.d[3]);
    e.extra = glm::vec4(f.extra[0], f.extra[1], f.extra[2], f.extra[3]);
    q.push_back(e);
  }
  const std::vector<ProbeOut> cpu = probe(Side::Cpu, t, q), gpu = probe(Side::Gpu, t, q);
  for (std::size_t i = 0; i < q.size(); ++i) {
    const float d = env_probe_diff(cpu[i], gpu[i]);
    std::printf("  find %zu: GPU/CPU difference %.3g\n", i, d);
    if (d > 1e-4f) sus.add(q[i], cpu[i], d, i);
  }
  const std::vector<bool> ok = nudge_excusal(t, sus, env_probe_nudge, env_probe_diff);
  for (std::size_t j = 0; j < ok.size(); ++j) EXPECT_TRUE(ok[j]) << "find " << sus.index[j];
}

// =============================================================================================
// DIFFERENTIALS and BUMP: a scene of bump_probe_test.cpp's kinds (its head, textures and
// materials): spheres (plain, flipped, scaled and rotated, a pole facing the camera, a
// displacement of -r whose bumped pair is zero), triangle meshes with and without vertex normals
// and uv, a wavy grid, a triangle of degenerate uv, a back-facing normal-mapped quad, a
// stochastic mix of a bumped and a plain material, fbm, wrinkled, image, constant and
// vector-turbulence bumps and normal maps.
// =============================================================================================

/// A uv sphere as a triangle mesh (bump_probe_test.cpp uv_sphere_mesh).
std::string uv_sphere_mesh(glm::vec3 c, float r, int nu, int nv, bool normals, bool uv) {
  std::string P, N, UV, I;
  auto f = [](float v) { return std::to_string(v) + " "; };
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      const float th = 3.14159265f * (0.02f + 0.96f * float(j) / float(nv));
      const float ph = 6.2831853f * float(i) / float(nu);
      const glm::vec3 n(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
      const glm::vec3 p = c + r * n;
      P += f(p.x) + f(p.y) + f(p.z);
      N += f(n.x) + f(n.y) + f(n.z);
      UV += f(float(i) / float(nu)) + f(float(j) / float(nv));
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int a = j * (nu + 1) + i, b = a + 1, d = a + nu + 1, e = d + 1;
      for (int v : {a, d, b, b, d, e}) I += std::to_string(v) + " ";
    }
  std::string sh = "Shape \"trianglemesh\" \"integer indices\" [ " + I + "] \"point3 P\" [ " + P + "]";
  if (normals) sh += " \"normal N\" [ " + N + "]";
  if (uv) sh += " \"point2 uv\" [ " + UV + "]";
  return sh + "\n";
}

/// A wavy height field with analytic vertex normals (bump_probe_test.cpp wavy_grid).
std::string wavy_grid(float w, float y0, int n) {
  std::string P, N, UV, I;
  auto f = [](float v) { return std::to_string(v) + " "; };
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const float x = -w + 2.0f * w * float(i) / float(n), z = -w + 2.0f * w * float(j) / float(n);
      const float y = y0 + 0.25f * std::sin(1.3f * x) * std::cos(0.9f * z);
      const glm::vec3 nn = glm::normalize(glm::vec3(-0.325f * std::cos(1.3f * x) * std::cos(0.9f * z), 1.0f,
                                                    0.225f * std::sin(1.3f * x) * std::sin(0.9f * z)));
      P += f(x) + f(y) + f(z);
      N += f(nn.x) + f(nn.y) + f(nn.z);
      UV += f(3.0f * float(i) / float(n)) + f(2.0f * float(j) / float(n));
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, d = a + n + 1, e = d + 1;
      for (int v : {a, b, d, b, e, d}) I += std::to_string(v) + " ";
    }
  return "Shape \"trianglemesh\" \"integer indices\" [ " + I + "] \"point3 P\" [ " + P +
         "] \"point2 uv\" [ " + UV + "] \"normal N\" [ " + N + "]\n";
}

/// The bump stress scene's tables (disp.png and normal.png written beside it).
SceneTables bump_stress_tables() {
  const std::filesystem::path dir = temp_dir("bump");
  Image disp{20, 12, {}}, nm{13, 9, {}};
  for (int y = 0; y < disp.height; ++y)
    for (int x = 0; x < disp.width; ++x)
      disp.pixels.push_back(glm::vec3(0.5f + 0.4f * std::sin(0.9f * float(x)) * std::cos(1.3f * float(y))));
  auto srgb_to_linear = [](float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
  };
  for (int y = 0; y < nm.height; ++y)
    for (int x = 0; x < nm.width; ++x) {
      glm::vec3 n = glm::normalize(glm::vec3(0.6f * std::sin(1.7f * float(x) + 0.3f * float(y)),
                                             0.5f * std::cos(2.1f * float(y)), 1.0f));
      if ((x + 2 * y) % 11 == 0) n = glm::normalize(glm::vec3(0.9f, -0.7f, 0.15f));  // steep
      const glm::vec3 e = 0.5f * n + glm::vec3(0.5f);
      nm.pixels.push_back(glm::vec3(srgb_to_linear(e.x), srgb_to_linear(e.y), srgb_to_linear(e.z)));
    }
  write_image((dir / "disp.png").string(), disp);
  write_image((dir / "normal.png").string(), nm);
  std::string scene = std::string(kBumpHead) + R"(
MakeNamedMaterial "bumped" "string type" "conductor" "float roughness" [ 0.2 ]
    "texture displacement" "fbm-s"
MakeNamedMaterial "plain" "string type" "diffuse" "rgb reflectance" [ .3 .5 .7 ]
MakeNamedMaterial "m1" "string type" "mix" "string materials" [ "bumped" "plain" ]
    "float amount" [ 0.5 ]
Material "diffuse" "rgb reflectance" [ .5 .5 .5 ] "texture displacement" "img-s"
Shape "trianglemesh" "integer indices" [ 0 1 2 0 2 3 ]
  "point3 P" [ -20 -1 -10  20 -1 -10  20 -1 6  -20 -1 6 ] "point2 uv" [ 0 0 8 0 8 4 0 4 ]
Material "conductor" "float roughness" [ 0.2 ] "texture displacement" "wr-s"
Shape "trianglemesh" "integer indices" [ 0 1 2 0 2 3 ]
  "point3 P" [ -20 -1 6  20 -1 6  20 15 6  -20 15 6 ]
AttributeBegin
  Translate -2.2 0.2 0
  Material "diffuse" "rgb reflectance" [ .6 .4 .3 ] "texture displacement" "fbm-s"
  Shape "sphere" "float radius" [ 1.1 ]
AttributeEnd
AttributeBegin
  Translate 0 0.2 0.3
  ReverseOrientation
  Material "conductor" "float roughness" [ 0.1 ] "texture displacement" "wr-s"
  Shape "sphere" "float radius" [ 1.0 ]
AttributeEnd
AttributeBegin
  Translate 2.2 0.2 0
  Rotate 40 1 0.3 0
  Scale 0.7 0.7 0.7
  Material "coateddiffuse" "float displacement" [ 0.05 ]
  Shape "sphere" "float radius" [ 1.4 ]
AttributeEnd
AttributeBegin
  Translate 0 0.9 -2.2
  Rotate 90 1 0 0
  Material "diffuse" "texture displacement" "fbm-s" "float normalturbulence" [ 0.2 ]
    "float normalturbulencescale" [ 6 ]
  Shape "sphere" "float radius" [ 0.35 ]
AttributeEnd
AttributeBegin
  Translate -1 2.2 1.5
  Rotate 160 0 1 0.3
  Material "diffuse" "string normalmap" "normal.png"
  Shape "sphere" "float radius" [ 0.9 ]
AttributeEnd
AttributeBegin
  Translate 1.3 2.3 1.5
  NamedMaterial "m1"
  Shape "sphere" "float radius" [ 0.8 ]
AttributeEnd
AttributeBegin
  Translate 3.2 2.6 2.5
  Material "diffuse" "float displacement" [ -1 ]
  Shape "sphere" "float radius" [ 1 ]
AttributeEnd
AttributeBegin
  Translate 1.2 -0.6 -2.0
  Material "coateddiffuse" "float displacement" [ 0.3 ] "string normalmap" "normal.png"
)" + wavy_grid(0.9f, 0.0f, 6) + R"(AttributeEnd
Material "diffuse" "texture displacement" "fbm-s"
)" + uv_sphere_mesh(glm::vec3(-3.4f, 2.6f, 2.2f), 1.0f, 20, 10, true, true) + R"(
Material "coateddiffuse" "texture displacement" "img-t"
)" + uv_sphere_mesh(glm::vec3(0.2f, 2.9f, 3.2f), 0.9f, 16, 8, false, false) + R"(
Material "diffuse" "texture displacement" "fbm-s"
Shape "trianglemesh" "point3 P" [ -3.5 -1 -2  -2 -1 -2  -2.75 0.5 -1.8 ] "integer indices" [ 0 1 2 ]
  "point2 uv" [ 0.3 0.3  0.3 0.3  0.3 0.3 ]
Material "diffuse" "string normalmap" "normal.png" "float normalturbulence" [ 0.1 ]
Shape "trianglemesh" "point3 P" [ 2 -1 -3  3.5 -1 -3  3.5 0.5 -3  2 0.5 -3 ]
  "integer indices" [ 0 2 1  0 3 2 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
)";
  SceneTables t = build_tables(load_scene_from_string(scene, "stress.pbrt", dir.string()));
  std::filesystem::remove_all(dir);
  return t;
}

float bits_float(std::uint32_t u) { return std::bit_cast<float>(u); }

/// \p t with its camera moved by k ulps of its largest coordinate (bump_probe_test.cpp).
SceneTables nudge_camera(const SceneTables& t, int k) {
  SceneTables n = t;
  glm::vec4& o = n.globals.world_from_camera[3];
  const float m = std::max(std::fabs(o.x), std::max(std::fabs(o.y), std::fabs(o.z)));
  const float s = float(k) * (std::nextafter(m, INFINITY) - m);
  o = glm::vec4(o.x + s, o.y - s, o.z + s, o.w);
  return n;
}

/// A pixel and sample of the film: corners and edges one time in five; samples 0, 2^32 - 1 or
/// any (precondition of the camera probes: the pixel lies in the film).
void camera_key(Rng& r, const SceneTables& t, std::uint32_t& px, std::uint32_t& py, std::uint32_t& smp) {
  const std::uint32_t w = t.width(), h = t.height();
  px = chance(r, 0.1) ? (chance(r, 0.5) ? 0u : w - 1) : std::uint32_t(r() % w);
  py = chance(r, 0.1) ? (chance(r, 0.5) ? 0u : h - 1) : std::uint32_t(r() % h);
  smp = hard_key(r);
}

/// The material a camera-probe hit's primitive carries.
std::uint32_t prim_material(const SceneTables& t, std::uint32_t prim) {
  if (prim == gpu::INVALID_INDEX) return gpu::INVALID_INDEX;
  if (prim & gpu::PRIM_SPHERE_BIT) return t.spheres[prim & gpu::PRIM_INDEX_MASK].material;
  return t.meshes[t.triangles[prim].mesh].material;
}

TEST(Stress, Differentials) {
  // PROBE_DIFFERENTIALS modes 0 (camera differentials), 1 (Approximate_dp_dxy), 2 (after a
  // perfectly specular reflection about ns) and 3 (after a refraction with relative IOR eta:
  // 1 exactly, 1 +- 1e-4, 1/1.5, 1.5, 0.25, 4, or any in [0.25, 4]; precondition eta > 0) at
  // pixels of the film (corners and edges included) and any sample index. Each input is the
  // query and its mode-0 companion at the same pixel and sample (the first hit of modes 2, 3).
  // Outputs: finite (dpdx, dudx, dpdy, dudy, uv, dvdx, dvdy, p) for a hit. Self-intersection:
  // the second ray of modes 2, 3 hits the first hit's own triangle (it leaves that plane), its
  // own sphere after a reflection, or its own sphere within 1e-4 r after a refraction with
  // eta >= 1 into an unflipped sphere (the chord is then >= 0.028 r); incidence within 1e-3
  // of the tangent is not judged (robustness_test.cpp's rule). GPU == CPU as
  // texture_probe_test.cpp FootprintsGpuMatchCpu: the same primitive and the same
  // "differentials survived" flag, each of (dpdx, dudx), (dpdy, dudy), (uv, dvdx, dvdy) within
  // 1e-4 of its length; excused as bump_probe_test.cpp does for camera-hit probes: moving the
  // camera by 1 .. 16 ulps moves the CPU's own answer by half as much (< 0.5%).
  const std::size_t n = stress_n();
  Stress st("Differentials");
  const SceneTables t = bump_stress_tables();
  auto runner_ptr = make_runner(t);
  ProbeRunner& runner = *runner_ptr;
  std::vector<SceneTables> nudged;
  for (int k : kNudges) nudged.push_back(nudge_camera(t, k));
  const glm::vec3 cam(t.globals.world_from_camera[3]);
  Rng rng(0xD1FF);
  u64 hits = 0, second_hits = 0, judged = 0;
  auto diff = [](const ProbeOut& a, const ProbeOut& b) {
    if (a.u.x != b.u.x || a.u.y != b.u.y) return INFINITY;
    if (a.u.x == gpu::INVALID_INDEX) return 0.0f;
    float d = 0.0f;
    for (int k = 0; k < 3; ++k) {
      const glm::vec4 x = k == 0 ? a.f0 : (k == 1 ? a.f1 : a.f2);
      const glm::vec4 y = k == 0 ? b.f0 : (k == 1 ? b.f1 : b.f2);
      const float scale = std::max(1e-6f, std::max(glm::length(x), glm::length(y)));
      d = std::max(d, glm::length(x - y) / (1e-4f * scale));
    }
    return std::isnan(d) ? INFINITY : d;
  };
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(kBatch / 2, n - done);
    std::vector<ProbeIn> q(2 * k);
    for (std::size_t i = 0; i < k; ++i) {
      std::uint32_t px, py, smp;
      camera_key(rng, t, px, py, smp);
      const std::uint32_t mode = std::uint32_t(pick(rng, 4));
      static const float etas[] = {1.0f, 1.0001f, 0.9999f, 1.0f / 1.5f, 1.5f, 0.25f, 4.0f};
      const float eta = chance(rng, 0.5) ? etas[pick(rng, 7)] : S(rng, 0.25f, 4.0f);
      q[2 * i] = ProbeIn{};
      q[2 * i].key = glm::uvec4(gpu::PROBE_DIFFERENTIALS, mode, px, py);
      q[2 * i].extra = glm::vec4(bits_float(smp), eta, 0.0f, 0.0f);
      q[2 * i + 1] = q[2 * i];
      q[2 * i + 1].key.y = 0u;
    }
    const Answers a = run_both(runner, t, q);
    std::vector<ProbeIn> sq;
    std::vector<std::size_t> si;
    std::vector<float> amount;
    for (std::size_t i = 0; i < k; ++i) {
      const std::size_t j = 2 * i;
      const ProbeIn& qi = q[j];
      const ProbeOut* o[2] = {&a.cpu[j], &a.gpu[j]};
      const ProbeOut* first[2] = {&a.cpu[j + 1], &a.gpu[j + 1]};
      for (int side = 0; side < 2; ++side) {
        for (const ProbeOut* r : {o[side], first[side]})
          if (r->u.x != gpu::INVALID_INDEX &&
              !(finite4(r->f0) && finite4(r->f1) && finite4(r->f2) && finite3(r->f3))) {
            st.count_nonfinite(side, qi, a.cpu[j], a.gpu[j]);
            break;
          }
        const std::uint32_t p1 = first[side]->u.x, p2 = o[side]->u.x;
        if (side == 0) {
          hits += p1 != gpu::INVALID_INDEX;
          second_hits += qi.key.y >= 2 && p2 != gpu::INVALID_INDEX;
          judged += qi.key.y >= 2 && p1 != gpu::INVALID_INDEX && p2 == p1;
        }
        if (qi.key.y < 2 || p1 == gpu::INVALID_INDEX || p2 != p1) continue;
        if (!(p1 & gpu::PRIM_SPHERE_BIT)) {
          st.count_self(side, qi, a.cpu[j], a.gpu[j]);
          continue;
        }
        const gpu::Sphere& sp = t.spheres[p1 & gpu::PRIM_INDEX_MASK];
        const glm::vec3 c(sp.center_radius), h1(first[side]->f3), h2(o[side]->f3);
        const float rad = sp.center_radius.w;
        const float cos_i = std::fabs(glm::dot(glm::normalize(h1 - cam), glm::normalize(h1 - c)));
        if (cos_i < 1e-3f) continue;  // near-tangent: not judged
        const bool flipped = (sp.flags & gpu::SHAPE_FLAG_FLIP_NORMAL) != 0;
        if (qi.key.y == 2 || (!flipped && qi.extra.y >= 1.0f && glm::length(h2 - h1) < 1e-4f * rad))
          st.count_self(side, qi, a.cpu[j], a.gpu[j]);
      }
      for (std::size_t m = j; m < j + 2; ++m) {
        const float d = diff(a.cpu[m], a.gpu[m]);
        if (d > 1.0f) {
          sq.push_back(q[m]);
          si.push_back(m);
          amount.push_back(d);
        }
      }
    }
    if (!sq.empty()) {
      std::vector<float> spread(sq.size(), 0.0f);
      for (const SceneTables& nt : nudged) {
        const std::vector<ProbeOut> c2 = probe_cpu_threads(nt, sq, 2);
        for (std::size_t m = 0; m < sq.size(); ++m) spread[m] = std::max(spread[m], diff(a.cpu[si[m]], c2[m]));
      }
      for (std::size_t m = 0; m < sq.size(); ++m) {
        if (spread[m] >= 0.5f * amount[m]) {
          ++st.excused;
          continue;
        }
        ++st.mismatches;
        st.offend("mismatch", sq[m], &a.cpu[si[m]], &a.gpu[si[m]]);
      }
    }
    st.inputs += k;
    done += k;
  }
  std::printf("  Differentials: %llu first hits, %llu second hits after a specular bounce, %llu "
              "same-primitive second hits judged\n", (unsigned long long)hits,
              (unsigned long long)second_hits, (unsigned long long)judged);
  st.finish(0.005, "moving the camera by 1..16 ulps moves the CPU's own answer by half as much");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
  EXPECT_GT(double(hits), 0.5 * double(st.inputs)) << "few hits";
  EXPECT_GT(double(second_hits), 0.1 * double(st.inputs)) << "few second hits";
}

/// bump_probe_test.cpp bounds: per-field tolerances (normal, dpdu', dpdv', t1) of the answers
/// \p a (CPU), \p b (GPU) given the footprint answer \p fp (PROBE_DIFFERENTIALS mode 0 layout:
/// dudx f0.w, dudy f1.w, dvdx f2.z, dvdy f2.w) and the displacement agreement \p tex_err.
glm::vec4 bump_bounds(const ProbeOut& a, const ProbeOut& b, const ProbeOut& fp, float tex_err) {
  auto length3 = [](glm::vec4 v) { return glm::length(glm::vec3(v)); };
  const float la = std::max(length3(a.f1), length3(b.f1));
  const float lb = std::max(length3(a.f2), length3(b.f2));
  float eu = 1e-6f + 1e-5f * la, ev = 1e-6f + 1e-5f * lb;
  if (a.u.y == 1u) {
    float du = 0.5f * (std::fabs(fp.f0.w) + std::fabs(fp.f1.w));
    float dv = 0.5f * (std::fabs(fp.f2.z) + std::fabs(fp.f2.w));
    if (du == 0.0f) du = 0.0005f;
    if (dv == 0.0f) dv = 0.0005f;
    eu += tex_err / du;
    ev += tex_err / dv;
  }
  const glm::vec3 u(a.f1), v(a.f2);
  const float sine = glm::length(glm::cross(u, v)) / std::max(1e-30f, glm::length(u) * glm::length(v));
  const float en = 1e-5f + (eu / std::max(1e-30f, la) + ev / std::max(1e-30f, lb)) / std::max(1e-30f, sine);
  const float et = en + 1e-5f + eu / std::max(1e-30f, la);
  return glm::vec4(en, eu, ev, et);
}

/// bump_probe_test.cpp mismatch: the largest field distance over its bound; infinite where the
/// primitive or the bump decision differs.
float bump_mismatch(const ProbeOut& a, const ProbeOut& b, glm::vec4 e) {
  if (a.u.x != b.u.x || a.u.y != b.u.y) return INFINITY;
  if (a.u.x == gpu::INVALID_INDEX) return 0.0f;
  const float d[4] = {glm::length(glm::vec3(a.f0 - b.f0)), glm::length(glm::vec3(a.f1 - b.f1)),
                      glm::length(glm::vec3(a.f2 - b.f2)), glm::length(glm::vec3(a.f3 - b.f3))};
  float m = 0.0f;
  for (int k = 0; k < 4; ++k) m = std::max(m, d[k] / e[k]);
  return std::isnan(m) ? INFINITY : m;
}

TEST(Stress, Bump) {
  // PROBE_BUMP (docs/bump-spec.md 6) in three kinds of input:
  // - camera hits (key.y = 0) at pixels of the film and any sample: compared as
  //   bump_probe_test.cpp compare_bump (the same primitive and bump decision; normal, dpdu',
  //   dpdv', t1 within the bounds derived there from the displacement agreement tex_err = 4e-5,
  //   0 for a material with a normal map only, over the footprint's steps), excused when moving
  //   the camera by 1 .. 16 ulps moves the CPU's own answer by half as much;
  // - ordinary synthetic points (key.y = 1): p in [-3, 3]^3, uv in [0, 1]^2, unit ng, ns within
  //   70 degrees of it, a non-parallel shading pair of lengths 0.1 .. 10, footprints 0 or 1e-4 ..
  //   0.1, dndu factor 0 or +-1: compared with the same bounds (the footprint is the input's),
  //   excused when moving p by 1 .. 16 ulps moves the CPU's own answer by half as much;
  // - extreme synthetic points (bump_probe_test.cpp RandomExtremeInputs: points up to 1e3 and
  //   1e30, footprints and pairs 0 or 1e-30 .. 1e30, parallel pairs, ns across the horizon of
  //   ng): not compared (that test compares none).
  // Every answer finite; where the frame changed: unit, orthonormal (1e-4) and, for synthetic
  // points, facing ng (a normal below ng counts as negative). Excusals bounded (< 0.5% of the
  // compared inputs).
  const std::size_t n = stress_n();
  Stress st("Bump");
  const SceneTables t = bump_stress_tables();
  auto runner_ptr = make_runner(t);
  ProbeRunner& runner = *runner_ptr;
  std::vector<SceneTables> nudged;
  for (int k : kNudges) nudged.push_back(nudge_camera(t, k));
  std::vector<std::uint32_t> mats;  // every material (bumped, normal-mapped, mixed, plain)
  for (std::uint32_t m = 0; m < t.materials.size(); ++m) mats.push_back(m);
  auto tex_err_of = [&](std::uint32_t m) {
    if (m >= t.materials.size()) return 4e-5f;
    const std::uint32_t f = t.materials[m].flags;
    const bool nm_only = (f & gpu::MATFLAG_NORMALMAP) && !(f & (gpu::MATFLAG_BUMP | gpu::MATFLAG_VTURB)) &&
                         t.materials[m].type != gpu::MATERIAL_MIX;
    return nm_only ? 0.0f : 4e-5f;
  };
  Rng rng(0xB0B);
  auto unit = [&] {
    for (;;) {
      const glm::vec3 v(S(rng, -1, 1), S(rng, -1, 1), S(rng, -1, 1));
      const float l2 = glm::dot(v, v);
      if (l2 > 1e-4f && l2 <= 1.0f) return v / std::sqrt(l2);
    }
  };
  auto mag = [&] {
    if (chance(rng, 0.1)) return 0.0f;
    return rsign(rng, log10_uniform(rng, -30, 30));
  };
  u64 compared = 0, bumped = 0;
  for (std::size_t done = 0; done < n;) {
    const std::size_t k = std::min(kBatch, n - done);
    std::vector<ProbeIn> q(k), fpq(k);
    std::vector<int> kind(k);  // 0 camera, 1 ordinary synthetic, 2 extreme synthetic
    std::vector<glm::vec3> ngs(k);
    for (std::size_t i0 = 0; i0 < k; i0 += 64) {
      const int kd = pick(rng, 10) < 6 ? 0 : (chance(rng, 0.5) ? 1 : 2);
      const std::uint32_t m = mats[std::size_t(pick(rng, int(mats.size())))];
      for (std::size_t i = i0; i < std::min(k, i0 + 64); ++i) {
        ProbeIn& e = q[i];
        e = ProbeIn{};
        kind[i] = kd;
        if (kd == 0) {
          std::uint32_t px, py, smp;
          camera_key(rng, t, px, py, smp);
          e.key = glm::uvec4(gpu::PROBE_BUMP, 0u, px, py);
          e.extra.x = bits_float(smp);
          fpq[i] = e;
          fpq[i].key.x = gpu::PROBE_DIFFERENTIALS;
          continue;
        }
        glm::vec3 ng, ns, p, a, b;
        glm::vec2 uv;
        float fu, fv, kk;
        if (kd == 1) {
          ng = unit();
          ns = chance(rng, 0.5) ? ng : dir_at_cos(rng, ng, S(rng, 0.35f, 1.0f));
          p = glm::vec3(S(rng, -3, 3), S(rng, -3, 3), S(rng, -3, 3));
          uv = glm::vec2(U(rng), U(rng));
          glm::dvec3 ta, tb;
          perp(glm::dvec3(ns), ta, tb);
          const double ang = 2 * kPi * Ud(rng), skew = S(rng, 0.3f, 2.8f);
          a = float(log10_uniform(rng, -1, 1)) * glm::vec3(std::cos(ang) * ta + std::sin(ang) * tb);
          b = float(log10_uniform(rng, -1, 1)) *
              glm::vec3(std::cos(ang + skew) * ta + std::sin(ang + skew) * tb);
          fu = chance(rng, 0.2) ? 0.0f : log10_uniform(rng, -4, -1);
          fv = chance(rng, 0.2) ? 0.0f : log10_uniform(rng, -4, -1);
          const int kc = pick(rng, 3);
          kk = kc == 0 ? 0.0f : (kc == 1 ? 1.0f : -1.0f);
        } else {
          ng = unit();
          ns = chance(rng, 0.5) ? ng : unit();
          if (glm::dot(ns, ng) < 0.0f) ng = -ng;
          p = glm::vec3(1e3f * S(rng, -1, 1), 1e3f * U(rng), chance(rng, 0.01) ? mag() : 0.0f);
          uv = glm::vec2(chance(rng, 0.05) ? mag() : U(rng), U(rng));
          const glm::vec3 adir = unit();
          a = adir * std::fabs(mag());
          const float rr = U(rng);
          b = rr < 0.05f ? adir * mag() : rr < 0.1f ? ns * mag() : unit() * std::fabs(mag());
          fu = mag();
          fv = mag();
          kk = chance(rng, 0.3) ? 0.0f : mag();
        }
        ngs[i] = ng;
        e.key = glm::uvec4(gpu::PROBE_BUMP, 1u, m, 0u);
        e.o_tmax = glm::vec4(p, uv.x);
        e.d = glm::vec4(ng, uv.y);
        e.extra = glm::vec4(a, fu);
        e.extra2 = glm::vec4(b, fv);
        e.extra3 = glm::vec4(ns, kk);
        fpq[i] = ProbeIn{};
      }
    }
    const Answers a = run_both(runner, t, q);
    // The camera hits' footprints (CPU, as bump_probe_test.cpp); synthetic ones are the input's.
    std::vector<ProbeIn> fq;
    std::vector<std::size_t> fi;
    for (std::size_t i = 0; i < k; ++i)
      if (kind[i] == 0) fq.push_back(fpq[i]), fi.push_back(i);
    const std::vector<ProbeOut> fpo = probe_cpu_threads(t, fq, 2);
    std::vector<ProbeOut> fp(k);
    for (std::size_t j = 0; j < fi.size(); ++j) fp[fi[j]] = fpo[j];
    for (std::size_t i = 0; i < k; ++i)
      if (kind[i] != 0) {
        fp[i].f0.w = fp[i].f1.w = q[i].extra.w;
        fp[i].f2.z = fp[i].f2.w = q[i].extra2.w;
      }
    std::vector<ProbeIn> sq;
    std::vector<std::size_t> si;
    std::vector<float> amount;
    for (std::size_t i = 0; i < k; ++i) {
      const ProbeOut* o[2] = {&a.cpu[i], &a.gpu[i]};
      bumped += a.cpu[i].u.y == 1u;
      bool finite_both = true;
      for (int side = 0; side < 2; ++side) {
        const ProbeOut& r = *o[side];
        if (!(finite3(r.f0) && finite3(r.f1) && finite3(r.f2) && finite3(r.f3))) {
          st.count_nonfinite(side, q[i], a.cpu[i], a.gpu[i]);
          finite_both = false;
          continue;
        }
        if (r.u.y != 1u) continue;
        const glm::dvec3 nn(r.f0), tt(r.f3);
        const double err = std::max({std::fabs(glm::length(nn) - 1.0), std::fabs(glm::length(tt) - 1.0),
                                     std::fabs(glm::dot(nn, tt))});
        if (err > 1e-4)
          st.count_detail(side ? "bumped frame not orthonormal gpu" : "bumped frame not orthonormal cpu",
                          q[i], o[0], o[1]);
        if (kind[i] != 0 && glm::dot(nn, glm::dvec3(ngs[i])) < -1e-6)
          st.count_negative(side, q[i], a.cpu[i], a.gpu[i]);
      }
      if (kind[i] == 2 || !finite_both) continue;
      ++compared;
      const std::uint32_t mat = kind[i] == 0 ? prim_material(t, a.cpu[i].u.x) : q[i].key.z;
      const float m = bump_mismatch(a.cpu[i], a.gpu[i], bump_bounds(a.cpu[i], a.gpu[i], fp[i], tex_err_of(mat)));
      if (m > 1.0f) {
        sq.push_back(q[i]);
        si.push_back(i);
        amount.push_back(m);
      }
    }
    if (!sq.empty()) {
      std::vector<float> spread(sq.size(), 0.0f);
      auto account = [&](std::size_t j, const ProbeOut& near) {
        const std::size_t i = si[j];
        const std::uint32_t mat = kind[i] == 0 ? prim_material(t, a.cpu[i].u.x) : q[i].key.z;
        spread[j] = std::max(spread[j], bump_mismatch(a.cpu[i], near, bump_bounds(a.cpu[i], near, fp[i], tex_err_of(mat))));
      };
      for (std::size_t kn = 0; kn < 10; ++kn) {
        // Camera hits: the camera nudged; synthetic points: p nudged.
        std::vector<ProbeIn> cq, pq;
        std::vector<std::size_t> cj, pj;
        for (std::size_t j = 0; j < sq.size(); ++j) {
          if (kind[si[j]] == 0) {
            cq.push_back(sq[j]);
            cj.push_back(j);
          } else {
            ProbeIn e = sq[j];
            e.o_tmax = glm::vec4(nudge_point(glm::vec3(e.o_tmax), kNudges[kn]), e.o_tmax.w);
            pq.push_back(e);
            pj.push_back(j);
          }
        }
        const std::vector<ProbeOut> c1 = probe_cpu_threads(nudged[kn], cq, 2);
        const std::vector<ProbeOut> c2 = probe_cpu_threads(t, pq, 2);
        for (std::size_t j = 0; j < cj.size(); ++j) account(cj[j], c1[j]);
        for (std::size_t j = 0; j < pj.size(); ++j) account(pj[j], c2[j]);
      }
      for (std::size_t j = 0; j < sq.size(); ++j) {
        if (spread[j] >= 0.5f * amount[j]) {
          ++st.excused;
          continue;
        }
        ++st.mismatches;
        st.offend(kind[si[j]] == 0 ? "mismatch (camera hit)" : "mismatch (synthetic point)", sq[j],
                  &a.cpu[si[j]], &a.gpu[si[j]], "bound units " + std::to_string(amount[j]));
      }
    }
    st.inputs += k;
    done += k;
  }
  std::printf("  Bump: %llu of %llu inputs compared (camera hits and ordinary synthetic points); "
              "%llu changed the CPU's frame\n", (unsigned long long)compared,
              (unsigned long long)st.inputs, (unsigned long long)bumped);
  EXPECT_GT(double(bumped), 0.2 * double(st.inputs)) << "few bumped answers";
  st.finish(0.005, "camera (or p) nudge of 1..16 ulps moves the CPU's own answer by half as much");
  for (const auto& [what, count] : st.detail) EXPECT_EQ(count, 0u) << what;
}

}  // namespace
}  // namespace basalt::test
