// MERL regular half-angle BRDF tables (pbrt-v2 src/materials/measured.cpp format).
#include "scene/merl.h"

#include "util/files.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <numbers>
#include <stdexcept>

namespace basalt {
namespace {

constexpr double kPi = std::numbers::pi;
// Largest table accepted: 2^26 entries (1.5 GiB of doubles), far above MERL's 1.46 M.
constexpr std::uint64_t kMaxEntries = std::uint64_t(1) << 26;

// Little-endian int32 / double from bytes (basalt's hosts are little-endian; checked).
std::int32_t read_i32(const unsigned char* b) {
  return std::int32_t(std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 |
                      std::uint32_t(b[3]) << 24);
}

}  // namespace

MeasuredTable read_merl(const std::string& path) {
  static_assert(sizeof(double) == 8);
  regular_file_size(path);  // a regular file only (util/files.h): no FIFO or device
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(std::string("cannot open: ") + std::strerror(errno));
  unsigned char head[12];
  if (!in.read(reinterpret_cast<char*>(head), 12))
    throw std::runtime_error("file too short for the 12-byte header (3 int32 dimensions)");
  std::int32_t d[3] = {read_i32(head), read_i32(head + 4), read_i32(head + 8)};
  for (std::int32_t v : d)
    if (v <= 0)
      throw std::runtime_error("bad dimensions " + std::to_string(d[0]) + " x " +
                               std::to_string(d[1]) + " x " + std::to_string(d[2]));
  std::uint64_t n = std::uint64_t(d[0]) * std::uint64_t(d[1]) * std::uint64_t(d[2]);
  if (n > kMaxEntries)
    throw std::runtime_error("table of " + std::to_string(n) + " entries is too large");
  std::vector<double> data(3 * n);
  in.read(reinterpret_cast<char*>(data.data()), std::streamsize(data.size() * sizeof(double)));
  if (std::uint64_t(in.gcount()) != data.size() * sizeof(double))
    throw std::runtime_error("file is short: " + std::to_string(d[0]) + " x " +
                             std::to_string(d[1]) + " x " + std::to_string(d[2]) + " needs " +
                             std::to_string(12 + data.size() * 8) + " bytes, found " +
                             std::to_string(12 + in.gcount()));
  MeasuredTable t;
  t.path = path;
  t.dims = glm::uvec3(unsigned(d[0]), unsigned(d[1]), unsigned(d[2]));
  t.rgb.resize(3 * n);
  // pbrt-v2 MeasuredMaterial: channel c of entry i is data[c n + i] * scale[c], negatives 0.
  for (int c = 0; c < 3; ++c)
    for (std::uint64_t i = 0; i < n; ++i) {
      double v = data[c * n + i] * kMerlScale[c];
      t.rgb[3 * i + c] = std::isfinite(v) && v > 0.0 ? float(v) : 0.0f;
    }
  return t;
}

bool merl_bin_directions(const glm::uvec3& dims, unsigned ih, unsigned id, unsigned ip,
                         glm::dvec3* wi, glm::dvec3* wo) {
  // Inverse of pbrt-v2 RegularHalfangleBRDF::f's REMAP at bin centres.
  double s = (ih + 0.5) / dims.x;
  double theta_h = 0.5 * kPi * s * s;
  double theta_d = 0.5 * kPi * (id + 0.5) / dims.y;
  double phi_d = kPi * (ip + 0.5) / dims.z;
  // Half vector at phi_h = 0 and pbrt-v2's frame around it: whx = (cos th, 0, -sin th), why = y.
  glm::dvec3 wh(std::sin(theta_h), 0.0, std::cos(theta_h));
  glm::dvec3 whx(std::cos(theta_h), 0.0, -std::sin(theta_h)), why(0.0, 1.0, 0.0);
  glm::dvec3 wd(std::sin(theta_d) * std::cos(phi_d), std::sin(theta_d) * std::sin(phi_d),
                std::cos(theta_d));
  *wi = wd.x * whx + wd.y * why + wd.z * wh;
  *wo = 2.0 * glm::dot(*wi, wh) * wh - *wi;
  return wi->z > 0.0 && wo->z > 0.0;
}

void write_merl(const std::string& path, const glm::uvec3& dims,
                const std::function<glm::dvec3(const glm::dvec3&, const glm::dvec3&)>& brdf) {
  if (dims.x == 0 || dims.y == 0 || dims.z == 0) throw std::runtime_error("zero dimension");
  std::uint64_t n = std::uint64_t(dims.x) * dims.y * dims.z;
  std::vector<double> data(3 * n);
  for (unsigned ih = 0; ih < dims.x; ++ih)
    for (unsigned id = 0; id < dims.y; ++id)
      for (unsigned ip = 0; ip < dims.z; ++ip) {
        std::uint64_t i = ip + std::uint64_t(dims.z) * (id + std::uint64_t(dims.y) * ih);
        glm::dvec3 wi, wo;
        bool ok = merl_bin_directions(dims, ih, id, ip, &wi, &wo);
        glm::dvec3 f = ok ? brdf(wi, wo) : glm::dvec3(-1.0);
        for (int c = 0; c < 3; ++c) data[c * n + i] = ok ? f[c] / kMerlScale[c] : -1.0;
      }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error("cannot write \"" + path + "\": " + std::strerror(errno));
  std::int32_t head[3] = {std::int32_t(dims.x), std::int32_t(dims.y), std::int32_t(dims.z)};
  out.write(reinterpret_cast<const char*>(head), sizeof(head));
  out.write(reinterpret_cast<const char*>(data.data()), std::streamsize(data.size() * 8));
  if (!out) throw std::runtime_error("cannot write \"" + path + "\"");
}

glm::dvec3 AnalyticBrdf::eval(const glm::dvec3& wi, const glm::dvec3& wo) const {
  if (wi.z <= 0.0 || wo.z <= 0.0) return glm::dvec3(0.0);
  glm::dvec3 wh = glm::normalize(wi + wo);
  // Trowbridge-Reitz D and Smith G (pbrt-v4 TrowbridgeReitzDistribution, isotropic).
  double a2 = alpha * alpha, c2 = wh.z * wh.z;
  double denom = c2 * (a2 - 1.0) + 1.0;
  double D = a2 / (kPi * denom * denom);
  auto lambda = [&](const glm::dvec3& w) {
    double t2 = (1.0 - w.z * w.z) / (w.z * w.z);
    return (std::sqrt(1.0 + a2 * t2) - 1.0) / 2.0;
  };
  double G = 1.0 / (1.0 + lambda(wi) + lambda(wo));
  // Schlick 1994: F = f0 + (1 - f0) (1 - cos)^5.
  double m = std::pow(1.0 - glm::clamp(glm::dot(wi, wh), 0.0, 1.0), 5.0);
  glm::dvec3 F = f0 + (glm::dvec3(1.0) - f0) * m;
  return kd / kPi + D * G * F / (4.0 * wi.z * wo.z);
}

}  // namespace basalt
