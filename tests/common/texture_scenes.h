// The texture scene of the texture probe tests (tests/gpu/texture_probe_test.cpp) and the
// stress probes (tests/gpu/stress_test.cpp).
#pragma once
#include <filesystem>
#include <string>

#include <glm/glm.hpp>

#include "image/image_io.h"

namespace basalt::test {

// Every procedural texture kind and mapping, each reached by a material so that its program
// is in the table; float textures reach through scale / mix / roughness slots.
inline const char* const kTextureScene = R"(
LookAt 0 3 -8  0 0.5 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "rgb" "integer xresolution" [ 32 ] "integer yresolution" [ 24 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Texture "c-uv" "spectrum" "checkerboard" "float uscale" [ 8 ] "float vscale" [ 5 ]
    "float udelta" [ 0.3 ] "rgb tex1" [ 0.9 0.1 0.2 ] "rgb tex2" [ 0.1 0.8 0.3 ]
Texture "c-sph" "spectrum" "checkerboard" "string mapping" "spherical"
    "rgb tex1" [ 1 0.5 0.25 ] "rgb tex2" [ 0 0.2 0.4 ]
Texture "c-cyl" "spectrum" "checkerboard" "string mapping" "cylindrical"
    "rgb tex1" [ 1 0.5 0.25 ] "rgb tex2" [ 0 0.2 0.4 ]
Texture "c-pl" "spectrum" "checkerboard" "string mapping" "planar" "vector3 v1" [ 1 0.5 0 ]
    "vector3 v2" [ 0 0.3 1 ] "float udelta" [ 0.25 ] "float vdelta" [ -0.5 ]
    "rgb tex1" [ 1 0.5 0.25 ] "rgb tex2" [ 0 0.2 0.4 ]
AttributeBegin
  Rotate 30 1 1 0
  Scale 0.7 0.7 0.7
  Texture "c-3d" "spectrum" "checkerboard" "integer dimension" [ 3 ]
      "rgb tex1" [ 0.8 0.3 0.1 ] "rgb tex2" [ 0.2 0.85 0.7 ]
  Texture "fbm" "float" "fbm" "integer octaves" [ 7 ] "float roughness" [ 0.6 ]
  Texture "wr" "float" "wrinkled" "integer octaves" [ 5 ] "float roughness" [ 0.45 ]
  Texture "windy" "float" "windy"
  Texture "marble" "spectrum" "marble" "integer octaves" [ 6 ] "float scale" [ 2.5 ]
      "float variation" [ 0.3 ]
AttributeEnd
Texture "dots" "spectrum" "dots" "float uscale" [ 7 ] "float vscale" [ 3 ]
    "rgb inside" [ 0.7 0.28 0.22 ] "rgb outside" [ 0.1 0.9 0.82 ]
Texture "bil" "spectrum" "bilerp" "rgb v00" [ 0.9 0.1 0.1 ] "rgb v01" [ 0.1 0.9 0.1 ]
    "rgb v10" [ 0.1 0.1 0.9 ] "rgb v11" [ 0.9 0.9 0.1 ] "string mapping" "planar"
Texture "dmix" "spectrum" "directionmix" "texture tex1" "dots" "texture tex2" "c-sph"
    "vector3 dir" [ 0.3 1 0.2 ]
Texture "fmix" "spectrum" "mix" "texture tex1" "c-uv" "texture tex2" "marble" "texture amount" "fbm"
Texture "wscale" "spectrum" "scale" "texture tex" "bil" "texture scale" "wr"
Texture "fchk" "float" "checkerboard" "float tex1" [ 0.2 ] "float tex2" [ 0.7 ]
Texture "nest" "float" "mix" "texture tex1" "fchk" "texture tex2" "windy" "texture amount" "wr"
Texture "st0" "spectrum" "stripe" "string form" "sign" "texture tex1" "c-uv" "rgb tex2" [ 0.1 0.2 0.3 ]
Texture "st1" "float" "stripe" "string form" "width" "float width" [ 0.37 ]
Texture "st2" "spectrum" "stripe" "string form" "smooth" "float width" [ 2.5 ]
    "rgb tex1" [ 0.9 0.3 0.1 ] "rgb tex2" [ 0.1 0.5 0.9 ]
AttributeBegin
  Scale 0.8 1.3 0.6
  Texture "sn" "float" "solidnoise" "float scale" [ 0.5 ] "float offset" [ 1 ]
  Texture "stu" "spectrum" "solidturbulence" "integer octaves" [ 5 ] "float scale" [ 1.3 ]
  Texture "tst" "spectrum" "turbulentstripe" "float k1" [ 6 ] "float k2" [ 2.5 ]
      "float width" [ 0.35 ] "integer octaves" [ 4 ] "texture tex1" "st2" "rgb tex2" [ 0.2 0.2 0.3 ]
  Texture "vol" "spectrum" "volume" "integer resolution" [ 2 3 2 ] "float values" [
      0.1 0.2 0.3  0.4 0.5 0.6  0.7 0.8 0.9  1.0 0.9 0.8  0.7 0.6 0.5  0.4 0.3 0.2
      0.15 0.25 0.35  0.45 0.55 0.65  0.75 0.85 0.95  0.05 0.5 0.95  0.6 0.1 0.3  0.2 0.9 0.4 ]
AttributeEnd
Texture "shmix" "spectrum" "mix" "texture tex1" "st0" "texture tex2" "vol" "texture amount" "sn"
Texture "shsc" "spectrum" "scale" "texture tex" "tst" "texture scale" "st1"
Material "diffuse" "texture reflectance" "shmix"
Shape "sphere" "float radius" [ 0.1 ]
Material "diffuse" "texture reflectance" "shsc"
Shape "sphere" "float radius" [ 0.1 ]
Material "diffuse" "texture reflectance" "stu"
Shape "sphere" "float radius" [ 0.1 ]
Material "diffuse" "texture reflectance" "c-pl"
Shape "trianglemesh" "integer indices" [ 0 1 2 0 2 3 ]
  "point3 P" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ] "point2 uv" [ 0 0 2 0 2 3 0 3 ]
Material "diffuse" "texture reflectance" "c-3d"
Shape "sphere" "float radius" [ 0.1 ]
Material "diffuse" "texture reflectance" "c-cyl"
Shape "sphere" "float radius" [ 0.1 ]
Material "diffuse" "texture reflectance" "dmix"
Shape "sphere" "float radius" [ 0.1 ]
Material "diffuse" "texture reflectance" "fmix"
Shape "sphere" "float radius" [ 0.1 ]
Material "diffuse" "texture reflectance" "wscale"
Shape "sphere" "float radius" [ 0.1 ]
Material "coateddiffuse" "texture roughness" "nest"
Shape "sphere" "float radius" [ 0.1 ]
)";

/// \brief kTextureScene plus image maps of every filter, wrap and option and Shirley's
///        interpimage with each interpolation, reading a non-power-of-two 8-bit sRGB PNG
///        (resampled pyramid, requantised levels) and a float EXR that it writes into \p dir.
inline std::string image_texture_scene(const std::filesystem::path& dir) {
  Image png{24, 20, {}}, exr{16, 16, {}};
  for (int y = 0; y < png.height; ++y)
    for (int x = 0; x < png.width; ++x)
      png.pixels.push_back(glm::vec3(float((x * 7 + y * 3) % 11) / 10.0f, float(x) / 23.0f,
                                     ((x / 3 + y / 2) % 2) ? 0.9f : 0.1f));
  for (int y = 0; y < exr.height; ++y)
    for (int x = 0; x < exr.width; ++x)
      exr.pixels.push_back(glm::vec3(0.2f + 3.0f * float(x) / 15.0f, float(y * y) / 225.0f,
                                     ((x + y) % 3) * 0.5f));
  write_image((dir / "a.png").string(), png);
  write_image((dir / "b.exr").string(), exr);
  std::string scene = kTextureScene;
  const std::string a = (dir / "a.png").string(), b = (dir / "b.exr").string();
  int k = 0;
  for (const char* filter : {"point", "bilinear", "trilinear", "ewa"})
    for (const char* wrap : {"repeat", "black", "clamp"})
      for (const std::string& file : {a, b}) {
        const std::string name = "img" + std::to_string(k++);
        const bool as_float = k % 3 == 0;
        scene += "Texture \"" + name + "\" \"" + (as_float ? "float" : "spectrum") +
                 "\" \"imagemap\" \"string filename\" \"" + file + "\" \"string filter\" \"" +
                 filter + "\" \"string wrap\" \"" + wrap + "\"" +
                 (k % 4 == 0 ? " \"bool invert\" true" : "") +
                 (k % 5 == 0 ? " \"float scale\" 1.7 \"float maxanisotropy\" 3" : "") +
                 (k % 7 == 0 ? " \"string mapping\" \"planar\"" : "") + "\n";
        scene += std::string("Material ") +
                 (as_float ? "\"coateddiffuse\" \"texture roughness\" \""
                           : "\"diffuse\" \"texture reflectance\" \"") +
                 name + "\"\nShape \"sphere\" \"float radius\" [ 0.1 ]\n";
      }
  for (const char* interp : {"nearest", "bilinear", "hermite"})
    for (const std::string& file : {a, b}) {
      const std::string name = "ia" + std::to_string(k++);
      const bool as_float = k % 3 == 0;
      scene += "Texture \"" + name + "\" \"" + (as_float ? "float" : "spectrum") +
               "\" \"interpimage\" \"string filename\" \"" + file +
               "\" \"string interpolation\" \"" + interp + "\"\n";
      scene += std::string("Material ") +
               (as_float ? "\"coateddiffuse\" \"texture roughness\" \""
                         : "\"diffuse\" \"texture reflectance\" \"") +
               name + "\"\nShape \"sphere\" \"float radius\" [ 0.1 ]\n";
    }
  return scene;
}

}  // namespace basalt::test
