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

/// \brief A world-space camera ray with its differentials (spec section 2 step 6, pbrt-v4
///        PerspectiveCamera::GenerateRayDifferential): rx and ry are the rays through the film
///        point one pixel to the right, pFilm + (1, 0), and one pixel down, pFilm + (0, 1),
///        with the same filter offset and lens sample. All directions are unit length.
struct CameraRay {
  glm::vec3 o, d;        // the camera ray (steps 1-5)
  glm::vec3 rx_o, rx_d;  // through pFilm + (1, 0)
  glm::vec3 ry_o, ry_d;  // through pFilm + (0, 1)
};

/// \brief World-space camera ray of pixel (px, py), sample s (spec section 2 steps 1-5):
///        unit direction, tMax = FLT_MAX. Computes no differentials (the integrator does
///        not consume them); see camera_ray_differential.
Ray camera_ray(const SceneTables& scene, std::uint32_t px, std::uint32_t py, std::uint32_t s);

/// \brief The same camera ray as camera_ray (bit for bit) together with its ray
///        differentials (spec section 2 step 6).
CameraRay camera_ray_differential(const SceneTables& scene, std::uint32_t px, std::uint32_t py,
                                  std::uint32_t s);

}  // namespace basalt::cpu
