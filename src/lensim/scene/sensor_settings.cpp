// pbrt-v4's film sensor model: names and formulas. See sensor_settings.h for the pbrt-v4 sources.
#include "lensim/scene/sensor_settings.h"

#include <algorithm>

namespace lensim::scene {

const std::vector<std::string>& pbrtCameraSensorNames() {
  // The names (without the _r/_g/_b suffix) of pbrt-v4's named camera sensor spectra,
  // src/pbrt/util/spectrum.cpp.
  static const std::vector<std::string> names = {
      "canon_eos_100d", "canon_eos_1dx_mkii", "canon_eos_200d",     "canon_eos_200d_mkii",
      "canon_eos_5d",   "canon_eos_5d_mkii",  "canon_eos_5d_mkiii", "canon_eos_5d_mkiv",
      "canon_eos_5ds",  "canon_eos_m",        "hasselblad_l1d_20c", "nikon_d810",
      "nikon_d850",     "sony_ilce_6400",     "sony_ilce_7m3",      "sony_ilce_7rm3",
      "sony_ilce_9"};
  return names;
}

const std::vector<std::string>& bundledSensorNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n = {"cie1931"};
    for (const std::string& c : pbrtCameraSensorNames()) n.push_back(c);
    return n;
  }();
  return names;
}

SensorSupport sensorSupport(const std::string& name) {
  const auto has = [&](const std::vector<std::string>& v) {
    return std::find(v.begin(), v.end(), name) != v.end();
  };
  return has(bundledSensorNames()) ? SensorSupport::Applied : SensorSupport::Unknown;
}

double sensorImagingRatio(double exposure_time_s, double iso) {
  return exposure_time_s * iso / 100;
}

double whiteBalanceCct(double temperature_k) {
  return temperature_k * 1.4388 / 1.4380;
}

}  // namespace lensim::scene
