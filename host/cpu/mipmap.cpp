// pbrt-v4 MIPMap lookups (util/mipmap.cpp, util/image.h) for the CPU reference; the rules
// the GLSL twin follows are in docs/textures-spec.md section 4.
#include "cpu/mipmap.h"

#include <algorithm>
#include <cmath>

namespace basalt::cpu {
namespace {

constexpr float kInvLog2 = 1.442695040888963387004650940071f;
constexpr float kIntLimit = 1073741824.0f;  // 2^30: float -> int conversions clamp to +-this

// pbrt-v4 Log2(Float): log(x) * (1 / ln 2), in float.
float log2_pbrt(float x) { return std::log(x) * kInvLog2; }

// A float (finite) converted to int after clamping to [-2^30, 2^30] (no undefined overflow).
int to_int(float v) { return int(std::clamp(v, -kIntLimit, kIntLimit)); }

// pbrt-v4 pstd::round (std::round: halves away from zero), to int.
int round_int(float v) { return to_int(std::round(v)); }

// pbrt-v4 RemapPixelCoords (util/image.h); false: outside a "black" image.
bool remap(glm::ivec2& p, glm::ivec2 res, std::uint32_t wrap) {
  if (wrap == gpu::WRAP_OCTAHEDRAL) {
    if (p.x < 0) {
      p.x = -p.x;
      p.y = res.y - 1 - p.y;
    } else if (p.x >= res.x) {
      p.x = 2 * res.x - 1 - p.x;
      p.y = res.y - 1 - p.y;
    }
    if (p.y < 0) {
      p.x = res.x - 1 - p.x;
      p.y = -p.y;
    } else if (p.y >= res.y) {
      p.x = res.x - 1 - p.x;
      p.y = 2 * res.y - 1 - p.y;
    }
    if (res.x == 1) p.x = 0;
    if (res.y == 1) p.y = 0;
    return true;
  }
  for (int c = 0; c < 2; ++c) {
    if (p[c] >= 0 && p[c] < res[c]) continue;
    if (wrap == gpu::WRAP_REPEAT) {
      p[c] = ((p[c] % res[c]) + res[c]) % res[c];
    } else if (wrap == gpu::WRAP_CLAMP) {
      p[c] = std::clamp(p[c], 0, res[c] - 1);
    } else {
      return false;
    }
  }
  return true;
}

// One channel of texel p of a level (pbrt-v4 Image::GetChannel), 0 outside a black image.
float channel(const SceneTables& s, const gpu::MipLevel& l, glm::ivec2 p, int c, std::uint32_t wrap) {
  if (!remap(p, glm::ivec2(int(l.width), int(l.height)), wrap)) return 0.0f;
  const std::size_t i =
      std::size_t(l.offset) + (std::size_t(p.y) * l.width + std::size_t(p.x)) * l.channels + c;
  return i < s.texels.size() ? s.texels[i] : 0.0f;
}

// pbrt-v4 Image::BilerpChannel (util/image.h).
float bilerp_channel(const SceneTables& s, const gpu::MipLevel& l, glm::vec2 st, int c,
                     std::uint32_t wrap) {
  const float x = st.x * float(l.width) - 0.5f, y = st.y * float(l.height) - 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  const int xi = to_int(fx), yi = to_int(fy);
  const float dx = x - fx, dy = y - fy;
  const float v0 = channel(s, l, {xi, yi}, c, wrap), v1 = channel(s, l, {xi + 1, yi}, c, wrap);
  const float v2 = channel(s, l, {xi, yi + 1}, c, wrap), v3 = channel(s, l, {xi + 1, yi + 1}, c, wrap);
  return (1.0f - dx) * (1.0f - dy) * v0 + dx * (1.0f - dy) * v1 + (1.0f - dx) * dy * v2 +
         dx * dy * v3;
}

glm::vec3 lerp3(float t, glm::vec3 a, glm::vec3 b) { return (1.0f - t) * a + t * b; }

struct Lookup {
  const SceneTables& s;
  std::uint32_t first, levels, wrap;
  bool want_float;

  glm::ivec2 res(int level) const {
    const gpu::MipLevel& l = s.mip_levels[first + std::uint32_t(level)];
    return glm::ivec2(int(l.width), int(l.height));
  }
  // pbrt-v4 MIPMap::Texel.
  glm::vec3 texel(int level, glm::ivec2 p) const {
    return mipmap_texel(s, first + std::uint32_t(level), p, wrap, want_float);
  }
  // pbrt-v4 MIPMap::Bilerp.
  glm::vec3 bilerp(int level, glm::vec2 st) const {
    return mipmap_bilerp(s, first + std::uint32_t(level), st, wrap, want_float);
  }
  // pbrt-v4 MIPMap::EWA.
  glm::vec3 ewa(int level, glm::vec2 st, glm::vec2 dst0, glm::vec2 dst1) const {
    if (level >= int(levels)) return texel(int(levels) - 1, {0, 0});
    const glm::ivec2 r = res(level);
    st.x = st.x * float(r.x) - 0.5f;
    st.y = st.y * float(r.y) - 0.5f;
    dst0.x *= float(r.x);
    dst0.y *= float(r.y);
    dst1.x *= float(r.x);
    dst1.y *= float(r.y);
    float A = dst0.y * dst0.y + dst1.y * dst1.y + 1.0f;
    float B = -2.0f * (dst0.x * dst0.y + dst1.x * dst1.y);
    float C = dst0.x * dst0.x + dst1.x * dst1.x + 1.0f;
    const float inv_f = 1.0f / (A * C - B * B * 0.25f);
    A *= inv_f;
    B *= inv_f;
    C *= inv_f;
    const float det = -(B * B) + 4.0f * A * C;
    const float inv_det = 1.0f / det;
    const float u_sqrt = std::sqrt(std::max(0.0f, det * C));
    const float v_sqrt = std::sqrt(std::max(0.0f, A * det));
    const int s0 = to_int(std::ceil(st.x - 2.0f * inv_det * u_sqrt));
    const int s1 = to_int(std::floor(st.x + 2.0f * inv_det * u_sqrt));
    const int t0 = to_int(std::ceil(st.y - 2.0f * inv_det * v_sqrt));
    const int t1 = to_int(std::floor(st.y + 2.0f * inv_det * v_sqrt));
    const float* lut = s.tex_data.data() + s.globals.tex_tables.y;
    glm::vec3 sum(0.0f);
    float sum_wts = 0.0f;
    for (int it = t0; it <= t1; ++it) {
      const float tt = float(it) - st.y;
      for (int is = s0; is <= s1; ++is) {
        const float ss = float(is) - st.x;
        const float r2 = A * (ss * ss) + B * ss * tt + C * (tt * tt);
        if (r2 < 1.0f) {
          const int index =
              std::min(int(r2 * float(gpu::EWA_LUT_SIZE)), int(gpu::EWA_LUT_SIZE) - 1);
          const float w = lut[index];
          sum += w * texel(level, {is, it});
          sum_wts += w;
        }
      }
    }
    // Not in pbrt-v4 (0 / 0): an ellipse that covers no texel centre, which happens only at
    // texel coordinates beyond float's integer precision (2^30, where int() clamps), gives 0,
    // as a non-finite coordinate does.
    return sum_wts > 0.0f ? sum / sum_wts : glm::vec3(0.0f);
  }
};

}  // namespace

// pbrt-v4 MIPMap::Texel<RGB> / Texel<Float> (util/mipmap.cpp).
glm::vec3 mipmap_texel(const SceneTables& s, std::uint32_t level, glm::ivec2 xy,
                       std::uint32_t wrap, bool want_float) {
  if (level >= s.mip_levels.size()) return glm::vec3(0.0f);
  const gpu::MipLevel& l = s.mip_levels[level];
  if (want_float || l.channels == 1) return glm::vec3(channel(s, l, xy, 0, wrap));
  return glm::vec3(channel(s, l, xy, 0, wrap), channel(s, l, xy, 1, wrap),
                   channel(s, l, xy, 2, wrap));
}

// pbrt-v4 MIPMap::Bilerp<RGB> / Bilerp<Float> (util/mipmap.cpp).
glm::vec3 mipmap_bilerp(const SceneTables& s, std::uint32_t level, glm::vec2 st,
                        std::uint32_t wrap, bool want_float) {
  if (level >= s.mip_levels.size()) return glm::vec3(0.0f);
  const gpu::MipLevel& l = s.mip_levels[level];
  if (l.channels == 1) return glm::vec3(bilerp_channel(s, l, st, 0, wrap));
  const float r = bilerp_channel(s, l, st, 0, wrap), g = bilerp_channel(s, l, st, 1, wrap),
              b = bilerp_channel(s, l, st, 2, wrap);
  if (want_float) return glm::vec3((r + g + b) / 3.0f);
  return glm::vec3(r, g, b);
}

// pbrt-v4 MIPMap::Filter (util/mipmap.cpp).
glm::vec3 mipmap_filter(const SceneTables& s, const gpu::Texture& t, glm::vec2 st, glm::vec2 dst0,
                        glm::vec2 dst1, bool want_float) {
  const std::uint32_t levels = t.ip.x;
  if (levels == 0 || t.image >= s.mip_levels.size() || t.image + levels > s.mip_levels.size())
    return glm::vec3(0.0f);
  // Not in pbrt-v4 (which propagates NaN or overflows): a non-finite coordinate or
  // differential gives 0.
  if (!std::isfinite(st.x) || !std::isfinite(st.y) || !std::isfinite(dst0.x) ||
      !std::isfinite(dst0.y) || !std::isfinite(dst1.x) || !std::isfinite(dst1.y))
    return glm::vec3(0.0f);
  const Lookup m{s, t.image, levels, (t.flags & gpu::TEXFLAG_WRAP_MASK) >> gpu::TEXFLAG_WRAP_SHIFT,
                 want_float};
  const std::uint32_t filter = (t.flags & gpu::TEXFLAG_FILTER_MASK) >> gpu::TEXFLAG_FILTER_SHIFT;
  const int n = int(levels);
  if (filter != gpu::FILTER_EWA) {
    const float width =
        2.0f * std::max(std::max(std::max(std::fabs(dst0.x), std::fabs(dst0.y)), std::fabs(dst1.x)),
                        std::fabs(dst1.y));
    const float level = float(n - 1) + log2_pbrt(std::max(width, 1e-8f));
    if (level >= float(n - 1)) return m.texel(n - 1, {0, 0});
    const int il = std::max(0, int(std::floor(level)));
    if (filter == gpu::FILTER_POINT) {
      const glm::ivec2 r = m.res(il);
      const glm::ivec2 sti(round_int(st.x * float(r.x) - 0.5f), round_int(st.y * float(r.y) - 0.5f));
      return m.texel(il, sti);
    }
    if (filter == gpu::FILTER_BILINEAR || il == 0) return m.bilerp(il, st);
    return lerp3(level - float(il), m.bilerp(il, st), m.bilerp(il + 1, st));
  }
  // EWA: the longer axis first, the shorter stretched to at most maxanisotropy times shorter.
  if (dst0.x * dst0.x + dst0.y * dst0.y < dst1.x * dst1.x + dst1.y * dst1.y) std::swap(dst0, dst1);
  const float longer = std::sqrt(dst0.x * dst0.x + dst0.y * dst0.y);
  float shorter = std::sqrt(dst1.x * dst1.x + dst1.y * dst1.y);
  const float max_aniso = t.param[0].y;
  if (shorter * max_aniso < longer && shorter > 0.0f) {
    const float scale = longer / (shorter * max_aniso);
    dst1 *= scale;
    shorter *= scale;
  }
  // Not in pbrt-v4 (which converts an infinite level of detail to int): an ellipse whose
  // length overflows float, before or after the eccentricity clamp (a footprint of finite but
  // enormous differentials), reads the coarsest texel, as every footprint wider than the image
  // does (EWA at a level >= the level count).
  if (!std::isfinite(shorter)) return m.texel(n - 1, {0, 0});
  if (shorter == 0.0f) return m.bilerp(0, st);
  const float lod = std::max(0.0f, float(n - 1) + log2_pbrt(shorter));
  const float fl = std::floor(lod);
  const int il = int(fl);
  return lerp3(lod - fl, m.ewa(il, st, dst0, dst1), m.ewa(il + 1, st, dst0, dst1));
}

}  // namespace basalt::cpu
