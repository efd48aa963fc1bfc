// Counter-based random numbers (docs/path-spec.md section 1). Needs bindings.glsl (seed).
#ifndef BASALT_RNG_GLSL
#define BASALT_RNG_GLSL

// Random dimensions of docs/path-spec.md section 1 (table "Dimensions"); dimension of slot
// k of bounce b is DIM_BOUNCE_BASE + DIM_BOUNCE_STRIDE * b + k.
const uint DIM_FILTER_X = 0u;
const uint DIM_FILTER_Y = 1u;
const uint DIM_LENS_X = 2u;
const uint DIM_LENS_Y = 3u;
const uint DIM_BOUNCE_BASE = 4u;
const uint DIM_BOUNCE_STRIDE = 16u;
const uint DIM_LIGHT_SELECT = 0u;
const uint DIM_LIGHT_U0 = 1u;
const uint DIM_LIGHT_U1 = 2u;
const uint DIM_BSDF_LOBE = 3u;
const uint DIM_BSDF_U0 = 4u;
const uint DIM_BSDF_U1 = 5u;
const uint DIM_ROULETTE = 6u;

// pcg4d hash: Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 9(3) 2020.
uvec4 pcg4d(uvec4 v) {
  v = v * 1664525u + 1013904223u;
  v.x += v.y * v.w;
  v.y += v.z * v.x;
  v.z += v.x * v.y;
  v.w += v.y * v.z;
  v ^= v >> 16u;
  v.x += v.y * v.w;
  v.y += v.z * v.x;
  v.z += v.x * v.y;
  v.w += v.y * v.z;
  return v;
}

// Uniform float in [0,1) for pixel (px, py), sample s and dimension dim, keyed by the scene
// seed Globals.image.w (docs/path-spec.md section 1; top 24 bits, exact in float).
float rng(uint px, uint py, uint s, uint dim) {
  uvec4 v = pcg4d(uvec4(px, py, s, dim ^ (globals.image.w * 0x9E3779B9u)));
  return float(v.x >> 8u) * (1.0 / 16777216.0);
}

#endif
