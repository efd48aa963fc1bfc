// pbrt-v4's Perlin noise and its sums (util/noise.cpp), in the CPU reference; the GLSL twin is
// shaders/include/noise.glsl. docs/textures-spec.md sections 2 and 8.
#pragma once
#include <glm/glm.hpp>

#include "scene/tables.h"

namespace basalt::cpu {

/// \brief pbrt-v4 Noise(x, y, z): improved Perlin noise with the permutation of tex_data
///        (Globals.tex_tables.x); 0 at lattice points, |n| <= 1.
float perlin_noise(const SceneTables& s, glm::vec3 p);

/// \brief pbrt-v4 FBm: octaves of noise at frequencies 1.99^i with weights omega^i, as many as
///        the footprint (dpdx, dpdy) resolves (at most max_octaves, and at most the octave cap
///        Globals.texture_opts.y when it is non-zero), the last one faded in.
float fbm(const SceneTables& s, glm::vec3 p, glm::vec3 dpdx, glm::vec3 dpdy, float omega,
          int max_octaves);

/// \brief pbrt-v4 Turbulence: as fbm with |noise|, plus 0.2 times the weight of every octave
///        the footprint leaves out (docs/textures-spec.md section 8).
float turbulence(const SceneTables& s, glm::vec3 p, glm::vec3 dpdx, glm::vec3 dpdy, float omega,
                 int max_octaves);

}  // namespace basalt::cpu
