// BSDF tests of the CPU reference: eval/pdf/sample consistency and a chi-square test of
// bsdf_sample against the numerically integrated bsdf_pdf (pbrt-v4 bsdfs_test.cpp style).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "cpu/bsdf.h"
#include "cpu/sampling.h"

using namespace basalt;
using namespace basalt::cpu;

namespace {

gpu::Material diffuse(glm::vec3 R) {
  gpu::Material m{};
  m.type = gpu::MATERIAL_DIFFUSE;
  m.value[gpu::SLOT_DIFFUSE_REFLECTANCE] = glm::vec4(R, 0.0f);
  return m;
}

/// Regularised upper incomplete gamma Q(a, x) by series / continued fraction (Numerical
/// Recipes 3rd ed. 6.2), for the chi-square p-value Q(dof/2, chi2/2).
double gamma_q(double a, double x) {
  if (x < a + 1.0) {
    double sum = 1.0 / a, term = sum;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::fabs(term) < std::fabs(sum) * 1e-15) break;
    }
    return 1.0 - sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
  }
  double b = x + 1.0 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::fabs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-15) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

}  // namespace

TEST(CpuBsdf, DiffuseEvalPdfSampleConsistent) {
  const gpu::Material m = diffuse(glm::vec3(0.2f, 0.5f, 0.8f));
  std::mt19937 gen(1);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  for (int i = 0; i < 20000; ++i) {
    glm::vec3 wo = uniform_sphere(glm::vec2(U(gen), U(gen)));
    if (wo.z == 0.0f) continue;
    const BsdfSample bs = bsdf_sample(m, wo, glm::vec3(U(gen), U(gen), U(gen)));
    ASSERT_TRUE(bs.valid);
    ASSERT_FALSE(bs.specular);
    ASSERT_NEAR(glm::length(bs.wi), 1.0f, 1e-5f);
    if (bs.wi.z == 0.0f) continue;
    ASSERT_GT(bs.wi.z * wo.z, 0.0f);  // reflection on wo's side
    ASSERT_NEAR(bs.pdf, bsdf_pdf(m, wo, bs.wi), 1e-6f);
    const glm::vec3 f = bsdf_eval(m, wo, bs.wi);
    ASSERT_EQ(f, bs.f);
    // f cos / pdf = R for a cosine-weighted Lambertian sample.
    const glm::vec3 w = f * std::fabs(bs.wi.z) / bs.pdf;
    ASSERT_NEAR(w.x, 0.2f, 1e-5f);
    ASSERT_NEAR(w.z, 0.8f, 1e-5f);
    // Opposite hemisphere: nothing.
    const glm::vec3 below(bs.wi.x, bs.wi.y, -bs.wi.z);
    ASSERT_EQ(bsdf_eval(m, wo, below), glm::vec3(0.0f));
    ASSERT_EQ(bsdf_pdf(m, wo, below), 0.0f);
  }
  // wo in the tangent plane: no sample, no value (pbrt-v4 BSDF wrapper).
  EXPECT_FALSE(bsdf_sample(m, glm::vec3(1, 0, 0), glm::vec3(0.5f)).valid);
  EXPECT_EQ(bsdf_pdf(m, glm::vec3(1, 0, 0), glm::vec3(0, 0, 1)), 0.0f);
  // Unknown material type: black, no sample.
  gpu::Material none{};
  EXPECT_FALSE(bsdf_sample(none, glm::vec3(0, 0, 1), glm::vec3(0.5f)).valid);
  EXPECT_EQ(bsdf_eval(none, glm::vec3(0, 0, 1), glm::vec3(0, 0, 1)), glm::vec3(0.0f));
  EXPECT_FALSE(bsdf_is_nonspecular(none));
  EXPECT_TRUE(bsdf_is_nonspecular(m));
}

TEST(CpuBsdf, DiffuseWhiteFurnace) {
  // Albedo of R = 1: the integral of f cos over the hemisphere is 1 (Monte Carlo, uniform).
  const gpu::Material m = diffuse(glm::vec3(1.0f));
  const glm::vec3 wo = glm::normalize(glm::vec3(0.3f, -0.2f, 0.9f));
  double sum = 0.0;
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const glm::vec3 wi = uniform_sphere(glm::vec2((i + 0.5f) / n, std::fmod(i * 0.618034f, 1.0f)));
    sum += bsdf_eval(m, wo, wi).x * std::fabs(wi.z) * 4.0 * M_PI;
  }
  EXPECT_NEAR(sum / n, 1.0, 0.01);
}

TEST(CpuBsdf, DiffuseChiSquare) {
  // pbrt-v4 bsdfs_test.cpp: histogram of sampled directions over (cos theta, phi) bins
  // against the pdf integrated over each bin; merge bins with expected count < 5.
  const gpu::Material m = diffuse(glm::vec3(0.5f));
  constexpr int THETA = 20, PHI = 40;
  constexpr int N = 400000;
  for (float woz : {0.9f, -0.4f}) {
    const glm::vec3 wo = glm::normalize(glm::vec3(std::sqrt(1 - woz * woz), 0.0f, woz));
    std::vector<double> observed(THETA * PHI, 0.0), expected(THETA * PHI, 0.0);
    std::mt19937 gen(7);
    std::uniform_real_distribution<float> U(0.0f, 1.0f);
    for (int i = 0; i < N; ++i) {
      const BsdfSample bs = bsdf_sample(m, wo, glm::vec3(U(gen), U(gen), U(gen)));
      if (!bs.valid || bs.pdf == 0.0f) continue;
      const float ct = glm::clamp(bs.wi.z, -1.0f, 1.0f);
      float phi = std::atan2(bs.wi.y, bs.wi.x);
      if (phi < 0) phi += 2.0f * PI;
      const int ti = std::min(THETA - 1, int((ct + 1.0f) * 0.5f * THETA));
      const int pi = std::min(PHI - 1, int(phi / (2.0f * PI) * PHI));
      observed[ti * PHI + pi] += 1.0;
    }
    // Integrate the pdf over each bin (Simpson-like midpoint grid in (cos theta, phi)).
    constexpr int SUB = 6;
    for (int ti = 0; ti < THETA; ++ti)
      for (int pi = 0; pi < PHI; ++pi) {
        double acc = 0.0;
        for (int a = 0; a < SUB; ++a)
          for (int b = 0; b < SUB; ++b) {
            const double ct = -1.0 + 2.0 * (ti + (a + 0.5) / SUB) / THETA;
            const double phi = 2.0 * M_PI * (pi + (b + 0.5) / SUB) / PHI;
            const double st = std::sqrt(std::max(0.0, 1.0 - ct * ct));
            const glm::vec3 wi(float(st * std::cos(phi)), float(st * std::sin(phi)), float(ct));
            acc += bsdf_pdf(m, wo, wi);
          }
        const double area = (2.0 / THETA) * (2.0 * M_PI / PHI);
        expected[ti * PHI + pi] = acc / (SUB * SUB) * area * N;
      }
    double chi2 = 0.0, pooled_obs = 0.0, pooled_exp = 0.0;
    int dof = 0;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      if (expected[i] < 5.0) {
        pooled_obs += observed[i];
        pooled_exp += expected[i];
        if (expected[i] == 0.0) {
          ASSERT_EQ(observed[i], 0.0) << "sample in a zero-pdf bin";
        }
        continue;
      }
      chi2 += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
      ++dof;
    }
    if (pooled_exp > 5.0) {
      chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
      ++dof;
    }
    dof -= 1;
    const double pval = gamma_q(dof / 2.0, chi2 / 2.0);
    // Significance 1% (a single test, so no Sidak correction across runs needed here).
    EXPECT_GT(pval, 0.01) << "chi2 " << chi2 << " dof " << dof;
  }
}
