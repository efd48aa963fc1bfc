// Integrator tests of the CPU reference on analytic scenes (pbrt-v4 integrators_test.cpp
// style): closed diffuse enclosures with known radiance, a furnace, exact direct lighting,
// render() accumulation and NaN-freedom.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <random>

#include "cpu/camera.h"
#include "cpu/cpu.h"
#include "cpu/sampling.h"
#include "cpu_test_scene.h"

using namespace basalt;
using namespace basalt::cpu;
using basalt::cpu::test_scene::TestScene;

namespace {

/// Mean and standard error of path_radiance (green channel) over all pixels and spp samples.
struct Estimate {
  double mean = 0.0, stderr_ = 0.0;
};
Estimate estimate(const SceneTables& t, std::uint32_t spp) {
  double sum = 0.0, sum2 = 0.0;
  std::size_t n = 0;
  for (std::uint32_t y = 0; y < t.height(); ++y)
    for (std::uint32_t x = 0; x < t.width(); ++x)
      for (std::uint32_t s = 0; s < spp; ++s) {
        const glm::vec3 L = path_radiance(t, x, y, s);
        EXPECT_TRUE(std::isfinite(L.x) && std::isfinite(L.y) && std::isfinite(L.z));
        sum += L.y;
        sum2 += double(L.y) * L.y;
        ++n;
      }
  Estimate e;
  e.mean = sum / n;
  e.stderr_ = std::sqrt(std::max(0.0, sum2 / n - e.mean * e.mean) / n);
  return e;
}

gpu::Light point_light(glm::vec3 pos, glm::vec3 I) {
  gpu::Light l{};
  l.type = gpu::LIGHT_POINT;
  l.L = glm::vec4(I, 0.0f);
  l.pos = glm::vec4(pos, 1.0f);
  return l;
}

}  // namespace

// pbrt-v4 integrators_test.cpp "RadianceInsideSphere": Kd = 0.5 inside a unit sphere with a
// point light of intensity pi at its centre: direct 0.5, and L = 0.5 + 0.5 L gives 1.
TEST(CpuIntegrator, PointLightInsideDiffuseSphere) {
  TestScene s(8, 8, 40);
  s.sphere(glm::vec3(0.0f), 1.0f, s.diffuse(glm::vec3(0.5f)), gpu::SHAPE_FLAG_FLIP_NORMAL);
  s.light(point_light(glm::vec3(0.0f), glm::vec3(PI)));
  s.finish();
  const Estimate e = estimate(s.t, 64);
  EXPECT_NEAR(e.mean, 1.0, std::max(0.02, 4.0 * e.stderr_));
  // Direct lighting only: exactly 0.5 on every path.
  s.t.globals.image.z = 1;
  for (std::uint32_t k = 0; k < 16; ++k) EXPECT_NEAR(path_radiance(s.t, k % 8, k / 2, k).y, 0.5f, 1e-4f);
}

// Emitting interior of a sphere: Le = 0.5, Kd = 0.5: L = 0.5 + 0.5 L = 1 (pbrt-v4
// integrators_test.cpp "RadianceInsideSphere" with an area light). Exercises the sphere's
// inside sampling and MIS between light and BSDF sampling.
TEST(CpuIntegrator, EmittingDiffuseSphereInterior) {
  TestScene s(8, 8, 40);
  const std::uint32_t sp = s.sphere(glm::vec3(0.0f, 0.0f, 0.5f), 2.0f, s.diffuse(glm::vec3(0.5f)),
                                    gpu::SHAPE_FLAG_FLIP_NORMAL);
  s.sphere_light(sp, glm::vec3(0.5f));  // one-sided: emits towards the flipped (inner) normal
  s.finish();
  const Estimate e = estimate(s.t, 64);
  EXPECT_NEAR(e.mean, 1.0, std::max(0.02, 4.0 * e.stderr_));
  // Max depth 0: only the directly seen emission.
  s.t.globals.image.z = 0;
  EXPECT_FLOAT_EQ(path_radiance(s.t, 3, 3, 0).y, 0.5f);
  // Without the flip the emitting side faces out: nothing reaches the inside.
  s.t.spheres[sp].flags = 0;
  s.t.globals.image.z = 5;
  EXPECT_EQ(path_radiance(s.t, 3, 3, 0), glm::vec3(0.0f));
}

// The same with a closed cube of 12 emitting, two-sided triangles: triangle light sampling,
// light selection among 12 lights, MIS, and watertight closure.
TEST(CpuIntegrator, EmittingDiffuseCubeInterior) {
  TestScene s(8, 8, 40);
  std::vector<glm::vec3> P;
  std::vector<glm::uvec3> idx;
  test_scene::cube(P, idx, 1.5f, glm::vec3(0.1f, -0.2f, 0.3f));
  const std::uint32_t mi = s.mesh(P, idx, s.diffuse(glm::vec3(0.5f)));
  s.mesh_light(mi, glm::vec3(0.5f), true);
  s.finish(2);
  const Estimate e = estimate(s.t, 48);
  EXPECT_NEAR(e.mean, 1.0, std::max(0.02, 4.0 * e.stderr_));
}

namespace {

/// What a furnace render of an 8x8 image shows: the mean of L.y over pixel samples whose
/// camera ray hits the scene, whether every miss sees exactly 1, and whether all L are finite.
struct FurnaceResult {
  double mean_on_hits = 0.0;
  int hits = 0;
  bool misses_see_one = true;
  bool all_finite = true;
};

/// Adds a uniform infinite light L = 1 to s, finishes it and renders spp samples per pixel.
FurnaceResult furnace(TestScene& s, std::uint32_t spp) {
  gpu::Light env{};
  env.type = gpu::LIGHT_INFINITE_UNIFORM;
  env.L = glm::vec4(1.0f);
  s.light(env);
  s.finish();
  FurnaceResult r;
  double sum = 0.0;
  for (std::uint32_t y = 0; y < 8; ++y)
    for (std::uint32_t x = 0; x < 8; ++x)
      for (std::uint32_t k = 0; k < spp; ++k) {
        const bool hit = intersect_closest(s.t, camera_ray(s.t, x, y, k)).valid();
        const glm::vec3 L = path_radiance(s.t, x, y, k);
        r.all_finite = r.all_finite && std::isfinite(L.x) && std::isfinite(L.y) &&
                       std::isfinite(L.z);
        if (!hit) {
          r.misses_see_one = r.misses_see_one && L.y == 1.0f;
        } else {
          sum += L.y;
          ++r.hits;
        }
      }
  if (r.hits) r.mean_on_hits = sum / r.hits;
  return r;
}

}  // namespace

// Furnace: a diffuse sphere (Kd = 0.5) under a uniform infinite light L = 1. A convex object
// has no interreflection, so every ray that hits it sees 0.5 and every other ray sees 1.
TEST(CpuIntegrator, InfiniteLightFurnace) {
  TestScene s(8, 8, 5);
  s.sphere(glm::vec3(0.0f, 0.0f, 3.0f), 1.0f, s.diffuse(glm::vec3(0.5f)));
  const FurnaceResult r = furnace(s, 32);
  EXPECT_TRUE(r.misses_see_one);
  ASSERT_GT(r.hits, 200);
  EXPECT_NEAR(r.mean_on_hits, 0.5, 0.03);
}

// Direct lighting from point, spot and distant lights on a diffuse plane is deterministic:
// L = R / pi * I cos / d^2 (times the spot falloff), or R / pi * L cos for a distant light.
TEST(CpuIntegrator, ExactDirectLighting) {
  TestScene s(8, 8, 1);
  const float R = 0.6f;
  const float z = 4.0f;
  s.mesh({glm::vec3(-50, -50, z), glm::vec3(50, -50, z), glm::vec3(50, 50, z), glm::vec3(-50, 50, z)},
         {glm::uvec3(0, 1, 2), glm::uvec3(0, 2, 3)}, s.diffuse(glm::vec3(R)));
  s.finish();
  const glm::vec3 lp(0.5f, -0.3f, 1.0f);
  for (int type = 0; type < 3; ++type) {
    gpu::Light l{};
    if (type == 0) l = point_light(lp, glm::vec3(2.0f));
    if (type == 1) {
      l = point_light(lp, glm::vec3(2.0f));
      l.type = gpu::LIGHT_SPOT;
      l.dir = glm::vec4(0, 0, 1, 0);
      l.params = glm::vec4(std::cos(0.2f), std::cos(0.5f), 0, 0);
    }
    if (type == 2) {
      l.type = gpu::LIGHT_DISTANT;
      l.L = glm::vec4(3.0f);
      l.dir = glm::vec4(glm::normalize(glm::vec3(0.2f, 0.1f, -1.0f)), 0.0f);
    }
    s.t.lights = {l};
    s.finish();
    for (std::uint32_t k = 0; k < 64; ++k) {
      const std::uint32_t x = k % 8, y = (k * 3) % 8;
      const Ray ray = camera_ray(s.t, x, y, k);
      const Hit h = intersect_closest(s.t, ray);
      ASSERT_TRUE(h.valid());
      const glm::vec3 p = surface_point(s.t, ray, h).g.p;
      double expected;
      if (type == 2) {
        expected = R / M_PI * 3.0 * std::fabs(glm::dot(glm::vec3(l.dir), glm::vec3(0, 0, 1)));
      } else {
        const glm::dvec3 d = glm::dvec3(lp) - glm::dvec3(p);
        const double d2 = glm::dot(d, d);
        const double cos = std::fabs(d.z) / std::sqrt(d2);
        expected = R / M_PI * 2.0 * cos / d2;
        if (type == 1) {
          const double c = -glm::dot(glm::normalize(d), glm::dvec3(0, 0, 1));
          const double t = std::clamp((c - std::cos(0.5)) / (std::cos(0.2) - std::cos(0.5)), 0.0, 1.0);
          expected *= t * t * (3.0 - 2.0 * t);
        }
      }
      EXPECT_NEAR(path_radiance(s.t, x, y, k).y, expected, 1e-4 * expected + 1e-7) << type;
    }
  }
}

// A thin-lens camera and a gaussian filter change where rays go, not the furnace result.
TEST(CpuIntegrator, ThinLensGaussianFurnace) {
  TestScene s(6, 6, 3);
  s.t.globals.lens = glm::vec4(1.0f, 0.3f, 2.0f, 0.0f);
  s.t.globals.counts.z = gpu::FILTER_GAUSSIAN;
  s.t.globals.counts.w = 8;
  s.t.globals.filter_radius = glm::vec4(1.5f, 1.5f, 0, 0);
  s.t.filter_cdf.clear();
  for (int axis = 0; axis < 2; ++axis)
    for (int i = 0; i <= 8; ++i) s.t.filter_cdf.push_back(0.5f - 0.5f * std::cos(PI * i / 8.0f));
  gpu::Light env{};
  env.type = gpu::LIGHT_INFINITE_UNIFORM;
  env.L = glm::vec4(0.7f);
  s.light(env);
  s.finish();
  for (std::uint32_t k = 0; k < 36; ++k) EXPECT_FLOAT_EQ(path_radiance(s.t, k % 6, k / 6, k).y, 0.7f);
}

// render() accumulates exactly the paths of path_radiance, in any split of the samples.
TEST(CpuRender, AccumulatesSamples) {
  TestScene s(19, 13, 4);  // not a multiple of the tile size
  const std::uint32_t m = s.diffuse(glm::vec3(0.7f, 0.5f, 0.3f));
  s.sphere(glm::vec3(0.0f, 0.0f, 3.0f), 1.0f, m);
  s.mesh({glm::vec3(-9, -1, 0), glm::vec3(9, -1, 0), glm::vec3(0, -1, 9)}, {glm::uvec3(0, 2, 1)}, m);
  s.light(point_light(glm::vec3(1.0f, 2.0f, 1.0f), glm::vec3(5.0f)));
  s.finish();
  std::vector<glm::vec4> a, b;
  double last = 0.0;
  int calls = 0;
  const std::uint64_t rays = render(s.t, 0, 4, a, [&](double f) {
    EXPECT_GE(f, last);
    last = f;
    ++calls;
  });
  // At least the camera ray of every path; path_radiance counts the same rays.
  EXPECT_GE(rays, std::uint64_t(19 * 13 * 4));
  std::uint64_t counted = 0;
  for (std::uint32_t y = 0; y < 13; ++y)
    for (std::uint32_t x = 0; x < 19; ++x)
      for (std::uint32_t k = 0; k < 4; ++k) path_radiance(s.t, x, y, k, &counted);
  EXPECT_EQ(rays, counted);
  EXPECT_EQ(last, 1.0);
  EXPECT_GT(calls, 0);
  render(s.t, 0, 1, b);
  render(s.t, 1, 3, b);
  ASSERT_EQ(a.size(), std::size_t(19 * 13));
  for (std::uint32_t y = 0; y < 13; ++y)
    for (std::uint32_t x = 0; x < 19; ++x) {
      glm::vec3 sum(0.0f);
      for (std::uint32_t k = 0; k < 4; ++k) sum += path_radiance(s.t, x, y, k);
      const glm::vec4 v = a[y * 19 + x];
      ASSERT_EQ(v.w, 4.0f);
      ASSERT_EQ(b[y * 19 + x].w, 4.0f);
      for (int c = 0; c < 3; ++c) {
        ASSERT_NEAR(v[c], sum[c], 1e-5f * (1.0f + sum[c]));
        ASSERT_NEAR(b[y * 19 + x][c], sum[c], 1e-5f * (1.0f + sum[c]));
      }
    }
}

// Every light type and both shapes together, seeds and depths varied: no NaN or inf, and the
// same key gives the same path.
TEST(CpuIntegrator, MixedSceneIsFiniteAndDeterministic) {
  std::mt19937 gen(3);
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  TestScene s(12, 12, 6);
  const std::uint32_t m = s.diffuse(glm::vec3(0.8f, 0.4f, 0.2f));
  for (int i = 0; i < 20; ++i) {
    const glm::vec3 c(3.0f * U(gen), 3.0f * U(gen), 5.0f + 3.0f * U(gen));
    const std::uint32_t mi = s.mesh({c, c + glm::vec3(U(gen), U(gen), U(gen)), c + glm::vec3(U(gen), U(gen), U(gen))},
                                    {glm::uvec3(0, 1, 2)}, m, i % 3 == 0 ? gpu::SHAPE_FLAG_FLIP_NORMAL : 0u);
    if (i % 5 == 0) s.mesh_light(mi, glm::vec3(2.0f), i % 2 == 0);
  }
  // A mesh with shading normals (one of them degenerate: zero interpolated normal).
  s.mesh({glm::vec3(-4, -2, 9), glm::vec3(4, -2, 9), glm::vec3(0, 4, 9)}, {glm::uvec3(0, 1, 2)}, m, 0,
         {glm::vec3(0, 0, -1), glm::normalize(glm::vec3(1, 0, -1)), glm::vec3(0, 0, 1)});
  for (int i = 0; i < 6; ++i) {
    const std::uint32_t sp = s.sphere(glm::vec3(3.0f * U(gen), 3.0f * U(gen), 6.0f + 2.0f * U(gen)),
                                      0.2f + 0.5f * (U(gen) + 1.0f), m);
    if (i % 2) s.sphere_light(sp, glm::vec3(1.5f), i == 3);
  }
  s.light(point_light(glm::vec3(0, 3, 2), glm::vec3(10.0f)));
  gpu::Light spot = point_light(glm::vec3(0, -3, 2), glm::vec3(10.0f));
  spot.type = gpu::LIGHT_SPOT;
  spot.dir = glm::vec4(0, 0.5f, 0.86f, 0);
  spot.params = glm::vec4(0.9f, 0.9f, 0, 0);  // hard-edged cone (a == b in SmoothStep)
  s.light(spot);
  gpu::Light dist{};
  dist.type = gpu::LIGHT_DISTANT;
  dist.L = glm::vec4(1.0f);
  dist.dir = glm::vec4(0, 1, 0, 0);
  s.light(dist);
  gpu::Light env{};
  env.type = gpu::LIGHT_INFINITE_UNIFORM;
  env.L = glm::vec4(0.2f);
  s.light(env);
  s.finish(2);
  for (std::uint32_t seed : {0u, 77u}) {
    s.t.globals.image.w = seed;
    const Estimate e = estimate(s.t, 8);
    EXPECT_GT(e.mean, 0.0);
  }
  EXPECT_EQ(path_radiance(s.t, 5, 6, 3), path_radiance(s.t, 5, 6, 3));
}

// Furnace with non-diffuse materials (docs/materials-spec.md section 5): a smooth glass sphere
// (Kr = Kt = 1) and a thin dielectric sphere lose no energy, so every pixel sees L = 1
// (radiance-mode eta^2 scaling and etaScale cancel on the way out); an interface sphere is
// invisible. Deep paths: max depth 64.
TEST(CpuIntegrator, LosslessMaterialsFurnace) {
  for (std::uint32_t type :
       {gpu::MATERIAL_DIELECTRIC, gpu::MATERIAL_THIN_DIELECTRIC, gpu::MATERIAL_INTERFACE}) {
    TestScene s(8, 8, 64);
    gpu::Material m{};
    m.type = type;
    for (auto& tx : m.texture) tx = glm::uvec4(gpu::INVALID_INDEX);
    m.value[gpu::SLOT_DIELECTRIC_ETA] = glm::vec4(1.5f);
    m.value[gpu::SLOT_DIELECTRIC_KR] = glm::vec4(1.0f);
    m.value[gpu::SLOT_DIELECTRIC_KT] = glm::vec4(1.0f);
    s.t.materials.push_back(m);
    s.sphere(glm::vec3(0.0f, 0.0f, 3.0f), 1.0f, std::uint32_t(s.t.materials.size() - 1));
    const FurnaceResult r = furnace(s, 64);
    EXPECT_TRUE(r.all_finite) << "material type " << type;
    ASSERT_GT(r.hits, 100);
    EXPECT_NEAR(r.mean_on_hits, 1.0, 0.02) << "material type " << type;
  }
}
