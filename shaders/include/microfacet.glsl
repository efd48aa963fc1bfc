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
    float x = log_accurate(max(r, 1e-3));
    return 1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x * x * x +
           0.000640711 * x * x * x * x;
  }
  return r;
}

// (cos 2 pi u, sin 2 pi u) for u in [0, 1], u reduced exactly to [-1/4, 1/4] first so that
// both keep their relative accuracy near their zeros (materials-spec 2.1 numerics).
precise vec2 cos_sin_2pi(float u) {
  float w = u, sgn = 1.0;
  if (u > 0.75) {
    w = u - 1.0;
  } else if (u > 0.25) {
    w = u - 0.5;
    sgn = -1.0;
  }
  precise float a = 2.0 * PI * w;
  return sgn * cos_sin_accurate(a);
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
// The angle terms come from the components of w (docs/materials-spec.md 2.1 numerics: never
// 1 - cos^2, which loses the relative accuracy of narrow lobes).
precise float mf_term(MfDist d, vec3 w, bool want_d) {
  float z2 = w.z * w.z;
  if (want_d) {
    float ex = w.x / d.ax, ey = w.y / d.ay;
    float e2 = ex * ex + ey * ey;
    if (d.beckmann) {
      if (z2 == 0.0) return 0.0;
      float arg = e2 / z2;
      if (arg > 87.0) return 0.0;  // exp(-arg) would be near or below FLT_MIN
      return exp_accurate(-arg) / (PI * d.ax * d.ay * z2 * z2);
    }
    if (z2 * z2 < 1e-16) return 0.0;
    float q = z2 + e2;
    return 1.0 / (PI * d.ax * d.ay * q * q);
  }
  if (w.z == 0.0) return 0.0;
  float axx = d.ax * w.x, ayy = d.ay * w.y;
  float a2 = axx * axx + ayy * ayy;
  if (d.beckmann) {
    float a = abs(w.z) / sqrt(a2);
    if (a >= 1.6) return 0.0;
    return (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a);
  }
  float s = a2 / z2;
  return s / (2.0 * (1.0 + sqrt(1.0 + s)));
}

// (D(wm), G(wo, wi), PDF(wo, wp)): the density of wm, masking-shadowing 1 / (1 + Lambda(wo) +
// Lambda(wi)) and the density with which Sample_wm(wo) yields wp: visible normals
// G1(wo) / |cos wo| D(wp) |wo.wp| (pbrt-v4 TrowbridgeReitzDistribution::PDF), or D(wp) |cos wp|
// (pbrt-v3 Beckmann, sampleVisibleArea = false). One loop over the directions, so that the
// angle terms are inlined once per call site.
vec3 mf_dgp(MfDist d, vec3 wo, vec3 wi, vec3 wm, vec3 wp) {
  float t0 = 0.0, t1 = 0.0, t2 = 0.0, t3 = 0.0;
  bool two = wp != wm;
  int k = 0;  // the end tested at the end of a pass (a loop's closing test costs lavapipe a pass)
  [[dont_unroll]] while (true) {
    vec3 w = k == 0 ? wm : (k == 1 ? wo : (k == 2 ? wi : wp));
    float v = mf_term(d, w, k == 0 || k == 3);
    if (k == 0) t0 = v;
    else if (k == 1) t1 = v;
    else if (k == 2) t2 = v;
    else t3 = v;
    if (++k >= (two ? 4 : 3)) break;
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
    precise float log_sample = log1p_accurate(-u.x);
    precise float tan2;
    precise vec2 cs;  // (cos phi, sin phi)
    if (d.ax == d.ay) {
      tan2 = -d.ax * d.ax * log_sample;
      float phi = u.y * 2.0 * PI;
      cs = cos_sin_accurate(phi);
    } else {
      // pbrt-v3's phi = atan(ay/ax tan(2 pi u1 + pi/2)) (+ pi past u1 = 1/2) as a direction
      precise vec2 t = cos_sin_2pi(u.y);
      precise vec2 v = vec2(d.ax * t.y, -d.ay * t.x);
      cs = v / sqrt(v.x * v.x + v.y * v.y);
      tan2 = -log_sample / (cs.x * cs.x / (d.ax * d.ax) + cs.y * cs.y / (d.ay * d.ay));
    }
    precise float cos_t = 1.0 / sqrt(1.0 + tan2);
    precise float sin_t = sqrt(tan2) * cos_t;
    return vec3(sin_t * cs.x, sin_t * cs.y, cos_t);
  }
  vec3 wh = safe_normalize(vec3(d.ax * w.x, d.ay * w.y, w.z));
  if (wh.z < 0.0) wh = -wh;
  bool cross_branch = wh.z < 0.99999;
  vec3 t1 = cross_branch ? safe_normalize(vec3(-wh.y, wh.x, 0.0)) : vec3(1.0, 0.0, 0.0);
  precise vec3 t2 = vec3(wh.y * t1.z - wh.z * t1.y, wh.z * t1.x - wh.x * t1.z,
                         wh.x * t1.y - wh.y * t1.x);
  // pbrt-v4 SampleUniformDiskPolar, Lerp((1 + wh.z) / 2, h, p.y) and the reprojection, in the
  // rim-stable arrangement of materials-spec 2.1 numerics (h - py and h + py never cancel)
  precise float r = sqrt(u.x);
  precise vec2 cs = cos_sin_2pi(u.y);
  precise float px = r * cs.x;
  precise float py = r * cs.y;
  precise float rest = 1.0 - u.x;
  precise float h = sqrt(rest + u.x * cs.y * cs.y);
  precise float dm, ep;  // h - py, h + py
  if (py >= 0.0) {
    ep = h + py;
    dm = ep > 0.0 ? rest / ep : 0.0;
  } else {
    dm = h - py;
    ep = rest / dm;
  }
  precise float rho2 = wh.x * wh.x + wh.y * wh.y;
  precise float t = (1.0 + wh.z) / 2.0;
  precise float one_minus_t = rho2 / (2.0 * (1.0 + wh.z));
  precise float py2 = h - t * dm;
  precise float pz = sqrt(max(0.0, t * dm * (2.0 * one_minus_t * h + t * ep)));
  precise vec3 nh = px * t1 + py2 * t2 + pz * wh;
  if (cross_branch && py2 < 0.0)
    nh.z = t * ep * (wh.z * h - py2) / (wh.z * pz - sqrt(rho2) * py2);
  return safe_normalize(vec3(d.ax * nh.x, d.ay * nh.y, max(1e-6, nh.z)));
}

#endif
