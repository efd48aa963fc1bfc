// Textures on the host (see textures.h): pbrt-v4's Texture directive, program flattening,
// shared tables and the camera's minimum differentials.
#include "scene/textures.h"

#include "util/files.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

namespace basalt {
namespace {

using gpu::INVALID_INDEX;

// "parameter "name"" for messages.
std::string pname(const std::string& n) { return "parameter \"" + n + "\""; }

// What the classes of pbrt-v4's textures.cpp accept: tag, types, mapping kind.
struct TextureClass {
  const char* name;
  std::uint32_t tag;
  bool float_ok, spectrum_ok;
  int mapping;  // 0: none, 2: TextureMapping2D, 3: PointTransformMapping
};

const TextureClass kClasses[] = {
    {"constant", gpu::TEXTURE_CONSTANT, true, true, 0},
    {"scale", gpu::TEXTURE_SCALE, true, true, 0},
    {"mix", gpu::TEXTURE_MIX, true, true, 0},
    {"directionmix", gpu::TEXTURE_DIRECTION_MIX, true, true, 0},
    {"bilerp", gpu::TEXTURE_BILERP, true, true, 2},
    {"checkerboard", gpu::TEXTURE_CHECKERBOARD, true, true, 2},
    {"dots", gpu::TEXTURE_DOTS, true, true, 2},
    {"fbm", gpu::TEXTURE_FBM, true, false, 3},
    {"wrinkled", gpu::TEXTURE_WRINKLED, true, false, 3},
    {"windy", gpu::TEXTURE_WINDY, true, false, 3},
    {"marble", gpu::TEXTURE_MARBLE, false, true, 3},
    {"imagemap", gpu::TEXTURE_IMAGEMAP, true, true, 2},
    // Shirley's solid textures (docs/textures-spec.md section 7; basalt extensions).
    {"stripe", gpu::TEXTURE_STRIPE, true, true, 3},
    {"turbulentstripe", gpu::TEXTURE_TURBULENT_STRIPE, true, true, 3},
    {"solidnoise", gpu::TEXTURE_SHIRLEY_NOISE, true, true, 3},
    {"solidturbulence", gpu::TEXTURE_SHIRLEY_TURBULENCE, true, true, 3},
    {"interpimage", gpu::TEXTURE_IMAGE_INTERP, true, true, 2},
    {"volume", gpu::TEXTURE_VOLUME, true, true, 3},
};

// Reads one child argument of texture type want_float (pbrt-v4 GetFloatTexture /
// GetSpectrumTexture with a default): a texture reference that must already be defined with
// that type, or a constant.
TextureArg read_child(const ParamSet& ps, const std::string& n, bool want_float, glm::vec3 def,
                      const SourceLoc& loc,
                      const std::function<bool(const std::string&, bool)>& defined) {
  TextureArg a;
  a.is_float = want_float;
  a.value = def;
  a.loc = loc;
  const Param* p = ps.find(n);
  if (!p) return a;
  a.loc = p->loc;
  const char* kind = want_float ? "float" : "spectrum";
  if (p->type == "texture") {
    ps.lookup(n, {"texture"});
    if (p->strings.size() != 1)
      throw SceneError(p->loc, "expected one texture name for " + pname(n));
    a.texture = p->strings[0];
    if (!defined(a.texture, want_float)) {
      if (defined(a.texture, !want_float))
        throw SceneError(p->loc, pname(n) + " needs a " + kind + " texture, but \"" +
                                     a.texture + "\" is a " + (want_float ? "spectrum" : "float") +
                                     " texture");
      throw SceneError(p->loc, pname(n) + ": " + kind + " texture \"" + a.texture +
                                   "\" is not defined (a texture must be defined before a "
                                   "Texture directive uses it)");
    }
    return a;
  }
  if (want_float) {
    ps.lookup(n, {"float", "texture"});
    a.value = glm::vec3(ps.get_float(n, def.x));
  } else {
    a.value = ps.get_spectrum(n, SpectrumUse::Unbounded, nullptr).value_or(def);
  }
  if (!std::isfinite(a.value.x) || !std::isfinite(a.value.y) || !std::isfinite(a.value.z))
    throw SceneError(p->loc, pname(n) + " is not finite");
  return a;
}

// pbrt-v4 TextureMapping2D::Create: "mapping" uv | spherical | cylindrical | planar.
void read_mapping2d(const ParamSet& ps, const glm::mat4& ctm, TextureDef& t) {
  std::string m = ps.get_string("mapping", "uv");
  if (m == "uv") {
    t.flags |= gpu::MAPPING_UV;
    t.map[0] = glm::vec4(ps.get_float("uscale", 1.0f), ps.get_float("vscale", 1.0f),
                         ps.get_float("udelta", 0.0f), ps.get_float("vdelta", 0.0f));
  } else if (m == "spherical") {
    t.flags |= gpu::MAPPING_SPHERICAL;
  } else if (m == "cylindrical") {
    t.flags |= gpu::MAPPING_CYLINDRICAL;
  } else if (m == "planar") {
    t.flags |= gpu::MAPPING_PLANAR;
    const Param* v1 = ps.lookup("v1", {"vector3", "vector"});
    const Param* v2 = ps.lookup("v2", {"vector3", "vector"});
    glm::vec3 a = v1 && v1->numbers.size() == 3
                      ? glm::vec3(v1->numbers[0], v1->numbers[1], v1->numbers[2])
                      : glm::vec3(1, 0, 0);
    glm::vec3 b = v2 && v2->numbers.size() == 3
                      ? glm::vec3(v2->numbers[0], v2->numbers[1], v2->numbers[2])
                      : glm::vec3(0, 1, 0);
    t.map[0] = glm::vec4(a, ps.get_float("udelta", 0.0f));
    t.map[1] = glm::vec4(b, ps.get_float("vdelta", 0.0f));
  } else {
    throw SceneError(ps.loc_of("mapping", t.loc), "unknown texture mapping \"" + m +
                                                      "\" (expected uv, spherical, "
                                                      "cylindrical or planar)");
  }
  (void)ctm;
}

void read_image_file(const ParamSet& ps, const SourceLoc& loc,
                     const std::function<std::string(const std::string&)>& resolve,
                     TextureDef& t);

// pbrt-v4 FloatImageTexture::Create / SpectrumImageTexture::Create: filter (default
// bilinear), maxanisotropy (8), wrap (repeat), scale (1), invert (false), filename (resolved
// like every other file), encoding (sRGB for .png, else linear; "gamma G").
void read_imagemap(const ParamSet& ps, const SourceLoc& loc,
                   const std::function<std::string(const std::string&)>& resolve, TextureDef& t) {
  const std::string filter = ps.get_string("filter", "bilinear");
  std::uint32_t fbits = 0;
  if (filter == "point")
    fbits = gpu::FILTER_POINT;
  else if (filter == "bilinear")
    fbits = gpu::FILTER_BILINEAR;
  else if (filter == "trilinear")
    fbits = gpu::FILTER_TRILINEAR;
  else if (filter == "ewa" || filter == "EWA")
    fbits = gpu::FILTER_EWA;
  else
    throw SceneError(ps.loc_of("filter", loc), "unknown image filter \"" + filter +
                                                   "\" (expected point, bilinear, trilinear or ewa)");
  const float max_aniso = ps.get_float("maxanisotropy", 8.0f);
  if (!(max_aniso > 0.0f) || !std::isfinite(max_aniso))
    throw SceneError(ps.loc_of("maxanisotropy", loc), "parameter \"maxanisotropy\" must be positive");
  const std::string wrap = ps.get_string("wrap", "repeat");
  std::uint32_t wbits = 0;
  if (wrap == "repeat")
    wbits = gpu::WRAP_REPEAT;
  else if (wrap == "black")
    wbits = gpu::WRAP_BLACK;
  else if (wrap == "clamp")
    wbits = gpu::WRAP_CLAMP;
  else
    throw SceneError(ps.loc_of("wrap", loc), "unknown wrap mode \"" + wrap +
                                                 "\" (expected repeat, black or clamp)");
  const float scale = ps.get_float("scale", 1.0f);
  const bool invert = ps.get_bool("invert", false);
  read_image_file(ps, loc, resolve, t);
  t.flags |= (fbits << gpu::TEXFLAG_FILTER_SHIFT) | (wbits << gpu::TEXFLAG_WRAP_SHIFT);
  if (invert) t.flags |= gpu::TEXFLAG_INVERT;
  t.param[0] = glm::vec4(scale, max_aniso, 0.0f, 0.0f);
}

// The image file of an imagemap or interpimage texture: "filename" (resolved like every other
// file) and "encoding" (sRGB for .png, else linear; "gamma G").
void read_image_file(const ParamSet& ps, const SourceLoc& loc,
                     const std::function<std::string(const std::string&)>& resolve,
                     TextureDef& t) {
  const Param* fp = ps.lookup("filename", {"string"});
  if (!fp || fp->strings.size() != 1 || fp->strings[0].empty())
    throw SceneError(fp ? fp->loc : loc, t.cls + " texture \"" + t.name +
                                             "\" needs a \"string filename\" parameter");
  t.image_loc = fp->loc;
  t.image_file = resolve ? resolve(fp->strings[0]) : fp->strings[0];
  std::string ext = t.image_file.size() >= 4 ? t.image_file.substr(t.image_file.size() - 4) : "";
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  const std::string enc = ps.get_string("encoding", ext == ".png" ? "sRGB" : "linear");
  if (enc == "sRGB") {
    t.image_encoding.kind = ImageEncoding::SRGB;
  } else if (enc == "linear") {
    t.image_encoding.kind = ImageEncoding::Linear;
  } else {
    // pbrt-v4 ColorEncoding::Get: "gamma <value>", value non-zero.
    std::istringstream in(enc);
    std::string word, extra;
    float g = 0.0f;
    if (!(in >> word) || word != "gamma" || !(in >> g) || (in >> extra) || g == 0.0f ||
        !std::isfinite(g))
      throw SceneError(ps.loc_of("encoding", loc), "unknown color encoding \"" + enc +
                                                       "\" (expected sRGB, linear or \"gamma <value>\")");
    t.image_encoding.kind = ImageEncoding::Gamma;
    t.image_encoding.gamma = g;
  }
}

// A non-negative octave count (pbrt-v4 "integer octaves", default 8).
std::uint32_t read_octaves(const ParamSet& ps, const SourceLoc& loc) {
  int o = ps.get_int("octaves", 8);
  if (o < 0) throw SceneError(ps.loc_of("octaves", loc), "parameter \"octaves\" must be >= 0");
  return std::uint32_t(o);
}

// Shirley's octave counts: 0 .. 30 (default 8).
std::uint32_t read_shirley_octaves(const ParamSet& ps, const SourceLoc& loc) {
  const std::uint32_t o = read_octaves(ps, loc);
  if (o > 30u) throw SceneError(ps.loc_of("octaves", loc), "parameter \"octaves\" must be <= 30");
  return o;
}

// A stripe width: "float width" (1), > 0.
float read_stripe_width(const ParamSet& ps, const SourceLoc& loc) {
  const float w = ps.get_float("width", 1.0f);
  if (!(w > 0.0f) || !std::isfinite(w))
    throw SceneError(ps.loc_of("width", loc), "parameter \"width\" must be > 0");
  return w;
}

// Shirley's 3D texture array (docs/textures-spec.md 7, volume): "integer resolution"
// [nx ny nz] and the voxels, inline ("float values") or from a raw little-endian float32 file
// ("string filename"), 1 float per voxel (float texture) or 3 (spectrum).
void read_volume(const ParamSet& ps, const SourceLoc& loc,
                 const std::function<std::string(const std::string&)>& resolve, TextureDef& t) {
  const Param* rp = ps.lookup("resolution", {"integer"});
  if (!rp)
    throw SceneError(loc, "volume texture \"" + t.name +
                              "\" needs an \"integer resolution\" parameter [ nx ny nz ]");
  const std::vector<int> r = ps.get_ints("resolution");
  if (r.size() != 3)
    throw SceneError(rp->loc, "parameter \"resolution\" needs 3 values (nx ny nz), got " +
                                  std::to_string(r.size()));
  for (int v : r)
    if (v < 1) throw SceneError(rp->loc, "parameter \"resolution\" values must be >= 1");
  // Each factor < 2^31: the partial product stays below 2^62, and below 2^57 once checked.
  std::uint64_t voxels = std::uint64_t(r[0]) * std::uint64_t(r[1]);
  if (voxels <= (std::uint64_t(1) << 26)) voxels *= std::uint64_t(r[2]);
  if (voxels > (std::uint64_t(1) << 26))
    throw SceneError(rp->loc, "parameter \"resolution\": nx * ny * nz must be at most 67108864");
  const std::uint64_t ch = t.is_float ? 1u : 3u;
  const std::uint64_t count = voxels * ch;
  const std::string shape = std::to_string(r[0]) + " x " + std::to_string(r[1]) + " x " +
                            std::to_string(r[2]) + (t.is_float ? " float" : " spectrum") +
                            " volume needs ";
  const Param* vp = ps.lookup("values", {"float"});
  const Param* fp = ps.lookup("filename", {"string"});
  if (vp && fp)
    throw SceneError(fp->loc, "volume texture \"" + t.name +
                                  "\" has both \"values\" and \"filename\"; give one");
  if (vp) {
    t.voxels = ps.get_floats("values");
    if (t.voxels.size() != count)
      throw SceneError(vp->loc, "parameter \"values\" has " + std::to_string(t.voxels.size()) +
                                    " values; a " + shape + std::to_string(count) +
                                    (t.is_float ? "" : " (3 per voxel)"));
    for (float v : t.voxels)
      if (!std::isfinite(v))
        throw SceneError(vp->loc, "parameter \"values\" has a value that is not finite");
  } else if (fp) {
    if (fp->strings.size() != 1 || fp->strings[0].empty())
      throw SceneError(fp->loc, "volume texture \"" + t.name +
                                    "\" needs one file name in \"string filename\"");
    const std::string path = resolve ? resolve(fp->strings[0]) : fp->strings[0];
    std::string bytes;
    try {
      bytes = read_regular_file(path);  // a regular file only: util/files.h
    } catch (const FileError& e) {
      throw SceneError(fp->loc, "cannot read volume file \"" + path + "\": " + e.what());
    }
    if (bytes.size() != count * 4u)
      throw SceneError(fp->loc, "volume file \"" + path + "\" has " +
                                    std::to_string(bytes.size()) + " bytes; a " + shape +
                                    std::to_string(count * 4u) + " (" + std::to_string(count) +
                                    " little-endian float32)");
    t.voxels.resize(std::size_t(count));
    for (std::size_t i = 0; i < t.voxels.size(); ++i) {
      const std::uint32_t u = std::uint32_t((unsigned char)bytes[4 * i]) | (std::uint32_t((unsigned char)bytes[4 * i + 1]) << 8) |
                              (std::uint32_t((unsigned char)bytes[4 * i + 2]) << 16) |
                              (std::uint32_t((unsigned char)bytes[4 * i + 3]) << 24);
      float f;
      std::memcpy(&f, &u, 4);
      if (!std::isfinite(f))
        throw SceneError(fp->loc, "volume file \"" + path + "\" has a value that is not finite "
                                      "(float " + std::to_string(i) + ")");
      t.voxels[i] = f;
    }
  } else {
    throw SceneError(loc, "volume texture \"" + t.name +
                              "\" needs its voxels: \"float values\" or \"string filename\"");
  }
  t.ip = glm::uvec4(0u, std::uint32_t(r[0]), std::uint32_t(r[1]), std::uint32_t(r[2]));
}

}  // namespace

TextureDef parse_texture(const std::string& name, const std::string& type,
                         const std::string& cls, const ParamSet& ps, const glm::mat4& ctm,
                         const SourceLoc& loc, const SourceLoc& cls_loc,
                         const std::function<bool(const std::string&, bool)>& defined,
                         const std::function<std::string(const std::string&)>& resolve) {
  if (type != "float" && type != "spectrum")
    throw SceneError(loc, "texture \"" + name + "\": type must be \"float\" or \"spectrum\", got \"" +
                              type + "\"");
  if (cls == "ptex")
    throw SceneError(cls_loc, "ptex textures are not supported (texture \"" + name + "\")");
  const TextureClass* k = nullptr;
  for (const TextureClass& c : kClasses)
    if (cls == c.name) k = &c;
  if (!k) throw SceneError(cls_loc, "unknown texture class \"" + cls + "\"");
  const bool f = type == "float";
  if ((f && !k->float_ok) || (!f && !k->spectrum_ok))
    throw SceneError(cls_loc, "\"" + cls + "\" has no " + type + " texture in pbrt-v4 (texture \"" +
                                  name + "\")");
  TextureDef t;
  t.name = name;
  t.is_float = f;
  t.cls = cls;
  t.tag = k->tag;
  t.loc = loc;
  {
    glm::dmat4 dm(ctm);
    if (!(std::abs(glm::determinant(dm)) > 1e-30))
      throw SceneError(loc, "the texture's transformation is not invertible");
    t.texture_from_world = glm::mat4(glm::inverse(dm));
  }
  if (f) t.flags |= gpu::TEXFLAG_FLOAT;
  const glm::vec3 one(1.0f), zero(0.0f);
  auto child = [&](const char* n, bool want_float, glm::vec3 def) {
    t.children.push_back(read_child(ps, n, want_float, def, loc, defined));
  };
  // A constant spectrum or float parameter (bilerp corners, constant value).
  auto constant = [&](const char* n, glm::vec3 def) {
    TextureArg a = read_child(ps, n, f, def, loc, [](const std::string&, bool) { return false; });
    if (!a.texture.empty()) throw SceneError(a.loc, pname(n) + " must be a constant");
    return glm::vec4(a.value, 0.0f);
  };
  if (k->mapping == 2) read_mapping2d(ps, ctm, t);
  switch (t.tag) {
    case gpu::TEXTURE_CONSTANT:
      t.param[0] = constant("value", one);
      break;
    case gpu::TEXTURE_SCALE:
      child("tex", f, one);
      child("scale", true, one);
      break;
    case gpu::TEXTURE_MIX:
      child("tex1", f, zero);
      child("tex2", f, one);
      child("amount", true, glm::vec3(0.5f));
      break;
    case gpu::TEXTURE_DIRECTION_MIX: {
      child("tex1", f, zero);
      child("tex2", f, one);
      const Param* d = ps.lookup("dir", {"vector3", "vector"});
      glm::vec3 dir = d && d->numbers.size() == 3
                          ? glm::vec3(d->numbers[0], d->numbers[1], d->numbers[2])
                          : glm::vec3(0, 1, 0);
      // pbrt-v4: dir = Normalize(renderFromTexture(dir)).
      glm::vec3 w = glm::mat3(ctm) * dir;
      float len = glm::length(w);
      if (!(len > 0.0f) || !std::isfinite(len))
        throw SceneError(d ? d->loc : loc, "parameter \"dir\" must be a non-zero direction");
      t.param[0] = glm::vec4(w / len, 0.0f);
      break;
    }
    case gpu::TEXTURE_BILERP:
      t.param[0] = constant("v00", zero);
      t.param[1] = constant("v01", one);
      t.param[2] = constant("v10", zero);
      t.param[3] = constant("v11", one);
      break;
    case gpu::TEXTURE_CHECKERBOARD: {
      int dim = ps.get_int("dimension", 2);
      if (dim != 2 && dim != 3)
        throw SceneError(ps.loc_of("dimension", loc),
                         std::to_string(dim) + " dimensional checkerboard texture not supported");
      t.ip.x = std::uint32_t(dim);
      if (dim == 3) {
        t.flags = (t.flags & ~gpu::TEXFLAG_MAPPING_MASK) | gpu::MAPPING_POINT3D;
        t.map[0] = glm::vec4(1.0f, 1.0f, 0.0f, 0.0f);
        for (const char* n : {"uscale", "vscale", "udelta", "vdelta", "mapping"})
          if (ps.find(n)) ps.lookup(n, {"float", "string"});  // read but unused, as pbrt-v4
      }
      child("tex1", f, one);
      child("tex2", f, zero);
      break;
    }
    case gpu::TEXTURE_DOTS: {
      // pbrt-v4's Create passes "inside" where the constructor expects the outside texture
      // (docs/textures-spec.md section 8): the "outside" parameter shows inside the dots.
      TextureArg in = read_child(ps, "inside", f, one, loc, defined);
      TextureArg out = read_child(ps, "outside", f, zero, loc, defined);
      t.children = {out, in};
      break;
    }
    case gpu::TEXTURE_FBM:
    case gpu::TEXTURE_WRINKLED:
      t.flags |= gpu::MAPPING_POINT3D;
      t.ip.x = read_octaves(ps, loc);
      t.param[0] = glm::vec4(ps.get_float("roughness", 0.5f), 0.0f, 0.0f, 0.0f);
      break;
    case gpu::TEXTURE_WINDY:
      t.flags |= gpu::MAPPING_POINT3D;
      break;
    case gpu::TEXTURE_MARBLE:
      t.flags |= gpu::MAPPING_POINT3D;
      t.ip.x = read_octaves(ps, loc);
      t.param[0] = glm::vec4(ps.get_float("roughness", 0.5f), ps.get_float("scale", 1.0f),
                             ps.get_float("variation", 0.2f), 0.0f);
      break;
    case gpu::TEXTURE_IMAGEMAP:
      read_imagemap(ps, loc, resolve, t);
      break;
    // Shirley's solid textures (docs/textures-spec.md section 7).
    case gpu::TEXTURE_STRIPE: {
      t.flags |= gpu::MAPPING_POINT3D;
      const std::string form = ps.get_string("form", "width");
      if (form == "sign")
        t.ip.x = 0u;
      else if (form == "width")
        t.ip.x = 1u;
      else if (form == "smooth")
        t.ip.x = 2u;
      else
        throw SceneError(ps.loc_of("form", loc), "unknown stripe form \"" + form +
                                                     "\" (expected sign, width or smooth)");
      t.param[0] = glm::vec4(read_stripe_width(ps, loc), 0.0f, 0.0f, 0.0f);
      child("tex1", f, one);
      child("tex2", f, zero);
      break;
    }
    case gpu::TEXTURE_TURBULENT_STRIPE: {
      t.flags |= gpu::MAPPING_POINT3D;
      const float k1 = ps.get_float("k1", 1.0f), k2 = ps.get_float("k2", 1.0f);
      const float w = read_stripe_width(ps, loc);
      t.ip.x = read_shirley_octaves(ps, loc);
      t.param[0] = glm::vec4(k1, k2, w, 0.0f);
      child("tex1", f, one);
      child("tex2", f, zero);
      break;
    }
    case gpu::TEXTURE_SHIRLEY_NOISE:
      t.flags |= gpu::MAPPING_POINT3D;
      t.param[0] = glm::vec4(ps.get_float("scale", 1.0f), ps.get_float("offset", 0.0f), 0.0f, 0.0f);
      break;
    case gpu::TEXTURE_SHIRLEY_TURBULENCE:
      t.flags |= gpu::MAPPING_POINT3D;
      t.ip.x = read_shirley_octaves(ps, loc);
      t.param[0] = glm::vec4(ps.get_float("scale", 1.0f), ps.get_float("offset", 0.0f), 0.0f, 0.0f);
      break;
    case gpu::TEXTURE_IMAGE_INTERP: {
      const std::string m = ps.get_string("interpolation", "bilinear");
      if (m == "nearest")
        t.ip.x = 0u;
      else if (m == "bilinear")
        t.ip.x = 1u;
      else if (m == "hermite")
        t.ip.x = 2u;
      else
        throw SceneError(ps.loc_of("interpolation", loc),
                         "unknown interpolation \"" + m +
                             "\" (expected nearest, bilinear or hermite)");
      read_image_file(ps, loc, resolve, t);
      break;
    }
    case gpu::TEXTURE_VOLUME:
      t.flags |= gpu::MAPPING_POINT3D;
      read_volume(ps, loc, resolve, t);
      break;
    default:
      break;
  }
  for (const glm::vec4& p : t.param)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw SceneError(loc, "texture \"" + name + "\" has a parameter that is not finite");
  for (const glm::vec4& p : t.map)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.w))
      throw SceneError(loc, "texture \"" + name + "\" has a mapping parameter that is not finite");
  return t;
}

TextureProgramBuilder::TextureProgramBuilder(const Scene& scene, std::vector<gpu::Texture>* table)
    : scene_(scene), table_(table ? table : &scratch_) {
  for (std::size_t i = 0; i < scene.textures.size(); ++i)
    index_[{scene.textures[i].name, scene.textures[i].is_float}] = i;
}

const TextureDef& TextureProgramBuilder::find(const std::string& name, bool is_float,
                                              const SourceLoc& loc) const {
  auto it = index_.find({name, is_float});
  if (it != index_.end()) return scene_.textures[it->second];
  const char* kind = is_float ? "float" : "spectrum";
  if (index_.count({name, !is_float}))
    throw SceneError(loc, "a " + std::string(kind) + " texture is needed here, but \"" + name +
                              "\" is a " + (is_float ? "spectrum" : "float") + " texture");
  throw SceneError(loc, std::string(kind) + " texture \"" + name + "\" is not defined");
}

std::uint32_t TextureProgramBuilder::emit_constant(glm::vec3 v, bool is_float) {
  gpu::Texture c{};
  c.type = gpu::TEXTURE_CONSTANT;
  c.flags = is_float ? gpu::TEXFLAG_FLOAT : 0u;
  c.first = std::uint32_t(table_->size());
  c.image = INVALID_INDEX;
  c.param[0] = glm::vec4(v, 0.0f);
  c.xform = glm::mat4(1.0f);
  table_->push_back(c);
  return c.first;
}

void TextureProgramBuilder::set_image_tables(std::vector<gpu::MipLevel>* levels,
                                             std::vector<float>* texels) {
  mip_levels_ = levels;
  texels_ = texels;
}

// pbrt-v4 MIPMap constructor (util/mipmap.cpp): the image's pyramid for the texture's wrap
// mode, appended once per (image, wrap); returns the first MipLevel and sets the count.
std::uint32_t TextureProgramBuilder::pyramid(const TextureDef& t, std::uint32_t& levels) {
  levels = 0;
  if (!mip_levels_ || !texels_ || t.image < 0 || std::size_t(t.image) >= scene_.images.size())
    return INVALID_INDEX;
  const std::uint32_t wrap = (t.flags & gpu::TEXFLAG_WRAP_MASK) >> gpu::TEXFLAG_WRAP_SHIFT;
  const auto key = std::make_pair(t.image, wrap);
  auto it = pyramids_.find(key);
  if (it == pyramids_.end()) {
    const std::vector<MipImage> p = generate_pyramid(scene_.images[std::size_t(t.image)], wrap);
    const std::uint32_t first = std::uint32_t(mip_levels_->size());
    for (const MipImage& m : p) {
      gpu::MipLevel l{};
      l.offset = std::uint32_t(texels_->size());
      l.width = std::uint32_t(m.width);
      l.height = std::uint32_t(m.height);
      l.channels = std::uint32_t(m.channels);
      mip_levels_->push_back(l);
      texels_->insert(texels_->end(), m.texels.begin(), m.texels.end());
    }
    it = pyramids_.emplace(key, std::make_pair(first, std::uint32_t(p.size()))).first;
  }
  levels = it->second.second;
  return it->second.first;
}

// The one MipLevel of an interpimage (its decoded image as stored, once per image) or of a
// volume (its voxels: width nx, height ny * nz; once per texture definition).
std::uint32_t TextureProgramBuilder::append_level(int w, int h, int ch,
                                                  const std::vector<float>& v) {
  gpu::MipLevel l{};
  l.offset = std::uint32_t(texels_->size());
  l.width = std::uint32_t(w);
  l.height = std::uint32_t(h);
  l.channels = std::uint32_t(ch);
  mip_levels_->push_back(l);
  texels_->insert(texels_->end(), v.begin(), v.end());
  return std::uint32_t(mip_levels_->size() - 1);
}

std::uint32_t TextureProgramBuilder::image_level(int image) {
  if (!mip_levels_ || !texels_) return INVALID_INDEX;
  if (image < 0 || std::size_t(image) >= scene_.images.size()) return INVALID_INDEX;
  auto it = single_levels_.find(image);
  if (it == single_levels_.end()) {
    const DecodedImage& im = scene_.images[std::size_t(image)];
    it = single_levels_.emplace(image, append_level(im.width, im.height, im.channels, im.texels))
             .first;
  }
  return it->second;
}

std::uint32_t TextureProgramBuilder::single_level(const TextureDef& t) {
  if (!mip_levels_ || !texels_) return INVALID_INDEX;
  if (t.tag == gpu::TEXTURE_VOLUME) {
    auto it = volumes_.find(&t);
    if (it == volumes_.end())
      it = volumes_.emplace(&t, append_level(int(t.ip.y), int(t.ip.z * t.ip.w),
                                             t.is_float ? 1 : 3, t.voxels)).first;
    return it->second;
  }
  return image_level(t.image);
}

std::uint32_t TextureProgramBuilder::emit(const TextureDef& t, int depth, int& stack,
                                          bool albedo) {
  if (depth > 64) throw SceneError(t.loc, "textures nested too deeply");
  const std::uint32_t first = std::uint32_t(table_->size());
  int need = t.children.empty() ? 1 : int(t.children.size());
  for (std::size_t j = 0; j < t.children.size(); ++j) {
    const TextureArg& a = t.children[j];
    int s = 1;
    if (a.texture.empty())
      emit_constant(a.value, a.is_float);
    else
      emit(find(a.texture, a.is_float, a.loc), depth + 1, s, albedo && !a.is_float);
    need = std::max(need, int(j) + s);
  }
  stack = need;
  gpu::Texture g{};
  g.type = t.tag;
  g.flags = t.flags;
  g.first = first;
  g.image = INVALID_INDEX;
  g.ip = t.ip;
  for (int i = 0; i < 4; ++i) g.param[i] = t.param[i];
  g.map[0] = t.map[0];
  g.map[1] = t.map[1];
  g.xform = t.texture_from_world;
  if (t.tag == gpu::TEXTURE_IMAGEMAP) {
    g.image = pyramid(t, g.ip.x);
    if (albedo && !t.is_float) g.flags |= gpu::TEXFLAG_ALBEDO;
  }
  if (t.tag == gpu::TEXTURE_IMAGE_INTERP || t.tag == gpu::TEXTURE_VOLUME) g.image = single_level(t);
  table_->push_back(g);
  return std::uint32_t(table_->size() - 1);
}

std::uint32_t TextureProgramBuilder::program(const std::string& name, bool rgb,
                                             const SourceLoc& loc, bool albedo) {
  const bool is_float = !rgb;
  albedo = albedo && rgb;
  auto key = std::make_tuple(name, is_float, albedo);
  auto it = roots_.find(key);
  if (it != roots_.end()) return it->second;
  const TextureDef& t = find(name, is_float, loc);
  const std::size_t mark = table_->size();
  int stack = 1;
  const std::uint32_t root = emit(t, 0, stack, albedo);
  if (stack > int(gpu::MAX_TEXTURE_STACK)) {
    table_->resize(mark);
    throw SceneError(t.loc, "texture \"" + name + "\" needs " + std::to_string(stack) +
                                " stack entries to evaluate; basalt allows " +
                                std::to_string(gpu::MAX_TEXTURE_STACK));
  }
  roots_[key] = root;
  return root;
}

// The decoded-image cache key: the file and, for 8/16-bit PNG, the encoding.
std::string image_key(const TextureDef& t) {
  std::string k = t.image_file + '\n';
  std::string ext = t.image_file.size() >= 4 ? t.image_file.substr(t.image_file.size() - 4) : "";
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".png") return k;  // EXR and PFM ignore the encoding
  switch (t.image_encoding.kind) {
    case ImageEncoding::SRGB: return k + "sRGB";
    case ImageEncoding::Linear: return k + "linear";
    case ImageEncoding::Gamma: {
      std::ostringstream o;
      o.precision(9);
      o << "gamma " << t.image_encoding.gamma;
      return k + o.str();
    }
  }
  return k;
}

// pbrt-v4 ImageTextureBase's texture cache (textures.h), for the decoded image.
void load_texture_image(Scene& scene, TextureDef& t) {
  if (t.tag != gpu::TEXTURE_IMAGEMAP && t.tag != gpu::TEXTURE_IMAGE_INTERP) return;
  const std::string key = image_key(t);
  auto it = scene.image_index.find(key);
  if (it == scene.image_index.end()) {
    scene.images.push_back(read_texture_image(t.image_file, t.image_encoding, t.image_loc));
    it = scene.image_index.emplace(key, int(scene.images.size() - 1)).first;
  }
  t.image = it->second;
}

glm::uvec4 texture_shared_tables(std::vector<float>& tex_data) {
  static const int kPerm[256] = {
#include "scene/perlin_permutation.inc"
  };
  glm::uvec4 off(0u);
  off.x = std::uint32_t(tex_data.size());
  for (int r = 0; r < 2; ++r)
    for (int v : kPerm) tex_data.push_back(float(v));
  // pbrt-v4 MIPMapFilterLUT: exp(-2 r2) - exp(-2), r2 = i / (N - 1) (image maps, later).
  off.y = std::uint32_t(tex_data.size());
  for (std::uint32_t i = 0; i < gpu::EWA_LUT_SIZE; ++i) {
    const double r2 = double(i) / double(gpu::EWA_LUT_SIZE - 1);
    tex_data.push_back(float(std::exp(-2.0 * r2) - std::exp(-2.0)));
  }
  // Shirley's solid noise (docs/textures-spec.md 7): 256 unit gradients by rejection in the
  // unit ball, then a Fisher-Yates permutation of 0..255, from one 64-bit LCG (seed 0x5eed;
  // every draw advances the state first).
  off.z = std::uint32_t(tex_data.size());
  {
    std::uint64_t x = 0x5eedu;
    auto next = [&x]() {
      x = x * 6364136223846793005ull + 1442695040888963407ull;
      return x;
    };
    auto xi = [&]() { return double(next() >> 40) / 16777216.0; };
    for (int k = 0; k < 256; ++k) {
      for (;;) {
        const double vx = 2.0 * xi() - 1.0;
        const double vy = 2.0 * xi() - 1.0;
        const double vz = 2.0 * xi() - 1.0;
        const double l2 = vx * vx + vy * vy + vz * vz;
        if (!(l2 > 1e-6 && l2 < 1.0)) continue;
        const double l = std::sqrt(l2);
        tex_data.push_back(float(vx / l));
        tex_data.push_back(float(vy / l));
        tex_data.push_back(float(vz / l));
        break;
      }
    }
    int perm[256];
    for (int i = 0; i < 256; ++i) perm[i] = i;
    for (int i = 255; i >= 1; --i) {
      const int j = int((next() >> 33) % std::uint64_t(i + 1));
      std::swap(perm[i], perm[j]);
    }
    for (int v : perm) tex_data.push_back(float(v));
  }
  return off;
}

namespace {
// pbrt-v4 CoordinateSystem (Duff et al. 2017) as Frame::FromZ uses it: x, y for unit z.
void coordinate_system(glm::vec3 z, glm::vec3& x, glm::vec3& y) {
  const float sign = std::copysign(1.0f, z.z);
  const float a = -1.0f / (sign + z.z);
  const float b = z.x * z.y * a;
  x = glm::vec3(1.0f + sign * z.x * z.x * a, sign * b, -sign * z.x);
  y = glm::vec3(b, sign + z.y * z.y * a, -z.y);
}
}  // namespace

void min_differentials(gpu::Globals& g, int spp) {
  const float w = float(g.image.x), h = float(g.image.y);
  const float tan_half = g.lens.x;
  // Camera-space direction through film point (fx, fy) (docs/path-spec.md 2 steps 3-4 with
  // the lens sample at the centre, pbrt-v4's pLens = (0.5, 0.5)).
  auto dir = [&](float fx, float fy) {
    const float sx = g.screen.x + fx / w * (g.screen.y - g.screen.x);
    const float sy = g.screen.w - fy / h * (g.screen.w - g.screen.z);
    return glm::normalize(glm::vec3(sx * tan_half, sy * tan_half, 1.0f));
  };
  const float inf = std::numeric_limits<float>::infinity();
  glm::vec3 mdx(inf), mdy(inf);
  const int n = 512;  // pbrt-v4 CameraBase::FindMinimumDifferentials
  for (int i = 0; i < n; ++i) {
    const float fx = float(i) / float(n - 1) * w, fy = float(i) / float(n - 1) * h;
    const glm::vec3 d = dir(fx, fy), dx = dir(fx + 1.0f, fy), dy = dir(fx, fy + 1.0f);
    glm::vec3 fxv, fyv;
    coordinate_system(d, fxv, fyv);
    auto local = [&](glm::vec3 v) {
      return glm::vec3(glm::dot(v, fxv), glm::dot(v, fyv), glm::dot(v, d));
    };
    const glm::vec3 df = local(d);
    const glm::vec3 dxf = glm::normalize(local(dx)), dyf = glm::normalize(local(dy));
    if (glm::length(dxf - df) < glm::length(mdx)) mdx = dxf - df;
    if (glm::length(dyf - df) < glm::length(mdy)) mdy = dyf - df;
  }
  // A pinhole, and a thin lens sampled at its centre, have no position differential.
  g.min_pos_dx = glm::vec4(0.0f);
  g.min_pos_dy = glm::vec4(0.0f);
  const float spp_scale = std::max(0.125f, 1.0f / std::sqrt(float(std::max(spp, 1))));
  g.min_dir_dx = glm::vec4(mdx, spp_scale);
  g.min_dir_dy = glm::vec4(mdy, 0.0f);
}

std::vector<std::pair<std::string, std::string>> apply_texture_knobs(SceneTables& t, int filter,
                                                                     int octave_cap,
                                                                     bool split_noise) {
  static const char* kFilterNames[] = {"point", "bilinear", "trilinear", "ewa"};
  std::vector<std::pair<std::string, std::string>> knobs;
  if (filter >= 0) {
    bool ewa = false;
    for (gpu::Texture& tex : t.textures)
      if (tex.type == gpu::TEXTURE_IMAGEMAP) {
        tex.flags = (tex.flags & ~gpu::TEXFLAG_FILTER_MASK) |
                    (std::uint32_t(filter) << gpu::TEXFLAG_FILTER_SHIFT);
        ewa = ewa || std::uint32_t(filter) == gpu::FILTER_EWA;
      }
    // The EWA bit follows the override only where the scene reaches an image map at all.
    if (t.features & gpu::FEATURE_TEX_IMAGE) {
      t.features2 = ewa ? (t.features2 | gpu::FEATURE2_TEX_EWA) : (t.features2 & ~gpu::FEATURE2_TEX_EWA);
      t.globals.features.y = t.features2;
    }
    knobs.emplace_back("texture_filter", kFilterNames[filter & 3]);
  } else {
    knobs.emplace_back("texture_filter", "scene");
  }
  t.globals.texture_opts.y = octave_cap > 0 ? std::uint32_t(octave_cap) : 0u;
  // Noise precision: the option bit for both sides, the feature bit (shader code) only where
  // the scene has noise.
  t.globals.texture_opts.x = split_noise ? (t.globals.texture_opts.x | gpu::TEXOPT_NOISE_SPLIT)
                                         : (t.globals.texture_opts.x & ~gpu::TEXOPT_NOISE_SPLIT);
  if (split_noise && (t.features & gpu::FEATURE_TEX_NOISE))
    t.features2 |= gpu::FEATURE2_NOISE_SPLIT;
  else
    t.features2 &= ~gpu::FEATURE2_NOISE_SPLIT;
  t.globals.features.y = t.features2;
  knobs.emplace_back("noise_precision", split_noise ? "split" : "fp32");
  knobs.emplace_back("noise_octave_cap", octave_cap > 0 ? std::to_string(octave_cap) : "none");
  knobs.emplace_back("texture_filtering",
                     (t.globals.texture_opts.x & gpu::TEXOPT_DISABLE_FILTERING) ? "disabled" : "on");
  return knobs;
}

std::vector<std::pair<std::string, std::string>> apply_bump_knobs(SceneTables& t, bool central,
                                                                  bool dndu, float fixed_step) {
  std::uint32_t& bits = t.globals.texture_opts.x;
  bits = central ? (bits | gpu::TEXOPT_BUMP_CENTRAL) : (bits & ~gpu::TEXOPT_BUMP_CENTRAL);
  bits = dndu ? (bits & ~gpu::TEXOPT_BUMP_NO_DNDU) : (bits | gpu::TEXOPT_BUMP_NO_DNDU);
  const float step = fixed_step > 0.0f && std::isfinite(fixed_step) ? fixed_step : 0.0f;
  std::memcpy(&t.globals.texture_opts.z, &step, sizeof(float));
  std::vector<std::pair<std::string, std::string>> knobs;
  knobs.emplace_back("bump_differences", central ? "central" : "forward");
  knobs.emplace_back("bump_dndu", dndu ? "on" : "off");
  knobs.emplace_back("bump_step", step > 0.0f ? std::to_string(step) : "footprint");
  return knobs;
}

std::pair<std::string, std::string> apply_shading_rule(SceneTables& t, bool pbrt_v4) {
  std::uint32_t& bits = t.globals.texture_opts.w;
  bits = pbrt_v4 ? (bits | gpu::SHADEOPT_PBRT_V4_SIDES) : (bits & ~gpu::SHADEOPT_PBRT_V4_SIDES);
  return {"shading_normal_rule", pbrt_v4 ? "pbrt-v4" : "geometric"};
}

}  // namespace basalt
