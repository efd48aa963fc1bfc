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
// Streams of docs/materials-spec.md section 5 (slots of bounce b, like the dimensions above).
const uint DIM_NEE_EVAL_STREAM = 7u;
const uint DIM_NEE_PDF_STREAM = 8u;
const uint DIM_SAMPLE_STREAM = 9u;
const uint DIM_PDF_STREAM = 10u;

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

// Base key of the random stream of pixel (px, py), sample s and dimension dim under scene seed
// seed (docs/materials-spec.md section 5): uvec4(px, py, s, dim ^ (seed * 0x9E3779B9u)).
uvec4 stream_key_seeded(uint px, uint py, uint s, uint dim, uint seed) {
  return uvec4(px, py, s, dim ^ (seed * 0x9E3779B9u));
}

// Base key of a stream under the scene seed Globals.image.w.
uvec4 stream_key(uint px, uint py, uint s, uint dim) {
  return stream_key_seeded(px, py, s, dim, globals.image.w);
}

// Element j of the stream with base key `key` (docs/materials-spec.md section 5):
// pcg4d(key + (0, 0, 0, (j + 1) * 0x01000193u)).x >> 8, times 2^-24.
float stream_at(uvec4 key, uint j) {
  uvec4 v = pcg4d(key + uvec4(0u, 0u, 0u, (j + 1u) * 0x01000193u));
  return float(v.x >> 8u) * (1.0 / 16777216.0);
}

#endif
