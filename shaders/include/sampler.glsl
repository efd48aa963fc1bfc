// pbrt-v4's samplers, filling the path dimensions of docs/path-spec.md section 1
// (docs/sampler-spec.md: bit-identical with host/cpu/sampler.cpp). Needs bindings.glsl (globals,
// sampler_data, FEATURES2) and GL_EXT_shader_explicit_arithmetic_types_int64 enabled by the
// shader.
#ifndef BASALT_SAMPLER_GLSL
#define BASALT_SAMPLER_GLSL

#ifndef GL_EXT_shader_explicit_arithmetic_types_int64
#error "sampler.glsl needs #extension GL_EXT_shader_explicit_arithmetic_types_int64 : require"
#endif

#include "rng.glsl"

// 32-bit binary fraction x as a float in [0, 1): its top 24 bits (sampler-spec 1 to_unit).
float to_unit(uint x) { return float(x >> 8u) * (1.0 / 16777216.0); }

// Integer hash: Wellons' "lowbias32" (2018) (sampler-spec 1).
uint mix32(uint x) {
  x ^= x >> 16u;
  x *= 0x7feb352du;
  x ^= x >> 15u;
  x *= 0x846ca68bu;
  x ^= x >> 16u;
  return x;
}

// Four 32-bit hashes of four words: pcg4d (path-spec 1; sampler-spec 1).
uvec4 hash4(uint a, uint b, uint c, uint d) { return pcg4d(uvec4(a, b, c, d)); }

// Element i of the random permutation of [0, n) chosen by p: Kensler, "Correlated
// Multi-Jittered Sampling", Pixar TM 13-01 (2013); pbrt-v4 PermutationElement (sampler-spec 1).
// n <= 1 gives 0 (the loop's own answer for n = 1; n = 0 never occurs and would not end).
uint permutation_element(uint i, uint n, uint p) {
  if (n <= 1u) return 0u;
  uint w = n - 1u;
  w |= w >> 1u;
  w |= w >> 2u;
  w |= w >> 4u;
  w |= w >> 8u;
  w |= w >> 16u;
  do {
    i ^= p;
    i *= 0xe170893du;
    i ^= p >> 16u;
    i ^= (i & w) >> 4u;
    i ^= p >> 8u;
    i *= 0x0929eb3fu;
    i ^= p >> 23u;
    i ^= (i & w) >> 1u;
    i *= 1u | (p >> 27u);
    i *= 0x6935fa69u;
    i ^= (i & w) >> 11u;
    i *= 0x74dcb303u;
    i ^= (i & w) >> 2u;
    i *= 0x9e501cc3u;
    i ^= (i & w) >> 2u;
    i *= 0xc860a3dfu;
    i &= w;
    i ^= i >> 5u;
  } while (i >= n);
  return (i + p) % n;
}

// Sobol' (1967) dimension 0, the van der Corput sequence: a's bits reversed (sampler-spec 1).
uint sobol0(uint a) { return bitfieldReverse(a); }

// Sobol' (1967) dimension 1: the spec's loop `v = 0; c = 0x80000000; for each bit of a from
// the lowest { if set v ^= c; c ^= c >> 1 }` in closed form. Column j is row j of Pascal's
// triangle mod 2, whose entry i is odd iff i's bits are a subset of j's (Lucas), so bit
// 31 - i of the result is the xor of a's bits j over the supersets j of i: five butterfly
// steps of the superset transform, then a reversal (sampler-spec 1).
uint sobol1(uint a) {
  a ^= (a >> 1u) & 0x55555555u;
  a ^= (a >> 2u) & 0x33333333u;
  a ^= (a >> 4u) & 0x0f0f0f0fu;
  a ^= (a >> 8u) & 0x00ff00ffu;
  a ^= (a >> 16u) & 0x0000ffffu;
  return bitfieldReverse(a);
}

// Randomisation rand (RAND_*) of the 32-bit fraction v with seed h (sampler-spec 1; pbrt-v4
// lowdiscrepancy.h): none; random digit permutation in base 2 (xor); Laine & Karras' (2011)
// hash with Burley's "Practical Hash-based Owen Scrambling" (JCGT 9(4) 2020) constants, as
// pbrt-v4 FastOwenScrambler; full Owen scrambling, one hash per bit (pbrt-v4 OwenScrambler).
uint scramble(uint v, uint h, uint rand) {
  if (rand == RAND_PERMUTE) return v ^ h;
  if (rand == RAND_FASTOWEN) {
    v = bitfieldReverse(v);
    v ^= v * 0x3d20adeau;
    v += h;
    v *= (h >> 16u) | 1u;
    v ^= v * 0x05526c56u;
    v ^= v * 0x53a22864u;
    return bitfieldReverse(v);
  }
  if (has_feature2(FEATURE2_SAMPLER_OWEN) && rand == RAND_OWEN) {
    if ((h & 1u) != 0u) v ^= 1u << 31u;
    for (uint b = 1u; b < 32u; ++b) {
      uint mask = 0xffffffffu << (32u - b);
      if ((mix32((v & mask) ^ h) & (1u << b)) != 0u) v ^= 1u << (31u - b);
    }
  }
  return v;
}

// Number of base-`base` digits radical_inverse uses: the largest n with base^n <= 2^40; B is
// base^n (sampler-spec 4 halton).
uint radical_inverse_digits(uint base, out uint64_t B) {
  uint n = 0u;
  B = 1ul;
  while (B * uint64_t(base) <= (1ul << 40u)) {
    B *= uint64_t(base);
    ++n;
  }
  return n;
}

// Radical inverse of a in base `base` (a prime), its first n digits (base^n <= 2^40) mirrored
// about the point, each digit permuted as rand says (RAND_PERMUTE: per-digit permutation,
// pbrt-v4 ScrambledRadicalInverse; RAND_OWEN: permutation keyed by the digits so far, pbrt-v4
// OwenScrambledRadicalInverse; RAND_FASTOWEN is RAND_PERMUTE), quantised to 24 bits exactly
// (sampler-spec 4 halton).
float radical_inverse(uint base, uint64_t a, uint rand) {
  // Base 2 unscrambled in closed form (the loop gives the same): the top 24 bits of the 40
  // digits mirrored are a's low 24 bits reversed.
  if (base == 2u && rand == RAND_NONE) return to_unit(bitfieldReverse(uint(a)));
  uint64_t B;
  uint n = radical_inverse_digits(base, B);
  uint seed = globals.image.w;
  uint owen_key = hash4(base, seed, 0x0E3u, 0u).x;
  uint64_t r = 0ul;
  for (uint j = 0u; j < n; ++j) {
    uint digit = uint(a % uint64_t(base));
    a /= uint64_t(base);
    // One permutation_element call site: lavapipe would run both of two branches.
    uint p = rand == RAND_OWEN ? mix32(uint(r) ^ uint(r >> 32u) ^ owen_key)
                               : hash4(base, j, seed, 0x0D16u).x;
    if (rand != RAND_NONE) digit = permutation_element(digit, base, p);
    r = r * uint64_t(base) + uint64_t(digit);
  }
  // Down in base 2, up in odd bases, so that a value on a stratum boundary stays in its stratum.
  uint64_t q = base == 2u ? (r << 24u) / B : min(((r << 24u) + B - 1ul) / B, 16777215ul);
  return float(uint(q)) * (1.0 / 16777216.0);
}

// The n-digit base-`base` integer whose digits are v's first n digits reversed: pbrt-v4
// InverseRadicalInverse (sampler-spec 4 halton).
uint64_t inverse_radical_inverse(uint64_t v, uint base, uint n) {
  uint64_t r = 0ul;
  for (uint j = 0u; j < n; ++j) {
    r = r * uint64_t(base) + v % uint64_t(base);
    v /= uint64_t(base);
  }
  return r;
}

// Morton code of (x, y): x's low 16 bits at the even bit positions, y's at the odd ones
// (pbrt-v4 EncodeMorton2; sampler-spec 4 zsobol).
uint morton2(uint x, uint y) {
  uvec2 v = uvec2(x, y) & 0x0000ffffu;
  v = (v | (v << 8u)) & 0x00ff00ffu;
  v = (v | (v << 4u)) & 0x0f0f0f0fu;
  v = (v | (v << 2u)) & 0x33333333u;
  v = (v | (v << 1u)) & 0x55555555u;
  return v.x | (v.y << 1u);
}

// Element `digit` of the p-th (0..23) permutation of (0, 1, 2, 3) in lexicographic order
// (pbrt-v4 ZSobolSampler's permutations table; sampler-spec 4 zsobol), from that table packed
// two bits an element, a byte a permutation, four permutations a word, the word picked by
// selects (lavapipe runs both sides of every branch: a third of the arithmetic of taking the
// elements out one at a time, docs/performance.md).
uint perm4(uint p, uint digit) {
  uint w = p < 12u ? (p < 4u ? 0x78d8b4e4u : (p < 8u ? 0xb1e16c9cu : 0x2d8d39c9u))
                   : (p < 16u ? 0x36c672d2u : (p < 20u ? 0x63931e4eu : 0x1b4b2787u));
  return (w >> (8u * (p & 3u) + 2u * digit)) & 3u;
}

// Sampler dimension of path dimension d (sampler-spec 2): ld, the component c, and whether
// it is one of a pair; false for the dimensions the samplers leave to rng (streams).
bool sampler_dimension(uint d, out uint ld, out uint c, out bool pair) {
  c = 0u;
  pair = true;
  if (d < DIM_BOUNCE_BASE) {
    ld = d < DIM_LENS_X ? 0u : 4u;
    c = d & 1u;
    return true;
  }
  uint k = (d - DIM_BOUNCE_BASE) % DIM_BOUNCE_STRIDE;
  uint b = (d - DIM_BOUNCE_BASE) / DIM_BOUNCE_STRIDE;
  if (k > DIM_ROULETTE) {
    ld = 0u;
    return false;
  }
  // Slots 0 | 1 2 | 3 | 4 5 | 6: pairs start at slots 1 and 4.
  pair = k == DIM_LIGHT_U0 || k == DIM_LIGHT_U1 || k == DIM_BSDF_U0 || k == DIM_BSDF_U1;
  uint first = k == DIM_LIGHT_U1 ? DIM_LIGHT_U0 : (k == DIM_BSDF_U1 ? DIM_BSDF_U0 : k);
  c = k - first;
  ld = 6u + 7u * b + first;
  return true;
}

// (k + j 2^-24) / q for a 24-bit offset j, exactly truncated to 24 bits: the stratified
// sampler's frac (sampler-spec 4 stratified; pmj02bn's 1D samples use it too).
float frac24(uint k, uint q, uint j) {
  return float(uint(((uint64_t(k) << 24u) | uint64_t(j)) / uint64_t(q))) * (1.0 / 16777216.0);
}

// pbrt-v4 StratifiedSampler (sampler-spec 4 stratified): sample s takes stratum
// permutation_element(s, n) of the n0 x n1 (pair) or n0 n1 (1D) strata, jittered or centred.
float stratified_get(uint px, uint py, uint s, uint ld, uint c, bool pair) {
  uint seed = globals.image.w;
  uint n0 = globals.sampler_opts.z, n1 = globals.sampler_opts.w;
  uint n = n0 * n1;
  uint stratum = permutation_element(s, n, hash4(px, py, ld, seed).x);
  uint j = globals.sampler_opts.y == 0u
               ? (1u << 23u)
               : hash4(px, py, s, (ld * 2u + c) ^ (seed * 0x9E3779B9u)).z >> 8u;
  uint k = stratum, q = n;
  if (pair) {
    k = c == 0u ? stratum % n0 : stratum / n0;
    q = c == 0u ? n0 : n1;
  }
  return frac24(k, q, j);
}

// pbrt-v4 HaltonSampler (sampler-spec 4 halton): the pixel's samples are the Halton points
// whose first two coordinates fall in it (scaled by 2^exp0 x 3^exp1, tiled every 128 pixels),
// found with the Chinese remainder theorem; the pixel pair is never scrambled.
float halton_get(uint px, uint py, uint s, uint ld, uint c) {
  uvec4 prm = globals.sampler_params;
  uint scale0 = prm.x & 0xffffu, scale1 = prm.x >> 16u;
  uint exp0 = prm.y & 0xffffu, exp1 = prm.y >> 16u;
  uint64_t stride = uint64_t(scale0) * uint64_t(scale1);
  uint64_t off = inverse_radical_inverse(uint64_t(px % 128u), 2u, exp0) *
                 (stride / uint64_t(scale0)) * uint64_t(prm.z);
  off += inverse_radical_inverse(uint64_t(py % 128u), 3u, exp1) * (stride / uint64_t(scale1)) *
         uint64_t(prm.w);
  uint64_t index = off % stride + uint64_t(s) * stride;
  // One radical_inverse call site (lavapipe inlines each and runs both sides of a branch).
  uint base = 2u + c, rand = RAND_NONE;
  uint64_t a = c == 0u ? index >> exp0 : index / uint64_t(scale1);
  if (ld != 0u) {
    uint dim = ld + c;
    if (dim >= SAMPLER_PRIME_COUNT) dim = 2u + (dim - 2u) % (SAMPLER_PRIME_COUNT - 2u);
    base = sampler_data_at(dim);
    rand = globals.sampler_opts.y;
    a = index;
  }
  return radical_inverse(base, a, rand);
}

// pbrt-v4 PaddedSobolSampler (sampler-spec 4 paddedsobol): Sobol' dimensions 0 (1D) or 0 and
// 1 (pair), the sample index permuted and the point scrambled per pixel and dimension.
float padded_sobol_get(uint px, uint py, uint s, uint ld, uint c, bool pair) {
  uvec4 hv = hash4(px, py, ld, globals.image.w);
  uint index = permutation_element(s, globals.sampler_opts.z, hv.x);
  uint v = c == 0u ? sobol0(index) : sobol1(index);
  uint h = pair && c == 0u ? hv.x : hv.y;
  return to_unit(scramble(v, h, globals.sampler_opts.y));
}

// pbrt-v4 ZSobolSampler, after Ahmed & Wonka, "Screen-Space Blue-Noise Diffusion of Monte
// Carlo Sampling Error via Hierarchical Ordering of Pixels" (SIGGRAPH Asia 2020)
// (sampler-spec 4 zsobol): one Sobol' sequence over the image in Morton order, its base-4
// digits randomly permuted by a hash of the digits above them.
float zsobol_get(uint px, uint py, uint s, uint ld, uint c) {
  uint l = globals.sampler_params.x;
  int digits = int(globals.sampler_params.y);
  uint64_t morton = (uint64_t(morton2(px, py)) << l) | uint64_t(s);
  uint64_t idx = 0ul;
  int odd = int(l & 1u);
  uint dkey = 0x55555555u * ld;
  // The end tested at the end of a pass (a for loop's closing test costs lavapipe a pass).
  int i = digits - 1;
  if (i >= odd) while (true) {
    uint shift = uint(2 * i - odd);
    uint digit = uint(morton >> shift) & 3u;
    uint64_t higher = morton >> (shift + 2u);
    uint p = (mix32(uint(higher) ^ mix32(uint(higher >> 32u)) ^ dkey) >> 24u) % 24u;
    idx |= uint64_t(perm4(p, digit)) << shift;
    if (--i < odd) break;
  }
  if (odd != 0)
    idx |= (morton & 1ul) ^
           uint64_t(mix32(uint(morton >> 1u) ^ mix32(uint(morton >> 33u)) ^ dkey) & 1u);
  uvec4 hv = hash4(ld, globals.image.w, 0x2B50u, 0u);
  uint v = c == 0u ? sobol0(uint(idx)) : sobol1(uint(idx));
  return to_unit(scramble(v, c == 0u ? hv.x : hv.y, globals.sampler_opts.y));
}

// Point i (i < 2^52) of Sobol' dimension dim: the xor of the generator matrix's columns
// M(dim, j) = sampler_data_at(SAMPLER_TABLES + dim SOBOL_COLUMNS + j) over i's set bits j
// (Sobol' 1967; Joe & Kuo 2008 directions; sampler-spec 3 and 4 sobol).
uint sobol(uint64_t i, uint dim) {
  uint base = SAMPLER_TABLES + dim * SOBOL_COLUMNS;
  uint lo = uint(i), hi = uint(i >> 32u), v = 0u;
  [[dont_unroll]] for (; lo != 0u; lo &= lo - 1u) v ^= sampler_data_at(base + uint(findLSB(lo)));
  [[dont_unroll]] for (; hi != 0u; hi &= hi - 1u)
    v ^= sampler_data_at(base + 32u + uint(findLSB(hi)));
  return v;
}

// pbrt-v4 SobolSampler, after Gruenschloss et al., "Enumerating quasi-Monte Carlo point
// sequences in elementary intervals" (MCQMC 2012) (sampler-spec 4 sobol): one Sobol' sequence
// over the whole image, sample s of pixel (px, py) being its s-th point whose first two
// dimensions' top m digits are (px, py), found with the inverse table INV.
float sobol_get(uint px, uint py, uint s, uint ld, uint c) {
  uint m = globals.sampler_params.x;
  // What the index bits s << 2m add to dimension 1's top m digits (dimension 0's: nothing).
  uint delta = 0u;
  if (m > 0u) {
    [[dont_unroll]] for (uint b = s; b != 0u; b &= b - 1u)
      delta ^= sampler_data_at(SAMPLER_TABLES + SOBOL_COLUMNS + 2u * m + uint(findLSB(b))) >>
               (32u - m);
  }
  uint t = (px << m) | (py ^ delta);
  uint r = 0u;
  [[dont_unroll]] for (; t != 0u; t &= t - 1u) r ^= sampler_data_at(SOBOL_INVERSE + uint(findLSB(t)));
  uint64_t i = (uint64_t(s) << (2u * m)) | uint64_t(r);
  // One sobol call site: the pixel pair is dimension c scaled by 2^m and never scrambled;
  // other dimensions restart at 2 past the table's end.
  uint e = ld + c;
  if (e >= SOBOL_DIMENSIONS) e = 2u + (e - 2u) % (SOBOL_DIMENSIONS - 2u);
  uint h = hash4(e, globals.image.w, 0x50B01u, 0u).x;
  uint v = sobol(i, e);  // e = c for the pixel pair
  return to_unit(ld == 0u ? v << m : scramble(v, h, globals.sampler_opts.y));
}

// pbrt-v4 PMJ02BNSampler, after Christensen, Kensler & Kilpatrick, "Progressive Multi-Jittered
// Sample Sequences" (EGSR 2018) (sampler-spec 4 pmj02bn): the pixel pair from the host's
// per-tile-pixel table Q, other pairs from the five point sets P with per-pixel
// Cranley-Patterson offsets, 1D samples stratified in n strata.
float pmj02bn_get(uint px, uint py, uint s, uint ld, uint c, bool pair) {
  uint n = globals.sampler_opts.z;
  uvec4 hv = hash4(px, py, ld, globals.image.w);
  uint inst = ld / 2u;
  // pbrt-v4 permutes the index of 1D samples, and of pairs from the second time through the sets.
  uint index = !pair || inst >= PMJ_SETS ? permutation_element(s, n, hv.x) : s;
  if (!pair) return frac24(index, n, hv.y >> 8u);
  uint tmask = (1u << globals.sampler_params.x) - 1u;  // T - 1, T = 2^tbits
  uint p = (px & tmask) + ((py & tmask) << globals.sampler_params.x);
  // One table read: Q(p, s) unrandomised for the pixel pair, else P(inst % 5, index) rotated.
  bool pixel = ld == 0u;
  uint at = pixel ? PMJ_PIXEL_TABLE + 2u * (p * n + s)
                  : SAMPLER_TABLES + 2u * ((inst % PMJ_SETS) * PMJ_SAMPLES + index);
  uint offset = pixel ? 0u : (c == 0u ? hv.y : hv.z);
  return to_unit(sampler_data_at(at + c) + offset);
}

#ifdef BASALT_FEATURES2_KEEP
#define BASALT_SAMPLER_BITS (FEATURES2 & (FEATURE2_SAMPLERS & BASALT_FEATURES2_KEEP))
#else
#define BASALT_SAMPLER_BITS (FEATURES2 & FEATURE2_SAMPLERS)
#endif
// The SAMPLER_* whose code is the only sampler code in the pipeline (FEATURE2_SAMPLER_*; the
// host sets the bit of the scene's sampler alone), or ~0u where several are (the probe,
// --pipeline all): a specialization-constant operation, so that with one sampler the tests
// of the others fold away (lavapipe runs both sides of every branch, docs/performance.md).
const uint SAMPLER_FIXED =
    BASALT_SAMPLER_BITS == 0u                             ? SAMPLER_INDEPENDENT
    : BASALT_SAMPLER_BITS == FEATURE2_SAMPLER_STRATIFIED  ? SAMPLER_STRATIFIED
    : BASALT_SAMPLER_BITS == FEATURE2_SAMPLER_HALTON      ? SAMPLER_HALTON
    : BASALT_SAMPLER_BITS == FEATURE2_SAMPLER_PADDED_SOBOL ? SAMPLER_PADDED_SOBOL
    : BASALT_SAMPLER_BITS == FEATURE2_SAMPLER_ZSOBOL      ? SAMPLER_ZSOBOL
    : BASALT_SAMPLER_BITS == FEATURE2_SAMPLER_SOBOL       ? SAMPLER_SOBOL
    : BASALT_SAMPLER_BITS == FEATURE2_SAMPLER_PMJ02BN     ? SAMPLER_PMJ02BN
                                                          : 0xffffffffu;

// The scene's sampler, Globals.sampler_opts.x: SAMPLER_FIXED where that is one.
uint sampler_type() { return SAMPLER_FIXED != 0xffffffffu ? SAMPLER_FIXED : globals.sampler_opts.x; }

// Value of sampler dimension (ld, c, pair) (sampler_dimension) for pixel (px, py) and sample
// s under sampler `type`, not the independent one (sampler-spec 4). Each sampler's code is
// compiled in only with its FEATURE2_SAMPLER_* bit.
float sampler_value(uint type, uint px, uint py, uint s, uint ld, uint c, bool pair) {
  if (has_feature2(FEATURE2_SAMPLER_STRATIFIED) && type == SAMPLER_STRATIFIED)
    return stratified_get(px, py, s, ld, c, pair);
  if (has_feature2(FEATURE2_SAMPLER_HALTON) && type == SAMPLER_HALTON)
    return halton_get(px, py, s, ld, c);
  if (has_feature2(FEATURE2_SAMPLER_PADDED_SOBOL) && type == SAMPLER_PADDED_SOBOL)
    return padded_sobol_get(px, py, s, ld, c, pair);
  if (has_feature2(FEATURE2_SAMPLER_ZSOBOL) && type == SAMPLER_ZSOBOL)
    return zsobol_get(px, py, s, ld, c);
  if (has_feature2(FEATURE2_SAMPLER_SOBOL) && type == SAMPLER_SOBOL)
    return sobol_get(px, py, s, ld, c);
  if (has_feature2(FEATURE2_SAMPLER_PMJ02BN) && type == SAMPLER_PMJ02BN)
    return pmj02bn_get(px, py, s, ld, c, pair);
  return 0.0;  // never: the host compiles in the scene's sampler
}

// Sample value of path dimension d for pixel (px, py) and sample s under the scene's sampler
// (sampler-spec 2 and 4); the independent sampler, and the dimensions the samplers leave to
// the streams, are rng itself. With `own` the caller knows that d is a sampler dimension
// (the camera's and the bounces'): with one sampler compiled in, rng's code then folds away.
float sampler_get_dim(uint px, uint py, uint s, uint d, bool own) {
  uint type = sampler_type();
  uint ld, c;
  bool pair;
  bool sampled = sampler_dimension(d, ld, c, pair) || own;
  if (has_feature2(FEATURE2_SAMPLERS) && type != SAMPLER_INDEPENDENT && sampled)
    return sampler_value(type, px, py, s, ld, c, pair);
  return rng(px, py, s, d);
}

// sampler_get_dim for any path dimension d (the probe's PROBE_SAMPLER).
float sampler_get(uint px, uint py, uint s, uint d) { return sampler_get_dim(px, py, s, d, false); }

// Whether the pipeline may run a sampler other than independent (FEATURE2_SAMPLER_*).
const bool SAMPLERS_ENABLED = feature2_const(FEATURE2_SAMPLERS);

// lavapipe inlines every call site, and before it folds FEATURES2: each sampler_get call
// costs compile time even where it reduces to rng. So with SAMPLERS_ENABLED the camera and each
// bounce fetch their dimensions in one loop around one call site, and without it they call rng
// where they need a value, as before the samplers.

// Values of path dimensions 0 .. n-1 (n = 2: filter; 4: filter and lens) of sample s.
vec4 camera_samples(uint px, uint py, uint s, uint n) {
  vec4 u = vec4(0.0);
  if (SAMPLERS_ENABLED) {
    uint k = 0u;  // n >= 2; the end tested at the end of a pass (see bounce_samples)
    [[dont_unroll]] while (true) {
      u[k] = sampler_get_dim(px, py, s, k, true);
      if (++k >= n) break;
    }
  } else {
    u.xy = vec2(rng(px, py, s, DIM_FILTER_X), rng(px, py, s, DIM_FILTER_Y));
    if (n > 2u) u.zw = vec2(rng(px, py, s, DIM_LENS_X), rng(px, py, s, DIM_LENS_Y));
  }
  return u;
}

// Sample values of slots 0..6 of the bounce whose first path dimension is dim: slots 0-3 in a,
// 4-6 in b (filled with SAMPLERS_ENABLED only; bounce_sample reads them).
struct BounceSamples {
  vec4 a;
  vec3 b;
};

// The bounce's values, all 7 through one sampler_get call site (SAMPLERS_ENABLED), else none.
BounceSamples bounce_samples(uint px, uint py, uint s, uint dim) {
  BounceSamples u = BounceSamples(vec4(0.0), vec3(0.0));
  if (SAMPLERS_ENABLED) {
    // The end tested at the end of a pass: lavapipe runs a pass that any lane enters in full,
    // so a `for` loop's closing test cost an eighth pass of the sampler (docs/performance.md).
    uint k = 0u;
    [[dont_unroll]] while (true) {
      float v = sampler_get_dim(px, py, s, dim + k, true);
      if (k < 4u) u.a[k] = v;
      else u.b[k - 4u] = v;
      if (++k > DIM_ROULETTE) break;
    }
  }
  return u;
}

// Slot k (DIM_LIGHT_SELECT .. DIM_ROULETTE, a constant) of the bounce at path dimension dim.
float bounce_sample(BounceSamples u, uint px, uint py, uint s, uint dim, uint k) {
  if (!SAMPLERS_ENABLED) return rng(px, py, s, dim + k);
  return k < 4u ? u.a[k] : u.b[k - 4u];
}

#endif
