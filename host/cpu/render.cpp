// Multithreaded image rendering of the CPU reference (docs/path-spec.md section 9).
#include "cpu/render.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>

#include "cpu/integrator.h"
#include "scene/samplers.h"

namespace basalt::cpu {

std::uint64_t render(const SceneTables& scene, std::uint32_t sample_start, std::uint32_t sample_count,
            std::vector<glm::vec4>& accum, const std::function<void(double)>& progress,
            std::uint64_t* nonfinite_samples) {
  check_sample_count(scene.globals, sample_start + sample_count);
  const std::uint32_t w = scene.width(), h = scene.height();
  const std::size_t npix = std::size_t(w) * h;
  if (accum.size() != npix) accum.assign(npix, glm::vec4(0.0f));
  if (npix == 0 || sample_count == 0) {
    if (progress) progress(1.0);
    return 0;
  }
  constexpr std::uint32_t TILE = 16;
  const std::uint32_t tiles_x = (w + TILE - 1) / TILE, tiles_y = (h + TILE - 1) / TILE;
  const std::uint32_t ntiles = tiles_x * tiles_y;
  std::atomic<std::uint32_t> next{0}, done{0};
  std::atomic<std::uint64_t> total_rays{0}, total_nonfinite{0};

  // Worker: takes tiles until none are left; worker 0 (the calling thread) reports progress.
  auto work = [&](bool reporter) {
    std::uint64_t rays = 0, nonfinite = 0;
    for (;;) {
      const std::uint32_t t = next.fetch_add(1, std::memory_order_relaxed);
      if (t >= ntiles) break;
      const std::uint32_t x0 = (t % tiles_x) * TILE, y0 = (t / tiles_x) * TILE;
      const std::uint32_t x1 = std::min(x0 + TILE, w), y1 = std::min(y0 + TILE, h);
      for (std::uint32_t y = y0; y < y1; ++y) {
        for (std::uint32_t x = x0; x < x1; ++x) {
          glm::vec3 sum(0.0f);
          for (std::uint32_t s = sample_start; s < sample_start + sample_count; ++s) {
            glm::vec3 L = path_radiance(scene, x, y, s, &rays);
            // A NaN or infinity would poison the pixel: dropped and counted (path-spec 9).
            if (!std::isfinite(L.x) || !std::isfinite(L.y) || !std::isfinite(L.z)) {
              L = glm::vec3(0.0f);
              ++nonfinite;
            }
            sum += L;
          }
          accum[std::size_t(y) * w + x] += glm::vec4(sum, float(sample_count));
        }
      }
      const std::uint32_t d = done.fetch_add(1, std::memory_order_relaxed) + 1;
      if (reporter && progress) progress(double(d) / double(ntiles));
    }
    total_rays.fetch_add(rays, std::memory_order_relaxed);
    total_nonfinite.fetch_add(nonfinite, std::memory_order_relaxed);
  };

  const unsigned nthreads = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> threads;
  threads.reserve(nthreads - 1);
  for (unsigned i = 1; i < nthreads; ++i) threads.emplace_back(work, false);
  work(true);
  for (std::thread& t : threads) t.join();
  if (progress) progress(1.0);
  if (nonfinite_samples) *nonfinite_samples += total_nonfinite.load();
  return total_rays.load();
}

}  // namespace basalt::cpu
