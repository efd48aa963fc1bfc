// Texture evaluation in the CPU reference (docs/textures-spec.md): the evaluation context of
// a hit, its pixel footprint, and the post-order texture programs of the Texture table. The
// GLSL twin is shaders/include/texture.glsl.
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "scene/tables.h"

namespace basalt::cpu {

/// pbrt-v4 TextureEvalContext (docs/textures-spec.md section 1).
struct TextureContext {
  glm::vec3 p{0.0f};
  glm::vec3 n{0.0f, 0.0f, 1.0f};
  glm::vec2 uv{0.0f};
  glm::vec3 dpdx{0.0f}, dpdy{0.0f};
  float dudx = 0.0f, dudy = 0.0f, dvdx = 0.0f, dvdy = 0.0f;
};

/// A ray's differential rays (docs/textures-spec.md 3.1 says which rays carry them).
struct RayDifferential {
  glm::vec3 rx_o, rx_d, ry_o, ry_d;
};

/// \brief pbrt-v4 RayDifferential::ScaleDifferentials (docs/textures-spec.md 3.1): the
///        differential rays of a ray (o, d) moved towards it by the factor \p s.
void scale_differentials(RayDifferential& diff, glm::vec3 o, glm::vec3 d, float s);

/// \brief Footprint of a hit (docs/textures-spec.md section 3, pbrt-v4
///        SurfaceInteraction::ComputeDifferentials): fills dpdx, dpdy and the (u, v)
///        differentials of \p ctx (p, n, uv set) from the ray's differentials \p diff or,
///        without them, approximate_dp_dxy; zero when texture filtering is disabled.
///        dpdu, dpdv: the surface's partial derivatives.
void compute_differentials(const SceneTables& s, TextureContext& ctx, glm::vec3 dpdu,
                           glm::vec3 dpdv, const RayDifferential* diff);

/// \brief Differentials of the ray leaving a perfectly specular bounce (docs/textures-spec.md
///        3.1, pbrt-v4 SurfaceInteraction::SpawnRay): \p ctx the hit's footprint, \p o the
///        spawned ray's origin, ns the shading normal with derivatives dndu, dndv, wo = -d of
///        the incoming ray (which had differentials \p in), wi the sampled world direction,
///        \p transmission the sampled kind, eta its relative IOR. Returns false when pbrt-v4
///        drops them (too large).
bool specular_differentials(const TextureContext& ctx, glm::vec3 o, glm::vec3 ns, glm::vec3 dndu,
                            glm::vec3 dndv, glm::vec3 wo, glm::vec3 wi, bool transmission,
                            float eta, const RayDifferential& in, RayDifferential& out);

/// \brief pbrt-v4 CameraBase::Approximate_dp_dxy with the minimum differentials of Globals.
void approximate_dp_dxy(const SceneTables& s, glm::vec3 p, glm::vec3 n, glm::vec3& dpdx,
                        glm::vec3& dpdy);

/// \brief Value of the rgb texture program with root instruction \p root.
glm::vec3 tex_eval_rgb(const SceneTables& s, std::uint32_t root, const TextureContext& ctx);
/// \brief Value of the float texture program with root instruction \p root.
float tex_eval_float(const SceneTables& s, std::uint32_t root, const TextureContext& ctx);

}  // namespace basalt::cpu
