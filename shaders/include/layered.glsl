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
// mf_interface_query. The walks call it from one site (layered_query); with coated conductors in the scene
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
// sigma_t / |w.z|), sigma_t = 1), for the walks. (A function of its own, as layer_pdf_mix:
// glslang's precise propagation through the walks' event loop exhausts memory.)
precise float layer_step_z(float z, vec3 w, float u) {
  float sigma_t = 1.0;
  float dz = -log(1.0 - u) / (sigma_t / abs(w.z));
  return w.z > 0.0 ? (z + dz) : (z - dz);
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

// pbrt-v4 LayeredBxDF::PDF's final Lerp(0.9, 1 / (4 pi), estimate). (A function of its own:
// glslang's precise propagation through the walks' loops exhausts memory.)
precise float layer_pdf_mix(float estimate) { return (1.0 - 0.9) * INV_4PI + 0.9 * estimate; }

// Sample_f's Russian roulette weight, max(f) / pdf (a function of its own, as layer_step_z).
precise float layer_rr_beta(vec3 f, float pdf) { return max_component(f) / pdf; }

// The walks of layered_query, in the order one query runs them.
const int LAYER_WALK_F = 0;       // pbrt-v4 LayeredBxDF::f
const int LAYER_WALK_PDF = 1;     // pbrt-v4 LayeredBxDF::PDF
const int LAYER_WALK_SAMPLE = 2;  // pbrt-v4 LayeredBxDF::Sample_f

// pbrt-v4 LayeredBxDF::f, PDF and Sample_f (radiance mode) in one loop nest with one
// layer_query call site, so that a pipeline inlines one interface for the three (lavapipe runs
// every branch: three walks were three interfaces' code, and each walk's loops ran at least
// one pass at every query; docs/performance.md, seventeenth session). smp: Sample_f (into bs;
// the first interface sample uses (uc, u), the walk the stream `key`; pdf_is_proportional on
// every sample); else f (want_f, from stream `key`) and PDF (want_pdf, from stream `pdf_key`),
// each walk drawing from the start of its stream. Two-sided: wo below is mirrored; light
// entering through the top can only leave through it (the bottom does not transmit), so f is
// 0 for wi on the other side and PDF the mixture's 0.1 / (4 pi) (pbrt-v4's estimates are 0
// there too). Each walk's steps are pbrt-v4's, in its order:
// - f: per sample, step -1 is the entrance (e = -3, first sample only: reflection at the
//   entrance, nSamples f_top(wo, wi); e = -2, -1: transmission through the top for wo
//   (radiance) and wi (importance)), then the walk's steps, each a free flight (or the slab
//   crossed) and its interface events: e = 0, NEE along the presampled wis at the bottom;
//   e = 1, sampling the interface at z (reflection); e = 2, 3, NEE through the top towards wi
//   along the new w: e = 2, the density with which the wis strategy produces -w, PDF(wi, -w)
//   in importance mode (MIS weight; pbrt-v4 uses PDF(-w, wi), see docs/materials-spec.md 2.3),
//   e = 3, f(-w, wi).
// - PDF: per sample, one step of events (the TRT term): e = -1 (first sample only),
//   reflection pdf of the entrance x nSamples; e = 0, 1, transmission through the top for wo
//   and wi (both always drawn); e = 2, bottom pdf(-wos.wi, -wis.wi); e = 3, bottom sample at
//   -wos.wi; e = 4, top pdf(-rs.wi, wi).
// - Sample_f: one sample, each step one interface sample (e = 1) after its free flight.
// The loops test their end at the end of a pass, not at the start of the next: lavapipe runs
// a pass that any lane enters in full, so a `for` loop's closing test cost a whole pass of its
// body (docs/performance.md, seventh session). Their `continue`s are ifs for the same reason.
void layered_query(Lobe L, bool smp, bool want_f, bool want_pdf, vec3 wo, vec3 wi, float uc,
                   vec2 u, uvec4 key, uvec4 pdf_key, out vec3 f_out, out float pdf_out,
                   out BsdfSample bs_out) {
  f_out = vec3(0.0);
  pdf_out = 0.0;
  bs_out = no_sample();
  bool flip = wo.z < 0.0;
  if (flip) {
    wo = -wo;
    wi = -wi;
  }
  bool same = same_hemisphere(wo, wi);
  if (want_pdf) pdf_out = layer_pdf_mix(0.0);  // wi on the other side, or no samples
  Layers y = layers_of(L);
  bool top_spec = mf_smooth(y.top), bot_spec = bottom_specular(y);
  bool has_albedo = nonzero(y.albedo);
  float exit_z = y.thickness;  // the exit interface is the top
  int mode = smp ? LAYER_WALK_SAMPLE
                 : (want_f && same ? LAYER_WALK_F : (want_pdf && same ? LAYER_WALK_PDF : -1));
  uvec4 walk_key = mode == LAYER_WALK_PDF ? pdf_key : key;
  uint j = 0u;
  int s = 0;
  vec3 f = vec3(0.0);    // f's sum
  float pdf_sum = 0.0;   // PDF's sum
  vec3 sf = vec3(1.0);   // Sample_f's f and pdf
  float spdf = 1.0;
  bool specular_path = false;
  if (mode >= 0 && (mode == LAYER_WALK_SAMPLE || y.n_samples > 0)) [[dont_unroll]] while (true) {
    BsdfSample wos, wis, rs;
    vec3 beta = vec3(0.0);
    float z = y.thickness;
    vec3 w = mode == LAYER_WALK_SAMPLE ? -wo : vec3(0.0);  // Sample_f's step -1 samples at wo
    int depth = -1;
    float r_pdf = 0.0, t_pdf = 0.0;  // PDF's
    bool wos_ok = false, wis_ok = false, rs_ok = false;
    [[dont_unroll]] while (true) {
      // f's NEE through the top along w after a scattering event: exit_nee (done at e = 2).
      bool exit_nee = false, exit_mis = true;
      float exit_pdf_s = 0.0, exit_dz = 0.0;
      vec3 exit_w = vec3(0.0);
      bool scattered = false;
      bool next = false;  // pbrt-v4's `continue`: on to the next step
      bool stop = false;  // the walk ends (Sample_f: no sample)
      if (depth < 0) {
      } else if (mode == LAYER_WALK_SAMPLE && w.z == 0.0) {
        next = stop = true;
      } else if (!has_albedo) {
        z = (z == y.thickness) ? 0.0 : y.thickness;
        float tr = layer_tr(y.thickness, w);
        if (mode == LAYER_WALK_SAMPLE) sf *= tr;
        else beta *= tr;
      } else {
        float zp = layer_step_z(z, w, layer_rn(walk_key, j, 1u).x);
        if (z == zp) {
          next = true;
          stop = mode == LAYER_WALK_SAMPLE;
        } else if (0.0 < zp && zp < y.thickness) {
          // Scattering in the medium; f: NEE along the presampled wis through the top first.
          if (mode == LAYER_WALK_F) {
            float wt = 1.0;
            float ph = hg_p(-w, -wis.wi, y.g);
            if (!top_spec) wt = layer_power(wis.pdf, ph);
            f += beta * y.albedo * ph * wt * layer_tr(zp - exit_z, wis.wi) * wis.f / wis.pdf;
          }
          vec3 ur = layer_rn(walk_key, j, 2u);
          float ps_pdf;
          vec3 ps_wi = hg_sample(-w, y.g, ur.xy, ps_pdf);
          if (ps_pdf == 0.0 || ps_wi.z == 0.0) {
            next = true;
            stop = mode == LAYER_WALK_SAMPLE;
          } else {
            if (mode == LAYER_WALK_SAMPLE) {
              sf *= y.albedo * ps_pdf;
              spdf *= ps_pdf;
              specular_path = false;
              next = true;  // no interface event in this step
            } else {
              beta *= y.albedo * ps_pdf / ps_pdf;
            }
            w = ps_wi;
            z = zp;
            if (mode == LAYER_WALK_F &&
                ((z < exit_z && w.z > 0.0) || (z > exit_z && w.z < 0.0)) && !top_spec) {
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
      if (!next) {
        // The interface events of this step, through one layer_query call site.
        bool at_exit = z == exit_z;
        float exit_pdf = 0.0;
        int e = mode == LAYER_WALK_PDF      ? (s == 0 ? -1 : 0)
                : mode == LAYER_WALK_SAMPLE ? 1
                : depth < 0                 ? (s == 0 ? -3 : -2)
                                            : (scattered ? 2 : 0);
        [[dont_unroll]] while (true) {
          bool f_walk = mode == LAYER_WALK_F, pdf_walk = mode == LAYER_WALK_PDF;
          bool skip = f_walk && ((e == 0 && (at_exit || bot_spec)) || (e >= 2 && !exit_nee) ||
                                 (e == 2 && !exit_mis));
          if (!skip) {
            bool entrance = f_walk && e < 0;
            bool draw = pdf_walk ? (e == 0 || e == 1 || e == 3)
                        : f_walk ? (e == 1 || e == -2 || e == -1)
                                 : depth >= 0;
            vec3 ur = draw ? layer_rn(walk_key, j, 3u) : vec3(uc, u);
            // f's e = 2 with --layered-mis pbrt-v4: pbrt-v4's PDF(-w, wi) in radiance mode.
            bool nee_pdf = f_walk && e == 2 && !y.pbrt_mis;
            bool top;
            vec3 qwo, qwi;
            bool qsmp, radiance;
            uint fl;
            if (pdf_walk) {
              top = e != 2 && e != 3;
              qwo = e == 1 ? wi : (e == 2 || e == 3 ? -wos.wi : (e == 4 ? -rs.wi : wo));
              qwi = e == 2 ? -wis.wi : wi;
              qsmp = draw;
              radiance = e != 1;
              fl = e < 0 ? SAMPLE_R : (e <= 1 ? SAMPLE_T : SAMPLE_ALL);
            } else if (f_walk) {
              top = entrance || e >= 2 || (e == 1 && at_exit);
              qwo = entrance ? (e == -1 ? wi : wo) : (nee_pdf ? wi : -w);
              qwi = entrance ? wi : (e == 0 ? -wis.wi : (nee_pdf ? -w : wi));
              qsmp = entrance ? e >= -2 : e == 1;
              radiance = entrance ? e != -1 : !nee_pdf;
              fl = entrance ? (e == -3 ? SAMPLE_ALL : SAMPLE_T) : (e >= 2 ? SAMPLE_T : SAMPLE_R);
            } else {
              top = z != 0.0;
              qwo = -w;
              qwi = vec3(0.0);
              qsmp = true;
              radiance = true;
              fl = SAMPLE_ALL;
            }
            BsdfSample t = layer_query(y, top, qwo, qwi, ur.x, ur.yz, qsmp, radiance, fl);
            if (pdf_walk) {
              bool t_ok = t.flags != 0u && nonzero(t.f) && t.pdf > 0.0;
              if (e < 0) {
                pdf_sum = float(y.n_samples) * t.pdf;
              } else if (e == 0) {
                wos = t;
                wos_ok = t_ok;
              } else if (e == 1) {
                wis = t;
                wis_ok = t_ok;
              } else if (e == 2) {
                r_pdf = t.pdf;
              } else if (e == 3) {
                rs = t;
                rs_ok = t_ok;
              } else {
                t_pdf = t.pdf;
              }
            } else if (!f_walk) {
              // Sample_f: the entrance's reflection is returned as is; a transmission through
              // the top ends the walk with its sample.
              if (!walk_sample_ok(t)) {
                stop = true;
                break;
              }
              if (depth < 0) {
                if ((t.flags & BSDF_REFLECTION) != 0u) {
                  if (flip) t.wi = -t.wi;
                  t.pdf_is_proportional = true;
                  bs_out = t;
                  stop = true;
                  break;
                }
                w = t.wi;
                specular_path = (t.flags & BSDF_SPECULAR) != 0u;
                sf = t.f * abs(t.wi.z);
                spdf = t.pdf;
              } else {
                sf *= t.f;
                spdf *= t.pdf;
                specular_path = specular_path && (t.flags & BSDF_SPECULAR) != 0u;
                w = t.wi;
                if ((t.flags & BSDF_TRANSMISSION) != 0u) {
                  uint flags = same_hemisphere(wo, w) ? BSDF_REFLECTION : BSDF_TRANSMISSION;
                  flags |= specular_path ? BSDF_SPECULAR : BSDF_GLOSSY;
                  if (flip) w = -w;
                  layer_renormalize(sf, spdf);
                  bs_out = BsdfSample(sf, spdf, w, flags, 1.0, true);
                  stop = true;
                  break;
                }
                sf *= abs(t.wi.z);
              }
            } else if (e == -3) {
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
          if (pdf_walk ? (e >= 5 || (e == 2 && !(wos_ok && wis_ok)) || (e == 3 && top_spec) ||
                          (e == 4 && !rs_ok))
                       : (!f_walk || (depth < 0 && e == 0) || e >= 4 || (e >= 2 && !exit_nee)))
            break;
        }
      }
      if (stop) break;
      if (mode == LAYER_WALK_PDF) {
        // The sample's TRT estimate; PDF's walk is this one step.
        if (wos_ok && wis_ok) {
          if (top_spec) {
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
        break;
      }
      if (mode == LAYER_WALK_F && depth < 0) {
        // Into the slab along the sampled transmission (pbrt-v4's walk start).
        beta = wos.f * abs(wos.wi.z) / wos.pdf;
        w = wos.wi;
      }
      ++depth;
      if (depth >= y.max_depth) break;
      // Russian roulette for the next step (pbrt-v4's at its start: the same draw, in order);
      // Sample_f's (f, pdf) renormalised first.
      if (mode == LAYER_WALK_SAMPLE) layer_renormalize(sf, spdf);
      float rr = mode == LAYER_WALK_SAMPLE ? layer_rr_beta(sf, spdf) : max_component(beta);
      if (depth > 3 && rr < 0.25) {
        float q = max(0.0, 1.0 - rr);
        if (layer_rn(walk_key, j, 1u).x < q) break;
        if (mode == LAYER_WALK_SAMPLE) spdf *= 1.0 - q;
        else beta /= 1.0 - q;
      }
    }
    ++s;
    if (mode == LAYER_WALK_SAMPLE || s >= y.n_samples) {
      if (mode == LAYER_WALK_F) f_out = f / float(y.n_samples);
      if (mode == LAYER_WALK_PDF) pdf_out = layer_pdf_mix(pdf_sum / float(y.n_samples));
      if (mode != LAYER_WALK_F || !want_pdf) break;
      // f's walk done: PDF's, from the start of its own stream.
      mode = LAYER_WALK_PDF;
      walk_key = pdf_key;
      j = 0u;
      s = 0;
    }
  }
}

#endif
