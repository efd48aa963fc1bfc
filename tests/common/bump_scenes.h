// Scenes shared by the CPU and GPU bump tests (tests/cpu/bump_test.cpp,
// tests/gpu/bump_probe_test.cpp).
#pragma once
#include <string>

#include "common/test_util.h"

namespace basalt::test {

/// A plane bumped by a steep stripe (\p bumped) or not, with tilted vertex normals, under a
/// sky, 48 x 48: the flip case of Bump.LargeDisplacementFlip and its GPU twin.
inline std::string steep_scene(bool bumped) {
  return scene_head("0 0 3  0 0 0  0 1 0", 30, 48, 48, 64, 5) + R"(
LightSource "infinite" "rgb L" [ 1 1 1 ]
Texture "steep" "float" "stripe" "string form" "smooth" "float width" [ 0.1 ]
  "float tex1" [ 0 ] "float tex2" [ 0.2 ]
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ] )" +
           (bumped ? "\"texture displacement\" \"steep\"" : "") + R"(
Shape "trianglemesh" "point3 P" [ -2 -2 0  2 -2 0  2 2 0  -2 2 0 ]
  "integer indices" [ 0 1 2  0 2 3 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
  "normal N" [ 0.5 0 1  0.5 0 1  0.5 0 1  0.5 0 1 ]
)";
}

}  // namespace basalt::test
