// Fresnel equations, reflection and refraction in the local shading frame
// (docs/materials-spec.md section 2.2). Precise: these are the ill-conditioned spots (grazing
// angles, total internal reflection) where a fused multiply-add would change results.
#ifndef BASALT_FRESNEL_GLSL
#define BASALT_FRESNEL_GLSL

#include "math.glsl"

// Unpolarized Fresnel reflectance of a dielectric interface, pbrt-v4 FrDielectric (eta =
// etaT / etaI; cos < 0 means from the inside; 1 on total internal reflection).
precise float fr_dielectric(float cos_i, float eta) {
  cos_i = clamp(cos_i, -1.0, 1.0);
  if (cos_i < 0.0) {
    eta = 1.0 / eta;
    cos_i = -cos_i;
  }
  float sin2_i = 1.0 - cos_i * cos_i;
  float sin2_t = sin2_i / (eta * eta);
  if (sin2_t >= 1.0) return 1.0;
  float cos_t = safe_sqrt(1.0 - sin2_t);
  float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return (r_parl * r_parl + r_perp * r_perp) / 2.0;
}

// Complex product (pbrt-v4 pstd::complex operator*): a = re + i im in (x, y).
precise vec2 c_mul(vec2 a, vec2 b) { return vec2(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }

// Complex quotient a / b (pbrt-v4 pstd::complex operator/).
precise vec2 c_div(vec2 a, vec2 b) {
  float scale = 1.0 / (b.x * b.x + b.y * b.y);
  return vec2(scale * (a.x * b.x + a.y * b.y), scale * (a.y * b.x - a.x * b.y));
}

// |z|^2 (pbrt-v4 pstd::norm).
precise float c_norm(vec2 z) { return z.x * z.x + z.y * z.y; }

// Principal complex square root (pbrt-v4 pstd::sqrt).
precise vec2 c_sqrt(vec2 z) {
  float n = sqrt(c_norm(z));
  if (n == 0.0) return vec2(0.0);
  float t1 = sqrt(0.5 * (n + abs(z.x)));
  float t2 = 0.5 * z.y / t1;
  if (z.x >= 0.0) return vec2(t1, t2);
  return vec2(abs(t2), z.y < 0.0 ? -t1 : t1);
}

// Fresnel reflectance of a conductor with complex IOR e = eta + i k, one channel: pbrt-v4
// FrComplex's value (cos c clamped to [0, 1]) in a form without cancellation near e = 1
// (docs/materials-spec.md 2.2): |r_perp|^2 = |1 - e^2|^2 / |c + e cos_t|^4 and |r_parl|^2 =
// |1 - e^2|^2 / |e|^4 * |(e^2 + 1) c^2 - 1|^2 / |e c + cos_t|^4 (each amplitude times its
// conjugate, with e^2 cos_t^2 = e^2 - sin^2 from Snell's law; cos_t^2 = (c^2 - (1 - e^2)) / e^2);
// 0 exactly at e = 1.
precise float fr_complex1(float cos_i, float eta_re, float eta_im) {
  float c = clamp(cos_i, 0.0, 1.0);
  vec2 eta = vec2(eta_re, eta_im);
  vec2 e2 = c_mul(eta, eta);
  // 1 - e^2 with the real part (1 - eta)(1 + eta) + k^2.
  vec2 ome2 = vec2((1.0 - eta_re) * (1.0 + eta_re) + eta_im * eta_im, -2.0 * eta_re * eta_im);
  float n0 = c_norm(ome2);
  if (n0 == 0.0) return 0.0;
  // cos_t^2 = (c^2 - (1 - e^2)) / e^2 (no cancellation at grazing incidence near e = 1).
  vec2 cos_t = c_sqrt(c_div(vec2(c * c - ome2.x, -ome2.y), e2));
  vec2 ect = c_mul(eta, cos_t);
  float n_perp = c_norm(vec2(c + ect.x, ect.y));
  float n_parl = c_norm(eta * c + cos_t);
  if (!(n_perp > 0.0) || !(n_parl > 0.0)) return 1.0;  // the grazing limit
  float nq = c_norm(vec2((e2.x + 1.0) * (c * c) - 1.0, e2.y * (c * c)));
  float perp = n0 / n_perp / n_perp;
  float parl = n0 / c_norm(e2) * (nq / n_parl / n_parl);
  return (parl + perp) / 2.0;
}

// FrComplex per rgb channel (docs/materials-spec.md 2.2), in a loop (one inlined copy).
vec3 fr_complex(float cos_i, vec3 eta, vec3 k) {
  vec3 r = vec3(0.0);
  int c = 0;  // the end tested at the end of a pass (a loop's closing test costs lavapipe a pass)
  [[dont_unroll]] while (true) {
    r[c] = fr_complex1(cos_i, eta[c], k[c]);
    if (++c >= 3) break;
  }
  return r;
}

// Mirror direction of wo about n (pbrt-v4 Reflect): -wo + 2 dot(wo, n) n.
vec3 reflect_about(vec3 wo, vec3 n) {
  precise vec3 r = -wo + 2.0 * dot_exact(wo, n) * n;
  return r;
}

// pbrt-v4 Refract: wi refracted through the interface with normal n and relative IOR eta =
// etaT / etaI (flipped, with n, when wi is on n's back side); etap receives the IOR ratio along
// the ray. False on total internal reflection.
bool refract_v4(vec3 wi, vec3 n, float eta, out float etap, out vec3 wt) {
  precise float cos_i = dot_exact(n, wi);
  if (cos_i < 0.0) {
    eta = 1.0 / eta;
    cos_i = -cos_i;
    n = -n;
  }
  precise float sin2_i = max(0.0, 1.0 - cos_i * cos_i);
  precise float sin2_t = sin2_i / (eta * eta);
  etap = eta;
  wt = vec3(0.0);
  if (sin2_t >= 1.0) return false;
  precise float cos_t = safe_sqrt(1.0 - sin2_t);
  precise vec3 t = -wi / eta + (cos_i / eta - cos_t) * n;
  wt = t;
  return true;
}

// pbrt-v3 Refract: wi refracted through n (on wi's side) with eta = etaI / etaT; false on total
// internal reflection.
bool refract_v3(vec3 wi, vec3 n, float eta, out vec3 wt) {
  precise float cos_i = dot_exact(n, wi);
  precise float sin2_i = max(0.0, 1.0 - cos_i * cos_i);
  precise float sin2_t = eta * eta * sin2_i;
  wt = vec3(0.0);
  if (sin2_t >= 1.0) return false;
  precise float cos_t = sqrt(1.0 - sin2_t);
  precise vec3 t = eta * -wi + (eta * cos_i - cos_t) * n;
  wt = t;
  return true;
}

#endif
