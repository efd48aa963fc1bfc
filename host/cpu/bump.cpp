// Bump and normal mapping on the CPU (docs/bump-spec.md sections 4-6). All arithmetic fp32,
// no fma (the build uses -ffp-contract=off), sums and products left to right as written.
#include "cpu/bump.h"

#include <cfloat>
#include <cmath>
#include <cstring>

#include "cpu/mipmap.h"
#include "cpu/noise.h"

namespace basalt::cpu {
namespace {

/// True if every component of v is finite.
bool finite3(glm::vec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

/// v / |v|, the normalize of the spec, as a float divide by sqrt(dot(v, v)).
glm::vec3 normalize_div(glm::vec3 v) { return v / std::sqrt(glm::dot(v, v)); }

/// A squared length a unit vector can be made from: finite and at least FLT_MIN (below it the
/// length has lost precision in a subnormal, and GPUs flush it to zero: bump-spec 6 "zero").
bool usable_length2(float l2) { return l2 >= FLT_MIN && std::isfinite(l2); }

/// The difference step of bump-spec 4 step 1 from one parameter's two differentials, or the
/// fixed step of bump-spec 4.5 when \p fixed is positive.
float bump_step(float dx, float dy, float fixed) {
  if (fixed > 0.0f) return fixed;
  const float d = 0.5f * (std::fabs(dx) + std::fabs(dy));
  return d == 0.0f ? 0.0005f : d;
}

/// ctx moved by step h along dir and by h in uv component k (bump-spec 4.2): cu, cv, and with
/// a negative h the backward contexts of 4.5.
TextureContext shifted(const TextureContext& ctx, float h, glm::vec3 dir, int k) {
  TextureContext c = ctx;
  c.p = ctx.p + h * dir;
  c.uv[k] = ctx.uv[k] + h;
  return c;
}

}  // namespace

BumpKnobs bump_knobs(const gpu::Globals& g) {
  BumpKnobs k;
  k.central = (g.texture_opts.x & gpu::TEXOPT_BUMP_CENTRAL) != 0u;
  k.dndu = (g.texture_opts.x & gpu::TEXOPT_BUMP_NO_DNDU) == 0u;
  std::memcpy(&k.fixed_step, &g.texture_opts.z, sizeof(float));
  return k;
}

void bump_map(const Displacement& D, const SurfacePoint& sp, glm::vec3& dpdu, glm::vec3& dpdv,
              const BumpKnobs& knobs) {
  // pbrt-v4 BumpMap (materials.h): forward differences of the displacement along the
  // shading pair, in shifted copies of the texture context (bump-spec 4); central differences,
  // a fixed step and no d dn/du term are the knobs of bump-spec 4.5.
  const TextureContext& ctx = sp.tex;
  const float du = bump_step(ctx.dudx, ctx.dudy, knobs.fixed_step);
  const float dv = bump_step(ctx.dvdx, ctx.dvdy, knobs.fixed_step);
  const float dU = D(shifted(ctx, du, sp.sdpdu, 0));
  const float dV = D(shifted(ctx, dv, sp.sdpdv, 1));
  const float d = D(ctx);
  float su, sv;
  if (knobs.central) {
    const float dUm = D(shifted(ctx, -du, sp.sdpdu, 0));
    const float dVm = D(shifted(ctx, -dv, sp.sdpdv, 1));
    su = (dU - dUm) / (du + du);
    sv = (dV - dVm) / (dv + dv);
  } else {
    su = (dU - d) / du;
    sv = (dV - d) / dv;
  }
  const glm::vec3 ns = sp.g.ns;
  dpdu = sp.sdpdu + su * ns;
  dpdv = sp.sdpdv + sv * ns;
  // Without the d dn/du term the displacement's own value does not enter (4.5).
  if (knobs.dndu) {
    dpdu = dpdu + d * sp.g.dndu;
    dpdv = dpdv + d * sp.g.dndv;
  }
}

void bump_map(const SceneTables& scene, const gpu::Material& m, const SurfacePoint& sp,
              glm::vec3& dpdu, glm::vec3& dpdv) {
  // D = the displacement slot: its (host-folded) texture program, or the constant.
  const std::uint32_t root = m.texture[gpu::SLOT_DISPLACEMENT / 4][gpu::SLOT_DISPLACEMENT % 4];
  const float constant = m.value[gpu::SLOT_DISPLACEMENT].x;
  if (root == gpu::INVALID_INDEX) {
    bump_map([constant](const TextureContext&) { return constant; }, sp, dpdu, dpdv,
             bump_knobs(scene.globals));
  } else {
    bump_map([&scene, root](const TextureContext& c) { return tex_eval_float(scene, root, c); },
             sp, dpdu, dpdv, bump_knobs(scene.globals));
  }
}

bool normal_map(const SceneTables& scene, std::uint32_t level, const SurfacePoint& sp,
                glm::vec3& dpdu, glm::vec3& dpdv) {
  // pbrt-v4 NormalMap (materials.h), bump-spec 5.
  if (level >= scene.mip_levels.size()) return false;
  // 1. Bilerp of level 0 at (u, 1 - v) with repeat wrap (pbrt-v4 Image::BilerpChannel, the
  // arithmetic of textures-spec 4.2 step 2). A non-finite uv has no texel.
  const glm::vec2 st(sp.tex.uv.x, 1.0f - sp.tex.uv.y);
  if (!std::isfinite(st.x) || !std::isfinite(st.y)) return false;
  const glm::vec3 rgb = mipmap_bilerp(scene, level, st, gpu::WRAP_REPEAT, false);
  // 2. The tangent-space normal; (0.5, 0.5, 0.5) or a non-finite texel: no normal map here.
  glm::vec3 nt(2.0f * rgb.x - 1.0f, 2.0f * rgb.y - 1.0f, 2.0f * rgb.z - 1.0f);
  const float nt2 = glm::dot(nt, nt);
  if (nt2 == 0.0f || !std::isfinite(nt2) || !finite3(nt)) return false;
  nt = nt / std::sqrt(nt2);
  // 3. To world space in pbrt-v4 Frame::FromXZ(normalize(sdpdu), ns): y = cross(z, x).
  const float u2 = glm::dot(sp.sdpdu, sp.sdpdu);
  if (!usable_length2(u2)) return false;
  const glm::vec3 x = sp.sdpdu / std::sqrt(u2);
  const glm::vec3 z = sp.g.ns;
  const glm::vec3 y = glm::cross(z, x);
  const glm::vec3 nw = (x * nt.x + y * nt.y) + z * nt.z;
  // 4. dpdu' = Gram-Schmidt of sdpdu against nw, dpdv' = cross(nw, dpdu'), original lengths.
  const float ulen = std::sqrt(u2);
  const float vlen = std::sqrt(glm::dot(sp.sdpdv, sp.sdpdv));
  dpdu = normalize_div(sp.sdpdu - glm::dot(sp.sdpdu, nw) * nw) * ulen;
  dpdv = normalize_div(glm::cross(nw, dpdu)) * vlen;
  return true;
}

bool set_shading_geometry(SurfacePoint& sp, glm::vec3 dpdu, glm::vec3 dpdv) {
  // bump-spec 6 steps 2-4 (pbrt-v4 GetBSDF's Normalize(Cross(dpdu, dpdv)) and
  // SetShadingGeometry with orientationIsAuthoritative = false).
  const glm::vec3 c = glm::cross(dpdu, dpdv);
  const float l2 = glm::dot(c, c);
  // A zero or non-finite normal (parallel or overflowing pair) keeps the unbumped frame,
  // where pbrt-v4 would carry a NaN on.
  if (!usable_length2(l2)) return false;
  glm::vec3 n = c / std::sqrt(l2);
  if (!finite3(n)) return false;
  if (glm::dot(n, sp.g.ng) < 0.0f) n = -n;
  sp.g.ns = n;
  sp.frame = shading_frame(n, dpdu);
  return true;
}

bool vector_turbulence_shading(const SceneTables& scene, const gpu::Material& m,
                               SurfacePoint& sp, glm::vec3& dpdu, glm::vec3& dpdv) {
  // bump-spec 9 steps 1-4.
  const glm::vec4 prm = m.value[gpu::SLOT_NORMALMAP];
  const glm::vec3 q = prm.z * sp.tex.p;
  const glm::vec3 v = vector_turbulence(scene, q, int(prm.w));
  const glm::vec3 mv = sp.g.ns + prm.y * v;
  const float m2 = glm::dot(mv, mv);
  if (!usable_length2(m2)) return false;
  const glm::vec3 nw = mv / std::sqrt(m2);
  const float a2 = glm::dot(dpdu, dpdu);
  if (!usable_length2(a2)) return false;
  const float ulen = std::sqrt(a2);
  const float vlen = std::sqrt(glm::dot(dpdv, dpdv));
  const glm::vec3 a = normalize_div(dpdu - glm::dot(dpdu, nw) * nw) * ulen;
  const glm::vec3 b = normalize_div(glm::cross(nw, a)) * vlen;
  if (!set_shading_geometry(sp, a, b)) return false;
  dpdu = a;
  dpdv = b;
  return true;
}

bool bump_shading(const SceneTables& scene, const gpu::Material& m, SurfacePoint& sp,
                  glm::vec3* dpdu_out, glm::vec3* dpdv_out) {
  // bump-spec 6 step 1: a normal map wins over a displacement (pbrt-v4 GetBSDF).
  glm::vec3 dpdu = sp.sdpdu, dpdv = sp.sdpdv;
  bool changed = false;
  if (m.flags & gpu::MATFLAG_NORMALMAP) {
    const float lv = m.value[gpu::SLOT_NORMALMAP].x;
    // The level index as a float (exact below 2^24); anything else is no level.
    const std::uint32_t level =
        (lv >= 0.0f && lv < 16777216.0f) ? std::uint32_t(lv) : gpu::INVALID_INDEX;
    glm::vec3 u, v;
    if (normal_map(scene, level, sp, u, v) && set_shading_geometry(sp, u, v)) {
      dpdu = u;
      dpdv = v;
      changed = true;
    }
  } else if (m.flags & gpu::MATFLAG_BUMP) {
    glm::vec3 u, v;
    bump_map(scene, m, sp, u, v);
    if (set_shading_geometry(sp, u, v)) {
      dpdu = u;
      dpdv = v;
      changed = true;
    }
  }
  // bump-spec 9: Shirley's vector turbulence on whatever the frame is now.
  if ((m.flags & gpu::MATFLAG_VTURB) && vector_turbulence_shading(scene, m, sp, dpdu, dpdv))
    changed = true;
  if (dpdu_out) *dpdu_out = dpdu;
  if (dpdv_out) *dpdv_out = dpdv;
  return changed;
}

}  // namespace basalt::cpu
