// Point spread function images: the diffraction PSF of each field (wavefront.h), polychromatic
// as the weighted sum of each wavelength's PSF (each normalised to unit energy), resampled on a
// square window about the primary chief ray's image point and drawn on a log scale.
#pragma once

#include <string>
#include <vector>

#include "lensim/optics/field_rays.h"

namespace lensim::optics {

struct PsfField {
  double field_fraction = 0, film_height_mm = 0, field_angle_deg = 0;
  int pixels = 0;             ///< the image is pixels x pixels
  double pixel_mm = 0;        ///< pixel pitch on the film
  std::vector<double> image;  ///< row-major (y down the film's +y... row 0 at -y), peak-normalised
  Vec2 image_point_mm;        ///< the window's centre (chief ray of the primary wavelength)
  Vec2 centroid_mm;           ///< PSF centroid relative to image_point_mm
  double strehl = 0;          ///< weighted over the wavelengths
  double airy_radius_mm = 0;  ///< 1.22 lambda N of the on-axis real cone, primary wavelength
  int pupil_cells = 0;
};

/// PSFs at fractions of the film half-diagonal. window_mm: half-width of the image; 0 picks,
/// per field, the larger of 6 Airy radii and the radius holding 99% of the energy.
std::vector<PsfField> computePsf(const SpectralLens& lens, double film_diagonal_mm,
                                 const std::vector<double>& fields, double window_mm = 0,
                                 int pixels = 80, int pupil_cells = 0);

/// Log-scale images (decades below the peak, `decades` of them).
std::string psfSvg(const FocusedLens& lens, const std::vector<PsfField>& psfs,
                   const std::vector<WeightedWavelength>& wl, int decades = 5);

}  // namespace lensim::optics
