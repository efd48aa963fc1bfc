// Texture evaluation in GLSL (docs/textures-spec.md; pbrt-v4 textures.h/.cpp,
// interaction.cpp, cameras.h): the evaluation context of a hit, its pixel footprint, and the
// post-order texture programs of the Texture table. The CPU twin is host/cpu/texture.cpp.
// Needs bindings.glsl.
#ifndef BASALT_TEXTURE_GLSL
#define BASALT_TEXTURE_GLSL

#include "math.glsl"
#include "trig.glsl"
#include "noise.glsl"
#include "mipmap.glsl"

// pbrt-v4 TextureEvalContext (docs/textures-spec.md section 1).
struct TexCtx {
  vec3 p;
  vec3 n;
  vec2 uv;
  vec3 dpdx;
  vec3 dpdy;
  float dudx, dudy, dvdx, dvdy;
};

// A ray's differential rays (docs/textures-spec.md 3.1 says which rays carry them).
struct RayDiff {
  vec3 rx_o;
  vec3 rx_d;
  vec3 ry_o;
  vec3 ry_d;
};

// m * (p, 1) summed left to right, uncontracted (as the CPU).
vec3 tex_xform_point(mat4 m, vec3 p) {
  precise vec3 r = m[0].xyz * p.x + m[1].xyz * p.y + m[2].xyz * p.z + m[3].xyz;
  return r;
}

// mat3(m) * v summed left to right, uncontracted.
vec3 tex_xform_vector(mat4 m, vec3 v) {
  precise vec3 r = m[0].xyz * v.x + m[1].xyz * v.y + m[2].xyz * v.z;
  return r;
}

// 2D texture coordinates and their screen derivatives (pbrt-v4 TexCoord2D).
struct TexCoord2D {
  vec2 st;
  float dsdx, dsdy, dtdx, dtdy;
};

// pbrt-v4 UVMapping / SphericalMapping / CylindricalMapping / PlanarMapping::Map.
TexCoord2D tex_map_2d(uint ti, TexCtx c) {
  TexCoord2D r = TexCoord2D(vec2(0.0), 0.0, 0.0, 0.0, 0.0);
  uint mapping = texture_at(ti).flags & TEXFLAG_MAPPING_MASK;
  if (mapping == MAPPING_UV) {
    vec4 m = texture_at(ti).map[0];
    precise float dsdx = m.x * c.dudx, dsdy = m.x * c.dudy;
    precise float dtdx = m.y * c.dvdx, dtdy = m.y * c.dvdy;
    precise vec2 st = vec2(m.x * c.uv.x + m.z, m.y * c.uv.y + m.w);
    r.st = st;
    r.dsdx = dsdx;
    r.dsdy = dsdy;
    r.dtdx = dtdx;
    r.dtdy = dtdy;
    return r;
  }
  mat4 xf = texture_at(ti).xform;
  vec3 pt = tex_xform_point(xf, c.p);
  vec3 dpdx = tex_xform_vector(xf, c.dpdx), dpdy = tex_xform_vector(xf, c.dpdy);
  if (mapping == MAPPING_PLANAR) {
    vec4 a = texture_at(ti).map[0], b = texture_at(ti).map[1];
    r.dsdx = dot_exact(a.xyz, dpdx);
    r.dsdy = dot_exact(a.xyz, dpdy);
    r.dtdx = dot_exact(b.xyz, dpdx);
    r.dtdy = dot_exact(b.xyz, dpdy);
    precise vec2 st = vec2(a.w + dot_exact(pt, a.xyz), b.w + dot_exact(pt, b.xyz));
    r.st = st;
    return r;
  }
  if (no_feature2(FEATURE2_TEX_MAP_CURVED)) return r;  // no such mapping in the scene
  precise float x2y2 = pt.x * pt.x + pt.y * pt.y;
  precise vec3 dsdp = vec3(-pt.y, pt.x, 0.0) / (2.0 * PI * x2y2);
  if (mapping == MAPPING_SPHERICAL) {
    float sq = sqrt(x2y2);
    precise float k = 1.0 / (PI * (x2y2 + pt.z * pt.z));
    precise vec3 dtdp = k * vec3(pt.x * pt.z / sq, pt.y * pt.z / sq, -sq);
    r.dsdx = dot_exact(dsdp, dpdx);
    r.dsdy = dot_exact(dsdp, dpdy);
    r.dtdx = dot_exact(dtdp, dpdx);
    r.dtdy = dot_exact(dtdp, dpdy);
    float len = sqrt(dot_exact(pt, pt));
    vec3 v = len > 0.0 ? pt / len : vec3(0.0, 0.0, 1.0);
    float theta = acos_accurate(clamp(v.z, -1.0, 1.0));
    float phi = atan2_accurate(v.y, v.x);
    if (phi < 0.0) phi += 2.0 * PI;
    r.st = vec2(theta * (1.0 / PI), phi * (1.0 / (2.0 * PI)));
  } else {  // cylindrical
    r.dsdx = dot_exact(dsdp, dpdx);
    r.dsdy = dot_exact(dsdp, dpdy);
    r.dtdx = dpdx.z;
    r.dtdy = dpdy.z;
    precise float s = (PI + atan2_accurate(pt.y, pt.x)) * (1.0 / (2.0 * PI));
    r.st = vec2(s, pt.z);
  }
  // A derivative at the mapping's axis (x2y2 = 0) is not finite: no filtering there.
  if (isinf(r.dsdx) || isnan(r.dsdx)) r.dsdx = 0.0;
  if (isinf(r.dsdy) || isnan(r.dsdy)) r.dsdy = 0.0;
  if (isinf(r.dtdx) || isnan(r.dtdx)) r.dtdx = 0.0;
  if (isinf(r.dtdy) || isnan(r.dtdy)) r.dtdy = 0.0;
  return r;
}

// 1 - 2 (floor(x) & 1), exactly in float for any x.
float checker_sign(float x) {
  float f = floor(x);
  precise float odd = f - 2.0 * floor(f * 0.5);
  return odd == 0.0 ? 1.0 : -1.0;
}

// Integral of the 1D checker (pbrt-v4 Checkerboard's d).
float checker_d(float x) {
  precise float y = x / 2.0 - floor(x / 2.0) - 0.5;
  precise float r = x / 2.0 + y * (1.0 - 2.0 * abs(y));
  return r;
}

// The 1D checker box-filtered with radius r (pbrt-v4 Checkerboard's bf).
float checker_bf(float x, float r) {
  precise float lo = x - r;
  precise float hi = x + r;
  precise float rr = r * r;
  // A radius whose square is not a normal float samples the checker at x (as the CPU twin).
  if (floor(lo) == floor(hi) || !(rr >= 1.17549435e-38)) return checker_sign(x);
  precise float v = (checker_d(hi) - 2.0 * checker_d(x) + checker_d(lo)) / rr;
  // Clamped to [-1, 1] (as the CPU twin; docs/textures-spec.md 8): the second difference
  // cancels where r is a few ulps of x.
  return v > 1.0 ? 1.0 : (v < -1.0 ? -1.0 : v);
}

// Weight of tex2 of checkerboard instruction ti (pbrt-v4 Checkerboard).
float tex_checkerboard(uint ti, TexCtx c) {
  if (texture_at(ti).ip.x == 3u) {
    mat4 xf = texture_at(ti).xform;
    vec3 p = tex_xform_point(xf, c.p);
    vec3 dx = tex_xform_vector(xf, c.dpdx), dy = tex_xform_vector(xf, c.dpdy);
    precise float rx = 1.5 * max(abs(dx.x), abs(dy.x));
    precise float ry = 1.5 * max(abs(dx.y), abs(dy.y));
    precise float rz = 1.5 * max(abs(dx.z), abs(dy.z));
    precise float w = 0.5 - 0.5 * checker_bf(p.x, rx) * checker_bf(p.y, ry) * checker_bf(p.z, rz);
    return w;
  }
  TexCoord2D m = tex_map_2d(ti, c);
  precise float ds = 1.5 * max(abs(m.dsdx), abs(m.dsdy));
  precise float dt = 1.5 * max(abs(m.dtdx), abs(m.dtdy));
  precise float w = 0.5 - checker_bf(m.st.x, ds) * checker_bf(m.st.y, dt) / 2.0;
  return w;
}

// pbrt-v4 InsidePolkaDot: one dot of radius 0.35 in some unit cells, jittered by noise. The
// three noise lookups share one call site (a loop), as lavapipe inlines every call.
bool tex_inside_polka_dot(vec2 st) {
  float sc = floor(st.x + 0.5), tc = floor(st.y + 0.5);
  float n[3];
  [[dont_unroll]] for (int k = 0; k < 3; ++k) {
    vec2 o = k == 0 ? vec2(0.5, 0.5) : (k == 1 ? vec2(1.5, 2.8) : vec2(4.5, 9.8));
    n[k] = perlin_noise(vec3(sc + o.x, tc + o.y, 0.5));
  }
  if (!(n[0] > 0.0)) return false;
  const float radius = 0.35, max_shift = 0.5 - 0.35;
  precise float s_center = sc + max_shift * n[1];
  precise float t_center = tc + max_shift * n[2];
  precise vec2 d = st - vec2(s_center, t_center);
  precise float d2 = d.x * d.x + d.y * d.y;
  return d2 < radius * radius;
}

// pbrt-v4 Lerp of colours, uncontracted.
vec3 tex_lerp3(float t, vec3 a, vec3 b) {
  precise vec3 r = (1.0 - t) * a + t * b;
  return r;
}

// Control point i of pbrt-v4 MarbleTexture's colour spline.
vec3 marble_color(int i) {
  if (i == 3) return vec3(0.5, 0.5, 0.5);
  if (i == 4) return vec3(0.6, 0.59, 0.58);
  if (i == 7) return vec3(0.2, 0.2, 0.33);
  return vec3(0.58, 0.58, 0.6);
}

// pbrt-v4 MarbleTexture: noise-perturbed sine bands through a cubic Bezier colour spline;
// py = y of the scaled texture-space point, f = its fbm (computed by the caller).
vec3 tex_marble(uint ti, float py, float f) {
  precise float m = py + texture_at(ti).param[0].z * f;
  // sin_accurate reduces exactly below 2^15 only and its polynomial overflows to NaN beyond
  // ~1e18: there (bands that differ from the CPU's anyway, docs/textures-spec.md 8) the
  // builtin sine.
  precise float u = 0.5 + 0.5 * (abs(m) < 32768.0 ? sin_accurate(m) : sin(m));
  int first = min(int(floor(u * 6.0)), 5);
  precise float t = u * 6.0 - float(first);
  vec3 c0 = marble_color(first), c1 = marble_color(first + 1);
  vec3 c2 = marble_color(first + 2), c3 = marble_color(first + 3);
  vec3 a = tex_lerp3(t, c0, c1), b = tex_lerp3(t, c1, c2), d = tex_lerp3(t, c2, c3);
  vec3 e = tex_lerp3(t, a, b), f2 = tex_lerp3(t, b, d);
  precise vec3 r = 1.5 * tex_lerp3(t, e, f2);
  return r;
}

// pbrt-v4 FloatImageTexture / SpectrumImageTexture::Evaluate (docs/textures-spec.md 4.2 step
// 0): map, flip t, MIP-map filter, then scale, invert and the clamps; 0 for a non-finite
// coordinate or differential.
vec3 tex_image(uint ti, TexCtx c) {
  TexCoord2D tc = tex_map_2d(ti, c);
  vec2 st = vec2(tc.st.x, 1.0 - tc.st.y);
  vec2 d0 = vec2(tc.dsdx, tc.dtdx), d1 = vec2(tc.dsdy, tc.dtdy);
  if (any(isnan(st)) || any(isinf(st)) || any(isnan(d0)) || any(isinf(d0)) || any(isnan(d1)) ||
      any(isinf(d1)))
    return vec3(0.0);
  uint flags = texture_at(ti).flags;
  bool is_float = (flags & TEXFLAG_FLOAT) != 0u;
  vec3 f = mipmap_filter(ti, st, d0, d1, is_float);
  float scale = texture_at(ti).param[0].x;
  bool invert = (flags & TEXFLAG_INVERT) != 0u;
  if (is_float) {
    precise float v = scale * f.x;
    precise float iv = 1.0 - v;
    return vec3(invert ? max(0.0, iv) : v);
  }
  precise vec3 rgb = scale * f;
  if (invert) rgb = vec3(1.0) - rgb;
  rgb = max(rgb, vec3(0.0));  // pbrt-v4 ClampZero
  if ((flags & TEXFLAG_ALBEDO) != 0u) rgb = min(rgb, vec3(1.0));
  return rgb;
}

// sin(pi u) (docs/textures-spec.md 7): r = u - 2 floor(u / 2) in [0, 2), then the accurate
// sine of the one float product pi * r.
float sin_pi(float u) {
  precise float r = u - 2.0 * floor(u / 2.0);
  precise float x = PI * r;
  return sin_accurate(x);
}

// Shirley's texture arrays (docs/textures-spec.md 7, seed 002 11.1.2): interpimage (2D mapping,
// nearest / bilinear / hermite over the one MipLevel, row j = 0 at the bottom) and volume
// (trilinear over nx x ny x nz voxels at p in texture space, period 1). The corners are read in
// one loop with one texel fetch, in the seed's order (2D: c00 c10 c01 c11; 3D: c000 c100 c010
// c001 c110 c101 c011 c111), each weight a left-to-right product times the texel value, summed
// left to right from 0. A float texture reads channel 0; a 1-channel image gives (g, g, g).
vec3 tex_shirley_array(uint ti, TexCtx c) {
  bool vol = texture_at(ti).type == TEXTURE_VOLUME;
  MipLevel ml = mip_level_at(texture_at(ti).image);
  uint interp = vol ? 1u : texture_at(ti).ip.x;
  ivec3 n = vol ? ivec3(texture_at(ti).ip.yzw) : ivec3(int(ml.width), int(ml.height), 1);
  vec3 x3 = vol ? tex_xform_point(texture_at(ti).xform, c.p) : vec3(tex_map_2d(ti, c).st, 0.0);
  if (any(isnan(x3)) || any(isinf(x3))) return vec3(0.0);
  precise vec3 X = x3 * vec3(n);
  vec3 fx = floor(X);
  precise vec3 f = X - fx;  // (u', v', w')
  ivec3 i0 = ivec3(mipmap_mod(shirley_int(fx.x), n.x), mipmap_mod(shirley_int(fx.y), n.y),
                   mipmap_mod(shirley_int(fx.z), n.z));
  ivec3 i1 = ivec3(mipmap_mod(i0.x + 1, n.x), mipmap_mod(i0.y + 1, n.y),
                   mipmap_mod(i0.z + 1, n.z));
  if (interp == 2u) {  // hermite: 3 u'^2 - 2 u'^3 in place of u'
    precise vec3 f2 = f * f;
    precise vec3 h = 3.0 * f2 - 2.0 * (f2 * f);
    f = h;
  }
  precise vec3 g = vec3(1.0) - f;
  bool want_float = (texture_at(ti).flags & TEXFLAG_FLOAT) != 0u;
  // Corner k's (di | dj << 1 | dk << 2) in nibble k.
  uint order = vol ? 0x76534210u : 0x3210u;
  int count = interp == 0u ? 1 : (vol ? 8 : 4);
  precise vec3 sum = vec3(0.0);
  [[dont_unroll]] for (int k = 0; k < count; ++k) {
    uint b = (order >> (4 * k)) & 7u;
    ivec3 ijk = ivec3((b & 1u) != 0u ? i1.x : i0.x, (b & 2u) != 0u ? i1.y : i0.y,
                      (b & 4u) != 0u ? i1.z : i0.z);
    // interpimage: row ny - 1 - j of the stored level (top row first); volume: slice k.
    uint row = vol ? uint(ijk.z * n.y + ijk.y) : uint(n.y - 1 - ijk.y);
    uint o = ml.offset + (row * uint(n.x) + uint(ijk.x)) * ml.channels;
    vec3 v = (want_float || ml.channels == 1u) ? vec3(texel_at(o))
                                               : vec3(texel_at(o), texel_at(o + 1u), texel_at(o + 2u));
    precise float wx = (b & 1u) != 0u ? f.x : g.x;
    precise float wy = (b & 2u) != 0u ? f.y : g.y;
    precise float wz = (b & 4u) != 0u ? f.z : g.z;
    precise float w = vol ? (wx * wy) * wz : wx * wy;
    if (interp == 0u) {
      sum = v;  // nearest: c(i0, j0)
    } else {
      precise vec3 term = w * v;
      sum += term;
    }
  }
  return sum;
}

// Whether instructions of this type are evaluated by tex_instruction_large (image maps, noise
// and Shirley's textures) rather than tex_instruction_small.
bool tex_type_large(uint type) { return type >= TEXTURE_DOTS; }

// Value of instruction ti of a small family (constant, checkerboard, scale, mix,
// directionmix, bilerp) whose children's values are a0, a1, a2 (docs/textures-spec.md 2).
vec3 tex_instruction_small(uint ti, TexCtx c, vec3 a0, vec3 a1, vec3 a2) {
  uint type = texture_at(ti).type;
  if (type == TEXTURE_CONSTANT) return texture_at(ti).param[0].xyz;
  // Each family below is compiled only into pipelines whose scene reaches it (FEATURES2): the
  // whole interpreter is inlined at its call site, and without the code of the families a
  // scene does not use lavapipe renders textures-image 25-45% and textures-procedural 11%
  // faster (8 spp, 3 runs each).
  if (has_feature2(FEATURE2_TEX_CHECKER_AA) && type == TEXTURE_CHECKERBOARD) {
    float w = tex_checkerboard(ti, c);
    vec3 t1 = w != 1.0 ? a0 : vec3(0.0);
    vec3 t2 = w != 0.0 ? a1 : vec3(0.0);
    precise vec3 r = (1.0 - w) * t1 + w * t2;
    return r;
  }
  if (has_feature2(FEATURE2_TEX_PROCEDURAL)) switch (type) {
    case TEXTURE_SCALE: {
      float sc = a1.x;
      precise vec3 r = a0 * sc;
      return sc == 0.0 ? vec3(0.0) : r;
    }
    case TEXTURE_MIX: {
      float amt = a2.x;
      vec3 t1 = amt != 1.0 ? a0 : vec3(0.0);
      vec3 t2 = amt != 0.0 ? a1 : vec3(0.0);
      precise vec3 r = (1.0 - amt) * t1 + amt * t2;
      return r;
    }
    case TEXTURE_DIRECTION_MIX: {
      float amt = abs(dot_exact(c.n, texture_at(ti).param[0].xyz));
      vec3 t1 = amt != 0.0 ? a0 : vec3(0.0);
      vec3 t2 = amt != 1.0 ? a1 : vec3(0.0);
      precise vec3 r = amt * t1 + (1.0 - amt) * t2;
      return r;
    }
    case TEXTURE_BILERP: {
      vec2 st = tex_map_2d(ti, c).st;
      precise vec3 r = (1.0 - st.x) * (1.0 - st.y) * texture_at(ti).param[0].xyz +
                       st.x * (1.0 - st.y) * texture_at(ti).param[2].xyz +
                       (1.0 - st.x) * st.y * texture_at(ti).param[1].xyz +
                       st.x * st.y * texture_at(ti).param[3].xyz;
      return r;
    }
  }
  return vec3(0.0);
}

// Value of instruction ti of a large family (tex_type_large) whose children's values are a0,
// a1 (docs/textures-spec.md 2).
vec3 tex_instruction_large(uint ti, TexCtx c, vec3 a0, vec3 a1) {
  uint type = texture_at(ti).type;
  if (has_feature(FEATURE_TEX_IMAGE) && type == TEXTURE_IMAGEMAP) return tex_image(ti, c);
  if (has_feature2(FEATURE2_TEX_SHIRLEY) && type >= TEXTURE_STRIPE && type <= TEXTURE_VOLUME) {
    // Shirley's solid textures (docs/textures-spec.md 7): one shirley_noise_sum call site
    // (solidnoise, solidturbulence, turbulentstripe), one sin_pi call site (stripe,
    // turbulentstripe), one array lookup (interpimage, volume).
    if (type == TEXTURE_IMAGE_INTERP || type == TEXTURE_VOLUME) return tex_shirley_array(ti, c);
    vec3 p = tex_xform_point(texture_at(ti).xform, c.p);
    vec4 prm = texture_at(ti).param[0];
    bool tstripe = type == TEXTURE_TURBULENT_STRIPE;
    float arg;
    if (type == TEXTURE_STRIPE) {
      uint form = texture_at(ti).ip.x;
      precise float xs = form == 0u ? p.x * 0.318309886 : p.x / prm.x;  // x / pi or x / w
      arg = xs;
    } else {
      bool turb = type != TEXTURE_SHIRLEY_NOISE;
      precise vec3 q = prm.y * p;  // turbulentstripe: k2 p
      float nt = shirley_noise_sum(tstripe ? q : p, turb ? int(texture_at(ti).ip.x) : 1, turb);
      if (!tstripe) {
        precise float v = prm.x * (nt + prm.y);  // scale * (n + offset)
        return vec3(v);
      }
      precise float a = prm.x * p.z + nt;  // k1 z + nt(k2 p)
      precise float xs = (a / prm.z) * 0.318309886;
      arg = xs;
    }
    float s = sin_pi(arg);
    if (type == TEXTURE_STRIPE && texture_at(ti).ip.x != 2u) return s > 0.0 ? a0 : a1;
    precise float t = (1.0 + s) / 2.0;
    // stripe smooth: (1 - t) tex1 + t tex2; turbulentstripe: t tex1 + (1 - t) tex2. A child
    // whose weight is 0 counts as 0 (as checkerboard's).
    float w1 = tstripe ? t : 1.0 - t, w2 = tstripe ? 1.0 - t : t;
    vec3 t1 = w1 != 0.0 ? a0 : vec3(0.0);
    vec3 t2 = w2 != 0.0 ? a1 : vec3(0.0);
    precise vec3 r = w1 * t1 + w2 * t2;
    return r;
  }
  if (has_feature(FEATURE_TEX_NOISE)) {
    switch (type) {
      case TEXTURE_DOTS:
        return tex_inside_polka_dot(tex_map_2d(ti, c).st) ? a0 : a1;
      case TEXTURE_FBM:
      case TEXTURE_WRINKLED:
      case TEXTURE_WINDY:
      case TEXTURE_MARBLE: {
        // One noise_sum call site for all four (windy needs two sums: a loop).
        mat4 xf = texture_at(ti).xform;
        vec4 prm = texture_at(ti).param[0];
        precise vec3 p = tex_xform_point(xf, c.p);
        precise vec3 dx = tex_xform_vector(xf, c.dpdx);
        precise vec3 dy = tex_xform_vector(xf, c.dpdy);
        if (type == TEXTURE_MARBLE) {  // pbrt-v4: p, dpdx, dpdy times scale
          p = prm.y * p;
          dx = prm.y * dx;
          dy = prm.y * dy;
        }
        bool windy = type == TEXTURE_WINDY;
        float v[2];
        [[dont_unroll]] for (int k = 0; k < (windy ? 2 : 1); ++k) {
          // windy: strength = fbm(0.1 p, 0.1 dpdx, 0.1 dpdy, 0.5, 3), height = fbm(p, .., 0.5, 6)
          float sc = windy && k == 0 ? 0.1 : 1.0;
          precise vec3 pk = sc * p;
          precise vec3 dxk = sc * dx;
          precise vec3 dyk = sc * dy;
          float omega = windy ? 0.5 : prm.x;
          int oct = windy ? (k == 0 ? 3 : 6) : int(texture_at(ti).ip.x);
          v[k] = noise_sum(windy && k == 0 ? pk : p, windy && k == 0 ? dxk : dx,
                           windy && k == 0 ? dyk : dy, omega, oct, type == TEXTURE_WRINKLED,
                           noise_split());
        }
        if (type == TEXTURE_MARBLE) return tex_marble(ti, p.y, v[0]);
        if (windy) {
          precise float w = abs(v[0]) * v[1];
          return vec3(w);
        }
        return vec3(v[0]);
      }
    }
  }
  return vec3(0.0);
}

// Children each tag pops (docs/textures-spec.md section 2).
int tex_child_count(uint type) {
  if (type == TEXTURE_MIX) return 3;
  if (type == TEXTURE_SCALE || type == TEXTURE_DIRECTION_MIX || type == TEXTURE_CHECKERBOARD ||
      type == TEXTURE_DOTS || type == TEXTURE_STRIPE || type == TEXTURE_TURBULENT_STRIPE)
    return 2;
  return 0;
}

// The value stack of the texture interpreter (tex_eval_rgb) and its depth; one spare slot
// (tex_push).
vec3 tex_stack[MAX_TEXTURE_STACK + 1u];
int tex_top;

// Pops the children of instruction i (tex_child_count) into a0, a1, a2 (zero beyond its count);
// false if the stack holds fewer (a malformed program: the host never emits one).
bool tex_pop_children(uint i, out vec3 a0, out vec3 a1, out vec3 a2) {
  int k = tex_child_count(texture_at(i).type);
  bool ok = tex_top >= k;
  if (ok) tex_top -= k;
  a0 = ok && k > 0 ? tex_stack[tex_top] : vec3(0.0);
  a1 = ok && k > 1 ? tex_stack[tex_top + 1] : vec3(0.0);
  a2 = ok && k > 2 ? tex_stack[tex_top + 2] : vec3(0.0);
  return ok;
}

// Pushes v; false if the stack is full (a malformed program). The store comes before the test
// (into the spare slot when full): lavapipe reads back and rewrites the old value of every lane a
// store's branch leaves out (docs/performance.md, fourteenth session).
bool tex_push(vec3 v) {
  tex_stack[tex_top] = v;
  if (tex_top >= int(MAX_TEXTURE_STACK)) return false;
  ++tex_top;
  return true;
}

// Value of the rgb texture program with root instruction root. The instructions run in program
// order, each run of small ones in a loop of their own and each large one after it: lavapipe
// runs the code of every family in each pass of a loop whatever the lanes need, so one loop
// over all instructions made every checkerboard or scale pay for the image and noise code.
vec3 tex_eval_rgb(uint root, TexCtx c) {
  if (no_feature(FEATURE_TEXTURES) || root >= uint(textures.length())) return vec3(0.0);
  tex_top = 0;
  // Each loop's end is tested at the end of a pass (a closing test at its start costs
  // lavapipe a pass).
  uint i = texture_at(root).first;
  if (i <= root) [[dont_unroll]] while (true) {
    if (!tex_type_large(texture_at(i).type)) [[dont_unroll]] while (true) {
      vec3 a0, a1, a2;
      bool ok = tex_pop_children(i, a0, a1, a2);
      if (!tex_push(tex_instruction_small(i, c, a0, a1, a2)) || !ok) return vec3(0.0);
      if (++i > root || tex_type_large(texture_at(i).type)) break;
    }
    if (i <= root) {
      vec3 a0, a1, a2;
      bool ok = tex_pop_children(i, a0, a1, a2);
      if (!tex_push(tex_instruction_large(i, c, a0, a1)) || !ok) return vec3(0.0);
      ++i;
    }
    if (i > root) break;
  }
  return tex_top > 0 ? tex_stack[tex_top - 1] : vec3(0.0);
}

// Value of the float texture program with root instruction root.
float tex_eval_float(uint root, TexCtx c) { return tex_eval_rgb(root, c).x; }

// pbrt-v4 CameraBase::Approximate_dp_dxy with the minimum differentials of Globals.
void approximate_dp_dxy(vec3 p, vec3 n, out vec3 dpdx, out vec3 dpdy) {
  vec3 pc = tex_xform_point(globals.camera_from_world, p);
  mat4 W = globals.world_from_camera;
  vec3 nc = vec3(dot_exact(W[0].xyz, n), dot_exact(W[1].xyz, n), dot_exact(W[2].xyz, n));
  // pbrt-v4 RotateFromTo(normalize(pc), (0, 0, 1)): two reflections.
  float pl = sqrt(dot_exact(pc, pc));
  vec3 from = pl > 0.0 ? pc / pl : vec3(0.0, 0.0, 1.0);
  vec3 to = vec3(0.0, 0.0, 1.0);
  vec3 refl = abs(from.x) < 0.72 ? vec3(1.0, 0.0, 0.0)
            : (abs(from.y) < 0.72 ? vec3(0.0, 1.0, 0.0) : vec3(0.0, 0.0, 1.0));
  precise vec3 u = refl - from;
  precise vec3 v = refl - to;
  float uu = dot_exact(u, u), vv = dot_exact(v, v), uvd = dot_exact(u, v);
  float r[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      precise float e = (i == j ? 1.0 : 0.0) - 2.0 / uu * u[i] * u[j] - 2.0 / vv * v[i] * v[j] +
                        4.0 * uvd / (uu * vv) * v[i] * u[j];
      r[i * 3 + j] = e;
    }
  precise vec3 p_down = vec3(r[0] * pc.x + r[1] * pc.y + r[2] * pc.z,
                             r[3] * pc.x + r[4] * pc.y + r[5] * pc.z,
                             r[6] * pc.x + r[7] * pc.y + r[8] * pc.z);
  precise vec3 n_down = vec3(r[0] * nc.x + r[1] * nc.y + r[2] * nc.z,
                             r[3] * nc.x + r[4] * nc.y + r[5] * nc.z,
                             r[6] * nc.x + r[7] * nc.y + r[8] * nc.z);
  precise float d = n_down.z * p_down.z;
  vec3 ox = globals.min_pos_dx.xyz, oy = globals.min_pos_dy.xyz;
  precise vec3 dx = to + globals.min_dir_dx.xyz;
  precise vec3 dy = to + globals.min_dir_dy.xyz;
  precise float tx = -(dot_exact(n_down, ox) - d) / dot_exact(n_down, dx);
  precise float ty = -(dot_exact(n_down, oy) - d) / dot_exact(n_down, dy);
  precise vec3 ex = ox + tx * dx - p_down;
  precise vec3 ey = oy + ty * dy - p_down;
  // The inverse rotation is the transpose.
  precise vec3 cx = vec3(r[0] * ex.x + r[3] * ex.y + r[6] * ex.z,
                         r[1] * ex.x + r[4] * ex.y + r[7] * ex.z,
                         r[2] * ex.x + r[5] * ex.y + r[8] * ex.z);
  precise vec3 cy = vec3(r[0] * ey.x + r[3] * ey.y + r[6] * ey.z,
                         r[1] * ey.x + r[4] * ey.y + r[7] * ey.z,
                         r[2] * ey.x + r[5] * ey.y + r[8] * ey.z);
  float s = globals.min_dir_dx.w;
  precise vec3 wx = s * tex_xform_vector(W, cx);
  precise vec3 wy = s * tex_xform_vector(W, cy);
  dpdx = wx;
  dpdy = wy;
}

// True if every component of v is finite.
bool tex_finite3(vec3 v) { return !any(isnan(v)) && !any(isinf(v)); }

// Clamp of a (u, v) differential to [-1e8, 1e8], 0 if not finite (pbrt-v4).
float tex_clean(float x) { return (isnan(x) || isinf(x)) ? 0.0 : clamp(x, -1e8, 1e8); }

// o + t d, uncontracted (the CPU's -ffp-contract=off).
vec3 point_along(vec3 o, vec3 d, float t) {
  precise vec3 p = o + t * d;
  return p;
}

// pbrt-v4 RayDifferential::ScaleDifferentials (docs/textures-spec.md 3.1): the differential
// rays of the ray (o, d) moved towards it by the factor s.
RayDiff scale_differentials(RayDiff r, vec3 o, vec3 d, float s) {
  precise vec3 rxo = o + (r.rx_o - o) * s;
  precise vec3 ryo = o + (r.ry_o - o) * s;
  precise vec3 rxd = d + (r.rx_d - d) * s;
  precise vec3 ryd = d + (r.ry_d - d) * s;
  return RayDiff(rxo, rxd, ryo, ryd);
}

// Differentials of the ray leaving a perfectly specular bounce (docs/textures-spec.md 3.1,
// pbrt-v4 SurfaceInteraction::SpawnRay): c the hit's footprint, o the spawned ray's origin, ns
// the shading normal with derivatives dndu, dndv, wo = -d of the incoming ray (differentials
// r), wi the sampled world direction, transmission the sampled kind, eta its relative IOR.
// False when pbrt-v4 drops them (a squared length above 1e16, or NaN).
bool specular_differentials(TexCtx c, vec3 o, vec3 ns, vec3 dndu, vec3 dndv, vec3 wo, vec3 wi,
                            bool transmission, float eta, inout RayDiff r) {
  precise vec3 n = ns;
  precise vec3 dndx = dndu * c.dudx + dndv * c.dvdx;
  precise vec3 dndy = dndu * c.dudy + dndv * c.dvdy;
  precise vec3 dwodx = -r.rx_d - wo;
  precise vec3 dwody = -r.ry_d - wo;
  precise vec3 rxo = o + c.dpdx;
  precise vec3 ryo = o + c.dpdy;
  if (transmission && dot_exact(wo, n) < 0.0) {
    n = -n;
    dndx = -dndx;
    dndy = -dndy;
  }
  precise float dx = dot_exact(dwodx, n) + dot_exact(wo, dndx);
  precise float dy = dot_exact(dwody, n) + dot_exact(wo, dndy);
  float won = dot_exact(wo, n);
  vec3 rxd, ryd;
  if (!transmission) {
    rxd = (wi - dwodx) + 2.0 * (won * dndx + dx * n);
    ryd = (wi - dwody) + 2.0 * (won * dndy + dy * n);
  } else {
    float win = dot_exact(wi, n);
    precise float mu = won / eta - abs(win);
    precise float k = 1.0 / eta + (1.0 / (eta * eta)) * won / win;
    precise float dmudx = dx * k;
    precise float dmudy = dy * k;
    rxd = (wi - eta * dwodx) + (mu * dndx + dmudx * n);
    ryd = (wi - eta * dwody) + (mu * dndy + dmudy * n);
  }
  r = RayDiff(rxo, rxd, ryo, ryd);
  // pbrt-v4 "squash potentially troublesome differentials" (NaN fails the test too).
  return dot_exact(rxd, rxd) <= 1e16 && dot_exact(ryd, ryd) <= 1e16 &&
         dot_exact(rxo, rxo) <= 1e16 && dot_exact(ryo, ryo) <= 1e16;
}

// Footprint of a hit (docs/textures-spec.md section 3, pbrt-v4
// SurfaceInteraction::ComputeDifferentials): dpdx, dpdy and the (u, v) differentials of c
// (p, n, uv set) from the ray's differentials r when has_diff, else approximate_dp_dxy.
void compute_differentials(inout TexCtx c, vec3 dpdu, vec3 dpdv, bool has_diff, RayDiff r) {
  c.dpdx = vec3(0.0);
  c.dpdy = vec3(0.0);
  c.dudx = 0.0;
  c.dudy = 0.0;
  c.dvdx = 0.0;
  c.dvdy = 0.0;
  if ((globals.texture_opts.x & TEXOPT_DISABLE_FILTERING) != 0u) return;
  bool done = false;
  if (has_diff) {
    vec3 rxo = r.rx_o, rxd = r.rx_d, ryo = r.ry_o, ryd = r.ry_d;
    float ndx = dot_exact(c.n, rxd), ndy = dot_exact(c.n, ryd);
    if (ndx != 0.0 && ndy != 0.0) {
      float dd = -dot_exact(c.n, c.p);
      precise float tx = (-dot_exact(c.n, rxo) - dd) / ndx;
      precise float ty = (-dot_exact(c.n, ryo) - dd) / ndy;
      precise vec3 px = rxo + tx * rxd;
      precise vec3 py = ryo + ty * ryd;
      precise vec3 ex = px - c.p;
      precise vec3 ey = py - c.p;
      c.dpdx = ex;
      c.dpdy = ey;
      done = true;
    }
  }
  if (!done) approximate_dp_dxy(c.p, c.n, c.dpdx, c.dpdy);
  if (!tex_finite3(c.dpdx)) c.dpdx = vec3(0.0);
  if (!tex_finite3(c.dpdy)) c.dpdy = vec3(0.0);
  // Least squares for (u, v) differentials (pbrt-v4 ComputeDifferentials).
  float a00 = dot_exact(dpdu, dpdu), a01 = dot_exact(dpdu, dpdv), a11 = dot_exact(dpdv, dpdv);
  precise float det = a00 * a11 - a01 * a01;
  float inv_det = 1.0 / det;
  if (isnan(inv_det) || isinf(inv_det)) inv_det = 0.0;
  float b0x = dot_exact(dpdu, c.dpdx), b1x = dot_exact(dpdv, c.dpdx);
  float b0y = dot_exact(dpdu, c.dpdy), b1y = dot_exact(dpdv, c.dpdy);
  precise float dudx = (a11 * b0x - a01 * b1x) * inv_det;
  precise float dvdx = (a00 * b1x - a01 * b0x) * inv_det;
  precise float dudy = (a11 * b0y - a01 * b1y) * inv_det;
  precise float dvdy = (a00 * b1y - a01 * b0y) * inv_det;
  c.dudx = tex_clean(dudx);
  c.dvdx = tex_clean(dvdx);
  c.dudy = tex_clean(dudy);
  c.dvdy = tex_clean(dvdy);
}

#endif
