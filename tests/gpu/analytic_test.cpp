// Tests that do not lean on the twin, run on both sides: the white furnace, the analytic
// sphere, and convergence of the seed mean to a high-spp image.
#include <gtest/gtest.h>

#include <cmath>

#include "common/test_util.h"

namespace basalt::test {
namespace {

class Analytic : public ::testing::TestWithParam<Side> {};

/// Mean of \p seeds independent renders and its standard error. In these scenes every pixel
/// estimates the same value with independent samples, so the pixels of all renders are
/// i.i.d. estimates: the standard error comes from their spread (thousands of degrees of
/// freedom), not from a handful of per-seed means (issue 11).
std::pair<double, double> seed_mean(Side side, SceneTables t, int seeds, std::uint32_t spp,
                                    std::vector<glm::vec3>* last = nullptr) {
  double sum = 0.0, sum2 = 0.0;
  std::size_t n = 0;
  for (int s = 0; s < seeds; ++s) {
    set_seed(t, 1000u + std::uint32_t(s));
    auto img = render(side, t, spp);
    EXPECT_TRUE(all_finite(img));
    for (const glm::vec3& p : img) {
      const double v = (double(p.x) + p.y + p.z) / 3.0;
      sum += v;
      sum2 += v * v;
      ++n;
    }
    if (last) *last = img;
  }
  const double mu = sum / double(n);
  const double var = (sum2 - double(n) * mu * mu) / double(n - 1);
  return {mu, std::sqrt(std::max(var, 0.0) / double(n))};
}

/// Two-sided bound for the analytic means: 4.5 standard errors (a false failure about once
/// in 1.5e5 runs per check, with the standard error itself known to within ~2 %).
constexpr double kZ = 4.5;

// A sphere of reflectance 1 inside a uniform environment of radiance 1 is invisible:
// every pixel is 1 (white furnace; pbrt-v4 integrators_test.cpp style).
TEST_P(Analytic, WhiteFurnace) {
  SceneTables t = tables_from_string(R"(
    LookAt 0 0 -4  0 0 0  0 1 0
    Camera "perspective" "float fov" [ 40 ]
    Film "rgb" "integer xresolution" [ 32 ] "integer yresolution" [ 32 ]
    Sampler "independent" "integer pixelsamples" [ 16 ]
    Integrator "path" "integer maxdepth" [ 20 ]
    WorldBegin
    LightSource "infinite" "rgb L" [ 1 1 1 ]
    Material "diffuse" "rgb reflectance" [ 1 1 1 ]
    Shape "sphere" "float radius" [ 1 ]
  )");
  std::vector<glm::vec3> img;
  auto [mu, se] = seed_mean(GetParam(), t, 4, 16, &img);
  EXPECT_NEAR(mu, 1.0, kZ * se + 1e-5) << "se " << se << ", z " << (mu - 1.0) / se;
  EXPECT_LT(se, 0.01);
  for (const auto& p : img)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], 1.0, 0.5);  // per pixel, 16 spp of noise
}

// Inside a sphere of reflectance 0.5 with a point light of intensity pi at its centre,
// radiance is 1 everywhere: 0.5 direct, and the interreflections sum to 1
// (pbrt-v4 integrators_test.cpp).
TEST_P(Analytic, PointLightInsideSphere) {
  SceneTables t = tables_from_string(R"(
    LookAt 0 0 0  0 0 1  0 1 0
    Camera "perspective" "float fov" [ 60 ]
    Film "rgb" "integer xresolution" [ 24 ] "integer yresolution" [ 24 ]
    Sampler "independent" "integer pixelsamples" [ 16 ]
    Integrator "path" "integer maxdepth" [ 200 ]
    WorldBegin
    LightSource "point" "rgb I" [ 3.14159265 3.14159265 3.14159265 ]
    Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
    ReverseOrientation
    Shape "sphere" "float radius" [ 1 ]
  )");
  auto [mu, se] = seed_mean(GetParam(), t, 4, 32);
  EXPECT_NEAR(mu, 1.0, kZ * se + 1e-5) << "se " << se << ", z " << (mu - 1.0) / se;
  EXPECT_LT(se, 0.02);
}

// The same sphere lit by a black spherical area light of radius 0.1 and radiance L = 100 at
// its centre. Direct irradiance at the wall is pi L sin^2(theta_max) = pi, so direct
// radiance is 0.5; the light blocks a projected-solid-angle fraction sin^2 = 0.01 of each
// wall point's view, so the wall's radiance solves Lw = 0.5 + 0.5 * 0.99 * Lw:
// Lw = 0.5 / 0.505. Exercises sphere light sampling and MIS with BSDF hits on the light.
TEST_P(Analytic, AreaLightInsideSphere) {
  SceneTables t = tables_from_string(R"(
    LookAt 0 0 -0.5  0 0 -1  0 1 0
    Camera "perspective" "float fov" [ 50 ]
    Film "rgb" "integer xresolution" [ 24 ] "integer yresolution" [ 24 ]
    Sampler "independent" "integer pixelsamples" [ 16 ]
    Integrator "path" "integer maxdepth" [ 200 ]
    WorldBegin
    AttributeBegin
      AreaLightSource "diffuse" "rgb L" [ 100 100 100 ]
      Material "diffuse" "rgb reflectance" [ 0 0 0 ]
      Shape "sphere" "float radius" [ 0.1 ]
    AttributeEnd
    Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
    Shape "sphere" "float radius" [ 1 ]
  )");
  auto [mu, se] = seed_mean(GetParam(), t, 4, 32);
  EXPECT_NEAR(mu, 0.5 / 0.505, kZ * se + 1e-5)
      << "se " << se << ", z " << (mu - 0.5 / 0.505) / se;
  EXPECT_LT(se, 0.02);
}

// The mean of several low-spp renders with different seeds converges to a high-spp render
// of another seed: per 8x8 block, within a Sidak-corrected normal bound.
TEST_P(Analytic, SeedMeanConvergesToHighSpp) {
  SceneTables t = tables_from_file(source_path("scenes/cornell-box.pbrt"), 32, 32);
  const int seeds = 8;
  const std::uint32_t spp = 8, ref_spp = 256;
  std::vector<std::vector<glm::vec3>> imgs;
  for (int s = 0; s < seeds; ++s) {
    set_seed(t, 7u + std::uint32_t(s));
    imgs.push_back(render(GetParam(), t, spp));
  }
  set_seed(t, 99999u);
  auto ref = render(GetParam(), t, ref_spp);
  ASSERT_TRUE(all_finite(ref));
  const int w = int(t.width()), h = int(t.height()), B = 8;
  const int blocks = (w / B) * (h / B) * 3;
  // Sidak: per-test alpha so that the family-wise false-failure rate is 1e-4.
  const double alpha = 1.0 - std::pow(1.0 - 1e-4, 1.0 / blocks);
  // Normal quantile for a two-sided test at alpha, by bisection on erfc.
  double lo = 0, hi = 20;
  for (int i = 0; i < 100; ++i) {
    double mid = 0.5 * (lo + hi);
    (std::erfc(mid / std::sqrt(2.0)) > alpha ? lo : hi) = mid;
  }
  const double z = lo;
  int failures = 0;
  for (int by = 0; by < h / B; ++by)
    for (int bx = 0; bx < w / B; ++bx)
      for (int c = 0; c < 3; ++c) {
        // Pixels are independent estimates: the block mean's variance is the sum of the
        // per-pixel variances (each from the spread over seeds) over (B^2)^2. Pooling the
        // 64 pixels makes the variance estimate accurate enough for a normal quantile.
        double mu = 0.0, r = 0.0, var_sum = 0.0;
        for (int y = by * B; y < (by + 1) * B; ++y)
          for (int x = bx * B; x < (bx + 1) * B; ++x) {
            double pm = 0.0, pv = 0.0;
            for (int s = 0; s < seeds; ++s) pm += imgs[s][y * w + x][c] / seeds;
            for (int s = 0; s < seeds; ++s) {
              double d = imgs[s][y * w + x][c] - pm;
              pv += d * d / (seeds - 1);
            }
            mu += pm / (B * B);
            var_sum += pv;
            r += ref[y * w + x][c] / (B * B);
          }
        const double var_block = var_sum / double(B * B) / double(B * B);  // one seed
        double sigma = std::sqrt(var_block / seeds + var_block * spp / ref_spp);
        if (std::abs(mu - r) > z * sigma + 1e-6) ++failures;
      }
  EXPECT_EQ(failures, 0) << "z " << z;
}

INSTANTIATE_TEST_SUITE_P(BothSides, Analytic, ::testing::Values(Side::Cpu, Side::Gpu),
                         [](const auto& info) { return side_name(info.param); });

}  // namespace
}  // namespace basalt::test
