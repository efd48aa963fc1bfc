// Unit tests of the CPU reference: random numbers, warps, intersection (watertightness,
// self-intersection, grazing rays), BVH traversal and tie-breaking, camera and probe.
#include <gtest/gtest.h>

#include <bit>
#include <cfloat>
#include <cmath>
#include <random>

#include "cpu/camera.h"
#include "cpu/cpu.h"
#include "cpu/lights.h"
#include "cpu/sampling.h"
#include "common/axis_rays.h"
#include "cpu_test_scene.h"

using namespace basalt;
using namespace basalt::cpu;
using basalt::cpu::test_scene::TestScene;

namespace {

/// Deterministic uniform floats in [0,1) for the tests (not the renderer's rng).
struct Rand {
  std::mt19937 gen;
  std::uniform_real_distribution<float> dist{0.0f, 1.0f};
  explicit Rand(unsigned seed) : gen(seed) {}
  float operator()() { return dist(gen); }
  glm::vec3 in_cube() { return glm::vec3((*this)(), (*this)(), (*this)()) * 2.0f - 1.0f; }
  glm::vec3 dir() { return uniform_sphere(glm::vec2((*this)(), (*this)())); }
  /// Direction k of a respawn test around frame f: k < 6 uniform; else grazing, a tangent
  /// direction tilted 1e-2 .. 1e-6 off the plane, above it for odd k, below for even k.
  glm::vec3 respawn_dir(const Frame& f, int k) {
    if (k < 6) return dir();
    const float phi = 6.2831853f * (*this)();
    const float eps = std::pow(10.0f, -2.0f - 4.0f * (*this)()) * (k % 2 ? 1.0f : -1.0f);
    return glm::normalize(f.to_world(glm::vec3(std::cos(phi), std::sin(phi), eps)));
  }
};

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// Scene holding one triangle (single leaf).
TestScene one_triangle(glm::vec3 a, glm::vec3 b, glm::vec3 c) {
  TestScene s;
  const std::uint32_t m = s.diffuse(glm::vec3(0.5f));
  s.mesh({a, b, c}, {glm::uvec3(0, 1, 2)}, m);
  s.finish();
  return s;
}

}  // namespace

// ---- random numbers -------------------------------------------------------------------------

TEST(CpuRng, PinnedValues) {
  // Computed by hand (Python, 32-bit masks) from the pcg4d definition of path-spec section 1.
  EXPECT_EQ(rng(0, 0, 0, 0, 0), 983800.0f * 0x1p-24f);
  EXPECT_EQ(rng(1, 2, 3, 4, 0), 3547853.0f * 0x1p-24f);
  EXPECT_EQ(rng(17, 42, 5, 9, 7), 6135492.0f * 0x1p-24f);
  EXPECT_EQ(rng(1023, 767, 65535, 123, 0xdeadbeefu), 4290265.0f * 0x1p-24f);
}

TEST(CpuRng, RangeAndMean) {
  double sum = 0.0;
  int n = 0;
  for (std::uint32_t px = 0; px < 16; ++px)
    for (std::uint32_t s = 0; s < 64; ++s)
      for (std::uint32_t d = 0; d < 40; ++d) {
        const float u = rng(px, 3, s, d, 11);
        ASSERT_GE(u, 0.0f);
        ASSERT_LT(u, 1.0f);
        sum += u;
        ++n;
      }
  EXPECT_NEAR(sum / n, 0.5, 0.01);
}

// ---- warps ------------------------------------------------------------------------------------

TEST(CpuSampling, ConcentricDiskInUnitDisk) {
  Rand r(1);
  for (int i = 0; i < 10000; ++i) {
    const glm::vec2 d = concentric_disk(glm::vec2(r(), r()));
    ASSERT_LE(glm::length(d), 1.0f + 1e-6f);
  }
  EXPECT_EQ(concentric_disk(glm::vec2(0.5f)), glm::vec2(0.0f));
  EXPECT_NEAR(glm::length(concentric_disk(glm::vec2(1.0f, 0.5f))), 1.0f, 1e-6f);
  EXPECT_NEAR(glm::length(concentric_disk(glm::vec2(0.0f, 0.0f))), 1.0f, 1e-6f);
  // Equal-area: the fraction inside radius 0.5 is 1/4.
  int inside = 0;
  const int n = 40000;
  for (int i = 0; i < n; ++i) inside += glm::length(concentric_disk(glm::vec2(r(), r()))) < 0.5f;
  EXPECT_NEAR(double(inside) / n, 0.25, 0.01);
}

TEST(CpuSampling, UniformTriangleCoversUniformly) {
  Rand r(2);
  glm::dvec3 mean(0.0);
  const int n = 200000;
  int corner = 0;  // fraction in the sub-triangle b0 > 1/2 must be 1/4
  for (int i = 0; i < n; ++i) {
    const glm::vec3 b = uniform_triangle(glm::vec2(r(), r()));
    ASSERT_GE(b.x, 0.0f);
    ASSERT_GE(b.y, 0.0f);
    ASSERT_GE(b.z, -1e-6f);
    ASSERT_NEAR(b.x + b.y + b.z, 1.0f, 1e-6f);
    mean += glm::dvec3(b);
    corner += b.x > 0.5f;
  }
  mean /= double(n);
  EXPECT_NEAR(mean.x, 1.0 / 3.0, 3e-3);
  EXPECT_NEAR(mean.y, 1.0 / 3.0, 3e-3);
  EXPECT_NEAR(mean.z, 1.0 / 3.0, 3e-3);
  EXPECT_NEAR(double(corner) / n, 0.25, 5e-3);
}

TEST(CpuSampling, UniformSphereIsUnit) {
  Rand r(3);
  glm::dvec3 mean(0.0);
  for (int i = 0; i < 20000; ++i) {
    const glm::vec3 w = uniform_sphere(glm::vec2(r(), r()));
    ASSERT_NEAR(glm::length(w), 1.0f, 1e-5f);
    mean += glm::dvec3(w);
  }
  EXPECT_LT(glm::length(mean / 20000.0), 0.02);
}

TEST(CpuSampling, PowerHeuristic) {
  EXPECT_FLOAT_EQ(power_heuristic(1.0f, 1.0f), 0.5f);
  EXPECT_FLOAT_EQ(power_heuristic(2.0f, 1.0f), 0.8f);
  EXPECT_FLOAT_EQ(power_heuristic(1.0f, 2.0f), 0.2f);
  EXPECT_EQ(power_heuristic(INFINITY, 1.0f), 1.0f);
  EXPECT_EQ(power_heuristic(1e30f, 1.0f), 1.0f);  // a^2 overflows: pbrt-v4 returns 1
  EXPECT_EQ(power_heuristic(0.0f, 0.0f), 0.0f);   // no NaN
  EXPECT_EQ(power_heuristic(0.0f, 3.0f), 0.0f);
  EXPECT_EQ(power_heuristic(3.0f, 0.0f), 1.0f);
  EXPECT_NEAR(power_heuristic(0.3f, 0.7f) + power_heuristic(0.7f, 0.3f), 1.0f, 1e-6f);
}

TEST(CpuSampling, DuffFrameOrthonormal) {
  Rand r(4);
  std::vector<glm::vec3> normals = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, -1, 0},
                                    glm::normalize(glm::vec3(1e-4f, 0, -1)),
                                    glm::normalize(glm::vec3(0, 1e-7f, -1))};
  for (int i = 0; i < 10000; ++i) normals.push_back(r.dir());
  for (const glm::vec3& n : normals) {
    const Frame f = Frame::from_z(n);
    ASSERT_TRUE(finite(f.t1) && finite(f.t2));
    ASSERT_NEAR(glm::length(f.t1), 1.0f, 1e-5f);
    ASSERT_NEAR(glm::length(f.t2), 1.0f, 1e-5f);
    ASSERT_NEAR(glm::dot(f.t1, f.t2), 0.0f, 1e-5f);
    ASSERT_NEAR(glm::dot(f.t1, n), 0.0f, 1e-5f);
    ASSERT_NEAR(glm::dot(f.t2, n), 0.0f, 1e-5f);
    // Right-handed: t1 x t2 = n.
    ASSERT_LT(glm::length(glm::cross(f.t1, f.t2) - n), 1e-5f);
    const glm::vec3 w = r.dir();
    ASSERT_LT(glm::length(f.to_world(f.to_local(w)) - w), 1e-5f);
  }
}

// ---- primitive intersection ---------------------------------------------------------------

TEST(CpuIntersect, SphereOutsideInsideTangentMiss) {
  const glm::vec3 c(1, 2, 3);
  // From outside: nearer root.
  PrimHit h = intersect_sphere(c + glm::vec3(0, 0, -5), glm::vec3(0, 0, 1), FLT_MAX, c, 2.0f);
  EXPECT_NEAR(h.t, 3.0f, 1e-5f);
  // Unnormalised direction: t scales.
  h = intersect_sphere(c + glm::vec3(0, 0, -5), glm::vec3(0, 0, 2), FLT_MAX, c, 2.0f);
  EXPECT_NEAR(h.t, 1.5f, 1e-5f);
  // tMax before the hit: miss; behind the origin: miss.
  EXPECT_LT(intersect_sphere(c + glm::vec3(0, 0, -5), glm::vec3(0, 0, 1), 2.9f, c, 2.0f).t, 0.0f);
  EXPECT_LT(intersect_sphere(c + glm::vec3(0, 0, -5), glm::vec3(0, 0, -1), FLT_MAX, c, 2.0f).t, 0.0f);
  // From inside: the far root.
  h = intersect_sphere(c + glm::vec3(0.5f, 0, 0), glm::vec3(1, 0, 0), FLT_MAX, c, 2.0f);
  EXPECT_NEAR(h.t, 1.5f, 1e-5f);
  // Miss beside.
  EXPECT_LT(intersect_sphere(c + glm::vec3(2.01f, 0, -5), glm::vec3(0, 0, 1), FLT_MAX, c, 2.0f).t, 0.0f);
  // Tangent: a hit at the tangent point or a miss, never NaN.
  h = intersect_sphere(c + glm::vec3(2.0f, 0, -5), glm::vec3(0, 0, 1), FLT_MAX, c, 2.0f);
  EXPECT_TRUE(h.t < 0.0f || std::fabs(h.t - 5.0f) < 1e-2f) << h.t;
  // Degenerate zero radius and zero direction: misses.
  EXPECT_LT(intersect_sphere(glm::vec3(0, 0, -5), glm::vec3(0, 0, 1), FLT_MAX, glm::vec3(0.0f), 0.0f).t,
            FLT_MAX);
  EXPECT_LT(intersect_sphere(glm::vec3(0, 0, -5), glm::vec3(0.0f), FLT_MAX, glm::vec3(0.0f), 1.0f).t, 0.0f);
}

TEST(CpuIntersect, SphereHugeAndTinyRadii) {
  Rand r(5);
  for (float radius : {1e-4f, 1e-2f, 1.0f, 1e3f, 1e6f}) {
    for (int i = 0; i < 200; ++i) {
      const glm::vec3 c = radius * 3.0f * r.in_cube();
      const glm::vec3 dir = r.dir();
      const glm::vec3 o = c - 3.0f * radius * dir;  // outside, aimed at the centre
      PrimHit h = intersect_sphere(o, dir, FLT_MAX, c, radius);
      ASSERT_NEAR(h.t, 2.0f * radius, 1e-4f * radius) << radius;
      // From the centre: exactly one radius.
      h = intersect_sphere(c, dir, FLT_MAX, c, radius);
      ASSERT_NEAR(h.t, radius, 1e-4f * radius) << radius;
      // Offset sideways by 1.01 radius: miss.
      const glm::vec3 side = glm::normalize(glm::cross(dir, r.dir()));
      h = intersect_sphere(o + 1.01f * radius * side, dir, FLT_MAX, c, radius);
      ASSERT_LT(h.t, 0.0f);
    }
  }
}

TEST(CpuIntersect, TriangleHitMissEdge) {
  const glm::vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  PrimHit h = intersect_triangle(glm::vec3(0.25f, 0.25f, 1), glm::vec3(0, 0, -1), FLT_MAX, a, b, c);
  EXPECT_NEAR(h.t, 1.0f, 1e-6f);
  EXPECT_NEAR(h.b1, 0.25f, 1e-6f);  // barycentric of b: x
  EXPECT_NEAR(h.b2, 0.25f, 1e-6f);  // barycentric of c: y
  // From below (back face): still a hit.
  h = intersect_triangle(glm::vec3(0.1f, 0.2f, -2), glm::vec3(0, 0, 1), FLT_MAX, a, b, c);
  EXPECT_NEAR(h.t, 2.0f, 1e-6f);
  EXPECT_NEAR(h.b1, 0.1f, 1e-6f);
  EXPECT_NEAR(h.b2, 0.2f, 1e-6f);
  // Outside the triangle, behind the origin, beyond tMax: misses.
  EXPECT_LT(intersect_triangle(glm::vec3(0.6f, 0.6f, 1), glm::vec3(0, 0, -1), FLT_MAX, a, b, c).t, 0.0f);
  EXPECT_LT(intersect_triangle(glm::vec3(0.2f, 0.2f, 1), glm::vec3(0, 0, 1), FLT_MAX, a, b, c).t, 0.0f);
  EXPECT_LT(intersect_triangle(glm::vec3(0.2f, 0.2f, 1), glm::vec3(0, 0, -1), 0.999f, a, b, c).t, 0.0f);
  // tMax is exclusive.
  EXPECT_LT(intersect_triangle(glm::vec3(0.2f, 0.2f, 1), glm::vec3(0, 0, -1), 1.0f, a, b, c).t, 0.0f);
  // Exactly on an edge and on a vertex: hits (edge functions of 0 are inside).
  h = intersect_triangle(glm::vec3(0.5f, 0.0f, 1), glm::vec3(0, 0, -1), FLT_MAX, a, b, c);
  EXPECT_NEAR(h.t, 1.0f, 1e-6f);
  h = intersect_triangle(glm::vec3(0.5f, 0.5f, 1), glm::vec3(0, 0, -1), FLT_MAX, a, b, c);
  EXPECT_NEAR(h.t, 1.0f, 1e-6f);
  h = intersect_triangle(glm::vec3(0.0f, 0.0f, 1), glm::vec3(0, 0, -1), FLT_MAX, a, b, c);
  EXPECT_NEAR(h.t, 1.0f, 1e-6f);
  // Ray in the triangle's plane: det == 0, miss.
  EXPECT_LT(intersect_triangle(glm::vec3(-1, 0.2f, 0), glm::vec3(1, 0, 0), FLT_MAX, a, b, c).t, 0.0f);
}

TEST(CpuIntersect, DegenerateTriangleMissesWithoutNaN) {
  Rand r(6);
  const glm::vec3 p(0.3f, -0.2f, 0.1f);
  const std::vector<std::array<glm::vec3, 3>> tris = {
      {p, p, p},                                                            // a point
      {glm::vec3(0, 0, 0), glm::vec3(1, 1, 1), glm::vec3(2, 2, 2)},         // collinear
      {glm::vec3(0, 0, 0), glm::vec3(1, 0, 0), glm::vec3(1, 0, 0)},         // repeated vertex
      {glm::vec3(0, 0, 0), glm::vec3(0, 1, 0), glm::vec3(0, 0.5f, 0)}};     // on a line
  for (const auto& t : tris) {
    for (int i = 0; i < 2000; ++i) {
      const glm::vec3 target = t[0] + r() * (t[1] - t[0]) + r() * (t[2] - t[0]);
      const glm::vec3 o = target + 2.0f * r.dir();
      const PrimHit h = intersect_triangle(o, target - o, FLT_MAX, t[0], t[1], t[2]);
      ASSERT_LT(h.t, 0.0f);
      ASSERT_FALSE(std::isnan(h.b1) || std::isnan(h.b2));
    }
  }
}

// ---- BVH and closed meshes --------------------------------------------------------------

TEST(CpuIntersect, WatertightCubeAndTetrahedron) {
  Rand r(7);
  std::vector<glm::vec3> P;
  std::vector<glm::uvec3> idx;
  for (int shape = 0; shape < 2; ++shape) {
    for (float scale : {1e-3f, 1.0f, 1e4f}) {
      if (shape == 0) {
        test_scene::cube(P, idx, scale, glm::vec3(0.3f, -0.7f, 0.1f) * scale);
      } else {
        // Irregular tetrahedron (shared vertices, 4 faces).
        P = {glm::vec3(0.1f, 0.2f, -0.3f), glm::vec3(1.3f, -0.1f, 0.2f),
             glm::vec3(-0.4f, 1.1f, 0.3f), glm::vec3(0.2f, 0.3f, 1.4f)};
        for (auto& v : P) v *= scale;
        idx = {glm::uvec3(0, 2, 1), glm::uvec3(0, 1, 3), glm::uvec3(0, 3, 2), glm::uvec3(1, 2, 3)};
      }
      // Random rigid motion so that edges are not axis aligned.
      const glm::vec3 axis = r.dir();
      const float ang = 6.28f * r();
      const glm::mat3 rot = glm::mat3(glm::cos(ang)) + glm::sin(ang) * glm::mat3(glm::vec3(0, axis.z, -axis.y),
                                                                              glm::vec3(-axis.z, 0, axis.x),
                                                                              glm::vec3(axis.y, -axis.x, 0)) +
                            (1.0f - glm::cos(ang)) * glm::outerProduct(axis, axis);
      for (auto& v : P) v = rot * v;
      glm::vec3 centroid(0.0f);
      for (auto& v : P) centroid += v / float(P.size());
      // Convex solid: inside iff behind every face plane (outward = away from the centroid).
      auto inside = [&](glm::dvec3 x, double margin) {
        for (const glm::uvec3& f : idx) {
          const glm::dvec3 a(P[f.x]), b(P[f.y]), c(P[f.z]);
          glm::dvec3 n = glm::normalize(glm::cross(b - a, c - a));
          if (glm::dot(n, glm::dvec3(centroid) - a) > 0) n = -n;
          if (glm::dot(n, x - a) > -margin) return false;
        }
        return true;
      };
      for (std::uint32_t leaf : {64u, 1u}) {  // one leaf with all prims, and one prim per leaf
        TestScene s;
        s.mesh(P, idx, s.diffuse(glm::vec3(0.5f)));
        s.finish(leaf);
        int failures = 0;
        for (int i = 0; i < 20000; ++i) {
          // Aim at a point on a random edge or exactly at a vertex.
          const glm::uvec3 f = idx[std::size_t(r() * idx.size()) % idx.size()];
          const int e = int(r() * 3) % 3;
          const glm::vec3 v0 = P[f[e]], v1 = P[f[(e + 1) % 3]];
          const glm::vec3 target = (i % 4 == 0) ? v0 : v0 + r() * (v1 - v0);
          // From the inside (centroid) and from outside.
          const Ray in{centroid, target - centroid, FLT_MAX};
          const glm::vec3 o = target + 3.0f * scale * r.dir();
          const Ray out{o, target - o, FLT_MAX};
          const Hit hi = intersect_closest(s.t, in);
          failures += !hi.valid();
          failures += !intersect_any(s.t, in);
          // From outside the ray either enters the solid there (and must hit) or only touches
          // it along an edge or at a vertex (either answer is right).
          const Hit ho = intersect_closest(s.t, out);
          if (ho.valid()) {
            ASSERT_TRUE(finite(glm::vec3(ho.t, ho.b1, ho.b2)));
          } else {
            const glm::dvec3 beyond = glm::dvec3(target) + 1e-3 * double(scale) *
                                                                glm::normalize(glm::dvec3(out.d));
            failures += inside(beyond, 1e-5 * double(scale));
          }
        }
        EXPECT_EQ(failures, 0) << "shape " << shape << " scale " << scale << " leaf " << leaf;
      }
    }
  }
}

TEST(CpuIntersect, ClosestMatchesBruteForceAndTieBreak) {
  Rand r(8);
  TestScene s;
  const std::uint32_t m = s.diffuse(glm::vec3(0.5f));
  std::vector<glm::vec3> P;
  std::vector<glm::uvec3> idx;
  for (int i = 0; i < 60; ++i) {
    const glm::vec3 c = 5.0f * r.in_cube();
    const std::uint32_t b = std::uint32_t(P.size());
    P.push_back(c + r.in_cube());
    P.push_back(c + r.in_cube());
    P.push_back(c + r.in_cube());
    idx.push_back(glm::uvec3(b, b + 1, b + 2));
  }
  s.mesh(P, idx, m);
  for (int i = 0; i < 30; ++i) s.sphere(5.0f * r.in_cube(), 0.2f + r(), m);
  s.finish(2);
  ASSERT_GT(s.t.nodes.size(), 10u);
  // The four-wide tree the renderer walks, then the binary tree alone.
  SceneTables binary = s.t;
  binary.cpu_wide.reset();
  for (int i = 0; i < 6000; ++i) {
    const SceneTables& t = i % 2 ? binary : s.t;
    const Ray ray{8.0f * r.in_cube(), r.dir(), i % 3 == 0 ? 4.0f : FLT_MAX};
    Hit brute;
    brute.t = ray.tmax;
    for (std::uint32_t ref : t.prim_refs) {
      const PrimHit h = intersect_prim(t, ref, ray.o, ray.d, ray.tmax);
      if (h.t > 0 && (h.t < brute.t || (h.t == brute.t && ref < brute.prim))) {
        brute.t = h.t;
        brute.prim = ref;
      }
    }
    const Hit h = intersect_closest(t, ray);
    ASSERT_EQ(h.prim, brute.prim) << (i % 2 ? "binary" : "wide");
    if (h.valid()) {
      ASSERT_EQ(h.t, brute.t);
    }
    ASSERT_EQ(intersect_any(t, ray), brute.valid());
  }
  // Tie break: duplicated triangles in two leaves in either order; the smaller ref wins.
  for (int order = 0; order < 2; ++order) {
    TestScene d;
    const glm::vec3 a(-1, -1, 2), b(1, -1, 2), c(0, 1, 2);
    d.mesh({a, b, c, a, b, c}, {glm::uvec3(0, 1, 2), glm::uvec3(3, 4, 5)}, d.diffuse(glm::vec3(1)));
    d.finish(1);
    ASSERT_EQ(d.t.nodes.size(), 3u);
    if (order) {
      std::swap(d.t.nodes[1], d.t.nodes[2]);
      d.t.cpu_wide = build_cpu_wide_bvh(d.t);
    }
    const Hit h = intersect_closest(d.t, Ray{glm::vec3(0.1f, 0.0f, 0.0f), glm::vec3(0, 0, 1), FLT_MAX});
    ASSERT_TRUE(h.valid());
    EXPECT_EQ(h.prim, 0u);
    EXPECT_NEAR(h.t, 2.0f, 1e-6f);
  }
}

// Rays along an axis (a direction component of +-0 or below 1e-20) whose origin lies in a face
// plane of the box ahead: the axis bounds nothing while the origin is in the slab, faces
// included (path-spec 3). With 1 / d's finite stand-in alone they left the slab at t = 0 and
// missed the vertex on that face (found by Stress.Closest). One triangle: its box is the BVH's.
TEST(CpuIntersect, AxisRaysInAFacePlaneMeetThePrimitivesAhead) {
  TestScene s;
  s.mesh(basalt::test::axis_ray_triangle(), {glm::uvec3(0, 1, 2)}, s.diffuse(glm::vec3(0.5f)));
  s.finish(1);
  SceneTables binary = s.t;
  binary.cpu_wide.reset();
  for (const SceneTables* t : {&s.t, &binary})
    for (const auto& c : basalt::test::axis_ray_cases()) {
      const Hit h = intersect_closest(*t, Ray{c.o, c.d, FLT_MAX});
      EXPECT_EQ(h.valid(), c.hit) << c.o.x << " " << c.o.y << " " << c.o.z;
      if (c.hit) {
        EXPECT_EQ(h.t, 5.0f);
      }
      EXPECT_EQ(intersect_any(*t, Ray{c.o, c.d, 6.0f}), c.hit);
      EXPECT_FALSE(intersect_any(*t, Ray{c.o, c.d, 4.0f}));  // ends before the triangle
    }
}

TEST(CpuIntersect, EmptyScene) {
  TestScene s;
  s.finish();
  EXPECT_TRUE(s.t.nodes.empty());
  EXPECT_FALSE(intersect_closest(s.t, Ray{glm::vec3(0), glm::vec3(0, 0, 1), FLT_MAX}).valid());
  EXPECT_FALSE(intersect_any(s.t, Ray{glm::vec3(0), glm::vec3(0, 0, 1), FLT_MAX}));
  EXPECT_EQ(path_radiance(s.t, 3, 4, 0), glm::vec3(0.0f));
}

// ---- self-intersection ----------------------------------------------------------------------

TEST(CpuSpawn, OffsetRayPinnedValues) {
  // path-spec section 5: d = m 2^-17, then p + d n, each operation rounded to float
  // (computed by hand in Python with float32 rounding after every operation).
  const glm::vec3 n = safe_normalize(glm::vec3(-1, 1, 1));
  EXPECT_EQ(n, glm::vec3(-0x1.279a74p-1f, 0x1.279a74p-1f, 0x1.279a74p-1f));
  const glm::vec3 q = offset_ray(glm::vec3(-3.0f, 5.0f, 7.0f), n, 1000.0f);  // d = 0x1.f4p-8
  EXPECT_EQ(q, glm::vec3(-0x1.809056p+1f, 0x1.40482cp+2f, 0x1.c0482cp+2f));
  // Tiny magnitudes: the offset scales down with m (no absolute floor as in Ray Tracing Gems).
  const glm::vec3 t = offset_ray(glm::vec3(1e-6f, 0.0f, -2e-6f), glm::vec3(1, 0, 0), 3e-6f);
  EXPECT_EQ(t, glm::vec3(0x1.0c710cp-20f, 0.0f, -2e-6f));
  // Exact cases: a zero normal or m = 0 leaves p unchanged; powers of two are exact.
  EXPECT_EQ(offset_ray(glm::vec3(1, 2, 3), glm::vec3(0.0f), 1e6f), glm::vec3(1, 2, 3));
  EXPECT_EQ(offset_ray(glm::vec3(1, 2, 3), glm::vec3(0, 0, -1), 0.0f), glm::vec3(1, 2, 3));
  EXPECT_EQ(offset_ray(glm::vec3(0, 0, 0), glm::vec3(0, -1, 0), 4.0f), glm::vec3(0, -0x1p-15f, 0));
}

TEST(CpuSpawn, MagnitudeBounds) {
  // Triangle: max component of abs(b0 p0) + abs(b1 p1) + abs(b2 p2) (section 5).
  const glm::vec3 p0(1, -2, 3), p1(-4, 5, -6), p2(7, 8, -9);
  EXPECT_EQ(triangle_magnitude(p0, p1, p2, 0.25f, 0.25f, 0.5f), 6.75f);  // (4.75, 5.75, 6.75)
  // Not |p|: the wall x = 0 of a large scene gets the bound of its y and z.
  EXPECT_EQ(triangle_magnitude(glm::vec3(0, 0, 500), glm::vec3(0, 0, 0), glm::vec3(0, 400, 0), 0.5f,
                               0.25f, 0.25f),
            250.0f);
  // Cancelling terms still count: p = 0 here, m = 2.
  EXPECT_EQ(triangle_magnitude(glm::vec3(-2, 0, 0), glm::vec3(2, 0, 0), glm::vec3(0, 0, 0), 0.5f, 0.5f,
                               0.0f),
            2.0f);
  // Sphere: max(|c.x|, |c.y|, |c.z|) + r, the same for every point of the sphere.
  EXPECT_EQ(sphere_magnitude(glm::vec3(-3.0f, 250.0f, -0.5f), 2.0f), 252.0f);
  TestScene s;
  const std::uint32_t m = s.diffuse(glm::vec3(0.5f));
  s.mesh({p0, p1, p2}, {glm::uvec3(0, 1, 2)}, m);
  s.sphere(glm::vec3(-300.0f, 2.0f, 1.0f), 0.5f, m);
  s.finish();
  EXPECT_EQ(triangle_geometry(s.t, 0, 0.25f, 0.25f, 0.5f).m, 6.75f);
  EXPECT_EQ(sphere_geometry(s.t, 0, glm::vec3(-300.0f, 2.0f, 2.0f)).m, 300.5f);
  // The probe's RESPAWN and the integrator use the hit's bound.
  const Ray ray{glm::vec3(-300.0f, 2.0f, 5.0f), glm::vec3(0, 0, -1), FLT_MAX};
  const Hit h = intersect_closest(s.t, ray);
  ASSERT_TRUE(h.valid());
  EXPECT_EQ(surface_point(s.t, ray, h).g.m, 300.5f);
}

TEST(CpuSpawn, TrianglesNeverRehitThemselves) {
  Rand r(9);
  int tested = 0;
  for (int i = 0; i < 40000; ++i) {
    const float scale = std::pow(10.0f, -4.0f + 10.0f * r());  // 1e-4 .. 1e6
    const glm::vec3 c = 4.0f * scale * r.in_cube();
    TestScene s = one_triangle(c + scale * r.in_cube(), c + scale * r.in_cube(), c + scale * r.in_cube());
    const gpu::Triangle& T = s.t.triangles[0];
    const glm::vec3 p0(s.t.vertices[T.v0].p_u), p1(s.t.vertices[T.v1].p_u), p2(s.t.vertices[T.v2].p_u);
    const glm::vec3 nrm = glm::normalize(glm::cross(p1 - p0, p2 - p0));
    // Hit an interior point from a random side.
    const glm::vec3 b = 0.05f + 0.9f * uniform_triangle(glm::vec2(r(), r()));
    const glm::vec3 target = (b.x * p0 + b.y * p1 + b.z * p2) / (b.x + b.y + b.z);
    const glm::vec3 o = target + scale * (r() < 0.5f ? 1.0f : -1.0f) * glm::normalize(nrm + 0.5f * r.dir());
    const Ray ray{o, target - o, FLT_MAX};
    const Hit h = intersect_closest(s.t, ray);
    if (!h.valid()) continue;  // a sliver may be missed at its edges; nothing to test
    const SurfacePoint sp = surface_point(s.t, ray, h);
    const Frame f = Frame::from_z(sp.g.ng);
    for (int k = 0; k < 12; ++k) {
      const glm::vec3 wi = r.respawn_dir(f, k);
      const Hit h2 = intersect_closest(s.t, spawn_ray(sp.g.p, sp.g.ng, sp.g.m, wi));
      ASSERT_FALSE(h2.valid()) << "scale " << scale << " t " << h2.t << " dot " << glm::dot(wi, sp.g.ng);
      ++tested;
    }
  }
  EXPECT_GT(tested, 400000);
}

// Mixed magnitudes: a wall in the plane x = 0 of a scene of size ~500 (the Cornell box's
// green wall and floor). The watertight test rounds at ~1e-4 in x there; a per-point offset
// (Waechter & Binder's absolute 1/65536 for |x| < 1/32) let about 0.2% of the spawned rays
// re-hit their own triangle. Section 5's offset scales with the triangle's bound m (up to
// ~559 here, so up to ~4e-3).
TEST(CpuSpawn, MixedMagnitudeWallNeverRehitsItself) {
  Rand r(13);
  TestScene s;
  s.mesh({glm::vec3(0, 0, 559.2f), glm::vec3(0, 0, 0), glm::vec3(0, 548.8f, 0), glm::vec3(0, 548.8f, 559.2f)},
         {glm::uvec3(0, 1, 2), glm::uvec3(0, 2, 3)}, s.diffuse(glm::vec3(0.5f)));
  s.finish();
  int self = 0;
  for (int i = 0; i < 20000; ++i) {
    const std::uint32_t tri = i & 1;
    const glm::vec3 b = uniform_triangle(glm::vec2(r(), r()));
    const SurfaceGeometry g = triangle_geometry(s.t, tri, b.x, b.y, b.z);
    const Ray ray = spawn_ray(g.p, g.ng, g.m, r.dir());
    self += intersect_prim(s.t, tri, ray.o, ray.d, ray.tmax).t > 0.0f;
  }
  EXPECT_EQ(self, 0);
}

TEST(CpuSpawn, SpheresNeverRehitNearSide) {
  Rand r(10);
  for (int i = 0; i < 40000; ++i) {
    const float scale = std::pow(10.0f, -4.0f + 10.0f * r());
    const float radius = scale * (0.5f + r());
    const glm::vec3 c = 4.0f * scale * r.in_cube();
    TestScene s;
    s.sphere(c, radius, s.diffuse(glm::vec3(0.5f)), r() < 0.3f ? gpu::SHAPE_FLAG_FLIP_NORMAL : 0u);
    s.finish();
    // Hit from outside or from inside.
    const glm::vec3 n0 = r.dir();
    const glm::vec3 target = c + radius * n0;
    const bool from_inside = r() < 0.3f;
    const glm::vec3 o = from_inside ? c + 0.3f * radius * r.in_cube()
                                    : target + radius * glm::normalize(n0 + 0.7f * r.dir());
    const Ray ray{o, target - o, FLT_MAX};
    const Hit h = intersect_closest(s.t, ray);
    ASSERT_TRUE(h.valid());
    const SurfacePoint sp = surface_point(s.t, ray, h);
    const glm::vec3 out = (sp.g.p - c) / radius;  // outward unit normal
    const Frame f = Frame::from_z(out);
    for (int k = 0; k < 12; ++k) {
      const glm::vec3 wi = r.respawn_dir(f, k);
      const Hit h2 = intersect_closest(s.t, spawn_ray(sp.g.p, sp.g.ng, sp.g.m, wi));
      const float cos_in = -glm::dot(wi, out);  // > 0: into the sphere
      if (cos_in <= 0.0f) {
        ASSERT_FALSE(h2.valid()) << "scale " << scale << " cos " << cos_in << " t " << h2.t / radius;
      } else if (cos_in > 0.05f) {
        // Into the sphere: the far side, about the chord length 2 r cos away (the origin
        // offset of section 5, at most m 2^-17 <= ~11 r 2^-17 here, changes it a bit).
        ASSERT_TRUE(h2.valid());
        ASSERT_GT(h2.t, 0.05f * radius);
        const Ray sr = spawn_ray(sp.g.p, sp.g.ng, sp.g.m, wi);
        ASSERT_NEAR(glm::length(sr.o + h2.t * sr.d - c), radius, 1e-3f * radius);
        ASSERT_GT(glm::dot(sr.o + h2.t * sr.d - sp.g.p, -out), 0.5f * radius * cos_in * cos_in);
      } else if (h2.valid()) {
        // Grazing into the sphere: a hit, if any, is the far end of a short chord, not p.
        ASSERT_GT(h2.t, 0.5f * 2.0f * radius * cos_in) << "scale " << scale << " cos " << cos_in;
      }
    }
  }
}

// Both ends of section 5's scale in one scene (and one BVH): spheres of radius 1e-6 .. 1e-5
// near the origin (a fixed 1/65536 offset jumps right across them, so rays into them started
// outside the far side) and geometry at ~1e6 (spheres, a tilted quad, a huge tilted wall).
// Every respawned ray leaves its primitive without re-hitting it; rays into a sphere meet
// its far side, not the point they left.
TEST(CpuSpawn, TinySpheresAndFarGeometryNeverRehitThemselves) {
  Rand r(14);
  TestScene s;
  const std::uint32_t mat = s.diffuse(glm::vec3(0.5f));
  std::vector<std::uint32_t> refs;
  // Disjoint tiny spheres with centres within 1e-4 of the origin, the first at the origin.
  std::vector<glm::vec4> tiny;
  while (tiny.size() < 24) {
    const float radius = std::pow(10.0f, -6.0f + r());
    const glm::vec3 c = tiny.empty() ? glm::vec3(0.0f) : 1e-4f * r.in_cube();
    bool overlap = false;
    for (const glm::vec4& t : tiny) overlap |= glm::length(c - glm::vec3(t)) < 1.1f * (radius + t.w);
    if (overlap) continue;
    tiny.push_back(glm::vec4(c, radius));
    const std::uint32_t flags = tiny.size() % 3 == 0 ? gpu::SHAPE_FLAG_FLIP_NORMAL : 0u;
    refs.push_back(s.sphere(c, radius, mat, flags) | gpu::PRIM_SPHERE_BIT);
  }
  refs.push_back(s.sphere(glm::vec3(1e6f, 2e5f, -3e5f), 1e4f, mat) | gpu::PRIM_SPHERE_BIT);
  refs.push_back(s.sphere(glm::vec3(-7e5f, 1.2e6f, 5e5f), 1e3f, mat, gpu::SHAPE_FLAG_FLIP_NORMAL) |
                 gpu::PRIM_SPHERE_BIT);
  const glm::vec3 qc(1e6f, 1e6f, -1e6f), qa(700.0f, 300.0f, -200.0f), qb(100.0f, -400.0f, 900.0f);
  std::uint32_t tri = std::uint32_t(s.t.triangles.size());
  s.mesh({qc - qa - qb, qc + qa - qb, qc + qa + qb, qc - qa + qb}, {glm::uvec3(0, 1, 2), glm::uvec3(0, 2, 3)},
         mat);
  refs.push_back(tri++);
  refs.push_back(tri++);
  s.mesh({glm::vec3(-2e6f, -1e6f, -2e6f), glm::vec3(2e6f, -0.9e6f, -2e6f), glm::vec3(2e6f, -1.1e6f, 2e6f),
          glm::vec3(-2e6f, -1.3e6f, 2e6f)},
         {glm::uvec3(0, 1, 2), glm::uvec3(0, 2, 3)}, mat);
  refs.push_back(tri++);
  refs.push_back(tri++);
  s.finish();

  int tested = 0;
  for (const std::uint32_t ref : refs) {
    const bool sphere = ref & gpu::PRIM_SPHERE_BIT;
    for (int i = 0; i < 300; ++i) {
      glm::vec3 o, target, c(0.0f);
      float radius = 0.0f;
      if (sphere) {
        const gpu::Sphere& S = s.t.spheres[ref & gpu::PRIM_INDEX_MASK];
        c = glm::vec3(S.center_radius);
        radius = S.center_radius.w;
        const glm::vec3 n0 = r.dir();
        target = c + radius * n0;
        o = r() < 0.3f ? c + 0.3f * radius * r.in_cube()
                       : target + radius * glm::normalize(n0 + 0.7f * r.dir());
      } else {
        const gpu::Triangle& T = s.t.triangles[ref];
        const glm::vec3 p0(s.t.vertices[T.v0].p_u), p1(s.t.vertices[T.v1].p_u), p2(s.t.vertices[T.v2].p_u);
        const glm::vec3 nrm = glm::normalize(glm::cross(p1 - p0, p2 - p0));
        const glm::vec3 b = 0.05f + 0.9f * uniform_triangle(glm::vec2(r(), r()));
        target = (b.x * p0 + b.y * p1 + b.z * p2) / (b.x + b.y + b.z);
        o = target + glm::length(p1 - p0) * (r() < 0.5f ? 1.0f : -1.0f) * glm::normalize(nrm + 0.5f * r.dir());
      }
      const Ray ray{o, target - o, FLT_MAX};
      const PrimHit ph = intersect_prim(s.t, ref, ray.o, ray.d, ray.tmax);
      ASSERT_GT(ph.t, 0.0f) << "ref " << ref;
      const SurfacePoint sp = surface_point(s.t, ray, Hit{ph.t, ref, ph.b1, ph.b2});
      const glm::vec3 out = sphere ? (sp.g.p - c) / radius : sp.g.ng;  // outward for spheres
      const Frame f = Frame::from_z(out);
      for (int k = 0; k < 12; ++k) {
        const glm::vec3 wi = r.respawn_dir(f, k);
        const Ray sr = spawn_ray(sp.g.p, sp.g.ng, sp.g.m, wi);
        const PrimHit self = intersect_prim(s.t, ref, sr.o, sr.d, sr.tmax);
        const float cos_in = -glm::dot(wi, out);  // > 0: into a sphere
        if (!sphere || cos_in <= 0.0f) {
          ASSERT_LE(self.t, 0.0f) << "ref " << ref << " t " << self.t << " cos " << -cos_in;
          const Hit h2 = intersect_closest(s.t, sr);
          ASSERT_NE(h2.prim, ref);
        } else if (cos_in > 0.05f) {
          ASSERT_GT(self.t, radius * cos_in) << "ref " << ref << " cos " << cos_in;
        } else if (self.t > 0.0f) {
          ASSERT_GT(self.t, radius * cos_in) << "ref " << ref << " cos " << cos_in;
        }
        ++tested;
      }
    }
  }
  EXPECT_EQ(tested, int(refs.size()) * 300 * 12);
}

TEST(CpuSpawn, GrazingRaysAreFinite) {
  Rand r(11);
  std::vector<glm::vec3> P;
  std::vector<glm::uvec3> idx;
  test_scene::cube(P, idx);
  TestScene s;
  const std::uint32_t m = s.diffuse(glm::vec3(0.5f));
  s.mesh(P, idx, m);
  s.sphere(glm::vec3(3, 0, 0), 1.0f, m);
  s.finish(1);
  for (int i = 0; i < 5000; ++i) {
    // Rays in a face plane of the cube and tangent to the sphere.
    Ray ray;
    if (i % 2) {
      ray = Ray{glm::vec3(-3.0f, 2.0f * r() - 1.0f, 1.0f), glm::vec3(1.0f, 0.1f * (r() - 0.5f), 0.0f), FLT_MAX};
    } else {
      const glm::vec3 d = r.dir();
      const glm::vec3 side = glm::normalize(glm::cross(d, r.dir()));
      ray = Ray{glm::vec3(3, 0, 0) + side - 5.0f * d, d, FLT_MAX};
    }
    const Hit h = intersect_closest(s.t, ray);
    if (h.valid()) {
      ASSERT_TRUE(std::isfinite(h.t) && h.t > 0.0f);
      ASSERT_TRUE(std::isfinite(h.b1) && std::isfinite(h.b2));
      const SurfacePoint sp = surface_point(s.t, ray, h);
      ASSERT_TRUE(finite(sp.g.p) && finite(sp.g.ng) && finite(sp.frame.t1));
    }
  }
}

// ---- camera, lights and probe -----------------------------------------------------------------

TEST(CpuCamera, PinholeAndThinLens) {
  TestScene s(4, 2);
  s.t.globals.screen = glm::vec4(-2.0f, 2.0f, -1.0f, 1.0f);
  s.finish();
  // Box filter radius 0.5: every ray of pixel (0, 0) lies within that pixel's footprint.
  for (std::uint32_t k = 0; k < 64; ++k) {
    const Ray c = camera_ray(s.t, 0, 0, k);
    EXPECT_EQ(c.o, glm::vec3(0.0f));
    EXPECT_NEAR(glm::length(c.d), 1.0f, 1e-6f);
    const glm::vec2 sxy = glm::vec2(c.d) / c.d.z;
    EXPECT_GE(sxy.x, -2.0f - 1e-6f);
    EXPECT_LE(sxy.x, -1.0f + 1e-6f);
    EXPECT_GE(sxy.y, 0.0f - 1e-6f);  // top row is +y
    EXPECT_LE(sxy.y, 1.0f + 1e-6f);
  }
  // Thin lens: rays of one pixel meet at the focal plane at the pinhole ray's point.
  s.t.globals.lens = glm::vec4(0.5f, 0.2f, 3.0f, 0.0f);
  s.t.globals.filter_radius = glm::vec4(0.0f);  // no filter jitter
  s.t.globals.world_from_camera = glm::mat4(1.0f);
  s.t.globals.world_from_camera[3] = glm::vec4(1.0f, 2.0f, 3.0f, 1.0f);
  glm::vec3 focus(0.0f);
  for (std::uint32_t k = 0; k < 32; ++k) {
    const Ray c = camera_ray(s.t, 2, 1, k);
    EXPECT_NEAR(c.o.z, 3.0f, 1e-6f);
    EXPECT_LE(glm::length(glm::vec2(c.o) - glm::vec2(1.0f, 2.0f)), 0.2f + 1e-6f);
    const glm::vec3 q = c.o + (3.0f / c.d.z) * c.d;
    if (k == 0) focus = q;
    EXPECT_LT(glm::length(q - focus), 1e-5f);
  }
}

// The differentials (spec section 2 step 6) share the ray's filter and lens sample: the main
// ray is camera_ray's bit for bit, the differential origins are the ray's lens point, and each
// differential ray is one pixel over on the z = 1 plane (pinhole) or the focal plane (thin lens).
TEST(CpuCamera, DifferentialsShareTheSample) {
  TestScene s(4, 2);
  s.t.globals.screen = glm::vec4(-2.0f, 2.0f, -1.0f, 1.0f);
  s.finish();
  for (float lens_radius : {0.0f, 0.2f}) {
    s.t.globals.lens = glm::vec4(0.5f, lens_radius, 3.0f, 0.0f);
    s.t.globals.world_from_camera = glm::mat4(1.0f);
    s.t.globals.world_from_camera[3] = glm::vec4(1.0f, 2.0f, 3.0f, 1.0f);
    for (std::uint32_t k = 0; k < 32; ++k) {
      const Ray r = camera_ray(s.t, 1, 1, k);
      const CameraRay c = camera_ray_differential(s.t, 1, 1, k);
      EXPECT_EQ(c.o, r.o);
      EXPECT_EQ(c.d, r.d);
      EXPECT_EQ(c.rx_o, c.o);
      EXPECT_EQ(c.ry_o, c.o);
      EXPECT_NEAR(glm::length(c.rx_d), 1.0f, 1e-6f);
      EXPECT_NEAR(glm::length(c.ry_d), 1.0f, 1e-6f);
      // One pixel is 4 / 4 * tanHalf = 0.5 on the z = 1 plane in x, 2 / 2 * 0.5 in y; with a
      // thin lens the step is measured on the focal plane (z = 3), where it is 3 times that.
      const float scale = lens_radius > 0.0f ? 3.0f : 1.0f;
      auto at = [&](glm::vec3 o, glm::vec3 d) { return o + (scale / d.z) * d; };
      const glm::vec3 p = at(c.o, c.d), px = at(c.rx_o, c.rx_d), py = at(c.ry_o, c.ry_d);
      EXPECT_NEAR(px.x - p.x, 0.5f * scale, 1e-5f);
      EXPECT_NEAR(px.y - p.y, 0.0f, 1e-5f);
      EXPECT_NEAR(py.x - p.x, 0.0f, 1e-5f);
      EXPECT_NEAR(py.y - p.y, -0.5f * scale, 1e-5f);
    }
  }
}

TEST(CpuCamera, GaussianTableSampling) {
  TestScene s(8, 8);
  const std::uint32_t N = 4;
  s.t.globals.counts.z = gpu::FILTER_GAUSSIAN;
  s.t.globals.counts.w = N;
  s.t.globals.filter_radius = glm::vec4(1.5f, 1.5f, 0, 0);
  // x: all mass in bin 1 ([-0.75, 0]); y: bins 2 and 3 with 1/2 each.
  s.t.filter_cdf = {0.0f, 0.0f, 1.0f, 1.0f, 1.0f, 0.0f, 0.0f, 0.0f, 0.5f, 1.0f};
  for (float u : {0.0f, 0.3f, 0.7f, 0.9999f}) {
    const glm::vec2 o = filter_offset(s.t, glm::vec2(u, u));
    EXPECT_NEAR(o.x, -0.75f + 0.75f * u, 1e-6f);
    EXPECT_NEAR(o.y, u < 0.5f ? 2.0f * u * 0.75f : 0.75f + (u - 0.5f) * 2.0f * 0.75f, 1e-6f);
  }
}

TEST(CpuLights, SelectionFollowsCdf) {
  TestScene s;
  for (int i = 0; i < 4; ++i) {
    gpu::Light l{};
    l.type = gpu::LIGHT_POINT;
    s.light(l);
  }
  s.finish();
  s.t.light_cdf = {0.0f, 0.5f, 0.5f, 0.75f, 1.0f};  // light 1 has zero probability
  EXPECT_EQ(select_light(s.t, 0.0f), 0u);
  EXPECT_EQ(select_light(s.t, 0.49f), 0u);
  EXPECT_EQ(select_light(s.t, 0.5f), 2u);
  EXPECT_EQ(select_light(s.t, 0.8f), 3u);
  EXPECT_EQ(select_light(s.t, 0.99999f), 3u);
  TestScene none;
  none.finish();
  EXPECT_EQ(select_light(none.t, 0.3f), gpu::INVALID_INDEX);
}

TEST(CpuLights, AreaSamplesMatchTheirPdf) {
  Rand r(12);
  TestScene s;
  const std::uint32_t m = s.diffuse(glm::vec3(0.5f));
  const std::uint32_t tri = s.mesh({glm::vec3(-1, -1, 4), glm::vec3(2, -1, 5), glm::vec3(0, 2, 4.5f)},
                                   {glm::uvec3(0, 1, 2)}, m);
  s.mesh_light(tri, glm::vec3(1.0f), true);
  const std::uint32_t big = s.sphere(glm::vec3(0, 0, -6), 2.0f, m);
  s.sphere_light(big, glm::vec3(1.0f));
  const std::uint32_t small = s.sphere(glm::vec3(0, 300, 0), 2.0f, m);  // < 1.5 degrees
  s.sphere_light(small, glm::vec3(1.0f));
  s.finish();
  for (const gpu::Light& light : s.t.lights) {
    for (const glm::vec3 p : {glm::vec3(0.1f, 0.2f, 0.3f), glm::vec3(0.0f, 0.5f, -5.5f)}) {
      for (int i = 0; i < 500; ++i) {
        const LightSample ls = sample_light(s.t, light, p, glm::vec3(0.0f), 0.0f, glm::vec2(r(), r()));
        if (ls.pdf == 0.0f) continue;
        ASSERT_TRUE(finite(ls.q) && finite(ls.wi) && std::isfinite(ls.pdf));
        // The sampled point is on the light, along wi, and its pdf is what area_light_pdf says.
        const Ray ray{p, ls.wi, FLT_MAX};
        const std::uint32_t ref = light.type == gpu::LIGHT_AREA_SPHERE ? light.prim | gpu::PRIM_SPHERE_BIT
                                                                         : light.prim;
        const PrimHit ph = intersect_prim(s.t, ref, ray.o, ray.d, ray.tmax);
        ASSERT_GT(ph.t, 0.0f);
        const Hit h{ph.t, ref, ph.b1, ph.b2};
        const SurfacePoint sp = surface_point(s.t, ray, h);
        ASSERT_EQ(sp.light, std::uint32_t(&light - s.t.lights.data()));
        ASSERT_LT(glm::length(sp.g.p - ls.q), 1e-3f * glm::length(ls.q - p) + 1e-4f);
        const float pdf = area_light_pdf(s.t, light, p, glm::vec3(0.0f), 0.0f, sp.g.p, sp.g.ng, ls.wi);
        ASSERT_NEAR(pdf, ls.pdf, 2e-3f * ls.pdf);
      }
    }
  }
}

TEST(CpuProbe, AnswersEveryOp) {
  TestScene s(16, 16);
  s.t.globals.image.w = 1234;  // seed
  const std::uint32_t m = s.diffuse(glm::vec3(0.5f));
  s.sphere(glm::vec3(0, 0, 5), 1.0f, m);
  s.finish();
  std::vector<gpu::ProbeIn> in(7);
  in[0] = {glm::uvec4(gpu::PROBE_CLOSEST, 0, 0, 0), glm::vec4(0, 0, 0, FLT_MAX), glm::vec4(0, 0, 1, 0), glm::vec4(0), glm::vec4(0), glm::vec4(0)};
  in[1] = {glm::uvec4(gpu::PROBE_CLOSEST, 0, 0, 0), glm::vec4(0, 0, 0, FLT_MAX), glm::vec4(0, 1, 0, 0), glm::vec4(0), glm::vec4(0), glm::vec4(0)};
  in[2] = {glm::uvec4(gpu::PROBE_OCCLUDED, 0, 0, 0), glm::vec4(0, 0, 0, 3.9f), glm::vec4(0, 0, 1, 0), glm::vec4(0), glm::vec4(0), glm::vec4(0)};
  in[3] = {glm::uvec4(gpu::PROBE_RESPAWN, 0, 0, 0), glm::vec4(0, 0, 0, FLT_MAX), glm::vec4(0, 0, 1, 0),
           glm::vec4(0, 0, 1, 0), glm::vec4(0), glm::vec4(0)};
  in[4] = {glm::uvec4(gpu::PROBE_RNG, 5, 6, 7), glm::vec4(0), glm::vec4(0),
           glm::vec4(std::bit_cast<float>(21u), 0, 0, 0), glm::vec4(0), glm::vec4(0)};
  in[5] = {glm::uvec4(gpu::PROBE_CAMERA, 8, 8, 3), glm::vec4(0), glm::vec4(0), glm::vec4(0), glm::vec4(0), glm::vec4(0)};
  in[6] = {glm::uvec4(gpu::PROBE_CAMERA_DIFF, 8, 8, 3), glm::vec4(0), glm::vec4(0), glm::vec4(0), glm::vec4(0), glm::vec4(0)};
  const std::vector<gpu::ProbeOut> out = probe(s.t, in);
  ASSERT_EQ(out.size(), in.size());
  EXPECT_NEAR(out[0].f0.x, 4.0f, 1e-5f);
  EXPECT_EQ(out[0].u.x, gpu::PRIM_SPHERE_BIT);
  EXPECT_EQ(out[1].f0.x, -1.0f);
  EXPECT_EQ(out[1].u.x, gpu::INVALID_INDEX);
  EXPECT_EQ(out[2].u.x, 0u);
  EXPECT_NEAR(out[3].f0.x, 4.0f, 1e-5f);
  EXPECT_NEAR(out[3].f1.x, 2.0f, 1e-3f);  // through the sphere to its far side
  EXPECT_EQ(out[3].u.y, gpu::PRIM_SPHERE_BIT);
  EXPECT_EQ(out[4].f0.x, rng(5, 6, 7, 21, 1234));
  const Ray c = camera_ray(s.t, 8, 8, 3);
  EXPECT_EQ(glm::vec3(out[5].f0), c.o);
  EXPECT_EQ(glm::vec3(out[5].f1), c.d);
  const CameraRay cd = camera_ray_differential(s.t, 8, 8, 3);
  EXPECT_EQ(out[6].f0, glm::vec4(cd.rx_d, 0.0f));
  EXPECT_EQ(out[6].f1, glm::vec4(cd.ry_d, 0.0f));
}
