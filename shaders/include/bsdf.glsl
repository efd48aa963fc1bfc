// BSDFs in the local shading frame (z = shading normal), one switch on Material.type per
// operation (docs/path-spec.md section 8). Needs bindings.glsl.
#ifndef BASALT_BSDF_GLSL
#define BASALT_BSDF_GLSL

#include "math.glsl"
#include "sampling.glsl"
#include "surface.glsl"


// The BSDF at a surface point: the material's type tag and its slot values evaluated there
// (constants now; textures later issues).
struct Bsdf {
  uint type;
  vec3 r;  // diffuse: reflectance
};

// A sampled direction: f, incident direction wi (local), pdf and BSDF_* flags;
// pdf == 0 means no sample.
struct BsdfSample {
  vec3 f;
  float pdf;
  vec3 wi;
  uint flags;
};

// Evaluates the slots of material m at surface point sp into a Bsdf.
Bsdf bsdf_at(uint m, SurfacePoint sp) {
  Bsdf bsdf;
  bsdf.type = m == INVALID_INDEX ? 0u : materials[m].type;
  bsdf.r = vec3(0.0);
  switch (bsdf.type) {
    case MATERIAL_DIFFUSE:
      if ((FEATURES & FEATURE_MAT_DIFFUSE) != 0u)
        bsdf.r = materials[m].value[SLOT_DIFFUSE_REFLECTANCE].xyz;
      break;
    default:
      break;
  }
  return bsdf;
}

// True if the BSDF is a pure delta distribution (no light sampling, no MIS).
bool bsdf_is_specular(Bsdf bsdf) {
  return false;  // diffuse is the only type so far
}

// f(wo, wi) in the local frame (pbrt-v4 BxDF::f).
vec3 bsdf_eval(Bsdf bsdf, vec3 wo, vec3 wi) {
  switch (bsdf.type) {
    case MATERIAL_DIFFUSE:
      // pbrt-v4 9.2 DiffuseBxDF: R / pi in the same hemisphere.
      if ((FEATURES & FEATURE_MAT_DIFFUSE) != 0u && wo.z * wi.z > 0.0) return bsdf.r / PI;
      break;
    default:
      break;
  }
  return vec3(0.0);
}

// Solid-angle pdf with which bsdf_sample produces wi given wo (pbrt-v4 BxDF::PDF).
float bsdf_pdf(Bsdf bsdf, vec3 wo, vec3 wi) {
  switch (bsdf.type) {
    case MATERIAL_DIFFUSE:
      // Cosine-weighted hemisphere of wo (pbrt-v4 A.5.3 CosineHemispherePDF).
      if ((FEATURES & FEATURE_MAT_DIFFUSE) != 0u && wo.z * wi.z > 0.0) return abs(wi.z) / PI;
      break;
    default:
      break;
  }
  return 0.0;
}

// Samples wi given wo with u = (lobe choice, direction u0, u1) (pbrt-v4 BxDF::Sample_f;
// docs/path-spec.md sections 1 and 8).
BsdfSample bsdf_sample(Bsdf bsdf, vec3 wo, vec3 u) {
  BsdfSample bs = BsdfSample(vec3(0.0), 0.0, vec3(0.0, 0.0, 1.0), 0u);
  switch (bsdf.type) {
    case MATERIAL_DIFFUSE:
      if ((FEATURES & FEATURE_MAT_DIFFUSE) != 0u) {
        // pbrt-v4 A.5.3 SampleCosineHemisphere (Malley's method), flipped to wo's side.
        vec2 d = concentric_disk(u.yz);
        vec3 wi = vec3(d.x, d.y, safe_sqrt(1.0 - d.x * d.x - d.y * d.y));
        if (wo.z < 0.0) wi.z = -wi.z;
        bs.wi = wi;
        bs.f = bsdf_eval(bsdf, wo, wi);
        bs.pdf = bsdf_pdf(bsdf, wo, wi);
        bs.flags = BSDF_REFLECTION | BSDF_DIFFUSE;
      }
      break;
    default:
      break;
  }
  return bs;
}

#endif
