// Transverse ray aberration fans: for each field and wavelength, where the rays of the
// tangential fan (pupil coordinate along x, the meridional direction) and of the sagittal fan
// (pupil coordinate along y) meet the film, relative to the chief ray of the primary wavelength.
// Pupil coordinates are offsets on the paraxial entrance-pupil plane from the chief ray's
// crossing, in units of the paraxial entrance-pupil radius; rays that the lens blocks are left
// out, so vignetting shows as a shortened fan.
#pragma once

#include <string>
#include <vector>

#include "lensim/optics/field_rays.h"

namespace lensim::optics {

struct RayFan {
  double wavelength_nm = kDLineNm;
  std::vector<double> tangential_pupil, tangential_ex_mm;  ///< e_x of rays at pupil (p, 0)
  std::vector<double> sagittal_pupil, sagittal_ey_mm;      ///< e_y of rays at pupil (0, p)
  std::vector<double> sagittal_ex_mm;                      ///< e_x of the same sagittal rays
};

struct FanField {
  double field_fraction = 0, film_height_mm = 0, field_angle_deg = 0;
  std::vector<RayFan> fans;  ///< one per wavelength
};

/// Fans across pupil coordinates -extent..extent (entrance-pupil radii) in `rays` steps.
std::vector<FanField> computeRayFans(const SpectralLens& lens, double film_diagonal_mm,
                                     const std::vector<double>& fields, int rays = 201,
                                     double extent = 1.5);

std::string rayFanSvg(const FocusedLens& lens, const std::vector<FanField>& fans,
                      const std::vector<WeightedWavelength>& wl);

}  // namespace lensim::optics
