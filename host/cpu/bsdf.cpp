// BSDFs of the CPU reference in the local shading frame (docs/path-spec.md section 8).
#include "cpu/bsdf.h"

#include <cmath>

#include "cpu/sampling.h"

namespace basalt::cpu {
namespace {

/// pbrt-v4 SameHemisphere: both directions strictly on the same side of the surface.
inline bool same_hemisphere(glm::vec3 a, glm::vec3 b) { return a.z * b.z > 0.0f; }

/// Diffuse reflectance R of slot SLOT_DIFFUSE_REFLECTANCE.
inline glm::vec3 diffuse_R(const gpu::Material& m) {
  return glm::vec3(m.value[gpu::SLOT_DIFFUSE_REFLECTANCE]);
}

/// Lambertian f = R / pi in the same hemisphere (pbrt-v4 9.2 DiffuseBxDF::f; spec section 8).
glm::vec3 diffuse_eval(const gpu::Material& m, glm::vec3 wo, glm::vec3 wi) {
  if (!same_hemisphere(wo, wi)) return glm::vec3(0.0f);
  return diffuse_R(m) / PI;
}

/// Cosine-weighted pdf |wi.z| / pi in the same hemisphere (pbrt-v4 DiffuseBxDF::PDF).
float diffuse_pdf(glm::vec3 wo, glm::vec3 wi) {
  if (!same_hemisphere(wo, wi)) return 0.0f;
  return std::fabs(wi.z) / PI;
}

/// Cosine-hemisphere sample by Malley's method on concentric_disk(u.yz), mirrored to wo's
/// side (pbrt-v4 A.5.3 SampleCosineHemisphere, DiffuseBxDF::Sample_f; spec section 8).
BsdfSample diffuse_sample(const gpu::Material& m, glm::vec3 wo, glm::vec3 u) {
  const glm::vec2 d = concentric_disk(glm::vec2(u.y, u.z));
  glm::vec3 wi(d.x, d.y, safe_sqrt(1.0f - d.x * d.x - d.y * d.y));
  if (wo.z < 0.0f) wi.z = -wi.z;
  BsdfSample bs;
  bs.wi = wi;
  bs.pdf = diffuse_pdf(wo, wi);
  bs.f = diffuse_eval(m, wo, wi);
  bs.specular = false;
  bs.valid = true;
  return bs;
}

}  // namespace

bool bsdf_is_nonspecular(const gpu::Material& m) {
  switch (m.type) {
    case gpu::MATERIAL_DIFFUSE:
      return true;
    default:
      return false;
  }
}

glm::vec3 bsdf_eval(const gpu::Material& m, glm::vec3 wo, glm::vec3 wi) {
  if (wo.z == 0.0f) return glm::vec3(0.0f);
  switch (m.type) {
    case gpu::MATERIAL_DIFFUSE:
      return diffuse_eval(m, wo, wi);
    default:
      return glm::vec3(0.0f);
  }
}

BsdfSample bsdf_sample(const gpu::Material& m, glm::vec3 wo, glm::vec3 u) {
  if (wo.z == 0.0f) return BsdfSample{};
  switch (m.type) {
    case gpu::MATERIAL_DIFFUSE:
      return diffuse_sample(m, wo, u);
    default:
      return BsdfSample{};
  }
}

float bsdf_pdf(const gpu::Material& m, glm::vec3 wo, glm::vec3 wi) {
  if (wo.z == 0.0f) return 0.0f;
  switch (m.type) {
    case gpu::MATERIAL_DIFFUSE:
      return diffuse_pdf(wo, wi);
    default:
      return 0.0f;
  }
}

}  // namespace basalt::cpu
