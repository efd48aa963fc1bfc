// The lobes of docs/materials-spec.md section 2.3 on the CPU: f, pdf and sample of each
// LOBE_* tag in the local shading frame, without the lobe weight. pbrt-v3 lobes follow
// pbrt-v3 src/core/reflection.cpp, pbrt-v4 lobes src/pbrt/bxdfs.{h,cpp}, the measured lobe
// pbrt-v2 src/core/reflection.cpp RegularHalfangleBRDF.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <vector>

#include "cpu/bxdfs.h"
#include "cpu/fresnel.h"
#include "cpu/microfacet.h"

namespace basalt::cpu {
namespace bxdf {

bool refract_v4(glm::vec3 wi, glm::vec3 n, float eta, float* etap, glm::vec3* wt) {
  // pbrt-v4 util/scattering.h Refract.
  float cos_i = glm::dot(n, wi);
  if (cos_i < 0.0f) {
    eta = 1.0f / eta;
    cos_i = -cos_i;
    n = -n;
  }
  const float sin2_i = std::fmax(0.0f, 1.0f - cos_i * cos_i);
  const float sin2_t = sin2_i / (eta * eta);
  if (sin2_t >= 1.0f) return false;
  const float cos_t = std::sqrt(1.0f - sin2_t);
  *wt = -wi / eta + (cos_i / eta - cos_t) * n;
  if (etap) *etap = eta;
  return true;
}

// ---- DiffuseBxDF ---------------------------------------------------------------------------

std::uint32_t Diffuse::flags() const {
  return nonzero(R) ? (gpu::BSDF_REFLECTION | gpu::BSDF_DIFFUSE) : 0u;
}

glm::vec3 Diffuse::f(glm::vec3 wo, glm::vec3 wi) const {
  if (!same_hemisphere(wo, wi)) return glm::vec3(0.0f);
  return R / PI;
}

/// pbrt-v4 SampleCosineHemisphere (path-spec section 8): the +z hemisphere.
static glm::vec3 cosine_hemisphere(glm::vec2 u) {
  const glm::vec2 d = concentric_disk(u);
  const float r = concentric_radius(u);
  return glm::vec3(d.x, d.y, safe_sqrt(1.0f - r * r));
}

BsdfSample Diffuse::sample(glm::vec3 wo, float, glm::vec2 u, std::uint32_t sf) const {
  if (!(sf & SAMPLE_R)) return BsdfSample{};
  glm::vec3 wi = cosine_hemisphere(u);
  if (wo.z < 0.0f) wi.z = -wi.z;
  BsdfSample s;
  s.f = R / PI;
  s.wi = wi;
  s.pdf = std::fabs(wi.z) / PI;
  s.flags = gpu::BSDF_REFLECTION | gpu::BSDF_DIFFUSE;
  return s;
}

float Diffuse::pdf(glm::vec3 wo, glm::vec3 wi, std::uint32_t sf) const {
  if (!(sf & SAMPLE_R) || !same_hemisphere(wo, wi)) return 0.0f;
  return std::fabs(wi.z) / PI;
}

// ---- ConductorBxDF -------------------------------------------------------------------------

std::uint32_t Conductor::flags() const {
  return mf.effectively_smooth() ? (gpu::BSDF_REFLECTION | gpu::BSDF_SPECULAR)
                                 : (gpu::BSDF_REFLECTION | gpu::BSDF_GLOSSY);
}

glm::vec3 Conductor::f(glm::vec3 wo, glm::vec3 wi) const {
  if (!same_hemisphere(wo, wi)) return glm::vec3(0.0f);
  if (mf.effectively_smooth()) return glm::vec3(0.0f);
  const float cos_o = std::fabs(wo.z), cos_i = std::fabs(wi.z);
  if (cos_i == 0.0f || cos_o == 0.0f) return glm::vec3(0.0f);
  glm::vec3 wm = wi + wo;
  if (glm::dot(wm, wm) == 0.0f) return glm::vec3(0.0f);
  wm = safe_normalize(wm);
  const glm::vec3 F = fr_complex(std::fabs(glm::dot(wo, wm)), eta, k);
  return mf.D(wm) * F * mf.G(wo, wi) / (4.0f * cos_i * cos_o);
}

BsdfSample Conductor::sample(glm::vec3 wo, float, glm::vec2 u, std::uint32_t sf) const {
  if (!(sf & SAMPLE_R)) return BsdfSample{};
  BsdfSample s;
  if (mf.effectively_smooth()) {
    // Perfectly specular conductor.
    s.wi = glm::vec3(-wo.x, -wo.y, wo.z);
    s.f = fr_complex(std::fabs(s.wi.z), eta, k) / std::fabs(s.wi.z);
    s.pdf = 1.0f;
    s.flags = gpu::BSDF_REFLECTION | gpu::BSDF_SPECULAR;
    return s;
  }
  if (wo.z == 0.0f) return BsdfSample{};
  const glm::vec3 wm = mf.sample_wm(wo, u);
  const glm::vec3 wi = reflect_about(wo, wm);
  if (!same_hemisphere(wo, wi)) return BsdfSample{};
  const float pdf = mf.PDF(wo, wm) / (4.0f * std::fabs(glm::dot(wo, wm)));
  const float cos_o = std::fabs(wo.z), cos_i = std::fabs(wi.z);
  if (cos_i == 0.0f || cos_o == 0.0f) return BsdfSample{};
  const glm::vec3 F = fr_complex(std::fabs(glm::dot(wo, wm)), eta, k);
  s.f = mf.D(wm) * F * mf.G(wo, wi) / (4.0f * cos_i * cos_o);
  s.wi = wi;
  s.pdf = pdf;
  s.flags = gpu::BSDF_REFLECTION | gpu::BSDF_GLOSSY;
  return s;
}

float Conductor::pdf(glm::vec3 wo, glm::vec3 wi, std::uint32_t sf) const {
  if (!(sf & SAMPLE_R)) return 0.0f;
  if (!same_hemisphere(wo, wi)) return 0.0f;
  if (mf.effectively_smooth()) return 0.0f;
  glm::vec3 wh = wo + wi;
  if (glm::dot(wh, wh) == 0.0f) return 0.0f;
  wh = face_forward(safe_normalize(wh), glm::vec3(0.0f, 0.0f, 1.0f));
  return mf.PDF(wo, wh) / (4.0f * std::fabs(glm::dot(wo, wh)));
}

// ---- DielectricBxDF ------------------------------------------------------------------------

std::uint32_t Dielectric::flags() const {
  const std::uint32_t fl = eta == 1.0f ? gpu::BSDF_TRANSMISSION
                                       : (gpu::BSDF_REFLECTION | gpu::BSDF_TRANSMISSION);
  return fl | (mf.effectively_smooth() ? gpu::BSDF_SPECULAR : gpu::BSDF_GLOSSY);
}

/// Microfacet normal for the pbrt-v4 dielectric: pbrt-v4 samples normals in the +z
/// hemisphere (its Fresnel and refraction rely on the sign); Beckmann's pbrt-v3 sampler flips
/// them to wo's side, so they are face-forwarded to +z here (a no-op for Trowbridge-Reitz).
static glm::vec3 sample_wm_up(const Microfacet& mf, glm::vec3 wo, glm::vec2 u) {
  return face_forward(mf.sample_wm(wo, u), glm::vec3(0.0f, 0.0f, 1.0f));
}

// The refracted half-vector denominator in its Snell's-law form (bxdfs.h).
float refracted_half_denom(float cos_i, float etap) {
  // cos_t^2 = 1 - (1 - cos_i^2) / etap^2 = ((etap - 1)(etap + 1) + cos_i^2) / etap^2.
  const float cos_t = std::sqrt(std::max(0.0f, ((etap - 1.0f) * (etap + 1.0f) + cos_i * cos_i) / (etap * etap)));
  const float t = ((1.0f - etap) * (1.0f + etap)) / (etap * (cos_i + etap * cos_t));
  return t * t;
}

BsdfSample Dielectric::sample(glm::vec3 wo, float uc, glm::vec2 u, Mode mode,
                              std::uint32_t sf) const {
  BsdfSample s;
  if (eta == 1.0f || mf.effectively_smooth()) {
    // Perfectly specular dielectric.
    const float R = fr_dielectric(wo.z, eta), T = 1.0f - R;
    float pr = R, pt = T;
    if (!(sf & SAMPLE_R)) pr = 0.0f;
    if (!(sf & SAMPLE_T)) pt = 0.0f;
    if (pr == 0.0f && pt == 0.0f) return BsdfSample{};
    if (uc < pr / (pr + pt)) {
      s.wi = glm::vec3(-wo.x, -wo.y, wo.z);
      s.f = glm::vec3(R / std::fabs(s.wi.z));
      s.pdf = pr / (pr + pt);
      s.flags = gpu::BSDF_REFLECTION | gpu::BSDF_SPECULAR;
      return s;
    }
    glm::vec3 wi;
    float etap = 1.0f;
    if (!refract_v4(wo, glm::vec3(0.0f, 0.0f, 1.0f), eta, &etap, &wi)) return BsdfSample{};
    float ft = T / std::fabs(wi.z);
    if (mode == Mode::Radiance) ft /= etap * etap;
    s.wi = wi;
    s.f = glm::vec3(ft);
    s.pdf = pt / (pr + pt);
    s.flags = gpu::BSDF_TRANSMISSION | gpu::BSDF_SPECULAR;
    s.eta = etap;
    return s;
  }
  // Rough dielectric.
  const glm::vec3 wm = sample_wm_up(mf, wo, u);
  const float R = fr_dielectric(glm::dot(wo, wm), eta), T = 1.0f - R;
  float pr = R, pt = T;
  if (!(sf & SAMPLE_R)) pr = 0.0f;
  if (!(sf & SAMPLE_T)) pt = 0.0f;
  if (pr == 0.0f && pt == 0.0f) return BsdfSample{};
  if (uc < pr / (pr + pt)) {
    const glm::vec3 wi = reflect_about(wo, wm);
    if (!same_hemisphere(wo, wi)) return BsdfSample{};
    s.pdf = mf.PDF(wo, wm) / (4.0f * std::fabs(glm::dot(wo, wm))) * pr / (pr + pt);
    s.f = glm::vec3(mf.D(wm) * mf.G(wo, wi) * R / (4.0f * wi.z * wo.z));
    s.wi = wi;
    s.flags = gpu::BSDF_REFLECTION | gpu::BSDF_GLOSSY;
    return s;
  }
  glm::vec3 wi;
  float etap = 1.0f;
  const bool tir = !refract_v4(wo, wm, eta, &etap, &wi);
  if (tir || same_hemisphere(wo, wi) || wi.z == 0.0f) return BsdfSample{};
  const float denom = refracted_half_denom(std::fabs(glm::dot(wo, wm)), etap);
  if (!(denom > 0.0f)) return BsdfSample{};
  const float dwm_dwi = std::fabs(glm::dot(wi, wm)) / denom;
  s.pdf = mf.PDF(wo, wm) * dwm_dwi * pt / (pr + pt);
  float ft = T * mf.D(wm) * mf.G(wo, wi) *
             std::fabs(glm::dot(wi, wm) * glm::dot(wo, wm) / (wi.z * wo.z * denom));
  if (mode == Mode::Radiance) ft /= etap * etap;
  s.f = glm::vec3(ft);
  s.wi = wi;
  s.flags = gpu::BSDF_TRANSMISSION | gpu::BSDF_GLOSSY;
  s.eta = etap;
  return s;
}

/// Generalized half vector of pbrt-v4 DielectricBxDF::f / PDF, face-forwarded to +z; false
/// for the degenerate and back-facing configurations pbrt-v4 returns 0 for.
static bool dielectric_half(float eta, glm::vec3 wo, glm::vec3 wi, glm::vec3* wm_out,
                            float* etap_out, bool* reflect_out) {
  const float cos_o = wo.z, cos_i = wi.z;
  const bool reflect = cos_i * cos_o > 0.0f;
  float etap = 1.0f;
  if (!reflect) etap = cos_o > 0.0f ? eta : (1.0f / eta);
  glm::vec3 wm = wi * etap + wo;
  if (cos_i == 0.0f || cos_o == 0.0f || glm::dot(wm, wm) == 0.0f) return false;
  wm = face_forward(safe_normalize(wm), glm::vec3(0.0f, 0.0f, 1.0f));
  // Discard back-facing microfacets.
  if (glm::dot(wm, wi) * cos_i < 0.0f || glm::dot(wm, wo) * cos_o < 0.0f) return false;
  *wm_out = wm;
  *etap_out = etap;
  *reflect_out = reflect;
  return true;
}

glm::vec3 Dielectric::f(glm::vec3 wo, glm::vec3 wi, Mode mode) const {
  if (eta == 1.0f || mf.effectively_smooth()) return glm::vec3(0.0f);
  glm::vec3 wm;
  float etap;
  bool reflect;
  if (!dielectric_half(eta, wo, wi, &wm, &etap, &reflect)) return glm::vec3(0.0f);
  const float F = fr_dielectric(glm::dot(wo, wm), eta);
  if (reflect) return glm::vec3(mf.D(wm) * mf.G(wo, wi) * F / std::fabs(4.0f * wi.z * wo.z));
  const float dn = glm::dot(wi, wm) + glm::dot(wo, wm) / etap;
  const float denom = dn * dn * wi.z * wo.z;
  float ft = mf.D(wm) * (1.0f - F) * mf.G(wo, wi) *
             std::fabs(glm::dot(wi, wm) * glm::dot(wo, wm) / denom);
  if (mode == Mode::Radiance) ft /= etap * etap;
  return glm::vec3(ft);
}

float Dielectric::pdf(glm::vec3 wo, glm::vec3 wi, Mode, std::uint32_t sf) const {
  if (eta == 1.0f || mf.effectively_smooth()) return 0.0f;
  glm::vec3 wm;
  float etap;
  bool reflect;
  if (!dielectric_half(eta, wo, wi, &wm, &etap, &reflect)) return 0.0f;
  const float R = fr_dielectric(glm::dot(wo, wm), eta), T = 1.0f - R;
  float pr = R, pt = T;
  if (!(sf & SAMPLE_R)) pr = 0.0f;
  if (!(sf & SAMPLE_T)) pt = 0.0f;
  if (pr == 0.0f && pt == 0.0f) return 0.0f;
  if (reflect) return mf.PDF(wo, wm) / (4.0f * std::fabs(glm::dot(wo, wm))) * pr / (pr + pt);
  const float dn = glm::dot(wi, wm) + glm::dot(wo, wm) / etap;
  const float dwm_dwi = std::fabs(glm::dot(wi, wm)) / (dn * dn);
  return mf.PDF(wo, wm) * dwm_dwi * pt / (pr + pt);
}

// ---- layered lobes -------------------------------------------------------------------------

Layered<Diffuse> coated_diffuse(const Lobe& l) {
  Layered<Diffuse> b;
  b.top = Dielectric{l.eta, Microfacet::make(l.ax, l.ay, l.beckmann)};
  b.bottom = Diffuse{l.c0};
  b.thickness = std::max(l.s0, FLT_MIN);
  b.g = l.s1;
  b.albedo = l.c1;
  b.max_depth = int(l.n0);
  b.n_samples = int(l.n1);
  b.pbrt_mis = l.pbrt_mis;
  return b;
}

Layered<Conductor> coated_conductor(const Lobe& l) {
  Layered<Conductor> b;
  b.top = Dielectric{l.eta, Microfacet::make(l.ax, l.ay, l.beckmann)};
  b.bottom = Conductor{Microfacet::make(l.bx, l.by, l.beckmann), l.c0, l.c2};
  b.thickness = std::max(l.s0, FLT_MIN);
  b.g = l.s1;
  b.albedo = l.c1;
  b.max_depth = int(l.n0);
  b.n_samples = int(l.n1);
  b.pbrt_mis = l.pbrt_mis;
  return b;
}

}  // namespace bxdf

namespace {

using bxdf::Mode;

/// Distribution of a lobe's (ax, ay).
Microfacet dist(const Lobe& l) { return Microfacet::make(l.ax, l.ay, l.beckmann); }

/// Fresnel term of MICROFACET_R / SPECULAR_R for the cosine c (docs/materials-spec.md 2.2):
/// ONE 1, DIELECTRIC FrDielectric(c, eta), CONDUCTOR FrComplex(|c|, eta, k).
glm::vec3 lobe_fresnel(const Lobe& l, float c) {
  switch (l.fresnel) {
    case gpu::FRESNEL_DIELECTRIC:
      return glm::vec3(fr_dielectric(c, l.eta));
    case gpu::FRESNEL_CONDUCTOR:
      return fr_complex(std::fabs(c), l.c0, l.c1);
    default:
      return glm::vec3(1.0f);
  }
}

/// pbrt-v3 Refract(wi, n, eta = etaI/etaT, &wt) (n on wi's side); false on total internal
/// reflection.
bool refract_v3(glm::vec3 wi, glm::vec3 n, float eta, glm::vec3* wt) {
  const float cos_i = glm::dot(n, wi);
  const float sin2_i = std::fmax(0.0f, 1.0f - cos_i * cos_i);
  const float sin2_t = eta * eta * sin2_i;
  if (sin2_t >= 1.0f) return false;
  const float cos_t = std::sqrt(1.0f - sin2_t);
  *wt = eta * -wi + (eta * cos_i - cos_t) * n;
  return true;
}

/// Cosine-hemisphere direction on wo's side (flip = false) or the opposite side (flip).
glm::vec3 cosine_on_side(glm::vec3 wo, glm::vec2 u, bool opposite) {
  const glm::vec2 d = concentric_disk(u);
  const float r = concentric_radius(u);
  glm::vec3 wi(d.x, d.y, safe_sqrt(1.0f - r * r));
  if ((wo.z < 0.0f) != opposite) wi.z = -wi.z;
  return wi;
}

// -- Oren-Nayar (pbrt-v3 OrenNayar::f) --
glm::vec3 oren_nayar_f(const Lobe& l, glm::vec3 wo, glm::vec3 wi) {
  if (!same_hemisphere(wo, wi)) return glm::vec3(0.0f);
  const float sin_i = sin_theta(wi), sin_o = sin_theta(wo);
  float max_cos = 0.0f;
  if (sin_i > 1e-4f && sin_o > 1e-4f) {
    const float d_cos = cos_phi(wi) * cos_phi(wo) + sin_phi(wi) * sin_phi(wo);
    max_cos = std::fmax(0.0f, d_cos);
  }
  float sin_alpha, tan_beta;
  if (std::fabs(wi.z) > std::fabs(wo.z)) {
    sin_alpha = sin_o;
    tan_beta = sin_i / std::fabs(wi.z);
  } else {
    sin_alpha = sin_i;
    tan_beta = sin_o / std::fabs(wo.z);
  }
  return glm::vec3(INV_PI * (l.s0 + l.s1 * max_cos * sin_alpha * tan_beta));
}

// -- MICROFACET_R (pbrt-v3 MicrofacetReflection, Fresnel at the +z-facing half vector) --
glm::vec3 microfacet_r_f(const Lobe& l, glm::vec3 wo, glm::vec3 wi) {
  if (!same_hemisphere(wo, wi)) return glm::vec3(0.0f);
  const float cos_o = std::fabs(wo.z), cos_i = std::fabs(wi.z);
  if (cos_i == 0.0f || cos_o == 0.0f) return glm::vec3(0.0f);
  glm::vec3 wh = wi + wo;
  if (wh.x == 0.0f && wh.y == 0.0f && wh.z == 0.0f) return glm::vec3(0.0f);
  wh = safe_normalize(wh);
  const glm::vec3 F = lobe_fresnel(l, glm::dot(wi, face_forward(wh, glm::vec3(0, 0, 1))));
  const Microfacet mf = dist(l);
  return mf.D(wh) * mf.G(wo, wi) * F / (4.0f * cos_i * cos_o);
}

float microfacet_r_pdf(const Lobe& l, glm::vec3 wo, glm::vec3 wi) {
  if (!same_hemisphere(wo, wi)) return 0.0f;
  const glm::vec3 wh = face_forward(safe_normalize(wo + wi), glm::vec3(0, 0, 1));
  return dist(l).PDF(wo, wh) / (4.0f * std::fabs(glm::dot(wo, wh)));
}

// -- MICROFACET_T (pbrt-v3 MicrofacetTransmission, etaA = 1, etaB = eta, radiance mode) --

/// \brief pbrt-v4 DielectricBxDF's "discard backfacing microfacets" test on the half vector wh
///        (either sign): with wh flipped to +z, dot(wh, wi) wi.z < 0 or dot(wh, wo) wo.z < 0.
///        pbrt-v3's MicrofacetTransmission lacks it, so its f and pdf are non-zero where the
///        +z-facing microfacet normal faces away from wo or wi: directions its sampler (normals
///        in the upper hemisphere) never produces, so its pdf integrates to more than the
///        sampled mass (chi-square failure; pbrt-v3 bug). Deviation from the literal contract,
///        reported to the lead; MICROFACET_T_PBRT_V3_LITERAL = true restores pbrt-v3.
constexpr bool MICROFACET_T_PBRT_V3_LITERAL = false;
bool microfacet_t_backfacing(glm::vec3 wo, glm::vec3 wi, glm::vec3 wh) {
  if (MICROFACET_T_PBRT_V3_LITERAL) return false;
  if (wh.z < 0.0f) wh = -wh;
  return glm::dot(wh, wi) * wi.z < 0.0f || glm::dot(wh, wo) * wo.z < 0.0f;
}

glm::vec3 microfacet_t_f(const Lobe& l, glm::vec3 wo, glm::vec3 wi) {
  if (same_hemisphere(wo, wi)) return glm::vec3(0.0f);
  const float cos_o = wo.z, cos_i = wi.z;
  if (cos_i == 0.0f || cos_o == 0.0f) return glm::vec3(0.0f);
  const float eta = wo.z > 0.0f ? l.eta : 1.0f / l.eta;  // etaB/etaA or etaA/etaB
  glm::vec3 wh = safe_normalize(wo + wi * eta);
  if (wh.z < 0.0f) wh = -wh;
  if (glm::dot(wo, wh) * glm::dot(wi, wh) > 0.0f) return glm::vec3(0.0f);
  if (microfacet_t_backfacing(wo, wi, wh)) return glm::vec3(0.0f);
  const float F = fr_dielectric(glm::dot(wo, wh), l.eta);
  const float sqrt_denom = glm::dot(wo, wh) + eta * glm::dot(wi, wh);
  const float factor = 1.0f / eta;  // radiance mode
  const Microfacet mf = dist(l);
  return glm::vec3((1.0f - F) *
                   std::fabs(mf.D(wh) * mf.G(wo, wi) * eta * eta *
                             std::fabs(glm::dot(wi, wh)) * std::fabs(glm::dot(wo, wh)) * factor *
                             factor / (cos_i * cos_o * sqrt_denom * sqrt_denom)));
}

float microfacet_t_pdf(const Lobe& l, glm::vec3 wo, glm::vec3 wi) {
  if (same_hemisphere(wo, wi)) return 0.0f;
  const float eta = wo.z > 0.0f ? l.eta : 1.0f / l.eta;
  const glm::vec3 wh = safe_normalize(wo + wi * eta);
  if (glm::dot(wo, wh) * glm::dot(wi, wh) > 0.0f) return 0.0f;
  if (microfacet_t_backfacing(wo, wi, wh)) return 0.0f;
  const float sqrt_denom = glm::dot(wo, wh) + eta * glm::dot(wi, wh);
  const float dwh_dwi =
      std::fabs((eta * eta * glm::dot(wi, wh)) / (sqrt_denom * sqrt_denom));
  return dist(l).PDF(wo, wh) * dwh_dwi;
}

// -- FRESNEL_BLEND (pbrt-v3 FresnelBlend) --
glm::vec3 fresnel_blend_f(const Lobe& l, glm::vec3 wo, glm::vec3 wi) {
  if (!same_hemisphere(wo, wi)) return glm::vec3(0.0f);
  auto pow5 = [](float v) { return (v * v) * (v * v) * v; };
  const glm::vec3 diffuse = (28.0f / (23.0f * PI)) * l.c0 * (glm::vec3(1.0f) - l.c1) *
                            (1.0f - pow5(1.0f - 0.5f * std::fabs(wi.z))) *
                            (1.0f - pow5(1.0f - 0.5f * std::fabs(wo.z)));
  glm::vec3 wh = wi + wo;
  if (wh.x == 0.0f && wh.y == 0.0f && wh.z == 0.0f) return glm::vec3(0.0f);
  wh = safe_normalize(wh);
  const glm::vec3 specular =
      dist(l).D(wh) /
      (4.0f * std::fabs(glm::dot(wi, wh)) * std::fmax(std::fabs(wi.z), std::fabs(wo.z))) *
      fr_schlick(l.c1, glm::dot(wi, wh));
  return diffuse + specular;
}

float fresnel_blend_pdf(const Lobe& l, glm::vec3 wo, glm::vec3 wi) {
  if (!same_hemisphere(wo, wi)) return 0.0f;
  const glm::vec3 wh = safe_normalize(wo + wi);
  const float pdf_wh = dist(l).PDF(wo, wh);
  return 0.5f * (std::fabs(wi.z) / PI + pdf_wh / (4.0f * std::fabs(glm::dot(wo, wh))));
}

// -- MEASURED (pbrt-v2 RegularHalfangleBRDF::f, two-sided) --
glm::vec3 measured_f(const Bsdf& b, const Lobe& l, glm::vec3 wo, glm::vec3 wi) {
  if (wo.z < 0.0f) {
    wo = -wo;
    wi = -wi;
  }
  if (!same_hemisphere(wo, wi)) return glm::vec3(0.0f);
  if (!b.scene) return glm::vec3(0.0f);
  const glm::vec3 wh = safe_normalize(wi + wo);
  // Half-angle frame (pbrt-v2: whx, why from theta_h, phi_h).
  const float wh_theta = std::acos(glm::clamp(wh.z, -1.0f, 1.0f));
  const float wh_cos_phi = cos_phi(wh), wh_sin_phi = sin_phi(wh);
  const float wh_cos_theta = wh.z, wh_sin_theta = sin_theta(wh);
  const glm::vec3 whx(wh_cos_phi * wh_cos_theta, wh_sin_phi * wh_cos_theta, -wh_sin_theta);
  const glm::vec3 why(-wh_sin_phi, wh_cos_phi, 0.0f);
  const glm::vec3 wd(glm::dot(wi, whx), glm::dot(wi, why), glm::dot(wi, wh));
  // Difference angles (pbrt-v2 SphericalTheta, SphericalPhi in [0, 2 pi)).
  const float wd_theta = std::acos(glm::clamp(wd.z, -1.0f, 1.0f));
  float wd_phi = std::atan2(wd.y, wd.x);
  if (wd_phi < 0.0f) wd_phi += 2.0f * PI;
  if (wd_phi > PI) wd_phi -= PI;
  // pbrt-v2 REMAP(V, MAX, COUNT) = Clamp(int(V / MAX * COUNT), 0, COUNT - 1).
  auto remap = [](float v, float max, std::uint32_t count) -> std::uint32_t {
    const float x = v / max * float(count);
    if (!(x > 0.0f)) return 0u;  // negative or NaN
    const float hi = float(count - 1u);
    return x >= hi ? count - 1u : std::uint32_t(int(x));
  };
  const std::uint32_t nth = l.dims.x, ntd = l.dims.y, npd = l.dims.z;
  if (nth == 0 || ntd == 0 || npd == 0) return glm::vec3(0.0f);
  const std::uint32_t ih = remap(std::sqrt(std::fmax(0.0f, wh_theta / (PI / 2.0f))), 1.0f, nth);
  const std::uint32_t id = remap(wd_theta, PI / 2.0f, ntd);
  const std::uint32_t ip = remap(wd_phi, PI, npd);
  const std::uint64_t index = ip + std::uint64_t(npd) * (id + std::uint64_t(ih) * ntd);
  const std::uint64_t at = std::uint64_t(l.n0) + 3u * index;
  const std::vector<float>& t = b.scene->measured;
  if (at + 2u >= t.size()) return glm::vec3(0.0f);
  return glm::vec3(t[at], t[at + 1], t[at + 2]);
}

}  // namespace

std::uint32_t lobe_flags(const Lobe& l) {
  using namespace gpu;
  switch (l.tag) {
    case LOBE_LAMBERT_R:
    case LOBE_OREN_NAYAR:
      return BSDF_REFLECTION | BSDF_DIFFUSE;
    case LOBE_LAMBERT_T:
      return BSDF_TRANSMISSION | BSDF_DIFFUSE;
    case LOBE_MICROFACET_R:
    case LOBE_FRESNEL_BLEND:
    case LOBE_MEASURED:
      return BSDF_REFLECTION | BSDF_GLOSSY;
    case LOBE_MICROFACET_T:
      return BSDF_TRANSMISSION | BSDF_GLOSSY;
    case LOBE_SPECULAR_R:
      return BSDF_REFLECTION | BSDF_SPECULAR;
    case LOBE_SPECULAR_T:
      return BSDF_TRANSMISSION | BSDF_SPECULAR;
    case LOBE_CONDUCTOR:
      return bxdf::Conductor{dist(l), l.c0, l.c1}.flags();
    case LOBE_DIELECTRIC:
      return bxdf::Dielectric{l.eta, dist(l)}.flags();
    case LOBE_THIN_DIELECTRIC:
      return BSDF_REFLECTION | BSDF_TRANSMISSION | BSDF_SPECULAR;
    case LOBE_DIFFUSE_TRANSMISSION:
      // pbrt-v4 DiffuseTransmissionBxDF::Flags.
      return (bxdf::nonzero(l.c0) ? (BSDF_REFLECTION | BSDF_DIFFUSE) : 0u) |
             (bxdf::nonzero(l.c1) ? (BSDF_TRANSMISSION | BSDF_DIFFUSE) : 0u);
    case LOBE_LAYERED_DIFFUSE:
      return bxdf::coated_diffuse(l).flags();
    case LOBE_LAYERED_CONDUCTOR:
      return bxdf::coated_conductor(l).flags();
    default:
      return 0u;
  }
}

glm::vec3 lobe_f(const Bsdf& b, const Lobe& l, glm::vec3 wo, glm::vec3 wi, glm::uvec4 stream) {
  using namespace gpu;
  switch (l.tag) {
    case LOBE_LAMBERT_R:
      return same_hemisphere(wo, wi) ? glm::vec3(INV_PI) : glm::vec3(0.0f);
    case LOBE_LAMBERT_T:
      return !same_hemisphere(wo, wi) ? glm::vec3(INV_PI) : glm::vec3(0.0f);
    case LOBE_OREN_NAYAR:
      return oren_nayar_f(l, wo, wi);
    case LOBE_MICROFACET_R:
      return microfacet_r_f(l, wo, wi);
    case LOBE_MICROFACET_T:
      return microfacet_t_f(l, wo, wi);
    case LOBE_FRESNEL_BLEND:
      return fresnel_blend_f(l, wo, wi);
    case LOBE_CONDUCTOR:
      return bxdf::Conductor{dist(l), l.c0, l.c1}.f(wo, wi);
    case LOBE_DIELECTRIC: {
      // pbrt-v3 glass scales: reflection by Kr (c0), transmission by Kt (c1).
      const glm::vec3 f = bxdf::Dielectric{l.eta, dist(l)}.f(wo, wi, Mode::Radiance);
      return f * (same_hemisphere(wo, wi) ? l.c0 : l.c1);
    }
    case LOBE_DIFFUSE_TRANSMISSION:
      // pbrt-v4 DiffuseTransmissionBxDF::f.
      return same_hemisphere(wo, wi) ? l.c0 / PI : l.c1 / PI;
    case LOBE_LAYERED_DIFFUSE:
      return bxdf::coated_diffuse(l).f(wo, wi, Mode::Radiance, stream);
    case LOBE_LAYERED_CONDUCTOR:
      return bxdf::coated_conductor(l).f(wo, wi, Mode::Radiance, stream);
    case LOBE_MEASURED:
      return measured_f(b, l, wo, wi);
    default:  // specular lobes, unknown tags
      return glm::vec3(0.0f);
  }
}

float lobe_pdf(const Bsdf&, const Lobe& l, glm::vec3 wo, glm::vec3 wi, glm::uvec4 stream) {
  using namespace gpu;
  switch (l.tag) {
    case LOBE_LAMBERT_R:
    case LOBE_OREN_NAYAR:
    case LOBE_MEASURED:
      return same_hemisphere(wo, wi) ? std::fabs(wi.z) / PI : 0.0f;
    case LOBE_LAMBERT_T:
      return !same_hemisphere(wo, wi) ? std::fabs(wi.z) / PI : 0.0f;
    case LOBE_MICROFACET_R:
      return microfacet_r_pdf(l, wo, wi);
    case LOBE_MICROFACET_T:
      return microfacet_t_pdf(l, wo, wi);
    case LOBE_FRESNEL_BLEND:
      return fresnel_blend_pdf(l, wo, wi);
    case LOBE_CONDUCTOR:
      return bxdf::Conductor{dist(l), l.c0, l.c1}.pdf(wo, wi, bxdf::SAMPLE_ALL);
    case LOBE_DIELECTRIC:
      return bxdf::Dielectric{l.eta, dist(l)}.pdf(wo, wi, Mode::Radiance, bxdf::SAMPLE_ALL);
    case LOBE_DIFFUSE_TRANSMISSION: {
      // pbrt-v4 DiffuseTransmissionBxDF::PDF.
      const float pr = max_component(l.c0), pt = max_component(l.c1);
      if (pr == 0.0f && pt == 0.0f) return 0.0f;
      const float c = std::fabs(wi.z) / PI;
      return same_hemisphere(wo, wi) ? pr / (pr + pt) * c : pt / (pr + pt) * c;
    }
    case LOBE_LAYERED_DIFFUSE:
      return bxdf::coated_diffuse(l).pdf(wo, wi, Mode::Radiance, stream);
    case LOBE_LAYERED_CONDUCTOR:
      return bxdf::coated_conductor(l).pdf(wo, wi, Mode::Radiance, stream);
    default:  // specular lobes, unknown tags
      return 0.0f;
  }
}

BsdfSample lobe_sample(const Bsdf& b, const Lobe& l, glm::vec3 wo, float uc, glm::vec2 u,
                       glm::uvec4 stream) {
  using namespace gpu;
  BsdfSample s;
  switch (l.tag) {
    case LOBE_LAMBERT_R:
    case LOBE_OREN_NAYAR:
    case LOBE_MEASURED:
    case LOBE_LAMBERT_T: {
      // Cosine-weighted hemisphere (pbrt-v3 BxDF::Sample_f, LambertianTransmission).
      s.wi = cosine_on_side(wo, u, l.tag == LOBE_LAMBERT_T);
      s.flags = lobe_flags(l);
      break;
    }
    case LOBE_MICROFACET_R: {
      if (wo.z == 0.0f) return BsdfSample{};
      const glm::vec3 wh = dist(l).sample_wm(wo, u);
      s.wi = reflect_about(wo, wh);
      if (!same_hemisphere(wo, s.wi)) return BsdfSample{};
      s.pdf = dist(l).PDF(wo, wh) / (4.0f * std::fabs(glm::dot(wo, wh)));
      s.f = microfacet_r_f(l, wo, s.wi);
      s.flags = BSDF_REFLECTION | BSDF_GLOSSY;
      return s;
    }
    case LOBE_MICROFACET_T: {
      if (wo.z == 0.0f) return BsdfSample{};
      // pbrt-v3 samples wh on wo's side (its Refract needs that).
      const glm::vec3 wh = face_forward(dist(l).sample_wm(wo, u), wo);
      if (glm::dot(wo, wh) < 0.0f) return BsdfSample{};
      const float eta = wo.z > 0.0f ? 1.0f / l.eta : l.eta;  // etaA/etaB or etaB/etaA
      if (!refract_v3(wo, wh, eta, &s.wi)) return BsdfSample{};
      s.pdf = microfacet_t_pdf(l, wo, s.wi);
      s.f = microfacet_t_f(l, wo, s.wi);
      s.flags = BSDF_TRANSMISSION | BSDF_GLOSSY;
      s.eta = 1.0f / eta;
      return s;
    }
    case LOBE_SPECULAR_R: {
      s.wi = glm::vec3(-wo.x, -wo.y, wo.z);
      s.f = lobe_fresnel(l, s.wi.z) / std::fabs(s.wi.z);
      s.pdf = 1.0f;
      s.flags = BSDF_REFLECTION | BSDF_SPECULAR;
      return s;
    }
    case LOBE_SPECULAR_T: {
      // pbrt-v3 SpecularTransmission (etaA = 1, etaB = eta), radiance mode.
      const bool entering = wo.z > 0.0f;
      const float eta_i = entering ? 1.0f : l.eta, eta_t = entering ? l.eta : 1.0f;
      if (!refract_v3(wo, face_forward(glm::vec3(0, 0, 1), wo), eta_i / eta_t, &s.wi))
        return BsdfSample{};
      const float ft = (1.0f - fr_dielectric(s.wi.z, l.eta)) * (eta_i * eta_i) /
                       (eta_t * eta_t);
      s.f = glm::vec3(ft / std::fabs(s.wi.z));
      s.pdf = 1.0f;
      s.flags = BSDF_TRANSMISSION | BSDF_SPECULAR;
      s.eta = eta_t / eta_i;
      return s;
    }
    case LOBE_FRESNEL_BLEND: {
      // docs/materials-spec.md 2.3: the remapped lobe number chooses diffuse or glossy.
      if (uc < 0.5f) {
        s.wi = cosine_on_side(wo, u, false);
      } else {
        const glm::vec3 wh = dist(l).sample_wm(wo, u);
        s.wi = reflect_about(wo, wh);
        if (!same_hemisphere(wo, s.wi)) return BsdfSample{};
      }
      s.flags = BSDF_REFLECTION | BSDF_GLOSSY;
      break;
    }
    case LOBE_CONDUCTOR:
      return bxdf::Conductor{dist(l), l.c0, l.c1}.sample(wo, uc, u, bxdf::SAMPLE_ALL);
    case LOBE_DIELECTRIC: {
      s = bxdf::Dielectric{l.eta, dist(l)}.sample(wo, uc, u, Mode::Radiance, bxdf::SAMPLE_ALL);
      if (s.flags != 0) s.f *= (s.flags & BSDF_REFLECTION) ? l.c0 : l.c1;
      return s;
    }
    case LOBE_THIN_DIELECTRIC: {
      // pbrt-v4 ThinDielectricBxDF::Sample_f.
      float R = fr_dielectric(std::fabs(wo.z), l.eta), T = 1.0f - R;
      if (R < 1.0f) {
        R += T * T * R / (1.0f - R * R);
        T = 1.0f - R;
      }
      const float pr = R, pt = T;
      if (pr == 0.0f && pt == 0.0f) return BsdfSample{};
      if (uc < pr / (pr + pt)) {
        s.wi = glm::vec3(-wo.x, -wo.y, wo.z);
        s.f = glm::vec3(R / std::fabs(s.wi.z));
        s.pdf = pr / (pr + pt);
        s.flags = BSDF_REFLECTION | BSDF_SPECULAR;
      } else {
        s.wi = -wo;
        s.f = glm::vec3(T / std::fabs(s.wi.z));
        s.pdf = pt / (pr + pt);
        s.flags = BSDF_TRANSMISSION | BSDF_SPECULAR;
      }
      return s;
    }
    case LOBE_DIFFUSE_TRANSMISSION: {
      // pbrt-v4 DiffuseTransmissionBxDF::Sample_f (choice by max component).
      const float pr = max_component(l.c0), pt = max_component(l.c1);
      if (pr == 0.0f && pt == 0.0f) return BsdfSample{};
      const bool refl = uc < pr / (pr + pt);
      s.wi = cosine_on_side(wo, u, !refl);
      s.pdf = std::fabs(s.wi.z) / PI * (refl ? pr : pt) / (pr + pt);
      s.f = same_hemisphere(wo, s.wi) ? l.c0 / PI : l.c1 / PI;
      s.flags = refl ? (BSDF_REFLECTION | BSDF_DIFFUSE) : (BSDF_TRANSMISSION | BSDF_DIFFUSE);
      return s;
    }
    case LOBE_LAYERED_DIFFUSE:
      return bxdf::coated_diffuse(l).sample(wo, uc, u, Mode::Radiance, stream);
    case LOBE_LAYERED_CONDUCTOR:
      return bxdf::coated_conductor(l).sample(wo, uc, u, Mode::Radiance, stream);
    default:
      return BsdfSample{};
  }
  // Lobes whose sample is evaluated by their own f and pdf.
  s.f = lobe_f(b, l, wo, s.wi, stream);
  s.pdf = lobe_pdf(b, l, wo, s.wi, stream);
  return s;
}

}  // namespace basalt::cpu
