// BSDF acceptance-test helpers (issue 3): everything goes through the PROBE_BSDF probe op
// (layout.h, docs/materials-spec.md section 6), so that the same checks run on the CPU
// reference and on the GPU. Material records are built here directly from layout.h (no
// parser), measured tables are generated here, and the statistics (chi-square with pooled
// cells, albedo estimates with standard errors) are the test's own.
#pragma once
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "common/test_util.h"

namespace basalt::test::bsdf {

constexpr double kPi = 3.14159265358979323846;
/// The largest float below 1 (u "just below 1").
constexpr float kOneMinus = 0.99999994f;

// ---- probe queries -----------------------------------------------------------------------

/// One PROBE_BSDF query in local directions (frame = world frame, ns = +z).
struct Query {
  std::uint32_t material = 0;
  glm::vec3 wo{0.0f, 0.0f, 1.0f};
  glm::vec3 wi{0.0f, 0.0f, 1.0f};
  glm::vec3 u{0.5f, 0.5f, 0.5f};  // u_lobe, u0, u1
  glm::vec3 ng{0.0f, 0.0f, 1.0f}; // geometric normal in the local frame
  glm::vec3 p{0.0f};              // surface point (mix hash)
  std::uint32_t px = 0, py = 0;   // stream key
};

/// One PROBE_BSDF answer, decoded (layout.h PROBE_BSDF comment).
struct Result {
  glm::vec3 f{0.0f};    // bsdf_eval(wo, wi)
  float pdf = 0.0f;     // bsdf_pdf(wo, wi)
  glm::vec3 sf{0.0f};   // sample f
  float spdf = 0.0f;    // sample pdf
  glm::vec3 swi{0.0f};  // sample wi
  float seta = 0.0f;    // sample eta
  float pdf_at_sample = 0.0f;  // bsdf_pdf(wo, sample wi), stream dim 10
  std::uint32_t lobes = 0;     // lobe count
  std::uint32_t sflags = 0;    // sample flags (0: no sample)
  std::uint32_t bflags = 0;    // union of the lobe flags
  std::uint32_t proportional = 0;
  std::uint32_t lobe0 = 0;     // tag of lobe 0

  bool sampled() const { return sflags != 0; }
  bool specular() const { return (sflags & gpu::BSDF_SPECULAR) != 0; }
  bool transmission() const { return (sflags & gpu::BSDF_TRANSMISSION) != 0; }
};

/// Probe input record of a query.
gpu::ProbeIn to_probe(const Query& q);
/// Decodes a probe output record.
Result from_probe(const gpu::ProbeOut& o);
/// Runs the queries on one side (one dispatch on the GPU).
std::vector<Result> run(Side side, const SceneTables& tables, const std::vector<Query>& qs);

/// \brief Tables of a tiny valid probe scene whose material table is replaced by \p materials
///        and whose measured table is \p measured.
SceneTables make_tables(const std::vector<gpu::Material>& materials,
                        const std::vector<float>& measured = {});

// ---- material records (layout.h slots) ---------------------------------------------------

/// A record of \p type with every slot zero and every texture INVALID_INDEX.
gpu::Material blank(std::uint32_t type, std::uint32_t flags = 0);
/// Sets slot \p s to rgb \p v.
void set(gpu::Material& m, std::uint32_t s, glm::vec3 v);
/// Sets slot \p s to the float \p v (in x).
void set(gpu::Material& m, std::uint32_t s, float v);

gpu::Material diffuse(glm::vec3 R);
gpu::Material oren_nayar(glm::vec3 R, float sigma_deg);
/// CONDUCTOR (or METAL with \p metal) from eta and k.
gpu::Material conductor(glm::vec3 eta, glm::vec3 k, float urough, float vrough,
                        std::uint32_t flags = 0, bool metal = false);
/// CONDUCTOR with MATFLAG_USE_REFLECTANCE.
gpu::Material conductor_reflectance(glm::vec3 r, float urough, float vrough,
                                    std::uint32_t flags = 0);
gpu::Material mirror(glm::vec3 Kr);
gpu::Material dielectric(float eta, float urough, float vrough, std::uint32_t flags = 0,
                         glm::vec3 Kr = glm::vec3(1.0f), glm::vec3 Kt = glm::vec3(1.0f));
gpu::Material thin_dielectric(float eta);
gpu::Material diffuse_transmission(glm::vec3 R, glm::vec3 T, float scale = 1.0f);
gpu::Material coated_diffuse(glm::vec3 R, float urough, float vrough, float thickness,
                             float eta, glm::vec3 albedo, float g, std::uint32_t maxdepth,
                             std::uint32_t nsamples, std::uint32_t flags = 0);
gpu::Material coated_conductor(float if_urough, float if_vrough, float thickness, float if_eta,
                               float g, glm::vec3 albedo, float urough, float vrough,
                               glm::vec3 eta, glm::vec3 k, std::uint32_t maxdepth,
                               std::uint32_t nsamples, std::uint32_t flags = 0);
gpu::Material plastic(glm::vec3 Kd, glm::vec3 Ks, float rough, std::uint32_t flags = 0);
gpu::Material substrate(glm::vec3 Kd, glm::vec3 Ks, float urough, float vrough,
                        std::uint32_t flags = 0);
gpu::Material translucent(glm::vec3 Kd, glm::vec3 Ks, glm::vec3 reflect, glm::vec3 transmit,
                          float rough, std::uint32_t flags = 0);
gpu::Material uber(glm::vec3 Kd, glm::vec3 Ks, glm::vec3 Kr, glm::vec3 Kt, float urough,
                   float vrough, float eta, glm::vec3 opacity, std::uint32_t flags = 0);
/// MEASURED reading the table at float offset \p offset with dims (nThetaH, nThetaD, nPhiD).
gpu::Material measured(std::uint32_t offset, glm::uvec3 dims);
gpu::Material mix_weighted(std::uint32_t a, std::uint32_t b, glm::vec3 amount);
gpu::Material mix(std::uint32_t a, std::uint32_t b, float amount);

/// Readable dump of a material record (type name, flags, aux, non-zero slots).
std::string describe(const gpu::Material& m);
std::string describe(const Query& q);
std::string describe(const Result& r);
/// Name of a MATERIAL_* tag.
std::string type_name(std::uint32_t type);

// ---- measured tables -----------------------------------------------------------------------

/// \brief A generated table in pbrt-v2 RegularHalfangleBRDF layout whose red channel encodes
///        the bin index (red = (0.05 + 0.85 i / N) / pi, unique per bin) and whose green and
///        blue channels are smooth functions of the bin centre; every value <= 0.9/pi, so the
///        BRDF's albedo is <= 0.9 (energy-conserving).
std::vector<float> measured_table(glm::uvec3 dims);
/// The bin index encoded by a red value of measured_table, or -1 if it encodes none.
long measured_bin_of(float red, glm::uvec3 dims);
/// \brief The set of bins (pbrt-v2 index phi + nPhiD (thd + thh nThetaD)) a lookup of
///        (wo, wi) may legitimately land in: the bin of the exact (double) half/difference
///        coordinates, plus its neighbours when a coordinate is within \p slack bins (or
///        float-conditioning distance) of a bin boundary. Empty if the BRDF is zero there.
std::vector<long> measured_candidate_bins(glm::vec3 wo, glm::vec3 wi, glm::uvec3 dims,
                                          double slack = 1e-5);

// ---- generators ----------------------------------------------------------------------------

/// Unit direction with cos theta \p c and azimuth \p phi (computed in double, rounded).
glm::vec3 dir(double c, double phi);
/// Uniform direction on the sphere.
glm::vec3 uniform_dir(std::mt19937& rng);
/// A "hard" cos theta: 0, +-1e-7, +-1, +-1e-4, +-(1 - 1e-7), or uniform.
double hard_cos(std::mt19937& rng);
/// A "hard" sample value: 0, 1e-7, 0.5, just below 1, or uniform.
float hard_u(std::mt19937& rng);

/// A growing material table (random materials may append children, e.g. mixes).
struct MaterialSet {
  std::vector<gpu::Material> materials;
  std::vector<float> measured;
  std::uint32_t add(const gpu::Material& m);
  /// Appends a measured table, returning its offset.
  std::uint32_t add_table(const std::vector<float>& t);
};

/// Material kinds the random generators draw from (every kind with lobes).
const std::vector<std::uint32_t>& random_kinds();
/// \brief Appends a random material of \p type (parameters from the hard ranges: roughness
///        0 or 1e-4 .. 1, eta 1 or 1.0001 .. 4, k up to 10, every remap mode, TR or Beckmann,
///        isotropic or anisotropic) and returns its index. MIX and MIX_WEIGHTED add children.
///        \p measured_offset: where a measured table of dims \p measured_dims lies.
std::uint32_t add_random_material(MaterialSet& set, std::uint32_t type, std::mt19937& rng,
                                  std::uint32_t measured_offset, glm::uvec3 measured_dims);

/// True if the material (after mix children) has only deterministic lobes (no layered).
bool deterministic(const MaterialSet& set, std::uint32_t index);

// ---- statistics ----------------------------------------------------------------------------

/// Regularised upper incomplete gamma function Q(a, x) (chi-square p-value Q(dof/2, chi2/2)).
double gamma_q(double a, double x);
/// Per-test significance for \p alpha over \p n tests (Sidak correction).
double sidak(double alpha, int n);

/// A chi-square test of bsdf_sample against bsdf_pdf for one (material, wo), in two phases
/// (queries, then evaluation) so that many tests share one GPU dispatch.
struct Chi2Test {
  std::uint32_t material = 0;
  glm::vec3 wo{0.0f, 0.0f, 1.0f};
  int theta_res = 40, phi_res = 80;
  int samples = 200000;
  int simpson = 8;  // Simpson sub-intervals per bin and dimension (even)
  std::uint32_t seed = 1;
  std::size_t sample_offset = 0, pdf_offset = 0;  // where its queries lie in the batch

  /// Appends the sample queries and the pdf-integration queries to \p qs.
  void add_queries(std::vector<Query>& qs);
  /// \brief Chi-square p-value from the batch results; \p message receives the statistics
  ///        (and the reason when the test fails outright, e.g. samples where pdf == 0).
  double p_value(const std::vector<Result>& rs, std::string* message) const;
};

/// Mean and standard error per channel.
struct Estimate {
  glm::dvec3 mean{0.0};
  glm::dvec3 se{0.0};
  std::size_t n = 0;
};

/// \brief Queries for a sampling estimate of the directional albedo at wo (random u,
///        stream key per sample). \p flux: transmission weights are multiplied by eta^2
///        (radiance-mode BTDFs carry 1/eta^2; the flux albedo of a lossless interface is 1).
std::vector<Query> albedo_queries(std::uint32_t material, glm::vec3 wo, int n,
                                  std::uint32_t seed, glm::vec3 ng = glm::vec3(0, 0, 1));
/// Mean of f |cos| / pdf over the results (0 for no sample); eta^2 on transmissions if flux.
Estimate albedo_estimate(const std::vector<Result>& rs, std::size_t begin, std::size_t n,
                         bool flux);

/// Output fields of a PROBE_BSDF answer, as bits.
enum Field : unsigned {
  kEval = 1, kPdf = 2, kSampleFlags = 4, kSampleF = 8, kSamplePdf = 16, kSampleWi = 32,
  kSampleEta = 64, kPdfAtSample = 128, kStatic = 256,  // lobe count, bsdf flags, lobe tag
};
/// Fields of two answers that disagree beyond \p rel relative / \p abs absolute (Field bits).
unsigned differences(const Result& a, const Result& b, float rel = 1e-4f, float abs = 1e-6f);
/// \brief Float conditioning of each query on \p side: the fields whose answer moves beyond the
///        tolerance when wo, wi (and u0, u1) are perturbed by up to 4 ulps per component (16 draws
///        seeded by the query's bits, so a verdict does not depend on its batch; signs and
///        zeros kept). A mismatch confined to such fields is a property of float arithmetic at that
///        input (e.g. a half vector from wo + wi ~ 0 at grazing retro-reflection), not a bug.
std::vector<unsigned> unstable_fields(Side side, const SceneTables& tables,
                                      const std::vector<Query>& qs,
                                      const std::vector<Result>& answers, float rel = 1e-4f,
                                      float abs = 1e-6f);

/// |a - b| <= max(rel max(|a|, |b|), abs) (issue 3: 1e-4 relative or 1e-6 absolute).
bool close(float a, float b, float rel = 1e-4f, float abs = 1e-6f);
bool close(glm::vec3 a, glm::vec3 b, float rel = 1e-4f, float abs = 1e-6f);
/// \brief Directions (unit vectors): |a - b| <= max(rel |a|, abs), i.e. an angle of about
///        rel radians; per-component relative error would hold a near-zero component of a
///        unit vector to an absolute error far below the direction's own rounding.
bool close_direction(glm::vec3 a, glm::vec3 b, float rel = 1e-4f, float abs = 1e-6f);
/// All outputs finite, values and pdfs non-negative; \p why receives the first violation.
bool sane(const Result& r, std::string* why);

// ---- query generators and conditioning shared by the BSDF probe and stress tests ------------

/// \brief True if each side either sampled nothing or sampled a direction within 1e-3 of the
///        tangent plane, where whether it is a sample at all depends on rounding.
bool tangent_or_no_sample(const Result& cpu, const Result& gpu);
/// \brief True if the material tree of \p index contains a MEASURED material.
bool has_measured(const MaterialSet& set, std::uint32_t index);
/// \brief Refraction of \p wo through the z = 0 plane with relative IOR \p eta (reflection on
///        TIR), in double.
glm::vec3 refract_dir(glm::vec3 wo, float eta);
/// \brief eta of a material, for the "near refraction" wi generators (1.5 without one).
float material_eta(const gpu::Material& m);
/// \brief wi as the BSDF evaluates it (materials-spec 1.2: wi.z negated when the geometric and
///        the shading decisions disagree).
glm::vec3 effective_wi(const Query& q, glm::vec3 wi);

/// How a query's GPU answer compares with the CPU's (judge).
enum class Verdict {
  Agree,           // every field within tolerance (differences() == 0)
  MeasuredBin,     // a MEASURED lookup near a bin boundary, which may land in either bin
  Tangent,         // only the sample differs, and each side's sample is none or near-tangent
  IllConditioned,  // only fields that 4-ulp input perturbations move (unstable_fields) differ
  OtherDirection,  // only the sample's values differ, explained by the sampled direction
  RandomWalk,      // a layered random walk or stochastic mix that branched on a last bit
  Mismatch,        // none of these: a disagreement
};
/// Judgements of a batch: per query the verdict, the differing fields (after the excusals that
/// applied, for a Mismatch) and the ill-conditioned fields (0 where none was needed).
struct Judgement {
  std::vector<Verdict> verdict;
  std::vector<unsigned> fields, ill;
};
/// \brief Compares GPU with CPU answers of \p qs (differences: 1e-4 relative or 1e-6 absolute,
///        directions 1e-4 of their length, flags, lobe count and tags identical), then applies
///        the excusal rules in order (bsdf_check.cpp judge). \p dims: the MEASURED tables' bins.
Judgement judge(const MaterialSet& set, const SceneTables& tables, glm::uvec3 dims,
                const std::vector<Query>& qs, const std::vector<Result>& cpu,
                const std::vector<Result>& gpu);
/// A verdict's name, for reports.
const char* verdict_name(Verdict v);

}  // namespace basalt::test::bsdf
