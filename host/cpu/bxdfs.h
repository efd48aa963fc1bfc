// pbrt-v4 BxDFs of the CPU reference used by the CONDUCTOR, DIELECTRIC and layered lobes
// (docs/materials-spec.md 2.3): DiffuseBxDF, ConductorBxDF, DielectricBxDF with pbrt-v4's
// transport mode and reflection/transmission sample restriction (pbrt-v4 src/pbrt/bxdfs.h,
// bxdfs.cpp). Internal to host/cpu.
#pragma once
#include <cfloat>
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

#include "cpu/bsdf.h"
#include "cpu/fresnel.h"
#include "cpu/microfacet.h"

namespace basalt::cpu::bxdf {

/// pbrt-v4 TransportMode.
enum class Mode { Radiance, Importance };
/// pbrt-v4 !mode.
inline Mode flip(Mode m) { return m == Mode::Radiance ? Mode::Importance : Mode::Radiance; }

/// pbrt-v4 BxDFReflTransFlags.
inline constexpr std::uint32_t SAMPLE_R = 1u, SAMPLE_T = 2u, SAMPLE_ALL = 3u;

/// pbrt-v4 IsSpecular / IsNonSpecular / IsReflection / IsTransmission of BxDFFlags.
inline bool is_specular(std::uint32_t f) { return (f & gpu::BSDF_SPECULAR) != 0; }
inline bool is_nonspecular(std::uint32_t f) {
  return (f & (gpu::BSDF_DIFFUSE | gpu::BSDF_GLOSSY)) != 0;
}
inline bool is_reflection(std::uint32_t f) { return (f & gpu::BSDF_REFLECTION) != 0; }
inline bool is_transmission(std::uint32_t f) { return (f & gpu::BSDF_TRANSMISSION) != 0; }
inline bool is_diffuse(std::uint32_t f) { return (f & gpu::BSDF_DIFFUSE) != 0; }
inline bool is_glossy(std::uint32_t f) { return (f & gpu::BSDF_GLOSSY) != 0; }

/// pbrt-v4 "bool(SampledSpectrum)": some component non-zero.
inline bool nonzero(glm::vec3 v) { return v.x != 0.0f || v.y != 0.0f || v.z != 0.0f; }

/// A valid pbrt-v4 sample: !bs || !bs->f || bs->pdf == 0 || bs->wi.z == 0 rejected. Values
/// below FLT_MIN count as 0 (materials-spec 1.3): GPUs may flush subnormals to zero.
inline bool usable(const BsdfSample& s) {
  const float fmax = std::fmax(std::fabs(s.f.x), std::fmax(std::fabs(s.f.y), std::fabs(s.f.z)));
  return s.flags != 0 && fmax >= FLT_MIN && std::fabs(s.pdf) >= FLT_MIN && s.wi.z != 0.0f;
}

/// \brief pbrt-v4 Refract(wi, n, eta, &etap, &wt): Snell's law with the interface flipped when
///        wi is below n; false on total internal reflection.
bool refract_v4(glm::vec3 wi, glm::vec3 n, float eta, float* etap, glm::vec3* wt);

/// \brief (dot(wi, wm) + dot(wo, wm) / etap)^2, the denominator of dwm/dwi and of rough
///        transmission in pbrt-v4 DielectricBxDF::Sample_f, for wi refracted from wo through wm
///        (cos_i = |dot(wo, wm)|): by Snell's law the sum is +-(1 - etap^2) / (etap (cos_i +
///        etap cos_t)) (cos_i / etap - cos_t times its conjugate), whose rounding error stays a
///        few ulps where the sum itself cancels to a few bits when etap is near 1.
float refracted_half_denom(float cos_i, float etap);

/// pbrt-v4 DiffuseBxDF (R / pi, cosine sampling).
struct Diffuse {
  glm::vec3 R{0.0f};
  std::uint32_t flags() const;
  glm::vec3 f(glm::vec3 wo, glm::vec3 wi) const;
  BsdfSample sample(glm::vec3 wo, float uc, glm::vec2 u, std::uint32_t sf) const;
  float pdf(glm::vec3 wo, glm::vec3 wi, std::uint32_t sf) const;
};

/// pbrt-v4 ConductorBxDF (FrComplex Fresnel, specular when effectively smooth).
struct Conductor {
  Microfacet mf;
  glm::vec3 eta{1.0f}, k{0.0f};
  std::uint32_t flags() const;
  glm::vec3 f(glm::vec3 wo, glm::vec3 wi) const;
  BsdfSample sample(glm::vec3 wo, float uc, glm::vec2 u, std::uint32_t sf) const;
  float pdf(glm::vec3 wo, glm::vec3 wi, std::uint32_t sf) const;
};

/// pbrt-v4 DielectricBxDF (rough transmission with the generalized half vector).
struct Dielectric {
  float eta = 1.0f;
  Microfacet mf;
  std::uint32_t flags() const;
  glm::vec3 f(glm::vec3 wo, glm::vec3 wi, Mode mode) const;
  BsdfSample sample(glm::vec3 wo, float uc, glm::vec2 u, Mode mode, std::uint32_t sf) const;
  float pdf(glm::vec3 wo, glm::vec3 wi, Mode mode, std::uint32_t sf) const;
};

/// \brief pbrt-v4 LayeredBxDF<DielectricBxDF, Bottom, twoSided = true>::f, Sample_f, PDF with
///        `r()` drawn from `stream` (docs/materials-spec.md 2.3). Bottom is Diffuse
///        (CoatedDiffuseBxDF) or Conductor (CoatedConductorBxDF).
template <typename Bottom>
struct Layered {
  Dielectric top;
  Bottom bottom;
  float thickness = 0.01f, g = 0.0f;
  glm::vec3 albedo{0.0f};
  int max_depth = 10, n_samples = 1;
  bool pbrt_mis = false;  // pbrt-v4's exit MIS weights in f (docs/materials-spec.md 2.3)
  std::uint32_t flags() const;
  glm::vec3 f(glm::vec3 wo, glm::vec3 wi, Mode mode, glm::uvec4 stream) const;
  BsdfSample sample(glm::vec3 wo, float uc, glm::vec2 u, Mode mode, glm::uvec4 stream) const;
  float pdf(glm::vec3 wo, glm::vec3 wi, Mode mode, glm::uvec4 stream) const;
};

/// Layered lobe objects of a lobe record (lobes.cpp).
Layered<Diffuse> coated_diffuse(const Lobe& l);
Layered<Conductor> coated_conductor(const Lobe& l);

}  // namespace basalt::cpu::bxdf
