// Displacement mapping of triangle meshes on the host (pbrt-v4 Shape::Create "plymesh" with a
// "displacement" texture, shapes.cpp, and TriQuadMesh::Displace / Refine / ComputeNormals,
// util/mesh.h and util/mesh.cpp): build_tables refines such a mesh until every world-space
// edge is shorter than "edgelength", moves each vertex along its normal by the float texture
// and recomputes the normals, before the triangles go into the tables and the BVH.
#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include <glm/glm.hpp>

#include "scene/scene.h"
#include "scene/tables.h"
#include "scene/textures.h"

namespace basalt {

/// Bounds on the refinement, so that a tiny edge length is a located error instead of an
/// out-of-memory crash or an endless recursion (pbrt-v4 has neither bound).
struct RefineLimits {
  std::size_t max_triangles = std::size_t(1) << 26;  // output triangles of one mesh (or its
                                                     // input count, if larger)
  int max_depth = 128;                               // bisections of one input triangle
};

/// \brief pbrt-v4 TriQuadMesh::ComputeNormals (util/mesh.cpp): each vertex normal is the
/// normalized sum of the unit face normals normalize((p1 - p0) x (p2 - p1)) of the triangles
/// using it (each face counts once, whatever its area); zero for unused vertices.
void compute_vertex_normals(TriangleMesh& mesh);

/// \brief pbrt-v4 TriQuadMesh::Refine over every triangle in order: a triangle whose three
/// edges, measured between the points transformed by \p world_from_object, are all shorter
/// than \p max_edge is kept; otherwise its longest edge is split at its midpoint (one vertex
/// per edge, shared through an edge map; normal normalize(n0 + n1) when non-zero, uv the
/// midpoint) and both halves are refined, in pbrt-v4's vertex order. New vertices are appended
/// after the input's, so vertex i < mesh.P.size() on input is unchanged. A triangle with a
/// non-finite edge length is kept as is (build_tables drops it with a warning).
/// \throws SceneError at \p loc for an index out of range, N or uv not one per vertex, or a
/// limit of \p limits exceeded: the triangle limit up front when the world-space area alone
/// needs more (at least area / (sqrt(3) / 4 max_edge^2) triangles), else while refining.
void refine_mesh(TriangleMesh& mesh, const glm::mat4& world_from_object, float max_edge,
                 const SourceLoc& loc, const RefineLimits& limits = {});

/// A displacement d(p, uv): p in object space, uv the vertex's (pbrt-v4 passes no more).
using DisplacementFn = std::function<float(glm::vec3 p, glm::vec2 uv)>;

/// \brief pbrt-v4 TriQuadMesh::Displace: computes vertex normals if \p mesh has none, refines
/// it (refine_mesh), moves every vertex p += d(p, uv) n (n as stored: a PLY's normals are not
/// renormalised, as in pbrt-v4) and recomputes the normals (compute_vertex_normals).
/// \throws SceneError at \p loc for a mesh without uvs, a mismatched N or uv count, or a
/// refinement beyond \p limits.
TriangleMesh displace_mesh(const TriangleMesh& mesh, const glm::mat4& world_from_object,
                           float max_edge, const DisplacementFn& d, const SourceLoc& loc,
                           const RefineLimits& limits = {});

/// The scene's float textures evaluated as displacements by the CPU texture evaluator
/// (host/cpu/texture.h), in texture tables of its own (programs, image pyramids and the shared
/// noise tables; the render tables get none of them). Not copyable: it points into itself.
class DisplacementTextures {
 public:
  explicit DisplacementTextures(const Scene& scene);
  DisplacementTextures(const DisplacementTextures&) = delete;
  DisplacementTextures& operator=(const DisplacementTextures&) = delete;
  /// \brief Root of the program of float texture \p name (built once).
  /// \throws SceneError at \p loc if there is no float texture of that name.
  std::uint32_t program(const std::string& name, const SourceLoc& loc);
  /// \brief Value of program \p root at object-space point \p p and \p uv, as pbrt-v4
  /// evaluates a displacement: a texture context with only p and uv set (n, the footprint and
  /// the uv derivatives zero), where p is the object-space point taken as a render-space one
  /// (a pbrt-v4 quirk): with pbrt-v4's default render space, "cameraworld" (world translated
  /// so that the camera is at the origin), the texture sees world point p + the camera
  /// position.
  float eval(std::uint32_t root, glm::vec3 p, glm::vec2 uv) const;
  /// \brief pbrt-v4's worldFromRender translation (the camera position) that eval adds.
  glm::vec3 render_origin() const { return render_origin_; }
  /// \brief The tables the programs live in (for tests and statistics).
  const SceneTables& tables() const { return tables_; }

 private:
  SceneTables tables_;
  TextureProgramBuilder builder_;
  glm::vec3 render_origin_{0.0f};
};

/// \brief The mesh of \p shape, refined and displaced if it has a "displacement" texture
/// (edge length Shape::edge_length times Scene::displacement_edge_scale), else a copy. The
/// texture is evaluated in parallel over the vertices.
/// \throws SceneError at the shape's parameters (see displace_mesh and
/// DisplacementTextures::program).
TriangleMesh displaced_shape_mesh(const Scene& scene, const Shape& shape,
                                  DisplacementTextures& textures,
                                  const RefineLimits& limits = {});

}  // namespace basalt
