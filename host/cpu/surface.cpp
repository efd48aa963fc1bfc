// Surface points and ray spawning of the CPU reference (docs/path-spec.md sections 4 and 5).
#include "cpu/surface.h"

#include <bit>
#include <cfloat>
#include <cmath>

namespace basalt::cpu {

SurfaceGeometry triangle_geometry(const SceneTables& scene, std::uint32_t tri, float b0, float b1,
                                  float b2) {
  const gpu::Triangle& t = scene.triangles[tri];
  const gpu::Vertex& v0 = scene.vertices[t.v0];
  const gpu::Vertex& v1 = scene.vertices[t.v1];
  const gpu::Vertex& v2 = scene.vertices[t.v2];
  const glm::vec3 p0(v0.p_u), p1(v1.p_u), p2(v2.p_u);
  const std::uint32_t flags = t.mesh < scene.meshes.size() ? scene.meshes[t.mesh].flags : 0u;
  SurfaceGeometry g;
  // Spec section 4: interpolated position, never o + t d.
  g.p = b0 * p0 + b1 * p1 + b2 * p2;
  // pbrt-v4 Triangle::InteractionFromIntersection: n = normalize(cross(dp02, dp12)).
  g.ng = safe_normalize(glm::cross(p0 - p2, p1 - p2));
  if (flags & gpu::SHAPE_FLAG_HAS_NORMALS) {
    g.ns = safe_normalize(b0 * glm::vec3(v0.n_v) + b1 * glm::vec3(v1.n_v) + b2 * glm::vec3(v2.n_v));
    if (g.ns == glm::vec3(0.0f)) g.ns = g.ng;
    // The geometric normal is face-forwarded to the shading normal.
    if (glm::dot(g.ng, g.ns) < 0.0f) g.ng = -g.ng;
  } else {
    if (flags & gpu::SHAPE_FLAG_FLIP_NORMAL) g.ng = -g.ng;
    g.ns = g.ng;
  }
  return g;
}

SurfaceGeometry sphere_geometry(const SceneTables& scene, std::uint32_t s, glm::vec3 p) {
  const gpu::Sphere& sp = scene.spheres[s];
  const glm::vec3 c(sp.center_radius);
  const float r = sp.center_radius.w;
  SurfaceGeometry g;
  // Spec section 4 (pbrt-v4 6.2.2 "refine sphere intersection point"): re-project onto the
  // sphere; a point at the centre (impossible for a hit) is left alone rather than made NaN.
  const float dist = glm::length(p - c);
  g.p = dist > 0.0f ? c + (p - c) * (r / dist) : p;
  g.ng = (g.p - c) / r;
  if (sp.flags & gpu::SHAPE_FLAG_FLIP_NORMAL) g.ng = -g.ng;
  g.ns = g.ng;
  return g;
}

SurfacePoint surface_point(const SceneTables& scene, const Ray& ray, const Hit& hit) {
  SurfacePoint sp;
  if (hit.prim & gpu::PRIM_SPHERE_BIT) {
    const std::uint32_t s = hit.prim & gpu::PRIM_INDEX_MASK;
    sp.g = sphere_geometry(scene, s, ray.o + hit.t * ray.d);
    sp.material = scene.spheres[s].material;
    sp.light = scene.spheres[s].light;
  } else {
    // Only b1, b2 are carried by a Hit: b0 = 1 - b1 - b2 (see the report on this choice).
    sp.g = triangle_geometry(scene, hit.prim, 1.0f - hit.b1 - hit.b2, hit.b1, hit.b2);
    const gpu::Triangle& t = scene.triangles[hit.prim];
    if (t.mesh < scene.meshes.size()) {
      const gpu::Mesh& m = scene.meshes[t.mesh];
      sp.material = m.material;
      if (m.light_base != gpu::INVALID_INDEX) sp.light = m.light_base + hit.prim - m.tri_base;
    }
  }
  sp.frame = Frame::from_z(sp.g.ns);
  return sp;
}

glm::vec3 offset_ray(glm::vec3 p, glm::vec3 n) {
  // Constants of Ray Tracing Gems ch. 6: origin 1/32, float_scale 1/65536, int_scale 256.
  constexpr float ORIGIN = 1.0f / 32.0f, FLOAT_SCALE = 1.0f / 65536.0f, INT_SCALE = 256.0f;
  glm::vec3 r;
  for (int i = 0; i < 3; ++i) {
    // ivec3(256 n): conversion truncates towards zero, as in GLSL.
    const std::int32_t oi = static_cast<std::int32_t>(INT_SCALE * n[i]);
    // Integer ulp step away from the surface; unsigned arithmetic for defined wrap-around.
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(p[i]) +
                               static_cast<std::uint32_t>(p[i] < 0.0f ? -oi : oi);
    const float pi = std::bit_cast<float>(bits);
    r[i] = std::fabs(p[i]) < ORIGIN ? p[i] + FLOAT_SCALE * n[i] : pi;
  }
  return r;
}

Ray spawn_ray(glm::vec3 p, glm::vec3 ng, glm::vec3 wi) {
  return Ray{offset_ray(p, glm::dot(wi, ng) > 0.0f ? ng : -ng), wi, FLT_MAX};
}

}  // namespace basalt::cpu
