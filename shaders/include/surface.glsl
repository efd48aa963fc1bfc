// Surface points, shading frames and ray spawning (docs/path-spec.md sections 4 and 5).
// Needs bindings.glsl.
#ifndef BASALT_SURFACE_GLSL
#define BASALT_SURFACE_GLSL

#include "math.glsl"
#include "sampling.glsl"
#include "intersect.glsl"
#include "texture.glsl"

// A point on a surface: position, geometric normal (after the flips of section 4), shading
// normal with its tangents (t1, t2) = (s, t) of the shading frame (docs/materials-spec.md
// section 1.1: from dpdu, or the Duff frame of ns without a usable dpdu), material index, area
// light index (INVALID_INDEX if none) and the magnitude bound m of its primitive that scales
// the spawn offset (section 5).
struct SurfacePoint {
  vec3 p;
  uint material;
  vec3 ng;
  uint light;
  vec3 ns;
  float m;
  vec3 t1;
  vec3 t2;
  TexCtx tex;  // texture context (docs/textures-spec.md 1, 3); set when FEATURE_TEXTURES
  vec3 dndu;   // shading-normal derivatives (textures-spec 3.2); set when FEATURE_TEXTURES
  vec3 dndv;
  // The shading pair (pbrt-v4 shading.dpdu, shading.dpdv; docs/bump-spec.md 3), replaced by
  // the bumped pair when a bump or normal map applies (bump-spec 6); set when FEATURE_TEXTURES.
  vec3 sdpdu;
  vec3 sdpdv;
};

// cross(a, b) spelled out and precise (no fma contraction), as the CPU computes it.
vec3 cross_exact(vec3 a, vec3 b) {
  precise vec3 c = vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
  return c;
}

// Parameterisation of triangle tri at barycentrics b (docs/materials-spec.md section 1.1,
// docs/textures-spec.md 1; pbrt-v4 Triangle::InteractionFromIntersection): uv interpolated from
// the mesh's per-vertex uv or (0,0), (1,0), (1,1) without them, and dpdu, dpdv, both zero when
// |det| < 1e-9 (a degenerate uv map); with vertex normals, the shading-normal derivatives
// dndu, dndv of textures-spec 3.2 (zero without).
void triangle_params(uint tri, vec3 b, out vec2 uv, out vec3 dpdu, out vec3 dpdv, out vec3 dndu,
                     out vec3 dndv) {
  Triangle T = triangle_at(tri);
  Vertex a = Vertex(vertex_p_u(T.v0), vertex_n_v(T.v0));
  Vertex bb = Vertex(vertex_p_u(T.v1), vertex_n_v(T.v1));
  Vertex c = Vertex(vertex_p_u(T.v2), vertex_n_v(T.v2));
  uint mflags = mesh_at(T.mesh).flags;
  vec2 uv0 = vec2(0.0, 0.0), uv1 = vec2(1.0, 0.0), uv2 = vec2(1.0, 1.0);
  if ((mflags & SHAPE_FLAG_HAS_UV) != 0u) {
    uv0 = vec2(a.p_u.w, a.n_v.w);
    uv1 = vec2(bb.p_u.w, bb.n_v.w);
    uv2 = vec2(c.p_u.w, c.n_v.w);
  }
  precise vec2 iuv = b.x * uv0 + b.y * uv1 + b.z * uv2;
  uv = iuv;
  precise vec2 duv02 = uv0 - uv2;
  precise vec2 duv12 = uv1 - uv2;
  precise vec3 dp02 = a.p_u.xyz - c.p_u.xyz;
  precise vec3 dp12 = bb.p_u.xyz - c.p_u.xyz;
  precise float det = duv02.x * duv12.y - duv02.y * duv12.x;
  bool degenerate = abs(det) < 1e-9;
  dndu = vec3(0.0);
  dndv = vec3(0.0);
  if (has_feature(FEATURE_SHADING_NORMALS) && (mflags & SHAPE_FLAG_HAS_NORMALS) != 0u) {
    vec3 n0 = a.n_v.xyz, n1 = bb.n_v.xyz, n2 = c.n_v.xyz;
    if (degenerate) {
      // The Duff pair of the unnormalised dn (pbrt-v4 CoordinateSystem).
      precise vec3 e20 = n2 - n0;
      precise vec3 e10 = n1 - n0;
      vec3 dn = cross_exact(e20, e10);
      if (dn.x != 0.0 || dn.y != 0.0 || dn.z != 0.0) duff_frame(dn, dndu, dndv);
    } else {
      precise vec3 dn1 = n0 - n2;
      precise vec3 dn2 = n1 - n2;
      precise vec3 ddu = (duv12.y * dn1 - duv02.y * dn2) / det;
      precise vec3 ddv = (duv02.x * dn2 - duv12.x * dn1) / det;
      dndu = ddu;
      dndv = ddv;
    }
  }
  if (degenerate) {
    dpdu = vec3(0.0);
    dpdv = vec3(0.0);
    return;
  }
  precise vec3 du = (duv12.y * dp02 - duv02.y * dp12) / det;
  precise vec3 dv = (duv02.x * dp12 - duv12.x * dp02) / det;
  dpdu = du;
  dpdv = dv;
}

// uv and dpdv of sphere sph at p (docs/textures-spec.md 1, pbrt-v4 Sphere, full sphere):
// u = phi / 2 pi, v = 1 - theta / pi, dpdv = -pi (z cos phi, z sin phi, -r sin theta).
void sphere_uv(uint sph, vec3 p, out vec2 uv, out vec3 dpdv) {
  Sphere S = sphere_at(sph);
  float r = S.center_radius.w;
  precise vec3 pc = p - S.center_radius.xyz;
  float qx = dot_exact(pc, S.axis_x.xyz);
  float qy = dot_exact(pc, S.axis_y.xyz);
  float qz = dot_exact(pc, S.axis_z.xyz);
  float phi = atan2_accurate(qy, qx);
  if (phi < 0.0) phi += 2.0 * PI;
  float cos_theta = clamp(qz / r, -1.0, 1.0);
  float theta = acos_accurate(cos_theta);
  precise float v = (theta - PI) / (0.0 - PI);
  uv = vec2(phi * (1.0 / (2.0 * PI)), v);
  precise float zr = sqrt(qx * qx + qy * qy);
  float cos_phi = zr > 0.0 ? qx / zr : 1.0, sin_phi = zr > 0.0 ? qy / zr : 0.0;
  precise float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
  precise float dvx = -PI * (qz * cos_phi);
  precise float dvy = -PI * (qz * sin_phi);
  precise float dvz = -PI * (-r * sin_theta);
  precise vec3 d = dvx * S.axis_x.xyz + dvy * S.axis_y.xyz + dvz * S.axis_z.xyz;
  dpdv = d;
}

// dpdu of sphere sph at p (docs/materials-spec.md section 1.1): in the object frame with
// q = p - c in object coordinates, (-2 pi q.y, 2 pi q.x, 0) (pbrt-v4 Sphere, phiMax = 2 pi),
// back in world space; zero at the poles.
vec3 sphere_dpdu(uint sph, vec3 p) {
  Sphere S = sphere_at(sph);
  precise vec3 pc = p - S.center_radius.xyz;
  float qx = dot_exact(pc, S.axis_x.xyz);
  float qy = dot_exact(pc, S.axis_y.xyz);
  precise float dx = (-2.0 * PI) * qy;
  precise float dy = (2.0 * PI) * qx;
  precise vec3 dpdu = dx * S.axis_x.xyz + dy * S.axis_y.xyz;
  return dpdu;
}

// Shading frame (t1, t2, ns) from the shading normal and dpdu (docs/materials-spec.md section
// 1.1): s = dpdu - ns dot(ns, dpdu) normalized and t = cross(ns, s) when dot(s, s) > 1e-20 and
// finite, else the Duff frame of ns (docs/path-spec.md section 4).
void shading_frame(vec3 ns, vec3 dpdu, out vec3 t1, out vec3 t2) {
  float d = dot_exact(ns, dpdu);
  precise vec3 s = dpdu - ns * d;
  float ss = dot_exact(s, s);
  if (ss > 1e-20 && ss <= FLT_MAX) {
    t1 = s / sqrt(ss);
    t2 = cross_exact(ns, t1);
  } else {
    duff_frame(ns, t1, t2);
  }
}

// The shading pair of a triangle with vertex normals (docs/bump-spec.md 3; pbrt-v4
// Triangle::InteractionFromIntersection): ss = dpdu, ts = cross(ns, ss); ss = cross(ts, ns)
// when |ts|^2 > 0, else (ss, ts) = the Duff pair of ns. dpdu in, (ss, ts) out.
void shading_pair_vertex_normals(vec3 ns, inout vec3 ss, out vec3 ts) {
  ts = cross_exact(ns, ss);
  if (dot_exact(ts, ts) > 0.0) ss = cross_exact(ts, ns);
  else duff_frame(ns, ss, ts);
}

// Magnitude bound of a sphere (center, radius) for offset_ray (docs/path-spec.md section 5):
// max(|c.x|, |c.y|, |c.z|) + r.
float sphere_bound(vec4 cr) {
  vec3 a = abs(cr.xyz);
  precise float m = max(a.x, max(a.y, a.z)) + cr.w;
  return m;
}

// Position, geometric normal, shading normal and magnitude bound of triangle tri at
// barycentrics b (docs/path-spec.md sections 4 and 5): p interpolated, ng =
// normalize(cross(p0 - p2, p1 - p2)) (pbrt-v4 6.5.3), face-forwarded to the interpolated
// normal when the mesh has normals, else flipped by SHAPE_FLAG_FLIP_NORMAL; m = max component
// of |b0 p0| + |b1 p1| + |b2 p2|. The interpolations and m are precise (no fma
// contraction), as on the CPU (-ffp-contract=off).
void triangle_geometry(uint tri, vec3 b, out vec3 p, out vec3 ng, out vec3 ns, out float m) {
  Triangle T = triangle_at(tri);
  uint flags = mesh_at(T.mesh).flags;
  vec3 p0 = vertex_p_u(T.v0).xyz;
  vec3 p1 = vertex_p_u(T.v1).xyz;
  vec3 p2 = vertex_p_u(T.v2).xyz;
  precise vec3 bp0 = b.x * p0;
  precise vec3 bp1 = b.y * p1;
  precise vec3 bp2 = b.z * p2;
  precise vec3 pp = bp0 + bp1 + bp2;
  precise vec3 mv = abs(bp0) + abs(bp1) + abs(bp2);
  p = pp;
  m = max(mv.x, max(mv.y, mv.z));
  ng = safe_normalize(cross(p0 - p2, p1 - p2));
  if (has_feature(FEATURE_SHADING_NORMALS) && (flags & SHAPE_FLAG_HAS_NORMALS) != 0u) {
    precise vec3 n = b.x * vertex_n_v(T.v0).xyz + b.y * vertex_n_v(T.v1).xyz +
                     b.z * vertex_n_v(T.v2).xyz;
    ns = safe_normalize(n);
    if (ns.x == 0.0 && ns.y == 0.0 && ns.z == 0.0) ns = ng;  // zero (or underflowed) normal
    if (dot(ng, ns) < 0.0) ng = -ng;
  } else {
    if ((flags & SHAPE_FLAG_FLIP_NORMAL) != 0u) ng = -ng;
    ns = ng;
  }
}

// Outward normal (negated by SHAPE_FLAG_FLIP_NORMAL) of sphere sph for a unit vector n
// from its centre.
vec3 sphere_normal(uint sph, vec3 n) {
  return (sphere_at(sph).flags & SHAPE_FLAG_FLIP_NORMAL) != 0u ? -n : n;
}

// The material index of a closest hit's primitive (INVALID_INDEX: none).
uint hit_material(Hit hit) {
  if ((hit.prim & PRIM_SPHERE_BIT) != 0u)
    return has_feature(FEATURE_SPHERES) ? sphere_at(hit.prim & PRIM_INDEX_MASK).material
                                              : INVALID_INDEX;
  return has_feature(FEATURE_TRIANGLES) ? mesh_at(triangle_at(hit.prim).mesh).material
                                              : INVALID_INDEX;
}

// Surface point of a closest hit (docs/path-spec.md section 4). Triangles: interpolated
// position, b0 = 1 - b1 - b2. Spheres: o + t d re-projected onto the sphere (pbrt-v4 6.2.2).
// With FEATURE_TEXTURES, also the texture context with its footprint (docs/textures-spec.md
// 3): from the ray's differentials rd when has_diff, else approximated; and dndu, dndv (3.2).
SurfacePoint surface_point(Ray ray, Hit hit, bool has_diff, RayDiff rd) {
  SurfacePoint sp;
  sp.material = INVALID_INDEX;
  sp.light = INVALID_INDEX;
  sp.p = ray.o;
  sp.ng = vec3(0.0, 0.0, 1.0);
  sp.ns = sp.ng;
  sp.m = 0.0;
  sp.tex = TexCtx(vec3(0.0), vec3(0.0, 0.0, 1.0), vec2(0.0), vec3(0.0), vec3(0.0), 0.0, 0.0, 0.0, 0.0);
  sp.dndu = vec3(0.0);
  sp.dndv = vec3(0.0);
  sp.sdpdu = vec3(0.0);
  sp.sdpdv = vec3(0.0);
  bool vertex_normals = false;  // a triangle of a mesh with vertex normals (bump-spec 3)
  vec3 dpdu = vec3(0.0);
  vec3 dpdv = vec3(0.0);
  vec2 uv = vec2(0.0);
  if ((hit.prim & PRIM_SPHERE_BIT) != 0u) {
    if (has_feature(FEATURE_SPHERES)) {
      uint sph = hit.prim & PRIM_INDEX_MASK;
      vec4 cr = sphere_at(sph).center_radius;
      precise vec3 p = ray.o + hit.t * ray.d;
      precise vec3 pc = p - cr.xyz;
      float len = sqrt(dot_exact(pc, pc));
      if (len > 0.0) p = cr.xyz + pc * (cr.w / len);
      sp.p = p;
      sp.ng = sphere_normal(sph, (p - cr.xyz) / cr.w);
      sp.ns = sp.ng;
      sp.m = sphere_bound(cr);
      sp.material = hit_material(hit);
      sp.light = sphere_at(sph).light;
      dpdu = sphere_dpdu(sph, sp.p);
      if (has_feature(FEATURE_TEXTURES)) {
        sphere_uv(sph, sp.p, uv, dpdv);
        // textures-spec 3.2: dpdu / (s r), not flipped with the normal.
        precise float sr = sphere_at(sph).axis_x.w * cr.w;
        precise vec3 ndu = dpdu / sr;
        precise vec3 ndv = dpdv / sr;
        sp.dndu = ndu;
        sp.dndv = ndv;
      }
    }
  } else if (has_feature(FEATURE_TRIANGLES)) {
    uint tri = hit.prim;
    triangle_geometry(tri, vec3(1.0 - hit.b1 - hit.b2, hit.b1, hit.b2), sp.p, sp.ng, sp.ns, sp.m);
    Mesh m = mesh_at(triangle_at(tri).mesh);
    sp.material = hit_material(hit);
    vertex_normals = has_feature(FEATURE_SHADING_NORMALS) &&
                     (m.flags & SHAPE_FLAG_HAS_NORMALS) != 0u;
    sp.light = m.light_base == INVALID_INDEX ? INVALID_INDEX : m.light_base + (tri - m.tri_base);
    // uv and dpdv are dead (and folded away) without FEATURE_TEXTURES.
    triangle_params(tri, vec3(1.0 - hit.b1 - hit.b2, hit.b1, hit.b2), uv, dpdu, dpdv, sp.dndu,
                    sp.dndv);
  }
  shading_frame(sp.ns, dpdu, sp.t1, sp.t2);
  if (has_feature(FEATURE_TEXTURES)) {
    sp.tex.p = sp.p;
    sp.tex.n = sp.ng;
    sp.tex.uv = uv;
    // docs/textures-spec.md 1: the Duff pair of ng stands in for a degenerate (dpdu, dpdv).
    vec3 du = dpdu, dv = dpdv;
    vec3 cr = cross_exact(du, dv);
    if (cr.x == 0.0 && cr.y == 0.0 && cr.z == 0.0) duff_frame(sp.ng, du, dv);
    compute_differentials(sp.tex, du, dv, has_diff, rd);
    sp.sdpdu = du;
    sp.sdpdv = dv;
    if (has_feature2(FEATURE2_BUMP | FEATURE2_NORMALMAP | FEATURE2_VTURB) && vertex_normals)
      shading_pair_vertex_normals(sp.ns, sp.sdpdu, sp.sdpdv);
  }
  return sp;
}

// World direction to the local shading frame (t1, t2, ns), with uncontracted dot products.
vec3 to_local(SurfacePoint sp, vec3 w) {
  return vec3(dot_exact(w, sp.t1), dot_exact(w, sp.t2), dot_exact(w, sp.ns));
}

// Local shading-frame direction to world space (l.x t1 + l.y t2 + l.z ns, left to right).
vec3 to_world(SurfacePoint sp, vec3 l) {
  precise vec3 w = l.x * sp.t1 + l.y * sp.t2 + l.z * sp.ns;
  return w;
}

// Ray origin off a surface (docs/path-spec.md section 5): p moved along n (the geometric
// normal on the side the ray leaves) by m * 2^-17, where m is the magnitude bound of the
// primitive p lies on (64 ulps at magnitude m). precise: p + d n must not become an fma.
vec3 offset_ray(vec3 p, vec3 n, float m) {
  precise float d = m * (1.0 / 131072.0);
  precise vec3 o = p + d * n;
  return o;
}

// Continuation ray from p (geometric normal ng, magnitude bound m) in unit direction wi
// (docs/path-spec.md section 5).
Ray spawn_ray(vec3 p, vec3 ng, float m, vec3 wi) {
  return Ray(offset_ray(p, dot(wi, ng) > 0.0 ? ng : -ng, m), FLT_MAX, wi);
}

#endif
