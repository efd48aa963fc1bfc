// Image infinite lights (environment maps) of the CPU reference: pbrt-v4 ImageInfiniteLight
// over the tables of docs/textures-spec.md section 6, with the lat-long and cube mappings of
// 6.8 (Light.data.w) (the GLSL twin is shaders/include/envmap.glsl).
#pragma once
#include <glm/glm.hpp>

#include "scene/tables.h"

namespace basalt::cpu {

/// \brief pbrt-v4 EqualAreaSquareToSphere (util/math.cpp): point of [0,1]^2 to a unit direction
///        (textures-spec section 6 gives the exact float operations).
glm::vec3 equal_area_square_to_sphere(glm::vec2 p);

/// \brief pbrt-v4 EqualAreaSphereToSquare (util/math.cpp): unit direction to [0,1]^2, with the
///        polynomial atan evaluated without fma.
glm::vec2 equal_area_sphere_to_square(glm::vec3 d);

/// \brief Lat-long map (textures-spec 6.8): unit direction in the light's frame to (u, v) =
///        (phi / 2 pi, theta / pi), theta from +z, phi = atan2(y, x) in [0, 2 pi).
glm::vec2 latlong_dir_to_uv(glm::vec3 wl);

/// \brief Lat-long map: (u, v) to the unit direction (sin theta cos phi, sin theta sin phi,
///        cos theta), theta = v pi, phi = u 2 pi.
glm::vec3 latlong_uv_to_dir(glm::vec2 uv);

/// \brief Cube map (textures-spec 6.8, OpenGL faces +x, -x, +y, -y, +z, -z stacked
///        vertically): face of direction \p wl (any length, not 0) and its face coordinates
///        (a, b) in [-1, 1]^2; returns the face index.
int cube_face_coords(glm::vec3 wl, float& a, float& b);

/// \brief Cube map: strip (u, v) of direction \p wl: (fu, (face + fv) / 6).
glm::vec2 cube_dir_to_uv(glm::vec3 wl);

/// \brief Cube map: unit direction of face \p face at face uv (fu, fv) in [0, 1]^2.
glm::vec3 cube_face_uv_to_dir(int face, float fu, float fv);

/// \brief Radiance of image infinite light \p l arriving from world direction \p w_world (unit,
///        pointing away from the scene) along a ray from \p o: pbrt-v4 ImageInfiniteLight::Le
///        (PortalImageInfiniteLight::Le for a portal, textures-spec 6.9, the only mapping that
///        reads \p o).
glm::vec3 env_le(const SceneTables& s, const gpu::Light& l, glm::vec3 w_world,
                 glm::vec3 o = glm::vec3(0.0f));

/// \brief Solid-angle pdf with which env_sample from reference point \p p produces
///        \p w_world: pbrt-v4 ImageInfiniteLight::PDF_Li; \p compensated selects the
///        MIS-compensated distribution (allowIncompletePDF = true, what the path tracer uses;
///        a portal, textures-spec 6.9, has one distribution and is the only mapping that reads
///        \p p).
float env_pdf(const SceneTables& s, const gpu::Light& l, glm::vec3 w_world, bool compensated,
              glm::vec3 p = glm::vec3(0.0f));

/// \brief pbrt-v4 ImageInfiniteLight::SampleLi from reference point \p p (read by portals
///        only, textures-spec 6.9): direction \p wi (world), solid-angle \p pdf and radiance
///        \p le for u = (u0, u1) (u0 picks the column, u1 the row). Returns false (and leaves
///        the outputs 0) when there is no sample.
bool env_sample(const SceneTables& s, const gpu::Light& l, glm::vec2 u, bool compensated,
                glm::vec3& wi, float& pdf, glm::vec3& le, glm::vec3 p = glm::vec3(0.0f));

}  // namespace basalt::cpu
