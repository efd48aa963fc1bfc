// Test helpers shared by the CPU and GPU test executables.
#include "common/test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <thread>

#include "cpu/probe.h"
#include "cpu/render.h"
#include "image/image_io.h"
#include "vk/gpu_renderer.h"

namespace basalt::test {

std::string side_name(Side side) { return side == Side::Cpu ? "cpu" : "gpu"; }

std::string source_path(const std::string& relative) {
  return std::string(BASALT_SOURCE_DIR) + "/" + relative;
}

namespace {

std::unique_ptr<vkx::Context> g_context;

/// Destroys the shared context after the last test, before static destructors run: the
/// Vulkan driver's own globals may be gone by then (destroying it at exit crashed).
class GpuEnvironment : public ::testing::Environment {
 public:
  void TearDown() override { g_context.reset(); }
};

[[maybe_unused]] ::testing::Environment* const g_environment =
    ::testing::AddGlobalTestEnvironment(new GpuEnvironment);

}  // namespace

vkx::Context& gpu_context() {
  auto& ctx = g_context;
  if (!ctx) {
    const char* dev = std::getenv("BASALT_TEST_DEVICE");
    ctx = std::make_unique<vkx::Context>(dev ? dev : "lavapipe",
                                         vkx::Context::validation_requested());
  }
  return *ctx;
}

SceneTables tables_from_string(const std::string& text) {
  return build_tables(load_scene_from_string(text, "test.pbrt", source_path("scenes")));
}

std::string scene_head(const std::string& look, int fov, int w, int h, int spp, int maxdepth,
                       const std::string& options) {
  // The independent sampler, whatever the sample count rendered (a scene without a Sampler
  // statement gets zsobol, built for its pixelsamples): with no count, on the Film line, so
  // that the lines of what follows are where they were.
  std::string s = "\nLookAt " + look + "\nCamera \"perspective\" \"float fov\" [ " +
                  std::to_string(fov) + " ]\nFilm \"rgb\" \"integer xresolution\" [ " +
                  std::to_string(w) + " ] \"integer yresolution\" [ " + std::to_string(h) + " ]";
  if (spp > 0)
    s += "\nSampler \"independent\" \"integer pixelsamples\" [ " + std::to_string(spp) + " ]\n";
  else
    s += " Sampler \"independent\"\n";
  if (maxdepth >= 0)
    s += "Integrator \"path\" \"integer maxdepth\" [ " + std::to_string(maxdepth) + " ]\n";
  return s + options + "WorldBegin\n";
}

const char* const kTexturedHead = R"(
LookAt 0 3 -8  0 0.5 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ] Sampler "independent"
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
)";

SceneTables textured_scene(const std::string& body, const std::string& dir) {
  return build_tables(load_scene_from_string(kTexturedHead + body, "t.pbrt", dir));
}

std::string textured_scene_error(const std::string& body, const std::string& dir) {
  try {
    textured_scene(body, dir);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

SceneTables tables_from_file(const std::string& path, int width, int height) {
  Scene scene = load_scene(path);
  if (width > 0) scene.film.xres = width;
  if (height > 0) scene.film.yres = height;
  return build_tables(scene);
}

void set_seed(SceneTables& tables, std::uint32_t seed) { tables.globals.image.w = seed; }

std::vector<glm::vec3> render(Side side, const SceneTables& tables, std::uint32_t spp) {
  std::vector<glm::vec4> accum;
  if (side == Side::Cpu) {
    accum.assign(std::size_t(tables.width()) * tables.height(), glm::vec4(0.0f));
    std::uint64_t nonfinite = 0;
    cpu::render(tables, 0, spp, accum, {}, &nonfinite);
    EXPECT_EQ(nonfinite, 0u) << "CPU samples with NaN or infinite radiance";
  } else {
    auto& ctx = gpu_context();
    const std::size_t before = ctx.validation_errors();
    vkx::GpuRenderer gpu(ctx, tables);
    gpu.render(0, spp);
    accum = gpu.accum();
    EXPECT_EQ(gpu.nonfinite_samples(), 0u) << "GPU samples with NaN or infinite radiance";
    EXPECT_EQ(ctx.validation_errors(), before) << "Vulkan validation errors";
  }
  return resolve(accum, int(tables.width()), int(tables.height())).pixels;
}

std::vector<gpu::ProbeOut> probe(Side side, const SceneTables& tables,
                                 const std::vector<gpu::ProbeIn>& queries) {
  if (side == Side::Cpu) return cpu::probe(tables, queries);
  auto& ctx = gpu_context();
  const std::size_t before = ctx.validation_errors();
  // Upload only: the probe builds its own pipeline (lavapipe compiles a render pipeline too
  // slowly to build one that is never used).
  vkx::GpuRenderer gpu(ctx, tables, tables.features, vkx::ShaderVariant::automatic, false);
  auto out = gpu.probe(queries);
  EXPECT_EQ(ctx.validation_errors(), before) << "Vulkan validation errors";
  return out;
}

std::vector<gpu::ProbeOut> probe_cpu_threads(const SceneTables& tables,
                                             const std::vector<gpu::ProbeIn>& queries,
                                             unsigned threads) {
  threads = std::max(1u, std::min<unsigned>(threads, unsigned(queries.size() / 1024 + 1)));
  if (threads == 1) return cpu::probe(tables, queries);
  std::vector<gpu::ProbeOut> out(queries.size());
  const std::size_t chunk = (queries.size() + threads - 1) / threads;
  auto work = [&](std::size_t b) {
    const std::size_t e = std::min(queries.size(), b + chunk);
    const std::vector<gpu::ProbeIn> in(queries.begin() + std::ptrdiff_t(b),
                                       queries.begin() + std::ptrdiff_t(e));
    const std::vector<gpu::ProbeOut> r = cpu::probe(tables, in);
    std::copy(r.begin(), r.end(), out.begin() + std::ptrdiff_t(b));
  };
  std::vector<std::thread> pool;
  for (unsigned k = 1; k < threads; ++k) pool.emplace_back(work, k * chunk);
  work(0);
  for (std::thread& t : pool) t.join();
  return out;
}

ProbeRunner::ProbeRunner(const SceneTables& tables)
    : gpu_(std::make_unique<vkx::GpuRenderer>(gpu_context(), tables, tables.features,
                                              vkx::ShaderVariant::automatic, false)) {}

ProbeRunner::~ProbeRunner() = default;

std::vector<gpu::ProbeOut> ProbeRunner::run(const std::vector<gpu::ProbeIn>& queries) {
  auto& ctx = gpu_context();
  const std::size_t before = ctx.validation_errors();
  auto out = gpu_->probe(queries);
  EXPECT_EQ(ctx.validation_errors(), before) << "Vulkan validation errors";
  return out;
}

void ProbeRunner::set_globals(const gpu::Globals& globals) { gpu_->set_globals(globals); }

double agreeing_fraction(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b,
                         float rel) {
  if (a.size() != b.size() || a.empty()) return 0.0;
  std::size_t ok = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    bool agree = true;
    for (int c = 0; c < 3; ++c) {
      float x = a[i][c], y = b[i][c];
      agree &= std::abs(x - y) <= rel * std::max(std::abs(x), std::abs(y)) + 1e-6f;
    }
    ok += agree;
  }
  return double(ok) / double(a.size());
}

bool all_finite(const std::vector<glm::vec3>& img) {
  for (const auto& p : img)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return false;
  return true;
}

double mean(const std::vector<glm::vec3>& img) {
  double s = 0.0;
  for (const auto& p : img) s += double(p.x) + p.y + p.z;
  return img.empty() ? 0.0 : s / (3.0 * img.size());
}

void mean_and_se(const std::vector<glm::vec3>& im, double& m, double& se) {
  double s = 0, s2 = 0;
  for (const glm::vec3& p : im) {
    const double v = (double(p.x) + double(p.y) + double(p.z)) / 3.0;
    s += v;
    s2 += v * v;
  }
  const double k = double(im.size());
  m = s / k;
  se = std::sqrt(std::max(0.0, s2 / k - m * m) / k);
}

LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = double(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sx += x[i];
    sy += y[i];
    sxx += x[i] * x[i];
    sxy += x[i] * y[i];
  }
  LineFit f{};
  f.slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  f.intercept = (sy - f.slope * sx) / n;
  double rss = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = y[i] - f.intercept - f.slope * x[i];
    rss += r * r;
  }
  f.se_slope = std::sqrt(rss / (n - 2) * n / (n * sxx - sx * sx));
  return f;
}

gpu::ProbeIn env_probe_nudge(gpu::ProbeIn q, int k) {
  auto ulp_of = [](float a, float b, float c) {
    const float m = std::max(std::fabs(a), std::max(std::fabs(b), std::fabs(c)));
    return std::nextafter(m, INFINITY) - m;
  };
  const int mag = std::abs(k);
  const int step = 2 * std::countr_zero(unsigned(mag)) + (k < 0 ? 1 : 0);  // k's place in the list
  const float sd = float(k) * ulp_of(q.d.x, q.d.y, q.d.z);
  const float su = float(k) * ulp_of(q.extra.x, q.extra.y, 0.0f);
  q.d[step % 3] += sd;
  q.extra.x = std::clamp(q.extra.x - su, 0.0f, 0x1.fffffep-1f);
  q.extra.y = std::clamp(q.extra.y + su, 0.0f, 0x1.fffffep-1f);
  return q;
}

float env_probe_diff(const gpu::ProbeOut& a, const gpu::ProbeOut& b) {
  auto rel = [](float x, float y) {
    return std::fabs(x - y) / std::max(1e-2f, std::max(std::fabs(x), std::fabs(y)));
  };
  float d = 0.0f;
  for (int c = 0; c < 4; ++c) {
    d = std::max(d, rel(a.f0[c], b.f0[c]));
    d = std::max(d, rel(a.f2[c], b.f2[c]));
  }
  d = std::max(d, rel(a.f1.w, b.f1.w));
  d = std::max(d, rel(a.f3.x, b.f3.x));
  d = std::max(d, 10.0f * glm::length(glm::vec3(a.f1) - glm::vec3(b.f1)));  // 1e-5 -> 1e-4
  return std::isnan(d) ? INFINITY : d;
}

Scene one_material_scene() {
  Scene s;
  s.film.xres = s.film.yres = 8;
  Material m;
  m.type = "diffuse";
  m.params["reflectance"] = MaterialParam{{0.5f, 0.5f, 0.5f}, "", {}};
  s.materials.push_back(m);
  return s;
}

Image sky_map(int w, int h) {
  Image im{w, h, {}};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      glm::vec3 c(0.2f + 0.6f * float(y) / float(h - 1), 0.3f + 0.4f * float(x) / float(w - 1), 0.8f);
      if (x == w * 5 / 8 && y == h * 9 / 32) c = glm::vec3(400.0f, 350.0f, 300.0f);
      if (y == h * 25 / 32) c *= 0.01f;
      im.pixels.push_back(c);
    }
  return im;
}

gpu::ProbeIn texture_probe_nudge(gpu::ProbeIn q, int k) {
  auto ulp_of = [](float a, float b, float c) {
    const float m = std::max(std::fabs(a), std::max(std::fabs(b), std::fabs(c)));
    return std::nextafter(m, INFINITY) - m;
  };
  const float sp = float(k) * ulp_of(q.o_tmax.x, q.o_tmax.y, q.o_tmax.z);
  const float su = float(k) * ulp_of(q.o_tmax.w, q.d.w, 0.0f);
  q.o_tmax = glm::vec4(q.o_tmax.x + sp, q.o_tmax.y - sp, q.o_tmax.z + sp, q.o_tmax.w - su);
  q.d.w = q.d.w + su;
  return q;
}

}  // namespace basalt::test
