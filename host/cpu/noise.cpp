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

namespace {

// Lattice cell and offset of one coordinate given as hi + lo (lo = 0: pbrt-v4's fp32 lookup):
// d = (hi - floor(hi)) + lo, cell = floor(hi) (wrapped as pbrt-v4's fmod(x, 2^30), exact) +
// floor(d), offset = d - floor(d) (docs/textures-spec.md 2.1).
void noise_cell(float hi, float lo, int& cell, float& offset) {
  const float f = std::floor(hi);
  float d = (hi - f) + lo;
  // lo is up to half an ulp of hi (several cells beyond 2^24): move whole cells over as an
  // integer (f + floor(d) may not be a float).
  const float fd = std::floor(d);
  d -= fd;
  cell = (int(wrap30(f)) + int(fd)) & 255;
  offset = d;
}

// Improved Perlin noise at the point hi + lo (per component).
float perlin_noise_hl(const SceneTables& s, glm::vec3 hi, glm::vec3 lo) {
  int ix, iy, iz;
  float dx, dy, dz;
  noise_cell(hi.x, lo.x, ix, dx);
  noise_cell(hi.y, lo.y, iy, dy);
  noise_cell(hi.z, lo.z, iz, dz);
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

// Veltkamp's split of a float into two halves of 12 bits (exact: a = hi + lo).
void veltkamp(float a, float& hi, float& lo) {
  const float c = 4097.0f * a;
  hi = c - (c - a);
  lo = a - hi;
}

// Dekker's exact product without fma: a b = p + e exactly (for |a b| well inside the float
// range).
void two_prod(float a, float b, float& p, float& e) {
  p = a * b;
  float ah, al, bh, bl;
  veltkamp(a, ah, al);
  veltkamp(b, bh, bl);
  e = (((ah * bh - p) + ah * bl) + al * bh) + al * bl;
}

}  // namespace

float perlin_noise(const SceneTables& s, glm::vec3 p) {
  return perlin_noise_hl(s, p, glm::vec3(0.0f));
}

float perlin_noise_scaled(const SceneTables& s, float lambda, glm::vec3 p, bool split) {
  if (!split) return perlin_noise_hl(s, lambda * p, glm::vec3(0.0f));
  glm::vec3 hi, lo;
  for (int c = 0; c < 3; ++c) two_prod(lambda, p[c], hi[c], lo[c]);
  return perlin_noise_hl(s, hi, lo);
}

bool noise_split(const SceneTables& s) {
  return (s.globals.texture_opts.x & gpu::TEXOPT_NOISE_SPLIT) != 0u;
}

namespace {

// Shirley's cubic weight w(t) = (2 a^3 - 3 a^2) + 1 for a = |t| < 1, else 0.
float shirley_weight(float t) {
  const float a = std::fabs(t);
  if (!(a < 1.0f)) return 0.0f;
  const float a2 = a * a, a3 = a2 * a;
  return (2.0f * a3 - 3.0f * a2) + 1.0f;
}

// float -> int after clamping to [-2^30, 2^30] (textures-spec 4.2's int()).
int shirley_int(float v) { return int(std::clamp(v, -1073741824.0f, 1073741824.0f)); }

}  // namespace

float shirley_noise(const SceneTables& s, glm::vec3 p) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return 0.0f;
  const float* g = s.tex_data.data() + s.globals.tex_tables.z;  // 256 gradients, then P
  const float* perm = g + 768;
  auto phi = [perm](int i) { return int(perm[((i % 256) + 256) % 256]); };
  const int ix = shirley_int(std::floor(p.x)), iy = shirley_int(std::floor(p.y)),
            iz = shirley_int(std::floor(p.z));
  float sum = 0.0f;
  for (int di = 0; di < 2; ++di) {
    const int i = ix + di;
    const float u = p.x - float(i);
    for (int dj = 0; dj < 2; ++dj) {
      const int j = iy + dj;
      const float v = p.y - float(j);
      for (int dk = 0; dk < 2; ++dk) {
        const int k = iz + dk;
        const float t = p.z - float(k);
        const float* gr = g + 3 * phi(i + phi(j + phi(k)));
        const float dot = (gr[0] * u + gr[1] * v) + gr[2] * t;
        sum += ((shirley_weight(u) * shirley_weight(v)) * shirley_weight(t)) * dot;
      }
    }
  }
  return sum;
}

glm::vec3 vector_noise(const SceneTables& s, glm::vec3 p) {
  // Shirley's n_v (seed 002 11.4): the lattice and weights of shirley_noise, each corner
  // contributing its gradient itself (docs/bump-spec.md 9).
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return glm::vec3(0.0f);
  const float* g = s.tex_data.data() + s.globals.tex_tables.z;
  const float* perm = g + 768;
  auto phi = [perm](int i) { return int(perm[((i % 256) + 256) % 256]); };
  const int ix = shirley_int(std::floor(p.x)), iy = shirley_int(std::floor(p.y)),
            iz = shirley_int(std::floor(p.z));
  glm::vec3 sum(0.0f);
  for (int di = 0; di < 2; ++di)
    for (int dj = 0; dj < 2; ++dj)
      for (int dk = 0; dk < 2; ++dk) {
        const int i = ix + di, j = iy + dj, k = iz + dk;
        const float u = p.x - float(i), v = p.y - float(j), t = p.z - float(k);
        const float* gr = g + 3 * phi(i + phi(j + phi(k)));
        const float w = (shirley_weight(u) * shirley_weight(v)) * shirley_weight(t);
        sum = sum + w * glm::vec3(gr[0], gr[1], gr[2]);
      }
  return sum;
}

glm::vec3 vector_turbulence(const SceneTables& s, glm::vec3 p, int octaves) {
  glm::vec3 sum(0.0f);
  float f = 1.0f;
  for (int i = 0; i < octaves; ++i) {
    sum = sum + vector_noise(s, f * p) / f;
    f *= 2.0f;
  }
  return sum;
}

float shirley_turbulence(const SceneTables& s, glm::vec3 p, int octaves) {
  float sum = 0.0f, f = 1.0f;
  for (int i = 0; i < octaves; ++i) {
    sum += std::fabs(shirley_noise(s, f * p)) / f;
    f *= 2.0f;
  }
  return sum;
}

namespace {

// pbrt-v4 FBm (turb false) and Turbulence (turb true), one loop: octaves at frequencies 1.99^i
// with weights omega^i, the partial one faded in; turbulence sums |noise| and adds 0.2 times
// the weight of every octave the footprint leaves out (docs/textures-spec.md section 8).
float noise_sum(const SceneTables& s, glm::vec3 p, glm::vec3 dpdx, glm::vec3 dpdy, float omega,
                int max_octaves, bool split, bool turb) {
  const float n = octave_count(s, dpdx, dpdy, max_octaves);
  const int n_int = int(std::floor(n));
  float sum = 0.0f, lambda = 1.0f, o = 1.0f;
  for (int i = 0; i < n_int; ++i) {
    const float v = perlin_noise_scaled(s, lambda, p, split);
    sum += o * (turb ? std::fabs(v) : v);
    lambda *= 1.99f;  // pbrt-v4's octave step
    o *= omega;
  }
  const float fade = smooth_step(n - float(n_int), 0.3f, 0.7f);
  const float v = perlin_noise_scaled(s, lambda, p, split);
  if (!turb) return sum + o * fade * v;
  sum += o * lerp(fade, 0.2f, std::fabs(v));
  for (int i = n_int; i < max_octaves; ++i) {
    sum += o * 0.2f;
    o *= omega;
  }
  return sum;
}

}  // namespace

float fbm(const SceneTables& s, glm::vec3 p, glm::vec3 dpdx, glm::vec3 dpdy, float omega,
          int max_octaves, bool split) {
  return noise_sum(s, p, dpdx, dpdy, omega, max_octaves, split, false);
}

float turbulence(const SceneTables& s, glm::vec3 p, glm::vec3 dpdx, glm::vec3 dpdy, float omega,
                 int max_octaves, bool split) {
  return noise_sum(s, p, dpdx, dpdy, omega, max_octaves, split, true);
}

}  // namespace basalt::cpu
