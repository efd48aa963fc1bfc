// Surface points, shading frames and ray spawning (docs/path-spec.md sections 4 and 5).
// Needs bindings.glsl.
#ifndef BASALT_SURFACE_GLSL
#define BASALT_SURFACE_GLSL

#include "math.glsl"
#include "sampling.glsl"
#include "intersect.glsl"

// A point on a surface: position, geometric normal (after the flips of section 4), shading
// normal with its Duff tangents, material index and area light index (INVALID_INDEX if none).
struct SurfacePoint {
  vec3 p;
  uint material;
  vec3 ng;
  uint light;
  vec3 ns;
  vec3 t1;
  vec3 t2;
};

// Position, geometric normal and shading normal of triangle tri at barycentrics b
// (docs/path-spec.md section 4): p interpolated, ng = normalize(cross(p0 - p2, p1 - p2))
// (pbrt-v4 6.5.3), face-forwarded to the interpolated normal when the mesh has normals,
// else flipped by SHAPE_FLAG_FLIP_NORMAL.
void triangle_geometry(uint tri, vec3 b, out vec3 p, out vec3 ng, out vec3 ns) {
  Triangle T = triangles[tri];
  uint flags = meshes[T.mesh].flags;
  vec3 p0 = vertices[T.v0].p_u.xyz;
  vec3 p1 = vertices[T.v1].p_u.xyz;
  vec3 p2 = vertices[T.v2].p_u.xyz;
  p = b.x * p0 + b.y * p1 + b.z * p2;
  ng = safe_normalize(cross(p0 - p2, p1 - p2));
  if ((FEATURES & FEATURE_SHADING_NORMALS) != 0u && (flags & SHAPE_FLAG_HAS_NORMALS) != 0u) {
    vec3 n = b.x * vertices[T.v0].n_v.xyz + b.y * vertices[T.v1].n_v.xyz +
             b.z * vertices[T.v2].n_v.xyz;
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
  return (spheres[sph].flags & SHAPE_FLAG_FLIP_NORMAL) != 0u ? -n : n;
}

// Surface point of a closest hit (docs/path-spec.md section 4). Triangles: interpolated
// position, b0 = 1 - b1 - b2. Spheres: o + t d re-projected onto the sphere (pbrt-v4 6.2.2).
SurfacePoint surface_point(Ray ray, Hit hit) {
  SurfacePoint sp;
  sp.material = INVALID_INDEX;
  sp.light = INVALID_INDEX;
  sp.p = ray.o;
  sp.ng = vec3(0.0, 0.0, 1.0);
  sp.ns = sp.ng;
  if ((hit.prim & PRIM_SPHERE_BIT) != 0u) {
    if ((FEATURES & FEATURE_SPHERES) != 0u) {
      uint sph = hit.prim & PRIM_INDEX_MASK;
      vec4 cr = spheres[sph].center_radius;
      vec3 p = ray.o + hit.t * ray.d;
      vec3 pc = p - cr.xyz;
      float len = length(pc);
      if (len > 0.0) p = cr.xyz + pc * (cr.w / len);
      sp.p = p;
      sp.ng = sphere_normal(sph, (p - cr.xyz) / cr.w);
      sp.ns = sp.ng;
      sp.material = spheres[sph].material;
      sp.light = spheres[sph].light;
    }
  } else if ((FEATURES & FEATURE_TRIANGLES) != 0u) {
    uint tri = hit.prim;
    triangle_geometry(tri, vec3(1.0 - hit.b1 - hit.b2, hit.b1, hit.b2), sp.p, sp.ng, sp.ns);
    Mesh m = meshes[triangles[tri].mesh];
    sp.material = m.material;
    sp.light = m.light_base == INVALID_INDEX ? INVALID_INDEX : m.light_base + (tri - m.tri_base);
  }
  duff_frame(sp.ns, sp.t1, sp.t2);
  return sp;
}

// World direction to the local shading frame (t1, t2, ns).
vec3 to_local(SurfacePoint sp, vec3 w) { return vec3(dot(w, sp.t1), dot(w, sp.t2), dot(w, sp.ns)); }

// Local shading-frame direction to world space.
vec3 to_world(SurfacePoint sp, vec3 l) { return l.x * sp.t1 + l.y * sp.t2 + l.z * sp.ns; }

// Ray origin off a surface: Waechter & Binder, "A Fast and Robust Method for Avoiding
// Self-Intersection", Ray Tracing Gems ch. 6 (docs/path-spec.md section 5). n is the
// geometric normal on the side the ray leaves; p moves 256 n ulps per component, or by
// n / 65536 near the origin (|p| < 1/32).
vec3 offset_ray(vec3 p, vec3 n) {
  ivec3 oi = ivec3(256.0 * n);
  ivec3 bits = floatBitsToInt(p);
  vec3 p_i = intBitsToFloat(bits + ivec3(p.x < 0.0 ? -oi.x : oi.x, p.y < 0.0 ? -oi.y : oi.y,
                                         p.z < 0.0 ? -oi.z : oi.z));
  vec3 p_f = p + n * (1.0 / 65536.0);
  return vec3(abs(p.x) < 1.0 / 32.0 ? p_f.x : p_i.x, abs(p.y) < 1.0 / 32.0 ? p_f.y : p_i.y,
              abs(p.z) < 1.0 / 32.0 ? p_f.z : p_i.z);
}

// Continuation ray from p in unit direction wi (docs/path-spec.md section 5).
Ray spawn_ray(vec3 p, vec3 ng, vec3 wi) {
  return Ray(offset_ray(p, dot(wi, ng) > 0.0 ? ng : -ng), FLT_MAX, wi);
}

#endif
