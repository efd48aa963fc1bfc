// The Vulkan side itself: validation errors are caught, and the specialised pipeline
// renders exactly what the all-features pipeline renders.
#include <gtest/gtest.h>

#include <cstring>

#include "common/test_util.h"
#include "vk/gpu_renderer.h"

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
      vkx::GpuRenderer gpu(ctx, t, t.features);
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

}  // namespace
}  // namespace basalt::test
