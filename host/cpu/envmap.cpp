// Image infinite lights of the CPU reference (docs/textures-spec.md section 6): pbrt-v4
// ImageInfiniteLight (lights.h) with its PiecewiseConstant2D distributions (util/sampling.h)
// read from tex_data, equal-area octahedral mapping (util/math.cpp) and nearest lookups with
// octahedral wrap (util/image.h). fp32, no fma (-ffp-contract=off), sums left to right.
#include "cpu/envmap.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "cpu/sampling.h"

namespace basalt::cpu {
namespace {

constexpr float FOUR_PI = 4.0f * PI;     // 12.566371f, exact multiple of the float pi
constexpr float PI_OVER_4 = PI / 4.0f;   // 0.785398185f

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
  std::uint32_t lo = 0, hi = n;
  while (hi - lo > 1) {
    const std::uint32_t mid = (lo + hi) / 2;
    if (cdf[mid] <= u) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  offset = lo;
  float du = u - cdf[lo];
  const float width = cdf[lo + 1] - cdf[lo];
  if (width > 0.0f) du = du / width;
  pdf = integral > 0.0f ? func[lo] / integral : 0.0f;
  return (float(lo) + du) / float(n);
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

// pbrt-v4 ImageInfiniteLight::Le.
glm::vec3 env_le(const SceneTables& s, const gpu::Light& l, glm::vec3 w_world) {
  const glm::vec3 wl = safe_normalize(to_light(l, w_world));
  return image_le(s, l, equal_area_sphere_to_square(wl));
}

// pbrt-v4 ImageInfiniteLight::PDF_Li with PiecewiseConstant2D::PDF.
float env_pdf(const SceneTables& s, const gpu::Light& l, glm::vec3 w_world, bool compensated) {
  const Distribution2D d = distribution(s, l, compensated);
  if (!d.valid()) return 0.0f;
  const glm::vec2 uv = equal_area_sphere_to_square(safe_normalize(to_light(l, w_world)));
  if (!(uv.x >= 0.0f && uv.x <= 1.0f && uv.y >= 0.0f && uv.y <= 1.0f)) return 0.0f;
  const int iu = std::clamp(int(uv.x * float(d.nu)), 0, int(d.nu) - 1);
  const int iv = std::clamp(int(uv.y * float(d.nv)), 0, int(d.nv) - 1);
  const float integral = d.integral();
  if (!(integral > 0.0f)) return 0.0f;  // pbrt-v4 divides by 0 here
  const float map_pdf = d.cond(std::uint32_t(iv))[iu] / integral;
  return map_pdf / FOUR_PI;
}

// pbrt-v4 ImageInfiniteLight::SampleLi with PiecewiseConstant2D::Sample.
bool env_sample(const SceneTables& s, const gpu::Light& l, glm::vec2 u, bool compensated,
                glm::vec3& wi, float& pdf, glm::vec3& le) {
  wi = glm::vec3(0.0f);
  pdf = 0.0f;
  le = glm::vec3(0.0f);
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
  wi = to_world(l, equal_area_square_to_sphere(uv));
  pdf = map_pdf / FOUR_PI;
  le = image_le(s, l, uv);
  return true;
}

}  // namespace basalt::cpu
