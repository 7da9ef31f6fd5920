// The DNG colour calibration of a sensor from its spectral QE curves (DNG 1.4 specification,
// chapter 6): ColorMatrix (XYZ to camera) and ForwardMatrix (white-balanced camera to XYZ D50)
// for two calibration illuminants, CIE standard illuminant A and D65, each fitted by linear least
// squares over the 24 ColorChecker patches (data/sensors/colorchecker.csv), and the camera
// neutral of a white-balance illuminant (AsShotNeutral).
#pragma once

#include <array>

#include "lensim/render/film/pixel_sensor.h"
#include "lensim/render/sensor/sensor_model.h"

namespace lensim::render {

struct DngColor {
  Mat3d color_matrix1, color_matrix2;      ///< XYZ -> camera, for illuminant A (1), D65 (2)
  Mat3d forward_matrix1, forward_matrix2;  ///< neutral-balanced camera -> XYZ (D50)
  Vec3 as_shot_neutral;                    ///< camera RGB of white, max 1
  /// A W (panchromatic) plane's ColorMatrix1/2 rows and AsShotNeutral entry: W's response is
  /// R + G + B (SensorModel::qe), so each is the sum of the R, G and B ones, on their scale.
  Vec3 w_color_row1, w_color_row2;
  double w_neutral = 1;
  static constexpr int kIlluminant1 = 17;  ///< EXIF LightSource: standard light A
  static constexpr int kIlluminant2 = 21;  ///< D65
};

/// The camera response (photo-electrons, relative) of each channel to the spectrum s.
Vec3 cameraResponse(const SensorModel& m, const Spectrum& s);
/// Fits the DNG matrices; `white_balance_k` is the CCT of the as-shot white (CIE D, 6500 default).
DngColor fitDngColor(const SensorModel& m, double white_balance_k);

}  // namespace lensim::render
