// The real axial beam: how far from the axis a real ray from an object at infinity can enter the
// lens and still get through every clear aperture, which surface stops it, and the f-number that
// real marginal ray gives. Paraxial data extrapolate the first-order beam to the rim, which can
// name the wrong surface (the ISET Petzval's front element paraxially, its stop row for real
// rays); this is the real-ray answer that the aperture-stop choice and `lens info` use.
#pragma once

#include <vector>

#include "lensim/optics/lens_system.h"

namespace lensim::optics {

/// The real on-axis beam from infinity.
struct RealAxialBeam {
  /// Per surface: the largest entrance height (mm) of a ray parallel to the axis that reaches
  /// this surface inside its clear aperture (and refracts there), ignoring the apertures of all
  /// other surfaces; a ray lost before the surface (a miss or total internal reflection) does not
  /// count against it. Infinity when no such ray up to the front clear aperture meets its rim.
  std::vector<double> surface_limit_height_mm;
  double marginal_height_mm = 0;  ///< the smallest of them: the real marginal ray's height
  int limit_surface = -1;         ///< the surface that stops the real marginal ray
  /// Image-space working f-number of the real marginal ray, 1 / (2 n' sin u').
  double f_number = 0;
  /// EFL / (2 marginal height): the entrance-pupil f-number of the real beam.
  double f_number_entrance = 0;
};

/// Traces real rays parallel to the axis (scan and bisection to 1e-9 of the front aperture).
/// Throws lensim::Error when no ray near the axis gets through.
RealAxialBeam realAxialBeam(const LensSystem& lens, double effective_focal_length_mm);

}  // namespace lensim::optics
