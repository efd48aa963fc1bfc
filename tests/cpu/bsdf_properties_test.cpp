// The shared BSDF property suite (tests/common/bsdf_properties.cpp) on the CPU reference,
// chi-square included (fast).
#include "common/bsdf_properties.h"

namespace basalt::test {

INSTANTIATE_TEST_SUITE_P(Cpu, BsdfProperties, ::testing::Values(Side::Cpu));
INSTANTIATE_TEST_SUITE_P(Cpu, BsdfChi2,
                         ::testing::Combine(::testing::Values(Side::Cpu),
                                            ::testing::Range(0, bsdf::chi2_entry_count())));

}  // namespace basalt::test
