// libFuzzer harness: the pbrt-v4 scene parser and table building (docs/hard-cases.md, fuzzing).
// Bad input must end in a SceneError (or another std::exception with a message); anything else
// (a crash, a sanitizer report, a hang, an allocation over the fuzzer's limit) is a defect.
#include <cstddef>
#include <cstdint>
#include <string>

#include "scene/scene.h"
#include "scene/tables.h"

/// Parses the input as a scene file in scenes/ (so its Includes and textures resolve) and builds
/// its tables, with lavapipe's 128 MiB table limit.
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    basalt::Scene scene = basalt::load_scene_from_string(
        text, "fuzz.pbrt", BASALT_SOURCE_DIR "/scenes", basalt::MixMode::Auto,
        std::uint64_t(1) << 27);
    basalt::build_tables(scene);
  } catch (const std::exception&) {
  }
  return 0;
}
