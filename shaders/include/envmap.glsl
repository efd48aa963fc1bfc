// Environment maps: pbrt-v4 ImageInfiniteLight (lights.h, lights.cpp) over an equal-area
// octahedral image (docs/textures-spec.md section 6), and the documented extensions of 6.8:
// pbrt-v3's lat-long map (InfiniteAreaLight) and Shirley's vertical-strip cube map. Needs
// bindings.glsl.
//
// Light fields: data.x = MipLevel of the image (level 0), data.y / data.z = offsets in
// tex_data of the plain / MIS-compensated PiecewiseConstant2D, data.w = mapping (ENVMAP_*),
// light_from_world = rotation into the light's frame (world from light is its transpose),
// L.rgb = scale.
// Distribution layout at offset o (floats): nu, nv, marginal integral, 0; marginal func[nv];
// marginal cdf[nv + 1]; then per row v: conditional func[nu], cdf[nu + 1], integral.
//
// Code size: lavapipe inlines every call, so the render shader calls env_eval once (escaped
// rays, lights.glsl infinite_light_le) and env_sample once (light_sample). The mapping is a
// branch inside each of them (direction -> (uv, Jacobian) in env_eval, (uv) -> (direction,
// Jacobian) in env_sample); the two 1D samplings of env_sample share one loop, its sines and
// cosines share one env_sincos call, and the texel fetch is written once (env_image_le: one
// loop over 1 texel (nearest) or 4 (lat-long bilerp) with one fetch, through texel_at).
// Arithmetic is precise (no fma contraction), sums left to right, sin / cos / acos / atan2
// from trig.glsl.
#ifndef BASALT_ENVMAP_GLSL
#define BASALT_ENVMAP_GLSL

#include "math.glsl"
#include "trig.glsl"

// Light.data.w of LIGHT_INFINITE_IMAGE (docs/textures-spec.md 6.8; the host's numbering).
const uint ENVMAP_EQUAL_AREA = 0u;
const uint ENVMAP_LATLONG = 1u;
const uint ENVMAP_CUBE = 2u;

// Constants of 6.8 (as float literals of the spec; PI of math.glsl is the same float).
const float ENV_INV_PI = 0.318309886;
const float ENV_INV_2PI = 0.159154937;
const float ENV_TWO_PI = 6.28318548;  // 2 * PI in float (exact)
const float ENV_TWO_PI2 = 19.7392088; // 2 pi^2

// copysign(m, s) for any m: |m| with the sign bit of s (std::copysign).
float env_copysign(float m, float s) {
  return uintBitsToFloat((floatBitsToUint(m) & 0x7fffffffu) | (floatBitsToUint(s) & 0x80000000u));
}

// pbrt-v4 EqualAreaSphereToSquare (util/math.cpp, Clarberg's mapping): unit d -> [0,1]^2.
// The atan polynomial is evaluated by Horner without fma (pbrt-v4's EvaluatePolynomial uses FMA).
vec2 equal_area_sphere_to_square(vec3 d) {
  float x = abs(d.x), y = abs(d.y), z = abs(d.z);
  float r = safe_sqrt(1.0 - z);
  float a = max(x, y);
  float b = min(x, y);
  b = a == 0.0 ? 0.0 : b / a;
  precise float phi =
      0.406758566246788489601959989e-5 +
      b * (0.636226545274016134946890922156 +
           b * (0.61572017898280213493197203466e-2 +
                b * (-0.247333733281268944196501420480 +
                     b * (0.881770664775316294736387951347e-1 +
                          b * (0.419038818029165735901852432784e-1 +
                               b * -0.251390972343483509333252996350e-1)))));
  if (x < y) phi = 1.0 - phi;
  precise float v = phi * r;
  precise float u = r - v;
  if (d.z < 0.0) {
    float t = u;
    u = 1.0 - v;
    v = 1.0 - t;
  }
  u = env_copysign(u, d.x);
  v = env_copysign(v, d.y);
  precise vec2 st = vec2(0.5 * (u + 1.0), 0.5 * (v + 1.0));
  return st;
}

// sin_accurate(x) and cos_accurate(x) of trig.glsl for x >= 0 with one shared reduction
// (the same r, j and polynomials, so the same results; std::sin / std::cos in pbrt-v4).
void env_sincos(float x, out float s, out float c) {
  int j;
  precise float r = trig_reduced(x, j);
  precise float z = r * r;
  float sp = trig_sin_poly(r, z), cp = trig_cos_poly(z);
  float ss = 1.0, cs = 1.0;
  if (j > 3) {
    j -= 4;
    ss = -1.0;
    cs = -1.0;
  }
  if (j > 1) cs = -cs;
  bool swap = j == 1 || j == 2;
  s = ss * (swap ? cp : sp);
  c = cs * (swap ? sp : cp);
}

// pbrt-v4 EqualAreaSquareToSphere (util/math.cpp): [0,1]^2 -> unit direction, in two
// halves around the sine and cosine of phi (computed by the caller, env_sample, with the
// lat-long angles in one env_sincos loop). First half: phi; u, v, r, signed distance out.
float equal_area_phi(vec2 p, out float u, out float v, out float r, out float sd) {
  precise float pu = 2.0 * p.x - 1.0;
  precise float pv = 2.0 * p.y - 1.0;
  float up = abs(pu), vp = abs(pv);
  precise float signed_distance = 1.0 - (up + vp);
  float d = abs(signed_distance);
  precise float rr = 1.0 - d;
  precise float phi = ((rr == 0.0 ? 1.0 : (vp - up) / rr + 1.0) * PI) / 4.0;
  u = pu;
  v = pv;
  r = rr;
  sd = signed_distance;
  return phi;
}

// Second half of EqualAreaSquareToSphere from sin(phi), cos(phi) and the first half's outputs.
vec3 equal_area_direction(float sin_phi, float cos_phi, float u, float v, float r, float sd) {
  precise float z = env_copysign(1.0 - r * r, sd);
  cos_phi = env_copysign(cos_phi, u);
  sin_phi = env_copysign(sin_phi, v);
  precise float s = safe_sqrt(2.0 - r * r);
  precise vec3 w = vec3(cos_phi * r * s, sin_phi * r * s, z);
  return w;
}

// pbrt-v4 MIPMap::Bilerp / Image::BilerpChannel's Mod (WRAP_REPEAT, spec 4.2 step 1):
// ((x % r) + r) % r from non-negative operands only (GLSL leaves % of negatives undefined).
int env_mod(int a, int b) { return a >= 0 ? a % b : b - 1 - ((-1 - a) % b); }

// Radiance of the image at lookup point p, scale applied, ClampZero per channel
// (docs/textures-spec.md 6.3 and 6.8), by mapping:
// - equal-area: pbrt-v4 ImageInfiniteLight::ImageLe, LookupNearestChannel(p) with
//   WrapMode::OctahedralSphere (util/image.h RemapPixelCoords);
// - lat-long: pbrt-v3 MIPMap::Lookup at width 0 = spec 4.2 step 2's Bilerp at level 0 with
//   repeat wrap in both axes, p = (u, v);
// - cube: nearest texel of face `face` at p = face coordinates (fu, fv) in [0,1]^2.
// One loop over the taps (1 nearest, 4 bilerp) with a single fetch; a 1-channel image gives
// (g, g, g).
vec3 env_image_le(uint light, vec2 p, int face, uint mapping) {
  MipLevel lv = mip_levels[lights[light].data.x];
  int w = int(lv.width), h = int(lv.height);
  int x, y;
  int taps = 1;
  float dx = 0.0, dy = 0.0;
  if (mapping == ENVMAP_LATLONG) {
    // Spec 4.2 step 2: x = u w - 0.5, fx = floor(x), xi = int(fx), dx = x - fx (y likewise).
    precise float xf = p.x * float(w) - 0.5;
    precise float yf = p.y * float(h) - 0.5;
    float fx = floor(xf), fy = floor(yf);
    const float lim = 1073741824.0;  // int(v) clamps to [-2^30, 2^30] (spec 4.2)
    x = int(clamp(fx, -lim, lim));
    y = int(clamp(fy, -lim, lim));
    precise float ddx = xf - fx;
    precise float ddy = yf - fy;
    dx = ddx;
    dy = ddy;
    taps = 4;
  } else if (mapping == ENVMAP_CUBE) {
    // tx = min(int(fu n), n - 1), ty = face n + min(int(fv n), n - 1), n = width.
    x = min(int(p.x * float(w)), w - 1);
    y = face * w + min(int(p.y * float(w)), w - 1);
  } else {
    x = int(p.x * float(w));
    y = int(p.y * float(h));
    if (x < 0) {
      x = -x;             // mirror across u = 0
      y = h - 1 - y;      // and v = 0.5
    } else if (x >= w) {
      x = 2 * w - 1 - x;  // mirror across u = 1
      y = h - 1 - y;
    }
    if (y < 0) {
      x = w - 1 - x;      // mirror across u = 0.5
      y = -y;             // and v = 0
    } else if (y >= h) {
      x = w - 1 - x;
      y = 2 * h - 1 - y;  // mirror across v = 1
    }
    if (w == 1) x = 0;
    if (h == 1) y = 0;
  }
  uint step = lv.channels == 3u ? 1u : 0u;  // a grey texel is read three times
  // Bilerp order v00, v10, v01, v11 with weights ((1-dx)(1-dy)), (dx(1-dy)), ((1-dx)dy),
  // (dx dy), summed left to right from the first term (0 + t00 = t00 exactly).
  precise vec3 sum = vec3(0.0);
  [[dont_unroll]] for (int k = 0; k < taps; ++k) {
    int tx = x, ty = y;
    precise float wgt = 1.0;
    if (mapping == ENVMAP_LATLONG) {
      int kx = k & 1, ky = k >> 1;
      tx = env_mod(x + kx, w);
      ty = env_mod(y + ky, h);
      precise float wx = kx != 0 ? dx : 1.0 - dx;
      precise float wy = ky != 0 ? dy : 1.0 - dy;
      wgt = wx * wy;
    }
    // Safety only (p far outside [0,1]^2 or NaN): never read outside the level.
    tx = clamp(tx, 0, w - 1);
    ty = clamp(ty, 0, h - 1);
    uint i = lv.offset + (uint(ty) * lv.width + uint(tx)) * lv.channels;
    vec3 c = vec3(texel_at(i), texel_at(i + step), texel_at(i + 2u * step));
    sum += wgt * c;
  }
  return lights[light].L.rgb * max(sum, vec3(0.0));
}

// Le and pdf at one world direction w (pointing away from the scene), sharing the lookup
// point (docs/textures-spec.md 6.3, 6.4, 6.8): returns Le (scale applied); pdf = the solid-angle
// pdf of the MIS-compensated distribution when compensated (allowIncompletePDF), else the
// plain one. mapPdf = PiecewiseConstant2D::PDF at the map's (u, v): texel (int(u nu),
// int(v nv)) clamped, func / marginal integral, 0 if the integral is not > 0. Then
//   equal-area: pdf = mapPdf / (4 pi) (pbrt-v4 PDF_Li);
//   lat-long:   pdf = mapPdf / (2 pi^2 sin theta), sin theta = sqrt(x^2 + y^2) of the
//               normalised wl, 0 if sin theta == 0 (pbrt-v3);
//   cube:       pdf = mapPdf * r^3 / 24 on the strip, mapPdf at the looked-up texel.
// The render shader calls this once (escaped rays); env_le and env_pdf are its two halves.
vec3 env_eval(uint light, vec3 w_world, bool compensated, out float pdf) {
  uint mapping = lights[light].data.w;
  // To the light's frame (6.2): normalize(m0 w.x + m1 w.y + m2 w.z), summed left to right.
  mat4 m = lights[light].light_from_world;
  precise vec3 wl0 = m[0].xyz * w_world.x + m[1].xyz * w_world.y + m[2].xyz * w_world.z;
  vec3 wl = safe_normalize(wl0);
  vec2 uv;          // the distribution's (u, v)
  vec2 p;           // the texel lookup's point (env_image_le)
  int face = 0;     // cube face
  float jac = 0.0;  // lat-long: sin theta; cube: r
  if (mapping == ENVMAP_LATLONG) {
    // theta = acos(clamp(z)), phi = atan2(y, x) (+ 2 pi if negative), uv = (phi / 2pi,
    // theta / pi). atan2_accurate returns 0 for a zero (x, y); C's atan2 gives +-pi there when
    // x is -0, which the + 2 pi turns into pi.
    float theta = acos_accurate(clamp(wl.z, -1.0, 1.0));
    float phi = atan2_accurate(wl.y, wl.x);
    if (wl.x == 0.0 && wl.y == 0.0) phi = (floatBitsToUint(wl.x) & 0x80000000u) != 0u ? PI : 0.0;
    if (phi < 0.0) {
      precise float pp = phi + ENV_TWO_PI;
      phi = pp;
    }
    precise vec2 uvl = vec2(phi * ENV_INV_2PI, theta * ENV_INV_PI);
    uv = uvl;
    p = uv;
    // sin theta = sqrt(x^2 + y^2) of the normalised wl (6.8; not sin(acos(z))).
    precise float st = sqrt(wl.x * wl.x + wl.y * wl.y);
    jac = st;
  } else if (mapping == ENVMAP_CUBE) {
    // Face by the largest |component| (ties to x, then y; 0 counts as not > 0), face
    // coordinates (a, b) = (., .) / m in OpenGL orientation, (fu, fv) = ((a + 1) / 2, (b + 1) / 2).
    float ax = abs(wl.x), ay = abs(wl.y), az = abs(wl.z);
    float mm;
    vec2 ab;
    if (ax >= ay && ax >= az) {
      face = wl.x > 0.0 ? 0 : 1;
      mm = ax;
      ab = face == 0 ? vec2(-wl.z, -wl.y) : vec2(wl.z, -wl.y);
    } else if (ay >= az) {
      face = wl.y > 0.0 ? 2 : 3;
      mm = ay;
      ab = face == 2 ? vec2(wl.x, wl.z) : vec2(wl.x, -wl.z);
    } else {
      face = wl.z > 0.0 ? 4 : 5;
      mm = az;
      ab = face == 4 ? vec2(wl.x, -wl.y) : vec2(-wl.x, -wl.y);
    }
    precise float a = ab.x / mm;
    precise float b = ab.y / mm;
    precise float fu = (a + 1.0) * 0.5;
    precise float fv = (b + 1.0) * 0.5;
    // The pdf reads the distribution at the lookup's texel (tx, ty) (6.8), not at the strip
    // uv (fu, (face + fv) / 6) re-quantised, so only (fu, fv) and the face are kept.
    p = vec2(fu, fv);
    uv = p;
    precise float r = sqrt((1.0 + a * a) + b * b);
    jac = r;
  } else {
    uv = equal_area_sphere_to_square(wl);
    p = uv;
  }
  uint o = compensated ? lights[light].data.z : lights[light].data.y;
  uint nu = uint(tex_data[o]), nv = uint(tex_data[o + 1u]);
  float integral = tex_data[o + 2u];
  int iu, iv;
  if (mapping == ENVMAP_CUBE) {
    // The texel of the lookup (env_image_le), n = nu: tx = min(int(fu n), n - 1),
    // ty = face n + min(int(fv n), n - 1).
    iu = min(int(p.x * float(nu)), int(nu) - 1);
    iv = face * int(nu) + min(int(p.y * float(nu)), int(nu) - 1);
  } else {
    iu = int(uv.x * float(nu));
    iv = int(uv.y * float(nv));
  }
  iu = clamp(iu, 0, int(nu) - 1);
  iv = clamp(iv, 0, int(nv) - 1);
  float f = tex_data[o + 5u + 2u * nv + uint(iv) * (2u * nu + 2u) + uint(iu)];
  float map_pdf = integral > 0.0 ? f / integral : 0.0;
  precise float pd;
  if (mapping == ENVMAP_LATLONG) {
    pd = jac == 0.0 ? 0.0 : map_pdf / (ENV_TWO_PI2 * jac);
  } else if (mapping == ENVMAP_CUBE) {
    pd = map_pdf * (jac * jac * jac) / 24.0;
  } else {
    pd = map_pdf / (4.0 * PI);
  }
  pdf = pd;
  return env_image_le(light, p, face, mapping);
}

// Le: radiance arriving from world direction w (pointing away from the scene), scale applied.
vec3 env_le(uint light, vec3 w_world) {
  float pdf_unused;
  return env_eval(light, w_world, false, pdf_unused);
}

// PDF_Li: solid-angle pdf of direction w (see env_eval).
float env_pdf(uint light, vec3 w_world, bool compensated) {
  float pdf;
  env_eval(light, w_world, compensated, pdf);
  return pdf;
}

// pbrt-v4 ImageInfiniteLight::SampleLi (pbrt-v3 InfiniteAreaLight::Sample_Li for lat-long):
// PiecewiseConstant2D::Sample (marginal with u.y, then the conditional of the chosen row with
// u.x; PiecewiseConstant1D::Sample with FindInterval), mapPdf = pdf_u * pdf_v, then by mapping
// (docs/textures-spec.md 6.5, 6.8):
//   equal-area: wl = EqualAreaSquareToSphere(uv), pdf = mapPdf / (4 pi);
//   lat-long:   theta = v pi, phi = u 2pi, wl = (sin t cos p, sin t sin p, cos t),
//               pdf = mapPdf / (2 pi^2 sin t), no sample unless sin t > 0;
//   cube:       face = (sampled row) / n, (a, b) = 2 (u, clamp(6 v - face, 0, 1)) - 1,
//               wl = normalize of the face's point, pdf = mapPdf r^3 / 24;
// wi = world from light of wl (not renormalised), le = the image at the sampled point.
// False (wi, pdf, le all 0) when mapPdf is 0 or there is no sample.
bool env_sample(uint light, vec2 u, bool compensated, out vec3 wi, out float pdf, out vec3 le) {
  wi = vec3(0.0);
  pdf = 0.0;
  le = vec3(0.0);
  uint o = compensated ? lights[light].data.z : lights[light].data.y;
  uint nu = uint(tex_data[o]), nv = uint(tex_data[o + 1u]);
  // Step 0: the marginal (func at o + 4, cdf after it); step 1: the conditional of row v.
  uint base = o + 4u, n = nv;
  float integral = tex_data[o + 2u];
  float uk = u.y;
  vec2 uv = vec2(0.0);
  float pdf_v = 0.0, pdf_u = 0.0;
  uint row = 0u;  // the sampled row (lo of the marginal)
  [[dont_unroll]] for (uint k = 0u; k < 2u; ++k) {
    uint cdf = base + n;
    // Largest i < n with cdf[i] <= uk (pbrt-v4 FindInterval).
    uint lo = 0u, hi = n;
    [[dont_unroll]] while (hi - lo > 1u) {
      uint mid = (lo + hi) / 2u;
      if (tex_data[cdf + mid] <= uk) lo = mid; else hi = mid;
    }
    float c0 = tex_data[cdf + lo];
    precise float width = tex_data[cdf + lo + 1u] - c0;
    precise float du = uk - c0;
    if (width > 0.0) du = du / width;
    float p = integral > 0.0 ? tex_data[base + lo] / integral : 0.0;
    precise float x = (float(lo) + du) / float(n);
    if (k == 0u) {
      uv.y = x;
      pdf_v = p;
      row = lo;
      base = o + 5u + 2u * nv + lo * (2u * nu + 2u);
      n = nu;
      integral = tex_data[base + 2u * nu + 1u];
      uk = u.x;
    } else {
      uv.x = x;
      pdf_u = p;
    }
  }
  float map_pdf = pdf_u * pdf_v;
  if (map_pdf == 0.0) return false;
  uint mapping = lights[light].data.w;
  vec3 wl;
  vec2 p = uv;   // the texel lookup's point
  int face = 0;  // cube face
  precise float pd;
  if (mapping == ENVMAP_CUBE) {
    // The face of the sampled row (6.8: not int(6 v), which rounding can push to the next
    // face), fv clamped to [0, 1].
    face = min(int(row / nu), 5);  // (min: safety only, row < 6 n)
    precise float s6 = uv.y * 6.0;
    precise float fv0 = s6 - float(face);
    float fv = clamp(fv0, 0.0, 1.0);
    precise float a = 2.0 * uv.x - 1.0;
    precise float b = 2.0 * fv - 1.0;
    vec3 d;
    if (face == 0) {
      d = vec3(1.0, -b, -a);
    } else if (face == 1) {
      d = vec3(-1.0, -b, a);
    } else if (face == 2) {
      d = vec3(a, 1.0, b);
    } else if (face == 3) {
      d = vec3(a, -1.0, -b);
    } else if (face == 4) {
      d = vec3(a, -b, 1.0);
    } else {
      d = vec3(-a, -b, -1.0);
    }
    wl = safe_normalize(d);
    precise float r = sqrt((1.0 + a * a) + b * b);
    pd = map_pdf * (r * r * r) / 24.0;
    p = vec2(uv.x, fv);
  } else {
    // Equal-area needs sin and cos of one angle (phi), lat-long of two (theta, phi): one
    // env_sincos call site for both (all angles are >= 0).
    bool latlong = mapping == ENVMAP_LATLONG;
    float eu = 0.0, ev = 0.0, er = 0.0, esd = 0.0;
    precise vec2 ang;
    if (latlong) {
      ang = vec2(uv.y * PI, uv.x * ENV_TWO_PI);
    } else {
      ang = vec2(equal_area_phi(uv, eu, ev, er, esd), 0.0);
    }
    vec2 sn = vec2(0.0), cs = vec2(1.0);
    [[dont_unroll]] for (int k = 0; k < (latlong ? 2 : 1); ++k) {
      float s, c;
      env_sincos(k == 0 ? ang.x : ang.y, s, c);
      if (k == 0) {
        sn.x = s;
        cs.x = c;
      } else {
        sn.y = s;
        cs.y = c;
      }
    }
    if (latlong) {
      if (!(sn.x > 0.0)) return false;  // uv.y = 1 gives sin(PI) < 0
      precise vec3 wll = vec3(sn.x * cs.y, sn.x * sn.y, cs.x);
      wl = wll;
      pd = map_pdf / (ENV_TWO_PI2 * sn.x);
    } else {
      wl = equal_area_direction(sn.x, cs.x, eu, ev, er, esd);
      pd = map_pdf / (4.0 * PI);
    }
  }
  mat4 m = lights[light].light_from_world;
  wi = vec3(dot_exact(m[0].xyz, wl), dot_exact(m[1].xyz, wl), dot_exact(m[2].xyz, wl));
  pdf = pd;
  le = env_image_le(light, p, face, mapping);
  return true;
}

#endif
