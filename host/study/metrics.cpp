// Image error metrics for `basalt study`: pbrt-v4's relative MSE and SSIM.
#include "study/metrics.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace basalt::study {

namespace {

/// Throws unless the two images have the same resolution.
void check_same_size(const Image& img, const Image& ref) {
  if (img.width != ref.width || img.height != ref.height)
    throw std::invalid_argument("image is " + std::to_string(img.width) + "x" +
                                std::to_string(img.height) + ", reference is " +
                                std::to_string(ref.width) + "x" + std::to_string(ref.height));
}

/// sRGB transfer function (IEC 61966-2-1) of a linear value clamped to [0, 1].
double srgb_encode(double v) {
  v = std::clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

/// Filters \p src (w x h) with the separable kernel \p k (odd length n) and keeps only the
/// positions where the kernel lies wholly inside: (w - n + 1) x (h - n + 1) values.
std::vector<double> filter_valid(const std::vector<double>& src, int w, int h,
                                 const std::vector<double>& k) {
  const int n = int(k.size()), ow = w - n + 1, oh = h - n + 1;
  std::vector<double> rows(std::size_t(ow) * h), out(std::size_t(ow) * oh);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < ow; ++x) {
      double s = 0.0;
      for (int i = 0; i < n; ++i) s += k[i] * src[std::size_t(y) * w + x + i];
      rows[std::size_t(y) * ow + x] = s;
    }
  for (int y = 0; y < oh; ++y)
    for (int x = 0; x < ow; ++x) {
      double s = 0.0;
      for (int i = 0; i < n; ++i) s += k[i] * rows[std::size_t(y + i) * ow + x];
      out[std::size_t(y) * ow + x] = s;
    }
  return out;
}

}  // namespace

double rel_mse(const Image& img, const Image& ref) {
  check_same_size(img, ref);
  double sum[3] = {0.0, 0.0, 0.0};
  for (std::size_t i = 0; i < img.pixels.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double v = img.pixels[i][c], r = ref.pixels[i][c];
      const double rse = (v - r) * (v - r) / ((r + 0.01) * (r + 0.01));
      if (std::isinf(rse)) continue;  // pbrt-v4 skips infinite terms (NaN ones propagate)
      sum[c] += rse;
    }
  const double n = double(img.pixels.size());
  return n > 0 ? (sum[0] + sum[1] + sum[2]) / (3.0 * n) : 0.0;
}

std::vector<float> srgb_luma(const Image& img) {
  std::vector<float> y(img.pixels.size());
  for (std::size_t i = 0; i < y.size(); ++i) {
    const glm::vec3& p = img.pixels[i];
    y[i] = float(0.2126 * srgb_encode(p.x) + 0.7152 * srgb_encode(p.y) +
                 0.0722 * srgb_encode(p.z));
  }
  return y;
}

double ssim(const Image& img, const Image& ref) {
  check_same_size(img, ref);
  if (img.pixels.empty()) return 1.0;
  const std::vector<float> lx = srgb_luma(img), ly = srgb_luma(ref);
  const int w = img.width, h = img.height;
  // Wang et al. 2004 section III-C: K1 = 0.01, K2 = 0.03, L = 1 (values in [0, 1]).
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  // Their 11x11 circular-symmetric Gaussian window, sigma 1.5, normalised to unit sum.
  std::vector<double> k(11);
  if (w < 11 || h < 11) {
    // Too small for one window: a single uniform window over the whole image.
    double mx = 0, my = 0;
    for (std::size_t i = 0; i < lx.size(); ++i) mx += lx[i], my += ly[i];
    mx /= double(lx.size()), my /= double(ly.size());
    double vx = 0, vy = 0, cxy = 0;
    for (std::size_t i = 0; i < lx.size(); ++i) {
      vx += (lx[i] - mx) * (lx[i] - mx);
      vy += (ly[i] - my) * (ly[i] - my);
      cxy += (lx[i] - mx) * (ly[i] - my);
    }
    vx /= double(lx.size()), vy /= double(lx.size()), cxy /= double(lx.size());
    return (2 * mx * my + c1) * (2 * cxy + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2));
  }
  double ksum = 0.0;
  for (int i = 0; i < 11; ++i)
    ksum += k[i] = std::exp(-double((i - 5) * (i - 5)) / (2 * 1.5 * 1.5));
  for (double& v : k) v /= ksum;
  std::vector<double> x(lx.begin(), lx.end()), y(ly.begin(), ly.end()), xx(x.size()),
      yy(x.size()), xy(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    xx[i] = x[i] * x[i];
    yy[i] = y[i] * y[i];
    xy[i] = x[i] * y[i];
  }
  const auto mx = filter_valid(x, w, h, k), my = filter_valid(y, w, h, k),
             exx = filter_valid(xx, w, h, k), eyy = filter_valid(yy, w, h, k),
             exy = filter_valid(xy, w, h, k);
  double sum = 0.0;
  for (std::size_t i = 0; i < mx.size(); ++i) {
    // Wang et al. eq. 13 with the local statistics of eqs. 14-16.
    const double vx = exx[i] - mx[i] * mx[i], vy = eyy[i] - my[i] * my[i],
                 cxy = exy[i] - mx[i] * my[i];
    sum += (2 * mx[i] * my[i] + c1) * (2 * cxy + c2) /
           ((mx[i] * mx[i] + my[i] * my[i] + c1) * (vx + vy + c2));
  }
  return sum / double(mx.size());
}

double max_abs_diff(const Image& img, const Image& ref) {
  check_same_size(img, ref);
  double m = 0.0;
  for (std::size_t i = 0; i < img.pixels.size(); ++i)
    for (int c = 0; c < 3; ++c)
      m = std::max(m, double(std::abs(img.pixels[i][c] - ref.pixels[i][c])));
  return m;
}

}  // namespace basalt::study
