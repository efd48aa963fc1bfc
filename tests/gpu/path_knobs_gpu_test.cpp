// The path knobs of docs/path-spec.md 7.1 on the GPU: under every setting the shader renders
// the knob scene as the CPU reference does (99.9% of pixels within 1e-3, as the conformance
// tests ask); the CPU side's own checks are tests/cpu/path_knobs_test.cpp.
#include <gtest/gtest.h>

#include <cstdio>

#include "common/path_knobs_scene.h"
#include "common/test_util.h"
#include "scene/tables.h"

namespace basalt::test {
namespace {

TEST(PathKnobsGpu, MatchesCpuUnderEveryKnob) {
  const SceneTables base = tables_from_string(path_knobs_scene());
  for (const PathKnobSetting& k : path_knob_settings()) {
    SceneTables t = base;
    apply_setting(t, k);
    const auto cpu = render(Side::Cpu, t, 2);
    const auto gpu = render(Side::Gpu, t, 2);
    ASSERT_TRUE(all_finite(gpu)) << k.name;
    const double agree = agreeing_fraction(cpu, gpu, 1e-3f);
    std::printf("  %-13s %.4f%% of pixels agree within 1e-3\n", k.name, 100.0 * agree);
    EXPECT_GE(agree, 0.999) << k.name;
  }
}

}  // namespace
}  // namespace basalt::test
