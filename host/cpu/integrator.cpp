// The path integrator of the CPU reference (docs/path-spec.md section 7).
#include "cpu/integrator.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "cpu/bsdf.h"
#include "cpu/camera.h"
#include "cpu/sampler.h"
#include "cpu/lights.h"
#include "cpu/sampling.h"
#include "cpu/surface.h"

namespace basalt::cpu {
namespace {

/// Direct lighting at a vertex b with a non-specular BSDF (spec section 7 "NEE"; pbrt-v4
/// PathIntegrator::SampleLd): one light chosen by the light CDF, one sample on it. The BSDF
/// is evaluated with stream +7 and its pdf with stream +8 (docs/materials-spec.md section 5);
/// ng_l is the geometric normal in the local frame (light-leak rule, materials-spec 1.2).
glm::vec3 sample_direct(const SceneTables& scene, const SurfacePoint& sp, const Bsdf& bsdf,
                        glm::vec3 wo, glm::vec3 ng_l, std::uint32_t b, const PathRng& r,
                        std::uint64_t& rays) {
  // Picked at p with the (bumped) shading normal (spec 6.1).
  const PickedLight pick = pick_light(scene, r(dim::bounce(b, dim::LIGHT_SELECT)), sp.g.p, sp.g.ns);
  if (pick.index == gpu::INVALID_INDEX || !(pick.pmf > 0.0f)) return glm::vec3(0.0f);
  const gpu::Light& light = scene.lights[pick.index];
  const LightSample ls = sample_light(
      scene, light, sp.g.p, sp.g.ng, sp.g.m,
      glm::vec2(r(dim::bounce(b, dim::LIGHT_U0)), r(dim::bounce(b, dim::LIGHT_U1))));
  if (!(ls.pdf > 0.0f) || !any_positive(ls.Li)) return glm::vec3(0.0f);
  const glm::vec3 wi = sp.frame.to_local(ls.wi);
  const glm::vec3 f =
      bsdf_eval(bsdf, wo, wi, ng_l, r.stream(dim::bounce(b, dim::STREAM_NEE_EVAL))) *
      std::fabs(glm::dot(ls.wi, sp.g.ns));
  if (!any_positive(f)) return glm::vec3(0.0f);
  ++rays;
  if (intersect_any(scene, shadow_ray(sp.g.p, sp.g.ng, sp.g.m, ls))) return glm::vec3(0.0f);
  if (ls.delta) return f * ls.Li / pick.pmf;
  const float pl = pick.pmf * ls.pdf;
  if (!(pl > 0.0f)) return glm::vec3(0.0f);  // underflow of pmf * pdf
  const float pb = bsdf_pdf(bsdf, wo, wi, ng_l, r.stream(dim::bounce(b, dim::STREAM_NEE_PDF)));
  return f * ls.Li * mis_light(scene.globals.render_opts.y, pl, pb) / pl;
}

/// docs/materials-spec.md section 5: interface crossings allowed per path.
constexpr std::uint32_t MAX_INTERFACE_CROSSINGS = 64;

}  // namespace

glm::vec3 trace_path(const SceneTables& scene, Ray ray, const PathRng& r, std::uint64_t* rays,
                     const RayDifferential* camera_diff) {
  const gpu::Globals& g = scene.globals;
  const std::uint32_t max_depth = g.image.z;
  const std::uint32_t n_inf = std::min(g.counts.y, gpu::MAX_INFINITE_LIGHTS);
  // ns_prev: the previous vertex's (bumped) shading normal, which light picking saw there.
  glm::vec3 L(0.0f), beta(1.0f), p_prev(0.0f), ng_prev(0.0f), ns_prev(0.0f);
  float m_prev = 0.0f;
  bool specular = false;
  float pdf_prev = 0.0f, eta_scale = 1.0f;
  std::uint32_t depth = 0, crossings = 0;
  std::uint64_t nrays = 0;
  // The ray's differentials (docs/textures-spec.md 3.1): the camera ray's, carried through
  // interfaces and perfectly specular bounces.
  RayDifferential diff{};
  bool has_diff = camera_diff != nullptr;
  if (has_diff) diff = *camera_diff;
  for (;;) {
    const Hit hit = intersect_closest(scene, ray);
    ++nrays;
    if (!hit.valid()) {
      // Escaped: every infinite light, MIS-weighted against its light-sampling density
      // (uniform sphere, or an environment map's compensated distribution).
      for (std::uint32_t i = 0; i < n_inf; ++i) {
        const std::uint32_t li = g.infinite_lights[int(i)];
        if (li >= scene.lights.size()) continue;
        const gpu::Light& light = scene.lights[li];
        const glm::vec3 Le = infinite_Le(scene, light, ray.o, ray.d);
        const float w = (depth == 0 || specular)
                            ? 1.0f
                            : mis_bsdf(g.render_opts.y, pdf_prev,
                                       infinite_light_pdf(scene, light, p_prev, ray.d));
        L += beta * w * Le;
      }
      break;
    }
    // The footprint from the ray's differentials, else approximated (textures-spec 3).
    // Not const: bsdf_at applies a bump or normal map to its shading normal and frame.
    SurfacePoint sp = surface_point(scene, ray, hit, has_diff ? &diff : nullptr);
    // Emission of an area light, MIS-weighted against light sampling from the previous vertex.
    if (sp.light < scene.lights.size()) {
      const gpu::Light& light = scene.lights[sp.light];
      const glm::vec3 Le = area_Le(light, sp.g.ng, -ray.d);
      if (any_positive(Le)) {
        if (depth == 0 || specular) {
          L += beta * Le;
        } else {
          const float pl = pick_light_pmf(scene, sp.light, p_prev, ns_prev) *
                           area_light_pdf(scene, light, p_prev, ng_prev, m_prev, sp.g.p, sp.g.ng,
                                          ray.d);
          L += beta * mis_bsdf(g.render_opts.y, pdf_prev, pl) * Le;
        }
      }
    }
    // The BSDF (stochastic mixes resolved at the hit, docs/materials-spec.md section 4), and
    // from here on the bumped shading normal and frame (docs/bump-spec.md 6).
    const Bsdf bsdf = bsdf_at(scene, sp.material, sp, -ray.d);
    if (bsdf.interface) {
      // materials-spec section 5 (pbrt-v4 PathIntegrator: no BSDF -> SkipIntersection): the
      // ray continues from the hit, depth unchanged, as after a specular bounce.
      if (crossings == MAX_INTERFACE_CROSSINGS) break;
      ++crossings;
      specular = true;
      ray = spawn_ray(sp.g.p, sp.g.ng, sp.g.m, ray.d);
      if (has_diff) {  // pbrt-v4 SkipIntersection: the differential origins move to the hit
        diff.rx_o = diff.rx_o + hit.t * diff.rx_d;
        diff.ry_o = diff.ry_o + hit.t * diff.ry_d;
      }
      continue;
    }
    if (depth == max_depth) break;
    const std::uint32_t b = depth;
    ++depth;
    const glm::vec3 wo = sp.frame.to_local(-ray.d);
    // The light-leak rule's geometric normal (materials-spec 1.2), or with
    // SHADEOPT_PBRT_V4_SIDES the shading normal (pbrt-v4: the shading frame alone decides).
    const glm::vec3 ng_l = (scene.globals.texture_opts.w & gpu::SHADEOPT_PBRT_V4_SIDES)
                               ? glm::vec3(0.0f, 0.0f, 1.0f)
                               : sp.frame.to_local(sp.g.ng);
    // Next-event estimation, unless the MIS mode samples the BSDF alone (path-spec 7.1).
    if (bsdf_is_nonspecular(bsdf) && g.render_opts.y != gpu::MIS_BSDF_ONLY)
      L += beta * sample_direct(scene, sp, bsdf, wo, ng_l, b, r, nrays);
    // Continue the path by sampling the BSDF (stream +9).
    const BsdfSample bs =
        bsdf_sample(bsdf, wo,
                    glm::vec3(r(dim::bounce(b, dim::BSDF_LOBE)), r(dim::bounce(b, dim::BSDF_U0)),
                              r(dim::bounce(b, dim::BSDF_U1))),
                    ng_l, r.stream(dim::bounce(b, dim::STREAM_SAMPLE)));
    if (bs.flags == 0 || !any_positive(bs.f) || bs.pdf == 0.0f || bs.wi.z == 0.0f) break;
    const glm::vec3 wi = sp.frame.to_world(bs.wi);
    beta *= bs.f * std::fabs(glm::dot(wi, sp.g.ns)) / bs.pdf;
    // pbrt-v4: a proportional pdf (layered lobes) is replaced by bsdf_pdf for MIS (stream +10).
    pdf_prev = bs.pdf_is_proportional
                   ? bsdf_pdf(bsdf, wo, bs.wi, ng_l,
                              r.stream(dim::bounce(b, dim::STREAM_SAMPLE_PDF)))
                   : bs.pdf;
    specular = (bs.flags & gpu::BSDF_SPECULAR) != 0;
    if (bs.flags & gpu::BSDF_TRANSMISSION) eta_scale *= bs.eta * bs.eta;
    p_prev = sp.g.p;
    ng_prev = sp.g.ng;
    ns_prev = sp.g.ns;
    m_prev = sp.g.m;
    // Differentials survive exactly-specular reflection and transmission only (3.1).
    const std::uint32_t kind = bs.flags & (gpu::BSDF_SPECULAR | gpu::BSDF_REFLECTION |
                                           gpu::BSDF_TRANSMISSION | gpu::BSDF_DIFFUSE |
                                           gpu::BSDF_GLOSSY);
    const bool spec_r = kind == (gpu::BSDF_SPECULAR | gpu::BSDF_REFLECTION);
    const bool spec_t = kind == (gpu::BSDF_SPECULAR | gpu::BSDF_TRANSMISSION);
    const glm::vec3 d_in = ray.d;
    ray = spawn_ray(sp.g.p, sp.g.ng, sp.g.m, wi);
    if (has_diff && (spec_r || spec_t))
      has_diff = specular_differentials(sp.tex, ray.o, sp.g.ns, sp.g.dndu, sp.g.dndv, -d_in, wi,
                                        spec_t, bs.eta, diff, diff);
    else
      has_diff = false;
    // Russian roulette on beta etaScale (pbrt-v4 13.1.3) once the path has bounced more than
    // once (pbrt-v4: from the third vertex on), or as render_opts.x says (path-spec 7.1).
    const float mb = max_component(beta * eta_scale);
    const std::uint32_t rr = g.render_opts.x;  // 0: pbrt-v4's start, 1; N + 1: start N
    if (mb < 1.0f && rr != gpu::ROULETTE_OFF && depth > (rr == 0u ? 1u : rr - 1u)) {
      const float q = std::max(0.0f, 1.0f - mb);
      if (r(dim::bounce(b, dim::ROULETTE)) < q) break;
      beta /= 1.0f - q;
    }
  }
  if (rays) *rays += nrays;
  return L;
}

glm::vec3 path_radiance(const SceneTables& scene, std::uint32_t px, std::uint32_t py,
                        std::uint32_t s, std::uint64_t* rays) {
  const PathRng r{px, py, s, scene.globals.image.w, sampler_of(scene)};
  if (scene.features & gpu::FEATURE_TEXTURES) {
    const CameraRay c = camera_ray_differential(scene, px, py, s);
    RayDifferential diff{c.rx_o, c.rx_d, c.ry_o, c.ry_d};
    scale_differentials(diff, c.o, c.d, scene.globals.min_dir_dx.w);
    return trace_path(scene, Ray{c.o, c.d, FLT_MAX}, r, rays, &diff);
  }
  return trace_path(scene, camera_ray(scene, px, py, s), r, rays);
}

}  // namespace basalt::cpu
