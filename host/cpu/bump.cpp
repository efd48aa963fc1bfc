// Bump and normal mapping on the CPU (docs/bump-spec.md sections 4-6). All arithmetic fp32,
// no fma (the build uses -ffp-contract=off), sums and products left to right as written.
#include "cpu/bump.h"

#include <cfloat>
#include <cmath>

#include "cpu/mipmap.h"

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

/// The difference step of bump-spec 4 step 1 from one parameter's two differentials.
float bump_step(float dx, float dy) {
  const float d = 0.5f * (std::fabs(dx) + std::fabs(dy));
  return d == 0.0f ? 0.0005f : d;
}

}  // namespace

void bump_map(const Displacement& D, const SurfacePoint& sp, glm::vec3& dpdu, glm::vec3& dpdv) {
  // pbrt-v4 BumpMap (materials.h): forward differences of the displacement along the
  // shading pair, in shifted copies of the texture context (bump-spec 4).
  const TextureContext& ctx = sp.tex;
  const float du = bump_step(ctx.dudx, ctx.dudy);
  const float dv = bump_step(ctx.dvdx, ctx.dvdy);
  TextureContext cu = ctx;
  cu.p = ctx.p + du * sp.sdpdu;
  cu.uv = ctx.uv + glm::vec2(du, 0.0f);
  TextureContext cv = ctx;
  cv.p = ctx.p + dv * sp.sdpdv;
  cv.uv = ctx.uv + glm::vec2(0.0f, dv);
  const float dU = D(cu);
  const float dV = D(cv);
  const float d = D(ctx);
  const glm::vec3 ns = sp.g.ns;
  const float su = (dU - d) / du;
  const float sv = (dV - d) / dv;
  dpdu = (sp.sdpdu + su * ns) + d * sp.g.dndu;
  dpdv = (sp.sdpdv + sv * ns) + d * sp.g.dndv;
}

void bump_map(const SceneTables& scene, const gpu::Material& m, const SurfacePoint& sp,
              glm::vec3& dpdu, glm::vec3& dpdv) {
  // D = the displacement slot: its (host-folded) texture program, or the constant.
  const std::uint32_t root = m.texture[gpu::SLOT_DISPLACEMENT / 4][gpu::SLOT_DISPLACEMENT % 4];
  const float constant = m.value[gpu::SLOT_DISPLACEMENT].x;
  if (root == gpu::INVALID_INDEX) {
    bump_map([constant](const TextureContext&) { return constant; }, sp, dpdu, dpdv);
  } else {
    bump_map([&scene, root](const TextureContext& c) { return tex_eval_float(scene, root, c); },
             sp, dpdu, dpdv);
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
  if (dpdu_out) *dpdu_out = dpdu;
  if (dpdv_out) *dpdv_out = dpdv;
  return changed;
}

}  // namespace basalt::cpu
