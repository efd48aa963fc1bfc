// The path knobs of docs/path-spec.md 7.1 (--maxdepth, --roulette, --mis) on the CPU reference:
// each changes the image; the unbiased ones converge to the default's image (their means agree
// within 4 standard errors of the paired pixel differences); the biased ones (maxdepth 1 and 2)
// lose light, a floor the error cannot go below.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "common/path_knobs_scene.h"
#include "common/test_util.h"
#include "scene/tables.h"

namespace basalt::test {
namespace {

/// The mean of a - b over pixels and channels and its standard error (pixels independent).
void difference(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b, double& d,
                double& se) {
  std::vector<glm::vec3> diff(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) diff[i] = a[i] - b[i];
  mean_and_se(diff, d, se);
}

TEST(PathKnobs, EveryKnobChangesTheImage) {
  const SceneTables base = tables_from_string(path_knobs_scene());
  EXPECT_EQ(base.globals.render_opts, glm::uvec4(0u));  // zero: pbrt-v4's behaviour
  const std::vector<glm::vec3> ref = render(Side::Cpu, base, 4);
  for (const PathKnobSetting& k : path_knob_settings()) {
    SceneTables t = base;
    apply_path_knobs(t, k.max_depth, k.roulette_start, k.mis);
    const std::vector<glm::vec3> img = render(Side::Cpu, t, 4);
    ASSERT_TRUE(all_finite(img)) << k.name;
    std::size_t changed = 0;
    for (std::size_t i = 0; i < img.size(); ++i) changed += img[i] != ref[i] ? 1u : 0u;
    std::printf("[ knobs ] %-13s changes %zu of %zu pixels\n", k.name, changed, img.size());
    EXPECT_GT(changed, img.size() / 10) << k.name;
  }
  // The default values given explicitly change nothing.
  SceneTables t = base;
  apply_path_knobs(t, -1, 1u, gpu::MIS_POWER);
  const std::vector<glm::vec3> same = render(Side::Cpu, t, 4);
  EXPECT_EQ(same, ref);
}

TEST(PathKnobs, UnbiasedSettingsConvergeAndDepthLimitsAreAFloor) {
  SceneTables base = tables_from_string(path_knobs_scene());
  const std::uint32_t spp = 256;
  set_seed(base, 1);
  const std::vector<glm::vec3> ref = render(Side::Cpu, base, spp);
  for (const PathKnobSetting& k : path_knob_settings()) {
    SceneTables t = base;
    apply_path_knobs(t, k.max_depth, k.roulette_start, k.mis);
    set_seed(t, 2);
    const std::vector<glm::vec3> img = render(Side::Cpu, t, spp);
    double d, se;
    difference(img, ref, d, se);
    std::printf("[ knobs ] %-13s mean %.5f vs default %.5f: difference %+.5f (%.1f se)\n",
                k.name, mean(img), mean(ref), d, d / se);
    if (k.unbiased)
      EXPECT_LT(std::fabs(d), 4.0 * se) << k.name << " should converge to the default";
    else
      EXPECT_LT(d, -4.0 * se) << k.name << " should lose the light of longer paths";
  }
}

}  // namespace
}  // namespace basalt::test
