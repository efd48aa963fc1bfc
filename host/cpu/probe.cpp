// CPU twin of shaders/tests/probe.comp: answers probe queries (layout.h PROBE_*).
#include "cpu/probe.h"

#include <bit>
#include <cfloat>

#include "cpu/bsdf.h"
#include "cpu/bump.h"
#include "cpu/bxdfs.h"
#include "cpu/camera.h"
#include "cpu/envmap.h"
#include "cpu/intersect.h"
#include "cpu/noise.h"
#include "cpu/rng.h"
#include "cpu/sampler.h"
#include "cpu/surface.h"
#include "cpu/texture.h"

namespace basalt::cpu {

std::vector<gpu::ProbeOut> probe(const SceneTables& scene, const std::vector<gpu::ProbeIn>& in) {
  std::vector<gpu::ProbeOut> out(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    const gpu::ProbeIn& q = in[i];
    gpu::ProbeOut& o = out[i];
    o = gpu::ProbeOut{};
    const Ray ray{glm::vec3(q.o_tmax), glm::vec3(q.d), q.o_tmax.w};
    switch (q.key.x) {
      case gpu::PROBE_CLOSEST:
      case gpu::PROBE_RESPAWN: {
        const Hit h = intersect_closest(scene, ray);
        o.f0 = glm::vec4(h.t, h.b1, h.b2, 0.0f);
        o.u.x = h.prim;
        if (q.key.x == gpu::PROBE_CLOSEST) break;
        Hit h2;
        if (h.valid()) {
          // Continuation from the first hit's surface point (spec sections 4 and 5).
          const SurfacePoint sp = surface_point(scene, ray, h);
          h2 = intersect_closest(scene, spawn_ray(sp.g.p, sp.g.ng, sp.g.m, glm::vec3(q.extra)));
        }
        o.f1 = glm::vec4(h2.t, h2.b1, h2.b2, 0.0f);
        o.u.y = h2.prim;
        break;
      }
      case gpu::PROBE_OCCLUDED:
        o.u.x = intersect_any(scene, ray) ? 1u : 0u;
        break;
      case gpu::PROBE_RNG:
        o.f0.x = rng(q.key.y, q.key.z, q.key.w, std::bit_cast<std::uint32_t>(q.extra.x),
                     scene.globals.image.w);
        break;
      case gpu::PROBE_SAMPLER:
        o.f0.x = sampler_get(scene, q.key.y, q.key.z, q.key.w,
                             std::bit_cast<std::uint32_t>(q.extra.x));
        break;
      case gpu::PROBE_CAMERA: {
        const Ray c = camera_ray(scene, q.key.y, q.key.z, q.key.w);
        o.f0 = glm::vec4(c.o, 0.0f);
        o.f1 = glm::vec4(c.d, 0.0f);
        break;
      }
      case gpu::PROBE_CAMERA_DIFF: {
        const CameraRay c = camera_ray_differential(scene, q.key.y, q.key.z, q.key.w);
        o.f0 = glm::vec4(c.rx_d, 0.0f);
        o.f1 = glm::vec4(c.ry_d, 0.0f);
        break;
      }
      case gpu::PROBE_BSDF: {
        // docs/materials-spec.md section 6: material key.y at p in a frame equal to the world
        // frame (ns = +z, dpdu = +x), streams (key.z, key.w, sample 0, dims 7..10), seed 0.
        SurfacePoint sp;
        sp.g.p = glm::vec3(q.o_tmax.w, q.d.w, q.extra.w);
        sp.g.ns = glm::vec3(0.0f, 0.0f, 1.0f);
        sp.g.ng = glm::vec3(q.extra2);
        sp.g.dpdu = glm::vec3(1.0f, 0.0f, 0.0f);
        sp.frame = shading_frame(sp.g.ns, sp.g.dpdu);
        sp.material = q.key.y;
        const glm::vec3 wo(q.o_tmax), wi(q.d), u(q.extra), ng(q.extra2);
        auto key = [&](std::uint32_t d) { return stream_key(q.key.z, q.key.w, 0u, d, 0u); };
        const Bsdf b = bsdf_at(scene, q.key.y, sp, wo);
        o.f0 = glm::vec4(bsdf_eval(b, wo, wi, ng, key(dim::STREAM_NEE_EVAL)),
                         bsdf_pdf(b, wo, wi, ng, key(dim::STREAM_NEE_PDF)));
        const BsdfSample bs = bsdf_sample(b, wo, u, ng, key(dim::STREAM_SAMPLE));
        if (bs.flags != 0) {
          o.f1 = glm::vec4(bs.f, bs.pdf);
          o.f2 = glm::vec4(bs.wi, bs.eta);
          o.f3.x = bsdf_pdf(b, wo, bs.wi, ng, key(dim::STREAM_SAMPLE_PDF));
        }
        o.f3.y = float(b.n);
        o.u = glm::uvec4(bs.flags, bsdf_flags(b), bs.pdf_is_proportional ? 1u : 0u,
                         b.n > 0 ? b.lobes[0].tag : 0u);
        break;
      }
      case gpu::PROBE_TEXTURE: {
        // tex_eval_rgb / tex_eval_float of texture key.y in a given context (layout.h).
        TextureContext c;
        c.p = glm::vec3(q.o_tmax);
        c.uv = glm::vec2(q.o_tmax.w, q.d.w);
        c.n = glm::vec3(q.d);
        c.dpdx = glm::vec3(q.extra);
        c.dpdy = glm::vec3(q.extra2);
        c.dudx = q.extra.w;
        c.dudy = q.extra2.w;
        c.dvdx = q.extra3.x;
        c.dvdy = q.extra3.y;
        o.f0 = glm::vec4(q.key.z == 1u ? glm::vec3(tex_eval_float(scene, q.key.y, c))
                                       : tex_eval_rgb(scene, q.key.y, c),
                         0.0f);
        break;
      }
      case gpu::PROBE_NOISE: {
        // Noise functions at p = o_tmax.xyz (layout.h): 0 Perlin, 1 Shirley's noise, 2 fbm,
        // 3 turbulence, 4 Shirley's turbulence with key.z octaves, 5 Perlin at extra.w p.
        const glm::vec3 p(q.o_tmax);
        if (q.key.y == 0u) o.f0.x = perlin_noise(scene, p);
        else if (q.key.y == 5u)  // noise at lambda p, lambda = extra.w, split if key.w = 1
          o.f0.x = perlin_noise_scaled(scene, q.extra.w, p, q.key.w == 1u);
        else if (q.key.y == 1u) o.f0.x = shirley_noise(scene, p);
        else if (q.key.y == 4u) o.f0.x = shirley_turbulence(scene, p, int(q.key.z));
        else if (q.key.y == 2u)
          o.f0.x = fbm(scene, p, glm::vec3(q.d), glm::vec3(q.extra), q.extra.w, int(q.key.z),
                       q.key.w == 1u);
        else if (q.key.y == 3u)
          o.f0.x = turbulence(scene, p, glm::vec3(q.d), glm::vec3(q.extra), q.extra.w,
                              int(q.key.z), q.key.w == 1u);
        break;
      }
      case gpu::PROBE_ENV: {
        // Image infinite light key.y (docs/textures-spec.md 6): Le and plain pdf at d, the
        // compensated pdf, and a sample of the plain distribution with u = extra.xy.
        if (q.key.y >= scene.lights.size()) break;
        const gpu::Light& l = scene.lights[q.key.y];
        // The reference point (ray origin of Le, point of the pdf and the sample) is
        // (d.w, extra.z, extra.w); only portals read it.
        const glm::vec3 d(q.d), ref(q.d.w, q.extra.z, q.extra.w);
        o.f0 = glm::vec4(env_le(scene, l, d, ref), env_pdf(scene, l, d, false, ref));
        o.f3.x = env_pdf(scene, l, d, true, ref);
        glm::vec3 wi(0.0f), le(0.0f);
        float pdf = 0.0f;
        if (env_sample(scene, l, glm::vec2(q.extra), false, wi, pdf, le, ref)) {
          o.f1 = glm::vec4(wi, pdf);
          o.f2 = glm::vec4(le, 0.0f);
        }
        break;
      }
      case gpu::PROBE_DIFFERENTIALS: {
        // Texture context at the first hit of the camera ray of pixel (key.z, key.w), sample
        // bits(extra.x): key.y = 0 with the camera ray's differentials, 1 approximated, 2 and 3
        // after a perfectly specular reflection or refraction (layout.h PROBE_DIFFERENTIALS).
        const CameraRay c = camera_ray_differential(scene, q.key.z, q.key.w,
                                                    std::bit_cast<std::uint32_t>(q.extra.x));
        const Ray cam{c.o, c.d, FLT_MAX};
        const Hit h = intersect_closest(scene, cam);
        o.u.x = h.prim;
        RayDifferential diff{c.rx_o, c.rx_d, c.ry_o, c.ry_d};
        scale_differentials(diff, c.o, c.d, scene.globals.min_dir_dx.w);
        if (h.valid() && q.key.y >= 2u) {
          // Modes 2, 3: one perfectly specular bounce, then the second hit's footprint.
          o.u.x = gpu::INVALID_INDEX;
          const SurfacePoint sp = surface_point(scene, cam, h, &diff);
          const glm::vec3 wo = -c.d;
          glm::vec3 wi;
          float eta = 1.0f;
          if (q.key.y == 2u) {
            wi = 2.0f * glm::dot(wo, sp.g.ns) * sp.g.ns - wo;
          } else if (!bxdf::refract_v4(wo, sp.g.ns, q.extra.y, &eta, &wi)) {
            break;  // total internal reflection: no second ray
          }
          RayDifferential out{};
          const Ray r2 = spawn_ray(sp.g.p, sp.g.ng, sp.g.m, wi);
          const bool keep = specular_differentials(sp.tex, r2.o, sp.g.ns, sp.g.dndu, sp.g.dndv, wo,
                                                   wi, q.key.y == 3u, eta, diff, out);
          const Hit h2 = intersect_closest(scene, r2);
          o.u.x = h2.prim;
          o.u.y = keep ? 1u : 0u;
          if (!h2.valid()) break;
          const SurfacePoint sp2 = surface_point(scene, r2, h2, keep ? &out : nullptr);
          o.f0 = glm::vec4(sp2.tex.dpdx, sp2.tex.dudx);
          o.f1 = glm::vec4(sp2.tex.dpdy, sp2.tex.dudy);
          o.f2 = glm::vec4(sp2.tex.uv, sp2.tex.dvdx, sp2.tex.dvdy);
          o.f3 = glm::vec4(sp2.tex.p, 0.0f);
        } else if (h.valid()) {
          const SurfacePoint sp = surface_point(scene, cam, h, q.key.y == 0u ? &diff : nullptr);
          o.f0 = glm::vec4(sp.tex.dpdx, sp.tex.dudx);
          o.f1 = glm::vec4(sp.tex.dpdy, sp.tex.dudy);
          o.f2 = glm::vec4(sp.tex.uv, sp.tex.dvdx, sp.tex.dvdy);
          o.f3 = glm::vec4(sp.tex.p, 0.0f);
        }
        break;
      }
      case gpu::PROBE_BUMP: {
        // bump_shading at the first hit of the camera ray of pixel (key.z, key.w), sample
        // bits(extra.x), with the camera ray's differentials as the path tracer has them, for
        // the material after mix resolution (wo = -d) (layout.h PROBE_BUMP).
        SurfacePoint sp;
        glm::vec3 wo;
        if (q.key.y == 1u) {
          // The synthetic surface point of layout.h PROBE_BUMP key.y = 1.
          sp.g.p = glm::vec3(q.o_tmax);
          sp.material = q.key.z;
          sp.scene = &scene;
          sp.g.ng = glm::vec3(q.d);
          sp.g.ns = glm::vec3(q.extra3);
          sp.g.uv = glm::vec2(q.o_tmax.w, q.d.w);
          sp.sdpdu = sp.g.dpdu = glm::vec3(q.extra);
          sp.sdpdv = sp.g.dpdv = glm::vec3(q.extra2);
          sp.g.dndu = q.extra3.w * glm::vec3(q.extra);
          sp.g.dndv = q.extra3.w * glm::vec3(q.extra2);
          sp.frame = shading_frame(sp.g.ns, sp.sdpdu);
          sp.tex.p = sp.g.p;
          sp.tex.n = sp.g.ng;
          sp.tex.uv = sp.g.uv;
          sp.tex.dudx = sp.tex.dudy = q.extra.w;
          sp.tex.dvdx = sp.tex.dvdy = q.extra2.w;
          wo = sp.g.ns;
          o.u.x = 0u;
        } else {
          const CameraRay c = camera_ray_differential(scene, q.key.z, q.key.w,
                                                      std::bit_cast<std::uint32_t>(q.extra.x));
          const Ray cam{c.o, c.d, FLT_MAX};
          RayDifferential diff{c.rx_o, c.rx_d, c.ry_o, c.ry_d};
          scale_differentials(diff, c.o, c.d, scene.globals.min_dir_dx.w);
          const Hit h = intersect_closest(scene, cam);
          o.u.x = h.prim;
          if (!h.valid()) break;
          sp = surface_point(scene, cam, h, &diff);
          wo = -c.d;
        }
        glm::vec3 dpdu = sp.sdpdu, dpdv = sp.sdpdv;
        bool changed = false;
        const std::uint32_t idx = resolve_mix(scene, sp.material, sp, wo);
        if (idx != gpu::INVALID_INDEX)
          changed = bump_shading(scene, scene.materials[idx], sp, &dpdu, &dpdv);
        o.f0 = glm::vec4(sp.g.ns, 0.0f);
        o.f1 = glm::vec4(dpdu, 0.0f);
        o.f2 = glm::vec4(dpdv, 0.0f);
        o.f3 = glm::vec4(sp.frame.t1, 0.0f);
        o.u.y = changed ? 1u : 0u;
        break;
      }
      default:
        break;
    }
  }
  return out;
}

}  // namespace basalt::cpu
