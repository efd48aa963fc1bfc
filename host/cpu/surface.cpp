// Surface points and ray spawning of the CPU reference (docs/path-spec.md sections 4 and 5).
#include "cpu/surface.h"

#include <cfloat>
#include <algorithm>
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
  g.m = triangle_magnitude(p0, p1, p2, b0, b1, b2);
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
  // docs/materials-spec.md 1.1 (pbrt-v4 Triangle::InteractionFromIntersection): dpdu from the
  // vertex uv, or (0,0), (1,0), (1,1) when the mesh has none; zero for a degenerate uv map.
  glm::vec2 uv0(0.0f, 0.0f), uv1(1.0f, 0.0f), uv2(1.0f, 1.0f);
  if (flags & gpu::SHAPE_FLAG_HAS_UV) {
    uv0 = glm::vec2(v0.p_u.w, v0.n_v.w);
    uv1 = glm::vec2(v1.p_u.w, v1.n_v.w);
    uv2 = glm::vec2(v2.p_u.w, v2.n_v.w);
  }
  const glm::vec2 duv02 = uv0 - uv2, duv12 = uv1 - uv2;
  const glm::vec3 dp02 = p0 - p2, dp12 = p1 - p2;
  const float det = duv02.x * duv12.y - duv02.y * duv12.x;
  if (std::fabs(det) < 1e-9f) {
    g.dpdu = glm::vec3(0.0f);
  } else {
    g.dpdu = (duv12.y * dp02 - duv02.y * dp12) / det;
    g.dpdv = (duv02.x * dp12 - duv12.x * dp02) / det;  // docs/textures-spec.md 1
  }
  g.uv = b0 * uv0 + b1 * uv1 + b2 * uv2;
  // docs/textures-spec.md 3.2 (pbrt-v4 Triangle shading geometry): dndu, dndv from the vertex
  // normals, the Duff pair of the unnormalised dn for a degenerate uv map.
  if (flags & gpu::SHAPE_FLAG_HAS_NORMALS) {
    const glm::vec3 n0(v0.n_v), n1(v1.n_v), n2(v2.n_v);
    if (std::fabs(det) < 1e-9f) {
      const glm::vec3 dn = glm::cross(n2 - n0, n1 - n0);
      if (dn != glm::vec3(0.0f)) {
        const Frame f = Frame::from_z(dn);
        g.dndu = f.t1;
        g.dndv = f.t2;
      }
    } else {
      const glm::vec3 dn1 = n0 - n2, dn2 = n1 - n2;
      g.dndu = (duv12.y * dn1 - duv02.y * dn2) / det;
      g.dndv = (duv02.x * dn2 - duv12.x * dn1) / det;
    }
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
  g.m = sphere_magnitude(c, r);
  // docs/materials-spec.md 1.1: dpdu = 2 pi (-q.y, q.x, 0) in the object frame, q = the point
  // in object coordinates (pbrt-v4 Sphere::InteractionFromIntersection with phiMax = 2 pi).
  const glm::vec3 d = g.p - c;
  const glm::vec3 ax(sp.axis_x), ay(sp.axis_y);
  const float qx = glm::dot(d, ax), qy = glm::dot(d, ay);
  const float du_x = -2.0f * PI * qy, du_y = 2.0f * PI * qx;
  g.dpdu = du_x * ax + du_y * ay;
  // docs/textures-spec.md 1 (pbrt-v4 Sphere::InteractionFromIntersection, full sphere):
  // u = phi / 2 pi, v = 1 - theta / pi, dpdv = -pi (z cos phi, z sin phi, -r sin theta).
  const glm::vec3 az(sp.axis_z);
  const float qz = glm::dot(d, az);
  float phi = std::atan2(qy, qx);
  if (phi < 0.0f) phi += 2.0f * PI;
  const float cos_theta = std::clamp(qz / r, -1.0f, 1.0f);
  const float theta = std::acos(cos_theta);
  g.uv = glm::vec2(phi * (1.0f / (2.0f * PI)), (theta - PI) / (0.0f - PI));
  const float zr = std::sqrt(qx * qx + qy * qy);
  const float cos_phi = zr > 0.0f ? qx / zr : 1.0f, sin_phi = zr > 0.0f ? qy / zr : 0.0f;
  const float sin_theta = std::sqrt(std::max(0.0f, 1.0f - cos_theta * cos_theta));
  const float dv_x = -PI * (qz * cos_phi), dv_y = -PI * (qz * sin_phi), dv_z = -PI * (-r * sin_theta);
  g.dpdv = dv_x * ax + dv_y * ay + dv_z * az;
  // docs/textures-spec.md 3.2: pbrt-v4's Weingarten result dpdu / r_obj, through its normal
  // transform (a further 1 / s); not flipped with the normal.
  const float sr = sp.axis_x.w * r;
  g.dndu = g.dpdu / sr;
  g.dndv = g.dpdv / sr;
  return g;
}

Frame shading_frame(glm::vec3 ns, glm::vec3 dpdu) {
  // docs/materials-spec.md 1.1: Gram-Schmidt of dpdu against ns (pbrt-v4 BSDF's frame
  // Frame::FromXZ(Normalize(dpdus), ns)); the Duff frame when dpdu is unusable.
  const glm::vec3 s = dpdu - ns * glm::dot(ns, dpdu);
  const float l2 = glm::dot(s, s);
  if (l2 > 1e-20f && std::isfinite(l2)) {
    Frame f;
    f.t1 = s / std::sqrt(l2);
    f.t2 = glm::cross(ns, f.t1);
    f.n = ns;
    return f;
  }
  return Frame::from_z(ns);
}

SurfacePoint surface_point(const SceneTables& scene, const Ray& ray, const Hit& hit,
                           const RayDifferential* diff) {
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
  sp.frame = shading_frame(sp.g.ns, sp.g.dpdu);
  sp.scene = &scene;
  if (scene.features & gpu::FEATURE_TEXTURES) {
    sp.tex.p = sp.g.p;
    sp.tex.n = sp.g.ng;
    sp.tex.uv = sp.g.uv;
    // docs/textures-spec.md 1: the Duff pair of ng stands in for a degenerate (dpdu, dpdv).
    glm::vec3 du = sp.g.dpdu, dv = sp.g.dpdv;
    const glm::vec3 c = glm::cross(du, dv);
    if (c == glm::vec3(0.0f)) {
      const Frame f = Frame::from_z(sp.g.ng);
      du = f.t1;
      dv = f.t2;
    }
    compute_differentials(scene, sp.tex, du, dv, diff);
    // docs/bump-spec.md 3: the shading pair is (du, dv), except on triangles with vertex
    // normals (pbrt-v4 Triangle::InteractionFromIntersection: ss = dpdu, ts = cross(ns, ss),
    // ss = cross(ts, ns), or the Duff pair of ns when ts is zero).
    sp.sdpdu = du;
    sp.sdpdv = dv;
    if (!(hit.prim & gpu::PRIM_SPHERE_BIT)) {
      const std::uint32_t mi = scene.triangles[hit.prim].mesh;
      if (mi < scene.meshes.size() && (scene.meshes[mi].flags & gpu::SHAPE_FLAG_HAS_NORMALS)) {
        const glm::vec3 ts = glm::cross(sp.g.ns, du);
        if (glm::dot(ts, ts) > 0.0f) {
          sp.sdpdu = glm::cross(ts, sp.g.ns);
          sp.sdpdv = ts;
        } else {
          const Frame f = Frame::from_z(sp.g.ns);
          sp.sdpdu = f.t1;
          sp.sdpdv = f.t2;
        }
      }
    }
  }
  return sp;
}

float triangle_magnitude(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2, float b0, float b1, float b2) {
  // Spec section 5: componentwise abs(b0 p0) + abs(b1 p1) + abs(b2 p2), then the largest.
  const glm::vec3 s = glm::abs(b0 * p0) + glm::abs(b1 * p1) + glm::abs(b2 * p2);
  return std::fmax(s.x, std::fmax(s.y, s.z));
}

float sphere_magnitude(glm::vec3 c, float r) {
  return std::fmax(std::fabs(c.x), std::fmax(std::fabs(c.y), std::fabs(c.z))) + r;
}

glm::vec3 offset_ray(glm::vec3 p, glm::vec3 n, float m) {
  // Spec section 5: 2^-17 = 64 ulps at magnitude m; the scalar first, then p + d n (the
  // build's -ffp-contract=off keeps the multiply and the add separately rounded).
  const float d = m * 0x1p-17f;
  return p + d * n;
}

Ray spawn_ray(glm::vec3 p, glm::vec3 ng, float m, glm::vec3 wi) {
  return Ray{offset_ray(p, glm::dot(wi, ng) > 0.0f ? ng : -ng, m), wi, FLT_MAX};
}

}  // namespace basalt::cpu
