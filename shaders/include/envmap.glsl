// Environment maps: pbrt-v4 ImageInfiniteLight (lights.h, lights.cpp) over an equal-area
// octahedral image (docs/textures-spec.md section 6). Needs bindings.glsl.
//
// Light fields: data.x = MipLevel of the image (level 0), data.y / data.z = offsets in
// tex_data of the plain / MIS-compensated PiecewiseConstant2D, light_from_world = rotation
// into the light's frame (world from light is its transpose), L.rgb = scale.
// Distribution layout at offset o (floats): nu, nv, marginal integral, 0; marginal func[nv];
// marginal cdf[nv + 1]; then per row v: conditional func[nu], cdf[nu + 1], integral.
//
// Code size: lavapipe inlines every call, so the render shader calls env_eval once (escaped
// rays, lights.glsl infinite_light_le) and env_sample once (light_sample); the two 1D
// samplings of env_sample share one loop and the texel fetch is written once (env_image_le).
// Arithmetic is precise (no fma contraction), sums left to right, sin / cos from trig.glsl.
#ifndef BASALT_ENVMAP_GLSL
#define BASALT_ENVMAP_GLSL

#include "math.glsl"
#include "trig.glsl"

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

// pbrt-v4 EqualAreaSquareToSphere (util/math.cpp): [0,1]^2 -> unit direction.
vec3 equal_area_square_to_sphere(vec2 p) {
  precise float u = 2.0 * p.x - 1.0;
  precise float v = 2.0 * p.y - 1.0;
  float up = abs(u), vp = abs(v);
  precise float signed_distance = 1.0 - (up + vp);
  float d = abs(signed_distance);
  precise float r = 1.0 - d;
  precise float phi = ((r == 0.0 ? 1.0 : (vp - up) / r + 1.0) * PI) / 4.0;
  precise float z = env_copysign(1.0 - r * r, signed_distance);
  float sin_phi, cos_phi;
  env_sincos(phi, sin_phi, cos_phi);
  cos_phi = env_copysign(cos_phi, u);
  sin_phi = env_copysign(sin_phi, v);
  precise float s = safe_sqrt(2.0 - r * r);
  precise vec3 w = vec3(cos_phi * r * s, sin_phi * r * s, z);
  return w;
}

// pbrt-v4 ImageInfiniteLight::Le / PDF_Li's direction to image point:
// EqualAreaSphereToSquare(normalize(light_from_world * w)), the product summed m0 w.x +
// m1 w.y + m2 w.z left to right (the pdf normalises too, so Le and pdf see the same uv).
vec2 env_uv(uint light, vec3 w) {
  mat4 m = lights[light].light_from_world;
  precise vec3 wl = m[0].xyz * w.x + m[1].xyz * w.y + m[2].xyz * w.z;
  return equal_area_sphere_to_square(safe_normalize(wl));
}

// pbrt-v4 ImageInfiniteLight::ImageLe: scale * ClampZero(LookupNearestChannel(uv) with
// WrapMode::OctahedralSphere) (util/image.h LookupNearestChannel, RemapPixelCoords);
// a 1-channel image gives (g, g, g).
vec3 env_image_le(uint light, vec2 uv) {
  MipLevel lv = mip_levels[lights[light].data.x];
  int w = int(lv.width), h = int(lv.height);
  int x = int(uv.x * float(w)), y = int(uv.y * float(h));
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
  // Safety only (uv far outside [0,1]^2 or NaN): never read outside the level.
  x = clamp(x, 0, w - 1);
  y = clamp(y, 0, h - 1);
  uint i = lv.offset + (uint(y) * lv.width + uint(x)) * lv.channels;
  uint step = lv.channels == 3u ? 1u : 0u;  // a grey texel is read three times
  vec3 c = vec3(texels[i], texels[i + step], texels[i + 2u * step]);
  return lights[light].L.rgb * max(c, vec3(0.0));
}

// pbrt-v4 ImageInfiniteLight::Le and PDF_Li at one world direction w (pointing away from
// the scene), sharing the uv: returns Le (scale applied); pdf = PiecewiseConstant2D::PDF at
// uv (texel (int(u nu), int(v nv)) clamped, func / marginal integral; 0 if the integral is 0)
// over 4 pi, of the MIS-compensated distribution when compensated (allowIncompletePDF).
// The render shader calls this once (escaped rays); env_le and env_pdf are its two halves.
vec3 env_eval(uint light, vec3 w_world, bool compensated, out float pdf) {
  vec2 uv = env_uv(light, w_world);
  uint o = compensated ? lights[light].data.z : lights[light].data.y;
  uint nu = uint(tex_data[o]), nv = uint(tex_data[o + 1u]);
  float integral = tex_data[o + 2u];
  int iu = clamp(int(uv.x * float(nu)), 0, int(nu) - 1);
  int iv = clamp(int(uv.y * float(nv)), 0, int(nv) - 1);
  float f = tex_data[o + 5u + 2u * nv + uint(iv) * (2u * nu + 2u) + uint(iu)];
  float map_pdf = integral > 0.0 ? f / integral : 0.0;
  pdf = map_pdf / (4.0 * PI);
  return env_image_le(light, uv);
}

// pbrt-v4 ImageInfiniteLight::Le: radiance arriving from world direction w (pointing away
// from the scene), scale applied.
vec3 env_le(uint light, vec3 w_world) {
  float pdf_unused;
  return env_eval(light, w_world, false, pdf_unused);
}

// pbrt-v4 ImageInfiniteLight::PDF_Li: solid-angle pdf of direction w (see env_eval).
float env_pdf(uint light, vec3 w_world, bool compensated) {
  float pdf;
  env_eval(light, w_world, compensated, pdf);
  return pdf;
}

// pbrt-v4 ImageInfiniteLight::SampleLi: PiecewiseConstant2D::Sample (marginal with u.y, then
// the conditional of the chosen row with u.x; PiecewiseConstant1D::Sample with FindInterval),
// mapPdf = pdf_u * pdf_v, wi = world from light of EqualAreaSquareToSphere(uv),
// pdf = mapPdf / (4 pi), le = ImageLe(uv). False (wi, pdf, le all 0) when mapPdf is 0.
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
  vec3 wl = equal_area_square_to_sphere(uv);
  mat4 m = lights[light].light_from_world;
  wi = vec3(dot_exact(m[0].xyz, wl), dot_exact(m[1].xyz, wl), dot_exact(m[2].xyz, wl));
  pdf = map_pdf / (4.0 * PI);
  le = env_image_le(light, uv);
  return true;
}

#endif
