// pbrt-v4 scene parser: directives, graphics state and the typed Scene (pbrt-v4 parser.cpp
// parse() and scene.cpp BasicSceneBuilder, re-implemented; see docs/scene-format.md).
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/gtc/type_ptr.hpp>
#include <map>
#include <numbers>
#include <sstream>

#include "scene/images.h"
#include "scene/materials.h"
#include "scene/paramset.h"
#include "scene/ply.h"
#include "scene/samplers.h"
#include "scene/scene.h"
#include "scene/textures.h"
#include "scene/tokenizer.h"
#include "util/files.h"

namespace basalt {

namespace {

/// An integer parameter that must be positive: its value (or \p def when absent), else an
/// error located at the parameter (or at \p loc).
int positive_int(const ParamSet& ps, const std::string& name, int def, const SourceLoc& loc) {
  const int v = ps.get_int(name, def);
  if (v <= 0)
    throw SceneError(ps.loc_of(name, loc), name + " must be positive, got " + std::to_string(v));
  return v;
}

namespace fs = std::filesystem;

/// Whether every component of v is finite.
bool finite3(const glm::vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

constexpr int kMaxIncludeDepth = 64;

// The attributes AttributeBegin saves and AttributeEnd restores (pbrt-v4 GraphicsState).
struct GraphicsState {
  glm::mat4 ctm{1.0f};
  int material = -1;           // index into Scene::materials; -1: default or pending named
  std::string named_material;  // NamedMaterial not yet defined when it was set
  SourceLoc named_material_loc;
  std::optional<AreaLight> area_light;
  bool reverse_orientation = false;
};

// A shape whose NamedMaterial is resolved at the end (pbrt-v4 resolves names after parsing).
struct PendingMaterial {
  std::size_t shape;
  std::string name;
  SourceLoc loc;
};

// pbrt-v4 normalizeArg: option names ignore case, '-' and '_'.
std::string normalize_option(const std::string& s) {
  std::string out;
  for (char c : s)
    if (c != '_' && c != '-') out += char(std::tolower((unsigned char)c));
  return out;
}

// Applies m to a point with the homogeneous divide (pbrt-v4 Transform::operator()(Point3f)).
glm::vec3 xform_point(const glm::mat4& m, glm::vec3 p) {
  glm::vec4 r = m * glm::vec4(p, 1.0f);
  return r.w == 1.0f ? glm::vec3(r) : glm::vec3(r) / r.w;
}

// Applies the linear part of m to a direction.
glm::vec3 xform_vector(const glm::mat4& m, glm::vec3 v) { return glm::mat3(m) * v; }

// Reads a whole scene file; failures are errors at where, naming the file and the reason.
std::string read_scene_file(const std::string& path, const SourceLoc& where, const char* kind) {
  if (path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0)
    throw SceneError(
        where, std::string("gzip-compressed scene files are not supported yet: \"") + path + "\"");
  try {
    return read_regular_file(path);
  } catch (const FileError& e) {
    throw SceneError(where, std::string("cannot read ") + kind + " \"" + path + "\": " + e.what());
  }
}

class Parser {
 public:
  Parser(std::string main_dir, MixMode mix_mode, std::uint64_t max_table_bytes)
      : main_dir_(std::move(main_dir)) {
    scene_.mix_mode = mix_mode;
    scene_.max_table_bytes = max_table_bytes;
  }

  // Parses the text of one file; dir resolves its relative paths.
  void parse(Tokenizer& tok, const std::string& dir);
  // Reads and parses an included file; from is the Include/Import location.
  void parse_file(const std::string& path, const SourceLoc* from);
  // Checks what can only be checked at the end and hands over the scene.
  Scene finish(const SourceLoc& eof);

 private:
  // ---- helpers ----
  std::string resolve(const std::string& name, const std::string& dir) const;
  double number_arg(Tokenizer& tok, const Token& d, int count);
  std::string string_arg(Tokenizer& tok, const Token& d, const char* what);
  void matrix_arg(Tokenizer& tok, const Token& d, float m[16]);
  ParamSet params(Tokenizer& tok);
  void verify_options(const Token& d);
  void verify_world(const Token& d);
  void warn(const SourceLoc& loc, const std::string& msg);
  int default_material();
  glm::mat4 invert(const glm::mat4& m, const SourceLoc& loc, const char* what);

  // ---- directives ----
  void directive(Tokenizer& tok, const Token& d, const std::string& dir);
  void camera(Tokenizer& tok, const Token& d);
  void film(Tokenizer& tok, const Token& d);
  void sampler(Tokenizer& tok, const Token& d);
  void pixel_filter(Tokenizer& tok, const Token& d);
  void integrator(Tokenizer& tok, const Token& d);
  void option(Tokenizer& tok, const Token& d);
  void texture(Tokenizer& tok, const Token& d, const std::string& dir);
  void shape(Tokenizer& tok, const Token& d, const std::string& dir);
  void light_source(Tokenizer& tok, const Token& d, const std::string& dir);
  void area_light_source(Tokenizer& tok, const Token& d);
  void image_infinite_light(const ParamSet& ps, const Token& d, const std::string& dir,
                            float scale, Light& l);
  Material make_material(const std::string& type, const ParamSet& ps, const SourceLoc& loc,
                         const SourceLoc& type_loc, const std::string& what,
                         const std::string& dir);
  void attribute_begin(const Token& d);
  void attribute_end(const Token& d);

  Scene scene_;
  std::string main_dir_;
  bool world_ = false;
  GraphicsState gs_;
  std::vector<std::pair<GraphicsState, SourceLoc>> stack_;  // with the AttributeBegin location
  std::map<std::string, glm::mat4> coord_systems_;
  std::map<std::string, int> named_materials_;
  std::vector<PendingMaterial> pending_;
  int default_material_ = -1;
  int include_depth_ = 0;
  bool warned_transform_begin_ = false;
  bool sampler_seed_given_ = false;
  int option_seed_ = 0;
  std::optional<float> frame_aspect_;
  SourceLoc frame_aspect_loc_;
};

// Records a warning at loc in Scene::warnings.
void Parser::warn(const SourceLoc& loc, const std::string& msg) {
  scene_.warnings.push_back(format_warning(loc, msg));
}

// Resolves a relative path against the referencing file's directory; if nothing is there, tries
// the top-level file's directory (pbrt-v4's single search directory, SetSearchDirectory).
std::string Parser::resolve(const std::string& name, const std::string& dir) const {
  fs::path p(name);
  if (p.is_absolute()) return name;
  fs::path a = (fs::path(dir) / p).lexically_normal();
  std::error_code ec;
  if (fs::exists(a, ec)) return a.string();
  fs::path b = (fs::path(main_dir_) / p).lexically_normal();
  if (b != a && fs::exists(b, ec)) return b.string();
  return a.string();
}

// Reads the next token as one of count numbers that directive d takes.
double Parser::number_arg(Tokenizer& tok, const Token& d, int count) {
  std::optional<Token> t = tok.next();
  if (!t || t->kind != Token::Kind::Number)
    throw SceneError(t ? t->loc : d.loc, d.text + " expects " + std::to_string(count) +
                                             " numbers, got " +
                                             (t ? t->describe() : std::string("end of file")));
  return t->number;
}

// Reads the next token as a quoted string argument of directive d.
std::string Parser::string_arg(Tokenizer& tok, const Token& d, const char* what) {
  std::optional<Token> t = tok.next();
  if (!t || t->kind != Token::Kind::String)
    throw SceneError(t ? t->loc : d.loc, d.text + " expects " + what + " in quotes, got " +
                                             (t ? t->describe() : std::string("end of file")));
  return t->text;
}

// Reads the 16 numbers of Transform/ConcatTransform, in brackets (brackets optional).
void Parser::matrix_arg(Tokenizer& tok, const Token& d, float m[16]) {
  const std::optional<Token>& open = tok.peek();
  bool bracket = open && open->kind == Token::Kind::LBracket;
  if (bracket) tok.next();
  for (int i = 0; i < 16; ++i) m[i] = float(number_arg(tok, d, 16));
  if (bracket) {
    std::optional<Token> close = tok.next();
    if (!close || close->kind != Token::Kind::RBracket)
      throw SceneError(close ? close->loc : d.loc, d.text + " expects ']' after 16 numbers");
  }
}

// Reads a parameter list; texture references are refused until textures exist.
ParamSet Parser::params(Tokenizer& tok) {
  ParamSet ps = parse_param_list(tok);
  for (const Param& p : ps.params)
    if (p.type == "texture")
      throw SceneError(p.loc, "textures are not supported yet (parameter \"" + p.name +
                                  "\" refers to texture \"" + p.strings[0] + "\")");
  return ps;
}

// pbrt-v4 VERIFY_OPTIONS: rendering options come before WorldBegin.
void Parser::verify_options(const Token& d) {
  if (world_) throw SceneError(d.loc, "'" + d.text + "' is not allowed after WorldBegin");
}

// pbrt-v4 VERIFY_WORLD: scene content comes after WorldBegin.
void Parser::verify_world(const Token& d) {
  if (!world_) throw SceneError(d.loc, "'" + d.text + "' is only allowed after WorldBegin");
}

// The index of pbrt-v4's default material, diffuse with reflectance 0.5, created on first use.
int Parser::default_material() {
  if (default_material_ < 0) {
    Material m;
    m.type = "diffuse";
    m.params["reflectance"] = MaterialParam{{0.5f, 0.5f, 0.5f}, "", SourceLoc{}};
    default_material_ = int(scene_.materials.size());
    scene_.materials.push_back(std::move(m));
  }
  return default_material_;
}

// Inverts m in double precision; a singular matrix is an error at loc.
glm::mat4 Parser::invert(const glm::mat4& m, const SourceLoc& loc, const char* what) {
  glm::dmat4 dm(m);
  double det = glm::determinant(dm);
  if (!(std::abs(det) > 1e-30) || !std::isfinite(det))
    throw SceneError(loc, std::string(what) + " is not invertible");
  return glm::mat4(glm::inverse(dm));
}

// Include/Import: parses another file in the current state (depth-limited against cycles).
void Parser::parse_file(const std::string& path, const SourceLoc* from) {
  if (++include_depth_ > kMaxIncludeDepth)
    throw SceneError(*from, "Include nesting deeper than " + std::to_string(kMaxIncludeDepth) +
                                " (recursive Include?)");
  Tokenizer tok(read_scene_file(path, *from, "included file"), path);
  parse(tok, fs::path(path).parent_path().string());
  --include_depth_;
}

// Runs directives until the end of the text.
void Parser::parse(Tokenizer& tok, const std::string& dir) {
  while (std::optional<Token> t = tok.next()) {
    if (t->kind != Token::Kind::Word)
      throw SceneError(t->loc, "expected a directive, got " + t->describe());
    directive(tok, *t, dir);
  }
}

// Dispatches one directive (pbrt-v4 parser.cpp parse(), same names and arguments).
void Parser::directive(Tokenizer& tok, const Token& d, const std::string& dir) {
  const std::string& n = d.text;
  // Transformations are allowed anywhere (pbrt-v4 file format, "Transformations").
  if (n == "Identity") {
    gs_.ctm = glm::mat4(1.0f);
  } else if (n == "Translate") {
    glm::vec3 t;
    for (int i = 0; i < 3; ++i) t[i] = float(number_arg(tok, d, 3));
    glm::mat4 m(1.0f);
    m[3] = glm::vec4(t, 1.0f);
    gs_.ctm = gs_.ctm * m;
  } else if (n == "Scale") {
    glm::vec3 s;
    for (int i = 0; i < 3; ++i) s[i] = float(number_arg(tok, d, 3));
    gs_.ctm = gs_.ctm * glm::mat4(glm::vec4(s.x, 0, 0, 0), glm::vec4(0, s.y, 0, 0),
                                  glm::vec4(0, 0, s.z, 0), glm::vec4(0, 0, 0, 1));
  } else if (n == "Rotate") {
    // pbrt-v4 Rotate (book 3.9.6): right-handed rotation by theta degrees about the
    // normalized axis, R = cos I + sin [a]x + (1 - cos) a a^T.
    float deg = float(number_arg(tok, d, 4));
    glm::vec3 a;
    for (int i = 0; i < 3; ++i) a[i] = float(number_arg(tok, d, 4));
    if (glm::length(a) == 0.0f) throw SceneError(d.loc, "Rotate axis is the zero vector");
    a = glm::normalize(a);
    float th = glm::radians(deg), c = std::cos(th), s = std::sin(th);
    glm::mat4 r(1.0f);  // r[col][row]
    r[0][0] = a.x * a.x + (1 - a.x * a.x) * c;
    r[1][0] = a.x * a.y * (1 - c) - a.z * s;
    r[2][0] = a.x * a.z * (1 - c) + a.y * s;
    r[0][1] = a.x * a.y * (1 - c) + a.z * s;
    r[1][1] = a.y * a.y + (1 - a.y * a.y) * c;
    r[2][1] = a.y * a.z * (1 - c) - a.x * s;
    r[0][2] = a.x * a.z * (1 - c) - a.y * s;
    r[1][2] = a.y * a.z * (1 - c) + a.x * s;
    r[2][2] = a.z * a.z + (1 - a.z * a.z) * c;
    gs_.ctm = gs_.ctm * r;
  } else if (n == "LookAt") {
    // pbrt-v4 LookAt (book 3.9.8): worldFromCamera has columns right, up', dir, eye with
    // right = normalize(cross(normalize(up), dir)), up' = cross(dir, right); the CTM is
    // post-multiplied by its inverse, cameraFromWorld.
    float v[9];
    for (float& x : v) x = float(number_arg(tok, d, 9));
    glm::vec3 eye(v[0], v[1], v[2]), look(v[3], v[4], v[5]), up(v[6], v[7], v[8]);
    if (eye == look) throw SceneError(d.loc, "LookAt eye and look-at points are the same");
    if (glm::length(up) == 0.0f) throw SceneError(d.loc, "LookAt up vector is the zero vector");
    glm::vec3 dir3 = glm::normalize(look - eye);
    glm::vec3 right = glm::cross(glm::normalize(up), dir3);
    if (glm::length(right) == 0.0f)
      throw SceneError(d.loc, "LookAt up vector and viewing direction are parallel");
    right = glm::normalize(right);
    glm::vec3 new_up = glm::cross(dir3, right);
    glm::mat4 world_from_camera(glm::vec4(right, 0), glm::vec4(new_up, 0), glm::vec4(dir3, 0),
                                glm::vec4(eye, 1));
    gs_.ctm = gs_.ctm * invert(world_from_camera, d.loc, "the LookAt matrix");
  } else if (n == "Transform" || n == "ConcatTransform") {
    // pbrt-v4 BasicSceneBuilder::Transform: Transpose(Transform(m)) of the row-major 16
    // numbers, i.e. the numbers are the matrix in column-major order, as glm stores it.
    float m[16];
    matrix_arg(tok, d, m);
    glm::mat4 t = glm::make_mat4(m);
    gs_.ctm = n == "Transform" ? t : gs_.ctm * t;
  } else if (n == "CoordinateSystem") {
    coord_systems_[string_arg(tok, d, "a name")] = gs_.ctm;
  } else if (n == "CoordSysTransform") {
    std::string name = string_arg(tok, d, "a name");
    auto it = coord_systems_.find(name);
    if (it != coord_systems_.end())
      gs_.ctm = it->second;
    else  // pbrt-v4 warns and keeps the CTM
      warn(d.loc, "unknown coordinate system \"" + name + "\"; CoordSysTransform ignored");
  } else if (n == "ActiveTransform") {
    std::optional<Token> a = tok.next();
    if (!a || a->kind != Token::Kind::Word ||
        (a->text != "All" && a->text != "StartTime" && a->text != "EndTime"))
      throw SceneError(a ? a->loc : d.loc, "ActiveTransform expects All, StartTime or EndTime");
    if (a->text != "All")
      throw SceneError(d.loc, "motion blur is not supported yet (ActiveTransform " + a->text + ")");
  } else if (n == "TransformTimes") {
    verify_options(d);
    number_arg(tok, d, 2);
    number_arg(tok, d, 2);
    warn(d.loc, "TransformTimes ignored: basalt has no motion blur");
  } else if (n == "Include" || n == "Import") {  // files
    // Import is Include whose graphics-state changes stay inside the file (pbrt-v4
    // CopyForImport); basalt parses it in place.
    std::string name = string_arg(tok, d, "a file name");
    std::string path = resolve(name, dir);
    if (n == "Import") {
      if (!world_) throw SceneError(d.loc, "'Import' is only allowed after WorldBegin");
      GraphicsState saved = gs_;
      std::size_t depth = stack_.size();
      parse_file(path, &d.loc);
      if (stack_.size() > depth)
        throw SceneError(stack_.back().second, "AttributeBegin without a matching AttributeEnd");
      gs_ = saved;
    } else {
      parse_file(path, &d.loc);
    }
  } else if (n == "Camera") {  // rendering options
    camera(tok, d);
  } else if (n == "Film") {
    film(tok, d);
  } else if (n == "Sampler") {
    sampler(tok, d);
  } else if (n == "PixelFilter") {
    pixel_filter(tok, d);
  } else if (n == "Integrator") {
    integrator(tok, d);
  } else if (n == "Accelerator") {
    verify_options(d);
    std::string type = string_arg(tok, d, "a type");
    params(tok);
    warn(d.loc, "Accelerator \"" + type + "\" ignored: basalt builds its own BVH");
  } else if (n == "ColorSpace") {
    std::string cs = string_arg(tok, d, "a color space name");
    if (cs != "srgb")
      throw SceneError(
          d.loc, "color space '" + cs + "' is not supported yet (basalt renders in linear sRGB)");
  } else if (n == "Option") {
    option(tok, d);
  } else if (n == "WorldBegin") {
    verify_options(d);
    world_ = true;
    gs_.ctm = glm::mat4(1.0f);
    coord_systems_["world"] = gs_.ctm;
  } else if (n == "WorldEnd") {
    warn(d.loc, "WorldEnd is a pbrt-v3 directive; ignored");
  } else if (n == "AttributeBegin" || n == "TransformBegin") {  // attributes
    if (n == "TransformBegin" && !warned_transform_begin_) {
      // pbrt-v4 parser.cpp: deprecated, and handled as AttributeBegin.
      warn(d.loc, "TransformBegin/TransformEnd are deprecated; treated as AttributeBegin/End");
      warned_transform_begin_ = true;
    }
    attribute_begin(d);
  } else if (n == "AttributeEnd" || n == "TransformEnd") {
    attribute_end(d);
  } else if (n == "ReverseOrientation") {
    verify_world(d);
    gs_.reverse_orientation = !gs_.reverse_orientation;
  } else if (n == "Attribute") {
    throw SceneError(d.loc, "the Attribute directive is not supported yet");
  } else if (n == "Shape") {  // scene content
    shape(tok, d, dir);
  } else if (n == "LightSource") {
    light_source(tok, d, dir);
  } else if (n == "AreaLightSource") {
    area_light_source(tok, d);
  } else if (n == "Material") {
    verify_world(d);
    std::string type = string_arg(tok, d, "a material type");
    ParamSet ps = parse_param_list(tok);  // texture references are material parameters
    Material m = make_material(type, ps, d.loc, d.loc, "Material '" + type + "'", dir);
    gs_.material = int(scene_.materials.size());
    gs_.named_material.clear();
    scene_.materials.push_back(std::move(m));
  } else if (n == "MakeNamedMaterial") {
    verify_world(d);
    std::string name = string_arg(tok, d, "a material name");
    ParamSet ps = parse_param_list(tok);  // texture references are material parameters
    if (named_materials_.count(name))
      throw SceneError(d.loc, "named material \"" + name + "\" redefined");
    const Param* tp = ps.find("type");
    if (!tp)
      throw SceneError(d.loc,
                       "MakeNamedMaterial \"" + name + "\" needs a \"string type\" parameter");
    std::string type = ps.get_string("type", "");
    Material m =
        make_material(type, ps, d.loc, tp->loc, "MakeNamedMaterial \"" + name + "\"", dir);
    m.name = name;
    named_materials_[name] = int(scene_.materials.size());
    scene_.materials.push_back(std::move(m));
  } else if (n == "NamedMaterial") {
    verify_world(d);
    std::string name = string_arg(tok, d, "a material name");
    auto it = named_materials_.find(name);
    if (it != named_materials_.end()) {
      gs_.material = it->second;
      gs_.named_material.clear();
    } else {  // may be defined later in the file (pbrt-v4 resolves names after parsing)
      gs_.material = -1;
      gs_.named_material = name;
      gs_.named_material_loc = d.loc;
    }
  } else if (n == "Texture") {
    texture(tok, d, dir);
  } else if (n == "MakeNamedMedium" || n == "MediumInterface") {
    if (n == "MediumInterface") {
      // MediumInterface "" "" (no media), as exporters write it, is harmless.
      std::string inside = string_arg(tok, d, "a medium name");
      std::string outside = inside;
      const std::optional<Token>& p = tok.peek();
      if (p && p->kind == Token::Kind::String) outside = tok.next()->text;
      if (inside.empty() && outside.empty()) return;
    }
    throw SceneError(d.loc, "participating media are not supported yet");
  } else if (n == "ObjectBegin" || n == "ObjectEnd" || n == "ObjectInstance") {
    throw SceneError(d.loc, "object instancing is not supported yet (" + n + ")");
  } else {
    throw SceneError(d.loc, "unknown directive '" + n + "'");
  }
}

// AttributeBegin (and deprecated TransformBegin): saves the whole graphics state.
void Parser::attribute_begin(const Token& d) {
  verify_world(d);
  stack_.emplace_back(gs_, d.loc);
}

// AttributeEnd (and TransformEnd): restores the state of the matching AttributeBegin.
void Parser::attribute_end(const Token& d) {
  verify_world(d);
  if (stack_.empty())
    throw SceneError(d.loc, d.text + " without a matching " +
                                (d.text == "TransformEnd" ? "TransformBegin" : "AttributeBegin"));
  gs_ = std::move(stack_.back().first);
  stack_.pop_back();
}

// Camera "perspective" (pbrt-v4 PerspectiveCamera::Create, book 5.2).
void Parser::camera(Tokenizer& tok, const Token& d) {
  verify_options(d);
  std::string type = string_arg(tok, d, "a camera type");
  ParamSet ps = params(tok);
  if (type != "perspective")
    throw SceneError(
        d.loc, "camera '" + type + "' is not supported yet (basalt has the perspective camera)");
  Camera c;
  c.loc = d.loc;
  // pbrt-v4 BasicSceneBuilder::Camera: cameraFromWorld is the CTM.
  c.world_from_camera = invert(gs_.ctm, d.loc, "the camera transform (CTM at Camera)");
  coord_systems_["camera"] = c.world_from_camera;
  c.fov_deg = ps.get_float("fov", 90.0f);
  if (!(c.fov_deg > 0.0f && c.fov_deg < 180.0f))
    throw SceneError(ps.loc_of("fov", d.loc), "fov must be in (0, 180) degrees");
  c.lens_radius = ps.get_float("lensradius", 0.0f);
  if (c.lens_radius < 0.0f)
    throw SceneError(ps.loc_of("lensradius", d.loc), "lensradius must not be negative");
  c.focal_distance = ps.get_float("focaldistance", 1e6f);
  if (!(c.focal_distance > 0.0f))
    throw SceneError(ps.loc_of("focaldistance", d.loc), "focaldistance must be positive");
  std::vector<float> sw = ps.get_floats("screenwindow");
  if (!sw.empty()) {
    if (sw.size() != 4)
      throw SceneError(ps.loc_of("screenwindow", d.loc), "screenwindow needs four values");
    c.screen_window = glm::vec4(sw[0], sw[1], sw[2], sw[3]);
  }
  frame_aspect_.reset();
  if (ps.find("frameaspectratio")) {
    frame_aspect_loc_ = ps.loc_of("frameaspectratio", d.loc);
    frame_aspect_ = ps.get_float("frameaspectratio", 1.0f);
    if (!(*frame_aspect_ > 0.0f))
      throw SceneError(frame_aspect_loc_, "frameaspectratio must be positive");
  }
  ps.report_unused("Camera 'perspective'", scene_.warnings);
  scene_.camera = c;
}

// Film "rgb" (pbrt-v4 RGBFilm / FilmBaseParameters).
void Parser::film(Tokenizer& tok, const Token& d) {
  verify_options(d);
  std::string type = string_arg(tok, d, "a film type");
  ParamSet ps = params(tok);
  if (type == "gbuffer" || type == "spectral")
    warn(d.loc, "Film '" + type + "' is rendered as Film 'rgb'");
  else if (type != "rgb")
    throw SceneError(d.loc, "film '" + type + "' is not supported (basalt writes Film 'rgb')");
  Film f;
  f.loc = d.loc;
  f.xres = positive_int(ps, "xresolution", 1280, d.loc);
  f.yres = positive_int(ps, "yresolution", 720, d.loc);
  f.filename = ps.get_string("filename", "pbrt.exr");
  // The film's accumulation table (16 bytes a pixel) must fit before anything is allocated
  // (issue 11, defects 4 and 6).
  for (const char* side : {"xresolution", "yresolution"})
    if ((side[0] == 'x' ? f.xres : f.yres) > kMaxFilmSide)
      throw SceneError(ps.loc_of(side, d.loc), std::string(side) + " " +
                                                   std::to_string(side[0] == 'x' ? f.xres : f.yres) +
                                                   " exceeds basalt's limit of 2^20 pixels");
  if (const std::uint64_t bytes = std::uint64_t(f.xres) * std::uint64_t(f.yres) * 16u;
      bytes > scene_.max_table_bytes)
    throw SceneError(ps.loc_of("xresolution", d.loc),
                     "a " + std::to_string(f.xres) + " x " + std::to_string(f.yres) +
                         " film needs " + std::to_string(bytes) +
                         " bytes of accumulation table, more than the " +
                         std::to_string(scene_.max_table_bytes) + " bytes the renderer takes");
  // pbrt-v4 RGBFilm clamps each sample's rgb to this maximum component; basalt does not, so
  // a finite value is refused rather than ignored (the default is infinite).
  if (const Param* mc = ps.lookup("maxcomponentvalue", {"float"});
      mc && !(mc->numbers.size() == 1 && std::isinf(mc->numbers[0])))
    throw SceneError(mc->loc, "\"maxcomponentvalue\" is not supported (basalt does not clamp "
                              "samples; remove it or set it to infinity)");
  ps.report_unused("Film '" + type + "'", scene_.warnings);
  scene_.film = f;
}

/// Largest sample count per pixel (the --spp limit too).
constexpr int kMaxSpp = 1 << 24;

// Sampler (docs/sampler-spec.md): pbrt-v4's samplers, with their sample counts, seed and
// randomisation (every sampler pbrt-v4 names).
void Parser::sampler(Tokenizer& tok, const Token& d) {
  verify_options(d);
  std::string type = string_arg(tok, d, "a sampler type");
  ParamSet ps = params(tok);
  Sampler s;
  if (type == "stratified") {
    // pbrt-v4 StratifiedSampler::Create: xsamples x ysamples per pixel, 4 x 4 by default.
    s.xsamples = positive_int(ps, "xsamples", 4, d.loc);
    s.ysamples = positive_int(ps, "ysamples", 4, d.loc);
    s.jitter = ps.get_bool("jitter", true);
    if (std::int64_t(s.xsamples) * s.ysamples > kMaxSpp)
      throw SceneError(d.loc, "Sampler 'stratified': xsamples x ysamples = " +
                                  std::to_string(std::int64_t(s.xsamples) * s.ysamples) +
                                  " exceeds basalt's limit of 2^24 samples per pixel");
    s.spp = s.xsamples * s.ysamples;
  } else {
    s.spp = positive_int(ps, "pixelsamples", 16, d.loc);
    if (s.spp > kMaxSpp)
      throw SceneError(ps.loc_of("pixelsamples", d.loc),
                       "pixelsamples " + std::to_string(s.spp) +
                           " exceeds basalt's limit of 2^24 samples per pixel");
  }
  if (type == "halton" || type == "sobol" || type == "paddedsobol" || type == "zsobol") {
    s.randomization = ps.get_string("randomization", "");
    static const char* kRand[] = {"", "none", "permutedigits", "fastowen", "owen"};
    if (std::find(std::begin(kRand), std::end(kRand), s.randomization) == std::end(kRand))
      throw SceneError(d.loc, "Sampler '" + type + "': unknown randomization '" +
                                  s.randomization +
                                  "' (none, permutedigits, fastowen or owen)");
    if (type == "halton" && s.randomization == "fastowen")
      throw SceneError(d.loc, "Sampler 'halton': randomization 'fastowen' is not supported "
                              "(pbrt-v4 refuses it too)");
  }
  sampler_seed_given_ = ps.find("seed") != nullptr;
  s.seed = ps.get_int("seed", 0);
  s.type = type;
  if (type == "pmj02bn" && s.spp > int(gpu::PMJ_SAMPLES))
    throw SceneError(ps.loc_of("pixelsamples", d.loc),
                     "Sampler 'pmj02bn' supports at most 65536 samples per pixel (as pbrt-v4), "
                     "not " + std::to_string(s.spp));
  const auto& names = sampler_names();
  if (std::find(names.begin(), names.end(), type) == names.end()) {
    throw SceneError(d.loc, "unknown Sampler '" + type +
                                "' (independent, stratified, halton, sobol, paddedsobol, "
                                "zsobol or pmj02bn)");
  }
  ps.report_unused("Sampler '" + type + "'", scene_.warnings);
  scene_.sampler = s;
}

// PixelFilter "box" / "gaussian" (pbrt-v4 BoxFilter::Create, GaussianFilter::Create).
void Parser::pixel_filter(Tokenizer& tok, const Token& d) {
  verify_options(d);
  std::string type = string_arg(tok, d, "a filter type");
  ParamSet ps = params(tok);
  Filter f;
  float def_radius;
  if (type == "box") {
    f.type = Filter::Type::Box;
    def_radius = 0.5f;
  } else if (type == "gaussian") {
    f.type = Filter::Type::Gaussian;
    def_radius = 1.5f;
    f.sigma = ps.get_float("sigma", 0.5f);
    if (!(f.sigma > 0.0f)) throw SceneError(ps.loc_of("sigma", d.loc), "sigma must be positive");
  } else {
    throw SceneError(d.loc, "filter '" + type + "' is not supported yet (box and gaussian are)");
  }
  f.radius = glm::vec2(ps.get_float("xradius", def_radius), ps.get_float("yradius", def_radius));
  if (!(f.radius.x > 0.0f))
    throw SceneError(ps.loc_of("xradius", d.loc), "xradius must be positive");
  if (!(f.radius.y > 0.0f))
    throw SceneError(ps.loc_of("yradius", d.loc), "yradius must be positive");
  ps.report_unused("PixelFilter '" + type + "'", scene_.warnings);
  scene_.filter = f;
}

// Integrator "path" (pbrt-v4 PathIntegrator::Create); "volpath" is the same without media.
void Parser::integrator(Tokenizer& tok, const Token& d) {
  verify_options(d);
  std::string type = string_arg(tok, d, "an integrator type");
  ParamSet ps = params(tok);
  if (type == "volpath")
    warn(d.loc, "Integrator 'volpath' is rendered as 'path' (basalt has no participating media)");
  else if (type != "path")
    throw SceneError(d.loc, "integrator '" + type +
                                "' is not supported (basalt renders with Integrator 'path')");
  Integrator in;
  in.max_depth = ps.get_int("maxdepth", 5);
  if (in.max_depth < 0)
    throw SceneError(ps.loc_of("maxdepth", d.loc), "maxdepth must not be negative");
  in.regularize = ps.get_bool("regularize", false);
  in.light_sampler = ps.get_string("lightsampler", "bvh");
  if (in.light_sampler != "bvh" && in.light_sampler != "uniform" && in.light_sampler != "power" &&
      in.light_sampler != "exhaustive")
    throw SceneError(ps.loc_of("lightsampler", d.loc),
                     "unknown lightsampler '" + in.light_sampler +
                         "' (bvh, exhaustive, uniform or power)");
  // pbrt-v4's BSDF regularisation is not implemented: refuse it rather than ignore it.
  if (in.regularize)
    throw SceneError(ps.loc_of("regularize", d.loc),
                     "\"regularize\" true is not supported (basalt does not regularize BSDFs)");
  ps.report_unused("Integrator '" + type + "'", scene_.warnings);
  scene_.integrator = in;
}

// Texture "name" "float"|"spectrum" "class" params (pbrt-v4 BasicSceneBuilder::Texture): the
// texture space is the CTM here; a name may be defined once per type.
void Parser::texture(Tokenizer& tok, const Token& d, const std::string& dir) {
  verify_world(d);
  std::string name = string_arg(tok, d, "a texture name");
  std::string type = string_arg(tok, d, "a texture type");
  const std::optional<Token>& ct = tok.peek();
  SourceLoc cls_loc = ct ? ct->loc : d.loc;
  std::string cls = string_arg(tok, d, "a texture class");
  ParamSet ps = parse_param_list(tok);
  for (const TextureDef& t : scene_.textures)
    if (t.name == name && t.is_float == (type == "float"))
      throw SceneError(d.loc, "redefining " + type + " texture \"" + name + "\"");
  auto defined = [&](const std::string& n, bool is_float) {
    for (const TextureDef& t : scene_.textures)
      if (t.name == n && t.is_float == is_float) return true;
    return false;
  };
  TextureDef t = parse_texture(name, type, cls, ps, gs_.ctm, d.loc, cls_loc, defined,
                               [&](const std::string& f) { return resolve(f, dir); });
  load_texture_image(scene_, t);  // imagemap: decode its file (once per file and encoding)
  ps.report_unused("Texture \"" + name + "\"", scene_.warnings);
  scene_.textures.push_back(std::move(t));
}

// Option "name" value (pbrt-v4 BasicSceneBuilder::Option); "seed", "disabletexturefiltering"
// and "displacementedgescale" affect basalt.
void Parser::option(Tokenizer& tok, const Token& d) {
  std::string decl = string_arg(tok, d, "an option name");
  std::optional<Token> v = tok.next();
  if (!v || (v->kind != Token::Kind::Number && v->kind != Token::Kind::String &&
             v->kind != Token::Kind::Word))
    throw SceneError(v ? v->loc : d.loc, "Option \"" + decl + "\" has no value");
  // Accept both "name" and "type name".
  std::string name =
      decl.substr(decl.find_last_of(" \t") == std::string::npos ? 0 : decl.find_last_of(" \t") + 1);
  std::string nn = normalize_option(name);
  static const char* known[] = {"disablepixeljitter",
                                "disablewavelengthjitter",
                                "msereferenceimage",
                                "msereferenceout",
                                "forcediffuse",
                                "pixelstats",
                                "wavefront"};
  if (nn == "disabletexturefiltering") {
    // pbrt-v4 BasicSceneBuilder::Option: "true" or "false".
    if (v->text != "true" && v->text != "false")
      throw SceneError(v->loc, "Option \"disabletexturefiltering\" expects true or false, got " +
                                   v->describe());
    scene_.disable_texture_filtering = v->text == "true";
  } else if (nn == "displacementedgescale") {
    // pbrt-v4 BasicSceneBuilder::Option (Atof of the value): Shape::Create multiplies every
    // displaced plymesh's "edgelength" by it, wherever the Option stands in the file. pbrt-v4
    // does not check it; a value <= 0 would refine forever, so it is refused here.
    if (v->kind != Token::Kind::Number)
      throw SceneError(v->loc, "Option \"displacementedgescale\" expects a number, got " +
                                   v->describe());
    const float scale = float(v->number);
    if (!(scale > 0.0f) || !std::isfinite(scale))
      throw SceneError(v->loc,
                       "Option \"displacementedgescale\" must be positive and finite, got " +
                           v->describe());
    scene_.displacement_edge_scale = scale;
  } else if (nn == "seed") {
    if (!v->is_integer_literal())
      throw SceneError(v->loc, "Option \"seed\" expects an integer, got " + v->describe());
    // Range before the cast (a value beyond int is undefined behaviour; found by the fuzzer).
    if (!(v->number >= -2147483648.0 && v->number <= 2147483647.0))
      throw SceneError(v->loc, "Option \"seed\" does not fit a 32-bit integer");
    option_seed_ = int(v->number);
  } else if (std::find(std::begin(known), std::end(known), nn) != std::end(known)) {
    warn(d.loc, "Option \"" + name + "\" has no effect in basalt");
  } else {
    warn(d.loc, "unknown Option \"" + name + "\" ignored");
  }
}

// Shape "sphere" / "trianglemesh" / "plymesh" (pbrt-v4 Sphere::Create, TriangleMesh::Create,
// and the plymesh case of Shape::Create).
void Parser::shape(Tokenizer& tok, const Token& d, const std::string& dir) {
  verify_world(d);
  std::string type = string_arg(tok, d, "a shape type");
  // Texture-valued parameters: only a mesh's "displacement" (below); others are refused as
  // params() refuses them.
  ParamSet ps = parse_param_list(tok);
  for (const Param& p : ps.params)
    if (p.type == "texture" &&
        !(p.name == "displacement" && (type == "plymesh" || type == "trianglemesh")))
      throw SceneError(p.loc, "textures are not supported yet (parameter \"" + p.name +
                                  "\" refers to texture \"" + p.strings[0] + "\")");
  Shape s;
  s.loc = d.loc;
  s.world_from_object = gs_.ctm;
  s.reverse_orientation = gs_.reverse_orientation;
  s.area_light = gs_.area_light;
  if (type == "sphere") {
    s.kind = Shape::Kind::Sphere;
    float r = ps.get_float("radius", 1.0f);
    if (!(r > 0.0f)) throw SceneError(ps.loc_of("radius", d.loc), "sphere radius must be positive");
    s.radius = r;
    // pbrt-v4 Sphere: zmin/zmax are clamped to [-r, r] and phimax to [0, 360].
    float zmin = ps.get_float("zmin", -r), zmax = ps.get_float("zmax", r);
    float phimax = ps.get_float("phimax", 360.0f);
    float z0 = std::clamp(std::min(zmin, zmax), -r, r),
          z1 = std::clamp(std::max(zmin, zmax), -r, r);
    const char* partial = z0 > -r  ? (zmin <= zmax ? "zmin" : "zmax")
                          : z1 < r ? (zmin <= zmax ? "zmax" : "zmin")
                          : std::clamp(phimax, 0.0f, 360.0f) < 360.0f ? "phimax"
                                                                      : nullptr;
    if (partial) throw SceneError(ps.loc_of(partial, d.loc), "partial spheres not supported");
  } else if (type == "trianglemesh") {
    // "displacement" and "edgelength" are not looked up: pbrt-v4 displaces plymesh shapes
    // only (Triangle::CreateMesh never reads them), so they are reported as unused parameters
    // (pbrt-v4 ReportUnused; a warning in basalt as every unused parameter) and ignored.
    s.kind = Shape::Kind::Triangles;
    TriangleMesh& m = s.mesh;
    m.P = ps.get_point3s("P");
    if (m.P.empty()) throw SceneError(d.loc, "trianglemesh needs vertex positions \"point3 P\"");
    std::vector<int> idx = ps.get_ints("indices");
    SourceLoc iloc = ps.loc_of("indices", d.loc);
    if (idx.empty()) {
      // pbrt-v4 TriangleMesh::Create: indices may be omitted for a single triangle.
      if (m.P.size() != 3)
        throw SceneError(d.loc,
                         "trianglemesh needs \"integer indices\" (only a mesh of exactly "
                         "3 vertices may omit them; this one has " +
                             std::to_string(m.P.size()) + ")");
      idx = {0, 1, 2};
    }
    if (idx.size() % 3 != 0)
      throw SceneError(
          iloc, "trianglemesh has " + std::to_string(idx.size()) + " indices, not a multiple of 3");
    m.indices.reserve(idx.size());
    for (int i : idx) {
      if (i < 0 || std::size_t(i) >= m.P.size())
        throw SceneError(iloc, "trianglemesh index " + std::to_string(i) +
                                   " out of range (the mesh has " + std::to_string(m.P.size()) +
                                   " vertices)");
      m.indices.push_back(unsigned(i));
    }
    m.N = ps.get_normals("N");
    if (!m.N.empty() && m.N.size() != m.P.size())
      throw SceneError(ps.loc_of("N", d.loc), "trianglemesh has " + std::to_string(m.N.size()) +
                                                  " normals \"N\" for " +
                                                  std::to_string(m.P.size()) + " vertices");
    m.uv = ps.get_point2s("uv");
    if (!m.uv.empty() && m.uv.size() != m.P.size())
      throw SceneError(ps.loc_of("uv", d.loc), "trianglemesh has " + std::to_string(m.uv.size()) +
                                                   " \"uv\" values for " +
                                                   std::to_string(m.P.size()) + " vertices");
  } else if (type == "plymesh") {
    s.kind = Shape::Kind::Triangles;
    if (!ps.find("filename"))
      throw SceneError(d.loc, "plymesh needs a \"string filename\" parameter");
    std::string name = ps.get_string("filename", "");
    std::string path = resolve(name, dir);
    if (path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0)
      throw SceneError(d.loc, "gzip-compressed PLY files are not supported yet: \"" + path + "\"");
    std::vector<std::string> ply_warnings;
    try {
      s.mesh = load_ply(path, &ply_warnings, scene_.max_table_bytes);
    } catch (const SceneError& e) {
      throw SceneError(d.loc, "PLY file \"" + path + "\": " + e.message);
    }
    for (const std::string& w : ply_warnings) warn(d.loc, "PLY file \"" + path + "\": " + w);
    // pbrt-v4 Shape::Create "plymesh": "edgelength" (1; times Option "displacementedgescale")
    // and "texture displacement" (an empty name: no displacement, as pbrt-v4). build_tables
    // refines and displaces the mesh (host/scene/displace.h); the texture name is resolved in
    // finish(), since pbrt-v4 creates shapes after every texture of the file.
    s.edge_length = ps.get_float("edgelength", 1.0f);
    s.edge_length_loc = ps.loc_of("edgelength", d.loc);
    if (const Param* p = ps.lookup("displacement", {"texture"}); p && !p->strings[0].empty()) {
      s.displacement = p->strings[0];
      s.displacement_loc = p->loc;
      // pbrt-v4 does not check edgelength; <= 0 (or NaN) would refine forever.
      if (!(s.edge_length > 0.0f) || !std::isfinite(s.edge_length))
        throw SceneError(s.edge_length_loc,
                         "plymesh \"edgelength\" must be positive and finite with a "
                         "\"displacement\" texture, got " + std::to_string(s.edge_length));
      // pbrt-v4 TriQuadMesh::Displace: "Vertex uvs are currently required by Displace()".
      if (s.mesh.uv.empty())
        throw SceneError(p->loc, "plymesh \"displacement\" needs vertex uvs, but PLY file \"" +
                                     path + "\" has none (u v, s t, texture_u texture_v or "
                                     "texture_s texture_t)");
    }
  } else {
    throw SceneError(d.loc, "shape '" + type + "' is not supported yet");
  }
  ps.report_unused("Shape '" + type + "'", scene_.warnings);

  if (gs_.material >= 0) {
    s.material = gs_.material;
  } else if (!gs_.named_material.empty()) {
    pending_.push_back({scene_.shapes.size(), gs_.named_material, gs_.named_material_loc});
  } else {
    s.material = default_material();
  }
  scene_.shapes.push_back(std::move(s));
}

// pbrt-v4 EqualAreaSquareToSphere (util/math.cpp) in double, for the host-side illuminance
// normalisation only (the renderers' fp32 twins live in host/cpu/envmap.cpp and envmap.glsl).
static glm::dvec3 equal_area_square_to_sphere_d(double px, double py) {
  const double u = 2.0 * px - 1.0, v = 2.0 * py - 1.0;
  const double up = std::abs(u), vp = std::abs(v);
  const double signed_distance = 1.0 - (up + vp);
  const double r = 1.0 - std::abs(signed_distance);
  const double phi = (r == 0.0 ? 1.0 : (vp - up) / r + 1.0) * (std::numbers::pi / 4.0);
  const double z = std::copysign(1.0 - r * r, signed_distance);
  const double s = r * std::sqrt(std::max(0.0, 2.0 - r * r));
  return {std::copysign(std::cos(phi), u) * s, std::copysign(std::sin(phi), v) * s, z};
}

// A light's "scale": finite and not negative, as its "I" and "L" must be (issue 11, defect 7).
float light_scale(const ParamSet& ps, const Token& d) {
  const float scale = ps.get_float("scale", 1.0f);
  if (!std::isfinite(scale) || scale < 0.0f)
    throw SceneError(ps.loc_of("scale", d.loc),
                     "light \"scale\" must be finite and not negative, got " +
                         std::to_string(scale));
  return scale;
}

// LightSource "infinite" with "filename" (pbrt-v4 Light::Create "infinite" and the
// ImageInfiniteLight constructor, lights.cpp): decodes the map (square equal-area by default;
// "mapping" "latlong" or "cube", docs/textures-spec.md 6.8), folds the "illuminance"
// normalisation into the scale and records the light's frame (the CTM).
void Parser::image_infinite_light(const ParamSet& ps, const Token& d, const std::string& dir,
                                  float scale, Light& l) {
  const SourceLoc file_loc = ps.loc_of("filename", d.loc);
  const Param* portal = ps.find("portal");
  if (const Param* p = ps.find("L"); p && ps.find("filename"))
    throw SceneError(p->loc,
                     "can't specify both emission \"L\" and \"filename\" with an infinite light");
  l.kind = Light::Kind::InfiniteImage;
  if (portal) {
    // pbrt-v4 PortalImageInfiniteLight (textures-spec 6.9): four points in world space (the
    // CTM orients only the image).
    const std::vector<glm::vec3> pts = ps.get_point3s("portal");
    if (pts.size() != 4)
      throw SceneError(portal->loc, "expected 4 vertices for infinite light \"portal\" but given " +
                                        std::to_string(pts.size()));
    for (int i = 0; i < 4; ++i) {
      if (!finite3(pts[i]))
        throw SceneError(portal->loc, "infinite light \"portal\" has a non-finite vertex");
      l.portal[i] = pts[i];
    }
    // pbrt-v4 checks (and only prints an error): opposite edges parallel, sides perpendicular.
    const glm::vec3 p01 = glm::normalize(pts[1] - pts[0]), p12 = glm::normalize(pts[2] - pts[1]);
    const glm::vec3 p32 = glm::normalize(pts[2] - pts[3]), p03 = glm::normalize(pts[3] - pts[0]);
    if (!finite3(p01) || !finite3(p12) || !finite3(p32) || !finite3(p03))
      throw SceneError(portal->loc, "infinite light \"portal\" has coincident vertices");
    if (std::abs(glm::dot(p01, p32) - 1.0f) > 1e-3f || std::abs(glm::dot(p12, p03) - 1.0f) > 1e-3f ||
        std::abs(glm::dot(p01, p12)) > 1e-3f || std::abs(glm::dot(p12, p32)) > 1e-3f ||
        std::abs(glm::dot(p32, p03)) > 1e-3f || std::abs(glm::dot(p03, p01)) > 1e-3f)
      warn(portal->loc, "infinite light portal isn't a planar rectangle (pbrt-v4 renders on, "
                        "as basalt does)");
    l.has_portal = true;
  }
  const std::string name = ps.get_string("filename", "");
  if (!portal && name.empty()) throw SceneError(file_loc, "infinite light \"filename\" is empty");
  if (portal && name.empty()) {
    // pbrt-v4: "L" with a portal is a 1 x 1 image of L's rgb (scale as for an image).
    l.mapping = 0;
    if (const Param* p = ps.find("illuminance"))
      throw SceneError(p->loc, "\"illuminance\" with a portal needs \"filename\"");
    const glm::vec3 L =
        ps.get_spectrum("L", SpectrumUse::Illuminant, &scene_.warnings).value_or(glm::vec3(1));
    if (!std::isfinite(scale)) throw SceneError(ps.loc_of("scale", d.loc), "scale is not finite");
    l.value = glm::vec3(scale);
    l.light_from_world = glm::mat3(1.0f);
    l.image_res = l.image_width = l.image_height = 1;
    l.image_rgb = {L.x, L.y, L.z};
    return;
  }
  l.filename = resolve(name, dir);
  // "mapping" (basalt extension, textures-spec 6.8): the map's parameterisation.
  const SourceLoc mapping_loc = ps.loc_of("mapping", d.loc);
  const std::string mapping = ps.get_string("mapping", "equalarea");
  if (mapping == "equalarea") {
    l.mapping = 0;
  } else if (mapping == "latlong") {
    l.mapping = 1;
  } else if (mapping == "cube") {
    l.mapping = 2;
  } else {
    throw SceneError(mapping_loc, "unknown infinite light \"mapping\" \"" + mapping +
                                      "\" (expected \"equalarea\", \"latlong\" or \"cube\")");
  }
  if (portal && l.mapping != 0)
    throw SceneError(mapping_loc, "an infinite light \"portal\" needs an equal-area map "
                                  "(\"mapping\" \"equalarea\")");
  // pbrt-v4 Image::Read: 8-bit and 16-bit PNG through sRGB (no "encoding" parameter for this
  // light), EXR and PFM linear.
  DecodedImage im = read_texture_image(l.filename, ColorEncoding{ImageEncoding::SRGB}, file_loc);
  if (im.channels != 3)
    throw SceneError(file_loc, "\"" + l.filename +
                                   "\": image provided to \"infinite\" light must have R, G, "
                                   "and B channels");
  const std::string size_text =
      "(" + std::to_string(im.width) + ", " + std::to_string(im.height) + ")";
  if (l.mapping == 0 && im.width != im.height)
    throw SceneError(file_loc, "\"" + l.filename + "\": image resolution " + size_text +
                                   " is non-square; an infinite light needs a square "
                                   "equal-area octahedral environment map");
  if (l.mapping == 2 && (im.width < 1 || im.height != 6 * im.width))
    throw SceneError(file_loc, "\"" + l.filename + "\": image resolution " + size_text +
                                   " is not n x 6n; a \"cube\" infinite light needs a vertical "
                                   "strip of six n x n faces (+x, -x, +y, -y, +z, -z)");
  if (im.width < 1 || im.height < 1)
    throw SceneError(file_loc, "\"" + l.filename + "\": image resolution " + size_text +
                                   " is empty");
  for (float v : im.texels)
    if (!std::isfinite(v))
      throw SceneError(file_loc, "\"" + l.filename +
                                     "\": image has infinite or not-a-number pixel values and "
                                     "so is not suitable as a light");
  const int res = im.width;
  // pbrt-v4: with "illuminance" E_v > 0 the map is scaled so that its illuminance at an
  // upward-facing (+z in the light's frame) point is E_v, measured as pbrt-v4 does: luminance
  // (sRGB Y weights) times cos theta summed over the texels whose centre has w.z > 0, times
  // 2 pi / (res^2). (pbrt-v4 quirk, reproduced: each texel covers 4 pi / res^2, so the
  // measured value is half the true illuminance and the result is lit by 2 E_v.)
  const float E_v = ps.get_float("illuminance", -1.0f);
  if (E_v > 0.0f && l.mapping != 0)
    throw SceneError(ps.loc_of("illuminance", d.loc),
                     "\"illuminance\" with \"mapping\" \"" + mapping +
                         "\" is not supported yet (only \"equalarea\" maps)");
  if (E_v > 0.0f) {
    constexpr double kLum[3] = {0.2126390, 0.7151687, 0.0721923};  // sRGB LuminanceVector
    double illuminance = 0.0;
    for (int y = 0; y < res; ++y) {
      const double v = (y + 0.5) / res;
      for (int x = 0; x < res; ++x) {
        const glm::dvec3 w = equal_area_square_to_sphere_d((x + 0.5) / res, v);
        if (w.z <= 0.0) continue;
        const float* t = &im.texels[3 * (std::size_t(y) * res + x)];
        for (int c = 0; c < 3; ++c) illuminance += t[c] * kLum[c] * w.z;
      }
    }
    illuminance *= 2.0 * std::numbers::pi / (double(res) * res);
    if (!(illuminance > 0.0))
      throw SceneError(ps.loc_of("illuminance", d.loc),
                       "\"illuminance\" given, but the upper hemisphere of \"" + l.filename +
                           "\" is black");
    scale = static_cast<float>(scale * (E_v / illuminance));
  }
  if (!std::isfinite(scale)) throw SceneError(ps.loc_of("scale", d.loc), "scale is not finite");
  l.value = glm::vec3(scale);
  // pbrt-v4 renderFromLight is the CTM: its rotation (uniform scale allowed, it does not change
  // directions) maps light directions to world; light_from_world is its transpose.
  const glm::mat3 m(gs_.ctm);
  glm::vec3 c[3] = {m[0], m[1], m[2]};
  const float len[3] = {glm::length(c[0]), glm::length(c[1]), glm::length(c[2])};
  const float sc = (len[0] + len[1] + len[2]) / 3.0f;
  bool ok = sc > 0.0f && std::isfinite(sc);
  for (int i = 0; ok && i < 3; ++i)
    ok = std::abs(len[i] - sc) <= 1e-4f * sc &&
         std::abs(glm::dot(c[i], c[(i + 1) % 3])) <= 1e-4f * sc * sc;
  if (!ok)
    throw SceneError(d.loc, "the transform of an image infinite light must be a rotation "
                            "(non-uniform scale and shear are not supported)");
  for (int i = 0; i < 3; ++i) c[i] /= len[i];
  l.light_from_world = glm::transpose(glm::mat3(c[0], c[1], c[2]));
  l.image_res = res;
  l.image_width = im.width;
  l.image_height = im.height;
  l.image_rgb = std::move(im.texels);
}

// LightSource "point" / "spot" / "distant" / "infinite" (pbrt-v4 lights.cpp Create functions);
// dir resolves an environment map's file name.
void Parser::light_source(Tokenizer& tok, const Token& d, const std::string& dir) {
  verify_world(d);
  std::string type = string_arg(tok, d, "a light type");
  ParamSet ps = params(tok);
  // "illuminance" is supported for image infinite lights only (image_infinite_light).
  const bool image_light = type == "infinite" && ps.find("filename") != nullptr;
  for (const char* photometric : {"power", "illuminance"})
    if (const Param* p = ps.find(photometric); p && !(image_light && p->name == "illuminance"))
      throw SceneError(
          p->loc, "parameter \"" + p->name + "\" (photometric light scaling) is not supported yet");
  Light l;
  l.loc = d.loc;
  float scale = light_scale(ps, d);
  if (type == "point") {
    // pbrt-v4 PointLight::Create: renderFromLight * Translate(from).
    l.kind = Light::Kind::Point;
    l.value =
        ps.get_spectrum("I", SpectrumUse::Illuminant, &scene_.warnings).value_or(glm::vec3(1)) *
        scale;
    l.from = xform_point(gs_.ctm, ps.get_point3("from", glm::vec3(0)));
  } else if (type == "spot") {
    // pbrt-v4 SpotLight::Create: the light looks from "from" towards "to".
    l.kind = Light::Kind::Spot;
    l.value =
        ps.get_spectrum("I", SpectrumUse::Illuminant, &scene_.warnings).value_or(glm::vec3(1)) *
        scale;
    glm::vec3 from = ps.get_point3("from", glm::vec3(0)),
              to = ps.get_point3("to", glm::vec3(0, 0, 1));
    l.from = xform_point(gs_.ctm, from);
    glm::vec3 axis = xform_point(gs_.ctm, to) - l.from;
    if (glm::length(axis) == 0.0f)
      throw SceneError(ps.loc_of("to", d.loc), "spot light \"from\" and \"to\" are the same point");
    l.dir = glm::normalize(axis);
    l.cone_angle = ps.get_float("coneangle", 30.0f);
    l.cone_delta = ps.get_float("conedeltaangle", 5.0f);
    if (!(l.cone_angle > 0.0f && l.cone_angle <= 180.0f))
      throw SceneError(ps.loc_of("coneangle", d.loc), "coneangle must be in (0, 180] degrees");
    if (l.cone_delta < 0.0f)
      throw SceneError(ps.loc_of("conedeltaangle", d.loc), "conedeltaangle must not be negative");
  } else if (type == "distant") {
    // pbrt-v4 DistantLight::Create: w = normalize(from - to) points towards the light.
    l.kind = Light::Kind::Distant;
    l.value =
        ps.get_spectrum("L", SpectrumUse::Illuminant, &scene_.warnings).value_or(glm::vec3(1)) *
        scale;
    glm::vec3 w = xform_vector(
        gs_.ctm, ps.get_point3("from", glm::vec3(0)) - ps.get_point3("to", glm::vec3(0, 0, 1)));
    if (glm::length(w) == 0.0f)
      throw SceneError(ps.loc_of("to", d.loc),
                       "distant light \"from\" and \"to\" are the same point");
    l.dir = glm::normalize(w);
  } else if (type == "infinite") {
    // pbrt-v4 Light::Create "infinite": uniform without "filename" or "portal", else
    // ImageInfiniteLight, or PortalImageInfiniteLight with "portal" (textures-spec 6.9).
    if (image_light || ps.find("portal")) {
      image_infinite_light(ps, d, dir, scale, l);
      ps.report_unused("LightSource 'infinite'", scene_.warnings);
      scene_.lights.push_back(std::move(l));
      return;
    }
    l.kind = Light::Kind::Infinite;
    l.value =
        ps.get_spectrum("L", SpectrumUse::Illuminant, &scene_.warnings).value_or(glm::vec3(1)) *
        scale;
  } else {
    throw SceneError(d.loc, "light '" + type + "' is not supported yet");
  }
  ps.report_unused("LightSource '" + type + "'", scene_.warnings);
  scene_.lights.push_back(l);
}

// AreaLightSource "diffuse" (pbrt-v4 DiffuseAreaLight::Create): emission of the shapes that
// follow in the current attribute scope.
void Parser::area_light_source(Tokenizer& tok, const Token& d) {
  verify_world(d);
  std::string type = string_arg(tok, d, "an area light type");
  ParamSet ps = params(tok);
  if (type != "diffuse") throw SceneError(d.loc, "area light '" + type + "' is not supported yet");
  if (const Param* p = ps.find("filename"))
    throw SceneError(p->loc, "image area lights are not supported yet");
  if (const Param* p = ps.find("power"))
    throw SceneError(p->loc,
                     "parameter \"power\" (photometric light scaling) is not supported yet");
  AreaLight a;
  const float scale = light_scale(ps, d);
  a.L = ps.get_spectrum("L", SpectrumUse::Illuminant, &scene_.warnings).value_or(glm::vec3(1)) *
        scale;
  a.twosided = ps.get_bool("twosided", false);
  ps.report_unused("AreaLightSource 'diffuse'", scene_.warnings);
  gs_.area_light = a;
}

// A material with its defaults filled in (host/scene/materials.cpp; pbrt-v4 materials.cpp and
// pbrt-v3 src/materials); dir resolves a measured material's file name.
Material Parser::make_material(const std::string& type, const ParamSet& ps, const SourceLoc& loc,
                               const SourceLoc& type_loc, const std::string& what,
                               const std::string& dir) {
  MaterialContext ctx;
  ctx.warnings = &scene_.warnings;
  ctx.measured = &scene_.measured;
  ctx.resolve = [this, dir](const std::string& name) { return resolve(name, dir); };
  Material m = parse_material(type, ps, loc, type_loc, what, ctx);
  if (!m.normal_map.empty()) {
    // docs/bump-spec.md 1: read linear whatever the file type (pbrt-v4 Image::Read with
    // ColorEncoding::Linear), decoded once per file as image textures are; R, G, B needed.
    TextureDef t;
    t.tag = gpu::TEXTURE_IMAGEMAP;
    t.image_file = m.normal_map;
    t.image_encoding = ColorEncoding{ImageEncoding::Linear};
    t.image_loc = m.normal_map_loc;
    load_texture_image(scene_, t);
    const DecodedImage& im = scene_.images[std::size_t(t.image)];
    if (im.channels != 3)
      throw SceneError(m.normal_map_loc, "\"" + m.normal_map +
                                             "\": a normal map needs R, G and B channels, it has " +
                                             std::to_string(im.channels));
    m.normal_map_image = t.image;
  }
  return m;
}

// End of input: unclosed scopes, named materials, emptiness, and values that depend on
// directives in any order (Option seed, frameaspectratio).
Scene Parser::finish(const SourceLoc& eof) {
  if (!stack_.empty())
    throw SceneError(stack_.back().second, "AttributeBegin without a matching AttributeEnd");
  for (const PendingMaterial& p : pending_) {
    auto it = named_materials_.find(p.name);
    if (it == named_materials_.end())
      throw SceneError(p.loc, "named material \"" + p.name + "\" is not defined");
    scene_.shapes[p.shape].material = it->second;
  }
  // Displacement textures of plymesh shapes: pbrt-v4 looks them up among all float textures
  // when it creates the shapes, after the whole file (so one defined later is found).
  for (const Shape& s : scene_.shapes) {
    if (s.displacement.empty()) continue;
    bool is_float = false, is_spectrum = false;
    for (const TextureDef& t : scene_.textures)
      if (t.name == s.displacement) (t.is_float ? is_float : is_spectrum) = true;
    if (!is_float)
      throw SceneError(s.displacement_loc,
                       is_spectrum ? "displacement texture \"" + s.displacement +
                                         "\" is a spectrum texture; displacement needs a float "
                                         "texture"
                                   : "displacement texture \"" + s.displacement +
                                         "\": no such float texture defined");
  }
  // Mix materials name named materials, resolved at the end as pbrt-v4 does.
  for (Material& m : scene_.materials) {
    for (int i = 0; i < 2 && m.type == "mix"; ++i) {
      auto it = named_materials_.find(m.mix_names[i]);
      if (it == named_materials_.end())
        throw SceneError(m.mix_locs[i],
                         "mix refers to named material \"" + m.mix_names[i] + "\", which is not defined");
      m.mix[i] = it->second;
    }
  }
  // Everything the GPU tables need from materials is checked now, with locations (weighted
  // mixes, nesting, texture references); build_tables repeats it for the final mix mode.
  convert_materials(scene_, scene_.mix_mode, nullptr, nullptr);
  if (scene_.shapes.empty() && scene_.lights.empty())
    throw SceneError(eof, world_ ? "empty scene: no shapes or lights"
                                 : "empty scene: no shapes or lights (no WorldBegin)");
  if (!sampler_seed_given_) scene_.sampler.seed = option_seed_;
  if (frame_aspect_ && !scene_.camera.screen_window) {
    // pbrt-v4 PerspectiveCamera::Create: the shorter side of the frame spans [-1, 1].
    float f = *frame_aspect_;
    scene_.camera.screen_window =
        f > 1.0f ? glm::vec4(-f, f, -1, 1) : glm::vec4(-1, 1, -1 / f, 1 / f);
  }
  return std::move(scene_);
}

}  // namespace

Scene load_scene(const std::string& path, MixMode mix_mode, std::uint64_t max_table_bytes) {
  std::string dir = fs::path(path).parent_path().string();
  Parser parser(dir, mix_mode, max_table_bytes);
  Tokenizer tok(read_scene_file(path, SourceLoc{path, 0, 0}, "scene file"), path);
  parser.parse(tok, dir);
  return parser.finish(tok.end_loc());
}

Scene load_scene_from_string(const std::string& text, const std::string& name,
                             const std::string& base_dir, MixMode mix_mode,
                             std::uint64_t max_table_bytes) {
  Parser parser(base_dir, mix_mode, max_table_bytes);
  Tokenizer tok(text, name);
  parser.parse(tok, base_dir);
  return parser.finish(tok.end_loc());
}

}  // namespace basalt
