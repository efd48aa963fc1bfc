// Bump and normal mapping of the CPU reference (docs/bump-spec.md sections 3-6): pbrt-v4's
// BumpMap and NormalMap (materials.h) and the shading-geometry update of
// SurfaceInteraction::GetBSDF (interaction.cpp). Same names as the GLSL twins
// (shaders/include/bump.glsl): bump_map, normal_map, bump_shading.
#pragma once
#include <cstdint>
#include <functional>

#include <glm/glm.hpp>

#include "../../shaders/shared/layout.h"
#include "cpu/surface.h"
#include "cpu/texture.h"
#include "scene/tables.h"

namespace basalt::cpu {

/// A displacement D(c): its value in texture context c (bump-spec 4).
using Displacement = std::function<float(const TextureContext&)>;

/// The bump quality knobs of bump-spec 4.5 (defaults: pbrt-v4's BumpMap).
struct BumpKnobs {
  bool central = false;     ///< central differences instead of forward ones
  bool dndu = true;         ///< the d dn/du, d dn/dv terms of the chain rule
  float fixed_step = 0.0f;  ///< du = dv = this when positive, else from the footprint
};

/// The bump knobs held in Globals.texture_opts (TEXOPT_BUMP_*, z = fixed step's bits).
BumpKnobs bump_knobs(const gpu::Globals& g);

/// \brief bump-spec 4 (pbrt-v4 BumpMap) with the displacement \p D: the bumped partial
///        derivatives dpdu', dpdv' of the hit \p sp, from its texture context sp.tex (p, uv
///        and footprint), shading normal sp.g.ns, shading pair (sp.sdpdu, sp.sdpdv) and
///        sp.g.dndu, sp.g.dndv. Forward differences of step du = (|dudx| + |dudy|) / 2
///        (0.0005 when zero), likewise dv; \p knobs may change that (bump-spec 4.5).
void bump_map(const Displacement& D, const SurfacePoint& sp, glm::vec3& dpdu, glm::vec3& dpdv,
              const BumpKnobs& knobs = {});

/// \brief bump_map with D = the displacement slot (SLOT_DISPLACEMENT) of material \p m:
///        tex_eval_float of its texture program, or its constant; knobs from scene.globals.
void bump_map(const SceneTables& scene, const gpu::Material& m, const SurfacePoint& sp,
              glm::vec3& dpdu, glm::vec3& dpdv);

/// \brief bump-spec 5 (pbrt-v4 NormalMap): dpdu', dpdv' from the normal map in MipLevel
///        \p level (level 0 of an rgb image, read linear) at sp's uv, in the frame of sp's
///        shading pair and normal. False when there is no normal map at this hit (the
///        texel is (0.5, 0.5, 0.5) or not finite, or sdpdu is zero or unusable).
bool normal_map(const SceneTables& scene, std::uint32_t level, const SurfacePoint& sp,
                glm::vec3& dpdu, glm::vec3& dpdv);

/// \brief bump-spec 6 steps 2-4 (pbrt-v4 SetShadingGeometry(..., false)): the shading normal
///        n' = normalize(cross(dpdu, dpdv)), face-forwarded to sp.g.ng, becomes sp.g.ns and
///        shading_frame(n', dpdu) becomes sp.frame. False (sp unchanged) when n' is zero or
///        not finite.
bool set_shading_geometry(SurfacePoint& sp, glm::vec3 dpdu, glm::vec3 dpdv);

/// \brief bump-spec 9 (Shirley's vector turbulence, a basalt extension) of material \p m on
///        sp's current shading normal and pair (\p dpdu, \p dpdv, updated): the normal
///        perturbed by k1 vector_turbulence(k2 p), the pair rebuilt around it as bump-spec 5.4
///        does, then set_shading_geometry. False (nothing changed) when degenerate.
bool vector_turbulence_shading(const SceneTables& scene, const gpu::Material& m,
                               SurfacePoint& sp, glm::vec3& dpdu, glm::vec3& dpdv);

/// \brief bump-spec 6: for material \p m (already resolved from any mix), the normal map if
///        MATFLAG_NORMALMAP, else the bump if MATFLAG_BUMP, then the vector turbulence if
///        MATFLAG_VTURB, applied to sp's shading normal and frame. Returns true when the frame changed. \p dpdu_out, \p dpdv_out (optional)
///        receive dpdu', dpdv' when it did, else the unbumped shading pair of bump-spec 3.
bool bump_shading(const SceneTables& scene, const gpu::Material& m, SurfacePoint& sp,
                  glm::vec3* dpdu_out = nullptr, glm::vec3* dpdv_out = nullptr);

}  // namespace basalt::cpu
