// Light selection, sampling and pdfs of the CPU reference (docs/path-spec.md section 6).
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "cpu/intersect.h"
#include "scene/tables.h"

namespace basalt::cpu {

/// A sampled light: incident radiance at the shading point and how to test visibility.
struct LightSample {
  glm::vec3 Li{0.0f};     // radiance arriving at p from the light sample (Le / d^2 for I)
  glm::vec3 wi{0.0f};     // unit direction from p towards the light
  float pdf = 0.0f;       // solid-angle pdf (1 for delta lights); 0 means no sample
  bool delta = false;     // point, spot, distant
  bool at_infinity = false;  // distant, infinite: the shadow ray has tMax = FLT_MAX
  bool area = false;      // area light: the shadow ray target is offset off the light
  glm::vec3 q{0.0f};      // point on the light (point, spot, area)
  glm::vec3 nl{0.0f};     // light surface normal at q (area)
  float m = 0.0f;         // magnitude bound of the light primitive at q (area; section 5)
};

/// \brief Number of lights usable by the light sampler (Globals.counts.x, bounded by the tables).
std::uint32_t light_count(const SceneTables& scene);

/// \brief Light index for u in [0,1): largest i with light_cdf[i] <= u (spec section 6 binary
///        search); INVALID_INDEX without lights.
std::uint32_t select_light(const SceneTables& scene, float u);

/// \brief Importance of \p light at point p with shading normal n (spec section 6.1; pbrt-v4
///        LightBounds::Importance over the light's bound_* fields); 0 for a light without
///        bounds (infinite extent, no power), at most LIGHT_IMPORTANCE_CAP.
float light_importance(const gpu::Light& light, glm::vec3 p, glm::vec3 n);

/// \brief A light picked for next-event estimation and the probability of that pick.
struct PickedLight {
  std::uint32_t index = gpu::INVALID_INDEX;  // INVALID_INDEX: no light
  float pmf = 0.0f;
};

/// \brief The light NEE uses at shading point p (shading normal n) for u in [0,1) (spec
///        sections 6 and 6.1): select_light's, or with importance selection on and a bounded
///        light selected, the bounded light whose importance interval holds u rescaled within
///        that light's cdf share. pmf 0 / INVALID_INDEX: no light.
PickedLight pick_light(const SceneTables& scene, float u, glm::vec3 p, glm::vec3 n);

/// \brief The probability that pick_light at (p, n) returns light \p index (spec 6.1).
float pick_light_pmf(const SceneTables& scene, std::uint32_t index, glm::vec3 p, glm::vec3 n);

/// \brief Samples light at shading point p (geometric normal ng, or 0 for a point in space;
///        magnitude bound m) with u = (u0, u1) (spec section 6; ng and m only decide a sphere
///        light's inside test).
LightSample sample_light(const SceneTables& scene, const gpu::Light& light, glm::vec3 p,
                         glm::vec3 ng, float m, glm::vec2 u);

/// \brief Solid-angle pdf with which sample_light(area light, p_ref) produces the point q
///        (normal nq) reached from p_ref (geometric normal ng_ref, magnitude bound m_ref) along
///        the unit direction w (pbrt-v4 Triangle/Sphere::PDF).
float area_light_pdf(const SceneTables& scene, const gpu::Light& light, glm::vec3 p_ref,
                     glm::vec3 ng_ref, float m_ref, glm::vec3 q, glm::vec3 nq, glm::vec3 w);

/// \brief Emitted radiance of an area light at a point with emitting-side normal nl towards
///        direction w (w points to the receiver; spec section 6 "Area emission").
glm::vec3 area_Le(const gpu::Light& light, glm::vec3 nl, glm::vec3 w);

/// \brief Radiance an escaped ray of unit direction w receives from infinite light \p light
///        from origin o (uniform: L; image: env_le, whose portals read o). pbrt-v4 Light::Le.
glm::vec3 infinite_Le(const SceneTables& scene, const gpu::Light& light, glm::vec3 o,
                      glm::vec3 w);

/// \brief pmf times solid-angle pdf with which NEE would have produced direction w from
///        infinite light \p light (the light-sampling density in the MIS weight of an escaped
///        ray, spec section 7): pmf / (4 pi) for a uniform light, pmf * env_pdf(compensated)
///        for an image light (from the previous vertex p, which portals read).
float infinite_light_pdf(const SceneTables& scene, const gpu::Light& light, glm::vec3 p,
                         glm::vec3 w);

/// \brief Shadow ray from shading point p (geometric normal ng, magnitude bound m) to the
///        light sample (spec section 5): an area light's target is offset off the light with
///        the sample's own bound ls.m.
Ray shadow_ray(glm::vec3 p, glm::vec3 ng, float m, const LightSample& ls);

}  // namespace basalt::cpu
