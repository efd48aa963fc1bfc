// The parsed scene: what the pbrt-v4 parser produces and the table builder consumes.
// Values are interpreted, defaulted and validated by the parser (pbrt-v4 semantics);
// positions and directions are in world space unless a field says otherwise.
#pragma once
#include <cstdint>
#include <glm/glm.hpp>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "scene/images.h"

namespace basalt {

/// A place in a scene file, for messages of the form file:line:column.
struct SourceLoc {
  std::string file;
  int line = 0;
  int column = 0;
  /// \brief "file:line:column" (or just the file when line is 0).
  std::string str() const;
};

/// Any error in scene input; what() is "file:line:column: error: message".
class SceneError : public std::runtime_error {
 public:
  SceneError(const SourceLoc& loc, const std::string& message);
  SourceLoc loc;
  std::string message;
};

/// Perspective camera (pbrt-v4 PerspectiveCamera parameters).
struct Camera {
  glm::mat4 world_from_camera{1.0f};  // inverse of the CTM at the Camera directive
  float fov_deg = 90.0f;              // field of view of the shorter image axis
  float lens_radius = 0.0f;
  float focal_distance = 1e6f;
  std::optional<glm::vec4> screen_window;  // xmin, xmax, ymin, ymax if given
  SourceLoc loc;
};

struct Film {
  int xres = 1280, yres = 720;
  std::string filename = "pbrt.exr";
  SourceLoc loc;
};

/// The scene's `Sampler` (docs/sampler-spec.md): pbrt-v4's name, sample count and options.
struct Sampler {
  std::string type = "zsobol";  // a name of sampler_names(); pbrt-v4's default without a Sampler
  int spp = 16;
  int seed = 0;
  int xsamples = 4, ysamples = 4;     // stratified
  bool jitter = true;                 // stratified
  std::string randomization;          // "" (the sampler's default), none, permutedigits,
                                      // fastowen, owen
};

struct Filter {
  enum class Type { Box, Gaussian } type = Type::Gaussian;  // pbrt-v4 default
  glm::vec2 radius{1.5f, 1.5f};                             // box default 0.5
  float sigma = 0.5f;                                        // gaussian only
};

struct Integrator {
  int max_depth = 5;
  bool regularize = false;
  std::string light_sampler = "bvh";  // "lightsampler": bvh, uniform or power (path-spec 6)
};

/// A material parameter: a constant (1 or 3 floats; 1 float of an rgb slot is grey) or a
/// named texture (issue: textures). Keys of Material::params are the slot names of
/// host/scene/materials.h (e.g. "reflectance", "uroughness", "Kd").
struct MaterialParam {
  std::vector<float> value;
  std::string texture;  // empty for a constant
  SourceLoc loc;
};

/// A texture's argument: a constant (x of a float texture; rgb of a spectrum texture) or a
/// named texture (looked up in the namespace of the argument's type).
struct TextureArg {
  glm::vec3 value{0.0f};
  std::string texture;  // empty for a constant
  bool is_float = false;
  SourceLoc loc;
};

/// A named texture (pbrt-v4 Texture directive), interpreted with pbrt-v4's defaults into the
/// fields of its instruction (shaders/shared/layout.h, docs/textures-spec.md section 2).
struct TextureDef {
  std::string name;
  bool is_float = false;       // "float" or "spectrum"
  std::string cls;             // pbrt-v4 class: "checkerboard", "fbm", ...
  std::uint32_t tag = 0;       // TEXTURE_*
  std::uint32_t flags = 0;     // TEXFLAG_* (mapping)
  glm::mat4 texture_from_world{1.0f};  // inverse of the CTM at the Texture line
  glm::vec4 map[2]{glm::vec4(1.0f, 1.0f, 0.0f, 0.0f), glm::vec4(0.0f)};
  glm::uvec4 ip{0u};
  glm::vec4 param[4]{};
  std::vector<TextureArg> children;  // in the order layout.h lists for the tag
  SourceLoc loc;
  // imagemap: the file (resolved path), its encoding and the decoded image (Scene::images)
  std::string image_file;
  ColorEncoding image_encoding;
  SourceLoc image_loc;  // the "filename" parameter
  int image = -1;
  // volume (Shirley's 3D texture array): nx * ny * nz voxels, 1 or 3 floats each, voxel
  // (i, j, k) at ((k * ny + j) * nx + i) * channels; the resolution is in ip.yzw.
  std::vector<float> voxels;
};

/// How mix materials are rendered (the CLI's --mix): as each scene's syntax says (pbrt-v4
/// `string materials` -> stochastic, pbrt-v3 `namedmaterial1/2` -> weighted), or forced.
enum class MixMode { Auto, Stochastic, Weighted };

/// A material: its type name as written in the scene ("diffuse", "matte", "mix", ...) and its
/// interpreted parameters with pbrt's defaults filled in (docs/materials.md).
struct Material {
  std::string type;  // pbrt-v4 or pbrt-v3 material name; "interface" also for "" and "none"
  std::string name;  // named material name, or "" for anonymous
  std::map<std::string, MaterialParam> params;
  SourceLoc loc;
  std::optional<std::uint32_t> flags;  // MATFLAG_*; unset: the kind's default remap
  // mix: the two materials, by name (as written) and resolved index; aux1 gets `amount`
  // (pbrt-v4: materials[1]; pbrt-v3: namedmaterial1).
  std::string mix_names[2];
  SourceLoc mix_locs[2];
  int mix[2] = {-1, -1};
  bool mix_v3 = false;    // pbrt-v3 syntax (namedmaterial1/2): weighted unless forced
  int measured = -1;      // measured: index into Scene::measured
  int max_depth = 10;     // coated*: pbrt-v4 LayeredBxDF maxdepth
  int n_samples = 1;      // coated*: nsamples
  // "normalmap" (docs/bump-spec.md 1): resolved file, its location, and the decoded image
  // (Scene::images index, read linear) set by the parser.
  std::string normal_map;
  SourceLoc normal_map_loc;
  int normal_map_image = -1;
  // docs/bump-spec.md 9 (extension): Shirley's vector-turbulence normals, on when vturb_k1 is
  // given ("normalturbulence"), with frequency vturb_k2 and vturb_octaves octaves.
  bool vturb = false;
  float vturb_k1 = 0.0f, vturb_k2 = 1.0f;
  int vturb_octaves = 4;
};

/// A tabulated BRDF in pbrt-v2's MERL regular half-angle layout (host/scene/merl.h).
struct MeasuredTable {
  std::string path;
  glm::uvec3 dims{0u};    // n theta_h, n theta_d, n phi_d
  std::vector<float> rgb; // 3 per entry, index phi_d + nPhiD (theta_d + nThetaD theta_h)
};

/// Diffuse area light attached to a shape (pbrt-v4 DiffuseAreaLight).
struct AreaLight {
  glm::vec3 L{1.0f};  // radiance, scale already applied
  bool twosided = false;
};

/// Triangle mesh in object space (trianglemesh, plymesh).
struct TriangleMesh {
  std::vector<glm::vec3> P;
  std::vector<glm::vec3> N;   // empty or one per vertex
  std::vector<glm::vec2> uv;  // empty or one per vertex
  std::vector<unsigned> indices;
};

struct Shape {
  enum class Kind { Sphere, Triangles } kind = Kind::Sphere;
  glm::mat4 world_from_object{1.0f};
  bool reverse_orientation = false;
  int material = -1;  // index into Scene::materials
  std::optional<AreaLight> area_light;
  float radius = 1.0f;  // sphere
  TriangleMesh mesh;    // triangles
  SourceLoc loc;
  // plymesh "texture displacement" (pbrt-v4 Shape::Create "plymesh"; host/scene/displace.h):
  // the float texture's name (empty: none) and its parameter's location, and "edgelength"
  // (world space; Scene::displacement_edge_scale not yet applied) with its location.
  std::string displacement;
  SourceLoc displacement_loc;
  float edge_length = 1.0f;
  SourceLoc edge_length_loc;
};

/// Point, spot, distant, uniform infinite and image infinite lights, in world space.
struct Light {
  enum class Kind { Point, Spot, Distant, Infinite, InfiniteImage } kind = Kind::Point;
  glm::vec3 value{1.0f};  // I (point, spot) or L (distant, infinite), scale applied;
                          // InfiniteImage: the scale (illuminance folded in) in each channel
  glm::vec3 from{0.0f};   // point, spot: world position
  glm::vec3 dir{0.0f, 0.0f, 1.0f};  // spot: unit emission axis; distant: unit direction towards the light
  float cone_angle = 30.0f;        // spot, degrees
  float cone_delta = 5.0f;         // spot, degrees
  // InfiniteImage (pbrt-v4 ImageInfiniteLight): the decoded image, linear rgb, rows top to
  // bottom (image_width * image_height * 3 floats) in the parameterisation `mapping`
  // (docs/textures-spec.md 6.8: 0 equal-area octahedral square, 1 lat-long, 2 cube strip
  // n x 6n), and the rotation from world to the light's frame (the inverse of the CTM's
  // rotation at the LightSource line).
  std::string filename;  // resolved path
  int image_res = 0;     // image_width (kept for the equal-area square)
  int image_width = 0, image_height = 0;
  int mapping = 0;  // Light.data.w: 0 "equalarea", 1 "latlong", 2 "cube"
  std::vector<float> image_rgb;
  glm::mat3 light_from_world{1.0f};
  // "portal" (pbrt-v4 PortalImageInfiniteLight, docs/textures-spec.md 6.9): world-space
  // corners p0 .. p3 of the window.
  bool has_portal = false;
  glm::vec3 portal[4] = {};
  SourceLoc loc;
};

/// Largest table (film accumulation, triangles, vertices, ...) without a device limit, in
/// bytes: 4 GiB, what 32-bit indices address. A Vulkan render passes its device's
/// maxStorageBufferRange instead (128 MiB on lavapipe, the minimum Vulkan guarantees).
constexpr std::uint64_t kMaxTableBytes = std::uint64_t(1) << 32;
/// Largest film side in pixels.
constexpr int kMaxFilmSide = 1 << 20;

struct Scene {
  Camera camera;
  Film film;
  Sampler sampler;
  Filter filter;
  Integrator integrator;
  std::vector<Material> materials;
  std::vector<Shape> shapes;
  std::vector<Light> lights;
  std::vector<MeasuredTable> measured;  // each file once (Material::measured indexes it)
  std::vector<TextureDef> textures;     // in file order; names unique per type
  std::vector<DecodedImage> images;     // each (file, encoding) once; TextureDef::image
  std::map<std::string, int> image_index;  // image_key(file, encoding) -> images index
  bool disable_texture_filtering = false;  // Option "disabletexturefiltering"
  float displacement_edge_scale = 1.0f;    // Option "displacementedgescale" (> 0)
  int bvh_bins = 32, bvh_max_leaf = 8;     // BVH build quality (--bvh-bins, --bvh-leaf)
  MixMode mix_mode = MixMode::Auto;     // set by the caller (--mix) before build_tables
  // The largest table the renderer takes, in bytes: the Vulkan device's maxStorageBufferRange
  // (given to load_scene), else kMaxTableBytes. The film, PLY headers and the triangle and
  // vertex tables are checked against it before anything of that size is allocated.
  std::uint64_t max_table_bytes = kMaxTableBytes;
  std::vector<std::string> warnings;  // "file:line:column: warning: ..."
};

/// \brief Parses a pbrt-v4 scene file (Include/Import resolved relative to each file).
/// \p max_table_bytes (Scene::max_table_bytes) bounds the film and the geometry tables.
/// \p mix_mode (stored in Scene::mix_mode) decides how mix materials render; the materials
/// are checked for it (e.g. a weighted mix of more than MAX_LOBES lobes is an error).
/// \throws SceneError with the location of the first problem.
Scene load_scene(const std::string& path, MixMode mix_mode = MixMode::Auto,
                 std::uint64_t max_table_bytes = kMaxTableBytes);
/// \brief Parses scene text; \p name is used in messages, \p base_dir resolves relative paths.
Scene load_scene_from_string(const std::string& text, const std::string& name,
                             const std::string& base_dir = ".",
                             MixMode mix_mode = MixMode::Auto,
                             std::uint64_t max_table_bytes = kMaxTableBytes);

}  // namespace basalt
