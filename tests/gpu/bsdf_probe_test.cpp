// Issue 3 acceptance: the GLSL BSDFs agree with the CPU reference through the PROBE_BSDF probe
// on >= 1e5 random inputs of every material kind (random parameters over the hard ranges,
// hard-case directions and sample values, shading normals that disagree with ng), and every
// output is finite and non-negative on both sides.
//
// Tolerance (issue 3): 1e-4 relative or 1e-6 absolute on eval, pdf, sample f, pdf, direction,
// eta and pdf(wo, sample wi); flags, lobe count, lobe tags and sample flags identical.
// Mismatches are excused only where the result cannot be decided to that precision in float:
// - ill-conditioned inputs: perturbing wo and wi by 4 ulps changes the CPU's own answer by more
//   than the tolerance (e.g. a Fresnel choice uc ~ R, a sample at the horizon, D of a sharp
//   lobe); measured on the CPU side, counted, and the count is bounded;
// - MEASURED lookups whose half/difference coordinates are within float reach of a bin
//   boundary (bsdf::measured_candidate_bins in double);
// - layered (stochastic) lobes whose random walk branches on a last-bit difference: bounded
//   fraction, reported.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "common/bsdf_check.h"

namespace basalt::test {
namespace {

using namespace bsdf;

constexpr glm::uvec3 kDims(16, 8, 16);

/// Rotates \p w by a small random angle (log-uniform 1e-5 .. 0.3 rad).
glm::vec3 jitter(glm::vec3 w, std::mt19937& rng) {
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const double a = std::exp(std::log(1e-5) + U(rng) * (std::log(0.3) - std::log(1e-5)));
  glm::dvec3 d(w), r(glm::dvec3(uniform_dir(rng)));
  r = glm::normalize(r - d * glm::dot(r, d));
  return glm::vec3(glm::normalize(d * std::cos(a) + r * std::sin(a)));
}

/// Random queries on random materials of every kind, half from the hard-case generators.
struct Workload {
  MaterialSet set;
  std::vector<Query> qs;
  std::vector<std::uint32_t> kind;  // generated kind of each query
};

Workload make_workload(int materials_per_kind, int queries_per_material, std::uint32_t seed) {
  Workload w;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  const std::uint32_t offset = w.set.add_table(measured_table(kDims));
  for (std::uint32_t kind : random_kinds())
    for (int m = 0; m < materials_per_kind; ++m) {
      const std::uint32_t idx = add_random_material(w.set, kind, rng, offset, kDims);
      const float eta = material_eta(w.set.materials[idx]);
      for (int i = 0; i < queries_per_material; ++i) {
        Query q;
        q.material = idx;
        const double phi = U(rng) < 0.2f ? 0.0 : 2 * kPi * U(rng);
        q.wo = U(rng) < 0.5f ? uniform_dir(rng) : dir(hard_cos(rng), phi);
        const float x = U(rng);
        if (x < 0.3f) q.wi = uniform_dir(rng);
        else if (x < 0.55f) q.wi = jitter(glm::vec3(-q.wo.x, -q.wo.y, q.wo.z), rng);
        else if (x < 0.75f) q.wi = jitter(refract_dir(q.wo, eta), rng);
        else q.wi = dir(hard_cos(rng), 2 * kPi * U(rng));
        for (int c = 0; c < 3; ++c) q.u[c] = U(rng) < 0.5f ? hard_u(rng) : U(rng);
        if (U(rng) < 0.15f) {
          const glm::dvec3 t(U(rng) - 0.5, U(rng) - 0.5, 1.0);
          q.ng = glm::vec3(glm::normalize(t * glm::dvec3(1.2, 1.2, 1.0)));
        }
        q.p = glm::vec3(U(rng), U(rng), U(rng)) * 10.0f - 5.0f;
        q.px = std::uint32_t(rng() & 0xffffu);
        q.py = std::uint32_t(rng() & 0xffffu);
        w.qs.push_back(q);
        w.kind.push_back(kind);
      }
    }
  return w;
}

struct KindStats {
  std::size_t queries = 0, samples = 0, raw_mismatch = 0, excused_conditioning = 0,
              excused_direction = 0, excused_tangent = 0,
              excused_measured = 0, stochastic = 0, failures = 0;
};

/// Largest fraction of one kind's queries that the excusal rules may excuse, all rules together.
constexpr double kMaxExcusedPerKind = 0.02;

/// Runs a workload on both sides and checks agreement; prints per-kind statistics.
void check_agreement(const Workload& w, double max_excused_fraction,
                     double max_stochastic_fraction) {
  const SceneTables t = make_tables(w.set.materials, w.set.measured);
  const std::vector<Result> cpu = run(Side::Cpu, t, w.qs);
  const std::vector<Result> gpu = run(Side::Gpu, t, w.qs);
  ASSERT_EQ(cpu.size(), w.qs.size());
  ASSERT_EQ(gpu.size(), w.qs.size());

  int insane = 0;
  for (std::size_t i = 0; i < w.qs.size(); ++i) {
    std::string why;
    for (int s = 0; s < 2; ++s) {
      const Result& r = s ? gpu[i] : cpu[i];
      if (!sane(r, &why) && ++insane <= 10)
        ADD_FAILURE() << (s ? "GPU: " : "CPU: ") << why << "\n  "
                      << describe(w.set.materials[w.qs[i].material]) << "\n  "
                      << describe(w.qs[i]) << "\n  " << describe(r);
    }
  }
  EXPECT_EQ(insane, 0) << "outputs not finite or negative";

  // Differences and the excusal rules: bsdf_check.h judge (shared with Stress.Bsdf).
  const Judgement J = judge(w.set, t, kDims, w.qs, cpu, gpu);
  std::map<std::uint32_t, KindStats> stats;
  int printed = 0;
  for (std::size_t i = 0; i < w.qs.size(); ++i) {
    KindStats& s = stats[w.kind[i]];
    ++s.queries;
    s.samples += cpu[i].sampled();
    switch (J.verdict[i]) {
      case Verdict::Agree: break;
      case Verdict::MeasuredBin: ++s.excused_measured; break;
      case Verdict::Tangent: ++s.excused_tangent; break;
      case Verdict::IllConditioned: ++s.excused_conditioning; break;
      case Verdict::OtherDirection: ++s.excused_direction; break;
      case Verdict::RandomWalk: ++s.stochastic; break;
      case Verdict::Mismatch:
        // Every unexcused disagreement is printed (at most 3 per kind, 30 in all) and counted;
        // the acceptance criterion is that there are none.
        if (++s.failures <= 3 && ++printed <= 30)
          std::printf("GPU and CPU disagree (field mask %u, ill-conditioned mask %u)\n  material %s\n"
                      "  %s\n  CPU %s\n  GPU %s\n",
                      J.fields[i], J.ill[i], describe(w.set.materials[w.qs[i].material]).c_str(),
                      describe(w.qs[i]).c_str(), describe(cpu[i]).c_str(), describe(gpu[i]).c_str());
        break;
    }
    s.raw_mismatch += J.verdict[i] != Verdict::Agree;
  }
  std::size_t total = 0, excused = 0, stochastic = 0, stochastic_queries = 0, failures = 0;
  for (auto& [kind, s] : stats) {
    failures += s.failures;
    std::printf("  %-22s queries %6zu samples %6zu mismatches %5zu (excused: ill-conditioned "
                "%zu, same at the GPU's direction %zu, tangent sample %zu, measured bin %zu; "
                "stochastic %zu; failures %zu)\n",
                type_name(kind).c_str(), s.queries, s.samples, s.raw_mismatch,
                s.excused_conditioning, s.excused_direction, s.excused_tangent,
                s.excused_measured, s.stochastic, s.failures);
    // Not vacuous: most queries of every kind must produce a sample.
    EXPECT_GT(double(s.samples), 0.2 * double(s.queries)) << type_name(kind) << ": few samples";
    // Every excusal is bounded per kind (issue 11): at most kMaxExcusedPerKind of a kind's
    // queries, whatever the rule (measured at seed 2024: at most 0.8 %, MEASURED bins).
    const std::size_t kind_excused =
        s.excused_conditioning + s.excused_direction + s.excused_tangent + s.excused_measured;
    EXPECT_LE(double(kind_excused), kMaxExcusedPerKind * double(s.queries))
        << type_name(kind) << ": " << kind_excused << " excused of " << s.queries;
    total += s.queries;
    excused += s.excused_conditioning + s.excused_direction + s.excused_tangent;
    stochastic += s.stochastic;
    if (kind == gpu::MATERIAL_COATED_DIFFUSE || kind == gpu::MATERIAL_COATED_CONDUCTOR ||
        kind == gpu::MATERIAL_MIX || kind == gpu::MATERIAL_MIX_WEIGHTED)
      stochastic_queries += s.queries;
  }
  std::printf("  total %zu queries; excused (ill-conditioned or direction) %.2e; stochastic mismatches %.2e "
              "of the layered/mix queries\n",
              total, double(excused) / total,
              stochastic_queries ? double(stochastic) / stochastic_queries : 0.0);
  std::printf("  unexcused disagreements: %zu of %zu queries\n", failures, total);
  EXPECT_EQ(failures, 0u) << failures << " unexcused GPU/CPU disagreements";
  EXPECT_LE(double(excused) / total, max_excused_fraction);
  EXPECT_LE(stochastic_queries ? double(stochastic) / stochastic_queries : 0.0,
            max_stochastic_fraction);
}

// >= 1e5 random inputs over every material kind (17 kinds x 48 materials x 128 queries).
TEST(BsdfProbe, GpuMatchesCpuEveryKind) {
  const Workload w = make_workload(48, 128, 2024);
  ASSERT_GE(w.qs.size(), 100000u);
  check_agreement(w, 0.005, 0.005);
}

// The same at 1e6 inputs with other seeds (slow suite).
TEST(BsdfProbeSlow, GpuMatchesCpuEveryKindMillion) {
  const Workload w = make_workload(240, 256, 77);
  check_agreement(w, 0.005, 0.005);
}

}  // namespace
}  // namespace basalt::test
