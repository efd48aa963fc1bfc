// The BSDF at a surface point (docs/materials-spec.md sections 1, 3 and 4): material ->
// lobes, stochastic mix resolution, and bsdf_eval / bsdf_pdf / bsdf_sample over the lobes with
// the light-leak rule of the geometric normal. Directions are in the local shading frame
// (z = shading normal); ng is the geometric normal in that frame. Needs bindings.glsl.
#ifndef BASALT_BSDF_GLSL
#define BASALT_BSDF_GLSL

#include "math.glsl"
#include "rng.glsl"
#include "sampling.glsl"
#include "surface.glsl"
#include "microfacet.glsl"
#include "fresnel.glsl"
#include "lobes.glsl"
#include "layered.glsl"
#include "bump.glsl"

// The lean variant of the render shader (render_lean.spv, compiled with
// -DBASALT_LEAN_MATERIALS=1; the host picks it when the scene's only material features are
// FEATURE_MAT_DIFFUSE, FEATURE_MAT_OREN_NAYAR and FEATURE_MAT_MEASURED) keeps MATERIAL_DIFFUSE,
// MATERIAL_OREN_NAYAR and MATERIAL_MEASURED (one lobe each) only: the code of every other kind
// and what only they need (lobe lists, mixes, interfaces, the stochastic lobes) is removed by
// the preprocessor wherever `#if BSDF_ALL_MATERIALS` guards it. lavapipe inlines every call
// before it folds FEATURES, so code gated by FEATURES alone still costs compile time.
#ifdef BASALT_LEAN_MATERIALS
#define BSDF_ALL_MATERIALS 0
#else
#define BSDF_ALL_MATERIALS 1
#endif

// The lobes of the current BSDF. One BSDF is live at a time per invocation (the integrator's
// current vertex, or the probe's query), so its lobe list lives here rather than being copied
// with every Bsdf argument: a Bsdf is valid until the next bsdf_at.
Lobe bsdf_lobes[MAX_LOBES];

// Material kinds whose BSDFs may have more than one lobe (section 3). Without them the list is
// lobe 0 alone. With them, bsdf_lobe and lobe_add still index the list with constants only
// (eight compares and selects): lavapipe keeps a list indexed so in registers, but reads and
// writes a varying index lane by lane through memory (material-zoo rendered 14% slower so).
// MAX_LOBES is 8 (layout.h): the eight cases below follow it.
const uint MULTI_LOBE_FEATURES = FEATURE_MAT_PLASTIC | FEATURE_MAT_TRANSLUCENT |
                                 FEATURE_MAT_UBER | FEATURE_MAT_MIX_WEIGHTED;
#if BSDF_ALL_MATERIALS
const bool BSDF_ONE_LOBE = !feature_const(MULTI_LOBE_FEATURES);
#else
const bool BSDF_ONE_LOBE = true;
#endif

// Lobe k of the current BSDF (constant indices only, see MULTI_LOBE_FEATURES).
Lobe bsdf_lobe(uint k) {
  if (BSDF_ONE_LOBE) return bsdf_lobes[0];
  Lobe L = bsdf_lobes[0];
  if (k == 1u) L = bsdf_lobes[1];
  if (k == 2u) L = bsdf_lobes[2];
  if (k == 3u) L = bsdf_lobes[3];
  if (k == 4u) L = bsdf_lobes[4];
  if (k == 5u) L = bsdf_lobes[5];
  if (k == 6u) L = bsdf_lobes[6];
  if (k == 7u) L = bsdf_lobes[7];
  return L;
}

// The BSDF at a surface point: lobe count (lobes in bsdf_lobes), union of the lobe flags, and
// the material after mix resolution (index, MATERIAL_* type; INVALID_INDEX / NONE if none).
struct Bsdf {
  uint n;
  uint flags;
  uint material;
  uint type;
};

// Slot values of the material whose lobes are being built (slots_resolve). With textures, every
// slot's texture program is evaluated in ONE place (slots_resolve's loop), because lavapipe
// inlines every call site: 50 slot_value sites each holding the texture interpreter made the
// render pipeline take minutes to compile. Without FEATURE_TEXTURES slot_value reads the
// material table directly and slot_cache is dead. One spare slot (slots_resolve).
vec4 slot_cache[MATERIAL_SLOTS + 1u];

// The displacement of a bump-mapped material (docs/bump-spec.md 4.3) at the shifted contexts
// of bump_shifted_ctx: cu (x), cv (y) and, for central differences, the backward ones (z, w);
// set by slots_resolve next to slot_cache[SLOT_DISPLACEMENT] (at the hit).
vec4 bump_disp_uv;

// Bit s: slot s of the material slots_resolve was last called for has a texture, whose value
// is in slot_cache[s] (a constant slot is read from the material table, slot_value).
uint slot_textured = 0u;

// Evaluates the textured slots of material m at sp into slot_cache: the value of each one's
// texture program in the hit's context (docs/textures-spec.md 2; a float program holds its
// value in x, y and z alike); the constant slots are left to slot_value, which reads them from
// the material table (visiting all 16 slots here made a textured scene's first bounce 2-3x as
// long on lavapipe). A material to bump (bump_wanted) takes two more iterations (four with
// central differences): its displacement slot at the shifted contexts of bump_shifted_ctx,
// into bump_disp_uv, so that the texture interpreter keeps its one call site.
void slots_resolve(uint m, SurfacePoint sp) {
  if (no_feature(FEATURE_TEXTURES)) return;
  uint mask = 0u;
  [[unroll]] for (uint q = 0u; q < MATERIAL_SLOTS / 4u; ++q) {
    uvec4 t = material_textures4(m, q);
    mask |= (t.x != INVALID_INDEX ? 1u : 0u) << (4u * q);
    mask |= (t.y != INVALID_INDEX ? 2u : 0u) << (4u * q);
    mask |= (t.z != INVALID_INDEX ? 4u : 0u) << (4u * q);
    mask |= (t.w != INVALID_INDEX ? 8u : 0u) << (4u * q);
  }
  slot_textured = mask;
  uint shifts = 0u;
  if (BUMP_ENABLED && bump_wanted(material_head(m).y)) shifts = bump_central() ? 4u : 2u;
  uint k = 0u;  // the end tested at the end of a pass (a for loop's closing test costs a pass)
  if (mask != 0u || k < shifts) [[dont_unroll]] while (true) {
    bool shifted = BUMP_ENABLED && mask == 0u;
    uint slot = shifted ? SLOT_DISPLACEMENT : uint(findLSB(mask));
    TexCtx c = sp.tex;
    if (shifted) c = bump_shifted_ctx(sp, k);
    uint tex = material_texture(m, slot);
    vec4 v = tex != INVALID_INDEX ? vec4(tex_eval_rgb(tex, c), 0.0) : material_value(m, slot);
    // Stored on every pass, a shifted one into the spare slot: a store under a branch costs
    // lavapipe a read-back for each lane it leaves out (docs/performance.md, fourteenth session).
    slot_cache[shifted ? MATERIAL_SLOTS : slot] = v;
    if (!shifted) {
      mask &= mask - 1u;
    } else {
      bump_disp_uv[k] = v.x;
      ++k;
    }
    if (mask == 0u && k >= shifts) break;
  }
}

// The shading geometry of the last bsdf_at with lobes after bump_shading (docs/bump-spec.md
// 6, 9), and whether a bump, normal map or vector turbulence changed it: the caller moves
// bsdf_frame into its SurfacePoint when bsdf_bumped (bsdf_at takes the SurfacePoint by value:
// an inout struct there made the render pipeline take 25% longer to compile on lavapipe).
bool bsdf_bumped;
BumpFrame bsdf_frame;

// Slot value of material m (the one slots_resolve was last called for) at sp.
vec4 slot_value(uint m, uint slot, SurfacePoint sp) {
  if (has_feature(FEATURE_TEXTURES) && ((slot_textured >> slot) & 1u) != 0u)
    return slot_cache[slot];
  return material_value(m, slot);
}

// Alpha of a roughness slot (docs/materials-spec.md 1.4).
float slot_alpha(uint m, uint slot, SurfacePoint sp) {
  return roughness_to_alpha(slot_value(m, slot, sp).x, material_head(m).y);
}

// pbrt-v4 MixMaterial::ChooseMaterial's hash as docs/materials-spec.md section 4 fixes it: a
// uniform float from the hit point and wo without their low 12 bits (q(x) = bits(x) >> 12, so
// that last-bit differences between the renderers rarely change the choice) and the mix's
// index.
float mix_hash(vec3 p, vec3 wo, uint index) {
  uvec3 qp = floatBitsToUint(p) >> 12u, qw = floatBitsToUint(wo) >> 12u;
  uint w = qw.x ^ (qw.y * 0x9E3779B9u) ^ (qw.z * 0x85EBCA6Bu);
  uvec4 v = pcg4d(uvec4(qp.x, qp.y, qp.z ^ (index * 0xC2B2AE35u), w));
  return float(v.x >> 8u) * (1.0 / 16777216.0);
}

// True if m indexes the material table.
bool material_valid(uint m) { return m < uint(materials.length()); }

// A lobe with every parameter zero.
Lobe lobe_new(uint tag, vec3 weight, uint flags, uint bits) {
  return Lobe(tag, bits | (flags << LOBEBIT_FLAGS_SHIFT), 0u, 0u, weight, vec4(0.0), vec4(0.0),
              vec4(0.0), vec4(0.0));
}

// Appends L to the lobe list if its weight has a component > 0 and there is room (constant
// indices only, see MULTI_LOBE_FEATURES).
void lobe_add(inout Bsdf b, Lobe L) {
  if (!any_positive(L.weight) || b.n >= MAX_LOBES) return;
  if (BSDF_ONE_LOBE) {
    bsdf_lobes[0] = L;
  } else {
    if (b.n == 0u) bsdf_lobes[0] = L;
    if (b.n == 1u) bsdf_lobes[1] = L;
    if (b.n == 2u) bsdf_lobes[2] = L;
    if (b.n == 3u) bsdf_lobes[3] = L;
    if (b.n == 4u) bsdf_lobes[4] = L;
    if (b.n == 5u) bsdf_lobes[5] = L;
    if (b.n == 6u) bsdf_lobes[6] = L;
    if (b.n == 7u) bsdf_lobes[7] = L;
  }
  b.n++;
  b.flags |= lobe_flags(L);
}

// MICROFACET_R (or SPECULAR_R when effectively smooth) with Fresnel `fresnel`: dielectric eta,
// or conductor eta, k.
Lobe microfacet_r_lobe(vec3 weight, float ax, float ay, uint mflags, uint fresnel, float eta,
                       vec3 ceta, vec3 ck) {
  bool smooth_ = max(ax, ay) < 1e-3;
  uint bits = fresnel | ((mflags & MATFLAG_BECKMANN) != 0u ? LOBEBIT_BECKMANN : 0u);
  Lobe L = lobe_new(smooth_ ? LOBE_SPECULAR_R : LOBE_MICROFACET_R, weight,
                    BSDF_REFLECTION | (smooth_ ? BSDF_SPECULAR : BSDF_GLOSSY), bits);
  L.p0 = vec4(mf_alphas(ax, ay), eta, 0.0);
  L.p1.xyz = ceta;
  L.p2.xyz = ck;
  return L;
}

// MICROFACET_T (or SPECULAR_T when effectively smooth) with IOR eta.
Lobe microfacet_t_lobe(vec3 weight, float ax, float ay, uint mflags, float eta) {
  bool smooth_ = max(ax, ay) < 1e-3;
  uint bits = (mflags & MATFLAG_BECKMANN) != 0u ? LOBEBIT_BECKMANN : 0u;
  Lobe L = lobe_new(smooth_ ? LOBE_SPECULAR_T : LOBE_MICROFACET_T, weight,
                    BSDF_TRANSMISSION | (smooth_ ? BSDF_SPECULAR : BSDF_GLOSSY), bits);
  L.p0 = vec4(mf_alphas(ax, ay), eta, 0.0);
  return L;
}

// Conductor eta and k of a material (docs/materials-spec.md section 3, CONDUCTOR): the slots,
// or with MATFLAG_USE_REFLECTANCE eta = 1, k = 2 sqrt(r) / sqrt(1 - r) (pbrt-v4
// ConductorMaterial) with r = clamp(reflectance, 0, 0.9999).
void conductor_eta_k(uint m, uint slot_eta, uint slot_k, uint slot_r, SurfacePoint sp,
                     out vec3 eta, out vec3 k) {
  if ((material_head(m).y & MATFLAG_USE_REFLECTANCE) != 0u) {
    vec3 r = clamp(slot_value(m, slot_r, sp).xyz, 0.0, 0.9999);
    eta = vec3(1.0);
    precise vec3 kk = 2.0 * sqrt(r) / sqrt(vec3(1.0) - r);
    k = kk;
  } else {
    eta = slot_value(m, slot_eta, sp).xyz;
    k = slot_value(m, slot_k, sp).xyz;
  }
}

// Appends the lobes of (non-mix) material m, weights scaled by `scale`
// (docs/materials-spec.md section 3). Each kind's case fills the candidates c0..c4 in order,
// and the lobe list is written at the five lobe_add calls after the switch: on lavapipe a
// store at a varying index of bsdf_lobes is a per-lane scatter, and one at each of the 23 places
// a kind appends a lobe made material-zoo's shading pipelines take 5 s longer to compile.
void add_material_lobes(inout Bsdf b, uint m, vec3 scale, SurfacePoint sp) {
  if (!material_valid(m)) return;
  Lobe none = lobe_new(LOBE_LAMBERT_R, vec3(0.0), 0u, 0u);  // lobe_add skips it
  Lobe c0 = none, c1 = none, c2 = none, c3 = none, c4 = none;
  uint type = material_head(m).x;
  uint mflags = material_head(m).y;
  uint beck = (mflags & MATFLAG_BECKMANN) != 0u ? LOBEBIT_BECKMANN : 0u;
  switch (type) {
    case MATERIAL_DIFFUSE:
      if (has_feature(FEATURE_MAT_DIFFUSE))
        // pbrt-v4 DiffuseMaterial clamps the reflectance to [0, 1].
        c0 = lobe_new(LOBE_LAMBERT_R,
                      scale * clamp(slot_value(m, SLOT_DIFFUSE_REFLECTANCE, sp).xyz, 0.0, 1.0),
                      BSDF_REFLECTION | BSDF_DIFFUSE, 0u);
      break;
    case MATERIAL_OREN_NAYAR:
      if (has_feature(FEATURE_MAT_OREN_NAYAR)) {
        vec3 kd = scale * slot_value(m, SLOT_ON_REFLECTANCE, sp).xyz;
        float sigma = slot_value(m, SLOT_ON_SIGMA, sp).x;
        if (sigma == 0.0) {
          c0 = lobe_new(LOBE_LAMBERT_R, kd, BSDF_REFLECTION | BSDF_DIFFUSE, 0u);
        } else {
          // pbrt-v3 OrenNayar constructor: A, B from sigma in radians.
          Lobe L = lobe_new(LOBE_OREN_NAYAR, kd, BSDF_REFLECTION | BSDF_DIFFUSE, 0u);
          precise float sr = (PI / 180.0) * sigma;
          precise float s2 = sr * sr;
          precise float A = 1.0 - (s2 / (2.0 * (s2 + 0.33)));
          precise float B = 0.45 * s2 / (s2 + 0.09);
          L.p0.xy = vec2(A, B);
          c0 = L;
        }
      }
      break;
    case MATERIAL_MEASURED:
      if (has_feature(FEATURE_MAT_MEASURED)) {
        Lobe L = lobe_new(LOBE_MEASURED, scale, BSDF_REFLECTION | BSDF_GLOSSY, 0u);
        L.aux = material_head(m).z;
        L.p0.xyz = material_value(m, SLOT_MEASURED_DIMS).xyz;
        c0 = L;
      }
      break;
#if BSDF_ALL_MATERIALS
    case MATERIAL_CONDUCTOR:
      if (has_feature(FEATURE_MAT_CONDUCTOR)) {
        Lobe L = lobe_new(LOBE_CONDUCTOR, scale, 0u, beck);
        L.p0.xy = mf_alphas(slot_alpha(m, SLOT_CONDUCTOR_UROUGH, sp), slot_alpha(m, SLOT_CONDUCTOR_VROUGH, sp));
        vec3 eta, k;
        conductor_eta_k(m, SLOT_CONDUCTOR_ETA, SLOT_CONDUCTOR_K, SLOT_CONDUCTOR_REFLECTANCE, sp, eta, k);
        L.p1.xyz = eta;
        L.p2.xyz = k;
        L.bits |= (BSDF_REFLECTION | (mf_smooth(lobe_dist(L)) ? BSDF_SPECULAR : BSDF_GLOSSY))
                  << LOBEBIT_FLAGS_SHIFT;
        c0 = L;
      }
      break;
    case MATERIAL_METAL:
      if (has_feature(FEATURE_MAT_METAL))
        c0 = microfacet_r_lobe(scale, slot_alpha(m, SLOT_CONDUCTOR_UROUGH, sp),
                               slot_alpha(m, SLOT_CONDUCTOR_VROUGH, sp), mflags, FRESNEL_CONDUCTOR,
                               1.0, slot_value(m, SLOT_CONDUCTOR_ETA, sp).xyz,
                               slot_value(m, SLOT_CONDUCTOR_K, sp).xyz);
      break;
    case MATERIAL_MIRROR:
      if (has_feature(FEATURE_MAT_MIRROR))
        c0 = lobe_new(LOBE_SPECULAR_R, scale * slot_value(m, SLOT_MIRROR_KR, sp).xyz,
                      BSDF_REFLECTION | BSDF_SPECULAR, FRESNEL_ONE);
      break;
    case MATERIAL_DIELECTRIC:
      if (has_feature(FEATURE_MAT_DIELECTRIC)) {
        Lobe L = lobe_new(LOBE_DIELECTRIC, scale, 0u, beck);
        L.p0.xyz = vec3(mf_alphas(slot_alpha(m, SLOT_DIELECTRIC_UROUGH, sp), slot_alpha(m, SLOT_DIELECTRIC_VROUGH, sp)),
                        slot_value(m, SLOT_DIELECTRIC_ETA, sp).x);
        L.p1.xyz = slot_value(m, SLOT_DIELECTRIC_KR, sp).xyz;
        L.p2.xyz = slot_value(m, SLOT_DIELECTRIC_KT, sp).xyz;
        L.bits |= dielectric_flags(L.p0.z, lobe_dist(L)) << LOBEBIT_FLAGS_SHIFT;
        c0 = L;
      }
      break;
    case MATERIAL_THIN_DIELECTRIC:
      if (has_feature(FEATURE_MAT_THIN_DIELECTRIC)) {
        Lobe L = lobe_new(LOBE_THIN_DIELECTRIC, scale,
                          BSDF_REFLECTION | BSDF_TRANSMISSION | BSDF_SPECULAR, 0u);
        L.p0.z = slot_value(m, SLOT_THIN_ETA, sp).x;
        c0 = L;
      }
      break;
    case MATERIAL_DIFFUSE_TRANSMISSION:
      if (has_feature(FEATURE_MAT_DIFFUSE_TRANSMISSION)) {
        float s = slot_value(m, SLOT_DT_SCALE, sp).x;
        vec3 R = clamp(s * slot_value(m, SLOT_DT_REFLECTANCE, sp).xyz, 0.0, 1.0);  // as pbrt-v4
        vec3 T = clamp(s * slot_value(m, SLOT_DT_TRANSMITTANCE, sp).xyz, 0.0, 1.0);
        uint flags = (nonzero(R) ? (BSDF_REFLECTION | BSDF_DIFFUSE) : 0u) |
                     (nonzero(T) ? (BSDF_TRANSMISSION | BSDF_DIFFUSE) : 0u);
        Lobe L = lobe_new(LOBE_DIFFUSE_TRANSMISSION, scale, flags, 0u);
        L.p1.xyz = R;
        L.p2.xyz = T;
        c0 = L;
      }
      break;
    case MATERIAL_COATED_DIFFUSE:
    case MATERIAL_COATED_CONDUCTOR:
      if ((has_feature(FEATURE_MAT_COATED_DIFFUSE) && type == MATERIAL_COATED_DIFFUSE) ||
          (has_feature(FEATURE_MAT_COATED_CONDUCTOR) && type == MATERIAL_COATED_CONDUCTOR)) {
        bool cd = type == MATERIAL_COATED_DIFFUSE;
        Lobe L = lobe_new(cd ? LOBE_LAYERED_DIFFUSE : LOBE_LAYERED_CONDUCTOR, scale, 0u, beck);
        L.aux = (material_head(m).z & 0xffffu) | (material_head(m).w << 16u);
        if ((material_head(m).y & MATFLAG_LAYERED_PBRT_MIS) != 0u) L.bits |= LOBEBIT_PBRT_MIS;
        if (cd) {
          L.p0 = vec4(mf_alphas(slot_alpha(m, SLOT_CD_UROUGH, sp), slot_alpha(m, SLOT_CD_VROUGH, sp)),
                      slot_value(m, SLOT_CD_ETA, sp).x, slot_value(m, SLOT_CD_THICKNESS, sp).x);
          // pbrt-v4 clamps reflectance and albedo to [0, 1] and g to [-1, 1].
          L.p1 = vec4(clamp(slot_value(m, SLOT_CD_ALBEDO, sp).xyz, 0.0, 1.0),
                      clamp(slot_value(m, SLOT_CD_G, sp).x, -1.0, 1.0));
          L.p2.xyz = clamp(slot_value(m, SLOT_CD_REFLECTANCE, sp).xyz, 0.0, 1.0);
        } else {
          L.p0 = vec4(mf_alphas(slot_alpha(m, SLOT_CC_IF_UROUGH, sp), slot_alpha(m, SLOT_CC_IF_VROUGH, sp)),
                      slot_value(m, SLOT_CC_IF_ETA, sp).x, slot_value(m, SLOT_CC_THICKNESS, sp).x);
          L.p1 = vec4(clamp(slot_value(m, SLOT_CC_ALBEDO, sp).xyz, 0.0, 1.0),
                      clamp(slot_value(m, SLOT_CC_G, sp).x, -1.0, 1.0));
          vec3 eta, k;
          conductor_eta_k(m, SLOT_CC_ETA, SLOT_CC_K, SLOT_CC_REFLECTANCE, sp, eta, k);
          // pbrt-v4 CoatedConductorMaterial: conductor eta and k relative to the coat's eta
          if (L.p0.z == 0.0) L.p0.z = 1.0;
          eta /= L.p0.z;
          k /= L.p0.z;
          vec2 a = mf_alphas(slot_alpha(m, SLOT_CC_UROUGH, sp), slot_alpha(m, SLOT_CC_VROUGH, sp));
          L.p2 = vec4(eta, a.x);
          L.p3 = vec4(k, a.y);
        }
        L.bits |= layered_flags(layers_of(L)) << LOBEBIT_FLAGS_SHIFT;
        c0 = L;
      }
      break;
    case MATERIAL_PLASTIC:
      if (has_feature(FEATURE_MAT_PLASTIC)) {
        c0 = lobe_new(LOBE_LAMBERT_R, scale * slot_value(m, SLOT_PLASTIC_KD, sp).xyz,
                      BSDF_REFLECTION | BSDF_DIFFUSE, 0u);
        float a = slot_alpha(m, SLOT_PLASTIC_ROUGH, sp);
        c1 = microfacet_r_lobe(scale * slot_value(m, SLOT_PLASTIC_KS, sp).xyz, a, a, mflags,
                               FRESNEL_DIELECTRIC, 1.5, vec3(0.0), vec3(0.0));
      }
      break;
    case MATERIAL_SUBSTRATE:
      if (has_feature(FEATURE_MAT_SUBSTRATE)) {
        Lobe L = lobe_new(LOBE_FRESNEL_BLEND, scale, BSDF_REFLECTION | BSDF_GLOSSY, beck);
        L.p0.xy = max(vec2(slot_alpha(m, SLOT_SUBSTRATE_UROUGH, sp), slot_alpha(m, SLOT_SUBSTRATE_VROUGH, sp)),
                      vec2(1e-3));
        L.p1.xyz = slot_value(m, SLOT_SUBSTRATE_KD, sp).xyz;
        L.p2.xyz = slot_value(m, SLOT_SUBSTRATE_KS, sp).xyz;
        c0 = L;
      }
      break;
    case MATERIAL_TRANSLUCENT:
      if (has_feature(FEATURE_MAT_TRANSLUCENT)) {
        vec3 r = slot_value(m, SLOT_TRANSLUCENT_REFLECT, sp).xyz;
        vec3 t = slot_value(m, SLOT_TRANSLUCENT_TRANSMIT, sp).xyz;
        if (any_positive(r) || any_positive(t)) {
          vec3 kd = slot_value(m, SLOT_TRANSLUCENT_KD, sp).xyz;
          vec3 ks = slot_value(m, SLOT_TRANSLUCENT_KS, sp).xyz;
          float a = slot_alpha(m, SLOT_TRANSLUCENT_ROUGH, sp);
          c0 = lobe_new(LOBE_LAMBERT_R, scale * (r * kd), BSDF_REFLECTION | BSDF_DIFFUSE, 0u);
          c1 = lobe_new(LOBE_LAMBERT_T, scale * (t * kd), BSDF_TRANSMISSION | BSDF_DIFFUSE, 0u);
          c2 = microfacet_r_lobe(scale * (r * ks), a, a, mflags, FRESNEL_DIELECTRIC, 1.5,
                                 vec3(0.0), vec3(0.0));
          c3 = microfacet_t_lobe(scale * (t * ks), a, a, mflags, 1.5);
        }
      }
      break;
    case MATERIAL_UBER:
      if (has_feature(FEATURE_MAT_UBER)) {
        vec3 op = slot_value(m, SLOT_UBER_OPACITY, sp).xyz;
        float eta = slot_value(m, SLOT_UBER_ETA, sp).x;
        c0 = lobe_new(LOBE_SPECULAR_T, scale * (vec3(1.0) - op), BSDF_TRANSMISSION | BSDF_SPECULAR,
                      0u);
        c0.p0.z = 1.0;
        c1 = lobe_new(LOBE_LAMBERT_R, scale * (op * slot_value(m, SLOT_UBER_KD, sp).xyz),
                      BSDF_REFLECTION | BSDF_DIFFUSE, 0u);
        c2 = microfacet_r_lobe(scale * (op * slot_value(m, SLOT_UBER_KS, sp).xyz),
                               slot_alpha(m, SLOT_UBER_UROUGH, sp),
                               slot_alpha(m, SLOT_UBER_VROUGH, sp), mflags, FRESNEL_DIELECTRIC, eta,
                               vec3(0.0), vec3(0.0));
        c3 = lobe_new(LOBE_SPECULAR_R, scale * (op * slot_value(m, SLOT_UBER_KR, sp).xyz),
                      BSDF_REFLECTION | BSDF_SPECULAR, FRESNEL_DIELECTRIC);
        c3.p0.z = eta;
        c4 = lobe_new(LOBE_SPECULAR_T, scale * (op * slot_value(m, SLOT_UBER_KT, sp).xyz),
                      BSDF_TRANSMISSION | BSDF_SPECULAR, 0u);
        c4.p0.z = eta;
      }
      break;
#endif
    default:
      break;
  }
  lobe_add(b, c0);
  lobe_add(b, c1);
  lobe_add(b, c2);
  lobe_add(b, c3);
  lobe_add(b, c4);
}

// The BSDF of material `material` at sp seen from wo_world (-ray direction): stochastic mixes
// resolved (docs/materials-spec.md section 4: INVALID_INDEX / MATERIAL_NONE for an invalid
// index or more than 16 nested mixes), then, if `lobes`, the lobes of the chosen material
// (section 3), or those of both MIX_WEIGHTED children with weights x (1 - amount) and
// x amount. One loop visits each material involved and resolves its slots at one call site
// of slots_resolve (see slot_cache), and add_material_lobes has one call site too.
// With lobes, the chosen material's bump or normal map and vector turbulence
// (docs/bump-spec.md 6, 9) then set bsdf_bumped and bsdf_frame, the shading geometry the
// caller uses from then on.
Bsdf bsdf_at(uint material, SurfacePoint sp, vec3 wo_world, bool lobes) {
  Bsdf b = Bsdf(0u, 0u, INVALID_INDEX, MATERIAL_NONE);
  uint m = material;
  if (BUMP_ENABLED || NORMALMAP_ENABLED || VTURB_ENABLED) bsdf_bumped = false;
#if !BSDF_ALL_MATERIALS
  if (!material_valid(m)) return b;
  b.material = m;
  b.type = material_head(m).x;
  if (lobes) {
    slots_resolve(m, sp);
    add_material_lobes(b, m, vec3(1.0), sp);
  }
#else
  uint level = 0u;              // stochastic mixes passed
  bool resolved = false;        // m is the chosen (non-stochastic-mix) material
  uint pending = INVALID_INDEX; // second child of a weighted mix, still to add
  vec3 scale = vec3(1.0), pending_scale = vec3(0.0);
  [[dont_unroll]] for (uint step = 0u; step < 20u; ++step) {
    if (!material_valid(m)) return Bsdf(0u, 0u, INVALID_INDEX, MATERIAL_NONE);
    uint type = material_head(m).x;
    bool stochastic = has_feature(FEATURE_MAT_MIX) && type == MATERIAL_MIX;
    if (resolved && !lobes) break;
    if (!resolved && !stochastic) {
      resolved = true;
      b.material = m;
      b.type = type;
      if (!lobes) break;
    }
    slots_resolve(m, sp);
    if (stochastic) {
      if (level == 16u) return Bsdf(0u, 0u, INVALID_INDEX, MATERIAL_NONE);
      ++level;
      float a = slot_value(m, SLOT_MIX_AMOUNT, sp).x;
      if (a <= 0.0) m = material_head(m).z;
      else if (a >= 1.0) m = material_head(m).w;
      else m = a < mix_hash(sp.p, wo_world, m) ? material_head(m).z : material_head(m).w;
      continue;
    }
    if (has_feature(FEATURE_MAT_MIX_WEIGHTED) && type == MATERIAL_MIX_WEIGHTED &&
        m == b.material) {
      vec3 amount = clamp(slot_value(m, SLOT_MIX_AMOUNT, sp).xyz, 0.0, 1.0);
      pending = material_head(m).w;
      pending_scale = amount;
      scale = vec3(1.0) - amount;
      m = material_head(m).z;
      continue;
    }
    add_material_lobes(b, m, scale, sp);
    if (pending == INVALID_INDEX) break;
    m = pending;
    scale = pending_scale;
    pending = INVALID_INDEX;
  }
#endif
  // The chosen material's bump or normal map, from its slots as slots_resolve left them (a
  // weighted mix, whose children are resolved after it, has neither: the host refuses them),
  // then its vector turbulence (docs/bump-spec.md 9).
  if ((BUMP_ENABLED || NORMALMAP_ENABLED || VTURB_ENABLED) && lobes &&
      b.material != INVALID_INDEX)
    bsdf_bumped = bump_shading(b.material, sp, slot_value(b.material, SLOT_DISPLACEMENT, sp).x,
                               bump_disp_uv,
                               bsdf_frame);
  return b;
}

// Union of the lobe flags (BSDF_*); non-specular if it has BSDF_DIFFUSE or BSDF_GLOSSY.
uint bsdf_flags(Bsdf b) { return b.flags; }

// What a lobe or BSDF query computes: f(wo, wi), pdf(wo, wi), or a sample.
const uint QUERY_F = 1u;
const uint QUERY_PDF = 2u;
const uint QUERY_SAMPLE = 4u;

// One lobe's f (without its weight; 0 for specular lobes) and/or pdf (0 for specular lobes) at
// (wo, wi), or its sample with u = (u_lobe', u0, u1) (QUERY_SAMPLE), f without the weight;
// stochastic lobes draw from `stream`, their pdf from `pdf_stream`. One switch for the three
// operations, so that every lobe's code is inlined once per call site of this function
// (bsdf_query has one).
void lobe_query(Lobe L, uint q, vec3 wo, vec3 wi, vec3 u, uvec4 stream, uvec4 pdf_stream,
                out vec3 f, out float pdf, out BsdfSample bs) {
  f = vec3(0.0);
  pdf = 0.0;
  bs = no_sample();
  bool smp = q == QUERY_SAMPLE;
  bool same = same_hemisphere(wo, wi);
  switch (L.tag) {
    case LOBE_LAMBERT_R:
    case LOBE_OREN_NAYAR:
    case LOBE_MEASURED:
    case LOBE_LAMBERT_T:
      if (has_feature(LOBE_FEATURES_LAMBERT_R | LOBE_FEATURES_OREN_NAYAR | LOBE_FEATURES_MEASURED |
                      LOBE_FEATURES_LAMBERT_T)) {
        // Cosine-weighted hemisphere lobes: pbrt-v4 DiffuseBxDF sampling (pbrt-v3 BxDF default
        // Sample_f for Oren-Nayar and measured), on the side opposite wo for LAMBERT_T.
        bool trans = has_feature(LOBE_FEATURES_LAMBERT_T) && L.tag == LOBE_LAMBERT_T;
        if (smp) {
          wi = cosine_hemisphere(u.yz);
          if ((wo.z < 0.0) != trans) wi.z = -wi.z;
          same = same_hemisphere(wo, wi);
          uint flags = L.tag == LOBE_MEASURED ? BSDF_GLOSSY : BSDF_DIFFUSE;
          bs = BsdfSample(vec3(0.0), cosine_pdf(wi), wi,
                          flags | (trans ? BSDF_TRANSMISSION : BSDF_REFLECTION), 1.0, false);
        }
        if (same == trans) break;
        if (has_feature(LOBE_FEATURES_OREN_NAYAR) && L.tag == LOBE_OREN_NAYAR)
          f = vec3(oren_nayar_f(L.p0.xy, wo, wi));
        else if (has_feature(LOBE_FEATURES_MEASURED) && L.tag == LOBE_MEASURED)
          f = measured_f(L.aux, L.p0.xyz, wo, wi);
        else
          f = vec3(INV_PI);
        pdf = cosine_pdf(wi);
        bs.f = f;
      }
      break;
#if BSDF_ALL_MATERIALS
    case LOBE_MICROFACET_R:
    case LOBE_FRESNEL_BLEND:
      if (has_feature(LOBE_FEATURES_MICROFACET_R | LOBE_FEATURES_FRESNEL_BLEND)) {
        // pbrt-v3 MicrofacetReflection / FresnelBlend (f, Pdf, Sample_f: f re-evaluated at
        // wi; MicrofacetReflection's sample pdf from the sampled normal, FresnelBlend's from
        // Pdf; FresnelBlend's choice by u_lobe' < 0.5, docs/materials-spec.md 2.3).
        bool blend = has_feature(LOBE_FEATURES_FRESNEL_BLEND) && L.tag == LOBE_FRESNEL_BLEND;
        vec3 ws = vec3(0.0);
        if (smp) {
          if (blend && u.x < 0.5) {
            wi = to_side_of(cosine_hemisphere(u.yz), wo);
          } else {
            ws = mf_sample_wm(lobe_dist(L), wo, u.yz);
            wi = reflect_about(wo, ws);
            if (!same_hemisphere(wo, wi)) break;
          }
        }
        if (blend) fresnel_blend_eval(L, wo, wi, f, pdf);
        else microfacet_r_eval(L, wo, wi, ws, f, pdf);
        if (smp) bs = BsdfSample(f, pdf, wi, BSDF_REFLECTION | BSDF_GLOSSY, 1.0, false);
      }
      break;
    case LOBE_MICROFACET_T:
      if (has_feature(LOBE_FEATURES_MICROFACET_T)) {
        if (smp && !microfacet_t_sample_wi(L, wo, u.yz, wi)) break;
        float ft;
        microfacet_t_eval(L, wo, wi, ft, pdf);
        f = vec3(ft);
        if (smp) {
          // eta = etaT / etaI of pbrt-v3 MicrofacetTransmission (etaA = 1, etaB = eta)
          float e = wo.z > 0.0 ? L.p0.z : 1.0 / L.p0.z;
          bs = BsdfSample(f, pdf, wi, BSDF_TRANSMISSION | BSDF_GLOSSY, e, false);
        }
      }
      break;
    case LOBE_SPECULAR_R:
      if (has_feature(LOBE_FEATURES_SPECULAR_R) && smp) bs = specular_r_sample(L, wo);
      break;
    case LOBE_SPECULAR_T:
      if (has_feature(LOBE_FEATURES_SPECULAR_T) && smp) bs = specular_t_sample(L, wo);
      break;
    case LOBE_CONDUCTOR:
    case LOBE_DIELECTRIC:
      if (has_feature(LOBE_FEATURES_CONDUCTOR | LOBE_FEATURES_DIELECTRIC)) {
        // pbrt-v4 ConductorBxDF, or DielectricBxDF with reflection scaled by Kr and
        // transmission by Kt (pbrt-v3 glass). A scene with both lobes runs one
        // mf_interface_query for them, not both queries (lavapipe runs every case).
        bool conductor = L.tag == LOBE_CONDUCTOR;
        BsdfSample c;
        if (has_feature(LOBE_FEATURES_CONDUCTOR) && has_feature(LOBE_FEATURES_DIELECTRIC))
          c = mf_interface_query(conductor, L.p0.z, L.p1.xyz, L.p2.xyz, lobe_dist(L), wo, wi, u.x,
                                 u.yz, smp, true, SAMPLE_ALL);
        else if (has_feature(LOBE_FEATURES_CONDUCTOR))
          c = conductor_query(L.p1.xyz, L.p2.xyz, lobe_dist(L), wo, wi, u.yz, smp);
        else
          c = dielectric_query(L.p0.z, lobe_dist(L), wo, wi, u.x, u.yz, smp, true, SAMPLE_ALL);
        bool refl = smp ? (c.flags & BSDF_REFLECTION) != 0u : same;
        f = conductor ? c.f : c.f.x * (refl ? L.p1.xyz : L.p2.xyz);
        pdf = c.pdf;
        bs = c;
        bs.f = f;
      }
      break;
    case LOBE_THIN_DIELECTRIC:
      if (has_feature(LOBE_FEATURES_THIN_DIELECTRIC) && smp)
        bs = thin_dielectric_sample(L.p0.z, wo, u.x);
      break;
    case LOBE_DIFFUSE_TRANSMISSION:
      if (has_feature(LOBE_FEATURES_DIFFUSE_TRANSMISSION)) {
        if (smp) {
          bs = dt_sample(L.p1.xyz, L.p2.xyz, wo, u.x, u.yz);
        } else {
          f = same ? L.p1.xyz * INV_PI : L.p2.xyz * INV_PI;
          pdf = dt_pdf(L.p1.xyz, L.p2.xyz, wo, wi);
        }
      }
      break;
    case LOBE_LAYERED_DIFFUSE:
    case LOBE_LAYERED_CONDUCTOR:
      if (has_feature(LOBE_FEATURES_LAYERED)) {
        layered_query(L, smp, (q & QUERY_F) != 0u, (q & QUERY_PDF) != 0u, wo, wi, u.x, u.yz,
                      stream, pdf_stream, f, pdf, bs);
      }
      break;
#endif
    default:
      break;
  }
}

// Result of a BSDF query: f and pdf (QUERY_F / QUERY_PDF) or the sample (QUERY_SAMPLE).
struct BsdfQuery {
  vec3 f;
  float pdf;
  BsdfSample bs;
};

// True if the lobe has a non-specular part (it contributes to f and pdf).
bool lobe_nonspecular(Lobe L) { return (lobe_flags(L) & (BSDF_DIFFUSE | BSDF_GLOSSY)) != 0u; }

// True if wi's side decided by the geometric normal (materials-spec 1.2) is reflection.
bool geo_reflect(vec3 wo, vec3 wi, vec3 ng) { return dot_exact(wo, ng) * dot_exact(wi, ng) > 0.0; }

// The BSDF operations of docs/materials-spec.md 1.2 and 1.3 behind one entry point, so that a
// shader calling it from a single site (the integrator's bounce loop, the probe) inlines the
// lobes once (lavapipe inlines every call before it folds the feature constants away):
// - QUERY_F and/or QUERY_PDF: f = sum of weight x lobe f with wi.z negated where the geometric
//   and shading hemisphere decisions disagree; pdf = (sum of the non-specular lobes' pdfs) / n,
//   0 where they disagree.
// - QUERY_SAMPLE with u = (u_lobe, u0, u1): lobe k = min(floor(u_lobe n), n - 1) samples with
//   u_lobe' = min(u_lobe n - k, OneMinusEpsilon) (pbrt-v3 BSDF::Sample_f); a sample whose kind
//   disagrees with the geometric normal is none; specular, stochastic (pdf_is_proportional) and
//   single-lobe samples keep their f (weight applied) and pdf / n, others take f and pdf of
//   all lobes at wi (none if the sampled lobe's own pdf there is below FLT_MIN, pbrt-v3);
//   empty samples (f = 0, pdf = 0, wi.z = 0) are none (pbrt-v4 BSDF::Sample_f).
// The stochastic lobes' f and samples draw from `stream`, their pdf from `pdf_stream` (the
// integrator asks f and pdf of the NEE direction in one query, from their two streams).
BsdfQuery bsdf_query2(Bsdf b, uint op, vec3 wo, vec3 wi, vec3 u, vec3 ng, uvec4 stream,
                      uvec4 pdf_stream) {
  BsdfQuery r = BsdfQuery(vec3(0.0), 0.0, no_sample());
  if (wo.z == 0.0 || b.n == 0u) return r;
  bool sampling = op == QUERY_SAMPLE;
  float n = float(b.n);
  uint ks = 0u;
  vec3 ul = u;
  uint q = op;
  if (sampling) {
    ks = min(uint(floor(u.x * n)), b.n - 1u);
    precise float u_lobe = min(u.x * n - float(ks), ONE_MINUS_EPSILON);
    ul.x = u_lobe;
  } else if (geo_reflect(wo, wi, ng) != (wo.z * wi.z > 0.0)) {
    wi.z = -wi.z;  // light-leak rule: evaluate on the side the geometry decides
    q &= ~QUERY_PDF;
    if (q == 0u) return r;
  }
  // Job t: the lobe sample first (t = 0 when sampling), then f / pdf of lobe k = t - first.
  uint first = sampling ? 1u : 0u;
  float own_pdf = 0.0;  // the sampled lobe's pdf at its wi (re-evaluated samples)
  uint t = 0u;
  [[dont_unroll]] while (true) {
    uint k = (sampling && t == 0u) ? ks : t - first;
    Lobe L = bsdf_lobe(k);
    bool lobe_sampling = sampling && t == 0u;
    if (lobe_sampling || lobe_nonspecular(L)) {
      vec3 f;
      float pdf;
      BsdfSample bs;
      // The re-evaluation at a sample's wi draws f and pdf from the sample's stream.
      lobe_query(L, lobe_sampling ? QUERY_SAMPLE : q, wo, wi, ul, stream,
                 sampling ? stream : pdf_stream, f, pdf, bs);
      if (lobe_sampling) {
        r.bs = bs;
        if (bs.flags == 0u) break;
        if (((bs.flags & BSDF_REFLECTION) != 0u) != geo_reflect(wo, bs.wi, ng)) {
          r.bs = no_sample();
          break;
        }
        if (bs.pdf_is_proportional || (bs.flags & BSDF_SPECULAR) != 0u || b.n == 1u) {
          r.bs.f = L.weight * bs.f;
          r.bs.pdf = bs.pdf / n;
          break;
        }
        wi = bs.wi;
        q = QUERY_F | QUERY_PDF;
        if (geo_reflect(wo, wi, ng) != (wo.z * wi.z > 0.0)) {
          wi.z = -wi.z;
          q = QUERY_F;
        }
      } else {
        if ((q & QUERY_F) != 0u) r.f += L.weight * f;
        if ((q & QUERY_PDF) != 0u) r.pdf += pdf;
        if (sampling && k == ks) own_pdf = pdf;
      }
    }
    ++t;
    if (t >= first + b.n) break;
  }
  if (!sampling) {
    r.pdf /= n;
  } else if (r.bs.flags != 0u) {
    if (b.n > 1u && !r.bs.pdf_is_proportional && (r.bs.flags & BSDF_SPECULAR) == 0u) {
      r.bs.f = r.f;
      r.bs.pdf = own_pdf < FLT_MIN ? 0.0 : r.pdf / n;  // pbrt-v3: the lobe's own pdf > 0
    }
    if (!usable(r.bs)) r.bs = no_sample();
  }
  return r;
}

// bsdf_query2 with one stream for everything.
BsdfQuery bsdf_query(Bsdf b, uint op, vec3 wo, vec3 wi, vec3 u, vec3 ng, uvec4 stream) {
  return bsdf_query2(b, op, wo, wi, u, ng, stream, stream);
}

// f(wo, wi) of the BSDF (docs/materials-spec.md 1.2, 1.3); see bsdf_query.
vec3 bsdf_eval(Bsdf b, vec3 wo, vec3 wi, vec3 ng, uvec4 stream) {
  return bsdf_query(b, QUERY_F, wo, wi, vec3(0.0), ng, stream).f;
}

// Solid-angle pdf of bsdf_sample producing wi (docs/materials-spec.md 1.2, 1.3).
float bsdf_pdf(Bsdf b, vec3 wo, vec3 wi, vec3 ng, uvec4 stream) {
  return bsdf_query(b, QUERY_PDF, wo, wi, vec3(0.0), ng, stream).pdf;
}

// Samples wi with u = (u_lobe, u0, u1) (docs/materials-spec.md 1.3).
BsdfSample bsdf_sample(Bsdf b, vec3 wo, vec3 u, vec3 ng, uvec4 stream) {
  return bsdf_query(b, QUERY_SAMPLE, wo, vec3(0.0), u, ng, stream).bs;
}

#endif
