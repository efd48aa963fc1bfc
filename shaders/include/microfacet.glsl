// Microfacet distributions in the local shading frame (z = shading normal): Trowbridge-Reitz
// (pbrt-v4 9.6) and Beckmann (pbrt-v3 8.4.2), the roughness remaps and the spherical-angle
// helpers (docs/materials-spec.md sections 1.4 and 2.1). Arithmetic is precise (no fma
// contraction) so that it rounds as the CPU reference does.
#ifndef BASALT_MICROFACET_GLSL
#define BASALT_MICROFACET_GLSL

#include "math.glsl"
#include "trig.glsl"

// True for +infinity (tan2 of a direction in the tangent plane); no isinf(), whose lowering may
// assume finite math.
bool is_pos_inf(float x) { return x > FLT_MAX; }

// sin^2 theta, clamped at 0 (pbrt-v4 Sin2Theta).
precise float sin2_theta(vec3 w) { return max(0.0, 1.0 - w.z * w.z); }

// cos phi, 1 at the pole (pbrt-v4 CosPhi).
precise float cos_phi(vec3 w) {
  float st = sqrt(sin2_theta(w));
  return st == 0.0 ? 1.0 : clamp(w.x / st, -1.0, 1.0);
}

// sin phi, 0 at the pole (pbrt-v4 SinPhi).
precise float sin_phi(vec3 w) {
  float st = sqrt(sin2_theta(w));
  return st == 0.0 ? 0.0 : clamp(w.y / st, -1.0, 1.0);
}

// Alpha from a roughness parameter by the remap of Material.flags (docs/materials-spec.md
// section 1.4): none; pbrt-v4 TrowbridgeReitzDistribution::RoughnessToAlpha (sqrt); pbrt-v3
// RoughnessToAlpha (polynomial in ln r, evaluated left to right as written).
precise float roughness_to_alpha(float r, uint flags) {
  uint remap = flags & MATFLAG_REMAP_MASK;
  if (remap == MATFLAG_REMAP_SQRT) return sqrt(r);
  if (remap == MATFLAG_REMAP_V3) {
    float x = log(max(r, 1e-3));
    return 1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x * x * x +
           0.000640711 * x * x * x * x;
  }
  return r;
}

// A microfacet distribution: alphas and which of the two (docs/materials-spec.md 2.1).
struct MfDist {
  float ax;
  float ay;
  bool beckmann;
};

// pbrt-v4 EffectivelySmooth as materials-spec 1.4 fixes it: max(alpha_x, alpha_y) < 1e-3.
bool mf_smooth(MfDist d) { return max(d.ax, d.ay) < 1e-3; }

// Alphas as pbrt-v4's TrowbridgeReitzDistribution constructor keeps them: when not effectively
// smooth, each at least 1e-4 (one rough direction and one zero alpha would make D blow up).
vec2 mf_alphas(float ax, float ay) {
  vec2 a = vec2(ax, ay);
  return max(ax, ay) < 1e-3 ? a : max(a, vec2(1e-4));
}

// D(w) (want_d: the microfacet density, pbrt-v4 TrowbridgeReitzDistribution::D or pbrt-v3
// BeckmannDistribution::D) or Smith's Lambda(w) (pbrt-v4 TrowbridgeReitzDistribution::Lambda or
// pbrt-v3 BeckmannDistribution::Lambda, the rational approximation); 0 in the tangent plane.
// The angle terms (pbrt-v4 Cos2Theta, Tan2Theta, CosPhi, SinPhi) are computed once here.
precise float mf_term(MfDist d, vec3 w, bool want_d) {
  float cos2 = w.z * w.z;
  float sin2 = max(0.0, 1.0 - cos2);
  float tan2 = sin2 / cos2;
  float st = sqrt(sin2);
  float cp = st == 0.0 ? 1.0 : clamp(w.x / st, -1.0, 1.0);
  float sp = st == 0.0 ? 0.0 : clamp(w.y / st, -1.0, 1.0);
  if (want_d) {
    if (is_pos_inf(tan2)) return 0.0;
    float cos4 = cos2 * cos2;
    if (d.beckmann)
      return exp(-tan2 * (cp * cp / (d.ax * d.ax) + sp * sp / (d.ay * d.ay))) /
             (PI * d.ax * d.ay * cos4);
    if (cos4 < 1e-16) return 0.0;
    float cx = cp / d.ax, sy = sp / d.ay;
    float e = tan2 * (cx * cx + sy * sy);
    return 1.0 / (PI * d.ax * d.ay * cos4 * ((1.0 + e) * (1.0 + e)));
  }
  if (d.beckmann) {
    float abs_tan = abs(st / w.z);
    if (is_pos_inf(abs_tan)) return 0.0;
    float alpha = sqrt(cp * cp * d.ax * d.ax + sp * sp * d.ay * d.ay);
    float a = 1.0 / (alpha * abs_tan);
    if (a >= 1.6) return 0.0;
    return (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a);
  }
  if (is_pos_inf(tan2)) return 0.0;
  float cx = cp * d.ax, sy = sp * d.ay;
  float alpha2 = cx * cx + sy * sy;
  return (sqrt(1.0 + alpha2 * tan2) - 1.0) / 2.0;
}

// (D(wm), G(wo, wi), PDF(wo, wp)): the density of wm, masking-shadowing 1 / (1 + Lambda(wo) +
// Lambda(wi)) and the density with which Sample_wm(wo) yields wp: visible normals
// G1(wo) / |cos wo| D(wp) |wo.wp| (pbrt-v4 TrowbridgeReitzDistribution::PDF), or D(wp) |cos wp|
// (pbrt-v3 Beckmann, sampleVisibleArea = false). One loop over the directions, so that the
// angle terms are inlined once per call site.
vec3 mf_dgp(MfDist d, vec3 wo, vec3 wi, vec3 wm, vec3 wp) {
  float t0 = 0.0, t1 = 0.0, t2 = 0.0, t3 = 0.0;
  bool two = wp != wm;
  [[dont_unroll]] for (int k = 0; k < (two ? 4 : 3); ++k) {
    vec3 w = k == 0 ? wm : (k == 1 ? wo : (k == 2 ? wi : wp));
    float v = mf_term(d, w, k == 0 || k == 3);
    if (k == 0) t0 = v;
    else if (k == 1) t1 = v;
    else if (k == 2) t2 = v;
    else t3 = v;
  }
  float dp = two ? t3 : t0;
  precise float g = 1.0 / (1.0 + t1 + t2);
  precise float pdf = d.beckmann ? dp * abs(wp.z)
                                 : 1.0 / (1.0 + t1) / abs(wo.z) * dp * abs(dot_exact(wo, wp));
  return vec3(t0, g, pdf);
}

// Samples a microfacet normal wm (always in the +z hemisphere) given w with u (docs/materials-
// spec.md 2.1). Trowbridge-Reitz: pbrt-v4 Sample_wm (Heitz 2018 visible normals, polar disk
// sample). Beckmann: pbrt-v3 BeckmannDistribution::Sample_wh with sampleVisibleArea = false;
// the flip to w's side is left to the callers that need it (reflection is invariant under it,
// and the pbrt-v4 lobes expect wm in +z).
vec3 mf_sample_wm(MfDist d, vec3 w, vec2 u) {
  if (d.beckmann) {
    precise float log_sample = log(1.0 - u.x);
    precise float tan2, phi;
    if (d.ax == d.ay) {
      tan2 = -d.ax * d.ax * log_sample;
      phi = u.y * 2.0 * PI;
    } else {
      phi = atan_accurate(d.ay / d.ax * (sin_accurate(2.0 * PI * u.y + 0.5 * PI) / cos_accurate(2.0 * PI * u.y + 0.5 * PI)));
      if (u.y > 0.5) phi += PI;
      float s = sin_accurate(phi), c = cos_accurate(phi);
      tan2 = -log_sample / (c * c / (d.ax * d.ax) + s * s / (d.ay * d.ay));
    }
    precise float cos_t = 1.0 / sqrt(1.0 + tan2);
    precise float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    precise vec3 wh = vec3(sin_t * cos_accurate(phi), sin_t * sin_accurate(phi), cos_t);
    return wh;
  }
  vec3 wh = safe_normalize(vec3(d.ax * w.x, d.ay * w.y, w.z));
  if (wh.z < 0.0) wh = -wh;
  vec3 t1 = wh.z < 0.99999 ? safe_normalize(vec3(-wh.y, wh.x, 0.0)) : vec3(1.0, 0.0, 0.0);
  precise vec3 t2 = vec3(wh.y * t1.z - wh.z * t1.y, wh.z * t1.x - wh.x * t1.z,
                         wh.x * t1.y - wh.y * t1.x);
  // pbrt-v4 SampleUniformDiskPolar
  precise float r = sqrt(u.x);
  precise float theta = 2.0 * PI * u.y;
  precise float px = r * cos_accurate(theta);
  precise float py = r * sin_accurate(theta);
  precise float h = sqrt(1.0 - px * px);
  precise float t = (1.0 + wh.z) / 2.0;
  py = (1.0 - t) * h + t * py;  // pbrt-v4 Lerp(t, h, py)
  precise float pz = sqrt(max(0.0, 1.0 - (px * px + py * py)));
  precise vec3 nh = px * t1 + py * t2 + pz * wh;
  return safe_normalize(vec3(d.ax * nh.x, d.ay * nh.y, max(1e-6, nh.z)));
}

#endif
