// Image-map lookups in the CPU reference: pbrt-v4 MIPMap::Texel, Bilerp, EWA and Filter
// (util/mipmap.cpp, util/image.h) on the MipLevel / texels tables (docs/textures-spec.md 4).
// The GLSL twin is shaders/include/mipmap.glsl.
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "scene/tables.h"

namespace basalt::cpu {

/// Texel (x, y) of MipLevel `level` with wrap mode `wrap` (WRAP_*): rgb, grey broadcast;
/// want_float reads channel 0 broadcast. Outside a "black" image: 0.
glm::vec3 mipmap_texel(const SceneTables& s, std::uint32_t level, glm::ivec2 xy,
                       std::uint32_t wrap, bool want_float);

/// pbrt-v4 Image::Bilerp of MipLevel `level` at st in [0,1]^2 (rgb, grey broadcast); with
/// want_float, pbrt-v4's MIPMap::Bilerp<Float>: channel 0 of a grey image, the average of
/// r, g, b of an rgb image.
glm::vec3 mipmap_bilerp(const SceneTables& s, std::uint32_t level, glm::vec2 st,
                        std::uint32_t wrap, bool want_float);

/// pbrt-v4 MIPMap::Filter of image texture t at st with dst0 = (dsdx, dtdx), dst1 = (dsdy, dtdy).
glm::vec3 mipmap_filter(const SceneTables& s, const gpu::Texture& t, glm::vec2 st, glm::vec2 dst0,
                        glm::vec2 dst1, bool want_float);

}  // namespace basalt::cpu
