// Camera rays of the CPU reference (docs/path-spec.md section 2, pbrt-v4 PerspectiveCamera).
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "cpu/intersect.h"
#include "scene/tables.h"

namespace basalt::cpu {

/// \brief Film-plane offset of the pixel filter sample for u = (rng dim 0, rng dim 1):
///        box or tabulated gaussian (spec section 2 step 1; weight is always 1).
glm::vec2 filter_offset(const SceneTables& scene, glm::vec2 u);

/// \brief World-space camera ray of pixel (px, py), sample s (spec section 2 steps 1-5):
///        unit direction, tMax = FLT_MAX. Ray differentials (step 6) are not computed yet:
///        nothing consumes them before texture filtering exists.
Ray camera_ray(const SceneTables& scene, std::uint32_t px, std::uint32_t py, std::uint32_t s);

}  // namespace basalt::cpu
