// BSDF acceptance-test helpers: probe batching, material records, generated measured tables,
// input generators, chi-square and albedo statistics (see bsdf_check.h).
#include "common/bsdf_check.h"
#include "scene/materials.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <set>
#include <sstream>

namespace basalt::test::bsdf {

// ---- probe queries -----------------------------------------------------------------------

gpu::ProbeIn to_probe(const Query& q) {
  gpu::ProbeIn in{};
  in.key = glm::uvec4(gpu::PROBE_BSDF, q.material, q.px, q.py);
  in.o_tmax = glm::vec4(q.wo, q.p.x);
  in.d = glm::vec4(q.wi, q.p.y);
  in.extra = glm::vec4(q.u, q.p.z);
  in.extra2 = glm::vec4(q.ng, 0.0f);
  return in;
}

Result from_probe(const gpu::ProbeOut& o) {
  Result r;
  r.f = glm::vec3(o.f0);
  r.pdf = o.f0.w;
  r.sf = glm::vec3(o.f1);
  r.spdf = o.f1.w;
  r.swi = glm::vec3(o.f2);
  r.seta = o.f2.w;
  r.pdf_at_sample = o.f3.x;
  r.lobes = std::uint32_t(o.f3.y);
  r.sflags = o.u.x;
  r.bflags = o.u.y;
  r.proportional = o.u.z;
  r.lobe0 = o.u.w;
  return r;
}

std::vector<Result> run(Side side, const SceneTables& tables, const std::vector<Query>& qs) {
  std::vector<Result> rs;
  rs.reserve(qs.size());
  // One GPU dispatch: at most 2^20 queries (80 MiB probe buffers, below lavapipe's
  // maxStorageBufferRange of 128 MiB, and 2^14 groups of 64); the CPU goes in smaller pieces
  // to bound the memory of the probe records.
  const std::size_t chunk = side == Side::Gpu ? (1u << 20) : (1u << 16);
  for (std::size_t b = 0; b < qs.size(); b += chunk) {
    std::vector<gpu::ProbeIn> in;
    const std::size_t e = std::min(qs.size(), b + chunk);
    in.reserve(e - b);
    for (std::size_t i = b; i < e; ++i) in.push_back(to_probe(qs[i]));
    for (const gpu::ProbeOut& o : probe(side, tables, in)) rs.push_back(from_probe(o));
  }
  return rs;
}

SceneTables make_tables(const std::vector<gpu::Material>& materials,
                        const std::vector<float>& measured) {
  // A valid scene with one small sphere: the BSDF probe reads only the material tables.
  SceneTables t = tables_from_string(R"(
    LookAt 0 0 -4  0 0 0  0 1 0
    Camera "perspective" "float fov" [ 40 ]
    Film "rgb" "integer xresolution" [ 8 ] "integer yresolution" [ 8 ]
    Sampler "independent" "integer pixelsamples" [ 1 ]
    WorldBegin
    Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
    Shape "sphere" "float radius" [ 1 ]
  )");
  t.materials = materials;
  t.measured = measured;
  // The feature words name every material kind of the table, as a parsed scene's do: the
  // probe pipeline is specialised for them (GpuRenderer::probe).
  for (const gpu::Material& m : materials) t.features |= material_feature(m.type);
  t.globals.features.x = t.features;
  set_seed(t, 0);
  return t;
}

// ---- material records ----------------------------------------------------------------------

gpu::Material blank(std::uint32_t type, std::uint32_t flags) {
  gpu::Material m;
  std::memset(&m, 0, sizeof(m));
  m.type = type;
  m.flags = flags;
  m.aux0 = m.aux1 = 0;
  for (auto& t : m.texture) t = glm::uvec4(gpu::INVALID_INDEX);
  return m;
}

void set(gpu::Material& m, std::uint32_t s, glm::vec3 v) { m.value[s] = glm::vec4(v, 0.0f); }
void set(gpu::Material& m, std::uint32_t s, float v) { m.value[s] = glm::vec4(v, 0, 0, 0); }

gpu::Material diffuse(glm::vec3 R) {
  gpu::Material m = blank(gpu::MATERIAL_DIFFUSE);
  set(m, gpu::SLOT_DIFFUSE_REFLECTANCE, R);
  return m;
}

gpu::Material oren_nayar(glm::vec3 R, float sigma_deg) {
  gpu::Material m = blank(gpu::MATERIAL_OREN_NAYAR);
  set(m, gpu::SLOT_ON_REFLECTANCE, R);
  set(m, gpu::SLOT_ON_SIGMA, sigma_deg);
  return m;
}

gpu::Material conductor(glm::vec3 eta, glm::vec3 k, float urough, float vrough,
                        std::uint32_t flags, bool metal) {
  gpu::Material m = blank(metal ? gpu::MATERIAL_METAL : gpu::MATERIAL_CONDUCTOR, flags);
  set(m, gpu::SLOT_CONDUCTOR_ETA, eta);
  set(m, gpu::SLOT_CONDUCTOR_K, k);
  set(m, gpu::SLOT_CONDUCTOR_UROUGH, urough);
  set(m, gpu::SLOT_CONDUCTOR_VROUGH, vrough);
  return m;
}

gpu::Material conductor_reflectance(glm::vec3 r, float urough, float vrough,
                                    std::uint32_t flags) {
  gpu::Material m = blank(gpu::MATERIAL_CONDUCTOR, flags | gpu::MATFLAG_USE_REFLECTANCE);
  set(m, gpu::SLOT_CONDUCTOR_REFLECTANCE, r);
  set(m, gpu::SLOT_CONDUCTOR_UROUGH, urough);
  set(m, gpu::SLOT_CONDUCTOR_VROUGH, vrough);
  return m;
}

gpu::Material mirror(glm::vec3 Kr) {
  gpu::Material m = blank(gpu::MATERIAL_MIRROR);
  set(m, gpu::SLOT_MIRROR_KR, Kr);
  return m;
}

gpu::Material dielectric(float eta, float urough, float vrough, std::uint32_t flags,
                         glm::vec3 Kr, glm::vec3 Kt) {
  gpu::Material m = blank(gpu::MATERIAL_DIELECTRIC, flags);
  set(m, gpu::SLOT_DIELECTRIC_ETA, eta);
  set(m, gpu::SLOT_DIELECTRIC_UROUGH, urough);
  set(m, gpu::SLOT_DIELECTRIC_VROUGH, vrough);
  set(m, gpu::SLOT_DIELECTRIC_KR, Kr);
  set(m, gpu::SLOT_DIELECTRIC_KT, Kt);
  return m;
}

gpu::Material thin_dielectric(float eta) {
  gpu::Material m = blank(gpu::MATERIAL_THIN_DIELECTRIC);
  set(m, gpu::SLOT_THIN_ETA, eta);
  return m;
}

gpu::Material diffuse_transmission(glm::vec3 R, glm::vec3 T, float scale) {
  gpu::Material m = blank(gpu::MATERIAL_DIFFUSE_TRANSMISSION);
  set(m, gpu::SLOT_DT_REFLECTANCE, R);
  set(m, gpu::SLOT_DT_TRANSMITTANCE, T);
  set(m, gpu::SLOT_DT_SCALE, scale);
  return m;
}

gpu::Material coated_diffuse(glm::vec3 R, float urough, float vrough, float thickness,
                             float eta, glm::vec3 albedo, float g, std::uint32_t maxdepth,
                             std::uint32_t nsamples, std::uint32_t flags) {
  gpu::Material m = blank(gpu::MATERIAL_COATED_DIFFUSE, flags);
  set(m, gpu::SLOT_CD_REFLECTANCE, R);
  set(m, gpu::SLOT_CD_UROUGH, urough);
  set(m, gpu::SLOT_CD_VROUGH, vrough);
  set(m, gpu::SLOT_CD_THICKNESS, thickness);
  set(m, gpu::SLOT_CD_ETA, eta);
  set(m, gpu::SLOT_CD_ALBEDO, albedo);
  set(m, gpu::SLOT_CD_G, g);
  m.aux0 = maxdepth;
  m.aux1 = nsamples;
  return m;
}

gpu::Material coated_conductor(float if_urough, float if_vrough, float thickness, float if_eta,
                               float g, glm::vec3 albedo, float urough, float vrough,
                               glm::vec3 eta, glm::vec3 k, std::uint32_t maxdepth,
                               std::uint32_t nsamples, std::uint32_t flags) {
  gpu::Material m = blank(gpu::MATERIAL_COATED_CONDUCTOR, flags);
  set(m, gpu::SLOT_CC_IF_UROUGH, if_urough);
  set(m, gpu::SLOT_CC_IF_VROUGH, if_vrough);
  set(m, gpu::SLOT_CC_THICKNESS, thickness);
  set(m, gpu::SLOT_CC_IF_ETA, if_eta);
  set(m, gpu::SLOT_CC_G, g);
  set(m, gpu::SLOT_CC_ALBEDO, albedo);
  set(m, gpu::SLOT_CC_UROUGH, urough);
  set(m, gpu::SLOT_CC_VROUGH, vrough);
  set(m, gpu::SLOT_CC_ETA, eta);
  set(m, gpu::SLOT_CC_K, k);
  m.aux0 = maxdepth;
  m.aux1 = nsamples;
  return m;
}

gpu::Material plastic(glm::vec3 Kd, glm::vec3 Ks, float rough, std::uint32_t flags) {
  gpu::Material m = blank(gpu::MATERIAL_PLASTIC, flags);
  set(m, gpu::SLOT_PLASTIC_KD, Kd);
  set(m, gpu::SLOT_PLASTIC_KS, Ks);
  set(m, gpu::SLOT_PLASTIC_ROUGH, rough);
  return m;
}

gpu::Material substrate(glm::vec3 Kd, glm::vec3 Ks, float urough, float vrough,
                        std::uint32_t flags) {
  gpu::Material m = blank(gpu::MATERIAL_SUBSTRATE, flags);
  set(m, gpu::SLOT_SUBSTRATE_KD, Kd);
  set(m, gpu::SLOT_SUBSTRATE_KS, Ks);
  set(m, gpu::SLOT_SUBSTRATE_UROUGH, urough);
  set(m, gpu::SLOT_SUBSTRATE_VROUGH, vrough);
  return m;
}

gpu::Material translucent(glm::vec3 Kd, glm::vec3 Ks, glm::vec3 reflect, glm::vec3 transmit,
                          float rough, std::uint32_t flags) {
  gpu::Material m = blank(gpu::MATERIAL_TRANSLUCENT, flags);
  set(m, gpu::SLOT_TRANSLUCENT_KD, Kd);
  set(m, gpu::SLOT_TRANSLUCENT_KS, Ks);
  set(m, gpu::SLOT_TRANSLUCENT_REFLECT, reflect);
  set(m, gpu::SLOT_TRANSLUCENT_TRANSMIT, transmit);
  set(m, gpu::SLOT_TRANSLUCENT_ROUGH, rough);
  return m;
}

gpu::Material uber(glm::vec3 Kd, glm::vec3 Ks, glm::vec3 Kr, glm::vec3 Kt, float urough,
                   float vrough, float eta, glm::vec3 opacity, std::uint32_t flags) {
  gpu::Material m = blank(gpu::MATERIAL_UBER, flags);
  set(m, gpu::SLOT_UBER_KD, Kd);
  set(m, gpu::SLOT_UBER_KS, Ks);
  set(m, gpu::SLOT_UBER_KR, Kr);
  set(m, gpu::SLOT_UBER_KT, Kt);
  set(m, gpu::SLOT_UBER_UROUGH, urough);
  set(m, gpu::SLOT_UBER_VROUGH, vrough);
  set(m, gpu::SLOT_UBER_ETA, eta);
  set(m, gpu::SLOT_UBER_OPACITY, opacity);
  return m;
}

gpu::Material measured(std::uint32_t offset, glm::uvec3 dims) {
  gpu::Material m = blank(gpu::MATERIAL_MEASURED);
  m.aux0 = offset;
  set(m, gpu::SLOT_MEASURED_DIMS, glm::vec3(dims));
  return m;
}

gpu::Material mix_weighted(std::uint32_t a, std::uint32_t b, glm::vec3 amount) {
  gpu::Material m = blank(gpu::MATERIAL_MIX_WEIGHTED);
  m.aux0 = a;
  m.aux1 = b;
  set(m, gpu::SLOT_MIX_AMOUNT, amount);
  return m;
}

gpu::Material mix(std::uint32_t a, std::uint32_t b, float amount) {
  gpu::Material m = blank(gpu::MATERIAL_MIX);
  m.aux0 = a;
  m.aux1 = b;
  set(m, gpu::SLOT_MIX_AMOUNT, amount);
  return m;
}

std::string type_name(std::uint32_t type) {
  static const char* names[] = {"NONE",          "DIFFUSE",        "OREN_NAYAR",
                                "CONDUCTOR",     "DIELECTRIC",     "THIN_DIELECTRIC",
                                "DIFFUSE_TRANSMISSION", "COATED_DIFFUSE", "COATED_CONDUCTOR",
                                "PLASTIC",       "SUBSTRATE",      "TRANSLUCENT",
                                "UBER",          "MEASURED",       "MIX",
                                "MIX_WEIGHTED",  "INTERFACE",      "MIRROR",
                                "METAL"};
  if (type < gpu::MATERIAL_TYPE_COUNT) return names[type];
  std::ostringstream s;
  s << "type" << type;
  return s.str();
}

namespace {

/// Floats printed with round-trip precision.
std::string fmt(float v) {
  std::ostringstream s;
  s.precision(9);
  s << v;
  return s.str();
}

std::string fmt(glm::vec3 v) {
  std::ostringstream s;
  s.precision(9);
  s << "(" << v.x << ", " << v.y << ", " << v.z << ")";
  return s.str();
}

}  // namespace

std::string describe(const gpu::Material& m) {
  std::ostringstream s;
  s << "Material{type " << type_name(m.type) << " (" << m.type << "), flags " << m.flags
    << ", aux0 " << m.aux0 << ", aux1 " << m.aux1;
  for (std::uint32_t i = 0; i < gpu::MATERIAL_SLOTS; ++i)
    if (m.value[i] != glm::vec4(0.0f))
      s << ", value[" << i << "] " << fmt(glm::vec3(m.value[i]));
  s << "}";
  return s.str();
}

std::string describe(const Query& q) {
  std::ostringstream s;
  s << "Query{material " << q.material << ", wo " << fmt(q.wo) << ", wi " << fmt(q.wi)
    << ", u " << fmt(q.u) << ", ng " << fmt(q.ng) << ", p " << fmt(q.p) << ", key (" << q.px
    << ", " << q.py << ")}";
  return s.str();
}

std::string describe(const Result& r) {
  std::ostringstream s;
  s << "Result{eval " << fmt(r.f) << " pdf " << fmt(r.pdf) << "; sample f " << fmt(r.sf)
    << " pdf " << fmt(r.spdf) << " wi " << fmt(r.swi) << " eta " << fmt(r.seta) << " flags "
    << r.sflags << " proportional " << r.proportional << "; pdf(wo, sample wi) "
    << fmt(r.pdf_at_sample) << "; lobes " << r.lobes << " bsdf flags " << r.bflags
    << " lobe0 " << r.lobe0 << "}";
  return s.str();
}

// ---- measured tables -----------------------------------------------------------------------

std::vector<float> measured_table(glm::uvec3 dims) {
  const std::size_t n = std::size_t(dims.x) * dims.y * dims.z;
  std::vector<float> t(3 * n);
  for (std::uint32_t h = 0; h < dims.x; ++h)
    for (std::uint32_t d = 0; d < dims.y; ++d)
      for (std::uint32_t p = 0; p < dims.z; ++p) {
        const std::size_t i = p + dims.z * (d + std::size_t(h) * dims.y);
        // Bin centres in the pbrt-v2 coordinates (theta_h through the sqrt remap).
        const double vh = (h + 0.5) / dims.x, th = vh * vh * kPi / 2;
        const double td = (d + 0.5) / dims.y * kPi / 2, pd = (p + 0.5) / dims.z * kPi;
        t[3 * i + 0] = float((0.05 + 0.85 * (i + 0.5) / n) / kPi);
        t[3 * i + 1] = float((0.1 + 0.8 * std::exp(-th * th / 0.05)) / kPi);
        t[3 * i + 2] = float(
            (0.3 + 0.5 * std::cos(td) * std::cos(td) * (0.5 + 0.5 * std::cos(2 * pd))) / kPi);
      }
  return t;
}

long measured_bin_of(float red, glm::uvec3 dims) {
  const double n = double(dims.x) * dims.y * dims.z;
  const double x = (double(red) * kPi - 0.05) / 0.85 * n - 0.5;
  const double r = std::round(x);
  if (std::fabs(x - r) > 0.25 || r < 0 || r >= n) return -1;
  return long(r);
}

namespace {

/// pbrt-v2 RegularHalfangleBRDF coordinates in double: continuous bin coordinates
/// (theta_h through the sqrt remap, theta_d, phi_d), each in [0, count].
bool measured_coords(glm::dvec3 wo, glm::dvec3 wi, glm::uvec3 dims, glm::dvec3* c) {
  if (wo.z < 0) wo = -wo, wi = -wi;  // two-sided (materials-spec 2.3 MEASURED)
  if (!(wo.z * wi.z > 0)) return false;
  glm::dvec3 wh = wi + wo;
  if (wh == glm::dvec3(0.0)) return false;
  wh = glm::normalize(wh);
  const double th = std::acos(std::clamp(wh.z, -1.0, 1.0));
  const double st = std::sqrt(std::max(0.0, 1.0 - wh.z * wh.z));
  const double cp = st == 0 ? 1.0 : std::clamp(wh.x / st, -1.0, 1.0);
  const double sp = st == 0 ? 0.0 : std::clamp(wh.y / st, -1.0, 1.0);
  const glm::dvec3 whx(cp * wh.z, sp * wh.z, -st), why(-sp, cp, 0.0);
  const glm::dvec3 wd(glm::dot(wi, whx), glm::dot(wi, why), glm::dot(wi, wh));
  const double td = std::acos(std::clamp(wd.z, -1.0, 1.0));
  double pd = std::atan2(wd.y, wd.x);
  if (pd < 0) pd += 2 * kPi;
  if (pd > kPi) pd -= kPi;
  *c = glm::dvec3(std::sqrt(std::max(0.0, th / (kPi / 2))) * dims.x, td / (kPi / 2) * dims.y,
                  pd / kPi * dims.z);
  return true;
}

}  // namespace

std::vector<long> measured_candidate_bins(glm::vec3 wo, glm::vec3 wi, glm::uvec3 dims,
                                          double slack) {
  // The exact coordinates and those of a few inputs perturbed by a few float ulps: a float
  // implementation may land in any bin these reach (ill-conditioned near theta_h = 0 or
  // theta_d = 0, where phi is undefined), or next to a boundary within `slack` bins.
  std::set<long> bins;
  std::mt19937 rng(std::hash<float>()(wo.x) ^ std::hash<float>()(wi.y));
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int k = 0; k < 33; ++k) {
    glm::dvec3 a(wo), b(wi);
    if (k > 0) {
      const double e = k < 17 ? 1e-6 : 1e-5;
      for (int c = 0; c < 3; ++c) a[c] *= 1 + e * U(rng), b[c] *= 1 + e * U(rng);
    }
    glm::dvec3 c;
    if (!measured_coords(a, b, dims, &c)) continue;
    std::vector<long> idx[3];
    for (int j = 0; j < 3; ++j) {
      const long n = long(dims[j]);
      const double s = slack * n;
      for (double x : {c[j] - s, c[j], c[j] + s}) {
        long i = long(std::floor(x));
        if (j == 2) {  // phi_d wraps: pi - 0 and 0 + 0 are neighbours
          i = ((i % n) + n) % n;
        } else {
          i = std::clamp(i, 0L, n - 1);
        }
        if (std::find(idx[j].begin(), idx[j].end(), i) == idx[j].end()) idx[j].push_back(i);
      }
    }
    for (long h : idx[0])
      for (long d : idx[1])
        for (long p : idx[2]) bins.insert(p + long(dims.z) * (d + h * long(dims.y)));
  }
  return std::vector<long>(bins.begin(), bins.end());
}

// ---- generators ----------------------------------------------------------------------------

glm::vec3 dir(double c, double phi) {
  c = std::clamp(c, -1.0, 1.0);
  const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
  return glm::vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(c));
}

glm::vec3 uniform_dir(std::mt19937& rng) {
  std::uniform_real_distribution<double> U(0.0, 1.0);
  return dir(1.0 - 2.0 * U(rng), 2.0 * kPi * U(rng));
}

double hard_cos(std::mt19937& rng) {
  static const double values[] = {0.0, 1e-7, -1e-7, 1.0, -1.0, 1e-4, -1e-4, 1.0 - 1e-7,
                                  -(1.0 - 1e-7), 1e-3, -1e-3};
  std::uniform_int_distribution<int> pick(0, int(std::size(values)));
  const int i = pick(rng);
  if (i < int(std::size(values))) return values[i];
  return std::uniform_real_distribution<double>(-1.0, 1.0)(rng);
}

float hard_u(std::mt19937& rng) {
  static const float values[] = {0.0f, 1e-7f, 0.5f, kOneMinus, 0.25f, 0.75f};
  std::uniform_int_distribution<int> pick(0, 2 * int(std::size(values)));
  const int i = pick(rng);
  if (i < int(std::size(values))) return values[i];
  return std::uniform_real_distribution<float>(0.0f, 1.0f)(rng);
}

std::uint32_t MaterialSet::add(const gpu::Material& m) {
  materials.push_back(m);
  return std::uint32_t(materials.size() - 1);
}

std::uint32_t MaterialSet::add_table(const std::vector<float>& t) {
  const std::uint32_t offset = std::uint32_t(measured.size());
  measured.insert(measured.end(), t.begin(), t.end());
  return offset;
}

const std::vector<std::uint32_t>& random_kinds() {
  static const std::vector<std::uint32_t> kinds = {
      gpu::MATERIAL_DIFFUSE,         gpu::MATERIAL_OREN_NAYAR,
      gpu::MATERIAL_CONDUCTOR,       gpu::MATERIAL_METAL,
      gpu::MATERIAL_MIRROR,          gpu::MATERIAL_DIELECTRIC,
      gpu::MATERIAL_THIN_DIELECTRIC, gpu::MATERIAL_DIFFUSE_TRANSMISSION,
      gpu::MATERIAL_COATED_DIFFUSE,  gpu::MATERIAL_COATED_CONDUCTOR,
      gpu::MATERIAL_PLASTIC,         gpu::MATERIAL_SUBSTRATE,
      gpu::MATERIAL_TRANSLUCENT,     gpu::MATERIAL_UBER,
      gpu::MATERIAL_MEASURED,        gpu::MATERIAL_MIX_WEIGHTED,
      gpu::MATERIAL_MIX};
  return kinds;
}

namespace {

/// Most lobes a material of this kind can have (MIX_WEIGHTED children must sum to <= 8).
std::uint32_t max_lobes(std::uint32_t type) {
  switch (type) {
    case gpu::MATERIAL_PLASTIC: return 2;
    case gpu::MATERIAL_TRANSLUCENT: return 4;
    case gpu::MATERIAL_UBER: return 5;
    default: return 1;
  }
}

struct Gen {
  std::mt19937& rng;
  float uni(float a, float b) { return std::uniform_real_distribution<float>(a, b)(rng); }
  bool chance(double p) { return std::uniform_real_distribution<double>(0, 1)(rng) < p; }
  float log_uni(float a, float b) { return std::exp(uni(std::log(a), std::log(b))); }
  /// A Henyey-Greenstein g: mostly in [-0.9, 0.9], 15 % at or near the ends of [-1, 1], which
  /// pbrt-v4 clamps to [-0.99, 0.99] in every use (docs/hard-cases.md).
  float phase_g() {
    static const float kEnds[] = {-1.0f, -0.995f, 0.995f, 1.0f};
    return chance(0.15) ? kEnds[std::uniform_int_distribution<int>(0, 3)(rng)] : uni(-0.9f, 0.9f);
  }
  /// Roughness: 0, 1e-4, 1, or log-uniform in [1e-4, 1].
  float rough() {
    const float x = uni(0, 1);
    if (x < 0.1f) return 0.0f;
    if (x < 0.17f) return 1e-4f;
    if (x < 0.24f) return 1.0f;
    if (x < 0.3f) return 1e-3f;
    return log_uni(1e-4f, 1.0f);
  }
  /// eta in [1.0001, 4], often close to 1.
  float eta() {
    const float x = uni(0, 1);
    if (x < 0.08f) return 1.0001f;
    if (x < 0.14f) return 4.0f;
    if (x < 0.4f) return 1.0f + log_uni(1e-4f, 0.3f);
    return uni(1.0001f, 4.0f);
  }
  float k() {
    const float x = uni(0, 1);
    if (x < 0.1f) return 0.0f;
    if (x < 0.2f) return 10.0f;
    return uni(0.0f, 10.0f);
  }
  glm::vec3 rgb() {
    const float x = uni(0, 1);
    if (x < 0.08f) return glm::vec3(0.0f);
    if (x < 0.16f) return glm::vec3(1.0f);
    return glm::vec3(uni(0, 1), uni(0, 1), uni(0, 1));
  }
  /// Remap mode and distribution.
  std::uint32_t flags() {
    std::uint32_t f = std::uniform_int_distribution<std::uint32_t>(0, 2)(rng);
    if (chance(0.35)) f |= gpu::MATFLAG_BECKMANN;
    return f;
  }
  /// (u, v) roughness: isotropic or anisotropic.
  std::pair<float, float> uv() {
    const float u = rough();
    return {u, chance(0.5) ? u : rough()};
  }
};

}  // namespace

std::uint32_t add_random_material(MaterialSet& set, std::uint32_t type, std::mt19937& rng,
                                  std::uint32_t measured_offset, glm::uvec3 measured_dims) {
  Gen g{rng};
  switch (type) {
    case gpu::MATERIAL_DIFFUSE: return set.add(diffuse(g.rgb()));
    case gpu::MATERIAL_OREN_NAYAR: {
      const float x = g.uni(0, 1);
      return set.add(oren_nayar(g.rgb(), x < 0.2f ? 0.0f : x < 0.3f ? 90.0f : g.uni(0, 90)));
    }
    case gpu::MATERIAL_CONDUCTOR:
    case gpu::MATERIAL_METAL: {
      auto [u, v] = g.uv();
      if (type == gpu::MATERIAL_CONDUCTOR && g.chance(0.3))
        return set.add(conductor_reflectance(g.rgb(), u, v, g.flags()));
      return set.add(conductor(glm::vec3(g.uni(0.05f, 4), g.uni(0.05f, 4), g.uni(0.05f, 4)),
                               glm::vec3(g.k(), g.k(), g.k()), u, v, g.flags(),
                               type == gpu::MATERIAL_METAL));
    }
    case gpu::MATERIAL_MIRROR: return set.add(mirror(g.rgb()));
    case gpu::MATERIAL_DIELECTRIC: {
      auto [u, v] = g.uv();
      const float eta = g.chance(0.06) ? 1.0f : g.eta();
      const bool v3 = g.chance(0.3);  // pbrt-v3 glass: Kr, Kt not 1
      return set.add(dielectric(eta, u, v, g.flags(), v3 ? g.rgb() : glm::vec3(1.0f),
                                v3 ? g.rgb() : glm::vec3(1.0f)));
    }
    case gpu::MATERIAL_THIN_DIELECTRIC: return set.add(thin_dielectric(g.eta()));
    case gpu::MATERIAL_DIFFUSE_TRANSMISSION:
      return set.add(diffuse_transmission(g.rgb(), g.rgb(), g.chance(0.7) ? 1.0f : g.uni(0, 1)));
    case gpu::MATERIAL_COATED_DIFFUSE: {
      auto [u, v] = g.uv();
      return set.add(coated_diffuse(
          g.rgb(), u, v, g.chance(0.1) ? 0.0f : g.log_uni(1e-4f, 1.0f), g.eta(),
          g.chance(0.5) ? glm::vec3(0.0f) : g.rgb(), g.phase_g(),
          std::uniform_int_distribution<std::uint32_t>(1, 10)(rng),
          std::uniform_int_distribution<std::uint32_t>(1, 3)(rng), g.flags()));
    }
    case gpu::MATERIAL_COATED_CONDUCTOR: {
      auto [iu, iv] = g.uv();
      auto [u, v] = g.uv();
      gpu::Material m = coated_conductor(
          iu, iv, g.chance(0.1) ? 0.0f : g.log_uni(1e-4f, 1.0f), g.eta(), g.phase_g(),
          g.chance(0.5) ? glm::vec3(0.0f) : g.rgb(), u, v,
          glm::vec3(g.uni(0.05f, 4), g.uni(0.05f, 4), g.uni(0.05f, 4)),
          glm::vec3(g.k(), g.k(), g.k()),
          std::uniform_int_distribution<std::uint32_t>(1, 10)(rng),
          std::uniform_int_distribution<std::uint32_t>(1, 3)(rng), g.flags());
      if (g.chance(0.3)) {
        m.flags |= gpu::MATFLAG_USE_REFLECTANCE;
        bsdf::set(m, gpu::SLOT_CC_REFLECTANCE, g.rgb());
      }
      return set.add(m);
    }
    case gpu::MATERIAL_PLASTIC: return set.add(plastic(g.rgb(), g.rgb(), g.rough(), g.flags()));
    case gpu::MATERIAL_SUBSTRATE: {
      auto [u, v] = g.uv();
      return set.add(substrate(g.rgb(), g.rgb(), u, v, g.flags()));
    }
    case gpu::MATERIAL_TRANSLUCENT:
      return set.add(translucent(g.rgb(), g.rgb(), g.rgb(), g.rgb(), g.rough(), g.flags()));
    case gpu::MATERIAL_UBER: {
      auto [u, v] = g.uv();
      const float x = g.uni(0, 1);
      const glm::vec3 op = x < 0.3f ? glm::vec3(1.0f) : x < 0.4f ? glm::vec3(0.0f) : g.rgb();
      return set.add(uber(g.rgb(), g.rgb(), g.chance(0.5) ? glm::vec3(0.0f) : g.rgb(),
                          g.chance(0.5) ? glm::vec3(0.0f) : g.rgb(), u, v, g.eta(), op,
                          g.flags()));
    }
    case gpu::MATERIAL_MEASURED: return set.add(measured(measured_offset, measured_dims));
    case gpu::MATERIAL_MIX_WEIGHTED:
    case gpu::MATERIAL_MIX: {
      const auto& kinds = random_kinds();
      std::uniform_int_distribution<std::size_t> pick(0, kinds.size() - 3);  // no mixes
      std::uint32_t ta = kinds[pick(rng)], tb = kinds[pick(rng)];
      while (max_lobes(ta) + max_lobes(tb) > gpu::MAX_LOBES) tb = kinds[pick(rng)];
      std::uint32_t a, b;
      if (type == gpu::MATERIAL_MIX && g.chance(0.25)) {
        // Nested: a MIX_WEIGHTED child, or a MIX child.
        a = add_random_material(set, g.chance(0.5) ? gpu::MATERIAL_MIX_WEIGHTED
                                                   : gpu::MATERIAL_MIX,
                                rng, measured_offset, measured_dims);
      } else {
        a = add_random_material(set, ta, rng, measured_offset, measured_dims);
      }
      b = add_random_material(set, tb, rng, measured_offset, measured_dims);
      if (type == gpu::MATERIAL_MIX) {
        const float x = g.uni(0, 1);
        return set.add(mix(a, b, x < 0.1f ? 0.0f : x < 0.2f ? 1.0f : g.uni(0, 1)));
      }
      const float x = g.uni(0, 1);
      const glm::vec3 amount = x < 0.1f   ? glm::vec3(0.0f)
                               : x < 0.2f ? glm::vec3(1.0f)
                               : x < 0.3f ? glm::vec3(g.uni(-0.5f, 1.5f))  // clamped
                                          : glm::vec3(g.uni(0, 1), g.uni(0, 1), g.uni(0, 1));
      return set.add(mix_weighted(a, b, amount));
    }
    default: return set.add(blank(type));
  }
}

bool deterministic(const MaterialSet& set, std::uint32_t index) {
  if (index >= set.materials.size()) return true;
  const gpu::Material& m = set.materials[index];
  switch (m.type) {
    case gpu::MATERIAL_COATED_DIFFUSE:
    case gpu::MATERIAL_COATED_CONDUCTOR: return false;
    case gpu::MATERIAL_MIX:
    case gpu::MATERIAL_MIX_WEIGHTED:
      return deterministic(set, m.aux0) && deterministic(set, m.aux1);
    default: return true;
  }
}

// ---- statistics ----------------------------------------------------------------------------

double gamma_q(double a, double x) {
  // Numerical Recipes 3rd ed. 6.2: series for x < a + 1, continued fraction otherwise.
  if (x <= 0) return 1.0;
  const double lg = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double sum = 1.0 / a, term = sum;
    for (int n = 1; n < 100000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::fabs(term) < std::fabs(sum) * 1e-15) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(lg));
  }
  double b = x + 1.0 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::fabs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-15) break;
  }
  return std::exp(lg) * h;
}

double sidak(double alpha, int n) { return 1.0 - std::pow(1.0 - alpha, 1.0 / n); }

void Chi2Test::add_queries(std::vector<Query>& qs) {
  std::mt19937 rng(seed * 7919u + material * 104729u + 17u);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  sample_offset = qs.size();
  for (int i = 0; i < samples; ++i) {
    Query q;
    q.material = material;
    q.wo = wo;
    q.wi = wo;
    q.u = glm::vec3(U(rng), U(rng), U(rng));
    q.px = std::uint32_t(i) & 0xffffu;
    q.py = (std::uint32_t(i) >> 16) + 4096u * seed;
    qs.push_back(q);
  }
  // pdf on a Simpson grid per bin; bin edges nudged inwards so that each bin sees its own
  // side of a discontinuity on its edge (the horizon is an edge: theta_res is even).
  pdf_offset = qs.size();
  const double dt = kPi / theta_res, dp = 2 * kPi / phi_res;
  for (int t = 0; t < theta_res; ++t)
    for (int p = 0; p < phi_res; ++p)
      for (int a = 0; a <= simpson; ++a)
        for (int b = 0; b <= simpson; ++b) {
          const double fa = std::clamp(double(a) / simpson, 1e-6, 1 - 1e-6);
          const double fb = std::clamp(double(b) / simpson, 1e-6, 1 - 1e-6);
          const double theta = (t + fa) * dt, phi = (p + fb) * dp;
          Query q;
          q.material = material;
          q.wo = wo;
          q.wi = dir(std::cos(theta), phi);
          q.u = glm::vec3(0.5f);
          qs.push_back(q);
        }
}

double Chi2Test::p_value(const std::vector<Result>& rs, std::string* message) const {
  const int cells = theta_res * phi_res;
  std::vector<double> obs(cells, 0.0), expct(cells, 0.0);
  std::size_t specular = 0, invalid = 0;
  for (int i = 0; i < samples; ++i) {
    const Result& r = rs[sample_offset + i];
    if (!r.sampled() || !(r.spdf > 0)) {
      ++invalid;
      continue;
    }
    if (r.specular()) {
      ++specular;
      continue;
    }
    const glm::dvec3 w = glm::normalize(glm::dvec3(r.swi));
    const double theta = std::acos(std::clamp(w.z, -1.0, 1.0));
    double phi = std::atan2(w.y, w.x);
    if (phi < 0) phi += 2 * kPi;
    const int t = std::min(int(theta / kPi * theta_res), theta_res - 1);
    const int p = std::min(int(phi / (2 * kPi) * phi_res), phi_res - 1);
    obs[t * phi_res + p] += 1;
  }
  // Simpson weights 1 4 2 4 ... 4 1 (h / 3).
  std::vector<double> wts(simpson + 1);
  for (int a = 0; a <= simpson; ++a) wts[a] = (a == 0 || a == simpson) ? 1 : (a % 2 ? 4 : 2);
  const double dt = kPi / theta_res, dp = 2 * kPi / phi_res;
  const double ht = dt / simpson, hp = dp / simpson;
  std::size_t k = pdf_offset;
  double total = 0.0;
  for (int t = 0; t < theta_res; ++t)
    for (int p = 0; p < phi_res; ++p) {
      double sum = 0.0;
      for (int a = 0; a <= simpson; ++a)
        for (int b = 0; b <= simpson; ++b) {
          const double fa = std::clamp(double(a) / simpson, 1e-6, 1 - 1e-6);
          const double theta = (t + fa) * dt;
          sum += wts[a] * wts[b] * double(rs[k++].pdf) * std::sin(theta);
        }
      expct[t * phi_res + p] = sum * ht * hp / 9.0 * samples;
      total += sum * ht * hp / 9.0;
    }
  std::ostringstream msg;
  msg << "chi2 test material " << material << " wo (" << wo.x << ", " << wo.y << ", " << wo.z
      << "): samples " << samples << ", invalid " << invalid << ", specular " << specular
      << ", integral of pdf " << total;
  if (specular > 0) {
    if (message) *message = msg.str() + ": specular samples in a chi-square test";
    return 0.0;
  }
  // pbrt-v3 Chi2Test: pool cells with expected frequency below 5, fail on observations where
  // the expected frequency is 0.
  std::vector<int> order(cells);
  for (int i = 0; i < cells; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return expct[a] < expct[b]; });
  const double min_exp = 5.0;
  double pooled_obs = 0, pooled_exp = 0, chsq = 0;
  int dof = 0;
  for (int i : order) {
    if (expct[i] == 0) {
      if (obs[i] > samples * 1e-5) {
        msg << "; " << obs[i] << " samples in cell (theta " << i / phi_res << ", phi "
            << i % phi_res << ") where the pdf integrates to 0";
        if (message) *message = msg.str();
        return 0.0;
      }
    } else if (expct[i] < min_exp) {
      pooled_obs += obs[i];
      pooled_exp += expct[i];
    } else if (pooled_exp > 0 && pooled_exp < min_exp) {
      pooled_obs += obs[i];
      pooled_exp += expct[i];
    } else {
      chsq += (obs[i] - expct[i]) * (obs[i] - expct[i]) / expct[i];
      ++dof;
    }
  }
  if (pooled_exp > 0 || pooled_obs > 0) {
    chsq += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / std::max(pooled_exp, 1e-300);
    ++dof;
  }
  dof -= 1;
  if (dof <= 0) {
    if (message) *message = msg.str() + "; no degrees of freedom";
    return 0.0;
  }
  const double pval = gamma_q(dof / 2.0, chsq / 2.0);
  msg << ", chi2 " << chsq << ", dof " << dof << ", p " << pval;
  // The worst cell, to point at the direction that disagrees.
  int worst = -1;
  double wv = 0;
  for (int i = 0; i < cells; ++i) {
    if (expct[i] < min_exp) continue;
    const double v = (obs[i] - expct[i]) * (obs[i] - expct[i]) / expct[i];
    if (v > wv) wv = v, worst = i;
  }
  if (worst >= 0)
    msg << "; worst cell (theta " << worst / phi_res << "/" << theta_res << ", phi "
        << worst % phi_res << "/" << phi_res << ") observed " << obs[worst] << " expected "
        << expct[worst];
  if (message) *message = msg.str();
  return pval;
}

std::vector<Query> albedo_queries(std::uint32_t material, glm::vec3 wo, int n,
                                  std::uint32_t seed, glm::vec3 ng) {
  std::mt19937 rng(seed * 31337u + material);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  std::vector<Query> qs(n);
  for (int i = 0; i < n; ++i) {
    Query& q = qs[i];
    q.material = material;
    q.wo = wo;
    q.wi = wo;
    q.ng = ng;
    q.u = glm::vec3(U(rng), U(rng), U(rng));
    q.px = std::uint32_t(i) & 0xffffu;
    q.py = (std::uint32_t(i) >> 16) + 8192u * (seed + 1);
  }
  return qs;
}

Estimate albedo_estimate(const std::vector<Result>& rs, std::size_t begin, std::size_t n,
                         bool flux) {
  glm::dvec3 s(0.0), s2(0.0);
  for (std::size_t i = begin; i < begin + n; ++i) {
    const Result& r = rs[i];
    glm::dvec3 w(0.0);
    if (r.sampled() && r.spdf > 0) {
      w = glm::dvec3(r.sf) * std::fabs(double(r.swi.z)) / double(r.spdf);
      if (flux && r.transmission()) w *= double(r.seta) * r.seta;
    }
    s += w;
    s2 += w * w;
  }
  Estimate e;
  e.n = n;
  e.mean = s / double(n);
  const glm::dvec3 var = glm::max(s2 / double(n) - e.mean * e.mean, glm::dvec3(0.0));
  e.se = glm::sqrt(var / double(std::max<std::size_t>(n - 1, 1)));
  return e;
}

unsigned differences(const Result& a, const Result& b, float rel, float abs) {
  unsigned d = 0;
  if (!close(a.f, b.f, rel, abs)) d |= kEval;
  if (!close(a.pdf, b.pdf, rel, abs)) d |= kPdf;
  if (a.lobes != b.lobes || a.bflags != b.bflags || a.lobe0 != b.lobe0) d |= kStatic;
  if (a.sflags != b.sflags || a.proportional != b.proportional) {
    d |= kSampleFlags;
  } else if (a.sampled()) {
    if (!close(a.sf, b.sf, rel, abs)) d |= kSampleF;
    if (!close(a.spdf, b.spdf, rel, abs)) d |= kSamplePdf;
    if (!close_direction(a.swi, b.swi, rel, abs)) d |= kSampleWi;
    if (!close(a.seta, b.seta, rel, abs)) d |= kSampleEta;
    if (!close(a.pdf_at_sample, b.pdf_at_sample, rel, abs)) d |= kPdfAtSample;
  }
  return d;
}

std::vector<unsigned> unstable_fields(Side side, const SceneTables& tables,
                                      const std::vector<Query>& qs,
                                      const std::vector<Result>& answers, float rel, float abs) {
  constexpr int kPerturb = 16;
  std::vector<Query> pq;
  pq.reserve(qs.size() * kPerturb);
  for (const Query& q0 : qs) {
    // Perturbations drawn from the query's own bits, so that its verdict does not depend on
    // which other queries of a batch are judged with it.
    std::uint64_t h = 1469598103934665603ull;
    auto mix = [&](float v) { h = (h ^ std::bit_cast<std::uint32_t>(v)) * 1099511628211ull; };
    for (int c = 0; c < 3; ++c) mix(q0.wo[c]), mix(q0.wi[c]), mix(q0.u[c]);
    h = (h ^ q0.material) * 1099511628211ull;
    std::mt19937 rng(std::uint32_t(h ^ (h >> 32)));
    for (int k = 0; k < kPerturb; ++k) {
      Query q = q0;
      // Up to 4 ulps of 1 per component, absolute: the components of a unit vector that a
      // renderer computes (dot products with a frame) carry an absolute error of that size,
      // so a cosine of 1e-7 is known only to about its own size. A component keeps its sign.
      auto nudge = [&](float x) {
        const float y = x + float(int(rng() % 9) - 4) * 6e-8f;
        return (y > 0.0f) == (x > 0.0f) && (y < 0.0f) == (x < 0.0f) ? y : x;
      };
      for (int c = 0; c < 3; ++c) {
        q.wo[c] = nudge(q.wo[c]);
        q.wi[c] = nudge(q.wi[c]);
      }
      // u0, u1 too (e.g. cosine sampling at u0 ~ 1 computes z from 1 - r^2), never u_lobe:
      // the lobe choice k = floor(u_lobe n) is exact on both sides.
      for (int c = 1; c < 3; ++c)
        q.u[c] = std::clamp(q.u[c] + float(int(rng() % 9) - 4) * 6e-8f, 0.0f, kOneMinus);
      pq.push_back(q);
    }
  }
  const std::vector<Result> pr = run(side, tables, pq);
  std::vector<unsigned> mask(qs.size(), 0);
  for (std::size_t j = 0; j < qs.size(); ++j)
    for (int k = 0; k < kPerturb; ++k)
      mask[j] |= differences(answers[j], pr[j * kPerturb + k], rel, abs);
  return mask;
}

bool close(float a, float b, float rel, float abs) {
  if (a == b) return true;
  const float d = std::fabs(a - b);
  return d <= std::max(rel * std::max(std::fabs(a), std::fabs(b)), abs);
}

bool close(glm::vec3 a, glm::vec3 b, float rel, float abs) {
  return close(a.x, b.x, rel, abs) && close(a.y, b.y, rel, abs) && close(a.z, b.z, rel, abs);
}

bool close_direction(glm::vec3 a, glm::vec3 b, float rel, float abs) {
  if (a == b) return true;
  const double d = glm::length(glm::dvec3(a) - glm::dvec3(b));
  const double scale = std::max(glm::length(glm::dvec3(a)), glm::length(glm::dvec3(b)));
  return d <= std::max(double(rel) * scale, double(abs));
}

bool sane(const Result& r, std::string* why) {
  auto fin = [](glm::vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
  };
  auto nonneg = [](glm::vec3 v) { return v.x >= 0 && v.y >= 0 && v.z >= 0; };
  const char* bad = nullptr;
  if (!fin(r.f) || !std::isfinite(r.pdf)) bad = "eval or pdf not finite";
  else if (!nonneg(r.f) || !(r.pdf >= 0)) bad = "eval or pdf negative";
  else if (!fin(r.sf) || !std::isfinite(r.spdf) || !fin(r.swi) || !std::isfinite(r.seta))
    bad = "sample not finite";
  else if (!nonneg(r.sf) || !(r.spdf >= 0)) bad = "sample f or pdf negative";
  else if (!std::isfinite(r.pdf_at_sample) || !(r.pdf_at_sample >= 0))
    bad = "pdf at the sample not finite or negative";
  else if (r.sampled() && !(r.spdf > 0)) bad = "a sample with pdf 0";
  else if (r.sampled() && std::fabs(glm::length(r.swi) - 1.0f) > 1e-3f)
    bad = "sampled direction not unit";
  else if (r.sampled() && !(r.seta > 0)) bad = "sample eta not positive";
  if (bad && why) *why = bad;
  return bad == nullptr;
}

bool has_measured(const MaterialSet& set, std::uint32_t index) {
  if (index >= set.materials.size()) return false;
  const gpu::Material& m = set.materials[index];
  if (m.type == gpu::MATERIAL_MEASURED) return true;
  if (m.type == gpu::MATERIAL_MIX || m.type == gpu::MATERIAL_MIX_WEIGHTED)
    return has_measured(set, m.aux0) || has_measured(set, m.aux1);
  return false;
}

glm::vec3 refract_dir(glm::vec3 wo, float eta) {
  const glm::dvec3 w(wo);
  const double e = w.z > 0 ? 1.0 / eta : eta;
  const double c = std::fabs(w.z), s2 = std::max(0.0, 1 - c * c) * e * e;
  if (s2 >= 1) return glm::vec3(-wo.x, -wo.y, wo.z);
  const double ct = std::sqrt(1 - s2);
  glm::dvec3 t = -w * e;
  t.z = w.z > 0 ? -ct : ct;
  return glm::vec3(glm::normalize(t));
}

float material_eta(const gpu::Material& m) {
  switch (m.type) {
    case gpu::MATERIAL_DIELECTRIC: return m.value[gpu::SLOT_DIELECTRIC_ETA].x;
    case gpu::MATERIAL_THIN_DIELECTRIC: return m.value[gpu::SLOT_THIN_ETA].x;
    case gpu::MATERIAL_UBER: return m.value[gpu::SLOT_UBER_ETA].x;
    case gpu::MATERIAL_COATED_DIFFUSE: return m.value[gpu::SLOT_CD_ETA].x;
    case gpu::MATERIAL_COATED_CONDUCTOR: return m.value[gpu::SLOT_CC_IF_ETA].x;
    default: return 1.5f;
  }
}

glm::vec3 effective_wi(const Query& q, glm::vec3 wi) {
  const double go = glm::dot(glm::dvec3(q.wo), glm::dvec3(q.ng));
  const double gi = glm::dot(glm::dvec3(wi), glm::dvec3(q.ng));
  const bool geo = go * gi > 0, sh = double(q.wo.z) * wi.z > 0;
  return geo != sh ? glm::vec3(wi.x, wi.y, -wi.z) : wi;
}

bool tangent_or_no_sample(const Result& cpu, const Result& gpu) {
  auto ok = [](const Result& r) { return !r.sampled() || std::fabs(r.swi.z) < 1e-3f; };
  return ok(cpu) && ok(gpu);
}

// ---- judging GPU against CPU answers ---------------------------------------------------------

namespace {

/// CPU answers of the mismatched queries asked again with wi = the direction that `from`
/// sampled (only where a sample's f, pdf or pdf at the sample differ, `from` sampled a
/// non-specular, non-proportional direction, and the difference mask has no bit of skip_if).
struct Requery {
  std::vector<Result> answers;
  std::vector<std::size_t> index;  // per mismatched query: its answer, or SIZE_MAX
};
Requery cpu_at_sampled_direction(const SceneTables& t, const std::vector<Query>& qs,
                                 const std::vector<std::size_t>& mismatched,
                                 const std::vector<unsigned>& diff, const std::vector<Result>& from,
                                 unsigned skip_if) {
  Requery r;
  r.index.assign(mismatched.size(), SIZE_MAX);
  std::vector<Query> rq;
  for (std::size_t j = 0; j < mismatched.size(); ++j) {
    const std::size_t i = mismatched[j];
    const Result& f = from[i];
    if ((diff[i] & skip_if) || !(diff[i] & (kSampleF | kSamplePdf | kPdfAtSample)) ||
        !f.sampled() || f.proportional || (f.sflags & gpu::BSDF_SPECULAR))
      continue;
    Query q = qs[i];
    q.wi = f.swi;
    r.index[j] = rq.size();
    rq.push_back(q);
  }
  r.answers = run(Side::Cpu, t, rq);
  return r;
}

}  // namespace

const char* verdict_name(Verdict v) {
  switch (v) {
    case Verdict::Agree: return "agree";
    case Verdict::MeasuredBin: return "measured bin";
    case Verdict::Tangent: return "tangent sample";
    case Verdict::IllConditioned: return "ill-conditioned";
    case Verdict::OtherDirection: return "same at the other side's direction";
    case Verdict::RandomWalk: return "random walk";
    case Verdict::Mismatch: return "mismatch";
  }
  return "?";
}

Judgement judge(const MaterialSet& set, const SceneTables& tables, glm::uvec3 dims,
                const std::vector<Query>& qs, const std::vector<Result>& cpu,
                const std::vector<Result>& gpu) {
  constexpr unsigned kSampleValues = kSampleF | kSamplePdf | kPdfAtSample;
  const std::size_t n = qs.size();
  Judgement J{std::vector<Verdict>(n, Verdict::Agree), std::vector<unsigned>(n, 0),
              std::vector<unsigned>(n, 0)};
  std::vector<std::size_t> mismatched;
  for (std::size_t i = 0; i < n; ++i) {
    J.fields[i] = differences(cpu[i], gpu[i]);
    if (J.fields[i]) mismatched.push_back(i);
  }
  std::vector<Query> mq;
  std::vector<Result> mr;
  for (std::size_t i : mismatched) mq.push_back(qs[i]), mr.push_back(cpu[i]);
  const std::vector<unsigned> ill = unstable_fields(Side::Cpu, tables, mq, mr);
  // Sampled values conditioned on the sampled direction: where the sampled directions agree
  // (kSampleWi clear) but the sample's values do not, the CPU evaluates bsdf_eval and bsdf_pdf
  // at the GPU's direction. Inside narrow lobes (alpha ~ 1e-3), or where the half vector is
  // recomputed from a wi that nearly cancels wo (eta near 1), a direction difference of a few
  // 1e-8 changes D by 1e-4 or more; if the CPU's values at the GPU's direction equal the GPU's
  // differing values, both implement the same function and only the direction's rounding
  // differs.
  const Requery at_gpu = cpu_at_sampled_direction(tables, qs, mismatched, J.fields, gpu, kSampleWi);
  // Self-consistency of the CPU's own sample: a lobe's sample computes f and pdf from the
  // sampled microfacet normal, bsdf_eval from the normal recomputed from (wo, wi). Where the two
  // differ by more than the tolerance on the CPU alone, the sample's values are not determined
  // to 1e-4 by float arithmetic and cannot be compared to 1e-4 across implementations either.
  const Requery at_cpu = cpu_at_sampled_direction(tables, qs, mismatched, J.fields, cpu, 0);
  for (std::size_t j = 0; j < mismatched.size(); ++j) {
    const std::size_t i = mismatched[j];
    const Query& q = qs[i];
    unsigned d = J.fields[i];
    J.ill[i] = ill[j];
    Verdict& v = J.verdict[i];
    v = Verdict::Mismatch;
    // MEASURED: a lookup near a bin boundary may land in either bin.
    if (has_measured(set, q.material)) {
      if ((d & (kEval | kPdf)) && measured_candidate_bins(q.wo, effective_wi(q, q.wi), dims).size() > 1)
        d &= ~unsigned(kEval | kPdf);
      if ((d & (kSampleF | kSamplePdf)) && !(d & kSampleWi) &&
          measured_candidate_bins(q.wo, cpu[i].swi, dims).size() > 1)
        d &= ~unsigned(kSampleF | kSamplePdf);
      if (d == 0) {
        v = Verdict::MeasuredBin;
        continue;
      }
    }
    // Validity of a near-tangent sample: whether a sampled direction within 1e-3 of the tangent
    // plane is a sample at all depends on the sign of its tiny z (and on the light-leak rule's
    // side test), which the renderers' different rounding may flip; such a sample carries a
    // cosine of that size and so almost no weight. Only the sample's fields are excused: eval
    // and pdf at the query's wi must still agree.
    if ((d & kSampleFlags) && !(d & kStatic) && tangent_or_no_sample(cpu[i], gpu[i])) {
      d &= ~unsigned(kSampleFlags | kSampleF | kSamplePdf | kSampleWi | kSampleEta | kPdfAtSample);
      if (d == 0) {
        v = Verdict::Tangent;
        continue;
      }
    }
    if (at_cpu.index[j] != SIZE_MAX) {
      const Result& c = at_cpu.answers[at_cpu.index[j]];
      if (!close(c.f, cpu[i].sf) || !close(c.pdf, cpu[i].spdf)) d &= ~kSampleValues;
      if (d == 0) {
        v = Verdict::OtherDirection;
        continue;
      }
    }
    if (at_gpu.index[j] != SIZE_MAX && !(d & kStatic) &&
        (d & ~kSampleValues & ~ill[j]) == 0) {
      // Each differing sample value is what the CPU computes at the GPU's direction.
      const Result& c = at_gpu.answers[at_gpu.index[j]];
      const Result& g = gpu[i];
      if ((!(d & kSampleF) || close(c.f, g.sf)) && (!(d & kSamplePdf) || close(c.pdf, g.spdf)) &&
          (!(d & kPdfAtSample) || close(c.pdf, g.pdf_at_sample))) {
        v = Verdict::OtherDirection;
        continue;
      }
    }
    if ((d & ~ill[j]) == 0 && !(d & kStatic)) {
      v = Verdict::IllConditioned;
      continue;
    }
    if (!deterministic(set, q.material) && !(d & kStatic)) {
      v = Verdict::RandomWalk;
      continue;
    }
    J.fields[i] = d;
  }
  return J;
}

}  // namespace basalt::test::bsdf
