// pbrt-v4's samplers (docs/sampler-spec.md), written from the spec on the CPU side:
// stratified, halton, paddedsobol, zsobol, sobol and pmj02bn; independent is rng() of
// path-spec 1.
#include "cpu/sampler.h"

#include <algorithm>
#include <array>
#include <bit>

#include "cpu/rng.h"
#include "scene/sobol.h"

namespace basalt::cpu {

namespace {

using u32 = std::uint32_t;
using u64 = std::uint64_t;

/// A 32-bit binary fraction as a float in [0,1), exact (sampler-spec 1 `to_unit`).
float to_unit(u32 x) { return float(x >> 8) * 0x1p-24f; }

/// Wellons' "lowbias32" integer hash ("Prospecting for Hash Functions", 2018).
u32 mix32(u32 x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

/// pcg4d of four words (sampler-spec 1 `hash4`).
glm::uvec4 hash4(u32 a, u32 b, u32 c, u32 d) { return pcg4d(glm::uvec4(a, b, c, d)); }

/// Element i of the random permutation of [0, n) chosen by p (Kensler, "Correlated
/// Multi-Jittered Sampling", Pixar TM 13-01, 2013; pbrt-v4 PermutationElement).
u32 permutation_element(u32 i, u32 n, u32 p) {
  u32 w = n - 1;
  w |= w >> 1;
  w |= w >> 2;
  w |= w >> 4;
  w |= w >> 8;
  w |= w >> 16;
  do {
    i ^= p;
    i *= 0xe170893du;
    i ^= p >> 16;
    i ^= (i & w) >> 4;
    i ^= p >> 8;
    i *= 0x0929eb3fu;
    i ^= p >> 23;
    i ^= (i & w) >> 1;
    i *= 1u | p >> 27;
    i *= 0x6935fa69u;
    i ^= (i & w) >> 11;
    i *= 0x74dcb303u;
    i ^= (i & w) >> 2;
    i *= 0x9e501cc3u;
    i ^= (i & w) >> 2;
    i *= 0xc860a3dfu;
    i &= w;
    i ^= i >> 5;
  } while (i >= n);
  return (i + p) % n;
}

/// Randomises a 32-bit fraction with seed h (pbrt-v4 lowdiscrepancy.h: BinaryPermute,
/// FastOwen after Laine & Karras 2011 and Burley, JCGT 9(4) 2020, and bitwise Owen).
u32 scramble(u32 v, u32 h, u32 rand) {
  switch (rand) {
    case gpu::RAND_PERMUTE:
      return v ^ h;
    case gpu::RAND_FASTOWEN:
      v = reverse_bits(v);
      v ^= v * 0x3d20adeau;
      v += h;
      v *= (h >> 16) | 1u;
      v ^= v * 0x05526c56u;
      v ^= v * 0x53a22864u;
      return reverse_bits(v);
    case gpu::RAND_OWEN:
      if (h & 1u) v ^= 1u << 31;
      for (u32 b = 1; b < 32; ++b) {
        const u32 mask = ~0u << (32 - b);
        if (mix32((v & mask) ^ h) & (1u << b)) v ^= 1u << (31 - b);
      }
      return v;
    default:
      return v;
  }
}

/// Where path dimension d lands in the sampler (sampler-spec 2).
struct LdDim {
  u32 ld = 0;
  u32 c = 0;           // component of a pair
  bool pair = false;
  bool pixel = false;  // the filter pair (pbrt-v4 GetPixel2D)
  bool valid = false;  // false: an independent dimension
};

/// The sampler dimension of path dimension d (sampler-spec 2 table).
LdDim ld_dim(u32 d) {
  LdDim r;
  if (d < 2) return {0u, d, true, true, true};
  if (d < 4) return {4u, d - 2, true, false, true};
  const u32 k = (d - 4) % 16, b = (d - 4) / 16, base = 6 + 7 * b;
  switch (k) {
    case 0: return {base, 0, false, false, true};
    case 1: case 2: return {base + 1, k - 1, true, false, true};
    case 3: return {base + 3, 0, false, false, true};
    case 4: case 5: return {base + 4, k - 4, true, false, true};
    case 6: return {base + 6, 0, false, false, true};
    default: return r;
  }
}

/// (k + j 2^-24) / q quantised to 24 bits (sampler-spec 4, stratified `frac`).
float strat_frac(u32 k, u32 q, u32 j) {
  return float(u32(((u64(k) << 24) | j) / u64(q))) * 0x1p-24f;
}

/// pbrt-v4 StratifiedSampler (sampler-spec 4).
float stratified_get(const gpu::Globals& g, u32 px, u32 py, u32 s, const LdDim& l) {
  const u32 seed = g.image.w, n0 = g.sampler_opts.z, n1 = g.sampler_opts.w;
  const u32 stratum = permutation_element(s, n0 * n1, hash4(px, py, l.ld, seed).x);
  auto jitter = [&](u32 c) {
    return g.sampler_opts.y == 0u ? 1u << 23
                                  : hash4(px, py, s, (l.ld * 2u + c) ^ (seed * 0x9E3779B9u)).z >> 8;
  };
  if (!l.pair) return strat_frac(stratum, n0 * n1, jitter(0));
  return l.c == 0 ? strat_frac(stratum % n0, n0, jitter(0)) : strat_frac(stratum / n0, n1, jitter(1));
}

/// Digits of v in base `base`, n of them, in reverse order (pbrt-v4 InverseRadicalInverse).
u64 inverse_radical_inverse(u64 v, u32 base, u32 n) {
  u64 r = 0;
  for (u32 i = 0; i < n; ++i) {
    r = r * base + v % base;
    v /= base;
  }
  return r;
}

/// Radical inverse of a in base `base` over the digits that fit 2^40, exact in integers, with
/// pbrt-v4's digit permutation or Owen scrambling (sampler-spec 4, halton).
float radical_inverse(u32 base, u64 a, u32 rand, u32 seed) {
  u32 n = 0;
  u64 big = 1;
  while (big * base <= (u64(1) << 40)) {
    big *= base;
    ++n;
  }
  const u32 owen_seed = hash4(base, seed, 0x0E3u, 0u).x;
  u64 r = 0;
  for (u32 j = 0; j < n; ++j) {
    u32 digit = u32(a % base);
    a /= base;
    if (rand == gpu::RAND_PERMUTE || rand == gpu::RAND_FASTOWEN)
      digit = permutation_element(digit, base, hash4(base, j, seed, 0x0D16u).x);
    else if (rand == gpu::RAND_OWEN)
      digit = permutation_element(digit, base, mix32(u32(r) ^ u32(r >> 32) ^ owen_seed));
    r = r * base + digit;
  }
  // Down in base 2, up in odd bases: a value on a stratum boundary stays in its stratum.
  const u64 q = base == 2u ? (r << 24) / big
                           : std::min<u64>(((r << 24) + big - 1) / big, (u64(1) << 24) - 1);
  return float(u32(q)) * 0x1p-24f;
}

/// pbrt-v4 HaltonSampler (sampler-spec 4).
float halton_get(const SceneTables& t, u32 px, u32 py, u32 s, const LdDim& l) {
  const gpu::Globals& g = t.globals;
  const u32 scale0 = g.sampler_params.x & 0xffffu, scale1 = g.sampler_params.x >> 16;
  const u32 exp0 = g.sampler_params.y & 0xffffu, exp1 = g.sampler_params.y >> 16;
  const u64 stride = u64(scale0) * scale1;
  u64 off = inverse_radical_inverse(px % 128u, 2u, exp0) * (stride / scale0) * g.sampler_params.z;
  off += inverse_radical_inverse(py % 128u, 3u, exp1) * (stride / scale1) * g.sampler_params.w;
  const u64 index = off % stride + u64(s) * stride;
  if (l.pixel)
    return l.c == 0 ? radical_inverse(2u, index >> exp0, gpu::RAND_NONE, 0u)
                    : radical_inverse(3u, index / scale1, gpu::RAND_NONE, 0u);
  u32 dim = l.ld + l.c;
  if (dim >= gpu::SAMPLER_PRIME_COUNT) dim = 2u + (dim - 2u) % (gpu::SAMPLER_PRIME_COUNT - 2u);
  return radical_inverse(t.sampler_data[dim], index, g.sampler_opts.y, g.image.w);
}

/// pbrt-v4 PaddedSobolSampler (sampler-spec 4).
float padded_sobol_get(const gpu::Globals& g, u32 px, u32 py, u32 s, const LdDim& l) {
  const glm::uvec4 hv = hash4(px, py, l.ld, g.image.w);
  const u32 index = permutation_element(s, g.sampler_opts.z, hv.x), rand = g.sampler_opts.y;
  if (!l.pair) return to_unit(scramble(sobol0(index), hv.y, rand));
  return l.c == 0 ? to_unit(scramble(sobol0(index), hv.x, rand))
                  : to_unit(scramble(sobol1(index), hv.y, rand));
}

/// Spreads the 32 bits of x to the even bit positions of a 64-bit word.
u64 spread_bits(u32 x) {
  u64 v = x;
  v = (v | (v << 16)) & 0x0000ffff0000ffffull;
  v = (v | (v << 8)) & 0x00ff00ff00ff00ffull;
  v = (v | (v << 4)) & 0x0f0f0f0f0f0f0f0full;
  v = (v | (v << 2)) & 0x3333333333333333ull;
  v = (v | (v << 1)) & 0x5555555555555555ull;
  return v;
}

/// Interleaves the bits of x (even positions) and y (odd positions).
u64 morton2(u32 x, u32 y) { return spread_bits(x) | (spread_bits(y) << 1); }

/// The 24 permutations of (0, 1, 2, 3) in lexicographic order, element i of permutation p at
/// bits 2i of entry p (built once by decoding p in the factorial number system).
const std::array<std::uint8_t, 24>& perm4_table() {
  static const std::array<std::uint8_t, 24> table = [] {
    std::array<std::uint8_t, 24> t{};
    const u32 fact[4] = {6, 2, 1, 1};
    for (u32 p = 0; p < 24; ++p) {
      u32 left[4] = {0, 1, 2, 3}, n = 4, q = p, packed = 0;
      for (u32 i = 0; i < 4; ++i) {
        const u32 k = q / fact[i];
        q %= fact[i];
        packed |= left[k] << (2 * i);
        for (u32 j = k; j + 1 < n; ++j) left[j] = left[j + 1];
        --n;
      }
      t[p] = std::uint8_t(packed);
    }
    return t;
  }();
  return table;
}

/// Element `digit` of the p-th permutation of (0, 1, 2, 3) in lexicographic order.
u32 perm4(u32 p, u32 digit) { return (perm4_table()[p] >> (2 * digit)) & 3u; }

/// Hash of a 64-bit value and a sampler dimension (sampler-spec 4, zsobol).
u32 digit_hash(u64 v, u32 ld) { return mix32(u32(v) ^ mix32(u32(v >> 32)) ^ (0x55555555u * ld)); }

/// pbrt-v4 ZSobolSampler (sampler-spec 4; Ahmed & Wonka, SIGGRAPH Asia 2020).
float zsobol_get(const gpu::Globals& g, u32 px, u32 py, u32 s, const LdDim& l) {
  const u32 log2spp = g.sampler_params.x, digits = g.sampler_params.y, odd = log2spp & 1u;
  const u64 morton = (morton2(px, py) << log2spp) | s;
  u64 idx = 0;
  for (int i = int(digits) - 1; i >= int(odd); --i) {
    const u32 shift = 2u * u32(i) - odd;
    const u32 digit = u32(morton >> shift) & 3u;
    const u32 p = (digit_hash(morton >> (shift + 2), l.ld) >> 24) % 24u;
    idx |= u64(perm4(p, digit)) << shift;
  }
  if (odd) idx |= (morton & 1u) ^ (digit_hash(morton >> 1, l.ld) & 1u);
  const glm::uvec4 hv = hash4(l.ld, g.image.w, 0x2B50u, 0u);
  const u32 rand = g.sampler_opts.y;
  if (!l.pair || l.c == 0) return to_unit(scramble(sobol0(u32(idx)), hv.x, rand));
  return to_unit(scramble(sobol1(u32(idx)), hv.y, rand));
}

/// Sobol' sample of the uint64 index i in dimension dim: the xor of the generator-matrix columns
/// of i's set bits (sampler-spec 4, sobol; the matrices are in sampler_data).
u32 sobol_sample(const SceneTables& t, u64 i, u32 dim) {
  const u32* col = &t.sampler_data[gpu::SAMPLER_TABLES + dim * gpu::SOBOL_COLUMNS];
  u32 v = 0;
  for (u32 j = 0; i != 0 && j < gpu::SOBOL_COLUMNS; ++j, i >>= 1)
    if (i & 1u) v ^= col[j];
  return v;
}

/// pbrt-v4 SobolSampler (sampler-spec 4): the index of sample s inside pixel (px, py) of one
/// Sobol' sequence over the image (Grünschloß et al., MCQMC 2012), then its dimensions.
float sobol_get(const SceneTables& t, u32 px, u32 py, u32 s, const LdDim& l) {
  const gpu::Globals& g = t.globals;
  const u32 m = g.sampler_params.x;
  u32 delta = 0;
  if (m > 0)
    for (u32 c = 0, f = s; f != 0; ++c, f >>= 1)
      if (f & 1u) delta ^= t.sampler_data[gpu::SAMPLER_TABLES + gpu::SOBOL_COLUMNS + 2 * m + c] >> (32 - m);
  const u64 target = (u64(px) << m) | u64(py ^ delta);
  u32 r = 0;
  for (u32 b = 0; b < 2 * m; ++b)
    if ((target >> b) & 1u) r ^= t.sampler_data[gpu::SOBOL_INVERSE + b];
  const u64 index = (u64(s) << (2 * m)) | r;
  if (l.pixel) return to_unit(sobol_sample(t, index, l.c) << m);
  u32 e = l.ld + l.c;
  if (e >= gpu::SOBOL_DIMENSIONS) e = 2u + (e - 2u) % (gpu::SOBOL_DIMENSIONS - 2u);
  return to_unit(scramble(sobol_sample(t, index, e), hash4(e, g.image.w, 0x50B01u, 0u).x,
                          g.sampler_opts.y));
}

/// pbrt-v4 PMJ02BNSampler (sampler-spec 4; Christensen, Kensler and Kilpatrick, EGSR 2018) on
/// basalt's own point sets, with Cranley-Patterson offsets from the pixel hash.
float pmj02bn_get(const SceneTables& t, u32 px, u32 py, u32 s, const LdDim& l) {
  const gpu::Globals& g = t.globals;
  const u32 n = g.sampler_opts.z, tbits = g.sampler_params.x;
  if (l.pixel) {
    const u32 mask = (1u << tbits) - 1u;
    const u32 p = (px & mask) + ((py & mask) << tbits);
    return to_unit(t.sampler_data[gpu::PMJ_PIXEL_TABLE + 2 * (p * n + s) + l.c]);
  }
  const glm::uvec4 hv = hash4(px, py, l.ld, g.image.w);
  if (!l.pair) return strat_frac(permutation_element(s, n, hv.x), n, hv.y >> 8);
  const u32 inst = l.ld / 2;
  const u32 index = inst >= 5 ? permutation_element(s, n, hv.x) : s;
  const u32 v = t.sampler_data[gpu::SAMPLER_TABLES +
                               2 * ((inst % gpu::PMJ_SETS) * gpu::PMJ_SAMPLES + index) + l.c];
  return to_unit(v + (l.c == 0 ? hv.y : hv.z));
}

}  // namespace

float sampler_get(const SceneTables& scene, u32 px, u32 py, u32 s, u32 d) {
  const gpu::Globals& g = scene.globals;
  const LdDim l = ld_dim(d);
  if (!l.valid) return rng(px, py, s, d, g.image.w);
  switch (g.sampler_opts.x) {
    case gpu::SAMPLER_STRATIFIED: return stratified_get(g, px, py, s, l);
    case gpu::SAMPLER_HALTON: return halton_get(scene, px, py, s, l);
    case gpu::SAMPLER_PADDED_SOBOL: return padded_sobol_get(g, px, py, s, l);
    case gpu::SAMPLER_ZSOBOL: return zsobol_get(g, px, py, s, l);
    case gpu::SAMPLER_SOBOL: return sobol_get(scene, px, py, s, l);
    case gpu::SAMPLER_PMJ02BN: return pmj02bn_get(scene, px, py, s, l);
    default: return rng(px, py, s, d, g.image.w);
  }
}

}  // namespace basalt::cpu
