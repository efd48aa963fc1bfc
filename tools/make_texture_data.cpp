// Writes the small images that the texture scenes of scenes/ read (scenes/data/), so that
// each committed image is reproducible: `cmake --build build --target basalt_make_texture_data
// && build/basalt_make_texture_data scenes/data`. Patterns are closed-form functions of the
// texel coordinates; nothing here evaluates a texture.
#include <png.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "image/image_io.h"

namespace {

constexpr float kPi = 3.14159265358979f;

/// 8-bit sRGB test card, 96 x 64 (not a power of two, so the pyramid resamples it): a
/// colour grid of 8 x 8 texel cells with one-texel lines and fine stripes in the top rows
/// (aliasing shows the filter at work).
basalt::Image test_card() {
  basalt::Image im{96, 64, {}};
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      glm::vec3 c(0.15f + 0.7f * float(x) / float(im.width - 1), 0.35f,
                  0.15f + 0.7f * float(y) / float(im.height - 1));
      if (((x / 8) + (y / 8)) % 2 == 0) c *= 0.45f;
      if (x % 16 == 0 || y % 16 == 0) c = glm::vec3(0.95f, 0.9f, 0.2f);
      if (y < 12 && (x % 2 == 0)) c = glm::vec3(0.02f);
      im.pixels.push_back(c);
    }
  return im;
}

/// Float height/roughness field: 64 x 64 linear values in [0, 1], concentric rings.
std::vector<std::uint16_t> rings16(int n) {
  std::vector<std::uint16_t> v;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const float dx = (float(x) + 0.5f) / float(n) - 0.5f, dy = (float(y) + 0.5f) / float(n) - 0.5f;
      const float r = std::sqrt(dx * dx + dy * dy);
      const float f = 0.5f + 0.5f * std::cos(2.0f * kPi * 6.0f * r);
      v.push_back(std::uint16_t(std::lround(f * 65535.0f)));
    }
  return v;
}

/// Writes an n x n PNG of \p depth bits per sample and libpng colour type \p color_type, row
/// by row: fill(y, row) writes row y's bytes (16-bit samples big-endian, as PNG stores them).
template <typename Fill>
void write_png_rows(const std::string& path, int n, int depth, int color_type, std::size_t row_bytes,
                    Fill fill) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) throw std::runtime_error("cannot write " + path);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    std::fclose(f);
    throw std::runtime_error("libpng failed on " + path);
  }
  png_init_io(png, f);
  png_set_IHDR(png, info, n, n, depth, color_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  std::vector<unsigned char> row(row_bytes);
  for (int y = 0; y < n; ++y) {
    fill(y, row.data());
    png_write_row(png, row.data());
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
}

/// Writes a 16-bit grey PNG (linear values; the scene says "encoding" "linear").
void write_png16(const std::string& path, int n, const std::vector<std::uint16_t>& v) {
  write_png_rows(path, n, 16, PNG_COLOR_TYPE_GRAY, 2 * std::size_t(n), [&](int y, unsigned char* row) {
    for (int x = 0; x < n; ++x) {
      const std::uint16_t s = v[std::size_t(y) * n + x];
      row[2 * x] = (unsigned char)(s >> 8);
      row[2 * x + 1] = (unsigned char)(s & 0xff);
    }
  });
}

/// Tangent-space normal map, 64 x 64: a 4 x 4 grid of domes (each the normal of a sphere cap
/// of height 0.35 over its 16 x 16 cell) with flat grooves between them; rgb = (n + 1) / 2.
std::vector<glm::vec3> dome_normals(int n) {
  std::vector<glm::vec3> v;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const float cx = (float(x % 16) + 0.5f) / 16.0f - 0.5f, cy = (float(y % 16) + 0.5f) / 16.0f - 0.5f;
      const float r2 = (cx * cx + cy * cy) / (0.42f * 0.42f);
      glm::vec3 nrm(0.0f, 0.0f, 1.0f);
      if (r2 < 1.0f) nrm = glm::normalize(glm::vec3(0.8f * cx / 0.42f, -0.8f * cy / 0.42f, std::sqrt(1.0f - r2) + 0.2f));
      v.push_back(0.5f * (nrm + glm::vec3(1.0f)));
    }
  return v;
}

/// Writes an 8-bit rgb PNG of linear values in [0, 1] (no sRGB curve: a normal map, which
/// pbrt-v4 reads linear whatever the file type).
void write_png8_linear(const std::string& path, int n, const std::vector<glm::vec3>& v) {
  write_png_rows(path, n, 8, PNG_COLOR_TYPE_RGB, 3 * std::size_t(n), [&](int y, unsigned char* row) {
    for (int x = 0; x < n * 3; ++x)
      row[x] = (unsigned char)std::lround(
          255.0f * std::fmin(1.0f, std::fmax(0.0f, v[std::size_t(y) * n + x / 3][x % 3])));
  });
}

/// Environment map, 64 x 64 equal-area octahedral square (pbrt-v4's layout; the pattern is
/// defined on the square itself): a smooth blue-to-warm gradient with values up to 1.2 and a
/// 3 x 3-texel "sun" of radiance 60 off-centre, so that importance sampling matters.
basalt::Image sky() {
  basalt::Image im{64, 64, {}};
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const float u = (float(x) + 0.5f) / 64.0f, v = (float(y) + 0.5f) / 64.0f;
      const float r = std::sqrt((u - 0.5f) * (u - 0.5f) + (v - 0.5f) * (v - 0.5f));
      glm::vec3 c = glm::mix(glm::vec3(0.25f, 0.45f, 1.2f), glm::vec3(0.5f, 0.35f, 0.2f),
                             std::fmin(1.0f, r * 1.6f));
      if (std::abs(x - 22) <= 1 && std::abs(y - 27) <= 1) c = glm::vec3(60.0f, 55.0f, 45.0f);
      im.pixels.push_back(c);
    }
  return im;
}

/// Lat-long environment map, 64 x 32 (pbrt-v3 InfiniteAreaLight layout, textures-spec 6.8:
/// row 0 is the +z pole, u = phi / 2 pi from +x towards +y): a sky whose blue deepens from
/// the horizon to the zenith, a dim brown ground below the horizon, and a sun of radiance 80
/// (texel centres within 0.09 rad of theta 1.05, phi 3.76; a few texels).
basalt::Image sky_latlong() {
  basalt::Image im{64, 32, {}};
  const float ts = 1.05f, ps = 3.76f;
  const glm::vec3 sun(std::sin(ts) * std::cos(ps), std::sin(ts) * std::sin(ps), std::cos(ts));
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const float theta = kPi * (float(y) + 0.5f) / float(im.height);
      const float phi = 2.0f * kPi * (float(x) + 0.5f) / float(im.width);
      const glm::vec3 w(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                        std::cos(theta));
      glm::vec3 c;
      if (w.z > 0.0f) {
        c = glm::mix(glm::vec3(0.9f, 0.95f, 1.1f), glm::vec3(0.2f, 0.4f, 1.0f), std::sqrt(w.z));
      } else {
        c = glm::mix(glm::vec3(0.3f, 0.25f, 0.2f), glm::vec3(0.12f, 0.1f, 0.08f), -w.z);
      }
      if (std::acos(std::fmin(1.0f, glm::dot(w, sun))) < 0.09f) c = glm::vec3(80.0f, 72.0f, 58.0f);
      im.pixels.push_back(c);
    }
  return im;
}

/// HDR float image, 64 x 32: a ramp from 0 to 4 in x with a red/blue split in y.
basalt::Image hdr_ramp() {
  basalt::Image im{64, 32, {}};
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const float a = 4.0f * float(x) / 63.0f;
      im.pixels.push_back(y < 16 ? glm::vec3(a, 0.2f * a, 0.1f) : glm::vec3(0.1f, 0.3f * a, a));
    }
  return im;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Writes the texture test images of scenes/data"};
  std::string dir = "scenes/data";
  app.add_option("dir", dir, "output folder");
  CLI11_PARSE(app, argc, argv);
  try {
    basalt::write_image(dir + "/tex-card.png", test_card());
    write_png16(dir + "/tex-rings16.png", 64, rings16(64));
    basalt::write_image(dir + "/tex-ramp.exr", hdr_ramp());
    basalt::write_image(dir + "/env-sky.exr", sky());
    basalt::write_image(dir + "/env-latlong.exr", sky_latlong());
    write_png8_linear(dir + "/normal-domes.png", 64, dome_normals(64));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "basalt_make_texture_data: %s\n", e.what());
    return 1;
  }
  return 0;
}
