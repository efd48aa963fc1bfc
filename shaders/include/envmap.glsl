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
//
// Portals (mapping 3, ENVMAP_PORTAL; pbrt-v4 PortalImageInfiniteLight, spec 6.9), compiled
// only into pipelines with FEATURE2_ENV_PORTAL: data.x = the rectified image, data.y = data.z
// = offset of the windowed distribution (nx, ny, 0, 0, func[nx ny], sat[nx ny]),
// light_from_world = the portal frame as rows, pos.xyz = p0, dir.xyz = p2. Each portal helper
// has one call site per render-shader function: env_eval maps the direction and the window's
// two corners from both points in one loop (portal_eval_uv), env_sample evaluates every
// summed-area integral of its two bisections in one loop (portal_sample_uv), and shares
// env_sincos (tan = sin / cos of the two angles) and env_image_le with the other mappings.
#ifndef BASALT_ENVMAP_GLSL
#define BASALT_ENVMAP_GLSL

#include "math.glsl"
#include "trig.glsl"

// Light.data.w of LIGHT_INFINITE_IMAGE (docs/textures-spec.md 6.8; the host's numbering).
const uint ENVMAP_EQUAL_AREA = 0u;
const uint ENVMAP_LATLONG = 1u;
const uint ENVMAP_CUBE = 2u;
const uint ENVMAP_PORTAL = 3u;  // 6.9

// Constants of 6.8 (as float literals of the spec; PI of math.glsl is the same float).
const float ENV_INV_PI = 0.318309886;
const float ENV_INV_2PI = 0.159154937;
const float ENV_TWO_PI = 6.28318548;  // 2 * PI in float (exact)
const float ENV_TWO_PI2 = 19.7392088; // 2 pi^2
const float ENV_PI2 = 9.86960411;     // PI * PI in float (6.9)

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

// sin_accurate(x) and cos_accurate(x) of trig.glsl (std::sin / std::cos in pbrt-v4).
void env_sincos(float x, out float s, out float c) {
  vec2 cs = cos_sin_accurate(x);
  s = cs.y;
  c = cs.x;
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
// - cube: nearest texel of face `face` at p = face coordinates (fu, fv) in [0,1]^2;
// - portal: the rectified image's nearest texel, clamped (pbrt-v4 PortalImageInfiniteLight::
//   ImageLookup, LookupNearestChannel with WrapMode::Clamp; spec 6.9 lookup).
// One loop over the taps (1 nearest, 4 bilerp) with a single fetch; a 1-channel image gives
// (g, g, g).
vec3 env_image_le(uint light, vec2 p, int face, uint mapping) {
  MipLevel lv = mip_level_at(light_at(light).data.x);
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
  } else if (has_feature2(FEATURE2_ENV_PORTAL) && mapping == ENVMAP_PORTAL) {
    x = int(p.x * float(w));  // clamped to the image below
    y = int(p.y * float(h));
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
  return light_at(light).L.rgb * max(sum, vec3(0.0));
}

// pbrt-v4 PortalImageInfiniteLight::ImageFromRender (lights.h; spec 6.9 world_to_image):
// world direction w -> portal image uv = ((atan2(x, z) + pi/2) / pi, (atan2(y, z) + pi/2) / pi)
// clamped to [0, 1], and duv_dw = pi^2 (1 - x^2) (1 - y^2) / z, with (x, y, z) = w in the
// portal frame (not normalised). False (none) when z <= 0 (or NaN).
bool portal_world_to_image(uint light, vec3 w, out vec2 uv, out float duv_dw) {
  mat4 m = light_at(light).light_from_world;
  precise vec3 wp = m[0].xyz * w.x + m[1].xyz * w.y + m[2].xyz * w.z;
  uv = vec2(0.0);
  duv_dw = 0.0;
  if (!(wp.z > 0.0)) return false;  // z <= 0 (or NaN): none
  precise float j = ((ENV_PI2 * (1.0 - wp.x * wp.x)) * (1.0 - wp.y * wp.y)) / wp.z;
  duv_dw = j;
  [[dont_unroll]] for (int k = 0; k < 2; ++k) {  // one atan2_accurate call site
    float a = atan2_accurate(k == 0 ? wp.x : wp.y, wp.z);
    precise float t = (a + PI_OVER_2) / PI;
    uv[k] = clamp(t, 0.0, 1.0);
  }
  return true;
}

// pbrt-v4 SummedAreaTable::Integral (util/sampling.h; spec 6.9 integral) of the windowed
// distribution at offset o over the box (bmin, bmax): the four corner Lookups A = (max.x,
// max.y), B = (min.x, max.y), C = (min.x, min.y), D = (max.x, min.y), each bilinear in the
// table (LookupInt: 0 on the lower borders, clamped at the upper ones); (A - B) + (C - D) with
// both differences exact (Knuth's two_diff; pbrt-v4 forms them in double); max(. / (nx ny), 0).
float portal_integral(uint o, uint nx, uint ny, vec2 bmin, vec2 bmax) {
  uint sat = o + 4u + nx * ny;
  precise vec4 s;
  [[dont_unroll]] for (int c = 0; c < 4; ++c) {
    float x = (c == 0 || c == 3) ? bmax.x : bmin.x;
    float y = c < 2 ? bmax.y : bmin.y;
    precise float xs = x * float(nx);
    precise float ys = y * float(ny);
    int x0 = int(xs), y0 = int(ys);
    precise float dx = xs - float(x0);
    precise float dy = ys - float(y0);
    // v00, v01, v10, v11 weighted ((1-dx)(1-dy)), ((1-dx) dy), (dx (1-dy)), (dx dy), summed
    // left to right from the first term (0 + t00 = t00 exactly).
    precise float sum = 0.0;
    [[dont_unroll]] for (int t = 0; t < 4; ++t) {
      int i = x0 + (t >> 1), jj = y0 + (t & 1);
      float v = 0.0;
      if (i > 0 && jj > 0)
        v = tex_data_at(sat + uint(min(jj - 1, int(ny) - 1)) * nx + uint(min(i - 1, int(nx) - 1)));
      precise float wx = (t >> 1) != 0 ? dx : 1.0 - dx;
      precise float wy = (t & 1) != 0 ? dy : 1.0 - dy;
      sum += (wx * wy) * v;
    }
    s[c] = sum;
  }
  // two_diff(a, b): h = a - b, bb = h - a, l = (a - (h - bb)) - (b + bb), h + l = a - b exactly.
  precise float h1 = s.x - s.y;
  precise float b1 = h1 - s.x;
  precise float l1 = (s.x - (h1 - b1)) - (s.y + b1);
  precise float h2 = s.z - s.w;
  precise float b2 = h2 - s.z;
  precise float l2 = (s.z - (h2 - b2)) - (s.w + b2);
  precise float total = (h1 + h2) + (l1 + l2);
  precise float r = total / float(nx * ny);
  return max(r, 0.0);
}

// The portal half of env_eval (pbrt-v4 PortalImageInfiniteLight::Le and PDF_Li, lights.cpp;
// spec 6.9 Le and pdf): uv_le = world_to_image(normalize(w)), visible when it and the window
// seen from ray_o (ImageBounds: the box of the images of p0 and p2) exist and uv_le lies in it
// (inclusive); uv_pdf, duv_dw = world_to_image(w) (duv_dw = 0 if none) and integral = the
// summed-area integral over the window seen from p_ref (0 if none). One loop maps the six
// directions (normalize(w), w, p0 - ray_o, p2 - ray_o, p0 - p_ref, p2 - p_ref), copying
// instead when w is already normalised or p_ref == ray_o.
void portal_eval_uv(uint light, vec3 w, vec3 ray_o, vec3 p_ref, out vec2 uv_le,
                    out bool visible, out vec2 uv_pdf, out float duv_dw, out float integral) {
  vec3 wn = safe_normalize(w);
  bool same_w = all(equal(floatBitsToUint(wn), floatBitsToUint(w)));
  bool same_p = all(equal(floatBitsToUint(p_ref), floatBitsToUint(ray_o)));
  vec3 c0 = light_at(light).pos.xyz, c2 = light_at(light).dir.xyz;
  bool ok_le = false, ok_pdf = false, ok_o = true, ok_p = true;
  float j_le = 0.0, j_pdf = 0.0;
  vec2 a_o = vec2(0.0), b_o = vec2(0.0), a_p = vec2(0.0), b_p = vec2(0.0);
  uv_le = vec2(0.0);
  uv_pdf = vec2(0.0);
  [[dont_unroll]] for (int k = 0; k < 6; ++k) {
    if ((k == 1 && same_w) || (k >= 4 && same_p)) continue;  // copied below
    vec3 d;
    if (k < 2) {
      d = k == 0 ? wn : w;
    } else {
      precise vec3 e = ((k & 1) == 0 ? c0 : c2) - (k < 4 ? ray_o : p_ref);
      d = safe_normalize(e);
    }
    vec2 t;
    float j;
    bool ok = portal_world_to_image(light, d, t, j);
    if (k == 0) {
      uv_le = t;
      j_le = j;
      ok_le = ok;
    } else if (k == 1) {
      uv_pdf = t;
      j_pdf = j;
      ok_pdf = ok;
    } else if (k == 2) {
      a_o = t;
      ok_o = ok;
    } else if (k == 3) {
      b_o = t;
      ok_o = ok_o && ok;
    } else if (k == 4) {
      a_p = t;
      ok_p = ok;
    } else {
      b_p = t;
      ok_p = ok_p && ok;
    }
  }
  if (same_w) {
    uv_pdf = uv_le;
    j_pdf = j_le;
    ok_pdf = ok_le;
  }
  if (same_p) {
    a_p = a_o;
    b_p = b_o;
    ok_p = ok_o;
  }
  visible = ok_le && ok_o && all(greaterThanEqual(uv_le, min(a_o, b_o))) &&
            all(lessThanEqual(uv_le, max(a_o, b_o)));
  duv_dw = ok_pdf ? j_pdf : 0.0;
  integral = 0.0;
  if (ok_pdf && j_pdf != 0.0 && ok_p) {
    uint o = light_at(light).data.y;
    integral = portal_integral(o, uint(tex_data_at(o)), uint(tex_data_at(o + 1u)), min(a_p, b_p),
                               max(a_p, b_p));
  }
}

// The portal half of env_sample before the direction (pbrt-v4 PortalImageInfiniteLight::
// SampleLi with ImageBounds and WindowedPiecewiseConstant2D::Sample, util/sampling.h; spec 6.9
// sample): the window box seen from p; I = its integral; x = bisect(Px, u.x) over the box's
// columns with Px(s) = integral(box with max.x = s) / I; the column box c of x's cell;
// y = bisect(Py, u.y) with Py(s) = integral(c with max.y = s) / integral(c); map_pdf =
// func(x, y) / I. Bisection (SampleBisection): halve [lo, hi] while ceil(n hi) - floor(n lo)
// > 1 (at most 64 steps), then interpolate between P(lo) and P(hi) (t = 0.5 if they are
// equal). Every integral is evaluated at the one call site of a state machine. False when
// there is no sample (no window, a zero integral).
bool portal_sample_uv(uint light, vec2 u, vec3 p, out vec2 uv, out float map_pdf) {
  uv = vec2(0.0);
  map_pdf = 0.0;
  vec2 ca = vec2(0.0), cb = vec2(0.0);
  [[dont_unroll]] for (int k = 0; k < 2; ++k) {  // ImageBounds: the images of p0 and p2
    precise vec3 e = (k == 0 ? light_at(light).pos.xyz : light_at(light).dir.xyz) - p;
    vec2 t;
    float j;
    if (!portal_world_to_image(light, safe_normalize(e), t, j)) return false;
    if (k == 0) ca = t; else cb = t;
  }
  vec2 bmin = min(ca, cb), bmax = max(ca, cb);
  uint o = light_at(light).data.y;
  uint nx = uint(tex_data_at(o)), ny = uint(tex_data_at(o + 1u));
  // k = 0 samples x in the window (cmin, cmax) = box, k = 1 samples y in the column c. States:
  // 0 = the normaliser (I, then integral(c)), 1 = P(mid), 2 = P(lo), 3 = P(hi).
  vec2 cmin = bmin, cmax = bmax;
  float total = 0.0, norm = 1.0, lo = 0.0, hi = 0.0, mid = 0.0, pl = 0.0;
  int k = 0, state = 0, steps = 0;
  bool done = false;
  [[dont_unroll]] for (int it = 0; it < 2 * (64 + 3); ++it) {
    vec2 qmax = cmax;
    if (state != 0) qmax[k] = state == 1 ? mid : (state == 2 ? lo : hi);
    float v = portal_integral(o, nx, ny, cmin, qmax);
    float uk = k == 0 ? u.x : u.y;
    float n = float(k == 0 ? nx : ny);
    if (state == 0) {
      if (v == 0.0) return false;
      norm = v;
      if (k == 0) total = v;
      lo = bmin[k];
      hi = bmax[k];
      steps = 0;
    } else {
      precise float pv = v / norm;
      if (state == 1) {
        if (pv > uk) hi = mid; else lo = mid;
        ++steps;
      } else if (state == 2) {
        pl = pv;
        state = 3;
        continue;
      } else {
        // Lerp(t, lo, hi) clamped to [lo, hi].
        precise float dp = pv - pl;
        precise float t = dp > 0.0 ? (uk - pl) / dp : 0.5;
        precise float xl = (1.0 - t) * lo + t * hi;
        float x = clamp(xl, lo, hi);
        uv[k] = x;
        if (k == 1) {
          done = true;
          break;
        }
        // The column of x: (floor(x nx) / nx, min.y) .. (ceil(x nx) / nx, max.y), one cell
        // wide when x lies on a cell edge.
        precise float xn = x * n;
        precise float c_lo = floor(xn) / n;
        precise float c_hi = ceil(xn) / n;
        if (c_lo == c_hi) c_hi = c_hi + 1.0 / n;
        cmin = vec2(c_lo, bmin.y);
        cmax = vec2(c_hi, bmax.y);
        k = 1;
        state = 0;
        continue;
      }
    }
    // After the normaliser or a step: bisect on, or evaluate the end points.
    precise float span = ceil(n * hi) - floor(n * lo);
    if (span > 1.0 && steps < 64) {
      precise float m2 = (lo + hi) / 2.0;
      mid = m2;
      state = 1;
    } else {
      state = 2;
    }
  }
  if (!done) return false;
  // WindowedPiecewiseConstant2D::Eval at (x, y), divided by I.
  uint ix = uint(min(int(uv.x * float(nx)), int(nx) - 1));
  uint iy = uint(min(int(uv.y * float(ny)), int(ny) - 1));
  map_pdf = tex_data_at(o + 4u + iy * nx + ix) / total;
  return true;
}

// Le and pdf at one world direction w (pointing away from the scene), sharing the lookup
// point (docs/textures-spec.md 6.3, 6.4, 6.8): returns Le (scale applied); pdf = the solid-angle
// pdf of the MIS-compensated distribution when compensated (allowIncompletePDF), else the
// plain one. mapPdf = PiecewiseConstant2D::PDF at the map's (u, v): texel (int(u nu),
// int(v nv)) clamped, func / marginal integral, 0 if the integral is not > 0. Then
//   equal-area: pdf = mapPdf / (4 pi) (pbrt-v4 PDF_Li);
//   lat-long:   pdf = mapPdf / (2 pi^2 sin theta), sin theta = sqrt(x^2 + y^2) of the
//               normalised wl, 0 if sin theta == 0 (pbrt-v3);
//   cube:       pdf = mapPdf * r^3 / 24 on the strip, mapPdf at the looked-up texel;
//   portal:     pdf = (func(uv) / window integral from p_ref) / duv_dw (6.9), and Le is 0
//               unless the direction passes through the window seen from ray_o.
// The render shader calls this once (escaped rays); env_le and env_pdf are its two halves.
vec3 env_eval(uint light, vec3 w_world, bool compensated, vec3 ray_o, vec3 p_ref, out float pdf) {
  uint mapping = light_at(light).data.w;
  // To the light's frame (6.2): normalize(m0 w.x + m1 w.y + m2 w.z), summed left to right.
  mat4 m = light_at(light).light_from_world;
  precise vec3 wl0 = m[0].xyz * w_world.x + m[1].xyz * w_world.y + m[2].xyz * w_world.z;
  vec3 wl = safe_normalize(wl0);
  vec2 uv;          // the distribution's (u, v)
  vec2 p;           // the texel lookup's point (env_image_le)
  int face = 0;     // cube face
  float jac = 0.0;  // lat-long: sin theta; cube: r; portal: duv_dw
  bool portal = has_feature2(FEATURE2_ENV_PORTAL) && mapping == ENVMAP_PORTAL;
  bool visible = true;       // portal: the Le direction passes through the window
  float portal_int = 0.0;    // portal: the window's integral seen from p_ref
  if (portal) {
    // Le at p = world_to_image(normalize(w)) if seen through the window from ray_o; the pdf at
    // uv = world_to_image(w) against the window seen from p_ref (6.9).
    portal_eval_uv(light, w_world, ray_o, p_ref, p, visible, uv, jac, portal_int);
  } else if (mapping == ENVMAP_LATLONG) {
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
  uint o = compensated ? light_at(light).data.z : light_at(light).data.y;
  uint nu = uint(tex_data_at(o)), nv = uint(tex_data_at(o + 1u));
  float integral = tex_data_at(o + 2u);
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
  // Portal: WindowedPiecewiseConstant2D::Eval reads func[iv nx + iu] at o + 4 (the same
  // min(int(uv nx), nx - 1) texel, uv being in [0, 1]).
  uint fi = portal ? o + 4u + uint(iv) * nu + uint(iu)
                   : o + 5u + 2u * nv + uint(iv) * (2u * nu + 2u) + uint(iu);
  float f = tex_data_at(fi);
  float map_pdf = integral > 0.0 ? f / integral : 0.0;
  precise float pd;
  if (portal) {
    // pdf = (func(uv) / I) / duv_dw, 0 if uv, the window or I is missing or duv_dw is 0.
    pd = (portal_int != 0.0 && jac != 0.0) ? (f / portal_int) / jac : 0.0;
  } else if (mapping == ENVMAP_LATLONG) {
    pd = jac == 0.0 ? 0.0 : map_pdf / (ENV_TWO_PI2 * jac);
  } else if (mapping == ENVMAP_CUBE) {
    pd = map_pdf * (jac * jac * jac) / 24.0;
  } else {
    pd = map_pdf / (4.0 * PI);
  }
  pdf = pd;
  vec3 le = env_image_le(light, p, face, mapping);
  return visible ? le : vec3(0.0);
}

// Le: radiance arriving from world direction w (pointing away from the scene), scale applied.
vec3 env_le(uint light, vec3 w_world, vec3 ray_o) {
  float pdf_unused;
  return env_eval(light, w_world, false, ray_o, ray_o, pdf_unused);
}

// PDF_Li: solid-angle pdf of direction w (see env_eval).
float env_pdf(uint light, vec3 w_world, bool compensated, vec3 p_ref) {
  float pdf;
  env_eval(light, w_world, compensated, p_ref, p_ref, pdf);
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
//   portal:     (uv, mapPdf) of the window seen from p_ref (portal_sample_uv), wl =
//               normalize(tan alpha, tan beta, 1), pdf = mapPdf / duv_dw (6.9);
// wi = world from light of wl (not renormalised), le = the image at the sampled point.
// False (wi, pdf, le all 0) when mapPdf is 0 or there is no sample.
bool env_sample(uint light, vec2 u, bool compensated, vec3 p_ref, out vec3 wi, out float pdf,
                out vec3 le) {
  wi = vec3(0.0);
  pdf = 0.0;
  le = vec3(0.0);
  uint mapping = light_at(light).data.w;
  bool portal = has_feature2(FEATURE2_ENV_PORTAL) && mapping == ENVMAP_PORTAL;
  uint o = compensated ? light_at(light).data.z : light_at(light).data.y;
  uint nu = uint(tex_data_at(o)), nv = uint(tex_data_at(o + 1u));
  // Step 0: the marginal (func at o + 4, cdf after it); step 1: the conditional of row v.
  // (A portal samples its windowed distribution instead, portal_sample_uv.)
  uint base = o + 4u, n = nv;
  float integral = tex_data_at(o + 2u);
  float uk = u.y;
  vec2 uv = vec2(0.0);
  float pdf_v = 0.0, pdf_u = 0.0;
  uint row = 0u;  // the sampled row (lo of the marginal)
  [[dont_unroll]] for (uint k = 0u; k < (portal ? 0u : 2u); ++k) {
    uint cdf = base + n;
    // Largest i < n with cdf[i] <= uk (pbrt-v4 FindInterval).
    uint lo = 0u, hi = n;
    [[dont_unroll]] while (hi - lo > 1u) {
      uint mid = (lo + hi) / 2u;
      if (tex_data_at(cdf + mid) <= uk) lo = mid; else hi = mid;
    }
    float c0 = tex_data_at(cdf + lo);
    precise float width = tex_data_at(cdf + lo + 1u) - c0;
    precise float du = uk - c0;
    if (width > 0.0) du = du / width;
    float p = integral > 0.0 ? tex_data_at(base + lo) / integral : 0.0;
    precise float x = (float(lo) + du) / float(n);
    if (k == 0u) {
      uv.y = x;
      pdf_v = p;
      row = lo;
      base = o + 5u + 2u * nv + lo * (2u * nu + 2u);
      n = nu;
      integral = tex_data_at(base + 2u * nu + 1u);
      uk = u.x;
    } else {
      uv.x = x;
      pdf_u = p;
    }
  }
  float map_pdf = pdf_u * pdf_v;
  if (portal && !portal_sample_uv(light, u, p_ref, uv, map_pdf)) return false;
  if (map_pdf == 0.0) return false;
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
    // Equal-area needs sin and cos of one angle (phi), lat-long of two (theta, phi), a portal
    // of two (|alpha|, |beta|, for tan = sin / cos): one env_sincos call site for all (all
    // angles are >= 0).
    bool latlong = mapping == ENVMAP_LATLONG;
    float eu = 0.0, ev = 0.0, er = 0.0, esd = 0.0;
    precise vec2 ang;
    // Portal (pbrt-v4 RenderFromImage): alpha = -pi/2 + u pi, beta = -pi/2 + v pi.
    precise vec2 ab = vec2(-PI_OVER_2 + uv.x * PI, -PI_OVER_2 + uv.y * PI);
    if (latlong) {
      ang = vec2(uv.y * PI, uv.x * ENV_TWO_PI);
    } else if (portal) {
      ang = abs(ab);
    } else {
      ang = vec2(equal_area_phi(uv, eu, ev, er, esd), 0.0);
    }
    vec2 sn = vec2(0.0), cs = vec2(1.0);
    [[dont_unroll]] for (int k = 0; k < (latlong || portal ? 2 : 1); ++k) {
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
    } else if (portal) {
      // (x, y) = (tan alpha, tan beta) (sin_accurate of a negative angle is -sin of its
      // magnitude); v = normalize(x, y, 1); duv_dw = pi^2 (1 - v.x^2) (1 - v.y^2) / v.z;
      // pdf = mapPdf / duv_dw; no sample if duv_dw == 0 or the pdf is not > 0 (6.9).
      precise vec2 tn = vec2((ab.x < 0.0 ? -sn.x : sn.x) / cs.x,
                             (ab.y < 0.0 ? -sn.y : sn.y) / cs.y);
      wl = safe_normalize(vec3(tn, 1.0));
      precise float duv_dw = ((ENV_PI2 * (1.0 - wl.x * wl.x)) * (1.0 - wl.y * wl.y)) / wl.z;
      if (duv_dw == 0.0) return false;
      pd = map_pdf / duv_dw;
      if (!(pd > 0.0)) return false;
    } else {
      wl = equal_area_direction(sn.x, cs.x, eu, ev, er, esd);
      pd = map_pdf / (4.0 * PI);
    }
  }
  mat4 m = light_at(light).light_from_world;
  wi = vec3(dot_exact(m[0].xyz, wl), dot_exact(m[1].xyz, wl), dot_exact(m[2].xyz, wl));
  pdf = pd;
  le = env_image_le(light, p, face, mapping);
  return true;
}

#endif
