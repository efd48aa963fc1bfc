// Texture evaluation in the CPU reference (docs/textures-spec.md; pbrt-v4 textures.h/.cpp,
// interaction.cpp, cameras.h).
#include "cpu/texture.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "cpu/mipmap.h"
#include "cpu/noise.h"

namespace basalt::cpu {
namespace {

constexpr float kPi = 3.14159265358979323846f;

// m * (p, 1) summed left to right (docs/path-spec.md arithmetic rules).
glm::vec3 xform_point(const glm::mat4& m, glm::vec3 p) {
  return glm::vec3(m[0]) * p.x + glm::vec3(m[1]) * p.y + glm::vec3(m[2]) * p.z + glm::vec3(m[3]);
}

// mat3(m) * v summed left to right.
glm::vec3 xform_vector(const glm::mat4& m, glm::vec3 v) {
  return glm::vec3(m[0]) * v.x + glm::vec3(m[1]) * v.y + glm::vec3(m[2]) * v.z;
}

// 2D texture coordinates and their screen derivatives (pbrt-v4 TexCoord2D).
struct TexCoord2D {
  glm::vec2 st;
  float dsdx, dsdy, dtdx, dtdy;
};

// pbrt-v4 UVMapping / SphericalMapping / CylindricalMapping / PlanarMapping::Map.
TexCoord2D map_2d(const gpu::Texture& t, const TextureContext& c) {
  TexCoord2D r{};
  const std::uint32_t mapping = t.flags & gpu::TEXFLAG_MAPPING_MASK;
  if (mapping == gpu::MAPPING_UV) {
    const glm::vec4 m = t.map[0];
    r.dsdx = m.x * c.dudx;
    r.dsdy = m.x * c.dudy;
    r.dtdx = m.y * c.dvdx;
    r.dtdy = m.y * c.dvdy;
    r.st = glm::vec2(m.x * c.uv.x + m.z, m.y * c.uv.y + m.w);
    return r;
  }
  const glm::vec3 pt = xform_point(t.xform, c.p);
  const glm::vec3 dpdx = xform_vector(t.xform, c.dpdx), dpdy = xform_vector(t.xform, c.dpdy);
  if (mapping == gpu::MAPPING_PLANAR) {
    const glm::vec3 vs(t.map[0]), vt(t.map[1]);
    r.dsdx = glm::dot(vs, dpdx);
    r.dsdy = glm::dot(vs, dpdy);
    r.dtdx = glm::dot(vt, dpdx);
    r.dtdy = glm::dot(vt, dpdy);
    r.st = glm::vec2(t.map[0].w + glm::dot(pt, vs), t.map[1].w + glm::dot(pt, vt));
    return r;
  }
  const float x2y2 = pt.x * pt.x + pt.y * pt.y;
  const glm::vec3 dsdp = glm::vec3(-pt.y, pt.x, 0.0f) / (2.0f * kPi * x2y2);
  if (mapping == gpu::MAPPING_SPHERICAL) {
    const float sq = std::sqrt(x2y2);
    const glm::vec3 dtdp = (1.0f / (kPi * (x2y2 + pt.z * pt.z))) *
                           glm::vec3(pt.x * pt.z / sq, pt.y * pt.z / sq, -sq);
    r.dsdx = glm::dot(dsdp, dpdx);
    r.dsdy = glm::dot(dsdp, dpdy);
    r.dtdx = glm::dot(dtdp, dpdx);
    r.dtdy = glm::dot(dtdp, dpdy);
    const float len = std::sqrt(glm::dot(pt, pt));
    const glm::vec3 v = len > 0.0f ? pt / len : glm::vec3(0.0f, 0.0f, 1.0f);
    // pbrt-v4 SphericalTheta (SafeACos of z) / pi and SphericalPhi / (2 pi).
    const float theta = std::acos(std::clamp(v.z, -1.0f, 1.0f));
    float phi = std::atan2(v.y, v.x);
    if (phi < 0.0f) phi += 2.0f * kPi;
    r.st = glm::vec2(theta * (1.0f / kPi), phi * (1.0f / (2.0f * kPi)));
  } else {  // cylindrical
    r.dsdx = glm::dot(dsdp, dpdx);
    r.dsdy = glm::dot(dsdp, dpdy);
    r.dtdx = dpdx.z;
    r.dtdy = dpdy.z;
    r.st = glm::vec2((kPi + std::atan2(pt.y, pt.x)) * (1.0f / (2.0f * kPi)), pt.z);
  }
  // A derivative at the mapping's axis (x2y2 = 0) is not finite: no filtering there.
  for (float* d : {&r.dsdx, &r.dsdy, &r.dtdx, &r.dtdy})
    if (!std::isfinite(*d)) *d = 0.0f;
  return r;
}

// Parity of floor(x), 1 - 2 (floor(x) & 1), computed exactly in float for any x.
float checker_sign(float x) {
  const float f = std::floor(x);
  return f - 2.0f * std::floor(f * 0.5f) == 0.0f ? 1.0f : -1.0f;
}

// pbrt-v4 Checkerboard(): integral of the 1D checker against a box of radius r.
float checker_d(float x) {
  const float y = x / 2.0f - std::floor(x / 2.0f) - 0.5f;
  return x / 2.0f + y * (1.0f - 2.0f * std::fabs(y));
}
// Not in pbrt-v4: the result is clamped to [-1, 1], the range of a filtered +-1 function; the
// second difference cancels where r is a few ulps of x (8e6 with r = 0.15) and then gave
// weights outside [0, 1], so that a checkerboard of non-negative textures went negative
// (docs/textures-spec.md 8).
// Not in pbrt-v4 either: a radius whose square is below the smallest normal float (a footprint
// of 1e-19 or less: 0 / 0 at a cell edge) samples the checker at x, as a zero radius does.
float checker_bf(float x, float r) {
  if (std::floor(x - r) == std::floor(x + r) || !(r * r >= FLT_MIN)) return checker_sign(x);
  const float v = (checker_d(x + r) - 2.0f * checker_d(x) + checker_d(x - r)) / (r * r);
  return v > 1.0f ? 1.0f : (v < -1.0f ? -1.0f : v);
}

// Weight of tex2 of the checkerboard (pbrt-v4 Checkerboard, closed-form box filtering).
float checkerboard(const gpu::Texture& t, const TextureContext& c) {
  if (t.ip.x == 3u) {
    const glm::vec3 p = xform_point(t.xform, c.p);
    const glm::vec3 dx = xform_vector(t.xform, c.dpdx), dy = xform_vector(t.xform, c.dpdy);
    const float rx = 1.5f * std::max(std::fabs(dx.x), std::fabs(dy.x));
    const float ry = 1.5f * std::max(std::fabs(dx.y), std::fabs(dy.y));
    const float rz = 1.5f * std::max(std::fabs(dx.z), std::fabs(dy.z));
    return 0.5f - 0.5f * checker_bf(p.x, rx) * checker_bf(p.y, ry) * checker_bf(p.z, rz);
  }
  const TexCoord2D m = map_2d(t, c);
  const float ds = 1.5f * std::max(std::fabs(m.dsdx), std::fabs(m.dsdy));
  const float dt = 1.5f * std::max(std::fabs(m.dtdx), std::fabs(m.dtdy));
  return 0.5f - checker_bf(m.st.x, ds) * checker_bf(m.st.y, dt) / 2.0f;
}

// pbrt-v4 InsidePolkaDot: one dot of radius 0.35 in some unit cells, jittered by noise.
bool inside_polka_dot(const SceneTables& s, glm::vec2 st) {
  const float sc = std::floor(st.x + 0.5f), tc = std::floor(st.y + 0.5f);
  if (!(perlin_noise(s, glm::vec3(sc + 0.5f, tc + 0.5f, 0.5f)) > 0.0f)) return false;
  const float radius = 0.35f, max_shift = 0.5f - radius;
  const float s_center = sc + max_shift * perlin_noise(s, glm::vec3(sc + 1.5f, tc + 2.8f, 0.5f));
  const float t_center = tc + max_shift * perlin_noise(s, glm::vec3(sc + 4.5f, tc + 9.8f, 0.5f));
  const glm::vec2 d = st - glm::vec2(s_center, t_center);
  return glm::dot(d, d) < radius * radius;
}

// pbrt-v4 Lerp of colours.
glm::vec3 lerp3(float t, glm::vec3 a, glm::vec3 b) { return (1.0f - t) * a + t * b; }

// pbrt-v4 MarbleTexture: noise-perturbed sine bands through a cubic Bezier colour spline.
glm::vec3 marble(const SceneTables& s, const gpu::Texture& t, const TextureContext& c) {
  const float scale = t.param[0].y, variation = t.param[0].z;
  const glm::vec3 p = scale * xform_point(t.xform, c.p);
  const glm::vec3 dx = scale * xform_vector(t.xform, c.dpdx);
  const glm::vec3 dy = scale * xform_vector(t.xform, c.dpdy);
  const float m = p.y + variation * fbm(s, p, dx, dy, t.param[0].x, int(t.ip.x), noise_split(s));
  float u = 0.5f + 0.5f * std::sin(m);
  static const glm::vec3 colors[9] = {
      {.58f, .58f, .6f}, {.58f, .58f, .6f}, {.58f, .58f, .6f}, {.5f, .5f, .5f},  {.6f, .59f, .58f},
      {.58f, .58f, .6f}, {.58f, .58f, .6f}, {.2f, .2f, .33f},  {.58f, .58f, .6f}};
  const int n_seg = 6;
  const int first = std::min(int(std::floor(u * float(n_seg))), n_seg - 1);
  u = u * float(n_seg) - float(first);
  const glm::vec3* cp = colors + first;
  // de Casteljau evaluation (pbrt-v4 EvaluateCubicBezier).
  const glm::vec3 a = lerp3(u, cp[0], cp[1]), b = lerp3(u, cp[1], cp[2]), d = lerp3(u, cp[2], cp[3]);
  const glm::vec3 e = lerp3(u, a, b), f = lerp3(u, b, d);
  return 1.5f * lerp3(u, e, f);
}

// pbrt-v4 FloatImageTexture / SpectrumImageTexture::Evaluate (textures.h, textures.cpp):
// t flipped, MIPMap::Filter, times scale; a float texture inverts to max(0, 1 - v), an rgb one
// clamps at 0 always (after 1 - v when inverted), then to [0, 1] in an albedo slot.
glm::vec3 image_texture(const SceneTables& s, const gpu::Texture& t, const TextureContext& c) {
  const TexCoord2D tc = map_2d(t, c);
  const glm::vec2 st(tc.st.x, 1.0f - tc.st.y);
  const bool is_float = (t.flags & gpu::TEXFLAG_FLOAT) != 0;
  const glm::vec3 f = mipmap_filter(s, t, st, glm::vec2(tc.dsdx, tc.dtdx),
                                    glm::vec2(tc.dsdy, tc.dtdy), is_float);
  const float scale = t.param[0].x;
  const bool invert = (t.flags & gpu::TEXFLAG_INVERT) != 0;
  if (is_float) {
    const float v = scale * f.x;
    return glm::vec3(invert ? std::max(0.0f, 1.0f - v) : v);
  }
  glm::vec3 rgb = scale * f;
  if (invert) rgb = glm::vec3(1.0f) - rgb;
  for (int i = 0; i < 3; ++i) {
    rgb[i] = std::max(0.0f, rgb[i]);  // pbrt-v4 ClampZero
    if ((t.flags & gpu::TEXFLAG_ALBEDO) && rgb[i] > 1.0f) rgb[i] = 1.0f;
  }
  return rgb;
}

// ---- Shirley's solid textures (docs/textures-spec.md section 7) ----------------------------

constexpr float kInvPi = 0.318309886f;  // the float 1 / pi of section 7

// sin(pi u) with exact periodicity: r = u - 2 floor(u / 2), then sin(pi r).
float sin_pi(float u) {
  const float r = u - 2.0f * std::floor(u / 2.0f);
  return std::sin(kPi * r);
}

// Section 4.2's int(): clamp to [-2^30, 2^30], then truncate.
int clamped_int(float v) { return int(std::clamp(v, -1073741824.0f, 1073741824.0f)); }

// Non-negative a mod n.
int pos_mod(int a, int n) { return ((a % n) + n) % n; }

// Value of voxel / texel `index` (in texels, not floats) of MipLevel l: rgb, a grey level
// broadcast; a float texture reads channel 0.
glm::vec3 level_value(const SceneTables& s, const gpu::MipLevel& l, std::size_t index,
                      bool want_float) {
  const float* v = s.texels.data() + l.offset + index * l.channels;
  if (want_float || l.channels == 1u) return glm::vec3(v[0]);
  return glm::vec3(v[0], v[1], v[2]);
}

// Seed 002 11.1.2: the image as an nx x ny array on the unit square, row j = 0 at the bottom,
// nearest / bilinear / hermite interpolation between samples at integer (s nx, t ny), tiled.
glm::vec3 interp_image(const SceneTables& s, const gpu::Texture& t, const TextureContext& c) {
  if (t.image >= s.mip_levels.size()) return glm::vec3(0.0f);
  const gpu::MipLevel& l = s.mip_levels[t.image];
  const glm::vec2 st = map_2d(t, c).st;
  if (!std::isfinite(st.x) || !std::isfinite(st.y)) return glm::vec3(0.0f);
  const bool want_float = (t.flags & gpu::TEXFLAG_FLOAT) != 0;
  const int nx = int(l.width), ny = int(l.height);
  const float X = st.x * float(nx), Y = st.y * float(ny);
  const float fx = std::floor(X), fy = std::floor(Y);
  const int i0 = pos_mod(clamped_int(fx), nx), j0 = pos_mod(clamped_int(fy), ny);
  const int i1 = pos_mod(i0 + 1, nx), j1 = pos_mod(j0 + 1, ny);
  // c(i, j): column i, row j counted from the bottom (stored rows run top to bottom).
  auto cij = [&](int i, int j) {
    return level_value(s, l, std::size_t(ny - 1 - j) * std::size_t(nx) + std::size_t(i),
                       want_float);
  };
  if (t.ip.x == 0u) return cij(i0, j0);
  float u = X - fx, v = Y - fy;
  if (t.ip.x == 2u) {
    u = 3.0f * (u * u) - 2.0f * ((u * u) * u);
    v = 3.0f * (v * v) - 2.0f * ((v * v) * v);
  }
  return ((1.0f - u) * (1.0f - v)) * cij(i0, j0) + (u * (1.0f - v)) * cij(i1, j0) +
         ((1.0f - u) * v) * cij(i0, j1) + (u * v) * cij(i1, j1);
}

// Seed 002 11.1.2 in 3D: trilinear interpolation of the nx x ny x nz voxels on the unit cube
// of texture space, tiled with period 1, summed in the order of the seed's eq. 11.2.
glm::vec3 volume_texture(const SceneTables& s, const gpu::Texture& t, const TextureContext& c) {
  if (t.image >= s.mip_levels.size()) return glm::vec3(0.0f);
  const gpu::MipLevel& l = s.mip_levels[t.image];
  const glm::vec3 p = xform_point(t.xform, c.p);
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return glm::vec3(0.0f);
  const bool want_float = (t.flags & gpu::TEXFLAG_FLOAT) != 0;
  const int nx = int(t.ip.y), ny = int(t.ip.z), nz = int(t.ip.w);
  const float X = p.x * float(nx), Y = p.y * float(ny), Z = p.z * float(nz);
  const float fx = std::floor(X), fy = std::floor(Y), fz = std::floor(Z);
  const int i0 = pos_mod(clamped_int(fx), nx), j0 = pos_mod(clamped_int(fy), ny),
            k0 = pos_mod(clamped_int(fz), nz);
  const int i1 = pos_mod(i0 + 1, nx), j1 = pos_mod(j0 + 1, ny), k1 = pos_mod(k0 + 1, nz);
  const float u = X - fx, v = Y - fy, w = Z - fz;
  auto cijk = [&](int i, int j, int k) {
    return level_value(s, l, (std::size_t(k) * std::size_t(ny) + std::size_t(j)) * std::size_t(nx) +
                                 std::size_t(i),
                       want_float);
  };
  return ((1.0f - u) * (1.0f - v)) * (1.0f - w) * cijk(i0, j0, k0) +
         (u * (1.0f - v)) * (1.0f - w) * cijk(i1, j0, k0) +
         ((1.0f - u) * v) * (1.0f - w) * cijk(i0, j1, k0) +
         ((1.0f - u) * (1.0f - v)) * w * cijk(i0, j0, k1) +
         (u * v) * (1.0f - w) * cijk(i1, j1, k0) +
         (u * (1.0f - v)) * w * cijk(i1, j0, k1) +
         ((1.0f - u) * v) * w * cijk(i0, j1, k1) +
         (u * v) * w * cijk(i1, j1, k1);
}

// Value of instruction t whose children's values are args[0 .. k) (docs/textures-spec.md 2).
glm::vec3 eval_instruction(const SceneTables& s, const gpu::Texture& t, const TextureContext& c,
                           const glm::vec3* args) {
  switch (t.type) {
    case gpu::TEXTURE_CONSTANT:
      return glm::vec3(t.param[0]);
    case gpu::TEXTURE_SCALE: {
      const float sc = args[1].x;
      return sc == 0.0f ? glm::vec3(0.0f) : args[0] * sc;
    }
    case gpu::TEXTURE_MIX: {
      const float amt = args[2].x;
      const glm::vec3 t1 = amt != 1.0f ? args[0] : glm::vec3(0.0f);
      const glm::vec3 t2 = amt != 0.0f ? args[1] : glm::vec3(0.0f);
      return (1.0f - amt) * t1 + amt * t2;
    }
    case gpu::TEXTURE_DIRECTION_MIX: {
      const float amt = std::fabs(glm::dot(c.n, glm::vec3(t.param[0])));
      const glm::vec3 t1 = amt != 0.0f ? args[0] : glm::vec3(0.0f);
      const glm::vec3 t2 = amt != 1.0f ? args[1] : glm::vec3(0.0f);
      return amt * t1 + (1.0f - amt) * t2;
    }
    case gpu::TEXTURE_BILERP: {
      const glm::vec2 st = map_2d(t, c).st;
      return (1.0f - st.x) * (1.0f - st.y) * glm::vec3(t.param[0]) +
             st.x * (1.0f - st.y) * glm::vec3(t.param[2]) +
             (1.0f - st.x) * st.y * glm::vec3(t.param[1]) + st.x * st.y * glm::vec3(t.param[3]);
    }
    case gpu::TEXTURE_CHECKERBOARD: {
      const float w = checkerboard(t, c);
      const glm::vec3 t1 = w != 1.0f ? args[0] : glm::vec3(0.0f);
      const glm::vec3 t2 = w != 0.0f ? args[1] : glm::vec3(0.0f);
      return (1.0f - w) * t1 + w * t2;
    }
    case gpu::TEXTURE_DOTS:
      return inside_polka_dot(s, map_2d(t, c).st) ? args[0] : args[1];
    case gpu::TEXTURE_FBM:
    case gpu::TEXTURE_WRINKLED: {
      const glm::vec3 p = xform_point(t.xform, c.p);
      const glm::vec3 dx = xform_vector(t.xform, c.dpdx), dy = xform_vector(t.xform, c.dpdy);
      const bool split = noise_split(s);
      const float v = t.type == gpu::TEXTURE_FBM
                          ? fbm(s, p, dx, dy, t.param[0].x, int(t.ip.x), split)
                          : turbulence(s, p, dx, dy, t.param[0].x, int(t.ip.x), split);
      return glm::vec3(v);
    }
    case gpu::TEXTURE_WINDY: {
      const glm::vec3 p = xform_point(t.xform, c.p);
      const glm::vec3 dx = xform_vector(t.xform, c.dpdx), dy = xform_vector(t.xform, c.dpdy);
      const float strength = fbm(s, 0.1f * p, 0.1f * dx, 0.1f * dy, 0.5f, 3, noise_split(s));
      const float height = fbm(s, p, dx, dy, 0.5f, 6, noise_split(s));
      return glm::vec3(std::fabs(strength) * height);
    }
    case gpu::TEXTURE_MARBLE:
      return marble(s, t, c);
    case gpu::TEXTURE_IMAGEMAP:
      return image_texture(s, t, c);
    case gpu::TEXTURE_STRIPE: {
      const float x = xform_point(t.xform, c.p).x;
      const float w = t.param[0].x;
      if (t.ip.x == 0u) return sin_pi(x * kInvPi) > 0.0f ? args[0] : args[1];
      if (t.ip.x == 1u) return sin_pi(x / w) > 0.0f ? args[0] : args[1];
      const float tt = (1.0f + sin_pi(x / w)) / 2.0f;
      const glm::vec3 t1 = tt != 1.0f ? args[0] : glm::vec3(0.0f);
      const glm::vec3 t2 = tt != 0.0f ? args[1] : glm::vec3(0.0f);
      return (1.0f - tt) * t1 + tt * t2;
    }
    case gpu::TEXTURE_TURBULENT_STRIPE: {
      const glm::vec3 p = xform_point(t.xform, c.p);
      const float k1 = t.param[0].x, k2 = t.param[0].y, w = t.param[0].z;
      const float a = k1 * p.z + shirley_turbulence(s, k2 * p, int(t.ip.x));
      const float tt = (1.0f + sin_pi((a / w) * kInvPi)) / 2.0f;
      const glm::vec3 t1 = tt != 0.0f ? args[0] : glm::vec3(0.0f);
      const glm::vec3 t2 = tt != 1.0f ? args[1] : glm::vec3(0.0f);
      return tt * t1 + (1.0f - tt) * t2;
    }
    case gpu::TEXTURE_SHIRLEY_NOISE: {
      const glm::vec3 p = xform_point(t.xform, c.p);
      return glm::vec3(t.param[0].x * (shirley_noise(s, p) + t.param[0].y));
    }
    case gpu::TEXTURE_SHIRLEY_TURBULENCE: {
      const glm::vec3 p = xform_point(t.xform, c.p);
      return glm::vec3(t.param[0].x * (shirley_turbulence(s, p, int(t.ip.x)) + t.param[0].y));
    }
    case gpu::TEXTURE_IMAGE_INTERP:
      return interp_image(s, t, c);
    case gpu::TEXTURE_VOLUME:
      return volume_texture(s, t, c);
    default:
      return glm::vec3(0.0f);
  }
}

// Children each tag pops (docs/textures-spec.md section 2).
int child_count(std::uint32_t tag) {
  switch (tag) {
    case gpu::TEXTURE_SCALE:
    case gpu::TEXTURE_DIRECTION_MIX:
    case gpu::TEXTURE_CHECKERBOARD:
    case gpu::TEXTURE_DOTS:
    case gpu::TEXTURE_STRIPE:
    case gpu::TEXTURE_TURBULENT_STRIPE:
      return 2;
    case gpu::TEXTURE_MIX:
      return 3;
    default:
      return 0;
  }
}

}  // namespace

glm::vec3 tex_eval_rgb(const SceneTables& s, std::uint32_t root, const TextureContext& ctx) {
  if (root >= s.textures.size()) return glm::vec3(0.0f);
  glm::vec3 stack[gpu::MAX_TEXTURE_STACK];
  int top = 0;
  for (std::uint32_t i = s.textures[root].first; i <= root; ++i) {
    const gpu::Texture& t = s.textures[i];
    const int k = child_count(t.type);
    if (top < k) return glm::vec3(0.0f);  // malformed program (the host never emits one)
    top -= k;
    const glm::vec3 v = eval_instruction(s, t, ctx, stack + top);
    if (top >= int(gpu::MAX_TEXTURE_STACK)) return glm::vec3(0.0f);
    stack[top++] = v;
  }
  return top > 0 ? stack[top - 1] : glm::vec3(0.0f);
}

float tex_eval_float(const SceneTables& s, std::uint32_t root, const TextureContext& ctx) {
  return tex_eval_rgb(s, root, ctx).x;
}

void approximate_dp_dxy(const SceneTables& s, glm::vec3 p, glm::vec3 n, glm::vec3& dpdx,
                        glm::vec3& dpdy) {
  const gpu::Globals& g = s.globals;
  const glm::vec3 pc = xform_point(g.camera_from_world, p);
  // Normals transform by the inverse transpose: camera-space n = transpose(W) n.
  const glm::vec3 nc(glm::dot(glm::vec3(g.world_from_camera[0]), n),
                     glm::dot(glm::vec3(g.world_from_camera[1]), n),
                     glm::dot(glm::vec3(g.world_from_camera[2]), n));
  // pbrt-v4 RotateFromTo(normalize(pc), (0, 0, 1)): two reflections.
  const float pl = std::sqrt(glm::dot(pc, pc));
  const glm::vec3 from = pl > 0.0f ? pc / pl : glm::vec3(0.0f, 0.0f, 1.0f);
  const glm::vec3 to(0.0f, 0.0f, 1.0f);
  const glm::vec3 refl = std::fabs(from.x) < 0.72f ? glm::vec3(1, 0, 0)
                         : std::fabs(from.y) < 0.72f ? glm::vec3(0, 1, 0)
                                                      : glm::vec3(0, 0, 1);
  const glm::vec3 u = refl - from, v = refl - to;
  const float uu = glm::dot(u, u), vv = glm::dot(v, v), uv = glm::dot(u, v);
  float r[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r[i][j] = (i == j ? 1.0f : 0.0f) - 2.0f / uu * u[i] * u[j] - 2.0f / vv * v[i] * v[j] +
                4.0f * uv / (uu * vv) * v[i] * u[j];
  auto rot = [&](glm::vec3 x) {
    return glm::vec3(r[0][0] * x.x + r[0][1] * x.y + r[0][2] * x.z,
                     r[1][0] * x.x + r[1][1] * x.y + r[1][2] * x.z,
                     r[2][0] * x.x + r[2][1] * x.y + r[2][2] * x.z);
  };
  auto rot_inv = [&](glm::vec3 x) {  // the transpose
    return glm::vec3(r[0][0] * x.x + r[1][0] * x.y + r[2][0] * x.z,
                     r[0][1] * x.x + r[1][1] * x.y + r[2][1] * x.z,
                     r[0][2] * x.x + r[1][2] * x.y + r[2][2] * x.z);
  };
  const glm::vec3 p_down = rot(pc), n_down = rot(nc);
  const float d = n_down.z * p_down.z;
  const glm::vec3 ox(g.min_pos_dx), oy(g.min_pos_dy);
  const glm::vec3 dx = to + glm::vec3(g.min_dir_dx), dy = to + glm::vec3(g.min_dir_dy);
  const float tx = -(glm::dot(n_down, ox) - d) / glm::dot(n_down, dx);
  const float ty = -(glm::dot(n_down, oy) - d) / glm::dot(n_down, dy);
  const glm::vec3 px = ox + tx * dx, py = oy + ty * dy;
  const float spp_scale = g.min_dir_dx.w;
  dpdx = spp_scale * xform_vector(g.world_from_camera, rot_inv(px - p_down));
  dpdy = spp_scale * xform_vector(g.world_from_camera, rot_inv(py - p_down));
}

void scale_differentials(RayDifferential& diff, glm::vec3 o, glm::vec3 d, float s) {
  diff.rx_o = o + (diff.rx_o - o) * s;
  diff.ry_o = o + (diff.ry_o - o) * s;
  diff.rx_d = d + (diff.rx_d - d) * s;
  diff.ry_d = d + (diff.ry_d - d) * s;
}

bool specular_differentials(const TextureContext& ctx, glm::vec3 o, glm::vec3 ns, glm::vec3 dndu,
                            glm::vec3 dndv, glm::vec3 wo, glm::vec3 wi, bool transmission,
                            float eta, const RayDifferential& in, RayDifferential& out) {
  glm::vec3 n = ns;
  glm::vec3 dndx = dndu * ctx.dudx + dndv * ctx.dvdx;
  glm::vec3 dndy = dndu * ctx.dudy + dndv * ctx.dvdy;
  const glm::vec3 dwodx = -in.rx_d - wo, dwody = -in.ry_d - wo;
  // From the spawned origin (pbrt-v4: p() + dpdx; basalt's spawn offset is large enough to
  // shift the footprint otherwise, textures-spec 3.1).
  out.rx_o = o + ctx.dpdx;
  out.ry_o = o + ctx.dpdy;
  if (!transmission) {
    const float dwo_n_dx = glm::dot(dwodx, n) + glm::dot(wo, dndx);
    const float dwo_n_dy = glm::dot(dwody, n) + glm::dot(wo, dndy);
    const float won = glm::dot(wo, n);
    out.rx_d = (wi - dwodx) + 2.0f * (won * dndx + dwo_n_dx * n);
    out.ry_d = (wi - dwody) + 2.0f * (won * dndy + dwo_n_dy * n);
  } else {
    if (glm::dot(wo, n) < 0.0f) {
      n = -n;
      dndx = -dndx;
      dndy = -dndy;
    }
    const float dwo_n_dx = glm::dot(dwodx, n) + glm::dot(wo, dndx);
    const float dwo_n_dy = glm::dot(dwody, n) + glm::dot(wo, dndy);
    const float won = glm::dot(wo, n), win = glm::dot(wi, n);
    const float mu = won / eta - std::fabs(win);
    const float k = 1.0f / eta + (1.0f / (eta * eta)) * won / win;
    const float dmudx = dwo_n_dx * k, dmudy = dwo_n_dy * k;
    out.rx_d = (wi - eta * dwodx) + (mu * dndx + dmudx * n);
    out.ry_d = (wi - eta * dwody) + (mu * dndy + dmudy * n);
  }
  // pbrt-v4: "squash potentially troublesome differentials" (NaN fails the test too).
  for (const glm::vec3& v : {out.rx_d, out.ry_d, out.rx_o, out.ry_o})
    if (!(glm::dot(v, v) <= 1e16f)) return false;
  return true;
}

void compute_differentials(const SceneTables& s, TextureContext& ctx, glm::vec3 dpdu,
                           glm::vec3 dpdv, const RayDifferential* diff) {
  ctx.dpdx = ctx.dpdy = glm::vec3(0.0f);
  ctx.dudx = ctx.dudy = ctx.dvdx = ctx.dvdy = 0.0f;
  if (s.globals.texture_opts.x & gpu::TEXOPT_DISABLE_FILTERING) return;
  const glm::vec3 n = ctx.n, p = ctx.p;
  bool done = false;
  if (diff) {
    const glm::vec3 rxo = diff->rx_o, rxd = diff->rx_d, ryo = diff->ry_o, ryd = diff->ry_d;
    const float ndx = glm::dot(n, rxd), ndy = glm::dot(n, ryd);
    if (ndx != 0.0f && ndy != 0.0f) {
      const float dd = -glm::dot(n, p);
      const float tx = (-glm::dot(n, rxo) - dd) / ndx;
      const float ty = (-glm::dot(n, ryo) - dd) / ndy;
      ctx.dpdx = (rxo + tx * rxd) - p;
      ctx.dpdy = (ryo + ty * ryd) - p;
      done = true;
    }
  }
  if (!done) approximate_dp_dxy(s, p, n, ctx.dpdx, ctx.dpdy);
  for (glm::vec3* v : {&ctx.dpdx, &ctx.dpdy})
    if (!std::isfinite(v->x) || !std::isfinite(v->y) || !std::isfinite(v->z)) *v = glm::vec3(0.0f);
  // Least squares for (u, v) differentials (pbrt-v4 ComputeDifferentials).
  const float a00 = glm::dot(dpdu, dpdu), a01 = glm::dot(dpdu, dpdv), a11 = glm::dot(dpdv, dpdv);
  float inv_det = 1.0f / (a00 * a11 - a01 * a01);
  if (!std::isfinite(inv_det)) inv_det = 0.0f;
  const float b0x = glm::dot(dpdu, ctx.dpdx), b1x = glm::dot(dpdv, ctx.dpdx);
  const float b0y = glm::dot(dpdu, ctx.dpdy), b1y = glm::dot(dpdv, ctx.dpdy);
  auto clean = [](float x) { return std::isfinite(x) ? std::clamp(x, -1e8f, 1e8f) : 0.0f; };
  ctx.dudx = clean((a11 * b0x - a01 * b1x) * inv_det);
  ctx.dvdx = clean((a00 * b1x - a01 * b0x) * inv_det);
  ctx.dudy = clean((a11 * b0y - a01 * b1y) * inv_det);
  ctx.dvdy = clean((a00 * b1y - a01 * b0y) * inv_det);
}

}  // namespace basalt::cpu
