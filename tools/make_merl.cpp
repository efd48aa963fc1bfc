// basalt_make_merl: writes a MERL regular half-angle BRDF table (pbrt-v2 "measured" material
// input) tabulating an analytic BRDF, Lambertian plus a Trowbridge-Reitz lobe with Schlick
// Fresnel (host/scene/merl.h AnalyticBrdf), at the bin centres of pbrt-v2's parameterisation.
// Usage and the command that made scenes/data/ are in docs/materials.md ("measured").
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>

#include "scene/merl.h"

int main(int argc, char** argv) {
  CLI::App app{"basalt_make_merl: tabulate an analytic BRDF as a MERL .binary file"};
  std::string out;
  std::vector<unsigned> dims{90, 90, 180};
  std::vector<double> kd{0.05, 0.1, 0.3}, f0{0.95, 0.64, 0.54};
  double alpha = 0.2;
  app.add_option("output", out, "file to write (.binary)")->required();
  app.add_option("--dims", dims, "n theta_h, n theta_d, n phi_d (MERL: 90 90 180)")
      ->expected(3)
      ->check(CLI::Range(1u, 4096u));
  app.add_option("--kd", kd, "diffuse albedo rgb")->expected(3);
  app.add_option("--f0", f0, "specular normal-incidence reflectance rgb")->expected(3);
  app.add_option("--alpha", alpha, "Trowbridge-Reitz alpha")->check(CLI::Range(1e-3, 4.0));
  CLI11_PARSE(app, argc, argv);
  try {
    basalt::AnalyticBrdf brdf;
    brdf.kd = glm::dvec3(kd[0], kd[1], kd[2]);
    brdf.f0 = glm::dvec3(f0[0], f0[1], f0[2]);
    brdf.alpha = alpha;
    basalt::write_merl(out, glm::uvec3(dims[0], dims[1], dims[2]),
                       [&](const glm::dvec3& wi, const glm::dvec3& wo) { return brdf.eval(wi, wo); });
    std::fprintf(stderr, "basalt_make_merl: wrote %s (%u x %u x %u)\n", out.c_str(), dims[0],
                 dims[1], dims[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "basalt_make_merl: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
