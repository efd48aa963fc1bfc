// Property checks of a Perlin noise function, run on both sides (issue 8): 0 at lattice
// points, bounded by 1, Lipschitz over close pairs, converging finite differences.
#pragma once
#include <functional>
#include <vector>

#include <glm/glm.hpp>

namespace basalt::test {

/// Noise values at many points at once (one probe batch on the GPU, a loop on the CPU).
using NoiseBatch = std::function<std::vector<float>(const std::vector<glm::vec3>&)>;

/// \brief Runs the noise property checks with \p pairs random close pairs (gtest
///        assertions inside): exact 0 at integer lattice points, |n| <= 1, |n(p) - n(q)| <=
///        kNoiseLipschitz |p - q| for |p - q| = 1e-3 at |p| up to 1e3, and central
///        differences at h = 1e-2 and 1e-3 agreeing within 2e-2 (bounded second derivative).
void check_noise_properties(const NoiseBatch& noise, std::size_t pairs);

/// A NoiseBatch that calls \p noise point by point (the CPU side).
NoiseBatch pointwise(const std::function<float(glm::vec3)>& noise);

/// Slope bound of pbrt's improved Perlin noise used by check_noise_properties.
constexpr float kNoiseLipschitz = 4.0f;

}  // namespace basalt::test
