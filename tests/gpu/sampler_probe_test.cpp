// pbrt-v4's samplers (docs/sampler-spec.md) are bit-identical on the GPU and the CPU reference:
// PROBE_SAMPLER over 10^5 random (pixel, sample, dimension) triples per sampler and
// randomisation, with dimensions spread over the camera, every bounce slot and the streams,
// at sample counts that are and are not powers of two. The CPU side's own checks
// (stratification, convergence rates) are tests/cpu/sampler_test.cpp.
#include <gtest/gtest.h>

#include <bit>
#include <chrono>
#include <cstdio>
#include <random>

#include "common/sampler_scenes.h"
#include "common/test_util.h"
#include "vk/gpu_renderer.h"

namespace basalt::test {
namespace {

TEST(SamplerProbe, GpuMatchesCpuBitForBit) {
  const SceneTables base = tables_from_string(lit_plane_scene());
  std::mt19937 gen(2026);
  // One renderer (one probe pipeline, built with every feature bit); each case replaces the
  // Globals, where the whole sampler configuration lives (the prime table is the same).
  auto& ctx = gpu_context();
  const std::size_t validation_before = ctx.validation_errors();
  const SceneTables first = with_sampler(base, {"halton", ""}, 24);
  vkx::GpuRenderer renderer(ctx, first, first.features, vkx::ShaderVariant::automatic, false);
  for (const SamplerCase& c : sampler_cases()) {
    // zsobol rounds its count to a power of two; the others also take 24 (not a power of 2).
    const int spp = std::string(c.type) == "zsobol" ? 64 : 24;
    SceneTables t = with_sampler(base, c, spp);
    set_seed(t, 7);
    std::vector<gpu::ProbeIn> q(100000);
    std::uniform_int_distribution<std::uint32_t> px(0, t.width() - 1), py(0, t.height() - 1),
        s(0, std::uint32_t(t.globals.sampler_opts.x == gpu::SAMPLER_STRATIFIED
                               ? t.globals.sampler_opts.z * t.globals.sampler_opts.w
                               : t.globals.sampler_opts.z) - 1),
        d(0, 4 + 16 * 80);  // bounces up to 80: halton bases past the 500th prime
    for (auto& e : q) {
      e = gpu::ProbeIn{};
      e.key = glm::uvec4(gpu::PROBE_SAMPLER, px(gen), py(gen), s(gen));
      e.extra.x = std::bit_cast<float>(d(gen));
    }
    const auto cpu = probe(Side::Cpu, t, q);
    ASSERT_EQ(t.sampler_data, base.sampler_data);
    renderer.set_globals(t.globals);
    const auto t0 = std::chrono::steady_clock::now();
    const auto gpu = renderer.probe(q);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::size_t differ = 0;
    for (std::size_t i = 0; i < q.size(); ++i)
      if (std::bit_cast<std::uint32_t>(cpu[i].f0.x) != std::bit_cast<std::uint32_t>(gpu[i].f0.x)) {
        if (differ < 5)
          std::printf("  %s: pixel (%u, %u) sample %u dim %u: cpu %.9g gpu %.9g\n",
                      sampler_label(c).c_str(), q[i].key.y, q[i].key.z, q[i].key.w,
                      std::bit_cast<std::uint32_t>(q[i].extra.x), cpu[i].f0.x, gpu[i].f0.x);
        ++differ;
      }
    std::printf("[ sampler probe ] %-26s %zu triples, %zu differ (GPU %.1f s)\n",
                sampler_label(c).c_str(), q.size(), differ, secs);
    EXPECT_EQ(differ, 0u) << sampler_label(c);
  }
  EXPECT_EQ(ctx.validation_errors(), validation_before) << "Vulkan validation errors";
}

}  // namespace
}  // namespace basalt::test
