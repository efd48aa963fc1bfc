// Unidirectional path tracer with next-event estimation and MIS (docs/path-spec.md
// section 7, pbrt-v4 13.4 PathIntegrator::Li). Needs bindings.glsl.
#ifndef BASALT_INTEGRATOR_GLSL
#define BASALT_INTEGRATOR_GLSL

#include "math.glsl"
#include "rng.glsl"
#include "sampler.glsl"
#include "sampling.glsl"
#include "intersect.glsl"
#include "surface.glsl"
#include "camera.glsl"
#include "lights.glsl"
#include "bsdf.glsl"

// The MIS weight of a light sample (density pl) against BSDF density pb under
// globals.render_opts.y (path-spec 7.1).
float mis_light(float pl, float pb) {
  uint mode = globals.render_opts.y;
  if (mode == MIS_LIGHT_ONLY) return 1.0;
  return mode == MIS_BALANCE ? balance_heuristic(pl, pb) : power_heuristic(pl, pb);
}

// The MIS weight of a BSDF-sampled hit on a light (BSDF density pb, light density pl) under
// globals.render_opts.y (path-spec 7.1).
float mis_bsdf(float pb, float pl) {
  uint mode = globals.render_opts.y;
  if (mode == MIS_BSDF_ONLY) return 1.0;
  if (mode == MIS_LIGHT_ONLY) return 0.0;
  return mode == MIS_BALANCE ? balance_heuristic(pb, pl) : power_heuristic(pb, pl);
}

// Radiance of an escaped ray of direction d from the infinite lights (uniform and
// environment maps, through the one infinite_light_le call site), MIS-weighted against light
// sampling unless the previous vertex could not sample lights (camera or specular).
vec3 escaped_radiance(vec3 o, vec3 d, vec3 p_prev, bool unweighted, float pdf_prev) {
  vec3 L = vec3(0.0);
  if (has_feature(FEATURE_LIGHT_INFINITE | FEATURE_LIGHT_INFINITE_IMAGE)) {
    uint n = min(globals.counts.y, MAX_INFINITE_LIGHTS);
    uint k = 0u;  // the end tested at the end of a pass (see path_bounce's BSDF loop)
    if (n > 0u) [[dont_unroll]] while (true) {
      uint li = globals.infinite_lights[k];
      float pl;
      vec3 Le = infinite_light_le(li, o, p_prev, d, pl);
      float w = unweighted ? 1.0 : mis_bsdf(pdf_prev, pl);
      L += w * Le;
      if (++k >= n) break;
    }
  }
  return L;
}

// Whether paths carry ray differentials (textures-spec 3): only the texture footprint reads
// them. A constant, so that the code under `RAY_DIFFS && ps.has_diff` goes with the
// specialisation (has_diff alone is path state, which it cannot prove false).
#ifdef BASALT_PLAIN
const bool RAY_DIFFS = false;  // no textures in the plain builds (see BUMP_ENABLED)
#else
const bool RAY_DIFFS = feature_const(FEATURE_TEXTURES);
#endif

// The state of one path between bounces: everything path_bounce reads and writes (the
// megakernel keeps it in registers, the wavefront stages in a storage buffer between
// dispatches, shaders/wavefront.comp).
struct PathState {
  Ray ray;          // the ray to trace next
  vec3 L;           // radiance gathered so far
  vec3 beta;        // path throughput
  bool specular;    // the last bounce was specular (no MIS on an emitter it hits)
  float pdf_prev;   // the last BSDF sample's density (MIS of an emitter it hits)
  float eta_scale;  // pbrt-v4 etaScale (Russian roulette)
  vec3 p_prev;      // the previous vertex: position, geometric and (bumped) shading normal,
  vec3 ng_prev;     //   magnitude bound (light_pdf and light_pick_pmf of an emitter hit)
  vec3 ns_prev;
  float m_prev;
  uint depth;       // bounces so far
  uint crossings;   // interfaces passed through
  bool has_diff;    // rd is valid
  RayDiff rd;       // the ray's differentials (docs/textures-spec.md 3.1)
  uint px, py, s;   // the sample: pixel and sample index
  uint rays;        // rays traced (camera, continuation and shadow rays)
};

// The path of sample s of pixel (px, py) before its first intersection: the camera ray (with
// its differentials, scaled by max(1/8, 1/sqrt(spp)), docs/textures-spec.md 3.1).
PathState path_start(uint px, uint py, uint s) {
  // The differential rays feed the texture footprint alone (textures-spec 3): without
  // textures no path uses them, and they are not traced.
  CameraRay cr = camera_ray(px, py, s, RAY_DIFFS);
  PathState ps;
  ps.ray = Ray(cr.o, FLT_MAX, cr.d);
  ps.L = vec3(0.0);
  ps.beta = vec3(1.0);
  ps.specular = false;
  ps.pdf_prev = 0.0;
  ps.eta_scale = 1.0;
  ps.p_prev = ps.ray.o;
  ps.ng_prev = vec3(0.0);
  ps.ns_prev = vec3(0.0);
  ps.m_prev = 0.0;
  ps.depth = 0u;
  ps.crossings = 0u;
  ps.has_diff = RAY_DIFFS;
  ps.rd = RayDiff(cr.rx_o, cr.rx_d, cr.ry_o, cr.ry_d);
  if (RAY_DIFFS) ps.rd = scale_differentials(ps.rd, cr.o, cr.d, globals.min_dir_dx.w);
  ps.px = px;
  ps.py = py;
  ps.s = s;
  ps.rays = 0u;
  return ps;
}

// The path's ray escaped: adds the infinite lights' radiance along it (the path ends).
void path_escape(inout PathState ps) {
  ps.L += ps.beta * escaped_radiance(ps.ray.o, ps.ray.d, ps.p_prev,
                                     ps.depth == 0u || ps.specular, ps.pdf_prev);
}

// One vertex of the path at its ray's closest hit `hit` (docs/path-spec.md section 7 with
// the changes of docs/materials-spec.md section 5: interface pass-through, per-bounce streams
// for the stochastic lobes, NEE when a lobe is non-specular, proportional pdfs, etaScale in
// Russian roulette, the light-leak rule through the local geometric normal): emission, NEE
// with its shadow ray, the BSDF sample and Russian roulette. Returns true if the path goes
// on along ps.ray, false if it ends here.
bool path_bounce(inout PathState ps, Hit hit) {
  uint px = ps.px, py = ps.py, s = ps.s;
  uint max_depth = globals.image.z;
  uint num_lights = globals.counts.x;
  // The footprint from the ray's differentials, else approximated (textures-spec 3).
  SurfacePoint sp = surface_point(ps.ray, hit, ps.has_diff, ps.rd);
  vec3 wo = -ps.ray.d;

  // Emission of an area light hit by the path.
  if (has_feature(FEATURE_LIGHT_AREA) && sp.light != INVALID_INDEX) {
    vec3 Le = area_le(sp.light, sp.ng, wo);
    if (any_positive(Le)) {
      float w = 1.0;
      if (!(ps.depth == 0u || ps.specular)) {
        float pl = light_pick_pmf(sp.light, num_lights, ps.p_prev, ps.ns_prev) *
                   light_pdf(sp.light, ps.p_prev, ps.ng_prev, ps.m_prev, sp.p, sp.ng, ps.ray.d);
        w = mis_bsdf(ps.pdf_prev, pl);
      }
      ps.L += ps.beta * w * Le;
    }
  }

  // Interface (no surface): the path passes through with depth unchanged (pbrt-v4
  // PathIntegrator's SkipIntersection; at most 64 crossings).
  // The BSDF (mixes resolved; lobes only if the path goes on from here). A bump or normal
  // map or vector turbulence of the chosen material replaces sp's shading normal and frame
  // (docs/bump-spec.md 6, 9), which the local frame, the cosines and the specular
  // differentials below use.
  Bsdf bsdf = bsdf_at(sp.material, sp, wo, ps.depth < max_depth);
  if ((BUMP_ENABLED || NORMALMAP_ENABLED || VTURB_ENABLED) && bsdf_bumped) {
    sp.ns = bsdf_frame.ns;
    sp.t1 = bsdf_frame.t1;
    sp.t2 = bsdf_frame.t2;
  }
#if BSDF_ALL_MATERIALS
  if (has_feature(FEATURE_MAT_INTERFACE) && bsdf.type == MATERIAL_INTERFACE) {
    if (ps.crossings == 64u) return false;
    ++ps.crossings;
    ps.specular = true;
    ps.ray = spawn_ray(sp.p, sp.ng, sp.m, ps.ray.d);
    if (RAY_DIFFS && ps.has_diff) {  // pbrt-v4 SkipIntersection: the differential origins move to the hit
      ps.rd.rx_o = point_along(ps.rd.rx_o, ps.rd.rx_d, hit.t);
      ps.rd.ry_o = point_along(ps.rd.ry_o, ps.rd.ry_d, hit.t);
    }
    return true;
  }
#endif
  if (ps.depth == max_depth) return false;
  uint dim = DIM_BOUNCE_BASE + DIM_BOUNCE_STRIDE * ps.depth;
  ++ps.depth;

  vec3 wo_l = to_local(sp, wo);
  // The light-leak rule's geometric normal (materials-spec 1.2); with SHADEOPT_PBRT_V4_SIDES
  // the shading normal stands in for it, so the shading frame alone decides, as in pbrt-v4.
  vec3 ng_l = (globals.texture_opts.w & SHADEOPT_PBRT_V4_SIDES) != 0u ? vec3(0.0, 0.0, 1.0)
                                                                        : to_local(sp, sp.ng);

  // Next-event estimation (one light picked by light_cdf, MIS against BSDF sampling) and BSDF
  // sampling. The BSDF queries of the bounce run in one loop through one bsdf_query call
  // site (see bsdf_query2): step 0 NEE f (stream +7) and NEE pdf (+8) in one query, 2 sample
  // (+9), 3 pdf at the sampled wi when the sample's pdf is only proportional (+10).
  // Next-event estimation, unless the MIS mode samples the BSDF alone (path-spec 7.1).
  bool nee = has_feature(FEATURE_ANY_LIGHT) && num_lights > 0u &&
             (bsdf_flags(bsdf) & (BSDF_DIFFUSE | BSDF_GLOSSY)) != 0u &&
             globals.render_opts.y != MIS_BSDF_ONLY;
  BounceSamples us = bounce_samples(px, py, s, dim);
  LightSample ls;
  float pmf = 0.0;
  vec3 wi_l = vec3(0.0), f_nee = vec3(0.0);
  if (nee) {
    LightPick pick = light_pick(bounce_sample(us, px, py, s, dim, DIM_LIGHT_SELECT),
                                num_lights, sp.p, sp.ns);
    uint li = pick.li;
    pmf = pick.pmf;
    vec2 ul = vec2(bounce_sample(us, px, py, s, dim, DIM_LIGHT_U0),
                   bounce_sample(us, px, py, s, dim, DIM_LIGHT_U1));
    ls = light_sample(li, sp.p, sp.ng, sp.m, ul);
    nee = ls.pdf > 0.0 && pmf > 0.0 && any_positive(ls.Li);
    if (nee) wi_l = to_local(sp, ls.wi);
  }
  vec3 ub = vec3(bounce_sample(us, px, py, s, dim, DIM_BSDF_LOBE),
                 bounce_sample(us, px, py, s, dim, DIM_BSDF_U0),
                 bounce_sample(us, px, py, s, dim, DIM_BSDF_U1));
  BsdfSample bs = no_sample();
  float pdf_nee = 0.0;
  // The loop's end is tested at the end of a pass (lavapipe runs a pass that any lane enters
  // in full: a `for` loop's closing test cost a whole pass, docs/performance.md).
  uint step = nee ? 0u : 2u;
  [[dont_unroll]] while (true) {
    // Step 0 asks f and pdf of the NEE direction in one query, each from its own stream (+7,
    // +8), so step 1 has no pass of its own (lavapipe runs every lobe's f, pdf and sample code
    // in each pass of this loop).
    uint op = step == 2u ? QUERY_SAMPLE : (step == 0u ? (QUERY_F | QUERY_PDF) : QUERY_PDF);
    vec3 wq = step == 3u ? bs.wi : wi_l;
#if BSDF_ALL_MATERIALS
    uvec4 stream = stream_key(px, py, s, dim + DIM_NEE_EVAL_STREAM + step);
    uvec4 pdf_stream = step == 0u ? stream_key(px, py, s, dim + DIM_NEE_PDF_STREAM) : stream;
#else
    uvec4 stream = uvec4(0u);  // the lean variant has no stochastic lobe
    uvec4 pdf_stream = stream;
#endif
    BsdfQuery r = bsdf_query2(bsdf, op, wo_l, wq, ub, ng_l, stream, pdf_stream);
    if (step == 0u) {
      f_nee = r.f * abs(dot(ls.wi, sp.ns));
      pdf_nee = r.pdf;  // the MIS weight's, where f > 0 and the light is not a delta light
      step = 1u;
    } else if (step == 2u) {
      bs = r.bs;
      if (bs.flags == 0u) break;
      ps.pdf_prev = bs.pdf;
      if (!bs.pdf_is_proportional) break;
    } else {
      ps.pdf_prev = r.pdf;
    }
    ++step;
    if (step >= 4u) break;
  }
  // The shadow ray after the loop, not in its step 0: lavapipe runs a loop's body, and every
  // loop in it, on each of its steps whatever the lanes need (docs/performance.md).
  if (any_positive(f_nee)) {
    bool lit = !intersect_any(shadow_ray(sp.p, sp.ng, sp.m, ls));
    ++ps.rays;
    if (lit && ls.delta) {
      ps.L += ps.beta * f_nee * ls.Li / pmf;
    } else if (lit) {
      float pl = pmf * ls.pdf;
      ps.L += ps.beta * f_nee * ls.Li * mis_light(pl, pdf_nee) / pl;
    }
  }
  if (bs.flags == 0u || bs.pdf == 0.0 || !any_positive(bs.f) || bs.wi.z == 0.0) return false;
  vec3 wi = to_world(sp, bs.wi);
  ps.beta *= bs.f * abs(dot(wi, sp.ns)) / bs.pdf;
  ps.specular = (bs.flags & BSDF_SPECULAR) != 0u;
  if ((bs.flags & BSDF_TRANSMISSION) != 0u) ps.eta_scale *= bs.eta * bs.eta;
  ps.p_prev = sp.p;
  ps.ng_prev = sp.ng;
  ps.ns_prev = sp.ns;
  ps.m_prev = sp.m;
  // Differentials survive exactly-specular reflection and transmission only (3.1).
  uint kind = bs.flags & (BSDF_SPECULAR | BSDF_REFLECTION | BSDF_TRANSMISSION | BSDF_DIFFUSE |
                          BSDF_GLOSSY);
  bool spec_t = kind == (BSDF_SPECULAR | BSDF_TRANSMISSION);
  ps.ray = spawn_ray(sp.p, sp.ng, sp.m, wi);
  if (RAY_DIFFS && ps.has_diff && (spec_t || kind == (BSDF_SPECULAR | BSDF_REFLECTION)))
    ps.has_diff = specular_differentials(sp.tex, ps.ray.o, sp.ns, sp.dndu, sp.dndv, wo, wi,
                                         spec_t, bs.eta, ps.rd);
  else
    ps.has_diff = false;

  // Russian roulette on beta x etaScale (pbrt-v4 13.4.2) once the path has bounced more than
  // once, or as render_opts.x says (0: pbrt-v4's; N + 1: more than N times; path-spec 7.1).
  float bmax = max_component(ps.beta * ps.eta_scale);
  uint rr = globals.render_opts.x;
  if (bmax < 1.0 && rr != ROULETTE_OFF && ps.depth > (rr == 0u ? 1u : rr - 1u)) {
    float q = max(0.0, 1.0 - bmax);
    if (bounce_sample(us, px, py, s, dim, DIM_ROULETTE) < q) return false;
    ps.beta /= 1.0 - q;
  }
  return true;
}

// Radiance estimate of sample s of pixel (px, py): one path, traced to its end by
// path_bounce (the megakernel's loop). rays is incremented by the number of rays traced
// (camera, continuation and shadow rays).
vec3 path_radiance(uint px, uint py, uint s, inout uint rays) {
  PathState ps = path_start(px, py, s);
  while (true) {
    Hit hit = intersect_closest(ps.ray);
    ++ps.rays;
    if (hit.prim == INVALID_INDEX) {
      path_escape(ps);
      break;
    }
    if (!path_bounce(ps, hit)) break;
  }
  rays += ps.rays;
  return ps.L;
}

#endif
