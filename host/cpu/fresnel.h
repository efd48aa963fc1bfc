// Fresnel reflectance of the CPU reference (docs/materials-spec.md section 2.2): dielectric,
// conductor (complex IOR per rgb channel) and Schlick's approximation.
#pragma once
#include <algorithm>
#include <cmath>

#include <glm/glm.hpp>

#include "cpu/sampling.h"

namespace basalt::cpu {

/// \brief Unpolarised Fresnel reflectance of a dielectric interface for the cosine cos_i of the
///        incident direction and relative IOR eta (pbrt-v4 util/scattering.h FrDielectric: cos
///        clamped to [-1, 1]; cos < 0 means from inside: eta -> 1/eta, cos -> -cos; 1 on total
///        internal reflection).
inline float fr_dielectric(float cos_i, float eta) {
  cos_i = glm::clamp(cos_i, -1.0f, 1.0f);
  if (cos_i < 0.0f) {
    eta = 1.0f / eta;
    cos_i = -cos_i;
  }
  const float sin2_i = 1.0f - cos_i * cos_i;
  const float sin2_t = sin2_i / (eta * eta);
  if (sin2_t >= 1.0f) return 1.0f;
  const float cos_t = safe_sqrt(1.0f - sin2_t);
  const float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return (r_parl * r_parl + r_perp * r_perp) / 2.0f;
}

/// Complex float with pbrt-v4 pstd::complex's arithmetic (same operation order).
struct Complexf {
  float re = 0.0f, im = 0.0f;
};
inline Complexf operator+(Complexf a, Complexf b) { return {a.re + b.re, a.im + b.im}; }
inline Complexf operator-(Complexf a, Complexf b) { return {a.re - b.re, a.im - b.im}; }
inline Complexf operator*(Complexf a, Complexf b) {
  return {a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re};
}
inline Complexf operator*(Complexf a, float s) { return {a.re * s, a.im * s}; }
inline Complexf operator/(Complexf a, Complexf b) {
  const float scale = 1.0f / (b.re * b.re + b.im * b.im);
  return {scale * (a.re * b.re + a.im * b.im), scale * (a.im * b.re - a.re * b.im)};
}
/// |z|^2 (pstd::norm).
inline float complex_norm(Complexf z) { return z.re * z.re + z.im * z.im; }
/// Principal square root (pbrt-v4 pstd::sqrt of a complex).
inline Complexf complex_sqrt(Complexf z) {
  const float n = std::sqrt(complex_norm(z));
  const float t1 = std::sqrt(0.5f * (n + std::fabs(z.re)));
  const float t2 = 0.5f * z.im / t1;
  if (n == 0.0f) return {0.0f, 0.0f};
  if (z.re >= 0.0f) return {t1, t2};
  return {std::fabs(t2), std::copysign(t1, z.im)};
}

/// \brief Fresnel reflectance of a conductor of complex IOR e = eta + i k for one channel: the
///        value of pbrt-v4 util/scattering.h FrComplex (cos c clamped to [0, 1]), with each
///        amplitude's numerator multiplied by its conjugate so that nothing cancels near e = 1:
///        r_perp = (1 - e^2) / (c + e cos_t)^2, r_parl = (e^2 - 1) ((e^2 + 1) c^2 - 1) /
///        (e^2 (e c + cos_t)^2) (Snell: e^2 cos_t^2 = e^2 - sin^2; materials-spec 2.2), their
///        squared moduli taken as quotients of norms, cos_t^2 as (c^2 - (1 - e^2)) / e^2. An index-matched conductor (e = 1)
///        reflects exactly 0, where pbrt-v4's form leaves rounding noise of ~1e-14.
inline float fr_complex(float cos_i, float eta, float k) {
  const float c = glm::clamp(cos_i, 0.0f, 1.0f);
  const Complexf e{eta, k};
  const Complexf e2 = e * e;
  // 1 - e^2 with the real part (1 - eta)(1 + eta) + k^2 (exactly 0 at e = 1).
  const Complexf one_minus_e2{(1.0f - eta) * (1.0f + eta) + k * k, -2.0f * eta * k};
  const float n0 = complex_norm(one_minus_e2);
  if (n0 == 0.0f) return 0.0f;
  // cos_t^2 = 1 - (1 - c^2) / e^2 = (c^2 - (1 - e^2)) / e^2, without the cancellation of the
  // first form at grazing incidence near e = 1.
  const Complexf cos_t = complex_sqrt(Complexf{c * c - one_minus_e2.re, -one_minus_e2.im} / e2);
  const float n_perp = complex_norm(Complexf{c, 0.0f} + e * cos_t);
  const float n_parl = complex_norm(e * c + cos_t);
  if (!(n_perp > 0.0f) || !(n_parl > 0.0f)) return 1.0f;  // the grazing limit
  const float nq = complex_norm(Complexf{(e2.re + 1.0f) * (c * c) - 1.0f, e2.im * (c * c)});
  const float perp = n0 / n_perp / n_perp;
  const float parl = n0 / complex_norm(e2) * (nq / n_parl / n_parl);
  return (parl + perp) / 2.0f;
}

/// \brief FrComplex per rgb channel (pbrt-v4 FrComplex of a SampledSpectrum).
inline glm::vec3 fr_complex(float cos_i, glm::vec3 eta, glm::vec3 k) {
  return glm::vec3(fr_complex(cos_i, eta.x, k.x), fr_complex(cos_i, eta.y, k.y),
                   fr_complex(cos_i, eta.z, k.z));
}

/// \brief Schlick's approximation R + (1 - cos)^5 (1 - R) per channel (pbrt-v3
///        FresnelBlend::SchlickFresnel; Schlick 1994).
inline glm::vec3 fr_schlick(glm::vec3 R, float cos_theta) {
  const float m = 1.0f - cos_theta;
  const float m5 = (m * m) * (m * m) * m;
  return R + m5 * (glm::vec3(1.0f) - R);
}

}  // namespace basalt::cpu
