// The scene of the light-importance tests (docs/path-spec.md 6.1), shared by the CPU test
// (tests/cpu/light_importance_test.cpp) and the GPU one (tests/gpu/light_importance_gpu_test.cpp).
#pragma once
#include <cstdio>
#include <string>

#include "common/test_util.h"

namespace basalt::test {

/// A floor at y = 0 lit by a point light, a spot light (cone 30 degrees, delta 5) pointing
/// down, a one-sided quad light facing down, a small emitting sphere and a distant light,
/// 40 x 32. With \p scale the whole world (camera included) is scaled about the origin and
/// the point and spot intensities by scale^2, so that the image stays the same.
inline std::string lights_scene(int spp, float scale = 1.0f) {
  char look[128], world[64], i_point[64], i_spot[64];
  std::snprintf(look, sizeof look, "0 %g %g  0 %g 0  0 1 0", 3.0 * scale, -6.0 * scale,
                0.5 * scale);
  std::snprintf(world, sizeof world, "Scale %g %g %g\n", scale, scale, scale);
  std::snprintf(i_point, sizeof i_point, "%g", 2.0 * scale * scale);
  std::snprintf(i_spot, sizeof i_spot, "%g", 30.0 * scale * scale);
  return scene_head(look, 50, 40, 32, spp, 5) + world +
         "LightSource \"point\" \"rgb I\" [ " + i_point + " " + i_point + " " + i_point +
         " ] \"point3 from\" [ 0 4 0 ]\n"
         "LightSource \"spot\" \"rgb I\" [ " + i_spot + " " + i_spot + " " + i_spot +
         " ] \"point3 from\" [ 2 4 0 ] \"point3 to\" [ 2 0 0 ]\n"
         "  \"float coneangle\" 30 \"float conedelta\" 5\n" + R"(
LightSource "distant" "rgb L" [ 0.2 0.2 0.25 ] "point3 from" [ 1 3 -2 ] "point3 to" [ 0 0 0 ]
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 4 4 4 ]
  Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
    "point3 P" [ -2.5 2 -0.5  -1.5 2 -0.5  -1.5 2 0.5  -2.5 2 0.5 ]
AttributeEnd
AttributeBegin
  Translate 1 0.6 1.5
  AreaLightSource "diffuse" "rgb L" [ 6 3 2 ]
  Shape "sphere" "float radius" 0.1
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0.6 0.6 0.6 ]
Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
  "point3 P" [ -6 0 -6  6 0 -6  6 0 6  -6 0 6 ]
)";
}

}  // namespace basalt::test
