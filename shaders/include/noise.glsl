// pbrt-v4's Perlin noise and its sums (docs/textures-spec.md; pbrt-v4 src/pbrt/util/noise.cpp,
// Perlin 2002 "Improving Noise"); the CPU twin is host/cpu/noise.cpp. Needs bindings.glsl.
#ifndef BASALT_NOISE_GLSL
#define BASALT_NOISE_GLSL

#include "math.glsl"
#include "trig.glsl"

// Permutation entry i of the 512-entry table in tex_data.
int noise_perm(int i) { return int(tex_data_at(globals.tex_tables.x + uint(i))); }

// Perlin's gradient of hash h at offset (dx, dy, dz) (pbrt-v4 Grad).
float noise_grad(int x, int y, int z, float dx, float dy, float dz) {
  int h = noise_perm(noise_perm(noise_perm(x) + y) + z) & 15;
  float u = (h < 8 || h == 12 || h == 13) ? dx : dy;
  float v = (h < 4 || h == 12 || h == 13) ? dy : dz;
  precise float g = ((h & 1) != 0 ? -u : u) + ((h & 2) != 0 ? -v : v);
  return g;
}

// Quintic fade 6t^5 - 15t^4 + 10t^3, powers rounded as pbrt-v4's Pow<n>.
float noise_fade(float t) {
  precise float t2 = t * t;
  precise float t3 = t2 * t;
  precise float t4 = t2 * t2;
  precise float t5 = t4 * t;
  precise float w = 6.0 * t5 - 15.0 * t4 + 10.0 * t3;
  return w;
}

// pbrt-v4 Lerp(t, a, b) = (1 - t) a + t b, uncontracted.
float noise_lerp(float t, float a, float b) {
  precise float r = (1.0 - t) * a + t * b;
  return r;
}

// fmod(x, 2^30) of pbrt-v4 Noise with exact operations (as the CPU).
float noise_wrap30(float x) {
  const float k = 1073741824.0;
  precise float r = abs(x) < k ? x : x - k * trunc(x / k);
  return r;
}

// Lattice cell and offset of one coordinate given as hi + lo (lo = 0: pbrt-v4's fp32 lookup):
// d = (hi - floor(hi)) + lo, cell = floor(hi) (wrapped as pbrt-v4's fmod(x, 2^30), exact) +
// floor(d), offset = d - floor(d) (docs/textures-spec.md 2.1).
void noise_cell(float hi, float lo, out int cell, out float offset) {
  float f = floor(hi);
  precise float d = (hi - f) + lo;
  // lo is up to half an ulp of hi (several cells beyond 2^24): move whole cells over as an
  // integer (f + floor(d) may not be a float).
  float fd = floor(d);
  d -= fd;
  cell = (int(noise_wrap30(f)) + int(fd)) & 255;
  offset = d;
}

// Improved Perlin noise at the point hi + lo (pbrt-v4 Noise for lo = 0).
float perlin_noise_hl(vec3 hi, vec3 lo) {
  int ix, iy, iz;
  float dx, dy, dz;
  noise_cell(hi.x, lo.x, ix, dx);
  noise_cell(hi.y, lo.y, iy, dy);
  noise_cell(hi.z, lo.z, iz, dz);
  precise float dx1 = dx - 1.0;
  precise float dy1 = dy - 1.0;
  precise float dz1 = dz - 1.0;
  float w000 = noise_grad(ix, iy, iz, dx, dy, dz);
  float w100 = noise_grad(ix + 1, iy, iz, dx1, dy, dz);
  float w010 = noise_grad(ix, iy + 1, iz, dx, dy1, dz);
  float w110 = noise_grad(ix + 1, iy + 1, iz, dx1, dy1, dz);
  float w001 = noise_grad(ix, iy, iz + 1, dx, dy, dz1);
  float w101 = noise_grad(ix + 1, iy, iz + 1, dx1, dy, dz1);
  float w011 = noise_grad(ix, iy + 1, iz + 1, dx, dy1, dz1);
  float w111 = noise_grad(ix + 1, iy + 1, iz + 1, dx1, dy1, dz1);
  float wx = noise_fade(dx), wy = noise_fade(dy), wz = noise_fade(dz);
  float x00 = noise_lerp(wx, w000, w100), x10 = noise_lerp(wx, w010, w110);
  float x01 = noise_lerp(wx, w001, w101), x11 = noise_lerp(wx, w011, w111);
  float y0 = noise_lerp(wy, x00, x10), y1 = noise_lerp(wy, x01, x11);
  return noise_lerp(wz, y0, y1);
}

// pbrt-v4 Noise(p): 0 at lattice points, |n| <= 1.
float perlin_noise(vec3 p) { return perlin_noise_hl(p, vec3(0.0)); }

// Dekker's exact product without fma, per component: lambda p = hi + lo exactly (Veltkamp's
// split of each factor into 12-bit halves; T. J. Dekker, "A floating-point technique for
// extending the available precision", 1971).
void noise_two_prod(float lambda, vec3 p, out vec3 hi, out vec3 lo) {
  precise float c = 4097.0 * lambda;
  precise float ah = c - (c - lambda);
  precise float al = lambda - ah;
  precise vec3 cp = 4097.0 * p;
  precise vec3 bh = cp - (cp - p);
  precise vec3 bl = p - bh;
  precise vec3 prod = lambda * p;
  precise vec3 e = (((ah * bh - prod) + ah * bl) + al * bh) + al * bl;
  hi = prod;
  lo = e;
}

// True if noise lookups use the split precision mode in this pipeline (FEATURE2_NOISE_SPLIT,
// TEXOPT_NOISE_SPLIT).
bool noise_split() {
  return has_feature2(FEATURE2_NOISE_SPLIT) &&
         (globals.texture_opts.x & TEXOPT_NOISE_SPLIT) != 0u;
}

// Octaves the footprint resolves (pbrt-v4 FBm / Turbulence): clamp(-1 - log2(len2) / 2, 0,
// max) with the octave cap of Globals.texture_opts.y applied to max (inout).
float noise_octaves(vec3 dpdx, vec3 dpdy, inout int max_octaves) {
  uint cap = globals.texture_opts.y;
  if (cap > 0u) max_octaves = min(max_octaves, int(cap));
  float len2 = max(dot_exact(dpdx, dpdx), dot_exact(dpdy, dpdy));
  if (!(len2 > 0.0)) return float(max_octaves);  // log2(0) = -inf
  if (isinf(len2)) return 0.0;
  precise float l2 = log_accurate(len2) * 1.44269504088896341;
  precise float n = -1.0 - l2 / 2.0;
  return clamp(n, 0.0, float(max_octaves));
}

// pbrt-v4 SmoothStep(x, a, b).
float noise_smooth_step(float x, float a, float b) {
  precise float t = clamp((x - a) / (b - a), 0.0, 1.0);
  precise float r = t * t * (3.0 - 2.0 * t);
  return r;
}

// pbrt-v4 FBm (turb false) or Turbulence (turb true) in one routine, so that a shader that
// needs both holds one copy (lavapipe inlines every call site): octaves at frequencies 1.99^i
// with weights omega^i, the last faded in; turbulence sums |noise| and adds 0.2 times the
// weight of every octave the footprint leaves out (docs/textures-spec.md section 8).
float noise_sum(vec3 p, vec3 dpdx, vec3 dpdy, float omega, int max_octaves, bool turb,
                bool split) {
  float n = noise_octaves(dpdx, dpdy, max_octaves);
  int n_int = int(floor(n));
  precise float sum = 0.0;
  precise float lambda = 1.0;
  precise float o = 1.0;
  precise float partial = n - float(n_int);
  float fade = noise_smooth_step(partial, 0.3, 0.7);
  // Octave i < n_int in full, then the partial one (i == n_int): one noise call site.
  {  // the end tested at the end of a pass (a for loop's closing test costs lavapipe a pass)
    int i = 0;
    if (i <= n_int) [[dont_unroll]] while (true) {
      // Lookup at lambda p: pbrt-v4's fp32 product, or the exact product as a float pair.
      precise vec3 hi = lambda * p;
      vec3 lo = vec3(0.0);
      if (split) noise_two_prod(lambda, p, hi, lo);
      float v = perlin_noise_hl(hi, lo);
      if (turb) v = abs(v);
      if (i < n_int) {
        sum += o * v;
        lambda *= 1.99;  // pbrt-v4's octave step
        o *= omega;
      } else if (turb) {
        sum += o * noise_lerp(fade, 0.2, v);
      } else {
        sum += o * fade * v;
      }
      if (++i > n_int) break;
    }
  }
  if (turb) {
    {  // the end tested at the end of a pass (a for loop's closing test costs lavapipe a pass)
      int i = n_int;
      if (i < max_octaves) [[dont_unroll]] while (true) {
        sum += o * 0.2;
        o *= omega;
        if (++i >= max_octaves) break;
      }
    }
  }
  return sum;
}

// pbrt-v4 FBm (util/noise.cpp).
float fbm(vec3 p, vec3 dpdx, vec3 dpdy, float omega, int max_octaves) {
  return noise_sum(p, dpdx, dpdy, omega, max_octaves, false, noise_split());
}

// pbrt-v4 Turbulence (util/noise.cpp).
float turbulence(vec3 p, vec3 dpdx, vec3 dpdy, float omega, int max_octaves) {
  return noise_sum(p, dpdx, dpdy, omega, max_octaves, true, noise_split());
}

// ---- Shirley's solid noise (docs/textures-spec.md section 7; seed 002 11.1.3, 11.1.4) ------
// Tables at tex_data_at(globals.tex_tables.z): G (256 unit vectors, 768 floats x0 y0 z0 x1 ...),
// then P (256 floats holding the permutation).

// int(v) of docs/textures-spec.md 4.2 / 7: v clamped to [-2^30, 2^30], then truncated.
int shirley_int(float v) { return int(clamp(v, -1073741824.0, 1073741824.0)); }

// phi(i) = P[i mod 256], mod non-negative: i & 255 is ((i % 256) + 256) % 256 for every int.
int shirley_perm(int i) { return int(tex_data_at(globals.tex_tables.z + 768u + uint(i & 255))); }

// w(t) = 2|t|^3 - 3|t|^2 + 1 = (2 a3 - 3 a2) + 1 for a = |t| < 1, else 0.
float shirley_weight(float t) {
  float a = abs(t);
  precise float a2 = a * a;
  precise float a3 = a2 * a;
  precise float w = (2.0 * a3 - 3.0 * a2) + 1.0;
  return a < 1.0 ? w : 0.0;
}

// Shirley's solid noise n(p): the eight lattice corners in the order di, dj, dk (di outer),
// summed left to right from 0, each ((w(u) w(v)) w(t)) ((Gx u + Gy v) + Gz t). One loop.
// 0 when a component of p is not finite.
float shirley_noise(vec3 p) {
  if (any(isnan(p)) || any(isinf(p))) return 0.0;
  int ix = shirley_int(floor(p.x)), iy = shirley_int(floor(p.y)), iz = shirley_int(floor(p.z));
  uint g0 = globals.tex_tables.z;
  precise float sum = 0.0;
  [[dont_unroll]] for (int c = 0; c < 8; ++c) {
    int i = ix + (c >> 2), j = iy + ((c >> 1) & 1), k = iz + (c & 1);
    precise float u = p.x - float(i);
    precise float v = p.y - float(j);
    precise float t = p.z - float(k);
    uint g = g0 + 3u * uint(shirley_perm(i + shirley_perm(j + shirley_perm(k))));
    precise float d = (tex_data_at(g) * u + tex_data_at(g + 1u) * v) + tex_data_at(g + 2u) * t;
    precise float term = ((shirley_weight(u) * shirley_weight(v)) * shirley_weight(t)) * d;
    sum += term;
  }
  return sum;
}

// sum for i = 0 .. octaves - 1 of n(f p) / f, f = 2^i (doubled each octave, f p one product
// per component), |n| when turb. The one call site of shirley_noise: plain noise is
// shirley_noise_sum(p, 1, false) (= n(p): 1 p, / 1 and 0 + are exact).
float shirley_noise_sum(vec3 p, int octaves, bool turb) {
  precise float sum = 0.0;
  precise float f = 1.0;
  {  // the end tested at the end of a pass (a for loop's closing test costs lavapipe a pass)
    int i = 0;
    if (i < octaves) [[dont_unroll]] while (true) {
      precise vec3 q = f * p;
      float n = shirley_noise(q);
      precise float term = (turb ? abs(n) : n) / f;
      sum += term;
      f *= 2.0;
      if (++i >= octaves) break;
    }
  }
  return sum;
}

// Shirley's turbulence nt(p) = sum for i < octaves of |n(2^i p)| / 2^i.
float shirley_turbulence(vec3 p, int octaves) { return shirley_noise_sum(p, octaves, true); }

// Shirley's vector noise n_v(p) (docs/bump-spec.md 9): the lattice and weights of
// shirley_noise with the gradient G itself in place of its dot product, corners c = 0..7,
// sum = sum + ((w(u) w(v)) w(t)) G per component from 0. (0, 0, 0) when p is not finite.
vec3 vector_noise(vec3 p) {
  if (any(isnan(p)) || any(isinf(p))) return vec3(0.0);
  int ix = shirley_int(floor(p.x)), iy = shirley_int(floor(p.y)), iz = shirley_int(floor(p.z));
  uint g0 = globals.tex_tables.z;
  precise vec3 sum = vec3(0.0);
  [[dont_unroll]] for (int c = 0; c < 8; ++c) {
    int i = ix + (c >> 2), j = iy + ((c >> 1) & 1), k = iz + (c & 1);
    precise float u = p.x - float(i);
    precise float v = p.y - float(j);
    precise float t = p.z - float(k);
    uint g = g0 + 3u * uint(shirley_perm(i + shirley_perm(j + shirley_perm(k))));
    vec3 grad = vec3(tex_data_at(g), tex_data_at(g + 1u), tex_data_at(g + 2u));
    precise float w = (shirley_weight(u) * shirley_weight(v)) * shirley_weight(t);
    precise vec3 term = w * grad;
    sum += term;
  }
  return sum;
}

// Shirley's vector turbulence (docs/bump-spec.md 9): sum for i = 0 .. octaves - 1 of
// n_v(f p) / f, f = 2^i (doubled each octave; f p and / f one operation per component),
// summed from 0 in order of i. The one call site of vector_noise.
vec3 vector_turbulence(vec3 p, int octaves) {
  precise vec3 sum = vec3(0.0);
  precise float f = 1.0;
  [[dont_unroll]] for (int i = 0; i < octaves; ++i) {
    precise vec3 q = f * p;
    vec3 n = vector_noise(q);
    precise vec3 term = n / f;
    sum += term;
    f *= 2.0;
  }
  return sum;
}

#endif
