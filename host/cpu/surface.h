// Surface points and ray spawning of the CPU reference (docs/path-spec.md sections 4 and 5).
#pragma once
#include <cstdint>

#include <glm/glm.hpp>

#include "cpu/intersect.h"
#include "cpu/sampling.h"
#include "cpu/texture.h"
#include "scene/tables.h"

namespace basalt::cpu {

/// Position and normals of a point on a primitive (docs/path-spec.md section 4).
struct SurfaceGeometry {
  glm::vec3 p{0.0f};
  glm::vec3 ng{0.0f, 0.0f, 1.0f};  // geometric normal, oriented as section 4 says
  glm::vec3 ns{0.0f, 0.0f, 1.0f};  // shading normal
  float m = 0.0f;  // magnitude bound of the primitive at p, for offset_ray (section 5)
  glm::vec3 dpdu{0.0f};  // dp/du (docs/materials-spec.md 1.1); zero when there is none
  glm::vec3 dpdv{0.0f};  // dp/dv (docs/textures-spec.md 1); zero for a degenerate uv map
  glm::vec2 uv{0.0f};    // surface parameterisation (docs/textures-spec.md 1)
  glm::vec3 dndu{0.0f};  // shading-normal derivatives (docs/textures-spec.md 3.2)
  glm::vec3 dndv{0.0f};
};

/// A shaded hit: geometry, shading frame, material and area light.
struct SurfacePoint {
  SurfaceGeometry g;
  Frame frame;  // shading frame (s, t, ns) of docs/materials-spec.md 1.1 (shading_frame)
  std::uint32_t material = gpu::INVALID_INDEX;
  std::uint32_t light = gpu::INVALID_INDEX;   // area light of the primitive, if emissive
  const SceneTables* scene = nullptr;  // for texture lookups (slot_value)
  TextureContext tex;                  // texture context (docs/textures-spec.md 1, 3)
  // The shading pair (sdpdu, sdpdv) a bump or normal map starts from (docs/bump-spec.md 3);
  // set with the texture context, zero without one.
  glm::vec3 sdpdu{0.0f}, sdpdv{0.0f};
};

/// \brief Point of triangle tri at barycentrics (b0, b1, b2): interpolated position, ng from
///        cross(p0 - p2, p1 - p2), ns interpolated when the mesh has normals (section 4),
///        the magnitude bound m = max component of |b0 p0| + |b1 p1| + |b2 p2| (section 5) and
///        dpdu from the vertex uv (docs/materials-spec.md 1.1).
SurfaceGeometry triangle_geometry(const SceneTables& scene, std::uint32_t tri, float b0, float b1,
                                  float b2);

/// \brief Point of sphere index s at p (re-projected onto the sphere), normals per section 4,
///        magnitude bound m = sphere_magnitude(c, r) (section 5), dpdu of
///        docs/materials-spec.md 1.1 (zero at the poles).
SurfaceGeometry sphere_geometry(const SceneTables& scene, std::uint32_t s, glm::vec3 p);

/// \brief Shading frame of docs/materials-spec.md 1.1: s = dpdu - ns dot(ns, dpdu)
///        (Gram-Schmidt), normalized if dot(s, s) > 1e-20 and finite, t = cross(ns, s);
///        otherwise the Duff frame of ns (docs/path-spec.md section 4).
Frame shading_frame(glm::vec3 ns, glm::vec3 dpdu);

/// \brief Shaded hit of a valid Hit of ray (b0 = 1 - b1 - b2 for triangles). When the scene
///        has textures, its texture context with the footprint of docs/textures-spec.md 3:
///        from \p diff (the ray's differentials, 3.1) when given, else approximated.
SurfacePoint surface_point(const SceneTables& scene, const Ray& ray, const Hit& hit,
                           const RayDifferential* diff = nullptr);

/// \brief Magnitude bound of a triangle point b0 p0 + b1 p1 + b2 p2 (docs/path-spec.md
///        section 5): the largest component of abs(b0 p0) + abs(b1 p1) + abs(b2 p2).
float triangle_magnitude(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2, float b0, float b1, float b2);

/// \brief Magnitude bound of any point of the sphere (c, r) (docs/path-spec.md section 5):
///        max(|c.x|, |c.y|, |c.z|) + r.
float sphere_magnitude(glm::vec3 c, float r);

/// \brief docs/path-spec.md section 5: p moved along n (the geometric normal flipped to the
///        side the ray leaves on) by m 2^-17, where m is the magnitude bound of the primitive
///        p lies on (64 ulps at magnitude m). The margin scales with the largest coordinate
///        the intersection tests round at, not with p's own coordinates, in the spirit of
///        pbrt-v4 6.8.6's error bounds; it replaces Waechter & Binder (Ray Tracing Gems ch. 6),
///        whose fixed 1/65536 near the origin exceeds objects of 1e-5 and whose per-component
///        ulp steps are too small for mixed magnitudes. Float arithmetic, no fma:
///        d = m * 2^-17, then p + d n componentwise.
glm::vec3 offset_ray(glm::vec3 p, glm::vec3 n, float m);

/// \brief Continuation ray from p (magnitude bound m) with geometric normal ng in direction
///        wi: o = offset_ray(p, dot(wi, ng) > 0 ? ng : -ng, m), tMax = FLT_MAX (section 5).
Ray spawn_ray(glm::vec3 p, glm::vec3 ng, float m, glm::vec3 wi);

}  // namespace basalt::cpu
