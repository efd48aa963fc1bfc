// pbrt-v4's samplers on the CPU reference (docs/sampler-spec.md), without the GPU: values in
// [0,1), deterministic, keyed by seed and pixel; the stratification each sampler promises
// (one sample per stratum or elementary interval); and the convergence rate on a smooth
// integrand, fitted from the variance over seeds (randomised QMC is unbiased, so the variance
// is the mean squared error).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <vector>

#include "common/sampler_scenes.h"
#include "common/test_util.h"
#include "cpu/sampler.h"

namespace basalt::test {
namespace {

using cpu::sampler_get;

/// Path dimensions of one 1D sample and the two components of one pair (path-spec 1).
constexpr std::uint32_t kDim1D = 4 + 16 * 1 + 3, kPairX = 4 + 16 * 2 + 4, kPairY = kPairX + 1;

/// Index of the interval of width 1/n holding u.
std::uint32_t cell(float u, std::uint32_t n) { return std::uint32_t(double(u) * n); }

TEST(Sampler, ValuesAreInTheUnitIntervalDeterministicAndKeyed) {
  const SceneTables base = tables_from_string(lit_plane_scene());
  for (const SamplerCase& c : sampler_cases()) {
    const SceneTables t = with_sampler(base, c, 16);
    SceneTables t2 = t;
    set_seed(t2, 99);
    std::size_t same_seed = 0, same_pixel = 0, n = 0;
    for (std::uint32_t d = 0; d < 4 + 16 * 6; ++d)
      for (std::uint32_t s = 0; s < 16; ++s) {
        const float u = sampler_get(t, 3, 5, s, d);
        ASSERT_TRUE(u >= 0.0f && u < 1.0f) << sampler_label(c) << " d " << d << " s " << s;
        ASSERT_EQ(u, sampler_get(t, 3, 5, s, d));  // deterministic
        same_seed += u == sampler_get(t2, 3, 5, s, d);
        same_pixel += u == sampler_get(t, 4, 5, s, d);
        ++n;
      }
    // Unrandomised samplers repeat across seeds by design (halton's pixel dimensions and all
    // of "none"); otherwise a seed or a pixel changes almost every value.
    if (std::string(c.randomization) != "none") {
      EXPECT_LT(same_seed, n / 10) << sampler_label(c);
    }
    EXPECT_LT(same_pixel, n / 10) << sampler_label(c);
  }
}

TEST(Sampler, EachSamplerKeepsItsStratification) {
  const SceneTables base = tables_from_string(lit_plane_scene());
  for (const SamplerCase& c : sampler_cases()) {
    const std::string type = c.type;
    if (type == "independent" || type == "halton") continue;  // halton: next test
    for (std::uint32_t spp : {16u, 64u}) {
      const SceneTables t = with_sampler(base, c, int(spp));
      for (std::uint32_t px : {0u, 7u, 15u}) {
        // 1D: one sample in each interval [k/spp, (k+1)/spp).
        std::set<std::uint32_t> cells1, cells2, rows, cols;
        for (std::uint32_t s = 0; s < spp; ++s) {
          cells1.insert(cell(sampler_get(t, px, 3, s, kDim1D), spp));
          const float x = sampler_get(t, px, 3, s, kPairX), y = sampler_get(t, px, 3, s, kPairY);
          // 2D: stratified: one per cell of its n0 x n1 grid; Sobol' pairs: a (0,m,2)-net, one
          // sample per elementary interval of area 1/spp, checked for the shapes 1 x spp,
          // spp x 1 and sqrt x sqrt.
          const std::uint32_t q = std::uint32_t(std::lround(std::sqrt(double(spp))));
          cells2.insert(cell(x, q) * q + cell(y, q));
          cols.insert(cell(x, spp));
          rows.insert(cell(y, spp));
        }
        EXPECT_EQ(cells1.size(), spp) << sampler_label(c) << " spp " << spp << " px " << px;
        EXPECT_EQ(cells2.size(), spp) << sampler_label(c) << " spp " << spp << " px " << px;
        if (type != "stratified") {
          EXPECT_EQ(cols.size(), spp) << sampler_label(c) << " spp " << spp;
          EXPECT_EQ(rows.size(), spp) << sampler_label(c) << " spp " << spp;
        }
      }
    }
  }
}

TEST(Sampler, HaltonIsStratifiedInItsBases) {
  // A pixel's Halton indices are s * stride + offset, stride = 2^j 3^k: dimension 2 (base 5) of
  // 25 consecutive samples falls once in each fifth, pbrt-v4's pixel dimensions (bases 2 and 3
  // of the index's high digits) once in each 1/16 and 1/27 over 16 and 27 samples. The first
  // bounce's light selection (ld 6, base 17) is one per 1/17 over 17 samples.
  const SceneTables base = tables_from_string(lit_plane_scene());
  for (const char* rand : {"", "none", "owen"}) {
    const SceneTables t = with_sampler(base, {"halton", rand}, 1024);
    for (std::uint32_t px : {0u, 9u}) {
      std::set<std::uint32_t> fx, fy, l17;
      for (std::uint32_t s = 0; s < 16; ++s) fx.insert(cell(sampler_get(t, px, 2, s, 0), 16));
      for (std::uint32_t s = 0; s < 27; ++s) fy.insert(cell(sampler_get(t, px, 2, s, 1), 27));
      for (std::uint32_t s = 0; s < 17; ++s) l17.insert(cell(sampler_get(t, px, 2, s, 4), 17));
      EXPECT_EQ(fx.size(), 16u) << rand;
      EXPECT_EQ(fy.size(), 27u) << rand;
      EXPECT_EQ(l17.size(), 17u) << rand;
    }
  }
}

/// The mean squared error of the lit plane's pixels at \p spp under case \p c: the variance of
/// each pixel over \p seeds seeds (unbiased estimators), averaged over pixels and channels.
double mse_over_seeds(const SceneTables& base, const SamplerCase& c, std::uint32_t spp,
                      std::uint32_t seeds) {
  std::vector<std::vector<glm::vec3>> imgs;
  for (std::uint32_t k = 0; k < seeds; ++k) {
    SceneTables t = with_sampler(base, c, int(spp));
    set_seed(t, 1000 + k);
    imgs.push_back(render(Side::Cpu, t, spp));
  }
  double sum = 0.0;
  for (std::size_t i = 0; i < imgs[0].size(); ++i)
    for (int ch = 0; ch < 3; ++ch) {
      double m = 0.0, m2 = 0.0;
      for (const auto& im : imgs) m += im[i][ch];
      m /= seeds;
      for (const auto& im : imgs) m2 += (im[i][ch] - m) * (im[i][ch] - m);
      sum += m2 / (seeds - 1);
    }
  return sum / (3.0 * double(imgs[0].size()));
}

TEST(Sampler, LowDiscrepancySamplersConvergeFasterThanOneOverSpp) {
  // Direct light from a uniform sky, light sampling only (--mis light): each pixel is a smooth
  // integral over the light pair, whose upper half holds cos theta. MSE ~ spp^slope.
  SceneTables base = tables_from_string(lit_plane_scene());
  apply_path_knobs(base, -1, 1u, gpu::MIS_LIGHT_ONLY);
  const std::vector<std::uint32_t> spps = {16, 64, 256};
  for (const SamplerCase& c : sampler_cases()) {
    if (std::string(c.randomization) == "none") continue;  // deterministic: no variance
    std::vector<double> lx, ly;
    for (std::uint32_t spp : spps) {
      lx.push_back(std::log(double(spp)));
      ly.push_back(std::log(mse_over_seeds(base, c, spp, 8)));
    }
    // Least-squares slope of log MSE against log spp.
    const double n = double(lx.size());
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t i = 0; i < lx.size(); ++i) {
      sx += lx[i];
      sy += ly[i];
      sxx += lx[i] * lx[i];
      sxy += lx[i] * ly[i];
    }
    const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    std::printf("[ sampler ] %-22s MSE at 16/64/256 spp %.3g %.3g %.3g  slope %.2f\n",
                sampler_label(c).c_str(), std::exp(ly[0]), std::exp(ly[1]), std::exp(ly[2]),
                slope);
    // The rate each promises on a smooth 2D integrand: independent 1; jittered strata and
    // randomised Halton 2; scrambled (0,2)-nets 3 (Owen 1997). Faster than 1/spp by a margin,
    // and no faster than promised (a faster fit would mean a variance estimate gone wrong).
    const std::string type = c.type;
    const double promised = type == "independent" ? -1.0
                            : type == "stratified" || type == "halton" ? -2.0
                                                                         : -3.0;
    if (type == "independent") {
      EXPECT_NEAR(slope, -1.0, 0.25) << sampler_label(c);
    } else {
      EXPECT_LT(slope, -1.5) << sampler_label(c);
      EXPECT_GT(slope, promised - 0.3) << sampler_label(c);
    }
  }
}

}  // namespace
}  // namespace basalt::test
