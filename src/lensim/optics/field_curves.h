// Field curvature and distortion, the classic pair: for each field, the axial distance from the
// film to the tangential and to the sagittal focus of a thin bundle about the real chief ray,
// beside the chief ray's distortion.
//
// The foci are found with real rays (no Coddington approximation): two rays offset by +-1e-3
// entrance-pupil radii from the chief ray in the meridional direction cross at the tangential
// focus (in the x-z plane); a ray offset in y crosses the meridional plane at the sagittal focus.
#pragma once

#include <string>
#include <vector>

#include "lensim/optics/field_rays.h"
#include "lensim/optics/plots.h"

namespace lensim::optics {

struct FieldCurves {
  std::vector<WeightedWavelength> wavelengths;
  std::vector<double> film_height_mm, field_angle_deg;  ///< per field sample
  /// Per wavelength, per field: focus z minus film z (mm, + behind the film); NaN where the
  /// thin bundle is blocked or the rays do not cross.
  std::vector<std::vector<double>> tangential_mm, sagittal_mm;
  DistortionData distortion;  ///< of the lens's own system (computeDistortion)
};

/// Fields from the axis to the film corner (or the edge of the image circle) in `samples` steps.
FieldCurves computeFieldCurves(const SpectralLens& lens, double film_diagonal_mm, int samples = 40);

std::string fieldCurvesSvg(const FocusedLens& lens, const FieldCurves& c);

}  // namespace lensim::optics
