// Textures on the host: the pbrt-v4 Texture directive interpreted with pbrt-v4's defaults
// (parse_texture), texture programs flattened into the Texture table for each material slot
// (TextureProgramBuilder), the shared tables both renderers read (texture_shared_tables) and
// the camera's minimum ray differentials (min_differentials). docs/textures-spec.md is the
// contract; docs/textures.md the user reference.
#pragma once
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "../../shaders/shared/layout.h"
#include "scene/paramset.h"
#include "scene/scene.h"
#include "scene/tables.h"

namespace basalt {

/// \brief Interprets `Texture "name" "float"|"spectrum" "class" params` with pbrt-v4's
/// defaults. \p ctm is the CTM at the directive (texture space); \p defined answers whether a
/// texture of a name and type (true: float) was defined earlier in the file; \p resolve maps
/// an imagemap's "filename" to a path (relative to the scene file; identity if empty).
/// \throws SceneError at the offending token or parameter (unknown class, a class that has no
/// such type, a texture used before it is defined or of the wrong type, bad values).
TextureDef parse_texture(const std::string& name, const std::string& type,
                         const std::string& cls, const ParamSet& ps, const glm::mat4& ctm,
                         const SourceLoc& loc, const SourceLoc& cls_loc,
                         const std::function<bool(const std::string&, bool)>& defined,
                         const std::function<std::string(const std::string&)>& resolve = {});

/// \brief Decodes the image of imagemap or interpimage texture \p t (once per (file, encoding)
/// in Scene::images, shared by both classes) and sets t.image. No-op for other textures.
/// \throws SceneError at the "filename" parameter for a missing, unreadable or corrupt file.
void load_texture_image(Scene& scene, TextureDef& t);

/// Flattens named textures into post-order programs (docs/textures-spec.md section 2), one per
/// (texture, type) pair, memoised; a null table only validates.
class TextureProgramBuilder {
 public:
  TextureProgramBuilder(const Scene& scene, std::vector<gpu::Texture>* table);
  /// \brief Where image pyramids go (SceneTables::mip_levels / texels); without it image maps
  /// get image = INVALID_INDEX (validation only). Each (image, wrap) pyramid is built once.
  void set_image_tables(std::vector<gpu::MipLevel>* levels, std::vector<float>* texels);
  /// \brief Root instruction of the program of texture \p name for a slot of the given type
  /// (rgb or float). \p albedo: the slot is a pbrt-v4 SpectrumType::Albedo slot, so every
  /// rgb imagemap of the program gets TEXFLAG_ALBEDO (its value clamped to [0, 1]).
  /// \throws SceneError at \p loc if there is no such texture of that type.
  std::uint32_t program(const std::string& name, bool rgb, const SourceLoc& loc,
                        bool albedo = false);
  /// \brief The MipLevel holding decoded image \p image (Scene::images) at full resolution, no
  ///        pyramid (a normal map, docs/bump-spec.md 2), built once; INVALID_INDEX without
  ///        image tables.
  std::uint32_t image_level(int image);

 private:
  const TextureDef& find(const std::string& name, bool is_float, const SourceLoc& loc) const;
  std::uint32_t emit(const TextureDef& t, int depth, int& stack, bool albedo);
  std::uint32_t emit_constant(glm::vec3 v, bool is_float);
  std::uint32_t pyramid(const TextureDef& t, std::uint32_t& levels);
  std::uint32_t single_level(const TextureDef& t);  // interpimage, volume: one MipLevel
  std::uint32_t append_level(int w, int h, int channels, const std::vector<float>& texels);
  const Scene& scene_;
  std::vector<gpu::Texture>* table_;
  std::vector<gpu::Texture> scratch_;
  std::map<std::pair<std::string, bool>, std::size_t> index_;  // (name, is_float) -> def
  std::map<std::tuple<std::string, bool, bool>, std::uint32_t> roots_;  // (name, float, albedo)
  std::vector<gpu::MipLevel>* mip_levels_ = nullptr;
  std::vector<float>* texels_ = nullptr;
  std::map<std::pair<int, std::uint32_t>, std::pair<std::uint32_t, std::uint32_t>>
      pyramids_;  // (image, wrap) -> (first level, level count)
  std::map<int, std::uint32_t> single_levels_;            // interpimage: image -> MipLevel
  std::map<const TextureDef*, std::uint32_t> volumes_;    // volume: definition -> MipLevel
};

/// \brief Appends the shared tables of docs/textures-spec.md section 5 to \p tex_data and
/// returns their offsets (Globals.tex_tables): x = Perlin permutation (512 entries), y = EWA
/// weights, z = Shirley's 256 gradients (768 floats) then his permutation (256 floats).
glm::uvec4 texture_shared_tables(std::vector<float>& tex_data);

/// \brief pbrt-v4 CameraBase::FindMinimumDifferentials for basalt's perspective camera
/// (docs/textures-spec.md section 3): fills Globals.min_pos_dx/dy and min_dir_dx/dy (camera
/// space) and min_dir_dx.w = max(1/8, 1/sqrt(spp)). Needs g.screen, g.lens and g.image set.
void min_differentials(gpu::Globals& g, int spp);

/// \brief Texture quality knobs of the command line (issue 8 item 9), applied to built tables:
/// \p filter (FILTER_*, or a negative value to keep each image map's own) overrides the filter
/// of every image map (and the FEATURE2_TEX_EWA bit follows); \p octave_cap > 0 caps the
/// octaves of every noise sum (Globals.texture_opts.y); \p split_noise chooses the noise lookup
/// precision (docs/textures-spec.md 2.1: true "split", the default of build_tables; false
/// pbrt-v4's "fp32"). Returns the knobs in force as name/value pairs for --stats.
std::vector<std::pair<std::string, std::string>> apply_texture_knobs(SceneTables& t, int filter,
                                                                     int octave_cap,
                                                                     bool split_noise = true);

/// \brief Bump quality knobs of the command line (docs/bump-spec.md 4.5), applied to built
/// tables (Globals.texture_opts): \p central differences instead of forward ones, \p dndu
/// keeps the d dn/du term, \p fixed_step > 0 replaces the footprint step. Returns the knobs in
/// force as name/value pairs for --stats.
std::vector<std::pair<std::string, std::string>> apply_bump_knobs(SceneTables& t, bool central,
                                                                  bool dndu, float fixed_step);

/// \brief The light-leak rule of the command line (docs/materials-spec.md 1.2): \p pbrt_v4
/// true lets the shading frame alone decide reflection or transmission, as pbrt-v4 does
/// (SHADEOPT_PBRT_V4_SIDES); false keeps basalt's geometric decision. Returns the knob for
/// --stats.
std::pair<std::string, std::string> apply_shading_rule(SceneTables& t, bool pbrt_v4);

}  // namespace basalt
