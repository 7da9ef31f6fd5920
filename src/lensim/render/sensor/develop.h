// A simple raw development pipeline (`lensim develop`): from a DNG's mosaic to a linear sRGB
// image. Steps, in order:
//   1. linearise: (DN - BlackLevel) / (WhiteLevel - BlackLevel);
//   2. white balance: each CFA channel divided by its AsShotNeutral component;
//   3. demosaic: Malvar, He and Cutler, "High-quality linear interpolation for demosaicing of
//      Bayer-patterned color images" (ICASSP 2004), 5x5 gradient-corrected kernels, the image
//      mirrored at its edges, for a 2x2 Bayer pattern (greens on a diagonal); for another pattern
//      each missing channel is the tent-weighted mean of that channel's pixels in a window about
//      the pixel (normalised convolution, weight (r + 1 - |dx|)(r + 1 - |dy|), r half the pattern's
//      larger side, rounded up); R, G and B come from their own pixels around, and with W
//      (white) pixels the luminance is the inverse-variance combination of W and R + G + B
//      (WPixels::kLuminance, below; docs/sensor.md);
//   4. colour: camera to linear sRGB through the DNG's ColorMatrix (D65, else the only one), as
//      dcraw does: cam_from_rgb = ColorMatrix x XYZ_from_sRGB, rows normalised to sum 1 (so the
//      balanced neutral stays neutral), inverted;
//   5. exposure: times 2^exposure_ev; negative values clamped to 0.
// The sRGB transfer curve (the tone curve) is applied by the image writer for 8-bit outputs.
#pragma once

#include <array>

#include "lensim/io/dng.h"
#include "lensim/io/image.h"
#include "lensim/render/film/pixel_sensor.h"

namespace lensim::render {

/// What the demosaic does with a CFA's W (white) pixels.
enum class WPixels {
  kLuminance,  ///< W and R + G + B combined into the luminance, R:G:B from the colour pixels
  kIgnore,     ///< W pixels left out: R, G and B from the colour pixels alone
};

/// The developed image (channels R, G, B, linear sRGB).
io::Image developRaw(const io::DngImage& raw, double exposure_ev = 0,
                     WPixels w_pixels = WPixels::kLuminance);

/// Step 4's matrix: linear sRGB from white-balanced camera values, for a DNG ColorMatrix (XYZ to
/// camera, row-major).
Mat3d srgbFromCamera(const std::array<double, 9>& color_matrix);

}  // namespace lensim::render
