// Light selection, sampling and pdfs of the CPU reference (docs/path-spec.md section 6).
#include "cpu/lights.h"

#include <algorithm>
#include <bit>
#include <cfloat>
#include <cmath>
#include <vector>

#include "cpu/envmap.h"
#include "cpu/sampling.h"
#include "cpu/surface.h"

namespace basalt::cpu {
namespace {

/// pbrt-v4 Sphere::Sample threshold below which the cone is sampled by its small-angle
/// expansion (sin^2 of 1.5 degrees; pbrt-v4 6.2.4).
constexpr float SIN2_SMALL_CONE = 0.00068523f;

/// 1 - cos(theta_max) of the cone subtended by a sphere of squared radius r2 from squared
/// distance d2, with pbrt-v4's small-angle form (spec section 6, "sphere").
inline float one_minus_cos_max(float r2, float d2) {
  const float sin2_max = r2 / d2;
  if (sin2_max < SIN2_SMALL_CONE) return sin2_max / 2.0f;
  return 1.0f - safe_sqrt(1.0f - sin2_max);
}

/// Whether sphere-light sampling from shading point p (geometric normal ng, magnitude bound m)
/// uses the inside (area) branch (docs/path-spec.md section 6, "sphere"): the test is made on
/// pi = offset_ray(p, dot(c - p, ng) > 0 ? ng : -ng, m) (section 5), as pbrt-v4
/// Sphere::Sample/PDF test ctx.OffsetRayOrigin(pCenter), so that a shading point on the light
/// sphere itself counts as inside rather than picking a branch by rounding (the cone branch
/// would degenerate there). With ng = 0 (a point in space) pi = p.
inline bool sphere_ref_inside(glm::vec3 p, glm::vec3 ng, float m, glm::vec3 c, float r) {
  const glm::vec3 po = offset_ray(p, glm::dot(c - p, ng) > 0.0f ? ng : -ng, m);
  return glm::dot(po - c, po - c) <= r * r;
}

/// Area pdf 1/A converted to solid angle at distance^2 d2 and cosine cos (spec section 6).
inline float area_to_solid_angle(float d2, float cos, float area) {
  const float denom = std::fabs(cos) * area;
  if (!(denom > 0.0f)) return 0.0f;
  const float pdf = d2 / denom;
  return std::isfinite(pdf) ? pdf : 0.0f;
}

/// Sphere light normal on the emitting side: the unit outward direction, negated when the
/// sphere's normal is flipped (spec section 4).
inline glm::vec3 sphere_light_normal(const gpu::Sphere& sp, glm::vec3 n) {
  return (sp.flags & gpu::SHAPE_FLAG_FLIP_NORMAL) ? -n : n;
}

/// Samples a point on a sphere light seen from p (spec section 6, "sphere"; pbrt-v4 6.2.4
/// Sphere::Sample(ctx, u)).
void sample_sphere(const SceneTables& scene, const gpu::Light& light, glm::vec3 p, glm::vec3 ng,
                   float m, glm::vec2 u, LightSample& ls) {
  const gpu::Sphere& sp = scene.spheres[light.prim];
  const glm::vec3 c(sp.center_radius);
  const float r = sp.center_radius.w;
  if (!(r > 0.0f)) return;  // a point-sized sphere has no area to sample (0/0 below)
  const float d2 = glm::dot(p - c, p - c);
  glm::vec3 n;
  ls.m = sphere_magnitude(c, r);  // bound of every point of the light (section 5)
  if (sphere_ref_inside(p, ng, m, c, r)) {
    // Inside (or on) the sphere: uniform area sampling, converted to solid angle.
    n = uniform_sphere(u);
    ls.q = c + r * n;
    const glm::vec3 dq = ls.q - p;
    const float dist2 = glm::dot(dq, dq);
    if (!(dist2 > 0.0f)) return;
    ls.wi = dq / std::sqrt(dist2);
    ls.pdf = area_to_solid_angle(dist2, glm::dot(n, -ls.wi), 4.0f * PI * r * r);
  } else {
    // Outside: uniform cone sampling of the visible cap.
    const float sin2_max = r * r / d2;
    const float cos_max = safe_sqrt(1.0f - sin2_max);
    float one_minus = 1.0f - cos_max;
    float cos_t = (cos_max - 1.0f) * u.x + 1.0f;
    float sin2_t = 1.0f - cos_t * cos_t;
    if (sin2_max < SIN2_SMALL_CONE) {
      sin2_t = sin2_max * u.x;
      cos_t = std::sqrt(1.0f - sin2_t);
      one_minus = sin2_max / 2.0f;
    }
    // Angle alpha from the sphere centre to the sampled point (pbrt-v4 6.2.4).
    const float cos_a = sin2_t / std::sqrt(sin2_max) + cos_t * safe_sqrt(1.0f - sin2_t / sin2_max);
    const float sin_a = safe_sqrt(1.0f - cos_a * cos_a);
    const float phi = 2.0f * PI * u.y;
    const glm::vec3 w(sin_a * std::cos(phi), sin_a * std::sin(phi), cos_a);
    // normalize as v / sqrt(dot(v, v)), like every normalize of the spec (not glm's inversesqrt).
    const Frame f = Frame::from_z(safe_normalize(c - p));
    n = -(w.x * f.t1 + w.y * f.t2 + w.z * f.n);
    ls.q = c + r * n;
    const glm::vec3 dq = ls.q - p;
    const float dist2 = glm::dot(dq, dq);
    if (!(dist2 > 0.0f) || !(one_minus > 0.0f)) return;
    ls.wi = dq / std::sqrt(dist2);
    ls.pdf = 1.0f / (2.0f * PI * one_minus);
  }
  ls.nl = sphere_light_normal(sp, n);
  ls.Li = area_Le(light, ls.nl, -ls.wi);
}

/// Samples a point on a triangle light (spec section 6, "triangle"; pbrt-v4 6.5.4
/// Triangle::Sample with SampleUniformTriangle).
void sample_triangle(const SceneTables& scene, const gpu::Light& light, glm::vec3 p, glm::vec2 u,
                     LightSample& ls) {
  const glm::vec3 b = uniform_triangle(u);
  const SurfaceGeometry g = triangle_geometry(scene, light.prim, b.x, b.y, b.z);
  ls.q = g.p;
  ls.nl = g.ng;
  ls.m = g.m;  // the triangle's bound at q (section 5)
  const glm::vec3 dq = ls.q - p;
  const float dist2 = glm::dot(dq, dq);
  if (!(dist2 > 0.0f)) return;
  ls.wi = dq / std::sqrt(dist2);
  ls.pdf = area_to_solid_angle(dist2, glm::dot(ls.nl, -ls.wi), light.params.x);
  ls.Li = area_Le(light, ls.nl, -ls.wi);
}

}  // namespace

std::uint32_t light_count(const SceneTables& scene) {
  std::uint32_t n = std::min<std::uint32_t>(scene.globals.counts.x,
                                            static_cast<std::uint32_t>(scene.lights.size()));
  if (scene.light_cdf.size() < std::size_t(n) + 1) n = 0;  // malformed tables: no NEE
  return n;
}

std::uint32_t select_light(const SceneTables& scene, float u) {
  const std::uint32_t n = light_count(scene);
  if (n == 0) return gpu::INVALID_INDEX;
  // Spec section 6 / section 2 binary search: largest i with cdf[i] <= u.
  std::uint32_t lo = 0, hi = n;
  while (hi - lo > 1) {
    const std::uint32_t mid = (lo + hi) / 2;
    if (scene.light_cdf[mid] <= u) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return lo;
}

namespace {

/// Lights of infinite extent are picked by their cdf share alone (spec section 6).
bool is_infinite_extent(const gpu::Light& l) {
  return l.type == gpu::LIGHT_DISTANT || l.type == gpu::LIGHT_INFINITE_UNIFORM ||
         l.type == gpu::LIGHT_INFINITE_IMAGE;
}

/// True when the tables ask for importance selection of the bounded lights (spec 6.1).
bool importance_selection(const SceneTables& scene) {
  return (scene.features2 & gpu::FEATURE2_LIGHT_IMPORTANCE) &&
         scene.globals.light_opts.x == gpu::LIGHT_SELECT_IMPORTANCE;
}

/// The bounded lights' total pmf, spread over them by importance (spec 6.1).
float bounded_mass(const SceneTables& scene) {
  return std::bit_cast<float>(scene.globals.light_opts.y);
}

/// cos(a - b) of two angles given by sine and cosine, 1 if a < b (pbrt-v4 cosSubClamped).
float cos_minus_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  if (cos_a > cos_b) return 1.0f;
  return cos_a * cos_b + sin_a * sin_b;
}

/// sin(a - b) of two angles given by sine and cosine, 0 if a < b (pbrt-v4 sinSubClamped).
float sin_minus_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  if (cos_a > cos_b) return 0.0f;
  return sin_a * cos_b - cos_a * sin_b;
}

}  // namespace

float light_importance(const gpu::Light& light, glm::vec3 p, glm::vec3 n) {
  const float phi = light.bound_c.w;
  if (!(phi > 0.0f)) return 0.0f;
  const glm::vec3 centre(light.bound_c), axis(light.bound_w);
  const float radius = light.bound_e.x, cos_o = light.bound_w.w, cos_e = light.bound_e.y;
  const glm::vec3 to_p = p - centre;
  const float dist2 = glm::dot(to_p, to_p);
  // Direction from the bounds to p; along the axis when p is at the centre (spec 6.1).
  const glm::vec3 wi = dist2 > 0.0f ? to_p / std::sqrt(dist2) : axis;
  float cos_w = glm::dot(axis, wi);
  if (light.flags & gpu::LIGHT_FLAG_TWOSIDED) cos_w = std::fabs(cos_w);
  const float sin_w = safe_sqrt(1.0f - cos_w * cos_w);
  // Half-angle of the cone that the bounds' sphere subtends from p (all directions inside).
  float cos_b = -1.0f;
  if (dist2 > 0.0f && !(dist2 < radius * radius))
    cos_b = safe_sqrt(1.0f - radius * radius / dist2);
  const float sin_b = safe_sqrt(1.0f - cos_b * cos_b);
  const float sin_o = safe_sqrt(1.0f - cos_o * cos_o);
  // theta' = max(0, theta_w - theta_o - theta_b): the smallest angle to the emission cone.
  const float cos_x = cos_minus_clamped(sin_w, cos_w, sin_o, cos_o);
  const float sin_x = sin_minus_clamped(sin_w, cos_w, sin_o, cos_o);
  const float cos_theta_p = cos_minus_clamped(sin_x, cos_x, sin_b, cos_b);
  if (cos_theta_p <= cos_e) return 0.0f;
  const float d2 = std::max(dist2, radius);  // pbrt-v4's clamp: |diagonal| / 2
  float importance = d2 > 0.0f ? phi * cos_theta_p / d2 : gpu::LIGHT_IMPORTANCE_CAP;
  // The cosine at the receiver, with the same cone allowance (theta_i - theta_b).
  const float cos_i = std::fabs(glm::dot(wi, n));
  const float sin_i = safe_sqrt(1.0f - cos_i * cos_i);
  importance *= cos_minus_clamped(sin_i, cos_i, sin_b, cos_b);
  if (!(importance > 0.0f)) return 0.0f;  // negative or NaN
  return std::min(importance, gpu::LIGHT_IMPORTANCE_CAP);
}

PickedLight pick_light(const SceneTables& scene, float u, glm::vec3 p, glm::vec3 n) {
  PickedLight out;
  out.index = select_light(scene, u);
  if (out.index == gpu::INVALID_INDEX) return out;
  const gpu::Light& chosen = scene.lights[out.index];
  out.pmf = chosen.pmf;
  if (!importance_selection(scene) || is_infinite_extent(chosen) || !(chosen.pmf > 0.0f))
    return out;
  // The importance of every light at p (0 for those of infinite extent), then the light
  // whose interval of the running sum holds u' * sum, u' = u within the chosen cdf share.
  const std::uint32_t count = light_count(scene);
  std::vector<float> importance(count);
  float total = 0.0f;
  for (std::uint32_t k = 0; k < count; ++k) {
    importance[k] = light_importance(scene.lights[k], p, n);
    total += importance[k];
  }
  if (!(total > 0.0f)) {
    out.pmf = 0.0f;
    return out;
  }
  const float u_share = std::clamp((u - scene.light_cdf[out.index]) / chosen.pmf, 0.0f,
                                   0x1.fffffep-1f);
  const float target = u_share * total;
  float running = 0.0f;
  for (std::uint32_t k = 0; k < count; ++k) {
    if (!(importance[k] > 0.0f)) continue;
    out.index = k;  // the last light with importance, should rounding leave target unmet
    running += importance[k];
    if (target < running) break;
  }
  out.pmf = bounded_mass(scene) * (importance[out.index] / total);
  return out;
}

float pick_light_pmf(const SceneTables& scene, std::uint32_t index, glm::vec3 p, glm::vec3 n) {
  const gpu::Light& light = scene.lights[index];
  if (!importance_selection(scene) || is_infinite_extent(light)) return light.pmf;
  float total = 0.0f;
  const std::uint32_t count = light_count(scene);
  for (std::uint32_t k = 0; k < count; ++k) total += light_importance(scene.lights[k], p, n);
  if (!(total > 0.0f)) return 0.0f;
  return bounded_mass(scene) * (light_importance(light, p, n) / total);
}

glm::vec3 area_Le(const gpu::Light& light, glm::vec3 nl, glm::vec3 w) {
  if ((light.flags & gpu::LIGHT_FLAG_TWOSIDED) || glm::dot(nl, w) > 0.0f) return glm::vec3(light.L);
  return glm::vec3(0.0f);
}

LightSample sample_light(const SceneTables& scene, const gpu::Light& light, glm::vec3 p,
                         glm::vec3 ng, float m, glm::vec2 u) {
  LightSample ls;
  switch (light.type) {
    case gpu::LIGHT_POINT:
    case gpu::LIGHT_SPOT: {
      // pbrt-v4 12.1 PointLight / 12.1.1 SpotLight::SampleLi: Li = I / d^2.
      const glm::vec3 pos(light.pos);
      const glm::vec3 dq = pos - p;
      const float dist2 = glm::dot(dq, dq);
      if (!(dist2 > 0.0f)) return ls;
      ls.wi = dq / std::sqrt(dist2);
      ls.q = pos;
      ls.Li = glm::vec3(light.L) / dist2;
      if (light.type == gpu::LIGHT_SPOT)
        ls.Li *= smooth_step(glm::dot(-ls.wi, glm::vec3(light.dir)), light.params.y, light.params.x);
      ls.pdf = 1.0f;
      ls.delta = true;
      return ls;
    }
    case gpu::LIGHT_DISTANT:
      // pbrt-v4 12.4 DistantLight::SampleLi.
      ls.wi = glm::vec3(light.dir);
      ls.Li = glm::vec3(light.L);
      ls.pdf = 1.0f;
      ls.delta = true;
      ls.at_infinity = true;
      return ls;
    case gpu::LIGHT_INFINITE_UNIFORM:
      // pbrt-v4 12.5.1 UniformInfiniteLight::SampleLi (uniform sphere, no allowIncompletePDF).
      ls.wi = uniform_sphere(u);
      ls.Li = glm::vec3(light.L);
      ls.pdf = 1.0f / (4.0f * PI);
      ls.at_infinity = true;
      return ls;
    case gpu::LIGHT_INFINITE_IMAGE:
      // pbrt-v4 ImageInfiniteLight::SampleLi with allowIncompletePDF = true, as
      // PathIntegrator::SampleLd asks (docs/textures-spec.md section 6): u.x picks the column,
      // u.y the row of the MIS-compensated distribution.
      env_sample(scene, light, u, true, ls.wi, ls.pdf, ls.Li, p);
      ls.at_infinity = true;
      return ls;
    case gpu::LIGHT_AREA_TRIANGLE:
      ls.area = true;
      sample_triangle(scene, light, p, u, ls);
      return ls;
    case gpu::LIGHT_AREA_SPHERE:
      ls.area = true;
      sample_sphere(scene, light, p, ng, m, u, ls);
      return ls;
    default:
      return ls;
  }
}

float area_light_pdf(const SceneTables& scene, const gpu::Light& light, glm::vec3 p_ref,
                     glm::vec3 ng_ref, float m_ref, glm::vec3 q, glm::vec3 nq, glm::vec3 w) {
  const glm::vec3 dq = q - p_ref;
  const float dist2 = glm::dot(dq, dq);
  switch (light.type) {
    case gpu::LIGHT_AREA_TRIANGLE:
      // pbrt-v4 Triangle::PDF with uniform area sampling.
      return area_to_solid_angle(dist2, glm::dot(nq, -w), light.params.x);
    case gpu::LIGHT_AREA_SPHERE: {
      // pbrt-v4 Sphere::PDF: area density inside, cone density outside.
      const gpu::Sphere& sp = scene.spheres[light.prim];
      const glm::vec3 c(sp.center_radius);
      const float r = sp.center_radius.w;
      const float d2c = glm::dot(p_ref - c, p_ref - c);
      if (sphere_ref_inside(p_ref, ng_ref, m_ref, c, r))
        return area_to_solid_angle(dist2, glm::dot(nq, -w), 4.0f * PI * r * r);
      const float one_minus = one_minus_cos_max(r * r, d2c);
      return one_minus > 0.0f ? 1.0f / (2.0f * PI * one_minus) : 0.0f;
    }
    default:
      return 0.0f;
  }
}

glm::vec3 infinite_Le(const SceneTables& scene, const gpu::Light& light, glm::vec3 o,
                      glm::vec3 w) {
  if (light.type == gpu::LIGHT_INFINITE_IMAGE) return env_le(scene, light, w, o);
  return glm::vec3(light.L);  // LIGHT_INFINITE_UNIFORM
}

float infinite_light_pdf(const SceneTables& scene, const gpu::Light& light, glm::vec3 p,
                         glm::vec3 w) {
  // pbrt-v4 PathIntegrator::Li: lightSampler.PMF * light.PDF_Li(prevIntrCtx, w, true).
  if (light.type == gpu::LIGHT_INFINITE_IMAGE)
    return light.pmf * env_pdf(scene, light, w, true, p);
  return light.pmf / (4.0f * PI);  // uniform sphere (spec section 7)
}

Ray shadow_ray(glm::vec3 p, glm::vec3 ng, float m, const LightSample& ls) {
  // Spec section 5: origin offset with the shading point's bound m, an area light's target
  // with the light primitive's bound at q.
  const glm::vec3 o = offset_ray(p, glm::dot(ls.wi, ng) > 0.0f ? ng : -ng, m);
  if (ls.at_infinity) return Ray{o, ls.wi, FLT_MAX};
  glm::vec3 target = ls.q;
  if (ls.area) target = offset_ray(ls.q, glm::dot(o - ls.q, ls.nl) > 0.0f ? ls.nl : -ls.nl, ls.m);
  return Ray{o, target - o, 1.0f - 1e-4f};
}

}  // namespace basalt::cpu
