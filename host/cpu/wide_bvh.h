// The CPU reference's own four-wide BVH: the binary tree's nodes regrouped four children a
// node with exact float boxes, laid out for a four-lane slab test (docs/path-spec.md 3.2).
// Built by the CPU reference from the binary nodes alone; the GPU's quantised wide tree
// (host/accel build_wide_bvh) is a separate construction, so each checks the other. Four-wide
// nodes tested in SIMD lanes after Dammertz, Hanika & Keller 2008 ("Shallow bounding volume
// hierarchies for fast SIMD ray tracing of incoherent rays") and Wald, Benthin & Boulos 2008
// ("Getting rid of packets"); here made by collapsing every other level of the binary tree.
#pragma once
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "scene/tables.h"

namespace basalt::cpu {

/// Most wide levels below the root (a wide level spans two binary ones; host/accel/bvh.h
/// bounds the binary depth by 64).
inline constexpr int kWideMaxDepth = 33;

/// Marks a leaf slot of triangle packets (WideNode::count).
inline constexpr std::uint32_t kWidePacketLeaf = 0x80000000u;

/// One node of four child slots, structure of arrays: lo[axis][slot], hi[axis][slot].
/// count[i] == 0: an interior child, wide node child[i]. count[i] = n | kWidePacketLeaf: a leaf
/// of triangles only, packets [child[i], child[i] + n). Other count[i] > 0: a leaf holding a
/// sphere, prim_refs [child[i], child[i] + count[i]). An empty slot has NaN bounds (every
/// comparison of the slab test is false, so it is never entered) and child INVALID_INDEX.
struct alignas(64) WideNode {
  float lo[3][4];
  float hi[3][4];
  std::uint32_t child[4];
  std::uint32_t count[4];
};
static_assert(sizeof(WideNode) == 128, "two cache lines a node");

/// Four triangles of one leaf, in prim_refs order, for a four-lane triangle test: corner v's
/// coordinate a of lane i is p[v][a][i]. An unused lane has NaN corners (the test misses) and
/// ref INVALID_INDEX.
struct alignas(16) TriPacket {
  float p[3][3][4];
  std::uint32_t ref[4];
};
static_assert(sizeof(TriPacket) == 160, "packed");

/// The tree: node 0 is the root. `source_nodes` is the size of the binary node array it was
/// built from (a check against tables edited after the build).
struct WideBvh {
  std::vector<WideNode> nodes;
  std::vector<TriPacket> packets;  // the triangle leaves' corners, copied from the tables
  std::size_t source_nodes = 0;
};

/// \brief Regroups the binary tree \p nodes (host/accel/bvh.h layout, non-empty) so that each
///        wide node holds the up to four grandchildren of a binary interior node (a child that
///        is a leaf stays one slot); a binary tree that is one leaf gives a root with one leaf
///        slot. Boxes are the binary nodes' own, bit for bit. A leaf of triangles only
///        becomes packets of the corners from \p t's vertex table: a table edited afterwards
///        needs the tree built again.
/// \throws std::invalid_argument for an empty or malformed array, or a tree deeper than
///         kWideMaxDepth wide levels.
std::shared_ptr<const WideBvh> build_cpu_wide_bvh(const SceneTables& t);

/// \brief Bytes of the tree's arrays (counted by table_bytes).
std::uint64_t wide_bvh_bytes(const WideBvh& w);

}  // namespace basalt::cpu
