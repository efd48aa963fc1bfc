// pbrt-v4 LayeredBxDF (CoatedDiffuseBxDF, CoatedConductorBxDF) of the CPU reference:
// stochastic evaluation, sampling and pdf of a dielectric coat over a diffuse or conductor
// base (pbrt-v4 src/pbrt/bxdfs.h LayeredBxDF, twoSided = true; pbrt-v4 book 14.3), with
// pbrt-v4's `r()` replaced by the stream of docs/materials-spec.md section 5 (element j =
// j-th call; in an argument list such as Point2f(r(), r()) the calls are taken left to right).
// Two deliberate deviations (docs/materials-spec.md 2.3): f's exit MIS weight uses the NEE
// strategy's own density, and Sample_f rescales its (f, pdf) products by powers of two.
#include <algorithm>
#include <cfloat>
#include <cmath>

#include "cpu/bxdfs.h"
#include "cpu/rng.h"

namespace basalt::cpu::bxdf {
namespace {

/// Henyey-Greenstein phase function value for cos theta (pbrt-v4 util/scattering.h
/// HenyeyGreenstein; g clamped to [-0.99, 0.99] as pbrt-v4).
float henyey_greenstein(float cos_theta, float g) {
  g = glm::clamp(g, -0.99f, 0.99f);
  const float denom = 1.0f + g * g + 2.0f * g * cos_theta;
  return (1.0f / (4.0f * PI)) * (1.0f - g * g) / (denom * safe_sqrt(denom));
}

/// A phase function sample (pbrt-v4 PhaseFunctionSample).
struct PhaseSample {
  float p = 0.0f;
  glm::vec3 wi{0.0f};
  float pdf = 0.0f;
};

/// pbrt-v4 HGPhaseFunction: p(wo, wi) = HG(dot(wo, wi), g); Sample_p by
/// SampleHenyeyGreenstein (pdf = p).
struct HGPhase {
  float g = 0.0f;
  /// Phase function value.
  float p(glm::vec3 wo, glm::vec3 wi) const { return henyey_greenstein(glm::dot(wo, wi), g); }
  /// pdf of sample (equal to p).
  float pdf(glm::vec3 wo, glm::vec3 wi) const { return p(wo, wi); }
  /// pbrt-v4 SampleHenyeyGreenstein(wo, g, u) with its g clamp to [-0.99, 0.99].
  PhaseSample sample(glm::vec3 wo, glm::vec2 u) const {
    const float gg = glm::clamp(g, -0.99f, 0.99f);
    float cos_theta;
    if (std::fabs(gg) < 1e-3f) {
      cos_theta = 1.0f - 2.0f * u.x;
    } else {
      const float t = (1.0f - gg * gg) / (1.0f + gg - 2.0f * gg * u.x);
      cos_theta = -1.0f / (2.0f * gg) * (1.0f + gg * gg - t * t);
    }
    const float sin_theta = safe_sqrt(1.0f - cos_theta * cos_theta);
    const float phi = 2.0f * PI * u.y;
    const Frame frame = Frame::from_z(wo);
    PhaseSample s;
    s.wi = frame.to_world(spherical_direction(sin_theta, cos_theta, phi));
    s.pdf = henyey_greenstein(cos_theta, g);
    s.p = s.pdf;
    return s;
  }
};

/// pbrt-v4 LayeredBxDF::Tr: transmittance exp(-|dz / w.z|) through a slab of depth dz
/// (1 for |dz| <= FLT_MIN).
float Tr(float dz, glm::vec3 w) {
  if (std::fabs(dz) <= FLT_MIN) return 1.0f;
  return std::exp(-std::fabs(dz / w.z));
}

/// pbrt-v4 SampleExponential(u, a) = -ln(1 - u) / a.
float sample_exponential(float u, float a) { return -std::log(1.0f - u) / a; }

/// \brief Rescales the Sample_f walk's (f, pdf) pair by the same power of two (exact, so f/pdf
///        is unchanged bit for bit) to pdf in [0.5, 1) when pdf leaves [2^-32, 2^32]: the
///        products of a long walk over sharp lobes overflow (f = pdf = inf) or underflow while
///        their ratio is finite (basalt deviation, docs/materials-spec.md 2.3; the pdf of a
///        layered sample is only proportional).
void layer_renormalize(glm::vec3& f, float& pdf) {
  if (!(pdf > 0x1p32f || pdf < 0x1p-32f) || pdf == 0.0f) return;
  int e = 0;
  (void)std::frexp(pdf, &e);
  f = glm::vec3(std::ldexp(f.x, -e), std::ldexp(f.y, -e), std::ldexp(f.z, -e));
  pdf = std::ldexp(pdf, -e);
}

/// pbrt-v4 PowerHeuristic(1, f, 1, g).
float power(float f, float g) { return power_heuristic(f, g); }

/// pbrt-v4 TopOrBottomBxDF: the coat (Dielectric) or the base.
template <typename Bottom>
struct Interface {
  const Dielectric* top = nullptr;
  const Bottom* bottom = nullptr;
  std::uint32_t flags() const { return top ? top->flags() : bottom->flags(); }
  glm::vec3 f(glm::vec3 wo, glm::vec3 wi, Mode mode) const {
    return top ? top->f(wo, wi, mode) : bottom->f(wo, wi);
  }
  BsdfSample sample(glm::vec3 wo, float uc, glm::vec2 u, Mode mode, std::uint32_t sf) const {
    return top ? top->sample(wo, uc, u, mode, sf) : bottom->sample(wo, uc, u, sf);
  }
  float pdf(glm::vec3 wo, glm::vec3 wi, Mode mode, std::uint32_t sf = SAMPLE_ALL) const {
    return top ? top->pdf(wo, wi, mode, sf) : bottom->pdf(wo, wi, sf);
  }
};

}  // namespace

template <typename Bottom>
std::uint32_t Layered<Bottom>::flags() const {
  // pbrt-v4 LayeredBxDF::Flags.
  const std::uint32_t tf = top.flags(), bf = bottom.flags();
  std::uint32_t fl = gpu::BSDF_REFLECTION;
  if (is_specular(tf)) fl |= gpu::BSDF_SPECULAR;
  if (is_diffuse(tf) || is_diffuse(bf) || nonzero(albedo)) {
    fl |= gpu::BSDF_DIFFUSE;
  } else if (is_glossy(tf) || is_glossy(bf)) {
    fl |= gpu::BSDF_GLOSSY;
  }
  if (is_transmission(tf) && is_transmission(bf)) fl |= gpu::BSDF_TRANSMISSION;
  return fl;
}

/// pbrt-v4 LayeredBxDF::f, except for the MIS weight of the exit through the exit interface
/// after a phase or non-exit sample -w: the other strategy (NEE along wis, sampled from wi)
/// produces -w with density exit.PDF(wi, -w, !mode, Transmission), which basalt uses where
/// pbrt-v4 uses exit.PDF(-w, wi, mode, Transmission), the density of wi given -w (biased for
/// rough coats: docs/materials-spec.md 2.3, pbrt-v4 issue #187).
template <typename Bottom>
glm::vec3 Layered<Bottom>::f(glm::vec3 wo, glm::vec3 wi, Mode mode, glm::uvec4 key) const {
  glm::vec3 f(0.0f);
  // Two-sided: evaluate from the top.
  if (wo.z < 0.0f) {
    wo = -wo;
    wi = -wi;
  }
  const Interface<Bottom> enter{&top, nullptr};
  const bool same = same_hemisphere(wo, wi);
  // Exit interface and exit z (enteredTop is always true when two-sided).
  Interface<Bottom> exit, non_exit;
  if (!same) {
    exit = Interface<Bottom>{nullptr, &bottom};
    non_exit = Interface<Bottom>{&top, nullptr};
  } else {
    exit = Interface<Bottom>{&top, nullptr};
    non_exit = Interface<Bottom>{nullptr, &bottom};
  }
  const float exit_z = !same ? 0.0f : thickness;
  // Reflection at the entrance interface.
  if (same) f = float(n_samples) * enter.f(wo, wi, mode);
  Stream r{key};
  const HGPhase phase{g};
  for (int s = 0; s < n_samples; ++s) {
    // Transmission direction through the entrance interface.
    float uc = r();
    float u0 = r(), u1 = r();
    const BsdfSample wos = enter.sample(wo, uc, glm::vec2(u0, u1), mode, SAMPLE_T);
    if (!usable(wos)) continue;
    // Sample the exit interface for the virtual light from wi.
    uc = r();
    u0 = r();
    u1 = r();
    const BsdfSample wis = exit.sample(wi, uc, glm::vec2(u0, u1), flip(mode), SAMPLE_T);
    if (!usable(wis)) continue;
    // Random walk through the layers.
    glm::vec3 beta = wos.f * std::fabs(wos.wi.z) / wos.pdf;
    float z = thickness;
    glm::vec3 w = wos.wi;
    for (int depth = 0; depth < max_depth; ++depth) {
      // Russian roulette.
      if (depth > 3 && max_component(beta) < 0.25f) {
        const float q = std::fmax(0.0f, 1.0f - max_component(beta));
        if (r() < q) break;
        beta /= 1.0f - q;
      }
      if (!nonzero(albedo)) {
        // Advance to the other interface.
        z = (z == thickness) ? 0.0f : thickness;
        beta *= Tr(thickness, w);
      } else {
        // Medium scattering between the interfaces.
        const float sigma_t = 1.0f;
        const float dz = sample_exponential(r(), sigma_t / std::fabs(w.z));
        const float zp = w.z > 0.0f ? (z + dz) : (z - dz);
        if (z == zp) continue;
        if (0.0f < zp && zp < thickness) {
          // Scattering through the exit interface along wis (NEE).
          float wt = 1.0f;
          if (!is_specular(exit.flags())) wt = power(wis.pdf, phase.pdf(-w, -wis.wi));
          f += beta * albedo * phase.p(-w, -wis.wi) * wt * Tr(zp - exit_z, wis.wi) * wis.f /
               wis.pdf;
          // Sample the phase function.
          const float v0 = r(), v1 = r();
          const PhaseSample ps = phase.sample(-w, glm::vec2(v0, v1));
          if (ps.pdf == 0.0f || ps.wi.z == 0.0f) continue;
          beta *= albedo * ps.p / ps.pdf;
          w = ps.wi;
          z = zp;
          // Scattering through the exit interface along the phase sample.
          if (((z < exit_z && w.z > 0.0f) || (z > exit_z && w.z < 0.0f)) &&
              !is_specular(exit.flags())) {
            const glm::vec3 f_exit = exit.f(-w, wi, mode);
            if (nonzero(f_exit)) {
              // Density with which the NEE strategy (wis, sampled from wi) produces -w; pbrt-v4
              // uses PDF(-w, wi, mode), the density of wi given -w (see above f).
              const float exit_pdf = pbrt_mis ? exit.pdf(-w, wi, mode, SAMPLE_T)
                                              : exit.pdf(wi, -w, flip(mode), SAMPLE_T);
              const float wt2 = power(ps.pdf, exit_pdf);
              f += beta * Tr(zp - exit_z, ps.wi) * f_exit * wt2;
            }
          }
          continue;
        }
        z = glm::clamp(zp, 0.0f, thickness);
      }
      if (z == exit_z) {
        // Reflection at the exit interface.
        const float uc2 = r();
        const float v0 = r(), v1 = r();
        const BsdfSample bs = exit.sample(-w, uc2, glm::vec2(v0, v1), mode, SAMPLE_R);
        if (!usable(bs)) break;
        beta *= bs.f * std::fabs(bs.wi.z) / bs.pdf;
        w = bs.wi;
      } else {
        // Scattering at the non-exit interface.
        if (!is_specular(non_exit.flags())) {
          // NEE along the presampled wis.
          float wt = 1.0f;
          if (!is_specular(exit.flags()))
            wt = power(wis.pdf, non_exit.pdf(-w, -wis.wi, mode));
          f += beta * non_exit.f(-w, -wis.wi, mode) * std::fabs(wis.wi.z) * wt *
               Tr(thickness, wis.wi) * wis.f / wis.pdf;
        }
        // New direction from the non-exit interface.
        const float uc2 = r();
        const float v0 = r(), v1 = r();
        const BsdfSample bs = non_exit.sample(-w, uc2, glm::vec2(v0, v1), mode, SAMPLE_R);
        if (!usable(bs)) break;
        beta *= bs.f * std::fabs(bs.wi.z) / bs.pdf;
        w = bs.wi;
        if (!is_specular(exit.flags())) {
          // NEE along the BSDF sample.
          const glm::vec3 f_exit = exit.f(-w, wi, mode);
          if (nonzero(f_exit)) {
            float wt = 1.0f;
            if (!is_specular(non_exit.flags())) {
              // As above: the NEE strategy's density of -w, not pbrt-v4's PDF(-w, wi, mode).
              const float exit_pdf = pbrt_mis ? exit.pdf(-w, wi, mode, SAMPLE_T)
                                              : exit.pdf(wi, -w, flip(mode), SAMPLE_T);
              wt = power(bs.pdf, exit_pdf);
            }
            f += beta * Tr(thickness, bs.wi) * f_exit * wt;
          }
        }
      }
    }
  }
  return f / float(n_samples);
}

template <typename Bottom>
BsdfSample Layered<Bottom>::sample(glm::vec3 wo, float uc, glm::vec2 u, Mode mode,
                                   glm::uvec4 key) const {
  // Two-sided: sample from the top, flip wi back at the end.
  bool flip_wi = false;
  if (wo.z < 0.0f) {
    wo = -wo;
    flip_wi = true;
  }
  // Initial direction from the entrance interface (the caller's uc, u).
  BsdfSample bs = top.sample(wo, uc, u, mode, SAMPLE_ALL);
  if (!usable(bs)) return BsdfSample{};
  if (is_reflection(bs.flags)) {
    if (flip_wi) bs.wi = -bs.wi;
    bs.pdf_is_proportional = true;
    return bs;
  }
  glm::vec3 w = bs.wi;
  bool specular_path = is_specular(bs.flags);
  Stream r{key};
  glm::vec3 f = bs.f * std::fabs(bs.wi.z);
  float pdf = bs.pdf;
  float z = thickness;
  const HGPhase phase{g};
  for (int depth = 0; depth < max_depth; ++depth) {
    layer_renormalize(f, pdf);
    // Russian roulette.
    const float rr_beta = max_component(f) / pdf;
    if (depth > 3 && rr_beta < 0.25f) {
      const float q = std::fmax(0.0f, 1.0f - rr_beta);
      if (r() < q) return BsdfSample{};
      pdf *= 1.0f - q;
    }
    if (w.z == 0.0f) return BsdfSample{};
    if (nonzero(albedo)) {
      // Possible scattering event in the medium.
      const float sigma_t = 1.0f;
      const float dz = sample_exponential(r(), sigma_t / std::fabs(w.z));
      const float zp = w.z > 0.0f ? (z + dz) : (z - dz);
      if (zp == z) return BsdfSample{};
      if (0.0f < zp && zp < thickness) {
        const float v0 = r(), v1 = r();
        const PhaseSample ps = phase.sample(-w, glm::vec2(v0, v1));
        if (ps.pdf == 0.0f || ps.wi.z == 0.0f) return BsdfSample{};
        f *= albedo * ps.p;
        pdf *= ps.pdf;
        specular_path = false;
        w = ps.wi;
        z = zp;
        continue;
      }
      z = glm::clamp(zp, 0.0f, thickness);
    } else {
      // Advance to the other interface.
      z = (z == thickness) ? 0.0f : thickness;
      f *= Tr(thickness, w);
    }
    const Interface<Bottom> itf = z == 0.0f ? Interface<Bottom>{nullptr, &bottom}
                                            : Interface<Bottom>{&top, nullptr};
    const float uc2 = r();
    const float v0 = r(), v1 = r();
    const BsdfSample is = itf.sample(-w, uc2, glm::vec2(v0, v1), mode, SAMPLE_ALL);
    if (!usable(is)) return BsdfSample{};
    f *= is.f;
    pdf *= is.pdf;
    specular_path = specular_path && is_specular(is.flags);
    w = is.wi;
    // Left the layers: done.
    if (is_transmission(is.flags)) {
      std::uint32_t fl = same_hemisphere(wo, w) ? gpu::BSDF_REFLECTION : gpu::BSDF_TRANSMISSION;
      fl |= specular_path ? gpu::BSDF_SPECULAR : gpu::BSDF_GLOSSY;
      if (flip_wi) w = -w;
      layer_renormalize(f, pdf);
      BsdfSample out;
      out.f = f;
      out.wi = w;
      out.pdf = pdf;
      out.flags = fl;
      out.eta = 1.0f;
      out.pdf_is_proportional = true;
      return out;
    }
    f *= std::fabs(is.wi.z);
  }
  return BsdfSample{};
}

template <typename Bottom>
float Layered<Bottom>::pdf(glm::vec3 wo, glm::vec3 wi, Mode mode, glm::uvec4 key) const {
  if (wo.z < 0.0f) {
    wo = -wo;
    wi = -wi;
  }
  Stream r{key};
  const bool same = same_hemisphere(wo, wi);
  float pdf_sum = 0.0f;
  // Reflection at the entrance (top) interface.
  if (same) pdf_sum += float(n_samples) * top.pdf(wo, wi, mode, SAMPLE_R);
  const Interface<Bottom> t_top{&top, nullptr}, t_bottom{nullptr, &bottom};
  for (int s = 0; s < n_samples; ++s) {
    if (same) {
      // TRT term: r_interface = bottom, t_interface = top.
      const Interface<Bottom>& ri = t_bottom;
      const Interface<Bottom>& ti = t_top;
      float uc = r(), u0 = r(), u1 = r();
      const BsdfSample wos = ti.sample(wo, uc, glm::vec2(u0, u1), mode, SAMPLE_T);
      uc = r();
      u0 = r();
      u1 = r();
      const BsdfSample wis = ti.sample(wi, uc, glm::vec2(u0, u1), flip(mode), SAMPLE_T);
      if (wos.flags != 0 && nonzero(wos.f) && wos.pdf > 0.0f && wis.flags != 0 &&
          nonzero(wis.f) && wis.pdf > 0.0f) {
        if (!is_nonspecular(ti.flags())) {
          pdf_sum += ri.pdf(-wos.wi, -wis.wi, mode);
        } else {
          // MIS estimate of the pdf product.
          uc = r();
          u0 = r();
          u1 = r();
          const BsdfSample rs = ri.sample(-wos.wi, uc, glm::vec2(u0, u1), mode, SAMPLE_ALL);
          if (rs.flags != 0 && nonzero(rs.f) && rs.pdf > 0.0f) {
            if (!is_nonspecular(ri.flags())) {
              pdf_sum += ti.pdf(-rs.wi, wi, mode);
            } else {
              const float r_pdf = ri.pdf(-wos.wi, -wis.wi, mode);
              float wt = power(wis.pdf, r_pdf);
              pdf_sum += wt * r_pdf;
              const float t_pdf = ti.pdf(-rs.wi, wi, mode);
              wt = power(rs.pdf, t_pdf);
              pdf_sum += wt * t_pdf;
            }
          }
        }
      }
    } else {
      // TT term: to_interface = top, ti_interface = bottom.
      const Interface<Bottom>& to = t_top;
      const Interface<Bottom>& tin = t_bottom;
      float uc = r(), u0 = r(), u1 = r();
      const BsdfSample wos = to.sample(wo, uc, glm::vec2(u0, u1), mode, SAMPLE_ALL);
      if (!usable(wos) || is_reflection(wos.flags)) continue;
      uc = r();
      u0 = r();
      u1 = r();
      const BsdfSample wis = tin.sample(wi, uc, glm::vec2(u0, u1), flip(mode), SAMPLE_ALL);
      if (!usable(wis) || is_reflection(wis.flags)) continue;
      if (is_specular(to.flags())) {
        pdf_sum += tin.pdf(-wos.wi, wi, mode);
      } else if (is_specular(tin.flags())) {
        pdf_sum += to.pdf(wo, -wis.wi, mode);
      } else {
        pdf_sum += (to.pdf(wo, -wis.wi, mode) + tin.pdf(-wos.wi, wi, mode)) / 2.0f;
      }
    }
  }
  // Mix with a uniform pdf: Lerp(0.9, 1/(4 pi), pdfSum / nSamples).
  const float t = 0.9f;
  return (1.0f - t) * (1.0f / (4.0f * PI)) + t * (pdf_sum / float(n_samples));
}

template struct Layered<Diffuse>;
template struct Layered<Conductor>;

}  // namespace basalt::cpu::bxdf
