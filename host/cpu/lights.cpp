// Light selection, sampling and pdfs of the CPU reference (docs/path-spec.md section 6).
#include "cpu/lights.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

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
