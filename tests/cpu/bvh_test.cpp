// Binned-SAH BVH: structural invariants, SAH quality against a median split, edge cases, and
// closest hits through a tiny reference traversal against brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "accel/bvh.h"

namespace basalt {
namespace {

struct Tri {
  glm::vec3 p0, p1, p2;
};

Aabb bounds_of(const Tri& t) {
  Aabb b;
  b.extend(t.p0);
  b.extend(t.p1);
  b.extend(t.p2);
  return b;
}

std::vector<Aabb> bounds_of(const std::vector<Tri>& tris) {
  std::vector<Aabb> b;
  for (const Tri& t : tris) b.push_back(bounds_of(t));
  return b;
}

// Random small triangles in [-10, 10]^3 (edge length up to `size`).
std::vector<Tri> random_triangles(std::size_t n, std::uint32_t seed, float size = 1.0f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-10.0f, 10.0f), off(-size, size);
  std::vector<Tri> tris(n);
  for (Tri& t : tris) {
    glm::vec3 c(pos(rng), pos(rng), pos(rng));
    t.p0 = c + glm::vec3(off(rng), off(rng), off(rng));
    t.p1 = c + glm::vec3(off(rng), off(rng), off(rng));
    t.p2 = c + glm::vec3(off(rng), off(rng), off(rng));
  }
  return tris;
}

bool contains(const gpu::BvhNode& n, const Aabb& b) {
  return n.lo.x <= b.lo.x && n.lo.y <= b.lo.y && n.lo.z <= b.lo.z && n.hi.x >= b.hi.x &&
         n.hi.y >= b.hi.y && n.hi.z >= b.hi.z;
}

bool contains(const gpu::BvhNode& n, const gpu::BvhNode& c) {
  Aabb b;
  b.lo = c.lo;
  b.hi = c.hi;
  return contains(n, b);
}

// Checks every structural invariant of the layout.h convention; returns the depth.
std::uint32_t check_invariants(const Bvh& bvh, const std::vector<Aabb>& prims) {
  const std::size_t n = prims.size();
  EXPECT_EQ(bvh.prim_order.size(), n);
  if (n == 0) {
    EXPECT_TRUE(bvh.nodes.empty());
    return 0;
  }
  EXPECT_FALSE(bvh.nodes.empty());
  // Each input primitive appears exactly once in prim_order.
  std::vector<int> seen(n, 0);
  for (std::uint32_t p : bvh.prim_order) {
    EXPECT_LT(p, n);
    if (p < n) ++seen[p];
  }
  for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(seen[i], 1) << "primitive " << i;

  // Walk from the root: every node reached exactly once, leaves cover prim_order exactly once.
  std::vector<int> visited(bvh.nodes.size(), 0), covered(n, 0);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> stack{{0u, 0u}};
  std::uint32_t max_depth = 0;
  while (!stack.empty()) {
    auto [i, depth] = stack.back();
    stack.pop_back();
    max_depth = std::max(max_depth, depth);
    const gpu::BvhNode& node = bvh.nodes[i];
    ++visited[i];
    if (node.b == 0) {
      EXPECT_GE(node.a, 1u);
      EXPECT_LT(node.a + 1, bvh.nodes.size());
      if (node.a + 1 >= bvh.nodes.size()) continue;
      for (std::uint32_t c = node.a; c <= node.a + 1; ++c) {
        EXPECT_TRUE(contains(node, bvh.nodes[c])) << "child " << c << " of " << i;
        stack.push_back({c, depth + 1});
      }
    } else {
      EXPECT_LE(node.a + node.b, n);
      EXPECT_LE(node.b, kBvhMaxLeaf);
      for (std::uint32_t k = node.a; k < node.a + node.b && k < n; ++k) {
        ++covered[k];
        EXPECT_TRUE(contains(node, prims[bvh.prim_order[k]])) << "leaf " << i << " prim " << k;
      }
    }
  }
  for (std::size_t i = 0; i < visited.size(); ++i) EXPECT_EQ(visited[i], 1) << "node " << i;
  for (std::size_t k = 0; k < n; ++k) EXPECT_EQ(covered[k], 1) << "prim_order slot " << k;
  EXPECT_EQ(max_depth, bvh.depth);
  EXPECT_LE(max_depth, kBvhMaxDepth);
  return max_depth;
}

TEST(Bvh, InvariantsOnRandomTriangles) {
  for (std::size_t n : {2u, 5u, 9u, 100u, 5000u}) {
    std::vector<Aabb> prims = bounds_of(random_triangles(n, 7 + static_cast<std::uint32_t>(n)));
    Bvh bvh = build_bvh(prims);
    check_invariants(bvh, prims);
    // The root box is the union of all primitive boxes.
    Aabb all;
    for (const Aabb& b : prims) all.extend(b);
    EXPECT_EQ(bvh.nodes[0].lo, all.lo);
    EXPECT_EQ(bvh.nodes[0].hi, all.hi);
  }
}

TEST(Bvh, Empty) {
  Bvh bvh = build_bvh(std::span<const Aabb>{});
  EXPECT_TRUE(bvh.nodes.empty());
  EXPECT_TRUE(bvh.prim_order.empty());
  EXPECT_EQ(bvh_sah_cost(bvh.nodes), 0.0);
}

TEST(Bvh, OnePrimitive) {
  std::vector<Aabb> prims(1);
  prims[0].lo = glm::vec3(-1, 2, 3);
  prims[0].hi = glm::vec3(1, 4, 3);  // flat box
  Bvh bvh = build_bvh(prims);
  ASSERT_EQ(bvh.nodes.size(), 1u);
  EXPECT_EQ(bvh.nodes[0].a, 0u);
  EXPECT_EQ(bvh.nodes[0].b, 1u);
  EXPECT_EQ(bvh.nodes[0].lo, prims[0].lo);
  EXPECT_EQ(bvh.nodes[0].hi, prims[0].hi);
  EXPECT_EQ(bvh.prim_order, std::vector<std::uint32_t>{0u});
}

TEST(Bvh, IdenticalPrimitives) {
  // Coinciding centroids: no binned split exists; the build halves the range down to leaves.
  for (std::size_t n : {3u, 8u, 9u, 1000u}) {
    Aabb box;
    box.lo = glm::vec3(0.0f);
    box.hi = glm::vec3(1.0f);
    std::vector<Aabb> prims(n, box);
    Bvh bvh = build_bvh(prims);
    std::uint32_t depth = check_invariants(bvh, prims);
    EXPECT_LE(depth, 10u);
  }
  // Points (zero-area boxes, zero-area root) at one place.
  Aabb point;
  point.lo = point.hi = glm::vec3(5.0f);
  std::vector<Aabb> points(100, point);
  check_invariants(build_bvh(points), points);
}

TEST(Bvh, DepthBoundedOnPathologicalInput) {
  // Exponentially spaced boxes: SAH peels off one primitive per level; the depth cap applies.
  std::vector<Aabb> prims;
  for (int i = 0; i < 120; ++i) {
    Aabb b;
    float x = std::ldexp(1.0f, i);
    b.lo = glm::vec3(x, 0, 0);
    b.hi = glm::vec3(x, 1, 1);
    prims.push_back(b);
  }
  check_invariants(build_bvh(prims), prims);
}

TEST(Bvh, SahBeatsMedianOnClusteredInput) {
  // A few dense clusters of small triangles far apart, of very different sizes: the object
  // median cuts through clusters, the SAH separates them.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Tri> tris;
  const glm::vec3 centres[] = {{-50, 0, 0}, {40, 30, 0}, {0, -60, 20}, {70, 70, 70}};
  const int counts[] = {3000, 300, 50, 1200};
  for (int c = 0; c < 4; ++c) {
    for (int i = 0; i < counts[c]; ++i) {
      glm::vec3 p = centres[c] + 2.0f * glm::vec3(u(rng), u(rng), u(rng));
      tris.push_back({p, p + 0.05f * glm::vec3(u(rng), u(rng), u(rng)),
                      p + 0.05f * glm::vec3(u(rng), u(rng), u(rng))});
    }
  }
  std::vector<Aabb> prims = bounds_of(tris);
  Bvh sah = build_bvh(prims);
  BvhOptions median_options;
  median_options.split = BvhOptions::Split::Median;
  Bvh median = build_bvh(prims, median_options);
  check_invariants(sah, prims);
  check_invariants(median, prims);
  double c_sah = bvh_sah_cost(sah.nodes), c_median = bvh_sah_cost(median.nodes);
  EXPECT_LT(c_sah, c_median);
  // And on uniformly random input the SAH build is no worse than the median split.
  std::vector<Aabb> uniform = bounds_of(random_triangles(4000, 11, 0.3f));
  EXPECT_LT(bvh_sah_cost(build_bvh(uniform).nodes),
            bvh_sah_cost(build_bvh(uniform, median_options).nodes));
}

TEST(Bvh, SameResultWithAnyThreadCount) {
  std::vector<Aabb> prims = bounds_of(random_triangles(60000, 5));
  BvhOptions one, four;
  one.max_threads = 1;
  four.max_threads = 4;
  Bvh a = build_bvh(prims, one), b = build_bvh(prims, four);
  check_invariants(b, prims);
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  EXPECT_EQ(0, std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(gpu::BvhNode)));
  EXPECT_EQ(a.prim_order, b.prim_order);
  EXPECT_EQ(a.depth, b.depth);
}


// The overload that takes the boxes by value (the table build's, which frees them before the
// build's arrays grow) builds the same tree and leaves the vector empty.
TEST(Bvh, ConsumingOverloadBuildsTheSameTree) {
  std::vector<Aabb> prims = bounds_of(random_triangles(60000, 6));
  Bvh a = build_bvh(prims);
  std::vector<Aabb> moved = prims;
  Bvh b = build_bvh(std::move(moved));
  EXPECT_TRUE(moved.empty());
  EXPECT_EQ(moved.capacity(), 0u);
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  EXPECT_EQ(0, std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(gpu::BvhNode)));
  EXPECT_EQ(a.prim_order, b.prim_order);
  check_invariants(b, prims);
}
// ---- reference traversal -------------------------------------------------------------------

struct Ray {
  glm::dvec3 o, d;
};

struct Hit {
  double t = std::numeric_limits<double>::infinity();
  std::uint32_t prim = 0xffffffffu;
};

// Moller-Trumbore in double; both searches below use it, so they must agree exactly.
std::optional<double> intersect(const Ray& r, const Tri& tri) {
  glm::dvec3 p0(tri.p0), p1(tri.p1), p2(tri.p2);
  glm::dvec3 e1 = p1 - p0, e2 = p2 - p0, pv = glm::cross(r.d, e2);
  double det = glm::dot(e1, pv);
  if (det == 0.0) return std::nullopt;
  glm::dvec3 tv = r.o - p0;
  double u = glm::dot(tv, pv) / det;
  if (u < 0.0 || u > 1.0) return std::nullopt;
  glm::dvec3 qv = glm::cross(tv, e1);
  double v = glm::dot(r.d, qv) / det;
  if (v < 0.0 || u + v > 1.0) return std::nullopt;
  double t = glm::dot(e2, qv) / det;
  if (!(t > 0.0)) return std::nullopt;
  return t;
}

void consider(Hit& best, double t, std::uint32_t prim) {
  if (t < best.t || (t == best.t && prim < best.prim)) best = {t, prim};
}

Hit brute_force(const Ray& r, const std::vector<Tri>& tris) {
  Hit best;
  for (std::uint32_t i = 0; i < tris.size(); ++i)
    if (auto t = intersect(r, tris[i])) consider(best, *t, i);
  return best;
}

// Slab test in double with a slightly grown box (this checks the tree, not box robustness).
bool hits_box(const Ray& r, const gpu::BvhNode& n, double t_max) {
  double t0 = 0.0, t1 = t_max;
  for (int a = 0; a < 3; ++a) {
    double pad = 1e-5 * (1.0 + std::abs(n.lo[a]) + std::abs(n.hi[a]));
    double inv = 1.0 / r.d[a];
    double tn = (n.lo[a] - pad - r.o[a]) * inv, tf = (n.hi[a] + pad - r.o[a]) * inv;
    if (tn > tf) std::swap(tn, tf);
    t0 = std::max(t0, tn);
    t1 = std::min(t1, tf);
    if (t0 > t1) return false;
  }
  return true;
}

Hit traverse(const Ray& r, const Bvh& bvh, const std::vector<Tri>& tris) {
  Hit best;
  if (bvh.nodes.empty()) return best;
  std::vector<std::uint32_t> stack{0};
  while (!stack.empty()) {
    const gpu::BvhNode& n = bvh.nodes[stack.back()];
    stack.pop_back();
    if (!hits_box(r, n, best.t)) continue;
    if (n.b == 0) {
      stack.push_back(n.a);
      stack.push_back(n.a + 1);
    } else {
      for (std::uint32_t k = n.a; k < n.a + n.b; ++k) {
        std::uint32_t prim = bvh.prim_order[k];
        if (auto t = intersect(r, tris[prim])) consider(best, *t, prim);
      }
    }
  }
  return best;
}

TEST(Bvh, ClosestHitMatchesBruteForce) {
  std::vector<Tri> tris = random_triangles(3000, 21, 1.5f);
  Bvh bvh = build_bvh(bounds_of(tris));
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    Ray r;
    r.o = glm::dvec3(12 * u(rng), 12 * u(rng), 12 * u(rng));
    // Aim at a random triangle for half the rays so that many of them hit.
    if (i % 2 == 0) {
      const Tri& t = tris[rng() % tris.size()];
      r.d = (glm::dvec3(t.p0) + glm::dvec3(t.p1) + glm::dvec3(t.p2)) / 3.0 - r.o;
    } else {
      r.d = glm::dvec3(u(rng), u(rng), u(rng));
      if (i % 10 == 1) r.d.y = 0.0;  // axis-parallel components
    }
    Hit want = brute_force(r, tris), got = traverse(r, bvh, tris);
    EXPECT_EQ(got.prim, want.prim) << "ray " << i;
    EXPECT_EQ(got.t, want.t) << "ray " << i;
    hits += want.prim != 0xffffffffu;
  }
  EXPECT_GT(hits, 900);
}

TEST(Bvh, SahCostOfLeafIsItsCount) {
  std::vector<Aabb> prims(3);
  for (int i = 0; i < 3; ++i) {
    prims[i].lo = glm::vec3(static_cast<float>(i), 0, 0);
    prims[i].hi = glm::vec3(static_cast<float>(i) + 1, 1, 1);
  }
  Bvh bvh = build_bvh(prims);
  ASSERT_EQ(bvh.nodes.size(), 1u);
  EXPECT_DOUBLE_EQ(bvh_sah_cost(bvh.nodes), 3.0);
}

// The wide BVH (build_wide_bvh): the GPU's tree, so its own oracle (the twins' comparison cannot
// see a box that is too small if both sides used it; the CPU reference uses the binary tree).
// Walks it from the root and checks: every wide node reached once; every prim_order slot in
// exactly one leaf; every child's decoded box, with separate or fused rounding, contains the
// boxes of all prims below it; a wide level spans two binary levels (depth <= 32, so the
// shader's stack of BVH_WIDE_STACK = 3 x 32 entries suffices); and the quantisation is tight
// (each decoded bound within two steps of the exact one). Sets growth to the total decoded
// surface area over the exact children's.
void check_wide(const Bvh& bvh, const std::vector<Aabb>& prims, double& growth) {
  growth = 1.0;
  const std::vector<gpu::BvhWideNode> wide = build_wide_bvh(bvh.nodes);
  if (bvh.nodes.empty()) {
    EXPECT_TRUE(wide.empty());
    return;
  }
  std::vector<int> visited(wide.size(), 0), covered(prims.size(), 0);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> stack{{0u, 1u}};
  double area_wide = 0.0, area_exact = 0.0;
  std::uint32_t max_depth = 0;
  while (!stack.empty()) {
    const auto [w, depth] = stack.back();
    stack.pop_back();
    max_depth = std::max(max_depth, depth);
    ++visited[w];
    const gpu::BvhWideNode& n = wide[w];
    for (int i = 0; i < 4; ++i) {
      const std::uint32_t c = n.child[i];
      if (c == gpu::INVALID_INDEX) continue;
      // The prims below child i.
      Aabb exact;
      std::vector<std::uint32_t> below;
      std::vector<std::uint32_t> todo{c};
      while (!todo.empty()) {
        const std::uint32_t x = todo.back();
        todo.pop_back();
        if (x & gpu::BVH_WIDE_LEAF) {
          const std::uint32_t first = x & (gpu::BVH_WIDE_FIRST_LIMIT - 1u);
          const std::uint32_t count = ((x >> 26) & 31u) + 1u;
          for (std::uint32_t k = first; k < first + count; ++k) below.push_back(k);
        } else {
          for (int j = 0; j < 4; ++j)
            if (wide[x].child[j] != gpu::INVALID_INDEX) todo.push_back(wide[x].child[j]);
        }
      }
      for (std::uint32_t k : below) {
        ASSERT_LT(k, prims.size());
        exact.extend(prims[bvh.prim_order[k]]);
      }
      const Aabb box = wide_child_box(n, i);
      for (int k = 0; k < 3; ++k) {
        const float scale = std::bit_cast<float>(((n.exponents >> (8 * k)) & 0xffu) << 23);
        const float qlo = float((n.qlo[k] >> (8 * i)) & 0xffu);
        const float qhi = float((n.qhi[k] >> (8 * i)) & 0xffu);
        const float fused_lo = std::fma(qlo, scale, n.origin[k]);
        const float fused_hi = std::fma(qhi, scale, n.origin[k]);
        EXPECT_LE(box.lo[k], exact.lo[k]) << "node " << w << " child " << i << " axis " << k;
        EXPECT_GE(box.hi[k], exact.hi[k]) << "node " << w << " child " << i << " axis " << k;
        EXPECT_LE(fused_lo, exact.lo[k]) << "node " << w << " child " << i << " axis " << k;
        EXPECT_GE(fused_hi, exact.hi[k]) << "node " << w << " child " << i << " axis " << k;
        if (std::isfinite(box.hi[k])) {
          EXPECT_GE(box.lo[k], exact.lo[k] - 2.0f * scale) << "node " << w << " child " << i;
          EXPECT_LE(box.hi[k], exact.hi[k] + 2.0f * scale) << "node " << w << " child " << i;
        }
      }
      area_wide += box.area();
      area_exact += exact.area();
      if (c & gpu::BVH_WIDE_LEAF) {
        for (std::uint32_t k : below) ++covered[k];
      } else {
        ASSERT_LT(c, wide.size());
        stack.push_back({c, depth + 1});
      }
    }
  }
  for (std::size_t i = 0; i < visited.size(); ++i) EXPECT_EQ(visited[i], 1) << "wide node " << i;
  for (std::size_t k = 0; k < covered.size(); ++k) EXPECT_EQ(covered[k], 1) << "slot " << k;
  EXPECT_LE(max_depth, (bvh.depth + 1) / 2 + 1);
  EXPECT_LE(3 * max_depth, gpu::BVH_WIDE_STACK);
  growth = area_exact > 0.0 ? area_wide / area_exact : 1.0;
}

TEST(WideBvh, ContainsEveryPrimAndIsTight) {
  for (std::size_t n : {1u, 2u, 3u, 5u, 9u, 100u, 5000u}) {
    SCOPED_TRACE(n);
    std::vector<Aabb> prims = bounds_of(random_triangles(n, 11 + static_cast<std::uint32_t>(n)));
    double growth = 0.0;
    check_wide(build_bvh(prims), prims, growth);
    // 8-bit boxes: the decoded boxes' area is within a few percent of the exact ones.
    if (n >= 100) {
      EXPECT_LT(growth, 1.1);
    }
  }
  std::vector<Aabb> none;
  double growth = 0.0;
  check_wide(build_bvh(none), none, growth);
}

TEST(WideBvh, HugeTinyAndExtremeScales) {
  // Boxes spaced 2^0 .. 2^119 apart (each wide node spans up to 2^119), a mix of 1e-30 boxes at
  // the origin and 1e30 walls, and boxes at +-3e38 (the decoded upper bound may overflow to
  // infinity, which still contains them).
  std::vector<Aabb> exp_spaced, mixed, extreme;
  for (int i = 0; i < 120; ++i) {
    Aabb b;
    b.lo = glm::vec3(std::ldexp(1.0f, i), 0, 0);
    b.hi = glm::vec3(std::ldexp(1.0f, i), 1, 1);
    exp_spaced.push_back(b);
  }
  std::vector<Tri> tiny = random_triangles(200, 3, 1.0f);
  for (std::size_t i = 0; i < tiny.size(); ++i) {
    const float s = i % 2 ? 1e-30f : 1e30f;
    Aabb b = bounds_of(tiny[i]);
    b.lo *= s;
    b.hi *= s;
    mixed.push_back(b);
  }
  for (int i = 0; i < 50; ++i) {
    Aabb b;
    const float x = (i % 2 ? 3e38f : -3e38f) * (1.0f - 0.001f * float(i));
    b.lo = glm::vec3(x, -3e38f, float(i));
    b.hi = glm::vec3(x, 3.4e38f, float(i) + 1e-30f);
    extreme.push_back(b);
  }
  double growth = 0.0;
  for (auto* prims : {&exp_spaced, &mixed, &extreme}) check_wide(build_bvh(*prims), *prims, growth);
}

TEST(WideBvh, OversizedLeafIsAClearError) {
  std::vector<gpu::BvhNode> nodes(1);
  nodes[0].lo = glm::vec3(0.0f);
  nodes[0].hi = glm::vec3(1.0f);
  nodes[0].a = 0;
  nodes[0].b = gpu::BVH_WIDE_LEAF_MAX + 1;
  try {
    build_wide_bvh(nodes);
    ADD_FAILURE() << "no error for a leaf of 33 prims";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("at most 32 prims a leaf"), std::string::npos) << e.what();
  }
  nodes[0].b = gpu::BVH_WIDE_LEAF_MAX;
  EXPECT_EQ(build_wide_bvh(nodes).size(), 1u);
}

}  // namespace
}  // namespace basalt
