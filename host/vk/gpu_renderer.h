// The Vulkan compute path: uploads scene tables, builds the specialised pipeline,
// dispatches sample passes and reads back the accumulated image.
#pragma once
#include <cstdint>
#include <functional>
#include <future>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "scene/tables.h"
#include "vk/context.h"

namespace basalt::vkx {

/// Which build of shaders/render.comp renders: `full` (every material kind) or `lean`
/// (compiled with BASALT_LEAN_MATERIALS: MATERIAL_DIFFUSE, MATERIAL_OREN_NAYAR and
/// MATERIAL_MEASURED only, for scenes whose feature bits have no other FEATURE_MAT_*);
/// `automatic` picks lean
/// whenever it can render the features, the wavefront for scenes with a material beyond
/// diffuse, Oren-Nayar and measured unless megakernel_suffices (then full); the all-features
/// pipeline stays full.
/// All are specialised for the features.
/// `wavefront`: the stages of shaders/wavefront.comp instead of the megakernel: an extend
/// pipeline, and shade pipelines for groups of material types (layered, mixes, the others,
/// and the untextured others where the others are the only group and some are textured),
/// each specialised for the features with only its group's material bits; the paths are
/// queued per material type (docs/performance.md).
enum class ShaderVariant { automatic, full, lean, wavefront };

/// Renders one SceneTables on one Context. Tables are uploaded at construction.
class GpuRenderer {
 public:
  /// \brief Uploads \p tables and creates the render pipeline specialised for \p features.
  /// \param features feature bits for the specialization constant; defaults to the scene's.
  /// \param variant the render shader build (see ShaderVariant); automatic by default.
  /// \throws std::runtime_error if a table exceeds the device's maxStorageBufferRange.
  /// \throws std::invalid_argument if \p variant is lean and lean_suffices(features) is false.
  /// \param render_pipeline false: upload only, for probe() (render() then throws).
  /// \param uploaded called once the tables are on the device, before any pipeline is made:
  ///        after it the constructor reads only \p tables' materials, textures and feature
  ///        words (the command line frees the large host tables there, for its peak memory).
  GpuRenderer(Context& ctx, const SceneTables& tables, std::uint32_t features,
              ShaderVariant variant = ShaderVariant::automatic, bool render_pipeline = true,
              const std::function<void()>& uploaded = {});
  GpuRenderer(Context& ctx, const SceneTables& tables)
      : GpuRenderer(ctx, tables, tables.features) {}
  ~GpuRenderer();
  GpuRenderer(const GpuRenderer&) = delete;
  GpuRenderer& operator=(const GpuRenderer&) = delete;

  /// \brief Adds samples [sample_start, sample_start + count) of every pixel into the
  ///        accumulation buffer, in passes of about \p seconds_per_pass each.
  /// \param progress called after each pass with the fraction of this call done.
  void render(std::uint32_t sample_start, std::uint32_t count,
              const std::function<void(double)>& progress = {}, double seconds_per_pass = 0.25);
  /// \brief The accumulation buffer: per pixel (sum of L, sum of weights).
  std::vector<glm::vec4> accum() const;
  /// \brief Rays traced (camera, continuation and shadow rays) since construction or clear().
  std::uint64_t rays() const { return rays_; }
  /// \brief Samples dropped because their radiance was NaN or infinite (path-spec section 9).
  std::uint64_t nonfinite_samples() const { return nonfinite_; }
  /// \brief Zeroes the accumulation buffer and the ray count.
  void clear();
  /// \brief Replaces the uploaded Globals (for probes that vary a Globals-only setting, such
  ///        as the sampler, without building new pipelines); the render pipeline keeps the
  ///        feature bits it was built with.
  void set_globals(const gpu::Globals& globals);
  /// \brief True if the lean render shader renders scenes with feature bits \p features
  ///        exactly as the full one does (no feature it lacks, i.e. no FEATURE_MAT_* other
  ///        than FEATURE_MAT_DIFFUSE and no bit it does not know).
  static bool lean_suffices(std::uint32_t features);
  /// \brief True if ShaderVariant::automatic renders \p t with feature words \p features,
  ///        \p features2 through a megakernel rather than the wavefront stages: where the
  ///        wavefront would make one shade pipeline (no layered material, no untextured_types)
  ///        and no portal, or the materials are diffuse, Oren-Nayar and measured alone.
  static bool megakernel_suffices(const SceneTables& t, std::uint32_t features,
                                  std::uint32_t features2);
  /// \brief The MATERIAL_* types (a bit each) whose materials have no texture, in a scene
  ///        whose materials are all of wf_group 0 (no layered material, no mix) and some
  ///        textured: the wavefront shades them in a pipeline of their own (group 3) without
  ///        the texture code. 0 for other scenes.
  static std::uint32_t untextured_types(const SceneTables& t);
  /// \brief Runs shaders/tests/probe.comp over \p queries (GPU twin of basalt::cpu::probe),
  ///        specialised for the uploaded Globals' feature words.
  std::vector<gpu::ProbeOut> probe(const std::vector<gpu::ProbeIn>& queries);
  /// \brief Traces \p rays with shaders/trace.comp (the renderer's traversal, specialised for
  ///        the scene's features): closest hits, or any hit per ray with \p any_hit; at most
  ///        65535 x 64 rays a call.
  std::vector<gpu::TraceHit> trace(const std::vector<gpu::TraceRay>& rays, bool any_hit);

  /// Largest leaf_prims table (BINDING_LEAF_PRIMS, 48 bytes a prim reference) to upload; 0:
  /// the device's maxStorageBufferRange. A larger one is left out and leaves read the
  /// reference, triangle and vertex tables instead (LEAF_PRIMS = 0); tests set 1 to take
  /// that path.
  static inline std::size_t leaf_prims_max_bytes = 0;
  bool leaf_prims = false;         // the leaf_prims table is bound (LEAF_PRIMS = 1)
  /// Most texels a table's uniform texel view may hold (BINDING_*_TEXELS of layout.h); 0: the
  /// device's maxTexelBufferElements. When one table is larger, the shaders read every table
  /// as a storage buffer (TEXEL_TABLES = 0); tests set 1 to take that path.
  static inline std::uint64_t texel_views_max_texels = 0;
  bool texel_tables = false;       // the tables are read through their texel views

  double seconds_upload = 0.0;    // table upload
  double seconds_pipeline = 0.0;  // pipeline creation plus the driver's compile at first use
  double seconds_specialise = 0.0;  // SPIR-V specialisation of the pipelines built (specialise.h)
  std::uint64_t device_bytes = 0; // bytes of all scene tables on the device
  std::uint64_t wave_bytes = 0;   // bytes of the wavefront's paths, lists and radiance
  std::string variant;            // render shader build in use: "lean", "full" or "wavefront"
  bool escape_stage = false;      // the wavefront's escape stage (an image infinite light)
  bool plain = false;             // the plain builds of it (plain_suffices), pruned at build time
  /// Whether a scene of these feature words can use the plain builds of the lean and wavefront
  /// modules (no texture, image-light or bump code: FEATURES_PLAIN_KEEP of layout.h).
  static bool plain_suffices(std::uint32_t features, std::uint32_t features2);
  /// Tests set this false to compare the plain builds with the full ones.
  static inline bool plain_builds = true;
  /// Tests set this false to specialise every shade group for all the scene's texture families.
  static inline bool group_texture_features = true;
  /// Whether the wavefront's pipelines may be compiled on a second device as well (lavapipe
  /// only, with Mesa's shader cache on; CompileDevice): tests and benchmarks turn it off to
  /// compare.
  static inline bool parallel_compile = true;
  /// Pipelines compiled on a second device (CompileDevice): at construction 0 or 1, and later
  /// the solo pipeline's (solo_pipeline) on a cold cache.
  std::uint32_t second_device_compiles = 0;
  /// The MATERIAL_* types whose shade pipeline the constructor had compiled on the second
  /// device (their group's material bits; 0 if none), and the size in words of the specialised
  /// module of \p type's shade group (0 until that pipeline is made).
  std::uint32_t second_device_materials = 0;
  std::size_t shade_module_words(std::uint32_t type) const {
    return wf_group_words_size_.empty() ? 0u : wf_group_words_size_.at(wf_group_of(type));
  }
  /// \brief The feature words the shade pipeline of MATERIAL_* \p type is specialised for
  ///        (wavefront only: the scene's, with the material bits and the texture families of
  ///        its group).
  std::pair<std::uint32_t, std::uint32_t> shade_feature_words(std::uint32_t type) const {
    return wf_group_words(wf_group_of(type));
  }
  /// The wavefront's solo pipeline (lavapipe only, with Mesa's shader cache on): the
  /// material type with the most hits among the first wave's camera rays, when its shade
  /// group's pipeline holds other types' code too, gets a pipeline specialised for it alone
  /// (lavapipe runs every type's code of a pipeline for every path; docs/performance.md).
  /// `background` (the default) makes it on a thread once the renderer will have rendered
  /// 0.5 s (its waves so far and the current call's rest), while the render goes on, and
  /// shades the type's queue with it once it is ready; `at_once` makes it at the first wave
  /// and waits for it (tests); `off` makes none.
  /// The image is the same bits every way: specialisation removes code, never changes a result.
  enum class Solo { off, background, at_once };
  static inline Solo solo_pipeline = Solo::background;
  /// MATERIAL_* type of the solo pipeline, or MATERIAL_TYPE_COUNT while there is none, and the
  /// feature words it is specialised for (the scene's, with that type's material bit and
  /// texture families only).
  std::uint32_t solo_type = gpu::MATERIAL_TYPE_COUNT;
  std::pair<std::uint32_t, std::uint32_t> solo_words{0u, 0u};
  /// Shade dispatches the solo pipeline ran.
  std::uint64_t solo_dispatches = 0;
  /// Paths of a wavefront wave (at most): this many (sample, pixel slot) pairs in order.
  static inline std::uint32_t wavefront_capacity = 262144;
  /// Samples of a wave at most (a tiny image's capacity is its slots times this).
  static constexpr std::uint32_t kWaveSamples = 64;

 private:
  struct Pipeline {
    vk::DescriptorSetLayout set_layout;
    vk::PipelineLayout layout;
    vk::Pipeline pipeline;
    vk::DescriptorPool pool;
    vk::DescriptorSet set;
  };
  /// \brief A compute pipeline of \p spirv specialised for \p features, \p features2 (the
  ///        wavefront's stages with \p wf_paths bound; compiled on \p compiler as well on a
  ///        cold cache). \p accept, if given, is called with the specialised module's size in
  ///        words and the compiler, which it may change: false makes nothing and returns an
  ///        empty Pipeline.
  Pipeline make_pipeline(const std::uint32_t* spirv, std::size_t bytes, std::uint32_t features,
                         std::uint32_t features2,
                         const std::vector<std::pair<std::uint32_t, Buffer*>>& bindings,
                         vk::BufferView wf_paths = {}, CompileDevice* compiler = nullptr,
                         const std::function<bool(std::size_t, CompileDevice*&)>& accept = {});
  void destroy_pipeline(Pipeline& p);
  void dispatch(Pipeline& p, const gpu::PassConstants& pc, std::uint32_t invocations);

  Context& ctx_;
  std::uint32_t width_, height_;
  std::uint32_t slots_;   // invocation slots: pixels padded to whole 8x8 tiles
  std::uint32_t stride_;  // tile shuffle multiplier, coprime with the tile count
  std::vector<Buffer> tables_;  // indexed by BINDING_*
  // The uniform texel views: BINDING_BVH_TEXELS + k views the table of kTexelViews[k]
  // (gpu_renderer.cpp); bound to every pipeline.
  std::vector<vk::BufferView> views_;
  std::vector<vk::DeviceSize> view_bytes_;  // their ranges
  Pipeline render_{};
  // A pipeline over an input and an output buffer of `capacity` entries (BINDING_PROBE_IN,
  // BINDING_PROBE_OUT), built on the first call and rebuilt only when a call needs more room
  // (lavapipe takes seconds to compile the probe shader).
  struct Stage {
    Pipeline pipeline{};
    Buffer in{}, out{};
    std::size_t capacity = 0;
  };
  Stage probe_, trace_;  // shaders/tests/probe.comp; shaders/trace.comp
  std::uint32_t probe_features_[2] = {0, 0};  // the feature words probe_ is specialised for
  /// \brief Makes \p s hold at least \p n entries of \p in_size and \p out_size bytes, with
  ///        its pipeline from \p spirv specialised for the feature words \p f1, \p f2; copies
  ///        \p n entries from \p input, dispatches one invocation each with \p pc.pad0 = \p
  ///        pad0, and copies the n outputs to \p output.
  void run_stage(Stage& s, const std::uint32_t* spirv, std::size_t spirv_bytes, std::uint32_t f1,
                 std::uint32_t f2, std::size_t n, const void* input, std::size_t in_size,
                 void* output, std::size_t out_size, std::uint32_t pad0);
  void destroy_stage(Stage& s);
  // The wavefront (variant "wavefront"): extend stage, shade stage per MATERIAL_* type (built
  // for the scene's types at construction, any other on first use), paths and lists; the
  // escape stage in a scene with an image infinite light (else the extend stage's own).
  Pipeline wf_extend_{};
  Pipeline wf_escape_{};
  std::vector<Pipeline> wf_shade_;
  Buffer wf_paths_{}, wf_lists_{};
  vk::BufferView wf_path_view_{};  // wf_paths_ as a uniform texel view (BINDING_WF_PATH_TEXELS)
  std::uint32_t wf_capacity_ = 0;
  std::uint32_t wf_features_ = 0, wf_features2_ = 0;  // the words the stages specialise
  std::uint32_t wf_mix_bits_ = 0;  // material bits of the types the scene's mixes reach
  std::uint32_t wf_mix_group_ = 2;  // the shade group of the mixes: 2, or 0 (none reaches a
                                    // layered material)
  std::uint32_t wf_untextured_types_ = 0;  // bit per MATERIAL_* type shaded by group 3
  std::vector<std::pair<std::uint32_t, Buffer*>> wf_bindings_;
  std::uint32_t globals_max_depth_ = 0;  // Globals image.z at the last render()
  /// \brief The shade group whose pipeline shades MATERIAL_* \p type (wf_group, with the
  /// mixes in wf_mix_group_ and the types of wf_untextured_types_ in group 3).
  std::uint32_t wf_group_of(std::uint32_t type) const;
  /// \brief Makes a shade pipeline specialised for the feature words \p words (the plain
  ///        build when \c plain).
  Pipeline make_wf_shade(std::pair<std::uint32_t, std::uint32_t> words,
                         CompileDevice* compiler = nullptr,
                         const std::function<bool(std::size_t, CompileDevice*&)>& accept = {});
  std::vector<std::size_t> wf_group_words_size_;  // per group: its specialised module's words
  /// Called before this device's copy of a pipeline compiled on the second device is made
  /// (set by the constructor while it makes the wavefront's pipelines).
  std::function<void(const std::function<bool()>&)> second_copy_wait_;
  /// \brief The shade pipeline of MATERIAL_* \p type, built if it is not yet.
  Pipeline& wf_shade(std::uint32_t type);
  /// \brief The feature words shade group \p group is specialised for: the scene's, with only
  ///        the material bits of the group's types and the texture families of its materials.
  std::pair<std::uint32_t, std::uint32_t> wf_group_words(std::uint32_t group) const;
  std::vector<glm::uvec2> wf_tex_bits_;  // per group: material_texture_features of its materials
  std::vector<glm::uvec2> wf_type_tex_bits_;  // the same per MATERIAL_* type
  /// \brief The feature words of a shade pipeline for the material bits \p materials and the
  ///        texture families \p tex: the scene's words with only those of each.
  std::pair<std::uint32_t, std::uint32_t> shade_words(std::uint32_t materials,
                                                      glm::uvec2 tex) const;
  // The solo pipeline (solo_pipeline): being made on a thread, then made.
  std::future<Pipeline> wf_solo_made_;
  Pipeline wf_solo_{};
  bool wf_solo_chosen_ = false;
  std::uint32_t wf_first_hits_[gpu::MATERIAL_TYPE_COUNT] = {};  // the first wave's camera
  bool wf_first_hits_known_ = false;                            // rays' hits by type
  double wf_rendered_seconds_ = 0.0, wf_rendered_paths_ = 0.0;  // the waves so far
  static constexpr double kSoloAfterSeconds = 0.5;
  static constexpr double kSoloMaxShare = 0.75;  // of its group's module, or no solo pipeline
  /// \brief Chooses the solo type from wf_first_hits_ and starts making its pipeline
  ///        (solo_pipeline).
  void wf_choose_solo();
  /// \brief The solo pipeline if it is made (compiled by an empty pass the first time), else
  ///        nullptr.
  Pipeline* wf_solo_ready();
  std::mutex stats_mutex_;  // seconds_specialise and second_device_compiles, added to by
                            // make_pipeline on several threads
  /// \brief Runs \p paths (sample, slot) pairs in order from slot \p slot0 of sample \p s
  /// through the wavefront stages.
  void wf_wave(std::uint32_t s, std::uint32_t slot0, std::uint32_t paths);
  std::uint64_t rays_ = 0, nonfinite_ = 0;
  double units_per_second_ = 0.0;  // measured pixel-samples per second
};

}  // namespace basalt::vkx
