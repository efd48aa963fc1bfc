// Light selection, light sampling and light pdfs for MIS (docs/path-spec.md section 6).
// Needs bindings.glsl.
#ifndef BASALT_LIGHTS_GLSL
#define BASALT_LIGHTS_GLSL

#include "math.glsl"
#include "sampling.glsl"
#include "surface.glsl"
#include "envmap.glsl"

const uint FEATURE_ANY_LIGHT = FEATURE_LIGHT_POINT | FEATURE_LIGHT_SPOT | FEATURE_LIGHT_DISTANT |
                               FEATURE_LIGHT_INFINITE | FEATURE_LIGHT_AREA |
                               FEATURE_LIGHT_INFINITE_IMAGE;

// Below this sin^2 of the cone half-angle (1.5 degrees) the sphere cone sampling switches to
// a Taylor expansion (pbrt-v4 6.2.4 Sphere::Sample).
const float SPHERE_SMALL_SIN2 = 0.00068523;

// A light sample at a shading point: incident direction wi (unit, towards the light),
// radiance Li arriving along it, solid-angle pdf (1 for delta lights), and what the shadow
// ray aims at: the point q (normal nl and magnitude bound m of the light primitive for area
// lights) or, when at_infinity, direction wi.
struct LightSample {
  vec3 Li;
  float pdf;
  vec3 wi;
  bool delta;
  vec3 q;
  bool at_infinity;
  vec3 nl;
  bool area;
  float m;
};

// Index of the light picked by u: the largest i < n with light_cdf[i] <= u (binary search of
// docs/path-spec.md sections 2 and 6 over the n + 1 cdf entries).
uint light_select(float u, uint n) {
  uint lo = 0u, hi = n;
  // The end tested at the end of a pass (a loop's closing test costs lavapipe a pass).
  if (hi - lo > 1u) while (true) {
    uint mid = (lo + hi) / 2u;
    if (light_cdf[mid] <= u) lo = mid; else hi = mid;
    if (hi - lo <= 1u) break;
  }
  return lo;
}

// Whether light li has infinite extent (distant, infinite): picked by its cdf share alone.
bool light_infinite_extent(uint li) {
  uint type = light_at(li).type;
  return type == LIGHT_DISTANT || type == LIGHT_INFINITE_UNIFORM || type == LIGHT_INFINITE_IMAGE;
}

// Whether the bounded lights are picked by importance (docs/path-spec.md 6.1).
bool light_importance_on() {
  return has_feature2(FEATURE2_LIGHT_IMPORTANCE) &&
         globals.light_opts.x == LIGHT_SELECT_IMPORTANCE;
}

// cos(theta_a - theta_b), 1 when theta_a < theta_b (pbrt-v4 LightBounds::Importance).
float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  return cos_a > cos_b ? 1.0 : cos_a * cos_b + sin_a * sin_b;
}

// sin(theta_a - theta_b), 0 when theta_a < theta_b (pbrt-v4 LightBounds::Importance).
float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  return cos_a > cos_b ? 0.0 : sin_a * cos_b - cos_a * sin_b;
}

// Importance of light li at point p with shading normal n, from its bounds (path-spec 6.1;
// pbrt-v4 LightBounds::Importance): 0 for lights without bounds.
float light_importance(uint li, vec3 p, vec3 n) {
  Light l = light_at(li);
  float phi = l.bound_c.w;
  if (!(phi > 0.0)) return 0.0;
  float r = l.bound_e.x;
  vec3 v = p - l.bound_c.xyz;
  float dist2 = dot(v, v);
  float d2 = max(dist2, r);
  vec3 wi = dist2 > 0.0 ? v * inversesqrt(dist2) : l.bound_w.xyz;
  float cos_w = dot(l.bound_w.xyz, wi);
  if ((l.flags & LIGHT_FLAG_TWOSIDED) != 0u) cos_w = abs(cos_w);
  float sin_w = safe_sqrt(1.0 - cos_w * cos_w);
  // The cone of directions from p to the bounds' sphere (the whole sphere from inside).
  float cos_b = (dist2 < r * r || dist2 == 0.0) ? -1.0 : safe_sqrt(1.0 - r * r / dist2);
  float sin_b = safe_sqrt(1.0 - cos_b * cos_b);
  float cos_o = l.bound_w.w;
  float sin_o = safe_sqrt(1.0 - cos_o * cos_o);
  float cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, cos_o);
  float sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, cos_o);
  float cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
  if (cos_p <= l.bound_e.y) return 0.0;
  float cos_i = abs(dot(wi, n));
  float sin_i = safe_sqrt(1.0 - cos_i * cos_i);
  float imp = (d2 > 0.0 ? phi * cos_p / d2 : LIGHT_IMPORTANCE_CAP) *
              cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
  return imp > 0.0 ? min(imp, LIGHT_IMPORTANCE_CAP) : 0.0;
}

// A picked light and the probability of picking it.
struct LightPick {
  uint li;
  float pmf;
};

// Picks one of the n lights with u for shading point p, shading normal n (path-spec 6, 6.1):
// by the light cdf, and when importance is on a bounded light's cdf share is spent again over
// all bounded lights by their importance at p. pmf = 0: no light.
LightPick light_pick(float u, uint n, vec3 p, vec3 ns) {
  uint li = light_select(u, n);
  float pmf = light_at(li).pmf;
  if (!light_importance_on() || light_infinite_extent(li) || !(pmf > 0.0))
    return LightPick(li, pmf);
  // u within the picked light's share of the cdf, uniform in [0, 1).
  float up = clamp((u - light_cdf[li]) / pmf, 0.0, ONE_MINUS_EPSILON);
  // Two passes over the lights, the sum and then the pick, in one loop so that
  // light_importance has one call site here (lavapipe inlines each).
  float sum = 0.0, target = 0.0, acc = 0.0, picked = 0.0;
  uint i = 0u;  // the end tested at the end of a pass (see light_select)
  if (n > 0u) [[dont_unroll]] while (true) {
    uint k = i < n ? i : i - n;
    if (i == n) {
      if (!(sum > 0.0)) return LightPick(li, 0.0);
      target = up * sum;
    }
    float w = light_importance(k, p, ns);
    if (i < n) {
      sum += w;
    } else if (w > 0.0) {
      li = k;
      picked = w;
      acc += w;
      if (target < acc) break;
    }
    if (++i >= 2u * n) break;
  }
  if (n == 0u && !(sum > 0.0)) return LightPick(li, 0.0);
  return LightPick(li, uintBitsToFloat(globals.light_opts.y) * (picked / sum));
}

// The probability that light_pick at (p, ns) picks light li of the n lights (the MIS weight
// of an emitting hit, path-spec 7).
float light_pick_pmf(uint li, uint n, vec3 p, vec3 ns) {
  float pmf = light_at(li).pmf;
  if (!light_importance_on() || light_infinite_extent(li)) return pmf;
  float sum = 0.0, own = 0.0;
  uint k = 0u;  // the end tested at the end of a pass (see light_select)
  if (n > 0u) [[dont_unroll]] while (true) {
    float w = light_importance(k, p, ns);
    sum += w;
    if (k == li) own = w;
    if (++k >= n) break;
  }
  return sum > 0.0 ? uintBitsToFloat(globals.light_opts.y) * (own / sum) : 0.0;
}

// Emitted radiance of area light li leaving its surface with normal n towards w (pbrt-v4
// DiffuseAreaLight::L): L on the front side or when two-sided, else 0.
vec3 area_le(uint li, vec3 n, vec3 w) {
  if ((light_at(li).flags & LIGHT_FLAG_TWOSIDED) != 0u || dot(n, w) > 0.0) return light_at(li).L.rgb;
  return vec3(0.0);
}

// 1 - cos(theta_max) of the cone subtended by a sphere of squared radius r2 seen from squared
// distance d2 > r2 (pbrt-v4 6.2.4 Sphere::Sample and PDF; docs/path-spec.md section 6).
float sphere_one_minus_cos_max(float r2, float d2, out float sin2_max) {
  sin2_max = r2 / d2;
  float one_minus = 1.0 - safe_sqrt(1.0 - sin2_max);
  return sin2_max < SPHERE_SMALL_SIN2 ? sin2_max / 2.0 : one_minus;
}

// Whether sphere-light sampling from shading point p (geometric normal ng, magnitude bound
// m; ng = 0 for a point in space) takes the inside (area-sampling) branch
// (docs/path-spec.md section 6): as pbrt-v4 Sphere::Sample/PDF test
// ctx.OffsetRayOrigin(pCenter), the test is made on offset_ray(p) towards the centre, so a
// shading point on the light sphere itself counts as inside rather than by rounding. With
// ng = 0 this is |p - c|^2 <= r^2.
bool sphere_ref_inside(vec3 p, vec3 ng, float m, vec3 c, float r2) {
  vec3 po = offset_ray(p, dot(c - p, ng) > 0.0 ? ng : -ng, m);
  vec3 pc = po - c;
  return dot(pc, pc) <= r2;
}

// Solid-angle pdf of area-sampling point q (normal nl) of a surface of the given area from p,
// with unit direction wi from p to q: |q - p|^2 / (|cos| area), 0 if the cosine is 0 or
// the pdf overflows.
float area_to_solid_angle(vec3 p, vec3 q, vec3 nl, vec3 wi, float area) {
  vec3 pq = q - p;
  float denom = abs(dot(nl, -wi)) * area;
  float pdf = denom > 0.0 ? dot(pq, pq) / denom : 0.0;
  return pdf <= FLT_MAX ? pdf : 0.0;  // an overflow to infinity counts as no sample
}

// Samples light li from shading point p (geometric normal ng, or 0 for a point in space;
// magnitude bound m) with u = (u0, u1) (docs/path-spec.md section 6; ng and m only decide a
// sphere light's inside test). pdf = 0 means no sample.
LightSample light_sample(uint li, vec3 p, vec3 ng, float m, vec2 u) {
  LightSample ls;
  ls.Li = vec3(0.0);
  ls.pdf = 0.0;
  ls.wi = vec3(0.0, 0.0, 1.0);
  ls.delta = false;
  ls.q = p;
  ls.at_infinity = false;
  ls.nl = vec3(0.0, 0.0, 1.0);
  ls.area = false;
  ls.m = 0.0;
  uint type = light_at(li).type;
  vec3 L = light_at(li).L.rgb;
  switch (type) {
    case LIGHT_POINT:
    case LIGHT_SPOT:
      if ((has_feature(FEATURE_LIGHT_POINT) && type == LIGHT_POINT) ||
          (has_feature(FEATURE_LIGHT_SPOT) && type == LIGHT_SPOT)) {
        vec3 pos = light_at(li).pos.xyz;
        vec3 dp = pos - p;
        float d2 = dot(dp, dp);
        if (d2 > 0.0) {
          ls.wi = dp / sqrt(d2);
          ls.Li = L / d2;
          if (type == LIGHT_SPOT) {
            vec4 prm = light_at(li).params;  // cos(falloff start), cos(falloff end)
            ls.Li *= smooth_step(dot(-ls.wi, light_at(li).dir.xyz), prm.y, prm.x);
          }
          ls.pdf = 1.0;
          ls.delta = true;
          ls.q = pos;
        }
      }
      break;
    case LIGHT_DISTANT:
      if (has_feature(FEATURE_LIGHT_DISTANT)) {
        ls.wi = light_at(li).dir.xyz;
        ls.Li = L;
        ls.pdf = 1.0;
        ls.delta = true;
        ls.at_infinity = true;
      }
      break;
    case LIGHT_INFINITE_UNIFORM:
      if (has_feature(FEATURE_LIGHT_INFINITE)) {
        ls.wi = uniform_sphere(u);
        ls.Li = L;
        ls.pdf = 1.0 / (4.0 * PI);
        ls.at_infinity = true;
      }
      break;
    case LIGHT_INFINITE_IMAGE:
      // Environment map: the MIS-compensated distribution, as pbrt-v4's path tracer asks
      // (allowIncompletePDF = true; docs/textures-spec.md section 6). The only env_sample
      // call of the render shader.
      if (has_feature(FEATURE_LIGHT_INFINITE_IMAGE)) {
        ls.at_infinity = env_sample(li, u, true, p, ls.wi, ls.pdf, ls.Li);
      }
      break;
    case LIGHT_AREA_TRIANGLE:
      if (has_feature(FEATURE_LIGHT_AREA) && has_feature(FEATURE_TRIANGLES)) {
        vec3 ns_unused;
        triangle_geometry(light_at(li).prim, uniform_triangle(u), ls.q, ls.nl, ns_unused, ls.m);
        vec3 dq = ls.q - p;
        if (dot(dq, dq) > 0.0) {
          ls.wi = safe_normalize(dq);
          ls.pdf = area_to_solid_angle(p, ls.q, ls.nl, ls.wi, light_at(li).params.x);
          ls.Li = area_le(li, ls.nl, -ls.wi);
          ls.area = true;
        }
      }
      break;
    case LIGHT_AREA_SPHERE:
      if (has_feature(FEATURE_LIGHT_AREA) && has_feature(FEATURE_SPHERES)) {
        uint sph = light_at(li).prim;
        vec4 cr = sphere_at(sph).center_radius;
        vec3 c = cr.xyz;
        float r = cr.w;
        vec3 pc = p - c;
        float d2 = dot(pc, pc);
        float r2 = r * r;
        if (!(r > 0.0)) break;
        vec3 nq;
        bool inside = sphere_ref_inside(p, ng, m, c, r2);
        if (inside) {
          // Inside: uniform area sampling (pbrt-v4 Sphere::Sample(u)).
          nq = uniform_sphere(u);
        } else {
          // Outside: uniform cone sampling (pbrt-v4 6.2.4 Sphere::Sample(ctx, u)).
          float sin2_max;
          float one_minus = sphere_one_minus_cos_max(r2, d2, sin2_max);
          float cos_max = safe_sqrt(1.0 - sin2_max);
          float cos_t = (cos_max - 1.0) * u.x + 1.0;
          float sin2_t = 1.0 - cos_t * cos_t;
          if (sin2_max < SPHERE_SMALL_SIN2) {
            sin2_t = sin2_max * u.x;
            cos_t = sqrt(1.0 - sin2_t);
          }
          float cos_a = sin2_t / sqrt(sin2_max) + cos_t * safe_sqrt(1.0 - sin2_t / sin2_max);
          float sin_a = safe_sqrt(1.0 - cos_a * cos_a);
          float phi = 2.0 * PI * u.y;
          vec2 cs = cos_sin_accurate(phi);
          vec3 w = vec3(sin_a * cs.x, sin_a * cs.y, cos_a);
          vec3 z = safe_normalize(c - p);
          vec3 t1, t2;
          duff_frame(z, t1, t2);
          nq = -(w.x * t1 + w.y * t2 + w.z * z);
          ls.pdf = one_minus > 0.0 ? 1.0 / (2.0 * PI * one_minus) : 0.0;
        }
        precise vec3 q = c + r * nq;
        ls.q = q;
        ls.m = sphere_bound(cr);
        ls.nl = sphere_normal(sph, nq);
        vec3 dq = ls.q - p;
        if (dot(dq, dq) > 0.0) {
          ls.wi = safe_normalize(dq);
          if (inside) ls.pdf = area_to_solid_angle(p, ls.q, ls.nl, ls.wi, 4.0 * PI * r * r);
          ls.Li = area_le(li, ls.nl, -ls.wi);
          ls.area = true;
        } else {
          ls.pdf = 0.0;
        }
      }
      break;
    default:
      break;
  }
  return ls;
}

// Solid-angle pdf with which light_sample of area light li, called at p_prev (geometric
// normal ng_prev, magnitude bound m_prev), would produce the point q (normal nl) that a ray
// from p_prev in unit direction wi hit (MIS weight of an emitting hit, docs/path-spec.md
// section 7; pbrt-v4 PDF_Li). Not multiplied by the pmf.
float light_pdf(uint li, vec3 p_prev, vec3 ng_prev, float m_prev, vec3 q, vec3 nl, vec3 wi) {
  uint type = light_at(li).type;
  if (has_feature(FEATURE_TRIANGLES) && type == LIGHT_AREA_TRIANGLE) {
    return area_to_solid_angle(p_prev, q, nl, wi, light_at(li).params.x);
  }
  if (has_feature(FEATURE_SPHERES) && type == LIGHT_AREA_SPHERE) {
    vec4 cr = sphere_at(light_at(li).prim).center_radius;
    vec3 pc = p_prev - cr.xyz;
    float d2 = dot(pc, pc);
    float r2 = cr.w * cr.w;
    if (sphere_ref_inside(p_prev, ng_prev, m_prev, cr.xyz, r2))
      return area_to_solid_angle(p_prev, q, nl, wi, 4.0 * PI * cr.w * cr.w);
    float sin2_max;
    float one_minus = sphere_one_minus_cos_max(r2, d2, sin2_max);
    return one_minus > 0.0 ? 1.0 / (2.0 * PI * one_minus) : 0.0;
  }
  return 0.0;
}

// Radiance of infinite light li arriving along an escaped ray of direction w, and in pl the
// pmf-weighted solid-angle pdf with which light_sample would have produced w (MIS weight,
// docs/path-spec.md section 7; pbrt-v4 Le and PMF * PDF_Li with allowIncompletePDF = true).
// One function for every infinite tag, so that env_eval (Le and pdf) has one call site.
// o is the ray's origin (Le) and p_prev the previous vertex (the pdf): only portals read them.
vec3 infinite_light_le(uint li, vec3 o, vec3 p_prev, vec3 w, out float pl) {
  pl = 0.0;
  uint type = light_at(li).type;
  if (has_feature(FEATURE_LIGHT_INFINITE_IMAGE) && type == LIGHT_INFINITE_IMAGE) {
    float pdf;
    vec3 le = env_eval(li, w, true, o, p_prev, pdf);
    pl = light_at(li).pmf * pdf;
    return le;
  }
  if (has_feature(FEATURE_LIGHT_INFINITE) && type == LIGHT_INFINITE_UNIFORM) {
    // Uniform infinite light: Le = L in every direction, light-sampling pdf 1 / (4 pi).
    pl = light_at(li).pmf / (4.0 * PI);
    return light_at(li).L.rgb;
  }
  return vec3(0.0);
}

// Shadow ray from shading point p (geometric normal ng, magnitude bound m) towards a light
// sample (docs/path-spec.md section 5): to infinity along wi, else to q (for area lights
// offset off the light's surface with the light primitive's bound ls.m) with
// tmax = 1 - 1e-4 on the unnormalised direction.
Ray shadow_ray(vec3 p, vec3 ng, float m, LightSample ls) {
  vec3 o = offset_ray(p, dot(ls.wi, ng) > 0.0 ? ng : -ng, m);
  if (ls.at_infinity) return Ray(o, FLT_MAX, ls.wi);
  vec3 target = ls.q;
  if (ls.area) target = offset_ray(ls.q, dot(o - ls.q, ls.nl) > 0.0 ? ls.nl : -ls.nl, ls.m);
  return Ray(o, 1.0 - 1e-4, target - o);
}

#endif
