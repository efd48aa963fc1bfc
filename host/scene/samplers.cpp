// Sampler resolution and tables (docs/sampler-spec.md 3).
#include "samplers.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "pmj02bn.h"

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

/// One row of Joe and Kuo's table: polynomial degree s, inner coefficients a, m_1 .. m_s.
struct SobolDirection {
  std::uint32_t s, a;
  std::uint32_t m[13];
};

/// Joe and Kuo's direction numbers (new-joe-kuo-6.21201) for dimensions 1 .. 1023.
constexpr SobolDirection kSobolDirections[] = {
#include "sobol_directions.inc"
};
static_assert(std::size(kSobolDirections) == gpu::SOBOL_DIMENSIONS - 1);

/// The generator matrices of Sobol' dimensions 0 .. 1023, SOBOL_COLUMNS 32-bit columns each:
/// dimension 0 is van der Corput, the others Bratley and Fox's recurrence (ACM TOMS 14, 1988)
/// on Joe and Kuo's direction numbers, v_k = m_k / 2^k truncated to 32 bits.
std::vector<std::uint32_t> sobol_matrices() {
  constexpr std::uint32_t C = gpu::SOBOL_COLUMNS;
  std::vector<std::uint32_t> out(std::size_t(gpu::SOBOL_DIMENSIONS) * C, 0u);
  for (std::uint32_t j = 0; j < 32; ++j) out[j] = 1u << (31 - j);
  for (std::uint32_t dim = 1; dim < gpu::SOBOL_DIMENSIONS; ++dim) {
    const SobolDirection& d = kSobolDirections[dim - 1];
    std::uint32_t* v = &out[std::size_t(dim) * C];  // v[k - 1] = v_k
    for (std::uint32_t k = 1; k <= d.s; ++k) v[k - 1] = d.m[k - 1] << (32 - k);
    for (std::uint32_t k = d.s + 1; k <= C; ++k) {
      std::uint32_t x = v[k - d.s - 1] ^ (v[k - d.s - 1] >> d.s);
      for (std::uint32_t i = 1; i < d.s; ++i)
        if ((d.a >> (d.s - 1 - i)) & 1u) x ^= v[k - i - 1];
      v[k - 1] = x;
    }
  }
  return out;
}

/// INV(b), b < 2m (docs/sampler-spec.md 3): the 2m-bit index whose first two Sobol' dimensions
/// have top-m digits equal to bit b of (x << m) | y; Gauss-Jordan elimination over GF(2) on the
/// images of the unit indices.
std::vector<std::uint32_t> sobol_inverse(const std::vector<std::uint32_t>& mat, std::uint32_t m) {
  const std::uint32_t n = 2 * m;
  // Rows (image, preimage): image of unit index k under r -> (top_m(dim 0) << m) | top_m(dim 1).
  std::vector<std::pair<std::uint64_t, std::uint64_t>> rows;
  for (std::uint32_t k = 0; k < n; ++k) {
    const std::uint64_t img = (std::uint64_t(mat[k] >> (32 - m)) << m) |
                              (mat[gpu::SOBOL_COLUMNS + k] >> (32 - m));
    rows.emplace_back(img, std::uint64_t(1) << k);
  }
  std::vector<std::uint32_t> inv(n, 0u);
  for (std::uint32_t b = 0; b < n; ++b) {
    auto piv = std::find_if(rows.begin() + b, rows.end(),
                            [b](const auto& r) { return (r.first >> b) & 1u; });
    if (piv == rows.end()) throw std::logic_error("Sobol' dimensions 0 and 1 are not a (0,2)-sequence");
    std::swap(rows[b], *piv);
    for (std::uint32_t k = 0; k < n; ++k)
      if (k != b && ((rows[k].first >> b) & 1u)) {
        rows[k].first ^= rows[b].first;
        rows[k].second ^= rows[b].second;
      }
  }
  for (std::uint32_t b = 0; b < n; ++b) inv[b] = std::uint32_t(rows[b].second);
  return inv;
}

/// Smallest power of 4 at least n.
std::uint32_t round_up_pow4(std::uint32_t n) {
  std::uint32_t q = 1;
  while (q < n) q *= 4;
  return q;
}

/// pmj02bn's pixel samples (docs/sampler-spec.md 4): set 0 sorted into a tile of 2^tbits x
/// 2^tbits pixels, the first spp points of each tile pixel in index order, as positions inside
/// the pixel.
std::vector<std::uint32_t> pmj02bn_pixel_table(const std::vector<std::uint32_t>& sets,
                                               std::uint32_t spp, std::uint32_t tbits) {
  const std::uint32_t tile = 1u << tbits;
  std::vector<std::uint32_t> out(2 * std::size_t(tile) * tile * spp, 0u), stored(tile * tile, 0u);
  for (std::uint32_t i = 0; i < gpu::PMJ_SAMPLES; ++i) {
    const std::uint32_t x = sets[2 * i], y = sets[2 * i + 1];
    const std::uint32_t tx = tbits == 0 ? 0 : x >> (32 - tbits);
    const std::uint32_t ty = tbits == 0 ? 0 : y >> (32 - tbits);
    const std::uint32_t p = tx + ty * tile;
    if (stored[p] == spp) continue;  // spp not a power of 4: the tile pixel keeps its first spp
    const std::size_t at = 2 * (std::size_t(p) * spp + stored[p]++);
    out[at] = x << tbits;
    out[at + 1] = y << tbits;
  }
  return out;
}

}  // namespace

void check_sample_count(const gpu::Globals& g, std::uint32_t end) {
  const glm::uvec4 o = g.sampler_opts;
  const std::uint64_t built = o.x == gpu::SAMPLER_STRATIFIED ? std::uint64_t(o.z) * o.w : o.z;
  if (o.x != gpu::SAMPLER_INDEPENDENT && end > built)
    throw std::invalid_argument("the sampler was built for " + std::to_string(built) +
                                " samples per pixel, not " + std::to_string(end) +
                                " (build the tables with the sample count rendered)");
}

const std::vector<std::string>& sampler_names() {
  static const std::vector<std::string> names = {"independent", "stratified", "halton",
                                                 "paddedsobol", "zsobol",     "sobol",
                                                 "pmj02bn"};
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
  if (r.type == "sobol" && !std::has_single_bit(unsigned(r.spp)) && warning)
    *warning = "basalt: warning: Sampler 'sobol': " + std::to_string(r.spp) +
               " samples per pixel is not a power of two and performs sub-optimally (as "
               "pbrt-v4 warns)";
  if (r.type == "pmj02bn") {
    if (r.spp > int(gpu::PMJ_SAMPLES))
      throw std::invalid_argument("Sampler 'pmj02bn' supports at most 65536 samples per pixel "
                                  "(as pbrt-v4), not " + std::to_string(r.spp));
    if (round_up_pow4(std::uint32_t(r.spp)) != std::uint32_t(r.spp) && warning)
      *warning = "basalt: warning: Sampler 'pmj02bn' gives its best results with a power of 4 "
                 "samples per pixel (1, 4, 16, 64, ...), not " + std::to_string(r.spp) +
                 " (as pbrt-v4 warns)";
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
                                            gpu::FEATURE2_SAMPLER_ZSOBOL,
                                            gpu::FEATURE2_SAMPLER_SOBOL,
                                            gpu::FEATURE2_SAMPLER_PMJ02BN};
  t.features2 = (t.features2 & ~(gpu::FEATURE2_SAMPLERS | gpu::FEATURE2_SAMPLER_OWEN)) |
                kFeature2[g.sampler_opts.x];
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
  if (type == gpu::SAMPLER_SOBOL) {
    // pbrt-v4 SobolSampler: one sequence over the image, scaled to the next power of two.
    const std::uint32_t m = std::uint32_t(std::countr_zero(std::bit_ceil(std::max(w, h))));
    const std::uint32_t sbits = std::uint32_t(std::bit_width(std::uint32_t(s.spp - 1)));
    if (m > 16 || 2 * m + sbits > gpu::SOBOL_COLUMNS)
      throw std::invalid_argument(
          "Sampler 'sobol': a " + std::to_string(w) + " x " + std::to_string(h) + " image at " +
          std::to_string(s.spp) + " samples per pixel needs sample indices above 2^52 (use "
          "zsobol, or fewer pixels or samples)");
    g.sampler_params = glm::uvec4(m, 0u, 0u, 0u);
    const std::vector<std::uint32_t> mat = sobol_matrices(), inv = sobol_inverse(mat, m);
    t.sampler_data.insert(t.sampler_data.end(), mat.begin(), mat.end());
    t.sampler_data.insert(t.sampler_data.end(), inv.begin(), inv.end());
  } else if (type == gpu::SAMPLER_PMJ02BN) {
    const std::uint32_t n = std::uint32_t(s.spp);
    if (n > gpu::PMJ_SAMPLES)
      throw std::invalid_argument("Sampler 'pmj02bn' supports at most 65536 samples per pixel");
    const std::uint32_t tbits = 8 - std::uint32_t(std::countr_zero(round_up_pow4(n))) / 2;
    g.sampler_params = glm::uvec4(tbits, 0u, 0u, 0u);
    g.sampler_opts.y = gpu::RAND_NONE;  // no randomisation but its offsets (sampler-spec 4)
    const std::vector<std::uint32_t>& sets = pmj02bn_sets();
    const std::vector<std::uint32_t> pix = pmj02bn_pixel_table(sets, n, tbits);
    t.sampler_data.insert(t.sampler_data.end(), sets.begin(), sets.end());
    t.sampler_data.insert(t.sampler_data.end(), pix.begin(), pix.end());
  }
  // Full Owen scrambling's loop is compiled in only where a sampler runs it (layout.h).
  if (g.sampler_opts.x != gpu::SAMPLER_INDEPENDENT && g.sampler_opts.y == gpu::RAND_OWEN)
    t.features2 |= gpu::FEATURE2_SAMPLER_OWEN;
  g.features.y = t.features2;
}

}  // namespace basalt
