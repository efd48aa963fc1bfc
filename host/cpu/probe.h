// CPU twin of shaders/tests/probe.comp: answers probe queries (layout.h PROBE_*).
#pragma once
#include <vector>

#include "scene/tables.h"

namespace basalt::cpu {

/// \brief Answers each ProbeIn as documented in layout.h: PROBE_CLOSEST, PROBE_OCCLUDED,
///        PROBE_RESPAWN, PROBE_RNG, PROBE_CAMERA, PROBE_CAMERA_DIFF, PROBE_BSDF
///        (docs/materials-spec.md section 6; with no sample, f1, f2 and f3.x are 0). Unknown
///        ops and unused fields give zeros; misses report t = -1 and prim INVALID_INDEX.
std::vector<gpu::ProbeOut> probe(const SceneTables& scene, const std::vector<gpu::ProbeIn>& in);

}  // namespace basalt::cpu
