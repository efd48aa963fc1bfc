// Scenes and helpers of the sampler tests (docs/sampler-spec.md), shared by the CPU test
// (tests/cpu/sampler_test.cpp) and the GPU probe test (tests/gpu/sampler_probe_test.cpp).
#pragma once
#include <string>
#include <vector>

#include "common/test_util.h"
#include "scene/samplers.h"
#include "scene/tables.h"

namespace basalt::test {

/// A sampler configuration under test: pbrt-v4's name and randomisation.
struct SamplerCase {
  const char* type;
  const char* randomization;  // "" for the sampler's default
};

/// Every sampler with its default randomisation, then the other randomisations.
inline std::vector<SamplerCase> sampler_cases() {
  return {{"independent", ""},       {"stratified", ""},       {"halton", ""},
          {"paddedsobol", ""},       {"zsobol", ""},           {"halton", "none"},
          {"halton", "owen"},        {"paddedsobol", "none"},  {"paddedsobol", "permutedigits"},
          {"paddedsobol", "owen"},   {"zsobol", "none"},       {"zsobol", "permutedigits"},
          {"zsobol", "owen"},        {"sobol", ""},            {"sobol", "none"},
          {"sobol", "permutedigits"}, {"sobol", "owen"},       {"pmj02bn", ""}};
}

/// Label of a case, e.g. "zsobol/owen".
inline std::string sampler_label(const SamplerCase& c) {
  return std::string(c.type) + (*c.randomization ? std::string("/") + c.randomization : "");
}

/// \brief \p t with its sampler replaced by case \p c at \p spp samples per pixel (stratified
/// without jitter when \p jitter is false).
inline SceneTables with_sampler(SceneTables t, const SamplerCase& c, int spp, bool jitter = true) {
  Sampler s;
  s.type = c.type;
  s.randomization = c.randomization;
  s.spp = spp;
  s.jitter = jitter;
  sampler_tables(t, resolve_sampler(s));
  return t;
}

/// A diffuse plane under a uniform sky, seen from above, 16 x 16 pixels, direct light only:
/// with light sampling alone (--mis light) every pixel is the same smooth integral over the
/// light pair (cos theta over the upper half of the uniformly sampled sphere).
inline std::string lit_plane_scene() {
  return scene_head("0 3 0  0 0 0  0 0 1", 30, 16, 16, 0, 1, "PixelFilter \"box\"\n") +
         R"(LightSource "infinite" "rgb L" [ 1 1 1 ]
Material "diffuse" "rgb reflectance" [ 0.8 0.8 0.8 ]
Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
  "point3 P" [ -4 0 -4  4 0 -4  4 0 4  -4 0 4 ]
)";
}

}  // namespace basalt::test
