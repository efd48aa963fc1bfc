// Sampler resolution and tables (docs/sampler-spec.md 3).
#include "samplers.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

namespace basalt {

namespace {

/// Inverse of a modulo n for coprime a, n (extended Euclid); 0 when n is 1.
std::uint32_t inverse_mod(std::int64_t a, std::int64_t n) {
  if (n <= 1) return 0;
  std::int64_t r0 = n, r1 = a % n, x0 = 0, x1 = 1;
  while (r1 != 0) {
    const std::int64_t q = r0 / r1;
    std::tie(r0, r1) = std::pair(r1, r0 - q * r1);
    std::tie(x0, x1) = std::pair(x1, x0 - q * x1);
  }
  return std::uint32_t(((x0 % n) + n) % n);
}

/// The first \p n primes (trial division; n is small).
std::vector<std::uint32_t> first_primes(std::uint32_t n) {
  std::vector<std::uint32_t> p;
  for (std::uint32_t c = 2; p.size() < n; ++c)
    if (std::none_of(p.begin(), p.end(), [c](std::uint32_t q) { return q * q <= c && c % q == 0; }))
      p.push_back(c);
  return p;
}

}  // namespace

const std::vector<std::string>& sampler_names() {
  static const std::vector<std::string> names = {"independent", "stratified", "halton",
                                                 "paddedsobol", "zsobol"};
  return names;
}

Sampler resolve_sampler(const Sampler& s, std::string* warning) {
  Sampler r = s;
  if (r.type == "stratified" && r.xsamples * r.ysamples != r.spp) {
    // pbrt-v4 StratifiedSampler::Create with --spp: the most square factorisation.
    int div = int(std::sqrt(double(r.spp)));
    while (div > 1 && r.spp % div) --div;
    r.ysamples = r.spp / std::max(div, 1);
    r.xsamples = r.spp / r.ysamples;
  }
  if (r.type == "zsobol" && !std::has_single_bit(unsigned(r.spp))) {
    r.spp = int(std::bit_floor(unsigned(r.spp)));
    if (warning)
      *warning = "basalt: warning: Sampler 'zsobol' takes a power-of-two sample count: " +
                 std::to_string(s.spp) + " samples rendered as " + std::to_string(r.spp) +
                 " (as pbrt-v4)";
  }
  return r;
}

void sampler_tables(SceneTables& t, const Sampler& s) {
  gpu::Globals& g = t.globals;
  const auto& names = sampler_names();
  const std::uint32_t type =
      std::uint32_t(std::find(names.begin(), names.end(), s.type) - names.begin());
  std::uint32_t rand = gpu::RAND_FASTOWEN;
  if (type == gpu::SAMPLER_HALTON) rand = gpu::RAND_PERMUTE;
  if (s.randomization == "none") rand = gpu::RAND_NONE;
  if (s.randomization == "permutedigits") rand = gpu::RAND_PERMUTE;
  if (s.randomization == "fastowen") rand = gpu::RAND_FASTOWEN;
  if (s.randomization == "owen") rand = gpu::RAND_OWEN;
  g.sampler_opts = glm::uvec4(type < names.size() ? type : gpu::SAMPLER_INDEPENDENT, rand,
                         std::uint32_t(s.spp), 0u);
  g.sampler_params = glm::uvec4(0u);
  // Specialisation: the render pipeline compiles the code of this sampler only (layout.h).
  static const std::uint32_t kFeature2[] = {0u, gpu::FEATURE2_SAMPLER_STRATIFIED,
                                            gpu::FEATURE2_SAMPLER_HALTON,
                                            gpu::FEATURE2_SAMPLER_PADDED_SOBOL,
                                            gpu::FEATURE2_SAMPLER_ZSOBOL};
  t.features2 = (t.features2 & ~gpu::FEATURE2_SAMPLERS) | kFeature2[g.sampler_opts.x];
  g.features.y = t.features2;
  const std::uint32_t w = t.width(), h = t.height();
  switch (type) {
    case gpu::SAMPLER_STRATIFIED:
      g.sampler_opts = glm::uvec4(type, s.jitter ? 1u : 0u, std::uint32_t(s.xsamples),
                             std::uint32_t(s.ysamples));
      break;
    case gpu::SAMPLER_HALTON: {
      // pbrt-v4 HaltonSampler: scales 2^j >= min(width, 128) and 3^k >= min(height, 128).
      std::uint32_t scale[2] = {1, 1}, exps[2] = {0, 0};
      const std::uint32_t base[2] = {2, 3}, limit[2] = {std::min(w, 128u), std::min(h, 128u)};
      for (int i = 0; i < 2; ++i)
        while (scale[i] < limit[i]) {
          scale[i] *= base[i];
          ++exps[i];
        }
      g.sampler_params = glm::uvec4(scale[0] | scale[1] << 16, exps[0] | exps[1] << 16,
                                    inverse_mod(scale[1], scale[0]),
                                    inverse_mod(scale[0], scale[1]));
      break;
    }
    case gpu::SAMPLER_ZSOBOL: {
      const std::uint32_t l = std::uint32_t(std::countr_zero(unsigned(s.spp)));
      const std::uint32_t res = std::bit_ceil(std::max(w, h));
      g.sampler_params = glm::uvec4(l, std::uint32_t(std::countr_zero(res)) + (l + 1) / 2, 0u, 0u);
      break;
    }
    default:
      break;
  }
  t.sampler_data = first_primes(gpu::SAMPLER_PRIME_COUNT);
}

}  // namespace basalt
