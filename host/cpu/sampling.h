// Sample warps, MIS weights and the shading frame of the CPU reference
// (docs/path-spec.md sections 2, 4, 6 and 7).
#pragma once
#include <cmath>
#include <cstdint>
#include <numbers>

#include <glm/glm.hpp>

#include "../../shaders/shared/layout.h"

namespace basalt::cpu {

inline constexpr float PI = std::numbers::pi_v<float>;
inline constexpr float INV_PI = std::numbers::inv_pi_v<float>;

/// sqrt clamped at 0 so that rounding below zero gives 0, not NaN (pbrt-v4 SafeSqrt).
/// Largest i in [0, n - 1] with cdf[i] <= u, by binary search (pbrt-v4 FindInterval as
/// docs/path-spec.md 2 fixes it; cdf has n + 1 entries).
inline std::uint32_t find_interval(const float* cdf, std::uint32_t n, float u) {
  std::uint32_t lo = 0, hi = n;
  while (hi - lo > 1) {
    const std::uint32_t mid = (lo + hi) / 2;
    if (cdf[mid] <= u) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return lo;
}

inline float safe_sqrt(float x) { return std::sqrt(std::fmax(x, 0.0f)); }

/// Largest component of an rgb value.
inline float max_component(glm::vec3 v) { return std::fmax(v.x, std::fmax(v.y, v.z)); }

/// True if some component of an rgb value is positive (pbrt-v4 "bool(SampledSpectrum)").
inline bool any_positive(glm::vec3 v) { return v.x > 0.0f || v.y > 0.0f || v.z > 0.0f; }

/// The spec's normalize, v / sqrt(dot(v, v)) (what lavapipe's GLSL normalize does; not
/// glm::normalize's v * inversesqrt(dot(v, v)), which can differ by an ulp), or the zero
/// vector when dot(v, v) is 0 (never NaN). Every direction of the CPU reference is normalized
/// here.
inline glm::vec3 safe_normalize(glm::vec3 v) {
  const float l2 = glm::dot(v, v);
  if (!(l2 > 0.0f)) return glm::vec3(0.0f);
  return v / std::sqrt(l2);
}

/// Signed radius of concentric_disk(u) (|result| is the distance from the centre), computed
/// without trigonometry so that 1 - r^2 is exact on both renderers (path-spec section 8).
inline float concentric_radius(glm::vec2 u) {
  const glm::vec2 o = 2.0f * u - 1.0f;
  return std::fabs(o.x) > std::fabs(o.y) ? o.x : o.y;
}

/// Shirley & Chiu 1997 concentric square-to-disk map, pbrt-v4 A.5.1 SampleUniformDiskConcentric
/// (docs/path-spec.md section 2 step 4).
inline glm::vec2 concentric_disk(glm::vec2 u) {
  const glm::vec2 o = 2.0f * u - 1.0f;
  if (o.x == 0.0f && o.y == 0.0f) return glm::vec2(0.0f);
  float r, th;
  if (std::fabs(o.x) > std::fabs(o.y)) {
    r = o.x;
    th = (PI / 4.0f) * (o.y / o.x);
  } else {
    r = o.y;
    th = PI / 2.0f - (PI / 4.0f) * (o.x / o.y);
  }
  return r * glm::vec2(std::cos(th), std::sin(th));
}

/// Uniform direction on the unit sphere, pbrt-v4 A.5.2 SampleUniformSphere
/// (docs/path-spec.md section 6, "infinite uniform").
inline glm::vec3 uniform_sphere(glm::vec2 u) {
  const float z = 1.0f - 2.0f * u.x;
  const float r = std::sqrt(std::fmax(0.0f, 1.0f - z * z));
  const float phi = 2.0f * PI * u.y;
  return glm::vec3(r * std::cos(phi), r * std::sin(phi), z);
}

/// Barycentrics (b0, b1, b2) uniform over a triangle, pbrt-v4 A.5.5 SampleUniformTriangle
/// (Heitz 2019 low-distortion map; docs/path-spec.md section 6, "triangle").
inline glm::vec3 uniform_triangle(glm::vec2 u) {
  float b0, b1;
  if (u.x < u.y) {
    b0 = u.x / 2.0f;
    b1 = u.y - b0;
  } else {
    b1 = u.y / 2.0f;
    b0 = u.x - b1;
  }
  return glm::vec3(b0, b1, 1.0f - b0 - b1);
}

/// Veach's power heuristic with beta = 2 (Veach 1997 9.2.4; pbrt-v4 13.4.1 PowerHeuristic):
/// a^2 / (a^2 + b^2); 1 when a^2 overflows (pbrt-v4's IsInf(Sqr(f)) test, which covers the
/// spec's "a infinite"); 0 when both are 0 (0/0 would be NaN).
inline float power_heuristic(float a, float b) {
  const float a2 = a * a;
  if (std::isinf(a2)) return 1.0f;
  const float s = a2 + b * b;
  if (!(s > 0.0f)) return 0.0f;
  return a2 / s;
}

/// The balance heuristic a / (a + b) (Veach 1997 9.2.2); 1 when a is infinite, 0 when both
/// are 0.
inline float balance_heuristic(float a, float b) {
  if (std::isinf(a)) return 1.0f;
  const float s = a + b;
  if (!(s > 0.0f)) return 0.0f;
  return a / s;
}

/// The MIS weight of a light sample of density pl against BSDF density pb under MIS mode
/// \p mode (path-spec 7.1: MIS_* of Globals.render_opts.y).
inline float mis_light(std::uint32_t mode, float pl, float pb) {
  if (mode == gpu::MIS_LIGHT_ONLY) return 1.0f;
  return mode == gpu::MIS_BALANCE ? balance_heuristic(pl, pb) : power_heuristic(pl, pb);
}

/// The MIS weight of a BSDF-sampled hit on a light (BSDF density pb, light density pl) under
/// MIS mode \p mode (path-spec 7.1).
inline float mis_bsdf(std::uint32_t mode, float pb, float pl) {
  if (mode == gpu::MIS_BSDF_ONLY) return 1.0f;
  if (mode == gpu::MIS_LIGHT_ONLY) return 0.0f;
  return mode == gpu::MIS_BALANCE ? balance_heuristic(pb, pl) : power_heuristic(pb, pl);
}

/// pbrt-v4 SmoothStep (docs/path-spec.md section 6, "spot"): Hermite step from a to b,
/// a hard step (x >= b) when a == b.
inline float smooth_step(float x, float a, float b) {
  if (a == b) return x < a ? 0.0f : 1.0f;
  const float t = glm::clamp((x - a) / (b - a), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

/// Orthonormal frame (t1, t2, n) around a unit normal.
struct Frame {
  glm::vec3 t1, t2, n;
  /// Duff et al. 2017, "Building an Orthonormal Basis, Revisited", JCGT 6(1), listing 3
  /// (docs/path-spec.md section 4), including n.z = -1 via copysign.
  static Frame from_z(glm::vec3 n) {
    const float s = std::copysign(1.0f, n.z);
    const float a = -1.0f / (s + n.z);
    const float b = n.x * n.y * a;
    Frame f;
    f.t1 = glm::vec3(1.0f + s * n.x * n.x * a, s * b, -s * n.x);
    f.t2 = glm::vec3(b, s + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
  }
  /// World direction to local coordinates (dot with t1, t2, n).
  glm::vec3 to_local(glm::vec3 w) const {
    return glm::vec3(glm::dot(w, t1), glm::dot(w, t2), glm::dot(w, n));
  }
  /// Local coordinates to a world direction.
  glm::vec3 to_world(glm::vec3 l) const { return l.x * t1 + l.y * t2 + l.z * n; }
};

}  // namespace basalt::cpu
