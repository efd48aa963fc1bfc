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

// Fresnel reflectance of a conductor with complex IOR eta + i k, one channel: pbrt-v4
// FrComplex (cos clamped to [0, 1]).
precise float fr_complex1(float cos_i, float eta_re, float eta_im) {
  cos_i = clamp(cos_i, 0.0, 1.0);
  vec2 eta = vec2(eta_re, eta_im);
  float sin2_i = 1.0 - cos_i * cos_i;
  vec2 sin2_t = c_div(vec2(sin2_i, 0.0), c_mul(eta, eta));
  vec2 cos_t = c_sqrt(vec2(1.0 - sin2_t.x, -sin2_t.y));
  vec2 ec = eta * cos_i;
  vec2 r_parl = c_div(ec - cos_t, ec + cos_t);
  vec2 ect = c_mul(eta, cos_t);
  vec2 r_perp = c_div(vec2(cos_i - ect.x, -ect.y), vec2(cos_i + ect.x, ect.y));
  return (c_norm(r_parl) + c_norm(r_perp)) / 2.0;
}

// FrComplex per rgb channel (docs/materials-spec.md 2.2), in a loop (one inlined copy).
vec3 fr_complex(float cos_i, vec3 eta, vec3 k) {
  vec3 r = vec3(0.0);
  [[dont_unroll]] for (int c = 0; c < 3; ++c) r[c] = fr_complex1(cos_i, eta[c], k[c]);
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
