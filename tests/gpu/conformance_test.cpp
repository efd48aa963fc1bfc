// CPU vs GPU image conformance: for every scene in scenes/, the shader and the CPU
// reference render the same image (same seed and spp): every pixel within 1e-3 relative,
// except in the few scenes where a path may take another branch on the two sides, whose
// differing pixels are bounded per scene from the measured rate of such flips.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>

#include "common/test_util.h"
#include "image/image_io.h"

namespace basalt::test {
namespace {

/// Every .pbrt file in scenes/.
std::vector<std::string> scene_files() {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(source_path("scenes")))
    if (e.path().extension() == ".pbrt") files.push_back(e.path().filename().string());
  std::sort(files.begin(), files.end());
  return files;
}

/// gtest name of a scene file's test: the file name without ".pbrt", non-alphanumerics as '_'.
std::string test_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string n = info.param.substr(0, info.param.size() - 5);
  for (char& c : n)
    if (!std::isalnum((unsigned char)c)) c = '_';
  return n;
}

/// On failure, leaves both images and their difference in the build tree for inspection.
void dump(const std::string& name, const SceneTables& t, const std::vector<glm::vec3>& cpu,
          const std::vector<glm::vec3>& gpu) {
  std::filesystem::create_directories("conformance-failures");
  std::vector<glm::vec3> diff(cpu.size());
  for (std::size_t i = 0; i < cpu.size(); ++i) diff[i] = glm::abs(cpu[i] - gpu[i]);
  const int w = int(t.width()), h = int(t.height());
  write_image("conformance-failures/" + name + "-cpu.exr", Image{w, h, cpu});
  write_image("conformance-failures/" + name + "-gpu.exr", Image{w, h, gpu});
  write_image("conformance-failures/" + name + "-diff.exr", Image{w, h, diff});
}

/// Rate per path of a flip: a path that takes another branch on the two sides because some
/// decision (a stochastic mix's hash of the hit point, the side of a bumped or normal-mapped
/// shading normal, a portal's edge) was computed a few ulps apart, so that its pixel differs
/// by more than 1e-3. Measured per scene as (share of differing pixels) / spp, the larger of
/// the estimates at 2 spp and at the scene's own spp (lavapipe against the CPU reference, the
/// scene's seed, the commit of issue 11). Scenes not listed have no differing pixel at either.
const std::map<std::string, double> kFlipsPerPath = {
    {"envmap-portal.pbrt", 1.3e-5},   // 16 spp: 99.9792 % agree; 2 spp: 100 %
    {"material-zoo.pbrt", 1.3e-5},    // 2 spp: 99.9974 %; 16 spp: 99.9948 %
    {"materials-mix.pbrt", 4.1e-5},   // 2 spp: 99.9965 %; 16 spp: 99.9340 % (materials-spec 4)
    {"normalmap-sky.pbrt", 3.0e-5},   // 2 spp: 99.9940 %; 16 spp: 99.9820 %
    {"normalmap.pbrt", 5.2e-5},       // 2 spp: 99.9896 %; 16 spp: 99.9870 %
};

/// Most pixels that may differ at \p spp among \p pixels: a pixel differs when any of its spp
/// paths flips, so three times the expected count, and at least 3 pixels where flips occur;
/// none elsewhere.
std::size_t allowed_flips(const std::string& file, std::uint32_t spp, std::size_t pixels) {
  const auto it = kFlipsPerPath.find(file);
  if (it == kFlipsPerPath.end()) return 0;
  return std::max<std::size_t>(3, std::size_t(std::ceil(3.0 * it->second * spp * double(pixels))));
}

/// Renders \p file on both sides at \p spp: the share of pixels beyond 1e-3 within the
/// scene's allowance, and the image means within 1e-4 relative (flips are rare and symmetric:
/// a bias in a few pixels would show here).
void check_scene(const std::string& file, std::uint32_t spp) {
  SceneTables t = tables_from_file(source_path("scenes/" + file));
  auto cpu = render(Side::Cpu, t, spp);
  auto gpu = render(Side::Gpu, t, spp);
  ASSERT_TRUE(all_finite(cpu)) << "NaN or Inf in the CPU image";
  ASSERT_TRUE(all_finite(gpu)) << "NaN or Inf in the GPU image";
  ASSERT_GT(mean(cpu), 0.0) << "black image";
  const double agree = agreeing_fraction(cpu, gpu, 1e-3f);
  const std::size_t differ = std::size_t(std::lround((1.0 - agree) * double(cpu.size())));
  const std::size_t allowed = allowed_flips(file, spp, cpu.size());
  const double mean_rel = std::abs(mean(cpu) - mean(gpu)) / mean(cpu);
  std::printf("  %s at %u spp: %.4f%% of pixels agree (%zu differ, %zu allowed); means %.2e apart\n",
              file.c_str(), spp, agree * 100.0, differ, allowed, mean_rel);
  if (differ > allowed) dump(file, t, cpu, gpu);
  EXPECT_LE(differ, allowed) << file << ": " << differ << " pixels differ";
  EXPECT_LE(mean_rel, 1e-4) << file << ": image means differ";
}

class Conformance : public ::testing::TestWithParam<std::string> {};

// The scene's own resolution, 2 samples per pixel: every pixel's paths, cheaply.
TEST_P(Conformance, CpuMatchesGpu) { check_scene(GetParam(), 2); }

INSTANTIATE_TEST_SUITE_P(Scenes, Conformance, ::testing::ValuesIn(scene_files()),
                         test_name);

class ConformanceFullSpp : public ::testing::TestWithParam<std::string> {};

// The scene's default sample count (labelled slow by its name), under the same per-scene
// allowance scaled to the sample count.
TEST_P(ConformanceFullSpp, SlowCpuMatchesGpuAtSceneSpp) {
  Scene scene = load_scene(source_path("scenes/" + GetParam()));
  check_scene(GetParam(), std::uint32_t(scene.sampler.spp));
}

INSTANTIATE_TEST_SUITE_P(Scenes, ConformanceFullSpp, ::testing::ValuesIn(scene_files()),
                         test_name);

}  // namespace
}  // namespace basalt::test
