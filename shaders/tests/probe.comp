#version 460
// Test probe: runs single shader functions on host-given inputs so that tests can compare
// them with the CPU reference (host/cpu/probe.cpp). One invocation per ProbeIn entry; the
// number of entries is pc.pixel_count. Compiled with FEATURES all ones (the default).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

#include "include/bindings.glsl"
#include "include/integrator.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Pass {
  PassConstants pc;
};

layout(std430, set = 0, binding = BINDING_PROBE_IN) restrict readonly buffer ProbeInBuffer {
  ProbeIn probe_in[];
};
layout(std430, set = 0, binding = BINDING_PROBE_OUT) restrict writeonly buffer ProbeOutBuffer {
  ProbeOut probe_out[];
};

// Closest hit as (t, b1, b2, 0); t = -1 for a miss.
vec4 hit_record(Hit h) { return vec4(h.prim == INVALID_INDEX ? -1.0 : h.t, h.b1, h.b2, 0.0); }

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= pc.pixel_count) return;
  ProbeIn q = probe_in[i];
  ProbeOut r = ProbeOut(vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0), uvec4(0u));
  Ray ray = Ray(q.o_tmax.xyz, q.o_tmax.w, q.d.xyz);
  switch (q.key.x) {
    case PROBE_CLOSEST: {
      Hit h = intersect_closest(ray);
      r.f0 = hit_record(h);
      r.u.x = h.prim;
      break;
    }
    case PROBE_OCCLUDED:
      r.u.x = intersect_any(ray) ? 1u : 0u;
      break;
    case PROBE_RESPAWN: {
      Hit h = intersect_closest(ray);
      r.f0 = hit_record(h);
      r.u.x = h.prim;
      r.f1 = vec4(-1.0, 0.0, 0.0, 0.0);
      r.u.y = INVALID_INDEX;
      if (h.prim != INVALID_INDEX) {
        SurfacePoint sp = surface_point(ray, h);
        Hit h2 = intersect_closest(spawn_ray(sp.p, sp.ng, sp.m, q.extra.xyz));
        r.f1 = hit_record(h2);
        r.u.y = h2.prim;
      }
      break;
    }
    case PROBE_RNG:
      r.f0.x = rng(q.key.y, q.key.z, q.key.w, floatBitsToUint(q.extra.x));
      break;
    case PROBE_CAMERA: {
      CameraRay cr = camera_ray(q.key.y, q.key.z, q.key.w);
      r.f0 = vec4(cr.o, 0.0);
      r.f1 = vec4(cr.d, 0.0);
      break;
    }
    case PROBE_CAMERA_DIFF: {
      CameraRay cr = camera_ray(q.key.y, q.key.z, q.key.w);
      r.f0 = vec4(cr.rx_d, 0.0);
      r.f1 = vec4(cr.ry_d, 0.0);
      break;
    }
    case PROBE_BSDF: {
      // One BSDF query in a shading frame equal to the world frame (docs/materials-spec.md
      // section 6); streams of pixel (key.z, key.w), sample 0, dims 7..10, seed 0.
      SurfacePoint sp;
      sp.p = vec3(q.o_tmax.w, q.d.w, q.extra.w);
      sp.material = q.key.y;
      sp.ng = q.extra2.xyz;
      sp.light = INVALID_INDEX;
      sp.ns = vec3(0.0, 0.0, 1.0);
      sp.m = 0.0;
      sp.t1 = vec3(1.0, 0.0, 0.0);
      sp.t2 = vec3(0.0, 1.0, 0.0);
      vec3 wo = q.o_tmax.xyz, wi = q.d.xyz, ng = q.extra2.xyz;
      Bsdf b = bsdf_at(q.key.y, sp, wo);
      uint px = q.key.z, py = q.key.w;
      // eval (stream dim 7), pdf (8), sample (9), pdf at the sampled wi (10), through one
      // bsdf_query call site (code size, see bsdf_query).
      BsdfSample bs = no_sample();
      [[dont_unroll]] for (uint step = 0u; step < 4u; ++step) {
        uint op = step == 2u ? QUERY_SAMPLE : (step == 0u ? QUERY_F : QUERY_PDF);
        if (step == 3u && bs.flags == 0u) break;
        BsdfQuery res = bsdf_query(b, op, wo, step == 3u ? bs.wi : wi, q.extra.xyz, ng,
                                   stream_key_seeded(px, py, 0u, 7u + step, 0u));
        if (step == 0u) r.f0.xyz = res.f;
        else if (step == 1u) r.f0.w = res.pdf;
        else if (step == 2u) bs = res.bs;
        else r.f3.x = res.pdf;
      }
      r.f1 = vec4(bs.f, bs.pdf);
      r.f2 = vec4(bs.wi, bs.eta);
      r.f3.y = float(b.n);
      r.u = uvec4(bs.flags, bsdf_flags(b), bs.pdf_is_proportional ? 1u : 0u,
                  b.n > 0u ? bsdf_lobe(0u).tag : 0u);
      break;
    }
    default:
      break;
  }
  probe_out[i] = r;
}
