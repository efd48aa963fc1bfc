// The flattened scene: host copies of every GPU table (layouts from shaders/shared/layout.h).
// Built once from a parsed Scene; uploaded as is to the GPU, read as is by the CPU reference.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "../../shaders/shared/layout.h"
#include "scene.h"

namespace basalt {

namespace cpu {
struct WideBvh;
}

struct SceneTables {
  gpu::Globals globals{};
  std::vector<gpu::BvhNode> nodes;
  std::vector<std::uint32_t> prim_refs;
  std::vector<gpu::Triangle> triangles;
  std::vector<gpu::Vertex> vertices;
  std::vector<gpu::Mesh> meshes;
  std::vector<gpu::Sphere> spheres;
  std::vector<gpu::Material> materials;
  std::vector<gpu::Light> lights;
  std::vector<float> light_cdf;   // lights.size() + 1 entries, cdf[0] = 0, cdf[n] = 1
  std::vector<float> filter_cdf;  // 2 (N + 1) entries for the gaussian filter, else empty
  std::vector<float> measured;    // measured BRDF tables (MATERIAL_MEASURED aux0 offsets), rgb
                                  // interleaved, scale factors applied; may be empty
  std::vector<gpu::Texture> textures;     // texture programs (docs/textures-spec.md 2)
  std::vector<gpu::MipLevel> mip_levels;  // every level of every image (finest first)
  std::vector<float> texels;              // image levels, linear, channel-interleaved
  std::vector<float> tex_data;            // shared tables (docs/textures-spec.md 5)
  std::vector<std::uint32_t> sampler_data;  // primes (docs/sampler-spec.md 3)
  // The CPU reference's own four-wide tree over nodes (cpu/wide_bvh.h), made by build_tables;
  // a device's renderer does not read it (the command line does not make it for one). A
  // tree whose binary nodes were replaced since is not used (cpu::intersect_* walk nodes).
  std::shared_ptr<const cpu::WideBvh> cpu_wide;
  std::uint32_t features = 0;     // FEATURE_* bits
  std::uint32_t features2 = 0;    // FEATURE2_* bits

  std::uint32_t width() const { return globals.image.x; }
  std::uint32_t height() const { return globals.image.y; }
};

/// Timing of the table build, reported by --stats.
struct BuildTimes {
  double seconds_bvh = 0.0;
};

/// \brief Bytes of every table of \p t (the vectors' contents, Globals included, and the CPU
///        reference's wide tree when present): what the CPU reference renders from, and what a
///        device's tables are built from.
std::uint64_t table_bytes(const SceneTables& t);

/// \brief Flattens a parsed scene into GPU tables and builds the BVH (binned SAH).
/// The seed in globals.image.w is the Sampler seed; a caller that overrides it (--seed) writes
/// globals.image.w afterwards. With no lights, light_cdf is {0} and counts.x is 0.
/// \param times if not null, receives the BVH build time.
/// \param warnings if not null, receives "file:line:column: warning: ..." lines (e.g. dropped
///        degenerate triangles).
/// \throws SceneError for content that parses but cannot be rendered (e.g. a non-uniformly
///         scaled sphere).
SceneTables build_tables(const Scene& scene, BuildTimes* times = nullptr,
                         std::vector<std::string>* warnings = nullptr);

/// \brief build_tables that frees each shape's parsed mesh (positions, normals, uvs, indices)
/// as soon as its vertices and triangles are in the tables, so that the parsed copy is gone
/// before the BVH build's arrays grow (the command line's peak memory, docs/performance.md).
/// The same tables; \p scene keeps everything but its shapes' meshes. \p cpu_tree false: no
/// cpu_wide (the command line rendering on a Vulkan device, which never reads it).
SceneTables build_tables_releasing_meshes(Scene& scene, BuildTimes* times = nullptr,
                                          std::vector<std::string>* warnings = nullptr,
                                          bool cpu_tree = true);

/// \brief The texture feature bits of material \p m of tables \p t (x: FEATURE_TEXTURES,
///        FEATURE_TEX_NOISE, FEATURE_TEX_IMAGE; y: the FEATURE2_* texture families, bump,
///        normal map and vector turbulence): those of its own slots' texture programs and
///        flags, not of a mix's children. build_tables ORs them over the materials the shapes
///        reach; the wavefront over the materials each shade group shades.
glm::uvec2 material_texture_features(const SceneTables& t, const gpu::Material& m);

/// \brief Frees the large tables of \p t (BVH, primitives, vertices, texels, shared texture
/// and measured-BRDF data), keeping the small ones (globals, materials, lights, textures, ...):
/// for a caller whose tables are on a device and no longer read on the host.
void release_bulk_tables(SceneTables& t);

/// \brief Light selection (docs/path-spec.md 6) by \p mode: "bvh" (pbrt-v4's BVHLightSampler
/// split between infinite and bounded lights, power within the bounded ones; the default),
/// "power" (pbrt-v4's PowerLightSampler) or "uniform"; rewrites light_cdf and every pmf.
/// Returns the mode, for --stats.
std::string apply_light_sampler(SceneTables& t, const std::string& mode);

/// \brief Replaces the coated materials' "nsamples" and "maxdepth" (docs/materials-spec.md)
/// where the argument is positive, and picks their exit MIS weights in f: basalt's (default)
/// or, with \p pbrt_mis, pbrt-v4's (materials-spec 2.3, deviation 1); returns the knob values
/// for --stats.
std::vector<std::pair<std::string, std::string>> apply_layered_knobs(SceneTables& t,
                                                                     int nsamples, int maxdepth,
                                                                     bool pbrt_mis = false);

/// \brief Names of the feature bits set in \p features, for --stats.
std::vector<std::string> feature_names(std::uint32_t features);

/// \brief The path knobs of the command line (docs/path-spec.md 7.1), applied to built tables:
/// \p max_depth >= 0 replaces the Integrator's maxdepth; \p roulette_start is the depth after
/// which Russian roulette may end a path (pbrt-v4's 1; gpu::ROULETTE_OFF: never; stored as
/// render_opts.x of layout.h); \p mis is a
/// gpu::MIS_* mode. Returns the knobs in force as name/value pairs for --stats.
std::vector<std::pair<std::string, std::string>> apply_path_knobs(SceneTables& t, int max_depth,
                                                                  std::uint32_t roulette_start,
                                                                  std::uint32_t mis);

}  // namespace basalt
