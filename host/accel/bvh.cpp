// Binned-SAH BVH build (Wald 2007, "On fast construction of SAH-based bounding volume
// hierarchies"; pbrt-v4 7.3.2), emitted directly as the flat gpu::BvhNode array.
#include "accel/bvh.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <exception>
#include <stdexcept>
#include <string>
#include <utility>
#include <thread>

namespace basalt {
namespace {

// One primitive during the build: its box and input index, 28 bytes. Partitioning moves these
// records (not indices into them) so every pass reads memory sequentially. The split key, the
// box's centre, is recomputed where it is needed rather than stored (12 bytes a primitive less
// at the build's peak; the same value as Aabb::center()).
struct Item {
  glm::vec3 lo;
  std::uint32_t index;
  glm::vec3 hi;
  glm::vec3 c() const { return 0.5f * (lo + hi); }
};
static_assert(sizeof(Item) == 28);

constexpr int kMaxBins = 64;
// Subtrees with fewer primitives than this are not worth a thread.
constexpr std::uint32_t kParallelMin = 16 * 1024;

struct Bin {
  Aabb box;
  std::uint32_t count = 0;
};

class Builder {
 public:
  Builder(std::vector<Item>& items, const BvhOptions& options, std::uint32_t thread_levels)
      : items_(items),
        options_(options),
        bins_(std::clamp(options.bins, 2, kMaxBins)),
        max_leaf_(std::uint32_t(std::clamp(options.max_leaf, 2, 16))),
        leaf_always_(std::min(kBvhLeafAlways, max_leaf_)),
        thread_levels_(thread_levels) {}

  // Builds the subtree over items_[begin, end) into nodes[node]; children are appended to nodes.
  // Returns the depth of the deepest node of the subtree, counted from the tree root.
  std::uint32_t build(std::vector<gpu::BvhNode>& nodes, std::uint32_t node, std::uint32_t begin,
                      std::uint32_t end, std::uint32_t depth) {
    Aabb box, cbox;
    for (std::uint32_t i = begin; i < end; ++i) {
      const Item& it = items_[i];
      box.lo = glm::min(box.lo, it.lo);
      box.hi = glm::max(box.hi, it.hi);
      cbox.extend(it.c());
    }
    nodes[node].lo = box.lo;
    nodes[node].hi = box.hi;
    const std::uint32_t n = end - begin;
    std::uint32_t mid = n <= leaf_always_ ? 0 : split(begin, end, box, cbox, depth);
    if (mid == 0) {  // leaf
      nodes[node].a = begin;
      nodes[node].b = n;
      return depth;
    }
    const auto c = static_cast<std::uint32_t>(nodes.size());
    nodes.resize(c + 2);
    nodes[node].a = c;
    nodes[node].b = 0;
    if (depth < thread_levels_ && n >= kParallelMin) {
      // Right subtree on a worker into its own array (root at 0), spliced in after the join so
      // the output is the same as a serial build's.
      std::vector<gpu::BvhNode> right(1);
      right.reserve(2 * std::size_t(end - mid));  // a subtree of k prims has < 2k nodes: no regrowth
      std::uint32_t right_depth = 0;
      std::exception_ptr error;
      std::thread worker([&] {
        try {
          right_depth = build(right, 0, mid, end, depth + 1);
        } catch (...) {
          error = std::current_exception();
        }
      });
      std::uint32_t left_depth = 0;
      try {
        left_depth = build(nodes, c, begin, mid, depth + 1);
      } catch (...) {
        worker.join();
        throw;
      }
      worker.join();
      if (error) std::rethrow_exception(error);
      splice(nodes, c + 1, right);
      return std::max(left_depth, right_depth);
    }
    std::uint32_t left_depth = build(nodes, c, begin, mid, depth + 1);
    std::uint32_t right_depth = build(nodes, c + 1, mid, end, depth + 1);
    return std::max(left_depth, right_depth);
  }

 private:
  // Copies a subtree built in its own array (root at sub[0]) into nodes: the root into slot,
  // sub[k] (k >= 1) to the end of nodes, relocating child indices.
  static void splice(std::vector<gpu::BvhNode>& nodes, std::uint32_t slot,
                     const std::vector<gpu::BvhNode>& sub) {
    const auto base = static_cast<std::uint32_t>(nodes.size());
    auto relocate = [base](gpu::BvhNode n) {
      if (n.b == 0) n.a = base + n.a - 1;
      return n;
    };
    nodes[slot] = relocate(sub[0]);
    nodes.reserve(nodes.size() + sub.size() - 1);
    for (std::size_t k = 1; k < sub.size(); ++k) nodes.push_back(relocate(sub[k]));
  }

  // Bin of a centroid coordinate; NaN and out-of-range values clamp (never UB on conversion).
  // The same expression is used for binning and partitioning, so the counts agree exactly.
  int bin_of(float x, float lo, float scale) const {
    float t = (x - lo) * scale;
    if (t >= static_cast<float>(bins_ - 1)) return bins_ - 1;
    return t > 0.0f ? static_cast<int>(t) : 0;
  }

  // Chooses a split of items_[begin, end) and partitions it; returns the first index of the
  // right half, or 0 when the node should be a leaf.
  std::uint32_t split(std::uint32_t begin, std::uint32_t end, const Aabb& box, const Aabb& cbox,
                      std::uint32_t depth) {
    const std::uint32_t n = end - begin;
    if (options_.split == BvhOptions::Split::Median || depth >= kBvhSahDepth)
      return median_split(begin, end, cbox);

    const glm::vec3 extent = cbox.hi - cbox.lo;
    std::array<float, 3> scale{};
    std::array<bool, 3> usable{};
    for (int a = 0; a < 3; ++a) {
      scale[a] = static_cast<float>(bins_) / extent[a];
      usable[a] = extent[a] > 0.0f && std::isfinite(scale[a]);
    }
    if (!usable[0] && !usable[1] && !usable[2]) {
      // All centroids coincide: no plane separates them.
      return n <= max_leaf_ ? 0 : median_split(begin, end, cbox);
    }

    std::array<std::array<Bin, kMaxBins>, 3> bins{};
    for (std::uint32_t i = begin; i < end; ++i) {
      const Item& it = items_[i];
      for (int a = 0; a < 3; ++a) {
        if (!usable[a]) continue;
        Bin& bin = bins[a][bin_of(it.c()[a], cbox.lo[a], scale[a])];
        bin.box.lo = glm::min(bin.box.lo, it.lo);
        bin.box.hi = glm::max(bin.box.hi, it.hi);
        ++bin.count;
      }
    }

    // SAH scaled by A(node): cost(split s) = Ct A + Ci (A_L N_L + A_R N_R), leaf = Ci N A.
    // Comparing unnormalised costs stays meaningful when A(node) is 0.
    const double area = box.area();
    double best_cost = std::numeric_limits<double>::infinity();
    int best_axis = -1, best_bin = 0;
    for (int a = 0; a < 3; ++a) {
      if (!usable[a]) continue;
      std::array<double, kMaxBins> right_cost{};  // right_cost[s]: bins [s, bins_)
      std::array<std::uint32_t, kMaxBins> right_count{};
      Aabb acc;
      std::uint32_t count = 0;
      for (int s = bins_ - 1; s >= 1; --s) {
        acc.extend(bins[a][s].box);
        count += bins[a][s].count;
        right_cost[s] = static_cast<double>(acc.area()) * count;
        right_count[s] = count;
      }
      acc = Aabb{};
      count = 0;
      for (int s = 1; s < bins_; ++s) {  // left = bins [0, s)
        acc.extend(bins[a][s - 1].box);
        count += bins[a][s - 1].count;
        if (count == 0 || right_count[s] == 0) continue;
        double cost = kBvhTraversalCost * area +
                      kBvhIntersectCost * (static_cast<double>(acc.area()) * count + right_cost[s]);
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = a;
          best_bin = s;
        }
      }
    }
    if (best_axis < 0)  // every centroid fell into one bin on every usable axis
      return n <= max_leaf_ ? 0 : median_split(begin, end, cbox);
    const double leaf_cost = kBvhIntersectCost * static_cast<double>(n) * area;
    if (n <= max_leaf_ && leaf_cost <= best_cost) return 0;

    const int a = best_axis;
    const float lo = cbox.lo[a], sc = scale[a];
    auto* first = items_.data() + begin;
    auto* split_at = std::partition(first, items_.data() + end, [&](const Item& it) {
      return bin_of(it.c()[a], lo, sc) < best_bin;
    });
    return static_cast<std::uint32_t>(split_at - items_.data());
  }

  // Object median along the largest centroid extent; halves the index range when the
  // centroids coincide. Always returns a split with both halves non-empty (n >= 2).
  std::uint32_t median_split(std::uint32_t begin, std::uint32_t end, const Aabb& cbox) {
    const std::uint32_t mid = begin + (end - begin) / 2;
    const glm::vec3 extent = cbox.hi - cbox.lo;
    int a = 0;
    if (extent.y > extent[a]) a = 1;
    if (extent.z > extent[a]) a = 2;
    if (extent[a] > 0.0f) {
      std::nth_element(items_.begin() + begin, items_.begin() + mid, items_.begin() + end,
                       [a](const Item& x, const Item& y) { return x.c()[a] < y.c()[a]; });
    }
    return mid;
  }

  std::vector<Item>& items_;
  const BvhOptions& options_;
  const int bins_;
  std::uint32_t max_leaf_, leaf_always_;
  const std::uint32_t thread_levels_;
};

}  // namespace

namespace {

/// Builds the tree over items (one per primitive, in input order; reordered by the build).
Bvh build_from_items(std::vector<Item> items, const BvhOptions& options) {
  Bvh bvh;
  const std::size_t n = items.size();
  // Threads for the top levels: each level up to thread_levels hands its right subtree to a
  // new thread, so about 2^thread_levels builders run at once.
  unsigned threads = options.max_threads > 0 ? static_cast<unsigned>(options.max_threads)
                                             : std::max(1u, std::thread::hardware_concurrency());
  std::uint32_t thread_levels = threads <= 1 ? 0 : std::bit_width(threads - 1u) + 1u;

  bvh.nodes.reserve(std::min<std::size_t>(2 * n, 1u << 20));
  bvh.nodes.resize(1);
  Builder builder(items, options, thread_levels);
  bvh.depth = builder.build(bvh.nodes, 0, 0, static_cast<std::uint32_t>(n), 0);
  bvh.nodes.shrink_to_fit();

  bvh.prim_order.resize(n);
  for (std::size_t i = 0; i < n; ++i) bvh.prim_order[i] = items[i].index;
  return bvh;
}

/// The build's records for bounds (checked for the index limit).
std::vector<Item> make_items(std::span<const Aabb> bounds) {
  const std::size_t n = bounds.size();
  if (n > gpu::PRIM_INDEX_MASK) throw std::length_error("build_bvh: too many primitives");
  std::vector<Item> items(n);
  for (std::size_t i = 0; i < n; ++i) {
    items[i].lo = bounds[i].lo;
    items[i].hi = bounds[i].hi;
    items[i].index = static_cast<std::uint32_t>(i);
  }
  return items;
}

}  // namespace

Bvh build_bvh(std::span<const Aabb> bounds, const BvhOptions& options) {
  if (bounds.empty()) return Bvh{};
  return build_from_items(make_items(bounds), options);
}

Bvh build_bvh(std::vector<Aabb>&& bounds, const BvhOptions& options) {
  if (bounds.empty()) return Bvh{};
  std::vector<Item> items = make_items(bounds);
  std::vector<Aabb>().swap(bounds);  // freed before the build's own arrays grow
  return build_from_items(std::move(items), options);
}

double bvh_sah_cost(std::span<const gpu::BvhNode> nodes, float traversal_cost,
                    float intersect_cost) {
  if (nodes.empty()) return 0.0;
  auto area = [](const gpu::BvhNode& n) {
    Aabb b;
    b.lo = n.lo;
    b.hi = n.hi;
    return static_cast<double>(b.area());
  };
  double root = area(nodes[0]);
  if (!(root > 0.0)) root = 1.0;
  double cost = 0.0;
  for (const gpu::BvhNode& n : nodes) {
    if (n.b == 0)
      cost += traversal_cost * area(n) / root;
    else
      cost += intersect_cost * static_cast<double>(n.b) * area(n) / root;
  }
  return cost;
}

namespace {

/// Scale 2^(byte - 127) of an exponent byte in [1, 254].
float wide_scale(std::uint32_t byte) { return std::bit_cast<float>(byte << 23); }

/// Both decodings of origin + q * scale a shader may compute: separate rounding (q * scale is
/// exact, so this is one rounding of the sum unless the product overflows) and a fused
/// multiply-add.
std::pair<float, float> wide_decode(float origin, std::uint32_t q, float scale) {
  const float product = float(q) * scale;
  return {origin + product, std::fma(float(q), scale, origin)};
}

/// Quantises one axis of up to four child intervals [lo[i], hi[i]] against origin: picks the
/// smallest exponent byte whose 255 steps reach every hi, and q values whose decodings (both
/// roundings) stay at or below lo and at or above hi. Returns the exponent byte.
std::uint32_t quantise_axis(float origin, const float* lo, const float* hi, int count,
                            std::uint32_t* qlo, std::uint32_t* qhi) {
  double extent = 0.0;
  for (int i = 0; i < count; ++i) extent = std::max(extent, double(hi[i]) - double(origin));
  int e = -126;
  if (extent > 0.0) e = std::clamp(int(std::ceil(std::log2(extent / 255.0))), -126, 127);
  for (;; ++e) {
    const std::uint32_t byte = std::uint32_t(e + 127);
    const float scale = wide_scale(byte);
    bool ok = true;
    for (int i = 0; i < count && ok; ++i) {
      double f = std::floor((double(lo[i]) - double(origin)) / double(scale));
      std::uint32_t ql = std::uint32_t(std::clamp(f, 0.0, 255.0));
      for (;;) {
        const auto [a, b] = wide_decode(origin, ql, scale);
        if ((a <= lo[i] && b <= lo[i]) || ql == 0) break;
        --ql;
      }
      double c = std::ceil((double(hi[i]) - double(origin)) / double(scale));
      std::uint32_t qh = std::uint32_t(std::clamp(c, 0.0, 255.0));
      for (;;) {
        const auto [a, b] = wide_decode(origin, qh, scale);
        if (a >= hi[i] && b >= hi[i]) break;
        if (qh == 255) {
          ok = false;  // this exponent's 255 steps fall short after rounding: take the next
          break;
        }
        ++qh;
      }
      qlo[i] = ql;
      qhi[i] = qh;
    }
    if (ok || e == 127) return byte;  // at e = 127, 255 steps overflow to infinity: always ok
  }
}

}  // namespace

std::vector<gpu::BvhWideNode> build_wide_bvh(std::span<const gpu::BvhNode> nodes) {
  std::vector<gpu::BvhWideNode> wide;
  if (nodes.empty()) return wide;
  // Binary node of each wide node, in creation order (breadth first).
  std::vector<std::uint32_t> source{0};
  for (std::size_t w = 0; w < source.size(); ++w) {
    const gpu::BvhNode& n = nodes[source[w]];
    std::uint32_t kids[4];
    int count = 0;
    if (n.b != 0) {
      kids[count++] = source[w];  // a root that is a leaf: one leaf child
    } else {
      for (std::uint32_t c : {n.a, n.a + 1}) {
        if (nodes[c].b != 0) {
          kids[count++] = c;
        } else {
          kids[count++] = nodes[c].a;
          kids[count++] = nodes[c].a + 1;
        }
      }
    }
    gpu::BvhWideNode out{};
    glm::vec3 origin(std::numeric_limits<float>::infinity());
    for (int i = 0; i < count; ++i) origin = glm::min(origin, nodes[kids[i]].lo);
    out.origin = origin;
    out.exponents = 0;
    std::uint32_t qlo[3][4] = {}, qhi[3][4] = {};
    for (int k = 0; k < 3; ++k) {
      float lo[4], hi[4];
      for (int i = 0; i < count; ++i) {
        lo[i] = nodes[kids[i]].lo[k];
        hi[i] = nodes[kids[i]].hi[k];
      }
      out.exponents |= quantise_axis(origin[k], lo, hi, count, qlo[k], qhi[k]) << (8 * k);
    }
    for (int i = 0; i < 4; ++i) {
      std::uint32_t child = gpu::INVALID_INDEX;
      std::uint32_t l[3] = {255, 255, 255}, h[3] = {0, 0, 0};  // empty slot: lo > hi
      if (i < count) {
        const gpu::BvhNode& c = nodes[kids[i]];
        for (int k = 0; k < 3; ++k) {
          l[k] = qlo[k][i];
          h[k] = qhi[k][i];
        }
        if (c.b != 0) {
          if (c.b > gpu::BVH_WIDE_LEAF_MAX || c.a + c.b > gpu::BVH_WIDE_FIRST_LIMIT)
            throw std::invalid_argument("BVH leaf of " + std::to_string(c.b) + " prims at " +
                                        std::to_string(c.a) +
                                        ": the GPU's wide BVH holds at most 32 prims a leaf, "
                                        "starting below 2^26");
          child = gpu::BVH_WIDE_LEAF | (c.b - 1) << 26 | c.a;
        } else {
          child = std::uint32_t(source.size());
          source.push_back(kids[i]);
        }
      }
      out.qlo[0] |= l[0] << (8 * i);
      out.qlo[1] |= l[1] << (8 * i);
      out.qlo[2] |= l[2] << (8 * i);
      out.qhi[0] |= h[0] << (8 * i);
      out.qhi[1] |= h[1] << (8 * i);
      out.qhi[2] |= h[2] << (8 * i);
      out.child[i] = child;
    }
    wide.push_back(out);
  }
  return wide;
}

Aabb wide_child_box(const gpu::BvhWideNode& n, int i) {
  Aabb b;
  for (int k = 0; k < 3; ++k) {
    const float scale = wide_scale((n.exponents >> (8 * k)) & 0xffu);
    b.lo[k] = wide_decode(n.origin[k], (n.qlo[k] >> (8 * i)) & 0xffu, scale).first;
    b.hi[k] = wide_decode(n.origin[k], (n.qhi[k] >> (8 * i)) & 0xffu, scale).first;
  }
  return b;
}

}  // namespace basalt
