// Material names, parameters and defaults of pbrt-v4 (src/pbrt/materials.cpp, the Create
// functions) and pbrt-v3 (src/materials/*.cpp, the Create*Material functions), and their
// GPU form (shaders/shared/layout.h slots, docs/materials-spec.md section 3).
#include "scene/materials.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "scene/merl.h"
#include "scene/spectra.h"

namespace basalt {
namespace {

namespace fs = std::filesystem;
using gpu::FEATURE_MAT_COATED_CONDUCTOR;
using gpu::FEATURE_MAT_COATED_DIFFUSE;
using gpu::FEATURE_MAT_CONDUCTOR;
using gpu::FEATURE_MAT_DIELECTRIC;
using gpu::FEATURE_MAT_DIFFUSE;
using gpu::FEATURE_MAT_DIFFUSE_TRANSMISSION;
using gpu::FEATURE_MAT_INTERFACE;
using gpu::FEATURE_MAT_MEASURED;
using gpu::FEATURE_MAT_METAL;
using gpu::FEATURE_MAT_MIRROR;
using gpu::FEATURE_MAT_MIX;
using gpu::FEATURE_MAT_MIX_WEIGHTED;
using gpu::FEATURE_MAT_OREN_NAYAR;
using gpu::FEATURE_MAT_PLASTIC;
using gpu::FEATURE_MAT_SUBSTRATE;
using gpu::FEATURE_MAT_THIN_DIELECTRIC;
using gpu::FEATURE_MAT_TRANSLUCENT;
using gpu::FEATURE_MAT_UBER;
using gpu::INVALID_INDEX;
using gpu::MATERIAL_COATED_CONDUCTOR;
using gpu::MATERIAL_COATED_DIFFUSE;
using gpu::MATERIAL_CONDUCTOR;
using gpu::MATERIAL_DIELECTRIC;
using gpu::MATERIAL_DIFFUSE;
using gpu::MATERIAL_DIFFUSE_TRANSMISSION;
using gpu::MATERIAL_INTERFACE;
using gpu::MATERIAL_MEASURED;
using gpu::MATERIAL_METAL;
using gpu::MATERIAL_MIRROR;
using gpu::MATERIAL_MIX;
using gpu::MATERIAL_MIX_WEIGHTED;
using gpu::MATERIAL_NONE;
using gpu::MATERIAL_OREN_NAYAR;
using gpu::MATERIAL_PLASTIC;
using gpu::MATERIAL_SUBSTRATE;
using gpu::MATERIAL_THIN_DIELECTRIC;
using gpu::MATERIAL_TRANSLUCENT;
using gpu::MATERIAL_UBER;
using gpu::MATFLAG_BECKMANN;
using gpu::MATFLAG_REMAP_MASK;
using gpu::MATFLAG_REMAP_NONE;
using gpu::MATFLAG_REMAP_SQRT;
using gpu::MATFLAG_REMAP_V3;
using gpu::MATFLAG_USE_REFLECTANCE;
using gpu::MAX_LOBES;
using gpu::SLOT_CC_ALBEDO;
using gpu::SLOT_CC_ETA;
using gpu::SLOT_CC_G;
using gpu::SLOT_CC_IF_ETA;
using gpu::SLOT_CC_IF_UROUGH;
using gpu::SLOT_CC_IF_VROUGH;
using gpu::SLOT_CC_K;
using gpu::SLOT_CC_REFLECTANCE;
using gpu::SLOT_CC_THICKNESS;
using gpu::SLOT_CC_UROUGH;
using gpu::SLOT_CC_VROUGH;
using gpu::SLOT_CD_ALBEDO;
using gpu::SLOT_CD_ETA;
using gpu::SLOT_CD_G;
using gpu::SLOT_CD_REFLECTANCE;
using gpu::SLOT_CD_THICKNESS;
using gpu::SLOT_CD_UROUGH;
using gpu::SLOT_CD_VROUGH;
using gpu::SLOT_CONDUCTOR_ETA;
using gpu::SLOT_CONDUCTOR_K;
using gpu::SLOT_CONDUCTOR_REFLECTANCE;
using gpu::SLOT_CONDUCTOR_UROUGH;
using gpu::SLOT_CONDUCTOR_VROUGH;
using gpu::SLOT_DIELECTRIC_ETA;
using gpu::SLOT_DIELECTRIC_KR;
using gpu::SLOT_DIELECTRIC_KT;
using gpu::SLOT_DIELECTRIC_UROUGH;
using gpu::SLOT_DIELECTRIC_VROUGH;
using gpu::SLOT_DIFFUSE_REFLECTANCE;
using gpu::SLOT_DT_REFLECTANCE;
using gpu::SLOT_DT_SCALE;
using gpu::SLOT_DT_TRANSMITTANCE;
using gpu::SLOT_MEASURED_DIMS;
using gpu::SLOT_MIRROR_KR;
using gpu::SLOT_MIX_AMOUNT;
using gpu::SLOT_ON_REFLECTANCE;
using gpu::SLOT_ON_SIGMA;
using gpu::SLOT_PLASTIC_KD;
using gpu::SLOT_PLASTIC_KS;
using gpu::SLOT_PLASTIC_ROUGH;
using gpu::SLOT_SUBSTRATE_KD;
using gpu::SLOT_SUBSTRATE_KS;
using gpu::SLOT_SUBSTRATE_UROUGH;
using gpu::SLOT_SUBSTRATE_VROUGH;
using gpu::SLOT_THIN_ETA;
using gpu::SLOT_TRANSLUCENT_KD;
using gpu::SLOT_TRANSLUCENT_KS;
using gpu::SLOT_TRANSLUCENT_REFLECT;
using gpu::SLOT_TRANSLUCENT_ROUGH;
using gpu::SLOT_TRANSLUCENT_TRANSMIT;
using gpu::SLOT_UBER_ETA;
using gpu::SLOT_UBER_KD;
using gpu::SLOT_UBER_KR;
using gpu::SLOT_UBER_KS;
using gpu::SLOT_UBER_KT;
using gpu::SLOT_UBER_OPACITY;
using gpu::SLOT_UBER_UROUGH;
using gpu::SLOT_UBER_VROUGH;

// Deepest chain of stochastic mixes (materials-spec section 4 resolves at most 16 levels).
constexpr int kMaxMixDepth = 16;

// A named spectrum as rgb by the reflectance rule (docs/materials.md "Spectra").
glm::vec3 named_rgb(const char* name) {
  return glm::vec3(spectrum_to_rgb_reflectance(*named_spectrum(name)));
}

// "parameter "name"" for messages.
std::string pname(const std::string& n) { return "parameter \"" + n + "\""; }

// Reads rgb slot key from parameter pbrt_name (rgb, spectrum, blackbody or texture); absent:
// the default, at the directive.
void read_rgb(const ParamSet& ps, const std::string& pbrt_name, const std::string& key,
              SpectrumUse use, glm::vec3 def, const SourceLoc& loc, Material& m) {
  const Param* p = ps.find(pbrt_name);
  if (p && p->type == "texture") {
    ps.lookup(pbrt_name, {"texture"});
    if (p->strings.size() != 1)
      throw SceneError(p->loc, "expected one texture name for " + pname(pbrt_name));
    m.params[key] = MaterialParam{{def.x, def.y, def.z}, p->strings[0], p->loc};
    return;
  }
  std::optional<glm::vec3> v = ps.get_spectrum(pbrt_name, use, nullptr);
  glm::vec3 c = v.value_or(def);
  m.params[key] = MaterialParam{{c.x, c.y, c.z}, "", v ? p->loc : loc};
}

// Reads float slot key from parameter pbrt_name (float or texture); absent: the default.
// Returns whether the parameter was given.
bool read_float(const ParamSet& ps, const std::string& pbrt_name, const std::string& key,
                float def, const SourceLoc& loc, Material& m) {
  const Param* p = ps.find(pbrt_name);
  if (p && p->type == "texture") {
    ps.lookup(pbrt_name, {"texture"});
    if (p->strings.size() != 1)
      throw SceneError(p->loc, "expected one texture name for " + pname(pbrt_name));
    m.params[key] = MaterialParam{{def}, p->strings[0], p->loc};
    return true;
  }
  if (p) ps.lookup(pbrt_name, {"float", "texture"});
  float v = ps.get_float(pbrt_name, def);
  if (!std::isfinite(v)) throw SceneError(p->loc, pname(pbrt_name) + " is not finite");
  m.params[key] = MaterialParam{{v}, "", p ? p->loc : loc};
  return p != nullptr;
}

// An index of refraction: a float, a texture, or a spectrum evaluated at 550 nm
// (docs/materials.md: basalt renders one eta per material).
void read_eta(const ParamSet& ps, const std::string& pbrt_name, const std::string& key, float def,
              const SourceLoc& loc, Material& m) {
  const Param* p = ps.find(pbrt_name);
  if (p && (p->type == "spectrum" || p->type == "blackbody")) {
    Spectrum s = *ps.get_spectrum_curve(pbrt_name);
    m.params[key] = MaterialParam{{float(s.eval(550.0))}, "", p->loc};
  } else if (p && p->type == "rgb") {
    throw SceneError(p->loc, pname(pbrt_name) +
                                 " is an index of refraction: give a float or a spectrum, "
                                 "not an rgb value");
  } else {
    read_float(ps, pbrt_name, key, def, loc, m);
  }
  const MaterialParam& e = m.params[key];
  if (e.texture.empty() && !(e.value[0] > 0.0f))
    throw SceneError(e.loc, pname(pbrt_name) + " must be positive");
}

// Reads a u/v roughness pair: prefix + "uroughness" / "vroughness", else prefix + "roughness",
// else def (pbrt-v4 materials.cpp and pbrt-v3 metal/uber). Keys are prefix + u/vroughness.
void read_roughness(const ParamSet& ps, const std::string& prefix, float def,
                    const SourceLoc& loc, Material& m) {
  for (const char* uv : {"uroughness", "vroughness"}) {
    std::string name = prefix + uv;
    std::string key = prefix + uv;
    if (!ps.find(name) && ps.find(prefix + "roughness"))
      read_float(ps, prefix + "roughness", key, def, loc, m);
    else
      read_float(ps, name, key, def, loc, m);
  }
}

// Throws at the parameter unless its constant value (every component) is >= lo (and <= hi).
void check_range(const Material& m, const std::string& key, float lo, float hi,
                 const char* what) {
  auto it = m.params.find(key);
  if (it == m.params.end() || !it->second.texture.empty()) return;
  for (float v : it->second.value)
    if (!(v >= lo && v <= hi)) throw SceneError(it->second.loc, pname(key) + " " + what);
}

// Roughness remap flag of remaproughness (pbrt-v4: sqrt; pbrt-v3: RoughnessToAlpha) and the
// basalt extension "string distribution" for pbrt-v3 names.
std::uint32_t remap_flags(const ParamSet& ps, bool v3, bool distribution) {
  bool remap = ps.get_bool("remaproughness", true);
  std::uint32_t f = remap ? (v3 ? MATFLAG_REMAP_V3 : MATFLAG_REMAP_SQRT) : MATFLAG_REMAP_NONE;
  if (distribution) {
    const Param* p = ps.find("distribution");
    std::string d = ps.get_string("distribution", "trowbridgereitz");
    if (d == "beckmann")
      f |= MATFLAG_BECKMANN;
    else if (d != "trowbridgereitz")
      throw SceneError(p->loc, "distribution \"" + d +
                                   "\" is not supported (\"trowbridgereitz\", the default, or "
                                   "\"beckmann\")");
  }
  return f;
}

// The kinds table (built once: the Cu defaults are computed from pbrt-v4's spectra).
std::vector<MaterialKind> make_kinds() {
  const glm::vec3 cu_eta = named_rgb("metal-Cu-eta"), cu_k = named_rgb("metal-Cu-k");
  const glm::vec3 z(0.0f);
  auto g = [](float v) { return glm::vec3(v); };
  return {
      // pbrt-v4 (materials.cpp Create functions)
      {"diffuse", MATERIAL_DIFFUSE, false, 1, {{"reflectance", SLOT_DIFFUSE_REFLECTANCE, true, g(0.5f)}}},
      {"coateddiffuse", MATERIAL_COATED_DIFFUSE, false, 1,
       {{"reflectance", SLOT_CD_REFLECTANCE, true, g(0.5f)},
        {"uroughness", SLOT_CD_UROUGH, false, z},
        {"vroughness", SLOT_CD_VROUGH, false, z},
        {"thickness", SLOT_CD_THICKNESS, false, g(0.01f)},
        {"eta", SLOT_CD_ETA, false, g(1.5f)},
        {"albedo", SLOT_CD_ALBEDO, true, z},
        {"g", SLOT_CD_G, false, z}}},
      {"coatedconductor", MATERIAL_COATED_CONDUCTOR, false, 1,
       {{"interface.uroughness", SLOT_CC_IF_UROUGH, false, z},
        {"interface.vroughness", SLOT_CC_IF_VROUGH, false, z},
        {"thickness", SLOT_CC_THICKNESS, false, g(0.01f)},
        {"interface.eta", SLOT_CC_IF_ETA, false, g(1.5f)},
        {"g", SLOT_CC_G, false, z},
        {"albedo", SLOT_CC_ALBEDO, true, z},
        {"conductor.uroughness", SLOT_CC_UROUGH, false, z},
        {"conductor.vroughness", SLOT_CC_VROUGH, false, z},
        {"conductor.eta", SLOT_CC_ETA, true, cu_eta},
        {"conductor.k", SLOT_CC_K, true, cu_k},
        {"reflectance", SLOT_CC_REFLECTANCE, true, z}}},
      {"conductor", MATERIAL_CONDUCTOR, false, 1,
       {{"eta", SLOT_CONDUCTOR_ETA, true, cu_eta},
        {"k", SLOT_CONDUCTOR_K, true, cu_k},
        {"reflectance", SLOT_CONDUCTOR_REFLECTANCE, true, z},
        {"uroughness", SLOT_CONDUCTOR_UROUGH, false, z},
        {"vroughness", SLOT_CONDUCTOR_VROUGH, false, z}}},
      {"dielectric", MATERIAL_DIELECTRIC, false, 1,
       {{"eta", SLOT_DIELECTRIC_ETA, false, g(1.5f)},
        {"uroughness", SLOT_DIELECTRIC_UROUGH, false, z},
        {"vroughness", SLOT_DIELECTRIC_VROUGH, false, z},
        {"Kr", SLOT_DIELECTRIC_KR, true, g(1.0f)},
        {"Kt", SLOT_DIELECTRIC_KT, true, g(1.0f)}}},
      {"thindielectric", MATERIAL_THIN_DIELECTRIC, false, 1, {{"eta", SLOT_THIN_ETA, false, g(1.5f)}}},
      {"diffusetransmission", MATERIAL_DIFFUSE_TRANSMISSION, false, 1,
       {{"reflectance", SLOT_DT_REFLECTANCE, true, g(0.25f)},
        {"transmittance", SLOT_DT_TRANSMITTANCE, true, g(0.25f)},
        {"scale", SLOT_DT_SCALE, false, g(1.0f)}}},
      {"measured", MATERIAL_MEASURED, false, 1, {}},
      {"mix", MATERIAL_MIX, false, 0, {{"amount", SLOT_MIX_AMOUNT, true, g(0.5f)}}},
      {"interface", MATERIAL_INTERFACE, false, 0, {}},
      // pbrt-v3 / pbrt-v2 (src/materials/*.cpp Create*Material)
      {"matte", MATERIAL_OREN_NAYAR, true, 1,
       {{"Kd", SLOT_ON_REFLECTANCE, true, g(0.5f)}, {"sigma", SLOT_ON_SIGMA, false, z}}},
      {"plastic", MATERIAL_PLASTIC, true, 2,
       {{"Kd", SLOT_PLASTIC_KD, true, g(0.25f)},
        {"Ks", SLOT_PLASTIC_KS, true, g(0.25f)},
        {"roughness", SLOT_PLASTIC_ROUGH, false, g(0.1f)}}},
      {"metal", MATERIAL_METAL, true, 1,
       {{"eta", SLOT_CONDUCTOR_ETA, true, cu_eta},
        {"k", SLOT_CONDUCTOR_K, true, cu_k},
        {"uroughness", SLOT_CONDUCTOR_UROUGH, false, g(0.01f)},
        {"vroughness", SLOT_CONDUCTOR_VROUGH, false, g(0.01f)}}},
      {"mirror", MATERIAL_MIRROR, true, 1, {{"Kr", SLOT_MIRROR_KR, true, g(0.9f)}}},
      {"glass", MATERIAL_DIELECTRIC, true, 1,
       {{"eta", SLOT_DIELECTRIC_ETA, false, g(1.5f)},
        {"uroughness", SLOT_DIELECTRIC_UROUGH, false, z},
        {"vroughness", SLOT_DIELECTRIC_VROUGH, false, z},
        {"Kr", SLOT_DIELECTRIC_KR, true, g(1.0f)},
        {"Kt", SLOT_DIELECTRIC_KT, true, g(1.0f)}}},
      {"substrate", MATERIAL_SUBSTRATE, true, 1,
       {{"Kd", SLOT_SUBSTRATE_KD, true, g(0.5f)},
        {"Ks", SLOT_SUBSTRATE_KS, true, g(0.5f)},
        {"uroughness", SLOT_SUBSTRATE_UROUGH, false, g(0.1f)},
        {"vroughness", SLOT_SUBSTRATE_VROUGH, false, g(0.1f)}}},
      {"translucent", MATERIAL_TRANSLUCENT, true, 4,
       {{"Kd", SLOT_TRANSLUCENT_KD, true, g(0.25f)},
        {"Ks", SLOT_TRANSLUCENT_KS, true, g(0.25f)},
        {"reflect", SLOT_TRANSLUCENT_REFLECT, true, g(0.5f)},
        {"transmit", SLOT_TRANSLUCENT_TRANSMIT, true, g(0.5f)},
        {"roughness", SLOT_TRANSLUCENT_ROUGH, false, g(0.1f)}}},
      {"uber", MATERIAL_UBER, true, 5,
       {{"Kd", SLOT_UBER_KD, true, g(0.25f)},
        {"Ks", SLOT_UBER_KS, true, g(0.25f)},
        {"Kr", SLOT_UBER_KR, true, z},
        {"Kt", SLOT_UBER_KT, true, z},
        {"uroughness", SLOT_UBER_UROUGH, false, g(0.1f)},
        {"vroughness", SLOT_UBER_VROUGH, false, g(0.1f)},
        {"eta", SLOT_UBER_ETA, false, g(1.5f)},
        {"opacity", SLOT_UBER_OPACITY, true, g(1.0f)}}},
  };
}

}  // namespace

const std::vector<MaterialKind>& material_kinds() {
  static const std::vector<MaterialKind> kinds = make_kinds();
  return kinds;
}

const MaterialKind* find_material_kind(const std::string& name) {
  for (const MaterialKind& k : material_kinds())
    if (name == k.name) return &k;
  return nullptr;
}

std::uint32_t material_feature(std::uint32_t tag) {
  switch (tag) {
    case MATERIAL_DIFFUSE: return FEATURE_MAT_DIFFUSE;
    case MATERIAL_OREN_NAYAR: return FEATURE_MAT_OREN_NAYAR;
    case MATERIAL_CONDUCTOR: return FEATURE_MAT_CONDUCTOR;
    case MATERIAL_DIELECTRIC: return FEATURE_MAT_DIELECTRIC;
    case MATERIAL_THIN_DIELECTRIC: return FEATURE_MAT_THIN_DIELECTRIC;
    case MATERIAL_DIFFUSE_TRANSMISSION: return FEATURE_MAT_DIFFUSE_TRANSMISSION;
    case MATERIAL_COATED_DIFFUSE: return FEATURE_MAT_COATED_DIFFUSE;
    case MATERIAL_COATED_CONDUCTOR: return FEATURE_MAT_COATED_CONDUCTOR;
    case MATERIAL_PLASTIC: return FEATURE_MAT_PLASTIC;
    case MATERIAL_SUBSTRATE: return FEATURE_MAT_SUBSTRATE;
    case MATERIAL_TRANSLUCENT: return FEATURE_MAT_TRANSLUCENT;
    case MATERIAL_UBER: return FEATURE_MAT_UBER;
    case MATERIAL_MEASURED: return FEATURE_MAT_MEASURED;
    case MATERIAL_MIX: return FEATURE_MAT_MIX;
    case MATERIAL_MIX_WEIGHTED: return FEATURE_MAT_MIX_WEIGHTED;
    case MATERIAL_INTERFACE: return FEATURE_MAT_INTERFACE;
    case MATERIAL_MIRROR: return FEATURE_MAT_MIRROR;
    case MATERIAL_METAL: return FEATURE_MAT_METAL;
    default: return 0u;
  }
}

std::vector<bool> materials_reached(const std::vector<gpu::Material>& materials,
                                    std::vector<std::uint32_t> roots) {
  std::vector<bool> reached(materials.size(), false);
  while (!roots.empty()) {
    const std::uint32_t mi = roots.back();
    roots.pop_back();
    if (mi >= materials.size() || reached[mi]) continue;
    reached[mi] = true;
    const gpu::Material& m = materials[mi];
    if (m.type == MATERIAL_MIX || m.type == MATERIAL_MIX_WEIGHTED) {
      roots.push_back(m.aux0);
      roots.push_back(m.aux1);
    }
  }
  return reached;
}

std::uint32_t material_max_lobes(std::uint32_t tag) {
  switch (tag) {
    case MATERIAL_PLASTIC: return 2;
    case MATERIAL_TRANSLUCENT: return 4;
    case MATERIAL_UBER: return 5;
    case MATERIAL_NONE:
    case MATERIAL_INTERFACE: return 0;
    case MATERIAL_MIX:
    case MATERIAL_MIX_WEIGHTED: return MAX_LOBES;  // never a weighted child (refused)
    default: return 1;
  }
}

Material parse_material(const std::string& type_in, const ParamSet& ps, const SourceLoc& loc,
                        const SourceLoc& type_loc, const std::string& what, MaterialContext& ctx) {
  std::string type = type_in;
  if (type.empty() || type == "none") {
    // pbrt-v4 Material::Create: deprecated spellings of "interface".
    if (ctx.warnings)
      ctx.warnings->push_back(format_warning(
          type_loc, "material \"" + type + "\" is deprecated; use \"interface\" (pbrt-v4)"));
    type = "interface";
  }
  for (const char* refused : {"hair", "subsurface", "kdsubsurface", "fourier", "disney"})
    if (type == refused)
      throw SceneError(type_loc, "material '" + type + "' is not supported by basalt");
  const MaterialKind* kind = find_material_kind(type);
  if (!kind) throw SceneError(type_loc, "unknown material type '" + type + "'");

  Material m;
  m.type = type;
  m.loc = loc;
  const SpectrumUse albedo = SpectrumUse::Albedo, unbounded = SpectrumUse::Unbounded;
  auto def = [&](const char* key) {
    for (const MaterialSlot& s : kind->slots)
      if (std::string(key) == s.key) return s.def;
    return glm::vec3(0.0f);
  };
  auto layered_config = [&]() {
    // pbrt-v4 CoatedDiffuseMaterial::Create: maxdepth 10, nsamples 1.
    m.max_depth = ps.get_int("maxdepth", 10);
    if (m.max_depth < 0)
      throw SceneError(ps.loc_of("maxdepth", loc), "maxdepth must not be negative");
    m.n_samples = ps.get_int("nsamples", 1);
    if (m.n_samples < 1) throw SceneError(ps.loc_of("nsamples", loc), "nsamples must be at least 1");
  };
  // Conductor Fresnel from eta/k or from reflectance (pbrt-v4 ConductorMaterial::Create).
  auto conductor = [&](const std::string& eta, const std::string& k) {
    const Param* r = ps.find("reflectance");
    if (r && (ps.find(eta) || ps.find(k)))
      throw SceneError(r->loc, "give either \"reflectance\" or \"" + eta + "\" and \"" + k +
                                   "\", not both (pbrt-v4 " + type + ")");
    read_rgb(ps, eta, eta, unbounded, def(eta.c_str()), loc, m);
    read_rgb(ps, k, k, unbounded, def(k.c_str()), loc, m);
    if (r) {
      read_rgb(ps, "reflectance", "reflectance", albedo, glm::vec3(0.0f), loc, m);
      return std::uint32_t(MATFLAG_USE_REFLECTANCE);
    }
    return 0u;
  };
  std::uint32_t flags = 0;

  if (type == "diffuse") {
    read_rgb(ps, "reflectance", "reflectance", albedo, def("reflectance"), loc, m);
  } else if (type == "coateddiffuse") {
    read_rgb(ps, "reflectance", "reflectance", albedo, def("reflectance"), loc, m);
    read_roughness(ps, "", 0.0f, loc, m);
    read_float(ps, "thickness", "thickness", 0.01f, loc, m);
    read_eta(ps, "eta", "eta", 1.5f, loc, m);
    read_rgb(ps, "albedo", "albedo", albedo, glm::vec3(0.0f), loc, m);
    read_float(ps, "g", "g", 0.0f, loc, m);
    layered_config();
    flags = remap_flags(ps, false, false);
  } else if (type == "coatedconductor") {
    read_roughness(ps, "interface.", 0.0f, loc, m);
    read_float(ps, "thickness", "thickness", 0.01f, loc, m);
    read_eta(ps, "interface.eta", "interface.eta", 1.5f, loc, m);
    read_float(ps, "g", "g", 0.0f, loc, m);
    read_rgb(ps, "albedo", "albedo", albedo, glm::vec3(0.0f), loc, m);
    read_roughness(ps, "conductor.", 0.0f, loc, m);
    flags = conductor("conductor.eta", "conductor.k");
    layered_config();
    flags |= remap_flags(ps, false, false);
  } else if (type == "conductor") {
    flags = conductor("eta", "k");
    read_roughness(ps, "", 0.0f, loc, m);
    flags |= remap_flags(ps, false, false);
  } else if (type == "dielectric") {
    read_eta(ps, "eta", "eta", 1.5f, loc, m);
    read_roughness(ps, "", 0.0f, loc, m);
    m.params["Kr"] = MaterialParam{{1.0f}, "", loc};
    m.params["Kt"] = MaterialParam{{1.0f}, "", loc};
    flags = remap_flags(ps, false, false);
  } else if (type == "thindielectric") {
    read_eta(ps, "eta", "eta", 1.5f, loc, m);
  } else if (type == "diffusetransmission") {
    read_rgb(ps, "reflectance", "reflectance", albedo, def("reflectance"), loc, m);
    read_rgb(ps, "transmittance", "transmittance", albedo, def("transmittance"), loc, m);
    const Param* sp = ps.find("scale");
    float scale = ps.get_float("scale", 1.0f);  // pbrt-v4: GetOneFloat, not a texture
    if (!(scale >= 0.0f) || !std::isfinite(scale))
      throw SceneError(sp->loc, "parameter \"scale\" must be finite and not negative");
    m.params["scale"] = MaterialParam{{scale}, "", sp ? sp->loc : loc};
    // pbrt-v4 reads these and does not use them: looked up so that they do not warn.
    if (ps.find("sigma")) ps.lookup("sigma", {"float", "texture"});
    ps.get_bool("remaproughness", true);
  } else if (type == "measured") {
    const Param* f = ps.find("filename");
    if (!f)
      throw SceneError(loc, "measured needs a \"string filename\" parameter (a MERL .binary file)");
    std::string name = ps.get_string("filename", "");
    auto ends_with = [&](const char* suf) {
      std::string s(suf);
      if (name.size() < s.size()) return false;
      std::string tail = name.substr(name.size() - s.size());
      std::transform(tail.begin(), tail.end(), tail.begin(), ::tolower);
      return tail == s;
    };
    if (ends_with(".bsdf"))
      throw SceneError(f->loc, "RGL .bsdf measured BRDFs (pbrt-v4's format) are not supported; "
                               "basalt reads MERL .binary tables (pbrt-v2's measured material)");
    if (ends_with(".brdf"))
      throw SceneError(f->loc, "irregular .brdf measured data (pbrt-v2) is not supported; "
                               "basalt reads MERL .binary tables");
    std::string path = ctx.resolve ? ctx.resolve(name) : name;
    std::string key = fs::path(path).lexically_normal().string();
    for (std::size_t i = 0; ctx.measured && i < ctx.measured->size(); ++i)
      if ((*ctx.measured)[i].path == key) m.measured = int(i);
    if (m.measured < 0) {
      MeasuredTable t;
      try {
        t = read_merl(path);
      } catch (const std::exception& e) {
        throw SceneError(f->loc, "measured BRDF file \"" + path + "\": " + e.what());
      }
      t.path = key;
      if (!ctx.measured) throw SceneError(f->loc, "measured materials need a scene to hold tables");
      m.measured = int(ctx.measured->size());
      ctx.measured->push_back(std::move(t));
    }
  } else if (type == "mix") {
    const Param* mats = ps.find("materials");
    const Param* n1 = ps.find("namedmaterial1");
    const Param* n2 = ps.find("namedmaterial2");
    if (mats && (n1 || n2))
      throw SceneError(mats->loc, "mix takes either \"string materials\" (pbrt-v4) or "
                                  "\"string namedmaterial1\"/\"namedmaterial2\" (pbrt-v3), not both");
    if (mats) {
      // pbrt-v4 MixMaterial: materials[1] is chosen with probability amount -> aux1.
      std::vector<std::string> names = ps.get_strings("materials");
      if (names.size() != 2)
        throw SceneError(mats->loc, "mix needs exactly two names in \"string materials\", got " +
                                        std::to_string(names.size()));
      for (int i = 0; i < 2; ++i) {
        m.mix_names[i] = names[i];
        m.mix_locs[i] = mats->loc;
      }
      read_float(ps, "amount", "amount", 0.5f, loc, m);
    } else if (n1 || n2) {
      // pbrt-v3 MixMaterial: namedmaterial1's BSDF is scaled by amount -> aux1.
      if (!n1 || !n2)
        throw SceneError(loc, "a pbrt-v3 mix needs both \"string namedmaterial1\" and "
                              "\"string namedmaterial2\"");
      m.mix_v3 = true;
      m.mix_names[1] = ps.get_string("namedmaterial1", "");
      m.mix_locs[1] = n1->loc;
      m.mix_names[0] = ps.get_string("namedmaterial2", "");
      m.mix_locs[0] = n2->loc;
      const Param* a = ps.find("amount");
      if (a && a->type == "float")
        read_float(ps, "amount", "amount", 0.5f, loc, m);
      else
        read_rgb(ps, "amount", "amount", unbounded, glm::vec3(0.5f), loc, m);
    } else {
      throw SceneError(type_loc, "mix needs \"string materials\" [ \"a\" \"b\" ] (pbrt-v4) or "
                                 "\"string namedmaterial1\" and \"string namedmaterial2\" (pbrt-v3)");
    }
  } else if (type == "interface") {
    // No parameters: the surface only bounds media (pbrt-v4 "interface").
  } else if (type == "matte") {
    read_rgb(ps, "Kd", "Kd", unbounded, def("Kd"), loc, m);
    read_float(ps, "sigma", "sigma", 0.0f, loc, m);
    check_range(m, "sigma", 0.0f, 90.0f, "must be in [0, 90] degrees");
  } else if (type == "plastic") {
    read_rgb(ps, "Kd", "Kd", unbounded, def("Kd"), loc, m);
    read_rgb(ps, "Ks", "Ks", unbounded, def("Ks"), loc, m);
    read_float(ps, "roughness", "roughness", 0.1f, loc, m);
    flags = remap_flags(ps, true, true);
  } else if (type == "metal") {
    read_rgb(ps, "eta", "eta", unbounded, def("eta"), loc, m);
    read_rgb(ps, "k", "k", unbounded, def("k"), loc, m);
    read_roughness(ps, "", 0.01f, loc, m);
    flags = remap_flags(ps, true, true);
  } else if (type == "mirror") {
    read_rgb(ps, "Kr", "Kr", unbounded, def("Kr"), loc, m);
  } else if (type == "glass") {
    read_rgb(ps, "Kr", "Kr", unbounded, glm::vec3(1.0f), loc, m);
    read_rgb(ps, "Kt", "Kt", unbounded, glm::vec3(1.0f), loc, m);
    read_eta(ps, ps.find("eta") ? "eta" : "index", "eta", 1.5f, loc, m);
    read_roughness(ps, "", 0.0f, loc, m);
    flags = remap_flags(ps, true, true);
    // pbrt-v3 GlassMaterial: roughness exactly 0 is specular before any remapping (its
    // RoughnessToAlpha(0) would be 0.047): keep alpha = 0 by not remapping.
    const MaterialParam &u = m.params["uroughness"], &v = m.params["vroughness"];
    if (u.texture.empty() && v.texture.empty() && u.value[0] == 0.0f && v.value[0] == 0.0f)
      flags &= ~MATFLAG_REMAP_MASK;
  } else if (type == "substrate") {
    read_rgb(ps, "Kd", "Kd", unbounded, def("Kd"), loc, m);
    read_rgb(ps, "Ks", "Ks", unbounded, def("Ks"), loc, m);
    read_roughness(ps, "", 0.1f, loc, m);
    flags = remap_flags(ps, true, true);
  } else if (type == "translucent") {
    read_rgb(ps, "Kd", "Kd", unbounded, def("Kd"), loc, m);
    read_rgb(ps, "Ks", "Ks", unbounded, def("Ks"), loc, m);
    read_rgb(ps, "reflect", "reflect", unbounded, def("reflect"), loc, m);
    read_rgb(ps, "transmit", "transmit", unbounded, def("transmit"), loc, m);
    read_float(ps, "roughness", "roughness", 0.1f, loc, m);
    flags = remap_flags(ps, true, true);
  } else if (type == "uber") {
    read_rgb(ps, "Kd", "Kd", unbounded, def("Kd"), loc, m);
    read_rgb(ps, "Ks", "Ks", unbounded, def("Ks"), loc, m);
    read_rgb(ps, "Kr", "Kr", unbounded, def("Kr"), loc, m);
    read_rgb(ps, "Kt", "Kt", unbounded, def("Kt"), loc, m);
    read_roughness(ps, "", 0.1f, loc, m);
    read_eta(ps, ps.find("eta") ? "eta" : "index", "eta", 1.5f, loc, m);
    read_rgb(ps, "opacity", "opacity", unbounded, def("opacity"), loc, m);
    flags = remap_flags(ps, true, true);
  }
  for (const char* key : {"uroughness", "vroughness", "roughness", "interface.uroughness",
                          "interface.vroughness", "conductor.uroughness", "conductor.vroughness",
                          "thickness"})
    check_range(m, key, 0.0f, INFINITY, "must not be negative");
  check_range(m, "g", -1.0f, 1.0f, "must be in [-1, 1]");
  m.flags = flags;
  // docs/bump-spec.md 1: pbrt-v4 "displacement" (pbrt-v3 "bumpmap") and "normalmap", on every
  // material but mix and interface.
  for (const char* name : {"displacement", "bumpmap", "normalmap"}) {
    const Param* p = ps.find(name);
    if (!p) continue;
    if (kind->tag == MATERIAL_MIX || kind->tag == MATERIAL_INTERFACE)
      throw SceneError(p->loc, "a '" + type + "' material takes no " + pname(name));
    if (std::string(name) == "normalmap") {
      const std::string file = ps.get_string("normalmap", "");
      if (file.empty()) throw SceneError(p->loc, pname(name) + " is empty");
      m.normal_map = ctx.resolve ? ctx.resolve(file) : file;
      m.normal_map_loc = p->loc;
    } else {
      if (m.params.count("displacement"))
        throw SceneError(p->loc, "both \"displacement\" and \"bumpmap\" are given");
      read_float(ps, name, "displacement", 0.0f, loc, m);
    }
  }
  // docs/bump-spec.md 9 (basalt extension): Shirley's vector turbulence, constants only.
  if (const Param* p = ps.lookup("normalturbulence", {"float"})) {
    if (kind->tag == MATERIAL_MIX || kind->tag == MATERIAL_INTERFACE)
      throw SceneError(p->loc, "a '" + type + "' material takes no " + pname("normalturbulence"));
    m.vturb = true;
    m.vturb_k1 = ps.get_float("normalturbulence", 0.0f);
    if (!std::isfinite(m.vturb_k1))
      throw SceneError(p->loc, pname("normalturbulence") + " must be finite");
    m.vturb_k2 = ps.get_float("normalturbulencescale", 1.0f);
    if (!(m.vturb_k2 > 0.0f) || !std::isfinite(m.vturb_k2))
      throw SceneError(ps.loc_of("normalturbulencescale", loc),
                       pname("normalturbulencescale") + " must be positive and finite");
    m.vturb_octaves = ps.get_int("normalturbulenceoctaves", 4);
    if (m.vturb_octaves < 1 || m.vturb_octaves > 16)
      throw SceneError(ps.loc_of("normalturbulenceoctaves", loc),
                       pname("normalturbulenceoctaves") + " must be in [1, 16]");
  } else {
    for (const char* name : {"normalturbulencescale", "normalturbulenceoctaves"})
      if (const Param* q = ps.find(name))
        throw SceneError(q->loc, pname(name) + " needs \"float normalturbulence\"");
  }
  if (ctx.warnings) ps.report_unused(what, *ctx.warnings);
  return m;
}

namespace {

// The MATERIAL_* tag material m renders as under mode (mixes depend on syntax and mode).
std::uint32_t tag_of(const Material& m, MixMode mode) {
  const MaterialKind* kind = find_material_kind(m.type);
  if (!kind) throw SceneError(m.loc, "material '" + m.type + "' is not supported yet");
  if (kind->tag != MATERIAL_MIX) return kind->tag;
  if (mode == MixMode::Auto) return m.mix_v3 ? MATERIAL_MIX_WEIGHTED : MATERIAL_MIX;
  return mode == MixMode::Weighted ? MATERIAL_MIX_WEIGHTED : MATERIAL_MIX;
}

// The root instruction of the program of a slot's texture reference (rgb slots need a
// spectrum texture, float slots a float one), an error at the parameter otherwise.
std::uint32_t texture_index(const Material& m, const std::string& key, const MaterialParam& p,
                            bool rgb, TextureProgramBuilder& textures) {
  const SourceLoc& loc = p.loc.file.empty() ? m.loc : p.loc;
  try {
    return textures.program(p.texture, rgb, loc);
  } catch (const SceneError& e) {
    if (e.loc.str() != loc.str()) throw;
    throw SceneError(loc, "parameter \"" + key + "\": " + e.message);
  }
}

// "material "name"" or "material 'type'" for messages.
std::string describe(const Material& m) {
  return m.name.empty() ? "a '" + m.type + "' material" : "material \"" + m.name + "\"";
}

}  // namespace

std::vector<gpu::Material> convert_materials(const Scene& scene, MixMode mode,
                                             std::vector<float>* measured,
                                             std::vector<std::string>* warnings,
                                             TextureProgramBuilder* textures) {
  const std::size_t n = scene.materials.size();
  TextureProgramBuilder check_only(scene, nullptr);
  TextureProgramBuilder& tb = textures ? *textures : check_only;
  std::vector<std::uint32_t> tags(n);
  for (std::size_t i = 0; i < n; ++i) tags[i] = tag_of(scene.materials[i], mode);

  // Measured tables, each once, in Scene::measured order.
  std::vector<std::uint32_t> offsets;
  std::size_t total = measured ? measured->size() : 0;
  for (const MeasuredTable& t : scene.measured) {
    offsets.push_back(std::uint32_t(total));
    total += t.rgb.size();
    if (measured) measured->insert(measured->end(), t.rgb.begin(), t.rgb.end());
  }

  // Mix structure: children exist; stochastic chains are acyclic and at most 16 deep.
  std::vector<int> depth(n, -1), state(n, 0);
  std::function<int(std::size_t)> mix_depth = [&](std::size_t i) -> int {
    if (tags[i] != MATERIAL_MIX && tags[i] != MATERIAL_MIX_WEIGHTED) return 0;
    if (state[i] == 1)
      throw SceneError(scene.materials[i].loc, describe(scene.materials[i]) + " contains itself (mix cycle)");
    if (state[i] == 2) return depth[i];
    state[i] = 1;
    int d = 0;
    for (int c : scene.materials[i].mix) {
      if (c < 0 || std::size_t(c) >= n)
        throw SceneError(scene.materials[i].loc, "mix refers to an undefined material");
      d = std::max(d, mix_depth(std::size_t(c)));
    }
    state[i] = 2;
    depth[i] = d + 1;
    if (depth[i] > kMaxMixDepth)
      throw SceneError(scene.materials[i].loc, "mix materials nested more than " +
                                                   std::to_string(kMaxMixDepth) + " deep");
    return depth[i];
  };
  for (std::size_t i = 0; i < n; ++i) mix_depth(i);

  std::vector<gpu::Material> out;
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Material& m = scene.materials[i];
    const MaterialKind* kind = find_material_kind(m.type);
    gpu::Material g{};
    g.type = tags[i];
    for (auto& v : g.value) v = glm::vec4(0.0f);
    for (auto& t : g.texture) t = glm::uvec4(INVALID_INDEX);
    g.flags = m.flags.value_or(kind->pbrt_v3 ? MATFLAG_REMAP_V3 : MATFLAG_REMAP_SQRT);
    if (!m.flags && (g.type == MATERIAL_CONDUCTOR || g.type == MATERIAL_COATED_CONDUCTOR) &&
        m.params.count("reflectance"))
      g.flags |= MATFLAG_USE_REFLECTANCE;
    for (const MaterialSlot& s : kind->slots) {
      glm::vec3 v = s.def;
      auto it = m.params.find(s.key);
      if (it != m.params.end()) {
        const MaterialParam& p = it->second;
        if (!p.texture.empty())
          g.texture[s.slot / 4][s.slot % 4] = texture_index(m, s.key, p, s.rgb, tb);
        if (p.value.size() == 1)
          v = glm::vec3(p.value[0]);
        else if (p.value.size() == 3)
          v = glm::vec3(p.value[0], p.value[1], p.value[2]);
        else
          throw SceneError(p.loc.file.empty() ? m.loc : p.loc,
                           "parameter \"" + std::string(s.key) + "\" needs 1 or 3 values");
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
          throw SceneError(p.loc.file.empty() ? m.loc : p.loc,
                           "parameter \"" + std::string(s.key) + "\" is not finite");
      }
      g.value[s.slot] = glm::vec4(v, 0.0f);
    }
    // docs/bump-spec.md 2: the displacement slot and the normal map's level.
    // A normal map wins over a displacement (pbrt-v4 GetBSDF), which is then not stored.
    if (auto it = m.params.find("displacement");
        it != m.params.end() && m.normal_map_image < 0) {
      const MaterialParam& p = it->second;
      g.flags |= gpu::MATFLAG_BUMP;
      g.value[gpu::SLOT_DISPLACEMENT] = glm::vec4(glm::vec3(p.value.empty() ? 0.0f : p.value[0]), 0.0f);
      if (!p.texture.empty())
        g.texture[gpu::SLOT_DISPLACEMENT / 4][gpu::SLOT_DISPLACEMENT % 4] =
            texture_index(m, "displacement", p, false, tb);
    }
    if (m.normal_map_image >= 0) {
      g.flags |= gpu::MATFLAG_NORMALMAP;
      g.value[gpu::SLOT_NORMALMAP] = glm::vec4(float(tb.image_level(m.normal_map_image)), 0.0f, 0.0f, 0.0f);
    }
    if (m.vturb) {
      g.flags |= gpu::MATFLAG_VTURB;
      g.value[gpu::SLOT_NORMALMAP].y = m.vturb_k1;
      g.value[gpu::SLOT_NORMALMAP].z = m.vturb_k2;
      g.value[gpu::SLOT_NORMALMAP].w = float(m.vturb_octaves);
    }
    switch (g.type) {
      case MATERIAL_COATED_DIFFUSE:
      case MATERIAL_COATED_CONDUCTOR:
        g.aux0 = std::uint32_t(std::max(0, m.max_depth));
        g.aux1 = std::uint32_t(std::max(1, m.n_samples));
        break;
      case MATERIAL_MEASURED:
        if (m.measured < 0 || std::size_t(m.measured) >= scene.measured.size())
          throw SceneError(m.loc, "measured material without a table");
        g.aux0 = offsets[std::size_t(m.measured)];
        g.value[SLOT_MEASURED_DIMS] = glm::vec4(glm::vec3(scene.measured[m.measured].dims), 0.0f);
        break;
      case MATERIAL_MIX:
      case MATERIAL_MIX_WEIGHTED: {
        g.aux0 = std::uint32_t(m.mix[0]);
        g.aux1 = std::uint32_t(m.mix[1]);
        glm::vec3 a(g.value[SLOT_MIX_AMOUNT]);
        if (g.type == MATERIAL_MIX && (a.x != a.y || a.y != a.z)) {
          // A pbrt-v3 spectrum amount rendered stochastically: one probability per hit.
          float mean = (a.x + a.y + a.z) / 3.0f;
          if (warnings)
            warnings->push_back(format_warning(
                m.loc, describe(m) + ": rgb amount (" + std::to_string(a.x) + ", " +
                           std::to_string(a.y) + ", " + std::to_string(a.z) +
                           ") rendered as a stochastic mix with its mean " + std::to_string(mean)));
          g.value[SLOT_MIX_AMOUNT] = glm::vec4(glm::vec3(mean), 0.0f);
        }
        if (g.type == MATERIAL_MIX_WEIGHTED) {
          std::uint32_t lobes = 0;
          for (int c : m.mix) {
            const Material& child = scene.materials[std::size_t(c)];
            std::uint32_t ct = tags[std::size_t(c)];
            if (ct == MATERIAL_MIX || ct == MATERIAL_MIX_WEIGHTED)
              throw SceneError(m.loc, "a weighted (pbrt-v3) mix cannot contain another mix (" +
                                          describe(child) + "); render it with --mix stochastic");
            if (ct == MATERIAL_INTERFACE)
              throw SceneError(m.loc, "a weighted (pbrt-v3) mix cannot contain an interface (" +
                                          describe(child) + ")");
            lobes += material_max_lobes(ct);
          }
          if (lobes > MAX_LOBES)
            throw SceneError(m.loc, "weighted mix of \"" + scene.materials[m.mix[0]].type +
                                        "\" and \"" + scene.materials[m.mix[1]].type + "\" has up to " +
                                        std::to_string(lobes) + " lobes; at most " +
                                        std::to_string(MAX_LOBES) +
                                        " are supported (use --mix stochastic)");
        }
        break;
      }
      default: break;
    }
    out.push_back(g);
  }
  return out;
}

}  // namespace basalt
