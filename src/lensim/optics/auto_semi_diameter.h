// Automatic semi-diameters, as OpticStudio computes them for surfaces whose file gives none (no
// `DIAM` line, `DIAM 0`): the largest height at which any real ray of the file's fields,
// wavelengths and system aperture meets the surface.
//
// The rays: the chief ray and rays around the edge of the pupil (its diameter from ENPD, FNUM or
// the stop's size), from every field (angles, or object heights for a finite object) at every
// wavelength, traced exactly. Without ray aiming (OpticStudio's default) they pass through the
// paraxial entrance pupil; with it they are aimed at the real stop.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lensim/optics/prescription.h"
#include "lensim/util/error.h"

namespace lensim::optics {

/// The fields and aperture the rays come from.
struct AutoSemiDiameterSpec {
  /// Field points: angles in degrees (x, y) or, for object_heights, object heights in mm.
  std::vector<std::pair<double, double>> fields;
  bool object_heights = false;  ///< fields are object heights (a finite object only)
  /// The entrance pupil's diameter; 0: the paraxial image of the stop (FLOA).
  double entrance_pupil_diameter_mm = 0;
  FileLoc fields_loc;  ///< the field lines, for messages
  /// Real ray aiming (OpticStudio's RAIM on): each ray is aimed so that it meets the stop at the
  /// pupil point scaled to the stop's radius; off: at the paraxial entrance pupil.
  bool aim_at_stop = false;
};

/// The surfaces of `p` (indices into p.surfaces) whose semi-diameters are to be computed: each
/// gets the largest ray height over the rays of `spec` (times 1 + 1e-9, so that those rays pass).
/// A ray counts up to the first surface whose given semi-diameter it passes outside (the stop
/// excepted: rays aimed at the paraxial pupil may pass its rim); the placeholder apertures of the
/// computed surfaces must lie inside their surfaces' extents. Returns the semi-diameters found
/// (mm), in the order of `surfaces`. Throws a located Error where a ray misses a surface or is
/// totally reflected, or where a surface cannot be as large as its rays need.
std::vector<double> computeAutoSemiDiameters(const LensPrescription& p,
                                             const std::vector<int>& surfaces,
                                             const AutoSemiDiameterSpec& spec);

}  // namespace lensim::optics
