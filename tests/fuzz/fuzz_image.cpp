// libFuzzer harness: the image readers (host/scene/images.cpp: PNG, OpenEXR, PFM, and stb for
// TGA, JPEG, BMP, GIF, HDR) and the MIP pyramid built from what they decode.
#include <unistd.h>

#include <cstddef>
#include <cstdio>
#include <cstdint>
#include <fstream>
#include <string>

#include "../../shaders/shared/layout.h"
#include "scene/images.h"
#include "scene/scene.h"

/// The first byte picks the file type (by extension, as the scene's file name would); the rest
/// is the file. Decodes it, and builds a pyramid of anything small enough to decode.
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const char* const kExt[] = {".png", ".exr", ".pfm", ".tga", ".hdr", ".jpg", ".bmp", ".gif"};
  const std::string path = "/tmp/basalt-fuzz-" + std::to_string(::getpid()) + kExt[data[0] % 8];
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
  try {
    basalt::ColorEncoding enc;
    enc.kind = data[0] & 8 ? basalt::ImageEncoding::Linear : basalt::ImageEncoding::SRGB;
    const basalt::DecodedImage img = basalt::read_texture_image(path, enc, basalt::SourceLoc{"fuzz.pbrt", 1, 1});
    if (std::size_t(img.width) * std::size_t(img.height) <= (1u << 16))
      basalt::generate_pyramid(img, data[0] & 16 ? basalt::gpu::WRAP_CLAMP : basalt::gpu::WRAP_REPEAT);
  } catch (const std::exception&) {
  }
  std::remove(path.c_str());  // nothing left behind in /tmp
  return 0;
}
