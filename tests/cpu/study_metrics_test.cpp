// `basalt study` error metrics: relMSE (pbrt-v4 Image::MRSE) and SSIM (Wang et al. 2004).
#include "study/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using basalt::Image;
using basalt::study::max_abs_diff;
using basalt::study::rel_mse;
using basalt::study::ssim;

namespace {

// A w x h image of one colour.
Image constant(int w, int h, glm::vec3 c) {
  return Image{w, h, std::vector<glm::vec3>(std::size_t(w) * h, c)};
}

// A smooth test pattern with values in (0, 1): gradients and a few bumps.
Image pattern(int w, int h) {
  Image img = constant(w, h, glm::vec3(0.0f));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float u = float(x) / float(w), v = float(y) / float(h);
      const float s = 0.5f + 0.3f * std::sin(6.0f * u) * std::cos(4.0f * v);
      img.pixels[std::size_t(y) * w + x] = glm::vec3(s, 0.8f * u + 0.1f, 0.8f * v + 0.1f);
    }
  return img;
}

// \p img with zero-mean Gaussian noise of standard deviation sigma (fixed seed).
Image noisy(const Image& img, float sigma, unsigned seed) {
  Image out = img;
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, sigma);
  for (auto& p : out.pixels) p += glm::vec3(n(rng), n(rng), n(rng));
  return out;
}

// sRGB transfer function (IEC 61966-2-1), written out again for the closed form.
double srgb(double v) { return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055; }

}  // namespace

TEST(StudyMetrics, IdenticalImagesHaveNoError) {
  const Image a = pattern(40, 30);
  EXPECT_EQ(rel_mse(a, a), 0.0);
  EXPECT_NEAR(ssim(a, a), 1.0, 1e-12);
  EXPECT_EQ(max_abs_diff(a, a), 0.0);
}

TEST(StudyMetrics, ConstantOffsetGivesClosedFormRelMse) {
  // Reference channels r = (0.2, 0.5, 1.0), image r + 0.1: the mean over channels of
  // 0.1^2 / (r + 0.01)^2 (pbrt-v4 Image::MRSE).
  const glm::vec3 r(0.2f, 0.5f, 1.0f);
  const Image ref = constant(16, 12, r), img = constant(16, 12, r + glm::vec3(0.1f));
  double expected = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double d = double(r[c] + 0.1f) - double(r[c]);
    expected += d * d / ((double(r[c]) + 0.01) * (double(r[c]) + 0.01)) / 3.0;
  }
  EXPECT_NEAR(rel_mse(img, ref), expected, 1e-12);
  EXPECT_NEAR(max_abs_diff(img, ref), 0.1, 1e-6);
}

TEST(StudyMetrics, RelMseSkipsInfiniteTerms) {
  Image ref = constant(4, 4, glm::vec3(0.5f)), img = ref;
  img.pixels[3] = glm::vec3(INFINITY);  // skipped, but still counted in the pixel count
  EXPECT_EQ(rel_mse(img, ref), 0.0);
}

TEST(StudyMetrics, SsimFallsWithNoise) {
  const Image ref = pattern(64, 48);
  const double less = ssim(noisy(ref, 0.02f, 1), ref), more = ssim(noisy(ref, 0.1f, 2), ref);
  EXPECT_LT(more, less);
  EXPECT_LT(less, 1.0);
  EXPECT_GT(more, 0.0);
  EXPECT_LT(rel_mse(noisy(ref, 0.02f, 1), ref), rel_mse(noisy(ref, 0.1f, 2), ref));
}

TEST(StudyMetrics, SsimMatchesTheDirectWindowSum) {
  // Wang et al. 2004 eqs. 13-16 written out per window with the 2D Gaussian weights (no
  // separable filtering), on the sRGB lumas, mean over the windows wholly inside the image.
  const Image ref = pattern(23, 17), img = noisy(ref, 0.05f, 3);
  const std::vector<float> x = basalt::study::srgb_luma(img), y = basalt::study::srgb_luma(ref);
  double w[11][11], wsum = 0.0;
  for (int i = 0; i < 11; ++i)
    for (int j = 0; j < 11; ++j)
      wsum += w[i][j] = std::exp(-((i - 5) * (i - 5) + (j - 5) * (j - 5)) / (2 * 1.5 * 1.5));
  double total = 0.0;
  int windows = 0;
  for (int y0 = 0; y0 + 11 <= ref.height; ++y0)
    for (int x0 = 0; x0 + 11 <= ref.width; ++x0) {
      double mx = 0, my = 0, sxx = 0, syy = 0, sxy = 0;
      for (int i = 0; i < 11; ++i)
        for (int j = 0; j < 11; ++j) {
          const std::size_t k = std::size_t(y0 + i) * ref.width + x0 + j;
          mx += w[i][j] / wsum * x[k], my += w[i][j] / wsum * y[k];
        }
      for (int i = 0; i < 11; ++i)
        for (int j = 0; j < 11; ++j) {
          const std::size_t k = std::size_t(y0 + i) * ref.width + x0 + j;
          const double a = x[k] - mx, b = y[k] - my;
          const double wk = w[i][j] / wsum;
          sxx += wk * a * a, syy += wk * b * b, sxy += wk * a * b;
        }
      const double c1 = 1e-4, c2 = 9e-4;
      total += (2 * mx * my + c1) * (2 * sxy + c2) / ((mx * mx + my * my + c1) * (sxx + syy + c2));
      ++windows;
    }
  EXPECT_EQ(windows, 13 * 7);
  EXPECT_NEAR(ssim(img, ref), total / windows, 1e-9);
}

TEST(StudyMetrics, SsimOfConstantImagesIsClosedForm) {
  // No variance anywhere: SSIM = (2ab + C1) / (a^2 + b^2 + C1) with a, b the sRGB lumas.
  const double c1 = 0.01 * 0.01;
  for (auto [ga, gb] : {std::pair{0.2f, 0.3f}, std::pair{0.05f, 0.8f}, std::pair{0.5f, 0.5f}}) {
    for (auto [w, h] : {std::pair{32, 24}, std::pair{8, 6}}) {  // windowed and whole-image
      const double a = srgb(ga), b = srgb(gb);
      EXPECT_NEAR(ssim(constant(w, h, glm::vec3(ga)), constant(w, h, glm::vec3(gb))),
                  (2 * a * b + c1) / (a * a + b * b + c1), 1e-6)
          << ga << " " << gb << " " << w << "x" << h;
    }
  }
}

TEST(StudyMetrics, DifferentSizesAreRefused) {
  EXPECT_THROW(rel_mse(constant(4, 4, glm::vec3(1)), constant(4, 5, glm::vec3(1))),
               std::invalid_argument);
  EXPECT_THROW(ssim(constant(4, 4, glm::vec3(1)), constant(5, 4, glm::vec3(1))),
               std::invalid_argument);
}
