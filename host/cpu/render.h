// Multithreaded image rendering of the CPU reference (docs/path-spec.md section 9).
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include <glm/glm.hpp>

#include "scene/tables.h"

namespace basalt::cpu {

/// \brief Adds samples [sample_start, sample_start + sample_count) of every pixel into accum
///        (rgb = sum of L, a = sum of weights; one path per sample, weight 1).
/// \param accum width*height entries, row-major from the top-left pixel; resized (zeros) if it
///        has another size.
/// \param progress called now and then from the calling thread with the fraction done
///        (may be empty).
/// \return the number of rays traced (camera, continuation and shadow rays), as the GPU's
///         counters[0].
/// \param nonfinite_samples if set, incremented by the number of samples whose radiance was
///        NaN or infinite (dropped: they add (0, 1), docs/path-spec.md section 9).
/// Runs on std::thread::hardware_concurrency() threads taking 16x16 tiles from an atomic
/// counter; each pixel is written by one thread only.
std::uint64_t render(const SceneTables& scene, std::uint32_t sample_start, std::uint32_t sample_count,
            std::vector<glm::vec4>& accum, const std::function<void(double)>& progress = {},
            std::uint64_t* nonfinite_samples = nullptr);

}  // namespace basalt::cpu
