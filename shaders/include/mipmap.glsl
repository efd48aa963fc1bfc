// MIP-mapped image lookups in GLSL (docs/textures-spec.md section 4; pbrt-v4 util/mipmap.cpp
// MIPMap::Filter / Texel / Bilerp / EWA, util/image.h RemapPixelCoords and BilerpChannel, at
// commit 5f7a606). The CPU twin is host/cpu/mipmap.cpp. Needs bindings.glsl.
//
// Compile-time note (lavapipe inlines every call): mipmap_filter has exactly one call of
// mipmap_texel, inside one texel loop that serves point, bilinear, trilinear and EWA; the two
// levels of trilinear / EWA are two iterations of a [[dont_unroll]] pass loop.
//
// Spec assumptions (where docs/textures-spec.md is silent or differs from pbrt-v4):
// - MipLevel.offset is the index in texels[] of the level's first float; texel (x, y) starts
//   at offset + (y * width + x) * channels (rows top to bottom, channels interleaved).
// - A float lookup (want_float) reads channel 0 in Texel-based lookups (point, EWA, the
//   coarsest-level texel) and averages r, g, b in Bilerp-based ones (bilinear, trilinear, EWA's
//   zero-minor-axis case), as pbrt-v4 MIPMap::Bilerp<Float> does (spec 4.2).
// - Guards where pbrt-v4 has undefined behaviour (never hit by finite, sane footprints):
//   a NaN filter width selects level 0 (pbrt: int(floor(NaN))); an EWA ellipse whose shorter
//   axis is not finite after the eccentricity clamp (squared lengths or the clamp's scale
//   overflowed: finite but enormous differentials) reads Texel(levels - 1, (0, 0)), what every
//   footprint wider than the image reads (the CPU twin does the same; pbrt converts the
//   infinite level of detail to int); the EWA level is clamped to the level count; an EWA
//   bounding box that is not finite or reaches beyond +-2^30 texels is empty, and an EWA pass
//   that gives no texel a weight returns 0 (pbrt: 0 / 0; the CPU twin does the same);
//   WRAP_OCTAHEDRAL clamps the remapped texel into the image (pbrt reads out of bounds for
//   points more than one image width outside).
#ifndef BASALT_MIPMAP_GLSL
#define BASALT_MIPMAP_GLSL

#include "math.glsl"
#include "trig.glsl"

// pbrt-v4 Mod(a, b) for b > 0 (math.h): the non-negative remainder, from non-negative operands
// only (GLSL leaves % of negative operands undefined).
int mipmap_mod(int a, int b) { return a >= 0 ? a % b : b - 1 - ((-1 - a) % b); }

// Texel (x, y) of MipLevel `level` with wrap mode `wrap` (WRAP_*): rgb; a 1-channel image gives
// (g,g,g); want_float reads channel 0 broadcast. pbrt-v4 MIPMap::Texel + Image::GetChannel with
// RemapPixelCoords (util/image.h).
vec3 mipmap_texel(uint level, ivec2 xy, uint wrap, bool want_float) {
  MipLevel ml = mip_level_at(level);
  ivec2 res = ivec2(int(ml.width), int(ml.height));
  ivec2 p = xy;
  if (wrap == WRAP_OCTAHEDRAL) {
    if (p.x < 0) {
      p = ivec2(-p.x, res.y - 1 - p.y);
    } else if (p.x >= res.x) {
      p = ivec2(2 * res.x - 1 - p.x, res.y - 1 - p.y);
    }
    if (p.y < 0) {
      p = ivec2(res.x - 1 - p.x, -p.y);
    } else if (p.y >= res.y) {
      p = ivec2(res.x - 1 - p.x, 2 * res.y - 1 - p.y);
    }
    if (res.x == 1) p.x = 0;
    if (res.y == 1) p.y = 0;
    p = clamp(p, ivec2(0), res - 1);  // basalt guard (Spec assumptions)
  } else if (any(lessThan(p, ivec2(0))) || any(greaterThanEqual(p, res))) {
    if (wrap == WRAP_BLACK) return vec3(0.0);
    if (wrap == WRAP_CLAMP) {
      p = clamp(p, ivec2(0), res - 1);
    } else {  // WRAP_REPEAT
      p = ivec2(mipmap_mod(p.x, res.x), mipmap_mod(p.y, res.y));
    }
  }
  uint o = ml.offset + (uint(p.y) * ml.width + uint(p.x)) * ml.channels;
  if (want_float || ml.channels == 1u) return vec3(texel_at(o));
  return vec3(texel_at(o), texel_at(o + 1u), texel_at(o + 2u));
}

// pbrt-v4 Log2(x) = std::log(x) * invLog2 (math.h), with the ~1-ulp log of trig.glsl; +inf and
// NaN pass through (log_accurate wants finite x > 0).
float mipmap_log2(float x) {
  if (isinf(x) || isnan(x)) return x;
  precise float r = log_accurate(x) * 1.442695040888963387004650940071;
  return r;
}

// pbrt-v4 pstd::round (std::round): half away from zero, exactly (x - trunc(x) is exact).
vec2 mipmap_round(vec2 x) {
  vec2 t = trunc(x);
  return vec2(abs(x.x - t.x) >= 0.5 ? t.x + sign(x.x) : t.x,
              abs(x.y - t.y) >= 0.5 ? t.y + sign(x.y) : t.y);
}

// The kinds of one filter pass (one MIP level).
const int MIPPASS_ORIGIN = 0;  // Texel(levels - 1, (0, 0)) (pbrt-v4's "very wide filter")
const int MIPPASS_POINT = 1;   // Texel(level, round(st * res - 0.5))
const int MIPPASS_BILERP = 2;  // pbrt-v4 MIPMap::Bilerp / Image::BilerpChannel
const int MIPPASS_EWA = 3;     // pbrt-v4 MIPMap::EWA

// pbrt-v4 MIPMap::Filter of image texture ti (texture_at(ti).image = first MipLevel, ip.x =
// level count, param[0].y = maxanisotropy, filter and wrap in flags) at st with dst0 = (dsdx,
// dtdx), dst1 = (dsdy, dtdy).
vec3 mipmap_filter(uint ti, vec2 st, vec2 dst0, vec2 dst1, bool want_float) {
  uint flags = texture_at(ti).flags;
  uint filt = (flags & TEXFLAG_FILTER_MASK) >> TEXFLAG_FILTER_SHIFT;
  uint wrap = (flags & TEXFLAG_WRAP_MASK) >> TEXFLAG_WRAP_SHIFT;
  uint base = texture_at(ti).image;
  int nlev = int(texture_at(ti).ip.x);
  float top = float(nlev - 1);

  // ---- plan: the pass kind, the first pass's level, one or two passes, the lerp weight ----
  bool ewa = filt == FILTER_EWA;
  vec2 d0 = dst0, d1 = dst1;  // EWA ellipse axes (d0 the longer)
  float lx;                   // argument of the one Log2: filter width or shorter axis
  if (!ewa) {
    float width = 2.0 * max(max(abs(dst0.x), abs(dst0.y)), max(abs(dst1.x), abs(dst1.y)));
    lx = width < 1e-8 ? 1e-8 : width;  // std::max<Float>(width, 1e-8)
  } else {
    precise float l0 = d0.x * d0.x + d0.y * d0.y;
    precise float l1 = d1.x * d1.x + d1.y * d1.y;
    if (l0 < l1) {
      d0 = dst1;
      d1 = dst0;
      float l = l0;
      l0 = l1;
      l1 = l;
    }
    float longer = sqrt(l0);
    precise float shorter = sqrt(l1);
    float maxaniso = texture_at(ti).param[0].y;
    precise float sa = shorter * maxaniso;
    if (sa < longer && shorter > 0.0) {  // clamp the ellipse's eccentricity
      precise float scale = longer / sa;
      d1 *= scale;
      shorter *= scale;
    }
    lx = shorter;
  }
  precise float level = top + mipmap_log2(lx != 0.0 ? lx : 1.0);
  int kind = MIPPASS_BILERP, lev0 = 0, npass = 1;
  float lt = 0.0;
  if (!ewa) {
    int ilevel = 0;  // max(0, int(floor(level))), a NaN level giving 0
    if (level >= 1.0 && level < top) ilevel = int(floor(level));
    if (level >= top) {
      kind = MIPPASS_ORIGIN;
    } else if (filt == FILTER_POINT) {
      kind = MIPPASS_POINT;
      lev0 = ilevel;
    } else if (filt == FILTER_BILINEAR || ilevel == 0) {
      lev0 = ilevel;  // bilinear, or trilinear at level 0: Bilerp(iLevel, st)
    } else {          // trilinear: Lerp(level - iLevel, Bilerp(iLevel), Bilerp(iLevel + 1))
      lev0 = ilevel;
      npass = 2;
      lt = level - float(ilevel);
    }
  } else if (!(lx <= 3.40282347e38)) {
    // An ellipse whose length overflowed (Spec assumptions): Texel(levels - 1, (0, 0)).
    kind = MIPPASS_ORIGIN;
  } else if (lx != 0.0) {  // lx == 0: Bilerp(0, st)
    float lod = 0.0 < level ? level : 0.0;  // std::max<Float>(0, level): NaN gives 0
    float flod = floor(lod);
    kind = MIPPASS_EWA;
    lev0 = int(min(flod, float(nlev)));  // guard (Spec assumptions)
    npass = 2;
    lt = lod - flod;
  }

  // ---- passes: each is a weighted sum over a rectangle of texels of one level ----
  vec3 a = vec3(0.0), b = vec3(0.0);
  [[dont_unroll]] for (int pass = 0; pass < npass; ++pass) {
    int k = kind, lev = lev0 + pass;
    if (k == MIPPASS_EWA && lev >= nlev) k = MIPPASS_ORIGIN;  // pbrt-v4 EWA's level >= Levels()
    if (k == MIPPASS_ORIGIN) lev = nlev - 1;
    uint ml = base + uint(lev);
    vec2 res = vec2(float(mip_level_at(ml).width), float(mip_level_at(ml).height));
    precise vec2 x = st * res - 0.5;  // st in texel units of this level
    ivec2 lo = ivec2(0), hi = ivec2(0);
    vec2 f = vec2(0.0);                   // bilerp: fractional offsets
    float ea = 0.0, eb = 0.0, ec = 0.0;   // EWA: ellipse coefficients
    if (k == MIPPASS_POINT) {
      lo = hi = ivec2(mipmap_round(x));
    } else if (k == MIPPASS_BILERP) {
      vec2 fl = floor(x);
      lo = ivec2(fl);
      hi = lo + 1;
      f = x - fl;
    } else if (k == MIPPASS_EWA) {
      precise vec2 e0 = d0 * res;
      precise vec2 e1 = d1 * res;
      precise float A = e0.y * e0.y + e1.y * e1.y + 1.0;
      precise float B = -2.0 * (e0.x * e0.y + e1.x * e1.y);
      precise float C = e0.x * e0.x + e1.x * e1.x + 1.0;
      precise float invf = 1.0 / (A * C - B * B * 0.25);
      A *= invf;
      B *= invf;
      C *= invf;
      precise float det = -(B * B) + 4.0 * A * C;
      precise float invdet = 1.0 / det;
      float usqrt = safe_sqrt(det * C), vsqrt = safe_sqrt(A * det);
      precise float du = 2.0 * invdet * usqrt;
      precise float dv = 2.0 * invdet * vsqrt;
      precise vec2 flo = vec2(x.x - du, x.y - dv);
      precise vec2 fhi = vec2(x.x + du, x.y + dv);
      flo = ceil(flo);
      fhi = floor(fhi);
      const float lim = 1073741824.0;  // 2^30
      if (all(lessThan(abs(flo), vec2(lim))) && all(lessThan(abs(fhi), vec2(lim)))) {
        lo = ivec2(flo);
        hi = ivec2(fhi);
      } else {
        lo = ivec2(1);  // empty (Spec assumptions)
      }
      ea = A;
      eb = B;
      ec = C;
    }
    precise vec3 sum = vec3(0.0);
    precise float sumw = 0.0;
    [[dont_unroll]] for (int it = lo.y; it <= hi.y; ++it) {
      [[dont_unroll]] for (int is = lo.x; is <= hi.x; ++is) {
        precise float w = 1.0;
        bool take = true;
        if (k == MIPPASS_BILERP) {
          // pbrt-v4: (1-dx)(1-dy) v00 + dx (1-dy) v10 + (1-dx) dy v01 + dx dy v11, in this order
          precise float wx = is == lo.x ? 1.0 - f.x : f.x;
          precise float wy = it == lo.y ? 1.0 - f.y : f.y;
          w = wx * wy;
        } else if (k == MIPPASS_EWA) {
          precise float ss = float(is) - x.x;
          precise float tt = float(it) - x.y;
          precise float r2 = ea * (ss * ss) + eb * ss * tt + ec * (tt * tt);
          take = r2 < 1.0;
          if (take) {
            int idx = min(int(r2 * float(EWA_LUT_SIZE)), int(EWA_LUT_SIZE) - 1);
            w = tex_data_at(globals.tex_tables.y + uint(idx));
          }
        }
        if (take) {
          // A float Bilerp reads all channels and averages them below (pbrt-v4).
          vec3 v = mipmap_texel(ml, ivec2(is, it), wrap, want_float && k != MIPPASS_BILERP);
          sum += w * v;
          sumw += w;
        }
      }
    }
    precise vec3 r = k == MIPPASS_EWA ? (sumw > 0.0 ? sum / sumw : vec3(0.0)) : sum;
    // pbrt-v4 MIPMap::Bilerp<Float> of a 3-channel level: the average of the bilerped r, g, b.
    if (k == MIPPASS_BILERP && want_float && mip_level_at(ml).channels == 3u) {
      precise float avg = (r.x + r.y + r.z) / 3.0;
      r = vec3(avg);
    }
    if (pass == 0) {
      a = r;
    } else {
      b = r;
    }
  }
  if (npass == 1) return a;
  precise vec3 r = (1.0 - lt) * a + lt * b;  // pbrt-v4 Lerp
  return r;
}

#endif
