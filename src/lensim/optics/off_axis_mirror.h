// An off-axis part of a paraboloid mirror (Zemax CONI -1 with its aperture decentred by OBDC),
// described as makers specify one (Thorlabs' "OAPM 90 DEG 50.8 X 190.6": off-axis angle,
// diameter, reflected focal length).
#pragma once

#include <optional>

#include "lensim/optics/prescription.h"

namespace lensim::optics {

/// The parent's focal length |R|/2; the reflected focal length, from the aperture centre's
/// point on the mirror to the focus; and the off-axis angle between the parent's axis and that
/// reflected ray (RFL = 2 f / (1 + cos angle)). Exact for light along the parent's axis, which a
/// paraboloid focuses without aberration.
struct OffAxisParabola {
  double parent_focal_length_mm = 0;
  double reflected_focal_length_mm = 0;
  double off_axis_angle_deg = 0;
};

/// nullopt unless `s` is a paraboloid mirror (no polynomial terms) with a decentred aperture.
std::optional<OffAxisParabola> offAxisParabola(const LensSurface& s);

}  // namespace lensim::optics
