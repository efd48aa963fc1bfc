// Test helpers shared by the CPU and GPU test executables: scene loading, rendering on
// either side, and statistics over images.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "image/image_io.h"
#include "scene/scene.h"
#include "scene/tables.h"
#include "vk/context.h"

namespace basalt::vkx {
class GpuRenderer;
}

namespace basalt::test {

enum class Side { Cpu, Gpu };
/// "cpu" or "gpu", for test names.
std::string side_name(Side side);

/// Path of a file in the source tree.
std::string source_path(const std::string& relative);
/// \brief The process-wide Vulkan context for GPU tests (device from BASALT_TEST_DEVICE,
///        default "lavapipe"; validation when BASALT_VALIDATION=1).
vkx::Context& gpu_context();

/// \brief A scene with one diffuse material (reflectance 0.5) and an 8 x 8 film; tests add
///        the shapes.
Scene one_material_scene();
/// \brief A w x h environment map: a smooth gradient, a bright one-texel sun and a dark band.
Image sky_map(int w = 32, int h = 32);

/// \brief Parses scene text and builds its tables.
SceneTables tables_from_string(const std::string& text);
/// A small scene head for texture tests (camera, 16 x 16 film, a uniform sky, WorldBegin): the
/// texture tests append their textures, materials and shapes (which start on line 7).
extern const char* const kTexturedHead;
/// \brief The head of a test scene through WorldBegin: `LookAt` \p look (eye, target and up),
/// a perspective camera of \p fov degrees, a \p w x \p h film, the independent sampler at
/// \p spp samples (its default count when 0), the path integrator at \p maxdepth (no Integrator
/// line when negative), then \p options (more lines before WorldBegin, e.g. a PixelFilter).
std::string scene_head(const std::string& look, int fov, int w, int h, int spp = 0,
                       int maxdepth = -1, const std::string& options = "");
/// \brief Tables of kTexturedHead + \p body as file "t.pbrt", relative files resolved in \p dir.
SceneTables textured_scene(const std::string& body, const std::string& dir = ".");
/// \brief The SceneError message of textured_scene(body, dir), or "" if it builds.
std::string textured_scene_error(const std::string& body, const std::string& dir = ".");
/// \brief Parses a scene file, optionally overriding resolution (0 keeps the scene's).
SceneTables tables_from_file(const std::string& path, int width = 0, int height = 0);
/// \brief Replaces the seed of built tables.
void set_seed(SceneTables& tables, std::uint32_t seed);

/// \brief Renders samples [0, spp) and returns per-pixel radiance (accum resolved).
///        GPU renders assert that the validation layer stayed silent.
std::vector<glm::vec3> render(Side side, const SceneTables& tables, std::uint32_t spp);
/// \brief Answers probe queries on either side.
std::vector<gpu::ProbeOut> probe(Side side, const SceneTables& tables,
                                 const std::vector<gpu::ProbeIn>& queries);

/// \brief Answers probe queries on the CPU over \p threads threads (contiguous chunks of the
///        queries; basalt::cpu::probe only reads the tables, as the multithreaded CPU render does).
std::vector<gpu::ProbeOut> probe_cpu_threads(const SceneTables& tables,
                                             const std::vector<gpu::ProbeIn>& queries,
                                             unsigned threads = 2);

/// \brief A GPU probe that keeps its tables, pipeline and query buffers across calls: probe()
///        above builds a new renderer (and lavapipe compiles the probe shader for seconds) on
///        every call; many batches on one scene go through one runner instead. Every run
///        asserts that the validation layer stayed silent.
class ProbeRunner {
 public:
  explicit ProbeRunner(const SceneTables& tables);
  ~ProbeRunner();
  ProbeRunner(const ProbeRunner&) = delete;
  ProbeRunner& operator=(const ProbeRunner&) = delete;
  /// Runs the queries (one dispatch; at most 2^20 per call keeps the buffers in range).
  std::vector<gpu::ProbeOut> run(const std::vector<gpu::ProbeIn>& queries);
  /// Replaces the uploaded Globals (camera, seed, sampler: settings that live in Globals).
  void set_globals(const gpu::Globals& globals);

 private:
  std::unique_ptr<vkx::GpuRenderer> gpu_;
};

/// \brief A PROBE_TEXTURE query with p and uv moved by k ulps of their largest components (p
///        by +-k alternately, so that ratios such as atan2(y, x) move too).
gpu::ProbeIn texture_probe_nudge(gpu::ProbeIn q, int k);
/// \brief A PROBE_ENV query with d turned and u moved by |k| ulps of their largest components,
///        for k in {+-1, +-2, +-4, +-8, +-16}: each k moves one component of d (x, y, z in turn
///        along that list, with k's sign), so that the ten nudges turn d about all three axes
///        (one fixed pattern can run along an iso-line of the map's (u, v)); u.x by -k, u.y by +k.
gpu::ProbeIn env_probe_nudge(gpu::ProbeIn q, int k);
/// \brief Largest relative difference of two PROBE_ENV answers (Le, pdfs, sampled Li and pdf,
///        relative to at least 1e-2; the sampled direction weighted 10x); NaN counts as infinite.
float env_probe_diff(const gpu::ProbeOut& a, const gpu::ProbeOut& b);

/// Fraction of pixels whose every channel agrees within \p rel relative (plus 1e-6 absolute).
double agreeing_fraction(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b,
                         float rel);
/// True if every channel of every pixel is finite.
bool all_finite(const std::vector<glm::vec3>& img);
/// Mean over pixels and channels.
double mean(const std::vector<glm::vec3>& img);

/// The mean of the pixels' channel averages of \p im and its standard error (pixels taken as
/// independent samples).
void mean_and_se(const std::vector<glm::vec3>& im, double& m, double& se);

/// A least-squares line y = intercept + slope x and the standard error of its slope.
struct LineFit {
  double slope, intercept, se_slope;
};
/// \brief Ordinary least squares of \p y on \p x (at least 3 points); se_slope from the
/// residuals.
LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y);

}  // namespace basalt::test
