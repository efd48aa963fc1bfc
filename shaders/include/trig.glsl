// Inverse trigonometric functions accurate to a few ulps. The SPIR-V -> NIR translation of
// GLSL acos / asin / atan uses short polynomials (errors around 1e-5 .. 1e-4), which move
// measured-BRDF lookups across bin boundaries and Beckmann azimuths away from the CPU's
// libm; these follow the single-precision Cephes library (S. L. Moshier, asinf.c, atanf.c).
#ifndef BASALT_TRIG_GLSL
#define BASALT_TRIG_GLSL

#include "math.glsl"

// Cephes asinf on [0, 1] (callers pass |x|).
precise float asin_pos(float a) {
  float x = a, z;
  bool big = a > 0.5;
  if (big) {
    z = 0.5 * (1.0 - a);
    x = sqrt(z);
  } else {
    z = a * a;
  }
  float p = ((((4.2163199048e-2 * z + 2.4181311049e-2) * z + 4.5470025998e-2) * z +
              7.4953002686e-2) * z + 1.6666752422e-1) * z * x + x;
  if (a < 1.0e-4) p = a;
  if (big) p = PI_OVER_2 - (p + p);
  return p;
}

// Cephes acosf: arc cosine of x in [-1, 1] (clamped).
precise float acos_accurate(float x) {
  x = clamp(x, -1.0, 1.0);
  if (x < -0.5) return PI - 2.0 * asin_pos(sqrt(0.5 * (1.0 + x)));
  if (x > 0.5) return 2.0 * asin_pos(sqrt(0.5 * (1.0 - x)));
  float s = asin_pos(abs(x));
  return PI_OVER_2 - (x < 0.0 ? -s : s);
}

// Cephes atanf.
precise float atan_accurate(float xx) {
  float x = abs(xx), y = 0.0;
  if (x > 2.414213562373095) {
    y = PI_OVER_2;
    x = -1.0 / x;
  } else if (x > 0.4142135623730950) {
    y = PI_OVER_4;
    x = (x - 1.0) / (x + 1.0);
  }
  float z = x * x;
  y += (((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z -
        3.33329491539e-1) * z * x + x;
  return xx < 0.0 ? -y : y;
}

// atan2(y, x) in [-pi, pi] from atan_accurate (C's atan2 conventions for zeros).
precise float atan2_accurate(float y, float x) {
  if (x == 0.0) {
    if (y == 0.0) return 0.0;
    return y > 0.0 ? PI_OVER_2 : -PI_OVER_2;
  }
  float a = atan_accurate(y / x);
  if (x > 0.0) return a;
  return y < 0.0 ? a - PI : a + PI;
}


// Cephes sinf / cosf (S. L. Moshier, sinf.c, cosf.c): octant reduction by pi/4 in three parts
// (DP1 + DP2 + DP3, each product exact for |x| < 2^15) and the single-precision minimax
// polynomials. lavapipe's sin and cos reduce in float: near 2 pi their absolute error (~1e-7)
// becomes a large relative error of a tiny result, which flips near-tangent sampled
// directions against the CPU's libm. Used by every sample warp.
precise float trig_reduced(float x, out int j) {
  float y = floor(x * 1.27323954473516);
  j = int(y);
  if ((j & 1) != 0) {
    j += 1;
    y += 1.0;
  }
  j &= 7;
  return ((x - y * 0.78515625) - y * 2.4187564849853515625e-4) - y * 3.77489497744594108e-8;
}
precise float trig_sin_poly(float x, float z) {
  return ((-1.9515295891e-4 * z + 8.3321608736e-3) * z - 1.6666654611e-1) * z * x + x;
}
precise float trig_cos_poly(float z) {
  return ((2.443315711809948e-5 * z - 1.388731625493765e-3) * z + 4.166664568298827e-2) * z * z -
         0.5 * z + 1.0;
}
// sin(x) to about 1 ulp for |x| < 2^15.
precise float sin_accurate(float x) {
  float sgn = x < 0.0 ? -1.0 : 1.0;
  int j;
  float r = trig_reduced(abs(x), j);
  if (j > 3) {
    sgn = -sgn;
    j -= 4;
  }
  float z = r * r;
  float y = (j == 1 || j == 2) ? trig_cos_poly(z) : trig_sin_poly(r, z);
  return sgn * y;
}
// (cos x, sin x) to about 1 ulp for |x| < 2^15 from one reduction and both polynomials (cos
// is even; sin takes the sign of x): every sample warp wants both, and two functions would
// reduce twice.
precise vec2 cos_sin_accurate(float x) {
  int j;
  float r = trig_reduced(abs(x), j);
  float z = r * r;
  float sp = trig_sin_poly(r, z), cp = trig_cos_poly(z);
  float ss = x < 0.0 ? -1.0 : 1.0, cs = 1.0;
  if (j > 3) {
    j -= 4;
    ss = -ss;
    cs = -cs;
  }
  if (j > 1) cs = -cs;
  bool swap = j == 1 || j == 2;
  return vec2(cs * (swap ? sp : cp), ss * (swap ? cp : sp));
}

// Cephes expf (S. L. Moshier, expf.c): x = n ln2 + r with ln2 in two parts (C1 exact in few
// bits), the single-precision minimax polynomial for e^r, scaled by 2^n. lavapipe's exp goes
// through exp2(x log2 e), whose rounded product loses relative accuracy as |x| grows (1e-4 at
// x ~ -16, where narrow Beckmann lobes evaluate it). 0 below -87.33654 (the result would be
// subnormal, which both renderers count as 0), +inf above 88.72284.
precise float exp_accurate(float x) {
  if (x < -87.33654) return 0.0;
  if (x > 88.72284) return 1.0 / 0.0;
  float n = floor(1.44269504088896341 * x + 0.5);
  precise float r = (x - n * 0.693359375) - n * -2.12194440e-4;
  precise float y = ((((((1.9875691500e-4 * r + 1.3981999507e-3) * r + 8.3334519073e-3) * r +
                        4.1665795894e-2) * r + 1.6666665459e-1) * r + 5.0000001201e-1) * r * r) +
                    r + 1.0;
  return ldexp(y, int(n));
}

// Cephes logf (S. L. Moshier, logf.c): x = m 2^e with m in [sqrt(1/2), sqrt(2)), ln(m) by the
// single-precision minimax polynomial in m - 1, e ln2 added in two parts. lavapipe's log loses
// relative accuracy (pbrt-v3's roughness polynomial, whose terms cancel 400:1 near roughness
// 1e-3, turns 1e-6 in ln r into 1e-4 in a Beckmann D). For x > 0 finite.
precise float log_accurate(float x) {
  int e;
  precise float m = frexp(x, e);
  if (m < 0.707106781186547524) {
    e -= 1;
    m = m + m - 1.0;
  } else {
    m = m - 1.0;
  }
  precise float z = m * m;
  precise float y = ((((((((7.0376836292e-2 * m - 1.1514610310e-1) * m + 1.1676998740e-1) * m -
                         1.2420140846e-1) * m + 1.4249322787e-1) * m - 1.6668057665e-1) * m +
                      2.0000714765e-1) * m - 2.4999993993e-1) * m + 3.3333331174e-1) * m * z;
  float fe = float(e);
  y += -2.12194440e-4 * fe;
  y += -0.5 * z;
  return (m + y) + 0.693359375 * fe;
}

// ln(1 + x) for x > -1, accurate near x = 0 as well (the GPU's log is only accurate in
// absolute terms there): 2 atanh(s), s = x / (2 + x), by its series for |x| < 1/8 (s^2 <= 0.0035,
// five terms reach float precision); log(1 + x) otherwise. docs/materials-spec.md 2.1 numerics.
precise float log1p_accurate(float x) {
  if (abs(x) >= 0.125) return log_accurate(1.0 + x);
  precise float s = x / (2.0 + x);
  precise float s2 = s * s;
  return 2.0 * s * (1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 / 9.0))));
}

#endif
