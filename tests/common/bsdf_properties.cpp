// Issue 3 acceptance: BSDF properties checked through the PROBE_BSDF probe, identical on both
// sides. The TEST_P bodies live here (compiled into both test executables); each side
// instantiates them (tests/cpu/bsdf_properties_test.cpp, tests/gpu/bsdf_properties_gpu_test.cpp).
// Each test batches its queries into one or two probe calls (one GPU dispatch each).
//
// - BsdfChi2: chi-square of bsdf_sample against the integrated bsdf_pdf (pbrt-v3/v4 style,
//   Sidak-corrected over all of this suite's tests). Layered materials are excluded: their
//   bsdf_pdf is pbrt-v4's stochastic *approximation* of the sampling density (a fixed-depth
//   estimate mixed with a uniform term), not its expectation, so no number of pdf samples
//   makes the test sound; they are covered by SampleAgreesWithEvalInExpectation instead.
// - SampleConsistentWithEvalAndPdf, AlbedoAtMostOne, LosslessAlbedoIsOne, Reciprocity,
//   LayeredReciprocityInExpectation, analytic values, TIR, light-leak rule, mix resolution.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <random>
#include <sstream>

#include "common/bsdf_check.h"
#include "common/bsdf_properties.h"

namespace basalt::test {
namespace {

using namespace bsdf;

constexpr glm::uvec3 kDims(16, 8, 16);

/// A named material of the property catalog and what it is.
struct Entry {
  std::string name;
  gpu::Material m;
  bool nonspecular;    // no specular lobe: chi-square applies
  bool brdf;           // reflection only: reciprocity applies
  bool deterministic;  // no layered lobe
  bool two_sided_t;    // transmits: test wo on both sides
};

/// Catalog: every kind, TR and Beckmann, isotropic and anisotropic, every remap mode.
/// Children of the weighted mix are appended after the entries (indices from 0 in order).
struct Catalog {
  std::vector<Entry> entries;
  std::vector<gpu::Material> materials;  // entries first, then children
  std::vector<float> measured;
};

const Catalog& catalog() {
  static const Catalog c = [] {
    Catalog c;
    const glm::vec3 cu_eta(0.2f, 0.92f, 1.1f), cu_k(3.9f, 2.45f, 2.14f);
    const glm::vec3 au_eta(0.14f, 0.37f, 1.44f), au_k(3.98f, 2.39f, 1.6f);
    const std::uint32_t NONE = gpu::MATFLAG_REMAP_NONE, SQRT = gpu::MATFLAG_REMAP_SQRT,
                        V3 = gpu::MATFLAG_REMAP_V3, BECK = gpu::MATFLAG_BECKMANN;
    auto add = [&](std::string name, gpu::Material m, bool ns, bool brdf, bool det, bool t) {
      c.entries.push_back({std::move(name), m, ns, brdf, det, t});
    };
    add("diffuse", diffuse({0.2f, 0.5f, 0.8f}), true, true, true, false);
    add("oren_nayar_30", oren_nayar({0.8f, 0.5f, 0.3f}, 30.0f), true, true, true, false);
    add("oren_nayar_90", oren_nayar({0.9f, 0.9f, 0.9f}, 90.0f), true, true, true, false);
    add("conductor_tr_iso", conductor(cu_eta, cu_k, 0.3f, 0.3f, NONE), true, true, true, false);
    add("conductor_tr_aniso_sqrt", conductor(cu_eta, cu_k, 0.04f, 0.25f, SQRT), true, true,
        true, false);
    add("conductor_beckmann_aniso", conductor(au_eta, au_k, 0.2f, 0.1f, NONE | BECK), true,
        true, true, false);
    add("conductor_reflectance_v3", conductor_reflectance({0.9f, 0.6f, 0.3f}, 0.1f, 0.1f, V3),
        true, true, true, false);
    add("metal_tr_v3", conductor(au_eta, au_k, 0.05f, 0.05f, V3, true), true, true, true, false);
    add("metal_beckmann_aniso", conductor(cu_eta, cu_k, 0.15f, 0.35f, NONE | BECK, true), true,
        true, true, false);
    add("dielectric_rough_tr", dielectric(1.5f, 0.3f, 0.3f, NONE), true, false, true, true);
    add("dielectric_rough_beckmann_aniso", dielectric(1.33f, 0.2f, 0.4f, NONE | BECK), true,
        false, true, true);
    add("glass_rough_v3_KrKt", dielectric(2.5f, 0.2f, 0.2f, V3, {0.7f, 0.8f, 0.9f},
                                          {0.5f, 0.6f, 0.4f}),
        true, false, true, true);
    add("diffuse_transmission",
        diffuse_transmission({0.3f, 0.5f, 0.2f}, {0.6f, 0.3f, 0.5f}, 1.0f), true, false, true,
        true);
    add("plastic_v3", plastic({0.5f, 0.3f, 0.2f}, {0.4f, 0.4f, 0.4f}, 0.1f, V3), true, true,
        true, false);
    add("plastic_beckmann", plastic({0.2f, 0.5f, 0.3f}, {0.5f, 0.5f, 0.5f}, 0.2f, BECK), true,
        true, true, false);
    add("substrate_tr_aniso", substrate({0.5f, 0.4f, 0.3f}, {0.05f, 0.05f, 0.05f}, 0.1f, 0.3f),
        true, true, true, false);
    add("substrate_beckmann_sqrt", substrate({0.3f, 0.6f, 0.2f}, {0.2f, 0.1f, 0.1f}, 0.09f,
                                             0.09f, SQRT | BECK),
        true, true, true, false);
    add("translucent",
        translucent({0.4f, 0.3f, 0.2f}, {0.3f, 0.3f, 0.3f}, {0.5f, 0.5f, 0.5f},
                    {0.4f, 0.4f, 0.4f}, 0.2f, NONE),
        true, false, true, true);
    add("uber_glossy", uber({0.4f, 0.3f, 0.2f}, {0.3f, 0.3f, 0.3f}, glm::vec3(0), glm::vec3(0),
                            0.2f, 0.1f, 1.5f, glm::vec3(1.0f), NONE),
        true, true, true, false);
    add("measured", measured(0, kDims), true, true, true, false);
    add("coated_diffuse", coated_diffuse({0.7f, 0.5f, 0.3f}, 0.2f, 0.2f, 0.01f, 1.5f,
                                         glm::vec3(0.0f), 0.0f, 10, 1, NONE),
        true, true, false, false);
    add("coated_diffuse_medium", coated_diffuse({0.4f, 0.6f, 0.8f}, 0.0f, 0.0f, 0.1f, 1.33f,
                                                {0.5f, 0.7f, 0.9f}, 0.3f, 6, 2, NONE),
        true, true, false, false);
    add("coated_conductor",
        coated_conductor(0.1f, 0.1f, 0.01f, 1.5f, 0.0f, glm::vec3(0.0f), 0.3f, 0.3f, au_eta,
                         au_k, 10, 1, NONE),
        true, true, false, false);
    // Specular ones (energy, consistency of flags).
    add("mirror", mirror({0.9f, 0.8f, 0.7f}), false, true, true, false);
    add("conductor_smooth", conductor(cu_eta, cu_k, 0.0f, 0.0f), false, true, true, false);
    add("dielectric_smooth", dielectric(1.5f, 0.0f, 0.0f), false, false, true, true);
    add("thin_dielectric", thin_dielectric(1.5f), false, false, true, true);
    add("uber_specular", uber({0.4f, 0.3f, 0.2f}, {0.3f, 0.3f, 0.3f}, {0.2f, 0.2f, 0.2f},
                              {0.3f, 0.3f, 0.3f}, 0.2f, 0.2f, 1.5f, {0.8f, 0.7f, 0.6f}),
        false, false, true, true);
    const std::size_t n = c.entries.size() + 1;  // + the weighted mix below
    for (const Entry& e : c.entries) c.materials.push_back(e.m);
    // Weighted mix of a diffuse and a rough metal (children after the entries).
    c.materials.push_back(mix_weighted(std::uint32_t(n), std::uint32_t(n + 1),
                                       {0.3f, 0.5f, 0.7f}));
    c.entries.push_back({"mix_weighted", c.materials.back(), true, true, true, false});
    c.materials.push_back(diffuse({0.6f, 0.6f, 0.6f}));
    c.materials.push_back(conductor(cu_eta, cu_k, 0.25f, 0.25f, NONE, true));
    c.measured = measured_table(kDims);
    return c;
  }();
  return c;
}

const SceneTables& catalog_tables() {
  static const SceneTables t = make_tables(catalog().materials, catalog().measured);
  return t;
}

/// The wo set of a material: normal, oblique, grazing; the lower side too if it transmits.
std::vector<glm::vec3> wo_set(const Entry& e) {
  std::vector<glm::vec3> w = {dir(0.95, 0.3), dir(0.5, 1.3), dir(0.06, 4.0)};
  if (e.two_sided_t) w.push_back(dir(-0.6, 2.2)), w.push_back(dir(-0.1, 5.0));
  return w;
}

std::string context(const Entry& e) { return e.name + " " + describe(e.m); }

// ---- 2. chi-square ----------------------------------------------------------------------------

/// Chi-square entries (non-specular, deterministic pdf).
std::vector<std::uint32_t> chi2_entries() {
  std::vector<std::uint32_t> r;
  const auto& e = catalog().entries;
  for (std::size_t i = 0; i < e.size(); ++i)
    if (e[i].nonspecular && e[i].deterministic) r.push_back(std::uint32_t(i));
  return r;
}

int chi2_test_count() {
  int n = 0;
  for (std::uint32_t i : chi2_entries()) n += int(wo_set(catalog().entries[i]).size());
  return n;
}

}  // namespace

TEST_P(BsdfChi2, SampleMatchesPdf) {
  const auto [side, which] = GetParam();
  const auto entries = chi2_entries();
  if (which >= int(entries.size())) GTEST_SKIP() << "no such entry";
  const std::uint32_t mat = entries[which];
  const Entry& e = catalog().entries[mat];
  std::vector<Chi2Test> tests;
  std::vector<Query> qs;
  for (glm::vec3 wo : wo_set(e)) {
    Chi2Test t;
    t.material = mat;
    t.wo = wo;
    t.samples = 200000;
    t.seed = std::uint32_t(tests.size() + 1);
    t.add_queries(qs);
    tests.push_back(t);
  }
  const std::vector<Result> rs = run(side, catalog_tables(), qs);
  const double alpha = sidak(0.01, chi2_test_count());
  for (const Chi2Test& t : tests) {
    std::string msg;
    const double p = t.p_value(rs, &msg);
    EXPECT_GT(p, alpha) << context(e) << "\n  " << msg;
    if (p > alpha) std::printf("  %s\n", msg.c_str());
  }
}

namespace {

// ---- 3. eval / pdf / sample consistency --------------------------------------------------

TEST_P(BsdfProperties, SampleConsistentWithEvalAndPdf) {
  const auto& cat = catalog();
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  std::vector<Query> qs;
  for (std::size_t m = 0; m < cat.entries.size(); ++m) {
    if (!cat.entries[m].deterministic) continue;
    for (int i = 0; i < 2000; ++i) {
      Query q;
      q.material = std::uint32_t(m);
      q.wo = i % 4 == 0 ? dir(hard_cos(rng), 2 * kPi * U(rng)) : uniform_dir(rng);
      if (!cat.entries[m].two_sided_t && q.wo.z < 0) q.wo.z = -q.wo.z;
      q.u = glm::vec3(U(rng), U(rng), U(rng));
      q.px = std::uint32_t(i);
      qs.push_back(q);
    }
  }
  const std::vector<Result> rs = run(GetParam(), catalog_tables(), qs);
  // Second pass: eval and pdf at the sampled directions.
  std::vector<Query> q2;
  std::vector<std::size_t> src;
  for (std::size_t i = 0; i < qs.size(); ++i) {
    std::string why;
    ASSERT_TRUE(sane(rs[i], &why)) << why << "\n  " << context(cat.entries[qs[i].material])
                                   << "\n  " << describe(qs[i]) << "\n  " << describe(rs[i]);
    if (!rs[i].sampled()) continue;
    // Reflection/transmission flag agrees with the side of wi (ng = +z here).
    const bool refl = double(qs[i].wo.z) * rs[i].swi.z > 0;
    EXPECT_EQ(refl, (rs[i].sflags & gpu::BSDF_REFLECTION) != 0)
        << context(cat.entries[qs[i].material]) << "\n  " << describe(qs[i]) << "\n  "
        << describe(rs[i]);
    EXPECT_EQ(!refl, (rs[i].sflags & gpu::BSDF_TRANSMISSION) != 0)
        << context(cat.entries[qs[i].material]) << "\n  " << describe(qs[i]);
    EXPECT_EQ(rs[i].sflags & ~rs[i].bflags, 0u) << "sample flags outside the BSDF's flags\n  "
                                                << context(cat.entries[qs[i].material]);
    if (rs[i].specular() || rs[i].proportional) continue;
    Query q = qs[i];
    q.wi = rs[i].swi;
    q2.push_back(q);
    src.push_back(i);
  }
  const std::vector<Result> r2 = run(GetParam(), catalog_tables(), q2);
  std::vector<std::size_t> off;
  std::vector<Query> oq;
  std::vector<Result> orr;
  for (std::size_t j = 0; j < q2.size(); ++j) {
    const Result& s = rs[src[j]];
    const Result& e = r2[j];
    if (!(close(s.sf, e.f, 2e-4f, 1e-6f) && close(s.spdf, e.pdf, 2e-4f, 1e-6f) &&
          s.pdf_at_sample == e.pdf))
      off.push_back(j), oq.push_back(q2[j]), orr.push_back(e);
  }
  // Disagreements are excused only where eval/pdf at the sampled wi are ill-conditioned in
  // float (the sample computes them from its half vector, eval from normalize(wo + wi)).
  const std::vector<unsigned> ill = unstable_fields(GetParam(), catalog_tables(), oq, orr, 2e-4f);
  // ... or where the sample's own f and pdf are: a sampled microfacet normal nearly
  // perpendicular to a grazing wo (wo.z ~ 1e-7) refracts to a wi from which the normal cannot
  // be recovered in float, and a few ulps of wo or u move the sample's f by orders of
  // magnitude (seen with clang's libm calls in the sanitizer build, not with g++'s).
  std::vector<Query> sq;
  std::vector<Result> sr;
  for (std::size_t j : off) sq.push_back(qs[src[j]]), sr.push_back(rs[src[j]]);
  const std::vector<unsigned> ill_sample =
      unstable_fields(GetParam(), catalog_tables(), sq, sr, 2e-4f);
  int bad = 0, excused = 0;
  for (std::size_t k = 0; k < off.size(); ++k) {
    const std::size_t j = off[k];
    const Result& s = rs[src[j]];
    const Result& e = r2[j];
    const bool f_ok = close(s.sf, e.f, 2e-4f, 1e-6f) || (ill[k] & kEval) ||
                      (ill_sample[k] & kSampleF);
    const bool p_ok = close(s.spdf, e.pdf, 2e-4f, 1e-6f) || (ill[k] & kPdf) ||
                      (ill_sample[k] & kSamplePdf);
    if (f_ok && p_ok && s.pdf_at_sample == e.pdf) {
      ++excused;
      continue;
    }
    if (++bad <= 10)
      ADD_FAILURE() << "sample f/pdf differ from eval/pdf at the sampled wi (ill-conditioned "
                    << "fields " << ill[k] << ")\n  " << context(cat.entries[q2[j].material])
                    << "\n  " << describe(qs[src[j]]) << "\n  sample " << describe(s)
                    << "\n  eval at wi " << describe(e);
  }
  EXPECT_EQ(bad, 0);
  std::printf("  %zu non-specular samples checked, %d excused as ill-conditioned\n", q2.size(),
              excused);
  EXPECT_LE(excused, int(q2.size() / 100));
}

// ---- 4. energy ---------------------------------------------------------------------------------

// Flux albedo (transmission weights x eta^2: radiance-mode BTDFs carry 1/eta^2) of every
// catalog material at several wo is <= 1 + 3 standard errors.
TEST_P(BsdfProperties, AlbedoAtMostOne) {
  const auto& cat = catalog();
  const int kN = GetParam() == Side::Gpu ? 5000 : 20000;  // lavapipe: keep the fast run short
  struct Job { std::uint32_t m; glm::vec3 wo; std::size_t at; };
  std::vector<Job> jobs;
  std::vector<Query> qs;
  for (std::size_t m = 0; m < cat.entries.size(); ++m)
    for (glm::vec3 wo : wo_set(cat.entries[m])) {
      jobs.push_back({std::uint32_t(m), wo, qs.size()});
      auto a = albedo_queries(std::uint32_t(m), wo, kN, std::uint32_t(jobs.size()));
      qs.insert(qs.end(), a.begin(), a.end());
    }
  const std::vector<Result> rs = run(GetParam(), catalog_tables(), qs);
  for (const Job& j : jobs) {
    const Estimate e = albedo_estimate(rs, j.at, kN, true);
    for (int c = 0; c < 3; ++c)
      EXPECT_LE(e.mean[c], 1.0 + 3.0 * e.se[c] + 1e-6)
          << context(cat.entries[j.m]) << "\n  wo (" << j.wo.x << ", " << j.wo.y << ", "
          << j.wo.z << ") channel " << c << " albedo " << e.mean[c] << " se " << e.se[c];
  }
}

// Lossless BSDFs: every sample carries flux weight 1 (so the albedo is exactly 1):
// perfect mirror (Kr = 1), smooth dielectric (Kr = Kt = 1; R + T = 1, eta 1.0001, 1.5, 4,
// from both sides, TIR included), eta 1 (pass-through), thin dielectric, uber with opacity 0
// (pass-through), white Lambertian, diffuse transmission with R + T = 1 (grey).
TEST_P(BsdfProperties, LosslessAlbedoIsOne) {
  std::vector<gpu::Material> mats = {
      mirror(glm::vec3(1.0f)),           dielectric(1.5f, 0, 0),
      dielectric(1.0001f, 0, 0),         dielectric(4.0f, 0, 0),
      dielectric(1.0f, 0, 0),            dielectric(1.0f, 0.3f, 0.3f),
      thin_dielectric(1.5f),             thin_dielectric(4.0f),
      uber(glm::vec3(0.5f), glm::vec3(0.5f), glm::vec3(0.5f), glm::vec3(0.5f), 0.1f, 0.1f,
           1.5f, glm::vec3(0.0f)),
      diffuse(glm::vec3(1.0f)),          diffuse_transmission(glm::vec3(0.3f), glm::vec3(0.7f)),
      dielectric(1.5f, 0.0005f, 0.0005f, gpu::MATFLAG_REMAP_NONE),  // effectively smooth
  };
  const SceneTables t = make_tables(mats);
  std::vector<Query> qs;
  const std::vector<glm::vec3> wos = {dir(1.0, 0), dir(0.8, 0.4), dir(0.3, 2.0), dir(0.01, 3.0),
                                      dir(-1.0, 0), dir(-0.9, 1.0), dir(-0.5, 4.0),
                                      dir(-0.2, 5.0), dir(-0.01, 1.0)};
  for (std::uint32_t m = 0; m < mats.size(); ++m)
    for (glm::vec3 wo : wos) {
      auto a = albedo_queries(m, wo, 2000, m + 1);
      qs.insert(qs.end(), a.begin(), a.end());
    }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  int bad = 0;
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const Result& r = rs[i];
    const gpu::Material& m = mats[qs[i].material];
    const bool one_sided = m.type == gpu::MATERIAL_MIRROR || m.type == gpu::MATERIAL_DIFFUSE;
    (void)one_sided;
    glm::dvec3 w(0.0);
    if (r.sampled() && r.spdf > 0) {
      w = glm::dvec3(r.sf) * std::fabs(double(r.swi.z)) / double(r.spdf);
      if (r.transmission()) w *= double(r.seta) * r.seta;
    }
    bool ok = true;
    for (int c = 0; c < 3; ++c) ok &= std::fabs(w[c] - 1.0) <= 2e-4;
    if (!ok && ++bad <= 10)
      ADD_FAILURE() << "flux weight f |cos| / pdf (x eta^2 for transmission) != 1: (" << w.x
                    << ", " << w.y << ", " << w.z << ")\n  " << describe(m) << "\n  "
                    << describe(qs[i]) << "\n  " << describe(r);
  }
  EXPECT_EQ(bad, 0) << "of " << qs.size();
}

// ---- 5. reciprocity ------------------------------------------------------------------------

// f(wo, wi) == f(wi, wo) for every deterministic BRDF of the catalog (both on the upper side,
// and both on the lower side: two-sided BRDFs).
TEST_P(BsdfProperties, Reciprocity) {
  const auto& cat = catalog();
  std::mt19937 rng(11);
  std::vector<Query> qs;
  for (std::size_t m = 0; m < cat.entries.size(); ++m) {
    if (!cat.entries[m].brdf || !cat.entries[m].deterministic) continue;
    for (int i = 0; i < 1000; ++i) {
      Query a;
      a.material = std::uint32_t(m);
      a.wo = uniform_dir(rng);
      a.wi = uniform_dir(rng);
      a.wo.z = std::fabs(a.wo.z);
      a.wi.z = std::fabs(a.wi.z);
      if (i % 5 == 0) a.wi = glm::vec3(-a.wo.x, -a.wo.y, a.wo.z) * 0.999f + a.wi * 0.001f,
                      a.wi = glm::normalize(a.wi);
      if (i % 2) a.wo.z = -a.wo.z, a.wi.z = -a.wi.z;
      Query b = a;
      std::swap(b.wo, b.wi);
      qs.push_back(a);
      qs.push_back(b);
    }
  }
  // Two-sided BRDFs evaluate on the lower side with ng = +z via the light-leak rule only when
  // geometry agrees: use ng = wo's side so that both sides are plain reflection.
  for (Query& q : qs) q.ng = glm::vec3(0, 0, q.wo.z < 0 ? -1.0f : 1.0f);
  const std::vector<Result> rs = run(GetParam(), catalog_tables(), qs);
  std::vector<std::size_t> off;
  std::vector<Query> oq;
  std::vector<Result> orr;
  for (std::size_t i = 0; i < qs.size(); i += 2) {
    if (close(rs[i].f, rs[i + 1].f, 2e-4f, 1e-6f)) continue;
    const Entry& e = cat.entries[qs[i].material];
    if (e.m.type == gpu::MATERIAL_MEASURED &&
        (measured_candidate_bins(qs[i].wo, qs[i].wi, kDims).size() > 1))
      continue;  // a lookup at a bin boundary
    off.push_back(i);
    for (int k = 0; k < 2; ++k) oq.push_back(qs[i + k]), orr.push_back(rs[i + k]);
  }
  // Excused where f itself is ill-conditioned in float at either argument order (e.g. a half
  // vector from wo + wi ~ 0 at grazing retro-reflection).
  const std::vector<unsigned> ill = unstable_fields(GetParam(), catalog_tables(), oq, orr, 2e-4f);
  int bad = 0, excused = 0;
  for (std::size_t k = 0; k < off.size(); ++k) {
    const std::size_t i = off[k];
    if ((ill[2 * k] | ill[2 * k + 1]) & kEval) {
      ++excused;
      continue;
    }
    if (++bad <= 10)
      ADD_FAILURE() << "f(wo, wi) != f(wi, wo)\n  " << context(cat.entries[qs[i].material])
                    << "\n  " << describe(qs[i]) << "\n  f(wo, wi) " << describe(rs[i])
                    << "\n  f(wi, wo) " << describe(rs[i + 1]);
  }
  EXPECT_EQ(bad, 0);
  std::printf("  %zu pairs, %d excused as ill-conditioned\n", qs.size() / 2, excused);
  EXPECT_LE(excused, int(qs.size() / 200));
}

/// Layered materials with maxdepth 50, where the depth truncation (which pbrt-v4's f and
/// Sample_f walks apply differently) is negligible: rough interface over diffuse, smooth
/// interface over a scattering medium, rough interface over a rough conductor.
std::vector<gpu::Material> deep_layered() {
  return {coated_diffuse({0.7f, 0.5f, 0.3f}, 0.2f, 0.2f, 0.01f, 1.5f, glm::vec3(0.0f), 0.0f,
                         50, 1),
          coated_diffuse({0.4f, 0.6f, 0.8f}, 0.0f, 0.0f, 0.1f, 1.33f, {0.5f, 0.7f, 0.9f}, 0.3f,
                         50, 1),
          coated_conductor(0.1f, 0.1f, 0.01f, 1.5f, 0.0f, glm::vec3(0.0f), 0.3f, 0.3f,
                           {0.14f, 0.37f, 1.44f}, {3.98f, 2.39f, 1.6f}, 50, 1)};
}

// Layered BRDFs are stochastic: compare the means over many streams of f(wo, wi) and
// f(wi, wo); they must agree within 4 combined standard errors plus 1%. (Issue 3: pbrt-v4's
// f weights its exit strategies with PDF(-w, wi) instead of PDF(wi, -w) and was 5% off here;
// docs/materials-spec.md 2.3. Ground truth: tests/cpu/layered_reference_test.cpp.)
TEST_P(BsdfProperties, LayeredReciprocityInExpectation) {
  constexpr int kStreams = 4000;
  const std::vector<std::pair<glm::vec3, glm::vec3>> pairs = {
      {dir(0.9, 0.2), dir(0.4, 2.5)}, {dir(0.3, 1.0), dir(0.7, 1.3)},
      {dir(0.6, 0.0), dir(0.55, 3.3)}};
  const std::vector<gpu::Material> layered = deep_layered();
  const SceneTables t = make_tables(layered);
  std::vector<Query> qs;
  std::vector<std::uint32_t> mats = {0, 1, 2};
  for (std::uint32_t m : mats)
    for (auto [wo, wi] : pairs)
      for (int dirn = 0; dirn < 2; ++dirn)
        for (int s = 0; s < kStreams; ++s) {
          Query q;
          q.material = m;
          q.wo = dirn ? wi : wo;
          q.wi = dirn ? wo : wi;
          q.px = std::uint32_t(s);
          q.py = 1000u + std::uint32_t(dirn);
          qs.push_back(q);
        }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  std::size_t k = 0;
  for (std::uint32_t m : mats)
    for (auto [wo, wi] : pairs) {
      glm::dvec3 mean[2], se[2];
      for (int dirn = 0; dirn < 2; ++dirn) {
        glm::dvec3 s(0), s2(0);
        for (int i = 0; i < kStreams; ++i, ++k) {
          const glm::dvec3 f(rs[k].f);
          s += f;
          s2 += f * f;
        }
        mean[dirn] = s / double(kStreams);
        se[dirn] = glm::sqrt(glm::max(s2 / double(kStreams) - mean[dirn] * mean[dirn],
                                      glm::dvec3(0)) /
                             double(kStreams - 1));
      }
      for (int c = 0; c < 3; ++c) {
        const double tol = 4.0 * std::hypot(se[0][c], se[1][c]) + 0.01 * mean[0][c];
        EXPECT_NEAR(mean[0][c], mean[1][c], tol)
            << describe(layered[m]) << "\n  wo (" << wo.x << ", " << wo.y << ", " << wo.z
            << ") wi (" << wi.x << ", " << wi.y << ", " << wi.z << ") channel " << c;
      }
    }
}

// Layered samples: the sampling estimate of the albedo (mean of f |cos| / pdf of the
// proportional samples) agrees with the eval estimate (uniform wi over the sphere, mean of
// f |cos| 4 pi) within 4 combined standard errors plus 2%. Specular samples (a smooth coat's
// Fresnel reflection, purely specular paths) are left out of the sampling estimate: they are
// deltas, which f does not hold (over the scattering medium they are the ~12% that this test
// once reported as a bias; issue 3).
TEST_P(BsdfProperties, SampleAgreesWithEvalInExpectation) {
  constexpr int kN = 40000;
  const std::vector<gpu::Material> layered = deep_layered();
  const SceneTables t = make_tables(layered);
  std::vector<Query> qs;
  std::vector<std::uint32_t> mats = {0, 1, 2};
  const glm::vec3 wo = dir(0.7, 0.4);
  std::mt19937 rng(3);
  for (std::uint32_t m : mats) {
    auto a = albedo_queries(m, wo, kN, 77);
    qs.insert(qs.end(), a.begin(), a.end());
    for (int i = 0; i < kN; ++i) {
      Query q;
      q.material = m;
      q.wo = wo;
      q.wi = uniform_dir(rng);
      q.px = std::uint32_t(i);
      q.py = 5000;
      qs.push_back(q);
    }
  }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  for (std::size_t j = 0; j < mats.size(); ++j) {
    const std::size_t base = j * 2 * kN;
    std::vector<Result> nonspecular(rs.begin() + base, rs.begin() + base + kN);
    for (Result& r : nonspecular)
      if (r.specular()) r.sflags = 0;  // no sample: weight 0
    const Estimate s = albedo_estimate(nonspecular, 0, kN, false);
    glm::dvec3 sum(0), sum2(0);
    for (int i = 0; i < kN; ++i) {
      const Result& r = rs[base + kN + i];
      const glm::dvec3 v = glm::dvec3(r.f) * std::fabs(double(qs[base + kN + i].wi.z)) * (4 * kPi);
      sum += v;
      sum2 += v * v;
    }
    const glm::dvec3 mean = sum / double(kN);
    const glm::dvec3 se = glm::sqrt(glm::max(sum2 / double(kN) - mean * mean, glm::dvec3(0)) /
                                    double(kN - 1));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(s.mean[c], mean[c], 4.0 * std::hypot(s.se[c], se[c]) + 0.02 * mean[c])
          << describe(layered[mats[j]]) << " channel " << c << ": sampling " << s.mean[c]
          << " +- " << s.se[c] << ", eval " << mean[c] << " +- " << se[c];
  }
}

// Layered samples stay finite (issue 3): over sharp rough lobes (alpha 1e-3, the roughest
// "smooth" limit) the walk's f and pdf are products of ~1e5-sized factors and overflowed to
// inf together over a few bounces; the walk rescales them by powers of two
// (docs/materials-spec.md 2.3). Every output is finite, samples are many and their weights
// f |cos| / pdf are finite.
TEST_P(BsdfProperties, LayeredSamplesFinite) {
  const std::vector<gpu::Material> mats = {
      coated_conductor(1e-3f, 1e-3f, 0.0f, 1.5f, 0.0f, glm::vec3(0.0f), 1e-3f, 1e-3f,
                       {0.2f, 0.9f, 1.1f}, {3.9f, 2.4f, 2.2f}, 100, 1),
      coated_conductor(1e-3f, 2e-3f, 1e-4f, 1.0001f, 0.9f, glm::vec3(0.99f), 1e-3f, 1e-3f,
                       {1.0f, 1.0f, 1.0f}, {9.0f, 9.0f, 9.0f}, 100, 1),
      coated_diffuse(glm::vec3(1.0f), 1e-3f, 1e-3f, 1e-4f, 4.0f, glm::vec3(0.99f), -0.9f, 100, 1)};
  const SceneTables t = make_tables(mats);
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  std::vector<Query> qs;
  for (std::uint32_t m = 0; m < mats.size(); ++m)
    for (int i = 0; i < 20000; ++i) {
      Query q;
      q.material = m;
      q.wo = i % 2 ? dir(hard_cos(rng), 2 * kPi * U(rng)) : uniform_dir(rng);
      q.wi = uniform_dir(rng);
      q.ng = glm::vec3(0, 0, q.wo.z < 0 ? -1.0f : 1.0f);
      q.u = glm::vec3(U(rng), U(rng), U(rng));
      q.px = std::uint32_t(i);
      q.py = 300u + m;
      qs.push_back(q);
    }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  int bad = 0;
  std::vector<int> samples(mats.size(), 0);
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const Result& r = rs[i];
    std::string why;
    if (!sane(r, &why) && ++bad <= 5)
      ADD_FAILURE() << why << "\n  " << describe(mats[qs[i].material]) << "\n  "
                    << describe(qs[i]) << "\n  " << describe(r);
    if (!r.sampled()) continue;
    ++samples[qs[i].material];
    const glm::dvec3 w = glm::dvec3(r.sf) * std::fabs(double(r.swi.z)) / double(r.spdf);
    if (!(std::isfinite(w.x) && std::isfinite(w.y) && std::isfinite(w.z)) && ++bad <= 5)
      ADD_FAILURE() << "sample weight " << w.x << " " << w.y << " " << w.z << "\n  "
                    << describe(mats[qs[i].material]) << "\n  " << describe(qs[i]) << "\n  "
                    << describe(r);
  }
  EXPECT_EQ(bad, 0);
  for (std::size_t m = 0; m < mats.size(); ++m) EXPECT_GT(samples[m], 5000) << m;
}

// ---- 6. analytic values -----------------------------------------------------------------------

// Lambertian: f = R/pi, pdf = cos/pi; Oren-Nayar with sigma 0 equals it.
TEST_P(BsdfProperties, LambertianAndOrenNayarSigmaZero) {
  const glm::vec3 R(0.2f, 0.5f, 0.8f);
  const SceneTables t = make_tables({diffuse(R), oren_nayar(R, 0.0f)});
  std::mt19937 rng(21);
  std::vector<Query> qs;
  for (int i = 0; i < 2000; ++i) {
    Query q;
    q.wo = uniform_dir(rng);
    q.wi = uniform_dir(rng);
    q.wi.z = std::copysign(q.wi.z, q.wo.z);
    if (q.wo.z == 0 || q.wi.z == 0) continue;
    q.ng = glm::vec3(0, 0, q.wo.z < 0 ? -1.0f : 1.0f);
    for (std::uint32_t m = 0; m < 2; ++m) {
      q.material = m;
      qs.push_back(q);
    }
  }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const glm::vec3 expect = R / float(kPi);
    ASSERT_TRUE(close(rs[i].f, expect, 1e-5f, 0.0f))
        << "material " << qs[i].material << " " << describe(qs[i]) << "\n  " << describe(rs[i]);
    ASSERT_TRUE(close(rs[i].pdf, std::fabs(qs[i].wi.z) / float(kPi), 1e-5f, 0.0f))
        << describe(qs[i]) << "\n  " << describe(rs[i]);
    if (i % 2) {
      ASSERT_EQ(rs[i].lobe0, gpu::LOBE_LAMBERT_R) << "sigma 0 is Lambertian";
    }
  }
}

/// pbrt-v3 FrDielectric in double (cos of the incident direction, etaI, etaT).
double fr_dielectric(double cos_i, double eta_i, double eta_t) {
  cos_i = std::clamp(cos_i, -1.0, 1.0);
  if (cos_i <= 0) std::swap(eta_i, eta_t), cos_i = -cos_i;
  const double sin_t = eta_i / eta_t * std::sqrt(std::max(0.0, 1 - cos_i * cos_i));
  if (sin_t >= 1) return 1;
  const double cos_t = std::sqrt(std::max(0.0, 1 - sin_t * sin_t));
  const double rpar = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
  const double rperp = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
  return (rpar * rpar + rperp * rperp) / 2;
}

/// pbrt-v3 FrConductor in double (reflection.cpp; etaI = 1).
double fr_conductor(double cos_i, double eta, double k) {
  cos_i = std::clamp(cos_i, -1.0, 1.0);
  const double c2 = cos_i * cos_i, s2 = 1 - c2, e2 = eta * eta, k2 = k * k;
  const double t0 = e2 - k2 - s2;
  const double a2b2 = std::sqrt(t0 * t0 + 4 * e2 * k2);
  const double t1 = a2b2 + c2;
  const double a = std::sqrt(std::max(0.0, 0.5 * (a2b2 + t0)));
  const double t2 = 2 * cos_i * a;
  const double rs = (t1 - t2) / (t1 + t2);
  const double t3 = c2 * a2b2 + s2 * s2;
  const double t4 = t2 * s2;
  const double rp = rs * (t3 - t4) / (t3 + t4);
  return 0.5 * (rp + rs);
}

// Smooth dielectric at normal incidence: the reflection sample (u_lobe < R) has
// f |cos| = R = ((eta-1)/(eta+1))^2 and pdf = R (pbrt-v4 DielectricBxDF: pr/(pr+pt) with
// pr + pt = 1); the transmission sample (u_lobe > R) has f |cos| eta'^2 = 1 - R and pdf 1 - R;
// eval is 0 (specular). Also at oblique angles against pbrt-v3 FrDielectric in double, from
// both sides, with Kr, Kt scaling f only.
TEST_P(BsdfProperties, DielectricFresnel) {
  const std::vector<float> etas = {1.0001f, 1.33f, 1.5f, 2.4f, 4.0f};
  std::vector<gpu::Material> mats;
  for (float e : etas) mats.push_back(dielectric(e, 0, 0));
  mats.push_back(dielectric(1.5f, 0, 0, 0, glm::vec3(0.5f, 0.6f, 0.7f), glm::vec3(0.2f, 0.3f, 0.4f)));
  const SceneTables t = make_tables(mats);
  const std::vector<double> coss = {1.0, 0.9, 0.6, 0.3, 0.1, -1.0, -0.95, -0.9, -0.8};
  std::vector<Query> qs;
  std::vector<double> R;
  for (std::uint32_t m = 0; m < mats.size(); ++m)
    for (double c : coss) {
      const double eta = mats[m].value[0].x;
      const double r = fr_dielectric(c, 1.0, eta);
      if (r >= 1.0 || r < 1e-9) {  // TIR is its own test; eta ~1 has R ~ 0: no reflection choice
        continue;
      }
      for (int refl = 0; refl < 2; ++refl) {
        Query q;
        q.material = m;
        q.wo = dir(c, 0.7);
        q.wi = glm::vec3(-q.wo.x, -q.wo.y, q.wo.z);
        q.ng = glm::vec3(0, 0, c < 0 ? -1.0f : 1.0f);
        q.u = glm::vec3(refl ? float(r * 0.5) : float(r + (1 - r) * 0.5), 0.3f, 0.6f);
        qs.push_back(q);
        R.push_back(r);
      }
    }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const Result& r = rs[i];
    const gpu::Material& m = mats[qs[i].material];
    const bool refl = i % 2 == 1;
    const double F = R[i];
    const glm::dvec3 scale(refl ? m.value[gpu::SLOT_DIELECTRIC_KR] : m.value[gpu::SLOT_DIELECTRIC_KT]);
    const std::string ctx = describe(m) + "\n  " + describe(qs[i]) + "\n  " + describe(r);
    EXPECT_EQ(r.f, glm::vec3(0.0f)) << "eval of a specular BSDF\n  " << ctx;
    ASSERT_EQ(r.sflags, gpu::BSDF_SPECULAR | (refl ? gpu::BSDF_REFLECTION : gpu::BSDF_TRANSMISSION))
        << ctx;
    const double pdf = refl ? F : 1 - F;
    EXPECT_NEAR(r.spdf, pdf, 1e-5 + 1e-4 * pdf) << ctx;
    double w = std::fabs(double(r.swi.z));
    if (!refl) w *= double(r.seta) * r.seta;
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(r.sf[c] * w, scale[c] * pdf, 1e-5 + 1e-4 * pdf) << "channel " << c << "\n  " << ctx;
    if (qs[i].wo.z == 1.0f && refl) {
      const double eta = m.value[0].x, r0 = (eta - 1) * (eta - 1) / ((eta + 1) * (eta + 1));
      EXPECT_NEAR(r.sf.x * w / scale.x, r0, 1e-6 + 1e-4 * r0) << "normal incidence\n  " << ctx;
    }
    if (!refl) {
      const double eta_rel = qs[i].wo.z > 0 ? m.value[0].x : 1.0 / m.value[0].x;
      EXPECT_NEAR(r.seta, eta_rel, 1e-5 * eta_rel) << ctx;
    }
  }
}

// Total internal reflection: a smooth dielectric seen from inside (wo.z < 0) beyond the
// critical angle reflects every sample with weight 1 (f |cos| / pdf) and never transmits.
TEST_P(BsdfProperties, TotalInternalReflection) {
  const std::vector<float> etas = {1.33f, 1.5f, 2.4f, 4.0f};
  std::vector<gpu::Material> mats;
  for (float e : etas) mats.push_back(dielectric(e, 0, 0));
  const SceneTables t = make_tables(mats);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<Query> qs;
  for (std::uint32_t m = 0; m < mats.size(); ++m) {
    const double crit = std::sqrt(1 - 1 / (double(etas[m]) * etas[m]));  // cos of critical
    for (int i = 0; i < 500; ++i) {
      Query q;
      q.material = m;
      const double c = -crit * (0.999 * U(rng) + 1e-4);  // |cos| below the critical cos
      q.wo = dir(c, 2 * kPi * U(rng));
      q.wi = glm::vec3(-q.wo.x, -q.wo.y, q.wo.z);
      q.ng = glm::vec3(0, 0, -1);
      q.u = glm::vec3(i % 10 == 0 ? kOneMinus : float(U(rng)), float(U(rng)), float(U(rng)));
      qs.push_back(q);
    }
  }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const Result& r = rs[i];
    const std::string ctx = describe(mats[qs[i].material]) + "\n  " + describe(qs[i]) + "\n  " +
                            describe(r);
    ASSERT_EQ(r.sflags, gpu::BSDF_REFLECTION | gpu::BSDF_SPECULAR) << ctx;
    ASSERT_NEAR(r.sf.x * std::fabs(r.swi.z) / r.spdf, 1.0, 1e-4) << ctx;
    ASSERT_TRUE(close(r.swi, glm::vec3(-qs[i].wo.x, -qs[i].wo.y, qs[i].wo.z), 1e-5f, 1e-6f))
        << ctx;
  }
}

// Conductor Fresnel against pbrt-v3 FrConductor in double: a smooth CONDUCTOR (and a smooth
// METAL, and the reflectance mode at normal incidence, where F = r) gives a specular
// sample with f |cos| = F(cos) per channel and pdf 1.
TEST_P(BsdfProperties, ConductorFresnel) {
  const glm::vec3 eta(0.2f, 1.5f, 3.0f), k(3.9f, 0.5f, 10.0f);
  std::vector<gpu::Material> mats = {conductor(eta, k, 0, 0), conductor(eta, k, 0, 0, 0, true),
                                     conductor({1.0f, 2.0f, 0.5f}, {0.0f, 0.0f, 0.0f}, 0, 0),
                                     conductor_reflectance({0.9f, 0.5f, 0.05f}, 0, 0)};
  const SceneTables t = make_tables(mats);
  const std::vector<double> coss = {1.0, 0.95, 0.8, 0.5, 0.2, 0.05, 1e-3};
  std::vector<Query> qs;
  for (std::uint32_t m = 0; m < mats.size(); ++m)
    for (double c : coss) {
      Query q;
      q.material = m;
      q.wo = dir(c, 1.1);
      q.u = glm::vec3(0.4f, 0.3f, 0.7f);
      qs.push_back(q);
    }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const Result& r = rs[i];
    const gpu::Material& m = mats[qs[i].material];
    const std::string ctx = describe(m) + "\n  " + describe(qs[i]) + "\n  " + describe(r);
    ASSERT_EQ(r.sflags, gpu::BSDF_REFLECTION | gpu::BSDF_SPECULAR) << ctx;
    EXPECT_NEAR(r.spdf, 1.0, 1e-6) << ctx;
    for (int c = 0; c < 3; ++c) {
      double F;
      if (m.flags & gpu::MATFLAG_USE_REFLECTANCE) {
        const double rr = m.value[gpu::SLOT_CONDUCTOR_REFLECTANCE][c];
        F = fr_conductor(qs[i].wo.z, 1.0, 2 * std::sqrt(rr) / std::sqrt(1 - rr));
        if (qs[i].wo.z == 1.0f) {
          EXPECT_NEAR(F, rr, 1e-9);
        }
      } else {
        F = fr_conductor(qs[i].wo.z, m.value[gpu::SLOT_CONDUCTOR_ETA][c],
                         m.value[gpu::SLOT_CONDUCTOR_K][c]);
      }
      EXPECT_NEAR(r.sf[c] * std::fabs(double(r.swi.z)), F, 2e-5 + 2e-4 * F)
          << "channel " << c << " cos " << qs[i].wo.z << "\n  " << ctx;
    }
  }
}

// pbrt-v4 CoatedConductorMaterial divides the conductor's eta and k by the coat's eta: a
// conductor with eta = the coat's and k = 0 is then index-matched to the coat (Fresnel 0), so
// a smooth coat over it reflects nothing off the base: f is 0 away from the coat's mirror
// direction (the coat's own reflection is a delta), and every sample is that reflection.
TEST_P(BsdfProperties, CoatedConductorEtaRelativeToCoat) {
  const SceneTables t = make_tables({coated_conductor(0.0f, 0.0f, 0.01f, 1.5f, 0.0f,
                                                      glm::vec3(0.0f), 0.3f, 0.3f,
                                                      glm::vec3(1.5f), glm::vec3(0.0f), 10, 1)});
  std::mt19937 rng(5);
  std::vector<Query> qs;
  for (int i = 0; i < 400; ++i) {
    Query q;
    q.wo = uniform_dir(rng);
    q.wi = uniform_dir(rng);
    q.wo.z = std::fabs(q.wo.z) + 0.05f;
    q.wi.z = std::fabs(q.wi.z) + 0.05f;
    q.wo = glm::normalize(q.wo);
    q.wi = glm::normalize(q.wi);
    q.u = glm::vec3(std::uniform_real_distribution<float>(0.0f, 1.0f)(rng), 0.3f, 0.6f);
    q.px = std::uint32_t(i);
    qs.push_back(q);
  }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  int sampled = 0;
  for (std::size_t i = 0; i < qs.size(); ++i) {
    // 0 up to the rounding of the complex Fresnel at relative eta 1 (~1e-30; without the
    // division f is ~1e-2).
    EXPECT_LT(std::fmax(rs[i].f.x, std::fmax(rs[i].f.y, rs[i].f.z)), 1e-6f)
        << describe(qs[i]) << "\n  " << describe(rs[i]);
    if (!rs[i].sampled()) continue;
    ++sampled;
    EXPECT_TRUE(rs[i].sflags & gpu::BSDF_SPECULAR) << describe(qs[i]) << "\n  " << describe(rs[i]);
    EXPECT_TRUE(close_direction(rs[i].swi, glm::vec3(-qs[i].wo.x, -qs[i].wo.y, qs[i].wo.z)))
        << describe(qs[i]) << "\n  " << describe(rs[i]);
  }
  EXPECT_GT(sampled, 0) << "no coat reflections sampled";
}

// ---- 7. light-leak rule (materials-spec 1.2, pbrt 2nd ed. Fig. 9.2) ------------------------

// With a tilted geometric normal: (a) an opaque BRDF gives no light from the geometric back
// side even where wi.z > 0 in the shading frame, pdf 0 there, and its samples never leave on
// the geometric back side; (b) where the geometry puts wi on wo's side but the shading frame
// does not, a diffuse surface is not black (eval = R/pi with wi.z negated, pdf 0).
TEST_P(BsdfProperties, LightLeakRule) {
  const glm::vec3 R(0.5f, 0.6f, 0.7f);
  std::vector<gpu::Material> mats = {diffuse(R), conductor({0.2f, 0.9f, 1.1f},
                                                           {3.9f, 2.4f, 2.1f}, 0.3f, 0.3f),
                                     plastic(glm::vec3(0.5f), glm::vec3(0.3f), 0.2f),
                                     oren_nayar(R, 20.0f)};
  const SceneTables t = make_tables(mats);
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<Query> qs;
  std::vector<int> kind;  // 0: leak case, 1: black-spot case, 2: sampling
  int tries = 0;
  while (qs.size() < 12000 && ++tries < 1000000) {
    // ng tilted by up to 60 degrees from the shading normal.
    const glm::vec3 ng = dir(0.5 + 0.5 * U(rng), 2 * kPi * U(rng));
    const glm::vec3 wo = uniform_dir(rng), wi = uniform_dir(rng);
    const double go = glm::dot(glm::dvec3(wo), glm::dvec3(ng)),
                 gi = glm::dot(glm::dvec3(wi), glm::dvec3(ng));
    if (!(go > 0.05 && wo.z > 0.05f)) continue;
    int k = -1;
    if (gi < -1e-3 && wi.z > 1e-3f) k = 0;        // geometric back side, shading front
    else if (gi > 1e-3 && wi.z < -1e-3f) k = 1;   // geometric front, shading back
    else continue;
    for (std::uint32_t m = 0; m < mats.size(); ++m) {
      Query q;
      q.material = m;
      q.wo = wo;
      q.wi = wi;
      q.ng = ng;
      q.u = glm::vec3(float(U(rng)), float(U(rng)), float(U(rng)));
      qs.push_back(q);
      kind.push_back(k);
    }
  }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  int leaks = 0, black = 0, bad_samples = 0;
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const Result& r = rs[i];
    const Query& q = qs[i];
    const std::string ctx = describe(mats[q.material]) + "\n  " + describe(q) + "\n  " + describe(r);
    EXPECT_EQ(r.pdf, 0.0f) << "pdf where the geometric and shading decisions disagree\n  " << ctx;
    if (kind[i] == 0 && r.f != glm::vec3(0.0f) && ++leaks <= 5)
      ADD_FAILURE() << "light leak: eval from the geometric back side\n  " << ctx;
    if (kind[i] == 1) {
      const bool is_diffuse = mats[q.material].type == gpu::MATERIAL_DIFFUSE;
      if (is_diffuse ? !close(r.f, R / float(kPi), 1e-5f, 0.0f)
                     : !(r.f.x > 0 || r.f.y > 0 || r.f.z > 0)) {
        if (mats[q.material].type == gpu::MATERIAL_CONDUCTOR) {
          // A glossy lobe may legitimately be ~0 far from its peak; only diffuse must be lit.
        } else if (++black <= 5) {
          ADD_FAILURE() << "black spot: no light where the geometry says reflection\n  " << ctx;
        }
      }
    }
    if (r.sampled()) {
      const double gi = glm::dot(glm::dvec3(r.swi), glm::dvec3(q.ng));
      const double go = glm::dot(glm::dvec3(q.wo), glm::dvec3(q.ng));
      if ((r.sflags & gpu::BSDF_REFLECTION) && !(gi * go > -1e-6) && ++bad_samples <= 5)
        ADD_FAILURE() << "reflection sample on the geometric back side\n  " << ctx;
    }
  }
  EXPECT_EQ(leaks, 0);
  EXPECT_EQ(black, 0);
  EXPECT_EQ(bad_samples, 0);
  EXPECT_GT(qs.size(), 10000u);
}

// Transmissive materials under the rule: where the geometry says transmission but the shading
// frame says reflection, a diffuse transmitter evaluates its transmission lobe (T/pi).
TEST_P(BsdfProperties, LightLeakRuleTransmission) {
  const glm::vec3 Rr(0.3f, 0.2f, 0.1f), T(0.4f, 0.5f, 0.6f);
  const SceneTables t = make_tables({diffuse_transmission(Rr, T)});
  std::mt19937 rng(32);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<Query> qs;
  std::vector<int> kind;
  while (qs.size() < 4000) {
    const glm::vec3 ng = dir(0.5 + 0.5 * U(rng), 2 * kPi * U(rng));
    const glm::vec3 wo = uniform_dir(rng), wi = uniform_dir(rng);
    const double go = glm::dot(glm::dvec3(wo), glm::dvec3(ng)),
                 gi = glm::dot(glm::dvec3(wi), glm::dvec3(ng));
    if (!(go > 0.05 && wo.z > 0.05f)) continue;
    if (gi < -1e-3 && wi.z > 1e-3f) kind.push_back(0);       // geo: transmission
    else if (gi > 1e-3 && wi.z < -1e-3f) kind.push_back(1);  // geo: reflection
    else continue;
    Query q;
    q.wo = wo;
    q.wi = wi;
    q.ng = ng;
    qs.push_back(q);
  }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const glm::vec3 expect = (kind[i] == 0 ? T : Rr) / float(kPi);
    ASSERT_TRUE(close(rs[i].f, expect, 1e-5f, 0.0f))
        << (kind[i] == 0 ? "geometric transmission" : "geometric reflection") << "\n  "
        << describe(qs[i]) << "\n  " << describe(rs[i]);
    ASSERT_EQ(rs[i].pdf, 0.0f) << describe(qs[i]);
  }
}

// wo in the tangent plane: eval 0, pdf 0, no sample, for every catalog material.
TEST_P(BsdfProperties, GrazingWoGivesNothing) {
  std::vector<Query> qs;
  std::mt19937 rng(4);
  for (std::uint32_t m = 0; m < catalog().entries.size(); ++m)
    for (int i = 0; i < 50; ++i) {
      Query q;
      q.material = m;
      q.wo = dir(0.0, 0.3 * i);
      q.wi = uniform_dir(rng);
      q.u = glm::vec3(hard_u(rng), hard_u(rng), hard_u(rng));
      qs.push_back(q);
    }
  const std::vector<Result> rs = run(GetParam(), catalog_tables(), qs);
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const std::string ctx = context(catalog().entries[qs[i].material]) + "\n  " +
                            describe(qs[i]) + "\n  " + describe(rs[i]);
    ASSERT_EQ(rs[i].f, glm::vec3(0.0f)) << ctx;
    ASSERT_EQ(rs[i].pdf, 0.0f) << ctx;
    ASSERT_EQ(rs[i].sflags, 0u) << ctx;
  }
}

// ---- measured ------------------------------------------------------------------------------

// MEASURED: every eval reads the pbrt-v2 RegularHalfangleBRDF bin of (wo, wi) computed here in
// double (the generated table's red channel names its bin; a neighbour is accepted only within
// float reach of a bin boundary), all three channels of that bin; two-sided (wo.z < 0 negates
// both); zero on opposite sides; a second table at a non-zero offset with other dims.
TEST_P(BsdfProperties, MeasuredLookup) {
  const glm::uvec3 dims2(8, 4, 12);
  std::vector<float> table = measured_table(kDims);
  const std::uint32_t off2 = std::uint32_t(table.size());
  const std::vector<float> t2 = measured_table(dims2);
  table.insert(table.end(), t2.begin(), t2.end());
  const SceneTables t = make_tables({measured(0, kDims), measured(off2, dims2)}, table);
  std::mt19937 rng(51);
  std::vector<Query> qs;
  for (int i = 0; i < 20000; ++i) {
    Query q;
    q.material = std::uint32_t(i % 2);
    q.wo = uniform_dir(rng);
    q.wi = uniform_dir(rng);
    if (i % 3 == 0) q.wi = glm::normalize(glm::vec3(-q.wo.x, -q.wo.y, q.wo.z) + 0.1f * q.wi);
    if (i % 7 == 0) q.wi.z = -q.wi.z;
    q.ng = glm::vec3(0, 0, q.wo.z < 0 ? -1.0f : 1.0f);
    qs.push_back(q);
  }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  int bad = 0, ambiguous = 0;
  for (std::size_t i = 0; i < qs.size(); ++i) {
    const Query& q = qs[i];
    const glm::uvec3 d = q.material ? dims2 : kDims;
    const std::size_t base = q.material ? off2 : 0;
    const Result& r = rs[i];
    const std::vector<long> cand = measured_candidate_bins(q.wo, q.wi, d);
    std::string why;
    if (cand.empty()) {
      if (r.f != glm::vec3(0.0f)) why = "non-zero on opposite sides";
    } else {
      ambiguous += cand.size() > 1;
      const long bin = measured_bin_of(r.f.x, d);
      if (std::find(cand.begin(), cand.end(), bin) == cand.end()) {
        why = "wrong bin " + std::to_string(bin) + ", expected " + std::to_string(cand[0]) +
              (cand.size() > 1 ? " or a neighbour" : "");
      } else {
        const glm::vec3 v(table[base + 3 * bin], table[base + 3 * bin + 1],
                          table[base + 3 * bin + 2]);
        if (r.f != v) why = "channels differ from the table at the bin";
      }
    }
    if (!why.empty() && ++bad <= 10)
      ADD_FAILURE() << why << "\n  " << describe(t.materials[q.material]) << "\n  "
                    << describe(q) << "\n  " << describe(r);
  }
  EXPECT_EQ(bad, 0);
  std::printf("  measured lookups near a bin boundary: %d of %zu\n", ambiguous, qs.size());
}

// ---- mixes ---------------------------------------------------------------------------------

// MIX: amount 0 resolves to aux0 and 1 to aux1 for every (p, wo); amount a picks aux1 for a
// fraction a of random (p, wo) (pbrt-v4 MixMaterial::ChooseMaterial, hash of p, wo, index).
// MIX_WEIGHTED: eval = (1 - a) f_0 + a f_1 per channel; pdf = mean over the lobes; lobes of a
// zero weight are not added.
TEST_P(BsdfProperties, MixResolution) {
  std::vector<gpu::Material> mats = {
      diffuse({0.5f, 0.5f, 0.5f}),                              // 0
      conductor({0.2f, 0.9f, 1.1f}, {3.9f, 2.4f, 2.1f}, 0.3f, 0.3f),  // 1
      mix(0, 1, 0.0f), mix(0, 1, 1.0f), mix(0, 1, 0.3f),        // 2, 3, 4
      mix_weighted(0, 1, {0.2f, 0.5f, 0.9f}),                   // 5
      mix_weighted(0, 1, {0.0f, 0.0f, 0.0f}),                   // 6
      mix_weighted(0, 1, {-0.5f, 2.0f, 0.5f}),                  // 7 clamped to (0, 1, 0.5)
  };
  const SceneTables t = make_tables(mats);
  std::mt19937 rng(41);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  constexpr int kN = 4000;
  std::vector<Query> qs;
  for (int i = 0; i < kN; ++i) {
    Query q;
    q.wo = uniform_dir(rng);
    q.wo.z = std::fabs(q.wo.z) + 1e-3f;
    q.wo = glm::normalize(q.wo);
    q.wi = uniform_dir(rng);
    q.wi.z = std::fabs(q.wi.z) + 1e-3f;
    q.wi = glm::normalize(q.wi);
    q.p = glm::vec3(U(rng), U(rng), U(rng)) * 20.0f - 10.0f;
    for (std::uint32_t m = 0; m < mats.size(); ++m) {
      q.material = m;
      qs.push_back(q);
    }
  }
  const std::vector<Result> rs = run(GetParam(), t, qs);
  const std::size_t M = mats.size();
  int picked1 = 0;
  for (int i = 0; i < kN; ++i) {
    const Result* r = &rs[i * M];
    const std::string ctx = describe(qs[i * M]);
    ASSERT_EQ(r[2].f, r[0].f) << "mix amount 0 is aux0\n  " << ctx;
    ASSERT_EQ(r[2].lobe0, gpu::LOBE_LAMBERT_R) << ctx;
    ASSERT_EQ(r[3].f, r[1].f) << "mix amount 1 is aux1\n  " << ctx;
    ASSERT_EQ(r[3].lobe0, gpu::LOBE_CONDUCTOR) << ctx;
    ASSERT_TRUE(r[4].lobe0 == gpu::LOBE_LAMBERT_R || r[4].lobe0 == gpu::LOBE_CONDUCTOR) << ctx;
    const bool one = r[4].lobe0 == gpu::LOBE_CONDUCTOR;
    picked1 += one;
    ASSERT_EQ(r[4].f, one ? r[1].f : r[0].f) << ctx;
    ASSERT_EQ(r[4].pdf, one ? r[1].pdf : r[0].pdf) << ctx;
    // Weighted.
    const glm::vec3 a(0.2f, 0.5f, 0.9f);
    ASSERT_EQ(r[5].lobes, 2u) << ctx;
    ASSERT_TRUE(close(r[5].f, (1.0f - a) * r[0].f + a * r[1].f, 1e-5f, 1e-7f))
        << "weighted mix eval\n  " << ctx << "\n  " << describe(r[5]);
    ASSERT_TRUE(close(r[5].pdf, 0.5f * (r[0].pdf + r[1].pdf), 1e-5f, 1e-7f))
        << "weighted mix pdf\n  " << ctx << "\n  " << describe(r[5]);
    ASSERT_EQ(r[6].lobes, 1u) << "zero-weight lobes are not added\n  " << ctx;
    ASSERT_TRUE(close(r[6].f, r[0].f, 1e-6f, 0.0f)) << ctx;
    ASSERT_TRUE(close(r[6].pdf, r[0].pdf, 1e-6f, 0.0f)) << ctx;
    const glm::vec3 c(0.0f, 1.0f, 0.5f);
    ASSERT_TRUE(close(r[7].f, (1.0f - c) * r[0].f + c * r[1].f, 1e-5f, 1e-7f))
        << "weighted mix amount clamped to [0, 1]\n  " << ctx << "\n  " << describe(r[7]);
  }
  const double frac = double(picked1) / kN, se = std::sqrt(0.3 * 0.7 / kN);
  EXPECT_NEAR(frac, 0.3, 4 * se) << "stochastic mix choice frequency";
}

}  // namespace
}  // namespace basalt::test

// Instantiation helpers used by the per-side test files.
namespace basalt::test::bsdf {
int chi2_entry_count() { return int(chi2_entries().size()); }
}  // namespace basalt::test::bsdf
