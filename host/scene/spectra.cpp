// Named spectra, blackbody, CIE matching functions and the spectrum-to-RGB conversions
// (docs/materials.md "Spectra").
#include "scene/spectra.h"

#include <algorithm>
#include <cmath>
#include <iterator>

namespace basalt {
namespace {

#include "scene/spectra_data.inc"

constexpr double kLambdaMin = 360.0, kLambdaMax = 830.0;  // pbrt-v4 Lambda_min, Lambda_max

// One named spectrum of pbrt-v4 (Spectra::Init names) and its table.
struct Named {
  const char* name;
  const double* pairs;
  std::size_t count;
};

#define BASALT_NAMED(n, t) {n, t, std::size(t)}
const Named kNamed[] = {
    BASALT_NAMED("metal-Ag-eta", kAg_eta),       BASALT_NAMED("metal-Ag-k", kAg_k),
    BASALT_NAMED("metal-Al-eta", kAl_eta),       BASALT_NAMED("metal-Al-k", kAl_k),
    BASALT_NAMED("metal-Au-eta", kAu_eta),       BASALT_NAMED("metal-Au-k", kAu_k),
    BASALT_NAMED("metal-Cu-eta", kCu_eta),       BASALT_NAMED("metal-Cu-k", kCu_k),
    BASALT_NAMED("metal-CuZn-eta", kCuZn_eta),   BASALT_NAMED("metal-CuZn-k", kCuZn_k),
    BASALT_NAMED("metal-MgO-eta", kMgO_eta),     BASALT_NAMED("metal-MgO-k", kMgO_k),
    BASALT_NAMED("metal-TiO2-eta", kTiO2_eta),   BASALT_NAMED("metal-TiO2-k", kTiO2_k),
    BASALT_NAMED("glass-BK7", kGlassBK7_eta),    BASALT_NAMED("glass-BAF10", kGlassBAF10_eta),
    BASALT_NAMED("glass-FK51A", kGlassFK51A_eta), BASALT_NAMED("glass-LASF9", kGlassLASF9_eta),
    BASALT_NAMED("glass-F5", kGlassSF5_eta),     BASALT_NAMED("glass-F10", kGlassSF10_eta),
    BASALT_NAMED("glass-F11", kGlassSF11_eta),
};
#undef BASALT_NAMED

// Wyman, Sloan & Shirley 2013, eq. 2: a gaussian with different widths left and right of mu.
double piecewise_gaussian(double x, double mu, double sigma_left, double sigma_right) {
  double t = (x - mu) / (x < mu ? sigma_left : sigma_right);
  return std::exp(-0.5 * t * t);
}

}  // namespace

double Spectrum::eval(double nm) const {
  if (temperature > 0.0) {
    // pbrt-v4 BlackbodySpectrum: normalised by the value at Wien's peak, 2.8977721e-3 m / T.
    double peak_nm = 2.8977721e-3 / temperature * 1e9;
    return planck(nm, temperature) / planck(peak_nm, temperature);
  }
  if (lambda.empty()) return 0.0;
  if (nm <= lambda.front()) return value.front();
  if (nm >= lambda.back()) return value.back();
  std::size_t i = std::size_t(std::upper_bound(lambda.begin(), lambda.end(), nm) - lambda.begin());
  double t = (nm - lambda[i - 1]) / (lambda[i] - lambda[i - 1]);
  return (1.0 - t) * value[i - 1] + t * value[i];
}

Spectrum Spectrum::from_pairs(const double* pairs, std::size_t count) {
  Spectrum s;
  for (std::size_t i = 0; i + 1 < count; i += 2) {
    s.lambda.push_back(pairs[i]);
    s.value.push_back(pairs[i + 1]);
  }
  return s;
}

Spectrum Spectrum::blackbody(double kelvin) {
  Spectrum s;
  s.temperature = kelvin;
  return s;
}

const std::vector<std::string>& named_spectrum_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const Named& s : kNamed) n.emplace_back(s.name);
    return n;
  }();
  return names;
}

std::optional<Spectrum> named_spectrum(const std::string& name) {
  for (const Named& s : kNamed)
    if (name == s.name) return Spectrum::from_pairs(s.pairs, s.count);
  return std::nullopt;
}

double planck(double nm, double kelvin) {
  // pbrt-v4 Blackbody (book 4.4.1): Le = 2 h c^2 / (l^5 (exp(h c / (l kb T)) - 1)).
  if (kelvin <= 0.0) return 0.0;
  const double c = 299792458.0, h = 6.62606957e-34, kb = 1.3806488e-23;
  double l = nm * 1e-9;
  return (2.0 * h * c * c) / (std::pow(l, 5.0) * (std::exp((h * c) / (l * kb * kelvin)) - 1.0));
}

glm::dvec3 cie_xyz_fit(double nm) {
  // Wyman, Sloan & Shirley, "Simple Analytic Approximations to the CIE XYZ Color Matching
  // Functions", JCGT 2(2) 2013, eq. 2 (multi-lobe fit).
  double x = 1.056 * piecewise_gaussian(nm, 599.8, 37.9, 31.0) +
             0.362 * piecewise_gaussian(nm, 442.0, 16.0, 26.7) -
             0.065 * piecewise_gaussian(nm, 501.1, 20.4, 26.2);
  double y = 0.821 * piecewise_gaussian(nm, 568.8, 46.9, 40.5) +
             0.286 * piecewise_gaussian(nm, 530.9, 16.3, 31.1);
  double z = 1.217 * piecewise_gaussian(nm, 437.0, 11.8, 36.0) +
             0.681 * piecewise_gaussian(nm, 459.0, 26.0, 13.8);
  return {x, y, z};
}

glm::dvec3 xyz_to_linear_srgb(const glm::dvec3& c) {
  // sRGB (IEC 61966-2-1) primaries, D65 white; matrix from Lindbloom's RGB/XYZ tables.
  return {3.2404542 * c.x - 1.5371385 * c.y - 0.4985314 * c.z,
          -0.9692660 * c.x + 1.8760108 * c.y + 0.0415560 * c.z,
          0.0556434 * c.x - 0.2040259 * c.y + 1.0572252 * c.z};
}

glm::dvec3 spectrum_to_rgb_reflectance(const Spectrum& s) {
  glm::dvec3 num(0.0), den(0.0);
  for (double nm = kLambdaMin; nm <= kLambdaMax; nm += 1.0) {
    glm::dvec3 w = glm::max(xyz_to_linear_srgb(cie_xyz_fit(nm)), glm::dvec3(0.0));
    num += w * s.eval(nm);
    den += w;
  }
  return num / den;
}

glm::dvec3 spectrum_to_rgb_illuminant(const Spectrum& s) {
  glm::dvec3 xyz(0.0);
  for (double nm = kLambdaMin; nm <= kLambdaMax; nm += 1.0) xyz += cie_xyz_fit(nm) * s.eval(nm);
  if (!(xyz.y > 0.0)) return glm::dvec3(0.0);
  return xyz_to_linear_srgb(xyz / xyz.y);
}

}  // namespace basalt
