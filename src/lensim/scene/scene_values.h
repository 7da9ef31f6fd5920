// The values a scene file gives to texturable parameters: spectra as written, and inputs that
// are either a constant or a texture.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "lensim/util/vec.h"

namespace lensim::scene {

/// A colour or spectral distribution as written in the scene.
struct SpectrumValue {
  enum class Kind { Rgb, Blackbody, Sampled, Named, File };
  Kind kind = Kind::Rgb;
  Vec3 rgb{0, 0, 0};                               ///< Kind::Rgb
  double temperature_k = 0;                        ///< Kind::Blackbody
  double blackbody_scale = 1;                      ///< pbrt-v3's second blackbody value
  std::vector<std::pair<double, double>> samples;  ///< Kind::Sampled: (wavelength nm, value)
  std::string name;  ///< Kind::Named: pbrt-v4 spectrum name; Kind::File: the resolved path

  static SpectrumValue gray(double v) {
    SpectrumValue s;
    s.rgb = {v, v, v};
    return s;
  }
  static SpectrumValue named(std::string n) {
    SpectrumValue s;
    s.kind = Kind::Named;
    s.name = std::move(n);
    return s;
  }
  /// pbrt-v4 syntax of the value: `rgb [0.5 0.5 0.5]`, `blackbody 6500`, ...
  std::string str() const;
};

/// A texturable material or texture input: a texture (index into Scene::textures) or a constant.
struct Input {
  int texture = -1;        ///< index into Scene::textures, or -1 for the constant
  double value = 0;        ///< the constant of a float input
  SpectrumValue spectrum;  ///< the constant of a spectrum input
};

}  // namespace lensim::scene
