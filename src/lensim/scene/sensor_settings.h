// The film sensor settings a scene gives, after pbrt-v4's film sensor model (src/pbrt/film.cpp,
// PixelSensor::Create; src/pbrt/util/spectrum.cpp, the named sensor curves and Spectra::D): the
// sensor names pbrt-v4 knows, the imaging ratio of ISO and exposure time, and the white-balance
// temperature. The sensors themselves (curves, matrices) are render/film/pixel_sensor.h.
#pragma once

#include <string>
#include <vector>

namespace lensim::scene {

/// The camera sensors pbrt-v4 names (`Film "rgb" "string sensor"`): each is a set of measured
/// spectral response curves `<name>_r`, `_g`, `_b` in pbrt-v4's named spectra
/// (src/pbrt/util/spectrum.cpp), the PhysLight measurements of Langlands and Fascione (Weta
/// Digital, 2020) that lensim bundles in data/sensors/camera_sensors.csv. "cie1931" is not among
/// them.
const std::vector<std::string>& pbrtCameraSensorNames();

/// The sensors lensim applies: "cie1931" (the CIE 1931 2-degree observer: the film records XYZ)
/// and every camera of pbrtCameraSensorNames().
const std::vector<std::string>& bundledSensorNames();

enum class SensorSupport {
  Applied,  ///< lensim has the curves and applies them
  Unknown,  ///< pbrt-v4 does not know the name (pbrt-v4: "unknown sensor type")
};
SensorSupport sensorSupport(const std::string& name);

/// pbrt-v4's imaging ratio (PixelSensor::Create): exposure time (the camera's shutterclose -
/// shutteropen, seconds) x ISO / 100, so the defaults (1 s, ISO 100) give exactly 1.
double sensorImagingRatio(double exposure_time_s, double iso);

/// The correlated colour temperature pbrt-v4's Spectra::D uses for a nominal temperature T: T x
/// 1.4388 / 1.4380 (the change of the second radiation constant c2 since the CIE daylight
/// definition), so "whitebalance" 6500 means CIE D65 (6504 K).
double whiteBalanceCct(double temperature_k);

}  // namespace lensim::scene
