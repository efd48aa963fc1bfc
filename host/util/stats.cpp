// Render statistics written by --stats as JSON.
#include "util/stats.h"

#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "util/files.h"

namespace basalt {

namespace {

/// JSON string literal with escapes.
std::string quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if ((unsigned char)c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

/// JSON number (non-finite values become null).
std::string number(double v) { return std::isfinite(v) ? format_number(v) : "null"; }

}  // namespace

std::string to_json(const RenderStats& st) {
  std::ostringstream o;
  o << "{\n";
  o << "  \"device\": " << quote(st.device) << ",\n";
  o << "  \"driver\": " << quote(st.driver) << ",\n";
  o << "  \"scene\": " << quote(st.scene) << ",\n";
  o << "  \"width\": " << st.width << ",\n  \"height\": " << st.height << ",\n";
  o << "  \"spp\": " << st.spp << ",\n  \"seed\": " << st.seed << ",\n";
  o << "  \"seconds_parse\": " << number(st.seconds_parse) << ",\n";
  o << "  \"seconds_bvh\": " << number(st.seconds_bvh) << ",\n";
  o << "  \"seconds_upload\": " << number(st.seconds_upload) << ",\n";
  o << "  \"seconds_pipeline\": " << number(st.seconds_pipeline) << ",\n";
  if (st.seconds_specialise > 0)
    o << "  \"seconds_specialise\": " << number(st.seconds_specialise) << ",\n";
  if (st.second_device_compiles > 0)
    o << "  \"second_device_compiles\": " << st.second_device_compiles << ",\n";
  if (!st.solo_pipeline.empty())
    o << "  \"solo_pipeline\": " << quote(st.solo_pipeline) << ",\n"
      << "  \"solo_dispatches\": " << st.solo_dispatches << ",\n";
  if (!st.shader_variant.empty())
    o << "  \"shader_variant\": " << quote(st.shader_variant) << ",\n"
      << "  \"shader_plain\": " << (st.shader_plain ? "true" : "false") << ",\n";
  o << "  \"seconds_render\": " << number(st.seconds_render) << ",\n";
  o << "  \"seconds_to_first_pass\": " << number(st.seconds_to_first_pass) << ",\n";
  o << "  \"samples_per_second\": " << number(st.samples_per_second) << ",\n";
  o << "  \"rays_per_second\": " << number(st.rays_per_second) << ",\n";
  o << "  \"rays\": " << st.rays << ",\n";
  o << "  \"nonfinite_samples\": " << st.nonfinite_samples << ",\n";
  o << "  \"peak_rss_bytes\": " << st.peak_rss_bytes << ",\n";
  o << "  \"table_bytes\": " << st.table_bytes << ",\n";
  o << "  \"wave_bytes\": " << st.wave_bytes << ",\n";
  o << "  \"triangles\": " << st.triangles << ",\n";
  o << "  \"spheres\": " << st.spheres << ",\n";
  o << "  \"lights\": " << st.lights << ",\n";
  o << "  \"quality\": {";
  for (size_t i = 0; i < st.quality.size(); ++i)
    o << (i ? ", " : "") << quote(st.quality[i].first) << ": " << quote(st.quality[i].second);
  o << "},\n";
  o << "  \"features\": [";
  for (size_t i = 0; i < st.features.size(); ++i) o << (i ? ", " : "") << quote(st.features[i]);
  o << "]\n}\n";
  return o.str();
}

std::uint64_t peak_rss_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return std::uint64_t(usage.ru_maxrss) * 1024u;  // Linux reports KiB
}

void write_file_atomic(const std::string& path, const std::string& text) {
  try {
    write_file_bytes(path, text);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write " + path + ": " + e.what());
  }
}

std::string format_number(double v) {
  std::ostringstream s;
  s.precision(9);
  s << v;
  return s.str();
}

}  // namespace basalt
