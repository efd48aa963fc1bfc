// pbrt-v4's Perlin noise and its sums (util/noise.cpp), in the CPU reference; the GLSL twin is
// shaders/include/noise.glsl. docs/textures-spec.md sections 2 and 8.
#pragma once
#include <glm/glm.hpp>

#include "scene/tables.h"

namespace basalt::cpu {

/// \brief pbrt-v4 Noise(x, y, z): improved Perlin noise with the permutation of tex_data
///        (Globals.tex_tables.x); 0 at lattice points, |n| <= 1.
float perlin_noise(const SceneTables& s, glm::vec3 p);

/// \brief pbrt-v4 FBm (\p split: the lookup precision, see perlin_noise_scaled): octaves of noise at frequencies 1.99^i with weights omega^i, as many as
///        the footprint (dpdx, dpdy) resolves (at most max_octaves, and at most the octave cap
///        Globals.texture_opts.y when it is non-zero), the last one faded in.
float fbm(const SceneTables& s, glm::vec3 p, glm::vec3 dpdx, glm::vec3 dpdy, float omega,
          int max_octaves, bool split);

/// \brief pbrt-v4 Turbulence: as fbm with |noise|, plus 0.2 times the weight of every octave
///        the footprint leaves out (docs/textures-spec.md section 8).
float turbulence(const SceneTables& s, glm::vec3 p, glm::vec3 dpdx, glm::vec3 dpdy, float omega,
                 int max_octaves, bool split);

/// \brief Noise at lambda * p: with \p split false pbrt-v4's fp32 product; with it true the
///        product exact as a float pair and the lattice cell and offset taken from the pair
///        (docs/textures-spec.md 2.1), so octaves at large coordinates keep their detail.
float perlin_noise_scaled(const SceneTables& s, float lambda, glm::vec3 p, bool split);

/// \brief True if the scene's noise lookups use the split precision mode (TEXOPT_NOISE_SPLIT).
bool noise_split(const SceneTables& s);

/// \brief Shirley's solid noise (seed 002 11.1.3, docs/textures-spec.md 7): gradient noise
///        with the unit gradients and permutation of tex_data at Globals.tex_tables.z and the
///        cubic weight 2|t|^3 - 3|t|^2 + 1; 0 at lattice points, 0 for a non-finite p.
float shirley_noise(const SceneTables& s, glm::vec3 p);

/// \brief Shirley's turbulence (seed 002 11.1.4): sum over i < octaves of |n(2^i p)| / 2^i.
float shirley_turbulence(const SceneTables& s, glm::vec3 p, int octaves);

/// \brief Shirley's vector noise n_v (seed 002 11.4, docs/bump-spec.md 9): the sum over the
///        eight lattice corners of gradient x cubic weights; (0, 0, 0) for a non-finite p.
glm::vec3 vector_noise(const SceneTables& s, glm::vec3 p);

/// \brief Shirley's vector turbulence: sum over i < octaves of n_v(2^i p) / 2^i.
glm::vec3 vector_turbulence(const SceneTables& s, glm::vec3 p, int octaves);

}  // namespace basalt::cpu
