// Flattens a parsed Scene into the GPU tables of shaders/shared/layout.h: world-space geometry,
// materials, lights with their selection distribution, the filter table and the BVH.
#include "scene/tables.h"

#include "cpu/wide_bvh.h"

#include <algorithm>
#include <bit>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>

#include "accel/bvh.h"
#include "scene/displace.h"
#include "scene/materials.h"
#include "scene/samplers.h"
#include "scene/textures.h"

namespace basalt {
namespace {

using gpu::INVALID_INDEX;

constexpr double kPi = std::numbers::pi;
// Bins per axis of the tabulated gaussian filter (Globals.counts.w).
constexpr std::uint32_t kFilterBins = 64;
// Relative tolerance of the similarity test for sphere transforms.
constexpr float kSimilarityTolerance = 1e-4f;

std::string warning_at(const SourceLoc& loc, const std::string& message) {
  return loc.str() + ": warning: " + message;
}

bool all_finite(const glm::vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Applies a homogeneous transform to a point (with the divide, as pbrt-v4 Transform does).
glm::vec3 transform_point(const glm::mat4& m, const glm::vec3& p) {
  glm::vec4 q = m * glm::vec4(p, 1.0f);
  if (q.w == 1.0f) return glm::vec3(q);
  return glm::vec3(q) / q.w;
}

gpu::Material diffuse_material(const glm::vec3& reflectance) {
  gpu::Material m{};
  m.type = gpu::MATERIAL_DIFFUSE;
  for (auto& v : m.value) v = glm::vec4(0.0f);
  m.value[gpu::SLOT_DIFFUSE_REFLECTANCE] = glm::vec4(reflectance, 0.0f);
  for (auto& t : m.texture) t = glm::uvec4(INVALID_INDEX);
  return m;
}

// Screen window (pbrt-v4 CameraBase / PerspectiveCamera): the shorter image axis spans [-1, 1].
glm::vec4 screen_window(const Scene& scene) {
  if (scene.camera.screen_window) return *scene.camera.screen_window;
  float aspect = static_cast<float>(scene.film.xres) / static_cast<float>(scene.film.yres);
  if (aspect > 1.0f) return {-aspect, aspect, -1.0f, 1.0f};
  return {-1.0f, 1.0f, -1.0f / aspect, 1.0f / aspect};
}

// Normalised cumulative table of weights: n + 1 entries, cdf[0] = 0, cdf[n] = 1 exactly;
// summed in double and rounded once, so the float table is monotone. Uniform when every
// weight is 0.
std::vector<float> cumulative(const std::vector<double>& w) {
  const std::size_t n = w.size();
  double total = 0.0;
  for (double x : w) total += x;
  const bool uniform = !(total > 0.0) || !std::isfinite(total);
  std::vector<float> cdf(n + 1);
  double acc = 0.0;
  cdf[0] = 0.0f;
  for (std::size_t i = 0; i < n; ++i) {
    acc += uniform ? 1.0 : w[i];
    cdf[i + 1] = static_cast<float>(acc / (uniform ? static_cast<double>(n) : total));
  }
  if (n > 0) cdf[n] = 1.0f;
  return cdf;
}

// Tabulated gaussian filter along one axis (pbrt-v4 GaussianFilter: f(x) = max(0, g(x) - g(r)),
// g the normal density of sigma): kFilterBins bins over [-r, r], each weighted by f at its
// centre. Centres are r (2i + 1 - N) / N so the table is exactly symmetric.
std::vector<float> gaussian_cdf(float radius, float sigma) {
  const double r = radius, s = sigma;
  auto g = [s](double x) { return std::exp(-x * x / (2.0 * s * s)) / (std::sqrt(2.0 * kPi) * s); };
  const double edge = g(r);
  std::vector<double> w(kFilterBins);
  for (std::uint32_t i = 0; i < kFilterBins; ++i) {
    double x = r * (2.0 * i + 1.0 - kFilterBins) / kFilterBins;
    double f = g(x) - edge;
    w[i] = f > 0.0 ? f : 0.0;  // also maps NaN (sigma <= 0) to 0: the table turns uniform
  }
  return cumulative(w);
}

// Relative solid angle of texel (x, y) of a w x h environment map in `mapping`
// (docs/textures-spec.md 6.8), in double: 1 for the equal-area square; sin theta at the
// row centre for lat-long; 1 / r^3 at the texel centre of its face for the cube strip.
double env_texel_weight(std::uint32_t mapping, std::uint32_t x, std::uint32_t y,
                        std::uint32_t w, std::uint32_t h) {
  if (mapping == 1) return std::sin(kPi * (double(y) + 0.5) / double(h));
  if (mapping == 2) {
    const double a = 2.0 * (double(x) + 0.5) / double(w) - 1.0;
    const double b = 2.0 * (double(y % w) + 0.5) / double(w) - 1.0;
    const double r2 = 1.0 + a * a + b * b;
    return 1.0 / (r2 * std::sqrt(r2));
  }
  return 1.0;
}

// Mean over the sphere of an image infinite light's map of the mean of its clamped rgb: for
// the equal-area square the sum in pbrt-v4 ImageInfiniteLight::Phi divided by the texel
// count; for lat-long and cube maps (data.w, textures-spec 6.8) the texels weighted by their
// relative solid angle (env_texel_weight).
double image_light_average(const gpu::Light& l, const std::vector<gpu::MipLevel>& mips,
                           const std::vector<float>& texels) {
  if (l.data.x >= mips.size()) return 0.0;
  const gpu::MipLevel& m = mips[l.data.x];
  const std::size_t n = std::size_t(m.width) * m.height;
  if (n == 0 || m.channels != 3) return 0.0;
  double sum = 0.0, wsum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const float* t = &texels[m.offset + 3 * i];
    const double w = env_texel_weight(l.data.w, std::uint32_t(i % m.width),
                                      std::uint32_t(i / m.width), m.width, m.height);
    sum += w * ((std::max(0.0, double(t[0])) + std::max(0.0, double(t[1])) +
                 std::max(0.0, double(t[2]))) / 3.0);
    wsum += w;
  }
  return wsum > 0.0 ? sum / wsum : 0.0;
}

// pbrt-v4 PiecewiseConstant1D constructor (util/sampling.h) over [0, 1], in float as pbrt-v4:
// func = |f|, cdf[i] = cdf[i-1] + func[i-1] / n, integral = cdf[n], cdf normalised (uniform
// when the integral is 0).
struct PiecewiseConstant1D {
  std::vector<float> func, cdf;
  float integral = 0.0f;
};
PiecewiseConstant1D piecewise_constant_1d(const float* f, std::size_t n) {
  PiecewiseConstant1D d;
  d.func.resize(n);
  d.cdf.resize(n + 1);
  for (std::size_t i = 0; i < n; ++i) d.func[i] = std::abs(f[i]);
  d.cdf[0] = 0.0f;
  for (std::size_t i = 1; i < n + 1; ++i) d.cdf[i] = d.cdf[i - 1] + d.func[i - 1] * 1.0f / float(n);
  d.integral = d.cdf[n];
  for (std::size_t i = 1; i < n + 1; ++i)
    d.cdf[i] = d.integral == 0.0f ? float(i) / float(n) : d.cdf[i] / d.integral;
  return d;
}

// pbrt-v4 PiecewiseConstant2D constructor over [0, 1]^2 (one conditional per row v of the
// nu x nv function, the marginal over the rows' integrals), appended to tex_data in the
// layout of docs/textures-spec.md section 6; returns its offset.
std::uint32_t append_distribution_2d(const std::vector<float>& f, std::uint32_t nu,
                                     std::uint32_t nv, std::vector<float>& tex_data) {
  std::vector<PiecewiseConstant1D> cond;
  std::vector<float> marginal_func(nv);
  for (std::uint32_t v = 0; v < nv; ++v) {
    cond.push_back(piecewise_constant_1d(&f[std::size_t(v) * nu], nu));
    marginal_func[v] = cond.back().integral;
  }
  const PiecewiseConstant1D marginal = piecewise_constant_1d(marginal_func.data(), nv);
  const auto offset = static_cast<std::uint32_t>(tex_data.size());
  tex_data.insert(tex_data.end(), {float(nu), float(nv), marginal.integral, 0.0f});
  tex_data.insert(tex_data.end(), marginal.func.begin(), marginal.func.end());
  tex_data.insert(tex_data.end(), marginal.cdf.begin(), marginal.cdf.end());
  for (const PiecewiseConstant1D& c : cond) {
    tex_data.insert(tex_data.end(), c.func.begin(), c.func.end());
    tex_data.insert(tex_data.end(), c.cdf.begin(), c.cdf.end());
    tex_data.push_back(c.integral);
  }
  return offset;
}

// Host-side equal-area octahedral map, direction to [0,1]^2 (Clarberg; pbrt-v4
// EqualAreaSphereToSquare with the exact arctangent in place of its polynomial), in double.
glm::dvec2 sphere_to_square_d(glm::dvec3 d) {
  const double x = std::abs(d.x), y = std::abs(d.y), z = std::abs(d.z);
  const double r = std::sqrt(std::max(1.0 - z, 0.0));
  const double a = std::max(x, y);
  const double b = a == 0.0 ? 0.0 : std::min(x, y) / a;
  double phi = std::atan(b) * 2.0 / kPi;
  if (x < y) phi = 1.0 - phi;
  double v = phi * r, u = r - v;
  if (d.z < 0.0) {
    const double t = u;
    u = 1.0 - v;
    v = 1.0 - t;
  }
  u = std::copysign(u, d.x);
  v = std::copysign(v, d.y);
  return {0.5 * (u + 1.0), 0.5 * (v + 1.0)};
}

// pbrt-v4 Image::BilerpChannel with WrapMode::OctahedralSphere (RemapPixelCoords) of an
// n x n rgb image at st, channel c.
double bilerp_octahedral(const std::vector<float>& rgb, int n, glm::dvec2 st, int c) {
  const double x = st.x * n - 0.5, y = st.y * n - 0.5;
  const int xi = int(std::floor(x)), yi = int(std::floor(y));
  const double dx = x - xi, dy = y - yi;
  auto texel = [&](int px, int py) {
    if (px < 0) {
      px = -px;
      py = n - 1 - py;
    } else if (px >= n) {
      px = 2 * n - 1 - px;
      py = n - 1 - py;
    }
    if (py < 0) {
      px = n - 1 - px;
      py = -py;
    } else if (py >= n) {
      px = n - 1 - px;
      py = 2 * n - 1 - py;
    }
    if (n == 1) px = py = 0;
    px = std::clamp(px, 0, n - 1);
    py = std::clamp(py, 0, n - 1);
    return double(rgb[3 * (std::size_t(py) * n + px) + c]);
  };
  return (1 - dx) * (1 - dy) * texel(xi, yi) + dx * (1 - dy) * texel(xi + 1, yi) +
         (1 - dx) * dy * texel(xi, yi + 1) + dx * dy * texel(xi + 1, yi + 1);
}

// A portal light's tables (docs/textures-spec.md 6.9; pbrt-v4 PortalImageInfiniteLight
// constructor): the map rectified into the portal's (alpha, beta) image (data.x), the
// windowed distribution (func = mean rgb times duv_dw, its summed-area table; data.y =
// data.z), mapping 3 (data.w), the portal frame (light_from_world), p0 and p2 (pos, dir),
// and in params.x the area times the mean of mean(max(rgb, 0)) / duv_dw (pbrt-v4 Phi).
void portal_light_tables(const Light& sl, gpu::Light& l, SceneTables& t) {
  const int n = sl.image_res;
  if (n < 1 || sl.image_width != n || sl.image_height != n ||
      sl.image_rgb.size() != std::size_t(n) * n * 3)
    throw SceneError(sl.loc, "portal infinite light has no square image");
  const glm::vec3* q = sl.portal;
  const glm::vec3 fx = glm::normalize(q[3] - q[0]), fy = glm::normalize(q[1] - q[0]);
  const glm::vec3 fz = glm::cross(fx, fy);
  if (!all_finite(fx) || !all_finite(fy) || !(glm::dot(fz, fz) > 0.0f))
    throw SceneError(sl.loc, "infinite light portal is degenerate");
  const glm::dmat3 light_from_world(sl.light_from_world);
  // pbrt-v4 RenderFromImage: (alpha, beta) = -pi/2 + uv pi, v = normalize(tan alpha,
  // tan beta, 1), duv_dw = pi^2 (1 - v.x^2) (1 - v.y^2) / v.z, world = frame of v.
  auto image_to_world = [&](double u, double v, double& duv_dw) {
    const glm::dvec3 w =
        glm::normalize(glm::dvec3(std::tan(-kPi / 2 + u * kPi), std::tan(-kPi / 2 + v * kPi), 1.0));
    duv_dw = kPi * kPi * (1 - w.x * w.x) * (1 - w.y * w.y) / w.z;
    return glm::dvec3(fx) * w.x + glm::dvec3(fy) * w.y + glm::dvec3(fz) * w.z;
  };
  const std::size_t cells = std::size_t(n) * n;
  std::vector<float> rect(3 * cells), func(cells);
  double phi_sum = 0.0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      double duv_dw = 0.0;
      const glm::dvec3 w = image_to_world((x + 0.5) / n, (y + 0.5) / n, duv_dw);
      const glm::dvec2 st = sphere_to_square_d(glm::normalize(light_from_world * w));
      const std::size_t i = std::size_t(y) * n + x;
      double mean = 0.0, clamped = 0.0;
      for (int c = 0; c < 3; ++c) {
        const float v = static_cast<float>(bilerp_octahedral(sl.image_rgb, n, st, c));
        rect[3 * i + c] = v;
        mean += v;
        clamped += std::max(0.0f, v);
      }
      func[i] = static_cast<float>(mean / 3.0 * duv_dw);
      if (duv_dw > 0.0) phi_sum += clamped / 3.0 / duv_dw;
    }
  gpu::MipLevel level{};
  level.offset = static_cast<std::uint32_t>(t.texels.size());
  level.width = level.height = static_cast<std::uint32_t>(n);
  level.channels = 3;
  l.data.x = static_cast<std::uint32_t>(t.mip_levels.size());
  t.mip_levels.push_back(level);
  t.texels.insert(t.texels.end(), rect.begin(), rect.end());
  // pbrt-v4 SummedAreaTable: accumulated in double, read back as float.
  std::vector<double> sat(cells);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const std::size_t i = std::size_t(y) * n + x;
      double v = func[i];
      if (x > 0) v += sat[i - 1];
      if (y > 0) v += sat[i - n];
      if (x > 0 && y > 0) v -= sat[i - n - 1];
      sat[i] = v;
    }
  const auto offset = static_cast<std::uint32_t>(t.tex_data.size());
  t.tex_data.insert(t.tex_data.end(), {float(n), float(n), 0.0f, 0.0f});
  t.tex_data.insert(t.tex_data.end(), func.begin(), func.end());
  for (double v : sat) t.tex_data.push_back(static_cast<float>(v));
  l.data.y = l.data.z = offset;
  l.data.w = 3;
  l.light_from_world = glm::mat4(glm::transpose(glm::mat3(fx, fy, fz)));
  l.pos = glm::vec4(q[0], 1.0f);
  l.dir = glm::vec4(q[2], 0.0f);
  const double area = double(glm::length(q[1] - q[0])) * double(glm::length(q[3] - q[0]));
  l.params = glm::vec4(static_cast<float>(area * phi_sum / double(cells)), 0.0f, 0.0f, 0.0f);
}

// An image infinite light's tables (docs/textures-spec.md section 6; pbrt-v4
// ImageInfiniteLight constructor): the map as one MipLevel (data.x), pbrt-v4's sampling
// distribution (Image::GetSamplingDistribution: the channel average of each texel; data.y)
// and the MIS-compensated one (minus the average, clamped at 0, all ones if nothing is left;
// data.z), for lat-long and cube maps times the cells' solid-angle weights (6.8: sin theta of
// half-texel cells or 1 / r^3 of texels, in double, rounded to float); the mapping (data.w);
// the light's frame.
void image_light_tables(const Light& sl, gpu::Light& l, SceneTables& t) {
  if (sl.has_portal) return portal_light_tables(sl, l, t);
  const std::uint32_t mapping = static_cast<std::uint32_t>(sl.mapping);
  const auto w = static_cast<std::uint32_t>(sl.image_width > 0 ? sl.image_width : sl.image_res);
  const auto h = static_cast<std::uint32_t>(sl.image_height > 0 ? sl.image_height : sl.image_res);
  if (w == 0 || h == 0 || mapping > 2 || sl.image_rgb.size() != std::size_t(w) * h * 3 ||
      (mapping == 0 && w != h) || (mapping == 2 && h != 6 * w))
    throw SceneError(sl.loc, "image infinite light has no image");
  gpu::MipLevel level{};
  level.offset = static_cast<std::uint32_t>(t.texels.size());
  level.width = w;
  level.height = h;
  level.channels = 3;
  l.data = glm::uvec4(0u);
  l.data.x = static_cast<std::uint32_t>(t.mip_levels.size());
  l.data.w = mapping;
  t.mip_levels.push_back(level);
  t.texels.insert(t.texels.end(), sl.image_rgb.begin(), sl.image_rgb.end());
  const std::size_t n = std::size_t(w) * h;
  std::vector<float> texel_f(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float* c = &sl.image_rgb[3 * i];
    texel_f[i] = (c[0] + c[1] + c[2]) / 3.0f;  // pbrt-v4 ImageChannelValues::Average
  }
  // The distributions' grid (nu x nv cells) and f on it: the texels themselves, except for
  // lat-long maps (textures-spec 6.8), whose bilinear Le reaches half a texel beyond each
  // texel: half-texel cells (2w x 2h, as pbrt-v3's distribution) each with the largest f of
  // the 2 x 2 texels its bilinear lookup reads (repeat wrap), so that no cell where Le is
  // bright has a small pdf.
  const std::uint32_t nu = mapping == 1 ? 2 * w : w, nv = mapping == 1 ? 2 * h : h;
  const std::size_t cells = std::size_t(nu) * nv;
  std::vector<float> d(cells), weight(cells, 1.0f);
  for (std::uint32_t j = 0; j < nv; ++j)
    for (std::uint32_t i = 0; i < nu; ++i) {
      const std::size_t c = std::size_t(j) * nu + i;
      if (mapping == 1) {
        const std::uint32_t x0 = (i + 2 * w - 1) / 2 % w, x1 = (x0 + 1) % w;
        const std::uint32_t y0 = (j + 2 * h - 1) / 2 % h, y1 = (y0 + 1) % h;
        d[c] = std::max(std::max(texel_f[std::size_t(y0) * w + x0], texel_f[std::size_t(y0) * w + x1]),
                        std::max(texel_f[std::size_t(y1) * w + x0], texel_f[std::size_t(y1) * w + x1]));
        weight[c] = static_cast<float>(std::sin(kPi * (double(j) + 0.5) / double(nv)));
      } else {
        d[c] = texel_f[c];
        if (mapping == 2) weight[c] = static_cast<float>(env_texel_weight(mapping, i, j, w, h));
      }
    }
  std::vector<float> f(cells);
  for (std::size_t i = 0; i < cells; ++i) f[i] = mapping == 0 ? d[i] : d[i] * weight[i];
  l.data.y = append_distribution_2d(f, nu, nv, t.tex_data);
  double average = 0.0;  // pbrt-v4 accumulates in double
  for (float v : d) average += v;
  average /= double(cells);
  bool all_zero = true;
  for (float& v : d) {
    v = static_cast<float>(std::max(double(v) - average, 0.0));
    all_zero = all_zero && v == 0.0f;
  }
  if (all_zero) std::fill(d.begin(), d.end(), 1.0f);
  for (std::size_t i = 0; i < cells; ++i) f[i] = mapping == 0 ? d[i] : d[i] * weight[i];
  l.data.z = append_distribution_2d(f, nu, nv, t.tex_data);
  l.light_from_world = glm::mat4(sl.light_from_world);
}

// Light power for the selection pmf (docs/path-spec.md section 6; pbrt-v4 Light::Phi), with
// the mean of rgb as the scalar; R is the scene bounding-sphere radius; an image infinite
// light's image is read from mips / texels.
double light_power(const gpu::Light& l, const std::vector<gpu::Sphere>& spheres, double R,
                   const std::vector<gpu::MipLevel>& mips, const std::vector<float>& texels) {
  const double L = (static_cast<double>(l.L.x) + l.L.y + l.L.z) / 3.0;
  const double sides = (l.flags & gpu::LIGHT_FLAG_TWOSIDED) ? 2.0 : 1.0;
  double p = 0.0;
  switch (l.type) {
    case gpu::LIGHT_POINT: p = 4.0 * kPi * L; break;
    case gpu::LIGHT_SPOT:
      p = 2.0 * kPi * L * (1.0 - (static_cast<double>(l.params.x) + l.params.y) / 2.0);
      break;
    case gpu::LIGHT_DISTANT: p = kPi * R * R * L; break;
    case gpu::LIGHT_INFINITE_UNIFORM: p = 4.0 * kPi * kPi * R * R * L; break;
    case gpu::LIGHT_INFINITE_IMAGE:  // L is the scale; the image average as pbrt-v4 Phi
      // (a portal's area-weighted average is in params.x, textures-spec 6.9).
      p = l.data.w == 3 ? L * l.params.x
                        : 4.0 * kPi * kPi * R * R * L * image_light_average(l, mips, texels);
      break;
    case gpu::LIGHT_AREA_TRIANGLE: p = kPi * L * l.params.x * sides; break;
    case gpu::LIGHT_AREA_SPHERE: {
      double r = spheres[l.prim].center_radius.w;
      p = kPi * L * 4.0 * kPi * r * r * sides;
      break;
    }
    default: break;
  }
  return p > 0.0 ? p : 0.0;  // negative emission or NaN: never picked (unless all are 0)
}

/// The importance bounds of light l (docs/path-spec.md 6.1; pbrt-v4 PointLight, SpotLight and
/// DiffuseAreaLight::Bounds, with max(r, g, b) for pbrt-v4's Spectrum::MaxValue): bound_c,
/// bound_w and bound_e; phi = 0 for lights of infinite extent and for those without power.
void set_light_bounds(gpu::Light& l, const SceneTables& t) {
  const double emit = std::max({double(l.L.x), double(l.L.y), double(l.L.z)});
  glm::vec3 lo(0.0f), hi(0.0f), w(0.0f, 0.0f, 1.0f);
  double phi = 0.0;
  float cos_o = -1.0f, cos_e = 0.0f;  // a point light: every direction, out to 90 degrees
  switch (l.type) {
    case gpu::LIGHT_POINT:
      lo = hi = glm::vec3(l.pos);
      phi = 4.0 * kPi * emit;
      break;
    case gpu::LIGHT_SPOT: {
      lo = hi = glm::vec3(l.pos);
      w = glm::vec3(l.dir);
      phi = 4.0 * kPi * emit;
      const double cos_start = l.params.x, cos_end = l.params.y;
      cos_o = l.params.x;
      cos_e = float(std::cos(std::acos(std::clamp(cos_end, -1.0, 1.0)) -
                             std::acos(std::clamp(cos_start, -1.0, 1.0))));
      // pbrt-v4's slop for the importance's round-off where the falloff is a step.
      if (cos_e == 1.0f && cos_end != cos_start) cos_e = 0.999f;
      break;
    }
    case gpu::LIGHT_AREA_TRIANGLE: {
      const gpu::Triangle& tri = t.triangles[l.prim];
      const gpu::Mesh& mesh = t.meshes[tri.mesh];
      const glm::vec3 p0(t.vertices[tri.v0].p_u), p1(t.vertices[tri.v1].p_u),
          p2(t.vertices[tri.v2].p_u);
      lo = glm::min(p0, glm::min(p1, p2));
      hi = glm::max(p0, glm::max(p1, p2));
      phi = kPi * emit * double(l.params.x);  // pi L A, not doubled when two-sided (pbrt-v4)
      // The emitting side: the triangle's geometric normal as path-spec 4 orients it.
      const glm::vec3 cr = glm::cross(p0 - p2, p1 - p2);
      const float len = glm::length(cr);
      w = len > 0.0f ? cr / len : glm::vec3(0.0f, 0.0f, 1.0f);
      cos_o = 1.0f;
      if (mesh.flags & gpu::SHAPE_FLAG_HAS_NORMALS) {
        // Face-forwarded to the vertex normals at each hit: to their sum here (pbrt-v4
        // Triangle::NormalBounds), and every direction when they disagree in side, where the
        // emitting side changes across the triangle.
        const glm::vec3 n0(t.vertices[tri.v0].n_v), n1(t.vertices[tri.v1].n_v),
            n2(t.vertices[tri.v2].n_v);
        if (glm::dot(w, n0 + n1 + n2) < 0.0f) w = -w;
        if (glm::dot(w, n0) < 0.0f || glm::dot(w, n1) < 0.0f || glm::dot(w, n2) < 0.0f)
          cos_o = -1.0f;
      } else if (mesh.flags & gpu::SHAPE_FLAG_FLIP_NORMAL) {
        w = -w;
      }
      break;
    }
    case gpu::LIGHT_AREA_SPHERE: {
      const glm::vec4 cr = t.spheres[l.prim].center_radius;
      lo = glm::vec3(cr) - glm::vec3(cr.w);
      hi = glm::vec3(cr) + glm::vec3(cr.w);
      phi = kPi * emit * 4.0 * kPi * double(cr.w) * cr.w;  // normals: the whole sphere
      break;
    }
    default:  // distant and infinite: picked by their share of the cdf, not by importance
      break;
  }
  if (!(phi > 0.0) || !std::isfinite(phi) || !all_finite(lo) || !all_finite(hi)) phi = 0.0;
  l.bound_c = glm::vec4(0.5f * (lo + hi), float(std::min(phi, double(FLT_MAX))));
  l.bound_w = glm::vec4(w, cos_o);
  l.bound_e = glm::vec4(0.5f * glm::length(hi - lo), cos_e, 0.0f, 0.0f);
}

gpu::Light area_light(std::uint32_t type, std::uint32_t prim, const AreaLight& a) {
  gpu::Light l{};
  l.type = type;
  l.prim = prim;
  l.flags = a.twosided ? gpu::LIGHT_FLAG_TWOSIDED : 0u;
  l.L = glm::vec4(a.L, 0.0f);
  return l;
}

// Checks that the 3x3 part of a sphere's transform is s * orthonormal (a similarity, mirror
// allowed) and returns s and the unit axes.
struct Similarity {
  float scale;
  glm::vec3 axis[3];
};
Similarity similarity_of(const Shape& shape) {
  glm::mat4 m = shape.world_from_object;
  if (m[0][3] != 0.0f || m[1][3] != 0.0f || m[2][3] != 0.0f || m[3][3] == 0.0f)
    throw SceneError(shape.loc, "projective transform on a sphere is not supported");
  m /= m[3][3];
  glm::vec3 c[3] = {glm::vec3(m[0]), glm::vec3(m[1]), glm::vec3(m[2])};
  float len[3] = {glm::length(c[0]), glm::length(c[1]), glm::length(c[2])};
  float s = (len[0] + len[1] + len[2]) / 3.0f;
  bool ok = s > 0.0f && std::isfinite(s) && all_finite(glm::vec3(m[3]));
  for (int i = 0; ok && i < 3; ++i) {
    ok = std::abs(len[i] - s) <= kSimilarityTolerance * s &&
         std::abs(glm::dot(c[i], c[(i + 1) % 3])) <= kSimilarityTolerance * s * s;
  }
  if (!ok) throw SceneError(shape.loc, "non-uniform scale on a sphere is not supported");
  Similarity out{s, {c[0] / len[0], c[1] / len[1], c[2] / len[2]}};
  return out;
}

void check_emission(const glm::vec3& L, const SourceLoc& loc) {
  if (!all_finite(L)) throw SceneError(loc, "light emission is not finite");
}

/// build_tables, freeing each shape's parsed mesh in \p release (the scene itself, or null)
/// once its vertices and triangles are in the tables.
SceneTables build_tables_impl(const Scene& scene, Scene* release, BuildTimes* times,
                              std::vector<std::string>* warnings, bool cpu_tree) {
  SceneTables t;
  gpu::Globals& g = t.globals;

  if (scene.film.xres <= 0 || scene.film.yres <= 0)
    throw SceneError(scene.film.loc, "image resolution must be positive");

  // ---- materials -------------------------------------------------------------------------
  // docs/materials-spec.md section 3 slots; mixes as Scene::mix_mode says; measured tables
  // appended to t.measured.
  TextureProgramBuilder texture_programs(scene, &t.textures);
  texture_programs.set_image_tables(&t.mip_levels, &t.texels);  // imagemap pyramids
  t.materials =
      convert_materials(scene, scene.mix_mode, &t.measured, warnings, &texture_programs);
  // A slot whose texture program is one constant instruction holds that value instead: the
  // same result (docs/textures-spec.md 2) without texture code (a scene whose textures are all
  // constants needs no texture pipeline).
  for (gpu::Material& m : t.materials)
    for (std::uint32_t slot = 0; slot < gpu::MATERIAL_SLOTS; ++slot) {
      std::uint32_t& root = m.texture[slot / 4][slot % 4];
      if (root != INVALID_INDEX && t.textures[root].type == gpu::TEXTURE_CONSTANT &&
          t.textures[root].first == root) {
        m.value[slot] = glm::vec4(glm::vec3(t.textures[root].param[0]), 0.0f);
        root = INVALID_INDEX;
      }
    }
  std::uint32_t default_material = INVALID_INDEX;  // diffuse 0.5, appended on first use
  auto material_of = [&](const Shape& s) -> std::uint32_t {
    if (s.material < 0) {
      if (default_material == INVALID_INDEX) {
        default_material = static_cast<std::uint32_t>(t.materials.size());
        t.materials.push_back(diffuse_material(glm::vec3(0.5f)));
      }
      return default_material;
    }
    if (static_cast<std::size_t>(s.material) >= scene.materials.size())
      throw SceneError(s.loc, "shape refers to an unknown material");
    return static_cast<std::uint32_t>(s.material);
  };

  // ---- non-area lights (first in the light table; area lights follow in shape order) ------
  g.infinite_lights = glm::uvec4(INVALID_INDEX);
  std::uint32_t infinite_count = 0;
  for (const Light& sl : scene.lights) {
    check_emission(sl.value, sl.loc);
    gpu::Light l{};
    l.L = glm::vec4(sl.value, 0.0f);
    const auto index = static_cast<std::uint32_t>(t.lights.size());
    switch (sl.kind) {
      case Light::Kind::Point:
        l.type = gpu::LIGHT_POINT;
        l.pos = glm::vec4(sl.from, 1.0f);
        t.features |= gpu::FEATURE_LIGHT_POINT;
        break;
      case Light::Kind::Spot: {
        l.type = gpu::LIGHT_SPOT;
        l.pos = glm::vec4(sl.from, 1.0f);
        glm::vec3 axis = glm::normalize(sl.dir);
        if (!all_finite(axis)) throw SceneError(sl.loc, "spot light has no direction");
        l.dir = glm::vec4(axis, 0.0f);
        // pbrt-v4 SpotLight: cosFalloffStart = cos(coneangle - conedelta), cosFalloffEnd =
        // cos(coneangle).
        l.params = glm::vec4(
            static_cast<float>(std::cos((sl.cone_angle - sl.cone_delta) * kPi / 180.0)),
            static_cast<float>(std::cos(sl.cone_angle * kPi / 180.0)), 0.0f, 0.0f);
        t.features |= gpu::FEATURE_LIGHT_SPOT;
        break;
      }
      case Light::Kind::Distant: {
        l.type = gpu::LIGHT_DISTANT;
        glm::vec3 w = glm::normalize(sl.dir);
        if (!all_finite(w)) throw SceneError(sl.loc, "distant light has no direction");
        l.dir = glm::vec4(w, 0.0f);
        t.features |= gpu::FEATURE_LIGHT_DISTANT;
        break;
      }
      case Light::Kind::Infinite:
      case Light::Kind::InfiniteImage:
        l.type = sl.kind == Light::Kind::Infinite ? gpu::LIGHT_INFINITE_UNIFORM
                                                  : gpu::LIGHT_INFINITE_IMAGE;
        if (infinite_count == gpu::MAX_INFINITE_LIGHTS)
          throw SceneError(sl.loc, "more than " + std::to_string(gpu::MAX_INFINITE_LIGHTS) +
                                       " infinite lights are not supported");
        g.infinite_lights[infinite_count++] = index;
        // FEATURE_LIGHT_INFINITE: some infinite light (escaped rays look them up);
        // FEATURE_LIGHT_INFINITE_IMAGE: one of them is an environment map.
        t.features |= gpu::FEATURE_LIGHT_INFINITE;
        if (sl.kind == Light::Kind::InfiniteImage) {
          t.features |= gpu::FEATURE_LIGHT_INFINITE_IMAGE;
          if (sl.has_portal) t.features2 |= gpu::FEATURE2_ENV_PORTAL;
          image_light_tables(sl, l, t);
        }
        break;
    }
    t.lights.push_back(l);
  }

  // ---- shapes: triangles and spheres in world space, area lights --------------------------
  std::vector<Aabb> tri_bounds, sphere_bounds;
  {
    // Sized once from the parsed meshes (displaced ones grow later): no regrowth copies at the
    // peak of memory (a doubling vector holds both copies while it moves).
    std::size_t vertices = 0, triangles = 0;
    for (const Shape& shape : scene.shapes) {
      vertices += shape.mesh.P.size();
      triangles += shape.mesh.indices.size() / 3;
    }
    t.vertices.reserve(vertices);
    t.triangles.reserve(triangles);
    tri_bounds.reserve(triangles);
  }
  std::unique_ptr<DisplacementTextures> displacement_textures;  // made on first use
  for (const Shape& shape : scene.shapes) {
    const std::uint32_t material = material_of(shape);
    const bool emissive = shape.area_light.has_value();
    if (emissive) check_emission(shape.area_light->L, shape.loc);

    if (shape.kind == Shape::Kind::Sphere) {
      if (!(shape.radius > 0.0f) || !std::isfinite(shape.radius))
        throw SceneError(shape.loc, "sphere radius must be positive and finite");
      Similarity sim = similarity_of(shape);
      const glm::vec3 center = transform_point(shape.world_from_object, glm::vec3(0.0f));
      const float radius = shape.radius * sim.scale;
      if (!std::isfinite(radius) || !(radius > 0.0f))
        throw SceneError(shape.loc, "sphere radius must be positive and finite");
      gpu::Sphere s{};
      s.center_radius = glm::vec4(center, radius);
      s.axis_x = glm::vec4(sim.axis[0], sim.scale);  // w: the scale (textures-spec 3.2)
      s.axis_y = glm::vec4(sim.axis[1], 0.0f);
      s.axis_z = glm::vec4(sim.axis[2], 0.0f);
      s.material = material;
      // pbrt-v4 spheres flip for ReverseOrientation only (the handedness flip of the
      // transform cancels against the object-space normal's, see layout.h).
      s.flags = shape.reverse_orientation ? gpu::SHAPE_FLAG_FLIP_NORMAL : 0u;
      s.light = INVALID_INDEX;
      const auto sphere_index = static_cast<std::uint32_t>(t.spheres.size());
      if (emissive) {
        s.light = static_cast<std::uint32_t>(t.lights.size());
        t.lights.push_back(area_light(gpu::LIGHT_AREA_SPHERE, sphere_index, *shape.area_light));
      }
      t.spheres.push_back(s);
      // Pad by a few ulps of the coordinates: centre +- r is rounded and the intersection
      // re-projects hits onto the sphere, which may land just outside a tight box.
      const float pad = (std::max({std::abs(center.x), std::abs(center.y), std::abs(center.z)}) +
                         radius) * 0x1p-20f;
      Aabb box;
      box.lo = center - glm::vec3(radius + pad);
      box.hi = center + glm::vec3(radius + pad);
      sphere_bounds.push_back(box);
      continue;
    }

    // Triangle mesh (pbrt-v4 TriangleMesh: positions and normals transformed to world space,
    // normals negated for ReverseOrientation).
    // A plymesh with a "displacement" texture is refined and displaced first (pbrt-v4
    // Shape::Create "plymesh"; host/scene/displace.h), in object space.
    TriangleMesh displaced;
    if (!shape.displacement.empty()) {
      if (!displacement_textures)
        displacement_textures = std::make_unique<DisplacementTextures>(scene);
      displaced = displaced_shape_mesh(scene, shape, *displacement_textures);
    }
    const TriangleMesh& tm = shape.displacement.empty() ? shape.mesh : displaced;
    if (tm.indices.size() % 3 != 0)
      throw SceneError(shape.loc, "triangle indices are not a multiple of 3");
    if (!tm.N.empty() && tm.N.size() != tm.P.size())
      throw SceneError(shape.loc, "number of normals differs from the number of positions");
    if (!tm.uv.empty() && tm.uv.size() != tm.P.size())
      throw SceneError(shape.loc, "number of uvs differs from the number of positions");
    for (unsigned i : tm.indices)
      if (i >= tm.P.size()) throw SceneError(shape.loc, "vertex index out of range");
    if (t.vertices.size() + tm.P.size() >= INVALID_INDEX)
      throw SceneError(shape.loc, "too many vertices");
    // The renderer's table limit (Scene::max_table_bytes), checked before the BVH is built
    // (issue 11, defect 10): vertices now, triangles (at most a third of the indices) too.
    if ((t.vertices.size() + tm.P.size()) * sizeof(gpu::Vertex) > scene.max_table_bytes ||
        (t.triangles.size() + tm.indices.size() / 3) * sizeof(gpu::Triangle) >
            scene.max_table_bytes)
      throw SceneError(shape.loc, "the scene's vertex or triangle table would need more than the " +
                                      std::to_string(scene.max_table_bytes) +
                                      " bytes the renderer takes");

    const glm::mat4& m = shape.world_from_object;
    const glm::mat3 linear(m);
    const glm::mat3 normal_from_object = glm::transpose(glm::inverse(linear));
    const auto vbase = static_cast<std::uint32_t>(t.vertices.size());
    for (std::size_t v = 0; v < tm.P.size(); ++v) {
      gpu::Vertex out{};
      glm::vec3 p = transform_point(m, tm.P[v]);
      glm::vec3 n(0.0f);
      if (!tm.N.empty()) {
        n = glm::normalize(normal_from_object * tm.N[v]);
        if (shape.reverse_orientation) n = -n;
        if (!all_finite(n)) n = glm::vec3(0.0f);  // zero normal: the shader falls back to ng
      }
      glm::vec2 uv = tm.uv.empty() ? glm::vec2(0.0f) : tm.uv[v];
      out.p_u = glm::vec4(p, uv.x);
      out.n_v = glm::vec4(n, uv.y);
      t.vertices.push_back(out);
    }

    gpu::Mesh mesh{};
    mesh.material = material;
    mesh.tri_base = static_cast<std::uint32_t>(t.triangles.size());
    mesh.light_base = INVALID_INDEX;
    const bool swaps_handedness = glm::determinant(linear) < 0.0f;
    mesh.flags = (shape.reverse_orientation != swaps_handedness) ? gpu::SHAPE_FLAG_FLIP_NORMAL : 0u;
    if (!tm.N.empty()) mesh.flags |= gpu::SHAPE_FLAG_HAS_NORMALS;
    if (!tm.uv.empty()) mesh.flags |= gpu::SHAPE_FLAG_HAS_UV;
    const auto mesh_index = static_cast<std::uint32_t>(t.meshes.size());

    std::size_t dropped = 0;
    for (std::size_t k = 0; k < tm.indices.size(); k += 3) {
      const std::uint32_t i0 = vbase + tm.indices[k], i1 = vbase + tm.indices[k + 1],
                          i2 = vbase + tm.indices[k + 2];
      const glm::vec3 p0(t.vertices[i0].p_u), p1(t.vertices[i1].p_u), p2(t.vertices[i2].p_u);
      // Degenerate: the intersection test (docs/path-spec.md section 3) misses triangles whose
      // cross(p0 - p2, p1 - p2) is zero, and the shading normal normalises it; drop those
      // (and any whose float length underflows or overflows) from every table.
      const glm::vec3 cr = glm::cross(p0 - p2, p1 - p2);
      const float len = glm::length(cr);
      if (!all_finite(p0) || !all_finite(p1) || !all_finite(p2) || !(len > 0.0f) ||
          !std::isfinite(len)) {
        ++dropped;
        continue;
      }
      if (t.triangles.size() >= gpu::PRIM_INDEX_MASK)
        throw SceneError(shape.loc, "too many triangles");
      const auto tri_index = static_cast<std::uint32_t>(t.triangles.size());
      t.triangles.push_back({i0, i1, i2, mesh_index});
      if (emissive) {
        if (mesh.light_base == INVALID_INDEX)
          mesh.light_base = static_cast<std::uint32_t>(t.lights.size());
        gpu::Light l = area_light(gpu::LIGHT_AREA_TRIANGLE, tri_index, *shape.area_light);
        // World area, from the double-precision cross product.
        const glm::dvec3 e0 = glm::dvec3(p0) - glm::dvec3(p2), e1 = glm::dvec3(p1) - glm::dvec3(p2);
        l.params = glm::vec4(static_cast<float>(0.5 * glm::length(glm::cross(e0, e1))), 0, 0, 0);
        t.lights.push_back(l);
      }
      Aabb box;
      box.extend(p0);
      box.extend(p1);
      box.extend(p2);
      tri_bounds.push_back(box);
    }
    if (dropped > 0 && warnings) {
      warnings->push_back(warning_at(
          shape.loc, "dropped " + std::to_string(dropped) + " degenerate triangle" +
                         (dropped == 1 ? "" : "s") + " (zero area or non-finite vertices)"));
    }
    if (!tm.N.empty()) t.features |= gpu::FEATURE_SHADING_NORMALS;
    t.meshes.push_back(mesh);
    if (release) release->shapes[std::size_t(&shape - scene.shapes.data())].mesh = TriangleMesh{};
  }

  // ---- scene bounds: bounding sphere of all kept geometry ---------------------------------
  Aabb world;
  for (const Aabb& b : tri_bounds) world.extend(b);
  for (const Aabb& b : sphere_bounds) world.extend(b);
  if (world.empty()) {
    g.scene_sphere = glm::vec4(glm::vec3(scene.camera.world_from_camera[3]), 1.0f);
  } else {
    g.scene_sphere = glm::vec4(world.center(), 0.5f * glm::length(world.hi - world.lo));
  }

  // ---- light selection (path-spec section 6) ---------------------------------------------
  apply_light_sampler(t, scene.integrator.light_sampler);

  // ---- BVH over triangles then spheres ---------------------------------------------------
  {
    // The triangles' boxes become the list (moved, not copied: a copy was 6.4 MB more at the
    // peak of the CPU reference's memory on Igea), the spheres' are appended.
    const auto tri_count = static_cast<std::uint32_t>(tri_bounds.size());
    std::vector<Aabb> bounds = std::move(tri_bounds);
    bounds.insert(bounds.end(), sphere_bounds.begin(), sphere_bounds.end());
    std::vector<Aabb>().swap(sphere_bounds);
    const auto start = std::chrono::steady_clock::now();
    BvhOptions bvh_options;
    bvh_options.bins = scene.bvh_bins;
    bvh_options.max_leaf = scene.bvh_max_leaf;
    Bvh bvh = build_bvh(std::move(bounds), bvh_options);
    t.nodes = std::move(bvh.nodes);
    t.prim_refs.resize(bvh.prim_order.size());
    for (std::size_t i = 0; i < t.prim_refs.size(); ++i) {
      const std::uint32_t p = bvh.prim_order[i];
      t.prim_refs[i] = p < tri_count ? p : (p - tri_count) | gpu::PRIM_SPHERE_BIT;
    }
    if (cpu_tree && !t.nodes.empty()) t.cpu_wide = cpu::build_cpu_wide_bvh(t);
    const auto stop = std::chrono::steady_clock::now();
    if (times) times->seconds_bvh = std::chrono::duration<double>(stop - start).count();
  }

  // ---- filter ----------------------------------------------------------------------------
  std::uint32_t filter_type = gpu::FILTER_BOX, filter_n = 0;
  if (scene.filter.type == Filter::Type::Gaussian) {
    filter_type = gpu::FILTER_GAUSSIAN;
    filter_n = kFilterBins;
    t.filter_cdf = gaussian_cdf(scene.filter.radius.x, scene.filter.sigma);
    std::vector<float> y = gaussian_cdf(scene.filter.radius.y, scene.filter.sigma);
    t.filter_cdf.insert(t.filter_cdf.end(), y.begin(), y.end());
    t.features |= gpu::FEATURE_FILTER_GAUSSIAN;
  }

  // ---- globals ---------------------------------------------------------------------------
  const Camera& cam = scene.camera;
  g.world_from_camera = cam.world_from_camera;
  g.screen = screen_window(scene);
  g.lens = glm::vec4(static_cast<float>(std::tan(cam.fov_deg * kPi / 180.0 / 2.0)),
                     cam.lens_radius, cam.focal_distance, 0.0f);
  g.filter_radius = glm::vec4(scene.filter.radius, 0.0f, 0.0f);
  g.image = glm::uvec4(static_cast<std::uint32_t>(scene.film.xres),
                       static_cast<std::uint32_t>(scene.film.yres),
                       static_cast<std::uint32_t>(std::max(0, scene.integrator.max_depth)),
                       static_cast<std::uint32_t>(scene.sampler.seed));
  g.counts = glm::uvec4(static_cast<std::uint32_t>(t.lights.size()), infinite_count, filter_type,
                        filter_n);

  if (!t.triangles.empty()) t.features |= gpu::FEATURE_TRIANGLES;
  if (!t.spheres.empty()) t.features |= gpu::FEATURE_SPHERES;
  if (t.lights.size() > scene.lights.size()) t.features |= gpu::FEATURE_LIGHT_AREA;
  // Material and texture features from what the shapes reach (a named material no shape
  // uses, and its textures, cost nothing): the shapes' materials and, through mixes, theirs.
  std::vector<std::uint32_t> roots;
  for (const gpu::Mesh& m : t.meshes) roots.push_back(m.material);
  for (const gpu::Sphere& sp : t.spheres) roots.push_back(sp.material);
  const std::vector<bool> reached = materials_reached(t.materials, std::move(roots));
  for (std::size_t mi = 0; mi < t.materials.size(); ++mi) {
    if (!reached[mi]) continue;
    const gpu::Material& m = t.materials[mi];
    // docs/bump-spec.md 1: one shading frame per hit cannot bump a weighted mix's children
    // separately, as pbrt-v3 does.
    if (m.type == gpu::MATERIAL_MIX_WEIGHTED)
      for (std::uint32_t c : {m.aux0, m.aux1})
        if (c < t.materials.size() &&
            (t.materials[c].flags & (gpu::MATFLAG_BUMP | gpu::MATFLAG_NORMALMAP | gpu::MATFLAG_VTURB)) &&
            c < scene.materials.size())
          throw SceneError(scene.materials[c].loc,
                           "a bump or normal map on a child of a pbrt-v3 weighted mix is not "
                           "supported (pbrt-v3 bumps each child in its own frame)");
    t.features |= material_feature(m.type);
    const glm::uvec2 tex = material_texture_features(t, m);
    t.features |= tex.x;
    t.features2 |= tex.y;
  }
  if (cam.lens_radius > 0.0f) t.features |= gpu::FEATURE_THIN_LENS;
  // Noise lookups in split precision by default (docs/textures-spec.md 2.1); --noise-precision
  // fp32 gives pbrt-v4's arithmetic (apply_texture_knobs).
  if (t.features & gpu::FEATURE_TEX_NOISE) t.features2 |= gpu::FEATURE2_NOISE_SPLIT;
  g.features = glm::uvec4(t.features, t.features2, 0u, 0u);

  // ---- textures: shared tables, footprint and options (docs/textures-spec.md) ---------------
  g.tex_tables = texture_shared_tables(t.tex_data);
  const Sampler sampler = resolve_sampler(scene.sampler);
  min_differentials(g, sampler.spp);
  g.camera_from_world = glm::mat4(glm::inverse(glm::dmat4(cam.world_from_camera)));
  g.render_opts = glm::uvec4(0u);  // pbrt-v4's roulette and MIS (path-spec 7.1)
  g.texture_opts = glm::uvec4((scene.disable_texture_filtering ? gpu::TEXOPT_DISABLE_FILTERING : 0u) |
                                  gpu::TEXOPT_NOISE_SPLIT,
                              0u, 0u, 0u);
  sampler_tables(t, sampler);  // docs/sampler-spec.md 3
  return t;
}

}  // namespace

SceneTables build_tables(const Scene& scene, BuildTimes* times,
                         std::vector<std::string>* warnings) {
  return build_tables_impl(scene, nullptr, times, warnings, true);
}

SceneTables build_tables_releasing_meshes(Scene& scene, BuildTimes* times,
                                          std::vector<std::string>* warnings, bool cpu_tree) {
  return build_tables_impl(scene, &scene, times, warnings, cpu_tree);
}


std::vector<std::string> feature_names(std::uint32_t features) {
  static const char* const kNames[gpu::FEATURE_COUNT] = {
      "triangles",
      "spheres",
      "light_point",
      "light_spot",
      "light_distant",
      "light_infinite",
      "light_area",
      "material_diffuse",
      "filter_gaussian",
      "thin_lens",
      "shading_normals",
      "material_oren_nayar",
      "material_conductor",
      "material_dielectric",
      "material_thin_dielectric",
      "material_diffuse_transmission",
      "material_coated_diffuse",
      "material_coated_conductor",
      "material_plastic",
      "material_substrate",
      "material_translucent",
      "material_uber",
      "material_measured",
      "material_mix",
      "material_mix_weighted",
      "material_interface",
      "material_mirror",
      "material_metal",
      "textures",
      "texture_noise",
      "texture_image",
      "light_infinite_image"};
  std::vector<std::string> names;
  for (std::uint32_t bit = 0; bit < gpu::FEATURE_COUNT; ++bit)
    if (features & (1u << bit)) names.emplace_back(kNames[bit]);
  for (std::uint32_t bit = gpu::FEATURE_COUNT; bit < 32; ++bit)
    if (features & (1u << bit)) names.push_back("feature_" + std::to_string(bit));
  return names;
}

std::string apply_light_sampler(SceneTables& t, const std::string& mode) {
  // "bvh" (the default): pbrt-v4's BVHLightSampler top-level split: each light of infinite
  // extent (distant, infinite) with power is picked with probability 1 / (n_inf + 1), the
  // bounded lights share the rest; within that share they are picked by their importance at
  // the shading point (path-spec 6.1) when at most LIGHT_IMPORTANCE_MAX_BVH of them have
  // power, else in proportion to their power (pbrt-v4 Light::Phi). "exhaustive": pbrt-v4's
  // ExhaustiveLightSampler, the same split with importance over any number of bounded lights.
  // "power": pbrt-v4's PowerLightSampler, every light in proportion to its power (infinite
  // lights with their pi R^2-scaled power, which starves small bright lights). "uniform":
  // pbrt-v4's UniformLightSampler.
  const bool split = mode == "bvh" || mode == "exhaustive";
  std::vector<double> power(t.lights.size());
  for (std::size_t i = 0; i < t.lights.size(); ++i)
    power[i] = mode == "uniform" ? 1.0
                                 : light_power(t.lights[i], t.spheres, t.globals.scene_sphere.w,
                                               t.mip_levels, t.texels);
  auto infinite_extent = [](const gpu::Light& l) {
    return l.type == gpu::LIGHT_DISTANT || l.type == gpu::LIGHT_INFINITE_UNIFORM ||
           l.type == gpu::LIGHT_INFINITE_IMAGE;
  };
  double bounded_power = 0.0;
  int n_inf = 0;
  std::uint32_t n_bounded = 0;  // bounded lights with importance bounds (phi > 0)
  for (std::size_t i = 0; i < t.lights.size(); ++i) {
    gpu::Light& l = t.lights[i];
    set_light_bounds(l, t);
    if (infinite_extent(l)) {
      n_inf += power[i] > 0.0;
    } else {
      bounded_power += power[i];
      n_bounded += l.bound_c.w > 0.0f;
    }
  }
  if (split && n_inf > 0) {
    const int shares = n_inf + (bounded_power > 0.0 ? 1 : 0);
    for (std::size_t i = 0; i < t.lights.size(); ++i)
      power[i] = infinite_extent(t.lights[i])
                     ? (power[i] > 0.0 ? 1.0 / shares : 0.0)
                     : (bounded_power > 0.0 ? power[i] / bounded_power / shares : 0.0);
  }
  if (t.lights.empty()) {
    t.light_cdf = {0.0f};
  } else {
    t.light_cdf = cumulative(power);
    // pmf is the float difference of the stored cdf, so both agree bit for bit.
    for (std::size_t i = 0; i < t.lights.size(); ++i)
      t.lights[i].pmf = t.light_cdf[i + 1] - t.light_cdf[i];
  }
  // Importance within the bounded lights' share (path-spec 6.1): their total pmf is the mass
  // that light_pick spreads over them by importance.
  const bool importance =
      bounded_power > 0.0 && n_bounded > 0 &&
      (mode == "exhaustive" || (mode == "bvh" && n_bounded <= gpu::LIGHT_IMPORTANCE_MAX_BVH));
  float mass = 0.0f;
  for (const gpu::Light& l : t.lights)
    if (!infinite_extent(l)) mass += l.pmf;
  t.globals.light_opts =
      importance ? glm::uvec4(gpu::LIGHT_SELECT_IMPORTANCE, std::bit_cast<std::uint32_t>(mass), 0u, 0u)
                 : glm::uvec4(0u);
  t.features2 = importance ? (t.features2 | gpu::FEATURE2_LIGHT_IMPORTANCE)
                           : (t.features2 & ~gpu::FEATURE2_LIGHT_IMPORTANCE);
  t.globals.features.y = t.features2;
  return mode;
}

std::vector<std::pair<std::string, std::string>> apply_layered_knobs(SceneTables& t,
                                                                     int nsamples, int maxdepth,
                                                                     bool pbrt_mis) {
  for (gpu::Material& m : t.materials)
    if (m.type == gpu::MATERIAL_COATED_DIFFUSE || m.type == gpu::MATERIAL_COATED_CONDUCTOR) {
      if (maxdepth > 0) m.aux0 = std::uint32_t(maxdepth);
      if (nsamples > 0) m.aux1 = std::uint32_t(nsamples);
      m.flags = pbrt_mis ? m.flags | gpu::MATFLAG_LAYERED_PBRT_MIS
                         : m.flags & ~gpu::MATFLAG_LAYERED_PBRT_MIS;
    }
  return {{"coated_nsamples", nsamples > 0 ? std::to_string(nsamples) : "scene"},
          {"coated_maxdepth", maxdepth > 0 ? std::to_string(maxdepth) : "scene"},
          {"layered_mis", pbrt_mis ? "pbrt-v4" : "basalt"}};
}

std::vector<std::pair<std::string, std::string>> apply_path_knobs(SceneTables& t, int max_depth,
                                                                  std::uint32_t roulette_start,
                                                                  std::uint32_t mis) {
  static const char* kMis[] = {"power", "balance", "bsdf", "light"};
  if (max_depth >= 0) t.globals.image.z = std::uint32_t(max_depth);
  t.globals.render_opts.x = roulette_start == 1u               ? 0u
                            : roulette_start == gpu::ROULETTE_OFF ? gpu::ROULETTE_OFF
                                                                  : roulette_start + 1u;
  t.globals.render_opts.y = mis <= gpu::MIS_LIGHT_ONLY ? mis : gpu::MIS_POWER;
  std::vector<std::pair<std::string, std::string>> knobs;
  knobs.emplace_back("maxdepth", std::to_string(t.globals.image.z));
  knobs.emplace_back("roulette", roulette_start == gpu::ROULETTE_OFF ? "off"
                                 : roulette_start == 1u            ? "pbrt-v4"
                                                                   : std::to_string(roulette_start));
  knobs.emplace_back("mis", kMis[t.globals.render_opts.y]);
  return knobs;
}

glm::uvec2 material_texture_features(const SceneTables& t, const gpu::Material& m) {
  glm::uvec2 f(0u);
  // docs/bump-spec.md 2: bump and normal maps need the texture context and its footprint.
  if (m.flags & gpu::MATFLAG_NORMALMAP) {
    f.x |= gpu::FEATURE_TEXTURES;
    f.y |= gpu::FEATURE2_NORMALMAP;
  } else if (m.flags & gpu::MATFLAG_BUMP) {
    f.x |= gpu::FEATURE_TEXTURES;
    f.y |= gpu::FEATURE2_BUMP;
  }
  if (m.flags & gpu::MATFLAG_VTURB) {  // bump-spec 9
    f.x |= gpu::FEATURE_TEXTURES;
    f.y |= gpu::FEATURE2_VTURB;
  }
  for (std::uint32_t slot = 0; slot < gpu::MATERIAL_SLOTS; ++slot) {
    const std::uint32_t root = m.texture[slot / 4][slot % 4];
    // (a root past the table reads as no texture, as tex_eval_rgb does)
    if (root == INVALID_INDEX || root >= t.textures.size()) continue;
    for (std::uint32_t i = t.textures[root].first; i <= root; ++i) {
      f.x |= gpu::FEATURE_TEXTURES;
      const std::uint32_t mapping = t.textures[i].flags & gpu::TEXFLAG_MAPPING_MASK;
      if (mapping == gpu::MAPPING_SPHERICAL || mapping == gpu::MAPPING_CYLINDRICAL)
        f.y |= gpu::FEATURE2_TEX_MAP_CURVED;
      switch (t.textures[i].type) {
        case gpu::TEXTURE_FBM:
        case gpu::TEXTURE_WRINKLED:
        case gpu::TEXTURE_WINDY:
        case gpu::TEXTURE_MARBLE:
          f.x |= gpu::FEATURE_TEX_NOISE;
          break;
        case gpu::TEXTURE_DOTS:  // pbrt-v4 places its dots with Perlin noise
          f.x |= gpu::FEATURE_TEX_NOISE;
          f.y |= gpu::FEATURE2_TEX_PROCEDURAL;
          break;
        case gpu::TEXTURE_CHECKERBOARD:
          f.y |= gpu::FEATURE2_TEX_CHECKER_AA;
          break;
        case gpu::TEXTURE_IMAGEMAP:
          f.x |= gpu::FEATURE_TEX_IMAGE;
          if (((t.textures[i].flags & gpu::TEXFLAG_FILTER_MASK) >> gpu::TEXFLAG_FILTER_SHIFT) ==
              gpu::FILTER_EWA)
            f.y |= gpu::FEATURE2_TEX_EWA;
          break;
        case gpu::TEXTURE_CONSTANT:
          break;
        // Shirley's solid textures (docs/textures-spec.md 7); the noise ones also use the
        // noise family's bit (layout.h).
        case gpu::TEXTURE_SHIRLEY_NOISE:
        case gpu::TEXTURE_SHIRLEY_TURBULENCE:
        case gpu::TEXTURE_TURBULENT_STRIPE:
          f.x |= gpu::FEATURE_TEX_NOISE;
          f.y |= gpu::FEATURE2_TEX_SHIRLEY;
          break;
        case gpu::TEXTURE_STRIPE:
        case gpu::TEXTURE_IMAGE_INTERP:
        case gpu::TEXTURE_VOLUME:
          f.y |= gpu::FEATURE2_TEX_SHIRLEY;
          break;
        default:
          f.y |= gpu::FEATURE2_TEX_PROCEDURAL;
          break;
      }
    }
  }
  return f;
}

void release_bulk_tables(SceneTables& t) {
  auto drop = [](auto& v) { std::remove_reference_t<decltype(v)>().swap(v); };
  drop(t.nodes);
  drop(t.prim_refs);
  drop(t.triangles);
  drop(t.vertices);
  drop(t.texels);
  drop(t.tex_data);
  drop(t.measured);
  t.cpu_wide.reset();
}

std::uint64_t table_bytes(const SceneTables& t) {
  auto b = [](const auto& v) { return std::uint64_t(v.size()) * sizeof(v[0]); };
  return sizeof(t.globals) + b(t.nodes) + b(t.prim_refs) + b(t.triangles) + b(t.vertices) +
         b(t.meshes) + b(t.spheres) + b(t.materials) + b(t.lights) + b(t.light_cdf) +
         b(t.filter_cdf) + b(t.measured) + b(t.textures) + b(t.mip_levels) + b(t.texels) +
         b(t.tex_data) + b(t.sampler_data) + (t.cpu_wide ? cpu::wide_bvh_bytes(*t.cpu_wide) : 0);
}

}  // namespace basalt
