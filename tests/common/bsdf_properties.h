// Fixtures of the shared BSDF property suite (tests/common/bsdf_properties.cpp); each test
// executable instantiates them for its side (CPU: bsdf_properties_test.cpp, GPU:
// bsdf_properties_gpu_test.cpp).
#pragma once
#include <gtest/gtest.h>

#include <tuple>

#include "common/test_util.h"

namespace basalt::test {

/// Property tests, parameterised by the side that answers the probes.
class BsdfProperties : public ::testing::TestWithParam<Side> {};
/// Chi-square tests: (side, index of the material among the chi-square entries).
class BsdfChi2 : public ::testing::TestWithParam<std::tuple<Side, int>> {};

namespace bsdf {
/// Number of catalog materials with a chi-square test (the index range of BsdfChi2).
int chi2_entry_count();
}  // namespace bsdf

}  // namespace basalt::test
