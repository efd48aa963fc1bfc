// The scene's Sampler as rendered (docs/sampler-spec.md 3): its resolved sample counts and the
// Globals fields and prime table both renderers read.
#pragma once
#include <string>
#include <vector>

#include "scene.h"
#include "tables.h"

namespace basalt {

/// \brief The sampler as pbrt-v4 builds it from \p s: stratified takes xsamples x ysamples
/// from the sample count when the two disagree (pbrt-v4's --spp rule), zsobol rounds its count
/// down to a power of two; \p warning (if not null) receives a note when the count changed.
Sampler resolve_sampler(const Sampler& s, std::string* warning = nullptr);

/// \brief Fills Globals.sampler_opts, Globals.sampler_params and the prime table of \p t for the
/// resolved sampler \p s (tables already hold the image size).
void sampler_tables(SceneTables& t, const Sampler& s);

/// \brief Throws std::invalid_argument when samples [0, \p end) exceed the count the sampler in
/// \p g was built for (Globals.sampler_opts.z, stratified z x w): past it, the stratified,
/// zsobol, sobol and pmj02bn samplers would reuse sample indices across pixels or strata.
void check_sample_count(const gpu::Globals& g, std::uint32_t end);

/// \brief Names of the samplers basalt renders, in SAMPLER_* order.
const std::vector<std::string>& sampler_names();

}  // namespace basalt
