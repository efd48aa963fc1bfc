// BSDFs of the CPU reference (docs/materials-spec.md): a material at a surface point becomes
// a list of lobes (bsdf_at), evaluated, sampled and weighed in the local shading frame. Same
// names as the GLSL twins (shaders/include/): bsdf_at, bsdf_flags, bsdf_eval, bsdf_pdf,
// bsdf_sample.
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "../../shaders/shared/layout.h"
#include "cpu/surface.h"
#include "scene/tables.h"

namespace basalt::cpu {

/// A sampled BSDF direction (pbrt-v4 BSDFSample; docs/materials-spec.md 1.3).
struct BsdfSample {
  glm::vec3 f{0.0f};    // BSDF value for (wo, wi), without the cosine
  glm::vec3 wi{0.0f};   // sampled local direction
  float pdf = 0.0f;     // solid-angle pdf of wi (proportional to it if pdf_is_proportional)
  std::uint32_t flags = 0;  // BSDF_* of the sample; 0: no sample
  float eta = 1.0f;     // relative IOR etaT/etaI of a transmission, 1 otherwise
  bool pdf_is_proportional = false;  // pdf is only proportional (stochastic layered lobes)
};

/// One lobe of a BSDF: a LOBE_* tag, an rgb weight and the parameters of its tag.
struct Lobe {
  std::uint32_t tag = 0;
  glm::vec3 weight{1.0f};
  glm::vec3 c0{0.0f}, c1{0.0f}, c2{0.0f};  // rgb parameters (see lobes.cpp, make_* helpers)
  float ax = 0.0f, ay = 0.0f;  // microfacet alphas (of the coat for layered lobes)
  float bx = 0.0f, by = 0.0f;  // alphas of the conductor base (LAYERED_CONDUCTOR)
  float eta = 1.0f;            // dielectric IOR (relative, outside = 1)
  float s0 = 0.0f, s1 = 0.0f;  // scalars: OREN_NAYAR A, B; layered thickness, g
  std::uint32_t fresnel = gpu::FRESNEL_ONE;  // MICROFACET_R / SPECULAR_R Fresnel
  bool beckmann = false;       // Beckmann instead of Trowbridge-Reitz (MATFLAG_BECKMANN)
  std::uint32_t n0 = 0, n1 = 0;  // layered maxdepth, nsamples; MEASURED table offset
  bool pbrt_mis = false;         // layered: pbrt-v4's exit MIS weights (MATFLAG_LAYERED_PBRT_MIS)
  glm::uvec3 dims{0u};           // MEASURED: n theta_h, n theta_d, n phi_d
};

/// The BSDF at a surface point: up to MAX_LOBES lobes (docs/materials-spec.md 1.3).
struct Bsdf {
  Lobe lobes[gpu::MAX_LOBES];
  std::uint32_t n = 0;
  bool interface = false;  // MATERIAL_INTERFACE: no surface, the path passes through
  const SceneTables* scene = nullptr;  // for MEASURED lookups
};

/// \brief Value of slot `slot` of material m at surface point sp: rgb in xyz, a float
///        parameter in x. A textured slot evaluates its program in sp.tex
///        (docs/textures-spec.md section 2).
glm::vec3 slot_value(const gpu::Material& m, std::uint32_t slot, const SurfacePoint& sp);

/// \brief Material index after resolving MATERIAL_MIX chains (pbrt-v4
///        MixMaterial::ChooseMaterial; docs/materials-spec.md section 4) at point p for
///        wo_world = -ray direction. Returns INVALID_INDEX for deeper than 16 levels or an
///        invalid index.
std::uint32_t resolve_mix(const SceneTables& scene, std::uint32_t material, glm::vec3 p,
                          glm::vec3 wo_world);
/// \brief As above at the surface point \p sp, whose texture context a textured `amount`
///        is evaluated in.
std::uint32_t resolve_mix(const SceneTables& scene, std::uint32_t material, const SurfacePoint& sp,
                          glm::vec3 wo_world);

/// \brief The BSDF of material index `material` at sp seen from wo_world (= -ray direction):
///        resolves stochastic mixes (section 4), applies the resolved material's bump or
///        normal map to sp's shading normal and frame (docs/bump-spec.md 6: bump_shading,
///        which everything after the BSDF uses) and builds the lobes of section 3 (roughness
///        of 1.4). An invalid index or MATERIAL_NONE gives no lobes (black); MATERIAL_INTERFACE
///        gives no lobes and interface = true.
Bsdf bsdf_at(const SceneTables& scene, std::uint32_t material, SurfacePoint& sp,
             glm::vec3 wo_world);

/// \brief Union of the lobes' flags (BSDF_REFLECTION/TRANSMISSION x DIFFUSE/GLOSSY/SPECULAR).
std::uint32_t bsdf_flags(const Bsdf& b);

/// \brief True if some lobe is non-specular (diffuse or glossy): light sampling applies.
bool bsdf_is_nonspecular(const Bsdf& b);

/// \brief f(wo, wi) in the local frame (no cosine), the sum over lobes with the light-leak rule
///        of 1.2 (ng: geometric normal in the local frame). `stream` is the base key of the
///        random stream used by stochastic lobes. wo.z == 0 gives 0.
glm::vec3 bsdf_eval(const Bsdf& b, glm::vec3 wo, glm::vec3 wi, glm::vec3 ng, glm::uvec4 stream);

/// \brief Solid-angle pdf of bsdf_sample producing wi (1.3): the mean over lobes of the
///        non-specular lobes' pdfs; 0 where the geometric and shading sides disagree (1.2).
float bsdf_pdf(const Bsdf& b, glm::vec3 wo, glm::vec3 wi, glm::vec3 ng, glm::uvec4 stream);

/// \brief Samples wi given wo with u = (u_lobe, u0, u1) (1.3, with the rule of 1.2).
///        flags == 0: no sample.
BsdfSample bsdf_sample(const Bsdf& b, glm::vec3 wo, glm::vec3 u, glm::vec3 ng,
                       glm::uvec4 stream);

// ---- single lobes (lobes.cpp, layered.cpp), for tests and bsdf.cpp -----------------------

/// \brief Flags of one lobe (BSDF_*; 0 for a lobe that scatters nothing).
std::uint32_t lobe_flags(const Lobe& l);
/// \brief f of one lobe without its weight (0 for specular lobes).
glm::vec3 lobe_f(const Bsdf& b, const Lobe& l, glm::vec3 wo, glm::vec3 wi, glm::uvec4 stream);
/// \brief pdf of one lobe's sampling (0 for specular lobes).
float lobe_pdf(const Bsdf& b, const Lobe& l, glm::vec3 wo, glm::vec3 wi, glm::uvec4 stream);
/// \brief Sample of one lobe without its weight, uc = remapped u_lobe, u = (u0, u1).
BsdfSample lobe_sample(const Bsdf& b, const Lobe& l, glm::vec3 wo, float uc, glm::vec2 u,
                       glm::uvec4 stream);

}  // namespace basalt::cpu
