// The pmj02bn point sets basalt makes for itself (docs/sampler-spec.md 4, pmj02bn): progressive
// (0, 2)-sequences in base 2 with best-candidate (blue-noise) placement.
#pragma once
#include <cstdint>
#include <vector>

namespace basalt {

/// \brief Set \p set (0 .. PMJ_SETS-1) of PMJ_SAMPLES points as 2 x 32-bit fractions per point
/// (x0, y0, x1, y1, ...): an Owen scrambling of Sobol' dimensions 0 and 1 whose free bits are
/// chosen, point by point, as the best of \p candidates candidates (the farthest from the points
/// already placed). Deterministic: the same words on every run and machine. \p count < PMJ_SAMPLES
/// gives the first \p count points of the same set.
std::vector<std::uint32_t> pmj02bn_set(std::uint32_t set, std::uint32_t candidates = 16,
                                       std::uint32_t count = 65536);

/// \brief All PMJ_SETS sets, made once per process and kept (they take about a second).
const std::vector<std::uint32_t>& pmj02bn_sets();

}  // namespace basalt
