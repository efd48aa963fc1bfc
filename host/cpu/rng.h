// Counter-based random numbers of the CPU reference (docs/path-spec.md section 1).
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

namespace basalt {
struct SceneTables;
}

namespace basalt::cpu {

/// Value of path dimension d under the scene's sampler (cpu/sampler.cpp).
float sampler_get(const SceneTables& scene, std::uint32_t px, std::uint32_t py,
                  std::uint32_t s, std::uint32_t d);

/// Random dimensions of docs/path-spec.md section 1 (table "Dimensions").
namespace dim {
inline constexpr std::uint32_t FILTER_X = 0, FILTER_Y = 1, LENS_X = 2, LENS_Y = 3;
inline constexpr std::uint32_t BOUNCE_BASE = 4, BOUNCE_STRIDE = 16;
inline constexpr std::uint32_t LIGHT_SELECT = 0, LIGHT_U0 = 1, LIGHT_U1 = 2, BSDF_LOBE = 3,
                               BSDF_U0 = 4, BSDF_U1 = 5, ROULETTE = 6;
/// Streams of docs/materials-spec.md section 5: NEE bsdf_eval, NEE bsdf_pdf, bsdf_sample and
/// the bsdf_pdf that replaces a proportional sample pdf.
inline constexpr std::uint32_t STREAM_NEE_EVAL = 7, STREAM_NEE_PDF = 8, STREAM_SAMPLE = 9,
                               STREAM_SAMPLE_PDF = 10;
/// Dimension of slot k (LIGHT_SELECT...ROULETTE) of bounce b.
constexpr std::uint32_t bounce(std::uint32_t b, std::uint32_t k) {
  return BOUNCE_BASE + BOUNCE_STRIDE * b + k;
}
}  // namespace dim

/// Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 9(3) 2020: pcg4d, as spelled
/// out in docs/path-spec.md section 1 (32-bit wrapping arithmetic).
inline glm::uvec4 pcg4d(glm::uvec4 v) {
  v = v * 1664525u + 1013904223u;
  v.x += v.y * v.w;
  v.y += v.z * v.x;
  v.z += v.x * v.y;
  v.w += v.y * v.z;
  v ^= v >> 16u;
  v.x += v.y * v.w;
  v.y += v.z * v.x;
  v.z += v.x * v.y;
  v.w += v.y * v.z;
  return v;
}

/// Uniform float in [0,1) for pixel (px,py), sample s, dimension d and scene seed
/// (docs/path-spec.md section 1: key (px, py, s, d ^ (seed * 0x9E3779B9)), top 24 bits).
inline float rng(std::uint32_t px, std::uint32_t py, std::uint32_t sample, std::uint32_t d,
                 std::uint32_t seed) {
  const glm::uvec4 v = pcg4d(glm::uvec4(px, py, sample, d ^ (seed * 0x9E3779B9u)));
  return float(v.x >> 8) * 0x1p-24f;
}

/// \brief Base key of the stream (px, py, s, d) for scene seed `seed`
///        (docs/materials-spec.md section 5): uvec4(px, py, s, d ^ (seed * 0x9E3779B9)).
inline glm::uvec4 stream_key(std::uint32_t px, std::uint32_t py, std::uint32_t sample,
                             std::uint32_t d, std::uint32_t seed) {
  return glm::uvec4(px, py, sample, d ^ (seed * 0x9E3779B9u));
}

/// \brief Element j of the stream with base key `key` (docs/materials-spec.md section 5):
///        float(pcg4d(key + (0, 0, 0, (j + 1) * 0x01000193)).x >> 8) 2^-24.
inline float stream_element(glm::uvec4 key, std::uint32_t j) {
  const glm::uvec4 v = pcg4d(key + glm::uvec4(0u, 0u, 0u, (j + 1u) * 0x01000193u));
  return float(v.x >> 8) * 0x1p-24f;
}

/// A stream being consumed: each call returns the next element (j = 0, 1, 2, ...), the
/// replacement of pbrt-v4's `r()` in LayeredBxDF.
struct Stream {
  glm::uvec4 key;
  std::uint32_t j = 0;
  /// Next element of the stream.
  float operator()() { return stream_element(key, j++); }
};

/// The random stream of one path: the scene's sampler (docs/sampler-spec.md) with pixel,
/// sample and seed fixed; `sampler` (the scene) is null for the
/// independent sampler, which is rng().
struct PathRng {
  std::uint32_t px, py, sample, seed;
  const SceneTables* sampler = nullptr;  // the scene, for samplers other than independent
  /// Value of dimension d of this path.
  float operator()(std::uint32_t d) const {
    return sampler ? sampler_get(*sampler, px, py, sample, d) : rng(px, py, sample, d, seed);
  }
  /// Base key of the stream of dimension d of this path (docs/materials-spec.md section 5).
  glm::uvec4 stream(std::uint32_t d) const { return stream_key(px, py, sample, d, seed); }
};

}  // namespace basalt::cpu
