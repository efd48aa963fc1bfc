// Scenes shared by the CPU and GPU bump tests (tests/cpu/bump_test.cpp,
// tests/gpu/bump_probe_test.cpp).
#pragma once
#include <string>

#include "common/test_util.h"

namespace basalt::test {

/// Camera, a 64 x 48 film, a sky, and the bump textures every bump probe scene may use; the
/// image map file is "disp.png" in the scene's directory (tests/gpu/bump_probe_test.cpp and
/// the stress probes).
inline const char* const kBumpHead = R"(
LookAt 0 2.2 -7  0 0.4 0  0 1 0
Camera "perspective" "float fov" [ 42 ]
Film "rgb" "integer xresolution" [ 64 ] "integer yresolution" [ 48 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
AttributeBegin
  Scale 3 3 3
  Texture "fbm" "float" "fbm" "integer octaves" [ 6 ] "float roughness" [ 0.55 ]
  Texture "wr" "float" "wrinkled" "integer octaves" [ 5 ] "float roughness" [ 0.5 ]
AttributeEnd
Texture "fbm-s" "float" "scale" "texture tex" "fbm" "float scale" [ 0.08 ]
Texture "wr-s" "float" "scale" "texture tex" "wr" "float scale" [ 0.05 ]
Texture "img" "float" "imagemap" "string filename" "disp.png" "string filter" "bilinear"
    "float uscale" [ 3 ] "float vscale" [ 2 ]
Texture "img-s" "float" "scale" "texture tex" "img" "float scale" [ 0.04 ]
Texture "img-t" "float" "imagemap" "string filename" "disp.png" "string filter" "trilinear"
    "float scale" [ 0.03 ]
)";

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
