// Unidirectional path tracer with next-event estimation and MIS (docs/path-spec.md
// section 7, pbrt-v4 13.4 PathIntegrator::Li). Needs bindings.glsl.
#ifndef BASALT_INTEGRATOR_GLSL
#define BASALT_INTEGRATOR_GLSL

#include "math.glsl"
#include "rng.glsl"
#include "sampling.glsl"
#include "intersect.glsl"
#include "surface.glsl"
#include "camera.glsl"
#include "lights.glsl"
#include "bsdf.glsl"

// Radiance of an escaped ray from the infinite lights, MIS-weighted against light sampling
// unless the previous vertex could not sample lights (camera or specular).
vec3 escaped_radiance(bool unweighted, float pdf_prev) {
  vec3 L = vec3(0.0);
  if ((FEATURES & FEATURE_LIGHT_INFINITE) != 0u) {
    uint n = min(globals.counts.y, MAX_INFINITE_LIGHTS);
    for (uint k = 0u; k < n; ++k) {
      uint li = globals.infinite_lights[k];
      // Uniform infinite light: Le = L in every direction, light-sampling pdf 1 / (4 pi).
      float w = unweighted ? 1.0 : power_heuristic(pdf_prev, lights[li].pmf / (4.0 * PI));
      L += w * lights[li].L.rgb;
    }
  }
  return L;
}

// Radiance estimate of sample s of pixel (px, py): one path (docs/path-spec.md section 7).
// rays is incremented by the number of rays traced (camera, continuation and shadow rays).
vec3 path_radiance(uint px, uint py, uint s, inout uint rays) {
  CameraRay cr = camera_ray(px, py, s);
  Ray ray = Ray(cr.o, FLT_MAX, cr.d);
  vec3 L = vec3(0.0);
  vec3 beta = vec3(1.0);
  bool specular = false;
  float pdf_prev = 0.0;
  vec3 p_prev = ray.o;
  vec3 ng_prev = vec3(0.0);
  float m_prev = 0.0;
  uint depth = 0u;
  uint max_depth = globals.image.z;
  uint num_lights = globals.counts.x;
  while (true) {
    Hit hit = intersect_closest(ray);
    ++rays;
    if (hit.prim == INVALID_INDEX) {
      L += beta * escaped_radiance(depth == 0u || specular, pdf_prev);
      break;
    }
    SurfacePoint sp = surface_point(ray, hit);
    vec3 wo = -ray.d;

    // Emission of an area light hit by the path.
    if ((FEATURES & FEATURE_LIGHT_AREA) != 0u && sp.light != INVALID_INDEX) {
      vec3 Le = area_le(sp.light, sp.ng, wo);
      if (any_positive(Le)) {
        float w = 1.0;
        if (!(depth == 0u || specular)) {
          float pl = lights[sp.light].pmf *
                     light_pdf(sp.light, p_prev, ng_prev, m_prev, sp.p, sp.ng, ray.d);
          w = power_heuristic(pdf_prev, pl);
        }
        L += beta * w * Le;
      }
    }
    if (depth == max_depth) break;
    uint dim = DIM_BOUNCE_BASE + DIM_BOUNCE_STRIDE * depth;
    ++depth;

    Bsdf bsdf = bsdf_at(sp.material, sp);
    vec3 wo_l = to_local(sp, wo);

    // Next-event estimation: one light picked by light_cdf, MIS against BSDF sampling.
    if ((FEATURES & FEATURE_ANY_LIGHT) != 0u && num_lights > 0u && !bsdf_is_specular(bsdf)) {
      uint li = light_select(rng(px, py, s, dim + DIM_LIGHT_SELECT), num_lights);
      float pmf = lights[li].pmf;
      vec2 ul = vec2(rng(px, py, s, dim + DIM_LIGHT_U0), rng(px, py, s, dim + DIM_LIGHT_U1));
      LightSample ls = light_sample(li, sp.p, sp.ng, sp.m, ul);
      if (ls.pdf > 0.0 && pmf > 0.0 && any_positive(ls.Li)) {
        vec3 wi_l = to_local(sp, ls.wi);
        vec3 f = bsdf_eval(bsdf, wo_l, wi_l) * abs(dot(ls.wi, sp.ns));
        bool lit = false;
        if (any_positive(f)) {
          lit = !intersect_any(shadow_ray(sp.p, sp.ng, sp.m, ls));
          ++rays;
        }
        if (lit) {
          if (ls.delta) {
            L += beta * f * ls.Li / pmf;
          } else {
            float pl = pmf * ls.pdf;
            L += beta * f * ls.Li * power_heuristic(pl, bsdf_pdf(bsdf, wo_l, wi_l)) / pl;
          }
        }
      }
    }

    // BSDF sampling of the continuation direction.
    vec3 ub = vec3(rng(px, py, s, dim + DIM_BSDF_LOBE), rng(px, py, s, dim + DIM_BSDF_U0),
                   rng(px, py, s, dim + DIM_BSDF_U1));
    BsdfSample bs = bsdf_sample(bsdf, wo_l, ub);
    if (bs.pdf == 0.0 || !any_positive(bs.f) || bs.wi.z == 0.0) break;
    vec3 wi = to_world(sp, bs.wi);
    beta *= bs.f * abs(dot(wi, sp.ns)) / bs.pdf;
    pdf_prev = bs.pdf;
    specular = (bs.flags & BSDF_SPECULAR) != 0u;
    p_prev = sp.p;
    ng_prev = sp.ng;
    m_prev = sp.m;
    ray = spawn_ray(sp.p, sp.ng, sp.m, wi);

    // Russian roulette (pbrt-v4 13.4.2).
    float bmax = max_component(beta);
    if (bmax < 1.0 && depth > 1u) {
      float q = max(0.0, 1.0 - bmax);
      if (rng(px, py, s, dim + DIM_ROULETTE) < q) break;
      beta /= 1.0 - q;
    }
  }
  return L;
}

#endif
