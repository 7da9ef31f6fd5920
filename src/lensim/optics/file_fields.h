// The design fields a lens file lists (LensPrescription::fields), reported with the paraxial image
// height of the largest one.
#pragma once

#include <optional>
#include <string>

#include "lensim/optics/lens_system.h"
#include "lensim/optics/paraxial.h"
#include "lensim/optics/prescription.h"

namespace lensim::optics {

/// The largest of a file's fields (radially: hypot of x and y for heights, of their tangents for
/// angles) and where the lens images it.
struct FileFieldSummary {
  std::string kind;  ///< "angle", "object height", "paraxial image height", "real image height"
  std::string unit;  ///< "deg" or "mm"
  int field = 1;     ///< 1-based, in the file's order
  double value = 0;  ///< the radial field (deg or mm)
  /// |y'| of its paraxial chief ray at the paraxial image plane of the file's object distance:
  /// EFL tan(angle) at infinity, |m| h for an object height h at magnification m (an angle at a
  /// finite distance is the height it subtends from the entrance pupil); the value itself for
  /// paraxial image heights. Unset for real image heights and object heights at infinity.
  std::optional<double> paraxial_image_height_mm;
};

/// Throws lensim::Error for an empty field list.
FileFieldSummary largestFileField(const FileFields& fields, const ParaxialData& p,
                                  const std::optional<double>& object_distance_mm);

}  // namespace lensim::optics
