// pbrt-v4's Perlin noise and its sums on the CPU (docs/textures-spec.md; pbrt-v4
// src/pbrt/util/noise.cpp, Perlin 2002 "Improving Noise").
#include "cpu/noise.h"

#include <algorithm>
#include <cmath>

namespace basalt::cpu {
namespace {

// Permutation entry i of the 512-entry table in tex_data.
int perm(const SceneTables& s, int i) { return int(s.tex_data[s.globals.tex_tables.x + i]); }

// Perlin's gradient of hash h at offset (dx, dy, dz) (pbrt-v4 Grad).
float grad(const SceneTables& s, int x, int y, int z, float dx, float dy, float dz) {
  const int h = perm(s, perm(s, perm(s, x) + y) + z) & 15;
  const float u = (h < 8 || h == 12 || h == 13) ? dx : dy;
  const float v = (h < 4 || h == 12 || h == 13) ? dy : dz;
  return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
}

// Quintic fade 6t^5 - 15t^4 + 10t^3 (Perlin 2002), powers as pbrt-v4's Pow<n> rounds them.
float fade(float t) {
  const float t2 = t * t, t3 = t2 * t, t4 = t2 * t2, t5 = t4 * t;
  return 6.0f * t5 - 15.0f * t4 + 10.0f * t3;
}

// pbrt-v4 Lerp(t, a, b) = (1 - t) a + t b.
float lerp(float t, float a, float b) { return (1.0f - t) * a + t * b; }

// fmod(x, 2^30) (pbrt-v4 Noise) written with exact operations: 2^30 trunc(x / 2^30) is
// exact and so is the difference (it is the representable remainder).
float wrap30(float x) {
  const float k = 1073741824.0f;
  return std::fabs(x) < k ? x : x - k * std::trunc(x / k);
}

// Number of octaves the footprint resolves, pbrt-v4 FBm / Turbulence:
// clamp(-1 - log2(len2) / 2, 0, max), with the octave cap applied to max.
float octave_count(const SceneTables& s, glm::vec3 dpdx, glm::vec3 dpdy, int& max_octaves) {
  const std::uint32_t cap = s.globals.texture_opts.y;
  if (cap > 0u) max_octaves = std::min(max_octaves, int(cap));
  const float len2 = std::max(glm::dot(dpdx, dpdx), glm::dot(dpdy, dpdy));
  const float l2 = std::log(len2) * 1.44269504088896341f;  // pbrt-v4 Log2
  return std::clamp(-1.0f - l2 / 2.0f, 0.0f, float(max_octaves));
}

// pbrt-v4 SmoothStep(x, a, b).
float smooth_step(float x, float a, float b) {
  const float t = std::clamp((x - a) / (b - a), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

}  // namespace

float perlin_noise(const SceneTables& s, glm::vec3 p) {
  const float x = wrap30(p.x), y = wrap30(p.y), z = wrap30(p.z);
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const float dx = x - fx, dy = y - fy, dz = z - fz;
  const int ix = int(fx) & 255, iy = int(fy) & 255, iz = int(fz) & 255;
  const float w000 = grad(s, ix, iy, iz, dx, dy, dz);
  const float w100 = grad(s, ix + 1, iy, iz, dx - 1.0f, dy, dz);
  const float w010 = grad(s, ix, iy + 1, iz, dx, dy - 1.0f, dz);
  const float w110 = grad(s, ix + 1, iy + 1, iz, dx - 1.0f, dy - 1.0f, dz);
  const float w001 = grad(s, ix, iy, iz + 1, dx, dy, dz - 1.0f);
  const float w101 = grad(s, ix + 1, iy, iz + 1, dx - 1.0f, dy, dz - 1.0f);
  const float w011 = grad(s, ix, iy + 1, iz + 1, dx, dy - 1.0f, dz - 1.0f);
  const float w111 = grad(s, ix + 1, iy + 1, iz + 1, dx - 1.0f, dy - 1.0f, dz - 1.0f);
  const float wx = fade(dx), wy = fade(dy), wz = fade(dz);
  const float x00 = lerp(wx, w000, w100), x10 = lerp(wx, w010, w110);
  const float x01 = lerp(wx, w001, w101), x11 = lerp(wx, w011, w111);
  const float y0 = lerp(wy, x00, x10), y1 = lerp(wy, x01, x11);
  return lerp(wz, y0, y1);
}

float fbm(const SceneTables& s, glm::vec3 p, glm::vec3 dpdx, glm::vec3 dpdy, float omega,
          int max_octaves) {
  const float n = octave_count(s, dpdx, dpdy, max_octaves);
  const int n_int = int(std::floor(n));
  float sum = 0.0f, lambda = 1.0f, o = 1.0f;
  for (int i = 0; i < n_int; ++i) {
    sum += o * perlin_noise(s, lambda * p);
    lambda *= 1.99f;  // pbrt-v4's octave step
    o *= omega;
  }
  const float partial = n - float(n_int);
  sum += o * smooth_step(partial, 0.3f, 0.7f) * perlin_noise(s, lambda * p);
  return sum;
}

float turbulence(const SceneTables& s, glm::vec3 p, glm::vec3 dpdx, glm::vec3 dpdy, float omega,
                 int max_octaves) {
  const float n = octave_count(s, dpdx, dpdy, max_octaves);
  const int n_int = int(std::floor(n));
  float sum = 0.0f, lambda = 1.0f, o = 1.0f;
  for (int i = 0; i < n_int; ++i) {
    sum += o * std::fabs(perlin_noise(s, lambda * p));
    lambda *= 1.99f;
    o *= omega;
  }
  const float partial = n - float(n_int);
  sum += o * lerp(smooth_step(partial, 0.3f, 0.7f), 0.2f, std::fabs(perlin_noise(s, lambda * p)));
  // pbrt-v4 adds 0.2 o for every octave left out, starting with the weight of the partial one.
  for (int i = n_int; i < max_octaves; ++i) {
    sum += o * 0.2f;
    o *= omega;
  }
  return sum;
}

}  // namespace basalt::cpu
