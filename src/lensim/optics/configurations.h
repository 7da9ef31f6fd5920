// Multi-configuration lenses (zooms): choosing one configuration, and the zoom between two
// neighbouring configurations at a requested focal length.
//
// Readers fill LensPrescription::configurations (Zemax MNUM and its operands, lensim JSON
// "configurations"); these functions turn them into ordinary single-configuration prescriptions
// that the rest of lensim traces.
#pragma once

#include "lensim/optics/prescription.h"

namespace lensim::optics {

/// The number of configurations (1 for a lens without multi-configuration data).
int configurationCount(const LensPrescription& p);

/// The prescription in configuration `n` (1-based). Throws lensim::Error naming the lens file
/// and the valid range when `n` is out of range.
LensPrescription selectConfiguration(const LensPrescription& p, int n);

/// The prescription between configurations `a` and `b` (1-based) at fraction t in [0, 1]: every
/// thickness and clear aperture is (1 - t) * value_a + t * value_b; radii, glasses, shapes and
/// the stop must be the same in both (a zoom moves groups, it does not change them), else
/// lensim::Error names the first surface that differs.
LensPrescription interpolateConfigurations(const LensPrescription& p, int a, int b, double t);

/// A zoom setting found for a requested focal length.
struct ZoomSetting {
  LensPrescription prescription;  ///< the interpolated lens (no configurations of its own)
  int config_a = 1, config_b = 1;  ///< the neighbouring configurations (1-based)
  double t = 0;                    ///< the fraction from a to b
  double requested_efl_mm = 0;
  double achieved_efl_mm = 0;  ///< paraxial EFL of the interpolated lens
};

/// The zoom position whose paraxial EFL is `efl_mm`: the two neighbouring configurations (in file
/// order) whose EFLs bracket it, and the fraction t between them (linear interpolation of the
/// thicknesses, interpolateConfigurations) solved by bisection on the paraxial EFL to 1e-9
/// relative. Throws lensim::Error when the lens has one configuration, or no neighbouring pair
/// brackets the request (the message gives the range the configurations span).
ZoomSetting zoomToFocalLength(const LensPrescription& p, double efl_mm);

/// Paraxial EFL (mm) of configuration `n` (1-based) at the primary wavelength.
double configurationEfl_mm(const LensPrescription& p, int n);

}  // namespace lensim::optics
