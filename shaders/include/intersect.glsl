// Ray-primitive tests and BVH traversal (docs/path-spec.md section 3). Needs bindings.glsl.
#ifndef BASALT_INTERSECT_GLSL
#define BASALT_INTERSECT_GLSL

#include "math.glsl"

// A ray o + t d; hits count for 0 < t < tmax (d non-zero, not necessarily unit length).
struct Ray {
  vec3 o;
  float tmax;
  vec3 d;
};

// Closest hit: distance t, prim reference (triangle index or sphere index | PRIM_SPHERE_BIT,
// INVALID_INDEX for a miss) and barycentrics b1, b2 of vertices v1, v2 (0 for spheres).
struct Hit {
  float t;
  float b1;
  float b2;
  uint prim;
};

// Depth of the traversal stack: nearer-child-first traversal holds at most one entry per
// level above the current node, and the host's BVH is at most kBvhMaxDepth = 64 deep
// (host/accel/bvh.h).
const int BVH_STACK_SIZE = 64;

// 1 + 2 gamma(3) with gamma(n) = n eps / (1 - n eps), eps = 2^-24 (pbrt-v4 6.1.2, 6.8.1):
// the conservative scale of the slab test's exit distance. Rounds to 1 + 3 ulp.
const float SLAB_EXIT_SCALE = 1.0 + 2.0 * (3.0 * 5.9604644775390625e-8) /
                                        (1.0 - 3.0 * 5.9604644775390625e-8);

// Cyclic permutation of v that puts component kz last (pbrt-v4 6.5.3 Permute with
// kx = kz + 1, ky = kx + 1 modulo 3).
vec3 permute_kz(vec3 v, int kz) { return kz == 0 ? v.yzx : (kz == 1 ? v.zxy : v); }

// Watertight ray-triangle test of Woop, Benthin & Wald (JCGT 2(1) 2013) as pbrt-v4 6.5.3
// Triangle::Intersect, without the double-precision fallback and the conservative t bound.
// Edge functions are plain products marked precise (no fma contraction, same rounding as
// the CPU reference compiled with -ffp-contract=off), which keeps shared edges watertight.
// Returns t in (0, tmax) with barycentrics (b1, b2), or -1 for a miss.
float intersect_triangle(Ray ray, uint tri, out vec2 b12) {
  b12 = vec2(0.0);
  Triangle T = triangles[tri];
  vec3 p0 = vertices[T.v0].p_u.xyz;
  vec3 p1 = vertices[T.v1].p_u.xyz;
  vec3 p2 = vertices[T.v2].p_u.xyz;
  vec3 ad = abs(ray.d);
  int kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
  precise vec3 d = permute_kz(ray.d, kz);
  precise vec3 p0t = permute_kz(p0 - ray.o, kz);
  precise vec3 p1t = permute_kz(p1 - ray.o, kz);
  precise vec3 p2t = permute_kz(p2 - ray.o, kz);
  // Shear so that the ray points along +z.
  precise float sx = -d.x / d.z;
  precise float sy = -d.y / d.z;
  precise float sz = 1.0 / d.z;
  p0t.x += sx * p0t.z;
  p0t.y += sy * p0t.z;
  p1t.x += sx * p1t.z;
  p1t.y += sy * p1t.z;
  p2t.x += sx * p2t.z;
  p2t.y += sy * p2t.z;
  // Edge functions.
  precise float e0 = p1t.x * p2t.y - p1t.y * p2t.x;
  precise float e1 = p2t.x * p0t.y - p2t.y * p0t.x;
  precise float e2 = p0t.x * p1t.y - p0t.y * p1t.x;
  if ((e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0)) return -1.0;
  precise float det = e0 + e1 + e2;
  if (det == 0.0) return -1.0;
  // Scaled distance, compared with tmax before the division (pbrt-v4).
  p0t.z *= sz;
  p1t.z *= sz;
  p2t.z *= sz;
  precise float t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
  if (det < 0.0 && (t_scaled >= 0.0 || t_scaled < ray.tmax * det)) return -1.0;
  if (det > 0.0 && (t_scaled <= 0.0 || t_scaled > ray.tmax * det)) return -1.0;
  precise float inv_det = 1.0 / det;
  precise float t = t_scaled * inv_det;
  // Degenerate triangles never hit (docs/path-spec.md section 3).
  vec3 c = cross(p0 - p2, p1 - p2);
  if (c.x == 0.0 && c.y == 0.0 && c.z == 0.0) return -1.0;
  if (!(t > 0.0 && t < ray.tmax)) return -1.0;
  b12 = vec2(e1 * inv_det, e2 * inv_det);
  return t;
}

// Ray-sphere test with pbrt-v4 6.2.2's robust quadratic (Hearn & Baker discriminant), in
// world space with f = o - c (docs/path-spec.md section 3). Returns the nearer root in
// (0, tmax), or -1 for a miss.
float intersect_sphere(Ray ray, uint sph) {
  vec4 cr = spheres[sph].center_radius;
  float r = cr.w;
  vec3 f = ray.o - cr.xyz;
  float a = dot(ray.d, ray.d);
  float b = 2.0 * dot(ray.d, f);
  float c = dot(f, f) - r * r;
  vec3 v = f - (b / (2.0 * a)) * ray.d;
  float l = length(v);
  float disc = 4.0 * a * (r + l) * (r - l);
  if (disc < 0.0) return -1.0;
  float root = sqrt(disc);
  float q = b < 0.0 ? -0.5 * (b - root) : -0.5 * (b + root);
  if (q == 0.0) return -1.0;  // tangent at the origin: c / q would be NaN
  float t0 = q / a;
  float t1 = c / q;
  if (t0 > t1) {
    float tmp = t0;
    t0 = t1;
    t1 = tmp;
  }
  float t = t0 > 0.0 ? t0 : t1;
  return (t > 0.0 && t < ray.tmax) ? t : -1.0;
}

// Tests the ray against one prim reference; t in (0, tmax) or -1, barycentrics b1, b2.
float intersect_prim(Ray ray, uint ref, out vec2 b12) {
  b12 = vec2(0.0);
  if ((ref & PRIM_SPHERE_BIT) != 0u) {
    if ((FEATURES & FEATURE_SPHERES) != 0u) return intersect_sphere(ray, ref & PRIM_INDEX_MASK);
  } else if ((FEATURES & FEATURE_TRIANGLES) != 0u) {
    return intersect_triangle(ray, ref, b12);
  }
  return -1.0;
}

// Slab test of pbrt-v4 6.1.2 Bounds3::IntersectP with a precomputed inverse direction: the
// exit distance is scaled by 1 + 2 gamma(3); inv has no infinities (see bvh_trace), so no
// 0 * inf. An inverted box (lo > hi) never hits. Accepts entry distances up to t_limit
// inclusive (closest-hit ties are decided by prim reference). Returns the entry distance
// (>= 0), or -1 for a miss.
float slab_test(uint node, vec3 o, vec3 inv, bvec3 neg, float t_limit) {
  vec3 lo = bvh_nodes[node].lo;
  vec3 hi = bvh_nodes[node].hi;
  vec3 tn = (mix(lo, hi, neg) - o) * inv;
  vec3 tf = (mix(hi, lo, neg) - o) * inv * SLAB_EXIT_SCALE;
  float enter = max(max(tn.x, tn.y), max(tn.z, 0.0));
  float exit = min(min(tf.x, tf.y), min(tf.z, t_limit));
  return enter <= exit ? enter : -1.0;
}

// Stack-based BVH traversal, nearer child first. Closest hit: the smallest t, on equal t the
// smaller prim reference, independent of traversal order (docs/path-spec.md section 3):
// every primitive is tested against the ray's own tmax and compared with the best hit
// afterwards. any_hit: returns at the first hit in (0, tmax) (shadow rays).
Hit bvh_trace(Ray ray, bool any_hit) {
  Hit best = Hit(ray.tmax, 0.0, 0.0, INVALID_INDEX);
  // pbrt-v4 6.1.2: |d| < 1e-20 becomes copysign(1e-20, d) so that inv stays finite.
  vec3 dd = vec3(abs(ray.d.x) < 1e-20 ? copysign_pos(1e-20, ray.d.x) : ray.d.x,
                 abs(ray.d.y) < 1e-20 ? copysign_pos(1e-20, ray.d.y) : ray.d.y,
                 abs(ray.d.z) < 1e-20 ? copysign_pos(1e-20, ray.d.z) : ray.d.z);
  vec3 inv = 1.0 / dd;
  bvec3 neg = lessThan(inv, vec3(0.0));
  uint stack_node[BVH_STACK_SIZE];
  float stack_t[BVH_STACK_SIZE];
  int sp = 0;
  uint node = 0u;
  // A scene without primitives has no nodes (host/accel/bvh.h); its table is bound as a
  // 16-byte buffer, shorter than one node.
  if (bvh_nodes.length() == 0 || slab_test(node, ray.o, inv, neg, ray.tmax) < 0.0) {
    best.t = -1.0;
    return best;
  }
  while (true) {
    uint a = bvh_nodes[node].a;
    uint b = bvh_nodes[node].b;
    bool descend = false;
    if (b == 0u) {
      // Interior: children at a and a + 1.
      float t0 = slab_test(a, ray.o, inv, neg, best.t);
      float t1 = slab_test(a + 1u, ray.o, inv, neg, best.t);
      if (t0 >= 0.0 && t1 >= 0.0) {
        bool second_first = t1 < t0;
        if (sp < BVH_STACK_SIZE) {
          stack_node[sp] = second_first ? a : a + 1u;
          stack_t[sp] = second_first ? t0 : t1;
          ++sp;
        }
        node = second_first ? a + 1u : a;
        descend = true;
      } else if (t0 >= 0.0 || t1 >= 0.0) {
        node = t0 >= 0.0 ? a : a + 1u;
        descend = true;
      }
    } else {
      // Leaf over prim_refs[a, a + b).
      for (uint k = a; k < a + b; ++k) {
        uint ref = prim_refs[k];
        vec2 b12;
        float t = intersect_prim(ray, ref, b12);
        if (t > 0.0 && (t < best.t || (t == best.t && ref < best.prim))) {
          best = Hit(t, b12.x, b12.y, ref);
          if (any_hit) return best;
        }
      }
    }
    if (!descend) {
      // Pop, skipping subtrees that start beyond the best hit so far.
      node = INVALID_INDEX;
      while (sp > 0) {
        --sp;
        if (stack_t[sp] <= best.t) {
          node = stack_node[sp];
          break;
        }
      }
      if (node == INVALID_INDEX) break;
    }
  }
  if (best.prim == INVALID_INDEX) best.t = -1.0;
  return best;
}

// Closest hit in (0, ray.tmax); a miss has prim INVALID_INDEX and t = -1.
Hit intersect_closest(Ray ray) { return bvh_trace(ray, false); }

// True if anything is hit in (0, ray.tmax) (shadow rays).
bool intersect_any(Ray ray) { return bvh_trace(ray, true).prim != INVALID_INDEX; }

#endif
