// pbrt-v2's "measured" material data: the MERL regular half-angle BRDF table (reader and a
// writer that tabulates an analytic BRDF at the bin centres of the same parameterisation).
#pragma once
#include <functional>
#include <glm/glm.hpp>
#include <string>

#include "scene/scene.h"

namespace basalt {

/// The per-channel factors pbrt-v2 applies to the stored values (measured.cpp: 1/1500,
/// 1.15/1500, 1.66/1500).
inline constexpr double kMerlScale[3] = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

/// \brief Reads a MERL .binary file: int32 dims[3] (n theta_h, n theta_d, n phi_d), then
/// 3 n doubles, channel-major (all of R, then G, then B), little-endian; each value times
/// kMerlScale, negative (missing) values become 0. Any dims are accepted (pbrt-v2 requires
/// 90 x 90 x 180).
/// \throws std::runtime_error for an unreadable, short, oversized or malformed file (the
///         message names the problem, not the file).
MeasuredTable read_merl(const std::string& path);

/// \brief Directions of the centre of bin (ih, id, ip) of pbrt-v2's RegularHalfangleBRDF
/// parameterisation: theta_h = pi/2 ((ih + 0.5) / nThetaH)^2, theta_d = pi/2 (id + 0.5) /
/// nThetaD, phi_d = pi (ip + 0.5) / nPhiD, phi_h = 0. Returns false when wi or wo is below
/// the surface (that entry is "missing").
bool merl_bin_directions(const glm::uvec3& dims, unsigned ih, unsigned id, unsigned ip,
                         glm::dvec3* wi, glm::dvec3* wo);

/// \brief Writes a MERL .binary file of size \p dims whose entries are \p brdf(wi, wo) (rgb,
/// the BRDF value without cosine) at the bin centres; missing entries are written as -1.
/// \throws std::runtime_error if the file cannot be written.
void write_merl(const std::string& path, const glm::uvec3& dims,
                const std::function<glm::dvec3(const glm::dvec3& wi, const glm::dvec3& wo)>& brdf);

/// An analytic BRDF to tabulate: Lambertian kd / pi plus an isotropic Trowbridge-Reitz lobe
/// with Schlick's Fresnel of normal reflectance f0 (a rough-conductor-like highlight).
struct AnalyticBrdf {
  glm::dvec3 kd{0.05, 0.1, 0.3};
  glm::dvec3 f0{0.95, 0.64, 0.54};
  double alpha = 0.2;
  /// \brief f(wi, wo) in the local frame (z = normal); 0 unless both are above the surface.
  glm::dvec3 eval(const glm::dvec3& wi, const glm::dvec3& wo) const;
};

}  // namespace basalt
