// Image textures (docs/textures-spec.md section 4): decoding (PNG 8/16-bit, EXR, PFM), pbrt-v4's
// MIP pyramid, the MIPMap::Filter lookups of the CPU reference, imagemap parsing, and every
// class of bad image file reported at the parameter's file:line:column.
#include <gtest/gtest.h>
#include <png.h>
#include <unistd.h>
#include <zlib.h>

#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "common/scratch_dir.h"
#include "cpu/mipmap.h"
#include "cpu/texture.h"
#include "scene/images.h"
#include "scene/scene.h"
#include "scene/tables.h"
#include "scene/textures.h"

namespace fs = std::filesystem;
using namespace basalt;

namespace {

fs::path temp_dir() { return basalt::test::scratch_dir("image-texture"); }

// Writes a PNG of the given colour type and depth; `v` holds the samples (8 or 16 bit).
void write_png(const fs::path& path, int w, int h, int color_type, int depth,
               const std::vector<unsigned>& v, const std::vector<png_color>& palette = {}) {
  FILE* f = std::fopen(path.string().c_str(), "wb");
  ASSERT_NE(f, nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
    FAIL() << "libpng failed";
  }
  png_init_io(png, f);
  png_set_IHDR(png, info, png_uint_32(w), png_uint_32(h), depth, color_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (!palette.empty()) png_set_PLTE(png, info, palette.data(), int(palette.size()));
  png_write_info(png, info);
  const int spp = color_type == PNG_COLOR_TYPE_GRAY         ? 1
                  : color_type == PNG_COLOR_TYPE_GRAY_ALPHA ? 2
                  : color_type == PNG_COLOR_TYPE_RGB        ? 3
                  : color_type == PNG_COLOR_TYPE_RGBA       ? 4
                                                            : 1;
  const int bytes = depth == 16 ? 2 : 1;
  std::vector<unsigned char> row(std::size_t(w * spp * bytes));
  for (int y = 0; y < h; ++y) {
    for (int i = 0; i < w * spp; ++i) {
      const unsigned s = v[std::size_t(y * w * spp + i)];
      if (bytes == 2) {
        row[std::size_t(2 * i)] = (unsigned char)(s >> 8);
        row[std::size_t(2 * i + 1)] = (unsigned char)(s & 255);
      } else {
        row[std::size_t(i)] = (unsigned char)s;
      }
    }
    png_write_row(png, row.data());
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
}

void write_exr(const fs::path& path, int w, int h, const std::vector<float>& rgb, bool half) {
  Imf::Header header(w, h);
  const Imf::PixelType t = half ? Imf::HALF : Imf::FLOAT;
  for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(t));
  std::vector<Imath::half> hv(rgb.begin(), rgb.end());
  Imf::OutputFile file(path.string().c_str(), header);
  Imf::FrameBuffer fb;
  const std::size_t es = half ? sizeof(Imath::half) : sizeof(float);
  char* base = half ? reinterpret_cast<char*>(hv.data()) : (char*)rgb.data();
  for (int c = 0; c < 3; ++c)
    fb.insert(c == 0 ? "R" : c == 1 ? "G" : "B",
              Imf::Slice(t, base + c * es, 3 * es, 3 * es * std::size_t(w)));
  file.setFrameBuffer(fb);
  file.writePixels(h);
}

void write_bytes(const fs::path& path, const std::vector<unsigned char>& b) {
  std::ofstream o(path, std::ios::binary);
  o.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}
std::vector<unsigned char> read_bytes(const fs::path& path) {
  std::ifstream i(path, std::ios::binary);
  return std::vector<unsigned char>((std::istreambuf_iterator<char>(i)), std::istreambuf_iterator<char>());
}

double srgb(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

SourceLoc here() { return SourceLoc{"test", 1, 1}; }

// Tables holding one image's pyramid and an imagemap instruction reading it.
struct Fixture {
  SceneTables s;
  gpu::Texture t{};
  Fixture(const DecodedImage& img, std::uint32_t filter, std::uint32_t wrap = gpu::WRAP_REPEAT,
          float max_aniso = 8.0f) {
    s.globals.tex_tables = texture_shared_tables(s.tex_data);
    t.type = gpu::TEXTURE_IMAGEMAP;
    t.flags = gpu::MAPPING_UV | (filter << gpu::TEXFLAG_FILTER_SHIFT) | (wrap << gpu::TEXFLAG_WRAP_SHIFT);
    t.image = std::uint32_t(s.mip_levels.size());
    for (const MipImage& m : generate_pyramid(img, wrap)) {
      s.mip_levels.push_back({std::uint32_t(s.texels.size()), std::uint32_t(m.width),
                              std::uint32_t(m.height), std::uint32_t(m.channels)});
      s.texels.insert(s.texels.end(), m.texels.begin(), m.texels.end());
    }
    t.ip.x = std::uint32_t(s.mip_levels.size()) - t.image;
    t.param[0] = glm::vec4(1.0f, max_aniso, 0.0f, 0.0f);
    t.xform = glm::mat4(1.0f);
  }
  glm::vec3 filter(glm::vec2 st, glm::vec2 d0, glm::vec2 d1, bool f = false) const {
    return cpu::mipmap_filter(s, t, st, d0, d1, f);
  }
};

DecodedImage float_image(int w, int h, int c, const std::vector<float>& v) {
  DecodedImage d;
  d.width = w;
  d.height = h;
  d.channels = c;
  d.texels = v;
  d.storage = PixelStorage::Float;
  return d;
}

DecodedImage random_image(int w, int h, int c, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> v(std::size_t(w * h * c));
  for (float& x : v) x = u(rng);
  return float_image(w, h, c, v);
}

const std::string kLight = "LightSource \"point\"\n";

// The what() of the SceneError that parsing text throws ("" if it parses).
std::string error_of(const std::string& text) {
  try {
    load_scene_from_string(text + kLight, "t.pbrt", temp_dir().string());
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

std::string texture_line(const std::string& file, const std::string& extra = "") {
  return "WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"" + file +
         "\"" + extra + "\n";
}

}  // namespace

// ---- lookups ------------------------------------------------------------------------------

TEST(ImageTexture, BilinearReproducesLinearRampExactly) {
  // 8 x 4 image, value = x (pixel centre at (x + 0.5) / 8).
  std::vector<float> v;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) v.push_back(float(x));
  Fixture f(float_image(8, 4, 1, v), gpu::FILTER_BILINEAR);
  for (float x : {0.0f, 0.5f, 0.75f, 1.0f, 2.25f, 3.5f, 6.875f, 7.0f})
    for (float y : {0.125f, 0.5f, 0.8125f}) {
      const glm::vec2 st((x + 0.5f) / 8.0f, y);
      const glm::vec3 r = f.filter(st, glm::vec2(0.0f), glm::vec2(0.0f));
      EXPECT_EQ(r.x, x) << "s = " << st.x;
      EXPECT_EQ(r.y, x);
      EXPECT_EQ(r.z, x);
    }
}

TEST(ImageTexture, TrilinearLevelMatchesFootprint) {
  Fixture f(random_image(16, 16, 3, 7), gpu::FILTER_TRILINEAR);
  ASSERT_EQ(f.t.ip.x, 5u);
  const glm::vec2 st(0.37f, 0.61f);
  auto bil = [&](int l) { return cpu::mipmap_bilerp(f.s, f.t.image + l, st, gpu::WRAP_REPEAT, false); };
  // width = 2 max|d| = 1/4: level = 4 + log2(1/4) = 2 exactly.
  const glm::vec3 at2 = f.filter(st, glm::vec2(0.125f, 0.0f), glm::vec2(0.0f, 0.05f));
  EXPECT_NEAR(at2.x, bil(2).x, 2e-6f);
  EXPECT_NEAR(at2.y, bil(2).y, 2e-6f);
  EXPECT_GT(std::fabs(at2.x - bil(1).x) + std::fabs(at2.x - bil(3).x), 1e-4f);
  // width = 2^-1.5: level 2.5, halfway between levels 2 and 3.
  const float d = 0.5f * std::pow(2.0f, -1.5f);
  const glm::vec3 mid = f.filter(st, glm::vec2(0.0f, d), glm::vec2(0.0f));
  const glm::vec3 want = 0.5f * bil(2) + 0.5f * bil(3);
  EXPECT_NEAR(mid.x, want.x, 1e-5f);
  EXPECT_NEAR(mid.z, want.z, 1e-5f);
  // A footprint wider than the image: the 1x1 top level.
  const glm::vec3 top = f.filter(st, glm::vec2(2.0f, 0.0f), glm::vec2(0.0f));
  EXPECT_EQ(top, cpu::mipmap_texel(f.s, f.t.image + 4, {0, 0}, gpu::WRAP_REPEAT, false));
  // Bilinear also picks the footprint's level (pbrt-v4 quirk), without blending.
  Fixture b(random_image(16, 16, 3, 7), gpu::FILTER_BILINEAR);
  const glm::vec3 b2 = b.filter(st, glm::vec2(0.0f, d), glm::vec2(0.0f));
  EXPECT_EQ(b2, bil(2));
}

TEST(ImageTexture, EwaOfConstantImageIsThatConstant) {
  std::vector<float> v(std::size_t(32 * 16 * 3));
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = i % 3 == 0 ? 0.25f : i % 3 == 1 ? 0.5f : 0.75f;
  Fixture f(float_image(32, 16, 3, v), gpu::FILTER_EWA);
  const glm::vec2 feet[][2] = {{{0.01f, 0.0f}, {0.0f, 0.01f}},
                               {{0.1f, 0.02f}, {-0.001f, 0.003f}},
                               {{0.002f, 0.5f}, {0.03f, 0.0f}},
                               {{3.0f, 1.0f}, {1.0f, 2.0f}},
                               {{1e-5f, 0.0f}, {0.0f, 1e-6f}}};
  for (const auto& ft : feet)
    for (glm::vec2 st : {glm::vec2(0.5f), glm::vec2(0.01f, 0.99f), glm::vec2(-3.7f, 12.2f)}) {
      const glm::vec3 r = f.filter(st, ft[0], ft[1]);
      EXPECT_NEAR(r.x, 0.25f, 1e-6f);
      EXPECT_NEAR(r.y, 0.5f, 1e-6f);
      EXPECT_NEAR(r.z, 0.75f, 1e-6f);
    }
}

TEST(ImageTexture, ZeroFootprintIsLevelZeroLookup) {
  const DecodedImage img = random_image(8, 8, 3, 3);
  Fixture p(img, gpu::FILTER_POINT), b(img, gpu::FILTER_BILINEAR), t(img, gpu::FILTER_TRILINEAR),
      e(img, gpu::FILTER_EWA);
  for (glm::vec2 st : {glm::vec2(0.3f, 0.7f), glm::vec2(0.0625f, 0.9375f), glm::vec2(1.3f, -0.2f)}) {
    const glm::vec3 bl = cpu::mipmap_bilerp(b.s, b.t.image, st, gpu::WRAP_REPEAT, false);
    EXPECT_EQ(b.filter(st, glm::vec2(0.0f), glm::vec2(0.0f)), bl);
    EXPECT_EQ(t.filter(st, glm::vec2(0.0f), glm::vec2(0.0f)), bl);
    EXPECT_EQ(e.filter(st, glm::vec2(0.0f), glm::vec2(0.0f)), bl);
    const glm::ivec2 xi(int(std::round(st.x * 8 - 0.5f)), int(std::round(st.y * 8 - 0.5f)));
    EXPECT_EQ(p.filter(st, glm::vec2(0.0f), glm::vec2(0.0f)),
              cpu::mipmap_texel(p.s, p.t.image, xi, gpu::WRAP_REPEAT, false));
  }
  // Bilinear at texel centres returns the texel.
  const glm::vec3 c = b.filter(glm::vec2(2.5f / 8, 5.5f / 8), glm::vec2(0.0f), glm::vec2(0.0f));
  EXPECT_EQ(c, cpu::mipmap_texel(b.s, b.t.image, {2, 5}, gpu::WRAP_REPEAT, false));
  // Float lookups: Texel reads red, Bilerp averages r, g, b (pbrt-v4 MIPMap::Bilerp<Float>).
  const glm::vec3 tf = cpu::mipmap_texel(b.s, b.t.image, {2, 5}, gpu::WRAP_REPEAT, true);
  EXPECT_EQ(tf, glm::vec3(c.x));
  const glm::vec3 bf = b.filter(glm::vec2(2.5f / 8, 5.5f / 8), glm::vec2(0.0f), glm::vec2(0.0f), true);
  EXPECT_EQ(bf, glm::vec3((c.x + c.y + c.z) / 3.0f));
}

TEST(ImageTexture, WrapModes) {
  Fixture f(random_image(4, 4, 3, 11), gpu::FILTER_POINT);
  const auto& s = f.s;
  const std::uint32_t l = f.t.image;
  EXPECT_EQ(cpu::mipmap_texel(s, l, {-1, 5}, gpu::WRAP_REPEAT, false),
            cpu::mipmap_texel(s, l, {3, 1}, gpu::WRAP_REPEAT, false));
  EXPECT_EQ(cpu::mipmap_texel(s, l, {-1, 5}, gpu::WRAP_CLAMP, false),
            cpu::mipmap_texel(s, l, {0, 3}, gpu::WRAP_CLAMP, false));
  EXPECT_EQ(cpu::mipmap_texel(s, l, {-1, 2}, gpu::WRAP_BLACK, false), glm::vec3(0.0f));
  // Octahedral: x = -1 mirrors to x = 1 and y to res - 1 - y.
  EXPECT_EQ(cpu::mipmap_texel(s, l, {-1, 0}, gpu::WRAP_OCTAHEDRAL, false),
            cpu::mipmap_texel(s, l, {1, 3}, gpu::WRAP_OCTAHEDRAL, false));
}

TEST(ImageTexture, NonPowerOfTwoPyramidHasPbrtSizes) {
  std::vector<float> v(std::size_t(5 * 3), 0.4f);
  const std::vector<MipImage> p = generate_pyramid(float_image(5, 3, 1, v), gpu::WRAP_CLAMP);
  ASSERT_EQ(p.size(), 4u);  // 8x4, 4x2, 2x1, 1x1
  EXPECT_EQ(p[0].width, 8);
  EXPECT_EQ(p[0].height, 4);
  EXPECT_EQ(p[1].width, 4);
  EXPECT_EQ(p[2].width, 2);
  EXPECT_EQ(p[2].height, 1);
  EXPECT_EQ(p[3].width, 1);
  EXPECT_EQ(p[3].height, 1);
  for (const MipImage& m : p)
    for (float x : m.texels) EXPECT_NEAR(x, 0.4f, 1e-6f);  // normalised resampling weights
  // 1 x 5: 1 x 8, 1 x 4, 1 x 2, 1 x 1.
  const std::vector<MipImage> q = generate_pyramid(float_image(1, 5, 1, std::vector<float>(5, 1.0f)), gpu::WRAP_REPEAT);
  ASSERT_EQ(q.size(), 4u);
  EXPECT_EQ(q[0].height, 8);
  EXPECT_EQ(q[0].width, 1);
  // The windowed-sinc resampling rings below 0; pbrt-v4 clamps at 0.
  std::vector<float> spike(std::size_t(3 * 3), 0.0f);
  spike[4] = 1.0f;
  for (const MipImage& m : generate_pyramid(float_image(3, 3, 1, spike), gpu::WRAP_CLAMP))
    for (float x : m.texels) EXPECT_GE(x, 0.0f);
  // A power-of-two float image is level 0 unchanged; level 1 the 2x2 box average.
  const DecodedImage r = random_image(4, 2, 1, 5);
  const std::vector<MipImage> rp = generate_pyramid(r, gpu::WRAP_REPEAT);
  EXPECT_EQ(rp[0].texels, r.texels);
  EXPECT_EQ(rp[1].texels[1], (r.texels[2] + r.texels[3] + r.texels[6] + r.texels[7]) / 4);
}

TEST(ImageTexture, EightBitLevelsAreRequantised) {
  // pbrt-v4 stores every level of an 8-bit image as 8-bit again (CopyRectIn with the encoding).
  const fs::path f = temp_dir() / "q.png";
  write_png(f, 2, 1, PNG_COLOR_TYPE_GRAY, 8, {0, 101});
  const DecodedImage img = read_texture_image(f.string(), ColorEncoding{}, here());
  const std::vector<MipImage> p = generate_pyramid(img, gpu::WRAP_REPEAT);
  ASSERT_EQ(p.size(), 2u);
  const float mean = (img.texels[0] + img.texels[1] + img.texels[0] + img.texels[1]) / 4;
  // The stored 1x1 level is the sRGB byte nearest to the mean, decoded.
  const int b = int(std::lround(255.0 * (1.055 * std::pow(double(mean), 1 / 2.4) - 0.055)));
  EXPECT_FLOAT_EQ(p[1].texels[0], float(srgb(b / 255.0)));
  EXPECT_NE(p[1].texels[0], mean);
  // gamma 2.2: pbrt-v4's 1024-entry inverse table turns byte 10 into 0 even at level 0.
  const DecodedImage g = read_texture_image(f.string(), {ImageEncoding::Gamma, 2.2f}, here());
  const fs::path f10 = temp_dir() / "g10.png";
  write_png(f10, 1, 1, PNG_COLOR_TYPE_GRAY, 8, {10});
  const DecodedImage g10 = read_texture_image(f10.string(), {ImageEncoding::Gamma, 2.2f}, here());
  EXPECT_GT(g10.texels[0], 0.0f);
  EXPECT_EQ(generate_pyramid(g10, gpu::WRAP_REPEAT)[0].texels[0], 0.0f);
  EXPECT_EQ(generate_pyramid(g, gpu::WRAP_REPEAT)[0].texels[1], g.texels[1]);  // 101 survives
}

// ---- decoding -----------------------------------------------------------------------------

TEST(ImageTexture, SrgbDecodeOfKnownBytes) {
  const fs::path f = temp_dir() / "srgb.png";
  write_png(f, 5, 1, PNG_COLOR_TYPE_RGB, 8,
            {0, 1, 10, 50, 128, 200, 255, 255, 255, 12, 34, 56, 90, 180, 240});
  const DecodedImage img = read_texture_image(f.string(), ColorEncoding{}, here());
  EXPECT_EQ(img.width, 5);
  EXPECT_EQ(img.height, 1);
  EXPECT_EQ(img.channels, 3);
  EXPECT_EQ(img.storage, PixelStorage::U8);
  const unsigned bytes[] = {0, 1, 10, 50, 128, 200, 255, 255, 255, 12, 34, 56, 90, 180, 240};
  for (int i = 0; i < 15; ++i) EXPECT_EQ(img.texels[std::size_t(i)], float(srgb(bytes[i] / 255.0))) << i;
  EXPECT_EQ(img.texels[0], 0.0f);
  EXPECT_EQ(img.texels[6], 1.0f);
  EXPECT_NEAR(img.texels[4], 0.2158605f, 1e-7f);  // 128
  const DecodedImage lin = read_texture_image(f.string(), {ImageEncoding::Linear, 1.0f}, here());
  EXPECT_EQ(lin.texels[4], 128.0f / 255.0f);
  const DecodedImage gam = read_texture_image(f.string(), {ImageEncoding::Gamma, 2.2f}, here());
  EXPECT_EQ(gam.texels[4], std::pow(128.0f / 255.0f, 2.2f));
}

TEST(ImageTexture, PngLayouts) {
  // grey+alpha: alpha dropped, 1 channel; RGBA: 3 channels; palette: expanded to rgb.
  const fs::path ga = temp_dir() / "ga.png", rgba = temp_dir() / "rgba.png", pal = temp_dir() / "pal.png";
  write_png(ga, 2, 1, PNG_COLOR_TYPE_GRAY_ALPHA, 8, {255, 0, 0, 255});
  write_png(rgba, 1, 1, PNG_COLOR_TYPE_RGBA, 8, {255, 0, 255, 7});
  write_png(pal, 2, 1, PNG_COLOR_TYPE_PALETTE, 8, {1, 0}, {{10, 20, 30}, {255, 128, 0}});
  const ColorEncoding lin{ImageEncoding::Linear, 1.0f};
  const DecodedImage a = read_texture_image(ga.string(), lin, here());
  EXPECT_EQ(a.channels, 1);
  EXPECT_EQ(a.texels, (std::vector<float>{1.0f, 0.0f}));
  const DecodedImage b = read_texture_image(rgba.string(), lin, here());
  EXPECT_EQ(b.channels, 3);
  EXPECT_EQ(b.texels, (std::vector<float>{1.0f, 0.0f, 1.0f}));
  const DecodedImage c = read_texture_image(pal.string(), lin, here());
  EXPECT_EQ(c.channels, 3);
  EXPECT_EQ(c.texels, (std::vector<float>{1.0f, 128 / 255.0f, 0.0f, 10 / 255.0f, 20 / 255.0f, 30 / 255.0f}));
}

TEST(ImageTexture, SixteenBitPng) {
  const fs::path f = temp_dir() / "g16.png";
  write_png(f, 4, 1, PNG_COLOR_TYPE_GRAY, 16, {0, 1000, 32768, 65535});
  const DecodedImage lin = read_texture_image(f.string(), {ImageEncoding::Linear, 1.0f}, here());
  EXPECT_EQ(lin.channels, 1);
  EXPECT_EQ(lin.storage, PixelStorage::Half);  // pbrt-v4 stores 16-bit PNGs as Half
  EXPECT_EQ(lin.texels[0], 0.0f);
  EXPECT_EQ(lin.texels[2], float(Imath::half(32768.0f / 65535.0f)));
  EXPECT_EQ(lin.texels[3], 1.0f);
  EXPECT_NE(lin.texels[1], 1000.0f / 65535.0f);  // rounded to half
  EXPECT_NEAR(lin.texels[1], 1000.0f / 65535.0f, 1e-5f);
  // The encoding applies to 16-bit PNGs too (pbrt-v4 ReadPNG: ToFloatLinear).
  const DecodedImage s = read_texture_image(f.string(), ColorEncoding{}, here());
  EXPECT_EQ(s.texels[2], float(Imath::half(float(srgb(32768.0 / 65535.0)))));
  const fs::path c = temp_dir() / "c16.png";
  write_png(c, 1, 1, PNG_COLOR_TYPE_RGB, 16, {65535, 0, 32768});
  const DecodedImage rgb = read_texture_image(c.string(), {ImageEncoding::Linear, 1.0f}, here());
  EXPECT_EQ(rgb.channels, 3);
  EXPECT_EQ(rgb.texels[0], 1.0f);
  EXPECT_EQ(rgb.texels[1], 0.0f);
}

TEST(ImageTexture, ExrAndPfm) {
  const fs::path f = temp_dir() / "a.exr", h = temp_dir() / "h.exr";
  const std::vector<float> v = {0.1f, 2.5f, 100.0f, 0.0f, 1.0f, 0.333f};
  write_exr(f, 2, 1, v, false);
  write_exr(h, 2, 1, v, true);
  const DecodedImage a = read_texture_image(f.string(), ColorEncoding{}, here());
  EXPECT_EQ(a.channels, 3);
  EXPECT_EQ(a.storage, PixelStorage::Float);
  EXPECT_EQ(a.texels, v);  // linear, encoding ignored
  const DecodedImage b = read_texture_image(h.string(), ColorEncoding{}, here());
  EXPECT_EQ(b.storage, PixelStorage::Half);
  EXPECT_EQ(b.texels[5], float(Imath::half(0.333f)));
  // PFM: rows bottom to top, negative scale = little endian.
  const fs::path p = temp_dir() / "a.pfm";
  std::string hdr = "Pf\n1 2\n-1.0\n";
  std::vector<unsigned char> bytes(hdr.begin(), hdr.end());
  for (float x : {0.25f, 0.75f}) {
    unsigned char b4[4];
    std::memcpy(b4, &x, 4);
    bytes.insert(bytes.end(), b4, b4 + 4);
  }
  write_bytes(p, bytes);
  const DecodedImage c = read_texture_image(p.string(), ColorEncoding{}, here());
  EXPECT_EQ(c.channels, 1);
  EXPECT_EQ(c.texels, (std::vector<float>{0.75f, 0.25f}));
}

// ---- parsing and bad input ---------------------------------------------------------------

TEST(ImageTexture, ParsesPbrtDefaultsAndSharesDecodedImages) {
  const fs::path f = temp_dir() / "p.png";
  write_png(f, 2, 2, PNG_COLOR_TYPE_RGB, 8, std::vector<unsigned>(12, 200));
  const std::string text = texture_line("p.png") +
                           "Texture \"u\" \"spectrum\" \"imagemap\" \"string filename\" \"p.png\" "
                           "\"string filter\" \"ewa\" \"string wrap\" \"clamp\" \"bool invert\" true "
                           "\"float scale\" 2 \"float maxanisotropy\" 4\n"
                           "Texture \"v\" \"float\" \"imagemap\" \"string filename\" \"p.png\" "
                           "\"string encoding\" \"gamma 2.2\"\n";
  const Scene sc = load_scene_from_string(text + kLight, "t.pbrt", temp_dir().string());
  ASSERT_EQ(sc.textures.size(), 3u);
  const TextureDef& t = sc.textures[0];
  EXPECT_EQ((t.flags & gpu::TEXFLAG_FILTER_MASK) >> gpu::TEXFLAG_FILTER_SHIFT, gpu::FILTER_BILINEAR);
  EXPECT_EQ((t.flags & gpu::TEXFLAG_WRAP_MASK) >> gpu::TEXFLAG_WRAP_SHIFT, gpu::WRAP_REPEAT);
  EXPECT_EQ(t.flags & gpu::TEXFLAG_INVERT, 0u);
  EXPECT_EQ(t.param[0], glm::vec4(1.0f, 8.0f, 0.0f, 0.0f));
  EXPECT_EQ(t.image_encoding.kind, ImageEncoding::SRGB);
  const TextureDef& u = sc.textures[1];
  EXPECT_EQ((u.flags & gpu::TEXFLAG_FILTER_MASK) >> gpu::TEXFLAG_FILTER_SHIFT, gpu::FILTER_EWA);
  EXPECT_EQ((u.flags & gpu::TEXFLAG_WRAP_MASK) >> gpu::TEXFLAG_WRAP_SHIFT, gpu::WRAP_CLAMP);
  EXPECT_NE(u.flags & gpu::TEXFLAG_INVERT, 0u);
  EXPECT_EQ(u.param[0], glm::vec4(2.0f, 4.0f, 0.0f, 0.0f));
  EXPECT_EQ(sc.textures[2].image_encoding.kind, ImageEncoding::Gamma);
  EXPECT_EQ(sc.textures[2].image_encoding.gamma, 2.2f);
  // Same file and encoding: one decoded image; another encoding: a second one.
  EXPECT_EQ(sc.images.size(), 2u);
  EXPECT_EQ(t.image, u.image);
  EXPECT_NE(t.image, sc.textures[2].image);
  // Programs: image = first level, ip.x = levels; each (image, wrap) pyramid once.
  std::vector<gpu::Texture> table;
  std::vector<gpu::MipLevel> levels;
  std::vector<float> texels;
  TextureProgramBuilder b(sc, &table);
  b.set_image_tables(&levels, &texels);
  const std::uint32_t rt = b.program("t", true, SourceLoc{});
  const std::uint32_t ru = b.program("u", true, SourceLoc{});
  const std::uint32_t ra = b.program("t", true, SourceLoc{}, true);
  EXPECT_EQ(table[rt].image, 0u);
  EXPECT_EQ(table[rt].ip.x, 2u);
  EXPECT_EQ(table[ru].image, 2u);  // other wrap mode: its own pyramid
  EXPECT_EQ(table[ra].image, 0u);
  EXPECT_EQ(table[rt].flags & gpu::TEXFLAG_ALBEDO, 0u);
  EXPECT_NE(table[ra].flags & gpu::TEXFLAG_ALBEDO, 0u);
  EXPECT_EQ(levels.size(), 4u);
}

TEST(ImageTexture, EvaluatesFlippedScaledInvertedAndAlbedoClamped) {
  // 2 x 2 linear EXR: top row red, green; bottom row blue, white*3.
  const fs::path f = temp_dir() / "e.exr";
  write_exr(f, 2, 2, {1, 0, 0, 0, 1, 0, 0, 0, 1, 3, 3, 3}, false);
  const std::string text = texture_line(f.string(), " \"string filter\" \"point\"") +
                           "Texture \"s\" \"spectrum\" \"imagemap\" \"string filename\" \"" + f.string() +
                           "\" \"string filter\" \"point\" \"float scale\" 0.5 \"bool invert\" true\n"
                           "Texture \"f\" \"float\" \"imagemap\" \"string filename\" \"" + f.string() +
                           "\" \"string filter\" \"point\"\n";
  const Scene sc = load_scene_from_string(text + kLight, "t.pbrt", temp_dir().string());
  SceneTables s;
  s.globals.tex_tables = texture_shared_tables(s.tex_data);
  TextureProgramBuilder b(sc, &s.textures);
  b.set_image_tables(&s.mip_levels, &s.texels);
  const std::uint32_t t = b.program("t", true, SourceLoc{});
  const std::uint32_t ta = b.program("t", true, SourceLoc{}, true);
  const std::uint32_t si = b.program("s", true, SourceLoc{});
  const std::uint32_t fl = b.program("f", false, SourceLoc{});
  cpu::TextureContext c;
  c.uv = glm::vec2(0.25f, 0.75f);  // v = 0.75: the top row (t is flipped)
  EXPECT_EQ(cpu::tex_eval_rgb(s, t, c), glm::vec3(1, 0, 0));
  c.uv = glm::vec2(0.75f, 0.25f);
  EXPECT_EQ(cpu::tex_eval_rgb(s, t, c), glm::vec3(3.0f));
  EXPECT_EQ(cpu::tex_eval_rgb(s, ta, c), glm::vec3(1.0f));          // albedo: clamped to 1
  EXPECT_EQ(cpu::tex_eval_rgb(s, si, c), glm::vec3(0.0f));          // max(0, 1 - 1.5)
  EXPECT_EQ(cpu::tex_eval_float(s, fl, c), 3.0f);
  c.uv = glm::vec2(0.75f, 0.75f);
  EXPECT_EQ(cpu::tex_eval_rgb(s, si, c), glm::vec3(1.0f, 0.5f, 1.0f));
  EXPECT_EQ(cpu::tex_eval_float(s, fl, c), 0.0f);  // red channel of green
}

TEST(ImageTexture, BadFilesAreLocatedErrorsNamingTheFile) {
  const fs::path d = temp_dir();
  // missing
  EXPECT_EQ(error_of(texture_line("nope.png")),
            "t.pbrt:2:35: error: image file \"" + (d / "nope.png").string() +
                "\": No such file or directory");
  // unreadable (a directory)
  fs::create_directories(d / "dir.png");
  EXPECT_EQ(error_of(texture_line("dir.png")),
            "t.pbrt:2:35: error: image file \"" + (d / "dir.png").string() + "\": is a directory");
  // truncated PNG
  write_png(d / "whole.png", 16, 16, PNG_COLOR_TYPE_RGB, 8, std::vector<unsigned>(16 * 16 * 3, 77));
  std::vector<unsigned char> bytes = read_bytes(d / "whole.png");
  write_bytes(d / "cut.png", std::vector<unsigned char>(bytes.begin(), bytes.begin() + long(bytes.size() / 2)));
  std::string e = error_of(texture_line("cut.png"));
  EXPECT_EQ(e.rfind("t.pbrt:2:35: error: image file \"" + (d / "cut.png").string() + "\": ", 0), 0u) << e;
  EXPECT_NE(e.find("truncated"), std::string::npos) << e;
  // corrupt PNG (garbage), corrupt EXR, corrupt PFM
  write_bytes(d / "junk.png", {'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd'});
  e = error_of(texture_line("junk.png"));
  EXPECT_EQ(e.rfind("t.pbrt:2:35: error: image file \"" + (d / "junk.png").string() + "\": not a PNG", 0), 0u) << e;
  std::vector<unsigned char> bad = bytes;
  for (std::size_t i = 40; i < bad.size(); i += 7) bad[i] ^= 0x5a;
  write_bytes(d / "flipped.png", bad);
  e = error_of(texture_line("flipped.png"));
  EXPECT_EQ(e.rfind("t.pbrt:2:35: error: image file \"" + (d / "flipped.png").string() + "\": corrupt", 0), 0u) << e;
  write_bytes(d / "junk.exr", {'v', '/', '1', 1, 0, 0, 0, 0, 0});
  e = error_of(texture_line("junk.exr"));
  EXPECT_EQ(e.rfind("t.pbrt:2:35: error: image file \"" + (d / "junk.exr").string() + "\": corrupt", 0), 0u) << e;
  write_exr(d / "whole.exr", 8, 8, std::vector<float>(8 * 8 * 3, 0.5f), false);
  std::vector<unsigned char> ex = read_bytes(d / "whole.exr");
  write_bytes(d / "cut.exr", std::vector<unsigned char>(ex.begin(), ex.begin() + long(ex.size() / 2)));
  e = error_of(texture_line("cut.exr"));
  EXPECT_EQ(e.rfind("t.pbrt:2:35: error: image file \"" + (d / "cut.exr").string() + "\": ", 0), 0u) << e;
  write_bytes(d / "cut.pfm", {'P', 'F', '\n', '4', ' ', '4', '\n', '-', '1', '\n', 0, 0, 0, 0});
  e = error_of(texture_line("cut.pfm"));
  EXPECT_EQ(e, "t.pbrt:2:35: error: image file \"" + (d / "cut.pfm").string() +
                   "\": unexpected end of file (truncated)");
  // zero-size images
  write_bytes(d / "zero.pfm", {'P', 'F', '\n', '0', ' ', '0', '\n', '-', '1', '\n'});
  EXPECT_EQ(error_of(texture_line("zero.pfm")),
            "t.pbrt:2:35: error: image file \"" + (d / "zero.pfm").string() + "\": the image has zero size");
  {
    // A PNG whose IHDR says width 0 (CRC fixed up so that only the size is wrong).
    std::vector<unsigned char> z = bytes;
    z[16] = z[17] = z[18] = z[19] = 0;  // width
    const unsigned long crc = crc32(crc32(0L, nullptr, 0), z.data() + 12, 17);
    z[29] = (unsigned char)(crc >> 24);
    z[30] = (unsigned char)(crc >> 16);
    z[31] = (unsigned char)(crc >> 8);
    z[32] = (unsigned char)crc;
    write_bytes(d / "zero.png", z);
    e = error_of(texture_line("zero.png"));
    EXPECT_EQ(e.rfind("t.pbrt:2:35: error: image file \"" + (d / "zero.png").string() + "\": ", 0), 0u) << e;
    EXPECT_NE(e.find("zero"), std::string::npos) << e;
  }
  // unsupported extension, no filename, bad parameters
  write_bytes(d / "x.webp", {1, 2, 3});
  e = error_of(texture_line("x.webp"));
  EXPECT_NE(e.find("unsupported image format"), std::string::npos) << e;
  // a truncated file of a format stb_image reads
  write_bytes(d / "x.tga", {1, 2, 3});
  e = error_of(texture_line("x.tga"));
  EXPECT_NE(e.find("x.tga\": corrupt or unsupported image"), std::string::npos) << e;
  // A TGA header claiming 8192 x 8192 RGB with three bytes of pixels: stb reads past the end as
  // zeros, so without a size check it decoded 200 MB and basalt made 800 MB of floats from it
  // (the image fuzzer's out-of-memory find, at 859 MB). Refused from its header now.
  write_bytes(d / "huge.tga", {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x00, 0x20, 0x00, 0x20, 24, 0, 1, 2, 3});
  EXPECT_EQ(error_of(texture_line("huge.tga")),
            "t.pbrt:2:35: error: image file \"" + (d / "huge.tga").string() +
                "\": the image is too large (8192 x 8192)");
  EXPECT_EQ(error_of("WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\"\n"),
            "t.pbrt:2:1: error: imagemap texture \"t\" needs a \"string filename\" parameter");
  write_png(d / "ok.png", 1, 1, PNG_COLOR_TYPE_GRAY, 8, {3});
  EXPECT_EQ(error_of(texture_line("ok.png", " \"string filter\" \"cubic\"")),
            "t.pbrt:2:62: error: unknown image filter \"cubic\" (expected point, bilinear, trilinear or ewa)");
  EXPECT_NE(error_of(texture_line("ok.png", " \"string wrap\" \"mirror\"")).find("unknown wrap mode"), std::string::npos);
  EXPECT_NE(error_of(texture_line("ok.png", " \"string encoding\" \"gamma x\"")).find("unknown color encoding"),
            std::string::npos);
  EXPECT_EQ(error_of(texture_line("ok.png")), "");
}

#include <stb_image_write.h>

namespace basalt {
namespace {

TEST(ImageTexture, StbFormatsAsPbrtReadsThem) {
  // TGA (written by hand: uncompressed 24-bit BGR, bottom-up), JPEG and HDR (stb_image_write):
  // pbrt-v4's Image::Read decodes 8-bit formats as sRGB whatever the texture's encoding, and
  // Radiance HDR as linear float.
  const fs::path tga = temp_dir() / "t.tga";
  {
    const unsigned char header[18] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 2, 0, 24, 0};
    std::ofstream out(tga, std::ios::binary);
    out.write(reinterpret_cast<const char*>(header), 18);
    // Bottom-up: first the bottom row (0, 128, 255 in rgb), then the top row (255, 64, 0).
    const unsigned char px[12] = {255, 128, 0, 255, 128, 0, 0, 64, 255, 0, 64, 255};
    out.write(reinterpret_cast<const char*>(px), 12);
  }
  const DecodedImage t = read_texture_image(tga.string(), {ImageEncoding::Linear, 1.0f}, here());
  ASSERT_EQ(t.width, 2);
  ASSERT_EQ(t.height, 2);
  ASSERT_EQ(t.channels, 3);
  EXPECT_EQ(t.storage, PixelStorage::U8);
  auto srgb = [](double b) {
    const double v = b / 255.0;
    return float(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
  };
  // Row 0 is the top row of the image: (255, 64, 0), sRGB-decoded despite "linear".
  EXPECT_FLOAT_EQ(t.texels[0], 1.0f);
  EXPECT_FLOAT_EQ(t.texels[1], srgb(64));
  EXPECT_FLOAT_EQ(t.texels[2], 0.0f);
  EXPECT_FLOAT_EQ(t.texels[7], srgb(128));

  const fs::path jpg = temp_dir() / "g.jpg";
  std::vector<unsigned char> grey(16 * 16, 200);
  ASSERT_NE(stbi_write_jpg(jpg.string().c_str(), 16, 16, 1, grey.data(), 95), 0);
  const DecodedImage j = read_texture_image(jpg.string(), ColorEncoding{}, here());
  ASSERT_EQ(j.channels, 3);  // stb's JPEG writer stores three components, even for grey
  for (float v : j.texels) EXPECT_NEAR(v, srgb(200), 0.01f);

  const fs::path hdr = temp_dir() / "h.hdr";
  const float rgb[6] = {0.5f, 2.0f, 8.0f, 0.25f, 1.0f, 16.0f};
  ASSERT_NE(stbi_write_hdr(hdr.string().c_str(), 2, 1, 3, rgb), 0);
  const DecodedImage h = read_texture_image(hdr.string(), ColorEncoding{}, here());
  ASSERT_EQ(h.channels, 3);
  EXPECT_EQ(h.storage, PixelStorage::Float);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(h.texels[i], rgb[i], 0.01f * rgb[i]);  // RGBE: 8-bit mantissas

  // A corrupt file of a supported extension is an error naming it.
  const fs::path bad = temp_dir() / "bad.jpg";
  std::ofstream(bad, std::ios::binary) << "not a jpeg at all";
  try {
    read_texture_image(bad.string(), ColorEncoding{}, here());
    ADD_FAILURE() << "no error for a corrupt jpeg";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.jpg"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("corrupt"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace basalt
