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

/// \brief (cos 2 pi u, sin 2 pi u) for u in [0, 1], with u reduced to [-1/4, 1/4] first
///        (exactly), so that both keep their relative accuracy near their zeros
///        (docs/materials-spec.md 2.1 numerics).
inline glm::vec2 cos_sin_2pi(float u) {
  float w = u, sign = 1.0f;
  if (u > 0.75f) {
    w = u - 1.0f;
  } else if (u > 0.25f) {
    w = u - 0.5f;
    sign = -1.0f;
  }
  const float a = 2.0f * PI * w;
  return sign * glm::vec2(std::cos(a), std::sin(a));
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

  /// \brief Microfacet normal density D(wm) (pbrt-v4 TrowbridgeReitzDistribution::D; pbrt-v3
  ///        BeckmannDistribution::D), with the angle terms from the components
  ///        (docs/materials-spec.md 2.1 numerics). 0 in the tangent plane.
  float D(glm::vec3 wm) const {
    const float z2 = wm.z * wm.z;
    const float ex = wm.x / ax, ey = wm.y / ay;
    const float e2 = ex * ex + ey * ey;  // tan^2 theta (cos^2 phi / ax^2 + sin^2 phi / ay^2) z2
    if (beckmann) {
      if (z2 == 0.0f) return 0.0f;
      const float arg = e2 / z2;
      if (arg > 87.0f) return 0.0f;  // exp(-arg) would be near or below FLT_MIN
      return std::exp(-arg) / (PI * ax * ay * z2 * z2);
    }
    if (z2 * z2 < 1e-16f) return 0.0f;
    const float q = z2 + e2;  // cos^2 theta (1 + e)
    return 1.0f / (PI * ax * ay * q * q);
  }

  /// \brief Smith's Lambda(w) (pbrt-v4 TR closed form; pbrt-v3 Beckmann rational
  ///        approximation), angle terms from the components (materials-spec 2.1 numerics).
  float Lambda(glm::vec3 w) const {
    if (w.z == 0.0f) return 0.0f;
    const float axx = ax * w.x, ayy = ay * w.y;
    const float a2 = axx * axx + ayy * ayy;  // alpha^2 tan^2 theta cos^2 theta
    if (beckmann) {
      const float a = std::fabs(w.z) / std::sqrt(a2);
      if (a >= 1.6f) return 0.0f;
      return (1.0f - 1.259f * a + 0.396f * a * a) / (3.535f * a + 2.181f * a * a);
    }
    const float s = a2 / (w.z * w.z);
    return s / (2.0f * (1.0f + std::sqrt(1.0f + s)));
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
      float tan2;
      glm::vec2 cs;  // (cos phi, sin phi)
      const float log_sample = std::log1p(-u.x);
      if (ax == ay) {
        tan2 = -ax * ax * log_sample;
        const float phi = u.y * 2.0f * PI;
        cs = glm::vec2(std::cos(phi), std::sin(phi));
      } else {
        // pbrt-v3's phi = atan(ay/ax tan(2 pi u1 + pi/2)) (+ pi if u1 > 1/2), as a direction.
        const glm::vec2 t = cos_sin_2pi(u.y);
        const glm::vec2 v(ax * t.y, -ay * t.x);
        cs = v / std::sqrt(v.x * v.x + v.y * v.y);
        tan2 = -log_sample / (cs.x * cs.x / (ax * ax) + cs.y * cs.y / (ay * ay));
      }
      const float cos_t = 1.0f / std::sqrt(1.0f + tan2);
      const float sin_t = std::sqrt(tan2) * cos_t;
      glm::vec3 wh(sin_t * cs.x, sin_t * cs.y, cos_t);
      if (!same_hemisphere(w, wh)) wh = -wh;
      return wh;
    }
    // Transform w to the hemispherical configuration.
    glm::vec3 wh = safe_normalize(glm::vec3(ax * w.x, ay * w.y, w.z));
    if (wh.z < 0.0f) wh = -wh;
    // Orthonormal basis for visible normal sampling.
    const bool cross_branch = wh.z < 0.99999f;
    const glm::vec3 T1 =
        cross_branch ? safe_normalize(glm::vec3(-wh.y, wh.x, 0.0f)) : glm::vec3(1.0f, 0.0f, 0.0f);
    const glm::vec3 T2 = glm::cross(wh, T1);
    // pbrt-v4 SampleUniformDiskPolar, then the Lerp((1 + wh.z) / 2, h, p.y) warp and the
    // reprojection, in the rim-stable form of materials-spec 2.1 numerics.
    const float r = std::sqrt(u.x);
    const glm::vec2 cs = cos_sin_2pi(u.y);
    const float px = r * cs.x, py = r * cs.y;
    const float one_minus_u0 = 1.0f - u.x;
    const float h = std::sqrt(one_minus_u0 + u.x * cs.y * cs.y);  // sqrt(1 - px^2)
    float d, e;                                                     // h - py, h + py
    if (py >= 0.0f) {
      e = h + py;
      d = e > 0.0f ? one_minus_u0 / e : 0.0f;
    } else {
      d = h - py;
      e = one_minus_u0 / d;
    }
    const float rho2 = wh.x * wh.x + wh.y * wh.y;
    const float t = (1.0f + wh.z) / 2.0f;
    const float one_minus_t = rho2 / (2.0f * (1.0f + wh.z));
    const float py2 = h - t * d;
    const float pz = std::sqrt(std::fmax(0.0f, t * d * (2.0f * one_minus_t * h + t * e)));
    glm::vec3 nh = px * T1 + py2 * T2 + pz * wh;
    if (cross_branch && py2 < 0.0f)
      nh.z = t * e * (wh.z * h - py2) / (wh.z * pz - std::sqrt(rho2) * py2);
    return safe_normalize(glm::vec3(ax * nh.x, ay * nh.y, std::fmax(1e-6f, nh.z)));
  }
};

}  // namespace basalt::cpu
