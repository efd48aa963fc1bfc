#version 460
// Test probe: runs single shader functions on host-given inputs so that tests can compare
// them with the CPU reference (host/cpu/probe.cpp). One invocation per ProbeIn entry; the
// number of entries is pc.pixel_count. Compiled with FEATURES all ones (the default).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

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

// k v per component, no fma (the synthetic dndu, dndv of PROBE_BUMP key.y = 1).
vec3 probe_scaled(float k, vec3 v) {
  precise vec3 r = k * v;
  return r;
}

// The perfectly specular bounce of PROBE_DIFFERENTIALS modes 2, 3 (layout.h): wo reflected
// about n, or refracted with relative IOR eta (pbrt-v4 Refract; eta becomes the etap used, 1
// for a reflection); 0 on total internal reflection.
vec3 probe_bounce(vec3 wo, vec3 n, bool refract, inout float eta) {
  if (!refract) {
    eta = 1.0;
    float cos_i = dot_exact(wo, n);
    precise vec3 w = 2.0 * cos_i * n - wo;
    return w;
  }
  vec3 wt;
  float etap;
  if (!refract_v4(wo, n, eta, etap, wt)) return vec3(0.0);
  eta = etap;
  return wt;
}

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
        SurfacePoint sp = surface_point(ray, h, false, RayDiff(vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0)));
        Hit h2 = intersect_closest(spawn_ray(sp.p, sp.ng, sp.m, q.extra.xyz));
        r.f1 = hit_record(h2);
        r.u.y = h2.prim;
      }
      break;
    }
    case PROBE_RNG:
      r.f0.x = rng(q.key.y, q.key.z, q.key.w, floatBitsToUint(q.extra.x));
      break;
    case PROBE_SAMPLER:
      r.f0.x = sampler_get(q.key.y, q.key.z, q.key.w, floatBitsToUint(q.extra.x));
      break;
    case PROBE_CAMERA: {
      CameraRay cr = camera_ray(q.key.y, q.key.z, q.key.w, true);
      r.f0 = vec4(cr.o, 0.0);
      r.f1 = vec4(cr.d, 0.0);
      break;
    }
    case PROBE_CAMERA_DIFF: {
      CameraRay cr = camera_ray(q.key.y, q.key.z, q.key.w, true);
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
      sp.tex = TexCtx(sp.p, sp.ng, vec2(0.0), vec3(0.0), vec3(0.0), 0.0, 0.0, 0.0, 0.0);
      vec3 wo = q.o_tmax.xyz, wi = q.d.xyz, ng = q.extra2.xyz;
      Bsdf b = bsdf_at(q.key.y, sp, wo, true);
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
    case PROBE_TEXTURE: {
      // tex_eval_rgb / tex_eval_float of texture key.y in a given context (layout.h).
      TexCtx c = TexCtx(q.o_tmax.xyz, q.d.xyz, vec2(q.o_tmax.w, q.d.w), q.extra.xyz,
                        q.extra2.xyz, q.extra.w, q.extra2.w, q.extra3.x, q.extra3.y);
      vec3 v = tex_eval_rgb(q.key.y, c);
      r.f0.xyz = q.key.z == 1u ? vec3(v.x) : v;
      break;
    }
    case PROBE_NOISE: {
      // Noise functions at p = o_tmax.xyz (layout.h): 0 Perlin, 1 Shirley's solid noise,
      // 2 fbm, 3 turbulence, 4 Shirley's turbulence with key.z octaves.
      vec3 p = q.o_tmax.xyz;
      if (q.key.y == 0u) r.f0.x = perlin_noise(p);
      else if (q.key.y == 1u || q.key.y == 4u)  // one call site: noise is the 1-octave plain sum
        r.f0.x = shirley_noise_sum(p, q.key.y == 4u ? int(q.key.z) : 1, q.key.y == 4u);
      else if (q.key.y == 2u || q.key.y == 3u)
        r.f0.x = noise_sum(p, q.d.xyz, q.extra.xyz, q.extra.w, int(q.key.z), q.key.y == 3u,
                           q.key.w == 1u);
      else if (q.key.y == 5u) {  // noise at lambda p, lambda = extra.w, split if key.w = 1
        precise vec3 hi = q.extra.w * p;
        vec3 lo = vec3(0.0);
        if (q.key.w == 1u) noise_two_prod(q.extra.w, p, hi, lo);
        r.f0.x = perlin_noise_hl(hi, lo);
      }
      break;
    }
    case PROBE_DIFFERENTIALS: {
      // Texture context at the first hit of the camera ray of pixel (key.z, key.w), sample
      // floatBitsToUint(extra.x): key.y = 0 with the camera ray's differentials, 1 approximated.
      // Modes 2, 3 (a perfectly specular bounce first) take a second pass of the loop; one
      // surface_point call site.
      CameraRay cr = camera_ray(q.key.z, q.key.w, floatBitsToUint(q.extra.x), true);
      Ray cam = Ray(cr.o, FLT_MAX, cr.d);
      RayDiff rd = scale_differentials(RayDiff(cr.rx_o, cr.rx_d, cr.ry_o, cr.ry_d), cr.o, cr.d,
                                       globals.min_dir_dx.w);
      bool has_diff = q.key.y != 1u;
      uint passes = q.key.y >= 2u ? 2u : 1u;
      [[dont_unroll]] for (uint k = 0u; k < passes; ++k) {
        Hit h = intersect_closest(cam);
        r.u.x = h.prim;
        if (h.prim == INVALID_INDEX) break;
        SurfacePoint sp = surface_point(cam, h, has_diff, rd);
        if (k + 1u == passes) {
          r.f0 = vec4(sp.tex.dpdx, sp.tex.dudx);
          r.f1 = vec4(sp.tex.dpdy, sp.tex.dudy);
          r.f2 = vec4(sp.tex.uv, sp.tex.dvdx, sp.tex.dvdy);
          r.f3 = vec4(sp.tex.p, 0.0);
          break;
        }
        // The bounce of layout.h PROBE_DIFFERENTIALS: reflection about ns, or pbrt-v4 Refract.
        vec3 wo = -cr.d;
        float eta = q.extra.y;
        vec3 wi = probe_bounce(wo, sp.ns, q.key.y == 3u, eta);
        if (wi.x == 0.0 && wi.y == 0.0 && wi.z == 0.0) {  // total internal reflection
          r.u.x = INVALID_INDEX;
          break;
        }
        cam = spawn_ray(sp.p, sp.ng, sp.m, wi);
        has_diff = specular_differentials(sp.tex, cam.o, sp.ns, sp.dndu, sp.dndv, wo, wi,
                                          q.key.y == 3u, eta, rd);
        r.u.y = has_diff ? 1u : 0u;
      }
      break;
    }
    case PROBE_BUMP: {
      // Shading geometry after bump_shading (docs/bump-spec.md 6) at the first hit of the
      // camera ray of pixel (key.z, key.w), sample floatBitsToUint(extra.x), with the camera
      // ray's differentials as the render uses them (layout.h PROBE_BUMP).
      SurfacePoint sp;
      vec3 wo;
      if (q.key.y == 1u) {
        // The synthetic surface point of layout.h PROBE_BUMP key.y = 1.
        sp.p = q.o_tmax.xyz;
        sp.material = q.key.z;
        sp.ng = q.d.xyz;
        sp.light = INVALID_INDEX;
        sp.ns = q.extra3.xyz;
        sp.m = 0.0;
        shading_frame(sp.ns, q.extra.xyz, sp.t1, sp.t2);
        sp.tex = TexCtx(sp.p, sp.ng, vec2(q.o_tmax.w, q.d.w), vec3(0.0), vec3(0.0), q.extra.w,
                        q.extra.w, q.extra2.w, q.extra2.w);
        sp.sdpdu = q.extra.xyz;
        sp.sdpdv = q.extra2.xyz;
        sp.dndu = probe_scaled(q.extra3.w, q.extra.xyz);
        sp.dndv = probe_scaled(q.extra3.w, q.extra2.xyz);
        wo = sp.ns;
        r.u.x = 0u;
      } else {
        CameraRay cr = camera_ray(q.key.z, q.key.w, floatBitsToUint(q.extra.x), true);
        Ray cam = Ray(cr.o, FLT_MAX, cr.d);
        RayDiff rd = scale_differentials(RayDiff(cr.rx_o, cr.rx_d, cr.ry_o, cr.ry_d), cr.o,
                                         cr.d, globals.min_dir_dx.w);
        Hit h = intersect_closest(cam);
        r.u.x = h.prim;
        if (h.prim == INVALID_INDEX) break;
        sp = surface_point(cam, h, true, rd);
        wo = -cr.d;
      }
      bsdf_at(sp.material, sp, wo, true);
      BumpFrame f = bsdf_bumped ? bsdf_frame : BumpFrame(sp.ns, sp.t1, sp.t2, sp.sdpdu, sp.sdpdv);
      r.f0 = vec4(f.ns, 0.0);
      r.f1 = vec4(f.dpdu, 0.0);
      r.f2 = vec4(f.dpdv, 0.0);
      r.f3 = vec4(f.t1, 0.0);
      r.u.y = bsdf_bumped ? 1u : 0u;
      break;
    }
    case PROBE_ENV: {
      // Image infinite light key.y (docs/textures-spec.md section 6) at world direction d:
      // Le and the plain pdf (f0), the compensated pdf (f3.x), and a sample with u = extra.xy
      // of the PLAIN distribution (pbrt-v4 allowIncompletePDF = false; the render shader
      // samples the compensated one). A failed sample reports wi, pdf and Le as 0.
      // The reference point (Le's ray origin, the pdf's and the sample's point) is
      // (d.w, extra.z, extra.w); only portals read it.
      uint li = q.key.y;
      vec3 ref = vec3(q.d.w, q.extra.zw);
      r.f0.xyz = env_le(li, q.d.xyz, ref);
      [[dont_unroll]] for (uint k = 0u; k < 2u; ++k) {  // one env_pdf call site
        float p = env_pdf(li, q.d.xyz, k == 1u, ref);
        if (k == 0u) r.f0.w = p; else r.f3.x = p;
      }
      vec3 env_wi, env_le_s;
      float env_p;
      env_sample(li, q.extra.xy, false, ref, env_wi, env_p, env_le_s);
      r.f1 = vec4(env_wi, env_p);
      r.f2 = vec4(env_le_s, 0.0);
      break;
    }
    default:
      break;
  }
  probe_out[i] = r;
}
