// Light picking by importance (docs/path-spec.md 6.1) on the GPU against the CPU reference at
// huge and tiny scales: the same scene scaled by 1e-4 .. 1e5 renders finite on both sides,
// with importance on, and the two images agree (the same random numbers pick the same lights
// but where a float rounding moves an interval boundary).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "common/lights_scene.h"
#include "common/test_util.h"

namespace basalt::test {
namespace {

TEST(LightImportanceGpu, ExtremeScalesMatchCpu) {
  for (float scale : {1e-4f, 1.0f, 1e5f}) {
    const SceneTables t = tables_from_string(lights_scene(1, scale));
    ASSERT_EQ(t.globals.light_opts.x, gpu::LIGHT_SELECT_IMPORTANCE) << scale;
    const std::vector<glm::vec3> cpu = render(Side::Cpu, t, 8);
    const std::vector<glm::vec3> gpu = render(Side::Gpu, t, 8);
    ASSERT_TRUE(all_finite(cpu)) << scale;
    ASSERT_TRUE(all_finite(gpu)) << scale;
    const double a = mean(cpu), b = mean(gpu);
    std::printf("[ lights ] scale %g: mean cpu %.5f gpu %.5f, %.4f of pixels agree\n", scale, a,
                b, agreeing_fraction(cpu, gpu, 1e-3));
    // The scaled scene is the same picture: its mean stays that of scale 1 (within the noise of
    // 8 spp) and the two sides agree closely.
    EXPECT_GT(a, 0.05) << scale;
    EXPECT_NEAR(a, b, 0.01 * a) << scale;
    EXPECT_GT(agreeing_fraction(cpu, gpu, 1e-3), 0.95) << scale;
  }
}

}  // namespace
}  // namespace basalt::test
