// Image error metrics for `basalt study`: pbrt-v4's relative MSE and SSIM.
#pragma once
#include <vector>

#include "image/image_io.h"

namespace basalt::study {

/// \brief Relative mean squared error of \p img against \p ref, as pbrt-v4's
///        `imgtool diff --metric MRSE` (src/pbrt/util/image.cpp Image::MRSE): per pixel and
///        channel (v - ref)^2 / (ref + 0.01)^2, infinite terms skipped, summed and divided by
///        the pixel count, then averaged over R, G and B.
/// \throws std::invalid_argument if the resolutions differ.
double rel_mse(const Image& img, const Image& ref);

/// \brief Luma of the sRGB-encoded image (each channel clamped to [0, 1] and encoded with the
///        IEC 61966-2-1 transfer function, then Rec. 709 weights 0.2126, 0.7152, 0.0722).
std::vector<float> srgb_luma(const Image& img);

/// \brief Mean SSIM (Wang, Bovik, Sheikh, Simoncelli, "Image quality assessment: from error
///        visibility to structural similarity", IEEE TIP 13(4), 2004) of the srgb_luma of
///        \p img against that of \p ref: 11x11 Gaussian window with sigma 1.5, dynamic range 1,
///        C1 = 0.01^2, C2 = 0.03^2, averaged over the windows that lie wholly inside the image
///        (one window covering the whole image if it is smaller than 11 pixels either way).
/// \throws std::invalid_argument if the resolutions differ.
double ssim(const Image& img, const Image& ref);

/// \brief Largest |img - ref| over all pixels and channels (0 for identical images).
/// \throws std::invalid_argument if the resolutions differ.
double max_abs_diff(const Image& img, const Image& ref);

}  // namespace basalt::study
