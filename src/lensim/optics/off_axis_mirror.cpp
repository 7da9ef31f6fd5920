#include "lensim/optics/off_axis_mirror.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lensim::optics {

std::optional<OffAxisParabola> offAxisParabola(const LensSurface& s) {
  if (!s.mirror || s.radius_mm == 0 || s.shape.conic != -1 || !s.shape.isRotational() ||
      s.shape.hasPolynomial() || !s.apertureDecentred())
    return std::nullopt;
  const double R = s.radius_mm;
  const double h2 = s.aperture_decentre_mm[0] * s.aperture_decentre_mm[0] +
                    s.aperture_decentre_mm[1] * s.aperture_decentre_mm[1];
  // The aperture centre's point (h, h^2 / 2R) and the focus (0, R/2), in the mirror's frame.
  const double dz = R / 2 - h2 / (2 * R);
  OffAxisParabola o;
  o.parent_focal_length_mm = std::abs(R) / 2;
  o.reflected_focal_length_mm = std::sqrt(h2 + dz * dz);
  // The parent's axis points from the vertex to the focus: +z for R > 0.
  const double c = std::clamp((R > 0 ? dz : -dz) / o.reflected_focal_length_mm, -1.0, 1.0);
  o.off_axis_angle_deg = std::acos(c) * 180 / std::numbers::pi;
  return o;
}

}  // namespace lensim::optics
