// Textures in the CPU reference (issue 8), with oracles that do not depend on the GPU twin:
// noise properties, closed-form checkerboard filtering, the program stack, pbrt-v4's dots
// swap and defaults, and the located errors of bad texture input.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/noise_check.h"
#include "common/test_util.h"
#include "cpu/noise.h"
#include "cpu/texture.h"
#include "scene/scene.h"

namespace basalt::test {
namespace {

/// Tables of kTexturedHead + \p body.
SceneTables textured(const std::string& body) { return textured_scene(body); }

/// Root instruction of the reflectance slot of material \p m.
std::uint32_t reflectance_root(const SceneTables& t, std::uint32_t m = 0) {
  return t.materials[m].texture[gpu::SLOT_DIFFUSE_REFLECTANCE / 4]
                               [gpu::SLOT_DIFFUSE_REFLECTANCE % 4];
}

/// The error message of kTexturedHead + \p body (empty if it builds).
std::string error_of(const std::string& body) { return textured_scene_error(body); }

TEST(Noise, PropertiesCpu) {
  const SceneTables t = textured("Shape \"sphere\"\n");
  check_noise_properties(pointwise([&](glm::vec3 x) { return cpu::perlin_noise(t, x); }),
                         1000000);
}

/// Improved Perlin noise in double at a point given in double (the test's own oracle: Perlin
/// 2002 with pbrt-v4's permutation from the tables, no float anywhere).
double perlin_double(const SceneTables& t, glm::dvec3 p) {
  auto perm = [&](long i) { return long(t.tex_data[t.globals.tex_tables.x + std::size_t(i)]); };
  auto grad = [&](long x, long y, long z, double dx, double dy, double dz) {
    const long h = perm(perm(perm(x) + y) + z) & 15;
    const double u = (h < 8 || h == 12 || h == 13) ? dx : dy;
    const double v = (h < 4 || h == 12 || h == 13) ? dy : dz;
    return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
  };
  auto fade = [](double x) { return x * x * x * (x * (x * 6 - 15) + 10); };
  auto lerp = [](double a, double x, double y) { return (1 - a) * x + a * y; };
  const glm::dvec3 f = glm::floor(p), d = p - f;
  const long ix = long(f.x) & 255, iy = long(f.y) & 255, iz = long(f.z) & 255;
  const double wx = fade(d.x), wy = fade(d.y), wz = fade(d.z);
  auto g = [&](int a, int b, int c) { return grad(ix + a, iy + b, iz + c, d.x - a, d.y - b, d.z - c); };
  return lerp(wz, lerp(wy, lerp(wx, g(0, 0, 0), g(1, 0, 0)), lerp(wx, g(0, 1, 0), g(1, 1, 0))),
              lerp(wy, lerp(wx, g(0, 0, 1), g(1, 0, 1)), lerp(wx, g(0, 1, 1), g(1, 1, 1))));
}

TEST(Noise, SplitPrecisionKeepsLargeCoordinates) {
  // Issue 8 item 8: noise(lambda p) for |p| up to 1e6 and the octave frequencies of fbm
  // (lambda = 1.99^i, i < 9) against the double-precision oracle. pbrt-v4's fp32 product
  // lambda p loses the lattice offset (beyond 2^24 it has none: the noise is 0 there, and
  // below it the offset is quantised to whole fractions of a cell); the split lookup keeps it.
  const SceneTables t = textured("Shape \"sphere\"\n");
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  double worst_split = 0.0, worst_fp32 = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const float range = i % 2 ? 1e6f : 1e4f;
    const glm::vec3 p(range * U(rng), range * U(rng), range * U(rng));
    float lambda = 1.0f;
    for (int k = 0; k < i % 9; ++k) lambda *= 1.99f;
    const glm::dvec3 exact = double(lambda) * glm::dvec3(p);  // exact: a float times a float
    const double ref = perlin_double(t, exact);
    worst_split = std::max(worst_split,
                           std::fabs(double(cpu::perlin_noise_scaled(t, lambda, p, true)) - ref));
    worst_fp32 = std::max(worst_fp32,
                          std::fabs(double(cpu::perlin_noise_scaled(t, lambda, p, false)) - ref));
  }
  std::printf("  noise(lambda p), |p| <= 1e6: worst error split %.3g, fp32 %.3g\n", worst_split,
              worst_fp32);
  EXPECT_LT(worst_split, 1e-5);
  // The failure the split mode fixes: pbrt-v4's fp32 lookup is off by a large part of the
  // noise's range there.
  EXPECT_GT(worst_fp32, 0.3);
  // At ordinary coordinates both modes agree with the oracle within the float evaluation of
  // the noise itself (its quintic fade cancels terms up to 15: a few 1e-6).
  for (int i = 0; i < 10000; ++i) {
    const glm::vec3 p(8.0f * U(rng), 8.0f * U(rng), 8.0f * U(rng));
    const float lambda = 1.99f;
    const double ref = perlin_double(t, double(lambda) * glm::dvec3(p));
    EXPECT_NEAR(cpu::perlin_noise_scaled(t, lambda, p, false), ref, 1e-5);
    EXPECT_NEAR(cpu::perlin_noise_scaled(t, lambda, p, true), ref, 1e-5);
  }
}

TEST(Noise, FbmKeepsOctavesTheFootprintResolves) {
  const SceneTables t = textured("Shape \"sphere\"\n");
  const glm::vec3 p(0.37f, 1.21f, -2.6f);
  // Zero footprint: all octaves; pbrt-v4's octave count clamp(-1 - log2(len^2) / 2, 0, max).
  const float all = cpu::fbm(t, p, glm::vec3(0.0f), glm::vec3(0.0f), 0.5f, 6, false);
  float manual = 0.0f, lambda = 1.0f, o = 1.0f;
  for (int i = 0; i < 6; ++i) {
    manual += o * cpu::perlin_noise(t, lambda * p);
    lambda *= 1.99f;
    o *= 0.5f;
  }
  EXPECT_FLOAT_EQ(all, manual);
  // A footprint of length 1 (log2 = 0, n = -1 -> 0 octaves) leaves only the faded partial
  // octave, whose weight SmoothStep(0, 0.3, 0.7) is 0.
  EXPECT_EQ(cpu::fbm(t, p, glm::vec3(1.0f, 0.0f, 0.0f), glm::vec3(0.0f), 0.5f, 6, false), 0.0f);
  // Turbulence with that footprint still adds 0.2 per octave left out (pbrt-v4 quirk):
  // 0.2 * (1 + 0.5 + ... + 0.5^5) plus the partial term Lerp(0, 0.2, |n|) = 0.2.
  float expect = 0.2f, w = 1.0f;
  for (int i = 0; i < 6; ++i) {
    expect += w * 0.2f;
    w *= 0.5f;
  }
  EXPECT_NEAR(cpu::turbulence(t, p, glm::vec3(1.0f, 0.0f, 0.0f), glm::vec3(0.0f), 0.5f, 6, false),
              expect, 1e-6f);
}

TEST(Checkerboard, WideFootprintAveragesItsTextures) {
  const SceneTables t = textured(
      "Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" [ 4 ] \"float vscale\" [ 4 ]"
      " \"rgb tex1\" [ 0.9 0.2 0.1 ] \"rgb tex2\" [ 0.1 0.4 0.7 ]\n"
      "Material \"diffuse\" \"texture reflectance\" \"c\"\nShape \"sphere\"\n");
  const std::uint32_t root = reflectance_root(t);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  for (int i = 0; i < 1000; ++i) {
    cpu::TextureContext c;
    c.uv = glm::vec2(U(rng), U(rng));
    // A footprint of 50 checks: the box-filtered checker is within 1/50 of the mean.
    c.dudx = 12.5f * (0.5f + U(rng));
    c.dvdy = 12.5f * (0.5f + U(rng));
    const glm::vec3 v = cpu::tex_eval_rgb(t, root, c);
    EXPECT_NEAR(v.x, 0.5f, 0.02f);
    EXPECT_NEAR(v.y, 0.3f, 0.01f);
    EXPECT_NEAR(v.z, 0.4f, 0.02f);
  }
  // Zero footprint: the point-sampled checker of pbrt-v4 (tex1 where floor(s) + floor(t) is
  // even).
  for (int i = 0; i < 1000; ++i) {
    cpu::TextureContext c;
    c.uv = glm::vec2(U(rng), U(rng));
    const int parity = (int(std::floor(4.0f * c.uv.x)) + int(std::floor(4.0f * c.uv.y))) & 1;
    const glm::vec3 v = cpu::tex_eval_rgb(t, root, c);
    EXPECT_EQ(v, parity == 0 ? glm::vec3(0.9f, 0.2f, 0.1f) : glm::vec3(0.1f, 0.4f, 0.7f));
  }
}

TEST(Checkerboard, FilteredValueIsTheTentAverage) {
  // pbrt-v4's closed form, (d(x + r) - 2 d(x) + d(x - r)) / r^2 with d the second integral of
  // the 1D checker, is the checker convolved with a tent of half-width r; the 2D weight is the
  // product of the 1D ones. Checked against numerical integration in double.
  const SceneTables t = textured(
      "Texture \"c\" \"float\" \"checkerboard\" \"float tex1\" [ 1 ] \"float tex2\" [ 0 ]\n"
      "Material \"coateddiffuse\" \"texture roughness\" \"c\"\nShape \"sphere\"\n");
  std::uint32_t root = gpu::INVALID_INDEX;
  for (std::uint32_t i = 0; i < t.textures.size(); ++i)
    if (t.textures[i].type == gpu::TEXTURE_CHECKERBOARD) root = i;
  ASSERT_NE(root, gpu::INVALID_INDEX);
  // Tent-weighted average of the +-1 checker over [x - r, x + r] (midpoint rule).
  auto tent1d = [](double x, double r) {
    const int n = 20000;
    double s = 0.0, w = 0.0;
    for (int k = 0; k < n; ++k) {
      const double y = x - r + 2.0 * r * (k + 0.5) / n;
      const double wk = 1.0 - std::fabs(y - x) / r;
      s += wk * ((static_cast<long long>(std::floor(y)) & 1) ? -1.0 : 1.0);
      w += wk;
    }
    return s / w;
  };
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    cpu::TextureContext c;
    c.uv = glm::vec2(float(8.0 * U(rng) - 4.0), float(8.0 * U(rng) - 4.0));
    c.dudx = float(0.05 + 1.5 * U(rng));
    c.dvdy = float(0.05 + 1.5 * U(rng));
    // pbrt-v4: half-width 1.5 max(|ds/dx|, |ds/dy|) in s, likewise in t.
    const double w2 = 0.5 - 0.5 * tent1d(c.uv.x, 1.5 * c.dudx) * tent1d(c.uv.y, 1.5 * c.dvdy);
    const double v = cpu::tex_eval_float(t, root, c);
    EXPECT_NEAR(v, 1.0 - w2, 1e-3) << "at uv " << c.uv.x << ", " << c.uv.y;
  }
}

TEST(TextureProgram, NestingAndPbrtDefaults) {
  const SceneTables t = textured(
      "Texture \"d\" \"spectrum\" \"dots\" \"rgb inside\" [ 1 0 0 ] \"rgb outside\" [ 0 0 1 ]\n"
      "Texture \"s\" \"spectrum\" \"scale\" \"texture tex\" \"d\" \"float scale\" [ 0.5 ]\n"
      "Texture \"m\" \"spectrum\" \"mix\" \"texture tex1\" \"s\" \"rgb tex2\" [ 0 1 0 ]"
      " \"float amount\" [ 0.25 ]\n"
      "Material \"diffuse\" \"texture reflectance\" \"m\"\nShape \"sphere\"\n");
  const std::uint32_t root = reflectance_root(t);
  ASSERT_EQ(t.textures[root].type, gpu::TEXTURE_MIX);
  // pbrt-v4's dots swap: the "outside" value shows inside the dots. Over many cells both
  // values occur, and the mix/scale arithmetic holds exactly.
  int inside = 0, outside = 0;
  for (int i = 0; i < 400; ++i) {
    cpu::TextureContext c;
    // Cell centres (pbrt-v4's dot cells are centred on integer (s, t); a dot, where the cell
    // has one, is within 0.15 of the centre and has radius 0.35).
    c.uv = glm::vec2(float(i % 20), float(i / 20));
    const glm::vec3 v = cpu::tex_eval_rgb(t, root, c);
    if (v == 0.75f * glm::vec3(0.5f, 0.0f, 0.0f) + 0.25f * glm::vec3(0, 1, 0)) ++outside;
    else if (v == 0.75f * glm::vec3(0.0f, 0.0f, 0.5f) + 0.25f * glm::vec3(0, 1, 0)) ++inside;
    else ADD_FAILURE() << "unexpected value " << v.x << " " << v.y << " " << v.z;
  }
  EXPECT_GT(inside, 20);
  EXPECT_GT(outside, 20);
}

TEST(TextureErrors, LocatedMessages) {
  EXPECT_EQ(error_of("Material \"diffuse\" \"texture reflectance\" \"nope\"\nShape \"sphere\"\n"),
            "t.pbrt:7:20: error: parameter \"reflectance\": spectrum texture \"nope\" is not "
            "defined");
  // Used before it is defined.
  EXPECT_EQ(error_of("Texture \"a\" \"spectrum\" \"scale\" \"texture tex\" \"b\"\n"
                     "Texture \"b\" \"spectrum\" \"constant\"\nShape \"sphere\"\n"),
            "t.pbrt:7:32: error: parameter \"tex\": spectrum texture \"b\" is not defined (a "
            "texture must be defined before a Texture directive uses it)");
  // A float texture where a spectrum is needed.
  EXPECT_EQ(error_of("Texture \"f\" \"float\" \"fbm\"\n"
                     "Material \"diffuse\" \"texture reflectance\" \"f\"\nShape \"sphere\"\n"),
            "t.pbrt:8:20: error: parameter \"reflectance\": a spectrum texture is needed here, "
            "but \"f\" is a float texture");
  EXPECT_EQ(error_of("Texture \"f\" \"spectrum\" \"fbm\"\n"),
            "t.pbrt:7:24: error: \"fbm\" has no spectrum texture in pbrt-v4 (texture \"f\")");
  EXPECT_EQ(error_of("Texture \"f\" \"float\" \"checkerboard\" \"integer dimension\" [ 4 ]\n"),
            "t.pbrt:7:36: error: 4 dimensional checkerboard texture not supported");
  EXPECT_EQ(error_of("Texture \"f\" \"float\" \"fbm\"\nTexture \"f\" \"float\" \"wrinkled\"\n"),
            "t.pbrt:8:1: error: redefining float texture \"f\"");
  EXPECT_EQ(error_of("Texture \"f\" \"float\" \"fbm\" \"integer octaves\" [ -1 ]\n"),
            "t.pbrt:7:27: error: parameter \"octaves\" must be >= 0");
  EXPECT_EQ(error_of("Texture \"f\" \"float\" \"bilerp\" \"string mapping\" \"cubic\"\n"),
            "t.pbrt:7:30: error: unknown texture mapping \"cubic\" (expected uv, spherical, "
            "cylindrical or planar)");
}

}  // namespace
}  // namespace basalt::test

namespace basalt::test {
namespace {

TEST(TextureFeatures, OnlyWhatTheSceneReaches) {
  // Checkerboards only: no noise, image, procedural or curved-mapping code.
  SceneTables t = textured(
      "Texture \"c\" \"spectrum\" \"checkerboard\" \"rgb tex1\" [ 1 0 0 ]\n"
      "Texture \"unused\" \"float\" \"fbm\"\n"
      "MakeNamedMaterial \"never\" \"string type\" \"conductor\" \"texture roughness\" \"unused\"\n"
      "Material \"diffuse\" \"texture reflectance\" \"c\"\nShape \"sphere\"\n");
  EXPECT_TRUE(t.features & gpu::FEATURE_TEXTURES);
  EXPECT_FALSE(t.features & (gpu::FEATURE_TEX_NOISE | gpu::FEATURE_TEX_IMAGE));
  EXPECT_FALSE(t.features & gpu::FEATURE_MAT_CONDUCTOR) << "a material no shape uses";
  EXPECT_EQ(t.features2, gpu::FEATURE2_TEX_CHECKER_AA);
  // Constant textures fold into the slot: no texture code at all, the same value.
  t = textured("Texture \"k\" \"spectrum\" \"constant\" \"rgb value\" [ 0.2 0.3 0.4 ]\n"
               "Material \"diffuse\" \"texture reflectance\" \"k\"\nShape \"sphere\"\n");
  EXPECT_FALSE(t.features & gpu::FEATURE_TEXTURES);
  EXPECT_EQ(reflectance_root(t), gpu::INVALID_INDEX);
  EXPECT_EQ(glm::vec3(t.materials[0].value[gpu::SLOT_DIFFUSE_REFLECTANCE]), glm::vec3(0.2f, 0.3f, 0.4f));
  // A spherical mapping adds its bit; noise adds the split-precision bit by default.
  t = textured("Texture \"c\" \"spectrum\" \"checkerboard\" \"string mapping\" \"spherical\"\n"
               "Texture \"f\" \"float\" \"fbm\"\n"
               "Texture \"m\" \"spectrum\" \"mix\" \"texture tex1\" \"c\" \"texture amount\" \"f\"\n"
               "Material \"diffuse\" \"texture reflectance\" \"m\"\nShape \"sphere\"\n");
  EXPECT_TRUE(t.features & gpu::FEATURE_TEX_NOISE);
  EXPECT_EQ(t.features2, gpu::FEATURE2_TEX_CHECKER_AA | gpu::FEATURE2_TEX_PROCEDURAL |
                             gpu::FEATURE2_TEX_MAP_CURVED | gpu::FEATURE2_NOISE_SPLIT);
}

// Each material's own texture families (the wavefront specialises a shade group for its
// materials' alone): noise for the fbm-scaled diffuse, the procedural family for the coated
// material's bilerp, the image and EWA bits for the conductor's image map, the bump bit for a
// displacement; none for an untextured material. Their union over the materials is the
// scene's (build_tables), less the split-precision bit that noise adds scene-wide.
TEST(TextureFeatures, OfEachMaterial) {
  const SceneTables t = textured_scene(
      "Texture \"f\" \"float\" \"fbm\"\n"
      "Texture \"s\" \"spectrum\" \"scale\" \"rgb tex\" [ 0.5 0.4 0.3 ] \"texture scale\" \"f\"\n"
      "Material \"diffuse\" \"texture reflectance\" \"s\"\nShape \"sphere\"\n"
      "Texture \"b\" \"spectrum\" \"bilerp\" \"rgb v00\" [ 0.9 0.1 0.1 ]\n"
      "Material \"coateddiffuse\" \"texture reflectance\" \"b\"\nShape \"sphere\"\n"
      "Texture \"i\" \"float\" \"imagemap\" \"string filename\" \"data/tex-card.png\" "
      "\"string filter\" \"ewa\"\n"
      "Material \"conductor\" \"texture roughness\" \"i\"\nShape \"sphere\"\n"
      "Texture \"d\" \"float\" \"bilerp\" \"float v00\" 0.01\n"
      "Material \"diffuse\" \"texture displacement\" \"d\"\nShape \"sphere\"\n"
      "Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.5 0.5 ]\nShape \"sphere\"\n",
      source_path("scenes"));
  ASSERT_EQ(t.materials.size(), 5u);
  using gpu::FEATURE_TEXTURES;
  const glm::uvec2 fbm = material_texture_features(t, t.materials[0]);
  EXPECT_EQ(fbm, glm::uvec2(FEATURE_TEXTURES | gpu::FEATURE_TEX_NOISE,
                            gpu::FEATURE2_TEX_PROCEDURAL));  // fbm and the scale combinator
  EXPECT_EQ(material_texture_features(t, t.materials[1]),
            glm::uvec2(FEATURE_TEXTURES, gpu::FEATURE2_TEX_PROCEDURAL));
  EXPECT_EQ(material_texture_features(t, t.materials[2]),
            glm::uvec2(FEATURE_TEXTURES | gpu::FEATURE_TEX_IMAGE, gpu::FEATURE2_TEX_EWA));
  EXPECT_EQ(material_texture_features(t, t.materials[3]),
            glm::uvec2(FEATURE_TEXTURES, gpu::FEATURE2_TEX_PROCEDURAL | gpu::FEATURE2_BUMP));
  EXPECT_EQ(material_texture_features(t, t.materials[4]), glm::uvec2(0u));
  glm::uvec2 all(0u);
  for (const gpu::Material& m : t.materials) all |= material_texture_features(t, m);
  EXPECT_EQ(all.x, t.features & (FEATURE_TEXTURES | gpu::FEATURE_TEX_NOISE | gpu::FEATURE_TEX_IMAGE));
  EXPECT_EQ(all.y, t.features2 & ~gpu::FEATURE2_NOISE_SPLIT);
}

}  // namespace
}  // namespace basalt::test
