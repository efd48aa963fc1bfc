// basalt command line: parse a pbrt-v4 scene, render it on a Vulkan device or the CPU
// reference, write EXR/PNG and optional JSON statistics.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <unistd.h>

#include "basalt_version.h"  // generated at build time (cmake/version.cmake)
#include "cpu/render.h"
#include "image/image_io.h"
#include "scene/materials.h"
#include "scene/samplers.h"
#include "scene/scene.h"
#include "scene/tables.h"
#include "util/cli_options.h"
#include "util/files.h"
#include "util/progress.h"
#include "scene/textures.h"
#include "study/study.h"
#include "util/stats.h"
#include "vk/context.h"
#include "vk/gpu_renderer.h"

namespace {

using Clock = std::chrono::steady_clock;

/// Seconds since \p t0.
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Exit codes: 0 success, 1 bad input or render failure, 2 bad command line,
/// 3 rendered but the Vulkan validation layer reported errors.
constexpr int kExitInput = 1, kExitValidation = 3;

struct Options {
  std::string scene, device = "auto", stats, mix = "auto", texture_filter = "scene",
              noise_precision = "split", bump_differences = "forward", bump_dndu = "on",
              bump_step = "footprint", shading_normal_rule = "geometric", roulette = "pbrt-v4",
              mis = "power", sampler = "scene", light_sampler = "scene",
              pipeline = "specialised", layered_mis = "basalt";
  int bvh_bins = 32, bvh_leaf = 8, coated_nsamples = 0, coated_maxdepth = 0;
  int max_depth = -1;  // -1: the scene's Integrator "maxdepth"
  int noise_octaves = 0;
  float displacement_edge_scale = 0.0f;  // 0: the scene's Option "displacementedgescale"
  std::vector<std::string> outputs;
  int spp = -1;
  long long seed = -1;
  bool quiet = false;
};

/// Parses, renders and writes; returns the process exit code.
int run(const Options& opt) {
  basalt::RenderStats st;
  st.scene = opt.scene;
  auto t0 = Clock::now();
  const Clock::time_point t_start = t0;
  // --mix: how mix materials render (docs/materials.md "Mix"); checked for that mode.
  basalt::MixMode mix = opt.mix == "stochastic" ? basalt::MixMode::Stochastic
                        : opt.mix == "weighted" ? basalt::MixMode::Weighted
                                                : basalt::MixMode::Auto;
  // The Vulkan device first: its maxStorageBufferRange bounds the film and the geometry tables,
  // checked while parsing, before anything that large is allocated (issue 11, defects 4, 10).
  std::optional<basalt::vkx::Context> ctx;
  if (opt.device != "cpu") ctx.emplace(opt.device, basalt::vkx::Context::validation_requested());
  basalt::Scene scene = basalt::load_scene(
      opt.scene, mix, ctx ? ctx->info().max_storage_buffer_range : basalt::kMaxTableBytes);
  st.seconds_parse = since(t0);
  for (const auto& w : scene.warnings) std::cerr << w << "\n";
  if (opt.spp >= 0) scene.sampler.spp = opt.spp;
  if (opt.displacement_edge_scale > 0.0f)
    scene.displacement_edge_scale = opt.displacement_edge_scale;
  if (opt.seed >= 0) scene.sampler.seed = int(opt.seed);
  if (opt.light_sampler != "scene") scene.integrator.light_sampler = opt.light_sampler;
  scene.bvh_bins = opt.bvh_bins;
  scene.bvh_max_leaf = opt.bvh_leaf;
  if (opt.sampler != "scene") {
    // --sampler: pbrt-v4's sampler of that name with its default randomisation.
    scene.sampler.type = opt.sampler;
    scene.sampler.randomization.clear();
  }
  {
    std::string warning;
    scene.sampler = basalt::resolve_sampler(scene.sampler, &warning);
    if (!warning.empty()) std::cerr << warning << "\n";
  }
  std::vector<std::string> outputs = opt.outputs;
  if (outputs.empty()) outputs.push_back(scene.film.filename);
  for (const auto& output : outputs)
    if (!basalt::is_supported_image_path(output)) {
      std::cerr << (opt.outputs.empty() ? scene.film.loc.str() + ": error: " : "basalt: error: ")
                << "output '" << output << "' must end in .exr or .png\n";
      return kExitInput;
    }
  // Every output must be writable before the render starts (issue 11, defect 11).
  std::vector<std::string> written = outputs;
  if (!opt.stats.empty()) written.push_back(opt.stats);
  for (const auto& path : written) try {
      basalt::check_writable(path);
    } catch (const basalt::FileError& e) {
      std::cerr << "basalt: error: cannot write " << path << ": " << e.what() << "\n";
      return kExitInput;
    }

  basalt::BuildTimes times;
  std::vector<std::string> warnings;
  // The parsed meshes are freed as they are flattened: nothing after this reads them.
  // The CPU reference's own four-wide tree only for the CPU reference.
  basalt::SceneTables tables =
      basalt::build_tables_releasing_meshes(scene, &times, &warnings, opt.device == "cpu");
  for (const auto& w : warnings) std::cerr << w << "\n";
  // Quality knobs (docs/textures.md): --texture-filter, --noise-octaves.
  static const char* kFilters[] = {"point", "bilinear", "trilinear", "ewa"};
  int filter = -1;
  for (int i = 0; i < 4; ++i)
    if (opt.texture_filter == kFilters[i]) filter = i;
  st.quality = basalt::apply_texture_knobs(tables, filter, opt.noise_octaves,
                                           opt.noise_precision == "split");
  {
    // --bump-*: docs/bump-spec.md 4.5; the CLI checks make bump_step "footprint" or a number.
    const float step = opt.bump_step == "footprint" ? 0.0f : std::stof(opt.bump_step);
    for (auto& k : basalt::apply_bump_knobs(tables, opt.bump_differences == "central",
                                            opt.bump_dndu == "on", step))
      st.quality.push_back(k);
    st.quality.push_back(
        basalt::apply_shading_rule(tables, opt.shading_normal_rule == "pbrt-v4"));
    // --maxdepth, --roulette, --mis: docs/path-spec.md 7.1 (the CLI checks the values).
    const std::uint32_t start = opt.roulette == "pbrt-v4" ? 1u
                                : opt.roulette == "off"   ? basalt::gpu::ROULETTE_OFF
                                                          : std::uint32_t(std::stoul(opt.roulette));
    const std::uint32_t mis = opt.mis == "balance" ? basalt::gpu::MIS_BALANCE
                              : opt.mis == "bsdf"  ? basalt::gpu::MIS_BSDF_ONLY
                              : opt.mis == "light" ? basalt::gpu::MIS_LIGHT_ONLY
                                                   : basalt::gpu::MIS_POWER;
    for (auto& k : basalt::apply_path_knobs(tables, opt.max_depth, start, mis))
      st.quality.push_back(k);
    // The sampler and its randomisation (stratified: its jitter), e.g. "halton permutedigits".
    static const char* kRand[] = {"none", "permutedigits", "fastowen", "owen"};
    const glm::uvec4 smp = tables.globals.sampler_opts;
    std::string sampler = scene.sampler.type;
    if (smp.x == basalt::gpu::SAMPLER_STRATIFIED)
      sampler += smp.y ? " jitter" : " no jitter";
    else if (smp.x != basalt::gpu::SAMPLER_INDEPENDENT && smp.x != basalt::gpu::SAMPLER_PMJ02BN)
      sampler += std::string(" ") + kRand[smp.y];  // pmj02bn has Cranley-Patterson offsets only
    st.quality.emplace_back("sampler", sampler);
    st.quality.emplace_back("light_sampler", scene.integrator.light_sampler);
    for (auto& k : basalt::apply_layered_knobs(tables, opt.coated_nsamples, opt.coated_maxdepth,
                                                opt.layered_mis == "pbrt-v4"))
      st.quality.push_back(k);
    st.quality.emplace_back("bvh_bins", std::to_string(opt.bvh_bins));
    st.quality.emplace_back("bvh_leaf", std::to_string(opt.bvh_leaf));
    st.quality.emplace_back("pipeline", opt.pipeline);
    st.quality.emplace_back("displacement_edge_scale",
                            std::to_string(scene.displacement_edge_scale));
  }
  st.seconds_bvh = times.seconds_bvh;
  st.width = int(tables.width());
  st.height = int(tables.height());
  st.spp = scene.sampler.spp;
  st.seed = scene.sampler.seed;
  st.features = basalt::feature_names(tables.features);
  st.triangles = tables.triangles.size();
  st.spheres = tables.spheres.size();
  st.lights = tables.lights.size();
  const std::uint64_t total = std::uint64_t(st.width) * st.height * st.spp;
  // Drawn only on a terminal; its clock starts with the render, after pipeline creation.
  basalt::ProgressBar bar(total, opt.quiet || !::isatty(STDERR_FILENO));
  // Time to the first pass: device, parse, BVH, upload, pipeline and one pass of samples.
  auto progress = [&](double f) {
    if (st.seconds_to_first_pass == 0.0) st.seconds_to_first_pass = since(t_start);
    bar.update(f);
  };

  std::vector<glm::vec4> accum;
  std::size_t validation_errors = 0;
  if (opt.device == "cpu") {
    st.device = "cpu";
    st.driver = "basalt CPU reference";
    accum.assign(std::size_t(st.width) * st.height, glm::vec4(0.0f));
    t0 = Clock::now();
    bar.restart();
    st.table_bytes = basalt::table_bytes(tables);
    st.rays = basalt::cpu::render(tables, 0, std::uint32_t(st.spp), accum, progress,
                                  &st.nonfinite_samples);
    st.seconds_render = since(t0);
  } else {
    st.device = ctx->info().name;
    st.driver = ctx->info().driver;
    // --pipeline all: every feature's code compiled in (a time-only knob: same image).
    // --pipeline wavefront: the wavefront stages instead of the megakernel (same expectation).
    namespace vkx = basalt::vkx;
    const std::uint32_t features = opt.pipeline == "all" ? 0xffffffffu : tables.features;
    const vkx::ShaderVariant variant =
        opt.pipeline == "all"          ? vkx::ShaderVariant::full
        : opt.pipeline == "wavefront"  ? vkx::ShaderVariant::wavefront
        : opt.pipeline == "megakernel" ? (vkx::GpuRenderer::lean_suffices(tables.features)
                                              ? vkx::ShaderVariant::lean
                                              : vkx::ShaderVariant::full)
                                       : vkx::ShaderVariant::automatic;
    // Once on the device the host's copies of the large tables are freed, before the
    // pipelines' compile (LLVM's memory on lavapipe) adds to them: nothing reads them after.
    vkx::GpuRenderer gpu(*ctx, tables, features, variant, true,
                         [&tables] { basalt::release_bulk_tables(tables); });
    st.seconds_upload = gpu.seconds_upload;
    st.seconds_pipeline = gpu.seconds_pipeline;
    st.seconds_specialise = gpu.seconds_specialise;
    st.second_device_compiles = gpu.second_device_compiles;
    st.table_bytes = gpu.device_bytes;
    st.wave_bytes = gpu.wave_bytes;
    st.shader_variant = gpu.variant;
    st.shader_plain = gpu.plain;
    t0 = Clock::now();
    bar.restart();
    gpu.render(0, std::uint32_t(st.spp), progress);
    st.seconds_render = since(t0);
    st.rays = gpu.rays();
    st.nonfinite_samples = gpu.nonfinite_samples();
    if (gpu.solo_type < basalt::gpu::MATERIAL_TYPE_COUNT) {
      st.solo_pipeline = basalt::feature_names(basalt::material_feature(gpu.solo_type)).at(0);
      st.solo_dispatches = gpu.solo_dispatches;
    }
    accum = gpu.accum();
    validation_errors = ctx->validation_errors();
  }
  bar.finish();
  if (st.nonfinite_samples)
    std::cerr << "basalt: warning: " << st.nonfinite_samples
              << " sample(s) had NaN or infinite radiance and were dropped\n";
  st.samples_per_second = st.seconds_render > 0 ? double(total) / st.seconds_render : 0.0;
  st.rays_per_second = st.seconds_render > 0 ? double(st.rays) / st.seconds_render : 0.0;

  const basalt::Image image = basalt::resolve(accum, st.width, st.height);
  for (const auto& output : outputs) basalt::write_image(output, image);
  st.peak_rss_bytes = basalt::peak_rss_bytes();
  if (!opt.stats.empty()) basalt::write_file_atomic(opt.stats, basalt::to_json(st));
  if (!opt.quiet)
    std::fprintf(stderr, "basalt: %s  %dx%d %d spp  %.2f s  %.3g Msamples/s  %.3g Mrays/s  (%s)\n",
                 outputs.front().c_str(), st.width, st.height, st.spp, st.seconds_render,
                 st.samples_per_second * 1e-6, st.rays_per_second * 1e-6, st.device.c_str());
  if (validation_errors) {
    std::cerr << "basalt: error: the Vulkan validation layer reported " << validation_errors
              << " error(s)\n";
    return kExitValidation;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // `basalt study SCENE.pbrt ...` is a command of its own (host/study/study.cpp); anything
  // else renders as before (a scene file named "study" renders as ./study).
  if (argc > 1 && std::string(argv[1]) == "study")
    return basalt::study::study_main(argc - 1, argv + 1);
  CLI::App app{"basalt: physically based rendering of pbrt-v4 scenes in Vulkan compute"};
  app.footer("basalt study SCENE.pbrt [options]: what accuracy costs in time, a sweep of spp and "
             "the quality knobs (basalt study --help)");
  Options opt;
  bool list = false;
  app.add_option("scene", opt.scene, "pbrt-v4 scene file");
  app.add_option("-o,--output", opt.outputs,
                 "output image: .exr (linear float) or .png (sRGB); may be repeated; "
                 "default: the Film's filename");
  app.add_option("--spp", opt.spp, "samples per pixel (default: the scene's Sampler)")
      ->check(CLI::Range(1, 1 << 24));
  app.add_option("--seed", opt.seed, "random seed (default: the scene's Sampler seed)")
      ->check(CLI::Range(0ll, 0xffffffffll));
  app.add_option("--device", opt.device,
                 "auto (a GPU if present, else lavapipe), lavapipe, cpu (the CPU reference), "
                 "or part of a Vulkan device name");
  app.add_option("--bump-step", opt.bump_step,
                 "bump difference step: footprint (pbrt-v4's, from the ray differentials; the "
                 "default) or a fixed step in (u, v) units, e.g. 1e-3")
      ->check([](const std::string& v) -> std::string {
        if (v == "footprint") return {};
        try {
          std::size_t used = 0;
          const float f = std::stof(v, &used);
          if (used == v.size() && f > 0.0f && std::isfinite(f)) return {};
        } catch (const std::exception&) {
        }
        return "must be 'footprint' or a positive number, got '" + v + "'";
      });
  app.add_option("--roulette", opt.roulette,
                 "Russian roulette: pbrt-v4 (the default, = 1), off, or N: roulette may end a path "
                 "once it has bounced more than N times")
      ->check([](const std::string& v) -> std::string {
        if (v == "pbrt-v4" || v == "off") return {};
        if (!v.empty() && v.size() < 7 && v.find_first_not_of("0123456789") == std::string::npos)
          return {};
        return "must be pbrt-v4, off or a bounce count, got '" + v + "'";
      });
  app.add_option("--displacement-edge-scale", opt.displacement_edge_scale,
                 "scale every displaced plymesh's \"edgelength\" (pbrt-v4's option of the same "
                 "name; default: the scene's Option \"displacementedgescale\", else 1)")
      ->check(CLI::PositiveNumber);
  // Quality knobs with a fixed set of values, and integer knobs within a range: a value outside
  // them is a bad command line (exit 2).
  struct Choice {
    const char* name;
    std::string* var;
    const char* help;
    std::vector<std::string> values;
  };
  const Choice choices[] = {
      {"--mix", &opt.mix,
       "mix materials: auto (pbrt-v4 \"materials\" syntax stochastic, pbrt-v3 \"namedmaterial1/2\" "
       "syntax weighted), stochastic or weighted (forces one)",
       {"auto", "stochastic", "weighted"}},
      {"--texture-filter", &opt.texture_filter,
       "override every image map's filter: point, bilinear, trilinear or ewa (default: each "
       "texture's own)",
       {"scene", "point", "bilinear", "trilinear", "ewa"}},
      {"--noise-precision", &opt.noise_precision,
       "noise lookups: split (exact lattice position at any scale, the default) or fp32 (pbrt-v4's "
       "arithmetic)",
       {"split", "fp32"}},
      {"--bump-differences", &opt.bump_differences,
       "bump mapping's finite differences: forward (pbrt-v4, the default) or central",
       {"forward", "central"}},
      {"--bump-dndu", &opt.bump_dndu,
       "the d dn/du term of the bump chain rule: on (pbrt-v4, the default) or off",
       {"on", "off"}},
      {"--mis", &opt.mis,
       "how light and BSDF sampling combine: power (pbrt-v4's power heuristic, the default), "
       "balance, bsdf (BSDF sampling only) or light (light sampling only)",
       {"power", "balance", "bsdf", "light"}},
      {"--shading-normal-rule", &opt.shading_normal_rule,
       "what decides reflection or transmission where shading and geometric normals disagree: "
       "geometric (basalt's default: no light leaks, no black spots) or pbrt-v4 (the shading frame "
       "alone, as pbrt-v4: black spots where a bump tilts the normal away from the light)",
       {"geometric", "pbrt-v4"}},
      {"--sampler", &opt.sampler,
       "sampler instead of the scene's (docs/sampler-spec.md): independent, stratified, halton, "
       "paddedsobol, zsobol, sobol or pmj02bn",
       {"scene", "independent", "stratified", "halton", "paddedsobol", "zsobol", "sobol",
        "pmj02bn"}},
      {"--light-sampler", &opt.light_sampler,
       "light selection instead of the scene's Integrator \"lightsampler\": bvh (default), "
       "exhaustive, power or uniform",
       {"scene", "bvh", "exhaustive", "power", "uniform"}},
      {"--pipeline", &opt.pipeline,
       "GPU pipeline, specialised to the scene's features: specialised (the default: the "
       "wavefront for scenes with a layered material, untextured materials beside textured "
       "ones, or a portal; else the megakernel), megakernel (one shader for the "
       "whole path), wavefront (an extend stage and shading pipelines by material type; the "
       "same image), or all (the megakernel with every feature "
       "compiled in; same image, for timing)",
       {"specialised", "megakernel", "wavefront", "all"}},
      {"--layered-mis", &opt.layered_mis,
       "coated materials' MIS weights: basalt (default, unbiased) or pbrt-v4 (reproduces pbrt-v4's "
       "images; docs/materials-spec.md 2.3)",
       {"basalt", "pbrt-v4"}},
  };
  for (const Choice& c : choices)
    app.add_option(c.name, *c.var, c.help)->check(CLI::IsMember(c.values));
  struct Ranged {
    const char* name;
    int* var;
    const char* help;
    int lo, hi;
  };
  const Ranged ranged[] = {
      {"--noise-octaves", &opt.noise_octaves,
       "cap the octaves of fbm, wrinkled, windy and marble (0: no cap)", 0, 64},
      {"--maxdepth", &opt.max_depth,
       "longest path in bounces (default: the scene's Integrator \"maxdepth\")", 0, 100000},
      {"--bvh-bins", &opt.bvh_bins, "SAH bins per axis of the BVH build (default 32)", 2, 64},
      {"--bvh-leaf", &opt.bvh_leaf, "largest BVH leaf (default 8)", 2, 16},
      {"--coated-nsamples", &opt.coated_nsamples,
       "replace every coated material's \"nsamples\" (default: the scene's)", 1, 1024},
      {"--coated-maxdepth", &opt.coated_maxdepth,
       "replace every coated material's \"maxdepth\" (default: the scene's)", 1, 1024},
  };
  for (const Ranged& r : ranged) basalt::cli::ranged(app, r.name, *r.var, r.help, r.lo, r.hi);
  app.add_option("--stats", opt.stats, "write render statistics as JSON to this file");
  app.add_flag("-q,--quiet", opt.quiet, "no progress bar or summary");
  app.add_flag("--list-devices", list, "list Vulkan devices and exit");
  app.set_version_flag("--version", std::string("basalt ") + BASALT_VERSION + " (commit " +
                                        BASALT_GIT_COMMIT + ")");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help prints and succeeds; any other parse error is a bad command line (exit 2).
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  }
  try {
    if (list) {
      for (const auto& name : basalt::vkx::Context::list_devices()) std::cout << name << "\n";
      return 0;
    }
    if (opt.scene.empty()) {
      std::cerr << app.help();
      return 2;
    }
    basalt::install_cleanup_handlers();  // SIGINT/SIGTERM remove partial output files
    return run(opt);
  } catch (const basalt::SceneError& e) {
    std::cerr << e.what() << "\n";
  } catch (const std::bad_alloc&) {
    std::cerr << "basalt: error: out of memory\n";
  } catch (const std::exception& e) {
    std::cerr << "basalt: error: " << e.what() << "\n";
  }
  return kExitInput;
}
