// The scene and knob settings of the path-knob tests (docs/path-spec.md 7.1), shared by the
// CPU test (tests/cpu/path_knobs_test.cpp) and the GPU conformance test
// (tests/gpu/path_knobs_gpu_test.cpp).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "common/test_util.h"
#include "scene/tables.h"

namespace basalt::test {

/// A diffuse room corner with a glossy sphere and a glass sphere, lit by a quad area light and
/// a dim uniform sky (no delta light: every MIS mode is unbiased on it), 40 x 32.
inline std::string path_knobs_scene() {
  return scene_head("0 1 -4  0 0.8 0  0 1 0", 45, 40, 32, 0, 6) + R"(
LightSource "infinite" "rgb L" [ 0.1 0.1 0.12 ]
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 8 8 8 ]
  Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
    "point3 P" [ -0.5 2.4 -0.5  0.5 2.4 -0.5  0.5 2.4 0.5  -0.5 2.4 0.5 ]
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0.7 0.7 0.7 ]
Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3  4 5 6  4 6 7 ]
  "point3 P" [ -3 0 -3  3 0 -3  3 0 3  -3 0 3   -3 0 2  3 0 2  3 3 2  -3 3 2 ]
AttributeBegin
  Translate -0.7 0.5 0.3
  Material "conductor" "float roughness" [ 0.2 ]
  Shape "sphere" "float radius" [ 0.5 ]
AttributeEnd
AttributeBegin
  Translate 0.7 0.5 0
  Material "dielectric" "float eta" [ 1.5 ]
  Shape "sphere" "float radius" [ 0.45 ]
AttributeEnd
)";
}

/// One setting of the path knobs (apply_path_knobs' and apply_light_sampler's arguments).
struct PathKnobSetting {
  const char* name;
  int max_depth;  // -1: the scene's
  std::uint32_t roulette_start;
  std::uint32_t mis;
  bool unbiased;  // converges to the default's image
  const char* light_sampler = "bvh";
};

/// Applies setting \p k to built tables.
inline void apply_setting(SceneTables& t, const PathKnobSetting& k) {
  apply_path_knobs(t, k.max_depth, k.roulette_start, k.mis);
  apply_light_sampler(t, k.light_sampler);
}

/// Every non-default value of every path knob.
inline std::vector<PathKnobSetting> path_knob_settings() {
  return {
      {"maxdepth-1", 1, 1u, gpu::MIS_POWER, false},
      {"maxdepth-2", 2, 1u, gpu::MIS_POWER, false},
      {"roulette-off", -1, gpu::ROULETTE_OFF, gpu::MIS_POWER, true},
      {"roulette-3", -1, 3u, gpu::MIS_POWER, true},
      {"mis-balance", -1, 1u, gpu::MIS_BALANCE, true},
      {"mis-bsdf", -1, 1u, gpu::MIS_BSDF_ONLY, true},
      {"mis-light", -1, 1u, gpu::MIS_LIGHT_ONLY, true},
      {"lights-uniform", -1, 1u, gpu::MIS_POWER, true, "uniform"},
      {"lights-power", -1, 1u, gpu::MIS_POWER, true, "power"},
  };
}

}  // namespace basalt::test
