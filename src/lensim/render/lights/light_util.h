// Helpers shared by the light implementations (lights.cpp, area_lights.cpp): emission
// normalisation and the scale of a transform.
#pragma once

#include "lensim/render/spectra/spectrum.h"
#include "lensim/scene/description.h"
#include "lensim/util/transform.h"

namespace lensim::render {

/// The factor pbrt-v4 applies to an emission spectrum: 1 / its luminance, except RGB values
/// (their D65 illuminant has unit luminance and the RGB magnitude is kept).
double photometricNorm(const scene::SpectrumValue& v, const Spectrum& s);

/// Luminance Y of an emission spectrum, clamped at 0 (for power computations).
double luminanceOf(const Spectrum& s);

/// The scale factor of a transform that scales uniformly: the cube root of |det|.
double uniformScale(const Transform& t);

}  // namespace lensim::render
