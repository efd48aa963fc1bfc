// Constants and small numeric helpers shared by every shader topic.
#ifndef BASALT_MATH_GLSL
#define BASALT_MATH_GLSL

const float PI = 3.14159265358979323846;
const float INV_PI = 0.31830988618379067154;
const float PI_OVER_2 = 1.57079632679489661923;
const float PI_OVER_4 = 0.78539816339744830962;
const float FLT_MAX = 3.402823466e+38;
const float FLT_MIN = 1.17549435e-38;  // smallest normal float
const float ONE_MINUS_EPSILON = 0.99999994;  // largest float below 1 (pbrt OneMinusEpsilon)

// sqrt clamped at 0 so that rounding below zero gives 0, not NaN (pbrt-v4 SafeSqrt).
float safe_sqrt(float x) { return sqrt(max(x, 0.0)); }

// Largest component of an rgb value or vector.
float max_component(vec3 v) { return max(v.x, max(v.y, v.z)); }

// True if some component is positive (pbrt-v4 "bool(SampledSpectrum)").
bool any_positive(vec3 v) { return v.x > 0.0 || v.y > 0.0 || v.z > 0.0; }

// dot(a, b) spelled out as (a.x b.x + a.y b.y) + a.z b.z (the CPU's order) and precise:
// glslang does not put NoContraction on OpDot, so a precise dot() could still become fmas.
float dot_exact(vec3 a, vec3 b) {
  precise float d = a.x * b.x + a.y * b.y + a.z * b.z;
  return d;
}

// v / |v|, or the zero vector when |v| is 0 (never NaN). Every normalisation in the shaders
// goes through here: v / sqrt(dot(v, v)) as docs/path-spec.md fixes it, rather than the
// driver's normalize() (which may use an approximate reciprocal square root), with an
// uncontracted dot product, so that it rounds like the CPU.
vec3 safe_normalize(vec3 v) {
  float l2 = dot_exact(v, v);
  return l2 > 0.0 ? v / sqrt(l2) : vec3(0.0);
}

// copysign(m, s) for m >= 0: m with the sign bit of s (also for s = -0).
float copysign_pos(float m, float s) {
  return uintBitsToFloat(floatBitsToUint(m) | (floatBitsToUint(s) & 0x80000000u));
}

#endif
