// Rays along an axis whose origin lies in a face plane of the box ahead (docs/path-spec.md 3,
// docs/hard-cases.md case 10), shared by the CPU test (tests/cpu/cpu_unit_test.cpp) and the
// test of both sides (tests/gpu/robustness_test.cpp). The scene is one triangle, so its box is
// the BVH's and the faces are its extremes.
#pragma once
#include <vector>

#include <glm/glm.hpp>

namespace basalt::test {

/// The triangle: vertices (0, 0, 0), (1, -1, 0), (1, 1, 0).
inline std::vector<glm::vec3> axis_ray_triangle() {
  return {glm::vec3(0, 0, 0), glm::vec3(1, -1, 0), glm::vec3(1, 1, 0)};
}

/// A ray and whether it meets the triangle (at t = 5 when it does).
struct AxisRayCase {
  glm::vec3 o, d;
  bool hit;
};

/// Direction components of +0, -0 and below 1e-20; origins on the faces, inside and outside.
inline std::vector<AxisRayCase> axis_ray_cases() {
  const float z = -0.0f;
  return {
      {{0, 0, -5}, {z, 0, 1}, true},                // vertex 0 on the face x = lo, d.x = -0
      {{0, 0, -5}, {0, z, 1}, true},                // the same with d.x = +0, d.y = -0
      {{1, 1, -5}, {0, 0, 1}, true},                // vertex 2 on the faces x = hi, y = hi
      {{1, -1, 5}, {z, z, -1}, true},               // vertex 1 from behind
      {{0.5f, 0, -5}, {1e-30f, -1e-30f, 1}, true},  // components below 1e-20, inside
      {{1, 0, -5}, {z, 1e-25f, 1}, true},           // on the edge x = 1 (face x = hi)
      {{1.5f, 0, -5}, {z, 0, 1}, false},            // outside the slab in x
      {{0.5f, 1.5f, -5}, {0, z, 1}, false},         // outside the slab in y
  };
}

}  // namespace basalt::test
