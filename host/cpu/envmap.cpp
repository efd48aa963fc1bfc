// Image infinite lights of the CPU reference (docs/textures-spec.md section 6): pbrt-v4
// ImageInfiniteLight (lights.h) with its PiecewiseConstant2D distributions (util/sampling.h)
// read from tex_data, equal-area octahedral mapping (util/math.cpp) and nearest lookups with
// octahedral wrap (util/image.h); the lat-long (pbrt-v3 InfiniteAreaLight) and cube (Shirley
// 11.6) mappings of 6.8 and the portal of 6.9 (pbrt-v4 PortalImageInfiniteLight), selected by
// Light.data.w. fp32, no fma (-ffp-contract=off, which two_diff's exactness needs), sums left
// to right.
#include "cpu/envmap.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "cpu/mipmap.h"
#include "cpu/sampling.h"

namespace basalt::cpu {
namespace {

constexpr float FOUR_PI = 4.0f * PI;     // 12.566371f, exact multiple of the float pi
constexpr float PI_OVER_4 = PI / 4.0f;   // 0.785398185f
constexpr float TWO_PI = 2.0f * PI;      // 6.28318548f
constexpr float INV_2PI = 0.159154937f;  // textures-spec 6.8 constants
constexpr float INV_PI_F = 0.318309886f;
constexpr float TWO_PI2 = 19.7392088f;   // 2 pi^2

// Light.data.w (textures-spec 6.8, 6.9).
constexpr std::uint32_t MAP_EQUAL_AREA = 0, MAP_LATLONG = 1, MAP_CUBE = 2, MAP_PORTAL = 3;
constexpr float HALF_PI = PI / 2.0f;  // textures-spec 6.9 constants
// pi^2 rounded to float, the spec's (and the GLSL's) literal; note that the float product
// PI * PI would be 9.86960506f, one ulp above.
constexpr float PI2 = 9.86960411f;

/// Rotation into the light's frame: columns of light_from_world summed left to right
/// (spec section 6, "light frame"; pbrt-v4 renderFromLight.ApplyInverse).
glm::vec3 to_light(const gpu::Light& l, glm::vec3 w) {
  const glm::mat4& m = l.light_from_world;
  return glm::vec3(m[0][0] * w.x + m[1][0] * w.y + m[2][0] * w.z,
                   m[0][1] * w.x + m[1][1] * w.y + m[2][1] * w.z,
                   m[0][2] * w.x + m[1][2] * w.y + m[2][2] * w.z);
}

/// Rotation back to world: the transpose, i.e. dot(column i, w) (pbrt-v4 renderFromLight(w)).
glm::vec3 to_world(const gpu::Light& l, glm::vec3 w) {
  const glm::mat4& m = l.light_from_world;
  return glm::vec3(m[0][0] * w.x + m[0][1] * w.y + m[0][2] * w.z,
                   m[1][0] * w.x + m[1][1] * w.y + m[1][2] * w.z,
                   m[2][0] * w.x + m[2][1] * w.y + m[2][2] * w.z);
}

/// The light's image level, or null when the tables do not hold it.
const gpu::MipLevel* env_level(const SceneTables& s, const gpu::Light& l) {
  if (l.data.x >= s.mip_levels.size()) return nullptr;
  const gpu::MipLevel& m = s.mip_levels[l.data.x];
  const std::size_t n = std::size_t(m.width) * m.height * m.channels;
  if (m.width == 0 || m.height == 0 || m.channels == 0 || m.offset + n > s.texels.size())
    return nullptr;
  return &m;
}

/// pbrt-v4 Image::LookupNearestChannel with WrapMode::OctahedralSphere (util/image.h
/// RemapPixelCoords), clamped at 0 and scaled as ImageInfiniteLight::ImageLe.
glm::vec3 image_le(const SceneTables& s, const gpu::Light& l, glm::vec2 uv) {
  const gpu::MipLevel* m = env_level(s, l);
  if (!m || !(uv.x >= 0.0f && uv.x <= 1.0f && uv.y >= 0.0f && uv.y <= 1.0f))
    return glm::vec3(0.0f);
  const int w = int(m->width), h = int(m->height);
  int x = int(uv.x * float(w)), y = int(uv.y * float(h));
  if (x < 0) {
    x = -x;
    y = h - 1 - y;
  } else if (x >= w) {
    x = 2 * w - 1 - x;
    y = h - 1 - y;
  }
  if (y < 0) {
    x = w - 1 - x;
    y = -y;
  } else if (y >= h) {
    x = w - 1 - x;
    y = 2 * h - 1 - y;
  }
  if (w == 1) x = 0;
  if (h == 1) y = 0;
  x = std::clamp(x, 0, w - 1);  // no effect for uv in [0, 1]
  y = std::clamp(y, 0, h - 1);
  const float* t = &s.texels[m->offset + m->channels * (std::size_t(y) * m->width + x)];
  const glm::vec3 rgb = m->channels >= 3 ? glm::vec3(t[0], t[1], t[2]) : glm::vec3(t[0]);
  return glm::vec3(l.L) * glm::max(rgb, glm::vec3(0.0f));
}

/// Lat-long radiance (textures-spec 6.8): pbrt-v3 MIPMap::Lookup at width 0, the bilinear
/// lookup of level 0 with repeat wrap in both axes, clamped at 0 and scaled.
glm::vec3 latlong_le(const SceneTables& s, const gpu::Light& l, glm::vec2 uv) {
  if (!env_level(s, l)) return glm::vec3(0.0f);
  const glm::vec3 rgb = mipmap_bilerp(s, l.data.x, uv, gpu::WRAP_REPEAT, false);
  return glm::vec3(l.L) * glm::max(rgb, glm::vec3(0.0f));
}

/// Cube-strip texel of face uv (fu, fv) on face `face` (textures-spec 6.8): nearest, column
/// min(int(fu n), n - 1), row face n + min(int(fv n), n - 1). NaN (a zero direction) reads 0.
glm::ivec2 cube_texel(int face, float fu, float fv, int n) {
  const int tx = fu >= 0.0f ? std::min(int(std::fmin(fu, 1.0f) * float(n)), n - 1) : 0;
  const int ty = fv >= 0.0f ? std::min(int(std::fmin(fv, 1.0f) * float(n)), n - 1) : 0;
  return glm::ivec2(tx, face * n + ty);
}

/// Cube radiance: texel (x, y) of the strip, clamped at 0 and scaled.
glm::vec3 cube_le(const SceneTables& s, const gpu::Light& l, glm::ivec2 t) {
  const gpu::MipLevel* m = env_level(s, l);
  if (!m || m->channels < 3) return glm::vec3(0.0f);
  const int x = std::clamp(t.x, 0, int(m->width) - 1), y = std::clamp(t.y, 0, int(m->height) - 1);
  const float* p = &s.texels[m->offset + m->channels * (std::size_t(y) * m->width + x)];
  return glm::vec3(l.L) * glm::max(glm::vec3(p[0], p[1], p[2]), glm::vec3(0.0f));
}

/// A PiecewiseConstant2D in tex_data (spec section 6 layout), or !valid().
struct Distribution2D {
  const float* base = nullptr;
  std::uint32_t nu = 0, nv = 0;
  bool valid() const { return base != nullptr; }
  float integral() const { return base[2]; }
  const float* marginal_func() const { return base + 4; }
  const float* marginal_cdf() const { return base + 4 + nv; }
  const float* cond(std::uint32_t v) const {
    return base + 5 + 2 * std::size_t(nv) + std::size_t(v) * (2 * std::size_t(nu) + 2);
  }
};

Distribution2D distribution(const SceneTables& s, const gpu::Light& l, bool compensated) {
  Distribution2D d;
  const std::size_t o = compensated ? l.data.z : l.data.y;
  if (o + 4 > s.tex_data.size()) return d;
  const float fu = s.tex_data[o], fv = s.tex_data[o + 1];
  if (!(fu >= 1.0f && fv >= 1.0f)) return d;
  d.nu = std::uint32_t(fu);
  d.nv = std::uint32_t(fv);
  const std::size_t size = 5 + 2 * std::size_t(d.nv) + std::size_t(d.nv) * (2 * std::size_t(d.nu) + 2);
  if (o + size > s.tex_data.size()) return d;
  d.base = &s.tex_data[o];
  return d;
}

/// pbrt-v4 PiecewiseConstant1D::Sample over [0, 1] (spec section 6, "sampling"): interval by
/// binary search (largest i in [0, n-1] with cdf[i] <= u), du = u - cdf[i], divided by the
/// interval width if that is positive, pdf = func[i] / integral (0 if the integral is 0).
float sample_1d(const float* func, const float* cdf, float integral, std::uint32_t n, float u,
                float& pdf, std::uint32_t& offset) {
  const std::uint32_t lo = find_interval(cdf, n, u);
  offset = lo;
  float du = u - cdf[lo];
  const float width = cdf[lo + 1] - cdf[lo];
  if (width > 0.0f) du = du / width;
  pdf = integral > 0.0f ? func[lo] / integral : 0.0f;
  return (float(lo) + du) / float(n);
}

// ---- Portals (textures-spec 6.9; pbrt-v4 PortalImageInfiniteLight, lights.h / lights.cpp,
// WindowedPiecewiseConstant2D and SummedAreaTable, util/sampling.h). The portal frame is
// light_from_world (rows x, y, z), p0 is Light.pos, p2 Light.dir.

/// A point of the portal image (u, v) with its Jacobian duv_dw, or none.
struct PortalUv {
  bool valid = false;
  glm::vec2 uv = glm::vec2(0.0f);
  float duv_dw = 0.0f;
};

/// A box of the portal image (min, max componentwise), or none.
struct PortalBox {
  bool valid = false;
  glm::vec2 lo = glm::vec2(0.0f), hi = glm::vec2(0.0f);
};

/// World direction \p w (unit) to the portal image (pbrt-v4 PortalImageInfiniteLight::
/// ImageFromRender): none behind the portal plane (wp.z <= 0, or NaN).
PortalUv portal_world_to_image(const gpu::Light& l, glm::vec3 w) {
  PortalUv r;
  const glm::vec3 wp = to_light(l, w);  // dots with the frame's rows, not normalised
  if (!(wp.z > 0.0f)) return r;
  r.valid = true;
  r.duv_dw = ((PI2 * (1.0f - wp.x * wp.x)) * (1.0f - wp.y * wp.y)) / wp.z;
  const float alpha = std::atan2(wp.x, wp.z), beta = std::atan2(wp.y, wp.z);
  r.uv = glm::vec2(std::clamp((alpha + HALF_PI) / PI, 0.0f, 1.0f),
                   std::clamp((beta + HALF_PI) / PI, 0.0f, 1.0f));
  return r;
}

/// Portal image point \p uv to the world direction and its Jacobian \p duv_dw (pbrt-v4
/// PortalImageInfiniteLight::RenderFromImage).
glm::vec3 portal_image_to_world(const gpu::Light& l, glm::vec2 uv, float& duv_dw) {
  const float alpha = -HALF_PI + uv.x * PI, beta = -HALF_PI + uv.y * PI;
  const glm::vec3 v = safe_normalize(glm::vec3(std::tan(alpha), std::tan(beta), 1.0f));
  duv_dw = ((PI2 * (1.0f - v.x * v.x)) * (1.0f - v.y * v.y)) / v.z;
  return to_world(l, v);
}

/// The box of the portal image visible from \p p through the window (pbrt-v4
/// PortalImageInfiniteLight::ImageBounds: the images of the corners p0 and p2), or none.
PortalBox portal_bounds(const gpu::Light& l, glm::vec3 p) {
  PortalBox b;
  const PortalUv a = portal_world_to_image(l, safe_normalize(glm::vec3(l.pos) - p));
  const PortalUv c = portal_world_to_image(l, safe_normalize(glm::vec3(l.dir) - p));
  if (!a.valid || !c.valid) return b;
  b.valid = true;
  b.lo = glm::vec2(std::fmin(a.uv.x, c.uv.x), std::fmin(a.uv.y, c.uv.y));
  b.hi = glm::vec2(std::fmax(a.uv.x, c.uv.x), std::fmax(a.uv.y, c.uv.y));
  return b;
}

/// Radiance of the rectified image at \p uv (pbrt-v4 PortalImageInfiniteLight::ImageLookup:
/// LookupNearestChannel with clamp), clamped at 0 and scaled.
glm::vec3 portal_lookup(const SceneTables& s, const gpu::Light& l, glm::vec2 uv) {
  const gpu::MipLevel* m = env_level(s, l);
  if (!m || m->channels < 3 || !(uv.x >= 0.0f && uv.x <= 1.0f && uv.y >= 0.0f && uv.y <= 1.0f))
    return glm::vec3(0.0f);
  const int w = int(m->width), h = int(m->height);
  const int x = std::clamp(int(uv.x * float(w)), 0, w - 1);
  const int y = std::clamp(int(uv.y * float(h)), 0, h - 1);
  const float* t = &s.texels[m->offset + m->channels * (std::size_t(y) * m->width + x)];
  return glm::vec3(l.L) * glm::max(glm::vec3(t[0], t[1], t[2]), glm::vec3(0.0f));
}

/// The windowed distribution in tex_data (textures-spec 6.9 layout: nx, ny, func, sat), or
/// !valid().
struct PortalDistribution {
  const float* base = nullptr;
  int nx = 0, ny = 0;
  bool valid() const { return base != nullptr; }
  const float* func() const { return base + 4; }
  const float* sat() const { return base + 4 + std::size_t(nx) * ny; }
};

PortalDistribution portal_distribution(const SceneTables& s, const gpu::Light& l) {
  PortalDistribution d;
  const std::size_t o = l.data.y;
  if (o + 4 > s.tex_data.size()) return d;
  const float fx = s.tex_data[o], fy = s.tex_data[o + 1];
  if (!(fx >= 1.0f && fy >= 1.0f)) return d;
  d.nx = int(fx);
  d.ny = int(fy);
  if (o + 4 + 2 * std::size_t(d.nx) * d.ny > s.tex_data.size()) return d;
  d.base = &s.tex_data[o];
  return d;
}

/// func at the cell of \p uv (pbrt-v4 WindowedPiecewiseConstant2D::Eval).
float portal_eval(const PortalDistribution& d, glm::vec2 uv) {
  const int x = std::clamp(int(uv.x * float(d.nx)), 0, d.nx - 1);
  const int y = std::clamp(int(uv.y * float(d.ny)), 0, d.ny - 1);
  return d.func()[std::size_t(y) * d.nx + x];
}

/// Bilinear summed-area value at (x, y) in [0, 1]^2 (pbrt-v4 SummedAreaTable::Lookup and
/// LookupInt: 0 on the lower boundaries).
float portal_sat_lookup(const PortalDistribution& d, float x, float y) {
  x = x * float(d.nx);
  y = y * float(d.ny);
  const int x0 = std::max(int(x), 0), y0 = std::max(int(y), 0);  // x, y >= 0 for a valid box
  const float dx = x - float(x0), dy = y - float(y0);
  auto v = [&](int i, int j) {
    if (i == 0 || j == 0) return 0.0f;
    return d.sat()[std::size_t(std::min(j - 1, d.ny - 1)) * d.nx + std::min(i - 1, d.nx - 1)];
  };
  return (((1.0f - dx) * (1.0f - dy)) * v(x0, y0) + ((1.0f - dx) * dy) * v(x0, y0 + 1)) +
         ((dx * (1.0f - dy)) * v(x0 + 1, y0)) + ((dx * dy) * v(x0 + 1, y0 + 1));
}

/// a - b as an unevaluated float pair (hi, lo) with hi + lo == a - b exactly (Knuth's TwoSum
/// of a and -b; exact without fma contraction).
void two_diff(float a, float b, float& hi, float& lo) {
  hi = a - b;
  const float bb = hi - a;
  lo = (a - (hi - bb)) - (b + bb);
}

/// Integral of func over the box [lo, hi] of [0, 1]^2 (pbrt-v4 SummedAreaTable::Integral,
/// which forms the differences in double; here exactly by two_diff, textures-spec 6.9).
float portal_integral(const PortalDistribution& d, glm::vec2 lo, glm::vec2 hi) {
  const float a = portal_sat_lookup(d, hi.x, hi.y), b = portal_sat_lookup(d, lo.x, hi.y);
  const float c = portal_sat_lookup(d, lo.x, lo.y), e = portal_sat_lookup(d, hi.x, lo.y);
  float h1, l1, h2, l2;
  two_diff(a, b, h1, l1);
  two_diff(c, e, h2, l2);
  const float sum = (h1 + h2) + (l1 + l2);
  return std::fmax(sum / float(d.nx * d.ny), 0.0f);
}

/// Inverts the monotone cdf \p P on [lo, hi] at \p u (pbrt-v4 WindowedPiecewiseConstant2D::
/// SampleBisection, with textures-spec 6.9's 64-step cap and t = 0.5 on a flat interval).
template <typename F>
float portal_bisect(const F& P, float u, float lo, float hi, int n) {
  const float fn = float(n);
  for (int step = 0; step < 64 && std::ceil(fn * hi) - std::floor(fn * lo) > 1.0f; ++step) {
    const float mid = (lo + hi) / 2.0f;
    if (P(mid) > u)
      hi = mid;
    else
      lo = mid;
  }
  const float pl = P(lo), ph = P(hi);
  const float t = ph - pl > 0.0f ? (u - pl) / (ph - pl) : 0.5f;
  return std::clamp((1.0f - t) * lo + t * hi, lo, hi);
}

/// Portal Le along a ray from \p o in direction \p w (pbrt-v4 PortalImageInfiniteLight::Le).
glm::vec3 portal_le(const SceneTables& s, const gpu::Light& l, glm::vec3 w, glm::vec3 o) {
  const PortalUv q = portal_world_to_image(l, safe_normalize(w));
  if (!q.valid) return glm::vec3(0.0f);
  const PortalBox b = portal_bounds(l, o);
  if (!b.valid || !(q.uv.x >= b.lo.x && q.uv.x <= b.hi.x && q.uv.y >= b.lo.y && q.uv.y <= b.hi.y))
    return glm::vec3(0.0f);
  return portal_lookup(s, l, q.uv);
}

/// Portal solid-angle pdf of \p w (unit) from \p p (pbrt-v4 PortalImageInfiniteLight::PDF_Li,
/// WindowedPiecewiseConstant2D::PDF; uv need not lie in the window, as pbrt-v4).
float portal_pdf(const SceneTables& s, const gpu::Light& l, glm::vec3 w, glm::vec3 p) {
  const PortalDistribution d = portal_distribution(s, l);
  if (!d.valid()) return 0.0f;
  const PortalUv q = portal_world_to_image(l, w);
  if (!q.valid || q.duv_dw == 0.0f) return 0.0f;
  const PortalBox b = portal_bounds(l, p);
  if (!b.valid) return 0.0f;
  const float integral = portal_integral(d, b.lo, b.hi);
  if (!(integral > 0.0f)) return 0.0f;
  return (portal_eval(d, q.uv) / integral) / q.duv_dw;
}

/// Portal sample from \p p (pbrt-v4 PortalImageInfiniteLight::SampleLi with
/// WindowedPiecewiseConstant2D::Sample); outputs untouched when there is none.
bool portal_sample(const SceneTables& s, const gpu::Light& l, glm::vec2 u, glm::vec3 p,
                   glm::vec3& wi, float& pdf, glm::vec3& le) {
  const PortalDistribution d = portal_distribution(s, l);
  if (!d.valid()) return false;
  const PortalBox b = portal_bounds(l, p);
  if (!b.valid) return false;
  const float integral = portal_integral(d, b.lo, b.hi);
  if (!(integral > 0.0f)) return false;
  // Column: the marginal cdf over the window's columns.
  const float x = portal_bisect(
      [&](float t) { return portal_integral(d, b.lo, glm::vec2(t, b.hi.y)) / integral; }, u.x,
      b.lo.x, b.hi.x, d.nx);
  // Row: the conditional cdf of the window's part of x's column.
  const float fnx = float(d.nx);
  glm::vec2 c_lo(std::floor(x * fnx) / fnx, b.lo.y), c_hi(std::ceil(x * fnx) / fnx, b.hi.y);
  if (c_lo.x == c_hi.x) c_hi.x = c_hi.x + 1.0f / fnx;
  const float c_integral = portal_integral(d, c_lo, c_hi);
  if (!(c_integral > 0.0f)) return false;
  const float y = portal_bisect(
      [&](float t) { return portal_integral(d, c_lo, glm::vec2(c_hi.x, t)) / c_integral; }, u.y,
      b.lo.y, b.hi.y, d.ny);
  const glm::vec2 uv(x, y);
  const float map_pdf = portal_eval(d, uv) / integral;
  float duv_dw = 0.0f;
  const glm::vec3 w = portal_image_to_world(l, uv, duv_dw);
  if (duv_dw == 0.0f) return false;
  const float pd = map_pdf / duv_dw;
  if (!(pd > 0.0f)) return false;
  wi = w;
  pdf = pd;
  le = portal_lookup(s, l, uv);
  return true;
}

}  // namespace

// pbrt-v4 EqualAreaSquareToSphere (util/math.cpp; Clarberg's equal-area octahedral map).
glm::vec3 equal_area_square_to_sphere(glm::vec2 p) {
  const float u = 2.0f * p.x - 1.0f, v = 2.0f * p.y - 1.0f;
  const float up = std::fabs(u), vp = std::fabs(v);
  const float signed_distance = 1.0f - (up + vp);
  const float d = std::fabs(signed_distance);
  const float r = 1.0f - d;
  const float phi = (r == 0.0f ? 1.0f : (vp - up) / r + 1.0f) * PI_OVER_4;
  const float z = std::copysign(1.0f - r * r, signed_distance);
  const float cos_phi = std::copysign(std::cos(phi), u);
  const float sin_phi = std::copysign(std::sin(phi), v);
  const float s = safe_sqrt(2.0f - r * r);
  return glm::vec3(cos_phi * r * s, sin_phi * r * s, z);
}

// pbrt-v4 EqualAreaSphereToSquare (util/math.cpp), its atan polynomial in Horner form
// without fma.
glm::vec2 equal_area_sphere_to_square(glm::vec3 d) {
  const float x = std::fabs(d.x), y = std::fabs(d.y), z = std::fabs(d.z);
  const float r = safe_sqrt(1.0f - z);
  const float a = std::fmax(x, y);
  float b = std::fmin(x, y);
  b = a == 0.0f ? 0.0f : b / a;
  constexpr float t1 = 0.406758566246788489601959989e-5f;
  constexpr float t2 = 0.636226545274016134946890922156f;
  constexpr float t3 = 0.61572017898280213493197203466e-2f;
  constexpr float t4 = -0.247333733281268944196501420480f;
  constexpr float t5 = 0.881770664775316294736387951347e-1f;
  constexpr float t6 = 0.419038818029165735901852432784e-1f;
  constexpr float t7 = -0.251390972343483509333252996350e-1f;
  float phi = t1 + b * (t2 + b * (t3 + b * (t4 + b * (t5 + b * (t6 + b * t7)))));
  if (x < y) phi = 1.0f - phi;
  float v = phi * r;
  float u = r - v;
  if (d.z < 0.0f) {
    std::swap(u, v);
    u = 1.0f - u;
    v = 1.0f - v;
  }
  u = std::copysign(u, d.x);
  v = std::copysign(v, d.y);
  return glm::vec2(0.5f * (u + 1.0f), 0.5f * (v + 1.0f));
}

// Lat-long direction to (u, v) (textures-spec 6.8; pbrt-v3 SphericalPhi / SphericalTheta).
glm::vec2 latlong_dir_to_uv(glm::vec3 wl) {
  const float theta = std::acos(std::clamp(wl.z, -1.0f, 1.0f));
  float phi = std::atan2(wl.y, wl.x);
  if (phi < 0.0f) phi = phi + TWO_PI;
  return glm::vec2(phi * INV_2PI, theta * INV_PI_F);
}

// Lat-long (u, v) to the direction (textures-spec 6.8, the sampling formulas).
glm::vec3 latlong_uv_to_dir(glm::vec2 uv) {
  const float theta = uv.y * PI, phi = uv.x * TWO_PI;
  const float sin_t = std::sin(theta), cos_t = std::cos(theta);
  return glm::vec3(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t);
}

// Cube face and face coordinates (textures-spec 6.8; OpenGL's major-axis table).
int cube_face_coords(glm::vec3 wl, float& a, float& b) {
  const float ax = std::fabs(wl.x), ay = std::fabs(wl.y), az = std::fabs(wl.z);
  int face;
  float m;
  if (ax >= ay && ax >= az) {
    face = wl.x > 0.0f ? 0 : 1;
    m = ax;
  } else if (ay >= az) {
    face = wl.y > 0.0f ? 2 : 3;
    m = ay;
  } else {
    face = wl.z > 0.0f ? 4 : 5;
    m = az;
  }
  switch (face) {
    case 0: a = -wl.z / m; b = -wl.y / m; break;
    case 1: a = wl.z / m; b = -wl.y / m; break;
    case 2: a = wl.x / m; b = wl.z / m; break;
    case 3: a = wl.x / m; b = -wl.z / m; break;
    case 4: a = wl.x / m; b = -wl.y / m; break;
    default: a = -wl.x / m; b = -wl.y / m; break;
  }
  return face;
}

// Cube strip (u, v) of a direction.
glm::vec2 cube_dir_to_uv(glm::vec3 wl) {
  float a, b;
  const int face = cube_face_coords(wl, a, b);
  const float fu = (a + 1.0f) * 0.5f, fv = (b + 1.0f) * 0.5f;
  return glm::vec2(fu, (float(face) + fv) / 6.0f);
}

// Cube face uv to the unit direction (textures-spec 6.8, the sampling formulas).
glm::vec3 cube_face_uv_to_dir(int face, float fu, float fv) {
  const float a = 2.0f * fu - 1.0f, b = 2.0f * fv - 1.0f;
  glm::vec3 d;
  switch (face) {
    case 0: d = glm::vec3(1.0f, -b, -a); break;
    case 1: d = glm::vec3(-1.0f, -b, a); break;
    case 2: d = glm::vec3(a, 1.0f, b); break;
    case 3: d = glm::vec3(a, -1.0f, -b); break;
    case 4: d = glm::vec3(a, -b, 1.0f); break;
    default: d = glm::vec3(-a, -b, -1.0f); break;
  }
  return safe_normalize(d);
}

// pbrt-v4 ImageInfiniteLight::Le; lat-long and cube maps as textures-spec 6.8, portals as
// 6.9 (PortalImageInfiniteLight::Le, the only mapping that reads o).
glm::vec3 env_le(const SceneTables& s, const gpu::Light& l, glm::vec3 w_world, glm::vec3 o) {
  if (l.data.w == MAP_PORTAL) return portal_le(s, l, w_world, o);
  const glm::vec3 wl = safe_normalize(to_light(l, w_world));
  if (l.data.w == MAP_LATLONG) return latlong_le(s, l, latlong_dir_to_uv(wl));
  if (l.data.w == MAP_CUBE) {
    const gpu::MipLevel* m = env_level(s, l);
    if (!m) return glm::vec3(0.0f);
    float a, b;
    const int face = cube_face_coords(wl, a, b);
    return cube_le(s, l, cube_texel(face, (a + 1.0f) * 0.5f, (b + 1.0f) * 0.5f, int(m->width)));
  }
  return image_le(s, l, equal_area_sphere_to_square(wl));
}

// pbrt-v4 ImageInfiniteLight::PDF_Li with PiecewiseConstant2D::PDF (a portal: 6.9, one
// distribution, compensated ignored).
float env_pdf(const SceneTables& s, const gpu::Light& l, glm::vec3 w_world, bool compensated,
              glm::vec3 p) {
  if (l.data.w == MAP_PORTAL) return portal_pdf(s, l, w_world, p);
  const Distribution2D d = distribution(s, l, compensated);
  if (!d.valid()) return 0.0f;
  const glm::vec3 wl = safe_normalize(to_light(l, w_world));
  if (l.data.w == MAP_CUBE) {
    // The pdf of the texel that Le reads (textures-spec 6.8): (tx, ty) of the face lookup.
    float a, b;
    const int face = cube_face_coords(wl, a, b);
    const int n = int(d.nu);
    if (d.nv != 6 * d.nu) return 0.0f;
    const glm::ivec2 t = cube_texel(face, (a + 1.0f) * 0.5f, (b + 1.0f) * 0.5f, n);
    const float integral = d.integral();
    if (!(integral > 0.0f)) return 0.0f;
    const float map_pdf = d.cond(std::uint32_t(t.y))[t.x] / integral;
    const float r = std::sqrt((1.0f + a * a) + b * b);
    return map_pdf * (r * r * r) / 24.0f;
  }
  float sin_t = 1.0f;
  glm::vec2 uv;
  if (l.data.w == MAP_LATLONG) {
    uv = latlong_dir_to_uv(wl);
    // sin theta from the direction itself (textures-spec 6.8): acos of z near +-1 loses
    // precision, and sin(acos(-1)) = sin(float pi) < 0.
    sin_t = std::sqrt(wl.x * wl.x + wl.y * wl.y);
    if (!(sin_t > 0.0f)) return 0.0f;  // the poles
  } else {
    uv = equal_area_sphere_to_square(wl);
  }
  if (!(uv.x >= 0.0f && uv.x <= 1.0f && uv.y >= 0.0f && uv.y <= 1.0f)) return 0.0f;
  const int iu = std::clamp(int(uv.x * float(d.nu)), 0, int(d.nu) - 1);
  const int iv = std::clamp(int(uv.y * float(d.nv)), 0, int(d.nv) - 1);
  const float integral = d.integral();
  if (!(integral > 0.0f)) return 0.0f;  // pbrt-v4 divides by 0 here
  const float map_pdf = d.cond(std::uint32_t(iv))[iu] / integral;
  if (l.data.w == MAP_LATLONG) return map_pdf / (TWO_PI2 * sin_t);
  return map_pdf / FOUR_PI;
}

// pbrt-v4 ImageInfiniteLight::SampleLi with PiecewiseConstant2D::Sample (a portal: 6.9).
bool env_sample(const SceneTables& s, const gpu::Light& l, glm::vec2 u, bool compensated,
                glm::vec3& wi, float& pdf, glm::vec3& le, glm::vec3 p) {
  wi = glm::vec3(0.0f);
  pdf = 0.0f;
  le = glm::vec3(0.0f);
  if (l.data.w == MAP_PORTAL) return portal_sample(s, l, u, p, wi, pdf, le);
  const Distribution2D d = distribution(s, l, compensated);
  if (!d.valid()) return false;
  float pdf_v = 0.0f, pdf_u = 0.0f;
  std::uint32_t iv = 0, iu = 0;
  const float d1 = sample_1d(d.marginal_func(), d.marginal_cdf(), d.integral(), d.nv, u.y, pdf_v, iv);
  const float* c = d.cond(iv);
  const float d0 = sample_1d(c, c + d.nu, c[2 * d.nu + 1], d.nu, u.x, pdf_u, iu);
  const float map_pdf = pdf_u * pdf_v;
  if (map_pdf == 0.0f) return false;
  const glm::vec2 uv(d0, d1);
  if (l.data.w == MAP_LATLONG) {
    const float theta = uv.y * PI, phi = uv.x * TWO_PI;
    const float sin_t = std::sin(theta), cos_t = std::cos(theta);
    if (!(sin_t > 0.0f)) return false;  // the poles (sin(float pi) < 0)
    wi = to_world(l, glm::vec3(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t));
    pdf = map_pdf / (TWO_PI2 * sin_t);
    le = latlong_le(s, l, uv);
    return true;
  }
  if (l.data.w == MAP_CUBE) {
    const int n = int(d.nu);
    if (d.nv != 6 * d.nu) {
      wi = glm::vec3(0.0f);
      return false;
    }
    // The face of the sampled row (not re-derived from uv.y, which rounding can push across
    // a face boundary); fv clamped to [0, 1].
    const int face = int(iv) / n;
    const float fv = std::clamp(uv.y * 6.0f - float(face), 0.0f, 1.0f);
    const float a = 2.0f * uv.x - 1.0f, b = 2.0f * fv - 1.0f;
    wi = to_world(l, cube_face_uv_to_dir(face, uv.x, fv));
    const float r = std::sqrt((1.0f + a * a) + b * b);
    pdf = map_pdf * (r * r * r) / 24.0f;
    le = cube_le(s, l, cube_texel(face, uv.x, fv, n));
    return true;
  }
  wi = to_world(l, equal_area_square_to_sphere(uv));
  pdf = map_pdf / FOUR_PI;
  le = image_le(s, l, uv);
  return true;
}

}  // namespace basalt::cpu
