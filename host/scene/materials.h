// Materials: the pbrt-v4 and pbrt-v3/v2 material names basalt reads, their parameters and
// pbrt defaults (parse_material), and their GPU form (convert_materials), slot by slot as
// shaders/shared/layout.h and docs/materials-spec.md section 3 define it. docs/materials.md is
// the user-facing reference.
#pragma once
#include <cstdint>
#include <functional>
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "../../shaders/shared/layout.h"
#include "scene/paramset.h"
#include "scene/scene.h"
#include "scene/textures.h"

namespace basalt {

/// One parameter slot of a material kind: its key in Material::params, its slot index, and
/// whether it is rgb (a spectrum texture) or a float (x only).
struct MaterialSlot {
  const char* key;
  std::uint32_t slot;
  bool rgb;
  glm::vec3 def;  // pbrt's default (rgb slots: the colour; float slots: x)
};

/// A material name of pbrt-v4 or pbrt-v3/v2 and how it maps to a MATERIAL_* tag.
struct MaterialKind {
  const char* name;            // "diffuse", "matte", ...
  std::uint32_t tag;           // MATERIAL_*; MIX for both mix syntaxes (decided per material)
  bool pbrt_v3;                // pbrt-v3/v2 name: MATFLAG_REMAP_V3, Beckmann allowed
  std::uint32_t max_lobes;     // most lobes it can produce (materials-spec section 3)
  std::vector<MaterialSlot> slots;
};

/// \brief The kind called \p name ("interface" for pbrt-v4's interface), or nullptr.
const MaterialKind* find_material_kind(const std::string& name);
/// \brief All kinds, pbrt-v4 names first.
const std::vector<MaterialKind>& material_kinds();
/// \brief The FEATURE_MAT_* bit of a MATERIAL_* tag (0 for NONE).
std::uint32_t material_feature(std::uint32_t tag);
/// \brief The largest lobe count of a MATERIAL_* tag (materials-spec section 3).
std::uint32_t material_max_lobes(std::uint32_t tag);
/// \brief Which of \p materials are reached from \p roots, a mix (MIX, MIX_WEIGHTED) reaching
///        its two children (aux0, aux1) and theirs; indices out of range reach nothing.
std::vector<bool> materials_reached(const std::vector<gpu::Material>& materials,
                                    std::vector<std::uint32_t> roots);

/// What parse_material needs from the parser besides the parameters.
struct MaterialContext {
  std::vector<std::string>* warnings = nullptr;
  std::function<std::string(const std::string&)> resolve;  // file name -> path
  std::vector<MeasuredTable>* measured = nullptr;          // tables read so far (deduplicated)
};

/// \brief Interprets the parameters of material \p type (Material or MakeNamedMaterial) with
/// pbrt's defaults; mix names stay unresolved (Material::mix_names). Reports unused
/// parameters as warnings (\p what names the directive).
/// \param loc the directive, \param type_loc where the type name is (for unknown types).
/// \throws SceneError at the offending parameter for bad values, unknown or refused types.
Material parse_material(const std::string& type, const ParamSet& ps, const SourceLoc& loc,
                        const SourceLoc& type_loc, const std::string& what, MaterialContext& ctx);

/// \brief The GPU materials of \p scene, index for index, with mixes rendered as \p mode says,
/// texture references resolved into programs by \p textures (a slot holds its root
/// instruction; null: references are only checked), and measured tables appended to
/// \p measured (aux0 = offset; each table once).
/// \throws SceneError at the material (or parameter) for what cannot be rendered: a weighted
///         mix of mixes or interfaces or with more than MAX_LOBES lobes, a mix cycle or a
///         nesting deeper than 16, an unknown type, an undefined texture or one of the
///         wrong type.
std::vector<gpu::Material> convert_materials(const Scene& scene, MixMode mode,
                                             std::vector<float>* measured,
                                             std::vector<std::string>* warnings,
                                             TextureProgramBuilder* textures = nullptr);

}  // namespace basalt
