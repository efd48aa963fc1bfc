// libFuzzer harness: the PLY reader (host/scene/ply.cpp) on files of any content.
#include <unistd.h>

#include <cstddef>
#include <cstdio>
#include <cstdint>
#include <fstream>
#include <string>

#include "scene/ply.h"

/// Writes the input to a file of this process and reads it as a PLY mesh (lavapipe's limit).
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = "/tmp/basalt-fuzz-" + std::to_string(::getpid()) + ".ply";
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), std::streamsize(size));
  try {
    basalt::load_ply(path, nullptr, std::uint64_t(1) << 27);
  } catch (const std::exception&) {
  }
  std::remove(path.c_str());  // nothing left behind in /tmp
  return 0;
}
