// Sample warps, the shading frame and MIS weights (docs/path-spec.md sections 2, 4, 6, 7).
#ifndef BASALT_SAMPLING_GLSL
#define BASALT_SAMPLING_GLSL

#include "math.glsl"
#include "trig.glsl"

// Shirley & Chiu 1997 concentric square-to-disk map, pbrt-v4 A.5.1
// SampleUniformDiskConcentric (docs/path-spec.md section 2 step 4).
// Signed radius of concentric_disk(u), without trigonometry, so that 1 - r^2 is the same on
// both renderers (docs/path-spec.md section 8).
float concentric_radius(vec2 u) {
  precise vec2 o = 2.0 * u - 1.0;
  return abs(o.x) > abs(o.y) ? o.x : o.y;
}

vec2 concentric_disk(vec2 u) {
  vec2 o = 2.0 * u - 1.0;
  if (o.x == 0.0 && o.y == 0.0) return vec2(0.0);
  float r, th;
  if (abs(o.x) > abs(o.y)) {
    r = o.x;
    th = PI_OVER_4 * (o.y / o.x);
  } else {
    r = o.y;
    th = PI_OVER_2 - PI_OVER_4 * (o.x / o.y);
  }
  return r * cos_sin_accurate(th);
}

// Uniform direction on the unit sphere, pbrt-v4 A.5.2 SampleUniformSphere
// (docs/path-spec.md section 6, "infinite uniform").
vec3 uniform_sphere(vec2 u) {
  float z = 1.0 - 2.0 * u.x;
  float r = sqrt(max(0.0, 1.0 - z * z));
  float phi = 2.0 * PI * u.y;
  vec2 cs = cos_sin_accurate(phi);
  return vec3(r * cs.x, r * cs.y, z);
}

// Barycentrics (b0, b1, b2) uniform over a triangle, pbrt-v4 A.5.5 SampleUniformTriangle
// (Heitz 2019 low-distortion map; docs/path-spec.md section 6, "triangle").
vec3 uniform_triangle(vec2 u) {
  float b0, b1;
  if (u.x < u.y) {
    b0 = u.x / 2.0;
    b1 = u.y - b0;
  } else {
    b1 = u.y / 2.0;
    b0 = u.x - b1;
  }
  return vec3(b0, b1, 1.0 - b0 - b1);
}

// Orthonormal tangents (t1, t2) of a unit normal n: Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited", JCGT 6(1), listing 3 (docs/path-spec.md section 4).
void duff_frame(vec3 n, out vec3 t1, out vec3 t2) {
  float s = copysign_pos(1.0, n.z);
  float a = -1.0 / (s + n.z);
  float b = n.x * n.y * a;
  t1 = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
  t2 = vec3(b, s + n.y * n.y * a, -n.y);
}

// Veach's power heuristic with beta = 2 (Veach 1997 9.2.4; pbrt-v4 13.4.1 PowerHeuristic):
// a^2 / (a^2 + b^2); 1 when a^2 overflows (covers "a infinite"); 0 when both are 0.
float power_heuristic(float a, float b) {
  float a2 = a * a;
  if (a2 > FLT_MAX) return 1.0;
  float s = a2 + b * b;
  return s > 0.0 ? a2 / s : 0.0;
}

// The balance heuristic a / (a + b) (Veach 1997 9.2.2); 1 when a is infinite, 0 when both are 0.
float balance_heuristic(float a, float b) {
  if (isinf(a)) return 1.0;
  precise float s = a + b;
  if (!(s > 0.0)) return 0.0;
  return a / s;
}


// pbrt-v4 SmoothStep (docs/path-spec.md section 6, "spot"): Hermite step from a to b, a hard
// step when a == b (GLSL smoothstep is undefined for a >= b, hence this twin).
float smooth_step(float x, float a, float b) {
  if (a == b) return x < a ? 0.0 : 1.0;
  float t = clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

#endif
