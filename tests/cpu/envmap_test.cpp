// Image infinite lights (environment maps) on the host and in the CPU reference: the parser
// and table builder (pbrt-v4 ImageInfiniteLight creation), the equal-area mapping, sampling
// against the pdf, and rendering (docs/textures-spec.md section 6).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "common/bsdf_check.h"
#include "common/test_util.h"
#include "cpu/camera.h"
#include "cpu/cpu.h"
#include "cpu/envmap.h"
#include "cpu/lights.h"
#include "cpu/sampling.h"
#include "image/image_io.h"
#include "scene/tables.h"

namespace fs = std::filesystem;
using basalt::Image;
using basalt::SceneError;
using basalt::SceneTables;
using namespace basalt::cpu;
namespace gpu = basalt::gpu;

namespace {

// A fresh directory under the test temp dir.
fs::path temp_dir(const std::string& name) {
  fs::path d = fs::path(::testing::TempDir()) / ("basalt_envmap_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// Writes a w x h image whose pixel (x, y) (y from the top) is f(x, y).
template <typename F>
std::string write_map(const fs::path& dir, const std::string& name, int w, int h, F f) {
  Image im;
  im.width = w;
  im.height = h;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) im.pixels.push_back(f(x, y));
  const std::string path = (dir / name).string();
  basalt::write_image(path, im);
  return path;
}

// A scene around one LightSource line (the light's attribute block gets `xform`), with an
// optional extra body (shapes).
std::string scene_text(const std::string& light, const std::string& xform = "",
                       const std::string& body = "", int max_depth = 5, int res = 16) {
  return "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n"
         "Film \"rgb\" \"integer xresolution\" [ " + std::to_string(res) +
         " ] \"integer yresolution\" [ " + std::to_string(res) + " ]\n"
         "Sampler \"independent\" \"integer pixelsamples\" [ 16 ]\n"
         "Integrator \"path\" \"integer maxdepth\" [ " + std::to_string(max_depth) + " ]\n"
         "PixelFilter \"box\"\nWorldBegin\nAttributeBegin\n" + xform + "\n" + light +
         "\nAttributeEnd\n" + body + "\n";
}

std::string env_line(const std::string& path, const std::string& extra = "") {
  return "LightSource \"infinite\" \"string filename\" [ \"" + path + "\" ] " + extra;
}

// The error what() of parsing text as "t.pbrt" ("" if it parses and builds).
std::string error_of(const std::string& text) {
  try {
    basalt::build_tables(basalt::load_scene_from_string(text, "t.pbrt", "."));
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

// The image light of built tables.
const gpu::Light& env_light(const SceneTables& t) {
  for (const gpu::Light& l : t.lights)
    if (l.type == gpu::LIGHT_INFINITE_IMAGE) return l;
  ADD_FAILURE() << "no image infinite light";
  return t.lights.at(0);
}

// A structured test map: a smooth gradient with a dark quadrant and (if spot) a bright texel.
glm::vec3 structured(int x, int y, int n, bool spot = true) {
  const float fx = (x + 0.5f) / n, fy = (y + 0.5f) / n;
  glm::vec3 c(0.2f + fx, 0.5f + 0.5f * fy, 1.0f - 0.7f * fx * fy);
  if (x < n / 2 && y >= n / 2) c *= 0.02f;
  if (spot && x == n / 4 && y == n / 3) c = glm::vec3(40.0f, 30.0f, 20.0f);
  return c;
}

// Chi-square p-value of observed against expected counts, bins with expected < 5 pooled
// (as pbrt-v4's chi-square tests do); dof receives the degrees of freedom.
double chi2_p_value(const std::vector<double>& expected, const std::vector<double>& observed,
                    int& dof) {
  double chi2 = 0.0, pool_e = 0.0, pool_o = 0.0;
  dof = -1;
  for (std::size_t b = 0; b < expected.size(); ++b) {
    if (expected[b] < 5.0) {
      pool_e += expected[b];
      pool_o += observed[b];
      continue;
    }
    chi2 += (observed[b] - expected[b]) * (observed[b] - expected[b]) / expected[b];
    ++dof;
  }
  if (pool_e > 5.0) {
    chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
    ++dof;
  }
  return dof > 0 ? basalt::test::bsdf::gamma_q(dof / 2.0, chi2 / 2.0) : 0.0;
}

// Integral of f(w) over the sphere by the midpoint rule on a (z, phi) grid of nz x nphi cells
// (cylindrical equal-area: every cell has solid angle 4 pi / (nz nphi)).
template <typename F>
double sphere_integral(int nz, int nphi, F f) {
  double sum = 0.0;
  for (int i = 0; i < nz; ++i) {
    const double z = -1.0 + 2.0 * (i + 0.5) / nz;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    for (int j = 0; j < nphi; ++j) {
      const double phi = 2.0 * M_PI * (j + 0.5) / nphi;
      sum += f(glm::vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
    }
  }
  return sum * 4.0 * M_PI / (double(nz) * nphi);
}

}  // namespace

// pbrt-v4's equal-area octahedral map: square -> sphere gives unit vectors and sphere ->
// square inverts it (to the accuracy of pbrt-v4's polynomial atan) away from the seams; the
// hemispheres land on the inner diamond (z > 0) and the corners (z < 0).
TEST(Envmap, EqualAreaRoundTrip) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> U(0.001f, 0.999f);
  for (int i = 0; i < 20000; ++i) {
    const glm::vec2 p(U(rng), U(rng));
    const glm::vec3 w = equal_area_square_to_sphere(p);
    ASSERT_NEAR(glm::length(w), 1.0f, 2e-6f) << p.x << " " << p.y;
    const bool inner = std::fabs(2 * p.x - 1) + std::fabs(2 * p.y - 1) < 1.0f;
    if (std::fabs(std::fabs(2 * p.x - 1) + std::fabs(2 * p.y - 1) - 1.0f) > 1e-4f) {
      ASSERT_EQ(w.z > 0.0f, inner);
    }
    const glm::vec2 q = equal_area_sphere_to_square(w);
    ASSERT_NEAR(q.x, p.x, 2e-5f) << p.x << " " << p.y;
    ASSERT_NEAR(q.y, p.y, 2e-5f) << p.x << " " << p.y;
  }
  // sphere -> square -> sphere for directions everywhere, poles and axes included.
  std::normal_distribution<float> N;
  std::vector<glm::vec3> dirs = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  for (int i = 0; i < 20000; ++i) dirs.push_back(safe_normalize(glm::vec3(N(rng), N(rng), N(rng))));
  for (const glm::vec3& w : dirs) {
    const glm::vec2 q = equal_area_sphere_to_square(w);
    ASSERT_TRUE(q.x >= 0.0f && q.x <= 1.0f && q.y >= 0.0f && q.y <= 1.0f);
    const glm::vec3 w2 = equal_area_square_to_sphere(q);
    ASSERT_LT(glm::length(w2 - w), 5e-5f) << w.x << " " << w.y << " " << w.z;
  }
  // Fixed points: the centre is +z, the corners are -z, the edge midpoints are the axes.
  EXPECT_NEAR(equal_area_square_to_sphere({0.5f, 0.5f}).z, 1.0f, 1e-7f);
  EXPECT_NEAR(equal_area_square_to_sphere({0.0f, 0.0f}).z, -1.0f, 1e-7f);
  EXPECT_NEAR(equal_area_square_to_sphere({1.0f, 0.5f}).x, 1.0f, 1e-6f);
  EXPECT_NEAR(equal_area_square_to_sphere({0.5f, 1.0f}).y, 1.0f, 1e-6f);
}

// The equal-area property: uniform points of the square are uniform on the sphere (the
// fraction of points above z0 is (1 - z0) / 2).
TEST(Envmap, EqualAreaIsEqualArea) {
  const int n = 400;
  for (float z0 : {-0.8f, -0.3f, 0.0f, 0.45f, 0.9f}) {
    int above = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        above += equal_area_square_to_sphere({(i + 0.5f) / n, (j + 0.5f) / n}).z > z0;
    EXPECT_NEAR(double(above) / (n * n), (1.0 - z0) / 2.0, 2e-3) << z0;
  }
}

// The tables: one MipLevel holding the image, both distributions in tex_data in the layout of
// the spec, feature bits, the infinite-light list and the light's pmf; a rotated frame.
TEST(Envmap, Tables) {
  const fs::path d = temp_dir("tables");
  const int n = 8;
  const std::string path = write_map(d, "m.exr", n, n, [&](int x, int y) { return structured(x, y, n); });
  const SceneTables t = basalt::test::tables_from_string(scene_text(
      env_line(path, "\"float scale\" [ 2.5 ]"), "Rotate 90 1 0 0",
      "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n"
      "Shape \"sphere\" \"float radius\" [ 0.2 ]\nAttributeEnd\n"));
  ASSERT_EQ(t.globals.counts.y, 1u);
  const std::uint32_t li = t.globals.infinite_lights.x;
  ASSERT_LT(li, t.lights.size());
  const gpu::Light& l = t.lights[li];
  ASSERT_EQ(l.type, gpu::LIGHT_INFINITE_IMAGE);
  EXPECT_TRUE(t.features & gpu::FEATURE_LIGHT_INFINITE);
  EXPECT_TRUE(t.features & gpu::FEATURE_LIGHT_INFINITE_IMAGE);
  EXPECT_EQ(glm::vec3(l.L), glm::vec3(2.5f));
  // pbrt-v4 BVHLightSampler: the infinite light gets 1 / (1 + 1) next to a bounded light.
  EXPECT_NEAR(l.pmf, 0.5f, 1e-6f);
  ASSERT_LT(l.data.x, t.mip_levels.size());
  const gpu::MipLevel& m = t.mip_levels[l.data.x];
  EXPECT_EQ(m.width, std::uint32_t(n));
  EXPECT_EQ(m.height, std::uint32_t(n));
  EXPECT_EQ(m.channels, 3u);
  EXPECT_EQ(t.texels[m.offset + 3 * (3 * n + 5) + 1], structured(5, 3, n).y);
  for (std::uint32_t o : {l.data.y, l.data.z}) {
    ASSERT_LT(o + 4, t.tex_data.size());
    EXPECT_EQ(t.tex_data[o], float(n));
    EXPECT_EQ(t.tex_data[o + 1], float(n));
    const float* mf = &t.tex_data[o + 4];
    const float* mc = mf + n;
    EXPECT_EQ(mc[0], 0.0f);
    EXPECT_EQ(mc[n], 1.0f);
    double msum = 0.0;
    for (int v = 0; v < n; ++v) {
      const float* f = &t.tex_data[o + 5 + 2 * n + v * (2 * n + 2)];
      const float* c = f + n;
      EXPECT_EQ(c[0], 0.0f);
      EXPECT_FLOAT_EQ(c[n], 1.0f);
      double s = 0.0;
      for (int u = 0; u < n; ++u) {
        EXPECT_LE(c[u], c[u + 1]);
        s += f[u];
        if (o == l.data.y) {  // the plain distribution is the channel average
          const glm::vec3 px = structured(u, v, n);
          EXPECT_FLOAT_EQ(f[u], (px.x + px.y + px.z) / 3.0f);
        }
      }
      EXPECT_NEAR(f[2 * n + 1], s / n, 1e-5 * s);  // the row's integral
      EXPECT_FLOAT_EQ(mf[v], f[2 * n + 1]);
      msum += mf[v];
    }
    EXPECT_NEAR(t.tex_data[o + 2], msum / n, 1e-5 * msum);
  }
  // Rotate 90 about x: light +z is world -y, so light_from_world maps world -y to +z.
  const glm::vec3 wl = glm::mat3(l.light_from_world) * glm::vec3(0, -1, 0);
  EXPECT_NEAR(wl.z, 1.0f, 1e-6f);
  // Le in world direction -y is the texel at the centre of the square.
  const glm::vec3 centre = structured(n / 2, n / 2, n) * 2.5f;
  const glm::vec3 le = env_le(t, l, glm::vec3(0, -1, 0));
  EXPECT_NEAR(le.x, centre.x, 1e-5f);
  EXPECT_NEAR(le.z, centre.z, 1e-5f);
}

// env_pdf integrates to 1 over the sphere, for both distributions and a rotated frame; the
// compensated one is 0 where the map is below its average; a constant map is uniform.
TEST(Envmap, PdfIntegratesToOne) {
  const fs::path d = temp_dir("pdf");
  const int n = 32;
  const std::string path = write_map(d, "m.exr", n, n, [&](int x, int y) { return structured(x, y, n); });
  const SceneTables t =
      basalt::test::tables_from_string(scene_text(env_line(path), "Rotate 37 1 2 3"));
  const gpu::Light& l = env_light(t);
  for (bool comp : {false, true}) {
    const double integral =
        sphere_integral(800, 1600, [&](glm::vec3 w) { return double(env_pdf(t, l, w, comp)); });
    EXPECT_NEAR(integral, 1.0, 2e-3) << "compensated " << comp;
  }
  // The dark quadrant (x < n/2, y >= n/2: below average) has compensated pdf 0.
  const glm::vec3 wl = equal_area_square_to_sphere({0.25f, 0.75f});
  const glm::vec3 w = glm::transpose(glm::mat3(l.light_from_world)) * wl;
  EXPECT_EQ(env_pdf(t, l, w, true), 0.0f);
  EXPECT_GT(env_pdf(t, l, w, false), 0.0f);

  const std::string cpath =
      write_map(d, "c.exr", 16, 16, [](int, int) { return glm::vec3(0.7f, 0.5f, 0.3f); });
  const SceneTables tc = basalt::test::tables_from_string(scene_text(env_line(cpath)));
  const gpu::Light& lc = env_light(tc);
  std::mt19937 rng(3);
  std::normal_distribution<float> N;
  for (int i = 0; i < 1000; ++i) {
    const glm::vec3 wi = safe_normalize(glm::vec3(N(rng), N(rng), N(rng)));
    ASSERT_FLOAT_EQ(env_pdf(tc, lc, wi, true), 1.0f / (4.0f * PI));
    ASSERT_FLOAT_EQ(env_pdf(tc, lc, wi, false), 1.0f / (4.0f * PI));
    ASSERT_EQ(env_le(tc, lc, wi), glm::vec3(0.7f, 0.5f, 0.3f));
  }
}

// Sampling matches the pdf, chi-square tests (Sidak-corrected over the four): (1) in world
// directions, (z, phi) bins against the integral of env_pdf over each bin, on a smooth map
// (so that midpoint quadrature of the bins is accurate); (2) in the light's square, bins of
// half a texel (the pdf is constant on each, so expected counts are exact), on a map with a
// bright texel. Both distributions, a rotated frame; each sample's pdf and radiance are
// env_pdf and env_le at its direction.
TEST(Envmap, SamplingMatchesPdfChi2) {
  const fs::path d = temp_dir("chi2");
  const int n = 16, samples = 300000;
  const double alpha = basalt::test::bsdf::sidak(0.01, 4);
  for (bool spot : {false, true}) {
    const std::string path = write_map(d, spot ? "s.exr" : "m.exr", n, n,
                                       [&](int x, int y) { return structured(x, y, n, spot); });
    const SceneTables t =
        basalt::test::tables_from_string(scene_text(env_line(path), "Rotate -50 0.3 1 0.2"));
    const gpu::Light& l = env_light(t);
    const glm::mat3 to_light(l.light_from_world);
    for (bool comp : {false, true}) {
      std::vector<double> expected, observed;
      std::function<int(glm::vec3)> bin_of;
      if (!spot) {
        const int nz = 24, nphi = 48, sub = 16;
        bin_of = [=](glm::vec3 w) {
          const int i = std::clamp(int((w.z + 1.0f) / 2.0f * nz), 0, nz - 1);
          double phi = std::atan2(double(w.y), double(w.x));
          if (phi < 0) phi += 2.0 * M_PI;
          const int j = std::clamp(int(phi / (2.0 * M_PI) * nphi), 0, nphi - 1);
          return i * nphi + j;
        };
        expected.assign(nz * nphi, 0.0);
        for (int i = 0; i < nz; ++i)
          for (int j = 0; j < nphi; ++j) {
            double sum = 0.0;
            for (int a = 0; a < sub; ++a)
              for (int b = 0; b < sub; ++b) {
                const double z = -1.0 + 2.0 * (i + (a + 0.5) / sub) / nz;
                const double phi = 2.0 * M_PI * (j + (b + 0.5) / sub) / nphi;
                const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
                sum += env_pdf(t, l, glm::vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)), comp);
              }
            expected[i * nphi + j] = sum / (sub * sub) * 4.0 * M_PI / (nz * nphi) * samples;
          }
      } else {
        const int nb = 2 * n;  // half-texel bins of the light's square
        bin_of = [=](glm::vec3 w) {
          const glm::vec2 uv = equal_area_sphere_to_square(safe_normalize(to_light * w));
          return std::clamp(int(uv.y * nb), 0, nb - 1) * nb + std::clamp(int(uv.x * nb), 0, nb - 1);
        };
        expected.assign(nb * nb, 0.0);
        for (int y = 0; y < nb; ++y)
          for (int x = 0; x < nb; ++x) {
            const glm::vec3 wl = equal_area_square_to_sphere({(x + 0.5f) / nb, (y + 0.5f) / nb});
            const glm::vec3 w = glm::transpose(to_light) * wl;
            // pdf in the square = 4 pi * solid-angle pdf; bin area 1 / nb^2.
            expected[y * nb + x] = 4.0 * M_PI * env_pdf(t, l, w, comp) / (nb * nb) * samples;
          }
      }
      observed.assign(expected.size(), 0.0);
      std::mt19937 rng(comp ? 11 : 5);
      std::uniform_real_distribution<float> U(0.0f, 1.0f);
      int pdf_mismatch = 0, le_mismatch = 0, failed = 0;
      for (int k = 0; k < samples; ++k) {
        glm::vec3 wi, le;
        float pdf;
        if (!env_sample(t, l, glm::vec2(U(rng), U(rng)), comp, wi, pdf, le)) {
          ++failed;
          continue;
        }
        ASSERT_NEAR(glm::length(wi), 1.0f, 1e-5f);
        observed[bin_of(wi)] += 1.0;
        const float p2 = env_pdf(t, l, wi, comp);
        if (std::fabs(p2 - pdf) > 1e-4f * pdf) ++pdf_mismatch;
        if (glm::length(env_le(t, l, wi) - le) > 1e-4f * glm::length(le)) ++le_mismatch;
      }
      EXPECT_EQ(failed, 0);
      // Directions within rounding of a texel edge may map back to the neighbour texel.
      EXPECT_LT(pdf_mismatch, samples / 1000) << comp;
      EXPECT_LT(le_mismatch, samples / 1000) << comp;
      int dof = 0;
      const double p = chi2_p_value(expected, observed, dof);
      EXPECT_GT(dof, 100);
      EXPECT_GT(p, alpha) << "spot " << spot << " compensated " << comp << " dof " << dof;
    }
  }
}

// A map that is black but for one bright texel is sampled in that texel (and only there for
// the compensated distribution); its pdf there is what one texel of area 1/n^2 gives.
TEST(Envmap, BrightTexelIsSampled) {
  const fs::path d = temp_dir("bright");
  const int n = 32, bx = 5, by = 20;
  const std::string path = write_map(d, "m.exr", n, n, [&](int x, int y) {
    return x == bx && y == by ? glm::vec3(1000.0f, 800.0f, 600.0f) : glm::vec3(0.001f);
  });
  const SceneTables t = basalt::test::tables_from_string(scene_text(env_line(path)));
  const gpu::Light& l = env_light(t);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  for (bool comp : {false, true}) {
    int inside = 0, near = 0, bright = 0;
    const int N = 20000;
    for (int k = 0; k < N; ++k) {
      glm::vec3 wi, le;
      float pdf;
      ASSERT_TRUE(env_sample(t, l, glm::vec2(U(rng), U(rng)), comp, wi, pdf, le));
      const glm::vec2 uv = equal_area_sphere_to_square(wi);  // identity frame
      inside += int(uv.x * n) == bx && int(uv.y * n) == by;
      // The direction maps back into the texel up to rounding at its edges.
      near += uv.x > (bx - 1e-4f) / n && uv.x < (bx + 1 + 1e-4f) / n &&
              uv.y > (by - 1e-4f) / n && uv.y < (by + 1 + 1e-4f) / n;
      bright += le.x == 1000.0f;  // Le is read at the sampled point of the square
    }
    if (comp) {
      EXPECT_EQ(near, N);
      EXPECT_EQ(bright, N);
      EXPECT_GT(inside, N - N / 1000);
    } else {
      EXPECT_GT(inside, int(0.99 * N));
      EXPECT_GT(bright, int(0.99 * N));
    }
  }
  const glm::vec3 centre = equal_area_square_to_sphere({(bx + 0.5f) / n, (by + 0.5f) / n});
  EXPECT_NEAR(env_pdf(t, l, centre, true), n * n / (4.0 * M_PI), 1e-3 * n * n);
  EXPECT_EQ(env_le(t, l, centre), glm::vec3(1000.0f, 800.0f, 600.0f));
  // A direction elsewhere: no compensated density, but the dim plain one.
  const glm::vec3 other = equal_area_square_to_sphere({0.8f, 0.1f});
  EXPECT_EQ(env_pdf(t, l, other, true), 0.0f);
  EXPECT_GT(env_pdf(t, l, other, false), 0.0f);
}

// A constant map renders as a uniform infinite light of that radiance: a diffuse sphere
// (furnace: a ray that hits sees R L, one that misses sees L) and the same mean image.
TEST(Envmap, ConstantMapMatchesUniformLight) {
  const fs::path d = temp_dir("constant");
  const glm::vec3 L(0.7f, 0.5f, 0.3f);
  const std::string path = write_map(d, "c.exr", 16, 16, [&](int, int) { return L; });
  const std::string body =
      "Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.5 0.5 ]\n"
      "Shape \"sphere\" \"float radius\" [ 1 ]\n";
  const SceneTables te = basalt::test::tables_from_string(
      scene_text(env_line(path), "Rotate 30 0 1 1", body, 5, 16));
  const SceneTables tu = basalt::test::tables_from_string(
      scene_text("LightSource \"infinite\" \"rgb L\" [ 0.7 0.5 0.3 ]", "", body, 5, 16));
  const std::uint32_t spp = 64;
  double hit_sum[2] = {0.0, 0.0};
  int hits = 0;
  bool misses_exact = true;
  for (std::uint32_t y = 0; y < 16; ++y)
    for (std::uint32_t x = 0; x < 16; ++x)
      for (std::uint32_t s = 0; s < spp; ++s) {
        const bool hit = intersect_closest(te, camera_ray(te, x, y, s)).valid();
        const glm::vec3 Le = path_radiance(te, x, y, s);
        const glm::vec3 Lu = path_radiance(tu, x, y, s);
        ASSERT_TRUE(std::isfinite(Le.x) && std::isfinite(Le.y) && std::isfinite(Le.z));
        if (!hit) {
          misses_exact = misses_exact && Le == L && Lu == L;
        } else {
          ++hits;
          hit_sum[0] += Le.x;
          hit_sum[1] += Lu.x;
        }
      }
  EXPECT_TRUE(misses_exact);
  ASSERT_GT(hits, 1000);
  EXPECT_NEAR(hit_sum[0] / hits, 0.5 * L.x, 0.02 * L.x);
  EXPECT_NEAR(hit_sum[0] / hits, hit_sum[1] / hits, 0.03 * L.x);
}

// Direct lighting from a single bright texel near the zenith on an upward diffuse plane: the
// image equals R / pi times the irradiance of that texel (its radiance times the cosine
// integrated over its solid angle, 4 pi / n^2 in area), as NEE and MIS deliver it.
TEST(Envmap, BrightTexelIrradiance) {
  const fs::path d = temp_dir("irradiance");
  const int n = 16, bx = 9, by = 7;  // texel next to the centre (+z)
  const float Lb = 50.0f;
  const std::string path = write_map(d, "m.exr", n, n, [&](int x, int y) {
    return x == bx && y == by ? glm::vec3(Lb) : glm::vec3(0.0f);
  });
  // Plane z = 0 facing +z, seen from above (camera at z = 4 looking down).
  const std::string text =
      "LookAt 0 0 4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 20 ]\n"
      "Film \"rgb\" \"integer xresolution\" [ 4 ] \"integer yresolution\" [ 4 ]\n"
      "Sampler \"independent\" \"integer pixelsamples\" [ 16 ]\n"
      "Integrator \"path\" \"integer maxdepth\" [ 1 ]\nPixelFilter \"box\"\nWorldBegin\n" +
      env_line(path) +
      "\nMaterial \"diffuse\" \"rgb reflectance\" [ 0.6 0.6 0.6 ]\n"
      "Shape \"trianglemesh\" \"integer indices\" [ 0 1 2 0 2 3 ]\n"
      "  \"point3 P\" [ -10 -10 0  10 -10 0  10 10 0  -10 10 0 ]\n";
  const SceneTables t = basalt::test::tables_from_string(text);
  double E = 0.0;  // irradiance at +z of the texel, by fine sub-sampling
  const int k = 64;
  for (int a = 0; a < k; ++a)
    for (int b = 0; b < k; ++b) {
      const glm::vec3 w = equal_area_square_to_sphere(
          {(bx + (a + 0.5f) / k) / n, (by + (b + 0.5f) / k) / n});
      E += Lb * std::max(0.0f, w.z);
    }
  E *= 4.0 * M_PI / (double(n) * n * k * k);
  const double expected = 0.6 / M_PI * E;
  double sum = 0.0;
  int count = 0;
  for (std::uint32_t y = 0; y < 4; ++y)
    for (std::uint32_t x = 0; x < 4; ++x)
      for (std::uint32_t s = 0; s < 256; ++s) {
        sum += path_radiance(t, x, y, s).y;
        ++count;
      }
  EXPECT_NEAR(sum / count, expected, 0.02 * expected);
}

// An 8-bit PNG map is decoded through sRGB, as pbrt-v4 reads it for this light.
TEST(Envmap, PngIsSrgb) {
  const fs::path d = temp_dir("png");
  const std::string path = write_map(d, "m.png", 4, 4, [](int, int) { return glm::vec3(0.5f, 0.2f, 0.05f); });
  const SceneTables t = basalt::test::tables_from_string(scene_text(env_line(path)));
  const glm::vec3 le = env_le(t, env_light(t), glm::vec3(0, 0, 1));
  EXPECT_NEAR(le.x, 0.5f, 0.01f);
  EXPECT_NEAR(le.y, 0.2f, 0.005f);
  EXPECT_NEAR(le.z, 0.05f, 0.002f);
}

// "illuminance" scales the map as pbrt-v4 does: E_v over its measure of the upper
// hemisphere's illuminance (luminance times cos over the texels with w.z > 0, times
// 2 pi / n^2, which for a constant map of luminance 1 is about pi / 2).
TEST(Envmap, Illuminance) {
  const fs::path d = temp_dir("illuminance");
  const std::string path = write_map(d, "c.exr", 64, 64, [](int, int) { return glm::vec3(1.0f); });
  const SceneTables t = basalt::test::tables_from_string(
      scene_text(env_line(path, "\"float illuminance\" [ 10 ] \"float scale\" [ 3 ]")));
  EXPECT_NEAR(env_light(t).L.x, 3.0 * 10.0 / (M_PI / 2.0), 0.01 * 3.0 * 10.0 / (M_PI / 2.0));
}

// Bad input: located errors (file:line:column) naming the file.
TEST(Envmap, BadInput) {
  const fs::path d = temp_dir("bad");
  const std::string rect = write_map(d, "rect.exr", 8, 4, [](int, int) { return glm::vec3(1.0f); });
  std::string e = error_of(scene_text(env_line(rect)));
  EXPECT_NE(e.find("t.pbrt:10:"), std::string::npos) << e;
  EXPECT_NE(e.find(rect), std::string::npos) << e;
  EXPECT_NE(e.find("non-square"), std::string::npos) << e;

  const std::string missing = (d / "nope.exr").string();
  e = error_of(scene_text(env_line(missing)));
  EXPECT_NE(e.find("t.pbrt:10:"), std::string::npos) << e;
  EXPECT_NE(e.find("nope.exr"), std::string::npos) << e;

  const std::string ok = write_map(d, "ok.exr", 4, 4, [](int, int) { return glm::vec3(1.0f); });
  e = error_of(scene_text(env_line(ok, "\"rgb L\" [ 1 1 1 ]")));
  EXPECT_NE(e.find("t.pbrt:10:"), std::string::npos) << e;
  EXPECT_NE(e.find("\"L\""), std::string::npos) << e;
  EXPECT_NE(e.find("\"filename\""), std::string::npos) << e;

  e = error_of(scene_text(env_line(ok, "\"point3 portal\" [ 0 0 0  1 0 0  1 1 0  0 1 0 ]")));
  EXPECT_NE(e.find("t.pbrt:10:"), std::string::npos) << e;
  EXPECT_NE(e.find("portal"), std::string::npos) << e;
  EXPECT_NE(e.find("not supported yet"), std::string::npos) << e;

  e = error_of(scene_text(env_line(ok), "Scale 1 2 1"));
  EXPECT_NE(e.find("rotation"), std::string::npos) << e;

  // A relative name resolves against the scene's directory.
  const std::string text = scene_text(env_line("ok.exr"));
  EXPECT_NO_THROW(basalt::build_tables(basalt::load_scene_from_string(text, "t.pbrt", d.string())));
}
