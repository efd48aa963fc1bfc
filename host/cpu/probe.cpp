// CPU twin of shaders/tests/probe.comp: answers probe queries (layout.h PROBE_*).
#include "cpu/probe.h"

#include <bit>
#include <cfloat>

#include "cpu/bsdf.h"
#include "cpu/camera.h"
#include "cpu/intersect.h"
#include "cpu/rng.h"
#include "cpu/surface.h"

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
      default:
        break;
    }
  }
  return out;
}

}  // namespace basalt::cpu
