// Whole-process benchmarks of tests/bench/anchors.cpp: equal error against pbrt-v4, and peak
// memory against the tables.
#pragma once
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

namespace basalt::bench {

/// Registers equal-error/<scene>/<lavapipe|cpu> (against pbrt-v4's stored or, with
/// BASALT_PBRT set, freshly measured figures) and memory/<scene>/<lavapipe|cpu> for each of
/// \p scene_files.
void register_anchors(const std::vector<std::string>& scene_files);

}  // namespace basalt::bench
