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
// cos(x) to about 1 ulp for |x| < 2^15.
precise float cos_accurate(float x) {
  int j;
  float r = trig_reduced(abs(x), j);
  float sgn = 1.0;
  if (j > 3) {
    j -= 4;
    sgn = -sgn;
  }
  if (j > 1) sgn = -sgn;
  float z = r * r;
  float y = (j == 1 || j == 2) ? trig_sin_poly(r, z) : trig_cos_poly(z);
  return sgn * y;
}

#endif
