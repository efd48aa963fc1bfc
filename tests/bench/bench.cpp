// basalt benchmark: samples/s and Mrays/s of every scene in scenes/ on a Vulkan device
// (lavapipe unless BASALT_BENCH_DEVICE names another) and on the CPU reference, and the
// cost of the specialised pipeline against one with every feature compiled in, and for
// diffuse-only scenes of the lean render shader against the full one; the render cost of
// each texture family and each bump family on one scene (texture/<family>/{gpu,cpu},
// bump/<family>/{gpu,cpu}); and displacement mapping's triangles, build time and table size
// at several edge-length scales (displacement/edge-scale-<scale x 1000>); traversal rates of
// lavapipe, the CPU reference and Embree on the same rays (rays/..., tests/bench/rays.cpp);
// and, as a user sees them, pipeline creation and the time to the first pass of samples of
// the `basalt` command cold and warm (pipeline/<scene>/{cold,warm}); the time to pbrt-v4's
// error against pbrt-v4's time, and peak memory against the tables (equal-error/..., memory/...:
// tests/bench/anchors.cpp). Rows that measure an issue 12 target carry it (target_s,
// target_vs_pbrt, target, or vs_cpu >= 1 on gpu/<scene>) beside the figure, and a table at
// the end lists every target row the run measured with its anchor, ratio and whether it is met
// (tests/bench/targets.h).
// Run: `cmake --build build --target bench` (5 repetitions, medians reported).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <memory>
#include <string>

#include <unistd.h>

#include "bench/anchors.h"
#include "bench/rays.h"
#include "bench/targets.h"
#include "cpu/render.h"
#include "scene/scene.h"
#include "scene/tables.h"
#include "scene/textures.h"
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
/// vs_cpu: its samples/s over the CPU reference's, rendering the same in the same benchmark
/// (issue 12's target: at least 1 on every scene).
void BM_Gpu(benchmark::State& state, std::string path) {
  const auto& t = tables(path);
  basalt::vkx::GpuRenderer gpu(context(), t);
  const double samples = double(t.width()) * t.height() * kSpp;
  double rays = 0, gpu_seconds = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    gpu.clear();
    gpu.render(0, kSpp);
    rays += double(gpu.rays());
    gpu_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  set_counters(state, samples * state.iterations(), rays);
  state.counters["pipeline_s"] = gpu.seconds_pipeline;
  std::vector<glm::vec4> accum(std::size_t(t.width()) * t.height(), glm::vec4(0.0f));
  const auto t0 = std::chrono::steady_clock::now();
  basalt::cpu::render(t, 0, kSpp, accum);
  const double cpu_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  state.counters["vs_cpu"] = cpu_seconds / (gpu_seconds / double(state.iterations()));
}

/// The `basalt` command next to this benchmark, rendering one sample per pixel of a scene with
/// its own caches (Mesa's shader cache and basalt's specialised SPIR-V) in a fresh directory:
/// cold empties them before each run, warm fills them once first. Reports the command's
/// seconds_pipeline (the row's time) and seconds_to_first_pass, with issue 12's targets
/// (pipeline: 2 s cold, 0.3 s warm; first pass of the Cornell box: 0.5 s cold).
void BM_PipelineProcess(benchmark::State& state, std::string path, bool warm) {
  namespace fs = std::filesystem;
  const fs::path exe = fs::read_symlink("/proc/self/exe").parent_path() / "basalt";
  const fs::path dir = fs::temp_directory_path() /
                       ("basalt-bench-" + std::to_string(::getpid()) + "-" +
                        fs::path(path).stem().string());
  const std::string command =
      "env -u MESA_SHADER_CACHE_DISABLE MESA_SHADER_CACHE_DIR='" + (dir / "mesa").string() +
      "' BASALT_CACHE_DIR='" + (dir / "basalt").string() + "' '" + exe.string() + "' '" + path +
      "' --spp 1 --quiet -o '" + (dir / "out.exr").string() + "' --stats '" +
      (dir / "stats.json").string() + "' >/dev/null 2>&1";
  // The value of a "key": number pair of the stats file.
  auto stat = [&](const std::string& key) {
    std::ifstream in(dir / "stats.json");
    const std::string text{std::istreambuf_iterator<char>(in), {}};
    const auto at = text.find("\"" + key + "\":");
    return at == std::string::npos ? -1.0 : std::atof(text.c_str() + at + key.size() + 3);
  };
  fs::remove_all(dir);
  fs::create_directories(dir);
  if (warm && std::system(command.c_str()) != 0) state.SkipWithError("basalt failed");
  double pipeline = 0, first_pass = 0, second_device = 0;
  for (auto _ : state) {
    if (!warm) {
      fs::remove_all(dir / "mesa");
      fs::remove_all(dir / "basalt");
    }
    if (std::system(command.c_str()) != 0) {
      state.SkipWithError("basalt failed");
      break;
    }
    pipeline += stat("seconds_pipeline");
    first_pass += stat("seconds_to_first_pass");
    second_device += std::max(0.0, stat("second_device_compiles"));
    state.SetIterationTime(stat("seconds_pipeline"));
  }
  fs::remove_all(dir);
  const double n = double(std::max<benchmark::IterationCount>(1, state.iterations()));
  state.counters["pipeline_s"] = pipeline / n;
  state.counters["first_pass_s"] = first_pass / n;
  // Pipelines compiled on a second device as well (CompileDevice): a cold run's group 0.
  state.counters["second_device"] = second_device / n;
  state.counters["target_s"] = warm ? 0.3 : 2.0;
  if (!warm && fs::path(path).stem() == "cornell-box") state.counters["first_pass_target_s"] = 0.5;
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
  kTexturesForced = 3,   // scene's features plus every texture and image-light bit (what a
                         // scene without textures would pay if they were not specialised away)
  kBumpForced = 4,       // scene's features plus the bump, normal-map and vector-turbulence
                         // code (FEATURES2; registered for textured scenes without them)
  kTexturedBuild = 5,    // scene's features, the textured build of the lean or wavefront
                         // shaders where the plain one would do (registered for plain scenes)
};

/// Pipeline creation (with the driver's compile at first dispatch) and render speed for one
/// Config; the label names the configuration and the render shader build (lean or full).
void BM_Specialisation(benchmark::State& state, std::string path) {
  const auto& t = tables(path);
  const auto config = Config(state.range(0));
  const std::uint32_t texture_bits = basalt::gpu::FEATURE_TEXTURES | basalt::gpu::FEATURE_TEX_NOISE |
                                     basalt::gpu::FEATURE_TEX_IMAGE |
                                     basalt::gpu::FEATURE_LIGHT_INFINITE_IMAGE;
  const std::uint32_t features = config == kAllFeatures      ? 0xffffffffu
                                 : config == kTexturesForced ? t.features | texture_bits
                                                             : t.features;
  const auto variant = config == kSpecialisedFull ? basalt::vkx::ShaderVariant::full
                                                  : basalt::vkx::ShaderVariant::automatic;
  const double samples = double(t.width()) * t.height() * kSpp;
  // The bump code lives in the second feature word (specialization constant FEATURES2).
  basalt::SceneTables forced;
  if (config == kBumpForced) {
    forced = t;
    forced.features2 |= basalt::gpu::FEATURE2_BUMP | basalt::gpu::FEATURE2_NORMALMAP |
                        basalt::gpu::FEATURE2_VTURB;
    forced.globals.features.y = forced.features2;
  }
  const basalt::SceneTables& used = config == kBumpForced ? forced : t;
  double pipeline = 0, rays = 0;
  for (auto _ : state) {
    state.PauseTiming();
    basalt::vkx::GpuRenderer::plain_builds = config != kTexturedBuild;
    basalt::vkx::GpuRenderer gpu(context(), used, features, variant);
    basalt::vkx::GpuRenderer::plain_builds = true;
    state.SetLabel(std::string(config == kAllFeatures      ? "all features, "
                               : config == kTexturesForced ? "texture code forced in, "
                               : config == kBumpForced     ? "bump code forced in, "
                               : config == kTexturedBuild  ? "textured build, "
                                                           : "specialised, ") +
                   gpu.variant + (gpu.plain ? " shader, plain build" : " shader"));
    pipeline += gpu.seconds_pipeline;
    state.ResumeTiming();
    gpu.render(0, kSpp);
    rays += double(gpu.rays());
  }
  set_counters(state, samples * state.iterations(), rays);
  state.counters["pipeline_s"] = pipeline / double(state.iterations());
}

/// Texture families compared by BM_TextureFamily: one scene (a floor and nine spheres under a
/// distant light and a sky, 160x120) whose every reflectance is the named texture.
const std::vector<std::pair<std::string, std::string>>& texture_families() {
  static const std::vector<std::pair<std::string, std::string>> f = {
      {"none", "Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.4 0.3 ]"},
      {"constant", "Texture \"t\" \"spectrum\" \"constant\" \"rgb value\" [ 0.5 0.4 0.3 ]"},
      {"checkerboard", "Texture \"t\" \"spectrum\" \"checkerboard\" \"float uscale\" 8 "
                       "\"float vscale\" 8 \"rgb tex1\" [ 0.8 0.8 0.8 ] \"rgb tex2\" [ 0.1 0.1 0.1 ]"},
      {"fbm", "Texture \"f\" \"float\" \"fbm\" \"integer octaves\" 8\n"
              "Texture \"t\" \"spectrum\" \"scale\" \"rgb tex\" [ 0.5 0.4 0.3 ] \"texture scale\" \"f\""},
      {"fbm-fp32", "Texture \"f\" \"float\" \"fbm\" \"integer octaves\" 8\n"
                   "Texture \"t\" \"spectrum\" \"scale\" \"rgb tex\" [ 0.5 0.4 0.3 ] \"texture scale\" \"f\""},
      {"marble", "Texture \"t\" \"spectrum\" \"marble\" \"float scale\" 3"},
      {"imagemap-bilinear", "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                            "\"data/tex-card.png\" \"string filter\" \"bilinear\""},
      {"imagemap-trilinear", "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                             "\"data/tex-card.png\" \"string filter\" \"trilinear\""},
      {"imagemap-ewa", "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                       "\"data/tex-card.png\" \"string filter\" \"ewa\""},
      {"solidnoise", "Texture \"t\" \"spectrum\" \"solidturbulence\" \"integer octaves\" 6"},
  };
  return f;
}

/// The scene of the texture and bump families (a floor and nine spheres under a distant light
/// and a sky, 160x120) with \p defs (Texture and Material lines) before the shapes.
std::string family_scene(const std::string& defs) {
  std::string text =
      "LookAt 0 3 -7  0 0.5 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n"
      "Film \"rgb\" \"integer xresolution\" 160 \"integer yresolution\" 120\n"
      "Sampler \"independent\"\n"  // as the figures in docs/performance.md were measured
      "Integrator \"path\" \"integer maxdepth\" 5\nWorldBegin\n"
      "LightSource \"infinite\" \"rgb L\" [ 0.4 0.4 0.5 ]\n"
      "LightSource \"distant\" \"point3 from\" [ -2 5 -3 ] \"rgb L\" [ 2 2 2 ]\n" + defs + "\n";
  text += "Shape \"trianglemesh\" \"integer indices\" [ 0 1 2 0 2 3 ] \"point3 P\" "
          "[ -10 0 -10 10 0 -10 10 0 10 -10 0 10 ] \"point2 uv\" [ 0 0 1 0 1 1 0 1 ]\n";
  for (int k = 0; k < 9; ++k)
    text += "AttributeBegin\nTranslate " + std::to_string(-2.4 + 2.4 * (k % 3)) + " 0.6 " +
            std::to_string(-1.5 + 1.6 * (k / 3)) + "\nShape \"sphere\" \"float radius\" 0.6\n"
            "AttributeEnd\n";
  return text;
}

/// Tables of the texture-family scene for family \p i, cached.
const basalt::SceneTables& family_tables(std::size_t i) {
  static std::map<std::size_t, basalt::SceneTables> cache;
  auto it = cache.find(i);
  if (it != cache.end()) return it->second;
  const auto& [name, def] = texture_families()[i];
  std::string defs = def;
  if (name != "none") defs += "\nMaterial \"diffuse\" \"texture reflectance\" \"t\"";
  basalt::SceneTables t =
      basalt::build_tables(basalt::load_scene_from_string(family_scene(defs), name, "scenes"));
  if (name == "fbm-fp32") basalt::apply_texture_knobs(t, -1, 0, false);
  return cache.emplace(i, std::move(t)).first->second;
}

/// Bump families compared by BM_BumpFamily on the family scene: every surface diffuse, with
/// no bump, or bumped by the named displacement (docs/bump-spec.md), normal map or vector
/// turbulence. The "-central" family takes --bump-differences central.
const std::vector<std::pair<std::string, std::string>>& bump_families() {
  static const std::string fbm =
      "Texture \"f\" \"float\" \"fbm\" \"integer octaves\" 8\n"
      "Texture \"d\" \"float\" \"scale\" \"texture tex\" \"f\" \"float scale\" 0.02\n";
  static const std::string diffuse = "Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.4 0.3 ] ";
  static const std::vector<std::pair<std::string, std::string>> f = {
      {"none", diffuse},
      {"constant", diffuse + "\"float displacement\" 0.01"},
      {"fbm", fbm + diffuse + "\"texture displacement\" \"d\""},
      {"fbm-central", fbm + diffuse + "\"texture displacement\" \"d\""},
      {"image", "Texture \"i\" \"float\" \"imagemap\" \"string filename\" "
                "\"data/tex-rings16.png\" \"string encoding\" \"linear\"\n"
                "Texture \"d\" \"float\" \"scale\" \"texture tex\" \"i\" \"float scale\" 0.01\n" +
                    diffuse + "\"texture displacement\" \"d\""},
      {"normalmap", diffuse + "\"string normalmap\" \"data/normal-domes.png\""},
      {"vturb", diffuse + "\"float normalturbulence\" 0.08 \"float normalturbulencescale\" 8"},
  };
  return f;
}

/// Tables of the bump-family scene for family \p i, cached.
const basalt::SceneTables& bump_family_tables(std::size_t i) {
  static std::map<std::size_t, basalt::SceneTables> cache;
  auto it = cache.find(i);
  if (it != cache.end()) return it->second;
  const auto& [name, def] = bump_families()[i];
  basalt::SceneTables t =
      basalt::build_tables(basalt::load_scene_from_string(family_scene(def), name, "scenes"));
  if (name == "fbm-central") basalt::apply_bump_knobs(t, true, true, 0.0f);
  return cache.emplace(i, std::move(t)).first->second;
}

/// One timed render of \p t (kSpp) on the GPU or the CPU reference, with its counters;
/// pipeline creation is not timed.
void render_family(benchmark::State& state, const basalt::SceneTables& t, bool cpu) {
  const double samples = double(t.width()) * t.height() * kSpp;
  double rays = 0;
  std::unique_ptr<basalt::vkx::GpuRenderer> gpu;
  if (!cpu) gpu = std::make_unique<basalt::vkx::GpuRenderer>(context(), t);
  std::vector<glm::vec4> accum;
  for (auto _ : state) {
    if (cpu) {
      accum.assign(std::size_t(t.width()) * t.height(), glm::vec4(0.0f));
      rays += double(basalt::cpu::render(t, 0, kSpp, accum));
    } else {
      gpu->clear();
      gpu->render(0, kSpp);
      rays += double(gpu->rays());
    }
  }
  set_counters(state, samples * state.iterations(), rays);
  if (gpu) state.counters["pipeline_s"] = gpu->seconds_pipeline;
}

/// Render cost of one texture family (argument: index into texture_families()) on the GPU
/// (range(1) = 0) or the CPU reference (1); pipeline creation is not timed.
void BM_TextureFamily(benchmark::State& state) {
  const bool cpu = state.range(1) == 1;
  state.SetLabel(texture_families()[std::size_t(state.range(0))].first + (cpu ? ", cpu" : ", gpu"));
  render_family(state, family_tables(std::size_t(state.range(0))), cpu);
}

/// Render cost of one bump family (argument: index into bump_families()) on the GPU
/// (range(1) = 0) or the CPU reference (1); pipeline creation is not timed.
void BM_BumpFamily(benchmark::State& state) {
  const bool cpu = state.range(1) == 1;
  state.SetLabel(bump_families()[std::size_t(state.range(0))].first + (cpu ? ", cpu" : ", gpu"));
  render_family(state, bump_family_tables(std::size_t(state.range(0))), cpu);
}

/// Displacement mapping's cost on the host (docs/bump-spec.md, scene-format "Displacement"):
/// scenes/displacement.pbrt with --displacement-edge-scale range(0) / 1000; times parse plus
/// table and BVH build, and reports the triangles and the bytes of the triangle, vertex and
/// BVH tables.
void BM_Displacement(benchmark::State& state) {
  const float scale = float(state.range(0)) / 1000.0f;
  std::size_t tris = 0, bytes = 0;
  double bvh = 0;
  for (auto _ : state) {
    basalt::Scene scene = basalt::load_scene("scenes/displacement.pbrt");
    scene.displacement_edge_scale = scale;
    basalt::BuildTimes times;
    const basalt::SceneTables t = basalt::build_tables(scene, &times);
    tris = t.triangles.size();
    bytes = t.triangles.size() * sizeof(t.triangles[0]) + t.vertices.size() * sizeof(t.vertices[0]) +
            t.nodes.size() * sizeof(t.nodes[0]) + t.prim_refs.size() * sizeof(std::uint32_t);
    bvh = times.seconds_bvh;
  }
  state.counters["triangles"] = double(tris);
  state.counters["table_MiB"] = double(bytes) / (1024.0 * 1024.0);
  state.counters["bvh_s"] = bvh;
}

/// Registers every benchmark for every scene file.
// The processor as /proc/cpuinfo names it, with its family and model: two machines both called
// "AMD EPYC" with 2 cores at 2.6 GHz ran lavapipe at 0.53-0.87 of the CPU reference's speed on
// the same scenes (docs/performance.md, thirteenth session), so the header says which it was.
std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::map<std::string, std::string> fields;
  for (std::string line; std::getline(in, line) && !line.empty();) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string key = line.substr(0, colon);
    key.erase(key.find_last_not_of(" \t") + 1);
    fields[key] = colon + 2 <= line.size() ? line.substr(colon + 2) : "";
  }
  if (fields.count("model name") == 0) return "unknown";
  return fields["model name"] + " (family " + fields["cpu family"] + ", model " +
         fields["model"] + ")";
}

void register_all() {
  for (std::size_t i = 0; i < texture_families().size(); ++i)
    for (int side = 0; side < 2; ++side)
      benchmark::RegisterBenchmark(("texture/" + texture_families()[i].first +
                                    (side ? "/cpu" : "/gpu")).c_str(),
                                   BM_TextureFamily)
          ->Args({int(i), side})
          ->Unit(benchmark::kMillisecond)
          ->Iterations(1)
          ->UseRealTime();
  for (std::size_t i = 0; i < bump_families().size(); ++i)
    for (int side = 0; side < 2; ++side)
      benchmark::RegisterBenchmark(("bump/" + bump_families()[i].first +
                                    (side ? "/cpu" : "/gpu")).c_str(),
                                   BM_BumpFamily)
          ->Args({int(i), side})
          ->Unit(benchmark::kMillisecond)
          ->Iterations(1)
          ->UseRealTime();
  for (int scale : {1000, 500, 250, 125})
    benchmark::RegisterBenchmark(("displacement/edge-scale-" + std::to_string(scale)).c_str(),
                                 BM_Displacement)
        ->Arg(scale)
        ->Unit(benchmark::kMillisecond)
        ->Iterations(1)
        ->UseRealTime();
  basalt::bench::register_rays(context);
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator("scenes"))
    if (e.path().extension() == ".pbrt") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  basalt::bench::register_anchors(files);
  for (const auto& f : files) {
    std::string name = std::filesystem::path(f).stem().string();
    benchmark::RegisterBenchmark(("gpu/" + name).c_str(), BM_Gpu, f)
        ->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
    benchmark::RegisterBenchmark(("cpu/" + name).c_str(), BM_Cpu, f)
        ->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
    for (bool warm : {false, true})
      benchmark::RegisterBenchmark(("pipeline/" + name + (warm ? "/warm" : "/cold")).c_str(),
                                   BM_PipelineProcess, f, warm)
          ->Unit(benchmark::kMillisecond)->Iterations(1)->UseManualTime();
    auto* spec = benchmark::RegisterBenchmark(("specialisation/" + name).c_str(),
                                              BM_Specialisation, f);
    spec->ArgName("config")->Arg(kSpecialised)->Arg(kAllFeatures);
    // Scenes without textures: what the texture code would cost them.
    if (!(tables(f).features & basalt::gpu::FEATURE_TEXTURES)) spec->Arg(kTexturesForced);
    // Textured scenes without bumps: what the bump code would cost them.
    constexpr std::uint32_t kBumpBits = basalt::gpu::FEATURE2_BUMP |
                                        basalt::gpu::FEATURE2_NORMALMAP | basalt::gpu::FEATURE2_VTURB;
    if ((tables(f).features & basalt::gpu::FEATURE_TEXTURES) && !(tables(f).features2 & kBumpBits))
      spec->Arg(kBumpForced);
    // Scenes of the plain builds: measure the textured build too (the build-time pruning's
    // saving, which is spirv-opt's time at the scene: both caches are off here).
    if (basalt::vkx::GpuRenderer::plain_suffices(tables(f).features, tables(f).features2))
      spec->Arg(kTexturedBuild);
    // Diffuse-only scenes get the lean shader: measure the full one too (the saving).
    if (basalt::vkx::GpuRenderer::lean_suffices(tables(f).features)) spec->Arg(kSpecialisedFull);
    spec->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
  }
}

}  // namespace

int main(int argc, char** argv) {
  // Measure compiles, not the on-disk caches.
  setenv("MESA_SHADER_CACHE_DISABLE", "true", 1);
  setenv("BASALT_CACHE_DIR", "off", 1);  // and not basalt's cache of specialised SPIR-V
  // The display the flags ask for (console or json), wrapped by the reporter that keeps
  // the figures of the issue 12 targets table printed at the end.
  std::string format = "console";
  bool tabular = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--benchmark_format=", 0) == 0) format = a.substr(19);
    if (a == "--benchmark_counters_tabular" || a == "--benchmark_counters_tabular=true")
      tabular = true;
  }
  benchmark::Initialize(&argc, argv);
  std::unique_ptr<benchmark::BenchmarkReporter> display;
  if (format == "json") {
    display = std::make_unique<benchmark::JSONReporter>();
  } else {
    if (format != "console")
      std::cerr << "basalt_bench: --benchmark_format=" << format
                << " is not supported here (console or json); showing the console format\n";
    int opts = ::isatty(STDOUT_FILENO) ? benchmark::ConsoleReporter::OO_Color
                                       : benchmark::ConsoleReporter::OO_None;
    if (tabular) opts |= benchmark::ConsoleReporter::OO_Tabular;
    display = std::make_unique<benchmark::ConsoleReporter>(
        benchmark::ConsoleReporter::OutputOptions(opts));
  }
  register_all();
  // The figures depend on the driver's version (docs/performance.md, twelfth session: lavapipe
  // of Mesa 22.3 and of Mesa 25.0 on the same machine), so the header names it.
  try {
    benchmark::AddCustomContext("vulkan_driver", context().info().driver);
  } catch (const std::exception& e) {
    benchmark::AddCustomContext("vulkan_driver", std::string("none (") + e.what() + ")");
  }
  benchmark::AddCustomContext("cpu_model", cpu_model());
  basalt::bench::TargetsReporter reporter(std::move(display));
  benchmark::RunSpecifiedBenchmarks(&reporter);
  // After a json display the table goes to stderr, keeping stdout parseable.
  basalt::bench::print_targets(basalt::bench::target_rows(reporter.figures()),
                               format == "console" ? std::cout : std::cerr);
  benchmark::Shutdown();
  basalt::bench::release_rays();
  g_context.reset();
  return 0;
}
