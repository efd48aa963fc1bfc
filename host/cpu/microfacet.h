// Microfacet distributions of the CPU reference (docs/materials-spec.md sections 1.4, 2.1):
// Trowbridge-Reitz as pbrt-v4 (visible-normal sampling) and Beckmann as pbrt-v3 (full
// distribution sampling), plus the local-frame trigonometry of pbrt's BxDFs.
#pragma once
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

#include "../../shaders/shared/layout.h"
#include "cpu/sampling.h"

namespace basalt::cpu {

// ---- local-frame trigonometry (pbrt-v4 util/vecmath.h; z = shading normal) ----------------

/// cos^2 theta.
inline float cos2_theta(glm::vec3 w) { return w.z * w.z; }
/// sin^2 theta, clamped at 0.
inline float sin2_theta(glm::vec3 w) { return std::fmax(0.0f, 1.0f - cos2_theta(w)); }
/// sin theta.
inline float sin_theta(glm::vec3 w) { return std::sqrt(sin2_theta(w)); }
/// tan^2 theta (infinite in the tangent plane).
inline float tan2_theta(glm::vec3 w) { return sin2_theta(w) / cos2_theta(w); }
/// tan theta.
inline float tan_theta(glm::vec3 w) { return sin_theta(w) / w.z; }
/// cos phi; 1 when sin theta is 0 (pbrt CosPhi).
inline float cos_phi(glm::vec3 w) {
  const float s = sin_theta(w);
  return s == 0.0f ? 1.0f : glm::clamp(w.x / s, -1.0f, 1.0f);
}
/// sin phi; 0 when sin theta is 0 (pbrt SinPhi).
inline float sin_phi(glm::vec3 w) {
  const float s = sin_theta(w);
  return s == 0.0f ? 0.0f : glm::clamp(w.y / s, -1.0f, 1.0f);
}
/// pbrt-v4 SameHemisphere: strictly on the same side of the surface.
inline bool same_hemisphere(glm::vec3 a, glm::vec3 b) { return a.z * b.z > 0.0f; }
/// pbrt SphericalDirection(sin theta, cos theta, phi) with pbrt-v4's clamps.
inline glm::vec3 spherical_direction(float sin_t, float cos_t, float phi) {
  const float s = glm::clamp(sin_t, -1.0f, 1.0f);
  return glm::vec3(s * std::cos(phi), s * std::sin(phi), glm::clamp(cos_t, -1.0f, 1.0f));
}
/// pbrt Reflect(wo, n) = -wo + 2 dot(wo, n) n.
inline glm::vec3 reflect_about(glm::vec3 wo, glm::vec3 n) {
  return -wo + 2.0f * glm::dot(wo, n) * n;
}
/// pbrt FaceForward(n, v): n flipped to v's side (dot(n, v) < 0 flips).
inline glm::vec3 face_forward(glm::vec3 n, glm::vec3 v) {
  return glm::dot(n, v) < 0.0f ? -n : n;
}

// ---- roughness (docs/materials-spec.md 1.4) ------------------------------------------------

/// \brief alpha of a roughness value by the remap of Material.flags & MATFLAG_REMAP_MASK: NONE
///        alpha = r; SQRT pbrt-v4 TrowbridgeReitzDistribution::RoughnessToAlpha; V3 pbrt-v3
///        RoughnessToAlpha (polynomial in x = ln(max(r, 1e-3)), evaluated as written).
inline float roughness_to_alpha(float r, std::uint32_t flags) {
  switch (flags & gpu::MATFLAG_REMAP_MASK) {
    case gpu::MATFLAG_REMAP_SQRT:
      return std::sqrt(r);
    case gpu::MATFLAG_REMAP_V3: {
      const float x = std::log(std::fmax(r, 1e-3f));
      return 1.62142f + 0.819955f * x + 0.1734f * x * x + 0.0171201f * x * x * x +
             0.000640711f * x * x * x * x;
    }
    default:
      return r;
  }
}

// ---- distributions -------------------------------------------------------------------------

/// A microfacet distribution: Trowbridge-Reitz (pbrt-v4 9.6) or Beckmann (pbrt-v3 8.4.2).
struct Microfacet {
  float ax = 0.0f, ay = 0.0f;
  bool beckmann = false;

  /// \brief Distribution of alphas (ax, ay). As pbrt-v4's TrowbridgeReitzDistribution
  ///        constructor, a rough distribution keeps both alphas >= 1e-4 (D blows up otherwise);
  ///        applied to Beckmann too.
  static Microfacet make(float ax, float ay, bool beckmann) {
    Microfacet m{ax, ay, beckmann};
    if (!m.effectively_smooth()) {
      m.ax = std::fmax(m.ax, 1e-4f);
      m.ay = std::fmax(m.ay, 1e-4f);
    }
    return m;
  }

  /// pbrt-v4 EffectivelySmooth: max(ax, ay) < 1e-3 (the lobe is specular).
  bool effectively_smooth() const { return std::fmax(ax, ay) < 1e-3f; }

  /// Microfacet normal density D(wm) (pbrt-v4 TrowbridgeReitzDistribution::D; pbrt-v3
  /// BeckmannDistribution::D). 0 where tan^2 theta is infinite.
  float D(glm::vec3 wm) const {
    const float tan2 = tan2_theta(wm);
    if (std::isinf(tan2)) return 0.0f;
    const float cos4 = cos2_theta(wm) * cos2_theta(wm);
    if (beckmann) {
      const float cp = cos_phi(wm), sp = sin_phi(wm);
      return std::exp(-tan2 * (cp * cp / (ax * ax) + sp * sp / (ay * ay))) /
             (PI * ax * ay * cos4);
    }
    if (cos4 < 1e-16f) return 0.0f;
    const float cx = cos_phi(wm) / ax, sy = sin_phi(wm) / ay;
    const float e = tan2 * (cx * cx + sy * sy);
    return 1.0f / (PI * ax * ay * cos4 * ((1.0f + e) * (1.0f + e)));
  }

  /// Smith's Lambda(w) (pbrt-v4 TR closed form; pbrt-v3 Beckmann rational approximation).
  float Lambda(glm::vec3 w) const {
    if (beckmann) {
      const float abs_tan = std::fabs(tan_theta(w));
      if (std::isinf(abs_tan)) return 0.0f;
      const float cp = cos_phi(w), sp = sin_phi(w);
      const float alpha = std::sqrt(cp * cp * ax * ax + sp * sp * ay * ay);
      const float a = 1.0f / (alpha * abs_tan);
      if (a >= 1.6f) return 0.0f;
      return (1.0f - 1.259f * a + 0.396f * a * a) / (3.535f * a + 2.181f * a * a);
    }
    const float tan2 = tan2_theta(w);
    if (std::isinf(tan2)) return 0.0f;
    const float cx = cos_phi(w) * ax, sy = sin_phi(w) * ay;
    const float alpha2 = cx * cx + sy * sy;
    return (std::sqrt(1.0f + alpha2 * tan2) - 1.0f) / 2.0f;
  }

  /// Masking G1(w) = 1 / (1 + Lambda(w)).
  float G1(glm::vec3 w) const { return 1.0f / (1.0f + Lambda(w)); }
  /// Height-correlated masking-shadowing G(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi)).
  float G(glm::vec3 wo, glm::vec3 wi) const { return 1.0f / (1.0f + Lambda(wo) + Lambda(wi)); }

  /// Density of sampled normals wm given w: TR the visible normals G1(w)/|cos w| D(wm)
  /// |dot(w, wm)| (pbrt-v4 PDF = D(w, wm)); Beckmann D(wm) |cos wm| (pbrt-v3, full
  /// distribution).
  float PDF(glm::vec3 w, glm::vec3 wm) const {
    if (beckmann) return D(wm) * std::fabs(wm.z);
    return G1(w) / std::fabs(w.z) * D(wm) * std::fabs(glm::dot(w, wm));
  }

  /// \brief Samples a microfacet normal for w with u = (u0, u1). TR: pbrt-v4 Sample_wm (Heitz
  ///        2018 visible normals, result in the +z hemisphere); Beckmann: pbrt-v3
  ///        BeckmannDistribution::Sample_wh with sampleVisibleArea = false (flipped to w's
  ///        side). docs/materials-spec.md 2.1.
  glm::vec3 sample_wm(glm::vec3 w, glm::vec2 u) const {
    if (beckmann) {
      float tan2, phi;
      const float log_sample = std::log(1.0f - u.x);
      if (ax == ay) {
        tan2 = -ax * ax * log_sample;
        phi = u.y * 2.0f * PI;
      } else {
        phi = std::atan(ay / ax * std::tan(2.0f * PI * u.y + 0.5f * PI));
        if (u.y > 0.5f) phi += PI;
        const float sp = std::sin(phi), cp = std::cos(phi);
        tan2 = -log_sample / (cp * cp / (ax * ax) + sp * sp / (ay * ay));
      }
      const float cos_t = 1.0f / std::sqrt(1.0f + tan2);
      const float sin_t = std::sqrt(std::fmax(0.0f, 1.0f - cos_t * cos_t));
      glm::vec3 wh = spherical_direction(sin_t, cos_t, phi);
      if (!same_hemisphere(w, wh)) wh = -wh;
      return wh;
    }
    // Transform w to the hemispherical configuration.
    glm::vec3 wh = safe_normalize(glm::vec3(ax * w.x, ay * w.y, w.z));
    if (wh.z < 0.0f) wh = -wh;
    // Orthonormal basis for visible normal sampling.
    const glm::vec3 T1 = wh.z < 0.99999f
                             ? safe_normalize(glm::cross(glm::vec3(0.0f, 0.0f, 1.0f), wh))
                             : glm::vec3(1.0f, 0.0f, 0.0f);
    const glm::vec3 T2 = glm::cross(wh, T1);
    // pbrt-v4 SampleUniformDiskPolar.
    const float r = std::sqrt(u.x);
    const float theta = 2.0f * PI * u.y;
    glm::vec2 p(r * std::cos(theta), r * std::sin(theta));
    // Warp the hemispherical projection: Lerp((1 + wh.z) / 2, h, p.y).
    const float h = std::sqrt(1.0f - p.x * p.x);
    const float t = (1.0f + wh.z) / 2.0f;
    p.y = (1.0f - t) * h + t * p.y;
    // Reproject to the hemisphere and transform back to the ellipsoid configuration.
    const float pz = std::sqrt(std::fmax(0.0f, 1.0f - (p.x * p.x + p.y * p.y)));
    const glm::vec3 nh = p.x * T1 + p.y * T2 + pz * wh;
    return safe_normalize(glm::vec3(ax * nh.x, ay * nh.y, std::fmax(1e-6f, nh.z)));
  }
};

}  // namespace basalt::cpu
