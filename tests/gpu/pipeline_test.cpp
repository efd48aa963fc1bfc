// The Vulkan side itself: validation errors are caught, the specialised pipeline renders
// exactly what the all-features pipeline renders, and the trace stage hits what the probe hits.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <stdexcept>

#include "common/test_util.h"
#include "cpu/intersect.h"
#include "scene/materials.h"
#include "shaders/render_lean.spv.h"
#include "shaders/render_lean_plain.spv.h"
#include "shaders/wavefront_shade.spv.h"
#include "shaders/wavefront_shade_plain.spv.h"
#include "shaders/trace.spv.h"
#include "vk/gpu_renderer.h"
#include "vk/specialise.h"

namespace basalt::test {
namespace {

// A deliberate misuse (a zero-sized buffer) is counted, so a test that checks the count
// would fail on a real validation error. Skipped only when validation is off (outside ctest).
TEST(Validation, ErrorsAreCounted) {
  if (!vkx::Context::validation_requested()) GTEST_SKIP() << "BASALT_VALIDATION is not 1";
  vkx::Context ctx("lavapipe", true);
  ASSERT_EQ(ctx.validation_errors(), 0u);
  vk::Buffer b = ctx.device.createBuffer(
      {.size = 0, .usage = vk::BufferUsageFlagBits::eStorageBuffer});
  EXPECT_GE(ctx.validation_errors(), 1u);
  if (b) ctx.device.destroyBuffer(b);
}

// For each scene, the image of the pipeline specialised to the scene's features equals,
// bit for bit, the image of the pipeline with every feature compiled in: specialisation
// removes code, never changes results.
TEST(Specialisation, SameImageAsAllFeatures) {
  for (const char* file : {"scenes/cornell-box.pbrt", "scenes/spheres-lights.pbrt"}) {
    SceneTables t = tables_from_file(source_path(file), 64, 48);
    ASSERT_NE(t.features, 0xffffffffu);
    auto& ctx = gpu_context();
    const std::size_t before = ctx.validation_errors();
    std::vector<glm::vec4> a, b;
    {
      vkx::GpuRenderer gpu(ctx, t, t.features, vkx::ShaderVariant::full);
      gpu.render(0, 2);
      a = gpu.accum();
    }
    {
      vkx::GpuRenderer gpu(ctx, t, 0xffffffffu);
      gpu.render(0, 2);
      b = gpu.accum();
    }
    EXPECT_EQ(ctx.validation_errors(), before);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(glm::vec4)), 0) << file;
  }
}

// Renders 2 samples per pixel of \p t with the pipeline specialised for \p features built
// from render shader \p variant; checks that the variant is the one asked for.
std::vector<glm::vec4> render_variant(const SceneTables& t, std::uint32_t features,
                                      vkx::ShaderVariant variant, const char* expected) {
  vkx::GpuRenderer gpu(gpu_context(), t, features, variant);
  EXPECT_EQ(gpu.variant, expected);
  gpu.render(0, 2);
  return gpu.accum();
}

// The table formats change which loads a ray makes, never a result: a scene renders the same
// image, bit for bit, without the leaf_prims table (leaf-ordered triangle positions; as it must
// when the table does not fit one binding) and without the geometry tables' texel views
// (TEXEL_TABLES = 0; as it must when one is beyond the device's maxTexelBufferElements).
TEST(TableFormats, SameImageWithoutLeafPrimsOrTexelViews) {
  for (const char* file : {"scenes/cornell-box.pbrt", "scenes/spheres-lights.pbrt"}) {
    const SceneTables t = tables_from_file(source_path(file), 64, 48);
    std::vector<glm::vec4> images[3];
    for (int k = 0; k < 3; ++k) {
      vkx::GpuRenderer::leaf_prims_max_bytes = k == 1 ? 1 : 0;
      vkx::GpuRenderer::texel_views_max_texels = k == 2 ? 1 : 0;
      vkx::GpuRenderer gpu(gpu_context(), t);
      vkx::GpuRenderer::leaf_prims_max_bytes = 0;
      vkx::GpuRenderer::texel_views_max_texels = 0;
      EXPECT_EQ(gpu.leaf_prims, k != 1) << file;
      EXPECT_EQ(gpu.texel_tables, k != 2) << file;
      gpu.render(0, 2);
      images[k] = gpu.accum();
    }
    for (int k = 1; k < 3; ++k) {
      ASSERT_EQ(images[k].size(), images[0].size());
      EXPECT_EQ(std::memcmp(images[k].data(), images[0].data(), images[0].size() * sizeof(glm::vec4)), 0)
          << file << (k == 1 ? ": without leaf_prims" : ": without texel views");
    }
  }
}

// For scenes of diffuse, Oren-Nayar and measured materials only the lean render shader (only
// those compiled in) is the automatic choice and renders, bit for bit, what the full shader
// renders, specialised or with every feature (materials-diffuse: matte spheres with sigma 0,
// 20 and 60; materials-measured: MERL tables).
TEST(LeanVariant, SameImageAsFullForDiffuseScenes) {
  for (const char* file : {"scenes/cornell-box.pbrt", "scenes/spheres-lights.pbrt",
                           "scenes/igea-infinite.pbrt", "scenes/materials-diffuse.pbrt",
                           "scenes/materials-measured.pbrt"}) {
    SceneTables t = tables_from_file(source_path(file), 64, 48);
    EXPECT_TRUE(vkx::GpuRenderer::lean_suffices(t.features)) << file;
    auto& ctx = gpu_context();
    const std::size_t before = ctx.validation_errors();
    auto lean = render_variant(t, t.features, vkx::ShaderVariant::automatic, "lean");
    auto full = render_variant(t, t.features, vkx::ShaderVariant::full, "full");
    auto all = render_variant(t, 0xffffffffu, vkx::ShaderVariant::automatic, "full");
    EXPECT_EQ(ctx.validation_errors(), before);
    ASSERT_EQ(lean.size(), full.size());
    ASSERT_EQ(lean.size(), all.size());
    EXPECT_EQ(std::memcmp(lean.data(), full.data(), lean.size() * sizeof(glm::vec4)), 0) << file;
    EXPECT_EQ(std::memcmp(lean.data(), all.data(), lean.size() * sizeof(glm::vec4)), 0) << file;
  }
}

// Textures and image lights on diffuse surfaces keep the lean shader, bit for bit.
TEST(LeanVariant, SameImageAsFullForTexturedDiffuseScenes) {
  SceneTables t = tables_from_string(
      "LookAt 0 2 -6  0 0.5 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n"
      "Film \"rgb\" \"integer xresolution\" 48 \"integer yresolution\" 32\nWorldBegin\n"
      "LightSource \"infinite\" \"string filename\" \"data/env-sky.exr\"\n"
      "Texture \"f\" \"float\" \"fbm\"\n"
      "Texture \"i\" \"spectrum\" \"imagemap\" \"string filename\" \"data/tex-card.png\" "
      "\"string filter\" \"ewa\"\n"
      "Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 8 \"float vscale\" 8 "
      "\"texture tex1\" \"i\" \"rgb tex2\" [ 0.1 0.2 0.3 ]\n"
      "Material \"diffuse\" \"texture reflectance\" \"c\"\n"
      "Shape \"trianglemesh\" \"integer indices\" [ 0 1 2 0 2 3 ] \"point3 P\" "
      "[ -5 0 -5 5 0 -5 5 0 5 -5 0 5 ] \"point2 uv\" [ 0 0 1 0 1 1 0 1 ]\n"
      "Texture \"s\" \"spectrum\" \"scale\" \"rgb tex\" [ 0.8 0.6 0.4 ] \"texture scale\" \"f\"\n"
      "Material \"diffuse\" \"texture reflectance\" \"s\"\n"
      "Shape \"sphere\" \"float radius\" 0.8\n");
  ASSERT_TRUE(t.features & gpu::FEATURE_TEXTURES);
  EXPECT_TRUE(vkx::GpuRenderer::lean_suffices(t.features));
  auto lean = render_variant(t, t.features, vkx::ShaderVariant::automatic, "lean");
  auto full = render_variant(t, t.features, vkx::ShaderVariant::full, "full");
  ASSERT_EQ(lean.size(), full.size());
  EXPECT_EQ(std::memcmp(lean.data(), full.data(), lean.size() * sizeof(glm::vec4)), 0);
}

// The wavefront's image of samples [0, 2) of a scene, its ray count and whether it made the
// escape stage.
struct WavefrontRun {
  std::vector<glm::vec4> image;
  std::uint64_t rays = 0;
  bool escape_stage = false;
};

// Renders samples [0, 2) of t with the megakernel (every feature; both samples in one pass)
// and with the wavefront in waves of 1000 slots, and expects the same image bit for bit, the
// same ray count, no non-finite sample and a silent validation layer.
WavefrontRun wavefront_against_megakernel(const SceneTables& t) {
  auto& ctx = gpu_context();
  const std::size_t before = ctx.validation_errors();
  std::vector<glm::vec4> images[2];
  std::uint64_t rays[2];
  bool escape_stage[2];
  for (int k = 0; k < 2; ++k) {
    vkx::GpuRenderer::wavefront_capacity = 1000;
    vkx::GpuRenderer gpu(ctx, t, t.features,
                         k == 0 ? vkx::ShaderVariant::full : vkx::ShaderVariant::wavefront);
    vkx::GpuRenderer::wavefront_capacity = 262144;
    EXPECT_EQ(gpu.variant, k == 0 ? "full" : "wavefront");
    gpu.render(0, 2);
    images[k] = gpu.accum();
    rays[k] = gpu.rays();
    escape_stage[k] = gpu.escape_stage;
    EXPECT_EQ(gpu.nonfinite_samples(), 0u);
  }
  EXPECT_EQ(ctx.validation_errors(), before);
  EXPECT_FALSE(escape_stage[0]);  // the megakernel has no stages
  EXPECT_EQ(images[0].size(), images[1].size());
  if (images[0].size() == images[1].size()) {
    EXPECT_EQ(
        std::memcmp(images[0].data(), images[1].data(), images[0].size() * sizeof(glm::vec4)), 0);
  }
  EXPECT_EQ(rays[0], rays[1]);
  return {images[1], rays[1], escape_stage[1]};
}

// The wavefront stages (shaders/wavefront.comp) run the megakernel's own path code
// (integrator.glsl: path_start, path_bounce, path_escape) cut at the intersection, a shade
// pipeline per material type: they give the megakernel's image bit for bit (both add a pixel's
// samples one at a time; the megakernel renders both samples in one pass) and count the same
// rays. The scene routes every kind
// of path the stages handle: four material types, a stochastic mix (its pipeline has all the
// scene's materials), an interface (passed through without a bounce), an area light, misses to
// an infinite light, ends by depth and by roulette; in waves of 1000 slots, so that a sample of
// the 1536 slots takes two waves. The CPU reference agrees as in the conformance tests.
TEST(Wavefront, SameImageAsTheMegakernel) {
  const SceneTables t = tables_from_string(
      scene_head("0 2 -6  0 0.6 0  0 1 0", 40, 48, 32, 2, 5) +
      "LightSource \"infinite\" \"rgb L\" [ 0.4 0.45 0.5 ]\n"
      "AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 6 6 6 ]\n"
      "  Translate 0 3 -1\n  Shape \"sphere\" \"float radius\" 0.3\nAttributeEnd\n"
      "MakeNamedMaterial \"white\" \"string type\" \"diffuse\" \"rgb reflectance\" [ 0.7 0.7 0.7 ]\n"
      "MakeNamedMaterial \"metal\" \"string type\" \"conductor\" \"float roughness\" 0.2\n"
      "MakeNamedMaterial \"glass\" \"string type\" \"dielectric\"\n"
      "MakeNamedMaterial \"mixed\" \"string type\" \"mix\" \"string materials\" [ \"white\" \"metal\" ]\n"
      "MakeNamedMaterial \"none\" \"string type\" \"interface\"\n"
      "NamedMaterial \"white\"\n"
      "Shape \"trianglemesh\" \"integer indices\" [ 0 1 2 0 2 3 ] \"point3 P\" "
      "[ -5 0 -5 5 0 -5 5 0 5 -5 0 5 ]\n"
      "AttributeBegin\n  NamedMaterial \"metal\"\n  Translate -1.6 0.7 0\n"
      "  Shape \"sphere\" \"float radius\" 0.7\nAttributeEnd\n"
      "AttributeBegin\n  NamedMaterial \"glass\"\n  Translate 0 0.7 0\n"
      "  Shape \"sphere\" \"float radius\" 0.7\nAttributeEnd\n"
      "AttributeBegin\n  NamedMaterial \"mixed\"\n  Translate 1.6 0.7 0\n"
      "  Shape \"sphere\" \"float radius\" 0.7\nAttributeEnd\n"
      "AttributeBegin\n  NamedMaterial \"none\"\n  Translate 0 0.7 -1.2\n"
      "  Shape \"sphere\" \"float radius\" 0.4\nAttributeEnd\n");
  const WavefrontRun run = wavefront_against_megakernel(t);
  EXPECT_GT(run.rays, 2u * 48u * 32u);  // camera rays and more
  const std::vector<glm::vec3> gpu = resolve(run.image, 48, 32).pixels;
  const std::vector<glm::vec3> cpu = render(Side::Cpu, t, 2);
  ASSERT_TRUE(all_finite(gpu));
  ASSERT_GT(mean(cpu), 0.0);
  // A mix's choice may flip with the last bit (conformance_test.cpp): at most 3 pixels.
  EXPECT_GE(agreeing_fraction(cpu, gpu, 1e-3f), 1.0 - 3.0 / (48 * 32));
}

// With an image infinite light the wavefront adds the escaped radiance in a stage of its own
// (wavefront.comp stage 2, fed by the extend stage's escape list) instead of in the extend
// stage: the image and the ray count are still the megakernel's, bit for bit. envmap.pbrt at
// 48 x 32, 2 samples (misses at every depth: camera rays to the sky, bounces off the spheres);
// waves of 1000 slots. A scene without one keeps the escape in the extend stage.
TEST(Wavefront, EscapeStageGivesTheMegakernelsImage) {
  const SceneTables t = tables_from_file(source_path("scenes/envmap.pbrt"), 48, 32);
  ASSERT_NE(t.features & gpu::FEATURE_LIGHT_INFINITE_IMAGE, 0u);
  const WavefrontRun run = wavefront_against_megakernel(t);
  EXPECT_TRUE(run.escape_stage);
  double sum = 0.0;
  for (const glm::vec4& v : run.image) sum += v.x + v.y + v.z;
  EXPECT_GT(sum, 0.0);
  auto& ctx = gpu_context();
  const std::size_t before = ctx.validation_errors();
  const SceneTables plain_sky = tables_from_file(source_path("scenes/materials-conductors.pbrt"), 16, 16);
  vkx::GpuRenderer other(ctx, plain_sky, plain_sky.features, vkx::ShaderVariant::wavefront);
  EXPECT_FALSE(other.escape_stage);
  EXPECT_EQ(ctx.validation_errors(), before);
}

// The megakernel's passes are sized by the time the last one took, so their sizes vary from run
// to run; each pixel adds its samples one at a time in sample order (render.comp starts from its
// accum value), so the image is the same bits however the passes fall. spheres-lights at 48 x 32
// (1,536 slots), 8 samples; the first pass is 4,096 units (2 samples of every slot), then: one
// pass of the other 6, passes of one tile (64 slots) and one sample, or two calls of 3 and 5.
TEST(Megakernel, PassSizesDoNotChangeTheImage) {
  const SceneTables t = tables_from_file(source_path("scenes/spheres-lights.pbrt"), 48, 32);
  auto& ctx = gpu_context();
  const std::size_t before = ctx.validation_errors();
  std::vector<glm::vec4> images[3];
  for (int k = 0; k < 3; ++k) {
    vkx::GpuRenderer gpu(ctx, t);
    ASSERT_NE(gpu.variant, "wavefront");
    if (k == 0) gpu.render(0, 8, {}, 1e9);
    if (k == 1) gpu.render(0, 8, {}, 1e-9);
    if (k == 2) {
      gpu.render(0, 3);
      gpu.render(3, 5);
    }
    images[k] = gpu.accum();
    EXPECT_EQ(gpu.nonfinite_samples(), 0u);
  }
  EXPECT_EQ(ctx.validation_errors(), before);
  for (int k = 1; k < 3; ++k) {
    ASSERT_EQ(images[0].size(), images[k].size());
    EXPECT_EQ(
        std::memcmp(images[0].data(), images[k].data(), images[0].size() * sizeof(glm::vec4)), 0)
        << k;
  }
  double weight = 0.0;  // every pixel got its 8 samples
  for (const glm::vec4& v : images[0]) weight += v.w;
  EXPECT_EQ(weight, 8.0 * 48 * 32);
}

// A wave runs (sample, slot) pairs in order, so a small image's wave holds several samples
// and a wave may end in the middle of a sample; the host adds the paths' radiance to the
// pixels in path order after the wave: the image and the ray count are those of waves of one
// sample, bit for bit. materials-coated at 48 x 32 (1,536 slots), 8 samples: waves of 1,536
// pairs (one sample each), of 1,000 (crossing the samples' ends) and one wave of 12,288.
TEST(Wavefront, WavesOfSeveralSamplesGiveTheSameImage) {
  const SceneTables t = tables_from_file(source_path("scenes/materials-coated.pbrt"), 48, 32);
  auto& ctx = gpu_context();
  const std::size_t before = ctx.validation_errors();
  const std::uint32_t capacities[3] = {48 * 32, 1000, 262144};
  std::vector<glm::vec4> images[3];
  std::uint64_t rays[3];
  for (int k = 0; k < 3; ++k) {
    vkx::GpuRenderer::wavefront_capacity = capacities[k];
    vkx::GpuRenderer gpu(ctx, t, t.features, vkx::ShaderVariant::wavefront);
    vkx::GpuRenderer::wavefront_capacity = 262144;
    ASSERT_EQ(gpu.variant, "wavefront");
    gpu.render(0, 8);
    images[k] = gpu.accum();
    rays[k] = gpu.rays();
  }
  EXPECT_EQ(ctx.validation_errors(), before);
  for (int k = 1; k < 3; ++k) {
    ASSERT_EQ(images[0].size(), images[k].size());
    EXPECT_EQ(
        std::memcmp(images[0].data(), images[k].data(), images[0].size() * sizeof(glm::vec4)), 0)
        << capacities[k];
    EXPECT_EQ(rays[0], rays[k]) << capacities[k];
  }
  double weight = 0.0;  // every pixel got its 8 samples
  for (const glm::vec4& v : images[2]) weight += v.w;
  EXPECT_EQ(weight, 8.0 * 48 * 32);
}

// A path passes through at most 64 interfaces (pbrt-v4's SkipIntersection; the crossings
// do not count as bounces) and ends at the 65th. The wavefront runs one extend and one shade
// dispatch per crossing, within its iteration bound (2 + maxdepth + 64), and agrees with the
// megakernel bit for bit: behind 60 interface quads the camera sees the sky (radiance 1), behind
// 70 its paths end unlit.
TEST(Wavefront, SameImageThroughSixtyFourInterfaces) {
  for (int quads : {60, 70}) {
    std::string text = scene_head("0 0 -1  0 0 1  0 1 0", 20, 8, 8, 1, 5) +
                       "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n"
                       "MakeNamedMaterial \"none\" \"string type\" \"interface\"\n"
                       "NamedMaterial \"none\"\n";
    for (int k = 0; k < quads; ++k) {
      const std::string z = std::to_string(1 + k);
      text += "Shape \"trianglemesh\" \"integer indices\" [ 0 1 2 0 2 3 ] \"point3 P\" [ -100 -100 " +
              z + " 100 -100 " + z + " 100 100 " + z + " -100 100 " + z + " ]\n";
    }
    const SceneTables t = tables_from_string(text);
    auto& ctx = gpu_context();
    const std::size_t before = ctx.validation_errors();
    std::vector<glm::vec4> images[2];
    for (int k = 0; k < 2; ++k) {
      vkx::GpuRenderer gpu(ctx, t, t.features,
                           k == 0 ? vkx::ShaderVariant::full : vkx::ShaderVariant::wavefront);
      gpu.render(0, 1);
      images[k] = gpu.accum();
    }
    EXPECT_EQ(ctx.validation_errors(), before);
    ASSERT_EQ(images[0].size(), 64u);
    EXPECT_EQ(std::memcmp(images[0].data(), images[1].data(), 64 * sizeof(glm::vec4)), 0) << quads;
    for (const glm::vec4& px : images[1]) {
      EXPECT_EQ(px.w, 1.0f);
      EXPECT_NEAR(px.x, quads < 64 ? 1.0f : 0.0f, 1e-5f) << quads << " interfaces";
    }
  }
}

// Renders 2 samples per pixel of \p t with the switch \p toggle (a static of GpuRenderer) off,
// then on (it is left on, its default), runs \p check on each renderer, and expects the same
// image bit for bit and no validation error.
void expect_same_image_both_ways(
    const SceneTables& t, bool& toggle, const std::function<void(vkx::GpuRenderer&, bool)>& check,
    const std::string& what, vkx::ShaderVariant which = vkx::ShaderVariant::automatic) {
  auto& ctx = gpu_context();
  const std::size_t before = ctx.validation_errors();
  std::vector<glm::vec4> image[2];
  for (int on = 0; on < 2; ++on) {
    toggle = on == 1;
    vkx::GpuRenderer gpu(ctx, t, t.features, which);
    check(gpu, on == 1);
    gpu.render(0, 2);
    image[on] = gpu.accum();
  }
  toggle = true;
  EXPECT_EQ(ctx.validation_errors(), before) << what;
  ASSERT_EQ(image[0].size(), image[1].size()) << what;
  EXPECT_EQ(std::memcmp(image[0].data(), image[1].data(), image[0].size() * sizeof(glm::vec4)),
            0)
      << what;
}

// Each shade group is specialised for its own materials' texture families (GpuRenderer::
// wf_group_words): in bump.pbrt the layered group (a coated diffuse bumped by an image map)
// gets the image and bump code but no noise, the other group (diffuse and conductors bumped by
// noise) the noise but no image; FEATURE_TEXTURES stays the scene's in both. Both render, bit
// for bit, what the groups render specialised for all the scene's families.
TEST(Wavefront, ShadeGroupsGetTheirOwnTextureFamilies) {
  SceneTables t = tables_from_file(source_path("scenes/bump.pbrt"), 48, 32);
  ASSERT_TRUE(t.features & gpu::FEATURE_TEX_NOISE);
  ASSERT_TRUE(t.features & gpu::FEATURE_TEX_IMAGE);
  expect_same_image_both_ways(t, vkx::GpuRenderer::group_texture_features,
                              [](vkx::GpuRenderer& gpu, bool own) {
    ASSERT_EQ(gpu.variant, "wavefront");
    const auto [coated, coated2] = gpu.shade_feature_words(gpu::MATERIAL_COATED_DIFFUSE);
    const auto [diffuse, diffuse2] = gpu.shade_feature_words(gpu::MATERIAL_DIFFUSE);
    EXPECT_TRUE(coated & gpu::FEATURE_TEXTURES);
    EXPECT_TRUE(diffuse & gpu::FEATURE_TEXTURES);
    EXPECT_TRUE(coated & gpu::FEATURE_TEX_IMAGE);
    EXPECT_TRUE(coated2 & gpu::FEATURE2_BUMP);
    EXPECT_TRUE(diffuse & gpu::FEATURE_TEX_NOISE);
    EXPECT_TRUE(diffuse2 & gpu::FEATURE2_BUMP);
    EXPECT_EQ((coated & gpu::FEATURE_TEX_NOISE) != 0u, !own);
    EXPECT_EQ((diffuse & gpu::FEATURE_TEX_IMAGE) != 0u, !own);
  }, "bump.pbrt", vkx::ShaderVariant::wavefront);
}

// A scene whose only shade group holds textured and untextured types gives the untextured ones
// a pipeline of their own without the texture code (group 3): in textures-specular.pbrt the
// conductor and the dielectric (untextured) get neither the image nor the checkerboard code,
// the diffuse materials (image and checkerboard textures) both. Both render, bit for bit, what
// one pipeline for all three renders (the split follows group_texture_features).
TEST(Wavefront, UntexturedTypesGetAPipelineOfTheirOwn) {
  SceneTables t = tables_from_file(source_path("scenes/textures-specular.pbrt"), 48, 32);
  ASSERT_TRUE(t.features & gpu::FEATURE_TEX_IMAGE);
  expect_same_image_both_ways(t, vkx::GpuRenderer::group_texture_features,
                              [](vkx::GpuRenderer& gpu, bool own) {
    ASSERT_EQ(gpu.variant, "wavefront");
    const auto diffuse = gpu.shade_feature_words(gpu::MATERIAL_DIFFUSE);
    const auto conductor = gpu.shade_feature_words(gpu::MATERIAL_CONDUCTOR);
    EXPECT_EQ(gpu.shade_feature_words(gpu::MATERIAL_DIELECTRIC), conductor);
    EXPECT_TRUE(diffuse.first & gpu::FEATURE_TEX_IMAGE);
    EXPECT_TRUE(diffuse.second & gpu::FEATURE2_TEX_CHECKER_AA);
    EXPECT_EQ((conductor.first & gpu::FEATURE_TEX_IMAGE) != 0u, !own);
    EXPECT_EQ((conductor.second & gpu::FEATURE2_TEX_CHECKER_AA) != 0u, !own);
    EXPECT_EQ((conductor.first & gpu::FEATURE_MAT_DIFFUSE) != 0u, !own);
    EXPECT_EQ(diffuse == conductor, !own);
  }, "textures-specular.pbrt", vkx::ShaderVariant::wavefront);
}

// On lavapipe with Mesa's shader cache on, a scene with two shade groups has the larger of its
// two specialised shade modules compiled on a second device as well (CompileDevice) when
// basalt's cache does not have it: bump.pbrt (the layered group the larger: 446 against 383
// KB) and material-zoo.pbrt (group 0's fifteen types the larger: 436 against 339 KB) render the
// same image, bit for bit, with and without it, and the second device's work passes the
// validation layer.
TEST(Wavefront, SecondDeviceCompilesTheLargerShadeModuleAndKeepsTheImage) {
  const char* old_cache = std::getenv("BASALT_CACHE_DIR");
  const std::string saved = old_cache ? old_cache : "";
  setenv("BASALT_CACHE_DIR", "off", 1);  // a cache hit would skip the second device
  const bool expected = gpu_context().info().is_cpu && vkx::CompileDevice::shader_cache_on();
  for (const char* file : {"bump.pbrt", "material-zoo.pbrt"}) {
    SceneTables t = tables_from_file(source_path(std::string("scenes/") + file), 48, 32);
    expect_same_image_both_ways(t, vkx::GpuRenderer::parallel_compile,
                                [&](vkx::GpuRenderer& gpu, bool on) {
      ASSERT_EQ(gpu.variant, "wavefront");
      EXPECT_EQ(gpu.second_device_compiles, on && expected ? 1u : 0u) << file;
      EXPECT_EQ(gpu.second_device_materials != 0u, on && expected) << file;
      if (!gpu.second_device_materials) return;
      // Every type of the scene in the second device's group has a module at least as large
      // as every type's outside it, and both sides have one.
      std::size_t inside = 0, outside = ~std::size_t(0);
      for (const gpu::Material& m : t.materials) {
        const std::uint32_t bit = basalt::material_feature(m.type);
        if (bit == 0u) continue;
        const std::size_t words = gpu.shade_module_words(m.type);
        if (gpu.second_device_materials & bit)
          inside = std::max(inside, words);
        else
          outside = std::min(outside, words);
      }
      EXPECT_GT(inside, 0u) << file;
      EXPECT_NE(outside, ~std::size_t(0)) << file;
      EXPECT_GT(inside, outside) << file;
    }, file);
  }
  if (old_cache)
    setenv("BASALT_CACHE_DIR", saved.c_str(), 1);
  else
    unsetenv("BASALT_CACHE_DIR");
}

// On lavapipe with Mesa's shader cache on, the wavefront gives the type with the most camera
// hits its own shade pipeline when its group's pipeline holds other types' code
// (GpuRenderer::solo_pipeline), specialised for that type's material bit and texture families
// only, and made only if that leaves out more than a quarter of the group's module: the image
// is the same bits with it (made at once, so that every shade dispatch of the type runs it) as
// without, under the validation layer. With basalt's cache off its code comes from the second
// device (CompileDevice). material-zoo: the diffuse floor and walls among 15 other types;
// materials-transmission: diffuse beside diffuse transmission and translucent; bump.pbrt: a
// diffuse floor bumped by noise beside noise-bumped conductors, whose code is mostly the
// textures the diffuse floor needs too (its module 0.88 of the group's: none is made). Each
// asks for the wavefront (materials-transmission renders as a megakernel by default).
TEST(Wavefront, SoloPipelineKeepsTheImage) {
  const char* old_cache = std::getenv("BASALT_CACHE_DIR");
  const std::string saved = old_cache ? old_cache : "";
  setenv("BASALT_CACHE_DIR", "off", 1);
  const bool expected = gpu_context().info().is_cpu && vkx::CompileDevice::shader_cache_on();
  for (const auto& [file, made] :
       {std::pair{"scenes/material-zoo.pbrt", true}, {"scenes/materials-transmission.pbrt", true},
        {"scenes/bump.pbrt", false}}) {
    const SceneTables t = tables_from_file(source_path(file), 48, 32);
    auto& ctx = gpu_context();
    const std::size_t before = ctx.validation_errors();
    std::vector<glm::vec4> image[2];
    for (int on = 0; on < 2; ++on) {
      vkx::GpuRenderer::solo_pipeline =
          on ? vkx::GpuRenderer::Solo::at_once : vkx::GpuRenderer::Solo::off;
      vkx::GpuRenderer gpu(ctx, t, t.features, vkx::ShaderVariant::wavefront);
      gpu.render(0, 4);  // the choice is made at the first wave
      vkx::GpuRenderer::solo_pipeline = vkx::GpuRenderer::Solo::background;
      ASSERT_EQ(gpu.variant, "wavefront") << file;
      image[on] = gpu.accum();
      EXPECT_EQ(gpu.nonfinite_samples(), 0u) << file;
      if (on && expected && made) {
        EXPECT_EQ(gpu.solo_type, gpu::MATERIAL_DIFFUSE) << file;
        EXPECT_GT(gpu.solo_dispatches, 0u) << file;
        const std::uint32_t materials = gpu::FEATURE_MAT_DIFFUSE | gpu::FEATURE_MAT_OREN_NAYAR |
                                        (gpu::FEATURE_MAT_METAL * 2u - gpu::FEATURE_MAT_OREN_NAYAR);
        EXPECT_EQ(gpu.solo_words.first & materials, gpu::FEATURE_MAT_DIFFUSE) << file;
        const auto group = gpu.shade_feature_words(gpu::MATERIAL_DIFFUSE);
        EXPECT_NE(group.first & materials, gpu::FEATURE_MAT_DIFFUSE) << file;
      } else {
        EXPECT_EQ(gpu.solo_type, gpu::MATERIAL_TYPE_COUNT) << file;
        EXPECT_EQ(gpu.solo_dispatches, 0u) << file;
      }
    }
    EXPECT_EQ(ctx.validation_errors(), before) << file;
    ASSERT_EQ(image[0].size(), image[1].size());
    EXPECT_EQ(std::memcmp(image[0].data(), image[1].data(), image[0].size() * sizeof(glm::vec4)),
              0)
        << file;
  }
  if (old_cache)
    setenv("BASALT_CACHE_DIR", saved.c_str(), 1);
  else
    unsetenv("BASALT_CACHE_DIR");
}

// A scene with any material kind other than diffuse never gets the lean shader: not by
// default (it gets the wavefront stages, or the full megakernel: Automatic.*), and asking for
// it is an error.
TEST(LeanVariant, NeverForOtherMaterials) {
  for (const char* file : {"scenes/material-zoo.pbrt", "scenes/materials-coated.pbrt",
                           "scenes/materials-conductors.pbrt", "scenes/materials-dielectrics.pbrt",
                           "scenes/materials-mix.pbrt", "scenes/materials-transmission.pbrt"}) {
    SceneTables t = tables_from_file(source_path(file), 8, 8);
    ASSERT_NE(t.features & ~(gpu::FEATURE_MAT_DIFFUSE | gpu::FEATURE_MAT_OREN_NAYAR |
                             gpu::FEATURE_MAT_MEASURED | (gpu::FEATURE_MAT_OREN_NAYAR - 1u)),
              0u)
        << file << " uses no material kind but diffuse, Oren-Nayar and measured";
    EXPECT_FALSE(vkx::GpuRenderer::lean_suffices(t.features)) << file;
    if (std::string(file) == "scenes/material-zoo.pbrt") {  // one pipeline build is enough
      vkx::GpuRenderer gpu(gpu_context(), t);
      EXPECT_EQ(gpu.variant, "wavefront") << file;  // the automatic choice beyond diffuse
    }
    EXPECT_THROW(vkx::GpuRenderer(gpu_context(), t, t.features, vkx::ShaderVariant::lean),
                 std::invalid_argument)
        << file;
  }
  // One bit of each material kind but diffuse, Oren-Nayar and measured rules lean out.
  for (std::uint32_t bit = 0; bit < gpu::FEATURE_COUNT; ++bit) {
    const std::uint32_t f = 1u << bit;
    // bits 11..27 are material kinds (the lean build has Oren-Nayar and measured); 28.. are
    // texture families and the image light, which the lean build supports
    const bool material = f > gpu::FEATURE_MAT_OREN_NAYAR && f < gpu::FEATURE_TEXTURES &&
                          f != gpu::FEATURE_MAT_MEASURED;
    EXPECT_EQ(vkx::GpuRenderer::lean_suffices(gpu::FEATURE_MAT_DIFFUSE | f), !material) << bit;
  }
}

// The automatic choice between the megakernel and the wavefront (megakernel_suffices): the
// wavefront where it splits the material code over pipelines (a layered material, or the
// untextured types beside textured ones: untextured_types) or the scene has a portal; the
// megakernel otherwise (one shade pipeline would hold the megakernel's material code).
TEST(Automatic, WavefrontWhereItSplitsTheMaterialCode) {
  const std::pair<const char*, bool> scenes[] = {
      {"scenes/cornell-box.pbrt", true},           {"scenes/materials-diffuse.pbrt", true},
      {"scenes/materials-dielectrics.pbrt", true}, {"scenes/envmap.pbrt", true},
      {"scenes/envmap-latlong.pbrt", true},        {"scenes/textures-image.pbrt", true},
      {"scenes/materials-mix.pbrt", true},         {"scenes/materials-transmission.pbrt", true},
      {"scenes/envmap-portal.pbrt", false},        {"scenes/textures-specular.pbrt", false},
      {"scenes/materials-coated.pbrt", false},     {"scenes/materials-conductors.pbrt", false},
      {"scenes/bump.pbrt", false},                 {"scenes/material-zoo.pbrt", false}};
  for (const auto& [file, megakernel] : scenes) {
    SceneTables t = tables_from_file(source_path(file), 8, 8);
    EXPECT_EQ(vkx::GpuRenderer::megakernel_suffices(t, t.features, t.features2), megakernel)
        << file;
  }
  // textures-specular: an untextured conductor and dielectric beside textured diffuse
  // materials; textures-image's conductor is textured (a roughness map); bump has a layered
  // material.
  auto untextured = [](const char* file) {
    return vkx::GpuRenderer::untextured_types(tables_from_file(source_path(file), 8, 8));
  };
  EXPECT_EQ(untextured("scenes/textures-specular.pbrt"),
            (1u << gpu::MATERIAL_CONDUCTOR) | (1u << gpu::MATERIAL_DIELECTRIC));
  EXPECT_EQ(untextured("scenes/textures-image.pbrt"), 0u);
  EXPECT_EQ(untextured("scenes/bump.pbrt"), 0u);
  EXPECT_EQ(untextured("scenes/envmap.pbrt"), 0u);  // nothing textured
  // The constructor follows it: materials-dielectrics renders through the full megakernel.
  SceneTables t = tables_from_file(source_path("scenes/materials-dielectrics.pbrt"), 8, 8);
  vkx::GpuRenderer gpu(gpu_context(), t);
  EXPECT_EQ(gpu.variant, "full");
}

// The plain builds (render_lean_plain, wavefront_*_plain: no texture, image-light or bump code,
// pruned at build time by tools/spirv_prune.cpp) render, bit for bit, what the textured builds
// render: the Cornell box and spheres-lights through the lean megakernel, materials-coated
// (coated diffuse and conductor, dielectric) through the wavefront stages.
TEST(PlainVariant, SameImageAsTheTexturedBuilds) {
  for (const char* file : {"scenes/cornell-box.pbrt", "scenes/spheres-lights.pbrt",
                           "scenes/materials-coated.pbrt"}) {
    SceneTables t = tables_from_file(source_path(file), 48, 32);
    ASSERT_TRUE(vkx::GpuRenderer::plain_suffices(t.features, t.features2)) << file;
    // materials-coated through the wavefront stages, the test's subject, whatever the
    // automatic choice.
    const bool coated = std::string(file) == "scenes/materials-coated.pbrt";
    expect_same_image_both_ways(
        t, vkx::GpuRenderer::plain_builds,
        [file](vkx::GpuRenderer& gpu, bool plain) { EXPECT_EQ(gpu.plain, plain) << file; }, file,
        coated ? vkx::ShaderVariant::wavefront : vkx::ShaderVariant::automatic);
  }
}

// A scene with a texture, an image light, or a bump, normal or vector-turbulence map never
// gets the plain builds; every other feature bit keeps them.
TEST(PlainVariant, NeverForTexturesImageLightsOrBumps) {
  for (const char* file : {"scenes/textures-procedural.pbrt", "scenes/envmap.pbrt",
                           "scenes/bump.pbrt", "scenes/normalmap.pbrt", "scenes/vturb.pbrt"}) {
    SceneTables t = tables_from_file(source_path(file), 8, 8);
    EXPECT_FALSE(vkx::GpuRenderer::plain_suffices(t.features, t.features2)) << file;
  }
  for (std::uint32_t bit = 0; bit < 32; ++bit) {
    const std::uint32_t f = 1u << bit;
    const bool texture = f == gpu::FEATURE_TEXTURES || f == gpu::FEATURE_TEX_NOISE ||
                         f == gpu::FEATURE_TEX_IMAGE || f == gpu::FEATURE_LIGHT_INFINITE_IMAGE;
    EXPECT_EQ(vkx::GpuRenderer::plain_suffices(f, 0u), !texture) << "feature bit " << bit;
    // The second word: the texture families and bumps out; the noise precision mode (set
    // without noise textures too), the samplers, Owen scrambling and the light importance in.
    const bool sampling = f == gpu::FEATURE2_NOISE_SPLIT || (f & gpu::FEATURE2_SAMPLERS) != 0u ||
                          f == gpu::FEATURE2_SAMPLER_OWEN || f == gpu::FEATURE2_LIGHT_IMPORTANCE;
    EXPECT_EQ(vkx::GpuRenderer::plain_suffices(0u, f), sampling) << "feature2 bit " << bit;
  }
  SceneTables t = tables_from_file(source_path("scenes/textures-procedural.pbrt"), 8, 8);
  vkx::GpuRenderer gpu(gpu_context(), t);
  EXPECT_FALSE(gpu.plain);
}

// The build removed the code the plain variants rule out: image maps, noise, the bump and the
// image light are gone from the modules (their OpName strings with them; what is left of the
// texture interpreter is its entry, which returns at once), the rest of the path stays, and
// the modules are at least a quarter smaller.
TEST(PlainVariant, PrunedAtBuildTime) {
  auto names = [](const std::uint32_t* words, std::size_t bytes, const std::string& name) {
    return std::string(reinterpret_cast<const char*>(words), bytes).find(name + "(") !=
           std::string::npos;
  };
  for (const char* f : {"tex_image", "perlin_noise", "bump_map", "env_eval"}) {
    EXPECT_TRUE(names(render_lean_spv, sizeof(render_lean_spv), f)) << f;
    EXPECT_FALSE(names(render_lean_plain_spv, sizeof(render_lean_plain_spv), f)) << f;
  }
  for (const char* f : {"tex_image", "perlin_noise", "bump_map"}) {  // (misses: the extend stage)
    EXPECT_TRUE(names(wavefront_shade_spv, sizeof(wavefront_shade_spv), f)) << f;
    EXPECT_FALSE(names(wavefront_shade_plain_spv, sizeof(wavefront_shade_plain_spv), f)) << f;
  }
  EXPECT_TRUE(names(render_lean_plain_spv, sizeof(render_lean_plain_spv), "path_bounce"));
  EXPECT_TRUE(names(wavefront_shade_plain_spv, sizeof(wavefront_shade_plain_spv), "layered_query"));
  EXPECT_LT(sizeof(render_lean_plain_spv), sizeof(render_lean_spv) * 3 / 4);
  EXPECT_LT(sizeof(wavefront_shade_plain_spv), sizeof(wavefront_shade_spv) * 3 / 4);
}

// The feature set names what the scene uses, and only that.
TEST(Specialisation, FeatureSetOfEachScene) {
  auto names = [](const char* file) {
    return feature_names(tables_from_file(source_path(file), 16, 16).features);
  };
  using V = std::vector<std::string>;
  EXPECT_EQ(names("scenes/cornell-box.pbrt"),
            (V{"triangles", "light_area", "material_diffuse", "filter_gaussian"}));
  EXPECT_EQ(names("scenes/spheres-lights.pbrt"),
            (V{"triangles", "spheres", "light_point", "light_spot", "light_distant",
               "material_diffuse", "filter_gaussian"}));
}

}  // namespace
}  // namespace basalt::test

namespace basalt::test {
namespace {

// A table beyond the device's maxStorageBufferRange is refused with a message naming the
// table and the limit, before anything is allocated (splitting arrives with the hardening
// issue; until then a clear error, never a silently truncated binding).
TEST(Limits, OversizedTableIsAClearError) {
  auto& ctx = gpu_context();
  const std::uint64_t limit = ctx.info().max_storage_buffer_range;
  if (limit > (std::uint64_t(1) << 30)) GTEST_SKIP() << "device limit too large to exceed cheaply";
  SceneTables t = tables_from_file(source_path("scenes/spheres-lights.pbrt"), 8, 8);
  t.vertices.resize(limit / sizeof(gpu::Vertex) + 1);
  try {
    vkx::GpuRenderer gpu(ctx, t);
    FAIL() << "no error for a " << t.vertices.size() * sizeof(gpu::Vertex) << "-byte table";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("vertices"), std::string::npos) << msg;
    EXPECT_NE(msg.find(std::to_string(limit)), std::string::npos) << msg;
  }
}

// The trace stage (shaders/trace.comp, GpuRenderer::trace) answers exactly as the probe's
// CLOSEST and OCCLUDED ops, which the robustness and stress tests hold to the CPU reference: the
// same traversal code, specialised for the scene instead of compiled with every feature. Rays
// from inside and around the Cornell box (triangles) and the spheres scene (spheres and
// triangles), some with a short tMax, some axis-parallel.
// The GPU traverses the wide BVH (build_wide_bvh), the CPU reference the binary one: the same
// closest hit and the same any-hit answer on every ray is the wide BVH's oracle (its boxes,
// quantisation and traversal), beside the probe's (the same shader code, compiled otherwise).
TEST(Trace, SameHitsAsTheProbeAndTheCpu) {
  for (const char* scene : {"scenes/cornell-box.pbrt", "scenes/spheres-lights.pbrt",
                            "scenes/displacement.pbrt"}) {
    SCOPED_TRACE(scene);
    const SceneTables t = tables_from_file(source_path(scene), 8, 8);
    vkx::GpuRenderer gpu(gpu_context(), t, t.features, vkx::ShaderVariant::automatic, false);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> U(-1.0f, 1.0f);
    std::vector<gpu::TraceRay> rays;
    std::vector<gpu::ProbeIn> closest, occluded;
    // Origins in the scene's bounds (the BVH root's), and in a box twice its size around it.
    ASSERT_FALSE(t.nodes.empty());
    const glm::vec3 lo = t.nodes[0].lo, hi = t.nodes[0].hi;
    const glm::vec3 mid = 0.5f * (lo + hi), half = 0.5f * (hi - lo);
    for (int i = 0; i < 20000; ++i) {
      const float scale = i % 2 ? 1.0f : 2.0f;
      const glm::vec3 o = mid + scale * half * glm::vec3(U(rng), U(rng), U(rng));
      glm::vec3 d(U(rng), U(rng), U(rng));
      if (i % 10 == 0) d = glm::vec3(0.0f, 0.0f, i % 20 ? 1.0f : -1.0f);
      if (!(glm::dot(d, d) > 1e-6f)) d = glm::vec3(1.0f, 0.0f, 0.0f);
      const float tmax = i % 3 ? 3.4e38f : 0.5f + U(rng);
      rays.push_back({glm::vec4(o, tmax), glm::vec4(d, 0.0f)});
      gpu::ProbeIn q{};
      q.o_tmax = glm::vec4(o, tmax);
      q.d = glm::vec4(d, 0.0f);
      q.key = glm::uvec4(gpu::PROBE_CLOSEST, 0u, 0u, 0u);
      closest.push_back(q);
      q.key.x = gpu::PROBE_OCCLUDED;
      occluded.push_back(q);
    }
    const std::vector<gpu::TraceHit> hits = gpu.trace(rays, false), any = gpu.trace(rays, true);
    const std::vector<gpu::ProbeOut> pc = gpu.probe(closest), po = gpu.probe(occluded);
    ASSERT_EQ(hits.size(), rays.size());
    std::size_t hit_count = 0, differ = 0, differ_cpu = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const bool same = hits[i].prim == pc[i].u.x && hits[i].t == pc[i].f0.x &&
                        hits[i].b1 == pc[i].f0.y && hits[i].b2 == pc[i].f0.z &&
                        (any[i].prim != gpu::INVALID_INDEX) == (po[i].u.x != 0u);
      hit_count += hits[i].prim != gpu::INVALID_INDEX;
      if (!same && ++differ <= 5)
        ADD_FAILURE() << "ray " << i << ": trace prim " << hits[i].prim << " t " << hits[i].t
                      << ", probe prim " << pc[i].u.x << " t " << pc[i].f0.x << "; any "
                      << any[i].prim << " occluded " << po[i].u.x;
      const cpu::Ray r{glm::vec3(rays[i].o_tmax), glm::vec3(rays[i].d), rays[i].o_tmax.w};
      const cpu::Hit h = cpu::intersect_closest(t, r);
      const bool occluded = cpu::intersect_any(t, r);
      // Same primitive, t within 1e-5 relative (the sphere's sqrt may differ in its last bits).
      const bool same_cpu = hits[i].prim == h.prim &&
                            (!h.valid() || std::abs(hits[i].t - h.t) <= 1e-5f * h.t) &&
                            (any[i].prim != gpu::INVALID_INDEX) == occluded;
      if (!same_cpu && ++differ_cpu <= 5)
        ADD_FAILURE() << "ray " << i << ": trace prim " << hits[i].prim << " t " << hits[i].t
                      << ", CPU prim " << h.prim << " t " << h.t << "; any " << any[i].prim
                      << " CPU occluded " << occluded;
    }
    EXPECT_EQ(differ, 0u);
    EXPECT_EQ(differ_cpu, 0u);
    EXPECT_TRUE(gpu.leaf_prims);
    EXPECT_TRUE(gpu.texel_tables);
    // Without the leaf_prims table (LEAF_PRIMS = 0: leaves read the reference, triangle and
    // vertex tables) and then also without the texel views (TEXEL_TABLES = 0: storage-buffer
    // loads), the trace stage answers bit for bit the same.
    for (int k = 1; k <= 2; ++k) {
      vkx::GpuRenderer::leaf_prims_max_bytes = 1;
      vkx::GpuRenderer::texel_views_max_texels = k == 2 ? 1 : 0;
      vkx::GpuRenderer fallback(gpu_context(), t, t.features, vkx::ShaderVariant::automatic, false);
      vkx::GpuRenderer::leaf_prims_max_bytes = 0;
      vkx::GpuRenderer::texel_views_max_texels = 0;
      EXPECT_FALSE(fallback.leaf_prims);
      EXPECT_EQ(fallback.texel_tables, k == 1);
      const std::vector<gpu::TraceHit> fh = fallback.trace(rays, false),
                                       fa = fallback.trace(rays, true);
      std::size_t differ_fallback = 0;
      for (std::size_t i = 0; i < rays.size(); ++i)
        differ_fallback += std::memcmp(&fh[i], &hits[i], sizeof(gpu::TraceHit)) != 0 ||
                           (fa[i].prim != gpu::INVALID_INDEX) != (any[i].prim != gpu::INVALID_INDEX);
      EXPECT_EQ(differ_fallback, 0u) << (k == 1 ? "without leaf_prims" : "without texel views");
    }
    EXPECT_GT(hit_count, rays.size() / 10);  // not vacuous: thousands of hits (open scenes: ~20 %)
  }
}

// Scene specialisation of SPIR-V (vk/specialise.h): it removes code (the trace shader without
// spheres loses the sphere test), the disk cache answers the second time with the same words,
// and a damaged cache file is specialised afresh rather than handed to the driver. The images
// of specialised pipelines are checked against the all-features pipeline above
// (Specialisation.SameImageAsAllFeatures) and against the CPU by every conformance test.
TEST(Specialisation, SpirvCacheRoundTripAndDamage) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("basalt-spirv-cache-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ASSERT_EQ(setenv("BASALT_CACHE_DIR", dir.c_str(), 1), 0);
  const std::uint32_t f1 = gpu::FEATURE_TRIANGLES, f2 = 0u;
  bool hit = true;
  const std::vector<std::uint32_t> first =
      vkx::specialise_spirv_cached(trace_spv, sizeof(trace_spv), {f1, f2, 1u}, hit);
  EXPECT_FALSE(hit);
  EXPECT_LT(first.size() * 4, sizeof(trace_spv));  // code removed
  EXPECT_EQ(first, vkx::specialise_spirv(trace_spv, sizeof(trace_spv), {f1, f2, 1u}));
  const std::vector<std::uint32_t> second =
      vkx::specialise_spirv_cached(trace_spv, sizeof(trace_spv), {f1, f2, 1u}, hit);
  EXPECT_TRUE(hit);
  EXPECT_EQ(second, first);
  // Damage every cache file (one word of the payload) and truncate another copy: both miss.
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    std::fstream f(e.path(), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(16 + 40);
    const std::uint32_t junk = 0xdeadbeefu;
    f.write(reinterpret_cast<const char*>(&junk), 4);
    ++files;
  }
  EXPECT_EQ(files, 1);
  const std::vector<std::uint32_t> third =
      vkx::specialise_spirv_cached(trace_spv, sizeof(trace_spv), {f1, f2, 1u}, hit);
  EXPECT_FALSE(hit);
  EXPECT_EQ(third, first);
  for (const auto& e : std::filesystem::directory_iterator(dir))
    std::filesystem::resize_file(e.path(), 100);
  EXPECT_EQ(vkx::specialise_spirv_cached(trace_spv, sizeof(trace_spv), {f1, f2, 1u}, hit), first);
  EXPECT_FALSE(hit);
  unsetenv("BASALT_CACHE_DIR");
  std::filesystem::remove_all(dir);
}

// A feature test written `has_feature(X) && c` is a phi after dead-branch elimination
// (glslang's short-circuit): the specialisation folds it too, so the code under it goes. The
// lean render module for the Cornell box's features keeps neither the measured BRDF nor
// Oren-Nayar (both behind such tests in bsdf.glsl), and keeps each when its material is in.
TEST(Specialisation, FoldsShortCircuitFeatureTests) {
  // Whether the module names a function whose name starts with `name` (its OpName string).
  auto names = [](const std::vector<std::uint32_t>& words, const std::string& name) {
    const char* bytes = reinterpret_cast<const char*>(words.data());
    return std::string(bytes, words.size() * 4).find(name + "(") != std::string::npos;
  };
  const std::uint32_t cornell = gpu::FEATURE_TRIANGLES | gpu::FEATURE_LIGHT_AREA |
                                gpu::FEATURE_MAT_DIFFUSE | gpu::FEATURE_FILTER_GAUSSIAN;
  const auto specialise = [](std::uint32_t f) {
    return vkx::specialise_spirv(render_lean_spv, sizeof(render_lean_spv), {f, 0u, 1u, 1u});
  };
  const std::vector<std::uint32_t> lean = specialise(cornell);
  ASSERT_TRUE(names({render_lean_spv, render_lean_spv + sizeof(render_lean_spv) / 4},
                    "measured_f"));  // the check can see the names
  EXPECT_FALSE(names(lean, "measured_f"));
  EXPECT_FALSE(names(lean, "oren_nayar_f"));
  EXPECT_TRUE(names(lean, "path_bounce"));
  EXPECT_TRUE(names(specialise(cornell | gpu::FEATURE_MAT_MEASURED), "measured_f"));
  EXPECT_TRUE(names(specialise(cornell | gpu::FEATURE_MAT_OREN_NAYAR), "oren_nayar_f"));
}

// A specialised module over kInlineAboveWords (the default bound) is inlined into its entry
// point (no function but main, no call left); a smaller one keeps its functions, unless the
// bound is 0, as for the wavefront's stages. The lean render module for the
// Cornell box's features is below the bound, the same module with every feature above it.
TEST(Specialisation, InlinesLargeModulesOnly) {
  // Functions and call instructions of a module (SPIR-V: 5 header words, then instructions
  // whose first word holds the word count above the opcode; OpFunction 54, OpFunctionCall 57).
  auto count = [](const std::vector<std::uint32_t>& w) {
    std::pair<int, int> n{0, 0};
    for (std::size_t i = 5; i < w.size() && (w[i] >> 16) != 0; i += w[i] >> 16) {
      n.first += (w[i] & 0xffffu) == 54u;
      n.second += (w[i] & 0xffffu) == 57u;
    }
    return n;
  };
  const auto specialise = [](std::uint32_t f) {
    return vkx::specialise_spirv(render_lean_spv, sizeof(render_lean_spv), {f, 0u, 1u, 1u});
  };
  const std::vector<std::uint32_t> small =
      specialise(gpu::FEATURE_TRIANGLES | gpu::FEATURE_LIGHT_AREA | gpu::FEATURE_MAT_DIFFUSE);
  EXPECT_LE(small.size(), vkx::kInlineAboveWords);
  EXPECT_GT(count(small).first, 10);
  EXPECT_GT(count(small).second, 10);
  const std::vector<std::uint32_t> large = specialise(0xffffffffu);
  vkx::inline_large_modules = false;
  EXPECT_GT(specialise(0xffffffffu).size(), vkx::kInlineAboveWords);
  vkx::inline_large_modules = true;
  EXPECT_EQ(count(large), std::make_pair(1, 0));
  // A bound of 0 (the wavefront's stages) inlines the small module too.
  const std::vector<std::uint32_t> all = vkx::specialise_spirv(
      render_lean_spv, sizeof(render_lean_spv),
      {gpu::FEATURE_TRIANGLES | gpu::FEATURE_LIGHT_AREA | gpu::FEATURE_MAT_DIFFUSE, 0u, 1u, 1u}, 0);
  EXPECT_EQ(count(all), std::make_pair(1, 0));
}

// The layered walks (f, PDF and Sample_f) reach their interfaces through one call site of
// layer_query, so that a pipeline inlines one interface for the three (layered.glsl,
// layered_query; docs/performance.md, seventeenth session): in the shade module as built, the
// function named layer_query is called by exactly one OpFunctionCall, and so is
// layered_query.
TEST(Specialisation, LayeredWalksShareOneInterfaceCallSite) {
  const std::vector<std::uint32_t> w(wavefront_shade_spv,
                                     wavefront_shade_spv + sizeof(wavefront_shade_spv) / 4);
  // SPIR-V: 5 header words, then instructions whose first word holds the word count above the
  // opcode; OpName 5 (target, then the name as a nul-terminated string), OpFunctionCall 57
  // (result type, result, function, arguments).
  auto calls_of = [&w](const std::string& name) {
    std::uint32_t id = 0;
    int calls = 0;
    for (std::size_t i = 5; i < w.size() && (w[i] >> 16) != 0; i += w[i] >> 16) {
      const std::uint32_t op = w[i] & 0xffffu, n = w[i] >> 16;
      if (op == 5u && n > 2) {
        const std::string s(reinterpret_cast<const char*>(&w[i + 2]));
        if (s.rfind(name + "(", 0) == 0) id = w[i + 1];
      }
      if (op == 57u && id != 0 && w[i + 3] == id) ++calls;
    }
    return std::make_pair(id != 0, calls);
  };
  EXPECT_EQ(calls_of("layer_query"), std::make_pair(true, 1));
  EXPECT_EQ(calls_of("layered_query"), std::make_pair(true, 1));
}

// Inlining changes no result: materials-coated, whose shade modules are above the bound,
// renders the same image, bit for bit, with and without it.
TEST(Specialisation, InliningKeepsTheImage) {
  SceneTables t = tables_from_file(source_path("scenes/materials-coated.pbrt"), 48, 32);
  expect_same_image_both_ways(t, vkx::inline_large_modules, [](vkx::GpuRenderer& gpu, bool) {
    ASSERT_EQ(gpu.variant, "wavefront");
  }, "materials-coated.pbrt", vkx::ShaderVariant::wavefront);
}

// The cache stays bounded: past 64 MiB the least recently used entries go, down to 48 MiB, and
// the entry just written stays (sparse 4 MiB stand-ins of older entries, oldest first).
TEST(Specialisation, SpirvCacheIsTrimmed) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("basalt-spirv-trim-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto now = std::filesystem::file_time_type::clock::now();
  for (int i = 0; i < 17; ++i) {
    const std::filesystem::path f = dir / ("spirv-old" + std::to_string(100 + i) + ".bin");
    std::ofstream{f}.put('x');
    std::filesystem::resize_file(f, 4u << 20);
    std::filesystem::last_write_time(f, now - std::chrono::hours(100 - i));
  }
  std::ofstream{dir / "unrelated.txt"}.put('x');  // not the cache's: never removed
  ASSERT_EQ(setenv("BASALT_CACHE_DIR", dir.c_str(), 1), 0);
  bool hit = true;
  vkx::specialise_spirv_cached(trace_spv, sizeof(trace_spv), {gpu::FEATURE_TRIANGLES, 0u, 1u}, hit);
  EXPECT_FALSE(hit);
  std::uintmax_t total = 0;
  int old_left = 0;
  bool newest_old_left = false, unrelated_left = false;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("spirv-", 0) == 0) total += e.file_size();
    old_left += name.rfind("spirv-old", 0) == 0;
    newest_old_left |= name == "spirv-old116.bin";
    unrelated_left |= name == "unrelated.txt";
  }
  EXPECT_LE(total, std::uintmax_t(48) << 20);
  EXPECT_EQ(old_left, 11);  // 17 x 4 MiB + the new entry, trimmed to 48 MiB: the 6 oldest go
  EXPECT_TRUE(newest_old_left);
  EXPECT_TRUE(unrelated_left);
  vkx::specialise_spirv_cached(trace_spv, sizeof(trace_spv), {gpu::FEATURE_TRIANGLES, 0u, 1u}, hit);
  EXPECT_TRUE(hit);  // the new entry survived the trim
  unsetenv("BASALT_CACHE_DIR");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace basalt::test
