// Materials to BSDFs on the CPU (docs/materials-spec.md sections 1, 3 and 4): stochastic mix
// resolution, lobe lists per material, and the BSDF-level eval / pdf / sample that combine the
// lobes with the light-leak rule.
#include "cpu/bsdf.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "cpu/bump.h"
#include "cpu/bxdfs.h"
#include "cpu/microfacet.h"
#include "cpu/rng.h"

namespace basalt::cpu {
namespace {

/// The largest float below 1 (pbrt OneMinusEpsilon).
constexpr float ONE_MINUS_EPSILON = 0x1.fffffep-1f;

/// Appends lobe l scaled by `scale` if its weight has a component > 0 and there is room
/// (docs/materials-spec.md 1.3; the parser keeps the total <= MAX_LOBES).
void add_lobe(Bsdf& b, Lobe l, glm::vec3 scale) {
  l.weight *= scale;
  if (!any_positive(l.weight) || b.n >= gpu::MAX_LOBES) return;
  b.lobes[b.n++] = l;
}

/// MICROFACET_R lobe (or SPECULAR_R when effectively smooth, docs/materials-spec.md 1.4).
Lobe microfacet_r(glm::vec3 weight, float ax, float ay, bool beckmann, std::uint32_t fresnel,
                  float eta, glm::vec3 ceta, glm::vec3 k) {
  Lobe l;
  l.tag = Microfacet::make(ax, ay, beckmann).effectively_smooth() ? gpu::LOBE_SPECULAR_R
                                                                  : gpu::LOBE_MICROFACET_R;
  l.weight = weight;
  l.ax = ax;
  l.ay = ay;
  l.beckmann = beckmann;
  l.fresnel = fresnel;
  l.eta = eta;
  l.c0 = ceta;
  l.c1 = k;
  return l;
}

/// SPECULAR_R lobe of weight and Fresnel.
Lobe specular_r(glm::vec3 weight, std::uint32_t fresnel, float eta) {
  Lobe l;
  l.tag = gpu::LOBE_SPECULAR_R;
  l.weight = weight;
  l.fresnel = fresnel;
  l.eta = eta;
  return l;
}

/// SPECULAR_T lobe of weight and IOR.
Lobe specular_t(glm::vec3 weight, float eta) {
  Lobe l;
  l.tag = gpu::LOBE_SPECULAR_T;
  l.weight = weight;
  l.eta = eta;
  return l;
}

/// LAMBERT_R / LAMBERT_T lobe of weight.
Lobe lambert(std::uint32_t tag, glm::vec3 weight) {
  Lobe l;
  l.tag = tag;
  l.weight = weight;
  return l;
}

/// Conductor eta and k of a material (docs/materials-spec.md section 3 CONDUCTOR): the slots,
/// or with MATFLAG_USE_REFLECTANCE eta = 1, k = 2 sqrt(r) / sqrt(1 - r) (pbrt-v4
/// ConductorMaterial).
void conductor_eta_k(const gpu::Material& m, const SurfacePoint& sp, std::uint32_t s_eta,
                     std::uint32_t s_k, std::uint32_t s_refl, glm::vec3* eta, glm::vec3* k) {
  if (m.flags & gpu::MATFLAG_USE_REFLECTANCE) {
    const glm::vec3 r = glm::clamp(slot_value(m, s_refl, sp), 0.0f, 0.9999f);
    *eta = glm::vec3(1.0f);
    *k = 2.0f * glm::sqrt(r) / glm::sqrt(glm::vec3(1.0f) - r);
  } else {
    *eta = slot_value(m, s_eta, sp);
    *k = slot_value(m, s_k, sp);
  }
}

/// Appends the lobes of a non-mix material (docs/materials-spec.md section 3), scaled by
/// `scale` (MIX_WEIGHTED).
void add_material_lobes(Bsdf& b, const gpu::Material& m, const SurfacePoint& sp,
                        glm::vec3 scale) {
  using namespace gpu;
  const bool beck = (m.flags & MATFLAG_BECKMANN) != 0;
  auto val = [&](std::uint32_t s) { return slot_value(m, s, sp); };
  auto alpha = [&](std::uint32_t s) { return roughness_to_alpha(val(s).x, m.flags); };
  // A layered lobe's coat and medium from the material's slots (both coated materials).
  auto layered = [&](std::uint32_t tag, std::uint32_t urough, std::uint32_t vrough,
                     std::uint32_t thickness, std::uint32_t eta, std::uint32_t albedo,
                     std::uint32_t g) {
    Lobe l;
    l.tag = tag;
    l.ax = alpha(urough);
    l.ay = alpha(vrough);
    l.s0 = val(thickness).x;
    l.eta = val(eta).x;
    // pbrt-v4 Coated*Material clamps albedo to [0, 1] and g to [-1, 1] (textures can leave them).
    l.c1 = glm::clamp(val(albedo), 0.0f, 1.0f);
    l.s1 = std::clamp(val(g).x, -1.0f, 1.0f);
    l.beckmann = beck;
    l.n0 = m.aux0;
    l.n1 = std::max(m.aux1, 1u);
    l.pbrt_mis = (m.flags & gpu::MATFLAG_LAYERED_PBRT_MIS) != 0u;
    return l;
  };
  switch (m.type) {
    case MATERIAL_DIFFUSE:
      // pbrt-v4 DiffuseMaterial clamps the reflectance to [0, 1].
      add_lobe(b, lambert(LOBE_LAMBERT_R, glm::clamp(val(SLOT_DIFFUSE_REFLECTANCE), 0.0f, 1.0f)),
               scale);
      break;
    case MATERIAL_OREN_NAYAR: {
      const glm::vec3 kd = val(SLOT_ON_REFLECTANCE);
      const float sigma_deg = val(SLOT_ON_SIGMA).x;
      if (sigma_deg == 0.0f) {
        add_lobe(b, lambert(LOBE_LAMBERT_R, kd), scale);
        break;
      }
      // pbrt-v3 OrenNayar constructor: A, B from sigma in radians.
      const float sigma = (PI / 180.0f) * sigma_deg;
      const float s2 = sigma * sigma;
      Lobe l = lambert(LOBE_OREN_NAYAR, kd);
      l.s0 = 1.0f - (s2 / (2.0f * (s2 + 0.33f)));
      l.s1 = 0.45f * s2 / (s2 + 0.09f);
      add_lobe(b, l, scale);
      break;
    }
    case MATERIAL_CONDUCTOR: {
      Lobe l;
      l.tag = LOBE_CONDUCTOR;
      conductor_eta_k(m, sp, SLOT_CONDUCTOR_ETA, SLOT_CONDUCTOR_K, SLOT_CONDUCTOR_REFLECTANCE,
                      &l.c0, &l.c1);
      l.ax = alpha(SLOT_CONDUCTOR_UROUGH);
      l.ay = alpha(SLOT_CONDUCTOR_VROUGH);
      l.beckmann = beck;
      add_lobe(b, l, scale);
      break;
    }
    case MATERIAL_METAL:
      add_lobe(b,
               microfacet_r(glm::vec3(1.0f), alpha(SLOT_CONDUCTOR_UROUGH),
                            alpha(SLOT_CONDUCTOR_VROUGH), beck, FRESNEL_CONDUCTOR, 1.0f,
                            val(SLOT_CONDUCTOR_ETA), val(SLOT_CONDUCTOR_K)),
               scale);
      break;
    case MATERIAL_MIRROR:
      add_lobe(b, specular_r(val(SLOT_MIRROR_KR), FRESNEL_ONE, 1.0f), scale);
      break;
    case MATERIAL_DIELECTRIC: {
      Lobe l;
      l.tag = LOBE_DIELECTRIC;
      l.eta = val(SLOT_DIELECTRIC_ETA).x;
      l.ax = alpha(SLOT_DIELECTRIC_UROUGH);
      l.ay = alpha(SLOT_DIELECTRIC_VROUGH);
      l.beckmann = beck;
      l.c0 = val(SLOT_DIELECTRIC_KR);
      l.c1 = val(SLOT_DIELECTRIC_KT);
      add_lobe(b, l, scale);
      break;
    }
    case MATERIAL_THIN_DIELECTRIC: {
      Lobe l;
      l.tag = LOBE_THIN_DIELECTRIC;
      l.eta = val(SLOT_THIN_ETA).x;
      add_lobe(b, l, scale);
      break;
    }
    case MATERIAL_DIFFUSE_TRANSMISSION: {
      Lobe l;
      l.tag = LOBE_DIFFUSE_TRANSMISSION;
      const float s = val(SLOT_DT_SCALE).x;
      l.c0 = glm::clamp(s * val(SLOT_DT_REFLECTANCE), 0.0f, 1.0f);  // pbrt-v4 clamps both
      l.c1 = glm::clamp(s * val(SLOT_DT_TRANSMITTANCE), 0.0f, 1.0f);
      add_lobe(b, l, scale);
      break;
    }
    case MATERIAL_COATED_DIFFUSE: {
      Lobe l = layered(LOBE_LAYERED_DIFFUSE, SLOT_CD_UROUGH, SLOT_CD_VROUGH, SLOT_CD_THICKNESS,
                       SLOT_CD_ETA, SLOT_CD_ALBEDO, SLOT_CD_G);
      l.c0 = glm::clamp(val(SLOT_CD_REFLECTANCE), 0.0f, 1.0f);  // pbrt-v4 clamps to [0, 1]
      add_lobe(b, l, scale);
      break;
    }
    case MATERIAL_COATED_CONDUCTOR: {
      Lobe l = layered(LOBE_LAYERED_CONDUCTOR, SLOT_CC_IF_UROUGH, SLOT_CC_IF_VROUGH,
                       SLOT_CC_THICKNESS, SLOT_CC_IF_ETA, SLOT_CC_ALBEDO, SLOT_CC_G);
      l.bx = alpha(SLOT_CC_UROUGH);
      l.by = alpha(SLOT_CC_VROUGH);
      conductor_eta_k(m, sp, SLOT_CC_ETA, SLOT_CC_K, SLOT_CC_REFLECTANCE, &l.c0, &l.c2);
      // pbrt-v4 CoatedConductorMaterial: the conductor's eta and k relative to the coat.
      if (l.eta == 0.0f) l.eta = 1.0f;
      l.c0 /= l.eta;
      l.c2 /= l.eta;
      add_lobe(b, l, scale);
      break;
    }
    case MATERIAL_PLASTIC: {
      add_lobe(b, lambert(LOBE_LAMBERT_R, val(SLOT_PLASTIC_KD)), scale);
      const float a = alpha(SLOT_PLASTIC_ROUGH);
      // Deliberate deviation from pbrt-v3 (spec section 3): Fresnel (1, 1.5), not (1.5, 1).
      add_lobe(b, microfacet_r(val(SLOT_PLASTIC_KS), a, a, beck, FRESNEL_DIELECTRIC, 1.5f,
                               glm::vec3(0.0f), glm::vec3(0.0f)),
               scale);
      break;
    }
    case MATERIAL_SUBSTRATE: {
      Lobe l;
      l.tag = LOBE_FRESNEL_BLEND;
      l.c0 = val(SLOT_SUBSTRATE_KD);
      l.c1 = val(SLOT_SUBSTRATE_KS);
      // FRESNEL_BLEND has no specular form: alpha clamped to >= 1e-3 (spec 1.4).
      l.ax = std::fmax(alpha(SLOT_SUBSTRATE_UROUGH), 1e-3f);
      l.ay = std::fmax(alpha(SLOT_SUBSTRATE_VROUGH), 1e-3f);
      l.beckmann = beck;
      add_lobe(b, l, scale);
      break;
    }
    case MATERIAL_TRANSLUCENT: {
      const glm::vec3 r = val(SLOT_TRANSLUCENT_REFLECT), t = val(SLOT_TRANSLUCENT_TRANSMIT);
      if (!any_positive(r) && !any_positive(t)) break;
      const glm::vec3 kd = val(SLOT_TRANSLUCENT_KD), ks = val(SLOT_TRANSLUCENT_KS);
      const float a = alpha(SLOT_TRANSLUCENT_ROUGH);
      add_lobe(b, lambert(LOBE_LAMBERT_R, r * kd), scale);
      add_lobe(b, lambert(LOBE_LAMBERT_T, t * kd), scale);
      add_lobe(b, microfacet_r(r * ks, a, a, beck, FRESNEL_DIELECTRIC, 1.5f, glm::vec3(0.0f),
                               glm::vec3(0.0f)),
               scale);
      Lobe mt;
      mt.tag = Microfacet::make(a, a, beck).effectively_smooth() ? LOBE_SPECULAR_T
                                                                 : LOBE_MICROFACET_T;
      mt.weight = t * ks;
      mt.ax = a;
      mt.ay = a;
      mt.beckmann = beck;
      mt.eta = 1.5f;
      add_lobe(b, mt, scale);
      break;
    }
    case MATERIAL_UBER: {
      const glm::vec3 op = val(SLOT_UBER_OPACITY);
      const float eta = val(SLOT_UBER_ETA).x;
      add_lobe(b, specular_t(glm::vec3(1.0f) - op, 1.0f), scale);
      add_lobe(b, lambert(LOBE_LAMBERT_R, op * val(SLOT_UBER_KD)), scale);
      add_lobe(b, microfacet_r(op * val(SLOT_UBER_KS), alpha(SLOT_UBER_UROUGH),
                               alpha(SLOT_UBER_VROUGH), beck, FRESNEL_DIELECTRIC, eta,
                               glm::vec3(0.0f), glm::vec3(0.0f)),
               scale);
      add_lobe(b, specular_r(op * val(SLOT_UBER_KR), FRESNEL_DIELECTRIC, eta), scale);
      add_lobe(b, specular_t(op * val(SLOT_UBER_KT), eta), scale);
      break;
    }
    case MATERIAL_MEASURED: {
      Lobe l;
      l.tag = LOBE_MEASURED;
      l.n0 = m.aux0;
      // The dims are not a texture: the constant value of slot 0.
      const glm::vec4 d = m.value[SLOT_MEASURED_DIMS];
      l.dims = glm::uvec3(std::uint32_t(std::fmax(d.x, 0.0f)), std::uint32_t(std::fmax(d.y, 0.0f)),
                          std::uint32_t(std::fmax(d.z, 0.0f)));
      add_lobe(b, l, scale);
      break;
    }
    default:  // NONE, INTERFACE, mixes (never children of MIX_WEIGHTED), unknown: no lobes
      break;
  }
}

/// docs/materials-spec.md section 4: the hash u in [0, 1) of the hit point and wo (low 12
/// bits of each dropped) and the mix material's index.
float mix_hash(glm::vec3 p, glm::vec3 wo, std::uint32_t index) {
  auto q = [](float f) { return std::bit_cast<std::uint32_t>(f) >> 12; };
  const std::uint32_t w = q(wo.x) ^ (q(wo.y) * 0x9E3779B9u) ^ (q(wo.z) * 0x85EBCA6Bu);
  const glm::uvec4 v = pcg4d(glm::uvec4(q(p.x), q(p.y), q(p.z) ^ (index * 0xC2B2AE35u), w));
  return float(v.x >> 8) * 0x1p-24f;
}

/// True if the geometric normal puts wo and wi on the same side (docs/materials-spec.md 1.2).
bool geo_reflect(glm::vec3 wo, glm::vec3 wi, glm::vec3 ng) {
  return glm::dot(wo, ng) * glm::dot(wi, ng) > 0.0f;
}

}  // namespace

glm::vec3 slot_value(const gpu::Material& m, std::uint32_t slot, const SurfacePoint& sp) {
  // A textured slot evaluates its program in the hit's context (docs/textures-spec.md 2);
  // a float program holds its value in x, y and z alike.
  const std::uint32_t tex = m.texture[slot / 4][slot % 4];
  if (tex != gpu::INVALID_INDEX && sp.scene) return tex_eval_rgb(*sp.scene, tex, sp.tex);
  return glm::vec3(m.value[slot]);
}

std::uint32_t resolve_mix(const SceneTables& scene, std::uint32_t material, glm::vec3 p,
                          glm::vec3 wo_world) {
  SurfacePoint sp;
  sp.g.p = p;
  return resolve_mix(scene, material, sp, wo_world);
}

std::uint32_t resolve_mix(const SceneTables& scene, std::uint32_t material, const SurfacePoint& sp,
                          glm::vec3 wo_world) {
  const glm::vec3 p = sp.g.p;
  std::uint32_t idx = material;
  for (std::uint32_t level = 0;; ++level) {
    if (idx >= scene.materials.size()) return gpu::INVALID_INDEX;
    const gpu::Material& m = scene.materials[idx];
    if (m.type != gpu::MATERIAL_MIX) return idx;
    if (level == 16) return gpu::INVALID_INDEX;  // deeper than 16 levels: MATERIAL_NONE
    // pbrt-v4 MixMaterial::ChooseMaterial with basalt's hash.
    const float a = slot_value(m, gpu::SLOT_MIX_AMOUNT, sp).x;
    if (a <= 0.0f) {
      idx = m.aux0;
    } else if (a >= 1.0f) {
      idx = m.aux1;
    } else {
      const float u = mix_hash(p, wo_world, idx);
      idx = a < u ? m.aux0 : m.aux1;
    }
  }
}

Bsdf bsdf_at(const SceneTables& scene, std::uint32_t material, SurfacePoint& sp,
             glm::vec3 wo_world) {
  Bsdf b;
  b.scene = &scene;
  const std::uint32_t idx = resolve_mix(scene, material, sp, wo_world);
  if (idx == gpu::INVALID_INDEX) return b;
  const gpu::Material& m = scene.materials[idx];
  if (m.type == gpu::MATERIAL_INTERFACE) {
    b.interface = true;
    return b;
  }
  // docs/bump-spec.md 6: the resolved material's normal or bump map sets the shading normal
  // and frame (pbrt-v4 GetBSDF, after ChooseMaterial); a no-op without MATFLAG_BUMP/NORMALMAP.
  bump_shading(scene, m, sp);
  if (m.type == gpu::MATERIAL_MIX_WEIGHTED) {
    // pbrt-v2/v3 MixMaterial: lobes of aux0 x (1 - amount), then aux1 x amount.
    const glm::vec3 amount = glm::clamp(slot_value(m, gpu::SLOT_MIX_AMOUNT, sp), 0.0f, 1.0f);
    const std::uint32_t child[2] = {m.aux0, m.aux1};
    const glm::vec3 scale[2] = {glm::vec3(1.0f) - amount, amount};
    for (int i = 0; i < 2; ++i) {
      if (child[i] >= scene.materials.size()) continue;
      add_material_lobes(b, scene.materials[child[i]], sp, scale[i]);
    }
    return b;
  }
  add_material_lobes(b, m, sp, glm::vec3(1.0f));
  return b;
}

std::uint32_t bsdf_flags(const Bsdf& b) {
  std::uint32_t f = 0;
  for (std::uint32_t i = 0; i < b.n; ++i) f |= lobe_flags(b.lobes[i]);
  return f;
}

bool bsdf_is_nonspecular(const Bsdf& b) { return bxdf::is_nonspecular(bsdf_flags(b)); }

glm::vec3 bsdf_eval(const Bsdf& b, glm::vec3 wo, glm::vec3 wi, glm::vec3 ng,
                    glm::uvec4 stream) {
  if (wo.z == 0.0f || b.n == 0) return glm::vec3(0.0f);
  // Light-leak rule (1.2): the geometric normal decides reflection or transmission.
  if (geo_reflect(wo, wi, ng) != same_hemisphere(wo, wi)) wi.z = -wi.z;
  glm::vec3 f(0.0f);
  for (std::uint32_t i = 0; i < b.n; ++i)
    f += b.lobes[i].weight * lobe_f(b, b.lobes[i], wo, wi, stream);
  return f;
}

float bsdf_pdf(const Bsdf& b, glm::vec3 wo, glm::vec3 wi, glm::vec3 ng, glm::uvec4 stream) {
  if (wo.z == 0.0f || b.n == 0) return 0.0f;
  if (geo_reflect(wo, wi, ng) != same_hemisphere(wo, wi)) return 0.0f;
  float pdf = 0.0f;
  for (std::uint32_t i = 0; i < b.n; ++i) {
    if (!bxdf::is_nonspecular(lobe_flags(b.lobes[i]))) continue;
    pdf += lobe_pdf(b, b.lobes[i], wo, wi, stream);
  }
  return pdf / float(b.n);
}

BsdfSample bsdf_sample(const Bsdf& b, glm::vec3 wo, glm::vec3 u, glm::vec3 ng,
                       glm::uvec4 stream) {
  if (wo.z == 0.0f || b.n == 0) return BsdfSample{};
  // Lobe choice and remap of u_lobe (pbrt-v3 BSDF::Sample_f).
  const float n = float(b.n);
  const std::uint32_t k = std::min(std::uint32_t(std::floor(u.x * n)), b.n - 1u);
  const float uc = std::fmin(u.x * n - float(k), ONE_MINUS_EPSILON);
  const Lobe& lobe = b.lobes[k];
  BsdfSample s = lobe_sample(b, lobe, wo, uc, glm::vec2(u.y, u.z), stream);
  if (s.flags == 0) return BsdfSample{};
  // Light-leak rule (1.2): the sample's kind must match the geometric side of wi.
  if (((s.flags & gpu::BSDF_REFLECTION) != 0) != geo_reflect(wo, s.wi, ng)) return BsdfSample{};
  if (b.n == 1 || bxdf::is_specular(s.flags) || s.pdf_is_proportional) {
    // The chosen lobe alone: specular lobes, and stochastic (layered) lobes whose f and pdf
    // come from one random walk (section 1.3); unbiased with the 1/n choice probability.
    s.f *= lobe.weight;
    s.pdf /= n;
  } else {
    // pbrt-v3 BSDF::Sample_f's `*pdf == 0` test on the chosen lobe's pdf at wi (subnormal
    // counts as 0), even where other lobes are non-zero there.
    if (!(lobe_pdf(b, lobe, wo, s.wi, stream) >= FLT_MIN)) return BsdfSample{};
    s.f = bsdf_eval(b, wo, s.wi, ng, stream);
    s.pdf = bsdf_pdf(b, wo, s.wi, ng, stream);
  }
  // pbrt-v4 BSDF::Sample_f: no sample without f, pdf or a direction off the tangent plane.
  if (!bxdf::usable(s)) return BsdfSample{};
  return s;
}

}  // namespace basalt::cpu
