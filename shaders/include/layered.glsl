// pbrt-v4 LayeredBxDF<DielectricBxDF, DiffuseBxDF | ConductorBxDF, twoSided = true>
// (CoatedDiffuseBxDF, CoatedConductorBxDF): f, Sample_f and PDF by random walks between a
// dielectric top interface and a diffuse or conductor bottom, with an optional homogeneous
// Henyey-Greenstein medium between them (docs/materials-spec.md section 2.3, LAYERED_*). No
// recursion: the two interfaces are plain functions of the lobe's parameters. pbrt-v4's r() is
// the stream of docs/materials-spec.md section 5 (element j = j-th call; calls in argument
// lists are taken left to right). Two deliberate deviations (docs/materials-spec.md 2.3): f's
// exit MIS weight uses the NEE strategy's own density, and Sample_f rescales its (f, pdf)
// products by powers of two. Needs bindings.glsl and rng.glsl.
#ifndef BASALT_LAYERED_GLSL
#define BASALT_LAYERED_GLSL

#include "lobes.glsl"
#include "rng.glsl"

// The parameters of a layered lobe (Lobe.p0..p3, aux).
struct Layers {
  float eta;        // top interface IOR
  MfDist top;       // top interface roughness
  bool conductor;   // bottom: conductor (else diffuse)
  vec3 bottom_a;    // diffuse R, or conductor eta
  vec3 bottom_k;    // conductor k
  MfDist bottom;    // conductor roughness
  float thickness;  // max(thickness, FLT_MIN)
  vec3 albedo;      // medium albedo (0: no medium)
  float g;          // HG asymmetry
  int max_depth;
  int n_samples;
  bool pbrt_mis;    // pbrt-v4's exit MIS weights in f (docs/materials-spec.md 2.3)
};

// Unpacks a LAYERED_* lobe.
Layers layers_of(Lobe L) {
  bool beck = (L.bits & LOBEBIT_BECKMANN) != 0u;
  return Layers(L.p0.z, MfDist(L.p0.x, L.p0.y, beck), L.tag == LOBE_LAYERED_CONDUCTOR,
                L.p2.xyz, L.p3.xyz, MfDist(L.p2.w, L.p3.w, beck), max(L.p0.w, 1.17549435e-38),
                L.p1.xyz, L.p1.w, int(L.aux & 0xffffu), int(L.aux >> 16u),
                (L.bits & LOBEBIT_PBRT_MIS) != 0u);
}

// The next n (1 to 3, a constant at each call) elements of the walk's random stream (pbrt-v4's
// r(), called n times): n copies of the hash, not a loop around one, which lavapipe would enter
// at every call whatever the lanes need (walks 10% faster on coated-rough, docs/performance.md).
vec3 layer_rn(uvec4 key, inout uint j, uint n) {
  vec3 r = vec3(stream_at(key, j), n > 1u ? stream_at(key, j + 1u) : 0.0,
                n > 2u ? stream_at(key, j + 2u) : 0.0);
  j += n;
  return r;
}

// BSDF_* flags of pbrt-v4 LayeredBxDF::Flags (top: dielectric; bottom never transmits).
uint layered_flags(Layers y) {
  uint flags = BSDF_REFLECTION;
  bool top_smooth = mf_smooth(y.top);
  if (top_smooth) flags |= BSDF_SPECULAR;
  bool bottom_diffuse = !y.conductor && nonzero(y.bottom_a);
  bool bottom_glossy = y.conductor && !mf_smooth(y.bottom);
  if (bottom_diffuse || nonzero(y.albedo)) flags |= BSDF_DIFFUSE;
  else if (!top_smooth || bottom_glossy) flags |= BSDF_GLOSSY;
  return flags;
}

// pbrt-v4 IsSpecular(bottom.Flags()).
bool bottom_specular(Layers y) { return y.conductor && mf_smooth(y.bottom); }

// pbrt-v4 IsNonSpecular(bottom.Flags()).
bool bottom_nonspecular(Layers y) { return y.conductor ? !mf_smooth(y.bottom) : nonzero(y.bottom_a); }

// The diffuse bottom (pbrt-v4 DiffuseBxDF): Sample_f (smp; reflection, the only kind it has)
// or f and PDF at (wo, wi), in a BsdfSample as mf_interface_query.
BsdfSample diffuse_bottom_query(Layers y, vec3 wo, vec3 wi, vec2 u, bool smp) {
  BsdfSample r = no_sample();
  if (no_feature(FEATURE_MAT_COATED_DIFFUSE) || y.conductor) return r;
  if (smp) return diffuse_sample(y.bottom_a * INV_PI, wo, u);
  if (same_hemisphere(wo, wi)) {
    r.f = y.bottom_a * INV_PI;
    r.pdf = cosine_pdf(wi);
  }
  return r;
}

// Sample_f (smp) or f and PDF of the top (pbrt-v4 DielectricBxDF, sample flags sflags) or the
// bottom interface (sampling it without SAMPLE_R gives none), in a BsdfSample as
// mf_interface_query. The walks call it from one site each; with coated conductors in the scene
// the top and the conductor bottom share one mf_interface_query (one microfacet sample and
// evaluation where lavapipe ran both interfaces': docs/performance.md, sixteenth session).
BsdfSample layer_query(Layers y, bool top, vec3 wo, vec3 wi, float uc, vec2 u, bool smp,
                       bool radiance, uint sflags) {
  if (!top && smp && (sflags & SAMPLE_R) == 0u) return no_sample();
  bool conductor = !top && y.conductor;
  if (!top && !(has_feature(FEATURE_MAT_COATED_CONDUCTOR) && conductor))
    return diffuse_bottom_query(y, wo, wi, u, smp);
  if (no_feature(FEATURE_MAT_COATED_CONDUCTOR))
    return dielectric_query(y.eta, y.top, wo, wi, uc, u, smp, radiance, sflags);
  return mf_interface_query(conductor, y.eta, y.bottom_a, y.bottom_k, top ? y.top : y.bottom, wo,
                            wi, uc, u, smp, radiance, sflags);
}

// pbrt-v4's validity test of an interface sample inside the walk (lobes.glsl usable).
bool walk_sample_ok(BsdfSample bs) { return usable(bs); }

// pbrt-v4 LayeredBxDF::Tr: transmittance exp(-|dz / w.z|) of a slab of height dz (1 if dz is
// at most FLT_MIN).
precise float layer_tr(float dz, vec3 w) {
  if (abs(dz) <= 1.17549435e-38) return 1.0;
  return exp(-abs(dz / w.z));
}

// pbrt-v4 HenyeyGreenstein(cos, g), g clamped to [-0.99, 0.99] as there.
precise float henyey_greenstein(float cos_t, float g) {
  g = clamp(g, -0.99, 0.99);  // pbrt-v4 clamps here too: |g| -> 1 is a delta, not a lobe
  float denom = 1.0 + g * g + 2.0 * g * cos_t;
  return INV_4PI * (1.0 - g * g) / (denom * safe_sqrt(denom));
}

// pbrt-v4 HGPhaseFunction::p(wo, wi) = HenyeyGreenstein(dot(wo, wi), g).
float hg_p(vec3 wo, vec3 wi, float g) { return henyey_greenstein(dot_exact(wo, wi), g); }

// pbrt-v4 SampleHenyeyGreenstein(wo, g, u): wi about wo's Duff frame, pdf = p (g clamped to
// [-0.99, 0.99]).
vec3 hg_sample(vec3 wo, float g, vec2 u, out float pdf) {
  g = clamp(g, -0.99, 0.99);
  precise float cos_t;
  if (abs(g) < 1e-3) {
    cos_t = 1.0 - 2.0 * u.x;
  } else {
    precise float t = (1.0 - g * g) / (1.0 + g - 2.0 * g * u.x);
    cos_t = -1.0 / (2.0 * g) * (1.0 + g * g - t * t);
  }
  precise float sin_t = safe_sqrt(1.0 - cos_t * cos_t);
  precise float phi = 2.0 * PI * u.y;
  vec3 t1, t2;
  duff_frame(wo, t1, t2);
  // pbrt-v4 SphericalDirection (clamped) in the frame, Frame::FromLocal
  precise float s = clamp(sin_t, -1.0, 1.0);
  vec2 cs = cos_sin_accurate(phi);
  precise vec3 wi = (s * cs.x) * t1 + (s * cs.y) * t2 + clamp(cos_t, -1.0, 1.0) * wo;
  pdf = henyey_greenstein(cos_t, g);
  return wi;
}

// pbrt-v4 PowerHeuristic(1, f, 1, g) (0 when both are 0, 1 when f^2 overflows).
float layer_power(float f, float g) { return power_heuristic(f, g); }

// The height after a free flight along w from z (pbrt-v4's dz = SampleExponential(u,
// sigma_t / |w.z|), sigma_t = 1), for f's walk. (A function of its own, as layer_pdf_mix:
// glslang's precise propagation through f's event loop exhausts memory.)
precise float layer_step_z(float z, vec3 w, float u) {
  float sigma_t = 1.0;
  float dz = -log(1.0 - u) / (sigma_t / abs(w.z));
  return w.z > 0.0 ? (z + dz) : (z - dz);
}

// pbrt-v4 LayeredBxDF::f (radiance mode) with random numbers from stream `key`. Two-sided:
// wo below is mirrored; light entering through the top can only leave through it (the bottom
// does not transmit), so f is 0 for wi on the other side (pbrt-v4's estimate is 0 there too).
vec3 layered_f(Lobe L, vec3 wo, vec3 wi, uvec4 key) {
  if (wo.z < 0.0) {
    wo = -wo;
    wi = -wi;
  }
  if (!same_hemisphere(wo, wi)) return vec3(0.0);
  Layers y = layers_of(L);
  bool top_spec = mf_smooth(y.top), bot_spec = bottom_specular(y);
  bool has_albedo = nonzero(y.albedo);
  float exit_z = y.thickness;  // the exit interface is the top
  uint j = 0u;
  vec3 f = vec3(0.0);
  // The loops below test their end at the end of a pass, not at the start of the next: lavapipe
  // runs a pass that any lane enters in full, so a `for` loop's closing test cost a whole pass
  // of its body (docs/performance.md, seventh session). Their `continue`s are ifs for the same
  // reason (a `continue` jumps to the test).
  int s = 0;
  if (y.n_samples > 0) [[dont_unroll]] while (true) {
    // Step -1 is the entrance, through the same event loop (and the same layer_query call
    // site, so a pipeline inlines one interface fewer) as the walk's steps: e = -3 (first
    // sample only), reflection at the entrance, nSamples f_top(wo, wi); e = -2, -1,
    // transmission through the top for wo (radiance) and for wi (importance).
    BsdfSample wos, wis;
    vec3 beta = vec3(0.0);
    float z = y.thickness;
    vec3 w = vec3(0.0);
    int depth = -1;
    [[dont_unroll]] while (true) {
      // NEE through the top along w after a scattering event: exit_nee (done at e = 2 below).
      bool exit_nee = false, exit_mis = true;
      float exit_pdf_s = 0.0, exit_dz = 0.0;
      vec3 exit_w = vec3(0.0);
      bool scattered = false;
      bool next = false;  // pbrt-v4's `continue`: on to the next step
      if (depth < 0) {
      } else if (!has_albedo) {
        z = (z == y.thickness) ? 0.0 : y.thickness;
        beta *= layer_tr(y.thickness, w);
      } else {
        float zp = layer_step_z(z, w, layer_rn(key, j, 1u).x);
        if (z == zp) {
          next = true;
        } else if (0.0 < zp && zp < y.thickness) {
          // Scattering in the medium: NEE along the presampled wis through the top.
          float wt = 1.0;
          float ph = hg_p(-w, -wis.wi, y.g);
          if (!top_spec) wt = layer_power(wis.pdf, ph);
          f += beta * y.albedo * ph * wt * layer_tr(zp - exit_z, wis.wi) * wis.f / wis.pdf;
          vec3 ur = layer_rn(key, j, 2u);
          float ps_pdf;
          vec3 ps_wi = hg_sample(-w, y.g, ur.xy, ps_pdf);
          if (ps_pdf == 0.0 || ps_wi.z == 0.0) {
            next = true;
          } else {
            beta *= y.albedo * ps_pdf / ps_pdf;
            w = ps_wi;
            z = zp;
            if (((z < exit_z && w.z > 0.0) || (z > exit_z && w.z < 0.0)) && !top_spec) {
              exit_nee = true;
              exit_pdf_s = ps_pdf;
              exit_dz = zp - exit_z;
              exit_w = ps_wi;
            }
            scattered = true;
          }
        } else {
          z = clamp(zp, 0.0, y.thickness);
        }
      }
      bool stop = false;
      if (!next) {
        // The interface events of this step, through one layer_query call site: the
        // entrance's (e < 0, above); e = 0, NEE along the presampled wis at the bottom; e = 1,
        // sampling the interface at z (reflection); e = 2, 3, NEE through the top towards wi
        // along the new w: e = 2, the density with which the wis strategy produces -w,
        // PDF(wi, -w) in importance mode (MIS weight; pbrt-v4 uses PDF(-w, wi), see
        // docs/materials-spec.md 2.3), e = 3, f(-w, wi).
        bool at_exit = z == exit_z;
        float exit_pdf = 0.0;
        int e = depth < 0 ? (s == 0 ? -3 : -2) : (scattered ? 2 : 0);
        [[dont_unroll]] while (true) {
          bool skip = (e == 0 && (at_exit || bot_spec)) || (e >= 2 && !exit_nee) ||
                      (e == 2 && !exit_mis);
          if (!skip) {
            bool entrance = e < 0;
            vec3 ur = (e == 1 || e == -2 || e == -1) ? layer_rn(key, j, 3u) : vec3(0.0);
            // e = 2 with --layered-mis pbrt-v4: pbrt-v4's PDF(-w, wi) in radiance mode instead.
            bool nee_pdf = e == 2 && !y.pbrt_mis;
            vec3 qwo = entrance ? (e == -1 ? wi : wo) : (nee_pdf ? wi : -w);
            vec3 qwi = entrance ? wi : (e == 0 ? -wis.wi : (nee_pdf ? -w : wi));
            bool smp = entrance ? e >= -2 : e == 1;
            bool radiance = entrance ? e != -1 : !nee_pdf;
            uint fl = entrance ? (e == -3 ? SAMPLE_ALL : SAMPLE_T) : (e >= 2 ? SAMPLE_T : SAMPLE_R);
            BsdfSample t = layer_query(y, entrance || e >= 2 || (e == 1 && at_exit), qwo, qwi,
                                       ur.x, ur.yz, smp, radiance, fl);
            if (e == -3) {
              f = float(y.n_samples) * vec3(t.f.x);
            } else if (entrance) {
              if (!walk_sample_ok(t)) {
                stop = true;
                break;
              }
              if (e == -2) wos = t;
              else wis = t;
            } else if (e == 0) {
              float wt = 1.0;
              if (!top_spec) wt = layer_power(wis.pdf, t.pdf);
              f += beta * t.f * abs(wis.wi.z) * wt * layer_tr(y.thickness, wis.wi) * wis.f /
                   wis.pdf;
            } else if (e == 1) {
              if (!walk_sample_ok(t)) {
                stop = true;
                break;
              }
              beta *= t.f * abs(t.wi.z) / t.pdf;
              w = t.wi;
              if (!at_exit && !top_spec) {
                exit_nee = true;
                exit_mis = !bot_spec;
                exit_pdf_s = t.pdf;
                exit_dz = y.thickness;
                exit_w = t.wi;
              }
            } else if (e == 2) {
              exit_pdf = t.pdf;
            } else {
              float f_exit = t.f.x;
              if (f_exit != 0.0) {
                float wt = 1.0;
                if (exit_mis) wt = layer_power(exit_pdf_s, exit_pdf);
                f += beta * layer_tr(exit_dz, exit_w) * f_exit * wt;
              }
            }
          }
          ++e;
          if ((depth < 0 && e == 0) || e >= 4 || (e >= 2 && !exit_nee)) break;
        }
      }
      if (stop) break;
      if (depth < 0) {
        // Into the slab along the sampled transmission (pbrt-v4's walk start).
        beta = wos.f * abs(wos.wi.z) / wos.pdf;
        w = wos.wi;
      }
      ++depth;
      if (depth >= y.max_depth) break;
      // Russian roulette for the next step (pbrt-v4's at its start: the same draw, in order)
      if (depth > 3 && max_component(beta) < 0.25) {
        float q = max(0.0, 1.0 - max_component(beta));
        if (layer_rn(key, j, 1u).x < q) break;
        beta /= 1.0 - q;
      }
    }
    ++s;
    if (s >= y.n_samples) break;
  }
  return y.n_samples > 0 ? f / float(y.n_samples) : vec3(0.0);  // pbrt-v4: 0 / 0
}

// Rescales Sample_f's (f, pdf) by one power of two (exact: f / pdf keeps every bit) to pdf in
// [0.5, 1) when pdf leaves [2^-32, 2^32], so that a long walk over sharp lobes neither
// overflows (f = pdf = inf) nor underflows (docs/materials-spec.md 2.3; the pdf is proportional).
void layer_renormalize(inout vec3 f, inout float pdf) {
  if (!(pdf > 4294967296.0 || pdf < 2.3283064365386963e-10) || pdf == 0.0) return;
  int e;
  frexp(pdf, e);
  f = ldexp(f, ivec3(-e));
  pdf = ldexp(pdf, -e);
}

// pbrt-v4 LayeredBxDF::Sample_f (radiance mode): the first interface sample (step -1) uses
// (uc, u), the walk the stream `key`; pdf_is_proportional on every sample.
BsdfSample layered_sample(Lobe L, vec3 wo, float uc, vec2 u, uvec4 key) {
  bool flip_wi = false;
  if (wo.z < 0.0) {
    wo = -wo;
    flip_wi = true;
  }
  Layers y = layers_of(L);
  uint j = 0u;
  vec3 w = -wo;  // step -1 samples the top at -w = wo
  bool specular_path = false;
  precise vec3 f = vec3(1.0);
  precise float pdf = 1.0;
  float z = y.thickness;
  bool has_albedo = nonzero(y.albedo);
  for (int depth = -1; depth < y.max_depth; ++depth) {
    vec3 ur = vec3(uc, u);
    if (depth >= 0) {
      layer_renormalize(f, pdf);
      precise float rr_beta = max_component(f) / pdf;
      if (depth > 3 && rr_beta < 0.25) {
        float q = max(0.0, 1.0 - rr_beta);
        if (layer_rn(key, j, 1u).x < q) return no_sample();
        pdf *= 1.0 - q;
      }
      if (w.z == 0.0) return no_sample();
      if (has_albedo) {
        float sigma_t = 1.0;
        precise float dz = -log(1.0 - layer_rn(key, j, 1u).x) / (sigma_t / abs(w.z));
        precise float zp = w.z > 0.0 ? (z + dz) : (z - dz);
        if (zp == z) return no_sample();
        if (0.0 < zp && zp < y.thickness) {
          vec3 up = layer_rn(key, j, 2u);
          float ps_pdf;
          vec3 ps_wi = hg_sample(-w, y.g, up.xy, ps_pdf);
          if (ps_pdf == 0.0 || ps_wi.z == 0.0) return no_sample();
          f *= y.albedo * ps_pdf;
          pdf *= ps_pdf;
          specular_path = false;
          w = ps_wi;
          z = zp;
          continue;
        }
        z = clamp(zp, 0.0, y.thickness);
      } else {
        z = (z == y.thickness) ? 0.0 : y.thickness;
        f *= layer_tr(y.thickness, w);
      }
      ur = layer_rn(key, j, 3u);
    }
    BsdfSample is = layer_query(y, z != 0.0, -w, vec3(0.0), ur.x, ur.yz, true, true, SAMPLE_ALL);
    if (!walk_sample_ok(is)) return no_sample();
    if (depth < 0) {
      // The entrance: a reflection is returned as is.
      if ((is.flags & BSDF_REFLECTION) != 0u) {
        if (flip_wi) is.wi = -is.wi;
        is.pdf_is_proportional = true;
        return is;
      }
      w = is.wi;
      specular_path = (is.flags & BSDF_SPECULAR) != 0u;
      f = is.f * abs(is.wi.z);
      pdf = is.pdf;
      continue;
    }
    f *= is.f;
    pdf *= is.pdf;
    specular_path = specular_path && (is.flags & BSDF_SPECULAR) != 0u;
    w = is.wi;
    if ((is.flags & BSDF_TRANSMISSION) != 0u) {
      uint flags = same_hemisphere(wo, w) ? BSDF_REFLECTION : BSDF_TRANSMISSION;
      flags |= specular_path ? BSDF_SPECULAR : BSDF_GLOSSY;
      if (flip_wi) w = -w;
      layer_renormalize(f, pdf);
      return BsdfSample(f, pdf, w, flags, 1.0, true);
    }
    f *= abs(is.wi.z);
  }
  return no_sample();
}

// pbrt-v4 LayeredBxDF::PDF's final Lerp(0.9, 1 / (4 pi), estimate). (A function of its own:
// glslang's precise propagation through layered_pdf's loop exhausts memory.)
precise float layer_pdf_mix(float estimate) { return (1.0 - 0.9) * INV_4PI + 0.9 * estimate; }

// pbrt-v4 LayeredBxDF::PDF (radiance mode) with random numbers from stream `key`: the mixture
// 0.1 / (4 pi) + 0.9 (stochastic estimate). For wi on the other side the estimate (pbrt-v4's TT
// term) is always 0, the bottom never transmitting: 0.1 / (4 pi).
float layered_pdf(Lobe L, vec3 wo, vec3 wi, uvec4 key) {
  if (wo.z < 0.0) {
    wo = -wo;
    wi = -wi;
  }
  if (!same_hemisphere(wo, wi)) {
    return layer_pdf_mix(0.0);
  }
  Layers y = layers_of(L);
  uint j = 0u;
  float pdf_sum = 0.0;
  bool top_spec_only = mf_smooth(y.top);  // !IsNonSpecular(top.Flags())
  // End tests at the end of a pass, as in layered_f.
  int s = 0;
  if (y.n_samples > 0) [[dont_unroll]] while (true) {
    // TRT term through one layer_query call site: k = -1 (first sample only), reflection pdf
    // of the entrance x nSamples; k = 0, 1, transmission through the top for wo and wi (both
    // always drawn); k = 2, bottom pdf(-wos.wi, -wis.wi); k = 3, bottom sample at -wos.wi;
    // k = 4, top pdf(-rs.wi, wi).
    BsdfSample wos, wis, rs;
    float r_pdf = 0.0, t_pdf = 0.0;
    bool wos_ok = false, wis_ok = false, rs_ok = false;
    int k = s == 0 ? -1 : 0;
    [[dont_unroll]] while (true) {
      bool smp = k == 0 || k == 1 || k == 3;
      vec3 ur = smp ? layer_rn(key, j, 3u) : vec3(0.0);
      vec3 qwo = k == 1 ? wi : (k == 2 || k == 3 ? -wos.wi : (k == 4 ? -rs.wi : wo));
      uint fl = k < 0 ? SAMPLE_R : (k <= 1 ? SAMPLE_T : SAMPLE_ALL);
      BsdfSample t = layer_query(y, k != 2 && k != 3, qwo, k == 2 ? -wis.wi : wi, ur.x, ur.yz,
                                 smp, k != 1, fl);
      bool t_ok = t.flags != 0u && nonzero(t.f) && t.pdf > 0.0;
      if (k < 0) pdf_sum = float(y.n_samples) * t.pdf;
      else if (k == 0) { wos = t; wos_ok = t_ok; }
      else if (k == 1) { wis = t; wis_ok = t_ok; }
      else if (k == 2) r_pdf = t.pdf;
      else if (k == 3) { rs = t; rs_ok = t_ok; }
      else t_pdf = t.pdf;
      ++k;
      if (k >= 5 || (k == 2 && !(wos_ok && wis_ok)) || (k == 3 && top_spec_only) ||
          (k == 4 && !rs_ok))
        break;
    }
    if (wos_ok && wis_ok) {
      if (top_spec_only) {
        pdf_sum += r_pdf;
      } else if (rs_ok) {
        if (!bottom_nonspecular(y)) {
          pdf_sum += t_pdf;
        } else {
          pdf_sum += layer_power(wis.pdf, r_pdf) * r_pdf;
          pdf_sum += layer_power(rs.pdf, t_pdf) * t_pdf;
        }
      }
    }
    ++s;
    if (s >= y.n_samples) break;
  }
  return layer_pdf_mix(y.n_samples > 0 ? pdf_sum / float(y.n_samples) : 0.0);
}

#endif
