// Camera rays of the CPU reference (docs/path-spec.md section 2, pbrt-v4 PerspectiveCamera).
#include "cpu/camera.h"

#include <cfloat>

#include "cpu/rng.h"
#include "cpu/sampler.h"
#include "cpu/sampling.h"

namespace basalt::cpu {
namespace {

/// One axis of the tabulated filter distribution (pbrt-v4 FilterSampler via PiecewiseConstant1D;
/// spec section 2 step 1): the bin i with cdf[i] <= u < cdf[i+1] by binary search, then the
/// linear position inside it, mapped to [-r, r].
float sample_tabulated(const float* cdf, std::uint32_t n, float r, float u) {
  const std::uint32_t lo = find_interval(cdf, n, u);
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

namespace {

/// The sample-dependent part of a camera ray (spec section 2 steps 1, 2 and the lens point
/// of step 4): the film position and the camera-space lens point (zero for a pinhole).
struct FilmSample {
  glm::vec2 film;
  glm::vec2 lens;
};

FilmSample film_sample(const SceneTables& scene, std::uint32_t px, std::uint32_t py,
                       std::uint32_t s) {
  const gpu::Globals& g = scene.globals;
  const PathRng r{px, py, s, g.image.w, sampler_of(scene)};
  // Step 1-2: film position of the filter sample.
  const glm::vec2 off = filter_offset(scene, glm::vec2(r(dim::FILTER_X), r(dim::FILTER_Y)));
  FilmSample fs{glm::vec2(float(px) + 0.5f + off.x, float(py) + 0.5f + off.y), glm::vec2(0.0f)};
  // Step 4's lens sample (pbrt-v4 5.2.3), drawn once and shared by the differentials.
  const float lens_radius = g.lens.y;
  if (lens_radius > 0.0f)
    fs.lens = lens_radius * concentric_disk(glm::vec2(r(dim::LENS_X), r(dim::LENS_Y)));
  return fs;
}

/// World-space ray through film point \p film (pixels) and camera-space lens point \p lens
/// (spec section 2 steps 3-5). Every normalize is v / sqrt(dot(v, v)) (safe_normalize), as
/// the GPU's; glm::normalize's v * inversesqrt differs by an ulp.
void ray_through(const gpu::Globals& g, glm::vec2 film, glm::vec2 lens, glm::vec3& wo,
                 glm::vec3& wd) {
  // Step 3: screen window, then the camera-space point on the z = 1 plane.
  const float sx = g.screen.x + film.x / float(g.image.x) * (g.screen.y - g.screen.x);
  const float sy = g.screen.w - film.y / float(g.image.y) * (g.screen.w - g.screen.z);
  const float tan_half = g.lens.x;
  const glm::vec3 d(sx * tan_half, sy * tan_half, 1.0f);
  // Step 4: pinhole or thin lens (the focal plane is z = focal distance, pFocus = d * fd).
  glm::vec3 o(0.0f), dir;
  if (g.lens.y > 0.0f) {
    const glm::vec3 focus = d * g.lens.z;
    o = glm::vec3(lens, 0.0f);
    dir = safe_normalize(focus - o);
  } else {
    dir = safe_normalize(d);
  }
  // Step 5: to world space.
  wo = glm::vec3(g.world_from_camera * glm::vec4(o, 1.0f));
  wd = safe_normalize(glm::mat3(g.world_from_camera) * dir);
}

}  // namespace

Ray camera_ray(const SceneTables& scene, std::uint32_t px, std::uint32_t py, std::uint32_t s) {
  const FilmSample fs = film_sample(scene, px, py, s);
  Ray ray{glm::vec3(0.0f), glm::vec3(0.0f), FLT_MAX};
  ray_through(scene.globals, fs.film, fs.lens, ray.o, ray.d);
  return ray;
}

CameraRay camera_ray_differential(const SceneTables& scene, std::uint32_t px, std::uint32_t py,
                                  std::uint32_t s) {
  const gpu::Globals& g = scene.globals;
  const FilmSample fs = film_sample(scene, px, py, s);
  CameraRay c;
  ray_through(g, fs.film, fs.lens, c.o, c.d);
  // Step 6: one pixel right and one pixel down on the film, same lens point.
  ray_through(g, glm::vec2(fs.film.x + 1.0f, fs.film.y), fs.lens, c.rx_o, c.rx_d);
  ray_through(g, glm::vec2(fs.film.x, fs.film.y + 1.0f), fs.lens, c.ry_o, c.ry_d);
  return c;
}

}  // namespace basalt::cpu
