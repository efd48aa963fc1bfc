// Counter-based random numbers of the CPU reference (docs/path-spec.md section 1).
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

namespace basalt::cpu {

/// Random dimensions of docs/path-spec.md section 1 (table "Dimensions").
namespace dim {
inline constexpr std::uint32_t FILTER_X = 0, FILTER_Y = 1, LENS_X = 2, LENS_Y = 3;
inline constexpr std::uint32_t BOUNCE_BASE = 4, BOUNCE_STRIDE = 16;
inline constexpr std::uint32_t LIGHT_SELECT = 0, LIGHT_U0 = 1, LIGHT_U1 = 2, BSDF_LOBE = 3,
                               BSDF_U0 = 4, BSDF_U1 = 5, ROULETTE = 6;
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

/// The random stream of one path: rng() with pixel, sample and seed fixed.
struct PathRng {
  std::uint32_t px, py, sample, seed;
  /// Value of dimension d of this path.
  float operator()(std::uint32_t d) const { return rng(px, py, sample, d, seed); }
};

}  // namespace basalt::cpu
