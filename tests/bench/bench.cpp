// basalt benchmark: samples/s and Mrays/s of every scene in scenes/ on a Vulkan device
// (lavapipe unless BASALT_BENCH_DEVICE names another) and on the CPU reference, and the
// cost of the specialised pipeline against one with every feature compiled in, and for
// diffuse-only scenes of the lean render shader against the full one.
// Run: `cmake --build build --target bench` (5 repetitions, medians reported).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>

#include "cpu/render.h"
#include "scene/scene.h"
#include "scene/tables.h"
#include "vk/context.h"
#include "vk/gpu_renderer.h"

namespace {

constexpr std::uint32_t kSpp = 8;  // samples per pixel of one timed render

std::unique_ptr<basalt::vkx::Context> g_context;

/// The shared Vulkan context of the benchmark (destroyed at the end of main, not at exit).
basalt::vkx::Context& context() {
  auto& ctx = g_context;
  if (!ctx) {
    const char* dev = std::getenv("BASALT_BENCH_DEVICE");
    ctx = std::make_unique<basalt::vkx::Context>(dev ? dev : "lavapipe", false);
  }
  return *ctx;
}

/// Tables of a scene file, cached.
const basalt::SceneTables& tables(const std::string& path) {
  static std::map<std::string, basalt::SceneTables> cache;
  auto it = cache.find(path);
  if (it == cache.end()) it = cache.emplace(path, basalt::build_tables(basalt::load_scene(path))).first;
  return it->second;
}

/// Sets the per-second counters from one render's sample and ray counts.
void set_counters(benchmark::State& state, double samples, double rays) {
  state.counters["samples/s"] = benchmark::Counter(samples, benchmark::Counter::kIsRate);
  state.counters["Mrays/s"] = benchmark::Counter(rays * 1e-6, benchmark::Counter::kIsRate);
}

/// One GPU render of kSpp samples per pixel; upload and pipeline creation are not timed.
void BM_Gpu(benchmark::State& state, std::string path) {
  const auto& t = tables(path);
  basalt::vkx::GpuRenderer gpu(context(), t);
  const double samples = double(t.width()) * t.height() * kSpp;
  double rays = 0;
  for (auto _ : state) {
    gpu.clear();
    gpu.render(0, kSpp);
    rays += double(gpu.rays());
  }
  set_counters(state, samples * state.iterations(), rays);
  state.counters["pipeline_s"] = gpu.seconds_pipeline;
}

/// One CPU reference render of kSpp samples per pixel on all cores.
void BM_Cpu(benchmark::State& state, std::string path) {
  const auto& t = tables(path);
  const double samples = double(t.width()) * t.height() * kSpp;
  std::vector<glm::vec4> accum;
  double rays = 0;
  for (auto _ : state) {
    accum.assign(std::size_t(t.width()) * t.height(), glm::vec4(0.0f));
    rays += double(basalt::cpu::render(t, 0, kSpp, accum));
  }
  set_counters(state, samples * state.iterations(), rays);
}

/// Pipeline configurations compared by BM_Specialisation (its argument).
enum Config : int {
  kSpecialised = 0,      // scene's features, shader chosen as basalt does (lean if it can)
  kAllFeatures = 1,      // every feature, full shader
  kSpecialisedFull = 2,  // scene's features, full shader (registered for lean scenes only)
};

/// Pipeline creation (with the driver's compile at first dispatch) and render speed for one
/// Config; the label names the configuration and the render shader build (lean or full).
void BM_Specialisation(benchmark::State& state, std::string path) {
  const auto& t = tables(path);
  const auto config = Config(state.range(0));
  const std::uint32_t features = config == kAllFeatures ? 0xffffffffu : t.features;
  const auto variant = config == kSpecialisedFull ? basalt::vkx::ShaderVariant::full
                                                  : basalt::vkx::ShaderVariant::automatic;
  const double samples = double(t.width()) * t.height() * kSpp;
  double pipeline = 0, rays = 0;
  for (auto _ : state) {
    state.PauseTiming();
    basalt::vkx::GpuRenderer gpu(context(), t, features, variant);
    state.SetLabel(std::string(config == kAllFeatures ? "all features, " : "specialised, ") +
                   gpu.variant + " shader");
    pipeline += gpu.seconds_pipeline;
    state.ResumeTiming();
    gpu.render(0, kSpp);
    rays += double(gpu.rays());
  }
  set_counters(state, samples * state.iterations(), rays);
  state.counters["pipeline_s"] = pipeline / double(state.iterations());
}

/// Registers every benchmark for every scene file.
void register_all() {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator("scenes"))
    if (e.path().extension() == ".pbrt") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    std::string name = std::filesystem::path(f).stem().string();
    benchmark::RegisterBenchmark(("gpu/" + name).c_str(), BM_Gpu, f)
        ->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
    benchmark::RegisterBenchmark(("cpu/" + name).c_str(), BM_Cpu, f)
        ->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
    auto* spec = benchmark::RegisterBenchmark(("specialisation/" + name).c_str(),
                                              BM_Specialisation, f);
    spec->ArgName("config")->Arg(kSpecialised)->Arg(kAllFeatures);
    // Diffuse-only scenes get the lean shader: measure the full one too (the saving).
    if (basalt::vkx::GpuRenderer::lean_suffices(tables(f).features)) spec->Arg(kSpecialisedFull);
    spec->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
  }
}

}  // namespace

int main(int argc, char** argv) {
  // Measure compiles, not Mesa's on-disk shader cache.
  setenv("MESA_SHADER_CACHE_DISABLE", "true", 1);
  benchmark::Initialize(&argc, argv);
  register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  g_context.reset();
  return 0;
}
