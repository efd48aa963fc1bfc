// Surface points and ray spawning of the CPU reference (docs/path-spec.md sections 4 and 5).
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "cpu/intersect.h"
#include "cpu/sampling.h"
#include "scene/tables.h"

namespace basalt::cpu {

/// Position and normals of a point on a primitive (docs/path-spec.md section 4).
struct SurfaceGeometry {
  glm::vec3 p{0.0f};
  glm::vec3 ng{0.0f, 0.0f, 1.0f};  // geometric normal, oriented as section 4 says
  glm::vec3 ns{0.0f, 0.0f, 1.0f};  // shading normal
};

/// A shaded hit: geometry, shading frame, material and area light.
struct SurfacePoint {
  SurfaceGeometry g;
  Frame frame;                                // Duff frame of ns
  std::uint32_t material = gpu::INVALID_INDEX;
  std::uint32_t light = gpu::INVALID_INDEX;   // area light of the primitive, if emissive
};

/// \brief Point of triangle tri at barycentrics (b0, b1, b2): interpolated position, ng from
///        cross(p0 - p2, p1 - p2), ns interpolated when the mesh has normals (section 4).
SurfaceGeometry triangle_geometry(const SceneTables& scene, std::uint32_t tri, float b0, float b1,
                                  float b2);

/// \brief Point of sphere index s at p (re-projected onto the sphere), normals per section 4.
SurfaceGeometry sphere_geometry(const SceneTables& scene, std::uint32_t s, glm::vec3 p);

/// \brief Shaded hit of a valid Hit of ray (b0 = 1 - b1 - b2 for triangles).
SurfacePoint surface_point(const SceneTables& scene, const Ray& ray, const Hit& hit);

/// \brief Waechter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection",
///        Ray Tracing Gems ch. 6 (2019): p moved off the surface along n (the geometric
///        normal on the side the ray leaves) by 256 n ulps per component, or by n / 65536 for
///        components with |p| < 1/32 (docs/path-spec.md section 5).
glm::vec3 offset_ray(glm::vec3 p, glm::vec3 n);

/// \brief Continuation ray from p with geometric normal ng in direction wi (section 5).
Ray spawn_ray(glm::vec3 p, glm::vec3 ng, glm::vec3 wi);

}  // namespace basalt::cpu
