// Image files for textures and environment maps: decoding to linear float (PNG 8/16-bit,
// OpenEXR, PFM) and pbrt-v4's MIP pyramid (docs/textures-spec.md section 4).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace basalt {

struct SourceLoc;  // scene/scene.h (which includes this header)

/// How 8-bit and 16-bit PNG values map to linear (pbrt-v4 ColorEncoding).
enum class ImageEncoding { SRGB, Linear, Gamma };
struct ColorEncoding {
  ImageEncoding kind = ImageEncoding::SRGB;
  float gamma = 1.0f;  // for Gamma: linear = v^gamma
};

/// How pbrt-v4 stores the file's pixels (its PixelFormat): every MIP level it builds is stored
/// in this format again (generate_pyramid reproduces that quantisation).
enum class PixelStorage { Float, Half, U8 };

/// A decoded image: linear values, rows top to bottom, channel-interleaved; channels 1 or 3.
struct DecodedImage {
  int width = 0, height = 0, channels = 0;
  std::vector<float> texels;
  PixelStorage storage = PixelStorage::Float;  // U8: 8-bit PNG (texels = encoding(byte))
  ColorEncoding encoding;                      // the encoding used for U8 storage
};

/// \brief Reads and linearises an image (8/16-bit PNG through \p enc, EXR/PFM linear).
/// Alpha is dropped; grey stays 1 channel, colour becomes 3 (R, G, B).
/// \throws SceneError(loc, msg naming the file) for a missing, unreadable, truncated or
///         corrupt file, an unsupported format or a zero-size image.
DecodedImage read_texture_image(const std::string& path, const ColorEncoding& enc,
                                const SourceLoc& loc);

/// One level of a MIP pyramid (same conventions as DecodedImage).
struct MipImage {
  int width = 0, height = 0, channels = 0;
  std::vector<float> texels;
};

/// \brief pbrt-v4 Image::GeneratePyramid (util/image.cpp): resamples a non-power-of-two image
/// up to the next powers of two (FloatResizeUp with wrap mode \p wrap, a WRAP_* value), then
/// halves with 2x2 box averages down to 1x1. Level 0 is the finest.
std::vector<MipImage> generate_pyramid(const DecodedImage& image, std::uint32_t wrap);

}  // namespace basalt
