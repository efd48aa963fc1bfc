// The CPU reference's four-wide tree (cpu/wide_bvh.h): its own oracles. The tree must be the
// binary tree regrouped (same boxes bit for bit, every primitive reference once, the corners
// of the vertex table), and its traversal must give the binary traversal's hits bit for bit:
// t, primitive and barycentrics, and the same any-hit answers, on rays of every kind.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <string>

#include "common/axis_rays.h"
#include "common/test_util.h"
#include "cpu/intersect.h"
#include "cpu/wide_bvh.h"

namespace basalt::test {
namespace {

using cpu::Hit;
using cpu::Ray;

/// Tables of a mesh of n x n quads on a bumpy sphere, 40 spheres and a ground quad, built
/// with leaves of at most max_leaf prims.
SceneTables mesh_scene(int n, int max_leaf) {
  std::string p, idx;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double th = M_PI * j / n, ph = 2.0 * M_PI * i / n;
      const double r = 1.0 + 0.05 * std::sin(7.0 * th) * std::cos(5.0 * ph);
      p += std::to_string(r * std::sin(th) * std::cos(ph)) + " " +
           std::to_string(r * std::cos(th)) + " " + std::to_string(r * std::sin(th) * std::sin(ph)) + " ";
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      idx += std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d) + " " +
             std::to_string(a) + " " + std::to_string(d) + " " + std::to_string(c) + " ";
    }
  std::string s = scene_head("0 0.5 4  0 0 0  0 1 0", 40, 16, 16) +
                  "Material \"diffuse\"\n"
                  "Shape \"trianglemesh\" \"point3 P\" [ " + p + "] \"integer indices\" [ " + idx + "]\n"
                  "Shape \"trianglemesh\" \"point3 P\" [ -3 -1.2 -3  3 -1.2 -3  3 -1.2 3  -3 -1.2 3 ]"
                  " \"integer indices\" [ 0 1 2 0 2 3 ]\n";
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(-1.5f, 1.5f);
  for (int i = 0; i < 40; ++i)
    s += "AttributeBegin\nTranslate " + std::to_string(U(rng)) + " " + std::to_string(U(rng)) + " " +
         std::to_string(U(rng)) + "\nShape \"sphere\" \"float radius\" [ " +
         std::to_string(0.02 + 0.1 * (U(rng) + 1.5f)) + " ]\nAttributeEnd\n";
  Scene scene = load_scene_from_string(s, "wide.pbrt", ".");
  scene.bvh_max_leaf = max_leaf;
  return build_tables(scene);
}

/// Equal bits (NaN-safe comparison of the hit records).
bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(CpuWideBvh, RegroupsTheBinaryTree) {
  for (int max_leaf : {2, 4, 8, 16}) {
    const SceneTables t = mesh_scene(24, max_leaf);
    ASSERT_TRUE(t.cpu_wide);
    const cpu::WideBvh& w = *t.cpu_wide;
    EXPECT_EQ(w.source_nodes, t.nodes.size());
    // Every binary box by its bits, to look slot boxes up.
    std::map<std::string, int> boxes;
    for (const gpu::BvhNode& n : t.nodes) {
      std::string key(24, '\0');
      std::memcpy(key.data(), &n.lo, 12);
      std::memcpy(key.data() + 12, &n.hi, 12);
      ++boxes[key];
    }
    std::vector<int> seen(t.prim_refs.size(), 0);
    std::map<std::uint32_t, int> refs_seen;
    std::vector<int> node_reached(w.nodes.size(), 0);
    struct Item {
      std::uint32_t node;
      int depth;
    };
    std::vector<Item> todo{{0, 0}};
    node_reached[0] = 1;
    while (!todo.empty()) {
      const Item it = todo.back();
      todo.pop_back();
      ASSERT_LE(it.depth, cpu::kWideMaxDepth);
      const cpu::WideNode& n = w.nodes[it.node];
      for (int i = 0; i < 4; ++i) {
        if (n.child[i] == gpu::INVALID_INDEX) {
          for (int k = 0; k < 3; ++k) EXPECT_TRUE(std::isnan(n.lo[k][i]) && std::isnan(n.hi[k][i]));
          continue;
        }
        gpu::BvhNode b{};
        b.lo = glm::vec3(n.lo[0][i], n.lo[1][i], n.lo[2][i]);
        b.hi = glm::vec3(n.hi[0][i], n.hi[1][i], n.hi[2][i]);
        std::string key(24, '\0');
        std::memcpy(key.data(), &b.lo, 12);
        std::memcpy(key.data() + 12, &b.hi, 12);
        EXPECT_TRUE(boxes.count(key)) << "slot box is no binary node's box";
        if (n.count[i] == 0) {
          ASSERT_LT(n.child[i], w.nodes.size());
          EXPECT_EQ(node_reached[n.child[i]]++, 0) << "wide node reached twice";
          todo.push_back({n.child[i], it.depth + 1});
        } else if (n.count[i] & cpu::kWidePacketLeaf) {
          const std::uint32_t np = n.count[i] & ~cpu::kWidePacketLeaf;
          ASSERT_LE(n.child[i] + np, w.packets.size());
          for (std::uint32_t k = n.child[i]; k < n.child[i] + np; ++k)
            for (int lane = 0; lane < 4; ++lane) {
              const cpu::TriPacket& pk = w.packets[k];
              const std::uint32_t ref = pk.ref[lane];
              if (ref == gpu::INVALID_INDEX) {
                EXPECT_TRUE(std::isnan(pk.p[0][0][lane]));
                continue;
              }
              ASSERT_LT(ref, t.triangles.size());
              ++refs_seen[ref];
              const gpu::Triangle& tri = t.triangles[ref];
              const std::uint32_t v[3] = {tri.v0, tri.v1, tri.v2};
              for (int c = 0; c < 3; ++c)
                for (int a = 0; a < 3; ++a) {
                  EXPECT_TRUE(same_bits(pk.p[c][a][lane], t.vertices[v[c]].p_u[a]));
                  // The corner lies in the slot's box.
                  EXPECT_GE(pk.p[c][a][lane], n.lo[a][i]);
                  EXPECT_LE(pk.p[c][a][lane], n.hi[a][i]);
                }
            }
        } else {
          ASSERT_LE(n.child[i] + n.count[i], t.prim_refs.size());
          bool sphere = false;
          for (std::uint32_t k = n.child[i]; k < n.child[i] + n.count[i]; ++k) {
            ++refs_seen[t.prim_refs[k]];
            sphere = sphere || (t.prim_refs[k] & gpu::PRIM_SPHERE_BIT);
          }
          EXPECT_TRUE(sphere) << "a triangle-only leaf not in packets";
        }
      }
    }
    for (std::size_t k = 0; k < node_reached.size(); ++k) EXPECT_EQ(node_reached[k], 1) << k;
    EXPECT_EQ(refs_seen.size(), t.prim_refs.size());
    for (std::uint32_t ref : t.prim_refs) EXPECT_EQ(refs_seen[ref], 1) << ref;
  }
}

TEST(CpuWideBvh, OneLeafTree) {
  const SceneTables t = tables_from_string(
      scene_head("0 0 -3  0 0 0  0 1 0", 40, 8, 8) +
      "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  0 1 0 ]"
      " \"integer indices\" [ 0 1 2 ]\n");
  ASSERT_EQ(t.nodes.size(), 1u);
  ASSERT_TRUE(t.cpu_wide);
  ASSERT_EQ(t.cpu_wide->nodes.size(), 1u);
  EXPECT_EQ(t.cpu_wide->nodes[0].count[0], 1u | cpu::kWidePacketLeaf);
  const Hit h = cpu::intersect_closest(t, Ray{glm::vec3(0.1f, 0, -3), glm::vec3(0, 0, 1), 1e30f});
  ASSERT_TRUE(h.valid());
  EXPECT_EQ(h.t, 3.0f);
}

TEST(CpuWideBvh, SameHitsAsTheBinaryTree) {
  for (int max_leaf : {2, 8}) {
    const SceneTables wide = mesh_scene(60, max_leaf);  // 7200 + 2 triangles
    ASSERT_TRUE(wide.cpu_wide);
    SceneTables binary = wide;
    binary.cpu_wide.reset();
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> U(-1.0f, 1.0f);
    auto dir = [&] {
      glm::vec3 d;
      do d = glm::vec3(U(rng), U(rng), U(rng));
      while (glm::dot(d, d) > 1.0f || glm::dot(d, d) < 1e-4f);
      return d;
    };
    int hits = 0, rays = 0;
    auto check = [&](const Ray& r) {
      ++rays;
      const Hit a = cpu::intersect_closest(wide, r), b = cpu::intersect_closest(binary, r);
      ASSERT_EQ(a.prim, b.prim) << r.o.x << " " << r.o.y << " " << r.o.z << " / " << r.d.x << " "
                                << r.d.y << " " << r.d.z;
      ASSERT_TRUE(same_bits(a.t, b.t) && same_bits(a.b1, b.b1) && same_bits(a.b2, b.b2));
      ASSERT_EQ(cpu::intersect_any(wide, r), cpu::intersect_any(binary, r));
      hits += a.valid();
    };
    for (int i = 0; i < 40000; ++i) {
      // From outside, from inside the mesh, and continuations off the hit surfaces.
      const glm::vec3 o = i % 3 == 0 ? 0.5f * glm::vec3(U(rng), U(rng), U(rng))
                                     : 4.0f * glm::vec3(U(rng), U(rng), U(rng));
      const float tmax = i % 4 == 0 ? 1.0f + 3.0f * (U(rng) + 1.0f) : 3.4e38f;
      Ray r{o, dir(), tmax};
      check(r);
      const Hit h = cpu::intersect_closest(wide, r);
      if (h.valid()) check(Ray{r.o + h.t * r.d, dir(), 3.4e38f});  // from on the surface
      // Axis-aligned and nearly axis-aligned directions: zero, denormal and tiny components.
      if (i % 8 == 0) {
        glm::vec3 d(0.0f);
        d[i / 8 % 3] = U(rng) < 0 ? -1.0f : 1.0f;
        const float tiny[] = {0.0f, -0.0f, 1e-30f, 1e-45f, 1e-19f};
        d[(i / 8 + 1) % 3] = tiny[i / 24 % 5];
        check(Ray{o, d, tmax});
      }
    }
    for (const auto& c : axis_ray_cases()) check(Ray{c.o, c.d, 3.4e38f});
    EXPECT_GT(hits, rays / 4);  // the rays do meet the geometry
  }
}

}  // namespace
}  // namespace basalt::test
