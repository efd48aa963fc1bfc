// The body of pbrt-v4's DielectricBxDF and ConductorBxDF in one function, included by lobes.glsl
// once for each MF_INTERFACE_KIND: 2, the interface chosen by the argument (mf_interface_query,
// for a layered walk that picks its top or its conductor bottom at run time); 1, the conductor
// (mf_interface_conductor); 0, the dielectric (mf_interface_dielectric). In the constant
// variants `conductor` is a compile-time constant, so the specialisation folds the other
// interface away before anything is inlined: a call site whose interface is known carries none
// of the other's code (docs/performance.md, sixteenth session). No include guard: lobes.glsl
// defines MF_INTERFACE_NAME and MF_INTERFACE_KIND before each inclusion.

// pbrt-v4 DielectricBxDF (conductor false: IOR eta, f unscaled in .x, radiance or importance
// mode, sample flags sflags) or ConductorBxDF (conductor true: complex IOR (c_eta, c_k),
// reflection only; eta, uc, radiance and sflags unused): Sample_f (smp, with uc and u) or f and
// PDF at (wo, wi). f, pdf, wi, flags and etap in the returned sample (flags 0 when smp finds
// none). One microfacet sample and one evaluation serve both: a walk that picks its interface
// at run time runs them once, not once for each (lavapipe runs both sides of a branch).
BsdfSample MF_INTERFACE_NAME(bool conductor_arg, float eta, vec3 c_eta, vec3 c_k, MfDist d,
                             vec3 wo, vec3 wi, float uc, vec2 u, bool smp, bool radiance, uint sflags) {
#if MF_INTERFACE_KIND == 2
  bool conductor = conductor_arg;
#else
  const bool conductor = MF_INTERFACE_KIND == 1;  // a constant: the other interface folds away
#endif
  BsdfSample r = no_sample();
  bool smooth_ = (!conductor && eta == 1.0) || mf_smooth(d);
  // The conductor's f and PDF are 0 across its surface.
  if (!smp && (smooth_ || (conductor && !same_hemisphere(wo, wi)))) return r;
  vec3 wm = vec3(0.0, 0.0, 1.0);
  float etap = 1.0;
  bool reflect = true;
  if (smp) {
    if (!smooth_) {
      if (conductor && wo.z == 0.0) return r;
      wm = mf_sample_wm(d, wo, u);
    }
  } else {
    // Generalized half vector (pbrt-v4 DielectricBxDF::f / PDF); the conductor's wi + wo, as
    // its wi reflects here (etap 1, and wi * 1 is exact).
    float cos_o = wo.z, cos_i = wi.z;
    reflect = cos_i * cos_o > 0.0;
    if (!reflect) etap = cos_o > 0.0 ? eta : 1.0 / eta;
    precise vec3 h = wi * etap + wo;
    if (cos_i == 0.0 || cos_o == 0.0 || dot_exact(h, h) == 0.0) return r;
    wm = safe_normalize(h);
    if (wm.z < 0.0) wm = -wm;  // FaceForward: D, G and |wo.wm| do not change
    // The dielectric discards back-facing microfacets.
    if (!conductor && (dot_exact(wm, wi) * cos_i < 0.0 || dot_exact(wm, wo) * cos_o < 0.0))
      return r;
  }
  precise float dwo = dot_exact(wo, wm);
  precise float R = fr_dielectric(dwo, eta);
  precise float T = 1.0 - R;
  float pr = (sflags & SAMPLE_R) != 0u ? R : 0.0;
  float pt = (sflags & SAMPLE_T) != 0u ? T : 0.0;
  bool no_choice = !conductor && pr == 0.0 && pt == 0.0;  // pdf 0 (f does not depend on sflags)
  if (smp && no_choice) return r;
  if (smp) {
    reflect = conductor || uc < pr / (pr + pt);
    if (reflect) {
      wi = smooth_ ? vec3(-wo.x, -wo.y, wo.z) : reflect_about(wo, wm);
      if (!smooth_ && !same_hemisphere(wo, wi)) return r;
    } else {
      bool ok = refract_v4(wo, wm, eta, etap, wi);
      if (!ok || (!smooth_ && (same_hemisphere(wo, wi) || wi.z == 0.0))) return r;
    }
    r.wi = wi;
    r.eta = etap;
    r.flags = (reflect ? BSDF_REFLECTION : BSDF_TRANSMISSION) |
              (smooth_ ? BSDF_SPECULAR : BSDF_GLOSSY);
    if (smooth_ && !conductor) {
      // Perfect specular reflection or transmission.
      precise float fs = (reflect ? R : T) / abs(wi.z);
      if (!reflect && radiance) fs /= etap * etap;
      r.f = vec3(fs);
      r.pdf = (reflect ? pr : pt) / (pr + pt);
      return r;
    }
  }
  vec3 dgp = vec3(0.0, 0.0, 1.0);
  if (!smooth_) dgp = mf_dgp(d, wo, wi, wm, wm);
  if (conductor) {
    float cos_o = abs(wo.z), cos_i = abs(wi.z);
    float dwm = abs(dwo);
    if (!smooth_) r.pdf = dgp.z / (4.0 * dwm);
    if (!smooth_ && (cos_i == 0.0 || cos_o == 0.0)) {
      BsdfSample none = no_sample();  // (a sample or a wi here has neither cosine 0)
      none.pdf = smp ? 0.0 : r.pdf;
      return none;
    }
    vec3 F = fr_complex(smooth_ ? cos_i : dwm, c_eta, c_k);
    precise vec3 f = smooth_ ? F / cos_i : dgp.x * F * dgp.y / (4.0 * cos_i * cos_o);
    r.f = f;
    r.wi = wi;
    if (smp && smooth_) r.pdf = 1.0;
    return r;
  }
  precise float dwi = dot_exact(wi, wm);
  // Transmission's (dwi + dwo / etap)^2: a sample's from Snell's law, f and PDF's as pbrt-v4.
  precise float tsum = dwi + dwo / etap;
  precise float denom = smp ? refracted_half_denom(abs(dwo), etap) : tsum * tsum;
  if (smp && !reflect && !(denom > 0.0)) return no_sample();
  precise float f;
  if (no_choice) {
    r.pdf = 0.0;
  } else if (reflect) {
    r.pdf = dgp.z / (4.0 * abs(dwo)) * pr / (pr + pt);
  } else {
    r.pdf = dgp.z * (abs(dwi) / denom) * pt / (pr + pt);
  }
  if (reflect) {
    f = smp ? dgp.x * dgp.y * R / (4.0 * wi.z * wo.z)
            : dgp.x * dgp.y * R / abs(4.0 * wi.z * wo.z);
  } else {
    f = smp ? T * dgp.x * dgp.y * abs(dwi * dwo / (wi.z * wo.z * denom))
            : dgp.x * T * dgp.y * abs(dwi * dwo / (denom * wi.z * wo.z));
    if (radiance) f /= etap * etap;
  }
  r.f = vec3(f);
  return r;
}

