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
/// totally reflected, or where a surface cannot be as large as its rays need; when the pupil is the
/// stop's image (FLOA) and no real ray from the axial object point reaches the stop's rim, that
/// error also gives the highest stop height real rays reach and where they stop getting through.
std::vector<double> computeAutoSemiDiameters(const LensPrescription& p,
                                             const std::vector<int>& surfaces,
                                             const AutoSemiDiameterSpec& spec);

/// OpticStudio's real image height field (FTYP 3) for an object at infinity: the field angle
/// (degrees) of the parallel bundle in the x-z plane whose real chief ray, at the lens's
/// wavelength, meets the image plane (the film plane of LensSystem(p)) at x = image_height_mm.
/// The chief ray passes the stop's centre (`aim_at_stop`: OpticStudio's ray aiming) or the
/// paraxial entrance pupil's centre, as the rays of computeAutoSemiDiameters do. Solved by
/// bisection on the chief ray's image height, bracketed by a scan from the axis in steps of
/// 0.25 degree (the first crossing); the angle's sign is the height's times that of the image
/// (negative for a lens whose chief rays land on the side they come from). nullopt when no chief
/// ray below 90 degrees reaches the height. Throws an Error for a lens without a stop.
std::optional<double> realImageHeightFieldAngle(const LensPrescription& p, double image_height_mm,
                                                bool aim_at_stop);

}  // namespace lensim::optics
