// Traversal-rate benchmarks of tests/bench/rays.cpp (lavapipe, the CPU reference, Embree).
#pragma once
#include <functional>

#include <benchmark/benchmark.h>

#include "vk/context.h"

namespace basalt::bench {

/// Registers rays/igea/<camera|bounce|shadow>/<gpu|cpu|embree> on the benchmark's context.
void register_rays(std::function<vkx::Context&()> context);
/// Releases the GPU objects of those benchmarks (before the context goes).
void release_rays();

}  // namespace basalt::bench
