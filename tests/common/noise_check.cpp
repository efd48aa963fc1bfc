// Noise property checks shared by the CPU and GPU tests (see noise_check.h).
#include "common/noise_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace basalt::test {

NoiseBatch pointwise(const std::function<float(glm::vec3)>& noise) {
  return [noise](const std::vector<glm::vec3>& p) {
    std::vector<float> v;
    v.reserve(p.size());
    for (const glm::vec3& x : p) v.push_back(noise(x));
    return v;
  };
}

void check_noise_properties(const NoiseBatch& noise, std::size_t pairs) {
  std::mt19937 rng(81);
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  // 0 at every integer lattice point (pbrt-v4 Noise: every gradient is dotted with 0).
  std::vector<glm::vec3> lattice;
  for (int i = 0; i < 4096; ++i)
    lattice.push_back(glm::floor(glm::vec3(300.0f * U(rng), 300.0f * U(rng), 300.0f * U(rng))));
  const std::vector<float> z = noise(lattice);
  std::size_t nonzero = 0;
  for (float v : z) nonzero += v != 0.0f;
  EXPECT_EQ(nonzero, 0u) << "noise is not 0 at lattice points";

  // Close pairs: bounded and Lipschitz. |p - q| is measured on the floats actually passed.
  std::vector<glm::vec3> pts;
  pts.reserve(2 * pairs);
  for (std::size_t i = 0; i < pairs; ++i) {
    const float r = i % 2 == 0 ? 10.0f : 1000.0f;
    const glm::vec3 p(r * U(rng), r * U(rng), r * U(rng));
    const glm::vec3 dir = glm::normalize(glm::vec3(U(rng), U(rng), U(rng)) + glm::vec3(1e-4f));
    pts.push_back(p);
    pts.push_back(p + 1e-3f * dir);
  }
  const std::vector<float> v = noise(pts);
  std::size_t out_of_bounds = 0, steep = 0;
  double max_slope = 0.0;
  for (std::size_t i = 0; i < pairs; ++i) {
    const float a = v[2 * i], b = v[2 * i + 1];
    out_of_bounds += !(std::fabs(a) <= 1.0f) + !(std::fabs(b) <= 1.0f);
    const double d = glm::length(glm::dvec3(pts[2 * i + 1]) - glm::dvec3(pts[2 * i]));
    const double slope = std::fabs(double(a) - double(b)) / d;
    max_slope = std::max(max_slope, slope);
    steep += !(slope <= kNoiseLipschitz);
  }
  std::printf("  noise: %zu close pairs, max slope %.3f (bound %.1f)\n", pairs, max_slope,
              double(kNoiseLipschitz));
  EXPECT_EQ(out_of_bounds, 0u) << "|noise| > 1";
  EXPECT_EQ(steep, 0u) << "noise jumps (max slope " << max_slope << ")";

  // Central differences at h = 1e-2 and 1e-3 (|p| < 10) agree: the derivative exists.
  std::vector<glm::vec3> fd;
  const std::size_t m = std::min<std::size_t>(pairs / 10, 20000);
  std::vector<glm::vec3> dirs;
  for (std::size_t i = 0; i < m; ++i) {
    const glm::vec3 p(8.0f * U(rng), 8.0f * U(rng), 8.0f * U(rng));
    const glm::vec3 dir = glm::normalize(glm::vec3(U(rng), U(rng), U(rng)) + glm::vec3(1e-4f));
    for (float h : {1e-2f, 1e-3f}) {
      fd.push_back(p + h * dir);
      fd.push_back(p - h * dir);
    }
    dirs.push_back(dir);
  }
  const std::vector<float> w = noise(fd);
  std::size_t diverging = 0;
  for (std::size_t i = 0; i < m; ++i) {
    const double d1 = (double(w[4 * i]) - w[4 * i + 1]) / 2e-2;
    const double d2 = (double(w[4 * i + 2]) - w[4 * i + 3]) / 2e-3;
    diverging += !(std::fabs(d1 - d2) <= 2e-2);
  }
  EXPECT_EQ(diverging, 0u) << "finite differences do not converge";
}

}  // namespace basalt::test
