// The BxDF lobes of docs/materials-spec.md section 2 in the local shading frame (z = shading
// normal): f, pdf and sampling of every LOBE_* tag except the layered ones (layered.glsl), which
// build on the dielectric, conductor and diffuse functions here; bsdf.glsl's lobe_query
// dispatches on the tag. A lobe's f is without its rgb weight (the BSDF applies it). Where
// pbrt's f, PDF and Sample_f share their arithmetic, one *_eval / *_query function does all
// three (lavapipe inlines every call, so fewer call sites mean faster pipeline creation).
// Needs bindings.glsl (FEATURES, measured[]).
#ifndef BASALT_LOBES_GLSL
#define BASALT_LOBES_GLSL

#include "math.glsl"
#include "sampling.glsl"
#include "microfacet.glsl"
#include "fresnel.glsl"
#include "trig.glsl"

const float INV_4PI = 0.07957747154594766788;

// Material kinds whose BSDFs may contain each lobe (the lobe's code is compiled only if the
// scene has one of them; docs/materials-spec.md section 3, smooth microfacet lobes included).
const uint LOBE_FEATURES_LAMBERT_R = FEATURE_MAT_DIFFUSE | FEATURE_MAT_OREN_NAYAR |
                                     FEATURE_MAT_PLASTIC | FEATURE_MAT_TRANSLUCENT |
                                     FEATURE_MAT_UBER;
const uint LOBE_FEATURES_LAMBERT_T = FEATURE_MAT_TRANSLUCENT;
const uint LOBE_FEATURES_OREN_NAYAR = FEATURE_MAT_OREN_NAYAR;
const uint LOBE_FEATURES_MICROFACET_R = FEATURE_MAT_METAL | FEATURE_MAT_PLASTIC |
                                        FEATURE_MAT_TRANSLUCENT | FEATURE_MAT_UBER;
const uint LOBE_FEATURES_MICROFACET_T = FEATURE_MAT_TRANSLUCENT;
const uint LOBE_FEATURES_SPECULAR_R = FEATURE_MAT_MIRROR | LOBE_FEATURES_MICROFACET_R;
const uint LOBE_FEATURES_SPECULAR_T = FEATURE_MAT_UBER | FEATURE_MAT_TRANSLUCENT;
const uint LOBE_FEATURES_FRESNEL_BLEND = FEATURE_MAT_SUBSTRATE;
const uint LOBE_FEATURES_CONDUCTOR = FEATURE_MAT_CONDUCTOR;
const uint LOBE_FEATURES_DIELECTRIC = FEATURE_MAT_DIELECTRIC;
const uint LOBE_FEATURES_THIN_DIELECTRIC = FEATURE_MAT_THIN_DIELECTRIC;
const uint LOBE_FEATURES_DIFFUSE_TRANSMISSION = FEATURE_MAT_DIFFUSE_TRANSMISSION;
const uint LOBE_FEATURES_LAYERED = FEATURE_MAT_COATED_DIFFUSE | FEATURE_MAT_COATED_CONDUCTOR;
const uint LOBE_FEATURES_MEASURED = FEATURE_MAT_MEASURED;

// BxDFReflTransFlags of pbrt-v4: which of reflection and transmission a sample may choose.
const uint SAMPLE_R = BSDF_REFLECTION;
const uint SAMPLE_T = BSDF_TRANSMISSION;
const uint SAMPLE_ALL = BSDF_REFLECTION | BSDF_TRANSMISSION;

// Lobe.bits: FRESNEL_* of MICROFACET_R / SPECULAR_R in bits 0-1, Beckmann in bit 2, layered
// pbrt-v4 MIS in bit 3, the
// lobe's BSDF_* flags in bits 8-15.
const uint LOBEBIT_FRESNEL_MASK = 3u;
const uint LOBEBIT_BECKMANN = 4u;
const uint LOBEBIT_PBRT_MIS = 8u;  // layered: pbrt-v4's exit MIS weights (MATFLAG_LAYERED_PBRT_MIS)
const uint LOBEBIT_FLAGS_SHIFT = 8u;

// One lobe: tag, bits, aux (layered: maxdepth | nsamples << 16; measured: table offset), rgb
// weight and parameters. Parameter layout per tag:
//   OREN_NAYAR: p0 = (A, B); MICROFACET_R, SPECULAR_R: p0 = (ax, ay, dielectric eta),
//   p1 = conductor eta, p2 = conductor k; MICROFACET_T, SPECULAR_T, THIN_DIELECTRIC:
//   p0 = (ax, ay, eta); FRESNEL_BLEND: p0 = (ax, ay), p1 = Rd, p2 = Rs; CONDUCTOR: p0 = (ax, ay),
//   p1 = eta, p2 = k; DIELECTRIC: p0 = (ax, ay, eta), p1 = Kr, p2 = Kt; DIFFUSE_TRANSMISSION:
//   p1 = R, p2 = T; LAYERED_*: p0 = (ax, ay, eta, thickness) of the top interface,
//   p1 = (albedo, g), p2 = (diffuse R | conductor eta, ax), p3 = (conductor k, ay);
//   MEASURED: p0 = (nThetaH, nThetaD, nPhiD).
struct Lobe {
  uint tag;
  uint bits;
  uint aux;
  uint pad;
  vec3 weight;
  vec4 p0;
  vec4 p1;
  vec4 p2;
  vec4 p3;
};

// A sampled direction (docs/materials-spec.md 1.3): f (rgb, no cosine), pdf, wi (local),
// BSDF_* flags (0: no sample), eta (etaT / etaI of a transmission, else 1) and whether pdf is
// only proportional to the true density (stochastic layered lobes, pbrt-v4 pdfIsProportional).
struct BsdfSample {
  vec3 f;
  float pdf;
  vec3 wi;
  uint flags;
  float eta;
  bool pdf_is_proportional;
};

// The empty sample (flags 0).
BsdfSample no_sample() { return BsdfSample(vec3(0.0), 0.0, vec3(0.0), 0u, 1.0, false); }

// BSDF_* flags stored in a lobe.
uint lobe_flags(Lobe L) { return L.bits >> LOBEBIT_FLAGS_SHIFT; }

// The lobe's microfacet distribution from p0.xy and its Beckmann bit.
MfDist lobe_dist(Lobe L) {
  return MfDist(L.p0.x, L.p0.y, (L.bits & LOBEBIT_BECKMANN) != 0u);
}

// pbrt SameHemisphere.
bool same_hemisphere(vec3 a, vec3 b) { return a.z * b.z > 0.0; }

// True if some component is non-zero (pbrt-v4 bool(SampledSpectrum)).
bool nonzero(vec3 v) { return v.x != 0.0 || v.y != 0.0 || v.z != 0.0; }

// A valid pbrt-v4 sample (!bs || !bs->f || bs->pdf == 0 || bs->wi.z == 0 rejected), with f
// and pdf below FLT_MIN counted as 0 (docs/materials-spec.md 1.3: a GPU may or may not flush
// subnormals, so both sides treat them as 0).
bool usable(BsdfSample bs) {
  float fmax = max(abs(bs.f.x), max(abs(bs.f.y), abs(bs.f.z)));
  return bs.flags != 0u && fmax >= FLT_MIN && abs(bs.pdf) >= FLT_MIN && bs.wi.z != 0.0;
}

// pbrt-v4 A.5.3 SampleCosineHemisphere (Malley's method over the concentric disk).
vec3 cosine_hemisphere(vec2 u) {
  vec2 d = concentric_disk(u);
  float r = concentric_radius(u);
  precise float z2 = 1.0 - r * r;
  return vec3(d.x, d.y, safe_sqrt(z2));
}

// The direction flipped to the side of the z axis that `side` is on (z negated if side.z < 0).
vec3 to_side_of(vec3 w, vec3 side) { return side.z < 0.0 ? vec3(w.xy, -w.z) : w; }

// ---- diffuse ------------------------------------------------------------------------------

// Cosine-hemisphere density of wi (pbrt-v4 CosineHemispherePDF(|cos wi|)).
precise float cosine_pdf(vec3 wi) { return abs(wi.z) * INV_PI; }

// Cosine-hemisphere sample on wo's side with f: pbrt-v4 DiffuseBxDF::Sample_f (f passed in).
BsdfSample diffuse_sample(vec3 f, vec3 wo, vec2 u) {
  vec3 wi = to_side_of(cosine_hemisphere(u), wo);
  return BsdfSample(f, cosine_pdf(wi), wi, BSDF_REFLECTION | BSDF_DIFFUSE, 1.0, false);
}

// pbrt-v3 OrenNayar::f without R (A = p0.x, B = p0.y; the 1e-4 sin thresholds; |cos| for the
// tangent).
precise float oren_nayar_f(vec2 ab, vec3 wo, vec3 wi) {
  float sin_i = sqrt(sin2_theta(wi)), sin_o = sqrt(sin2_theta(wo));
  float max_cos = 0.0;
  if (sin_i > 1e-4 && sin_o > 1e-4) {
    float dcos = cos_phi(wi) * cos_phi(wo) + sin_phi(wi) * sin_phi(wo);
    max_cos = max(0.0, dcos);
  }
  float sin_alpha, tan_beta;
  if (abs(wi.z) > abs(wo.z)) {
    sin_alpha = sin_o;
    tan_beta = sin_i / abs(wi.z);
  } else {
    sin_alpha = sin_i;
    tan_beta = sin_o / abs(wo.z);
  }
  return INV_PI * (ab.x + ab.y * max_cos * sin_alpha * tan_beta);
}

// pbrt-v4 DiffuseTransmissionBxDF: choice probability of reflection, max(R) / (max(R) + max(T)),
// and of transmission; false if both are 0.
bool dt_probs(vec3 R, vec3 T, out float pr, out float pt) {
  pr = max_component(R);
  pt = max_component(T);
  return !(pr == 0.0 && pt == 0.0);
}

// pbrt-v4 DiffuseTransmissionBxDF::PDF.
precise float dt_pdf(vec3 R, vec3 T, vec3 wo, vec3 wi) {
  float pr, pt;
  if (!dt_probs(R, T, pr, pt)) return 0.0;
  if (same_hemisphere(wo, wi)) return pr / (pr + pt) * cosine_pdf(wi);
  return pt / (pr + pt) * cosine_pdf(wi);
}

// pbrt-v4 DiffuseTransmissionBxDF::Sample_f.
BsdfSample dt_sample(vec3 R, vec3 T, vec3 wo, float uc, vec2 u) {
  float pr, pt;
  if (!dt_probs(R, T, pr, pt)) return no_sample();
  vec3 wi = cosine_hemisphere(u);
  bool reflect = uc < pr / (pr + pt);
  if (reflect == (wo.z < 0.0)) wi.z = -wi.z;
  precise float pdf = cosine_pdf(wi) * (reflect ? pr : pt) / (pr + pt);
  vec3 f = same_hemisphere(wo, wi) ? R * INV_PI : T * INV_PI;
  uint flags = (reflect ? BSDF_REFLECTION : BSDF_TRANSMISSION) | BSDF_DIFFUSE;
  return BsdfSample(f, pdf, wi, flags, 1.0, false);
}

// ---- Fresnel of MICROFACET_R / SPECULAR_R --------------------------------------------------

// F(cos) of the lobe's Fresnel kind (docs/materials-spec.md 2.2).
vec3 lobe_fresnel(Lobe L, float cos_i) {
  uint kind = L.bits & LOBEBIT_FRESNEL_MASK;
  if (kind == FRESNEL_DIELECTRIC) return vec3(fr_dielectric(cos_i, L.p0.z));
  if (kind == FRESNEL_CONDUCTOR) return fr_complex(abs(cos_i), L.p1.xyz, L.p2.xyz);
  return vec3(1.0);
}

// ---- pbrt-v3 microfacet reflection and transmission ------------------------------------------

// pbrt-v3 MicrofacetReflection::f (without R) and the pdf of its sampling at wi: pdf(wo, wh) /
// (4 |wo.wh|) with wh the sampled normal ws (Sample_f), or normalize(wo + wi) faced to +z
// (ws = 0: Pdf). Fresnel F(wi . wh faced to +z).
void microfacet_r_eval(Lobe L, vec3 wo, vec3 wi, vec3 ws, out vec3 f, out float pdf) {
  f = vec3(0.0);
  pdf = 0.0;
  if (!same_hemisphere(wo, wi)) return;
  float cos_o = abs(wo.z), cos_i = abs(wi.z);
  precise vec3 h = wi + wo;
  if (h.x == 0.0 && h.y == 0.0 && h.z == 0.0) return;
  vec3 wh = safe_normalize(h);
  if (wh.z < 0.0) wh = -wh;  // D is even; the Fresnel cosine uses the +z-faced wh
  bool sampled = ws != vec3(0.0);
  vec3 wp = sampled ? ws : wh;
  vec3 dgp = mf_dgp(lobe_dist(L), wo, wi, wh, wp);
  pdf = dgp.z / (4.0 * abs(dot_exact(wo, wp)));
  if (cos_i == 0.0 || cos_o == 0.0) return;
  vec3 F = lobe_fresnel(L, dot_exact(wi, wh));
  precise float dg = dgp.x * dgp.y;
  precise vec3 fr = dg * F / (4.0 * cos_i * cos_o);
  f = fr;
}

// pbrt-v3 MicrofacetTransmission::f (without T; etaA = 1, etaB = eta, radiance mode) and Pdf,
// both 0 for back-facing microfacets as pbrt-v4 DielectricBxDF (docs/materials-spec.md 2.3,
// deliberate deviation: pbrt-v3's sampler never produces them).
void microfacet_t_eval(Lobe L, vec3 wo, vec3 wi, out float f, out float pdf) {
  f = 0.0;
  pdf = 0.0;
  if (same_hemisphere(wo, wi)) return;
  float cos_o = wo.z, cos_i = wi.z;
  float eta = L.p0.z;
  float e = cos_o > 0.0 ? eta : 1.0 / eta;
  vec3 wh = safe_normalize(wo + wi * e);
  if (wh.z < 0.0) wh = -wh;  // Pdf's unflipped wh gives the same |values|
  precise float dwo = dot_exact(wo, wh);
  precise float dwi = dot_exact(wi, wh);
  if (dwo * dwi > 0.0) return;
  if (dwi * cos_i < 0.0 || dwo * cos_o < 0.0) return;
  vec3 dgp = mf_dgp(lobe_dist(L), wo, wi, wh, wh);
  precise float sqrt_denom = dwo + e * dwi;
  precise float dwh_dwi = abs((e * e * dwi) / (sqrt_denom * sqrt_denom));
  pdf = dgp.z * dwh_dwi;
  if (cos_i == 0.0 || cos_o == 0.0) return;
  precise float F = fr_dielectric(dwo, eta);
  precise float factor = 1.0 / e;
  precise float ft = (1.0 - F) * abs(dgp.x * dgp.y * e * e * abs(dwi) * abs(dwo) * factor *
                                     factor / (cos_i * cos_o * sqrt_denom * sqrt_denom));
  f = ft;
}

// Direction of pbrt-v3 MicrofacetTransmission::Sample_f: wh on wo's side (pbrt-v3 Sample_wh's
// flip), pbrt-v3 Refract with etaI / etaT; false if none. (f and pdf are re-evaluated at wi.)
bool microfacet_t_sample_wi(Lobe L, vec3 wo, vec2 u, out vec3 wi) {
  wi = vec3(0.0);
  if (wo.z == 0.0) return false;
  vec3 wh = mf_sample_wm(lobe_dist(L), wo, u);
  if (!same_hemisphere(wo, wh)) wh = -wh;
  if (dot_exact(wo, wh) < 0.0) return false;
  float eta = L.p0.z;
  return refract_v3(wo, wh, wo.z > 0.0 ? 1.0 / eta : eta, wi);
}

// pbrt-v3 SpecularReflection::Sample_f without R: mirror direction, F(cos wi) / |cos wi|.
BsdfSample specular_r_sample(Lobe L, vec3 wo) {
  vec3 wi = vec3(-wo.x, -wo.y, wo.z);
  precise vec3 f = lobe_fresnel(L, wi.z) / abs(wi.z);
  return BsdfSample(f, 1.0, wi, BSDF_REFLECTION | BSDF_SPECULAR, 1.0, false);
}

// pbrt-v3 SpecularTransmission::Sample_f without T (etaA = 1, etaB = eta, radiance mode);
// with eta = 1 (pbrt-v3 uber's opacity lobe) this passes through, wi = -wo up to rounding.
BsdfSample specular_t_sample(Lobe L, vec3 wo) {
  float eta = L.p0.z;
  bool entering = wo.z > 0.0;
  float eta_i = entering ? 1.0 : eta, eta_t = entering ? eta : 1.0;
  vec3 wi;
  if (!refract_v3(wo, vec3(0.0, 0.0, wo.z < 0.0 ? -1.0 : 1.0), eta_i / eta_t, wi))
    return no_sample();
  precise float r = eta_i / eta_t;
  precise float f = (1.0 - fr_dielectric(wi.z, eta)) * (r * r) / abs(wi.z);
  return BsdfSample(vec3(f), 1.0, wi, BSDF_TRANSMISSION | BSDF_SPECULAR, eta_t / eta_i, false);
}

// ---- pbrt-v3 FresnelBlend ---------------------------------------------------------------------

// (v^2)^2 v as pbrt-v3's pow5.
precise float pow5(float v) { return (v * v) * (v * v) * v; }

// pbrt-v3 FresnelBlend::f (Rd = p1, Rs = p2) and Pdf (with |dot(wo, wh)|).
void fresnel_blend_eval(Lobe L, vec3 wo, vec3 wi, out vec3 f, out float pdf) {
  f = vec3(0.0);
  pdf = 0.0;
  if (!same_hemisphere(wo, wi)) return;
  vec3 Rd = L.p1.xyz, Rs = L.p2.xyz;
  precise vec3 wh = wi + wo;
  if (wh.x == 0.0 && wh.y == 0.0 && wh.z == 0.0) return;
  wh = safe_normalize(wh);
  vec3 dgp = mf_dgp(lobe_dist(L), wo, wi, wh, wh);
  precise float pdf_wh = dgp.z;
  pdf = 0.5 * (abs(wi.z) * INV_PI + pdf_wh / (4.0 * abs(dot_exact(wo, wh))));
  precise vec3 diffuse = (28.0 / (23.0 * PI)) * Rd * (vec3(1.0) - Rs) *
                         (1.0 - pow5(1.0 - 0.5 * abs(wi.z))) * (1.0 - pow5(1.0 - 0.5 * abs(wo.z)));
  float dih = dot_exact(wi, wh);
  precise vec3 schlick = Rs + pow5(1.0 - dih) * (vec3(1.0) - Rs);
  precise vec3 specular = dgp.x / (4.0 * abs(dih) * max(abs(wi.z), abs(wo.z))) * schlick;
  precise vec3 fr = diffuse + specular;
  f = fr;
}

// ---- pbrt-v4 DielectricBxDF and ConductorBxDF -----------------------------------------------

// BSDF_* flags of pbrt-v4 DielectricBxDF::Flags.
uint dielectric_flags(float eta, MfDist d) {
  uint f = eta == 1.0 ? BSDF_TRANSMISSION : (BSDF_REFLECTION | BSDF_TRANSMISSION);
  return f | (mf_smooth(d) ? BSDF_SPECULAR : BSDF_GLOSSY);
}

// (dot(wi, wm) + dot(wo, wm) / etap)^2 of a wi refracted from wo through wm (cos_i =
// |dot(wo, wm)|; pbrt-v4 DielectricBxDF::Sample_f's dwm/dwi and transmission denominator) as
// ((1 - etap^2) / (etap (cos_i + etap cos_t)))^2 by Snell's law: no cancellation near etap = 1.
precise float refracted_half_denom(float cos_i, float etap) {
  // cos_t^2 = 1 - (1 - cos_i^2) / etap^2 = ((etap - 1)(etap + 1) + cos_i^2) / etap^2.
  precise float cos_t = sqrt(max(0.0, ((etap - 1.0) * (etap + 1.0) + cos_i * cos_i) / (etap * etap)));
  precise float t = ((1.0 - etap) * (1.0 + etap)) / (etap * (cos_i + etap * cos_t));
  return t * t;
}

// mf_interface_query (the interface chosen by its first argument at run time),
// mf_interface_conductor and mf_interface_dielectric (first argument ignored): mf_interface.glsl.
#define MF_INTERFACE_NAME mf_interface_query
#define MF_INTERFACE_KIND 2
#include "mf_interface.glsl"
#undef MF_INTERFACE_NAME
#undef MF_INTERFACE_KIND
#define MF_INTERFACE_NAME mf_interface_conductor
#define MF_INTERFACE_KIND 1
#include "mf_interface.glsl"
#undef MF_INTERFACE_NAME
#undef MF_INTERFACE_KIND
#define MF_INTERFACE_NAME mf_interface_dielectric
#define MF_INTERFACE_KIND 0
#include "mf_interface.glsl"
#undef MF_INTERFACE_NAME
#undef MF_INTERFACE_KIND

// pbrt-v4 ConductorBxDF: Sample_f (smp; reflection only, u for the microfacet normal) or f and
// PDF at (wo, wi); f, pdf, wi and flags in the returned sample (flags 0 when smp finds none).
BsdfSample conductor_query(vec3 eta, vec3 k, MfDist d, vec3 wo, vec3 wi, vec2 u, bool smp) {
  return mf_interface_conductor(true, 1.0, eta, k, d, wo, wi, 0.0, u, smp, true, SAMPLE_ALL);
}

// pbrt-v4 DielectricBxDF (f unscaled): Sample_f (smp, with uc, u and sample flags sflags) or f
// and PDF (with sflags) at (wo, wi); radiance or importance mode. f (in .x), pdf, wi, flags
// and etap in the returned sample (flags 0 when smp finds none).
BsdfSample dielectric_query(float eta, MfDist d, vec3 wo, vec3 wi, float uc, vec2 u, bool smp,
                            bool radiance, uint sflags) {
  return mf_interface_dielectric(false, eta, vec3(0.0), vec3(0.0), d, wo, wi, uc, u, smp,
                                 radiance, sflags);
}

// ---- pbrt-v4 ThinDielectricBxDF -------------------------------------------------------------

// pbrt-v4 ThinDielectricBxDF::Sample_f (all flags).
BsdfSample thin_dielectric_sample(float eta, vec3 wo, float uc) {
  precise float R = fr_dielectric(abs(wo.z), eta);
  precise float T = 1.0 - R;
  if (R < 1.0) {
    R += T * T * R / (1.0 - R * R);
    T = 1.0 - R;
  }
  if (R == 0.0 && T == 0.0) return no_sample();
  precise float pr = R / (R + T);
  if (uc < pr) {
    vec3 wi = vec3(-wo.x, -wo.y, wo.z);
    return BsdfSample(vec3(R / abs(wi.z)), pr, wi, BSDF_REFLECTION | BSDF_SPECULAR, 1.0, false);
  }
  precise float pt = T / (R + T);
  return BsdfSample(vec3(T / abs(wo.z)), pt, -wo, BSDF_TRANSMISSION | BSDF_SPECULAR, 1.0, false);
}

// ---- pbrt-v2 RegularHalfangleBRDF (MERL table) -----------------------------------------------

// pbrt-v2 RegularHalfangleBRDF::f, two-sided as docs/materials-spec.md 2.3: the table at
// measured[offset] with dims (nThetaH, nThetaD, nPhiD).
vec3 measured_f(uint offset, vec3 dims, vec3 wo, vec3 wi) {
  if (wo.z < 0.0) {
    wo = -wo;
    wi = -wi;
  }
  if (!same_hemisphere(wo, wi)) return vec3(0.0);
  vec3 wh = safe_normalize(wi + wo);
  float wh_theta = acos_accurate(wh.z);
  float wh_cos_phi = cos_phi(wh), wh_sin_phi = sin_phi(wh);
  float wh_cos_theta = wh.z, wh_sin_theta = sqrt(sin2_theta(wh));
  precise vec3 whx = vec3(wh_cos_phi * wh_cos_theta, wh_sin_phi * wh_cos_theta, -wh_sin_theta);
  vec3 why = vec3(-wh_sin_phi, wh_cos_phi, 0.0);
  vec3 wd = vec3(dot_exact(wi, whx), dot_exact(wi, why), dot_exact(wi, wh));
  float wd_theta = acos_accurate(wd.z);
  float wd_phi = atan2_accurate(wd.y, wd.x);
  if (wd_phi < 0.0) wd_phi += 2.0 * PI;
  if (wd_phi > PI) wd_phi -= PI;
  int nh = int(dims.x), nd = int(dims.y), np = int(dims.z);
  // pbrt-v2 REMAP(V, MAX, COUNT) = clamp(int(V / MAX * COUNT), 0, COUNT - 1)
  precise float vh = sqrt(max(0.0, wh_theta / PI_OVER_2)) / 1.0 * float(nh);
  precise float vd = wd_theta / PI_OVER_2 * float(nd);
  precise float vp = wd_phi / PI * float(np);
  int ih = clamp(int(vh), 0, nh - 1);
  int id = clamp(int(vd), 0, nd - 1);
  int ip = clamp(int(vp), 0, np - 1);
  uint i = offset + 3u * uint(ip + np * (id + ih * nd));
  return vec3(measured[i], measured[i + 1u], measured[i + 2u]);
}

#endif
