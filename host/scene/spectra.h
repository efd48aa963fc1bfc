// Spectral inputs turned into the linear-sRGB values basalt renders with, once, on the host:
// pbrt-v4's named spectra, inline (wavelength, value) spectra and blackbody emitters.
// The conversions are documented in docs/materials.md ("Spectra").
#pragma once
#include <glm/glm.hpp>
#include <optional>
#include <string>
#include <vector>

namespace basalt {

/// A spectrum over wavelength in nm: piecewise linear through (lambda, value) samples, or a
/// blackbody of temperature T (Kelvin) normalised to 1 at its peak (pbrt-v4 BlackbodySpectrum).
struct Spectrum {
  std::vector<double> lambda, value;  // piecewise linear; lambda strictly increasing
  double temperature = 0.0;           // > 0: blackbody instead of the samples

  /// \brief The value at wavelength \p nm; outside the samples the end values are held.
  double eval(double nm) const;
  /// \brief A piecewise-linear spectrum from interleaved (lambda, value) pairs.
  static Spectrum from_pairs(const double* pairs, std::size_t count);
  /// \brief pbrt-v4 BlackbodySpectrum(T): Planck's law divided by its value at Wien's peak.
  static Spectrum blackbody(double kelvin);
};

/// \brief The names of pbrt-v4's named spectra that basalt knows (metal-*-eta/k, glass-*).
const std::vector<std::string>& named_spectrum_names();
/// \brief pbrt-v4's named spectrum \p name (e.g. "metal-Cu-eta", "glass-BK7"), or nothing.
std::optional<Spectrum> named_spectrum(const std::string& name);

/// \brief Planck's law: emitted spectral radiance at \p nm for temperature \p kelvin
/// (pbrt-v4 Blackbody, SI units, W / (m^2 sr m)); 0 for kelvin <= 0.
double planck(double nm, double kelvin);

/// \brief CIE 1931 colour matching functions (x, y, z) at \p nm: the multi-lobe piecewise
/// gaussian fit of Wyman, Sloan & Shirley 2013 (JCGT 2(2), eq. 2).
glm::dvec3 cie_xyz_fit(double nm);

/// \brief Linear sRGB (D65) from CIE XYZ (IEC 61966-2-1 matrix, as tabulated by Lindbloom).
glm::dvec3 xyz_to_linear_srgb(const glm::dvec3& xyz);

/// \brief A reflectance-like spectrum (albedo, eta, k) as rgb: per channel c the average of the
/// spectrum weighted by w_c(l) = max(0, (M_XYZ->sRGB cmf(l))_c) over 360..830 nm in 1 nm steps.
/// A constant spectrum maps to itself.
glm::dvec3 spectrum_to_rgb_reflectance(const Spectrum& s);

/// \brief An emission spectrum as rgb with luminance Y = 1 (pbrt-v4 lights divide the spectrum
/// by its photometric value before `scale`): M_XYZ->sRGB * XYZ / Y, XYZ integrated over
/// 360..830 nm in 1 nm steps with cie_xyz_fit.
glm::dvec3 spectrum_to_rgb_illuminant(const Spectrum& s);

}  // namespace basalt
