// Ray-primitive intersection and BVH traversal of the CPU reference
// (docs/path-spec.md section 3).
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "scene/tables.h"

namespace basalt::cpu {

/// A ray o + t d; hits count for 0 < t < tmax (d need not be unit length, only non-zero).
struct Ray {
  glm::vec3 o;
  glm::vec3 d;
  float tmax;
};

/// A hit: distance t, primitive reference (prim_refs value: triangle index, or sphere index |
/// PRIM_SPHERE_BIT) and barycentrics b1, b2 of vertices v1, v2 (triangles only).
struct Hit {
  float t = -1;
  std::uint32_t prim = gpu::INVALID_INDEX;
  float b1 = 0, b2 = 0;
  /// True if the ray hit something.
  bool valid() const { return prim != gpu::INVALID_INDEX; }
};

/// Result of one primitive test: t (> 0) or a miss (t < 0), and barycentrics b1, b2.
struct PrimHit {
  float t = -1.0f;
  float b1 = 0.0f, b2 = 0.0f;
};

/// \brief Watertight ray-triangle test (Woop, Benthin & Wald, JCGT 2(1) 2013; pbrt-v4 6.5.3)
///        without the double-precision fallback and the conservative t bound.
/// \return t in (0, tmax) and (b1, b2), or t = -1 for a miss (including det == 0 and a
///         triangle whose cross(p0 - p2, p1 - p2) is the zero vector).
PrimHit intersect_triangle(glm::vec3 o, glm::vec3 d, float tmax, glm::vec3 p0, glm::vec3 p1,
                           glm::vec3 p2);

/// \brief Ray-sphere test with pbrt-v4 6.2.2's robust quadratic, in world space.
/// \return t in (0, tmax) (the nearer positive root) or t = -1 for a miss.
PrimHit intersect_sphere(glm::vec3 o, glm::vec3 d, float tmax, glm::vec3 center, float radius);

/// \brief Closest hit of the ray among all primitives of the BVH; on equal t the smaller
///        primitive reference wins (docs/path-spec.md section 3), so the result does not
///        depend on the traversal order. Empty tables: a miss.
Hit intersect_closest(const SceneTables& scene, const Ray& ray);

/// \brief True if anything is hit at 0 < t < ray.tmax (shadow rays).
bool intersect_any(const SceneTables& scene, const Ray& ray);

/// \brief Tests the ray against one primitive reference (triangle or sphere | PRIM_SPHERE_BIT).
PrimHit intersect_prim(const SceneTables& scene, std::uint32_t ref, glm::vec3 o, glm::vec3 d,
                       float tmax);

}  // namespace basalt::cpu
