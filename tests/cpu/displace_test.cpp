// Displacement mapping of plymesh shapes (pbrt-v4 TriQuadMesh::Displace; host/scene/displace.h):
// vertices moved by closed-form textures along their normals; the point the texture sees (object
// space plus the camera position, pbrt-v4's quirk); a sphere grown by a constant; world-space
// edge lengths after refinement and pbrt-v4's vertex order; closed meshes staying closed (no
// cracks); silhouettes seen by ray casts; located errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "common/scratch_dir.h"
#include "common/test_util.h"
#include "cpu/intersect.h"
#include "scene/displace.h"
#include "scene/scene.h"
#include "scene/tables.h"

namespace basalt::test {
namespace {

namespace fs = std::filesystem;

/// Writes an ascii PLY (normals and uv written when not empty) and returns its path.
std::string write_ply(const std::string& name, const TriangleMesh& m) {
  const fs::path dir = basalt::test::scratch_dir("displace");
  const fs::path path = dir / name;
  std::ofstream out(path);
  out << "ply\nformat ascii 1.0\nelement vertex " << m.P.size()
      << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (!m.N.empty()) out << "property float nx\nproperty float ny\nproperty float nz\n";
  if (!m.uv.empty()) out << "property float u\nproperty float v\n";
  out << "element face " << m.indices.size() / 3
      << "\nproperty list uchar int vertex_indices\nend_header\n";
  out.precision(9);
  for (std::size_t i = 0; i < m.P.size(); ++i) {
    out << m.P[i].x << ' ' << m.P[i].y << ' ' << m.P[i].z;
    if (!m.N.empty()) out << ' ' << m.N[i].x << ' ' << m.N[i].y << ' ' << m.N[i].z;
    if (!m.uv.empty()) out << ' ' << m.uv[i].x << ' ' << m.uv[i].y;
    out << '\n';
  }
  for (std::size_t k = 0; k < m.indices.size(); k += 3)
    out << "3 " << m.indices[k] << ' ' << m.indices[k + 1] << ' ' << m.indices[k + 2] << '\n';
  return path.string();
}

/// An n x n grid of quads over [0, 1]^2 at z = 0 (two triangles each, counter-clockwise seen
/// from +z), uv = (x, y), and normals tilted differently at every vertex (unit length).
TriangleMesh grid(int n) {
  TriangleMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const float x = float(i) / float(n), y = float(j) / float(n);
      m.P.emplace_back(x, y, 0.0f);
      m.uv.emplace_back(x, y);
      m.N.push_back(glm::normalize(glm::vec3(0.3f * x - 0.1f, 0.2f * y, 1.0f)));
    }
  auto at = [n](int i, int j) { return unsigned(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j),
                                         at(i + 1, j + 1), at(i, j + 1)});
  return m;
}

/// A latitude-longitude sphere of radius r about the origin (poles on z): nu segments,
/// nv rings, analytic normals p / r, uv = (phi / 2 pi, theta / pi); the u = 0 and u = 1 seam
/// columns are separate vertices, as in common exported spheres.
TriangleMesh uv_sphere(float r, int nu, int nv) {
  TriangleMesh m;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      const double theta = std::numbers::pi * j / nv, phi = 2 * std::numbers::pi * i / nu;
      const glm::vec3 n(float(std::sin(theta) * std::cos(phi)),
                        float(std::sin(theta) * std::sin(phi)), float(std::cos(theta)));
      m.P.push_back(r * n);
      m.N.push_back(n);
      m.uv.emplace_back(float(i) / float(nu), float(j) / float(nv));
    }
  auto at = [nu](int i, int j) { return unsigned(j * (nu + 1) + i); };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      if (j > 0) m.indices.insert(m.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j)});
      if (j + 1 < nv)
        m.indices.insert(m.indices.end(), {at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)});
    }
  return m;
}

/// A regular octahedron of radius 1 (closed, 6 vertices, 8 faces, outward winding), uv from
/// the position; no normals.
TriangleMesh octahedron() {
  TriangleMesh m;
  m.P = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const glm::vec3& p : m.P) m.uv.emplace_back(0.5f + 0.5f * p.x, 0.5f + 0.5f * p.y);
  m.indices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  return m;
}

/// Undirected edges of a mesh with the number of triangles using each.
std::map<std::pair<unsigned, unsigned>, int> edge_uses(const TriangleMesh& m) {
  std::map<std::pair<unsigned, unsigned>, int> uses;
  for (std::size_t k = 0; k < m.indices.size(); k += 3)
    for (int e = 0; e < 3; ++e) {
      const unsigned a = m.indices[k + e], b = m.indices[k + (e + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  return uses;
}

/// Applies a homogeneous transform to a point.
glm::vec3 xform(const glm::mat4& m, glm::vec3 p) {
  const glm::vec4 q = m * glm::vec4(p, 1.0f);
  return glm::vec3(q) / q.w;
}

/// The scene of kTexturedHead + \p body (the body starts on line 7 of "t.pbrt").
Scene scene_of(const std::string& body) {
  return load_scene_from_string(kTexturedHead + body, "t.pbrt", ".");
}

/// The mesh of the first shape of kTexturedHead + \p body, displaced as build_tables does.
TriangleMesh displaced_first_shape(const std::string& body) {
  const Scene scene = scene_of(body);
  DisplacementTextures textures(scene);
  return displaced_shape_mesh(scene, scene.shapes.at(0), textures);
}

/// "t.pbrt:LINE:COL" of the first occurrence of \p token on body line \p body_line (0-based).
std::string loc_of(const std::string& body, int body_line, const std::string& token) {
  std::istringstream in(body);
  std::string line;
  for (int i = 0; i <= body_line; ++i) std::getline(in, line);
  const std::size_t col = line.find(token);
  EXPECT_NE(col, std::string::npos) << token;
  return "t.pbrt:" + std::to_string(7 + body_line) + ":" + std::to_string(col + 1) + ":";
}

/// pbrt-v4 Bilerp texture value at st = uv, in double (v00, v10, v01, v11 as in pbrt-v4).
double bilerp(glm::vec2 uv, double v00, double v01, double v10, double v11) {
  const double s = uv.x, t = uv.y;
  return (1 - s) * (1 - t) * v00 + s * (1 - t) * v10 + (1 - s) * t * v01 + s * t * v11;
}

// Every original vertex moves to p0 + d(uv0) n0 with the PLY's own normal n0, d = 0.5 times a
// bilerp texture evaluated here in closed form; every new vertex moves from its refined
// (undisplaced) position by d(uv) n of its refined uv and normal.
TEST(Displace, VerticesMoveByTextureAlongNormal) {
  const TriangleMesh mesh = grid(3);
  const std::string path = write_ply("grid.ply", mesh);
  const std::string body = R"(Texture "b" "float" "bilerp" "float v00" 0.1 "float v01" 0.3
  "float v10" -0.2 "float v11" 0.5
Texture "d" "float" "scale" "texture tex" "b" "float scale" 0.5
Shape "plymesh" "string filename" ")" + path +
                           R"(" "texture displacement" "d" "float edgelength" 0.2
)";
  const TriangleMesh out = displaced_first_shape(body);
  auto d = [](glm::vec2 uv) { return 0.5 * bilerp(uv, 0.1, 0.3, -0.2, 0.5); };
  ASSERT_GT(out.P.size(), mesh.P.size());  // edgelength 0.2 < 1/3: refined
  ASSERT_EQ(out.uv.size(), out.P.size());
  for (std::size_t i = 0; i < mesh.P.size(); ++i) {
    const glm::dvec3 want = glm::dvec3(mesh.P[i]) + d(mesh.uv[i]) * glm::dvec3(mesh.N[i]);
    EXPECT_NEAR(out.P[i].x, want.x, 1e-6) << i;
    EXPECT_NEAR(out.P[i].y, want.y, 1e-6) << i;
    EXPECT_NEAR(out.P[i].z, want.z, 1e-6) << i;
    EXPECT_EQ(out.uv[i], mesh.uv[i]);
  }
  TriangleMesh refined = mesh;
  refine_mesh(refined, glm::mat4(1.0f), 0.2f, SourceLoc{});
  ASSERT_EQ(refined.P.size(), out.P.size());
  EXPECT_EQ(refined.indices, out.indices);
  for (std::size_t i = mesh.P.size(); i < out.P.size(); ++i) {
    const glm::dvec3 want = glm::dvec3(refined.P[i]) + d(refined.uv[i]) * glm::dvec3(refined.N[i]);
    EXPECT_NEAR(glm::length(glm::dvec3(out.P[i]) - want), 0.0, 1e-6) << i;
  }
}

// The texture sees the object-space point taken as a render-space one (pbrt-v4 passes p before
// renderFromObject; its default render space is the world translated so that the camera, here
// at (0, 3, -8), is the origin): a 3D checkerboard defined in world space, on a translated and
// scaled mesh, gives the value at object-space p + (0, 3, -8), which differs from the value at
// the world-space point at some vertices and from the value at p itself at every one (the
// offset's coordinates sum to an odd number).
TEST(Displace, TextureSeesObjectSpacePoint) {
  TriangleMesh mesh;
  for (float y : {0.25f, 0.75f, 1.25f, 1.75f})
    for (float x : {0.25f, 0.75f, 1.25f, 1.75f}) {
      mesh.P.emplace_back(x, y, 0.5f);
      mesh.uv.emplace_back(x, y);
      mesh.N.emplace_back(0.0f, 0.0f, 1.0f);
    }
  for (unsigned j = 0; j < 3; ++j)
    for (unsigned i = 0; i < 3; ++i) {
      const unsigned a = j * 4 + i;
      mesh.indices.insert(mesh.indices.end(), {a, a + 1, a + 5, a, a + 5, a + 4});
    }
  const std::string path = write_ply("checker.ply", mesh);
  const TriangleMesh out = displaced_first_shape(
      R"(Texture "c" "float" "checkerboard" "integer dimension" 3 "float tex1" 0.1 "float tex2" 0.3
AttributeBegin
Translate 10.5 0 0
Scale 1.5 1.5 1.5
Shape "plymesh" "string filename" ")" +
      path + R"(" "texture displacement" "c" "float edgelength" 100
AttributeEnd
)");
  ASSERT_EQ(out.P.size(), mesh.P.size());  // edgelength 100: no refinement
  const glm::vec3 camera(0.0f, 3.0f, -8.0f);  // kTexturedHead's LookAt
  const glm::vec3 origin = DisplacementTextures(scene_of("Shape \"sphere\"\n")).render_origin();
  EXPECT_LT(glm::distance(origin, camera), 1e-5f);  // basalt inverts the LookAt matrix
  // pbrt-v4 Checkerboard (3D): tex1 where floor(x) + floor(y) + floor(z) is even.
  auto checker = [](glm::vec3 p) {
    const int s = int(std::floor(p.x)) + int(std::floor(p.y)) + int(std::floor(p.z));
    return s % 2 == 0 ? 0.1f : 0.3f;
  };
  const glm::mat4 world_from_object =
      glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(10.5f, 0, 0)), glm::vec3(1.5f));
  int differs = 0;
  for (std::size_t i = 0; i < mesh.P.size(); ++i) {
    EXPECT_FLOAT_EQ(out.P[i].z, mesh.P[i].z + checker(mesh.P[i] + camera)) << i;
    EXPECT_NE(checker(mesh.P[i] + camera), checker(mesh.P[i])) << i;
    differs += checker(mesh.P[i] + camera) != checker(xform(world_from_object, mesh.P[i]));
  }
  EXPECT_GT(differs, 0);  // the test tells object from world space
}

// A sphere of radius 1 displaced by a constant 0.2 becomes a sphere of radius 1.2: without
// refinement every vertex is at 1.2 (1e-4); with refinement every vertex moves radially by
// exactly 0.2 (midpoint normals normalize(n0 + n1) are radial for a centred sphere).
TEST(Displace, SphereGrowsByConstant) {
  const TriangleMesh sphere = uv_sphere(1.0f, 24, 12);
  const std::string path = write_ply("sphere.ply", sphere);
  const std::string shape = R"(Texture "d" "float" "constant" "float value" 0.2
Shape "plymesh" "string filename" ")" + path + R"(" "texture displacement" "d")";
  const TriangleMesh coarse = displaced_first_shape(shape + R"( "float edgelength" 10
)");
  ASSERT_EQ(coarse.P.size(), sphere.P.size());
  for (const glm::vec3& p : coarse.P) EXPECT_NEAR(glm::length(p), 1.2f, 1e-4f);

  const TriangleMesh fine = displaced_first_shape(shape + R"( "float edgelength" 0.1
)");
  TriangleMesh refined = sphere;
  refine_mesh(refined, glm::mat4(1.0f), 0.1f, SourceLoc{});
  ASSERT_EQ(fine.P.size(), refined.P.size());
  EXPECT_GT(fine.indices.size(), 4 * sphere.indices.size());
  float lo = 1e9f, hi = 0.0f;
  for (std::size_t i = 0; i < fine.P.size(); ++i) {
    EXPECT_NEAR(glm::length(fine.P[i]) - glm::length(refined.P[i]), 0.2f, 1e-5f) << i;
    lo = std::min(lo, glm::length(fine.P[i]));
    hi = std::max(hi, glm::length(fine.P[i]));
  }
  // Refined vertices lie on the coarse facets, inside the unit sphere by less than
  // 1 - cos(pi / 12): every coarse facet lies within an arc of pi / 12 of its circumcentre.
  EXPECT_NEAR(hi, 1.2f, 1e-4f);
  EXPECT_GT(lo, 1.2f - (1.0f - std::cos(std::numbers::pi_v<float> / 12.0f)));
  // The recomputed normals point outwards (pbrt-v4 ComputeNormals of outward triangles).
  for (std::size_t i = 0; i < fine.P.size(); ++i) {
    if (glm::length(fine.N[i]) > 0.0f) {
      EXPECT_GT(glm::dot(fine.N[i], fine.P[i]), 0.9f) << i;
    }
  }
}

// Refinement measures edges in world space: a unit square (two right isosceles triangles) under
// Scale 2 is refined until every world edge is shorter than edgelength; halving edgelength
// multiplies the triangle count by exactly 4 (two more bisection levels); the same square
// without the transform needs half the edge length for the same count. Edges used once lie on
// the square's border (no T-junctions).
TEST(Displace, RefinementRespectsWorldEdgeLength) {
  TriangleMesh square;
  square.P = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  square.uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  square.N.assign(4, glm::vec3(0, 0, 1));
  square.indices = {0, 1, 2, 0, 2, 3};
  const glm::mat4 scale2 = glm::scale(glm::mat4(1.0f), glm::vec3(2.0f));
  std::vector<std::size_t> counts;
  for (float e : {0.6f, 0.3f, 0.15f}) {
    TriangleMesh m = square;
    refine_mesh(m, scale2, e, SourceLoc{});
    counts.push_back(m.indices.size() / 3);
    for (std::size_t k = 0; k < m.indices.size(); k += 3)
      for (int j = 0; j < 3; ++j) {
        const glm::vec3 a = xform(scale2, m.P[m.indices[k + j]]),
                        b = xform(scale2, m.P[m.indices[k + (j + 1) % 3]]);
        ASSERT_LT(glm::distance(a, b), e) << "edgelength " << e;
      }
    for (const auto& [edge, uses] : edge_uses(m)) {
      ASSERT_LE(uses, 2);
      if (uses == 1) {
        const glm::vec3 a = m.P[edge.first], b = m.P[edge.second];
        const bool border = (a.x == 0 && b.x == 0) || (a.x == 1 && b.x == 1) ||
                            (a.y == 0 && b.y == 0) || (a.y == 1 && b.y == 1);
        EXPECT_TRUE(border) << "T-junction at edgelength " << e;
      }
    }
  }
  // Legs 2 / sqrt(2)^k, hypotenuse 2 / sqrt(2)^(k-1) < e: k = 5, 7, 9 levels, 2 * 2^k triangles.
  EXPECT_EQ(counts, (std::vector<std::size_t>{64, 256, 1024}));
  TriangleMesh object = square;
  refine_mesh(object, glm::mat4(1.0f), 0.3f, SourceLoc{});
  EXPECT_EQ(object.indices.size() / 3, 64u);

  // Through the scene: "edgelength" 0.3 times Option "displacementedgescale" 2 is 0.6.
  const std::string path = write_ply("square.ply", square);
  const SceneTables t = textured_scene(R"(Option "displacementedgescale" 2
Texture "z" "float" "constant" "float value" 0
Scale 2 2 2
Shape "plymesh" "string filename" ")" + path +
                                       R"(" "texture displacement" "z" "float edgelength" 0.3
)");
  EXPECT_EQ(t.triangles.size(), 64u);
}

// pbrt-v4's vertex order and tie-breaking, worked by hand: triangle (0,0,0), (2,0,0), (0,1,0)
// at edge length 1.5 splits edge 1-2 first (vertex 3), then edge 0-1 of (1, 3, 0) (vertex 4);
// an isosceles triangle whose two longest edges tie splits the second of them.
TEST(Displace, RefinementFollowsPbrtVertexOrder) {
  TriangleMesh m;
  m.P = {{0, 0, 0}, {2, 0, 0}, {0, 1, 0}};
  m.uv = {{0, 0}, {1, 0}, {0, 1}};
  m.N = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  m.indices = {0, 1, 2};
  refine_mesh(m, glm::mat4(1.0f), 1.5f, SourceLoc{});
  EXPECT_EQ(m.indices, (std::vector<unsigned>{0, 4, 3, 4, 1, 3, 3, 2, 0}));
  ASSERT_EQ(m.P.size(), 5u);
  EXPECT_EQ(m.P[3], glm::vec3(1.0f, 0.5f, 0.0f));
  EXPECT_EQ(m.P[4], glm::vec3(1.0f, 0.0f, 0.0f));
  EXPECT_EQ(m.uv[3], glm::vec2(0.5f, 0.5f));
  EXPECT_EQ(m.uv[4], glm::vec2(0.5f, 0.0f));
  EXPECT_EQ(m.N[3], glm::vec3(0, 0, 1));

  // Two equally long longest edges, d01 == d12 == sqrt(5) > d20 = 2: pbrt-v4 splits edge 1-2
  // (d01 > d12 is false), then edge 0-1 of (1, 3, 0).
  TriangleMesh tie;
  tie.P = {{0, 0, 0}, {1, 2, 0}, {2, 0, 0}};
  tie.uv = {{0, 0}, {0, 1}, {1, 0}};
  tie.indices = {0, 1, 2};
  refine_mesh(tie, glm::mat4(1.0f), 2.2f, SourceLoc{});
  EXPECT_EQ(tie.indices, (std::vector<unsigned>{0, 4, 3, 4, 1, 3, 3, 2, 0}));
  ASSERT_EQ(tie.P.size(), 5u);
  EXPECT_EQ(tie.P[3], glm::vec3(1.5f, 1.0f, 0.0f));
  EXPECT_EQ(tie.P[4], glm::vec3(0.5f, 1.0f, 0.0f));
  EXPECT_TRUE(tie.N.empty());  // no normals in, none made up by the refinement
}

// Shared edges are split once: a closed octahedron under a non-uniform scale, refined and
// displaced by fbm noise, stays closed (every edge in exactly two triangles, V - E + F = 2)
// and no two vertices share a position (each split edge's midpoint is one shared vertex).
TEST(Displace, SharedEdgesHaveNoCracks) {
  const std::string path = write_ply("octahedron.ply", octahedron());
  const TriangleMesh out = displaced_first_shape(
      R"(Texture "n" "float" "fbm" "integer octaves" 4
Texture "d" "float" "scale" "texture tex" "n" "float scale" 0.2
Scale 1 2 0.5
Shape "plymesh" "string filename" ")" +
      path + R"(" "texture displacement" "d" "float edgelength" 0.25
)");
  ASSERT_GT(out.indices.size() / 3, 200u);
  const auto uses = edge_uses(out);
  for (const auto& [edge, n] : uses) ASSERT_EQ(n, 2) << edge.first << "-" << edge.second;
  const long V = long(out.P.size()), E = long(uses.size()), F = long(out.indices.size() / 3);
  EXPECT_EQ(V - E + F, 2);
  std::set<std::tuple<float, float, float>> positions;
  for (const glm::vec3& p : out.P) positions.insert({p.x, p.y, p.z});
  EXPECT_EQ(positions.size(), out.P.size());
  double moved = 0.0;  // the noise really displaced it
  const TriangleMesh flat = displaced_first_shape(
      R"(Texture "d" "float" "constant" "float value" 0
Scale 1 2 0.5
Shape "plymesh" "string filename" ")" +
      path + R"(" "texture displacement" "d" "float edgelength" 0.25
)");
  ASSERT_EQ(flat.P.size(), out.P.size());
  for (std::size_t i = 0; i < out.P.size(); ++i) moved += glm::distance(out.P[i], flat.P[i]);
  EXPECT_GT(moved / double(out.P.size()), 1e-3);
}

// pbrt-v4 ComputeNormals sums unit face normals (each face once, whatever its area): a vertex
// shared by a large face in z = 0 and a tiny one in x = 0 gets the bisector of the two.
TEST(Displace, NormalsAreUnweightedFaceAverages) {
  TriangleMesh m;
  m.P = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0.01f, 0}, {0, 0, 0.01f}};
  m.indices = {0, 1, 2, 0, 3, 4};
  compute_vertex_normals(m);
  EXPECT_NEAR(m.N[0].x, std::sqrt(0.5f), 1e-6f);
  EXPECT_NEAR(m.N[0].z, std::sqrt(0.5f), 1e-6f);
  EXPECT_EQ(m.N[1], glm::vec3(0, 0, 1));
  EXPECT_EQ(m.N[4], glm::vec3(1, 0, 0));
}

// The displaced sphere's silhouette is larger: a ray passing 1.1 from the centre misses the
// undisplaced unit sphere and hits the one displaced by 0.25, and a central ray hits 0.25
// earlier. (Rendered tables: build_tables displaces before the BVH.)
TEST(Displace, SilhouetteGrowsInRayCasts) {
  const std::string path = write_ply("sphere32.ply", uv_sphere(1.0f, 32, 16));
  auto tables = [&](float d) {
    return textured_scene("Texture \"d\" \"float\" \"constant\" \"float value\" " +
                          std::to_string(d) + "\nShape \"plymesh\" \"string filename\" \"" +
                          path + "\" \"texture displacement\" \"d\" \"float edgelength\" 10\n");
  };
  const SceneTables plain = tables(0.0f), grown = tables(0.25f);
  const cpu::Ray grazing{{-5.0f, 1.1f, 0.0f}, {1.0f, 0.0f, 0.0f}, 100.0f};
  EXPECT_FALSE(cpu::intersect_closest(plain, grazing).valid());
  EXPECT_TRUE(cpu::intersect_closest(grown, grazing).valid());
  const cpu::Ray central{{-5.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, 100.0f};
  const cpu::Hit a = cpu::intersect_closest(plain, central);
  const cpu::Hit b = cpu::intersect_closest(grown, central);
  ASSERT_TRUE(a.valid() && b.valid());
  EXPECT_NEAR(a.t - b.t, 0.25f, 1e-4f);
  // The displaced mesh's normals were recomputed: the tables carry shading normals.
  EXPECT_TRUE(grown.features & gpu::FEATURE_SHADING_NORMALS);
}

// A texture defined after the Shape is found (pbrt-v4 creates shapes after all textures), and a
// trianglemesh ignores "displacement" as pbrt-v4 does (reported unused: a warning in basalt).
TEST(Displace, LateTextureAndTriangleMeshDisplacement) {
  const std::string path = write_ply("late.ply", grid(1));
  const SceneTables t = textured_scene(
      "Shape \"plymesh\" \"string filename\" \"" + path +
      "\" \"texture displacement\" \"d\" \"float edgelength\" 10\n"
      "Texture \"d\" \"float\" \"constant\" \"float value\" 0.5\n");
  const TriangleMesh g = grid(1);
  ASSERT_EQ(t.vertices.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(t.vertices[i].p_u.z, 0.5f * g.N[i].z, 1e-6f);

  const Scene s = scene_of(R"(Texture "d" "float" "constant" "float value" 0.5
Shape "trianglemesh" "point3 P" [0 0 0 1 0 0 0 1 0] "point2 uv" [0 0 1 0 0 1]
  "texture displacement" "d"
)");
  bool warned = false;
  for (const std::string& w : s.warnings)
    warned = warned || (w.find("t.pbrt:9:3: warning: unused parameter \"texture displacement\"") !=
                        std::string::npos);
  EXPECT_TRUE(warned);
  EXPECT_TRUE(s.shapes.at(0).displacement.empty());
  const SceneTables tm = build_tables(s);
  for (const gpu::Vertex& v : tm.vertices) EXPECT_EQ(v.p_u.z, 0.0f);
}

/// True when the vector \p a holds the same bytes as \p b.
template <class T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// build_tables_releasing_meshes (the command line's, which frees each parsed mesh once it is
// flattened) gives the same tables byte for byte as build_tables, for displaced, plain and
// emissive meshes beside spheres, and leaves the scene's shapes without their meshes.
TEST(Displace, ReleasingMeshesGivesTheSameTables) {
  const std::string path = write_ply("release.ply", uv_sphere(1.0f, 16, 8));
  const std::string body = R"(Texture "d" "float" "constant" "float value" 0.2
Shape "plymesh" "string filename" ")" + path + R"(" "texture displacement" "d" "float edgelength" 0.3
AttributeBegin
  Translate 3 0 0
  AreaLightSource "diffuse" "rgb L" [2 2 2]
  Shape "trianglemesh" "point3 P" [0 0 0 1 0 0 0 1 0 1 1 0] "integer indices" [0 1 2 2 1 3]
AttributeEnd
Shape "sphere" "float radius" 0.5
Shape "plymesh" "string filename" ")" + path + R"("
)";
  const SceneTables kept = build_tables(scene_of(body));
  Scene scene = scene_of(body);
  const SceneTables released = build_tables_releasing_meshes(scene);
  ASSERT_GT(kept.triangles.size(), 2u * 16 * 8);
  EXPECT_TRUE(same_bytes(kept.nodes, released.nodes));
  EXPECT_TRUE(same_bytes(kept.prim_refs, released.prim_refs));
  EXPECT_TRUE(same_bytes(kept.triangles, released.triangles));
  EXPECT_TRUE(same_bytes(kept.vertices, released.vertices));
  EXPECT_TRUE(same_bytes(kept.meshes, released.meshes));
  EXPECT_TRUE(same_bytes(kept.spheres, released.spheres));
  EXPECT_TRUE(same_bytes(kept.lights, released.lights));
  EXPECT_TRUE(same_bytes(kept.light_cdf, released.light_cdf));
  EXPECT_TRUE(same_bytes(kept.materials, released.materials));
  EXPECT_EQ(std::memcmp(&kept.globals, &released.globals, sizeof(gpu::Globals)), 0);
  EXPECT_EQ(kept.features, released.features);
  ASSERT_EQ(scene.shapes.size(), 4u);
  for (const Shape& shape : scene.shapes) {
    EXPECT_TRUE(shape.mesh.P.empty());
    EXPECT_TRUE(shape.mesh.indices.empty());
  }
}

/// The error message of kTexturedHead + \p body, or "" when it builds.
std::string error_of(const std::string& body) { return textured_scene_error(body); }

// Bad input: located errors (file:line:column naming the problem), no scene and no tables.
TEST(Displace, BadInputIsLocated) {
  TriangleMesh no_uv = grid(1);
  no_uv.uv.clear();
  const std::string no_uv_path = write_ply("no_uv.ply", no_uv);
  const std::string path = write_ply("ok.ply", grid(1));
  const std::string tex = "Texture \"d\" \"float\" \"constant\" \"float value\" 0.5\n"
                          "Texture \"s\" \"spectrum\" \"constant\" \"rgb value\" [0.5 0.5 0.5]\n";
  auto shape = [](const std::string& file, const std::string& params) {
    return "Shape \"plymesh\" \"string filename\" \"" + file + "\" " + params + "\n";
  };
  struct Case {
    std::string body;
    int line;           // body line of the error
    std::string token;  // where on it
    std::string says;   // part of the message
  };
  const std::vector<Case> cases = {
      {tex + shape(no_uv_path, "\"texture displacement\" \"d\""), 2, "\"texture displacement\"",
       "needs vertex uvs"},
      {tex + shape(path, "\"texture displacement\" \"nope\""), 2, "\"texture displacement\"",
       "displacement texture \"nope\": no such float texture defined"},
      {tex + shape(path, "\"texture displacement\" \"s\""), 2, "\"texture displacement\"",
       "\"s\" is a spectrum texture; displacement needs a float texture"},
      {tex + shape(path, "\"texture displacement\" \"d\" \"float edgelength\" 0"), 2,
       "\"float edgelength\"", "\"edgelength\" must be positive"},
      {tex + shape(path, "\"texture displacement\" \"d\" \"float edgelength\" -1"), 2,
       "\"float edgelength\"", "\"edgelength\" must be positive"},
      {"Option \"displacementedgescale\" 0\n" + tex + shape(path, "\"texture displacement\" \"d\""),
       0, "0", "must be positive and finite"},
      {"Option \"displacementedgescale\" \"big\"\n", 0, "\"big\"", "expects a number"},
      {tex + shape(path, "\"float displacement\" 0.1"), 2, "\"float displacement\"",
       "has type float; expected texture"},
      {tex + "Shape \"sphere\" \"texture displacement\" \"d\"\n", 2, "\"texture displacement\"",
       "textures are not supported yet"},
  };
  for (const Case& c : cases) {
    const std::string e = error_of(c.body);
    EXPECT_EQ(e.rfind(loc_of(c.body, c.line, c.token) + " error: ", 0), 0u) << e << "\n" << c.body;
    EXPECT_NE(e.find(c.says), std::string::npos) << e;
    EXPECT_THROW(scene_of(c.body), SceneError);  // nothing comes out of the parser
  }
}

// Refinement that cannot finish is a located error, not a crash: too many triangles for the
// limit, found up front from the world-space area (at least area / (sqrt(3) / 4 e^2)) or while
// refining (a sliver whose area promises few), and an edge that float precision cannot shorten
// (vertices near 1e7, 1 apart).
TEST(Displace, RefinementLimitsAreLocatedErrors) {
  const SourceLoc loc{"t.pbrt", 3, 5};
  RefineLimits few;
  few.max_triangles = 100;
  auto error = [&](TriangleMesh m, const glm::mat4& xf, float e) -> std::string {
    try {
      refine_mesh(m, xf, e, loc, few);
    } catch (const SceneError& err) {
      return err.what();
    }
    return "";
  };
  // Unit square under Scale 2: world area 4, at least 4 / (sqrt(3) / 4 0.04^2) = 5774
  // triangles.
  const std::string area = error(grid(1), glm::scale(glm::mat4(1.0f), glm::vec3(2.0f)), 0.04f);
  EXPECT_EQ(area.rfind("t.pbrt:3:5: error: displacement refinement of this mesh would make at "
                       "least 5774 triangles",
                       0),
            0u)
      << area;
  TriangleMesh sliver;
  sliver.P = {{0, 0, 0}, {100, 0, 0}, {0, 0.001f, 0}};
  sliver.uv = {{0, 0}, {1, 0}, {0, 1}};
  sliver.indices = {0, 1, 2};
  const std::string running = error(sliver, glm::mat4(1.0f), 0.5f);
  EXPECT_EQ(running.rfind("t.pbrt:3:5: error: displacement refinement of this mesh exceeds 100 "
                          "triangles",
                          0),
            0u)
      << running;
  EXPECT_EQ(error(sliver, glm::mat4(1.0f), 10.0f), "");  // a coarser refinement fits
  TriangleMesh far;
  far.P = {{1e7f, 0, 0}, {1e7f + 1.0f, 0, 0}, {1e7f, 1, 0}};
  far.uv = {{0, 0}, {1, 0}, {0, 1}};
  far.indices = {0, 1, 2};
  try {
    refine_mesh(far, glm::mat4(1.0f), 1e-3f, loc);
    ADD_FAILURE() << "no error";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("float precision"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace basalt::test
