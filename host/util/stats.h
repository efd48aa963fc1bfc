// Render statistics written by --stats as JSON.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace basalt {

/// Everything --stats reports (keys named as in the JSON).
struct RenderStats {
  std::string device, driver, scene;
  std::string shader_variant;  // Vulkan render shader build ("lean" or "full"); empty on cpu
  bool shader_plain = false;   // the plain build of it (no texture, image-light or bump code)
  int width = 0, height = 0, spp = 0, seed = 0;
  double seconds_parse = 0, seconds_bvh = 0, seconds_upload = 0, seconds_pipeline = 0,
         seconds_render = 0;
  double seconds_specialise = 0;     // of seconds_pipeline: SPIR-V specialisation (vk/specialise.h)
  unsigned second_device_compiles = 0;  // pipelines compiled on a second device (CompileDevice)
  // The wavefront's solo pipeline (GpuRenderer::solo_pipeline): its material (a feature name,
  // "material_diffuse"), empty if none, and the shade dispatches it ran.
  std::string solo_pipeline;
  std::uint64_t solo_dispatches = 0;
  double seconds_to_first_pass = 0;  // from the start of the render command to the first pass done
  double samples_per_second = 0, rays_per_second = 0;
  std::uint64_t rays = 0, nonfinite_samples = 0, peak_rss_bytes = 0, triangles = 0, spheres = 0, lights = 0;
  // Bytes of the scene tables rendered from: the device's buffers (accumulation included), or
  // on cpu the host tables (tables.h table_bytes); and the wavefront's working buffers (paths,
  // lists, radiance: GpuRenderer::wave_bytes), not counted as tables.
  std::uint64_t table_bytes = 0, wave_bytes = 0;
  std::vector<std::string> features;
  std::vector<std::pair<std::string, std::string>> quality;  // quality knobs in force
};

/// \brief Serialises \p stats as a JSON object.
std::string to_json(const RenderStats& stats);
/// \brief Peak resident set size of this process, in bytes.
std::uint64_t peak_rss_bytes();
/// \brief Writes \p text to \p path as write_file_bytes does (util/files.h).
void write_file_atomic(const std::string& path, const std::string& text);

/// \brief A finite number as text with 9 significant digits (JSON and CSV output).
std::string format_number(double v);

}  // namespace basalt
