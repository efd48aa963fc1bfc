// The path integrator of the CPU reference (docs/path-spec.md section 7).
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "cpu/intersect.h"
#include "cpu/texture.h"
#include "cpu/rng.h"
#include "scene/tables.h"

namespace basalt::cpu {

/// \brief Radiance along ray for the random stream r (pbrt-v4 PathIntegrator::Li as fixed by
///        spec section 7: NEE with MIS by the power heuristic, Russian roulette).
///        Non-finite results are replaced by 0.
/// \param rays if not null, incremented by the rays traced: every closest-hit ray (camera
///        and continuation) and every shadow ray, counted as the GPU's counters[0].
glm::vec3 trace_path(const SceneTables& scene, Ray ray, const PathRng& r,
                     std::uint64_t* rays = nullptr, const RayDifferential* camera_diff = nullptr);

/// \brief Radiance of one path: camera ray of pixel (px, py), sample s, traced by trace_path.
glm::vec3 path_radiance(const SceneTables& scene, std::uint32_t px, std::uint32_t py,
                        std::uint32_t s, std::uint64_t* rays = nullptr);

}  // namespace basalt::cpu
