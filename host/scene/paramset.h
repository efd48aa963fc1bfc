// Parameter lists of pbrt-v4 directives ("type name" value...): parsing, typed lookup with
// defaults, and the report of parameters nobody looked up (pbrt-v4 paramdict.h, re-implemented).
#pragma once
#include <glm/glm.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scene/scene.h"
#include "scene/spectra.h"
#include "scene/tokenizer.h"

namespace basalt {

/// One parsed parameter. Exactly one of numbers, strings, bools holds the values.
struct Param {
  std::string type;  // canonical: float integer bool string texture point2 vector2 point3
                     // vector3 normal rgb spectrum blackbody
  std::string name;
  SourceLoc loc;  // of the "type name" string
  std::vector<double> numbers;
  std::vector<std::string> strings;
  std::vector<bool> bools;
  mutable bool used = false;
};

/// How a spectrum-valued parameter is used; decides its checks (pbrt-v4 SpectrumType).
enum class SpectrumUse {
  Albedo,      // reflectances: components in [0, 1]
  Unbounded,   // eta, k, pbrt-v3 Kd/Ks/...: components >= 0
  Illuminant,  // light emission: components >= 0, spectra normalised to luminance 1
};

/// The parameters of one directive, looked up by name and type as pbrt-v4's ParameterDictionary.
/// When a name is given twice the last one wins (pbrt-v4 reverses the list). A lookup whose
/// name exists with another type is an error at that parameter's location.
class ParamSet {
 public:
  std::vector<Param> params;

  /// Single values: the value of the last parameter \p name, or \p def if there is none;
  /// more than one value is an error at the parameter.
  float get_float(const std::string& name, float def) const;
  int get_int(const std::string& name, int def) const;
  bool get_bool(const std::string& name, bool def) const;
  std::string get_string(const std::string& name, const std::string& def) const;
  glm::vec3 get_point3(const std::string& name, glm::vec3 def) const;

  /// Arrays: all values of the last parameter \p name (grouped per item), or empty.
  std::vector<float> get_floats(const std::string& name) const;
  std::vector<int> get_ints(const std::string& name) const;
  std::vector<glm::vec2> get_point2s(const std::string& name) const;
  std::vector<glm::vec3> get_point3s(const std::string& name) const;
  std::vector<glm::vec3> get_normals(const std::string& name) const;

  /// \brief An rgb, spectrum or blackbody parameter as linear sRGB, or nothing if absent.
  /// Spectra (named, inline (lambda, value) pairs, blackbody) are converted as
  /// docs/materials.md "Spectra" says: reflectance weighting for Albedo/Unbounded, luminance-1
  /// XYZ for Illuminant. \p warnings is unused (kept for callers).
  /// \throws SceneError for unknown named spectra, malformed spectra, negative components, and
  ///         albedos above 1 (pbrt-v4 checks the same).
  std::optional<glm::vec3> get_spectrum(const std::string& name, SpectrumUse use,
                                        std::vector<std::string>* warnings) const;
  /// \brief A spectrum or blackbody parameter as a Spectrum (an rgb one is an error: it has no
  /// wavelength dependence to evaluate), or nothing if absent.
  std::optional<Spectrum> get_spectrum_curve(const std::string& name) const;
  /// \brief All strings of the last string parameter \p name (empty if absent).
  std::vector<std::string> get_strings(const std::string& name) const;

  /// \brief The last parameter called \p name, checked to have one of \p types (an error at
  /// its location otherwise) and marked used; nullptr if absent.
  const Param* lookup(const std::string& name, std::initializer_list<const char*> types) const;

  /// \brief The parameter named \p name (the last one), or nullptr; marks nothing.
  const Param* find(const std::string& name) const;
  /// \brief Location of parameter \p name, or \p fallback if it is absent.
  SourceLoc loc_of(const std::string& name, const SourceLoc& fallback) const;

  /// \brief Appends "file:line:column: warning: ..." for each parameter never looked up
  /// (pbrt-v4 ReportUnused, which errors; basalt warns). \p what names the directive.
  void report_unused(const std::string& what, std::vector<std::string>& warnings) const;

};

/// \brief Reads "type name" value pairs until the next token that is not a quoted string.
/// \throws SceneError at the parameter's location for an unknown type, a missing value, a
///         value of the wrong kind or a wrong number of values.
ParamSet parse_param_list(Tokenizer& tok);

/// \brief "file:line:column: warning: message".
std::string format_warning(const SourceLoc& loc, const std::string& message);

}  // namespace basalt
