// The Vulkan compute path: uploads scene tables, builds the specialised pipeline,
// dispatches sample passes and reads back the accumulated image.
#include "vk/gpu_renderer.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <condition_variable>
#include <cmath>
#include <cstring>
#include <exception>
#include <future>
#include <memory>
#include <mutex>
#include <atomic>
#include <thread>
#include <numeric>
#include <stdexcept>
#include <string>

#include "accel/bvh.h"
#include "scene/materials.h"
#include "scene/samplers.h"
#include "vk/specialise.h"
#include "shaders/probe.spv.h"
#include "shaders/render.spv.h"
#include "shaders/render_lean.spv.h"
#include "shaders/render_lean_plain.spv.h"
#include "shaders/trace.spv.h"
#include "shaders/wavefront_extend.spv.h"
#include "shaders/wavefront_extend_plain.spv.h"
#include "shaders/wavefront_escape.spv.h"
#include "shaders/wavefront_shade.spv.h"
#include "shaders/wavefront_shade_plain.spv.h"

namespace basalt::vkx {

namespace {

using Clock = std::chrono::steady_clock;

/// Seconds since \p t0.
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// A multiplier coprime with \p n near n * 0.618, so that consecutive tiles of the dispatch
/// land all over the image (lavapipe gives each thread a contiguous chunk of workgroups;
/// shuffling balances expensive regions). The product (n-1) * stride must fit in 32 bits
/// (shader contract), so the stride is capped.
std::uint32_t tile_stride(std::uint32_t n) {
  if (n <= 2) return 1;
  std::uint64_t cap = std::max<std::uint64_t>(1, (0xffffffffull / (n - 1)));
  std::uint64_t s = std::min<std::uint64_t>(cap, std::uint64_t(n * 0.6180339887) | 1u);
  for (; s > 1; --s)
    if (std::gcd<std::uint64_t, std::uint64_t>(s, n) == 1) return std::uint32_t(s);
  return 1;
}

const char* kTableNames[] = {"globals", "wide BVH nodes", "primitive refs", "triangles",
                             "vertices", "meshes",    "spheres",        "materials",
                             "lights",   "light cdf", "filter table",   "accumulation", "counters",
                             "measured BRDF", "textures",   "image levels", "texels",
                             "texture data", "texels (chunk 1)", "texels (chunk 2)",
                             "texels (chunk 3)", "sampler data", "leaf prims"};

/// Feature bits the lean render shader (BASALT_LEAN_MATERIALS) implements: everything but
/// the material kinds other than diffuse. A feature added to layout.h later is not in this
/// list, so it gets the full shader until someone checks the lean one handles it.
constexpr std::uint32_t kLeanFeatures =
    gpu::FEATURE_TRIANGLES | gpu::FEATURE_SPHERES | gpu::FEATURE_LIGHT_POINT |
    gpu::FEATURE_LIGHT_SPOT | gpu::FEATURE_LIGHT_DISTANT | gpu::FEATURE_LIGHT_INFINITE |
    gpu::FEATURE_LIGHT_AREA | gpu::FEATURE_MAT_DIFFUSE | gpu::FEATURE_MAT_OREN_NAYAR |
    gpu::FEATURE_MAT_MEASURED | gpu::FEATURE_FILTER_GAUSSIAN |
    gpu::FEATURE_THIN_LENS | gpu::FEATURE_SHADING_NORMALS |
    // Textures and image lights do not depend on the material code the lean build drops
    // (slots_resolve serves its diffuse material too; LeanVariant tests check the images).
    gpu::FEATURE_TEXTURES | gpu::FEATURE_TEX_NOISE | gpu::FEATURE_TEX_IMAGE |
    gpu::FEATURE_LIGHT_INFINITE_IMAGE;

/// The leaf_prims table (BINDING_LEAF_PRIMS): per prim_refs entry, the triangle's three
/// positions, the reference's bits in w of the first (spheres: only those).
std::vector<glm::vec4> leaf_prim_table(const SceneTables& t) {
  std::vector<glm::vec4> out(t.prim_refs.size() * 3, glm::vec4(0.0f));
  for (std::size_t k = 0; k < t.prim_refs.size(); ++k) {
    const std::uint32_t ref = t.prim_refs[k];
    out[3 * k].w = std::bit_cast<float>(ref);
    if (ref & gpu::PRIM_SPHERE_BIT) continue;
    const gpu::Triangle& T = t.triangles[ref];
    out[3 * k] = glm::vec4(glm::vec3(t.vertices[T.v0].p_u), std::bit_cast<float>(ref));
    out[3 * k + 1] = glm::vec4(glm::vec3(t.vertices[T.v1].p_u), 0.0f);
    out[3 * k + 2] = glm::vec4(glm::vec3(t.vertices[T.v2].p_u), 0.0f);
  }
  return out;
}

/// Texel view k (binding BINDING_BVH_TEXELS + k, layout.h): the storage table it shows and
/// its texel format (four or one 32-bit words).
struct TexelView {
  std::uint32_t table;
  vk::Format format;
  std::uint32_t texel_bytes;
};
constexpr TexelView kTexelViews[TEXEL_VIEW_COUNT] = {
    {BINDING_BVH_NODES, vk::Format::eR32G32B32A32Uint, 16},
    {BINDING_LEAF_PRIMS, vk::Format::eR32G32B32A32Uint, 16},
    {BINDING_TRIANGLES, vk::Format::eR32G32B32A32Uint, 16},
    {BINDING_VERTICES, vk::Format::eR32G32B32A32Uint, 16},
    {BINDING_MESHES, vk::Format::eR32G32B32A32Uint, 16},
    {BINDING_TEXELS, vk::Format::eR32Uint, 4},
    {BINDING_TEXELS1, vk::Format::eR32Uint, 4},
    {BINDING_TEXELS2, vk::Format::eR32Uint, 4},
    {BINDING_TEXELS3, vk::Format::eR32Uint, 4},
    {BINDING_TEX_DATA, vk::Format::eR32Uint, 4},
    {BINDING_SAMPLER_DATA, vk::Format::eR32Uint, 4},
    {BINDING_MATERIALS, vk::Format::eR32G32B32A32Uint, 16},
    {BINDING_LIGHTS, vk::Format::eR32G32B32A32Uint, 16},
    {BINDING_SPHERES, vk::Format::eR32G32B32A32Uint, 16},
    {BINDING_MIP_LEVELS, vk::Format::eR32G32B32A32Uint, 16},
    {BINDING_TEXTURES, vk::Format::eR32G32B32A32Uint, 16}};
static_assert(BINDING_BVH_TEXELS == BINDING_COUNT && BINDING_LEAF_TEXELS == BINDING_COUNT + 1 &&
                  BINDING_TRIANGLE_TEXELS == BINDING_COUNT + 2 &&
                  BINDING_VERTEX_TEXELS == BINDING_COUNT + 3 &&
                  BINDING_MESH_TEXELS == BINDING_COUNT + 4 &&
                  BINDING_TEXELS0_TEXELS == BINDING_COUNT + 5 &&
                  BINDING_TEXELS1_TEXELS == BINDING_COUNT + 6 &&
                  BINDING_TEXELS2_TEXELS == BINDING_COUNT + 7 &&
                  BINDING_TEXELS3_TEXELS == BINDING_COUNT + 8 &&
                  BINDING_TEX_DATA_TEXELS == BINDING_COUNT + 9 &&
                  BINDING_SAMPLER_TEXELS == BINDING_COUNT + 10 &&
                  BINDING_MATERIAL_TEXELS == BINDING_COUNT + 11 &&
                  BINDING_LIGHT_TEXELS == BINDING_COUNT + 12 &&
                  BINDING_SPHERE_TEXELS == BINDING_COUNT + 13 &&
                  BINDING_MIP_LEVEL_TEXELS == BINDING_COUNT + 14 &&
                  BINDING_TEXTURE_TEXELS == BINDING_COUNT + 15 &&
                  BINDING_BVH_TEXELS + TEXEL_VIEW_COUNT <= BINDING_WF_PATH_TEXELS &&
                  BINDING_WF_PATH_TEXELS < BINDING_PROBE_IN,
              "texel view bindings follow the storage tables in kTexelViews' order");

/// The texel view of storage table b, or null if it has none.
const TexelView* texel_view_of(std::uint32_t b) {
  for (const TexelView& v : kTexelViews)
    if (v.table == b) return &v;
  return nullptr;
}

/// Every FEATURE_MAT_* bit.
std::uint32_t material_bits() {
  std::uint32_t bits = 0;
  for (std::uint32_t t = 0; t < gpu::MATERIAL_TYPE_COUNT; ++t) bits |= material_feature(t);
  return bits;
}

/// The wavefront's shade pipeline of MATERIAL_* \p type (docs/performance.md): 1 for the
/// layered materials (their random walks are most of the shading code), 2 for the mixes (whose
/// choice may land on any material of the scene; GpuRenderer::wf_group_of moves them to 0 when
/// they reach no layered material), 0 for the others. The layered materials keep a pipeline of
/// their own: shaded by the others' pipeline they render 1.3-2.2x slower on lavapipe. A pipeline per group,
/// not per type, keeps the number of pipelines (lavapipe's fixed cost of each) at four; the
/// queues stay per type, so the lanes of a dispatch still run one material's code.
std::uint32_t wf_group(std::uint32_t type) {
  if (type == gpu::MATERIAL_COATED_DIFFUSE || type == gpu::MATERIAL_COATED_CONDUCTOR) return 1;
  if (type == gpu::MATERIAL_MIX || type == gpu::MATERIAL_MIX_WEIGHTED) return 2;
  return 0;
}
// Group 3: group 0's types without a textured material, in a scene whose group 0 also has
// textured ones and which has no other shade group (GpuRenderer's constructor).
constexpr std::uint32_t kWfUntexturedGroup = 3;
constexpr std::uint32_t kWfGroups = 4;
// The texture families a shade group is specialised for by its materials' textures alone
// (GpuRenderer::shade_words): of the first feature word and of the second.
constexpr std::uint32_t kTexFamilies = gpu::FEATURE_TEX_NOISE | gpu::FEATURE_TEX_IMAGE;
constexpr std::uint32_t kTexFamilies2 =
    gpu::FEATURE2_TEX_EWA | gpu::FEATURE2_TEX_CHECKER_AA | gpu::FEATURE2_TEX_PROCEDURAL |
    gpu::FEATURE2_TEX_SHIRLEY | gpu::FEATURE2_TEX_MAP_CURVED | gpu::FEATURE2_BUMP |
    gpu::FEATURE2_NORMALMAP | gpu::FEATURE2_VTURB;

}  // namespace

bool GpuRenderer::lean_suffices(std::uint32_t features) {
  return (features & ~kLeanFeatures) == 0u;
}

std::uint32_t GpuRenderer::untextured_types(const SceneTables& t) {
  // Where group 0 holds textured and untextured types and the scene has no other shade group
  // (no layered material, no mix), the untextured types get a pipeline of their own without
  // the texture code (group 3): two pipelines of about 0.7 of the one each, compiled in
  // parallel, and the untextured paths no longer run the texture interpreter
  // (textures-specular 9% faster, its cold pipelines 1.13 -> 1.03 s). Beside a layered or mix
  // group it would be a third shade pipeline, which breaks the cold budget (bump 1.98 ->
  // 2.44 s). Figures: docs/performance.md, eleventh session.
  std::uint32_t untextured = 0, textured = 0;
  for (const gpu::Material& m : t.materials) {
    if (m.type >= gpu::MATERIAL_TYPE_COUNT) continue;
    if (wf_group(m.type) != 0) return 0;
    // none and interface: no BSDF code of their own
    if (material_feature(m.type) == 0u || m.type == gpu::MATERIAL_INTERFACE) continue;
    if (material_texture_features(t, m) == glm::uvec2(0u))
      untextured |= 1u << m.type;
    else
      textured |= 1u << m.type;
  }
  // A type with a textured material stays with the textured ones.
  untextured &= ~textured;
  return textured != 0u ? untextured : 0u;
}

bool GpuRenderer::megakernel_suffices(const SceneTables& t, std::uint32_t features,
                                      std::uint32_t features2) {
  // The wavefront stages pay where they split the scene's material code over pipelines: a
  // dispatch then runs only its queue's types' code, where the megakernel runs every type's on
  // every bounce (lavapipe runs every branch for all lanes). That is the case with a layered
  // material (its random walk in a group of its own: the 11 shipped scenes with one render
  // 1.5-1.9x slower as a megakernel) and where group 0's untextured types get their own
  // pipeline (untextured_types: textures-specular 6-17% slower as a megakernel), and a portal
  // keeps its lookups off the bounces in the escape stage (envmap-portal 1.43x slower).
  // Otherwise the wavefront's one shade pipeline holds the megakernel's material code, and its
  // path stores, loads and dispatches cost more than its queues save: materials-dielectrics,
  // envmap, envmap-latlong, textures-image, materials-mix 5-22% faster as a megakernel at
  // 8-64 spp, materials-transmission within 3%. Diffuse, Oren-Nayar and measured alone get
  // the lean megakernel (materials-diffuse 1.29x, materials-measured 1.22x slower as a
  // wavefront). Figures: docs/performance.md, eleventh session.
  constexpr std::uint32_t kReflection =
      gpu::FEATURE_MAT_DIFFUSE | gpu::FEATURE_MAT_OREN_NAYAR | gpu::FEATURE_MAT_MEASURED;
  constexpr std::uint32_t kLayered =
      gpu::FEATURE_MAT_COATED_DIFFUSE | gpu::FEATURE_MAT_COATED_CONDUCTOR;
  const std::uint32_t materials = features & material_bits();
  if ((materials & ~kReflection) == 0u) return true;
  return (materials & kLayered) == 0u && (features2 & gpu::FEATURE2_ENV_PORTAL) == 0u &&
         untextured_types(t) == 0u;
}

bool GpuRenderer::plain_suffices(std::uint32_t features, std::uint32_t features2) {
  return (features & ~gpu::FEATURES_PLAIN_KEEP) == 0u &&
         (features2 & ~gpu::FEATURES2_PLAIN_KEEP) == 0u;
}

GpuRenderer::GpuRenderer(Context& ctx, const SceneTables& t, std::uint32_t features,
                         ShaderVariant which, bool render_pipeline,
                         const std::function<void()>& uploaded)
    : ctx_(ctx), width_(t.width()), height_(t.height()) {
  if (which == ShaderVariant::lean && !lean_suffices(features))
    throw std::invalid_argument("the lean render shader cannot render feature bits " +
                                std::to_string(features));
  // The wavefront binds one more uniform texel view than the tables (its paths): a device
  // with fewer per stage than Vulkan's 16 + 1 keeps the megakernel.
  const bool wavefront_fits = ctx.info().max_per_stage_sampled_images > TEXEL_VIEW_COUNT;
  if (which == ShaderVariant::wavefront && !wavefront_fits)
    throw std::invalid_argument("the wavefront stages need " +
                                std::to_string(TEXEL_VIEW_COUNT + 1) +
                                " uniform texel views per stage; " + ctx.info().name + " has " +
                                std::to_string(ctx.info().max_per_stage_sampled_images));
  // automatic: the wavefront stages unless megakernel_suffices; the all-features pipeline stays
  // one megakernel.
  const bool wavefront =
      which == ShaderVariant::wavefront ||
      (which == ShaderVariant::automatic && wavefront_fits && features != 0xffffffffu &&
       !megakernel_suffices(t, features, features == t.features ? t.features2 : 0xffffffffu));
  const bool lean = !wavefront && which != ShaderVariant::full && lean_suffices(features);
  variant = wavefront ? "wavefront" : lean ? "lean" : "full";
  // Invocations cover 8x8 pixel tiles (one workgroup each): slots_ is the tile-padded count.
  const std::uint32_t tiles = ((width_ + 7) / 8) * ((height_ + 7) / 8);
  slots_ = tiles * 64;
  stride_ = tile_stride(tiles);
  auto t0 = Clock::now();
  auto usage = vk::BufferUsageFlagBits::eStorageBuffer;
  struct Src {
    const void* data;
    std::size_t bytes;
  };
  const std::size_t pixels = std::size_t(width_) * height_;
  // A table that may be empty is always bound: empty, it gets a zeroed 16-byte buffer
  // (zero-sized buffers are invalid).
  auto optional_table = [](const auto& v) {
    const std::size_t bytes = v.size() * sizeof(v[0]);
    return Src{v.empty() ? nullptr : v.data(), std::max<std::size_t>(16, bytes)};
  };
  // The texel table in chunks of 2^TEXEL_CHUNK_SHIFT floats, one binding each (layout.h).
  auto texel_chunk = [&t](std::size_t k) {
    const std::size_t first = k << TEXEL_CHUNK_SHIFT;
    const std::size_t n = t.texels.size() > first
                              ? std::min(t.texels.size() - first, std::size_t(1) << TEXEL_CHUNK_SHIFT)
                              : 0;
    return Src{n ? t.texels.data() + first : nullptr, std::max<std::size_t>(16, n * sizeof(float))};
  };
  // The GPU traverses the wide BVH (docs/path-spec.md 3.1); the binary nodes stay on the host.
  const std::vector<gpu::BvhWideNode> wide = build_wide_bvh(t.nodes);
  // Leaf-ordered positions when they fit one binding (else the tables they come from).
  const std::uint64_t leaf_limit =
      leaf_prims_max_bytes ? leaf_prims_max_bytes : ctx.info().max_storage_buffer_range;
  leaf_prims = t.prim_refs.size() * 3 * sizeof(glm::vec4) <= leaf_limit;
  const std::vector<glm::vec4> leaf = leaf_prims ? leaf_prim_table(t) : std::vector<glm::vec4>{};
  const Src src[BINDING_COUNT] = {
      {&t.globals, sizeof(t.globals)},
      optional_table(wide),
      {t.prim_refs.data(), t.prim_refs.size() * sizeof(std::uint32_t)},
      {t.triangles.data(), t.triangles.size() * sizeof(gpu::Triangle)},
      {t.vertices.data(), t.vertices.size() * sizeof(gpu::Vertex)},
      {t.meshes.data(), t.meshes.size() * sizeof(gpu::Mesh)},
      {t.spheres.data(), t.spheres.size() * sizeof(gpu::Sphere)},
      {t.materials.data(), t.materials.size() * sizeof(gpu::Material)},
      {t.lights.data(), t.lights.size() * sizeof(gpu::Light)},
      {t.light_cdf.data(), t.light_cdf.size() * sizeof(float)},
      {t.filter_cdf.data(), t.filter_cdf.size() * sizeof(float)},
      {nullptr, pixels * sizeof(glm::vec4)},
      {nullptr, 4 * sizeof(std::uint32_t)},
      optional_table(t.measured), optional_table(t.textures), optional_table(t.mip_levels),
      texel_chunk(0), optional_table(t.tex_data), texel_chunk(1), texel_chunk(2),
      texel_chunk(3), optional_table(t.sampler_data), optional_table(leaf)};
  if (t.texels.size() > (std::size_t(TEXEL_CHUNK_COUNT) << TEXEL_CHUNK_SHIFT))
    throw std::runtime_error("scene too large: its images need " +
                             std::to_string(t.texels.size() * sizeof(float)) +
                             " bytes of texels, more than basalt's " +
                             std::to_string(TEXEL_CHUNK_COUNT) + " bindings of 128 MiB");
  const std::uint64_t limit = ctx.info().max_storage_buffer_range;
  for (int i = 0; i < BINDING_COUNT; ++i)
    if (src[i].bytes > limit)
      throw std::runtime_error(
          std::string("scene too large for this device: the ") + kTableNames[i] + " table needs " +
          std::to_string(src[i].bytes) + " bytes, more than maxStorageBufferRange (" +
          std::to_string(limit) + " bytes) of " + ctx.info().name);
  tables_.resize(BINDING_COUNT);
  for (int i = 0; i < BINDING_COUNT; ++i) {
    // A table's data is copied over its buffer, which is zeroed only where the copy does not
    // reach (an empty table, or one under create_buffer's 16 bytes).
    const bool copied = src[i].data && src[i].bytes >= 16;
    tables_[i] = ctx.create_buffer(
        src[i].bytes,
        texel_view_of(i) ? usage | vk::BufferUsageFlagBits::eUniformTexelBuffer : usage,
        !copied);
    if (src[i].data && src[i].bytes) std::memcpy(tables_[i].mapped, src[i].data, src[i].bytes);
    device_bytes += tables_[i].size;
  }
  // The texel views: each over its whole table when every table fits the device's texel limit
  // (TEXEL_TABLES = 1), else each over what fits, bound but not read (TEXEL_TABLES = 0).
  const std::uint64_t texel_limit =
      texel_views_max_texels ? texel_views_max_texels : ctx.info().max_texel_buffer_elements;
  texel_tables = true;
  for (const TexelView& v : kTexelViews)
    texel_tables = texel_tables && tables_[v.table].size / v.texel_bytes <= texel_limit;
  for (const TexelView& v : kTexelViews) {
    const std::uint64_t texels =
        std::min<std::uint64_t>(tables_[v.table].size / v.texel_bytes, texel_limit);
    views_.push_back(ctx.device.createBufferView({.buffer = tables_[v.table].buffer,
                                                  .format = v.format,
                                                  .offset = 0,
                                                  .range = texels * v.texel_bytes}));
    view_bytes_.push_back(texels * v.texel_bytes);
  }
  seconds_upload = since(t0);
  if (uploaded) uploaded();  // from here on only materials, textures and feature words are read

  if (!render_pipeline) return;  // probes only: their pipeline is built by probe()
  t0 = Clock::now();
  std::vector<std::pair<std::uint32_t, Buffer*>> bindings;
  for (std::uint32_t i = 0; i < tables_.size(); ++i) bindings.push_back({i, &tables_[i]});
  // The second feature word follows the first: the scene's own when the scene's features are
  // asked for, everything when a caller forces another set (the all-features comparison).
  const std::uint32_t features2 = features == t.features ? t.features2 : 0xffffffffu;
  if (wavefront) {
    // Paths and lists of one wave (layout.h, WF_*), the stages' pipelines: extend, and shade
    // for each material type of the scene (and MATERIAL_NONE, for shapes without one).
    // The paths' texel view holds WF_PATH_VEC4S texels a path: capacity within the device's
    // maxTexelBufferElements (Vulkan promises 65,536: 5,461 paths).
    // A wave runs (sample, slot) pairs in order, so a small image's wave holds several
    // samples (a tiny image's capacity is its slots times kWaveSamples): each dispatch has the
    // work to keep lavapipe's threads busy, and a sample costs fewer submissions.
    wf_capacity_ = std::min<std::uint64_t>(
        {wavefront_capacity, std::uint64_t(slots_) * kWaveSamples,
         ctx.info().max_texel_buffer_elements / gpu::WF_PATH_VEC4S});
    // The wave buffers' allocation is timed with the upload (the tables' buffers), not as
    // pipeline creation. They are zeroed by a pipeline worker once it has no pipeline left to
    // make (below), not here: 0.04 s of the main thread on lavapipe at 262,144 paths (77 MB),
    // while the other core waits for the largest shade pipeline (docs/performance.md,
    // fifteenth session).
    const auto t_alloc = Clock::now();
    const auto usage = vk::BufferUsageFlagBits::eStorageBuffer;
    wf_paths_ = ctx_.create_buffer(std::size_t(wf_capacity_) * gpu::WF_PATH_VEC4S * 16,
                                   usage | vk::BufferUsageFlagBits::eUniformTexelBuffer, false);
    wf_path_view_ = ctx.device.createBufferView({.buffer = wf_paths_.buffer,
                                                 .format = vk::Format::eR32G32B32A32Uint,
                                                 .offset = 0,
                                                 .range = wf_paths_.size});
    wf_lists_ = ctx_.create_buffer(
        (gpu::WF_COUNTERS + std::size_t(gpu::WF_LISTS + gpu::WF_RADIANCE_WORDS) * wf_capacity_) *
            4,
        usage, false);
    wave_bytes = wf_paths_.size + wf_lists_.size;
    const double alloc = since(t_alloc);
    seconds_upload += alloc;
    t0 += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(alloc));
    wf_bindings_ = bindings;
    wf_bindings_.push_back({BINDING_PROBE_IN, &wf_paths_});
    wf_bindings_.push_back({BINDING_PROBE_OUT, &wf_lists_});
    wf_features_ = features;
    wf_features2_ = features2;
    plain = plain_builds && plain_suffices(features, features2);
    // The mix group's material bits: the types a mix of the scene may reach (its children,
    // theirs, ...), not every type of the scene.
    wf_mix_bits_ = 0;
    std::vector<std::uint32_t> mixes;
    for (std::uint32_t m = 0; m < t.materials.size(); ++m)
      if (wf_group(t.materials[m].type) == wf_group(gpu::MATERIAL_MIX)) mixes.push_back(m);
    const std::vector<bool> reached = materials_reached(t.materials, std::move(mixes));
    for (std::uint32_t m = 0; m < t.materials.size(); ++m)
      if (reached[m]) wf_mix_bits_ |= material_feature(t.materials[m].type);
    // Mixes that reach no layered material are shaded by group 0's pipeline, specialised for
    // their types as well: its code is then theirs, and the scene makes one pipeline fewer
    // (each pipeline repeats the path's shared code; the queues stay per type).
    const std::uint32_t layered = material_feature(gpu::MATERIAL_COATED_DIFFUSE) |
                                  material_feature(gpu::MATERIAL_COATED_CONDUCTOR);
    wf_mix_group_ = (wf_mix_bits_ & layered) == 0 ? 0u : wf_group(gpu::MATERIAL_MIX);
    // The texture families of each type's materials and of each group's (the mixes' group: of
    // what they reach): a shade pipeline is specialised without the others' (shade_words).
    wf_type_tex_bits_.assign(gpu::MATERIAL_TYPE_COUNT, glm::uvec2(0u));
    for (const gpu::Material& m : t.materials)
      if (m.type < gpu::MATERIAL_TYPE_COUNT)
        wf_type_tex_bits_[m.type] |= material_texture_features(t, m);
    // Group 3: the untextured types beside textured ones (untextured_types).
    wf_untextured_types_ = group_texture_features ? untextured_types(t) : 0u;
    wf_tex_bits_.assign(kWfGroups, glm::uvec2(0u));
    for (std::uint32_t m = 0; m < t.materials.size(); ++m) {
      const glm::uvec2 bits = material_texture_features(t, t.materials[m]);
      const std::uint32_t type = t.materials[m].type;
      if (type < gpu::MATERIAL_TYPE_COUNT) wf_tex_bits_[wf_group_of(type)] |= bits;
      if (reached[m]) wf_tex_bits_[wf_mix_group_] |= bits;
    }
    wf_shade_.resize(kWfGroups);
    wf_group_words_size_.assign(kWfGroups, 0);
    // The stages the scene needs: extend, and the shade group of each material type present
    // (and MATERIAL_NONE's, for shapes without a material).
    std::vector<bool> needed(kWfGroups, false);
    needed[wf_group_of(gpu::MATERIAL_NONE)] = true;
    for (const gpu::Material& m : t.materials)
      if (m.type < gpu::MATERIAL_TYPE_COUNT) needed[wf_group_of(m.type)] = true;
    constexpr std::uint32_t kExtend = kWfGroups;      // in stages: the extend stage,
    constexpr std::uint32_t kEscape = kWfGroups + 1;  // the escape stage, else a shade group
    std::vector<std::uint32_t> stages = {kExtend};
    for (std::uint32_t g = 0; g < kWfGroups; ++g)
      if (needed[g]) stages.push_back(g);
    // An image infinite light's escape in a stage of its own (wavefront.comp, stage 2).
    escape_stage = (features & gpu::FEATURE_LIGHT_INFINITE_IMAGE) != 0u;
    if (escape_stage) stages.push_back(kEscape);
    // The pipelines are created on worker threads: lavapipe translates and optimises a shader
    // in the thread that creates its pipeline, and compiles it with LLVM at its first dispatch
    // on the queue's thread, so the later pipelines' translation overlaps the earlier ones'
    // compilation (docs/performance.md). One worker a core, taking the pipelines in order: with
    // fewer cores than pipelines each is then made by the time the queue's thread reaches it,
    // instead of all being made slowly at once (material-zoo on 2 cores: 3.45 -> 3.08 s).
    const std::size_t cores = std::max(2u, std::thread::hardware_concurrency());
    // On lavapipe, with two shade groups or more, one shade pipeline is compiled by a second
    // device (CompileDevice) while this device's queue compiles the others; this queue then
    // finds its code in Mesa's shader cache. With exactly two shade groups both are
    // specialised first, side by side, and the larger module goes to the second device (the
    // longest chain of work starts first, and this queue compiles the smaller one and the
    // extend stage meanwhile: docs/performance.md, "Shade groups first, the larger on the
    // second device"); with more, group 0's pipeline comes last and goes there.
    std::unique_ptr<CompileDevice> compiler;
    const std::size_t shade_stages =
        std::size_t(std::count_if(stages.begin(), stages.end(),
                                  [](std::uint32_t g) { return g < kWfGroups; }));
    const bool by_size = ctx_.info().is_cpu && shade_stages == 2 && parallel_compile &&
                         CompileDevice::shader_cache_on();
    if (by_size) {
      compiler = std::make_unique<CompileDevice>(ctx_);
      std::stable_partition(stages.begin(), stages.end(),
                            [](std::uint32_t g) { return g < kWfGroups; });
    } else if (ctx_.info().is_cpu && stages.size() >= 3 && stages[1] == 0 && parallel_compile &&
               CompileDevice::shader_cache_on()) {
      compiler = std::make_unique<CompileDevice>(ctx_);
      std::rotate(stages.begin() + 1, stages.begin() + 2, stages.end());
    }
    const auto on_second = [&](std::size_t i) {
      return compiler && !by_size && i + 1 == stages.size();
    };
    // The two shade groups' sizes once both are specialised (by_size: stages 0 and 1, made on
    // two workers at once); a stage whose specialisation failed arrives with size 0.
    struct Meeting {
      std::mutex m;
      std::condition_variable cv;
      std::size_t words[2] = {0, 0};
      bool here[2] = {false, false};
      /// Records stage \p i's size and waits for the other's: true if \p i's is the larger.
      bool larger(std::size_t i, std::size_t size) {
        std::unique_lock<std::mutex> lock(m);
        if (!here[i]) words[i] = size;
        here[i] = true;
        cv.notify_all();
        cv.wait(lock, [&] { return here[1 - i]; });
        return words[i] > words[1 - i] || (words[i] == words[1 - i] && i == 0);
      }
    } meeting;
    const std::size_t workers = std::min(stages.size(), cores);
    std::vector<std::promise<Pipeline>> promised(stages.size());
    std::vector<std::future<Pipeline>> made;
    for (auto& p : promised) made.push_back(p.get_future());
    // Which pipelines are made (1), being compiled by this device's queue (2) and compiled (3):
    // the queue takes them as they come.
    std::mutex made_m;
    std::condition_variable made_cv;
    std::vector<char> state(stages.size(), 0);
    // This device's copy of the pipeline compiled on the second device (its translation, a
    // core's work) is made once one of the two queues has nothing left to compile: this one
    // has compiled every other stage, or the second device its pipeline. Before that both
    // queues compile, on the two cores of the CI machine, and a third thread would slow the
    // longer of them (docs/performance.md, "Shade groups first, the larger on the second
    // device").
    if (compiler) second_copy_wait_ = [&](const std::function<bool()>& compiled) {
      std::unique_lock<std::mutex> lock(made_m);
      while (!made_cv.wait_for(lock, std::chrono::milliseconds(5), [&] {
        return std::count(state.begin(), state.end(), char(3)) + 1 >= std::ptrdiff_t(state.size());
      }) && !compiled()) {
      }
    };
    std::atomic<std::size_t> next{0};
    std::vector<std::thread> threads;
    for (std::size_t w = 0; w < workers; ++w)
      threads.emplace_back([&, features, features2] {
        for (std::size_t i; (i = next++) <= stages.size();) {
          // The last job: the wave buffers zeroed (the empty dispatches below read none of
          // them; every thread is joined before the constructor returns).
          if (i == stages.size()) {
            std::memset(wf_paths_.mapped, 0, wf_paths_.size);
            std::memset(wf_lists_.mapped, 0, wf_lists_.size);
            break;
          }
          const std::uint32_t g = stages[i];
          try {
            promised[i].set_value(
                g == kExtend
                    ? (plain ? make_pipeline(wavefront_extend_plain_spv,
                                             sizeof(wavefront_extend_plain_spv), features,
                                             features2, wf_bindings_, wf_path_view_)
                             : make_pipeline(wavefront_extend_spv, sizeof(wavefront_extend_spv),
                                             features, features2, wf_bindings_, wf_path_view_))
                : g == kEscape
                    ? make_pipeline(wavefront_escape_spv, sizeof(wavefront_escape_spv), features,
                                    features2, wf_bindings_, wf_path_view_)
                    : make_wf_shade(wf_group_words(g), on_second(i) ? compiler.get() : nullptr,
                                    [&, g, i](std::size_t words, CompileDevice*& second) {
                                      wf_group_words_size_[g] = words;  // this worker's own
                                      if (by_size)
                                        second = meeting.larger(i, words) ? compiler.get()
                                                                          : nullptr;
                                      if (second)  // one stage's worker only
                                        second_device_materials = wf_group_words(g).first &
                                                                  material_bits();
                                      return true;
                                    }));
          } catch (...) {
            if (by_size && i < 2) meeting.larger(i, 0);  // the other stage waits for no size
            promised[i].set_exception(std::current_exception());
          }
          {
            const std::lock_guard<std::mutex> lock(made_m);
            state[i] = 1;
          }
          made_cv.notify_all();
        }
      });
    // Each compiled by an empty dispatch as soon as it is made, the first made first; on an
    // error every thread is waited for and what they made is destroyed before it is passed on.
    std::exception_ptr error;
    for (std::size_t n = 0; n < stages.size(); ++n) {
      std::size_t i = 0;
      {
        std::unique_lock<std::mutex> lock(made_m);
        made_cv.wait(lock, [&] {
          for (i = 0; i < stages.size(); ++i)
            if (state[i] == 1) return true;
          return false;
        });
        state[i] = 2;
      }
      try {
        Pipeline p = made[i].get();
        (stages[i] == kExtend   ? wf_extend_
         : stages[i] == kEscape ? wf_escape_
                                : wf_shade_[stages[i]]) = p;
        if (!error)
          dispatch(p, gpu::PassConstants{0, 0, 0, 0, stride_, slots_, 0, wf_capacity_}, 1);
      } catch (...) {
        if (!error) error = std::current_exception();
      }
      {
        const std::lock_guard<std::mutex> lock(made_m);
        state[i] = 3;
      }
      made_cv.notify_all();
    }
    for (std::thread& t : threads) t.join();
    second_copy_wait_ = nullptr;
    if (error) {
      ctx_.device.waitIdle();
      destroy_pipeline(wf_extend_);
      destroy_pipeline(wf_escape_);
      for (Pipeline& p : wf_shade_) destroy_pipeline(p);
      ctx_.device.destroyBufferView(wf_path_view_);
      ctx_.destroy_buffer(wf_paths_);
      ctx_.destroy_buffer(wf_lists_);
      for (auto& v : views_) ctx_.device.destroyBufferView(v);
      for (auto& b : tables_) ctx_.destroy_buffer(b);
      std::rethrow_exception(error);
    }
    seconds_pipeline = since(t0);
    return;
  }
  plain = lean && plain_builds && plain_suffices(features, features2);
  render_ = plain  ? make_pipeline(render_lean_plain_spv, sizeof(render_lean_plain_spv), features,
                                   features2, bindings)
            : lean ? make_pipeline(render_lean_spv, sizeof(render_lean_spv), features, features2,
                                   bindings)
                   : make_pipeline(render_spv, sizeof(render_spv), features, features2, bindings);
  // lavapipe compiles at first dispatch: an empty pass makes that cost part of pipeline time.
  dispatch(render_, gpu::PassConstants{0, 0, 0, 0, stride_, slots_, 0, 0}, 1);
  seconds_pipeline = since(t0);
}

GpuRenderer::~GpuRenderer() {
  if (wf_solo_made_.valid()) {
    try {
      wf_solo_ = wf_solo_made_.get();
    } catch (...) {  // nothing was made
    }
  }
  ctx_.device.waitIdle();
  destroy_pipeline(wf_solo_);
  destroy_pipeline(render_);
  destroy_stage(probe_);
  destroy_stage(trace_);
  destroy_pipeline(wf_extend_);
  destroy_pipeline(wf_escape_);
  for (Pipeline& p : wf_shade_) destroy_pipeline(p);
  if (wf_capacity_) {
    ctx_.device.destroyBufferView(wf_path_view_);
    ctx_.destroy_buffer(wf_paths_);
    ctx_.destroy_buffer(wf_lists_);
  }
  for (auto& v : views_) ctx_.device.destroyBufferView(v);
  for (auto& b : tables_) ctx_.destroy_buffer(b);
}

GpuRenderer::Pipeline GpuRenderer::make_pipeline(const std::uint32_t* spirv, std::size_t bytes,
                                                 std::uint32_t features, std::uint32_t features2,
                                                 const std::vector<std::pair<std::uint32_t, Buffer*>>& bindings,
                                                 vk::BufferView wf_paths, CompileDevice* compiler,
                                                 const std::function<bool(std::size_t, CompileDevice*&)>& accept) {
  auto& dev = ctx_.device;
  Pipeline p;
  std::vector<vk::DescriptorSetLayoutBinding> layout_bindings;
  for (const auto& [binding, buffer] : bindings)
    layout_bindings.push_back({.binding = binding,
                               .descriptorType = vk::DescriptorType::eStorageBuffer,
                               .descriptorCount = 1,
                               .stageFlags = vk::ShaderStageFlagBits::eCompute});
  for (std::uint32_t k = 0; k < views_.size(); ++k)
    layout_bindings.push_back({.binding = BINDING_BVH_TEXELS + k,
                               .descriptorType = vk::DescriptorType::eUniformTexelBuffer,
                               .descriptorCount = 1,
                               .stageFlags = vk::ShaderStageFlagBits::eCompute});
  if (wf_paths)
    layout_bindings.push_back({.binding = BINDING_WF_PATH_TEXELS,
                               .descriptorType = vk::DescriptorType::eUniformTexelBuffer,
                               .descriptorCount = 1,
                               .stageFlags = vk::ShaderStageFlagBits::eCompute});
  p.set_layout = dev.createDescriptorSetLayout(
      {.bindingCount = std::uint32_t(layout_bindings.size()), .pBindings = layout_bindings.data()});
  vk::PushConstantRange push{.stageFlags = vk::ShaderStageFlagBits::eCompute,
                             .offset = 0,
                             .size = sizeof(gpu::PassConstants)};
  p.layout = dev.createPipelineLayout({.setLayoutCount = 1,
                                       .pSetLayouts = &p.set_layout,
                                       .pushConstantRangeCount = 1,
                                       .pPushConstantRanges = &push});
  // A pipeline for a scene's features gets SPIR-V without the code they rule out (specialise.h:
  // on lavapipe 0.55 -> 0.09 s warm for the Cornell box, kept in basalt's per-user cache); the
  // all-features one is used as given.
  // Constant 0: FEATURES (the scene's feature word); constant 1: FEATURES2 (the second word,
  // the texture families of layout.h); constant 2: LEAF_PRIMS; constant 3: TEXEL_TABLES
  // (bindings.glsl).
  const std::vector<std::uint32_t> words = {features, features2, leaf_prims ? 1u : 0u,
                                            texel_tables ? 1u : 0u};
  std::vector<std::uint32_t> specialised;
  bool hit = false;  // basalt's cache had the specialised module
  if (features != 0xffffffffu || features2 != 0xffffffffu) {
    const auto t0 = Clock::now();
    // The wavefront's stages are inlined whatever their size (the extend stage, 71-78 KiB,
    // translates faster so too, and it shares a worker with a shade pipeline); the
    // megakernels above kInlineAboveWords only (the Cornell box's cold start pays nothing).
    specialised = specialise_spirv_cached(spirv, bytes, words, hit,
                                          wf_paths ? 0u : kInlineAboveWords);
    const std::lock_guard<std::mutex> lock(stats_mutex_);  // pipelines made on several threads
    seconds_specialise += since(t0);
    spirv = specialised.data();
    bytes = specialised.size() * sizeof(std::uint32_t);
  }
  if (accept && !accept(bytes / sizeof(std::uint32_t), compiler)) {
    dev.destroyPipelineLayout(p.layout);
    dev.destroyDescriptorSetLayout(p.set_layout);
    return Pipeline{};
  }
  std::vector<vk::SpecializationMapEntry> entries;
  for (std::uint32_t k = 0; k < words.size(); ++k)
    entries.push_back(vk::SpecializationMapEntry{
        .constantID = k, .offset = k * 4u, .size = sizeof(std::uint32_t)});
  vk::SpecializationInfo spec{.mapEntryCount = std::uint32_t(entries.size()),
                              .pMapEntries = entries.data(),
                              .dataSize = words.size() * sizeof(std::uint32_t),
                              .pData = words.data()};
  const auto create = [&] {
    vk::ShaderModule module = dev.createShaderModule({.codeSize = bytes, .pCode = spirv});
    vk::ComputePipelineCreateInfo info{.stage = {.stage = vk::ShaderStageFlagBits::eCompute,
                                                 .module = module,
                                                 .pName = "main",
                                                 .pSpecializationInfo = &spec},
                                       .layout = p.layout};
    auto result = dev.createComputePipeline(nullptr, info);
    dev.destroyShaderModule(module);
    if (result.result != vk::Result::eSuccess) throw std::runtime_error("pipeline creation failed");
    p.pipeline = result.value;
  };
  // With a second device, created here while that device compiles it: the first dispatch on
  // this device then finds LLVM's code in Mesa's shader cache (CompileDevice, context.h).
  // Not when basalt's cache had the module: Mesa's then has its code too, and the second
  // device would only translate it once more.
  if (compiler && !hit) {
    std::vector<CompileDevice::TexelBinding> texels;
    for (std::uint32_t k = 0; k < views_.size(); ++k)
      texels.push_back({kTexelViews[k].format, tables_[kTexelViews[k].table].size,
                        view_bytes_[k]});
    if (wf_paths) texels.push_back({vk::Format::eR32G32B32A32Uint, wf_paths_.size, wf_paths_.size});
    const gpu::PassConstants pc{0, 0, 0, 0, stride_, slots_, 0, wf_capacity_};
    std::vector<std::uint8_t> push(sizeof pc);
    std::memcpy(push.data(), &pc, sizeof pc);
    compiler->compile(spirv, bytes, spec, layout_bindings, texels, push,
                      [&](const std::function<bool()>& compiled) {
                        if (second_copy_wait_) second_copy_wait_(compiled);
                        create();
                      });
    const std::lock_guard<std::mutex> lock(stats_mutex_);
    ++second_device_compiles;
  } else {
    create();
  }

  const vk::DescriptorPoolSize sizes[2] = {
      {.type = vk::DescriptorType::eStorageBuffer, .descriptorCount = std::uint32_t(bindings.size())},
      {.type = vk::DescriptorType::eUniformTexelBuffer, .descriptorCount = TEXEL_VIEW_COUNT + 1}};
  p.pool = dev.createDescriptorPool({.maxSets = 1, .poolSizeCount = 2, .pPoolSizes = sizes});
  p.set = dev.allocateDescriptorSets(
      {.descriptorPool = p.pool, .descriptorSetCount = 1, .pSetLayouts = &p.set_layout})[0];
  std::vector<vk::DescriptorBufferInfo> infos;
  for (const auto& [binding, b] : bindings)
    infos.push_back({.buffer = b->buffer, .offset = 0, .range = b->size});
  std::vector<vk::WriteDescriptorSet> writes;
  for (std::uint32_t i = 0; i < infos.size(); ++i)
    writes.push_back({.dstSet = p.set,
                      .dstBinding = bindings[i].first,
                      .descriptorCount = 1,
                      .descriptorType = vk::DescriptorType::eStorageBuffer,
                      .pBufferInfo = &infos[i]});
  for (std::uint32_t k = 0; k < views_.size(); ++k)
    writes.push_back({.dstSet = p.set,
                      .dstBinding = BINDING_BVH_TEXELS + k,
                      .descriptorCount = 1,
                      .descriptorType = vk::DescriptorType::eUniformTexelBuffer,
                      .pTexelBufferView = &views_[k]});
  if (wf_paths)
    writes.push_back({.dstSet = p.set,
                      .dstBinding = BINDING_WF_PATH_TEXELS,
                      .descriptorCount = 1,
                      .descriptorType = vk::DescriptorType::eUniformTexelBuffer,
                      .pTexelBufferView = &wf_paths});
  dev.updateDescriptorSets(writes, {});
  return p;
}

void GpuRenderer::destroy_pipeline(Pipeline& p) {
  auto& dev = ctx_.device;
  if (p.pool) dev.destroyDescriptorPool(p.pool);
  if (p.pipeline) dev.destroyPipeline(p.pipeline);
  if (p.layout) dev.destroyPipelineLayout(p.layout);
  if (p.set_layout) dev.destroyDescriptorSetLayout(p.set_layout);
  p = Pipeline{};
}

void GpuRenderer::dispatch(Pipeline& p, const gpu::PassConstants& pc, std::uint32_t invocations) {
  ctx_.submit_and_wait([&](vk::CommandBuffer cmd) {
    cmd.bindPipeline(vk::PipelineBindPoint::eCompute, p.pipeline);
    cmd.bindDescriptorSets(vk::PipelineBindPoint::eCompute, p.layout, 0, p.set, {});
    cmd.pushConstants(p.layout, vk::ShaderStageFlagBits::eCompute, 0, sizeof(pc), &pc);
    cmd.dispatch(std::max(1u, (invocations + 63) / 64), 1, 1);
  });
  // The device counts rays in 32 bits per pass; the host keeps the 64-bit total.
  auto* counters = static_cast<std::uint32_t*>(tables_[BINDING_COUNTERS].mapped);
  rays_ += counters[0];
  nonfinite_ += counters[1];
  counters[0] = counters[1] = 0;
}

std::uint32_t GpuRenderer::wf_group_of(std::uint32_t type) const {
  if (type < 32 && (wf_untextured_types_ >> type & 1u) != 0u) return kWfUntexturedGroup;
  return wf_group(type) == wf_group(gpu::MATERIAL_MIX) ? wf_mix_group_ : wf_group(type);
}

std::pair<std::uint32_t, std::uint32_t> GpuRenderer::shade_words(std::uint32_t materials,
                                                                 glm::uvec2 tex) const {
  // Of the texture families, those of \p tex: the pipeline evaluates no other material's
  // textures. FEATURE_TEXTURES itself stays the scene's (every bounce carries the ray
  // differentials that the next hit's footprint needs, whatever its pipeline).
  const std::uint32_t families = group_texture_features ? kTexFamilies : 0u;
  const std::uint32_t families2 = group_texture_features ? kTexFamilies2 : 0u;
  return {(wf_features_ & ~material_bits() & ~families) | (wf_features_ & materials) |
              (wf_features_ & families & tex.x),
          (wf_features2_ & ~families2) | (wf_features2_ & families2 & tex.y)};
}

std::pair<std::uint32_t, std::uint32_t> GpuRenderer::wf_group_words(std::uint32_t group) const {
  // The scene's material bits of the group's types; for the mixes' group, of the types they
  // reach as well.
  std::uint32_t bits = group == wf_mix_group_ ? wf_mix_bits_ : 0u;
  if (group != wf_group(gpu::MATERIAL_MIX))
    for (std::uint32_t t = 0; t < gpu::MATERIAL_TYPE_COUNT; ++t)
      if (wf_group(t) != wf_group(gpu::MATERIAL_MIX) && wf_group_of(t) == group)
        bits |= material_feature(t);
  return shade_words(bits, wf_tex_bits_.empty() ? glm::uvec2(~0u) : wf_tex_bits_[group]);
}

GpuRenderer::Pipeline GpuRenderer::make_wf_shade(std::pair<std::uint32_t, std::uint32_t> words,
                                                 CompileDevice* compiler,
                                                 const std::function<bool(std::size_t, CompileDevice*&)>& accept) {
  return plain ? make_pipeline(wavefront_shade_plain_spv, sizeof(wavefront_shade_plain_spv),
                               words.first, words.second, wf_bindings_, wf_path_view_, compiler,
                               accept)
               : make_pipeline(wavefront_shade_spv, sizeof(wavefront_shade_spv), words.first,
                               words.second, wf_bindings_, wf_path_view_, compiler, accept);
}

void GpuRenderer::wf_choose_solo() {
  wf_solo_chosen_ = true;
  // On lavapipe only: a GPU branches over the other types' code at no cost. Without Mesa's
  // shader cache the main device's queue would compile the pipeline at its first dispatch and
  // stall the render for it (on a cold cache the second device compiles it: CompileDevice).
  if (solo_pipeline == Solo::off || !ctx_.info().is_cpu || !CompileDevice::shader_cache_on())
    return;
  const std::uint32_t* hits = wf_first_hits_;
  std::uint32_t busiest = 0;
  for (std::uint32_t type = 1; type < gpu::MATERIAL_TYPE_COUNT; ++type)
    if (hits[type] > hits[busiest]) busiest = type;
  // Not a type without material code of its own (none, interface), not the mixes (their
  // pipeline holds what they reach), not one alone in its group's pipeline already.
  const std::uint32_t own = material_feature(busiest);
  if (hits[busiest] == 0 || own == 0 || wf_group(busiest) == wf_group(gpu::MATERIAL_MIX) ||
      (wf_group_words(wf_group_of(busiest)).first & material_bits()) == (wf_features_ & own))
    return;
  solo_type = busiest;
  solo_words = shade_words(own, wf_type_tex_bits_[busiest]);
  // Made only if its specialised module is at most kSoloMaxShare of its group's: where the
  // group's other types add little code (textured scenes, whose diffuse materials hold most
  // of the texture code: 0.78-0.88), making it cost more than it saved (docs/performance.md).
  const double most = kSoloMaxShare * double(wf_group_words_size_[wf_group_of(busiest)]);
  wf_solo_made_ = std::async(std::launch::async, [this, words = solo_words, most] {
    CompileDevice compiler(ctx_);  // used on a cold cache only (make_pipeline)
    return make_wf_shade(words, &compiler,
                         [most](std::size_t size, auto&) { return double(size) <= most; });
  });
  if (solo_pipeline == Solo::at_once) wf_solo_made_.wait();
}

GpuRenderer::Pipeline* GpuRenderer::wf_solo_ready() {
  if (wf_solo_.pipeline) return &wf_solo_;
  if (!wf_solo_made_.valid() ||
      wf_solo_made_.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
    return nullptr;
  wf_solo_ = wf_solo_made_.get();
  if (!wf_solo_.pipeline) {  // not made: too little code of other types to leave out
    solo_type = gpu::MATERIAL_TYPE_COUNT;
    solo_words = {0u, 0u};
    return nullptr;
  }
  // lavapipe compiles at first dispatch (see the constructor's empty pass): from Mesa's cache.
  dispatch(wf_solo_, gpu::PassConstants{0, 0, 0, 0, stride_, slots_, 0, wf_capacity_}, 1);
  return &wf_solo_;
}

GpuRenderer::Pipeline& GpuRenderer::wf_shade(std::uint32_t type) {
  const std::uint32_t group = wf_group_of(type);
  Pipeline& p = wf_shade_.at(group);
  if (p.pipeline) return p;
  p = make_wf_shade(wf_group_words(group), nullptr, [this, group](std::size_t words, auto&) {
    wf_group_words_size_[group] = words;
    return true;
  });
  // lavapipe compiles at first dispatch (see the constructor's empty pass).
  dispatch(p, gpu::PassConstants{0, 0, 0, 0, stride_, slots_, 0, wf_capacity_}, 1);
  return p;
}

void GpuRenderer::wf_wave(std::uint32_t s, std::uint32_t slot0, std::uint32_t paths) {
  auto* lists = static_cast<std::uint32_t*>(wf_lists_.mapped);
  std::memset(lists, 0, gpu::WF_COUNTERS * sizeof(std::uint32_t));
  // Every path's radiance words: no pixel until the path ends.
  std::uint32_t* radiance = lists + gpu::WF_COUNTERS + std::size_t(gpu::WF_LISTS) * wf_capacity_;
  std::memset(radiance, 0xff, std::size_t(paths) * gpu::WF_RADIANCE_WORDS * 4);
  // Each submission starts with a barrier: the previous one's writes (paths, lists, accum)
  // are visible to this one's reads.
  auto barrier = [](vk::CommandBuffer cmd) {
    vk::MemoryBarrier mb{.srcAccessMask = vk::AccessFlagBits::eShaderWrite,
                         .dstAccessMask =
                             vk::AccessFlagBits::eShaderRead | vk::AccessFlagBits::eShaderWrite};
    cmd.pipelineBarrier(vk::PipelineStageFlagBits::eComputeShader,
                        vk::PipelineStageFlagBits::eComputeShader, {}, mb, {}, {});
  };
  auto run = [&](Pipeline& p, const gpu::PassConstants& pc, std::uint32_t invocations,
                 vk::CommandBuffer cmd) {
    cmd.bindPipeline(vk::PipelineBindPoint::eCompute, p.pipeline);
    cmd.bindDescriptorSets(vk::PipelineBindPoint::eCompute, p.layout, 0, p.set, {});
    cmd.pushConstants(p.layout, vk::ShaderStageFlagBits::eCompute, 0, sizeof(pc), &pc);
    cmd.dispatch((invocations + 63) / 64, 1, 1);
  };
  // Iteration 0 starts the paths; a path crosses at most 64 interfaces besides its bounces.
  std::uint32_t active = paths;
  for (std::uint32_t it = 0; active > 0 && it < 2 + globals_max_depth_ + 64; ++it) {
    const std::uint32_t in_list = (it + 1) & 1u, out_list = it & 1u;
    ctx_.submit_and_wait([&](vk::CommandBuffer cmd) {
      barrier(cmd);
      run(wf_extend_, gpu::PassConstants{s, it, slot0, active, stride_, slots_, in_list,
                                         wf_capacity_},
          active, cmd);
    });
    lists[out_list] = 0;
    const std::uint32_t escaped = lists[gpu::WF_LIST_ESCAPE];  // (an image infinite light's)
    lists[gpu::WF_LIST_ESCAPE] = 0;
    std::uint32_t queued[gpu::MATERIAL_TYPE_COUNT];
    for (std::uint32_t type = 0; type < gpu::MATERIAL_TYPE_COUNT; ++type) {
      queued[type] = lists[gpu::WF_LIST_QUEUE + type];
      lists[gpu::WF_LIST_QUEUE + type] = 0;
      if (queued[type]) wf_shade(type);
    }
    if (!wf_first_hits_known_) {  // the camera rays of the first wave
      std::copy(queued, queued + gpu::MATERIAL_TYPE_COUNT, wf_first_hits_);
      wf_first_hits_known_ = true;
      if (solo_pipeline == Solo::at_once) wf_choose_solo();
    }
    Pipeline* solo =
        solo_type < gpu::MATERIAL_TYPE_COUNT && queued[solo_type] ? wf_solo_ready() : nullptr;
    ctx_.submit_and_wait([&](vk::CommandBuffer cmd) {
      barrier(cmd);
      if (escaped)
        run(wf_escape_,
            gpu::PassConstants{s, it, slot0, escaped, stride_, slots_, gpu::WF_LIST_ESCAPE,
                               wf_capacity_},
            escaped, cmd);
      for (std::uint32_t type = 0; type < gpu::MATERIAL_TYPE_COUNT; ++type)
        if (queued[type])
          run(type == solo_type && solo ? *solo : wf_shade(type),
              gpu::PassConstants{s, it, slot0, queued[type], stride_, slots_,
                                 (gpu::WF_LIST_QUEUE + type) | (out_list << 16), wf_capacity_},
              queued[type], cmd);
    });
    if (solo) ++solo_dispatches;
    active = lists[out_list];
  }
  if (active)
    throw std::logic_error("GpuRenderer: a wavefront path outlived its depth and crossings");
  // The paths' radiance into their pixels, in path order: the samples of a pixel in order, as
  // a wave a sample would add them (the same sums, bit for bit).
  auto* accum = static_cast<glm::vec4*>(tables_[BINDING_ACCUM].mapped);
  const std::size_t pixels = std::size_t(width_) * height_;
  for (std::uint32_t i = 0; i < paths; ++i) {
    const std::uint32_t* r = radiance + std::size_t(i) * gpu::WF_RADIANCE_WORDS;
    if (r[3] >= pixels) continue;  // a slot beyond the image
    float L[3];
    std::memcpy(L, r, sizeof(L));
    accum[r[3]] += glm::vec4(L[0], L[1], L[2], 1.0f);
  }
  auto* counters = static_cast<std::uint32_t*>(tables_[BINDING_COUNTERS].mapped);
  rays_ += counters[0];
  nonfinite_ += counters[1];
  counters[0] = counters[1] = 0;
}

void GpuRenderer::render(std::uint32_t sample_start, std::uint32_t count,
                         const std::function<void(double)>& progress, double seconds_per_pass) {
  if (wf_capacity_) {
    {
      gpu::Globals g;
      std::memcpy(&g, tables_[BINDING_GLOBALS].mapped, sizeof(g));
      check_sample_count(g, sample_start + count);
      globals_max_depth_ = g.image.z;
    }
    // Waves of wf_capacity_ (sample, slot) pairs in order (the last one fewer): a wave may
    // end in the middle of a sample and the next go on from there.
    const double work = double(slots_) * count;
    double done = 0.0;
    const std::uint32_t end = sample_start + count;
    std::uint32_t s = sample_start, slot0 = 0;
    while (s < end) {
      const std::uint64_t left = std::uint64_t(end - s) * slots_ - slot0;
      const std::uint32_t n = std::uint32_t(std::min<std::uint64_t>(wf_capacity_, left));
      const auto t_wave = Clock::now();
      wf_wave(s, slot0, n);
      const std::uint64_t next = std::uint64_t(slot0) + n;
      s += std::uint32_t(next / slots_);
      slot0 = std::uint32_t(next % slots_);
      done += n;
      // The solo pipeline once this renderer will have rendered kSoloAfterSeconds (the waves
      // so far and this call's rest at their rate): making it costs lavapipe 0.07-0.12 s of
      // a core from a warm cache, and it takes 7-14% off the renders it helps.
      wf_rendered_seconds_ += since(t_wave);
      wf_rendered_paths_ += n;
      if (!wf_solo_chosen_ &&
          wf_rendered_seconds_ * (1.0 + (work - done) / wf_rendered_paths_) >= kSoloAfterSeconds)
        wf_choose_solo();
      if (progress) progress(done / work);
    }
    return;
  }
  if (!render_.pipeline)
    throw std::logic_error("GpuRenderer::render: built without a render pipeline (probes only)");
  {
    gpu::Globals g;  // the uploaded Globals, whose sampler must cover the samples asked for
    std::memcpy(&g, tables_[BINDING_GLOBALS].mapped, sizeof(g));
    check_sample_count(g, sample_start + count);
  }
  // Work is counted in invocation slots (pixels, padded to whole 8x8 tiles) times samples.
  const std::uint32_t total = slots_;
  const double work = double(total) * count;
  double done = 0.0;
  std::uint32_t s = sample_start;
  const std::uint32_t end = sample_start + count;
  std::uint32_t slot = 0;  // next slot (in shuffled tile order) of the current sample block
  while (s < end) {
    // Size the pass from the measured rate; the first pass is small to measure it.
    double units = units_per_second_ > 0 ? units_per_second_ * seconds_per_pass : 4096.0;
    std::uint32_t samples = 1, slots = total - slot;
    if (slot == 0 && units >= 2.0 * total) {
      samples = std::uint32_t(std::min<double>(end - s, std::floor(units / total)));
    } else {
      // Whole tiles, at least one.
      double tiles = std::max(1.0, std::floor(units / 64.0));
      slots = std::uint32_t(std::min<double>(total - slot, tiles * 64.0));
    }
    gpu::PassConstants pc{s, samples, slot, slots, stride_, total, 0, 0};
    auto t0 = Clock::now();
    dispatch(render_, pc, slots);
    double dt = since(t0), u = double(slots) * samples;
    units_per_second_ = dt > 0 ? u / dt : units_per_second_;
    done += u;
    slot += slots;
    if (slot >= total) {
      slot = 0;
      s += samples;
    }
    if (progress) progress(done / work);
  }
}

std::vector<glm::vec4> GpuRenderer::accum() const {
  const Buffer& b = tables_[BINDING_ACCUM];
  std::vector<glm::vec4> out(std::size_t(width_) * height_);
  std::memcpy(out.data(), b.mapped, out.size() * sizeof(glm::vec4));
  return out;
}

void GpuRenderer::clear() {
  Buffer& b = tables_[BINDING_ACCUM];
  std::memset(b.mapped, 0, b.size);
  rays_ = nonfinite_ = 0;
}

void GpuRenderer::set_globals(const gpu::Globals& globals) {
  std::memcpy(tables_[BINDING_GLOBALS].mapped, &globals, sizeof(globals));
}

void GpuRenderer::destroy_stage(Stage& s) {
  if (!s.capacity) return;
  destroy_pipeline(s.pipeline);
  ctx_.destroy_buffer(s.in);
  ctx_.destroy_buffer(s.out);
  s.capacity = 0;
}

void GpuRenderer::run_stage(Stage& s, const std::uint32_t* spirv, std::size_t spirv_bytes,
                            std::uint32_t f1, std::uint32_t f2, std::size_t n, const void* input,
                            std::size_t in_size, void* output, std::size_t out_size,
                            std::uint32_t pad0) {
  // One dispatch of groups of 64: at most 65535 groups (Vulkan's minimum maxComputeWorkGroupCount).
  if (n > std::size_t(65535) * 64)
    throw std::invalid_argument("GpuRenderer: more than 65535 x 64 queries in one call");
  if (n > s.capacity || s.capacity == 0) {
    destroy_stage(s);
    const std::size_t cap = std::max<std::size_t>(n, 1);
    const auto usage = vk::BufferUsageFlagBits::eStorageBuffer;
    s.in = ctx_.create_buffer(cap * in_size, usage);
    s.out = ctx_.create_buffer(cap * out_size, usage);
    std::vector<std::pair<std::uint32_t, Buffer*>> bindings;
    for (std::uint32_t i = 0; i < tables_.size(); ++i) bindings.push_back({i, &tables_[i]});
    bindings.push_back({BINDING_PROBE_IN, &s.in});
    bindings.push_back({BINDING_PROBE_OUT, &s.out});
    s.pipeline = make_pipeline(spirv, spirv_bytes, f1, f2, bindings);
    s.capacity = cap;
  }
  if (n) std::memcpy(s.in.mapped, input, n * in_size);
  const std::uint32_t count = std::uint32_t(n);
  dispatch(s.pipeline, gpu::PassConstants{0, 1, 0, count, 1, count, pad0, 0}, count);
  if (n) std::memcpy(output, s.out.mapped, n * out_size);
}

std::vector<gpu::ProbeOut> GpuRenderer::probe(const std::vector<gpu::ProbeIn>& queries) {
  // The probe is specialised for the uploaded Globals' feature words like the render pipeline
  // (lavapipe compiles it with every feature in about 80 s, for the scene's in a few), and
  // rebuilt when set_globals changes them.
  gpu::Globals g;
  std::memcpy(&g, tables_[BINDING_GLOBALS].mapped, sizeof(g));
  if (probe_.capacity && (g.features.x != probe_features_[0] || g.features.y != probe_features_[1]))
    destroy_stage(probe_);
  probe_features_[0] = g.features.x;
  probe_features_[1] = g.features.y;
  std::vector<gpu::ProbeOut> result(queries.size());
  run_stage(probe_, probe_spv, sizeof(probe_spv), g.features.x, g.features.y, queries.size(),
            queries.data(), sizeof(gpu::ProbeIn), result.data(), sizeof(gpu::ProbeOut), 0u);
  return result;
}

std::vector<gpu::TraceHit> GpuRenderer::trace(const std::vector<gpu::TraceRay>& rays, bool any_hit) {
  gpu::Globals g;  // the scene's feature words
  std::memcpy(&g, tables_[BINDING_GLOBALS].mapped, sizeof(g));
  std::vector<gpu::TraceHit> hits(rays.size());
  run_stage(trace_, trace_spv, sizeof(trace_spv), g.features.x, g.features.y, rays.size(),
            rays.data(), sizeof(gpu::TraceRay), hits.data(), sizeof(gpu::TraceHit),
            any_hit ? 1u : 0u);
  return hits;
}

}  // namespace basalt::vkx
