// Shirley's solid textures in the CPU reference (docs/textures-spec.md section 7; seed 002
// 11.1): stripes, solid noise and turbulence, turbulent stripes, interpolated image arrays and
// volume arrays, their shared tables, parsing and located errors. The oracles are closed forms
// (duty cycles, periods, interpolation of ramps and trilinear functions), not the GPU twin.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "common/scratch_dir.h"
#include "common/noise_check.h"
#include "common/test_util.h"
#include "cpu/noise.h"
#include "cpu/texture.h"
#include "scene/scene.h"
#include "scene/tables.h"
#include "scene/textures.h"

namespace fs = std::filesystem;

namespace basalt::test {
namespace {

constexpr double kPiD = 3.14159265358979323846;

/// This process's scratch folder, removed when the process exits (one per pid, so that the
/// parallel ctest processes of this binary do not share it).
fs::path temp_dir() { return basalt::test::scratch_dir("shirley"); }

/// Tables of kTexturedHead + \p body (relative files resolve in temp_dir()).
SceneTables textured(const std::string& body) { return textured_scene(body, temp_dir().string()); }

/// The error message of kTexturedHead + \p body (empty if it builds).
std::string error_of(const std::string& body) {
  return textured_scene_error(body, temp_dir().string());
}

/// A scene using float texture "x" (as a coateddiffuse roughness) after the lines \p defs.
std::string float_use(const std::string& defs) {
  return defs + "Material \"coateddiffuse\" \"texture roughness\" \"x\"\nShape \"sphere\"\n";
}
/// A scene using spectrum texture "x" (as a diffuse reflectance) after the lines \p defs.
std::string rgb_use(const std::string& defs) {
  return defs + "Material \"diffuse\" \"texture reflectance\" \"x\"\nShape \"sphere\"\n";
}

/// The root instruction of the last instruction of tag \p tag (the program of the one texture
/// of that class the scene uses).
std::uint32_t root_of(const SceneTables& t, std::uint32_t tag) {
  std::uint32_t r = gpu::INVALID_INDEX;
  for (std::uint32_t i = 0; i < t.textures.size(); ++i)
    if (t.textures[i].type == tag) r = i;
  return r;
}

cpu::TextureContext at(glm::vec3 p) {
  cpu::TextureContext c;
  c.p = p;
  c.n = glm::vec3(0.0f, 0.0f, 1.0f);
  return c;
}
cpu::TextureContext at_uv(glm::vec2 uv) {
  cpu::TextureContext c;
  c.uv = uv;
  c.n = glm::vec3(0.0f, 0.0f, 1.0f);
  return c;
}

// ---- tables ------------------------------------------------------------------------------

TEST(ShirleyTables, UnitGradientsAndAPermutation) {
  std::vector<float> data;
  const glm::uvec4 off = texture_shared_tables(data);
  ASSERT_EQ(data.size(), std::size_t(off.z) + 768u + 256u);
  const float* g = data.data() + off.z;
  glm::dvec3 mean(0.0);
  for (int k = 0; k < 256; ++k) {
    const glm::dvec3 v(g[3 * k], g[3 * k + 1], g[3 * k + 2]);
    EXPECT_NEAR(glm::length(v), 1.0, 1e-6) << "gradient " << k;
    mean += v / 256.0;
  }
  // Uniform directions: the mean of 256 of them is small (each component ~ 1 / sqrt(3 * 256)).
  EXPECT_LT(glm::length(mean), 0.2);
  std::vector<int> p;
  for (int i = 0; i < 256; ++i) {
    const float v = g[768 + i];
    EXPECT_EQ(v, std::floor(v));
    p.push_back(int(v));
  }
  int fixed = 0;
  for (int i = 0; i < 256; ++i) fixed += p[std::size_t(i)] == i;
  EXPECT_LT(fixed, 10);  // shuffled, not the identity
  std::sort(p.begin(), p.end());
  for (int i = 0; i < 256; ++i) EXPECT_EQ(p[std::size_t(i)], i);
  // Deterministic: a second build gives the same floats.
  std::vector<float> again;
  texture_shared_tables(again);
  EXPECT_EQ(data, again);
}

// ---- noise ---------------------------------------------------------------------------------

TEST(ShirleyNoise, PropertiesCpu) {
  const SceneTables t = textured("Shape \"sphere\"\n");
  // Shirley's cubic weight has |w'| <= 1.5 and the unit gradients |g . d| <= 1: the slope stays
  // well within pbrt's bound (the check prints the largest one seen).
  check_noise_properties(pointwise([&](glm::vec3 x) { return cpu::shirley_noise(t, x); }),
                         1000000);
}

TEST(ShirleyNoise, MatchesTheSeedFormulaInDouble) {
  // An independent evaluation of seed 002 11.1.3 in double from the tables.
  const SceneTables t = textured("Shape \"sphere\"\n");
  const float* g = t.tex_data.data() + t.globals.tex_tables.z;
  auto phi = [&](long i) { return long(g[768 + ((i % 256) + 256) % 256]); };
  auto w = [](double x) {
    const double a = std::fabs(x);
    return a < 1.0 ? 2.0 * a * a * a - 3.0 * a * a + 1.0 : 0.0;
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> U(-40.0f, 40.0f);
  double max_err = 0.0, max_abs = 0.0;
  for (int n = 0; n < 20000; ++n) {
    const glm::vec3 p(U(rng), U(rng), U(rng));
    double sum = 0.0;
    for (long i = long(std::floor(p.x)); i <= long(std::floor(p.x)) + 1; ++i)
      for (long j = long(std::floor(p.y)); j <= long(std::floor(p.y)) + 1; ++j)
        for (long k = long(std::floor(p.z)); k <= long(std::floor(p.z)) + 1; ++k) {
          const double u = double(p.x) - double(i), v = double(p.y) - double(j),
                       s = double(p.z) - double(k);
          const float* gr = g + 3 * phi(i + phi(j + phi(k)));
          sum += w(u) * w(v) * w(s) * (gr[0] * u + gr[1] * v + gr[2] * s);
        }
    max_err = std::max(max_err, std::fabs(sum - double(cpu::shirley_noise(t, p))));
    max_abs = std::max(max_abs, std::fabs(sum));
  }
  EXPECT_LT(max_err, 1e-6);
  EXPECT_GT(max_abs, 0.3);  // not trivially 0
  // Non-finite points give 0.
  EXPECT_EQ(cpu::shirley_noise(t, glm::vec3(NAN, 0.5f, 0.5f)), 0.0f);
  EXPECT_EQ(cpu::shirley_noise(t, glm::vec3(0.5f, INFINITY, 0.5f)), 0.0f);
}

TEST(ShirleyNoise, TurbulenceSumsOctaves) {
  const SceneTables t = textured("Shape \"sphere\"\n");
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> U(-20.0f, 20.0f);
  for (int n = 0; n < 2000; ++n) {
    const glm::vec3 p(U(rng), U(rng), U(rng));
    EXPECT_EQ(cpu::shirley_turbulence(t, p, 0), 0.0f);
    EXPECT_EQ(cpu::shirley_turbulence(t, p, 1), std::fabs(cpu::shirley_noise(t, p)));
    float sum = 0.0f, f = 1.0f;
    for (int i = 0; i < 5; ++i) {
      sum += std::fabs(cpu::shirley_noise(t, f * p)) / f;
      f *= 2.0f;
    }
    EXPECT_EQ(cpu::shirley_turbulence(t, p, 5), sum);
  }
  // The probe (layout.h PROBE_NOISE key.y = 1 and 4) answers the same functions.
  std::vector<gpu::ProbeIn> q(2);
  q[0].key = glm::uvec4(gpu::PROBE_NOISE, 1u, 0u, 0u);
  q[0].o_tmax = glm::vec4(1.3f, -2.7f, 0.45f, 0.0f);
  q[1] = q[0];
  q[1].key = glm::uvec4(gpu::PROBE_NOISE, 4u, 6u, 0u);
  const std::vector<gpu::ProbeOut> o = probe(Side::Cpu, t, q);
  EXPECT_EQ(o[0].f0.x, cpu::shirley_noise(t, glm::vec3(1.3f, -2.7f, 0.45f)));
  EXPECT_EQ(o[1].f0.x, cpu::shirley_turbulence(t, glm::vec3(1.3f, -2.7f, 0.45f), 6));
}

TEST(ShirleyNoise, SolidNoiseAndTurbulenceTextures) {
  const SceneTables t = textured(
      "Texture \"x\" \"float\" \"solidnoise\" \"float scale\" [ 0.5 ] \"float offset\" [ 1 ]\n"
      "Texture \"y\" \"spectrum\" \"solidturbulence\" \"integer octaves\" [ 4 ]"
      " \"float scale\" [ 2 ] \"float offset\" [ -0.25 ]\n"
      "Material \"coateddiffuse\" \"texture roughness\" \"x\" \"texture reflectance\" \"y\"\n"
      "Shape \"sphere\"\n");
  const std::uint32_t rn = root_of(t, gpu::TEXTURE_SHIRLEY_NOISE);
  const std::uint32_t rt = root_of(t, gpu::TEXTURE_SHIRLEY_TURBULENCE);
  ASSERT_NE(rn, gpu::INVALID_INDEX);
  ASSERT_NE(rt, gpu::INVALID_INDEX);
  EXPECT_EQ(t.textures[rt].ip.x, 4u);
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> U(-5.0f, 5.0f);
  float lo = 1e9f, hi = -1e9f;
  for (int n = 0; n < 2000; ++n) {
    const glm::vec3 p(U(rng), U(rng), U(rng));
    const float v = cpu::tex_eval_float(t, rn, at(p));
    EXPECT_EQ(v, 0.5f * (cpu::shirley_noise(t, p) + 1.0f));
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    EXPECT_EQ(cpu::tex_eval_rgb(t, rt, at(p)),
              glm::vec3(2.0f * (cpu::shirley_turbulence(t, p, 4) + -0.25f)));
  }
  // Shirley's 0.5 (noise + 1) stays in [0, 1].
  EXPECT_GE(lo, 0.0f);
  EXPECT_LE(hi, 1.0f);
  // Features: the noise family and Shirley's bit, not the pbrt procedural one.
  EXPECT_NE(t.features & gpu::FEATURE_TEXTURES, 0u);
  EXPECT_NE(t.features & gpu::FEATURE_TEX_NOISE, 0u);
  EXPECT_NE(t.features2 & gpu::FEATURE2_TEX_SHIRLEY, 0u);
  EXPECT_EQ(t.features2 & gpu::FEATURE2_TEX_PROCEDURAL, 0u);
}

// ---- stripes -------------------------------------------------------------------------------

/// Float stripe texture of \p form and \p extra parameters, tex1 1, tex2 0 (the defaults).
struct Stripe {
  SceneTables t;
  std::uint32_t root;
  explicit Stripe(const std::string& params)
      : t(textured(float_use("Texture \"x\" \"float\" \"stripe\" " + params + "\n"))),
        root(root_of(t, gpu::TEXTURE_STRIPE)) {}
  float operator()(float x) const { return cpu::tex_eval_float(t, root, at(glm::vec3(x, 0.3f, -0.7f))); }
};

TEST(Stripe, SignFormHasHalfDutyAndPeriodTwoPi) {
  const Stripe s("\"string form\" \"sign\"");
  ASSERT_NE(s.root, gpu::INVALID_INDEX);
  EXPECT_EQ(s.t.textures[s.root].ip.x, 0u);
  // Fraction of tex1 over a long range (many periods).
  const int n = 2000000;
  double ones = 0.0;
  for (int i = 0; i < n; ++i) {
    const float v = s(-3000.0f + 6000.0f * (float(i) + 0.5f) / float(n));
    ASSERT_TRUE(v == 0.0f || v == 1.0f) << v;
    ones += v;
  }
  EXPECT_NEAR(ones / n, 0.5, 1e-3);
  // tex1 exactly where sin(x) > 0: stripes of period 2 pi (away from the zero crossings).
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> U(-200.0, 200.0);
  int checked = 0;
  for (int i = 0; i < 20000; ++i) {
    const float x = float(U(rng));
    const double sx = std::sin(double(x));
    if (std::fabs(sx) < 1e-4) continue;
    ++checked;
    EXPECT_EQ(s(x), sx > 0.0 ? 1.0f : 0.0f) << "x = " << x;
    const float y = float(double(x) + 2.0 * kPiD);
    if (std::fabs(std::sin(double(y))) > 1e-4) {
      EXPECT_EQ(s(y), s(x)) << "x = " << x;
    }
  }
  EXPECT_GT(checked, 19000);
}

TEST(Stripe, WidthFormHasPeriodTwoW) {
  const Stripe s("\"float width\" [ 0.7 ]");  // form "width" is the default
  ASSERT_NE(s.root, gpu::INVALID_INDEX);
  EXPECT_EQ(s.t.textures[s.root].ip.x, 1u);
  EXPECT_EQ(s.t.textures[s.root].param[0].x, 0.7f);
  std::mt19937 rng(22);
  std::uniform_real_distribution<double> U(-100.0, 100.0);
  for (int i = 0; i < 20000; ++i) {
    const float x = float(U(rng));
    // tex1 on (2 k w, (2 k + 1) w): the first half of each period 2 w.
    const double ph = double(x) / (2.0 * double(0.7f));
    const double fr = ph - std::floor(ph);
    if (fr < 1e-5 || std::fabs(fr - 0.5) < 1e-5 || fr > 1.0 - 1e-5) continue;
    EXPECT_EQ(s(x), fr < 0.5 ? 1.0f : 0.0f) << "x = " << x;
  }
  // Duty cycle 1/2 over many periods.
  const int n = 1000000;
  double ones = 0.0;
  for (int i = 0; i < n; ++i) ones += s(-700.0f + 1400.0f * (float(i) + 0.5f) / float(n));
  EXPECT_NEAR(ones / n, 0.5, 1e-3);
  // Period exactly 2 w on representable multiples (x and x + 2 w exact): the same stripe.
  const Stripe one("\"float width\" [ 0.5 ]");
  for (int i = -400; i < 400; ++i) {
    const float x = float(i) / 64.0f + 1.0f / 128.0f;
    EXPECT_EQ(one(x), one(x + 1.0f)) << x;
    EXPECT_NE(one(x), one(x + 0.5f)) << x;
  }
}

TEST(Stripe, SmoothFormMeanAndExactValues) {
  const float w = 0.75f;
  const SceneTables t = textured(rgb_use(
      "Texture \"x\" \"spectrum\" \"stripe\" \"string form\" \"smooth\" \"float width\" [ 0.75 ]"
      " \"rgb tex1\" [ 0.9 0.2 0.1 ] \"rgb tex2\" [ 0.1 0.4 0.7 ]\n"));
  const std::uint32_t r = root_of(t, gpu::TEXTURE_STRIPE);
  ASSERT_NE(r, gpu::INVALID_INDEX);
  EXPECT_EQ(t.textures[r].ip.x, 2u);
  const glm::vec3 a(0.9f, 0.2f, 0.1f), b(0.1f, 0.4f, 0.7f);
  auto v = [&](float x) { return cpu::tex_eval_rgb(t, r, at(glm::vec3(x, 1.0f, 2.0f))); };
  // x = w / 2: sin(pi / 2) = 1, t = 1: exactly tex2. x = 0: t = 1/2. x = 3 w / 2: t = 0.
  EXPECT_EQ(v(w / 2.0f), b);
  EXPECT_EQ(v(0.0f), 0.5f * a + 0.5f * b);
  EXPECT_EQ(v(1.5f * w), a);
  EXPECT_EQ(v(-w / 2.0f), a);
  // The mean over many periods is (tex1 + tex2) / 2.
  const int n = 1000000;
  glm::dvec3 sum(0.0);
  for (int i = 0; i < n; ++i) sum += glm::dvec3(v(-750.0f + 1500.0f * (float(i) + 0.5f) / float(n)));
  const glm::dvec3 mean = sum / double(n);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[c], 0.5 * (double(a[c]) + double(b[c])), 1e-3);
  // Everywhere the closed form (1 - t) tex1 + t tex2 with t = (1 + sin(pi x / w)) / 2.
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> U(-30.0f, 30.0f);
  for (int i = 0; i < 5000; ++i) {
    const float x = U(rng);
    const double tt = 0.5 * (1.0 + std::sin(kPiD * double(x) / double(w)));
    const glm::vec3 got = v(x);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], (1.0 - tt) * a[c] + tt * b[c], 2e-5) << x;
  }
  EXPECT_NE(t.features2 & gpu::FEATURE2_TEX_SHIRLEY, 0u);
  EXPECT_EQ(t.features & gpu::FEATURE_TEX_NOISE, 0u);
  EXPECT_EQ(t.features2 & gpu::FEATURE2_TEX_PROCEDURAL, 0u);
}

TEST(Stripe, ChildrenAreTextures) {
  // tex1 a solid noise texture, tex2 a constant: a program of 3 instructions, tex2 on top.
  const SceneTables t = textured(float_use(
      "Texture \"n\" \"float\" \"solidnoise\"\n"
      "Texture \"x\" \"float\" \"stripe\" \"string form\" \"sign\" \"texture tex1\" \"n\""
      " \"float tex2\" [ 0.25 ]\n"));
  const std::uint32_t r = root_of(t, gpu::TEXTURE_STRIPE);
  ASSERT_NE(r, gpu::INVALID_INDEX);
  EXPECT_EQ(r - t.textures[r].first, 2u);
  for (float x : {0.5f, 1.7f, 2.9f, 3.5f, 4.4f, 6.0f}) {
    const glm::vec3 p(x, 0.3f, 0.6f);
    EXPECT_EQ(cpu::tex_eval_float(t, r, at(p)),
              std::sin(double(x)) > 0.0 ? cpu::shirley_noise(t, p) : 0.25f) << x;
  }
}

TEST(TurbulentStripe, ClosedFormAndDefaults) {
  const SceneTables t = textured(rgb_use(
      "Texture \"x\" \"spectrum\" \"turbulentstripe\" \"float k1\" [ 2.5 ] \"float k2\" [ 3 ]"
      " \"float width\" [ 0.6 ] \"integer octaves\" [ 5 ]"
      " \"rgb tex1\" [ 1 0 0 ] \"rgb tex2\" [ 0 0 1 ]\n"));
  const std::uint32_t r = root_of(t, gpu::TEXTURE_TURBULENT_STRIPE);
  ASSERT_NE(r, gpu::INVALID_INDEX);
  EXPECT_EQ(t.textures[r].ip.x, 5u);
  EXPECT_EQ(t.textures[r].param[0], glm::vec4(2.5f, 3.0f, 0.6f, 0.0f));
  std::mt19937 rng(31);
  std::uniform_real_distribution<float> U(-4.0f, 4.0f);
  for (int i = 0; i < 3000; ++i) {
    const glm::vec3 p(U(rng), U(rng), U(rng));
    const double a = 2.5 * double(p.z) + double(cpu::shirley_turbulence(t, 3.0f * p, 5));
    const double tt = 0.5 * (1.0 + std::sin(a / double(0.6f)));
    const glm::vec3 got = cpu::tex_eval_rgb(t, r, at(p));
    EXPECT_NEAR(got.x, tt, 2e-5);  // t goes with tex1 (Shirley's order)
    EXPECT_EQ(got.y, 0.0f);
    EXPECT_NEAR(got.z, 1.0 - tt, 2e-5);
  }
  // Defaults: k1 = k2 = w = 1, 8 octaves, tex1 1, tex2 0; with octaves 0 it is the smooth
  // stripe along z: (1 + sin(z)) / 2.
  const SceneTables d = textured(float_use(
      "Texture \"x\" \"float\" \"turbulentstripe\" \"integer octaves\" [ 0 ]\n"));
  const std::uint32_t rd = root_of(d, gpu::TEXTURE_TURBULENT_STRIPE);
  ASSERT_NE(rd, gpu::INVALID_INDEX);
  EXPECT_EQ(d.textures[rd].param[0], glm::vec4(1.0f, 1.0f, 1.0f, 0.0f));
  for (int i = 0; i < 1000; ++i) {
    const glm::vec3 p(U(rng), U(rng), U(rng));
    EXPECT_NEAR(cpu::tex_eval_float(d, rd, at(p)), 0.5 * (1.0 + std::sin(double(p.z))), 2e-6);
  }
  const SceneTables e = textured(float_use("Texture \"x\" \"float\" \"turbulentstripe\"\n"));
  EXPECT_EQ(e.textures[root_of(e, gpu::TEXTURE_TURBULENT_STRIPE)].ip.x, 8u);
  EXPECT_NE(e.features & gpu::FEATURE_TEX_NOISE, 0u);
  EXPECT_NE(e.features2 & gpu::FEATURE2_TEX_SHIRLEY, 0u);
}

// ---- image arrays (interpimage) --------------------------------------------------------------

/// Tables holding one nx x ny image (values by column i and row j from the *bottom*, as the
/// seed counts them) as one MipLevel, and an interpimage instruction of \p mode on uv.
struct Interp {
  SceneTables s;
  std::uint32_t root = 0;
  int nx, ny;
  std::vector<float> c;  // c[j * nx + i], j from the bottom
  Interp(int nx_, int ny_, std::uint32_t mode, const std::function<float(int, int)>& f)
      : nx(nx_), ny(ny_) {
    s.globals.tex_tables = texture_shared_tables(s.tex_data);
    gpu::MipLevel l{0u, std::uint32_t(nx), std::uint32_t(ny), 1u};
    s.mip_levels.push_back(l);
    c.resize(std::size_t(nx * ny));
    s.texels.resize(std::size_t(nx * ny));
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        c[std::size_t(j * nx + i)] = f(i, j);
        s.texels[std::size_t((ny - 1 - j) * nx + i)] = f(i, j);  // stored top row first
      }
    gpu::Texture t{};
    t.type = gpu::TEXTURE_IMAGE_INTERP;
    t.flags = gpu::MAPPING_UV | gpu::TEXFLAG_FLOAT;
    t.image = 0;
    t.ip.x = mode;
    t.map[0] = glm::vec4(1.0f, 1.0f, 0.0f, 0.0f);
    t.xform = glm::mat4(1.0f);
    s.textures.push_back(t);
  }
  float operator()(float X, float Y) const {  // at image coordinates (X, Y) = (s nx, t ny)
    return cpu::tex_eval_float(s, root, at_uv(glm::vec2(X / float(nx), Y / float(ny))));
  }
  float cij(int i, int j) const {
    i = ((i % nx) + nx) % nx;
    j = ((j % ny) + ny) % ny;
    return c[std::size_t(j * nx + i)];
  }
};

TEST(InterpImage, NearestReturnsTheLowerLeftSample) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<float> V(0.0f, 1.0f);
  std::vector<float> vals(7 * 5);
  for (float& v : vals) v = V(rng);
  const Interp im(7, 5, 0u, [&](int i, int j) { return vals[std::size_t(j * 7 + i)]; });
  std::uniform_real_distribution<float> U(-3.0f, 3.0f);
  for (int n = 0; n < 5000; ++n) {
    const glm::vec2 st(U(rng), U(rng));  // tiles: the integer part of (s, t) is dropped
    const float X = st.x * 7.0f, Y = st.y * 5.0f;
    const float got = cpu::tex_eval_float(im.s, 0, at_uv(st));
    EXPECT_EQ(got, im.cij(int(std::floor(X)), int(std::floor(Y)))) << st.x << " " << st.y;
  }
}

TEST(InterpImage, BilinearReproducesALinearRampBetweenSamples) {
  // c(i, j) = 3 i + 5 j (j from the bottom); exact at dyadic points inside the image (no
  // wrapped cell), within rounding elsewhere.
  const Interp im(6, 4, 1u, [](int i, int j) { return float(3 * i + 5 * j); });
  for (int a = 0; a <= 40; ++a)
    for (int b = 0; b <= 24; ++b) {
      const float X = float(a) / 8.0f, Y = float(b) / 8.0f;  // [0, 5] x [0, 3]
      EXPECT_EQ(im(X, Y), 3.0f * X + 5.0f * Y) << X << " " << Y;
    }
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  for (int n = 0; n < 5000; ++n) {
    const float X = 5.0f * U(rng), Y = 3.0f * U(rng);
    EXPECT_NEAR(im(X, Y), 3.0 * X + 5.0 * Y, 2e-5) << X << " " << Y;
  }
  // The last column interpolates towards the first (tiling).
  EXPECT_NEAR(im(5.5f, 0.0f), 0.5 * 15.0 + 0.5 * 0.0, 1e-6);
}

TEST(InterpImage, HermiteKeepsConstantsAndHasZeroSlopeAtSamples) {
  const Interp k(5, 3, 2u, [](int, int) { return 0.3f; });
  std::mt19937 rng(43);
  std::uniform_real_distribution<float> U(-2.0f, 2.0f);
  for (int n = 0; n < 5000; ++n) {
    const glm::vec2 st(U(rng), U(rng));
    EXPECT_NEAR(cpu::tex_eval_float(k.s, 0, at_uv(st)), 0.3f, 2e-7f);
  }
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_EQ(k(float(i), float(j)), 0.3f);  // exact at samples
  // A random image: at every sample hermite is the sample; its one-sided slopes in X vanish
  // there (O(h)), while bilinear's are the neighbour differences.
  std::vector<float> vals(8 * 6);
  std::uniform_real_distribution<float> V(0.0f, 1.0f);
  for (float& v : vals) v = V(rng);
  auto f = [&](int i, int j) { return vals[std::size_t(j * 8 + i)]; };
  const Interp h(8, 6, 2u, f), b(8, 6, 1u, f);
  const float d = 1.0f / 256.0f;
  int steep = 0;
  for (int i = 1; i < 7; ++i)
    for (int j = 1; j < 5; ++j) {
      const float X = float(i), Y = float(j) + 0.5f;
      EXPECT_EQ(h(X, float(j)), f(i, j));
      const float right_h = (h(X + d, Y) - h(X, Y)) / d, left_h = (h(X, Y) - h(X - d, Y)) / d;
      const float right_b = (b(X + d, Y) - b(X, Y)) / d;
      EXPECT_LT(std::fabs(right_h), 0.03f) << i << " " << j;
      EXPECT_LT(std::fabs(left_h), 0.03f) << i << " " << j;
      // bilinear slope at Y = j + 1/2: the mean of the two rows' differences
      const float expect_b = 0.5f * ((f(i + 1, j) - f(i, j)) + (f(i + 1, j + 1) - f(i, j + 1)));
      EXPECT_NEAR(right_b, expect_b, 1e-3f);
      steep += std::fabs(expect_b) > 0.1f;
    }
  EXPECT_GT(steep, 5);  // the image does have slopes that hermite flattens
}

TEST(InterpImage, ParsesLoadsOneLevelAndSharesTheDecodedImage) {
  // A 3 x 2 grey PFM (rows stored bottom to top in the file): bottom row 1 2 3, top 4 5 6.
  const fs::path f = temp_dir() / "ramp.pfm";
  {
    std::ofstream o(f, std::ios::binary);
    o << "Pf\n3 2\n-1\n";
    const float v[6] = {1, 2, 3, 4, 5, 6};
    o.write(reinterpret_cast<const char*>(v), sizeof v);
  }
  const std::string defs =
      "Texture \"x\" \"float\" \"interpimage\" \"string filename\" \"ramp.pfm\""
      " \"string interpolation\" \"nearest\"\n"
      "Texture \"y\" \"spectrum\" \"interpimage\" \"string filename\" \"ramp.pfm\""
      " \"float uscale\" [ 2 ]\n"
      "Texture \"z\" \"spectrum\" \"imagemap\" \"string filename\" \"ramp.pfm\"\n"
      "Material \"coateddiffuse\" \"texture roughness\" \"x\" \"texture reflectance\" \"y\"\n"
      "Shape \"sphere\"\n"
      "Material \"diffuse\" \"texture reflectance\" \"z\"\nShape \"sphere\"\n";
  const Scene sc = load_scene_from_string(kTexturedHead + defs, "t.pbrt", temp_dir().string());
  ASSERT_EQ(sc.textures.size(), 3u);
  EXPECT_EQ(sc.images.size(), 1u);  // one decoded image for the three textures
  EXPECT_EQ(sc.textures[0].image, sc.textures[2].image);
  EXPECT_EQ(sc.textures[1].map[0], glm::vec4(2.0f, 1.0f, 0.0f, 0.0f));
  const SceneTables t = build_tables(sc);
  std::uint32_t rx = gpu::INVALID_INDEX, ry = gpu::INVALID_INDEX;
  for (std::uint32_t i = 0; i < t.textures.size(); ++i)
    if (t.textures[i].type == gpu::TEXTURE_IMAGE_INTERP)
      ((t.textures[i].flags & gpu::TEXFLAG_FLOAT) ? rx : ry) = i;
  ASSERT_NE(rx, gpu::INVALID_INDEX);
  ASSERT_NE(ry, gpu::INVALID_INDEX);
  EXPECT_EQ(t.textures[rx].ip.x, 0u);
  EXPECT_EQ(t.textures[ry].ip.x, 1u);  // bilinear by default
  EXPECT_EQ(t.textures[rx].image, t.textures[ry].image);  // one level for both
  const gpu::MipLevel& l = t.mip_levels[t.textures[rx].image];
  EXPECT_EQ(l.width, 3u);
  EXPECT_EQ(l.height, 2u);
  EXPECT_EQ(l.channels, 1u);
  EXPECT_EQ(t.texels[l.offset], 4.0f);  // stored top row first
  // (s, t) = (0, 0): the bottom-left sample; (1/3, 1/2): column 1 of the top row.
  EXPECT_EQ(cpu::tex_eval_float(t, rx, at_uv(glm::vec2(0.0f, 0.0f))), 1.0f);
  EXPECT_EQ(cpu::tex_eval_float(t, rx, at_uv(glm::vec2(0.4f, 0.6f))), 5.0f);
  // Bilinear, uscale 2: u = 1/12 is s = 1/6, X = 0.5 on the bottom row: (1 + 2) / 2.
  EXPECT_EQ(cpu::tex_eval_rgb(t, ry, at_uv(glm::vec2(1.0f / 12.0f, 0.0f))), glm::vec3(1.5f));
  EXPECT_NE(t.features2 & gpu::FEATURE2_TEX_SHIRLEY, 0u);
  // Non-finite st gives 0.
  EXPECT_EQ(cpu::tex_eval_float(t, rx, at_uv(glm::vec2(NAN, 0.0f))), 0.0f);
}

// ---- volume arrays ---------------------------------------------------------------------------

/// "float values" text of a volume of nx x ny x nz voxels with value f(i, j, k).
std::string values_of(int nx, int ny, int nz, const std::function<double(int, int, int)>& f) {
  std::string s = "[";
  char buf[64];
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        std::snprintf(buf, sizeof buf, " %.9g", f(i, j, k));
        s += buf;
      }
  return s + " ]";
}

TEST(Volume, TrilinearReproducesTrilinearFunctionsAndTiles) {
  // f = 1 + 2 i - j + 0.5 k + 0.25 i j - 0.125 j k + 0.0625 i k + 0.03125 i j k: every voxel and
  // every sum exact in float.
  auto f = [](double i, double j, double k) {
    return 1.0 + 2.0 * i - j + 0.5 * k + 0.25 * i * j - 0.125 * j * k + 0.0625 * i * k +
           0.03125 * i * j * k;
  };
  const int nx = 3, ny = 4, nz = 5;
  const SceneTables t = textured(float_use(
      "Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 3 4 5 ] \"float values\" " +
      values_of(nx, ny, nz, [&](int i, int j, int k) { return f(i, j, k); }) + "\n"));
  const std::uint32_t r = root_of(t, gpu::TEXTURE_VOLUME);
  ASSERT_NE(r, gpu::INVALID_INDEX);
  EXPECT_EQ(t.textures[r].ip, glm::uvec4(0u, 3u, 4u, 5u));
  const gpu::MipLevel& l = t.mip_levels[t.textures[r].image];
  EXPECT_EQ(l.width, 3u);
  EXPECT_EQ(l.height, 20u);
  EXPECT_EQ(l.channels, 1u);
  EXPECT_NE(t.features2 & gpu::FEATURE2_TEX_SHIRLEY, 0u);
  std::mt19937 rng(51);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  for (int n = 0; n < 5000; ++n) {
    // p inside the cells that do not wrap: X in [0, nx - 1), ...
    const glm::vec3 p(U(rng) * 2.0f / 3.0f, U(rng) * 3.0f / 4.0f, U(rng) * 4.0f / 5.0f);
    const double X = double(p.x * 3.0f), Y = double(p.y * 4.0f), Z = double(p.z * 5.0f);
    EXPECT_NEAR(cpu::tex_eval_float(t, r, at(p)), f(X, Y, Z), 2e-5) << p.x << " " << p.y << " " << p.z;
    // Period 1: p + (a, b, c) for integers gives the same value (exact where p + 1 is).
    const glm::vec3 q = p + glm::vec3(1.0f, -2.0f, 3.0f);
    EXPECT_NEAR(cpu::tex_eval_float(t, r, at(q)), cpu::tex_eval_float(t, r, at(p)), 1e-4);
  }
  for (int a = 0; a < 16; ++a)
    for (int b = 0; b < 16; ++b) {
      const glm::vec3 p(float(a) / 16.0f, float(b) / 16.0f, float((a * 7 + b) % 16) / 16.0f);
      const float v = cpu::tex_eval_float(t, r, at(p));
      EXPECT_EQ(cpu::tex_eval_float(t, r, at(p + glm::vec3(1.0f, 0.0f, 0.0f))), v);
      EXPECT_EQ(cpu::tex_eval_float(t, r, at(p + glm::vec3(0.0f, -3.0f, 0.0f))), v);
      EXPECT_EQ(cpu::tex_eval_float(t, r, at(p + glm::vec3(0.0f, 0.0f, 2.0f))), v);
    }
  // Voxel (i, j, k) sits at p = (i / nx, j / ny, k / nz).
  EXPECT_EQ(cpu::tex_eval_float(t, r, at(glm::vec3(1.0f / 3.0f, 0.5f, 0.4f))), float(f(1, 2, 2)));
  EXPECT_EQ(cpu::tex_eval_float(t, r, at(glm::vec3(0.0f))), 1.0f);
  // Non-finite p gives 0.
  EXPECT_EQ(cpu::tex_eval_float(t, r, at(glm::vec3(0.1f, NAN, 0.2f))), 0.0f);
}

TEST(Volume, SpectrumVoxelsAndRawFile) {
  // 2 x 1 x 2 rgb voxels, inline and from a raw little-endian float32 file: the same texture.
  const std::vector<float> v = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0.5f, 0.5f, 0.25f};
  {
    std::ofstream o(temp_dir() / "vox.raw", std::ios::binary);
    for (float x : v) {
      std::uint32_t u;
      std::memcpy(&u, &x, 4);
      const unsigned char b[4] = {(unsigned char)u, (unsigned char)(u >> 8), (unsigned char)(u >> 16),
                                  (unsigned char)(u >> 24)};
      o.write(reinterpret_cast<const char*>(b), 4);
    }
  }
  const SceneTables a = textured(rgb_use(
      "Texture \"x\" \"spectrum\" \"volume\" \"integer resolution\" [ 2 1 2 ]"
      " \"float values\" [ 1 0 0  0 1 0  0 0 1  0.5 0.5 0.25 ]\n"));
  const SceneTables b = textured(rgb_use(
      "Texture \"x\" \"spectrum\" \"volume\" \"integer resolution\" [ 2 1 2 ]"
      " \"string filename\" \"vox.raw\"\n"));
  const std::uint32_t ra = root_of(a, gpu::TEXTURE_VOLUME), rb = root_of(b, gpu::TEXTURE_VOLUME);
  ASSERT_NE(ra, gpu::INVALID_INDEX);
  ASSERT_NE(rb, gpu::INVALID_INDEX);
  const gpu::MipLevel& la = a.mip_levels[a.textures[ra].image];
  const gpu::MipLevel& lb = b.mip_levels[b.textures[rb].image];
  EXPECT_EQ(la.channels, 3u);
  EXPECT_EQ(lb.channels, 3u);
  EXPECT_EQ(std::vector<float>(a.texels.begin() + la.offset, a.texels.begin() + la.offset + 12), v);
  EXPECT_EQ(std::vector<float>(b.texels.begin() + lb.offset, b.texels.begin() + lb.offset + 12), v);
  // Voxel (1, 0, 0) at p = (1/2, 0, 0); voxel (1, 0, 1) at (1/2, 0, 1/2).
  EXPECT_EQ(cpu::tex_eval_rgb(a, ra, at(glm::vec3(0.5f, 0.0f, 0.0f))), glm::vec3(0, 1, 0));
  EXPECT_EQ(cpu::tex_eval_rgb(b, rb, at(glm::vec3(0.5f, 0.0f, 0.5f))), glm::vec3(0.5f, 0.5f, 0.25f));
  // Halfway between voxels (0,0,0) and (1,0,0) in x, at y = 0 (ny = 1: the row wraps to itself).
  EXPECT_EQ(cpu::tex_eval_rgb(a, ra, at(glm::vec3(0.25f, 0.7f, 0.0f))), glm::vec3(0.5f, 0.5f, 0.0f));
  std::mt19937 rng(52);
  std::uniform_real_distribution<float> U(-3.0f, 3.0f);
  for (int n = 0; n < 1000; ++n) {
    const glm::vec3 p(U(rng), U(rng), U(rng));
    EXPECT_EQ(cpu::tex_eval_rgb(a, ra, at(p)), cpu::tex_eval_rgb(b, rb, at(p)));
  }
}

// ---- located errors -------------------------------------------------------------------------

TEST(ShirleyErrors, LocatedMessages) {
  // kHead is 6 lines; the body starts on line 7.
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"stripe\" \"string form\" \"zigzag\"\n"),
            "t.pbrt:7:30: error: unknown stripe form \"zigzag\" (expected sign, width or smooth)");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"stripe\" \"float width\" [ 0 ]\n"),
            "t.pbrt:7:30: error: parameter \"width\" must be > 0");
  EXPECT_EQ(error_of("Texture \"x\" \"spectrum\" \"turbulentstripe\" \"float width\" [ -1 ]\n"),
            "t.pbrt:7:42: error: parameter \"width\" must be > 0");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"solidturbulence\" \"integer octaves\" [ 31 ]\n"),
            "t.pbrt:7:39: error: parameter \"octaves\" must be <= 30");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"turbulentstripe\" \"integer octaves\" [ -2 ]\n"),
            "t.pbrt:7:39: error: parameter \"octaves\" must be >= 0");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 2 2 2 ]"
                     " \"float values\" [ 1 2 3 ]\n"),
            "t.pbrt:7:61: error: parameter \"values\" has 3 values; a 2 x 2 x 2 float volume "
            "needs 8");
  EXPECT_EQ(error_of("Texture \"x\" \"spectrum\" \"volume\" \"integer resolution\" [ 1 1 2 ]"
                     " \"float values\" [ 1 2 3 4 ]\n"),
            "t.pbrt:7:64: error: parameter \"values\" has 4 values; a 1 x 1 x 2 spectrum volume "
            "needs 6 (3 per voxel)");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 1 1 2 ]"
                     " \"float values\" [ 1 1e39 ]\n"),
            "t.pbrt:7:61: error: parameter \"values\" has a value that is not finite");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 2 2 ]"
                     " \"float values\" [ 1 2 3 4 ]\n"),
            "t.pbrt:7:30: error: parameter \"resolution\" needs 3 values (nx ny nz), got 2");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 2 0 2 ]"
                     " \"float values\" [ 1 ]\n"),
            "t.pbrt:7:30: error: parameter \"resolution\" values must be >= 1");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 1024 1024 1024 ]"
                     " \"string filename\" \"big.raw\"\n"),
            "t.pbrt:7:30: error: parameter \"resolution\": nx * ny * nz must be at most 67108864");
  // A product that would wrap a 64-bit integer is still refused.
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\""
                     " [ 2147483647 2147483647 2147483647 ] \"float values\" [ 1 ]\n"),
            "t.pbrt:7:30: error: parameter \"resolution\": nx * ny * nz must be at most 67108864");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"float values\" [ 1 ]\n"),
            "t.pbrt:7:1: error: volume texture \"x\" needs an \"integer resolution\" parameter "
            "[ nx ny nz ]");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 1 1 1 ]\n"),
            "t.pbrt:7:1: error: volume texture \"x\" needs its voxels: \"float values\" or "
            "\"string filename\"");
  const std::string missing = (temp_dir() / "missing.raw").string();
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 2 2 2 ]"
                     " \"string filename\" \"missing.raw\"\n"),
            "t.pbrt:7:61: error: cannot read volume file \"" + missing +
                "\": No such file or directory");
  {
    std::ofstream o(temp_dir() / "short.raw", std::ios::binary);
    o.write("\0\0\0\0\0\0\0\0\0\0", 10);
  }
  const std::string shortf = (temp_dir() / "short.raw").string();
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 1 1 2 ]"
                     " \"string filename\" \"short.raw\"\n"),
            "t.pbrt:7:61: error: volume file \"" + shortf + "\" has 10 bytes; a 1 x 1 x 2 "
            "float volume needs 8 (2 little-endian float32)");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"interpimage\" \"string filename\" \"a.png\""
                     " \"string interpolation\" \"bicubic\"\n"),
            "t.pbrt:7:61: error: unknown interpolation \"bicubic\" (expected nearest, bilinear "
            "or hermite)");
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"interpimage\"\n"),
            "t.pbrt:7:1: error: interpimage texture \"x\" needs a \"string filename\" parameter");
  const std::string nope = (temp_dir() / "nope.png").string();
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"interpimage\" \"string filename\" \"nope.png\"\n"),
            "t.pbrt:7:35: error: image file \"" + nope + "\": No such file or directory");
  // Good inputs parse.
  EXPECT_EQ(error_of("Texture \"x\" \"float\" \"volume\" \"integer resolution\" [ 1 1 2 ]"
                     " \"float values\" [ 1 2 ]\n"),
            "");
}

}  // namespace
}  // namespace basalt::test
