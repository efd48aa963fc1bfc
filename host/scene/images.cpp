// Image decoding (PNG, OpenEXR, PFM) and pbrt-v4's MIP pyramid; see images.h and
// docs/textures-spec.md section 4.
#include "scene/images.h"

#include <png.h>
#include <stb_image.h>

#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "../../shaders/shared/layout.h"
#include "scene/scene.h"
#include "util/files.h"

namespace basalt {
namespace {

namespace fs = std::filesystem;

/// Most floats one decoded image may have: what the texel tables hold (TEXEL_CHUNK_COUNT
/// bindings of 2^TEXEL_CHUNK_SHIFT floats, layout.h), checked before decoding allocates.
constexpr std::uint64_t kMaxImageTexels = std::uint64_t(TEXEL_CHUNK_COUNT) << TEXEL_CHUNK_SHIFT;

[[noreturn]] void fail(const SourceLoc& loc, const std::string& path, const std::string& what) {
  throw SceneError(loc, "image file \"" + path + "\": " + what);
}

std::string lower_ext(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

// The whole file; a missing or unreadable file is an error naming it.
std::vector<unsigned char> read_file(const std::string& path, const SourceLoc& loc) {
  try {
    const std::string data = read_regular_file(path);
    return std::vector<unsigned char>(data.begin(), data.end());
  } catch (const FileError& e) {
    fail(loc, path, e.what());
  }
}

// The exact sRGB decoding curve (IEC 61966-2-1), in double.
double srgb_to_linear(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}
double linear_to_srgb(double v) {
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

// pbrt-v4 ColorEncoding::ToLinear of one byte (sRGB: the exact curve; pbrt-v4 tabulates it).
float byte_to_linear(std::uint8_t b, const ColorEncoding& enc) {
  switch (enc.kind) {
    case ImageEncoding::SRGB:
      return float(srgb_to_linear(double(b) / 255.0));
    case ImageEncoding::Linear:
      return float(b) / 255.0f;
    case ImageEncoding::Gamma:
      return std::pow(float(b) / 255.0f, enc.gamma);
  }
  return 0.0f;
}

// TGA, JPEG, BMP, GIF (8-bit, through stb_image) and Radiance HDR (float) as pbrt-v4's
// Image::Read reads them: 8-bit formats are always sRGB (the texture's `encoding` applies to
// PNG only), grey stays one channel, alpha is dropped, HDR is linear.
DecodedImage read_stb(const std::string& path, bool hdr, const SourceLoc& loc) {
  const std::vector<unsigned char> data = read_file(path, loc);
  if (data.empty()) fail(loc, path, "empty file");
  int w = 0, h = 0, n = 0;
  DecodedImage img;
  auto keep = [](int channels) { return channels <= 2 ? 1 : 3; };
  // The size from the header first: an image beyond the texel tables is refused before stb
  // allocates it (the fuzzer found a 60-byte file that made it allocate gigabytes).
  if (stbi_info_from_memory(data.data(), int(data.size()), &w, &h, &n) &&
      double(w) * double(h) * keep(n) > double(kMaxImageTexels))
    fail(loc, path, "the image is too large (" + std::to_string(w) + " x " + std::to_string(h) + ")");
  if (hdr) {
    float* px = stbi_loadf_from_memory(data.data(), int(data.size()), &w, &h, &n, 0);
    if (!px) fail(loc, path, std::string("corrupt or unsupported image: ") + stbi_failure_reason());
    img.width = w;
    img.height = h;
    img.channels = keep(n);
    img.texels.reserve(std::size_t(w) * std::size_t(h) * std::size_t(img.channels));
    for (std::size_t i = 0; i < std::size_t(w) * std::size_t(h); ++i)
      for (int c = 0; c < img.channels; ++c) img.texels.push_back(px[i * std::size_t(n) + std::size_t(c)]);
    stbi_image_free(px);
    return img;
  }
  unsigned char* px = stbi_load_from_memory(data.data(), int(data.size()), &w, &h, &n, 0);
  if (!px) fail(loc, path, std::string("corrupt or unsupported image: ") + stbi_failure_reason());
  img.width = w;
  img.height = h;
  img.channels = keep(n);
  img.storage = PixelStorage::U8;
  img.encoding = ColorEncoding{ImageEncoding::SRGB};
  float lut[256];
  for (int i = 0; i < 256; ++i) lut[i] = byte_to_linear(std::uint8_t(i), img.encoding);
  img.texels.reserve(std::size_t(w) * std::size_t(h) * std::size_t(img.channels));
  for (std::size_t i = 0; i < std::size_t(w) * std::size_t(h); ++i)
    for (int c = 0; c < img.channels; ++c)
      img.texels.push_back(lut[px[i * std::size_t(n) + std::size_t(c)]]);
  stbi_image_free(px);
  return img;
}


// pbrt-v4 ColorEncoding::FromLinear of one value (sRGB: LinearToSRGB8 with the exact curve;
// linear: truncation of v 255 + 0.5; gamma: pbrt-v4's 1024-entry inverse table).
std::uint8_t linear_to_byte(float v, const ColorEncoding& enc) {
  switch (enc.kind) {
    case ImageEncoding::SRGB: {
      if (v <= 0.0f) return 0;
      if (v >= 1.0f) return 255;
      const float e = 255.0f * float(linear_to_srgb(double(v)));
      return std::uint8_t(std::clamp(std::round(e), 0.0f, 255.0f));
    }
    case ImageEncoding::Linear:
      return std::uint8_t(std::clamp(v * 255.0f + 0.5f, 0.0f, 255.0f));
    case ImageEncoding::Gamma: {
      const float i = std::clamp(v * 1023.0f, 0.0f, 1023.0f);
      const float x = float(int(i)) / 1023.0f;
      return std::uint8_t(std::clamp(255.0f * std::pow(x, 1.0f / enc.gamma) + 0.5f, 0.0f, 255.0f));
    }
  }
  return 0;
}

// pbrt-v4 ColorEncoding::ToFloatLinear (16-bit PNG values in [0, 1]).
float float_to_linear(float v, const ColorEncoding& enc) {
  switch (enc.kind) {
    case ImageEncoding::SRGB:
      return float(srgb_to_linear(double(v)));
    case ImageEncoding::Linear:
      return v;
    case ImageEncoding::Gamma:
      return std::pow(v, enc.gamma);
  }
  return v;
}

float to_half(float v) { return float(Imath::half(v)); }

// ---- PNG (libpng from memory) -------------------------------------------------------------

struct PngReader {
  const unsigned char* data;
  std::size_t size, pos;
  char error[512];
  char warning[128];
};

void png_read_mem(png_structp png, png_bytep out, png_size_t n) {
  auto* r = static_cast<PngReader*>(png_get_io_ptr(png));
  if (n > r->size - r->pos) png_error(png, "unexpected end of file (truncated)");
  std::memcpy(out, r->data + r->pos, n);
  r->pos += n;
}

void png_on_error(png_structp png, png_const_charp msg) {
  auto* r = static_cast<PngReader*>(png_get_error_ptr(png));
  if (r->warning[0])
    std::snprintf(r->error, sizeof r->error, "%s (%s)", msg, r->warning);
  else
    std::snprintf(r->error, sizeof r->error, "%s", msg);
  png_longjmp(png, 1);
}
// Keeps the first warning: libpng explains a bad header (e.g. "Image width is zero in IHDR")
// in warnings before its error.
void png_on_warning(png_structp png, png_const_charp msg) {
  auto* r = static_cast<PngReader*>(png_get_error_ptr(png));
  if (!r->warning[0]) std::snprintf(r->warning, sizeof r->warning, "%s", msg);
}

struct PngRaw {
  png_uint_32 width = 0, height = 0;
  int channels = 0;  // 1 (grey) or 3 (rgb) after the transforms below
  int depth = 8;     // 8 or 16
  std::vector<unsigned char> bytes;
};

// Decodes PNG bytes to 8- or 16-bit grey or RGB (palette expanded, alpha stripped, low bit
// depths expanded to 8, as pbrt-v4's lodepng decode to LCT_GREY / LCT_RGB does). Returns false
// with r.error set on failure. No C++ object with a destructor lives between setjmp and the
// libpng calls that may longjmp back.
bool decode_png(PngReader& r, PngRaw& out) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r, png_on_error, png_on_warning);
  if (!png) {
    std::snprintf(r.error, sizeof r.error, "out of memory");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    std::snprintf(r.error, sizeof r.error, "out of memory");
    return false;
  }
  std::vector<png_bytep> rows;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_set_read_fn(png, &r, png_read_mem);
  png_read_info(png, info);
  const png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
  const int ct = png_get_color_type(png, info);
  const int bd = png_get_bit_depth(png, info);
  if (ct == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (ct == PNG_COLOR_TYPE_GRAY && bd < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (ct & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  out.width = w;
  out.height = h;
  out.channels = int(png_get_channels(png, info));
  out.depth = png_get_bit_depth(png, info) == 16 ? 16 : 8;
  if ((out.channels != 1 && out.channels != 3) || w == 0 || h == 0) {
    std::snprintf(r.error, sizeof r.error, "unsupported PNG layout");
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  if (double(w) * double(h) * out.channels > double(kMaxImageTexels)) {
    std::snprintf(r.error, sizeof r.error, "the image is too large (%u x %u)", unsigned(w),
                  unsigned(h));
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  const std::size_t rowbytes = png_get_rowbytes(png, info);
  out.bytes.resize(rowbytes * h);
  rows.resize(h);
  for (png_uint_32 y = 0; y < h; ++y) rows[y] = out.bytes.data() + y * rowbytes;
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

// pbrt-v4 ReadPNG (util/image.cpp): 8-bit stays bytes (U256, decoded with the encoding on
// every read), 16-bit goes through encoding.ToFloatLinear and is stored as Half.
DecodedImage read_png(const std::string& path, const ColorEncoding& enc, const SourceLoc& loc) {
  std::vector<unsigned char> file = read_file(path, loc);
  PngReader r{file.data(), file.size(), 0, {0}, {0}};
  if (file.size() < 8 || png_sig_cmp(file.data(), 0, 8) != 0)
    fail(loc, path, file.empty() ? "empty file" : "not a PNG file (corrupt signature)");
  PngRaw raw;
  if (!decode_png(r, raw)) fail(loc, path, std::string("corrupt or truncated PNG: ") + r.error);
  DecodedImage img;
  img.width = int(raw.width);
  img.height = int(raw.height);
  img.channels = raw.channels;
  img.encoding = enc;
  const std::size_t n = std::size_t(img.width) * std::size_t(img.height) * std::size_t(img.channels);
  img.texels.resize(n);
  if (raw.depth == 8) {
    img.storage = PixelStorage::U8;
    float lut[256];
    for (int i = 0; i < 256; ++i) lut[i] = byte_to_linear(std::uint8_t(i), enc);
    for (std::size_t i = 0; i < n; ++i) img.texels[i] = lut[raw.bytes[i]];
  } else {
    img.storage = PixelStorage::Half;
    for (std::size_t i = 0; i < n; ++i) {
      const float v = float((int(raw.bytes[2 * i]) << 8) + int(raw.bytes[2 * i + 1])) / 65535.0f;
      img.texels[i] = to_half(float_to_linear(v, enc));
    }
  }
  return img;
}

// ---- OpenEXR --------------------------------------------------------------------------------

// pbrt-v4 ReadEXR + MIPMap::CreateFromFile's channel choice: R, G, B if present, else a single
// channel (or Y). Half channels keep pbrt-v4's Half storage.
DecodedImage read_exr(const std::string& path, const SourceLoc& loc) {
  read_file(path, loc);  // missing / unreadable: the same messages as for PNG
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    const long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0) fail(loc, path, "the image has zero size");
    const Imf::ChannelList& cl = file.header().channels();
    std::vector<std::string> names;
    if (cl.findChannel("R") && cl.findChannel("G") && cl.findChannel("B")) {
      names = {"R", "G", "B"};
    } else {
      int count = 0;
      for (auto it = cl.begin(); it != cl.end(); ++it) ++count;
      if (count == 1)
        names = {cl.begin().name()};
      else if (cl.findChannel("Y"))
        names = {"Y"};
      else
        fail(loc, path, "the image has neither R, G and B channels nor a single channel");
    }
    if (double(w) * double(h) * double(names.size()) > double(kMaxImageTexels))
      fail(loc, path, "the image is too large (" + std::to_string(w) + " x " + std::to_string(h) + ")");
    bool all_half = true;
    for (const std::string& nm : names) all_half = all_half && cl.findChannel(nm)->type == Imf::HALF;
    DecodedImage img;
    img.width = int(w);
    img.height = int(h);
    img.channels = int(names.size());
    img.storage = all_half ? PixelStorage::Half : PixelStorage::Float;
    img.encoding.kind = ImageEncoding::Linear;
    img.texels.assign(std::size_t(w) * std::size_t(h) * names.size(), 0.0f);
    const std::size_t xs = sizeof(float) * names.size(), ys = xs * std::size_t(w);
    // Slice::Make offsets the buffer by the data window in integer arithmetic: forming the
    // pointer texels - origin ourselves overflowed for a window far from the origin (undefined
    // behaviour; found by the fuzzer).
    Imf::FrameBuffer fb;
    for (std::size_t c = 0; c < names.size(); ++c)
      fb.insert(names[c].c_str(),
                Imf::Slice::Make(Imf::FLOAT, img.texels.data() + c, dw, xs, ys));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return img;
  } catch (const SceneError&) {
    throw;
  } catch (const std::exception& e) {
    fail(loc, path, std::string("corrupt or truncated OpenEXR file: ") + e.what());
  }
}

// ---- PFM ------------------------------------------------------------------------------------

// pbrt-v4 ReadPFM: "PF" (rgb) or "Pf" (grey), width, height, scale (negative: little endian),
// rows bottom to top, values times |scale| when |scale| != 1.
DecodedImage read_pfm(const std::string& path, const SourceLoc& loc) {
  std::vector<unsigned char> file = read_file(path, loc);
  std::size_t pos = 0;
  auto word = [&]() {
    while (pos < file.size() && std::isspace(file[pos])) ++pos;
    std::string s;
    while (pos < file.size() && !std::isspace(file[pos])) s += char(file[pos++]);
    return s;
  };
  const std::string magic = word();
  int nc = 0;
  if (magic == "PF")
    nc = 3;
  else if (magic == "Pf")
    nc = 1;
  else
    fail(loc, path, "not a PFM file (corrupt header)");
  long long w = 0, h = 0;
  double scale = 0;
  try {
    std::size_t used = 0;
    std::string ws = word(), hs = word(), ss = word();
    w = std::stoll(ws, &used);
    if (used != ws.size()) throw std::invalid_argument("w");
    h = std::stoll(hs, &used);
    if (used != hs.size()) throw std::invalid_argument("h");
    scale = std::stod(ss, &used);
    if (used != ss.size()) throw std::invalid_argument("s");
  } catch (const std::exception&) {
    fail(loc, path, "corrupt PFM header");
  }
  if (w < 0 || h < 0 || scale == 0.0) fail(loc, path, "corrupt PFM header");
  if (w == 0 || h == 0) fail(loc, path, "the image has zero size");
  if (w > (1 << 16) || h > (1 << 16) || double(w) * h * nc > double(kMaxImageTexels))
    fail(loc, path, "the image is too large");
  ++pos;  // the single whitespace byte after the scale
  const std::size_t n = std::size_t(w) * std::size_t(h) * std::size_t(nc);
  if (pos > file.size() || file.size() - pos < n * 4)
    fail(loc, path, "unexpected end of file (truncated)");
  const bool little = scale < 0;
  const std::uint16_t probe = 1;
  const bool host_little = *reinterpret_cast<const unsigned char*>(&probe) == 1;
  DecodedImage img;
  img.width = int(w);
  img.height = int(h);
  img.channels = nc;
  img.storage = PixelStorage::Float;
  img.encoding.kind = ImageEncoding::Linear;
  img.texels.resize(n);
  const float s = float(std::abs(scale));
  const std::size_t row = std::size_t(w) * std::size_t(nc);
  for (long long y = 0; y < h; ++y) {
    const unsigned char* src = file.data() + pos + std::size_t(y) * row * 4;
    float* dst = img.texels.data() + std::size_t(h - 1 - y) * row;
    for (std::size_t i = 0; i < row; ++i) {
      unsigned char b[4];
      std::memcpy(b, src + 4 * i, 4);
      if (little != host_little) {
        std::swap(b[0], b[3]);
        std::swap(b[1], b[2]);
      }
      float v;
      std::memcpy(&v, b, 4);
      dst[i] = s != 1.0f ? v * s : v;
    }
  }
  return img;
}

// ---- pyramid --------------------------------------------------------------------------------

// pbrt-v4 Sinc / WindowedSinc (util/math.h).
float sinc(float x) {
  const float px = 3.14159265358979323846f * x;
  if (1.0f - px * px == 1.0f) return 1.0f;
  return std::sin(px) / px;
}
float windowed_sinc(float x, float radius, float tau) {
  if (std::abs(x) > radius) return 0.0f;
  return sinc(x) * sinc(x / tau);
}

struct ResampleWeight {
  int first = 0;
  float w[4] = {0, 0, 0, 0};
};

// pbrt-v4 Image::ResampleWeights: 4 taps of a windowed sinc (radius 2, tau 2), normalised.
std::vector<ResampleWeight> resample_weights(int old_res, int new_res) {
  std::vector<ResampleWeight> wt(static_cast<std::size_t>(new_res));
  const float radius = 2.0f, tau = 2.0f;
  for (int i = 0; i < new_res; ++i) {
    const float center = (float(i) + 0.5f) * float(old_res) / float(new_res);
    wt[i].first = int(std::floor((center - radius) + 0.5f));
    for (int j = 0; j < 4; ++j) {
      const float pos = float(wt[i].first + j) + 0.5f;
      wt[i].w[j] = windowed_sinc(pos - center, radius, tau);
    }
    const float inv = 1.0f / (wt[i].w[0] + wt[i].w[1] + wt[i].w[2] + wt[i].w[3]);
    for (int j = 0; j < 4; ++j) wt[i].w[j] *= inv;
  }
  return wt;
}

// pbrt-v4 RemapPixelCoords for one axis; false: black (outside).
bool remap(int& p, int res, std::uint32_t wrap) {
  if (p >= 0 && p < res) return true;
  if (wrap == gpu::WRAP_REPEAT) {
    p = ((p % res) + res) % res;
    return true;
  }
  if (wrap == gpu::WRAP_CLAMP) {
    p = std::clamp(p, 0, res - 1);
    return true;
  }
  return false;
}

// pbrt-v4 Image::FloatResizeUp: separable 4-tap resampling, x pass then y pass (clamped at 0).
// Pixels outside the image follow the wrap mode (pbrt-v4 aborts for "black"; basalt reads 0).
MipImage float_resize_up(const MipImage& in, int nw, int nh, std::uint32_t wrap) {
  const int nc = in.channels;
  const std::vector<ResampleWeight> xw = resample_weights(in.width, nw);
  const std::vector<ResampleWeight> yw = resample_weights(in.height, nh);
  auto src = [&](int x, int y, int c) -> float {
    if (!remap(x, in.width, wrap) || !remap(y, in.height, wrap)) return 0.0f;
    return in.texels[(std::size_t(y) * std::size_t(in.width) + std::size_t(x)) * nc + c];
  };
  // x pass for every source row the y weights reach: rows y0 .. y1 - 1 (with wrapping).
  const int y0 = yw.front().first, y1 = yw.back().first + 4;
  const int rows = y1 - y0;
  std::vector<float> xbuf(std::size_t(rows) * std::size_t(nw) * nc);
  for (int yi = 0; yi < rows; ++yi)
    for (int x = 0; x < nw; ++x) {
      const ResampleWeight& r = xw[std::size_t(x)];
      for (int c = 0; c < nc; ++c)
        xbuf[(std::size_t(yi) * nw + x) * nc + c] =
            r.w[0] * src(r.first, y0 + yi, c) + r.w[1] * src(r.first + 1, y0 + yi, c) +
            r.w[2] * src(r.first + 2, y0 + yi, c) + r.w[3] * src(r.first + 3, y0 + yi, c);
    }
  MipImage out;
  out.width = nw;
  out.height = nh;
  out.channels = nc;
  out.texels.resize(std::size_t(nw) * std::size_t(nh) * nc);
  for (int y = 0; y < nh; ++y) {
    const ResampleWeight& r = yw[std::size_t(y)];
    const int b = r.first - y0;
    for (int x = 0; x < nw; ++x)
      for (int c = 0; c < nc; ++c) {
        auto at = [&](int k) { return xbuf[(std::size_t(b + k) * nw + x) * nc + c]; };
        const float v = r.w[0] * at(0) + r.w[1] * at(1) + r.w[2] * at(2) + r.w[3] * at(3);
        out.texels[(std::size_t(y) * nw + x) * nc + c] = std::max(0.0f, v);
      }
  }
  return out;
}

bool is_pow2(int v) { return v > 0 && (v & (v - 1)) == 0; }
int round_up_pow2(int v) {
  int p = 1;
  while (p < v) p <<= 1;
  return p;
}

// A level stored in the source's pixel format (pbrt-v4 CopyRectIn into an origFormat image):
// 8-bit levels are re-encoded to bytes and decoded again, half levels rounded to half.
MipImage stored_level(const MipImage& m, const DecodedImage& src) {
  MipImage s = m;
  if (src.storage == PixelStorage::U8) {
    for (float& v : s.texels) v = byte_to_linear(linear_to_byte(v, src.encoding), src.encoding);
  } else if (src.storage == PixelStorage::Half) {
    for (float& v : s.texels) v = to_half(v);
  }
  return s;
}

}  // namespace

DecodedImage read_texture_image(const std::string& path, const ColorEncoding& enc,
                                const SourceLoc& loc) {
  const std::string ext = lower_ext(path);
  DecodedImage img;
  if (ext == ".png")
    img = read_png(path, enc, loc);
  else if (ext == ".exr")
    img = read_exr(path, loc);
  else if (ext == ".pfm")
    img = read_pfm(path, loc);
  else if (ext == ".hdr")
    img = read_stb(path, true, loc);
  else if (ext == ".tga" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".gif")
    img = read_stb(path, false, loc);
  else
    fail(loc, path, "unsupported image format \"" + ext +
                        "\" (basalt reads .png, .exr, .pfm, .hdr, .tga, .jpg, .bmp and .gif)");
  if (img.width <= 0 || img.height <= 0) fail(loc, path, "the image has zero size");
  return img;
}

// pbrt-v4 Image::GeneratePyramid (util/image.cpp).
std::vector<MipImage> generate_pyramid(const DecodedImage& image, std::uint32_t wrap) {
  MipImage cur;
  cur.width = image.width;
  cur.height = image.height;
  cur.channels = image.channels;
  cur.texels = image.texels;
  if (!is_pow2(cur.width) || !is_pow2(cur.height))
    cur = float_resize_up(cur, round_up_pow2(cur.width), round_up_pow2(cur.height), wrap);
  const int n_levels = 1 + int(std::log2(double(std::max(cur.width, cur.height))) + 0.5);
  std::vector<MipImage> pyramid;
  pyramid.reserve(std::size_t(n_levels));
  const int nc = cur.channels;
  for (int i = 0; i < n_levels - 1; ++i) {
    pyramid.push_back(stored_level(cur, image));
    MipImage next;
    next.width = std::max(1, cur.width / 2);
    next.height = std::max(1, cur.height / 2);
    next.channels = nc;
    next.texels.resize(std::size_t(next.width) * std::size_t(next.height) * nc);
    // The 4 source offsets; a 1-wide (1-high) level averages its pixels with themselves.
    int d1 = nc, d2 = nc * cur.width, d3 = nc * (cur.width + 1);
    if (cur.width == 1) {
      d1 = 0;
      d3 -= nc;
    }
    if (cur.height == 1) {
      d2 = 0;
      d3 -= nc * cur.width;
    }
    for (int y = 0; y < next.height; ++y) {
      std::size_t so = std::size_t(nc) * std::size_t(2 * y) * std::size_t(cur.width);
      std::size_t no = std::size_t(nc) * std::size_t(y) * std::size_t(next.width);
      for (int x = 0; x < next.width; ++x, so += nc)
        for (int c = 0; c < nc; ++c, ++so, ++no)
          next.texels[no] =
              (cur.texels[so] + cur.texels[so + d1] + cur.texels[so + d2] + cur.texels[so + d3]) / 4;
    }
    cur = std::move(next);
  }
  pyramid.push_back(stored_level(cur, image));
  return pyramid;
}

}  // namespace basalt
