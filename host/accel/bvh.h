// Binned-SAH bounding volume hierarchy over primitive boxes, emitted as the flat node array of
// shaders/shared/layout.h (gpu::BvhNode): node 0 is the root; an interior node has b == 0 and its
// two children at a and a + 1 (children are always allocated as adjacent pairs); a leaf has
// b >= 1 and covers prim_order[a, a + b).
//
// With no primitives there are NO nodes (nodes is empty): a traversal must check the node count
// before reading the root. The tree depth (root at depth 0) is at most kBvhMaxDepth, so a
// traversal stack of kBvhMaxDepth entries always suffices.
#pragma once
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "../../shaders/shared/layout.h"

namespace basalt {

/// Axis-aligned box; empty (lo > hi) when default constructed.
struct Aabb {
  glm::vec3 lo{std::numeric_limits<float>::infinity()};
  glm::vec3 hi{-std::numeric_limits<float>::infinity()};

  /// Grows the box to contain point \p p.
  void extend(const glm::vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  /// Grows the box to contain box \p b.
  void extend(const Aabb& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  glm::vec3 center() const { return 0.5f * (lo + hi); }
  /// Surface area (0 for an empty box).
  float area() const {
    if (empty()) return 0.0f;
    glm::vec3 d = hi - lo;
    return 2.0f * (d.x * d.y + d.y * d.z + d.z * d.x);
  }
};

/// SAH cost constants: a traversal step and a primitive test are taken to cost the same (only
/// their ratio matters; pbrt-v4 7.3.2 uses 1/2 : 1).
inline constexpr float kBvhTraversalCost = 1.0f;
inline constexpr float kBvhIntersectCost = 1.0f;
/// A node with this many primitives or fewer is always a leaf.
inline constexpr std::uint32_t kBvhLeafAlways = 4;
/// Largest leaf the SAH may choose (or that a failed split may leave).
inline constexpr std::uint32_t kBvhMaxLeaf = 8;
/// Below depth kBvhSahDepth splits are binned SAH; deeper nodes are split at the object median
/// (balanced), which bounds the depth by kBvhSahDepth + log2(2^31 / 4) + 1 < kBvhMaxDepth.
inline constexpr std::uint32_t kBvhSahDepth = 32;
inline constexpr std::uint32_t kBvhMaxDepth = 64;

struct BvhOptions {
  enum class Split {
    Sah,     // binned SAH (Wald 2007, "On fast construction of SAH-based BVHs"; pbrt-v4 7.3.2)
    Median,  // object median along the largest centroid extent (for comparisons and tests)
  };
  Split split = Split::Sah;
  /// Bins per axis for the SAH (all three axes are binned); clamped to [2, 64].
  int bins = 32;
  /// Largest leaf the SAH may choose (kBvhMaxLeaf by default); clamped to [2, 16]. Nodes of
  /// up to min(kBvhLeafAlways, max_leaf) primitives are always leaves.
  int max_leaf = int(kBvhMaxLeaf);
  /// Worker threads for the top-level subtrees; 0 = std::thread::hardware_concurrency().
  /// The result does not depend on the thread count.
  int max_threads = 0;
};

struct Bvh {
  std::vector<gpu::BvhNode> nodes;        // empty when there are no primitives
  std::vector<std::uint32_t> prim_order;  // leaf ranges index this; values are input indices
  std::uint32_t depth = 0;                // deepest node (root = 0); 0 also when empty
};

/// \brief Builds a BVH over primitive boxes.
/// \param bounds one box per primitive (finite; degenerate boxes such as points are fine); the
///        split key of a primitive is its box's centre.
/// \return nodes and the primitive order the leaves refer to (a permutation of 0..n-1).
Bvh build_bvh(std::span<const Aabb> bounds, const BvhOptions& options = {});

/// \brief build_bvh over \p bounds, which it empties (and frees) once it has copied them,
/// before its own arrays grow: the same tree, at a lower peak of memory.
Bvh build_bvh(std::vector<Aabb>&& bounds, const BvhOptions& options = {});

/// \brief SAH cost of a built tree (pbrt-v4 7.3.2 / MacDonald & Booth 1990): sum over interior
/// nodes of traversal_cost * A(node) / A(root) plus over leaves of intersect_cost * count *
/// A(leaf) / A(root). 0 for an empty tree.
double bvh_sah_cost(std::span<const gpu::BvhNode> nodes,
                    float traversal_cost = kBvhTraversalCost,
                    float intersect_cost = kBvhIntersectCost);

/// \brief The GPU's wide BVH (gpu::BvhWideNode, docs/path-spec.md 3.1): each node holds the
/// up to four grandchildren of a binary interior node (a child that is a leaf stays one), so a
/// wide level spans two binary levels; child boxes are quantised to 8 bits an axis and rounded
/// outwards, checked with both the rounding of origin + q * scale and that of a fused
/// multiply-add, so the box a shader decodes contains the binary box either way. Node 0 is the
/// root; a binary tree that is one leaf gives a root with one leaf child. Empty for no nodes.
/// \throws std::invalid_argument for a leaf of more than BVH_WIDE_LEAF_MAX prims or a leaf
/// starting at or beyond BVH_WIDE_FIRST_LIMIT.
std::vector<gpu::BvhWideNode> build_wide_bvh(std::span<const gpu::BvhNode> nodes);

/// \brief Box of child \p i of wide node \p n as decoded with separate multiply and add
/// (lo > hi for an empty slot).
Aabb wide_child_box(const gpu::BvhWideNode& n, int i);

}  // namespace basalt
