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

// Per-ray constants of the watertight triangle test (Woop, Benthin & Wald, JCGT 2(1) 2013,
// section 3): the axis kz of the largest |d| (pbrt-v4 6.5.3 MaxComponentIndex), the permuted
// origin and the shear. pbrt-v4 computes them per triangle; the values do not depend on the
// triangle, so computing them once per ray gives the same bits.
struct RayTri {
  vec3 o;      // origin, permuted
  int kz;
  vec3 shear;  // sx, sy, sz
};

// The triangle test's per-ray constants of ray.
RayTri ray_tri(Ray ray) {
  vec3 ad = abs(ray.d);
  int kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
  precise vec3 d = permute_kz(ray.d, kz);
  precise float sx = -d.x / d.z;
  precise float sy = -d.y / d.z;
  precise float sz = 1.0 / d.z;
  return RayTri(permute_kz(ray.o, kz), kz, vec3(sx, sy, sz));
}

// Watertight ray-triangle test of Woop, Benthin & Wald (JCGT 2(1) 2013) as pbrt-v4 6.5.3
// Triangle::Intersect, without the double-precision fallback and the conservative t bound.
// Edge functions are plain products marked precise (no fma contraction, same rounding as
// the CPU reference compiled with -ffp-contract=off), which keeps shared edges watertight.
// Returns t in (0, tmax) with barycentrics (b1, b2), or -1 for a miss. p0, p1, p2: the
// triangle's world-space vertices.
float intersect_triangle_at(Ray ray, RayTri rt, vec3 p0, vec3 p1, vec3 p2, out vec2 b12) {
  b12 = vec2(0.0);
  // Translate to the ray origin (permuting first and subtracting the permuted origin is the
  // same arithmetic per component).
  precise vec3 p0t = permute_kz(p0, rt.kz) - rt.o;
  precise vec3 p1t = permute_kz(p1, rt.kz) - rt.o;
  precise vec3 p2t = permute_kz(p2, rt.kz) - rt.o;
  // Shear so that the ray points along +z.
  precise float sx = rt.shear.x;
  precise float sy = rt.shear.y;
  precise float sz = rt.shear.z;
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
  vec4 cr = sphere_at(sph).center_radius;
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

// The watertight test against triangle tri of the triangle table.
float intersect_triangle(Ray ray, RayTri rt, uint tri, out vec2 b12) {
  Triangle T = triangle_at(tri);
  return intersect_triangle_at(ray, rt, vertex_p_u(T.v0).xyz, vertex_p_u(T.v1).xyz,
                               vertex_p_u(T.v2).xyz, b12);
}

// Tests the ray against one prim reference; t in (0, tmax) or -1, barycentrics b1, b2.
float intersect_prim(Ray ray, RayTri rt, uint ref, out vec2 b12) {
  b12 = vec2(0.0);
  if ((ref & PRIM_SPHERE_BIT) != 0u) {
    if (has_feature(FEATURE_SPHERES)) return intersect_sphere(ray, ref & PRIM_INDEX_MASK);
  } else if (has_feature(FEATURE_TRIANGLES)) {
    return intersect_triangle(ray, rt, ref, b12);
  }
  return -1.0;
}

// Slab test of pbrt-v4 6.1.2 Bounds3::IntersectP with a precomputed inverse direction on the
// box lo, hi: the exit distance is scaled by 1 + 2 gamma(3). inv is +-inf on the axes the ray
// runs parallel to (|d| < 1e-20, see bvh_trace) and finite on the others: a parallel axis gives
// -inf .. +inf when o is inside the slab and an empty interval when outside, and 0 * inf = NaN
// when o lies on a face plane, which counts as inside (docs/path-spec.md 3: faces included, so a
// ray lying in a face plane meets the primitives on that face ahead of it). Accepts entry
// distances up to t_limit inclusive (closest-hit ties are decided by prim reference). Returns
// the entry distance (>= 0), or -1 for a miss.
float slab_test(vec3 lo, vec3 hi, vec3 o, vec3 inv, bvec3 neg, float t_limit) {
  const float INF = uintBitsToFloat(0x7f800000u);
  vec3 tn = (mix(lo, hi, neg) - o) * inv;
  vec3 tf = (mix(hi, lo, neg) - o) * inv * SLAB_EXIT_SCALE;
  tn = mix(tn, vec3(-INF), isnan(tn));
  tf = mix(tf, vec3(INF), isnan(tf));
  float enter = max(max(tn.x, tn.y), max(tn.z, 0.0));
  float exit = min(min(tf.x, tf.y), min(tf.z, t_limit));
  return enter <= exit ? enter : -1.0;
}

// Orders two (key, item) pairs by key (a sorting-network step).
void bvh_order(inout float ka, inout uint ia, inout float kb, inout uint ib) {
  bool swap = kb < ka;
  float k = ka;
  uint i = ia;
  ka = swap ? kb : ka;
  ia = swap ? ib : ia;
  kb = swap ? k : kb;
  ib = swap ? i : ib;
}

// Entry distance of child c of a wide node against the ray (-1: missed or an empty slot):
// the box origin + q * scale per axis, q the child's bytes of qlo and qhi (docs/path-spec.md
// 3.1; the host rounds q outwards for this decoding with or without a fused multiply-add).
float bvh_child_test(uvec4 w0, uvec4 qlo, uvec4 qhi, uint child, uint c, vec3 o, vec3 inv,
                     bvec3 neg, float t_limit) {
  vec3 origin = uintBitsToFloat(w0.xyz);
  vec3 scale = uintBitsToFloat(uvec3(w0.w & 0xffu, (w0.w >> 8) & 0xffu, (w0.w >> 16) & 0xffu) << 23);
  vec3 lo = origin + vec3((qlo.xyz >> (8u * c)) & 0xffu) * scale;
  vec3 hi = origin + vec3((qhi.xyz >> (8u * c)) & 0xffu) * scale;
  float t = slab_test(lo, hi, o, inv, neg, t_limit);
  return child == INVALID_INDEX ? -1.0 : t;
}

// Stack-based traversal of the wide BVH (docs/path-spec.md 3.1): at a node all four child
// boxes are tested, the hit children sorted by entry distance, the nearest visited next and
// the others pushed far to near. Closest hit: the smallest t, on equal t the smaller prim
// reference, independent of traversal order (docs/path-spec.md section 3): every primitive is
// tested against the ray's own tmax and compared with the best hit afterwards. any_hit:
// returns at the first hit in (0, tmax) (shadow rays). Each step descends through wide nodes
// in a loop of its own down to a leaf, tests the leaf, then pops ("while-while" traversal,
// Aila and Laine 2009, "Understanding the Efficiency of Ray Traversal on GPUs"): the same
// nodes and leaves in the same order as one loop over both, but lavapipe runs every branch's
// code for all lanes, and in one loop a lane's every node step paid for a leaf and a pop.
Hit bvh_trace(Ray ray, bool any_hit) {
  Hit best = Hit(ray.tmax, 0.0, 0.0, INVALID_INDEX);
  // An axis with |d| < 1e-20 is one the ray runs parallel to: its inverse is +-inf (the sign of
  // d), which slab_test reads as "bounds nothing inside the slab, misses outside"; the other
  // axes' inverses are finite.
  const float INF = uintBitsToFloat(0x7f800000u);
  vec3 inv = mix(1.0 / ray.d,
                 vec3(copysign_pos(INF, ray.d.x), copysign_pos(INF, ray.d.y), copysign_pos(INF, ray.d.z)),
                 lessThan(abs(ray.d), vec3(1e-20)));
  bvec3 neg = lessThan(inv, vec3(0.0));
  RayTri rt = ray_tri(ray);
  // One slot more than the stack holds: a push not taken writes to the slot above the top,
  // which is this spare one when the stack is full.
  uint stack_item[BVH_WIDE_STACK + 1u];
  float stack_t[BVH_WIDE_STACK + 1u];
  int sp = 0;
  // A scene without primitives has no nodes (host/accel/bvh.h); its table is bound as a
  // 16-byte buffer, shorter than one node.
  uint item = bvh_word_count() < 4u ? INVALID_INDEX : 0u;
  const float FAR = uintBitsToFloat(0x7f800000u);
  // Each loop tests its end at the end of a pass: lavapipe runs a pass that any lane enters in
  // full, so a loop's closing test at the start of a pass cost a whole pass of it (for the
  // traversal: a node step, a primitive and a pop; docs/performance.md, seventh session).
  if (item != INVALID_INDEX) [[dont_unroll]] while (true) {
    // Wide nodes, down to a leaf or a node none of whose children the ray meets (item
    // INVALID_INDEX). A loop of its own: the lanes that descend do not run the leaf's code at
    // every level, as they would in one loop over nodes and leaves (lavapipe runs both sides
    // of every branch).
    if ((item & BVH_WIDE_LEAF) == 0u) [[dont_unroll]] while (true) {
      uvec4 w0 = bvh_word(4u * item);
      uvec4 qlo = bvh_word(4u * item + 1u);
      uvec4 qhi = bvh_word(4u * item + 2u);
      uvec4 ch = bvh_word(4u * item + 3u);
      float k0 = bvh_child_test(w0, qlo, qhi, ch.x, 0u, ray.o, inv, neg, best.t);
      float k1 = bvh_child_test(w0, qlo, qhi, ch.y, 1u, ray.o, inv, neg, best.t);
      float k2 = bvh_child_test(w0, qlo, qhi, ch.z, 2u, ray.o, inv, neg, best.t);
      float k3 = bvh_child_test(w0, qlo, qhi, ch.w, 3u, ray.o, inv, neg, best.t);
      k0 = k0 < 0.0 ? FAR : k0;
      k1 = k1 < 0.0 ? FAR : k1;
      k2 = k2 < 0.0 ? FAR : k2;
      k3 = k3 < 0.0 ? FAR : k3;
      uint i0 = ch.x, i1 = ch.y, i2 = ch.z, i3 = ch.w;
      bvh_order(k0, i0, k1, i1);
      bvh_order(k2, i2, k3, i3);
      bvh_order(k0, i0, k2, i2);
      bvh_order(k1, i1, k3, i3);
      bvh_order(k1, i1, k2, i2);
      // Push the hit children far to near. Each entry is written whether the push is taken or
      // not (an untaken one lands in the free slot above the top), so the stores are not under
      // a branch: lavapipe then stores every lane's value, where under a branch it loads and
      // stores back the old value of each lane that skips (docs/performance.md, fourteenth
      // session).
      stack_item[sp] = i3;
      stack_t[sp] = k3;
      sp += (k3 < FAR && sp < int(BVH_WIDE_STACK)) ? 1 : 0;
      stack_item[sp] = i2;
      stack_t[sp] = k2;
      sp += (k2 < FAR && sp < int(BVH_WIDE_STACK)) ? 1 : 0;
      stack_item[sp] = i1;
      stack_t[sp] = k1;
      sp += (k1 < FAR && sp < int(BVH_WIDE_STACK)) ? 1 : 0;
      item = k0 < FAR ? i0 : INVALID_INDEX;
      if (item == INVALID_INDEX || (item & BVH_WIDE_LEAF) != 0u) break;
    }
    if (item != INVALID_INDEX) {
      // A leaf over prim_refs[first, first + count), count >= 1.
      uint first = item & (BVH_WIDE_FIRST_LIMIT - 1u);
      uint end = first + ((item >> 26) & 31u) + 1u;
      uint k = first;
      [[dont_unroll]] while (true) {
        uint ref;
        vec2 b12;
        float t;
        if (LEAF_PRIMS != 0u) {
          // The positions in leaf order: three vec4 loads instead of the reference, the
          // triangle and three vertices (lavapipe loops over lanes for every load).
          vec4 q0 = leaf_prim(3u * k);
          ref = floatBitsToUint(q0.w);
          b12 = vec2(0.0);
          t = -1.0;
          if ((ref & PRIM_SPHERE_BIT) != 0u) {
            if (has_feature(FEATURE_SPHERES)) t = intersect_sphere(ray, ref & PRIM_INDEX_MASK);
          } else if (has_feature(FEATURE_TRIANGLES)) {
            t = intersect_triangle_at(ray, rt, q0.xyz, leaf_prim(3u * k + 1u).xyz,
                                      leaf_prim(3u * k + 2u).xyz, b12);
          }
        } else {
          ref = prim_refs[k];
          t = intersect_prim(ray, rt, ref, b12);
        }
        if (t > 0.0 && (t < best.t || (t == best.t && ref < best.prim))) {
          best = Hit(t, b12.x, b12.y, ref);
          if (any_hit) return best;
        }
        if (++k >= end) break;
      }
    }
    // Pop, skipping entries that start beyond the best hit so far.
    item = INVALID_INDEX;
    if (sp > 0) [[dont_unroll]] while (true) {
      --sp;
      if (stack_t[sp] <= best.t) {
        item = stack_item[sp];
        break;
      }
      if (sp <= 0) break;
    }
    if (item == INVALID_INDEX) break;
  }
  if (best.prim == INVALID_INDEX) best.t = -1.0;
  return best;
}

// Closest hit in (0, ray.tmax); a miss has prim INVALID_INDEX and t = -1.
Hit intersect_closest(Ray ray) { return bvh_trace(ray, false); }

// True if anything is hit in (0, ray.tmax) (shadow rays).
bool intersect_any(Ray ray) { return bvh_trace(ray, true).prim != INVALID_INDEX; }

#endif
