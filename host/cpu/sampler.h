// pbrt-v4's samplers on the CPU (docs/sampler-spec.md): the value of path dimension d of
// sample s of pixel (px, py), bit-identical to shaders/include/sampler.glsl.
#pragma once
#include <cstdint>

#include "scene/tables.h"

namespace basalt::cpu {

/// \brief Value in [0,1) of path dimension \p d (docs/path-spec.md 1) of sample \p s of pixel
/// (\p px, \p py) under the scene's sampler (Globals.sampler_opts; docs/sampler-spec.md 4).
float sampler_get(const SceneTables& scene, std::uint32_t px, std::uint32_t py, std::uint32_t s,
                  std::uint32_t d);

/// The scene for PathRng when its sampler is not the independent one, else null (rng()).
inline const SceneTables* sampler_of(const SceneTables& scene) {
  return scene.globals.sampler_opts.x == gpu::SAMPLER_INDEPENDENT ? nullptr : &scene;
}

}  // namespace basalt::cpu
