// The CPU reference's four-wide BVH (docs/path-spec.md 3.2): the binary tree regrouped.
#include "cpu/wide_bvh.h"

#include <limits>
#include <stdexcept>

namespace basalt::cpu {
namespace {

/// Writes binary node \p b's box into slot \p i of \p w.
void set_slot_box(WideNode& w, int i, const gpu::BvhNode& b) {
  for (int k = 0; k < 3; ++k) {
    w.lo[k][i] = b.lo[k];
    w.hi[k][i] = b.hi[k];
  }
}

/// A wide node with four empty slots (NaN bounds: the slab test never enters them).
WideNode empty_node() {
  WideNode w;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 4; ++i) w.lo[k][i] = w.hi[k][i] = nan;
  for (int i = 0; i < 4; ++i) {
    w.child[i] = gpu::INVALID_INDEX;
    w.count[i] = 0;
  }
  return w;
}

/// A packet of four unused lanes.
TriPacket empty_packet() {
  TriPacket p;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (auto& corner : p.p)
    for (auto& axis : corner)
      for (float& x : axis) x = nan;
  for (std::uint32_t& r : p.ref) r = gpu::INVALID_INDEX;
  return p;
}

}  // namespace

std::shared_ptr<const WideBvh> build_cpu_wide_bvh(const SceneTables& t) {
  const std::span<const gpu::BvhNode> nodes = t.nodes;
  if (nodes.empty()) throw std::invalid_argument("build_cpu_wide_bvh: no nodes");
  auto out = std::make_shared<WideBvh>();
  // A leaf slot: packets when it holds triangles only, else its prim_refs range.
  auto set_leaf = [&](WideNode& node, int i, const gpu::BvhNode& b) {
    bool triangles_only = true;
    for (std::uint32_t k = b.a; k < b.a + b.b; ++k)
      triangles_only = triangles_only && !(t.prim_refs.at(k) & gpu::PRIM_SPHERE_BIT);
    if (!triangles_only) {
      node.child[i] = b.a;
      node.count[i] = b.b;
      return;
    }
    node.child[i] = std::uint32_t(out->packets.size());
    node.count[i] = ((b.b + 3) / 4) | kWidePacketLeaf;
    for (std::uint32_t k = b.a; k < b.a + b.b; k += 4) {
      TriPacket pk = empty_packet();
      for (std::uint32_t lane = 0; lane < 4 && k + lane < b.a + b.b; ++lane) {
        const std::uint32_t ref = t.prim_refs[k + lane];
        const gpu::Triangle& tri = t.triangles.at(ref);
        const std::uint32_t v[3] = {tri.v0, tri.v1, tri.v2};
        for (int c = 0; c < 3; ++c)
          for (int a = 0; a < 3; ++a) pk.p[c][a][lane] = t.vertices.at(v[c]).p_u[a];
        pk.ref[lane] = ref;
      }
      out->packets.push_back(pk);
    }
  };
  out->source_nodes = nodes.size();
  std::vector<WideNode>& w = out->nodes;
  w.reserve(nodes.size() / 3 + 1);
  w.push_back(empty_node());
  if (nodes[0].b != 0) {  // the whole tree is one leaf: a root with one leaf slot
    set_slot_box(w[0], 0, nodes[0]);
    set_leaf(w[0], 0, nodes[0]);
    return out;
  }
  // Depth first: (wide node, binary interior node whose grandchildren fill it).
  struct Job {
    std::uint32_t wide, binary;
    int depth;
  };
  std::vector<Job> jobs{{0, 0, 0}};
  while (!jobs.empty()) {
    const Job job = jobs.back();
    jobs.pop_back();
    if (job.depth > kWideMaxDepth) throw std::invalid_argument("build_cpu_wide_bvh: too deep");
    // The slots: each binary child that is a leaf, else its two children.
    std::uint32_t slots[4];
    int n = 0;
    const gpu::BvhNode& parent = nodes[job.binary];
    for (std::uint32_t c = parent.a; c < parent.a + 2; ++c) {
      if (c >= nodes.size()) throw std::invalid_argument("build_cpu_wide_bvh: child out of range");
      if (nodes[c].b != 0) {
        slots[n++] = c;
      } else {
        if (nodes[c].a + 1 >= nodes.size())
          throw std::invalid_argument("build_cpu_wide_bvh: child out of range");
        slots[n++] = nodes[c].a;
        slots[n++] = nodes[c].a + 1;
      }
    }
    // Interior slots get their wide nodes; pushed in reverse so that slot 0's subtree is laid
    // out first (depth-first order keeps a ray's nearer path on neighbouring lines).
    std::uint32_t child_wide[4];
    for (int i = 0; i < n; ++i) {
      const gpu::BvhNode& b = nodes[slots[i]];
      set_slot_box(w[job.wide], i, b);
      if (b.b != 0) {
        set_leaf(w[job.wide], i, b);
      } else {
        child_wide[i] = std::uint32_t(w.size());
        w[job.wide].child[i] = child_wide[i];
        w.push_back(empty_node());
      }
    }
    for (int i = n - 1; i >= 0; --i)
      if (nodes[slots[i]].b == 0) jobs.push_back({child_wide[i], slots[i], job.depth + 1});
  }
  return out;
}

std::uint64_t wide_bvh_bytes(const WideBvh& w) {
  return std::uint64_t(w.nodes.size()) * sizeof(WideNode) +
         std::uint64_t(w.packets.size()) * sizeof(TriPacket);
}

}  // namespace basalt::cpu
