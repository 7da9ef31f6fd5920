// Measured scattering coefficients of named media, as pbrt-v4's homogeneous medium `preset`
// (and its subsurface material `name`) accepts them.
#pragma once

#include <string>
#include <vector>

#include "lensim/scene/description.h"

namespace lensim::scene {

/// sigma_a and sigma_s (reduced scattering sigma_s', as pbrt-v4 uses it), in mm^-1, as RGB
/// values of the named measured medium; false for an unknown name.
bool mediumPreset(const std::string& name, SpectrumValue& sigma_a, SpectrumValue& sigma_s);
/// Every name mediumPreset knows.
std::vector<std::string> mediumPresetNames();

}  // namespace lensim::scene
