// The shared BSDF property suite (tests/common/bsdf_properties.cpp) on the GPU (lavapipe);
// the chi-square tests are slow there (one pipeline and ~1M probe queries per material).
#include "common/bsdf_properties.h"

namespace basalt::test {

INSTANTIATE_TEST_SUITE_P(Gpu, BsdfProperties, ::testing::Values(Side::Gpu));
INSTANTIATE_TEST_SUITE_P(GpuSlow, BsdfChi2,
                         ::testing::Combine(::testing::Values(Side::Gpu),
                                            ::testing::Range(0, bsdf::chi2_entry_count())));

}  // namespace basalt::test
