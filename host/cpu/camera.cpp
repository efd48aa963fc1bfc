// Camera rays of the CPU reference (docs/path-spec.md section 2, pbrt-v4 PerspectiveCamera).
#include "cpu/camera.h"

#include <cfloat>

#include "cpu/rng.h"
#include "cpu/sampling.h"

namespace basalt::cpu {
namespace {

/// One axis of the tabulated filter distribution (pbrt-v4 FilterSampler via PiecewiseConstant1D;
/// spec section 2 step 1): the bin i with cdf[i] <= u < cdf[i+1] by binary search, then the
/// linear position inside it, mapped to [-r, r].
float sample_tabulated(const float* cdf, std::uint32_t n, float r, float u) {
  std::uint32_t lo = 0, hi = n;
  while (hi - lo > 1) {
    const std::uint32_t mid = (lo + hi) / 2;
    if (cdf[mid] <= u) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  const float width = cdf[lo + 1] - cdf[lo];
  const float du = width > 0.0f ? (u - cdf[lo]) / width : 0.0f;
  return -r + 2.0f * r * (float(lo) + du) / float(n);
}

}  // namespace

glm::vec2 filter_offset(const SceneTables& scene, glm::vec2 u) {
  const gpu::Globals& g = scene.globals;
  const float rx = g.filter_radius.x, ry = g.filter_radius.y;
  if (g.counts.z == gpu::FILTER_GAUSSIAN) {
    const std::uint32_t n = g.counts.w;
    // A missing table (malformed input) degrades to the pixel centre rather than reading past it.
    if (n == 0 || scene.filter_cdf.size() < 2 * (std::size_t(n) + 1)) return glm::vec2(0.0f);
    const float* cdf = scene.filter_cdf.data();
    return glm::vec2(sample_tabulated(cdf, n, rx, u.x), sample_tabulated(cdf + n + 1, n, ry, u.y));
  }
  // Box filter: uniform over [-r, r] (pbrt-v4 BoxFilter::Sample).
  return glm::vec2((u.x - 0.5f) * 2.0f * rx, (u.y - 0.5f) * 2.0f * ry);
}

Ray camera_ray(const SceneTables& scene, std::uint32_t px, std::uint32_t py, std::uint32_t s) {
  const gpu::Globals& g = scene.globals;
  const PathRng r{px, py, s, g.image.w};
  // Step 1-2: film position of the filter sample.
  const glm::vec2 off = filter_offset(scene, glm::vec2(r(dim::FILTER_X), r(dim::FILTER_Y)));
  const glm::vec2 film(float(px) + 0.5f + off.x, float(py) + 0.5f + off.y);
  // Step 3: screen window, then the camera-space point on the z = 1 plane.
  const float sx = g.screen.x + film.x / float(g.image.x) * (g.screen.y - g.screen.x);
  const float sy = g.screen.w - film.y / float(g.image.y) * (g.screen.w - g.screen.z);
  const float tan_half = g.lens.x;
  const glm::vec3 d(sx * tan_half, sy * tan_half, 1.0f);
  // Step 4: pinhole or thin lens (pbrt-v4 5.2.3). Every normalize is v / sqrt(dot(v, v))
  // (safe_normalize), as the GPU's; glm::normalize's v * inversesqrt differs by an ulp.
  glm::vec3 o(0.0f), dir;
  const float lens_radius = g.lens.y;
  if (lens_radius > 0.0f) {
    const glm::vec2 lens = lens_radius * concentric_disk(glm::vec2(r(dim::LENS_X), r(dim::LENS_Y)));
    const glm::vec3 focus = d * g.lens.z;
    o = glm::vec3(lens, 0.0f);
    dir = safe_normalize(focus - o);
  } else {
    dir = safe_normalize(d);
  }
  // Step 5: to world space.
  const glm::vec3 wo = glm::vec3(g.world_from_camera * glm::vec4(o, 1.0f));
  const glm::vec3 wd = safe_normalize(glm::mat3(g.world_from_camera) * dir);
  return Ray{wo, wd, FLT_MAX};
}

}  // namespace basalt::cpu
