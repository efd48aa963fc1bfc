// pbrt-v4's samplers on the CPU reference (docs/sampler-spec.md), without the GPU: values in
// [0,1), deterministic, keyed by seed and pixel; the stratification each sampler promises
// (one sample per stratum or elementary interval); and the convergence rate on a smooth
// integrand, fitted from the variance over seeds (randomised QMC is unbiased, so the variance
// is the mean squared error).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <set>
#include <vector>

#include "common/sampler_scenes.h"
#include "common/test_util.h"
#include "cpu/sampler.h"
#include "scene/pmj02bn.h"

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
    // halton, sobol (one sequence over the image) and pmj02bn's tables: tests below.
    if (type == "independent" || type == "halton" || type == "sobol") continue;
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
        // pmj02bn's pairs are its point sets turned by a Cranley-Patterson offset, which keeps
        // no cell structure (its sets and pixel samples are checked below).
        if (type == "pmj02bn") continue;
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

/// \brief Whether the 2^k points (x, y) (k = log2 of their count) are a (0, k, 2)-net in base 2:
/// one point in each elementary interval of area 2^-k, for every shape 2^-a x 2^-(k-a).
bool is_zero_net(const std::vector<double>& x, const std::vector<double>& y, std::string* why) {
  const std::size_t n = x.size();
  const int k = std::countr_zero(n);
  for (int a = 0; a <= k; ++a) {
    std::vector<bool> seen(n, false);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t cx = std::size_t(x[i] * double(std::size_t(1) << a));
      const std::size_t cy = std::size_t(y[i] * double(std::size_t(1) << (k - a)));
      const std::size_t cell = (cy << a) | cx;
      if (cell >= n || seen[cell]) {
        *why = "point " + std::to_string(i) + " of " + std::to_string(n) + " shares its " +
               std::to_string(1 << a) + " x " + std::to_string(1 << (k - a)) + " cell";
        return false;
      }
      seen[cell] = true;
    }
  }
  return true;
}

TEST(Sampler, SobolIsOneSequenceOverTheImage) {
  // pbrt-v4's SobolSampler: the 16 x 16 image (m = 4) at 2^j spp takes indices [0, 2^(8+j)) of
  // one Sobol' sequence. The pixel pair, placed in the image, is then its first two dimensions
  // (a (0, 8+j, 2)-net: every sample in its own pixel, the pixels' samples interleaved), and any
  // other dimension, over all pixels, one point in each of the 2^(8+j) intervals. This checks the
  // host's generator matrices and inverse table, which both renderers read.
  const SceneTables base = tables_from_string(lit_plane_scene());
  for (const char* rand : {"none", "", "owen"})
    for (std::uint32_t spp : {1u, 4u, 16u}) {
      const SceneTables t = with_sampler(base, {"sobol", rand}, int(spp));
      ASSERT_EQ(t.globals.sampler_params.x, 4u);
      const std::uint32_t n = 256 * spp;
      std::vector<double> gx, gy;
      std::vector<std::vector<std::uint32_t>> cells(4);
      for (std::uint32_t py = 0; py < 16; ++py)
        for (std::uint32_t px = 0; px < 16; ++px)
          for (std::uint32_t s = 0; s < spp; ++s) {
            gx.push_back((px + double(sampler_get(t, px, py, s, 0))) / 16.0);
            gy.push_back((py + double(sampler_get(t, px, py, s, 1))) / 16.0);
            const std::uint32_t dims[4] = {2, kDim1D, kPairX, kPairY};
            for (int k = 0; k < 4; ++k) cells[k].push_back(cell(sampler_get(t, px, py, s, dims[k]), n));
          }
      std::string why;
      EXPECT_TRUE(is_zero_net(gx, gy, &why)) << rand << " spp " << spp << ": " << why;
      for (int k = 0; k < 4; ++k) {
        std::sort(cells[k].begin(), cells[k].end());
        EXPECT_EQ(std::unique(cells[k].begin(), cells[k].end()) - cells[k].begin(), std::ptrdiff_t(n))
            << rand << " spp " << spp << " dimension slot " << k;
      }
    }
}

TEST(Sampler, Pmj02bnSetsAreProgressiveZeroTwoSequences) {
  // Every prefix of 2^k points (k = 0 .. 16) of each of the five tables is a (0, k, 2)-net,
  // pmj02's defining property (Christensen et al. 2018), checked on the host's tables that both
  // renderers read.
  const SceneTables t = with_sampler(tables_from_string(lit_plane_scene()), {"pmj02bn", ""}, 16);
  for (std::uint32_t set = 0; set < gpu::PMJ_SETS; ++set) {
    const std::uint32_t* p = &t.sampler_data[gpu::SAMPLER_TABLES + 2 * set * gpu::PMJ_SAMPLES];
    for (std::uint32_t k = 0; k <= 16; ++k) {
      std::vector<double> x, y;
      for (std::uint32_t i = 0; i < (1u << k); ++i) {
        x.push_back(p[2 * i] * 0x1p-32);
        y.push_back(p[2 * i + 1] * 0x1p-32);
      }
      std::string why;
      ASSERT_TRUE(is_zero_net(x, y, &why)) << "set " << set << " prefix 2^" << k << ": " << why;
    }
  }
}

TEST(Sampler, Pmj02bnPixelSamplesAreNetsInEachPixel) {
  // The pixel pair: each pixel's spp samples (a power of 4) are the points of set 0 that fall in
  // its cell of the tile, so they form a (0, log2 spp, 2)-net inside the pixel; pixels one tile
  // apart (256 / sqrt(spp) pixels) repeat the pattern, as pbrt-v4's.
  const SceneTables base = tables_from_string(lit_plane_scene());
  for (std::uint32_t spp : {1u, 16u, 64u}) {
    const SceneTables t = with_sampler(base, {"pmj02bn", ""}, int(spp));
    const std::uint32_t tile = 256u / std::uint32_t(std::lround(std::sqrt(double(spp))));
    EXPECT_EQ(1u << t.globals.sampler_params.x, tile);
    for (std::uint32_t px : {0u, 5u, 15u}) {
      std::vector<double> x, y;
      for (std::uint32_t s = 0; s < spp; ++s) {
        x.push_back(sampler_get(t, px, 3, s, 0));
        y.push_back(sampler_get(t, px, 3, s, 1));
        EXPECT_EQ(sampler_get(t, px + tile, 3 + tile, s, 0), x.back());
      }
      std::string why;
      EXPECT_TRUE(is_zero_net(x, y, &why)) << "spp " << spp << " px " << px << ": " << why;
    }
  }
}

TEST(Sampler, Pmj02bnBestCandidatesSpreadThePoints) {
  // The "bn" of pmj02bn: choosing each point's free digits as the best of 16 candidates keeps the
  // closest pairs apart. Over the first n points of each set: the smallest distance between two
  // points and the mean distance to the nearest neighbour (toroidal), times sqrt(n), against the
  // same construction with one candidate (plain pmj02), averaged over the five sets. The (0, 2)
  // structure fixes most digits of each new point, so only the closest pairs move much (see
  // docs/sampler-spec.md 4, pmj02bn).
  constexpr std::uint32_t n = 256;
  auto spread = [](const std::vector<std::uint32_t>& p) {
    double min_d2 = 1.0, mean = 0.0;
    for (std::uint32_t i = 0; i < n; ++i) {
      double best = 1.0;
      for (std::uint32_t j = 0; j < n; ++j) {
        if (j == i) continue;
        double dx = std::abs(p[2 * i] * 0x1p-32 - p[2 * j] * 0x1p-32);
        double dy = std::abs(p[2 * i + 1] * 0x1p-32 - p[2 * j + 1] * 0x1p-32);
        dx = std::min(dx, 1.0 - dx);
        dy = std::min(dy, 1.0 - dy);
        best = std::min(best, dx * dx + dy * dy);
      }
      min_d2 = std::min(min_d2, best);
      mean += std::sqrt(best) / n;
    }
    return std::pair(std::sqrt(min_d2 * n), mean * std::sqrt(double(n)));
  };
  double bn_min = 0, bn_mean = 0, plain_min = 0, plain_mean = 0;
  for (std::uint32_t set = 0; set < gpu::PMJ_SETS; ++set) {
    const auto [a, b] = spread(pmj02bn_set(set, 16, n));
    const auto [c, d] = spread(pmj02bn_set(set, 1, n));
    bn_min += a / gpu::PMJ_SETS;
    bn_mean += b / gpu::PMJ_SETS;
    plain_min += c / gpu::PMJ_SETS;
    plain_mean += d / gpu::PMJ_SETS;
  }
  std::printf("[ pmj02bn ] n = %u, x sqrt(n): smallest distance %.3f (one candidate %.3f), mean "
              "nearest-neighbour distance %.3f (one candidate %.3f; uniform random 0.5)\n",
              n, bn_min, plain_min, bn_mean, plain_mean);
  EXPECT_GT(bn_min, 1.25 * plain_min);
  EXPECT_GT(bn_mean, 0.6);
  // The table holds the same points (the first n of each set).
  const SceneTables t = with_sampler(tables_from_string(lit_plane_scene()), {"pmj02bn", ""}, 16);
  const std::vector<std::uint32_t> head = pmj02bn_set(2, 16, n);
  EXPECT_TRUE(std::equal(head.begin(), head.end(),
                         t.sampler_data.begin() + gpu::SAMPLER_TABLES + 2 * 2 * gpu::PMJ_SAMPLES));
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
    const double slope = fit_line(lx, ly).slope;
    std::printf("[ sampler ] %-22s MSE at 16/64/256 spp %.3g %.3g %.3g  slope %.2f\n",
                sampler_label(c).c_str(), std::exp(ly[0]), std::exp(ly[1]), std::exp(ly[2]),
                slope);
    // The rate each promises on a smooth 2D integrand: independent 1; jittered strata and
    // randomised Halton 2; scrambled (0,2)-nets 3 (Owen 1997). Faster than 1/spp by a margin,
    // and no faster than promised (a faster fit would mean a variance estimate gone wrong).
    const std::string type = c.type;
    // pmj02bn's light pair is one fixed net turned by a random offset per pixel and seed
    // (Cranley-Patterson): rate 2, like jittered strata.
    const double promised = type == "independent" ? -1.0
                            : type == "stratified" || type == "halton" || type == "pmj02bn"
                                ? -2.0
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
