// The parsed scene: what the pbrt-v4 parser produces and the table builder consumes.
// Values are interpreted, defaulted and validated by the parser (pbrt-v4 semantics);
// positions and directions are in world space unless a field says otherwise.
#pragma once
#include <glm/glm.hpp>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

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

struct Sampler {
  int spp = 16;
  int seed = 0;
};

struct Filter {
  enum class Type { Box, Gaussian } type = Type::Gaussian;  // pbrt-v4 default
  glm::vec2 radius{1.5f, 1.5f};                             // box default 0.5
  float sigma = 0.5f;                                        // gaussian only
};

struct Integrator {
  int max_depth = 5;
  bool regularize = false;
};

/// A material parameter: a constant (1 or 3 floats) or a named texture (issue: textures).
struct MaterialParam {
  std::vector<float> value;
  std::string texture;  // empty for a constant
  SourceLoc loc;
};

/// A material: its pbrt-v4 type name and interpreted parameters (defaults filled in).
struct Material {
  std::string type;  // "diffuse", ...
  std::string name;  // named material name, or "" for anonymous
  std::map<std::string, MaterialParam> params;
  SourceLoc loc;
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
};

/// Point, spot, distant and uniform infinite lights, in world space.
struct Light {
  enum class Kind { Point, Spot, Distant, Infinite } kind = Kind::Point;
  glm::vec3 value{1.0f};  // I (point, spot) or L (distant, infinite), scale applied
  glm::vec3 from{0.0f};   // point, spot: world position
  glm::vec3 dir{0.0f, 0.0f, 1.0f};  // spot: unit emission axis; distant: unit direction towards the light
  float cone_angle = 30.0f;        // spot, degrees
  float cone_delta = 5.0f;         // spot, degrees
  SourceLoc loc;
};

struct Scene {
  Camera camera;
  Film film;
  Sampler sampler;
  Filter filter;
  Integrator integrator;
  std::vector<Material> materials;
  std::vector<Shape> shapes;
  std::vector<Light> lights;
  std::vector<std::string> warnings;  // "file:line:column: warning: ..."
};

/// \brief Parses a pbrt-v4 scene file (Include/Import resolved relative to each file).
/// \throws SceneError with the location of the first problem.
Scene load_scene(const std::string& path);
/// \brief Parses scene text; \p name is used in messages, \p base_dir resolves relative paths.
Scene load_scene_from_string(const std::string& text, const std::string& name,
                             const std::string& base_dir = ".");

}  // namespace basalt
