// Image output: OpenEXR (linear float RGB) and PNG (sRGB, clamped), written atomically.
#include "image/image_io.h"

#include <png.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIO.h>
#include <ImfOutputFile.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>

#include "util/files.h"

namespace basalt {

namespace {

/// Lower-case extension of a path, with the dot.
std::string extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext;
}

/// sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
float srgb_encode(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

/// An in-memory OpenEXR output stream (the file is then written whole: write_file_bytes).
class MemoryOStream : public Imf::OStream {
 public:
  MemoryOStream() : Imf::OStream("memory") {}
  void write(const char c[], int n) override {
    if (pos_ + std::size_t(n) > data.size()) data.resize(pos_ + std::size_t(n));
    std::memcpy(data.data() + pos_, c, std::size_t(n));
    pos_ += std::size_t(n);
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = std::size_t(pos); }
  std::string data;

 private:
  std::size_t pos_ = 0;
};

/// Encodes float RGB channels as an OpenEXR file.
std::string encode_exr(const Image& img) {
  Imf::Header header(img.width, img.height);
  header.channels().insert("R", Imf::Channel(Imf::FLOAT));
  header.channels().insert("G", Imf::Channel(Imf::FLOAT));
  header.channels().insert("B", Imf::Channel(Imf::FLOAT));
  MemoryOStream out;
  {
    Imf::OutputFile file(out, header);
    Imf::FrameBuffer fb;
    char* base = const_cast<char*>(reinterpret_cast<const char*>(img.pixels.data()));
    const size_t xs = sizeof(glm::vec3), ys = xs * img.width;
    fb.insert("R", Imf::Slice(Imf::FLOAT, base + 0, xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + 4, xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + 8, xs, ys));
    file.setFrameBuffer(fb);
    file.writePixels(img.height);
  }  // the OutputFile writes its line offsets when it closes
  return std::move(out.data);
}

/// libpng's write callback: appends to the std::string behind the io pointer.
void png_append(png_structp png, png_bytep data, png_size_t n) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), n);
}

/// Encodes 8-bit sRGB as a PNG file.
std::string encode_png(const Image& img) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("libpng could not start");
  }
  std::string out;
  std::vector<unsigned char> row(std::size_t(img.width) * 3);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("libpng failed");
  }
  png_set_write_fn(png, &out, png_append, nullptr);
  png_set_IHDR(png, info, img.width, img.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_write_info(png, info);
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      const glm::vec3& c = img.pixels[std::size_t(y) * img.width + x];
      for (int k = 0; k < 3; ++k) {
        float v = std::isfinite(c[k]) ? c[k] : 0.0f;
        row[std::size_t(x) * 3 + k] = (unsigned char)std::lround(srgb_encode(v) * 255.0f);
      }
    }
    png_write_row(png, row.data());
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

}  // namespace

Image resolve(const std::vector<glm::vec4>& accum, int width, int height) {
  Image img{width, height, std::vector<glm::vec3>(std::size_t(width) * height)};
  for (std::size_t i = 0; i < img.pixels.size(); ++i) {
    const glm::vec4& a = accum[i];
    img.pixels[i] = a.w > 0.0f ? glm::vec3(a) / a.w : glm::vec3(0.0f);
  }
  return img;
}

bool is_supported_image_path(const std::string& path) {
  std::string ext = extension(path);
  return ext == ".exr" || ext == ".png";
}

void write_image(const std::string& path, const Image& img) {
  std::string ext = extension(path);
  if (ext != ".exr" && ext != ".png")
    throw std::runtime_error("unsupported output format '" + ext + "' (use .exr or .png): " + path);
  try {
    write_file_bytes(path, ext == ".exr" ? encode_exr(img) : encode_png(img));
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write " + path + ": " + e.what());
  }
}

Image read_exr(const std::string& path) {
  Imf::InputFile file(path.c_str());
  Imath::Box2i dw = file.header().dataWindow();
  Image img;
  img.width = dw.max.x - dw.min.x + 1;
  img.height = dw.max.y - dw.min.y + 1;
  img.pixels.resize(std::size_t(img.width) * img.height);
  // Slice::Make applies the data window's origin in integer arithmetic (no pointer overflow).
  float* base = reinterpret_cast<float*>(img.pixels.data());
  const size_t xs = sizeof(glm::vec3), ys = xs * img.width;
  Imf::FrameBuffer fb;
  fb.insert("R", Imf::Slice::Make(Imf::FLOAT, base + 0, dw, xs, ys));
  fb.insert("G", Imf::Slice::Make(Imf::FLOAT, base + 1, dw, xs, ys));
  fb.insert("B", Imf::Slice::Make(Imf::FLOAT, base + 2, dw, xs, ys));
  file.setFrameBuffer(fb);
  file.readPixels(dw.min.y, dw.max.y);
  return img;
}

}  // namespace basalt
