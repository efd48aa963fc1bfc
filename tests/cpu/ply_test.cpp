// PLY reader: ascii and binary bodies, polygons, triangle strips, truncation, and the Igea model.
#include "common/scratch_dir.h"
#include "scene/ply.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include "scene/scene.h"

namespace fs = std::filesystem;
using basalt::load_ply;
using basalt::SceneError;
using basalt::TriangleMesh;

namespace {

// This process's directory under the test temp dir: ctest runs tests in parallel processes,
// and two of them writing the same file name in one directory read each other's bytes.
fs::path ply_dir() { return basalt::test::scratch_dir("ply"); }

// Writes bytes to a fresh file under ply_dir() and returns its path.
std::string write_temp(const std::string& name, const std::string& bytes) {
  fs::path d = ply_dir();
  fs::create_directories(d);
  fs::path p = d / name;
  std::ofstream(p, std::ios::binary) << bytes;
  return p.string();
}

// The what() of the error load_ply throws for path ("" if none).
std::string error_of(const std::string& path) {
  try {
    load_ply(path);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

// Appends the bytes of v in little (or big) endian order.
template <typename T>
void put(std::string& out, T v, bool big = false) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));  // the test machines are little endian
  if (big)
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  out.append(b, sizeof(T));
}

// A square (quad) and a triangle over 5 vertices with normals and uv, in the given format.
std::string quad_and_triangle(const std::string& format) {
  std::string h = "ply\r\nformat " + format +
                  " 1.0\r\ncomment made by a test\r\n"
                  "element vertex 5\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
                  "property float nx\r\nproperty float ny\r\nproperty float nz\r\n"
                  "property float s\r\nproperty float t\r\n"
                  "element material 1\r\nproperty list uchar float junk\r\n"
                  "element face 2\r\nproperty uchar flags\r\n"
                  "property list uchar int vertex_indices\r\nend_header\r\n";
  float v[5][8] = {{0, 0, 0, 0, 0, 1, 0, 0},
                   {1, 0, 0, 0, 0, 1, 1, 0},
                   {1, 1, 0, 0, 0, 1, 1, 1},
                   {0, 1, 0, 0, 0, 1, 0, 1},
                   {2, 0, 0, 0, 0, 1, 0.5f, 0.5f}};
  if (format == "ascii") {
    for (auto& r : v) {
      for (float x : r) h += std::to_string(x) + " ";
      h += "\n";
    }
    h += "2 1.5 2.5\n7 4 0 1 2 3\n0 3 1 4 2\n";
    return h;
  }
  bool big = format == "binary_big_endian";
  for (auto& r : v)
    for (float x : r) put(h, x, big);
  put<std::uint8_t>(h, 2);
  put(h, 1.5f, big);
  put(h, 2.5f, big);
  put<std::uint8_t>(h, 7);
  put<std::uint8_t>(h, 4);
  for (int i : {0, 1, 2, 3}) put(h, std::int32_t(i), big);
  put<std::uint8_t>(h, 0);
  put<std::uint8_t>(h, 3);
  for (int i : {1, 4, 2}) put(h, std::int32_t(i), big);
  return h;
}

}  // namespace

TEST(Ply, AsciiAndBinaryAgree) {
  for (const char* format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    SCOPED_TRACE(format);
    TriangleMesh m = load_ply(write_temp(std::string(format) + ".ply", quad_and_triangle(format)));
    ASSERT_EQ(m.P.size(), 5u);
    EXPECT_EQ(m.P[2], glm::vec3(1, 1, 0));
    ASSERT_EQ(m.N.size(), 5u);
    EXPECT_EQ(m.N[4], glm::vec3(0, 0, 1));
    ASSERT_EQ(m.uv.size(), 5u);  // from s, t
    EXPECT_EQ(m.uv[4], glm::vec2(0.5f, 0.5f));
    // The quad is fanned around its first vertex: (0 1 2) (0 2 3); then the triangle.
    EXPECT_EQ(m.indices, (std::vector<unsigned>{0, 1, 2, 0, 2, 3, 1, 4, 2}));
  }
}

TEST(Ply, TriangleStrips) {
  std::string h =
      "ply\nformat ascii 1.0\nelement vertex 7\nproperty float x\nproperty float y\n"
      "property float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n1 1 0\n0 0 1\n1 0 1\n0 1 1\n"
      // run 1: 0 1 2 3 -> (0 1 2) (2 1 3); run 2 repeats 6 to restart the winding:
      // (4 5 6) then (6 5 6) and (6 6 4) are degenerate and dropped.
      "12 0 1 2 3 -1 4 5 6 6 4 -1 -1\n";
  TriangleMesh m = load_ply(write_temp("strips.ply", h));
  EXPECT_TRUE(m.N.empty());
  EXPECT_TRUE(m.uv.empty());
  EXPECT_EQ(m.indices, (std::vector<unsigned>{0, 1, 2, 2, 1, 3, 4, 5, 6}));
}

TEST(Ply, ErrorsNameTheFile) {
  std::string good = quad_and_triangle("binary_little_endian");
  std::string p = write_temp("truncated.ply", good.substr(0, good.size() - 7));
  EXPECT_EQ(error_of(p), p + ": error: truncated PLY file: the data ends early in element 'face' "
                             "(item 2 of 2)");
  std::string a = quad_and_triangle("ascii");
  p = write_temp("truncated_ascii.ply", a.substr(0, a.find("7 4 0")));
  EXPECT_EQ(error_of(p), p + ": error: truncated PLY file: the data ends early in element 'face' "
                             "(item 1 of 2)");
  // A count beyond the table limit is refused from the header, before anything is allocated
  // (issue 11, defect 10); one beyond the file's size is truncation, found from the header too.
  p = write_temp("huge.ply",
                 "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
                 "property float x\nproperty float y\nproperty float z\nend_header\n");
  EXPECT_EQ(error_of(p), p + ": error: the header declares 1000000000000 vertex elements; their "
                             "table needs more than the 4294967296 bytes the renderer takes");
  p = write_temp("long.ply",
                 "ply\nformat binary_little_endian 1.0\nelement vertex 1000000\n"
                 "property float x\nproperty float y\nproperty float z\nend_header\n");
  EXPECT_EQ(error_of(p), p + ": error: truncated PLY file: the header's element counts need at "
                             "least 12000000 bytes of data, the file has 0");
  p = write_temp("noheader.ply", "ply\nformat ascii 1.0\nelement vertex 1\n");
  EXPECT_EQ(error_of(p), p + ": error: truncated PLY file: no end_header");
  p = write_temp("notply.ply", "solid cube\n");
  EXPECT_EQ(error_of(p), p + ": error: not a PLY file (no 'ply' magic line)");
  p = write_temp("range.ply",
                 "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                 "property float z\nelement face 1\nproperty list uchar uint vertex_indices\n"
                 "end_header\n0 0 0 1 0 0 0 1 0 3 0 1 3\n");
  EXPECT_EQ(error_of(p), p + ": error: vertex index 3 out of range (the file has 3 vertices)");
  p = (ply_dir() / "absent.ply").string();
  EXPECT_EQ(error_of(p), p + ": error: cannot read PLY file: No such file or directory");
  p = ply_dir().string();
  EXPECT_EQ(error_of(p), p + ": error: cannot read PLY file: is a directory");
}

// Issue 11, defects 3, 9 and 10: the header's counts are checked before the body is read, an
// element without properties costs nothing whatever its count, and ascii integers outside
// their type's range (1e30, nan) are errors, never casts.
TEST(Ply, HeaderCountsAndAsciiRangesAreCheckedFirst) {
  const std::string tri =
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  // 2^63 - 1 items of nothing: read at once (it looped for hours).
  std::string p = write_temp("noprop.ply", "ply\nformat ascii 1.0\nelement junk 9223372036854775807\n" +
                                               tri + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(load_ply(p).indices.size(), 3u);
  for (const char* bad : {"3 0 1 1e30\n", "3 0 1 nan\n", "nan 0 1 2\n", "3 0 1 -inf\n",
                          "3 0 1 2.5\n", "3 0 1 4294967296\n", "300 0 1 2\n"}) {
    p = write_temp("range.ply", "ply\nformat ascii 1.0\n" + tri + "0 0 0\n1 0 0\n0 1 0\n" + bad);
    EXPECT_NE(error_of(p).find("is not an integer in the range of its type"), std::string::npos)
        << bad << ": " << error_of(p);
  }
  // A face count whose table exceeds the renderer's limit: refused from the header (lavapipe's
  // 128 MiB takes 8388608 triangles of 16 bytes).
  p = write_temp("many.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                             "property float x\nproperty float y\nproperty float z\n"
                             "element face 20000000\nproperty list uchar int vertex_indices\n"
                             "end_header\n");
  try {
    load_ply(p, nullptr, std::uint64_t(1) << 27);
    ADD_FAILURE() << "20M faces accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("declares 20000000 face elements"), std::string::npos)
        << e.what();
  }
  // -1 strip restarts stay legal in files that declare unsigned lists.
  p = write_temp("ustrip.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                               "property float y\nproperty float z\nelement tristrips 1\n"
                               "property list uchar uint vertex_indices\nend_header\n"
                               "0 0 0\n1 0 0\n0 1 0\n1 1 0\n5 0 1 2 -1 3\n");
  EXPECT_EQ(load_ply(p).indices.size(), 3u);
}

TEST(Ply, ShortFacesAreSkippedWithAWarning) {
  std::string h =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 2\nproperty list uchar int vertex_index\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n2 0 1\n3 0 1 2\n";
  std::vector<std::string> warnings;
  TriangleMesh m = load_ply(write_temp("short.ply", h), &warnings);
  EXPECT_EQ(m.indices, (std::vector<unsigned>{0, 1, 2}));
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "skipped 1 face(s) with fewer than 3 vertices");
}

TEST(Ply, IgeaTriangleStrips) {
  // The standard test meshes sit in shared/models beside the checkout (README); a missing
  // documented input fails the test.
  const std::string path = std::string(BASALT_SOURCE_DIR) + "/../shared/models/igea.ply";
  ASSERT_TRUE(fs::exists(path)) << path << " is missing: shared/models must sit beside the checkout";
  TriangleMesh m = load_ply(path);
  EXPECT_EQ(m.P.size(), 134345u);
  EXPECT_TRUE(m.N.empty());
  ASSERT_EQ(m.indices.size() % 3, 0u);
  // 268,686 = 2 * 134,345 - 4 non-degenerate triangles remain of the 373,830 strip indices.
  EXPECT_EQ(m.indices.size() / 3, 268686u);
  // Consistent winding: every edge used by two triangles is used once in each direction.
  std::size_t same_direction = 0;
  std::vector<std::pair<std::uint64_t, int>> edges;
  for (std::size_t t = 0; t < m.indices.size(); t += 3)
    for (int e = 0; e < 3; ++e) {
      std::uint64_t a = m.indices[t + e], b = m.indices[t + (e + 1) % 3];
      edges.push_back({(std::min(a, b) << 32) | std::max(a, b), a < b ? 1 : -1});
    }
  std::sort(edges.begin(), edges.end());
  for (std::size_t i = 0; i + 1 < edges.size(); ++i)
    if (edges[i].first == edges[i + 1].first && edges[i].second == edges[i + 1].second)
      ++same_direction;
  EXPECT_EQ(same_direction, 0u);
}
