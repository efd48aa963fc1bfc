// Ray-primitive intersection and BVH traversal of the CPU reference
// (docs/path-spec.md section 3): the four-wide tree of cpu/wide_bvh.h (3.2), or the binary
// tree when the tables have none.
#include "cpu/intersect.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "cpu/wide_bvh.h"

namespace basalt::cpu {
namespace {

/// pbrt-v4 gamma(n) = n eps / (1 - n eps) with eps = 2^-24 (pbrt-v4 6.8.1).
constexpr float gamma_n(int n) {
  return (float(n) * 0x1p-24f) / (1.0f - float(n) * 0x1p-24f);
}
/// Far-plane scale of the slab test (pbrt-v4 6.1.2: tFar *= 1 + 2 gamma(3)).
constexpr float SLAB_FAR_SCALE = 1.0f + 2.0f * gamma_n(3);

/// pbrt-v4 MaxComponentIndex: index of the largest component (ties go to the later axis
/// exactly as pbrt-v4 writes the comparisons).
inline int max_component_index(glm::vec3 v) {
  return (v.x > v.y) ? ((v.x > v.z) ? 0 : 2) : ((v.y > v.z) ? 1 : 2);
}

/// Per-ray constants of the watertight triangle test (Woop et al. 2013, section 3): the axis
/// permutation (kz = pbrt-v4 MaxComponentIndex of |d|) and the shear. pbrt-v4 6.5.3 computes
/// them per triangle; the values are the same, so computing them once per ray is exact.
struct RayTri {
  glm::vec3 o;
  int kx, ky, kz;
  float sx, sy, sz;
  explicit RayTri(glm::vec3 origin, glm::vec3 d) : o(origin) {
    kz = max_component_index(glm::abs(d));
    kx = kz + 1;
    if (kx == 3) kx = 0;
    ky = kx + 1;
    if (ky == 3) ky = 0;
    sx = -d[kx] / d[kz];
    sy = -d[ky] / d[kz];
    sz = 1.0f / d[kz];
  }
};

/// Watertight triangle test (Woop et al. 2013; pbrt-v4 6.5.3) with no upper bound on t:
/// returns t > 0 and barycentrics, or t = -1. Edge functions are plain a*b - c*d (the spec's
/// "precise", no FMA): exact negation for the shared edge of two triangles keeps it watertight.
inline PrimHit triangle_hit(const RayTri& r, glm::vec3 p0, glm::vec3 p1, glm::vec3 p2) {
  PrimHit miss;
  // Translate the vertices to the ray origin, permute so that the largest |d| is along z.
  const glm::vec3 q0 = p0 - r.o, q1 = p1 - r.o, q2 = p2 - r.o;
  glm::vec3 p0t(q0[r.kx], q0[r.ky], q0[r.kz]);
  glm::vec3 p1t(q1[r.kx], q1[r.ky], q1[r.kz]);
  glm::vec3 p2t(q2[r.kx], q2[r.ky], q2[r.kz]);
  // Shear so that the ray direction is +z.
  const float sx = r.sx, sy = r.sy, sz = r.sz;
  p0t.x += sx * p0t.z;
  p0t.y += sy * p0t.z;
  p1t.x += sx * p1t.z;
  p1t.y += sy * p1t.z;
  p2t.x += sx * p2t.z;
  p2t.y += sy * p2t.z;
  // Edge functions.
  const float e0 = p1t.x * p2t.y - p1t.y * p2t.x;
  const float e1 = p2t.x * p0t.y - p2t.y * p0t.x;
  const float e2 = p0t.x * p1t.y - p0t.y * p1t.x;
  if ((e0 < 0 || e1 < 0 || e2 < 0) && (e0 > 0 || e1 > 0 || e2 > 0)) return miss;
  const float det = e0 + e1 + e2;
  if (det == 0) return miss;
  // Scaled distance; its sign must match det's for t > 0.
  p0t.z *= sz;
  p1t.z *= sz;
  p2t.z *= sz;
  const float t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
  if (det < 0 && t_scaled >= 0) return miss;
  if (det > 0 && t_scaled <= 0) return miss;
  const float inv_det = 1.0f / det;
  const float t = t_scaled * inv_det;
  if (!(t > 0.0f)) return miss;
  // Spec section 3: a triangle whose cross(p0 - p2, p1 - p2) is the zero vector misses.
  const glm::vec3 c = glm::cross(p0 - p2, p1 - p2);
  if (c.x == 0.0f && c.y == 0.0f && c.z == 0.0f) return miss;
  return PrimHit{t, e1 * inv_det, e2 * inv_det};
}

/// Robust quadratic ray-sphere test (pbrt-v4 6.2.2, in float and world space, spec section 3)
/// with no upper bound on t: returns the nearer positive root, or t = -1.
inline PrimHit sphere_hit(glm::vec3 o, glm::vec3 d, glm::vec3 center, float r) {
  PrimHit miss;
  const glm::vec3 f = o - center;
  const float a = glm::dot(d, d);
  if (!(a > 0.0f)) return miss;
  const float b = 2.0f * glm::dot(d, f);
  const float c = glm::dot(f, f) - r * r;
  // pbrt-v4 6.2.2: discriminant from the distance l of the closest approach point.
  const glm::vec3 v = f - (b / (2.0f * a)) * d;
  const float l = glm::length(v);
  const float disc = 4.0f * a * (r + l) * (r - l);
  if (disc < 0.0f) return miss;
  const float root = std::sqrt(disc);
  const float q = b < 0.0f ? -0.5f * (b - root) : -0.5f * (b + root);
  // q == 0 only for a tangent ray starting on the sphere: c / q is not a hit (inf or NaN).
  if (q == 0.0f) return miss;
  float t0 = q / a, t1 = c / q;
  if (t0 > t1) std::swap(t0, t1);
  const float t = t0 > 0.0f ? t0 : t1;
  if (!(t > 0.0f)) return miss;
  return PrimHit{t, 0.0f, 0.0f};
}

/// Ray data shared by all tests of one traversal.
struct RayBox {
  glm::vec3 o;
  glm::vec3 d;
  glm::vec3 inv;  // 1 / d with |d| < 1e-20 replaced by copysign(1e-20, d) (spec section 3)
  RayTri tri;
  bool parallel[3];           // |d| < 1e-20 along the axis: the slab test's inside rule
  bool any_parallel = false;
  explicit RayBox(const Ray& r) : o(r.o), d(r.d), tri(r.o, r.d) {
    for (int i = 0; i < 3; ++i) {
      parallel[i] = std::fabs(r.d[i]) < 1e-20f;
      any_parallel = any_parallel || parallel[i];
      const float di = parallel[i] ? std::copysign(1e-20f, r.d[i]) : r.d[i];
      inv[i] = 1.0f / di;
    }
  }
};

/// Primitive test by reference, no upper bound on t.
inline PrimHit prim_hit(const SceneTables& s, std::uint32_t ref, const RayBox& rb) {
  if (ref & gpu::PRIM_SPHERE_BIT) {
    const gpu::Sphere& sp = s.spheres[ref & gpu::PRIM_INDEX_MASK];
    return sphere_hit(rb.o, rb.d, glm::vec3(sp.center_radius), sp.center_radius.w);
  }
  const gpu::Triangle& tri = s.triangles[ref];
  return triangle_hit(rb.tri, glm::vec3(s.vertices[tri.v0].p_u), glm::vec3(s.vertices[tri.v1].p_u),
                      glm::vec3(s.vertices[tri.v2].p_u));
}

/// Slab test (Kay & Kajiya 1986; pbrt-v4 6.1.2 with tFar scaled by 1 + 2 gamma(3)).
/// Inclusive at tlimit so that equal-t candidates survive for the tie break, and inclusive at an
/// exit distance of 0 (as pbrt-v4's t0 > t1 test and the shader's enter <= exit). An axis the
/// ray runs parallel to (|d| < 1e-20) bounds nothing when the origin lies in the slab, faces
/// included, and misses the box otherwise (spec section 3): with the finite 1e-20 stand-in, a
/// ray lying in a face plane would leave the slab at t = 0 and miss the primitives on that
/// face ahead of it (pbrt-v4's 0 * inf = NaN drops the axis instead).
inline bool slab_box(glm::vec3 lo, glm::vec3 hi, const RayBox& rb, float tlimit, float& tnear) {
  const glm::vec3 ta = (lo - rb.o) * rb.inv;
  const glm::vec3 tb = (hi - rb.o) * rb.inv;
  glm::vec3 tmin = glm::min(ta, tb), tmax = glm::max(ta, tb);
  if (rb.any_parallel)
    for (int i = 0; i < 3; ++i) {
      if (!rb.parallel[i]) continue;
      if (!(rb.o[i] >= lo[i] && rb.o[i] <= hi[i])) return false;
      tmin[i] = -std::numeric_limits<float>::infinity();
      tmax[i] = std::numeric_limits<float>::infinity();
    }
  const float t0 = std::max(tmin.x, std::max(tmin.y, tmin.z));
  const float t1 = std::min(tmax.x, std::min(tmax.y, tmax.z)) * SLAB_FAR_SCALE;
  tnear = t0;
  return t0 <= t1 && t0 <= tlimit && t1 >= 0.0f;
}

/// slab_box of a binary node.
inline bool slab(const gpu::BvhNode& n, const RayBox& rb, float tlimit, float& tnear) {
  return slab_box(n.lo, n.hi, rb, tlimit, tnear);
}

constexpr int STACK_SIZE = 64;

/// State of a closest-hit traversal: the best hit so far.
struct ClosestState {
  float tmax;  // the ray's tMax: hits must have t < tmax
  float best_t;
  std::uint32_t best_ref = gpu::INVALID_INDEX;
  float b1 = 0, b2 = 0;
  /// Keeps hit (t, b1, b2) of primitive reference \p ref if it is the closest so far. Spec
  /// section 3: 0 < t < tmax; smallest t, then the smaller primitive reference.
  void offer(std::uint32_t ref, float t, float hb1, float hb2) {
    if (t > 0.0f && t < tmax && (t < best_t || (t == best_t && ref < best_ref))) {
      best_t = t;
      best_ref = ref;
      b1 = hb1;
      b2 = hb2;
    }
  }
};

/// The primitives prim_refs[first, first + count) offered to \p st one by one.
inline void closest_leaf(const SceneTables& s, const RayBox& rb, std::uint32_t first,
                         std::uint32_t count, ClosestState& st) {
  for (std::uint32_t i = first; i < first + count; ++i) {
    const PrimHit h = prim_hit(s, s.prim_refs[i], rb);
    st.offer(s.prim_refs[i], h.t, h.b1, h.b2);
  }
}

/// True if any of prim_refs[first, first + count) is hit at 0 < t < tmax.
inline bool any_leaf(const SceneTables& s, const RayBox& rb, std::uint32_t first,
                     std::uint32_t count, float tmax) {
  for (std::uint32_t i = first; i < first + count; ++i) {
    const PrimHit h = prim_hit(s, s.prim_refs[i], rb);
    if (h.t > 0.0f && h.t < tmax) return true;
  }
  return false;
}

/// Closest-hit traversal of the subtree at root (whose box is already known to be hit):
/// stack based, nearer child first; recursion only when the fixed stack would overflow.
void closest_from(const SceneTables& s, const Ray& ray, const RayBox& rb, std::uint32_t root,
                  ClosestState& st) {
  struct Entry {
    std::uint32_t node;
    float t;
  };
  Entry stack[STACK_SIZE];
  int sp = 0;
  std::uint32_t node = root;
  for (;;) {
    const gpu::BvhNode& n = s.nodes[node];
    bool descend = false;
    if (n.b == 0) {
      std::uint32_t c0 = n.a, c1 = n.a + 1;
      float t0, t1;
      const bool h0 = slab(s.nodes[c0], rb, st.best_t, t0);
      const bool h1 = slab(s.nodes[c1], rb, st.best_t, t1);
      if (h0 && h1) {
        if (t1 < t0) {
          std::swap(c0, c1);
          std::swap(t0, t1);
        }
        if (sp < STACK_SIZE) {
          stack[sp++] = Entry{c1, t1};
        } else {
          closest_from(s, ray, rb, c1, st);
        }
        node = c0;
        descend = true;
      } else if (h0 || h1) {
        node = h0 ? c0 : c1;
        descend = true;
      }
    } else {
      closest_leaf(s, rb, n.a, n.b, st);
    }
    if (descend) continue;
    // Pop the next subtree whose entry distance can still hold the closest hit.
    for (;;) {
      if (sp == 0) return;
      const Entry e = stack[--sp];
      if (e.t <= st.best_t) {
        node = e.node;
        break;
      }
    }
  }
}

/// Any-hit traversal of the subtree at root: true at the first hit with 0 < t < tmax.
bool any_from(const SceneTables& s, const Ray& ray, const RayBox& rb, std::uint32_t root) {
  std::uint32_t stack[STACK_SIZE];
  int sp = 0;
  std::uint32_t node = root;
  for (;;) {
    const gpu::BvhNode& n = s.nodes[node];
    bool descend = false;
    if (n.b == 0) {
      const std::uint32_t c0 = n.a, c1 = n.a + 1;
      float t0, t1;
      const bool h0 = slab(s.nodes[c0], rb, ray.tmax, t0);
      const bool h1 = slab(s.nodes[c1], rb, ray.tmax, t1);
      if (h0 && h1) {
        if (sp < STACK_SIZE) {
          stack[sp++] = c1;
        } else if (any_from(s, ray, rb, c1)) {
          return true;
        }
        node = c0;
        descend = true;
      } else if (h0 || h1) {
        node = h0 ? c0 : c1;
        descend = true;
      }
    } else {
      if (any_leaf(s, rb, n.a, n.b, ray.tmax)) return true;
    }
    if (descend) continue;
    if (sp == 0) return false;
    node = stack[--sp];
  }
}

// ---- the four-wide tree (cpu/wide_bvh.h) ----------------------------------------------------

typedef float V4f __attribute__((vector_size(16)));
typedef std::int32_t V4i __attribute__((vector_size(16)));

/// Bit i set where lane i of \p m is true (all bits set).
inline unsigned lane_mask(V4i m) {
#if defined(__SSE2__)
  return unsigned(_mm_movemask_ps(_mm_castsi128_ps(__m128i(m))));
#else
  return unsigned(m[0] & 1) | unsigned(m[1] & 2) | unsigned(m[2] & 4) | unsigned(m[3] & 8);
#endif
}

/// The ray's origin and reciprocal direction, each component in all four lanes.
struct RayBox4 {
  V4f o[3], inv[3];
  explicit RayBox4(const RayBox& rb) {
    for (int k = 0; k < 3; ++k) {
      o[k] = V4f{rb.o[k], rb.o[k], rb.o[k], rb.o[k]};
      inv[k] = V4f{rb.inv[k], rb.inv[k], rb.inv[k], rb.inv[k]};
    }
  }
};

/// slab_box on the four slots of \p n at once: the same operations in the same order per
/// lane (glm::min / max and std::min / max written as their comparisons), so each lane's
/// answer is slab_box's bit for bit. Returns the mask of slots entered, their entry distances
/// in tnear. Rays parallel to an axis take slab_box per slot (its inside rule).
inline unsigned slab4(const WideNode& n, const RayBox& rb, const RayBox4& r4, float tlimit,
                      float tnear[4]) {
  if (rb.any_parallel) {
    unsigned m = 0;
    for (int i = 0; i < 4; ++i)
      if (slab_box(glm::vec3(n.lo[0][i], n.lo[1][i], n.lo[2][i]),
                   glm::vec3(n.hi[0][i], n.hi[1][i], n.hi[2][i]), rb, tlimit, tnear[i]))
        m |= 1u << i;
    return m;
  }
  V4f tmin[3], tmax[3];
  for (int k = 0; k < 3; ++k) {
    V4f lo, hi;
    __builtin_memcpy(&lo, n.lo[k], sizeof lo);
    __builtin_memcpy(&hi, n.hi[k], sizeof hi);
    const V4f ta = (lo - r4.o[k]) * r4.inv[k];
    const V4f tb = (hi - r4.o[k]) * r4.inv[k];
    tmin[k] = (tb < ta) ? tb : ta;  // glm::min(ta, tb)
    tmax[k] = (ta < tb) ? tb : ta;  // glm::max(ta, tb)
  }
  const V4f min_yz = (tmin[1] < tmin[2]) ? tmin[2] : tmin[1];  // std::max(y, z)
  const V4f t0 = (tmin[0] < min_yz) ? min_yz : tmin[0];       // std::max(x, .)
  const V4f max_yz = (tmax[2] < tmax[1]) ? tmax[2] : tmax[1];  // std::min(y, z)
  const V4f far = V4f{SLAB_FAR_SCALE, SLAB_FAR_SCALE, SLAB_FAR_SCALE, SLAB_FAR_SCALE};
  const V4f t1 = ((max_yz < tmax[0]) ? max_yz : tmax[0]) * far;  // std::min(x, .)
  const V4f limit = V4f{tlimit, tlimit, tlimit, tlimit};
  const V4f zero = V4f{0.0f, 0.0f, 0.0f, 0.0f};
  __builtin_memcpy(tnear, &t0, sizeof t0);
  return lane_mask((t0 <= t1) & (t0 <= limit) & (t1 >= zero));
}

/// The ray's constants of the triangle test (RayTri) in four lanes.
struct RayTri4 {
  int kx, ky, kz;
  V4f o[3];
  V4f sx, sy, sz;
  explicit RayTri4(const RayTri& r) : kx(r.kx), ky(r.ky), kz(r.kz) {
    for (int k = 0; k < 3; ++k) o[k] = V4f{r.o[k], r.o[k], r.o[k], r.o[k]};
    sx = V4f{r.sx, r.sx, r.sx, r.sx};
    sy = V4f{r.sy, r.sy, r.sy, r.sy};
    sz = V4f{r.sz, r.sz, r.sz, r.sz};
  }
};

/// triangle_hit on the four lanes of \p pk: each lane's operations are triangle_hit's, in its
/// order and without contraction, so t and the barycentrics are its bits. Returns the mask of
/// lanes hit (t > 0, no upper bound); unused lanes (NaN corners) miss.
inline unsigned triangle_hit4(const TriPacket& pk, const RayTri4& r, V4f& t, V4f& b1, V4f& b2) {
  V4f p[3][3];  // corner, axis
  for (int c = 0; c < 3; ++c)
    for (int a = 0; a < 3; ++a) __builtin_memcpy(&p[c][a], pk.p[c][a], sizeof(V4f));
  // Translate to the ray origin, permute (largest |d| along z), shear.
  V4f x[3], y[3], z[3];
  for (int c = 0; c < 3; ++c) {
    x[c] = p[c][r.kx] - r.o[r.kx];
    y[c] = p[c][r.ky] - r.o[r.ky];
    z[c] = p[c][r.kz] - r.o[r.kz];
    x[c] = x[c] + r.sx * z[c];
    y[c] = y[c] + r.sy * z[c];
  }
  const V4f zero = V4f{0.0f, 0.0f, 0.0f, 0.0f};
  const V4f e0 = x[1] * y[2] - y[1] * x[2];
  const V4f e1 = x[2] * y[0] - y[2] * x[0];
  const V4f e2 = x[0] * y[1] - y[0] * x[1];
  const V4i neg = (e0 < zero) | (e1 < zero) | (e2 < zero);
  const V4i pos = (e0 > zero) | (e1 > zero) | (e2 > zero);
  const V4f det = e0 + e1 + e2;
  const V4f ts = e0 * (z[0] * r.sz) + e1 * (z[1] * r.sz) + e2 * (z[2] * r.sz);
  const V4f one = V4f{1.0f, 1.0f, 1.0f, 1.0f};
  const V4f inv_det = one / det;
  t = ts * inv_det;
  b1 = e1 * inv_det;
  b2 = e2 * inv_det;
  // cross(p0 - p2, p1 - p2) == 0: a degenerate triangle misses (as glm::cross computes it).
  const V4f ux = p[0][0] - p[2][0], uy = p[0][1] - p[2][1], uz = p[0][2] - p[2][2];
  const V4f vx = p[1][0] - p[2][0], vy = p[1][1] - p[2][1], vz = p[1][2] - p[2][2];
  const V4f cx = uy * vz - vy * uz, cy = uz * vx - vz * ux, cz = ux * vy - vx * uy;
  const V4i degenerate = (cx == zero) & (cy == zero) & (cz == zero);
  const V4i miss = (neg & pos) | (det == zero) | ((det < zero) & (ts >= zero)) |
                   ((det > zero) & (ts <= zero)) | degenerate;
  return lane_mask(~miss & (t > zero));
}

/// Closest-hit traversal of the four-wide tree: the slots entered, nearest first.
void closest_wide(const SceneTables& s, const WideBvh& w, const RayBox& rb, ClosestState& st) {
  struct Entry {
    std::uint32_t child, count;  // as WideNode::child / count
    float t;
  };
  // A wide level pushes at most three entries; build_cpu_wide_bvh bounds the depth.
  Entry stack[3 * kWideMaxDepth + 1];
  int sp = 0;
  const RayBox4 r4(rb);
  const RayTri4 r4t(rb.tri);
  Entry cur{0, 0, 0.0f};
  for (;;) {
    if (cur.count == 0) {
      const WideNode& n = w.nodes[cur.child];
      float tn[4];
      unsigned m = slab4(n, rb, r4, st.best_t, tn);
      if (m != 0) {
        // Entered slots by entry distance (insertion sort; ties keep the slot order).
        Entry e[4];
        int k = 0;
        for (; m != 0; m &= m - 1) {
          const int i = __builtin_ctz(m);
          Entry x{n.child[i], n.count[i], tn[i]};
          int j = k++;
          for (; j > 0 && x.t < e[j - 1].t; --j) e[j] = e[j - 1];
          e[j] = x;
        }
        for (int j = k - 1; j > 0; --j) stack[sp++] = e[j];
        cur = e[0];
        continue;
      }
    } else if (cur.count & kWidePacketLeaf) {
      const std::uint32_t end = cur.child + (cur.count & ~kWidePacketLeaf);
      for (std::uint32_t k = cur.child; k < end; ++k) {
        const TriPacket& pk = w.packets[k];
        V4f t, b1, b2;
        for (unsigned m = triangle_hit4(pk, r4t, t, b1, b2); m != 0; m &= m - 1) {
          const int i = __builtin_ctz(m);
          st.offer(pk.ref[i], t[i], b1[i], b2[i]);
        }
      }
    } else {
      closest_leaf(s, rb, cur.child, cur.count, st);
    }
    // Pop the next slot whose entry distance can still hold the closest hit.
    for (;;) {
      if (sp == 0) return;
      cur = stack[--sp];
      if (cur.t <= st.best_t) break;
    }
  }
}

/// Any-hit traversal of the four-wide tree: true at the first hit with 0 < t < tmax.
bool any_wide(const SceneTables& s, const WideBvh& w, const Ray& ray, const RayBox& rb) {
  struct Entry {
    std::uint32_t child, count;
  };
  Entry stack[3 * kWideMaxDepth + 1];
  int sp = 0;
  const RayBox4 r4(rb);
  const RayTri4 r4t(rb.tri);
  Entry cur{0, 0};
  for (;;) {
    if (cur.count == 0) {
      const WideNode& n = w.nodes[cur.child];
      float tn[4];
      unsigned m = slab4(n, rb, r4, ray.tmax, tn);
      if (m != 0) {
        const int first = __builtin_ctz(m);
        for (m &= m - 1; m != 0; m &= m - 1) {
          const int i = __builtin_ctz(m);
          stack[sp++] = Entry{n.child[i], n.count[i]};
        }
        cur = Entry{n.child[first], n.count[first]};
        continue;
      }
    } else if (cur.count & kWidePacketLeaf) {
      const std::uint32_t end = cur.child + (cur.count & ~kWidePacketLeaf);
      for (std::uint32_t k = cur.child; k < end; ++k) {
        V4f t, b1, b2;
        const V4f tmax = V4f{ray.tmax, ray.tmax, ray.tmax, ray.tmax};
        if (triangle_hit4(w.packets[k], r4t, t, b1, b2) & lane_mask(t < tmax)) return true;
      }
    } else {
      if (any_leaf(s, rb, cur.child, cur.count, ray.tmax)) return true;
    }
    if (sp == 0) return false;
    cur = stack[--sp];
  }
}

/// The CPU reference's wide tree of \p scene when it was built from the present node array.
inline const WideBvh* wide_of(const SceneTables& scene) {
  const WideBvh* w = scene.cpu_wide.get();
  return w && w->source_nodes == scene.nodes.size() ? w : nullptr;
}

}  // namespace

PrimHit intersect_triangle(glm::vec3 o, glm::vec3 d, float tmax, glm::vec3 p0, glm::vec3 p1,
                           glm::vec3 p2) {
  PrimHit h = triangle_hit(RayTri(o, d), p0, p1, p2);
  if (!(h.t < tmax)) return PrimHit{};
  return h;
}

PrimHit intersect_sphere(glm::vec3 o, glm::vec3 d, float tmax, glm::vec3 center, float radius) {
  PrimHit h = sphere_hit(o, d, center, radius);
  if (!(h.t < tmax)) return PrimHit{};
  return h;
}

PrimHit intersect_prim(const SceneTables& scene, std::uint32_t ref, glm::vec3 o, glm::vec3 d,
                       float tmax) {
  PrimHit h = prim_hit(scene, ref, RayBox(Ray{o, d, tmax}));
  if (!(h.t > 0.0f && h.t < tmax)) return PrimHit{};
  return h;
}

Hit intersect_closest(const SceneTables& scene, const Ray& ray) {
  Hit hit;
  if (scene.nodes.empty()) return hit;
  const RayBox rb(ray);
  float tnear;
  if (!slab(scene.nodes[0], rb, ray.tmax, tnear)) return hit;
  ClosestState st{ray.tmax, ray.tmax};
  if (const WideBvh* w = wide_of(scene)) {
    closest_wide(scene, *w, rb, st);
  } else {
    closest_from(scene, ray, rb, 0, st);
  }
  if (st.best_ref == gpu::INVALID_INDEX) return hit;
  hit.t = st.best_t;
  hit.prim = st.best_ref;
  hit.b1 = st.b1;
  hit.b2 = st.b2;
  return hit;
}

bool intersect_any(const SceneTables& scene, const Ray& ray) {
  if (scene.nodes.empty()) return false;
  const RayBox rb(ray);
  float tnear;
  if (!slab(scene.nodes[0], rb, ray.tmax, tnear)) return false;
  if (const WideBvh* w = wide_of(scene)) return any_wide(scene, *w, ray, rb);
  return any_from(scene, ray, rb, 0);
}

}  // namespace basalt::cpu
