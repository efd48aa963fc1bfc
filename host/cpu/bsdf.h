// BSDFs of the CPU reference in the local shading frame, dispatched on the material type tag
// (docs/path-spec.md section 8). Same names as the GLSL twins: bsdf_eval, bsdf_sample, bsdf_pdf.
#pragma once
#include <glm/glm.hpp>

#include "../../shaders/shared/layout.h"

namespace basalt::cpu {

/// A sampled BSDF direction (pbrt-v4 BSDFSample).
struct BsdfSample {
  glm::vec3 f{0.0f};    // BSDF value for (wo, wi), without the cosine
  glm::vec3 wi{0.0f};   // sampled local direction
  float pdf = 0.0f;     // solid-angle pdf of wi (0: no sample)
  bool specular = false;
  bool valid = false;   // false: no sample (the path ends)
};

/// \brief True if the material has a non-specular component, i.e. light sampling applies
///        (pbrt-v4 IsNonSpecular(bsdf.Flags())).
bool bsdf_is_nonspecular(const gpu::Material& m);

/// \brief BSDF value f(wo, wi) for local directions (no cosine). wo.z == 0 gives 0 (pbrt-v4
///        BSDF::f).
glm::vec3 bsdf_eval(const gpu::Material& m, glm::vec3 wo, glm::vec3 wi);

/// \brief Samples wi given wo with u = (lobe choice, direction u0, direction u1) from
///        dimensions 4+16b+3..5 (spec section 7). wo.z == 0 gives no sample.
BsdfSample bsdf_sample(const gpu::Material& m, glm::vec3 wo, glm::vec3 u);

/// \brief Solid-angle pdf with which bsdf_sample produces wi given wo.
float bsdf_pdf(const gpu::Material& m, glm::vec3 wo, glm::vec3 wi);

}  // namespace basalt::cpu
