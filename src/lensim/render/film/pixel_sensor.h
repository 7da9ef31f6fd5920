// pbrt-v4's PixelSensor (src/pbrt/film.h and film.cpp): how a film turns the radiance of a
// sample into the sensor's RGB, and that RGB into CIE XYZ.
//
// - "cie1931" (the default): the sensor's RGB is CIE XYZ; with "whitebalance" T the XYZ is
//   adapted (von Kries in the Bradford cone space) from the white of CIE illuminant D at T to the
//   output colour space's white.
// - A named camera ("canon_eos_5d_mkiv", "nikon_d810", ...): the sensor's RGB integrates the
//   radiance against the camera's measured red, green and blue sensitivities
//   (data/sensors/camera_sensors.csv). The 3x3 matrix to XYZ is fitted by linear least squares
//   over the 24 ColorChecker patches (data/sensors/colorchecker.csv): their camera RGB lit by the
//   sensor illuminant (CIE D at "whitebalance", default 6500 K) against their XYZ lit by the output
//   colour space's illuminant (D65), so the fit also white-balances.
// In both, the sensor RGB is multiplied by the imaging ratio, exposure time x ISO / 100.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "lensim/render/spectra/spectrum.h"

namespace lensim::render {

/// A 3x3 matrix, row-major.
using Mat3d = std::array<double, 9>;

/// A tabulated spectrum that is linear between its samples and zero outside them (pbrt-v4's
/// PiecewiseLinearSpectrum; lensim's PiecewiseLinearSpectrum is constant beyond its ends).
class ZeroOutsideSpectrum final : public Spectrum {
 public:
  ZeroOutsideSpectrum(std::vector<double> lambda_nm, std::vector<double> values);
  double eval(double lambda_nm) const override;
  double maxValue() const override;

 private:
  std::vector<double> lambda_nm_, values_;
  double inv_step_ = 0;  ///< 1 / spacing of evenly spaced samples, else 0
};

/// The camera sensors with measured curves (pbrt-v4's named sensors), in the data file's order.
const std::vector<std::string>& cameraSensorNames();
/// The measured sensitivity of `camera`'s channel c (0 red, 1 green, 2 blue); throws
/// std::out_of_range for an unknown camera.
const ZeroOutsideSpectrum& cameraSensorCurve(const std::string& camera, int c);
/// The 24 ColorChecker patch reflectances, in chart order.
const std::vector<ZeroOutsideSpectrum>& colorCheckerReflectances();
/// pbrt-v4's Spectra::D(T): CIE illuminant D of correlated colour temperature T x 1.4388 / 1.4380
/// (relative power, 100 near 560 nm), a blackbody at that temperature below 4000 K.
std::shared_ptr<const Spectrum> daylightIlluminant(double temperature_k);

/// pbrt-v4's ProjectReflectance: the sums over 360..830 nm at 1 nm of b_c x refl x illum, each
/// divided by the sum of b_1 x illum (so a perfect white gives 1 in the middle channel).
Vec3 projectReflectance(const Spectrum& refl, const Spectrum& illum,
                        const std::array<const Spectrum*, 3>& b);

/// The least-squares M minimising the sum over rows of |M a_i - b_i|^2 (pbrt-v4's
/// LinearLeastSquares through the normal equations).
Mat3d linearLeastSquares(const std::vector<Vec3>& a, const std::vector<Vec3>& b);

Vec3 mulMat3(const Mat3d& m, const Vec3& v);
Mat3d mulMat3(const Mat3d& a, const Mat3d& b);
Mat3d invertMat3(const Mat3d& m);
/// Bradford von Kries adaptation from white chromaticity `src` (xy) to white XYZ `dst`.
Mat3d bradfordAdaptation(Vec2 src, const Vec3& dst);

class PixelSensor {
 public:
  /// `name`: "cie1931" or a camera of cameraSensorNames() (throws std::out_of_range otherwise);
  /// `white_balance_k`: 0 for none (cie1931 only; cameras default to 6500, as pbrt-v4);
  /// `imaging_ratio`: exposure time x ISO / 100 (times pbrt-v3's film "scale").
  PixelSensor(const std::string& name, double white_balance_k, double imaging_ratio);

  /// The sensor RGB of radiance L carried by `lambda` (lensim's radiance units, in which the
  /// cie1931 sensor gives XYZ with Y the luminance), times the imaging ratio.
  Vec3 toSensorRgb(const SampledSpectrum& L, const SampledWavelengths& lambda) const;
  /// XYZ from sensor RGB (pbrt-v4's XYZFromSensorRGB).
  const Mat3d& xyzFromSensorRgb() const { return xyz_from_sensor_; }
  const std::string& name() const { return name_; }
  /// The white the sensor is balanced for (a camera's illuminant), or null (cie1931 without
  /// "whitebalance").
  const std::shared_ptr<const Spectrum>& sensorIlluminant() const { return illuminant_; }
  /// The sensor's RGB response curves; null for cie1931 (the CIE 1931 matching functions).
  const ZeroOutsideSpectrum* curve(int c) const { return curves_[size_t(c)]; }
  double imagingRatio() const { return imaging_ratio_; }

  /// The camera RGB of the ColorChecker patches under the sensor illuminant and their target XYZ
  /// under the output illuminant (the rows the matrix is fitted to); empty for cie1931.
  std::vector<Vec3> trainingRgb, trainingXyz;

 private:
  std::string name_;
  double imaging_ratio_ = 1;
  std::array<const ZeroOutsideSpectrum*, 3> curves_{nullptr, nullptr, nullptr};
  std::shared_ptr<const Spectrum> illuminant_;
  Mat3d xyz_from_sensor_{1, 0, 0, 0, 1, 0, 0, 0, 1};
};

}  // namespace lensim::render
