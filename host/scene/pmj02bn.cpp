// pmj02bn point sets (docs/sampler-spec.md 4, pmj02bn). A progressive (0, 2)-sequence in base 2
// is an Owen scrambling of Sobol' dimensions 0 and 1 (Helmer, Christensen and Kensler,
// "Stochastic Generation of (t, s) Sample Sequences", EGSR 2021): point i's first digits are
// fixed by the flips of the scrambling-tree nodes earlier points visited, the rest are free.
// Choosing those free digits as the best of several candidates, the one farthest from the points
// already placed, gives the blue-noise variant (Christensen, Kensler and Kilpatrick,
// "Progressive Multi-Jittered Sample Sequences", EGSR 2018, section 6).
#include "pmj02bn.h"

#include <algorithm>
#include <array>
#include <bit>
#include <mutex>
#include <thread>

#include "../../shaders/shared/layout.h"
#include "sobol.h"

namespace basalt {

namespace {

using u32 = std::uint32_t;
using u64 = std::uint64_t;

constexpr u32 kLevels = 16;  // 2^16 points: tree nodes below depth 16 hold one point each

/// splitmix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number generators", 2014).
struct SplitMix {
  u64 state;
  u64 next() {
    u64 z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
};

/// One dimension's Owen scrambling tree, depths 0 .. kLevels-1: flip[d][p] for the node whose
/// unscrambled prefix is the d-digit number p; -1 until a point has visited it.
struct ScrambleTree {
  std::array<std::vector<std::int8_t>, kLevels> flip;
  ScrambleTree() {
    for (u32 d = 0; d < kLevels; ++d) flip[d].assign(std::size_t(1) << d, std::int8_t(-1));
  }
  /// The digits of \p v (unscrambled) fixed by visited nodes: their count and the scrambled
  /// value of those leading digits (the rest zero).
  std::pair<u32, u32> fixed(u32 v) const {
    u32 out = 0, d = 0;
    for (; d < kLevels; ++d) {
      const u32 prefix = d == 0 ? 0u : v >> (32 - d);
      const std::int8_t f = flip[d][prefix];
      if (f < 0) break;
      const u32 digit = ((v >> (31 - d)) & 1u) ^ u32(f);
      out |= digit << (31 - d);
    }
    return {d, out};
  }
  /// Records the flips that map unscrambled \p v to scrambled \p w at depths from..kLevels-1.
  void commit(u32 v, u32 w, u32 from) {
    for (u32 d = from; d < kLevels; ++d) {
      const u32 prefix = d == 0 ? 0u : v >> (32 - d);
      flip[d][prefix] = std::int8_t(((v ^ w) >> (31 - d)) & 1u);
    }
  }
};

/// Toroidal distance of two 32-bit fractions.
u64 wrap_dist(u32 a, u32 b) {
  const u32 d = a - b;
  return std::min(d, u32(0u - d));
}

/// The placed points, bucketed in grids of 2^L x 2^L cells for L = 0 .. 8. With n points placed,
/// the prefix of 4^(L+1) points is a (0, 2L+2, 2)-net for L = floor(log4 n), so each cell of
/// level L holds one to four points: four slots per cell, no allocation while placing.
struct PointGrid {
  std::array<std::vector<u32>, 9> slots;  // 4 per cell: point index + 1, 0 when empty
  const std::vector<u32>* pts;
  explicit PointGrid(const std::vector<u32>* p) : pts(p) {
    for (u32 l = 0; l < 9; ++l) slots[l].assign(std::size_t(4) << (2 * l), 0u);
  }
  void insert(u32 i) {
    const u32 x = (*pts)[2 * i], y = (*pts)[2 * i + 1];
    for (u32 l = 0; l < 9; ++l) {
      const u32 cx = l == 0 ? 0 : x >> (32 - l), cy = l == 0 ? 0 : y >> (32 - l);
      u32* cell = &slots[l][4 * std::size_t((cy << l) | cx)];
      for (u32 k = 0; k < 4; ++k)
        if (cell[k] == 0) {
          cell[k] = i + 1;
          break;
        }
    }
  }
  /// Squared toroidal distance from (x, y) to the nearest of the first n placed points (n >= 1):
  /// the 7 x 7 cells around it at level floor(log4 n) hold the nearest point (every cell of that
  /// level holds one, so it is nearer than 2 sqrt(2) cells, and cells 4 away are 3 away).
  u64 nearest(u32 x, u32 y, u32 n) const {
    const u32 l = std::min<u32>(8, u32(std::bit_width(n) - 1) / 2);
    if (n < 64) {  // few points: all of them
      u64 best = ~u64(0);
      for (u32 j = 0; j < n; ++j) {
        const u64 ddx = wrap_dist(x, (*pts)[2 * j]), ddy = wrap_dist(y, (*pts)[2 * j + 1]);
        best = std::min(best, ddx * ddx + ddy * ddy);
      }
      return best;
    }
    const int side = 1 << l;  // >= 8 here
    const int cx = int(x >> (32 - l)), cy = int(y >> (32 - l));
    const u64 cell = u64(1) << (32 - l);
    u64 best = ~u64(0);
    // Rings of cells at Chebyshev distance r = 0 .. 3; after ring r every cell left is at least
    // r cells away.
    for (int r = 0; r <= 3; ++r) {
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          if (std::max(std::abs(dx), std::abs(dy)) != r) continue;
          const int gx = (cx + dx) & (side - 1), gy = (cy + dy) & (side - 1);
          const u32* c = &slots[l][4 * (std::size_t(gy) * std::size_t(side) + std::size_t(gx))];
          for (u32 k = 0; k < 4 && c[k] != 0; ++k) {
            const u32 j = c[k] - 1;
            const u64 ddx = wrap_dist(x, (*pts)[2 * j]), ddy = wrap_dist(y, (*pts)[2 * j + 1]);
            best = std::min(best, ddx * ddx + ddy * ddy);
          }
        }
      if (r > 0 && best <= u64(r) * cell * (u64(r) * cell)) break;
    }
    return best;
  }
};

}  // namespace

std::vector<std::uint32_t> pmj02bn_set(std::uint32_t set, std::uint32_t candidates,
                                       std::uint32_t count) {
  const u32 n = std::min<u32>(count, gpu::PMJ_SAMPLES);
  std::vector<u32> pts(2 * std::size_t(n));
  ScrambleTree tx, ty;
  PointGrid grid(&pts);
  SplitMix rng{0x706d6a3032626eull ^ (u64(set) << 48)};  // "pmj02bn" and the set
  for (u32 i = 0; i < n; ++i) {
    // Unscrambled Sobol' dimensions 0 (van der Corput) and 1 of index i.
    const u32 ux = sobol0(i), uy = sobol1(i);
    const auto [dx, fx] = tx.fixed(ux);
    const auto [dy, fy] = ty.fixed(uy);
    const u32 mask_x = dx >= 32 ? 0u : ~0u >> dx, mask_y = dy >= 32 ? 0u : ~0u >> dy;
    u32 bx = 0, by = 0;
    u64 best = 0;
    const u32 tries = i == 0 ? 1u : candidates;
    for (u32 k = 0; k < tries; ++k) {
      const u64 r = rng.next();
      const u32 cx = fx | (u32(r) & mask_x), cy = fy | (u32(r >> 32) & mask_y);
      const u64 dist = i == 0 ? 0 : grid.nearest(cx, cy, i);
      if (k == 0 || dist > best) {
        best = dist;
        bx = cx;
        by = cy;
      }
    }
    pts[2 * std::size_t(i)] = bx;
    pts[2 * std::size_t(i) + 1] = by;
    tx.commit(ux, bx, dx);
    ty.commit(uy, by, dy);
    grid.insert(i);
  }
  return pts;
}

const std::vector<std::uint32_t>& pmj02bn_sets() {
  static std::once_flag once;
  static std::vector<std::uint32_t> all;
  std::call_once(once, [] {
    // One thread per set (each is independent and deterministic).
    std::vector<std::vector<std::uint32_t>> sets(gpu::PMJ_SETS);
    std::vector<std::thread> threads;
    for (std::uint32_t k = 0; k < gpu::PMJ_SETS; ++k)
      threads.emplace_back([&sets, k] { sets[k] = pmj02bn_set(k); });
    for (auto& th : threads) th.join();
    all.reserve(2 * std::size_t(gpu::PMJ_SETS) * gpu::PMJ_SAMPLES);
    for (const auto& s : sets) all.insert(all.end(), s.begin(), s.end());
  });
  return all;
}

}  // namespace basalt
