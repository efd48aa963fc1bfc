// Image output: OpenEXR (linear float RGB) and PNG (sRGB, clamped), written atomically.
#pragma once
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace basalt {

/// A linear RGB image, rows top to bottom.
struct Image {
  int width = 0, height = 0;
  std::vector<glm::vec3> pixels;
};

/// \brief Resolves an accumulation buffer (sum of L, sum of weights) into pixel values.
Image resolve(const std::vector<glm::vec4>& accum, int width, int height);

/// \brief Writes \p image as OpenEXR (".exr": 32-bit float R, G, B) or PNG (".png": sRGB
///        8-bit, values clamped to [0, 1]) by the extension of \p path, through
///        write_file_bytes (util/files.h): a regular file appears complete or not at all, a
///        FIFO or device gets the bytes directly.
/// \throws std::runtime_error for an unknown extension or an I/O failure.
void write_image(const std::string& path, const Image& image);

/// \brief Reads a float RGB OpenEXR file (for tests and tools).
Image read_exr(const std::string& path);

/// \brief True if \p path ends in an extension write_image supports.
bool is_supported_image_path(const std::string& path);

}  // namespace basalt
