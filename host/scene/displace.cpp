// Displacement mapping of triangle meshes (pbrt-v4 shapes.cpp Shape::Create "plymesh",
// util/mesh.h TriQuadMesh::Displace and Refine, util/mesh.cpp ComputeNormals), in pbrt-v4's
// float arithmetic and vertex order.
#include "scene/displace.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cpu/texture.h"

namespace basalt {
namespace {

// pbrt-v4 DifferenceOfProducts (util/math.h): a b - c d with one rounding of error.
float difference_of_products(float a, float b, float c, float d) {
  const float cd = c * d;
  const float dop = std::fma(a, b, -cd);
  const float err = std::fma(-c, d, cd);
  return dop + err;
}

// pbrt-v4 Cross (util/vecmath.h) of two vectors.
glm::vec3 cross_pbrt(glm::vec3 a, glm::vec3 b) {
  return {difference_of_products(a.y, b.z, a.z, b.y), difference_of_products(a.z, b.x, a.x, b.z),
          difference_of_products(a.x, b.y, a.y, b.x)};
}

// pbrt-v4 LengthSquared: x^2 + y^2 + z^2, summed left to right.
float length_squared(glm::vec3 v) { return v.x * v.x + v.y * v.y + v.z * v.z; }

// pbrt-v4 Normalize: v / Length(v) (a division, not glm's multiplication by inversesqrt).
glm::vec3 normalize_pbrt(glm::vec3 v) { return v / std::sqrt(length_squared(v)); }

// pbrt-v4 Transform::operator()(Point3f): row by row, left to right, then the divide by w.
glm::vec3 transform_point_pbrt(const glm::mat4& m, glm::vec3 p) {
  const float x = m[0][0] * p.x + m[1][0] * p.y + m[2][0] * p.z + m[3][0];
  const float y = m[0][1] * p.x + m[1][1] * p.y + m[2][1] * p.z + m[3][1];
  const float z = m[0][2] * p.x + m[1][2] * p.y + m[2][2] * p.z + m[3][2];
  const float w = m[0][3] * p.x + m[1][3] * p.y + m[2][3] * p.z + m[3][3];
  return w == 1.0f ? glm::vec3(x, y, z) : glm::vec3(x, y, z) / w;
}

// The midpoint vertex of each split edge (pbrt-v4's HashMap<pair<int, int>, int> edgeSplit):
// open addressing with linear probing over a power-of-two table, keyed by (min << 32 | max).
class EdgeMap {
 public:
  // Reserves room for about n edges.
  void reserve(std::size_t n) {
    if (2 * n > slots_.size()) rehash(std::bit_ceil(std::max<std::size_t>(2 * n, 64)));
  }
  // The vertex of edge key, or nullptr.
  const unsigned* find(std::uint64_t key) const {
    if (slots_.empty()) return nullptr;
    for (std::size_t i = hash(key) & mask();; i = (i + 1) & mask()) {
      if (slots_[i].first == key) return &slots_[i].second;
      if (slots_[i].first == kEmpty) return nullptr;
    }
  }
  // Records vertex v for edge key (not present yet).
  void insert(std::uint64_t key, unsigned v) {
    if (2 * (size_ + 1) > slots_.size()) rehash(std::max<std::size_t>(64, 2 * slots_.size()));
    std::size_t i = hash(key) & mask();
    while (slots_[i].first != kEmpty) i = (i + 1) & mask();
    slots_[i] = {key, v};
    ++size_;
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t(0);  // (min, max) never both ~0
  // pbrt-v4 MixBits (util/hash.h).
  static std::size_t hash(std::uint64_t v) {
    v ^= (v >> 31);
    v *= 0x7fb5d329728ea185ull;
    v ^= (v >> 27);
    v *= 0x81dadef4bc2dd44dull;
    v ^= (v >> 33);
    return std::size_t(v);
  }
  std::size_t mask() const { return slots_.size() - 1; }
  void rehash(std::size_t n) {
    std::vector<std::pair<std::uint64_t, unsigned>> old(n, {kEmpty, 0u});
    old.swap(slots_);
    size_ = 0;
    for (const auto& [k, v] : old)
      if (k != kEmpty) insert(k, v);
  }
  std::vector<std::pair<std::uint64_t, unsigned>> slots_;
  std::size_t size_ = 0;
};

// Recursive longest-edge bisection of one mesh (pbrt-v4 TriQuadMesh::Refine).
class Refiner {
 public:
  Refiner(TriangleMesh& mesh, const glm::mat4& world_from_object, float max_edge,
          const SourceLoc& loc, const RefineLimits& limits, std::size_t max_triangles,
          std::vector<unsigned>& out)
      : mesh_(mesh), m_(world_from_object), max_edge_(max_edge), loc_(loc), limits_(limits),
        max_triangles_(max_triangles), out_(out) {
    world_.reserve(mesh.P.size());
    for (const glm::vec3& p : mesh.P) world_.push_back(transform_point_pbrt(m_, p));
  }

  // Reserves room for about \p vertices new vertices (split edges).
  void reserve(std::size_t vertices) { split_.reserve(vertices); }

  // Refines triangle (v0, v1, v2) at recursion depth \p depth, appending kept triangles.
  void refine(unsigned v0, unsigned v1, unsigned v2, int depth) {
    const float d01 = distance(v0, v1), d12 = distance(v1, v2), d20 = distance(v2, v0);
    // Kept: every edge short enough, or a length that is not finite (pbrt-v4 would recurse
    // forever on NaN; build_tables drops such a triangle with its warning).
    const bool finite = std::isfinite(d01) && std::isfinite(d12) && std::isfinite(d20);
    if ((d01 < max_edge_ && d12 < max_edge_ && d20 < max_edge_) || !finite) {
      if (out_.size() / 3 >= max_triangles_)
        throw SceneError(loc_, "displacement refinement of this mesh exceeds " +
                                   std::to_string(max_triangles_) +
                                   " triangles; raise \"edgelength\" or Option "
                                   "\"displacementedgescale\" (edge length now " +
                                   std::to_string(max_edge_) + ")");
      out_.insert(out_.end(), {v0, v1, v2});
      return;
    }
    if (depth >= limits_.max_depth)
      throw SceneError(loc_, "displacement refinement cannot bring an edge of world length " +
                                 std::to_string(std::max({d01, d12, d20})) + " below " +
                                 std::to_string(max_edge_) + " in " +
                                 std::to_string(limits_.max_depth) +
                                 " bisections (float precision); raise \"edgelength\"");
    // The first two vertices of v span the longest edge (pbrt-v4's order and tie-breaking).
    unsigned v[3];
    if (d01 > d12) {
      if (d01 > d20)
        v[0] = v0, v[1] = v1, v[2] = v2;
      else
        v[0] = v2, v[1] = v0, v[2] = v1;
    } else {
      if (d12 > d20)
        v[0] = v1, v[1] = v2, v[2] = v0;
      else
        v[0] = v2, v[1] = v0, v[2] = v1;
    }
    // Has the edge been split before (by the triangle on its other side)?
    const std::uint64_t key = (std::uint64_t(std::min(v[0], v[1])) << 32) | std::max(v[0], v[1]);
    unsigned vmid;
    if (const unsigned* found = split_.find(key)) {
      vmid = *found;
    } else {
      vmid = unsigned(mesh_.P.size());
      split_.insert(key, vmid);
      const glm::vec3 p = (mesh_.P[v[0]] + mesh_.P[v[1]]) / 2.0f;
      mesh_.P.push_back(p);
      world_.push_back(transform_point_pbrt(m_, p));
      if (!mesh_.N.empty()) {
        glm::vec3 n = mesh_.N[v[0]] + mesh_.N[v[1]];
        if (length_squared(n) > 0.0f) n = normalize_pbrt(n);
        mesh_.N.push_back(n);
      }
      if (!mesh_.uv.empty()) {
        const glm::vec2 uv = (mesh_.uv[v[0]] + mesh_.uv[v[1]]) / 2.0f;
        mesh_.uv.push_back(uv);
      }
    }
    refine(v[0], vmid, v[2], depth + 1);
    refine(vmid, v[1], v[2], depth + 1);
  }

 private:
  // World-space distance of two vertices (pbrt-v4 Distance of the transformed points).
  float distance(unsigned a, unsigned b) const {
    return std::sqrt(length_squared(world_[a] - world_[b]));
  }

  TriangleMesh& mesh_;
  const glm::mat4& m_;
  float max_edge_;
  const SourceLoc& loc_;
  const RefineLimits& limits_;
  std::size_t max_triangles_;
  std::vector<unsigned>& out_;
  std::vector<glm::vec3> world_;  // world_from_object applied to mesh_.P
  EdgeMap split_;
};

// Runs f(i) for i in [0, n) on the hardware threads (pbrt-v4 ParallelFor); f must be
// thread-safe and must not throw.
void parallel_for(std::size_t n, const std::function<void(std::size_t)>& f) {
  const std::size_t hw = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t workers = std::min<std::size_t>(hw, n / 4096 + 1);
  if (workers <= 1) {
    for (std::size_t i = 0; i < n; ++i) f(i);
    return;
  }
  std::vector<std::thread> threads;
  const std::size_t chunk = (n + workers - 1) / workers;
  for (std::size_t w = 0; w < workers; ++w)
    threads.emplace_back([&, w] {
      for (std::size_t i = w * chunk; i < std::min(n, (w + 1) * chunk); ++i) f(i);
    });
  for (std::thread& t : threads) t.join();
}

}  // namespace

// pbrt-v4 TriQuadMesh::ComputeNormals.
void compute_vertex_normals(TriangleMesh& mesh) {
  mesh.N.assign(mesh.P.size(), glm::vec3(0.0f));
  for (std::size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
    const unsigned v[3] = {mesh.indices[i], mesh.indices[i + 1], mesh.indices[i + 2]};
    const glm::vec3 v10 = mesh.P[v[1]] - mesh.P[v[0]];
    const glm::vec3 v21 = mesh.P[v[2]] - mesh.P[v[1]];
    glm::vec3 vn = cross_pbrt(v10, v21);
    if (length_squared(vn) > 0.0f) {
      vn = normalize_pbrt(vn);
      for (unsigned k : v) mesh.N[k] += vn;
    }
  }
  for (glm::vec3& n : mesh.N)
    if (length_squared(n) > 0.0f) n = normalize_pbrt(n);
}

// pbrt-v4 TriQuadMesh::Displace's refinement loop over TriQuadMesh::Refine.
void refine_mesh(TriangleMesh& mesh, const glm::mat4& world_from_object, float max_edge,
                 const SourceLoc& loc, const RefineLimits& limits) {
  if ((!mesh.N.empty() && mesh.N.size() != mesh.P.size()) ||
      (!mesh.uv.empty() && mesh.uv.size() != mesh.P.size()))
    throw SceneError(loc, "displacement needs one normal and uv (if any) per vertex");
  for (unsigned i : mesh.indices)
    if (i >= mesh.P.size()) throw SceneError(loc, "vertex index out of range");
  const std::size_t max_triangles = std::max(limits.max_triangles, mesh.indices.size() / 3);
  // Fail fast: the output triangles tile the input's world-space area, each covering at most
  // an equilateral triangle of side max_edge, so area / (sqrt(3) / 4 max_edge^2) is a lower
  // bound on their number.
  double area = 0.0;
  for (std::size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
    const glm::dvec3 a(transform_point_pbrt(world_from_object, mesh.P[mesh.indices[i]]));
    const glm::dvec3 b(transform_point_pbrt(world_from_object, mesh.P[mesh.indices[i + 1]]));
    const glm::dvec3 c(transform_point_pbrt(world_from_object, mesh.P[mesh.indices[i + 2]]));
    const double t = 0.5 * glm::length(glm::cross(b - a, c - a));
    if (std::isfinite(t)) area += t;
  }
  const double at_least = area / (std::sqrt(3.0) / 4.0 * double(max_edge) * max_edge);
  if (at_least * 0.999 > double(max_triangles)) {  // a margin for the rounding of the areas
    char count[32];
    std::snprintf(count, sizeof count, "%.0f", at_least);
    throw SceneError(loc, "displacement refinement of this mesh would make at least " +
                              std::string(count) +
                              " triangles (world area " + std::to_string(area) +
                              ", edge length " + std::to_string(max_edge) +
                              "), more than basalt's limit of " + std::to_string(max_triangles) +
                              "; raise \"edgelength\" or Option \"displacementedgescale\"");
  }
  const std::vector<unsigned> old = std::move(mesh.indices);
  std::vector<unsigned> out;
  out.reserve(old.size());
  Refiner r(mesh, world_from_object, max_edge, loc, limits, max_triangles, out);
  // About one new vertex per two new triangles (Euler), from the lower bound on triangles.
  r.reserve(std::size_t(std::min(at_least, double(max_triangles))) / 2);
  for (std::size_t i = 0; i + 2 < old.size(); i += 3) r.refine(old[i], old[i + 1], old[i + 2], 0);
  mesh.indices = std::move(out);
}

// pbrt-v4 TriQuadMesh::Displace (basalt's meshes are triangles already: the PLY reader
// fan-triangulates quads into pbrt-v4's ConvertToOnlyTriangles pair (0 1 2), (0 2 3)).
TriangleMesh displace_mesh(const TriangleMesh& mesh, const glm::mat4& world_from_object,
                           float max_edge, const DisplacementFn& d, const SourceLoc& loc,
                           const RefineLimits& limits) {
  if (mesh.uv.empty())
    throw SceneError(loc, "vertex uvs are required for displacement");
  if (mesh.uv.size() != mesh.P.size() || (!mesh.N.empty() && mesh.N.size() != mesh.P.size()))
    throw SceneError(loc, "displacement needs one uv (and normal, if any) per vertex");
  for (unsigned i : mesh.indices)  // before compute_vertex_normals reads them
    if (i >= mesh.P.size()) throw SceneError(loc, "vertex index out of range");
  TriangleMesh out = mesh;
  if (out.N.empty()) compute_vertex_normals(out);
  refine_mesh(out, world_from_object, max_edge, loc, limits);
  std::vector<float> dv(out.P.size());
  parallel_for(out.P.size(), [&](std::size_t i) { dv[i] = d(out.P[i], out.uv[i]); });
  for (std::size_t i = 0; i < out.P.size(); ++i) out.P[i] += dv[i] * out.N[i];
  compute_vertex_normals(out);
  return out;
}

// Texture tables of its own, set up as build_tables sets the render tables.
DisplacementTextures::DisplacementTextures(const Scene& scene)
    : builder_(scene, &tables_.textures) {
  builder_.set_image_tables(&tables_.mip_levels, &tables_.texels);
  // The noise tables, split-precision noise lookups (docs/textures-spec.md 2.1) and the
  // scene's texture filtering option (irrelevant here: the footprint is zero).
  tables_.globals.tex_tables = texture_shared_tables(tables_.tex_data);
  // pbrt-v4 CameraTransform, RenderingCoordinateSystem::CameraWorld (its default; basalt has
  // no other): worldFromRender = Translate(worldFromCamera(0, 0, 0)).
  render_origin_ = transform_point_pbrt(scene.camera.world_from_camera, glm::vec3(0.0f));
  tables_.globals.texture_opts =
      glm::uvec4((scene.disable_texture_filtering ? gpu::TEXOPT_DISABLE_FILTERING : 0u) |
                     gpu::TEXOPT_NOISE_SPLIT,
                 0u, 0u, 0u);
}

// The program of a float texture, built into this object's tables.
std::uint32_t DisplacementTextures::program(const std::string& name, const SourceLoc& loc) {
  return builder_.program(name, /*rgb=*/false, loc);
}

// pbrt-v4 Shape::Create "plymesh": TextureEvalContext ctx; ctx.p = p; ctx.uv = uv. Its
// texture mappings apply textureFromRender = textureFromWorld * worldFromRender to ctx.p;
// basalt's apply texture_from_world, so the render-to-world translation is added here.
float DisplacementTextures::eval(std::uint32_t root, glm::vec3 p, glm::vec2 uv) const {
  cpu::TextureContext ctx;
  ctx.p = p + render_origin_;
  ctx.n = glm::vec3(0.0f);
  ctx.uv = uv;
  return cpu::tex_eval_float(tables_, root, ctx);
}

// pbrt-v4 Shape::Create "plymesh" with "displacement".
TriangleMesh displaced_shape_mesh(const Scene& scene, const Shape& shape,
                                  DisplacementTextures& textures, const RefineLimits& limits) {
  if (shape.displacement.empty()) return shape.mesh;
  const std::uint32_t root = textures.program(shape.displacement, shape.displacement_loc);
  // pbrt-v4: edgeLength *= Options->displacementEdgeScale, in float. Both are positive and
  // finite (the parser checks them); a product that overflows to infinity refines nothing, as
  // in pbrt-v4, one that underflows to 0 would refine forever.
  const float max_edge = shape.edge_length * scene.displacement_edge_scale;
  if (!(max_edge > 0.0f))
    throw SceneError(shape.edge_length_loc,
                     "displacement edge length (\"edgelength\" times Option "
                     "\"displacementedgescale\") must be positive, got " +
                         std::to_string(max_edge));
  if (shape.mesh.uv.empty())
    throw SceneError(shape.displacement_loc, "plymesh \"displacement\" needs vertex uvs");
  return displace_mesh(
      shape.mesh, shape.world_from_object, max_edge,
      [&](glm::vec3 p, glm::vec2 uv) { return textures.eval(root, p, uv); },
      shape.edge_length_loc, limits);
}

}  // namespace basalt
